"""Properties of the diagnosis building blocks: surrogate, input transforms, windows, statistics."""

from __future__ import annotations

import numpy as np
import pytest

from mjtrack.diagnose import residuals as rs
from mjtrack.diagnose.stats import paired_t
from mjtrack.diagnose.surrogate import Surrogate
from mjtrack.diagnose.surrogate import response as sg
from mjtrack.diagnose.surrogate.fit import SETTINGS
from mjtrack.diagnose.vocabulary import EFFECTS
from mjtrack.io.robot import G, Robot
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


def test_effects_at_their_nominal_values_reduce_to_the_baseline(rng):
    v = _steps(rng)
    poses = np.column_stack([np.zeros((v.shape[0], 2)), rng.uniform(-3, 3, v.shape[0])])
    data = _data(v, poses=poses)
    s = Surrogate(ROBOT, "coulomb")
    base = s.twist(data, v)
    for name, settings in SETTINGS.items():  # every effect the surrogate simulates
        e, nominal = EFFECTS[name], settings.nominal(ROBOT)
        if e.kind == "input":
            if e.name == "drive_lag":
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
    np.testing.assert_allclose(s.inputs(data, EFFECTS["drive_speed_limit"], [0.3]), np.clip(v, -0.3, 0.3))
    delayed = np.vstack([np.repeat(v[:1], 5, axis=0), v[:-5]])  # held at the initial speed before the start
    np.testing.assert_allclose(s.inputs(data, EFFECTS["drive_delay"], [0.25]), delayed, atol=1e-12)
    tau = 0.3
    lag = s.inputs(data, EFFECTS["drive_lag"], [tau], instant=True)
    t = data.t[10:] - data.t[10]
    np.testing.assert_allclose(lag[10:, 0], 0.5 * (1 - np.exp(-t / tau)), atol=1e-12)
    mean = s.inputs(data, EFFECTS["drive_lag"], [tau])  # mean over each held step
    h = 0.05
    np.testing.assert_allclose(mean[10:, 0], 0.5 - 0.5 * np.exp(-t / tau) * tau / h * (1 - np.exp(-h / tau)), atol=1e-12)


def test_lag_filter_paths_agree(rng):
    """The lfilter path (long segments) equals the exact recursion (short segments)."""
    import mjtrack.diagnose.surrogate.model as eff

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


# -- the friction-limited transient of the rigid body (surrogate.friction_limited) ---------------
def _dead_time(x: np.ndarray, x0: float, h: float) -> float:
    """Equivalent dead time [s] int (x_end - x)/(x_end - x0) dt of per-step means x (exact for them)."""
    return float(np.sum(x[-1] - x) * h / (x[-1] - x0))


def _transient(u0, u1, *, h=1e-3, n=600, fs=1.0, robot=ROBOT):
    """Per-step means (n, 2) of the effective track speeds after the step u0 -> u1 at sample 10."""
    u = np.array([u0] * 10 + [u1] * n, float)
    s = Surrogate(robot, "coulomb", transient=True)
    return s.effective_speeds(_data(u, dt=h), u, {"friction_scale": fs} if fs != 1.0 else None)[10:]


def _params(robot=ROBOT):
    r = sg.ground_response(robot)
    b = robot.mu * G / 2
    kappa = 3 * robot.track_gauge * (r.q0[0] - r.q0[1]) / (robot.track_length**2 + robot.track_gauge**2)
    return b, kappa, r.resist_ratio * 2 * b


def test_friction_limited_straight_step_is_the_mu_g_ramp():
    """Both tracks stepping together: no yaw, the common mode ramps at (b_L + b_R) = mu g, the
    accel_limited ramp exactly."""
    h = 0.05
    u = np.r_[np.zeros(10), np.full(20, 0.7), np.full(10, -0.5)]
    starts = np.zeros(u.size, bool)
    starts[0] = True
    b, kappa, resist = _params()
    e = sg.friction_limited(np.stack([u, u], -1), np.full(u.size, h), starts, b_left=b, b_right=b, kappa=kappa,
                            resist=resist)
    np.testing.assert_allclose(e[:, 0], e[:, 1], atol=1e-12)
    np.testing.assert_allclose(e[:, 0], sg.accel_limited(u, np.full(u.size, h), 2 * b, starts), atol=1e-12)


