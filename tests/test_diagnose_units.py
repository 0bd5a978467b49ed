"""Properties of the diagnosis building blocks: surrogate, input transforms, windows, statistics."""

from __future__ import annotations

import numpy as np
import pytest

from mjtrack.diagnose import residuals as rs
from mjtrack.diagnose import surrogate as sg
from mjtrack.diagnose.effects import EFFECTS, Surrogate
from mjtrack.diagnose.select import paired_t
from mjtrack.io.robot import Robot
from mjtrack.metrics import horizon_errors
from mjtrack.models import MICR, Nominal, integrate, steady_state

ROBOT = Robot()


def _data(v, dt=0.05, seg=None, poses=None, meas=None):
    n = v.shape[0]
    return rs.DriveData(t=np.arange(n) * dt, seg=np.zeros(n, int) if seg is None else seg, cmd=v, meas=meas,
                        poses=np.zeros((n, 3)) if poses is None else poses)


def _steps(rng, n=400, hold=20):
    return np.repeat(rng.uniform(-1, 1, (n // hold, 2)), hold, axis=0)


def test_kinematic_baseline_is_the_nominal_model(rng):
    v = _steps(rng)
    tw = Surrogate(ROBOT, "kinematic").twist(_data(v), v)
    np.testing.assert_allclose(tw, Nominal(ROBOT.track_gauge).twist(v[:, 0], v[:, 1]), atol=1e-12)


@pytest.mark.parametrize("vl, vr", [(0.2, 0.8), (0.8, 0.2), (-0.3, -0.9), (0.6, -0.6), (1.0, 1.2)])
def test_coulomb_baseline_matches_the_exact_steady_state(vl, vr):
    """First-order inertial response vs the exact nonlinear solve (|a| <= ~0.6 m/s^2 here)."""
    v = np.array([[vl, vr]])
    tw = Surrogate(ROBOT, "coulomb").twist(_data(v), v)[0]
    exact = steady_state(ROBOT, vl, vr).twist
    # second-order terms in a/(mu g) ~ 0.07 and 100 vs 200 contact points: 1e-3 relative
    np.testing.assert_allclose(tw, exact, atol=1e-3 * max(abs(vl), abs(vr)) / ROBOT.track_gauge)


def test_quasi_static_icrs_do_not_depend_on_the_speeds():
    """Derivation check: on Coulomb ground without inertia the ICRs are constant."""
    q = [steady_state(ROBOT, a, b, inertial=False, n_points=sg._N_POINTS).icr for a, b in ((0.1, 0.5), (-0.7, 0.2), (0.9, 0.3))]
    np.testing.assert_allclose(q, np.tile(sg.ground_response(ROBOT).q0, (3, 1)), atol=1e-6)


def test_static_tables_pass_through_the_nominal_robot():
    values, table = sg.static_table(ROBOT, "cg_x", [-0.05, 0.0, 0.05])
    np.testing.assert_allclose(table[1], sg.ground_response(ROBOT).q0, atol=1e-9)
    assert table[2, 2] > 0 > table[0, 2]  # x_c follows the centre of mass


def test_effects_at_their_nominal_values_reduce_to_the_baseline(rng):
    v = _steps(rng)
    poses = np.column_stack([np.zeros((v.shape[0], 2)), rng.uniform(-3, 3, v.shape[0])])
    data = _data(v, poses=poses)
    s = Surrogate(ROBOT, "coulomb")
    base = s.twist(data, v)
    for e in EFFECTS.values():
        nominal = e.nominal(ROBOT)
        if e.kind == "input":
            if e.name == "actuator_lag":
                nominal = (1e-12,)  # tau -> 0; the step mean deviates by O(tau/dt)
            tw = s.twist(data, s.inputs(data, e, nominal))
        else:
            tw = s.twist(data, v, e, nominal)
        np.testing.assert_allclose(tw, base, atol=1e-9, err_msg=e.name)


def test_input_transforms_exact(rng):
    v = np.zeros((100, 2))
    v[10:] = [0.5, -0.5]
    data = _data(v)
    s = Surrogate(ROBOT, "kinematic")
    np.testing.assert_allclose(s.inputs(data, EFFECTS["track_speed_scale"], [0.8]), 0.8 * v)
    np.testing.assert_allclose(s.inputs(data, EFFECTS["speed_limit"], [0.3]), np.clip(v, -0.3, 0.3))
    delayed = np.vstack([np.repeat(v[:1], 5, axis=0), v[:-5]])  # held at the initial speed before the start
    np.testing.assert_allclose(s.inputs(data, EFFECTS["command_delay"], [0.25]), delayed, atol=1e-12)
    tau = 0.3
    lag = s.inputs(data, EFFECTS["actuator_lag"], [tau], instant=True)
    t = data.t[10:] - data.t[10]
    np.testing.assert_allclose(lag[10:, 0], 0.5 * (1 - np.exp(-t / tau)), atol=1e-12)
    mean = s.inputs(data, EFFECTS["actuator_lag"], [tau])  # mean over each held step
    h = 0.05
    np.testing.assert_allclose(mean[10:, 0], 0.5 - 0.5 * np.exp(-t / tau) * tau / h * (1 - np.exp(-h / tau)), atol=1e-12)


def test_lag_filter_paths_agree(rng):
    """The lfilter path (long segments) equals the exact recursion (short segments)."""
    import mjtrack.diagnose.effects as eff

    v = _steps(rng, n=1000)
    data = _data(v)
    a = eff._lag(data, v, 0.2, v)
    old = eff._LOOP_MAX
    try:
        eff._LOOP_MAX = 10**6
        b = eff._lag(data, v, 0.2, v)
    finally:
        eff._LOOP_MAX = old
    np.testing.assert_allclose(a, b, atol=1e-12)


def test_window_errors_agree_with_metrics_horizon_errors(rng):
    v = _steps(rng)
    n = v.shape[0]
    seg = np.repeat([0, 1], n // 2)
    model = Nominal(ROBOT.track_gauge)
    truth = MICR(0.3, -0.25, 0.05)
    poses = np.vstack([integrate(truth, [0, 0, 0], np.arange(n // 2) * 0.05, v[: n // 2, 0], v[: n // 2, 1]),
                       integrate(truth, [5, 1, 2], np.arange(n // 2) * 0.05, v[n // 2:, 0], v[n // 2:, 1])])
    data = _data(v, seg=seg, poses=poses)
    starts, ends = rs.windows(data.t, seg, 2.0)
    err = rs.window_errors(model.twist(v[:, 0], v[:, 1]), data.step_dt(), poses, starts, ends)
    ref = horizon_errors(model, data.t, v[:, 0], v[:, 1], poses, 2.0, segments=seg)
    np.testing.assert_array_equal(starts, ref.start)
    np.testing.assert_allclose(np.hypot(err[:, 0], err[:, 1]), ref.pos_err, atol=1e-12)
    np.testing.assert_allclose(err[:, 2], ref.yaw_err, atol=1e-12)


def test_measured_icr_recovers_constant_icrs(rng):
    v = np.repeat([[0.2, 0.8], [0.9, -0.1], [-0.5, 0.5]], 100, axis=0)
    truth = MICR(0.3, -0.25, 0.05)
    t = np.arange(v.shape[0]) * 0.05
    poses = integrate(truth, [0, 0, 0], t, v[:, 0], v[:, 1])
    data = _data(v, poses=poses)
    starts, ends = rs.windows(data.t, data.seg, 1.0)
    icr = rs.measured_icr(data, starts, ends, v)
    assert icr["turn"].size > 100
    np.testing.assert_allclose(icr["y_l"], 0.3, atol=1e-9)
    np.testing.assert_allclose(icr["y_r"], -0.25, atol=1e-9)
    np.testing.assert_allclose(icr["x_c"], 0.05, atol=1e-9)


def test_paired_t():
    assert paired_t([1, 2, 3], [1, 2, 3]) == 0.0
    assert paired_t([2, 3, 4], [1, 2, 3]) == np.inf
    assert paired_t([2, 3, 5], [1, 2, 3]) == pytest.approx(4 / 3 / (np.std([1, 1, 2], ddof=1) / np.sqrt(3)))
