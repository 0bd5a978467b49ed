"""Rigid-track Coulomb reference: closed form, convergence, symmetries, loads, time domain."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate

from mjtrack.errors import InputError, MjtrackError, SingularMotionError
from mjtrack.io.robot import Robot
from mjtrack.models.coulomb import (
    contact_wrench,
    normal_loads,
    pivot_turn_closed_form,
    rollout,
    steady_state,
)

ROBOT = Robot()
# Cases: both turn directions, pivot both ways, one track stopped, reversing, gentle turn.
CASES = [(0.2, 0.6), (0.6, 0.2), (-0.5, 0.5), (0.5, -0.5), (0.0, 0.4), (-0.4, 0.0),
         (-0.3, -0.8), (-0.8, -0.3), (0.7, 0.75)]
ROBOTS = [ROBOT, Robot(cg_x=0.05, cg_y=-0.03), Robot(cg_x=-0.1, mu_left=0.5), Robot(cg_z=0.3)]


# -- closed form ------------------------------------------------------------------------------
def test_closed_form_solves_the_moment_integral():
    """The elementary (asinh) integrals of eq. (4) agree with direct quadrature at the root."""
    v = 0.5
    p = pivot_turn_closed_form(ROBOT, v)
    T, h = ROBOT.track_gauge, ROBOT.track_length / 2
    a = p.wz * T / 2 - v
    f = lambda x: (p.wz * x * x + T / 2 * a) / np.hypot(a, p.wz * x)  # noqa: E731
    val, _ = integrate.quad(f, -h, h, epsabs=1e-14, epsrel=1e-14)
    scale, _ = integrate.quad(lambda x: abs(f(x)), -h, h)
    assert abs(val) < 1e-12 * scale
    assert a < 0  # the tracks slip backwards: yaw rate below the ideal 2V/T
    assert 0.5 < p.wz * T / (2 * v) < 1.0
    assert p.y_l == pytest.approx(-p.y_r) and p.y_l > T / 2


def test_closed_form_mirrors_and_scales():
    p, q, s = (pivot_turn_closed_form(ROBOT, v) for v in (0.5, -0.5, 1.0))
    assert q.wz == pytest.approx(-p.wz, rel=1e-14)
    assert q.y_l == pytest.approx(p.y_l, rel=1e-14)  # y_l = (vx - V_L)/wz: both signs flip
    assert s.wz == pytest.approx(2 * p.wz, rel=1e-14)


def test_closed_form_refuses_asymmetric_robot():
    with pytest.raises(InputError, match="cg_x = cg_y = 0"):
        pivot_turn_closed_form(Robot(cg_x=0.05), 0.5)
    with pytest.raises(InputError, match="non-zero"):
        pivot_turn_closed_form(ROBOT, 0.0)


def test_steady_pivot_converges_to_closed_form_second_order():
    """Midpoint rule: the ICR error falls as n^-2; at n = 1000 it is below 1e-6 m."""
    p = pivot_turn_closed_form(ROBOT, 0.5)
    err = {}
    for n in (100, 200, 400, 1000):
        s = steady_state(ROBOT, -0.5, 0.5, inertial=False, n_points=n)
        assert s.vx == pytest.approx(0.0, abs=1e-12) and s.vy == pytest.approx(0.0, abs=1e-12)
        err[n] = abs(s.y_l - p.y_l)
        assert abs(s.y_r - p.y_r) == pytest.approx(err[n], rel=1e-6)
    assert 3.8 < err[100] / err[200] < 4.2 and 3.8 < err[200] / err[400] < 4.2
    assert err[1000] < 1e-7
    s = steady_state(ROBOT, -0.5, 0.5, inertial=True, n_points=1000)  # CoM at rest: no inertia effect
    assert abs(s.y_l - p.y_l) < 1e-6 and abs(s.wz - p.wz) < 1e-6


# -- steady state properties --------------------------------------------------------------------
@pytest.mark.parametrize("robot", ROBOTS)
@pytest.mark.parametrize("inertial", [False, True])
def test_residual_small_on_all_cases(robot, inertial):
    for vl, vr in CASES:
        s = steady_state(robot, vl, vr, inertial=inertial)
        assert s.residual <= 1e-10
        assert np.sign(s.wz) == np.sign(vr - vl)
        # ICRs consistent with eq. (2.13) computed from the twist
        assert s.y_l == pytest.approx((s.vx - vl) / s.wz, abs=1e-9)
        assert s.x_c == pytest.approx(-s.vy / s.wz, abs=1e-9)


def test_tolerance_does_not_change_icrs():
    robot = Robot(cg_x=0.05, cg_y=0.02)
    a = steady_state(robot, 0.2, 0.7, tol=1e-12)
    b = steady_state(robot, 0.2, 0.7, tol=1e-9)
    for k in range(3):
        assert a.icr[k] == pytest.approx(b.icr[k], abs=1e-9)


def test_quasi_static_icrs_do_not_depend_on_speeds():
    """Without inertia u_i = wz (y_side - y_i, x_i - x_c): the ICRs depend on geometry only."""
    robot = Robot(cg_x=0.04, cg_y=0.02)
    ref = steady_state(robot, -0.5, 0.5, inertial=False)
    for vl, vr in [(0.1, 0.9), (0.0, 0.3), (0.7, 0.7000001)]:
        s = steady_state(robot, vl, vr, inertial=False)
        np.testing.assert_allclose(s.icr, ref.icr, atol=1e-9)


@pytest.mark.parametrize("inertial", [False, True])
def test_cg_forward_moves_x_c_forward(inertial):
    fwd = steady_state(ROBOT.replace(cg_x=0.05), -0.5, 0.5, inertial=inertial)
    back = steady_state(ROBOT.replace(cg_x=-0.05), -0.5, 0.5, inertial=inertial)
    assert fwd.x_c > 0.03 and back.x_c < -0.03
    if not inertial:
        assert fwd.x_c == pytest.approx(-back.x_c, abs=1e-10)


def test_speed_pushes_centre_outside_the_turn():
    """Inertia: the centripetal force needs net inward lateral friction, so the body slides
    outwards (vy < 0 in a left turn, x_c > 0), more at higher speed; zero at low speed."""
    x = [steady_state(ROBOT, 0.6 * k, 1.4 * k).x_c for k in (0.01, 0.5, 1.0)]
    assert abs(x[0]) < 1e-4 and 0 < x[1] < x[2]


@pytest.mark.parametrize("inertial", [False, True])
@pytest.mark.parametrize("vl, vr", [(0.2, 0.6), (-0.5, 0.5), (0.0, 0.4), (-0.3, -0.8)])
def test_mirror_symmetry(vl, vr, inertial):
    a = steady_state(ROBOT, vl, vr, inertial=inertial)
    b = steady_state(ROBOT, vr, vl, inertial=inertial)
    np.testing.assert_allclose([b.vx, b.vy, b.wz], [a.vx, -a.vy, -a.wz], atol=1e-10)
    assert b.y_l == pytest.approx(-a.y_r, abs=1e-10) and b.x_c == pytest.approx(a.x_c, abs=1e-10)


@pytest.mark.parametrize("robot", ROBOTS)
def test_reversing_all_speeds_reverses_the_twist_without_inertia(robot):
    a = steady_state(robot, 0.2, 0.7, inertial=False)
    b = steady_state(robot, -0.2, -0.7, inertial=False)
    np.testing.assert_allclose(b.twist, -a.twist, atol=1e-10)


@pytest.mark.parametrize("inertial", [False, True])
def test_equal_speeds_drive_straight(inertial):
    s = steady_state(Robot(cg_x=0.05, cg_y=0.03, mu_left=0.4), 0.6, 0.6, inertial=inertial)
    assert s.straight and (s.vx, s.vy, s.wz) == (0.6, 0.0, 0.0) and s.residual == 0.0
    with pytest.raises(SingularMotionError, match="straight"):
        _ = s.y_l
    assert contact_wrench(ROBOT, 0.6, 0.0, 0.0, 0.6, 0.6) == pytest.approx(np.zeros(3))


def test_no_steady_state_when_friction_cannot_hold_the_turn():
    with pytest.raises(MjtrackError, match="no steady state"):
        steady_state(ROBOT, 0.6, 6.0)


# -- loads and wrench ---------------------------------------------------------------------------
@pytest.mark.parametrize("cg", [(0.0, 0.0), (0.05, 0.03), (-0.07, -0.1), (0.15, 0.0), (-0.2, 0.1)])
@pytest.mark.parametrize("n_across", [1, 3])
def test_wong_loads_sum_and_centroid(cg, n_across):
    """Sum N = m g and centroid = cg, exactly (discrete), also beyond |cg_x| = L/6."""
    robot = ROBOT.replace(cg_x=cg[0], cg_y=cg[1])
    x, y, N = normal_loads(robot, n_points=50, n_across=n_across)
    assert np.all(N >= 0) and N.sum() == pytest.approx(robot.weight, rel=1e-13)
    assert N @ x / N.sum() == pytest.approx(cg[0], abs=1e-12)
    assert N @ y / N.sum() == pytest.approx(cg[1], abs=1e-12)
    if abs(cg[0]) > robot.track_length / 6:
        assert np.sum(N == 0) > 0  # Wong's shortened (triangular) contact


@pytest.mark.parametrize("cg", [(0.05, 0.03), (0.15, 0.05), (-0.2, -0.1), (0.0, 0.15)])
@pytest.mark.parametrize("n_across", [1, 3])
def test_loads_are_those_of_a_rigid_plate_on_tensionless_springs(cg, n_across):
    """A rigid chassis on equal springs deflects as a plane: N_i = max(0, a + b x_i + c y_i) (the
    MuJoCo robot's suspension). Checked by the optimality conditions, not by the solver: a plane
    fitted through the loaded points reproduces them, and is <= 0 where the load is 0; without
    lift-off the closed form W/n (1 + c_x x/mean(x^2) + c_y y/mean(y^2)). An earlier form gave the two
    tracks separate Wong distributions (a c_x c_y x y twist term a rigid chassis cannot carry)."""
    robot = ROBOT.replace(cg_x=cg[0], cg_y=cg[1])
    x, y, N = normal_loads(robot, n_points=50, n_across=n_across)
    loaded = N > 0
    A = np.stack([np.ones(loaded.sum()), x[loaded], y[loaded]], axis=1)
    coef, *_ = np.linalg.lstsq(A, N[loaded], rcond=None)
    np.testing.assert_allclose(A @ coef, N[loaded], rtol=0, atol=1e-9 * N.max())
    plane = coef[0] + coef[1] * x + coef[2] * y
    assert np.all(plane[~loaded] <= 1e-9 * N.max())
    if loaded.all():
        closed = robot.weight / x.size * (1 + cg[0] * x / np.mean(x**2) + cg[1] * y / np.mean(y**2))
        np.testing.assert_allclose(N, closed, rtol=1e-12)
    # one slope along both tracks (a rigid chassis pitches as one)
    left = y > 0
    if loaded.all() and n_across == 1:
        slope = [np.polyfit(x[side], N[side], 1)[0] for side in (left, ~left)]
        assert slope[0] == pytest.approx(slope[1], rel=1e-9)


def test_plate_loads_hold_on_random_robots_and_centroids():
    """Seeded sweep: 300 robots (gauge, length, track width, 1 or 3 points across) and load
    centroids anywhere inside 0.95 of the support, lift-off included: the loads sum to the
    weight, put the centroid exactly where asked and are the positive part of one plane
    (optimality conditions of the plate on tensionless springs, checked independently)."""
    from mjtrack.models.coulomb import _Contacts

    rng = np.random.default_rng(20261125)
    for _ in range(300):
        robot = Robot(track_gauge=float(rng.uniform(0.2, 0.9)), track_length=float(rng.uniform(0.2, 1.5)),
                      track_width=float(rng.uniform(0.02, 0.12)), mass=float(rng.uniform(5, 150)), cg_z=0.1)
        c = _Contacts(robot, int(rng.integers(10, 80)), int(rng.choice([1, 3])))
        xmax, ymax = c.xg.max(), robot.track_gauge / 2
        cx, cy = rng.uniform(-0.95, 0.95) * xmax, rng.uniform(-0.95, 0.95) * ymax
        w = c._plate(float(cx), float(cy))
        assert np.all(w >= 0) and w.sum() == pytest.approx(1.0, abs=1e-12)
        assert w @ c.x == pytest.approx(cx, abs=1e-10) and w @ c.y == pytest.approx(cy, abs=1e-10)
        on = w > 1e-14
        A = np.stack([np.ones(on.sum()), c.x[on], c.y[on]], axis=1)
        coef, *_ = np.linalg.lstsq(A, w[on], rcond=None)
        assert np.max(np.abs(A @ coef - w[on])) < 1e-9 * w.max()
        assert np.all(coef[0] + coef[1] * c.x[~on] + coef[2] * c.y[~on] <= 1e-9 * w.max())


def test_load_transfer_moves_the_centroid():
    x, y, N = normal_loads(ROBOT, accel=(1.0, 2.0))
    h, g = ROBOT.cg_z, ROBOT.weight / ROBOT.mass
    assert N @ x / N.sum() == pytest.approx(-h * 1.0 / g, abs=1e-12)
    assert N @ y / N.sum() == pytest.approx(-h * 2.0 / g, abs=1e-12)


def test_wrench_is_minus_gradient_of_dissipation():
    """f_i = -mu N_i grad|u_i|: the wrench is -grad D, D = sum mu_i N_i |u_i| (finite differences)."""
    robot = Robot(cg_x=0.03, cg_y=-0.02, mu_left=0.6)
    x, y, N = normal_loads(robot, n_points=40)
    mu = np.where(y > 0, robot.friction_left, robot.friction_right)
    vs = np.where(y > 0, 0.1, 0.5)

    def D(z):
        return float(mu * N @ np.hypot(z[0] - z[2] * y - vs, z[1] + z[2] * x))

    z0 = np.array([0.3, -0.02, 0.8])
    h = 1e-6
    grad = np.array([(D(z0 + h * e) - D(z0 - h * e)) / (2 * h) for e in np.eye(3)])
    w = contact_wrench(robot, *z0, 0.1, 0.5, n_points=40)
    np.testing.assert_allclose(w, -grad, rtol=1e-7, atol=1e-7)


# -- time domain --------------------------------------------------------------------------------
def test_rollout_long_time_limit_matches_steady_state():
    """At two rtol values the long-time twist equals the exact steady state; the tiny eps
    (regularisation error O(eps^2/|u|^2) ~ 1e-10) leaves the comparison to the integrator."""
    robot = Robot(cg_x=0.05, cg_y=0.02)
    s = steady_state(robot, 0.2, 0.6)
    t = np.linspace(0.0, 3.0, 31)
    for rtol in (1e-6, 1e-9):
        r = rollout(robot, t, 0.2, 0.6, rtol=rtol, eps=1e-6)
        np.testing.assert_allclose(r.twist[-1], s.twist, atol=1e-7)
    # a robot at the steady twist stays there (t = 0.5 s)
    r = rollout(robot, t[:6], 0.2, 0.6, twist0=s.twist, eps=1e-6)
    np.testing.assert_allclose(r.twist, np.tile(s.twist, (6, 1)), atol=1e-7)


def test_rollout_held_samples_equal_callable_and_straight_driving():
    t = np.linspace(0.0, 2.0, 21)
    vl = np.where(t < 1.0, 0.3, -0.2)
    a = rollout(ROBOT, t, vl, 0.4)
    b = rollout(ROBOT, t, lambda tt: 0.3 if tt < 1.0 else -0.2, lambda tt: 0.4)
    np.testing.assert_allclose(a.pose, b.pose, atol=2e-6)  # callable: the integrator steps over the jump
    s = rollout(ROBOT, t, 0.5, 0.5, pose0=(1.0, 2.0, 0.5))
    assert np.all(np.abs(s.pose[:, 2] - 0.5) < 1e-12) and np.all(np.abs(s.twist[:, 1:]) < 1e-12)
    assert s.twist[-1, 0] == pytest.approx(0.5, abs=1e-6)


def test_rollout_refuses_bad_input():
    with pytest.raises(InputError, match="increasing"):
        rollout(ROBOT, [0.0, 0.0, 1.0], 0.1, 0.2)
    with pytest.raises(InputError, match="shaped like t"):
        rollout(ROBOT, [0.0, 1.0], [0.1, 0.2, 0.3], 0.2)
    with pytest.raises(InputError, match="eps"):
        rollout(ROBOT, [0.0, 1.0], 0.1, 0.2, eps=0.0)


@pytest.mark.parametrize("inertial", [False, True])
def test_fallback_path_reaches_the_same_steady_state(monkeypatch, inertial):
    """Make the first (direct) solve fail: the dissipation-minimum + continuation fallback
    must find the same steady state."""
    from mjtrack.models import coulomb

    robot = Robot(cg_x=0.05, cg_y=0.02)
    ref = steady_state(robot, 0.1, 0.7, inertial=inertial)
    real_root, calls = coulomb.optimize.root, []

    def failing_first(fun, x0, **kw):
        calls.append(1)
        sol = real_root(fun, x0, **kw)
        if len(calls) == 1:
            sol.x = np.array([0.5, 0.5, 0.0])  # y_l == y_r: infinite twist
        return sol

    monkeypatch.setattr(coulomb.optimize, "root", failing_first)
    s = steady_state(robot, 0.1, 0.7, inertial=inertial)
    assert len(calls) > 1 and s.residual <= 1e-10
    np.testing.assert_allclose(s.twist, ref.twist, atol=1e-10)