def test_friction_limited_turn_entry_closed_form():
    """Entering a turn from straight, (V, V) -> (V, 0): the left track holds its speed with
    f_L = ((kappa - 1) f_R - kappa m)/(1 + kappa), f_R = -b, m = -resist (the yaw is clockwise),
    so d = (e_R - e_L)/2 ramps at kappa (f_R - f_L - m) and its dead time is (V/2) / (2 |d'|)."""
    V, h = 0.6, 1e-3
    b, kappa, resist = _params()
    e = _transient((V, V), (V, 0.0), h=h)
    fl = ((kappa - 1) * -b + kappa * resist) / (1 + kappa)
    dd = kappa * (-b - fl + resist)
    assert dd < 0 and abs(fl) < b
    np.testing.assert_allclose(e[:, 0], V, atol=1e-12)  # the outer track keeps its speed
    assert _dead_time(0.5 * (e[:, 1] - e[:, 0]), 0.0, h) == pytest.approx((V / 2) / (2 * abs(dd)), rel=1e-6)


@pytest.mark.parametrize("fs", [0.5, 2.0])
def test_friction_scale_scales_the_transient_time(fs):
    """Every acceleration of the reduced model is proportional to the friction (the force bounds
    and the turning resistance): the transient's dead times scale exactly as 1/fs."""
    h = 1e-3
    for u0, u1 in [((0.0, 0.0), (0.6, 0.6)), ((0.6, 0.6), (0.6, 0.0)), ((0.5, -0.5), (-0.5, 0.5))]:
        d0, d1 = 0.5 * (u0[1] - u0[0]), 0.5 * (u0[1] + u0[0])
        ref, sc = _transient(u0, u1, h=h, n=1200), _transient(u0, u1, h=h, n=1200, fs=fs)
        for mode, x0 in ((lambda e: 0.5 * (e[:, 1] - e[:, 0]), d0), (lambda e: e.mean(1), d1)):
            if abs(mode(ref)[-1] - x0) > 1e-6:
                assert _dead_time(mode(sc), x0, h) == pytest.approx(_dead_time(mode(ref), x0, h) / fs, rel=1e-6)


# (u0, u1), largest |relative error| of the reduced model's yaw dead time vs the Coulomb rollout.
# The reduced model puts each sliding track's force at its Coulomb bound and the turning resistance at
# its steady value; the rigid body builds the slip pattern gradually: measured +49 % / +38 % on the two
# turn entries, -4 % / -3 % on the reversals (python -m pytest -q -s tests/test_diagnose_units.py -k rollout).
# The first entry's bound was 0.4 while the rollout's load transfer took one fixed-point step; solved to
# convergence (tests/test_coulomb_transient.py): the reference's dead
# time fell from 0.0529 to 0.0470 s, the reduced model's (0.0699 s) did not change, so the measured
# error went from +32 % to +49 %; 0.55 records that, it is the reduced model's error.
_YAW_STEPS = [(((0.6, 0.6), (0.6, 0.0)), 0.55), (((0.3, 0.3), (0.6, 0.0)), 0.4),
              (((0.6, 0.0), (0.0, 0.6)), 0.1), (((0.5, -0.5), (-0.5, 0.5)), 0.1)]


@pytest.mark.parametrize("step, tol", _YAW_STEPS)
def test_friction_limited_yaw_dead_time_against_the_coulomb_rollout(step, tol):
    """The yaw-rate transient of the reduced model vs the time-domain Coulomb reference (box yaw
    inertia, the model's own), and better than the mode-wise mu g ramp it replaced (accel_limited)
    on the slow turn entry, where that ramp is 2.7x too fast."""
    from mjtrack.models import coulomb

    (u0, u1), h = step, 1e-3
    tw0 = (u0[0], 0.0, 0.0) if u0[0] == u0[1] else tuple(coulomb.steady_state(ROBOT, *u0).twist)
    ref = coulomb.rollout(ROBOT, np.arange(0.0, 0.4, h), u1[0], u1[1], twist0=tw0, n_points=20).twist[:, 2]
    t_ref = float(np.sum(ref[-1] - ref) * h / (ref[-1] - ref[0]))
    e = _transient(u0, u1, h=h, n=400)
    t_model = _dead_time(0.5 * (e[:, 1] - e[:, 0]), 0.5 * (u0[1] - u0[0]), h)
    print(f"{u0} -> {u1}: dead time Coulomb {t_ref:.4f} s, reduced model {t_model:.4f} s")
    assert t_model == pytest.approx(t_ref, rel=tol)
    ramp = abs(u1[1] - u1[0] - u0[1] + u0[0]) / 2 / (2 * ROBOT.mu * G)  # accel_limited's D / (2 a)
    if u0 == (0.6, 0.6):
        # better than the ramp, but not by much: 0.82 of its error against the converged rigid body;
        # 0.50 against the one-step load transfer (load_iterations=1), which made the
        # reference itself 12 % slow here. 0.9 keeps the claim "better", not the digits.
        assert abs(t_model - t_ref) < 0.9 * abs(ramp - t_ref)


