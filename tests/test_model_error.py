"""Model-error term (mjtrack.estimation.model_error): covariance matching of the parameter covariance.

Truths written here, independently of the filter: innovations drawn with a known excess
covariance, and an MPP robot (closed-form twist, exact SE(2) step of mjtrack.geometry) whose
slips jump to known values at each command change, by a track-speed deficit that does not scale
with the command (s = d/V: large for a slow track), which no fixed random walk describes.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mjtrack.errors import InputError
from mjtrack.estimation import run_slip_ekf
from mjtrack.estimation import consistency as cons
from mjtrack.estimation.model_error import CovarianceMatching, ModelErrorSettings, model_error_settings, scale_param_block
from mjtrack.geometry import se2_step
from mjtrack.models import MPP

T = 0.4
POSE_STD = np.array([0.01, 0.01, 0.01])
TWIST_STD = np.array([0.02, 0.02, 0.02])


def _matched_lambda(lam_true: float, noise_mult: float, *, n=6000, seed=0, gate_z=0.0):
    """Feed innovations ε ~ N(0, λ_true·JPJᵀ + n·R) with the filter's claim S = JPJᵀ + n·R; return λ's."""
    rng = np.random.default_rng(seed)
    r = np.array([0.02, 0.03, 0.01]) ** 2
    A = rng.normal(size=(3, 3)) * 0.02
    M = A @ A.T  # J P Jᵀ: correlated components, same order as R
    S = M + noise_mult * np.diag(r)
    C = lam_true * M + noise_mult * np.diag(r)
    L = np.linalg.cholesky(C)
    cm = CovarianceMatching(ModelErrorSettings(window_s=40.0, gate_z=gate_z))
    out = []
    for _ in range(n):
        cm.observe(0.04, L @ rng.normal(size=3), S, r, noise_mult)
        out.append(cm.factor())
    return np.asarray(out)


@pytest.mark.parametrize("lam_true, noise_mult", [(1.0, 1.0), (4.0, 1.0), (25.0, 1.0), (9.0, 2.5)])
def test_matching_recovers_a_known_excess(lam_true, noise_mult):
    lam = _matched_lambda(lam_true, noise_mult)
    est = lam[2000:].mean()  # after the 40-s average has filled (1000 steps per window)
    if lam_true == 1.0:
        assert est < 1.1  # max(1, ·) of a noisy average: a small upward bias only
    else:
        assert est == pytest.approx(lam_true, rel=0.1)


def test_gate_keeps_lambda_one_when_the_filter_is_right_and_opens_when_it_is_not():
    cm_settings = ModelErrorSettings(window_s=0.5, gate_z=2.33)
    rng = np.random.default_rng(1)
    r = TWIST_STD**2
    S = np.diag(r) * 1.2
    for lam_true, expect_open in ((1.0, False), (30.0, True)):
        cm = CovarianceMatching(cm_settings)
        opened = []
        for _ in range(5000):
            e = rng.normal(size=3) * np.sqrt(r + lam_true * 0.2 * r)
            cm.observe(0.04, e, S, r, 1.0)
            opened.append(cm.factor() > 1.0)
        frac = np.mean(opened[100:])
        assert (frac > 0.9) if expect_open else (frac < 0.03), (lam_true, frac)


def test_settings_and_scaling():
    assert model_error_settings(None) is None and model_error_settings(False) is None
    assert model_error_settings("matching") == ModelErrorSettings()
    for bad in (dict(window_s=0.0), dict(lambda_max=0.5), dict(gate_z=-1.0), dict(restart_after_s=0.0),
                dict(restart_window_s=-1.0), dict(steady_tol=math.nan)):
        with pytest.raises(InputError):
            ModelErrorSettings(**bad)
    with pytest.raises(InputError):
        model_error_settings("sage-husa")
    rng = np.random.default_rng(2)
    A = rng.normal(size=(6, 6))
    P = A @ A.T
    Q = scale_param_block(P, 4.0, params=(0, 1))
    np.testing.assert_allclose(Q[:3, :3], P[:3, :3])
    np.testing.assert_allclose(Q[3:5, 3:5], 4.0 * P[3:5, 3:5])
    np.testing.assert_allclose(Q[5, 5], P[5, 5])
    np.testing.assert_allclose(Q[:3, 3:5], 2.0 * P[:3, 3:5])
    assert np.all(np.linalg.eigvalsh(Q) > 0)


def jumping_slips_drive(seed, *, duration=60.0, dt=0.04, deficit=0.04, alpha=math.radians(3.0)):
    """Random steps (held 2–4 s); at each change the tracks' speed deficits d_L, d_R ~ U(−d, d) [m/s]
    are redrawn and the slips are s = d/V. Returns t, V_L, V_R, noisy pose, noisy twist, true params (N, 3)."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(duration / dt)) + 1) * dt
    vl, vr, par = np.zeros(t.size), np.zeros(t.size), np.zeros((t.size, 3))
    k = 0
    while k < t.size:
        n = int(round(rng.uniform(2.0, 4.0) / dt))
        V = rng.choice([-1, 1], 2) * rng.uniform(0.1, 0.9, 2)
        d = rng.uniform(-deficit, deficit, 2)
        vl[k:k + n], vr[k:k + n] = V
        par[k:k + n] = (d[0] / V[0], d[1] / V[1], alpha)
        k += n
    pose, twist = np.zeros((t.size, 3)), np.zeros((t.size, 3))
    for k in range(t.size):
        twist[k] = MPP(T, *par[k]).twist(vl[k], vr[k])
        if k + 1 < t.size:
            pose[k + 1] = se2_step(pose[k], twist[k], dt)
    pm = pose + rng.normal(size=pose.shape) * POSE_STD
    tm = twist + rng.normal(size=twist.shape) * TWIST_STD
    return t, vl, vr, pm, tm, par


