"""Shear-displacement ground reference: the Coulomb limit, an independent balance, the turn's sign."""

from __future__ import annotations

import numpy as np
import pytest

from mjtrack.errors import InputError
from mjtrack.io.robot import G, Robot
from mjtrack.models import coulomb, shear

ROBOT = Robot()  # tracks: T 0.4 m, L 0.5 m, 20 kg, mu 0.8
WHEELED = Robot(traction="wheels", track_gauge=0.555, wheelbase=0.512, mass=50.0, mu=0.5, cg_z=0.2)
# turn radii from a pivot to a gentle turn, at a slow and a fast speed, both turn directions
GRID = [(-0.5, 0.5), (0.0, 0.6), (0.2, 0.6), (0.6, 0.2), (0.5, 0.7), (1.0, 1.4), (1.5, 0.9), (-0.3, -0.8)]


def _yaw_ratio(s, T):
    return s.wz / ((s.v_right - s.v_left) / T)


@pytest.mark.parametrize("robot", [ROBOT, Robot(cg_x=0.05, cg_y=-0.03, mu_left=0.6), WHEELED],
                         ids=["tracks", "tracks-offset", "wheels"])
def test_k_to_zero_recovers_coulomb(robot):
    """K -> 0: every ICR within 0.005 T/2 of the Coulomb reference's over the grid of turns and
    speeds (the requirement), and the gap shrinks with K (the limit, not a coincidence). A wheel's
    patch is 2 cm here: the reference's wheels are points, and the default 0.1 m patch alone moves
    the ICRs by up to 0.0014 m (0.005 T/2 on this robot)."""
    T = robot.track_gauge
    for vl, vr in GRID:
        ref = np.array(coulomb.steady_state(robot, vl, vr).icr)
        gaps = [np.max(np.abs(np.array(shear.steady_state(robot, vl, vr, shear_modulus=K, patch_length=0.02).icr)
                              - ref)) for K in (1e-2, 1e-3, 1e-5)]
        assert gaps[-1] <= 0.005 * T / 2, (vl, vr, gaps)
        assert gaps[-1] <= max(gaps[0], 1e-4 * T), (vl, vr, gaps)  # (below 1e-4 T: the patch's own gap)
        # K = 0 is Coulomb's law exactly; a wheel's patch spreads its load, a point as it shrinks
        exact = shear.steady_state(robot, vl, vr, shear_modulus=0.0, patch_length=1e-6)
        assert np.allclose(exact.icr, ref, atol=1e-7)


def _independent_wrench(robot, n, state, K, cg_x=0.0):
    """Sum of forces and yaw moment of the shear law written out here: midpoint grid of n points
    per track, Wong's linear load for a centroid cg_x (no point lifts), and each element's shear
    displacement integrated numerically from its sliding velocity in the ground frame (no
    closed form)."""
    L, T, m, mu = robot.track_length, robot.track_gauge, robot.mass, robot.mu
    x = -L / 2 + (np.arange(n) + 0.5) * L / n
    N = m * G / (2 * n) * (1 + cg_x * x / np.mean(x * x))
    vx, vy, wz = state.vx, state.vy, state.wz
    F = np.zeros(3)
    for y, V in ((T / 2, state.v_left), (-T / 2, state.v_right)):
        xe = L / 2 if V > 0 else -L / 2
        t_in = np.abs(xe - x) / abs(V)
        s = np.linspace(0.0, 1.0, 4001)[:, None]  # element's path, from touch-down (s=0) to now (s=1)
        xp = xe + (x - xe) * s  # its body position along the way
        ux, uy = vx - wz * y - V, vy + wz * xp  # its sliding velocity, body frame then
        ang = -wz * t_in * (1.0 - s)  # body heading then, relative to now
        gx = np.cos(ang) * ux - np.sin(ang) * uy
        gy = np.sin(ang) * ux + np.cos(ang) * uy
        jx = np.trapezoid(gx, s, axis=0) * t_in
        jy = np.trapezoid(gy, s, axis=0) * t_in
        j = np.hypot(jx, jy)
        ux, uy = vx - wz * y - V, vy + wz * x
        mag = mu * N * (1.0 - np.exp(-j / K)) / np.hypot(ux, uy)
        fx, fy = -mag * ux, -mag * uy
        F += [fx.sum(), fy.sum(), np.sum(x * fy - y * fx)]
    return F


