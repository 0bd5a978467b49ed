"""Wheeled-robot models of the wheeled-robot thesis: each model's own verification case.

Thesis numbers reproduced (Jonszta 2008, docs/theory/wheeled.md; digits restored as explained in the modules):
kinematic circle R = 1 m at v = 1 m/s in 2 pi s; dynamic model 1 reaches 2 m/s at 0.333 s and
spins up at 130 rad/s^2 under +-1 N; dynamic model 2 leaves the R = 0.2 m circle at 2.16 s;
skid steer reaches 1 m/s at about 0.17 s; Ackermann circles 0.52 m (rear) / 0.6 m (front) at
30 degrees of steering.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mjtrack.errors import InputError
from mjtrack.models.wheeled import (
    Ackermann,
    DiffDriveDynamic1,
    DiffDriveDynamic2,
    DiffDriveKinematic,
    SkidSteer4,
    rk4,
    rk4_step,
    simulate,
    steering_angles,
    wheel_speeds,
)


def test_diffdrive_wheel_speed_round_trip():
    rng = np.random.default_rng(0)
    m = DiffDriveKinematic()
    for v, w in rng.normal(size=(5, 2)):
        wl, wr = wheel_speeds(v, w, track=m.track, wheel_radius=m.wheel_radius)
        np.testing.assert_allclose(m.twist(m.initial_state((0, 0, 0)), np.array([wl, wr])), [v, 0, w], atol=1e-12)


def test_diffdrive_circle_radius_and_period():
    """1.1.1.1: v = 1 m/s, omega = 1 rad/s -> circle R = 1 m, back at the start after 2 pi s."""
    m = DiffDriveKinematic()
    v, w = 1.0, 1.0
    u = np.array(wheel_speeds(v, w, track=m.track, wheel_radius=m.wheel_radius))
    period = 2 * math.pi / w
    t, states = simulate(m, m.initial_state((0, 0, 0)), lambda t, s: u, duration=period, dt=period / 400)
    centre = np.array([0.0, v / w])
    np.testing.assert_allclose(np.hypot(*(states[:, :2] - centre).T), v / w, atol=1e-9)
    np.testing.assert_allclose(states[-1, :2], [0.0, 0.0], atol=1e-9)
    assert states[-1, 2] == pytest.approx(2 * math.pi, abs=1e-12)


def _first_time(t, mask):
    idx = np.flatnonzero(mask)
    assert idx.size, "event never happened"
    return t[idx[0]]


def test_dynamic1_straight_start_reaches_speed_at_saturation_time():
    """1.1.2.2 no. 1: F_max = 1.5 N, M = 0.5 kg, v_req = 2 m/s -> a = 6 m/s^2, t = M v/(2 F_max) = 0.333 s."""
    m = DiffDriveDynamic1()
    v_req = 2.0
    u = np.array(wheel_speeds(v_req, 0.0, track=m.track, wheel_radius=m.wheel_radius))
    dt = 1e-4
    t, s = simulate(m, m.initial_state((0, 0, 0)), lambda t, x: u, duration=0.5, dt=dt)
    t_pred = m.mass * v_req / (2 * m.force_max)
    assert t_pred == pytest.approx(1 / 3)
    early = t < 0.9 * t_pred
    np.testing.assert_allclose(s[early, 3], 2 * m.force_max * t[early] / m.mass, atol=1e-9)
    # Saturation ends when K (omega_req - v/r) < F_max, i.e. v_req - v < F_max r/K = 37.5 mm/s;
    # after that the speed converges with time constant M r/(2K) = 6.25 ms, so 99 % of v_req
    # is reached within ~ (F_max r/K)/a + tau ln(...) of t_pred: 10 ms is a safe bound.
    t99 = _first_time(t, s[:, 3] >= 0.99 * v_req)
    assert t_pred - 0.01 < t99 < t_pred + 0.01
    assert s[-1, 3] == pytest.approx(v_req, rel=1e-6)


def test_dynamic1_opposite_forces_spin_up():
    """1.1.2.2 no. 2: F_R = 1 N, F_L = -1 N -> omegadot = (F_R - F_L)(b/2)/J = 130 rad/s^2; phi(1 s) = 65 rad."""
    m = DiffDriveDynamic1()
    state = m.initial_state((0, 0, 0))
    dt = 1e-3
    for _ in range(1000):
        state = rk4(lambda x: m.derivative_from_forces(x, -1.0, 1.0), state, dt)
    assert (2.0 * m.track / 2 / m.inertia) == pytest.approx(130.0)
    assert state[4] == pytest.approx(130.0, rel=1e-9)
    assert state[2] == pytest.approx(65.0, rel=1e-9)
    np.testing.assert_allclose(state[[0, 1, 3]], 0.0, atol=1e-12)


def test_dynamic1_force_law_saturates():
    m = DiffDriveDynamic1()
    state = m.initial_state((0, 0, 0))
    assert m.forces(state, np.array([1e3, -1e3])) == (m.force_max, -m.force_max)
    assert m.forces(state, np.array([0.5, 0.0])) == (pytest.approx(0.5 * m.gain), 0.0)


def _circle_run(model, radius, accel, duration):
    """Feed-forward: v = a t, omega = v/R, wheel requests from (1.3)-(1.4)."""
    def u_of_t(t, s):
        v = accel * t
        return np.array(wheel_speeds(v, v / radius, track=model.track, wheel_radius=model.wheel_radius))
    return simulate(model, model.initial_state((0, 0, 0)), u_of_t, duration=duration, dt=model.max_stable_dt)


def test_dynamic2_leaves_circle_when_centripetal_force_exceeds_friction():
    """1.1.2.4 no. 1: R = 0.2 m, a = 0.5 m/s^2: M omega^2 R > sqrt((mu W_tot)^2 - (M a)^2) at t = 2.16 s."""
    m = DiffDriveDynamic2()
    radius, accel = 0.2, 0.5
    w_tot = 2 * m.mu * m.wheel_load
    s_max = math.sqrt(w_tot**2 - (m.mass * accel) ** 2)
    omega_crit = math.sqrt(s_max / (m.mass * radius))
    t_pred = omega_crit * radius / accel
    assert (w_tot, omega_crit, t_pred) == (pytest.approx(2.94), pytest.approx(5.41, abs=0.01), pytest.approx(2.16, abs=0.01))
    t, s = _circle_run(m, radius, accel, duration=t_pred + 0.6)
    dist = np.hypot(s[:, 0], s[:, 1] - radius)
    # Before the friction saturates the wheels creep sideways at S/C < mu W/C = 4.9 mm/s, which
    # drifts the robot out by a few mm; once saturated the deficit grows like (2 v a/R) tau^3/6.
    assert np.all(np.abs(dist[t < 0.97 * t_pred] - radius) < 5e-3)
    t_leave = _first_time(t, dist > radius + 0.01)
    assert t_pred < t_leave < t_pred + 0.3
    # The onset itself: the lateral friction saturates (slip beyond mu W/C) within 2 % of t_pred.
    lateral_slip = np.array([abs(m.twist(x)[1]) for x in s])
    eps = m.mu * m.wheel_load / m.stiffness
    t_skid = _first_time(t, lateral_slip > eps)
    assert t_skid == pytest.approx(t_pred, rel=0.02)


def test_friction_characteristic_linear_then_saturated():
    from mjtrack.models.wheeled import wheel_friction
    f, s = wheel_friction(0.003, 0.004, stiffness=100.0, limit=1.0)
    assert (f, s) == (pytest.approx(0.3), pytest.approx(-0.4))
    f, s = wheel_friction(3.0, 4.0, stiffness=100.0, limit=1.0)
    assert (f, s) == (pytest.approx(0.6), pytest.approx(-0.8))


def test_skidsteer_straight_start_reaches_speed():
    """1.2.1: four forces saturate at mu W; v_req = 1 m/s is reached at t = M v/(4 mu W) = 0.17 s."""
    m = SkidSteer4()
    v_req = 1.0
    u = np.full(2, v_req / m.wheel_radius)
    t, s = simulate(m, m.initial_state((0, 0, 0)), lambda t, x: u, duration=0.3, dt=m.max_stable_dt / 2)
    t_pred = m.mass * v_req / (4 * m.mu * m.wheel_load)
    assert t_pred == pytest.approx(0.17, abs=0.005)
    # Linear-friction tail: slip below eps = mu W/C = 17 mm/s decays at rate 4C/M = 339 1/s, so
    # 99 % of v_req is reached within a few ms of t_pred.
    t99 = _first_time(t, s[:, 3] >= 0.99 * v_req)
    assert abs(t99 - t_pred) < 0.005
    np.testing.assert_allclose(s[:, [1, 2, 4, 5]], 0.0, atol=1e-12)


@pytest.mark.parametrize("p", [0.54, 0.8])
def test_skidsteer_slow_spin_turns_about_geometric_centre(p):
    """Equal loads, linear friction: spin about the geometric centre, (p - 1/2) a ahead of the COG,
    at b^2/(a^2 + b^2) of the no-slip yaw rate (derived in the module docstring)."""
    m = SkidSteer4(cg_ratio=p)
    big_omega = 0.02  # wheel speed [rad/s]: rim speed 3 mm/s < eps = 17 mm/s keeps friction linear
    u = np.array([-big_omega, big_omega])
    t, s = simulate(m, m.initial_state((0, 0, 0)), lambda t, x: u, duration=1.0, dt=m.max_stable_dt)
    tw = m.twist(s[-1])
    a, b = m.wheelbase, m.track
    rate = m.wheel_radius * big_omega * (b / 2) / ((a / 2) ** 2 + (b / 2) ** 2)
    assert tw[2] == pytest.approx(rate, rel=1e-4)
    assert rate / (2 * m.wheel_radius * big_omega / b) == pytest.approx(b**2 / (a**2 + b**2))
    # point of zero velocity: x = -v_y/phidot ahead of the COG, y = v_x/phidot
    assert -tw[1] / tw[2] == pytest.approx((p - 0.5) * a, abs=1e-4)
    # the COG circles the centre at (p - 1/2) a, so a tiny centripetal force M phidot^2 (p - 1/2) a
    # shifts the centre sideways by micrometres (2.6 um at p = 0.8): 1e-5 m bounds it
    assert tw[0] / tw[2] == pytest.approx(0.0, abs=1e-5)


@pytest.mark.parametrize("p", [0.3, 0.54, 0.8])
def test_skidsteer_static_loads_spin_about_the_cog(p):
    """Loads (and slip stiffness) by the COG position: the slow spin centre is the COG itself and
    phidot = r Omega (b/2)/(a^2 p (1-p) + (b/2)^2) (derived in the module docstring)."""
    m = SkidSteer4(cg_ratio=p, load_distribution="static")
    big_omega = 0.02
    t, s = simulate(m, m.initial_state((0, 0, 0)), lambda t, x: np.array([-big_omega, big_omega]), duration=1.0,
                    dt=m.max_stable_dt)
    tw = m.twist(s[-1])
    a, half = m.wheelbase, m.track / 2
    assert tw[2] == pytest.approx(m.wheel_radius * big_omega * half / (a**2 * p * (1 - p) + half**2), rel=1e-4)
    assert np.hypot(tw[0], tw[1]) / tw[2] < 1e-6  # the COG stays put (spin centre = COG)
    assert float(np.sum(m.load_factors)) == pytest.approx(4.0)


def test_skidsteer_static_loads_equal_equal_loads_at_midpoint():
    rng = np.random.default_rng(3)
    eq, st = SkidSteer4(cg_ratio=0.5), SkidSteer4(cg_ratio=0.5, load_distribution="static")
    for _ in range(5):
        x, u = rng.normal(size=6), rng.normal(scale=5.0, size=2)
        np.testing.assert_allclose(st.derivative(x, u), eq.derivative(x, u), rtol=1e-12)


def test_skidsteer_reduces_to_dynamic2_when_axles_coincide():
    rng = np.random.default_rng(1)
    d2 = DiffDriveDynamic2(stiffness=600.0, wheel_load=5.0, track=0.3, wheel_radius=0.05, mass=2.0, inertia=0.01)
    s4 = SkidSteer4(wheelbase=0.0, stiffness=300.0, wheel_load=2.5, track=0.3, wheel_radius=0.05, mass=2.0,
                    inertia=0.01, mu=d2.mu)
    for _ in range(10):
        body = rng.normal(size=6)
        wheels = rng.normal(scale=20.0, size=2)
        x2 = np.concatenate([body, wheels])
        np.testing.assert_allclose(s4.derivative(body, wheels), d2.derivative(x2, np.zeros(2))[:6], rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("drive, expected_radius", [("rear", 0.3 / math.tan(math.pi / 6)), ("front", 0.3 / math.sin(math.pi / 6))])
def test_ackermann_circle_radius(drive, expected_radius):
    """1.3.1.1 / 1.3.2.1: theta = 30 deg, speed 0.2 m/s: R = l/tan = 0.52 m (rear), l/sin = 0.6 m (front);
    the thesis's lap times are 16.34 s and 18.85 s."""
    m = Ackermann(drive=drive)
    theta, speed = math.pi / 6, 0.2
    lap = {"rear": 16.32, "front": 18.85}[drive]
    v_b, omega = m.body_rates((speed, theta))
    period = 2 * math.pi / omega
    assert period == pytest.approx(lap, abs=0.03)
    t, s = simulate(m, m.initial_state((0, 0, 0)), lambda t, x: np.array([speed, theta]), duration=period, dt=period / 500)
    r_b = v_b / omega
    np.testing.assert_allclose(np.hypot(s[:, 0], s[:, 1] - r_b), r_b, atol=1e-9)
    # the radius that the thesis quotes is that of the driven wheel: B (rear), front wheel (front)
    front = s[:, :2] + m.wheelbase * np.stack([np.cos(s[:, 2]), np.sin(s[:, 2])], 1)
    quoted = s[:, :2] if drive == "rear" else front
    np.testing.assert_allclose(np.hypot(quoted[:, 0], quoted[:, 1] - r_b), expected_radius, atol=1e-9)
    np.testing.assert_allclose(s[-1, :2], 0.0, atol=1e-9)