def test_matching_makes_the_slip_ekf_consistent_when_the_slips_jump():
    """The IMM alone is over-confident when slips jump by d/V; with the matching it is not."""
    res = {}
    for label, me in (("imm", None), ("imm+matching", "auto")):
        nis, nees = [], []
        for seed in (0, 1):
            t, vl, vr, pm, tm, par = jumping_slips_drive(seed)
            r = run_slip_ekf(t, vl, vr, track_gauge=T, pose_meas=pm, twist_meas=tm, pose_std=POSE_STD,
                             twist_std=TWIST_STD, adaptive="imm", model_error=me)
            # truth on the steady parts (from 1 s after each change), the estimate's own time index
            st = cons.command_stretches(t, vl, vr)
            truth = cons.steady_truth(t, par, st, settle_s=1.0)
            c = cons.per_dof(cons.summary(r, truth[1:], t_from=5.0))
            nis.append(c[0])
            nees.append(c[1])
        res[label] = (max(nis), max(nees))
    assert res["imm"][1] > 3.0, res  # the truth written here does break the plain IMM
    nis, nees = res["imm+matching"]
    assert 0.5 <= nis <= 2.0 and 1 / 3 <= nees <= 3.0, res


def test_unopened_gate_is_the_plain_imm_and_the_thesis_filter_is_unchanged():
    t, vl, vr, pm, tm, _ = jumping_slips_drive(3, duration=10.0)
    kw = dict(track_gauge=T, pose_meas=pm, twist_meas=tm, pose_std=POSE_STD, twist_std=TWIST_STD)
    never = run_slip_ekf(t, vl, vr, adaptive="imm", model_error=ModelErrorSettings(gate_z=1e12), **kw)
    plain = run_slip_ekf(t, vl, vr, adaptive="imm", model_error=None, **kw)
    np.testing.assert_array_equal(never.x_post, plain.x_post)
    np.testing.assert_array_equal(never.P_post, plain.P_post)
    assert never.info["model_error"]["inflated_steps"] == 0
    thesis = run_slip_ekf(t, vl, vr, **kw)
    assert "model_error" not in thesis.info and "adaptive" not in thesis.info
    auto = run_slip_ekf(t, vl, vr, adaptive="imm", **kw)
    assert auto.info["model_error"]["params"] == [0, 1]


def test_mpp_from_twist_inverts_mpp_and_refuses_where_undefined():
    from mjtrack.estimation.slip_ekf import mpp_from_twist

    rng = np.random.default_rng(4)
    for _ in range(50):
        p = np.array([rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), rng.uniform(-1.2, 1.2)])
        vl, vr = rng.choice([-1, 1], 2) * rng.uniform(0.1, 1.0, 2)
        tw = MPP(T, *p).twist(vl, vr)
        if abs(tw[0]) < 0.05:
            assert mpp_from_twist(T, tw, vl, vr) is None
            continue
        np.testing.assert_allclose(mpp_from_twist(T, tw, vl, vr), p, atol=1e-12)
    assert mpp_from_twist(T, (0.3, 0.0, 0.1), 0.01, 0.5) is None