@pytest.mark.parametrize("K", [0.01, 0.05])
@pytest.mark.parametrize("v", [(-0.5, 0.5), (0.2, 0.6), (0.9, 0.6), (0.5, 0.7)])
def test_balance_at_the_solution_independently(K, v):
    """At the quasi-static solution the forces and the yaw moment vanish when summed by code
    that shares nothing with the reference (uniform and offset loads)."""
    n = 200
    for robot, cg_x in ((ROBOT, 0.0), (Robot(cg_x=0.04), 0.04)):
        s = shear.steady_state(robot, *v, shear_modulus=K, inertial=False, n_points=n)
        F = _independent_wrench(robot, n, s, K, cg_x)
        # quadrature of the displacement: 4000 steps, relative error ~1e-7 of a force
        assert np.all(np.abs(F[:2]) <= 1e-5 * robot.weight), F
        assert abs(F[2] - (cg_x * F[1])) <= 1e-5 * robot.weight * robot.track_length, F


def test_pivot_yaw_rises_with_shear_modulus():
    """Derived (docs/theory/shear.md): in a pivot the stress deficit sits at the entry ends, where
    the lateral forces resist the turn, so the yaw rate rises with K (quasi-static)."""
    T = ROBOT.track_gauge
    ratios = [_yaw_ratio(shear.steady_state(ROBOT, -0.5, 0.5, shear_modulus=K, inertial=False), T)
              for K in (0.0, 0.003, 0.01, 0.03, 0.1)]
    assert np.all(np.diff(ratios) > 0), ratios


def test_quasi_static_turn_is_rate_independent_and_turn_dependent():
    """Without inertia j depends on the path only: the same ICRs at three times the speeds; but
    unlike Coulomb's (equal in every turn on a centred robot) the yaw ratio depends on the turn."""
    T = ROBOT.track_gauge
    a = shear.steady_state(ROBOT, 0.2, 0.6, shear_modulus=0.03, inertial=False)
    b = shear.steady_state(ROBOT, 0.6, 1.8, shear_modulus=0.03, inertial=False)
    assert np.allclose(a.icr, b.icr, atol=1e-9)

    def spread(K):
        r = [_yaw_ratio(shear.steady_state(ROBOT, 1 - q, 1 + q, shear_modulus=K, inertial=False), T)
             for q in (1.0, 0.5, 0.1)]
        return max(r) - min(r)

    assert spread(0.0) < 1e-3
    assert spread(0.03) > 0.03


def test_speed_lowers_yaw_on_a_soft_ground():
    """With inertia the centripetal force needs shear that a large K builds only with large
    slip: the yaw ratio falls with speed by much more than under Coulomb (measured at turn ratio
    1/4: Coulomb changes by < 0.01, K = 0.1 m by > 0.05)."""
    T = ROBOT.track_gauge

    def drop(K):
        slow, fast = (_yaw_ratio(shear.steady_state(ROBOT, 0.75 * v, 1.25 * v, shear_modulus=K), T)
                      for v in (0.3, 1.0))
        return slow - fast

    assert abs(drop(0.0)) < 0.01
    assert drop(0.1) > 0.05


def test_shear_modulus_from_the_argument_only_here():
    with pytest.raises(InputError, match="shear_modulus"):
        shear.steady_state(ROBOT, 0.2, 0.6)
    with pytest.raises(InputError, match=">= 0"):
        shear.steady_state(ROBOT, 0.2, 0.6, shear_modulus=-0.01)
    with pytest.raises(InputError, match="patch_length"):
        shear.steady_state(WHEELED, 0.2, 0.6, shear_modulus=0.01, patch_length=0.0)
    s = shear.steady_state(ROBOT, 0.4, 0.4, shear_modulus=0.01)
    assert s.straight and s.vx == 0.4


def test_slower_side_grips_more_on_wheels():
    """Derived (docs/theory/shear.md): a slow side's patch elements slide further before they
    leave, so with one side slow the yaw ratio falls below Coulomb's, while a symmetric pivot,
    the same displacement profile under every wheel, hardly moves (quasi-static, K = 0.03 m)."""
    T = WHEELED.track_gauge

    def ratio(vl, vr, K):
        return _yaw_ratio(shear.steady_state(WHEELED, vl, vr, shear_modulus=K, inertial=False, n_points=60), T)

    slow_side, gentle = ratio(0.125, 0.875, 0.03), ratio(0.45, 0.55, 0.03)
    assert slow_side < ratio(0.125, 0.875, 0.0) - 0.05
    assert slow_side < gentle - 0.05
    assert abs(ratio(-0.5, 0.5, 0.03) - ratio(-0.5, 0.5, 0.0)) < 0.005