def test_ackermann_inner_outer_angles():
    l, b, radius = 0.3, 0.15, 0.52
    inner, outer = steering_angles(radius, wheelbase=l, track=b)
    assert inner > outer
    assert math.tan(inner) == pytest.approx(l / (radius - b / 2))
    assert math.tan(outer) == pytest.approx(l / (radius + b / 2))
    # the bicycle angle lies between them: cot(theta) is the mean of the two cotangents
    assert 1 / math.tan(math.atan(l / radius)) == pytest.approx(0.5 * (1 / math.tan(inner) + 1 / math.tan(outer)))
    with pytest.raises(InputError, match="half the track"):
        steering_angles(0.05, wheelbase=l, track=b)


def test_models_reject_bad_parameters():
    with pytest.raises(InputError, match="track"):
        DiffDriveKinematic(track=-1.0)
    with pytest.raises(InputError, match="cg_ratio"):
        SkidSteer4(cg_ratio=1.5)
    with pytest.raises(InputError, match="load_distribution"):
        SkidSteer4(load_distribution="dynamic")
    with pytest.raises(InputError, match="drive"):
        Ackermann(drive="all")


def test_rk4_step_is_fourth_order():
    """Local error of rk4_step on the kinematic circle shrinks ~ dt^5."""
    m = DiffDriveKinematic()
    u = np.array(wheel_speeds(1.0, 2.0, track=m.track, wheel_radius=m.wheel_radius))
    exact = lambda dt: np.array([math.sin(2 * dt) / 2, (1 - math.cos(2 * dt)) / 2, 2 * dt])
    errs = [np.linalg.norm(rk4_step(m, np.zeros(3), u, dt) - exact(dt)) for dt in (0.1, 0.05)]
    assert errs[0] / errs[1] == pytest.approx(32, rel=0.15)


def test_thesis_verification_table_passes():
    """The table that ``python -m mjtrack.models.wheeled.verification`` prints: every case within tolerance."""
    from mjtrack.models.wheeled.verification import thesis_checks

    checks = thesis_checks()
    assert len(checks) == 14
    failed = [(c.name, c.predicted, c.measured) for c in checks if not c.passed]
    assert not failed
