"""Adaptive (IMM) parameter filters and the consistency summaries (mjtrack.estimation.imm / consistency).

Generators: MICR / MPP truths from mjtrack.models (closed-form twists) stepped with the exact SE(2)
step of mjtrack.geometry; nothing here calls the filters' transition or measurement code.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mjtrack.errors import InputError
from mjtrack.estimation import InverseICR, icr_from_psi, run_icr_ekf, run_slip_ekf
from mjtrack.estimation import consistency as cons
from mjtrack.estimation.imm import IMMSettings, combine, mix, posterior_probabilities
from mjtrack.estimation.online import OnlineICREstimator
from mjtrack.geometry import se2_step
from mjtrack.models import MICR, MPP

T = 0.4
POSE_STD = np.array([0.01, 0.01, 0.01])
TWIST_STD = np.array([0.02, 0.02, 0.02])


def micr_drive(icr_before, icr_after, t_change, *, seed, duration=30.0, dt=0.04, v=0.5, w=0.5):
    """Circle commands; the true ICRs jump at t_change. Returns t, V_L, V_R, noisy pose, noisy twist."""
    t = np.arange(int(round(duration / dt)) + 1) * dt
    vl, vr = np.full(t.size, v - w * T / 2), np.full(t.size, v + w * T / 2)
    pose = np.zeros((t.size, 3))
    twist = np.zeros((t.size, 3))
    for k in range(t.size):
        m = MICR(*(icr_before if t[k] < t_change else icr_after))
        twist[k] = m.twist(vl[k], vr[k])
        if k + 1 < t.size:
            pose[k + 1] = se2_step(pose[k], twist[k], dt)
    rng = np.random.default_rng(seed)
    return t, vl, vr, pose + rng.normal(size=pose.shape) * POSE_STD, twist + rng.normal(size=twist.shape) * TWIST_STD


def test_settings_validate_and_transition_rows_sum_to_one():
    s = IMMSettings()
    pi = s.transition_matrix(0.04)
    np.testing.assert_allclose(pi.sum(1), 1.0)
    assert pi[0, 1] < 1e-4 < pi[1, 0]
    assert s.transition_matrix(0.04, du=0.5)[0, 1] > 0.9  # a step of the command announces a change
    for bad in (dict(fast_factor=0.0), dict(fast_meas_factor=0.5), dict(dwell_s=(1.0,)), dict(prior=(0.7, 0.7)),
                dict(command_scale=-1.0)):
        with pytest.raises(InputError):
            IMMSettings(**bad)


def test_mixing_and_combination_are_moment_matching():
    rng = np.random.default_rng(0)
    xs = [rng.normal(size=2), rng.normal(size=2)]
    Ps = [np.eye(2) * 0.1, np.eye(2) * 0.3]
    x, P = combine(xs, Ps, np.array([0.25, 0.75]))
    samples = np.concatenate([rng.multivariate_normal(xs[0], Ps[0], 100_000), rng.multivariate_normal(xs[1], Ps[1], 300_000)])
    np.testing.assert_allclose(x, samples.mean(0), atol=5e-3)
    np.testing.assert_allclose(P, np.cov(samples.T), atol=5e-3)
    x0, P0, cbar = mix(xs, Ps, np.array([1.0, 0.0]), np.array([[0.9, 0.1], [0.2, 0.8]]))
    np.testing.assert_allclose(cbar, [0.9, 0.1])
    np.testing.assert_allclose(x0[1], xs[0])  # all of the fast mode's mass came from the slow one
    np.testing.assert_allclose(posterior_probabilities([0.0, math.log(3.0)], np.array([0.5, 0.5])), [0.25, 0.75])


def test_imm_of_two_equal_modes_is_the_single_ekf():
    t, vl, vr, pm, tm = micr_drive((0.25, -0.25, 0.05), (0.25, -0.25, 0.05), 99.0, seed=1, duration=6.0)
    kw = dict(track_gauge=T, pose_meas=pm, twist_meas=tm, pose_std=POSE_STD, twist_std=TWIST_STD)
    single = run_icr_ekf(t, vl, vr, **kw)
    imm = run_icr_ekf(t, vl, vr, adaptive=IMMSettings(fast_factor=1.0, fast_meas_factor=1.0), **kw)
    np.testing.assert_allclose(imm.x_post, single.x_post, atol=1e-9)
    np.testing.assert_allclose(imm.P_post, single.P_post, atol=1e-12)
    np.testing.assert_allclose(imm.nis(), single.nis(), rtol=1e-6)
    assert imm.mode_prob is not None and single.mode_prob is None


def test_adaptive_filter_recovers_from_an_icr_jump_and_stays_consistent():
    """Kinematic truth whose left ICR jumps 0.25 -> 0.45 m at 10 s (a friction drop on the left)."""
    before, after = (0.25, -0.25, 0.05), (0.45, -0.22, 0.05)
    t, vl, vr, pm, tm = micr_drive(before, after, 10.0, seed=3)
    kw = dict(track_gauge=T, pose_meas=pm, twist_meas=tm, pose_std=POSE_STD, twist_std=TWIST_STD)
    single = run_icr_ekf(t, vl, vr, **kw)
    imm = run_icr_ekf(t, vl, vr, adaptive="imm", **kw)
    truth = np.where((t[1:] < 10.0)[:, None], InverseICR.from_icr(*before).params, InverseICR.from_icr(*after).params)

    def back_after(r):
        err = np.abs(np.stack(icr_from_psi(r.x_post[:, 3:]), -1) - after).max(1)
        bad = np.flatnonzero((err > 0.05 * T / 2) & (r.t >= 10.0))
        return r.t[bad[-1] + 1] - 10.0 if bad.size else 0.0

    assert back_after(imm) < 2.0 < back_after(single)
    c_imm, c_single = cons.summary(imm, truth, t_from=3.0), cons.summary(single, truth, t_from=3.0)
    nis, nees = cons.per_dof(c_imm)
    assert 0.5 < nis < 2.0 and 1 / 3 < nees < 3.0, (nis, nees)
    assert cons.per_dof(c_single)[1] > 10.0  # the single random walk is over-confident after the jump


def test_online_estimator_adaptive_option_keeps_its_api():
    t, vl, vr, pm, tm = micr_drive((0.25, -0.25, 0.05), (0.45, -0.22, 0.05), 10.0, seed=4, duration=16.0)
    est = OnlineICREstimator(T, pose_std=POSE_STD, twist_std=TWIST_STD, adaptive="imm")
    assert OnlineICREstimator(T).mode_prob is None
    est.reset(t[0], pm[0])
    for k in range(1, t.size):
        est.step(t[k], vl[k - 1], vr[k - 1], pose=pm[k], twist=tm[k])
    np.testing.assert_allclose(est.icr(), (0.45, -0.22, 0.05), atol=0.05 * T / 2)
    assert est.P.shape == (6, 6) and est.psi_cov.shape == (3, 3) and 0.0 <= est.mode_prob <= 1.0


def test_own_parameters_invert_the_models():
    rng = np.random.default_rng(5)
    vl, vr = rng.uniform(-1, 1, 200), rng.uniform(-1, 1, 200)
    m = MICR(0.3, -0.26, 0.07)
    psi = cons.own_psi(m.twist(vl, vr), vl, vr)
    ok = np.abs(vr - vl) >= cons.DV_MIN
    np.testing.assert_allclose(psi[ok], np.broadcast_to(InverseICR.from_icr(0.3, -0.26, 0.07).params, psi[ok].shape), atol=1e-12)
    assert np.all(np.isnan(psi[~ok]))
    mpp = MPP(T, 0.15, -0.05, math.radians(10.0))
    slips = cons.own_slips(mpp.twist(vl, vr), vl, vr, T)
    good = np.all(np.isfinite(slips), axis=1)
    assert good.sum() > 100
    np.testing.assert_allclose(slips[good], np.broadcast_to([0.15, -0.05, math.radians(10.0)], slips[good].shape), atol=1e-12)


def test_steady_truth_averages_each_stretch_after_settling():
    t = np.arange(10) * 0.5
    st = cons.command_stretches(t, np.r_[np.zeros(5), np.ones(5)], np.zeros(10))
    np.testing.assert_array_equal(st, np.r_[np.zeros(5), np.ones(5)])
    vals = np.arange(10.0)[:, None]
    out = cons.steady_truth(t, vals, st, settle_s=1.0, min_samples=2)
    np.testing.assert_allclose(out[:, 0], [np.nan, np.nan, 3.0, 3.0, 3.0, np.nan, np.nan, 8.0, 8.0, 8.0])


def test_summary_reports_nis_and_nees_and_none_without_truth():
    t, vl, vr, pm, tm = micr_drive((0.25, -0.25, 0.05), (0.25, -0.25, 0.05), 99.0, seed=6, duration=8.0)
    r = run_slip_ekf(t, vl, vr, track_gauge=T, pose_meas=pm, pose_std=POSE_STD)
    c = cons.summary(r)
    assert c["nis_dof"] == 3 and c["nees_mean"] is None and c["nees_dof"] == 3 and c["n_nis"] == t.size - 1
    lo, hi = c["band95"]["nis"]
    assert lo < 3 < hi