def test_restart_leaves_the_wrong_side_of_the_alpha_pole():
    """A spin turn backwards with α = −40°, the filter started at α = +80°: without the restart
    the slips turn v_x positive to suit α at the bound (+85°) and it stays there; with it the filter
    restarts from the twist's own parameters and ends at the truth."""
    import dataclasses

    from mjtrack.estimation.slip_ekf import SLIP_MODEL_ERROR

    dt = 0.04
    t = np.arange(int(10 / dt) + 1) * dt
    vl, vr = np.full(t.size, -0.9), np.full(t.size, 0.7)
    truth = np.array([0.15, 0.25, math.radians(-40.0)])
    tw = MPP(T, *truth).twist(vl[0], vr[0])
    assert tw[0] < 0  # v_x backwards: tan α = −v_y/v_x has the other sign than with v_x > 0
    pose = np.zeros((t.size, 3))
    for k in range(t.size - 1):
        pose[k + 1] = se2_step(pose[k], tw, dt)
    rng = np.random.default_rng(0)
    kw = dict(track_gauge=T, pose_meas=pose + rng.normal(size=pose.shape) * POSE_STD,
              twist_meas=tw + rng.normal(size=pose.shape) * TWIST_STD, pose_std=POSE_STD, twist_std=TWIST_STD,
              adaptive="imm", params0=(0.0, 0.0, math.radians(80.0)))
    stuck = run_slip_ekf(t, vl, vr, model_error=dataclasses.replace(SLIP_MODEL_ERROR, restart_after_s=None), **kw)
    assert stuck.x_post[-1, 5] > math.radians(80.0) and stuck.info["model_error"]["restarts"] == 0
    r = run_slip_ekf(t, vl, vr, **kw)
    assert r.info["model_error"]["restarts"] >= 1
    err = r.x_post[-1, 3:] - truth
    np.testing.assert_allclose(err, 0.0, atol=0.03)
    assert err @ np.linalg.solve(r.P_post[-1, 3:, 3:], err) < 16.0  # within 4σ of its own covariance


@pytest.mark.parametrize("cap_std", [None, 1e6])
def test_matching_stays_bounded_when_the_twist_does_not_depend_on_a_slip(cap_std):
    """Left track at rest (∂ν/∂s_L = 0) and a twist 10x noisier than the filter's R: the excess is
    large and the parameters cannot explain it; the covariance must stay at most the fresh-start one
    (with ``cap_std`` the same run with a cap of 1e6 shows that without it the variance explodes)."""
    import dataclasses

    from mjtrack.estimation.pose_ekf import run_pose_param_ekf
    from mjtrack.estimation.slip_ekf import SLIP_MODEL_ERROR

    dt = 0.04
    t = np.arange(int(20 / dt) + 1) * dt
    vl, vr = np.zeros(t.size), np.full(t.size, 0.5)
    truth = MPP(T, 0.0, 0.1, 0.05)
    tw = truth.twist(vl[0], vr[0])
    pose = np.zeros((t.size, 3))
    for k in range(t.size - 1):
        pose[k + 1] = se2_step(pose[k], tw, dt)
    rng = np.random.default_rng(7)
    pm = pose + rng.normal(size=pose.shape) * POSE_STD * 10
    tm = tw + rng.normal(size=pose.shape) * TWIST_STD * 10
    std0 = np.array([0.3, 0.3, math.radians(20.0)]) if cap_std is None else np.full(3, cap_std)
    me = dataclasses.replace(SLIP_MODEL_ERROR, restart_after_s=None)
    r = run_pose_param_ekf(MPP(T, 0.0, 0.0, 0.0), t, vl, vr, pose_meas=pm, twist_meas=tm, pose_std=POSE_STD,
                           twist_std=TWIST_STD, param_std0=std0, q_param_std=(1e-3, 1e-3, 1e-3), adaptive="imm",
                           model_error=me)
    var = r.P_post[:, 3, 3]
    assert np.all(np.isfinite(r.P_post)) and r.info["model_error"]["inflated_steps"] > 100
    if cap_std is None:
        # s_L is unobservable here, so the IMM's random walk alone lets its variance grow; the
        # matching adds no more than the fresh-start variance on top of that
        plain = run_pose_param_ekf(MPP(T, 0.0, 0.0, 0.0), t, vl, vr, pose_meas=pm, twist_meas=tm, pose_std=POSE_STD,
                                   twist_std=TWIST_STD, param_std0=std0, q_param_std=(1e-3, 1e-3, 1e-3),
                                   adaptive="imm")
        assert var.max() <= plain.P_post[:, 3, 3].max() + 0.3**2
    else:
        assert var.max() > 1e3  # what the cap prevents