# -- statistics on per-window arrays (mjtrack.diagnose.stats) and the physics of ties -------
def test_blocks_pool_short_segments_and_cut_long_ones():
    from mjtrack.diagnose.stats import sample_blocks

    t = np.arange(0.0, 60.0, 0.05)
    blocks = sample_blocks(t, np.zeros(t.size, int), 2.0)  # 3 horizons = 6 s, 1 % of 60 s < 6 s
    assert blocks.max() + 1 == 10 and np.all(np.diff(blocks) >= 0)
    seg = (t // 2.0).astype(int)  # 2 s windows: pooled by three (6 s)
    blocks = sample_blocks(t, seg, 2.0)
    assert blocks.max() + 1 == 10
    assert all(np.unique(blocks[seg == k]).size == 1 for k in range(30))  # a segment is never split


def test_gain_test_sees_an_effect_in_part_of_the_log_and_not_noise():
    from mjtrack.diagnose.stats import gain_test

    rng = np.random.default_rng(0)
    m = 6000
    block = np.arange(m) // 60  # 100 blocks
    before = rng.chisquare(2, m) * 1e-4
    after = before.copy()
    part = block % 6 == 0  # the effect acts in a sixth of the blocks only, removing 80 % of its error there
    before[part] += 25e-4
    after[part] = 0.2 * before[part]
    g = gain_test(before, after, block)
    assert g.lower > 0 and g.relative > 0.3 and g.blocks == 100
    noise = gain_test(before, before * rng.uniform(0.98, 1.02, m), block)
    assert noise.lower < 0 < noise.upper


def test_cluster_sandwich_reduces_to_the_iid_formula():
    from mjtrack.diagnose.stats import cluster_sandwich as sandwich

    rng = np.random.default_rng(1)
    jac = rng.normal(size=(4000, 2))
    r = rng.normal(0, 0.5, 4000)
    cov = sandwich(jac, r, np.arange(4000))
    np.testing.assert_allclose(cov, 0.25 * np.linalg.inv(jac.T @ jac), rtol=0.1, atol=1e-6)


def test_gain_in_one_block_does_not_pass_on_round_off():
    """An effect that acts in 1 of 10 blocks and leaves the others equal up to round-off: a
    bootstrap replicate without that block has no gain (not +1e-16), so the one-sided bound is
    not above zero ((1 - 1/10)^10 = 35 % of the replicates draw none of it)."""
    from mjtrack.diagnose.stats import gain_test

    rng = np.random.default_rng(3)
    block = np.repeat(np.arange(10), 5)
    before = rng.uniform(0.5, 1.5, block.size)
    after = before * (1.0 - 2.0**-52)  # the last bit: what two fits that agree to round-off give
    after[block == 0] *= 0.2
    assert np.all(after[block > 0] < before[block > 0])
    gt = gain_test(before, after, block)
    assert gt.relative > 0.02 and gt.lower <= 0.0 and gt.p >= 0.2


def test_traction_ratio_equivalents_round_trip():
    from mjtrack.diagnose.ties import equivalent, traction_ratio

    a = equivalent(ROBOT, "cg_y", 0.06)  # the friction asymmetry that sets the same ratio
    assert traction_ratio(ROBOT, "mu_ratio", a) == pytest.approx(traction_ratio(ROBOT, "cg_y", 0.06))
    assert equivalent(ROBOT, "mu_ratio", a) == pytest.approx(0.06)
    assert a == pytest.approx((0.2 + 0.06) / (0.2 - 0.06))  # lever rule with T = 0.4 m


def test_transient_carries_on_across_a_chained_window_start():
    """A DRIVE log's windows (1.95 s of every 2 s, each its own segment): a command change at a
    window start is followed by the friction-limited transient, starting from the previous
    window's motion; after a long gap (an unchained segment) the segment starts in steady motion."""
    h = 0.05
    t = np.r_[np.arange(39) * h, 2.0 + np.arange(39) * h]  # the sample at 1.95 s dropped
    seg = np.r_[np.zeros(39, int), np.ones(39, int)]
    v = np.r_[np.full((39, 2), 0.2), np.full((39, 2), 0.9)]
    sur = Surrogate(ROBOT, "coulomb", transient=True)
    chained = rs.DriveData(t=t, seg=seg, cmd=v, meas=None, poses=np.zeros((t.size, 3)))
    e = sur.effective_speeds(chained, v)
    b = ROBOT.mu * G / 2  # per track, equal loads: the common mode ramps at mu g
    ramp = 0.7 / (2 * b)  # [s] from 0.2 to 0.9 m/s
    assert e[39, 0] < 0.9 - 0.5 * h * 2 * b  # still ramping through the first step of the new window
    # the straight ramp of the new window is the mu g ramp from the previous window's speed
    u = np.r_[0.2, v[39:, 0]]
    np.testing.assert_allclose(e[39:, 0], sg.accel_limited(u, np.full(u.size, h), 2 * b, np.r_[True, np.zeros(39, bool)])[1:],
                               atol=1e-9)
    k = int(np.ceil(ramp / h)) + 1
    np.testing.assert_allclose(e[39 + k:], 0.9, atol=1e-9)  # arrived
    far = rs.DriveData(t=np.r_[t[:39], t[39:] + 1.0], seg=seg, cmd=v, meas=None, poses=np.zeros((t.size, 3)))
    np.testing.assert_allclose(sur.effective_speeds(far, v)[39:], 0.9, atol=1e-12)


def test_min_active_blocks_is_where_the_blocked_bootstrap_bound_leaves_zero():
    """An effect that acts in k of B blocks (exactly no change elsewhere): the one-sided 95 %
    bound of the gain test exceeds zero from k = min_active_blocks(B) on, not below."""
    from mjtrack.diagnose.stats import min_active_blocks
    from mjtrack.diagnose.stats import gain_test

    rng = np.random.default_rng(1)
    n_blocks = 40
    block = np.arange(n_blocks * 30) // 30
    before = rng.chisquare(2, block.size) * 1e-4 + 1e-3
    need = min_active_blocks(n_blocks)
    assert need == 3
    for k in (need - 1, need, need + 2):
        after = before.copy()
        act = np.isin(block, rng.choice(n_blocks, k, replace=False))
        after[act] *= 0.1
        g = gain_test(before, after, block)
        assert (g.lower > 0) == (k >= need), (k, g)


def test_pose_floor_is_a_share_of_the_nominal_error():
    """The gain floor of a step on top of found effects is min_gain of the nominal RMSE, as a
    share of the step's own (never below min_gain)."""
    from mjtrack.diagnose.select import pose_floor
    assert pose_floor(0.03, None, 0.01) == 0.03
    assert pose_floor(0.03, 0.2, 0.02) == pytest.approx(0.3)  # 3 % of 0.2 m = 6 mm = 30 % of 0.02 m
    assert pose_floor(0.03, 0.2, 0.4) == 0.03


def _candidate(name, sq_err, base=()):
    from mjtrack.diagnose.select import CandidateResult
    err = np.zeros((sq_err.size, 3))
    err[:, 0] = np.sqrt(sq_err)
    z = np.zeros(1)
    return CandidateResult(EFFECTS[name], z, z[None], np.zeros((1, 2)), z, z, 1.0, float(np.sqrt(sq_err.mean())),
                           0.0, None, None, None, True, "", err, on_top_of=tuple(base))


@pytest.mark.parametrize("rival_sq,named", [(0.0100, False), (0.0200, True)])
def test_an_effect_on_top_is_named_only_if_it_beats_every_rival_alone(rng, rival_sq, named):
    """drive_delay + friction_scale against drive_lag alone: not named when the lag alone does
    as well (the first is then reported tied with it), named when the pair beats it by the floor."""
    from mjtrack.diagnose.select import _no_substitute, _tie_substitutes
    n = 400
    block = np.arange(n) // 20
    nominal_sq = np.full(n, 0.04) * rng.uniform(0.9, 1.1, n)  # a nominal RMSE of 0.2 m
    pair = _candidate("friction_scale", 0.0100 * rng.uniform(0.9, 1.1, n), base=("drive_delay",))
    lag = _candidate("drive_lag", rival_sq * rng.uniform(0.9, 1.1, n))
    first = _candidate("drive_delay", 0.0150 * rng.uniform(0.9, 1.1, n))
    _no_substitute(pair, [lag], nominal_sq, block, 0.03)
    assert pair.passed is named
    assert pair.substitute == (None if named else "drive_lag")
    _tie_substitutes(first, [pair], [lag])
    assert ("drive_lag" in first.tied_with) is (not named)
    assert ("drive_delay" in lag.tied_with) is (not named)
    if not named:
        assert "drive_lag alone explains the log as well" in first.tie_notes[0]


def test_a_further_step_only_when_the_error_left_can_hold_a_finding():
    """After a finding with 0.05 m left, pose noise 0.02 m and a floor of 3 % of a 0.5 m nominal
    error (0.015 m), another effect could still remove 0.03 m: a further step; with 0.03 m left it
    could remove at most 0.01 m, below the floor: none."""
    from mjtrack.diagnose.select import residual_left

    left = _candidate("drive_delay", np.full(10, 0.05 ** 2))
    assert left.after == pytest.approx(0.05)
    assert residual_left(left, 0.5, 0.02, 0.03)
    assert not residual_left(_candidate("drive_delay", np.full(10, 0.03 ** 2)), 0.5, 0.02, 0.03)
