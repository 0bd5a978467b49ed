"""Simplified tracked dynamics (2.4)-(2.6): turning-resistance moment (2.5') and time domain."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate

from mjtrack.errors import InputError
from mjtrack.io.robot import Robot
from mjtrack.models.coulomb import contact_wrench, steady_state
from mjtrack.models.dynamics import (
    TrackedDynamics,
    lateral_friction_force,
    simulate,
    turning_resistance_moment,
)

ROBOT = Robot()
L, T = ROBOT.track_length, ROBOT.track_gauge
Q = ROBOT.mu * ROBOT.weight / L  # lateral friction load per unit length, both tracks [N/m]


@pytest.mark.parametrize("wz", [1.3, -0.4])
@pytest.mark.parametrize("d", [0.0, 0.07, -0.18, 0.3, -0.4])
def test_moment_and_force_match_quadrature_of_the_distribution(wz, d):
    """(i) M_r = -int x f(x) dx and f_l = int f(x) dx, f = -q sgn(wz (x - d)), by scipy quad."""
    f = lambda x: -Q * np.sign(wz * (x - d))  # noqa: E731
    cuts = [-L / 2, float(np.clip(d, -L / 2, L / 2)), L / 2]  # integrate each side of the jump
    mz = sum(integrate.quad(lambda x: x * f(x), a, b)[0] for a, b in zip(cuts[:-1], cuts[1:]))
    fy = sum(integrate.quad(f, a, b)[0] for a, b in zip(cuts[:-1], cuts[1:]))
    assert turning_resistance_moment(ROBOT, wz, d) == pytest.approx(-mz, abs=1e-9)
    assert lateral_friction_force(ROBOT, wz, d) == pytest.approx(fy, abs=1e-9)
    if abs(d) >= L / 2:
        assert turning_resistance_moment(ROBOT, wz, d) == 0.0  # the track slides one way


def test_moment_resists_rotation_and_uses_the_track_length():
    m0 = turning_resistance_moment(ROBOT, 2.0, 0.0)
    assert m0 == pytest.approx(ROBOT.mu * ROBOT.weight * L / 4)  # l = L, d = 0
    assert turning_resistance_moment(ROBOT, -2.0, 0.0) == -m0
    assert turning_resistance_moment(ROBOT, 2.0, 0.1) < m0  # minus d^2
    assert turning_resistance_moment(ROBOT, 2.0, 0.1, mu_y=0.4) == pytest.approx(
        0.5 * turning_resistance_moment(ROBOT, 2.0, 0.1))


@pytest.mark.parametrize("wz", [1.5, -0.8])
@pytest.mark.parametrize("k", [100, 140, 37])
def test_moment_equals_coulomb_reference_without_longitudinal_slip(wz, k):
    """(ii) Rotation about (d, 0) with the tracks running at V = -wz y_track: u_x = 0 on the
    track centre lines, so every Coulomb contact slides purely sideways with |f| = mu N
    (uniform load, line contacts). The Coulomb wrench is then exactly (0, f_l, -M_r); with d on
    a cell boundary of the midpoint grid the quadrature is exact. Limit of the comparison: in
    any motion with longitudinal slip the Coulomb lateral force is mu N |u_y|/|u| < mu N, so
    (2.5') overestimates the resistance there (see test_simplified_pivot_overestimates_yaw_rate)."""
    n = 200
    d = -L / 2 + k * L / n
    w = contact_wrench(ROBOT, 0.0, -wz * d, wz, -wz * T / 2, wz * T / 2, n_points=n)
    assert w[0] == pytest.approx(0.0, abs=1e-9)
    assert w[1] == pytest.approx(lateral_friction_force(ROBOT, wz, d), abs=1e-9)
    assert w[2] == pytest.approx(-turning_resistance_moment(ROBOT, wz, d), abs=1e-9)


def test_time_domain_lateral_friction_tends_to_closed_form():
    model = TrackedDynamics(ROBOT, lateral_eps=1e-9, n_points=4000)
    for vy, wz in [(-0.1, 2.0), (0.05, -1.0), (0.0, 0.5)]:
        f_l, m_r = model.lateral(vy, wz)
        d = -vy / wz
        assert m_r == pytest.approx(turning_resistance_moment(ROBOT, wz, d), rel=1e-3)
        assert f_l == pytest.approx(lateral_friction_force(ROBOT, wz, d), abs=1e-3 * ROBOT.weight)
    f_l, m_r = model.lateral(0.2, 0.0)  # no rotation: the whole track slides sideways
    assert f_l == pytest.approx(-ROBOT.mu * ROBOT.weight) and abs(m_r) < 1e-9


def test_straight_driving_with_equal_traction_does_not_rotate():
    """(iii) Equal forces from rest: wz = vy = 0 for ever and x = F t^2 / m exactly."""
    model = TrackedDynamics(ROBOT)
    t = np.linspace(0.0, 2.0, 21)
    out = simulate(model, t, forces=(30.0, 30.0), pose0=(0.0, 0.0, 0.3))
    assert np.all(out.twist[:, 1:] == 0.0) and np.all(out.pose[:, 2] == 0.3)
    s = 60.0 * t**2 / (2 * ROBOT.mass)
    np.testing.assert_allclose(out.pose[:, 0], s * np.cos(0.3), atol=1e-8)
    np.testing.assert_allclose(out.pose[:, 1], s * np.sin(0.3), atol=1e-8)
    out = simulate(model, t, v_left=0.5, v_right=0.5)
    assert np.all(out.twist[:, 2] == 0.0) and out.twist[-1, 0] == pytest.approx(0.5, abs=1e-6)


def test_opposite_forces_spin_up_against_the_turning_resistance():
    """Opposite forces F while spinning (vx = vy = 0): I wz' = F T - M_r with d = 0."""
    model = TrackedDynamics(ROBOT)
    F = 50.0
    d = model.derivative(np.array([0, 0, 0, 0, 0, 1.0]), -F, F)
    m_r = model.lateral(0.0, 1.0)[1]
    assert d[5] == pytest.approx((F * T - m_r) / model.yaw_inertia)
    assert m_r == pytest.approx(turning_resistance_moment(ROBOT, 1.0, 0.0), rel=1e-2)


def test_simplified_pivot_overestimates_yaw_rate():
    """Independent longitudinal and lateral friction (a friction box) let the simplified
    model turn faster in a pivot than the Coulomb reference (circle); mirror-symmetric."""
    model = TrackedDynamics(ROBOT)
    t = np.linspace(0.0, 3.0, 31)
    a = simulate(model, t, v_left=-0.5, v_right=0.5)
    b = simulate(model, t, v_left=0.5, v_right=-0.5)
    coulomb = steady_state(ROBOT, -0.5, 0.5)
    assert a.twist[-1, 2] > 1.1 * coulomb.wz
    assert b.twist[-1, 2] == pytest.approx(-a.twist[-1, 2], rel=1e-6)
    # steady: the traction moment balances (2.5') at d = 0
    fl, fr = model.traction(a.twist[-1, 0], a.twist[-1, 2], -0.5, 0.5)
    assert (fr - fl) * T / 2 == pytest.approx(model.lateral(0.0, a.twist[-1, 2])[1], rel=1e-5)


def test_bad_input_is_refused():
    with pytest.raises(InputError, match="either forces"):
        simulate(TrackedDynamics(ROBOT), [0.0, 1.0], forces=(1.0, 1.0), v_left=0.1, v_right=0.1)
    with pytest.raises(InputError, match="traction_eps"):
        TrackedDynamics(ROBOT, traction_eps=0.0)
    with pytest.raises(InputError, match="mu_y"):
        turning_resistance_moment(ROBOT, 1.0, 0.0, mu_y=-1.0)