# -- the MuJoCo robot on the shear ground (surfacevel track model) ---------------------------------
def _mujoco_icr(robot, vl, vr):
    from mjtrack.sim.config import surfacevel_config
    from mjtrack.sim.steady import steady_state as mujoco_steady

    s = mujoco_steady(robot, vl, vr, config=surfacevel_config())
    return np.array([s.y_l, s.y_r, s.x_c])


def test_mujoco_shear_ground_agrees_with_its_reference():
    """One turn of the fidelity grid (python benchmarks/ground_selection.py --fidelity runs all of it): the MuJoCo
    robot's steady ICRs within 0.02 T/2 of the reference's at the surfacevel model's 12 elements."""
    robot = Robot(ground={"model": "shear", "shear_modulus": 0.03})
    got = _mujoco_icr(robot, 0.2, 0.6)
    ref = np.array(shear.steady_state(robot, 0.2, 0.6, n_points=12).icr)
    assert np.max(np.abs(got - ref)) <= 0.02 * robot.track_gauge / 2, (got, ref)
    coulomb_ref = np.array(coulomb.steady_state(robot, 0.2, 0.6, n_points=12).icr)
    assert np.max(np.abs(got - coulomb_ref)) > 0.05 * robot.track_gauge / 2  # the ground changed the turn


@pytest.mark.slow
def test_mujoco_shear_ground_recovers_the_coulomb_robot():
    """K -> 0: the MuJoCo robot on the shear ground turns as the Coulomb one within 0.005 T/2."""
    for vl, vr in ((-0.5, 0.5), (0.2, 0.6), (0.5, 0.7)):
        a = _mujoco_icr(Robot(ground={"model": "shear", "shear_modulus": 1e-4}), vl, vr)
        b = _mujoco_icr(ROBOT, vl, vr)
        assert np.max(np.abs(a - b)) <= 0.005 * ROBOT.track_gauge / 2, (vl, vr, a, b)


def test_shear_ground_is_built_on_every_track_model_of_its_robot():
    # the roller chain and the wheels take it (their friction is set per chunk of a rollout); a
    # wheeled robot is built on the roller chain's settings only, its shear ground too
    from mjtrack.sim.builder import build_model
    from mjtrack.sim.config import SimConfig
    from mjtrack.sim.ground import ShearChunks, chunk_ground

    for robot in (Robot(ground="shear"), Robot(traction="wheels", track_gauge=0.5, ground="shear")):
        model = build_model(robot)
        assert isinstance(chunk_ground(model, robot, SimConfig()), ShearChunks)
        assert chunk_ground(model, robot, SimConfig(), 0.0) is None  # K = 0: the Coulomb ground
    assert chunk_ground(build_model(Robot()), Robot(), SimConfig()) is None
    with pytest.raises(InputError, match="a wheeled robot has wheels, not the 'surfacevel'"):
        build_model(Robot(traction="wheels", track_gauge=0.5, ground="shear"), SimConfig(track_model="surfacevel"))


def test_motion_resistance_balance_and_sign():
    """(S5): at the quasi-static solution the contact wrench (checked independently above) balances
    the two sides' resistances written here from the robot key's definition: f_r times the weight
    each side carries at rest, against the velocity of its mid-contact along x. And the
    resistance lowers the yaw rate of a pivot (it resists the counter-running sides)."""
    robot = Robot(rolling_resistance=0.1, cg_y=0.02)
    T, W, n, K = robot.track_gauge, robot.weight, 200, 0.02
    c = shear.ShearContacts(robot, n_points=n)
    for v in ((-0.5, 0.5), (0.3, 0.6)):
        s = shear.steady_state(robot, *v, shear_modulus=K, inertial=False, n_points=n)
        total = c.wrench(s.vx, s.vy, s.wz, s.v_left, s.v_right, c.loads(), K)
        for y, share in ((T / 2, 0.5 + robot.cg_y / T), (-T / 2, 0.5 - robot.cg_y / T)):
            fx = -0.1 * W * share * np.tanh((s.vx - s.wz * y) / shear.RESISTANCE_EPS)
            total += [fx, 0.0, -y * fx]
        assert np.all(np.abs(total) <= 1e-8 * W), total
    with_r = _yaw_ratio(shear.steady_state(robot, -0.5, 0.5, shear_modulus=K, inertial=False), T)
    without = _yaw_ratio(shear.steady_state(robot.replace(rolling_resistance=0.0), -0.5, 0.5, shear_modulus=K,
                                            inertial=False), T)
    assert with_r < without - 0.01, (with_r, without)
