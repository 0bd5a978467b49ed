"""mjtrack.validate and ``mjtrack validate``: horizon errors, window fits, metric sanity, outputs, CLI."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from mjtrack.demo import DEMO_ROBOT, demo_commands
from mjtrack.errors import InputError
from mjtrack.estimation.icr_ekf import InverseICR
from mjtrack.icr import twist_from_icr
from mjtrack.io.logs import DriveLog, robot_path_for, write_log
from mjtrack.io.robot import write_robot
from mjtrack.metrics import horizon_errors
from mjtrack.models import MICR, MPP, Nominal, integrate
from mjtrack.validate import (Noise, case_from_log, evaluate_case, fit_icr_windows, fit_mpp_windows,
                              horizon_errors_per_start, mpp_case, run_filters, validate)
from mjtrack.validate.horizon import starts_for
from mjtrack.validate.truth import Case

DURATION = 16.0  # [s] short: the default run stays fast; long enough for the filters to converge
T = DEMO_ROBOT.track_gauge


@pytest.fixture(scope="module")
def drive() -> DriveLog:
    from mjtrack.sim.rollout import drive_log

    return drive_log(DEMO_ROBOT, demo_commands(DEMO_ROBOT, duration=DURATION, seed=0), duration=DURATION)


@pytest.fixture(scope="module")
def validation(drive, tmp_path_factory):
    return validate(drive, DEMO_ROBOT, tmp_path_factory.mktemp("val"), source="test rollout", quiet=True)


def test_per_start_errors_equal_metrics_horizon_errors_for_constant_parameters(drive):
    case = case_from_log(drive)
    stride = 7
    for model in (Nominal(T), MPP(T, 0.1, -0.05, 0.2), MICR(0.3, -0.25, 0.05)):
        ref = horizon_errors(model, case.t, case.v_left, case.v_right, case.pose, 1.0, stride=stride)
        got = horizon_errors_per_start(model, model.params, case, 1.0, starts=np.arange(0, case.t.size, stride))
        np.testing.assert_array_equal(got.start, ref.start)
        np.testing.assert_array_equal(got.end, ref.end)
        np.testing.assert_allclose(got.pos_err, ref.pos_err, atol=1e-10)
        np.testing.assert_allclose(got.yaw_err, ref.yaw_err, atol=1e-10)


def test_per_start_parameters_are_held_over_the_horizon(drive):
    """Parameters that jump after the start must not change a prediction that started before."""
    case = case_from_log(drive)
    p = np.tile(MPP(T, 0.1, 0.0, 0.1).params, (case.t.size, 1))
    jumped = p.copy()
    jumped[200:] = [0.5, 0.5, -0.5]
    a = horizon_errors_per_start(MPP(T), p, case, 1.0, starts=[100])
    b = horizon_errors_per_start(MPP(T), jumped, case, 1.0, starts=[100])
    np.testing.assert_array_equal(a.predicted, b.predicted)
    c = horizon_errors_per_start(MPP(T), jumped, case, 1.0, starts=[200])
    d = horizon_errors_per_start(MPP(T), p, case, 1.0, starts=[200])
    assert not np.allclose(c.predicted, d.predicted)


def test_window_fits_recover_an_mpp_truth(drive):
    """On the MPP truth the MPP window fit returns the known slips wherever the window is excited,
    and the ICR fit reproduces the true twist exactly inside windows of one constant command."""
    mj = case_from_log(drive, speeds="cmd", noise=Noise(scale=0.0))  # piecewise-constant commands
    truth = {"s_left": 0.2, "s_right": 0.05, "alpha": math.radians(10.0)}
    case = mpp_case(mj, DEMO_ROBOT, params=truth, noise=Noise(scale=0.0))
    fit = fit_mpp_windows(case, T, 1.0)
    moving = (np.abs(case.v_left) > 0.1) & (np.abs(case.v_right) > 0.1) & (case.t < case.t[-1] - 1.0)
    # ridge lambda = (1 mm/s)^2 h against sum V^2 dt >= 0.01 m^2 s: relative bias <= 1e-4
    np.testing.assert_allclose(fit[moving], np.tile([0.2, 0.05, math.radians(10.0)], (moving.sum(), 1)), atol=5e-3)
    psi = fit_icr_windows(case, T, 0.5)
    n = case.t.size
    end = np.minimum(np.searchsorted(case.t, case.t + 0.5 - 1e-9), n - 1)
    const = np.array([np.ptp(case.v_left[k:end[k] + 1]) == 0 and np.ptp(case.v_right[k:end[k] + 1]) == 0
                      and abs(case.v_right[k] - case.v_left[k]) > 0.05 for k in range(n)])
    assert const.sum() > n / 2
    model = InverseICR(*psi[const].T)
    np.testing.assert_allclose(model.twist(case.v_left[const], case.v_right[const]), case.twist[const], atol=3e-4)  # ridge bias <= 4e-4 x |twist| <= 0.5


def test_mpp_truth_filter_fitted_mpp_beats_nominal_by_a_large_factor(validation):
    head = validation.metrics["headline"]["pos_rmse_m"]["mpp"]
    # measured ~50x on 16 s and 60 s logs; 10x is "large" and leaves room for seeds and durations
    assert head["nominal"] > 10 * head["mpp_slip_ekf"], head


def test_mpp_truth_slip_ekf_recovers_the_known_slips(validation):
    err = validation.metrics["truths"]["mpp"]["filters"]["slip_ekf"]["param_error_final"]
    assert err["s_left"] < 0.02 and err["s_right"] < 0.02, err
    assert err["alpha"] < math.radians(2.0), err


def test_mujoco_truth_own_icr_micr_beats_nominal(validation):
    head = validation.metrics["headline"]["pos_rmse_m"]["log"]
    # measured ~8x (16 s) and ~15x (60 s); demand 3x
    assert head["nominal"] > 3 * head["micr_own_icr"], head


def test_own_icrs_are_masked_where_the_robot_does_not_turn(validation):
    res = validation.results["log"]
    wz = res.case.twist[:, 2]
    assert not np.any(res.icr_true.valid[np.abs(wz) < 0.05])
    assert np.all(np.isnan(res.icr_true.y_l[~res.icr_true.valid]))
    assert res.metrics["icr_samples_compared"] > 0


def test_metrics_json_holds_every_predictor_horizon_and_the_verdicts(validation):
    doc = json.loads(validation.metrics_path.read_text())  # strict JSON: no NaN
    keys = {"nominal", "mpp_slip_ekf", "micr_icr_ekf", "mvir_vir_filter", "mpp_fit", "micr_own_icr"}
    for truth in ("log", "mpp"):
        preds = doc["truths"][truth]["predictors"]
        assert set(preds) == keys
        for entry in preds.values():
            assert set(entry["horizons"]) == {"0.5", "1", "2", "5"}
            assert all(v["pos_rmse_m"] >= 0 and v["n"] > 0 for v in entry["horizons"].values())
    assert set(doc["verdicts"]) == keys
    assert doc["setup"]["speeds"] == "measured"
    html = validation.report_path.read_text()
    for text in doc["verdicts"].values():
        assert text.split(":")[0] in html
    assert html.count("data:image/png;base64,") == 8  # horizon, 2 x (paths, ICRs), MPP params, 2 x NIS
    for truth in ("log", "mpp"):
        for name, f in doc["truths"][truth]["filters"].items():
            c = f["consistency"]
            assert set(c) >= {"nis_mean", "nis_dof", "nees_mean", "nees_dof", "band95"}
            assert c["nis_mean"] > 0 and c["nees_mean"] > 0, (truth, name)
            assert c["band95"]["nis"][0] < c["nis_dof"] < c["band95"]["nis"][1]


def test_noise_is_seeded_and_scale_zero_gives_the_truth(drive):
    a, b = case_from_log(drive, seed=3), case_from_log(drive, seed=3)
    np.testing.assert_array_equal(a.pose_meas, b.pose_meas)
    c = case_from_log(drive, seed=4)
    assert not np.array_equal(a.pose_meas, c.pose_meas)
    clean = case_from_log(drive, noise=Noise(scale=0.0))
    np.testing.assert_array_equal(clean.pose_meas, clean.pose)
    noise = (a.pose_meas - a.pose)[:, 0]
    assert 0.7 * 0.01 < noise.std() < 1.3 * 0.01  # sigma 1 cm, ~800 samples


def test_speeds_auto_is_measured_when_logged_else_commanded(drive):
    assert case_from_log(drive).info["speeds"] == "measured"
    bare = drive.replace(v_left=None, v_right=None)
    assert case_from_log(bare).info["speeds"] == "cmd"
    with pytest.raises(InputError, match="no measured track speeds"):
        case_from_log(bare, speeds="measured")


def _spin_case():
    """A spin turn with an offset centre needs vy != 0 at vx = 0: MPP's alpha runs to 90 deg."""
    t = np.arange(0, 6.0, 0.02)
    vl, vr = np.full(t.size, -0.5), np.full(t.size, 0.5)
    truth = MICR(0.25, -0.25, 0.08)
    pose = integrate(truth, np.zeros(3), t, vl, vr)
    twist = np.tile(twist_from_icr(0.25, -0.25, 0.08, -0.5, 0.5), (t.size, 1))
    return Case("log", "spin", t, vl, vr, pose, twist, pose.copy(), twist.copy(), np.zeros(t.size, int))


def test_mpp_cannot_express_a_spin_turn_with_offset_centre_but_its_filter_survives():
    res = evaluate_case(_spin_case(), T, horizons=(0.5, 2.0))
    assert res.filters["slip_ekf"].error is None  # alpha is projected inside its bound
    mpp = res.metrics["predictors"]["mpp_slip_ekf"]["horizons"]["2"]["pos_rmse_m"]
    micr = res.metrics["predictors"]["micr_icr_ekf"]["horizons"]["2"]["pos_rmse_m"]
    assert micr < 0.05 and mpp > 2 * micr  # a structural limit of MPP, not of its filter


def test_a_filter_that_fails_is_reported_not_raised(monkeypatch):
    import mjtrack.validate.predictors as predictors
    from mjtrack.errors import MjtrackError

    def broken(*args, **kwargs):
        raise MjtrackError("diverged (injected by the test)")

    monkeypatch.setattr(predictors, "run_slip_ekf", broken)
    res = evaluate_case(_spin_case(), T, horizons=(0.5, 2.0))
    assert "injected" in res.filters["slip_ekf"].error
    entry = res.metrics["predictors"]["mpp_slip_ekf"]
    assert "failed" in entry and math.isnan(entry["horizons"]["2"]["pos_rmse_m"])
    assert res.metrics["predictors"]["micr_icr_ekf"]["horizons"]["2"]["pos_rmse_m"] < 0.05


def test_filters_carry_parameters_across_segments_and_restart_the_pose(drive):
    n = drive.n_samples
    window = np.where(np.arange(n) < n // 2, 0, 1)
    case = case_from_log(drive.replace(window=window), noise=Noise(scale=0.0))
    carried = run_filters(case, T, adaptive=None)  # single random walks: the carrying is the same, at half the cost
    restarted = run_filters(case, T, adaptive=None, carry=False)
    np.testing.assert_array_equal(restarted["slip_ekf"].params[n // 2], [0.0, 0.0, 0.0])
    np.testing.assert_allclose(restarted["icr_ekf"].params[n // 2], InverseICR.nominal(T).params)
    for name in ("slip_ekf", "icr_ekf", "vir_filter"):
        np.testing.assert_array_equal(carried[name].params[n // 2], carried[name].params[n // 2 - 1])
        second = carried[name].results[1]
        np.testing.assert_allclose(second.x_prior[0, :2], case.pose_meas[n // 2, :2], atol=0.5)  # pose restarts
    errs = horizon_errors_per_start(Nominal(T), [T], case, 2.0, starts=starts_for(case))
    seg = window
    assert np.all(seg[errs.start] == seg[errs.end])


def test_carried_covariance_grows_by_the_random_walk_over_the_gap():
    from mjtrack.estimation.common import History
    from mjtrack.validate.predictors import _run_segments

    t = np.r_[np.arange(5) * 0.1, 10.0 + np.arange(5) * 0.1]  # gap of 9.6 s between the windows
    z = np.zeros((10, 3))
    case = Case("log", "test", t, np.ones(10), np.ones(10), z, z, z, z, np.r_[np.zeros(5, int), np.ones(5, int)])
    seen = []

    def fake(tt, vl, vr, pm, tm, p, P):
        seen.append((p.copy(), P.copy()))
        h = History(4, 1)
        for k in range(1, tt.size):
            h.add(tt[k], np.r_[0, 0, 0, p + 1], np.diag([1, 1, 1, P[0, 0] / 4]), np.r_[0, 0, 0, p + 1],
                  np.diag([1, 1, 1, P[0, 0] / 4]), [0.0], [0.0])
        return h.result("fake", ("x", "y", "theta", "p"), ("z",))

    q2 = np.array([0.01])
    _run_segments(case, fake, np.array([0.0]), np.eye(1), q2, ("p",), "fake", "z")
    (p1, P1), (p2, P2) = seen
    assert p1[0] == 0.0 and p2[0] == 1.0  # the first window's final estimate
    np.testing.assert_allclose(P2[0, 0], 0.25 + 0.01 * (10.0 - 0.4))


# -- command line ----------------------------------------------------------------------------
@pytest.fixture
def cli(monkeypatch):
    import mjtrack.cli
    from support.cli import run_cli

    monkeypatch.setitem(mjtrack.cli.COMMANDS, "validate", "validate")
    return run_cli


def test_cli_validate_a_log_writes_report_and_metrics(cli, drive, tmp_path):
    log_path = tmp_path / "run.csv"
    write_log(drive.slice(0, 400), log_path)
    write_robot(DEMO_ROBOT, robot_path_for(log_path))
    res = cli(["validate", log_path, "--out", tmp_path / "out", "--quiet"])
    assert res.rc == 0, res.err
    assert (tmp_path / "out" / "report.html").stat().st_size > 10000
    doc = json.loads((tmp_path / "out" / "metrics.json").read_text())
    assert doc["setup"]["source"].endswith("run.csv") and doc["setup"]["samples"] == 400
    assert "report.html" in res.out


def test_cli_validate_refuses_bad_input(cli, drive, tmp_path):
    from support.cli import assert_usage_error

    assert_usage_error(cli(["validate", "--out", tmp_path / "o"]), "LOG.csv or --scenario")
    log_path = tmp_path / "norobot.csv"
    write_log(drive.slice(0, 100), log_path)
    assert_usage_error(cli(["validate", log_path, "--out", tmp_path / "o"]), "no robot description")
    assert_usage_error(cli(["validate", log_path, "--scenario", "circle", "--out", tmp_path / "o"]), "exactly one")
    assert_usage_error(cli(["validate", log_path, "--track-gauge", "0.4", "--duration", "3", "--out", tmp_path / "o"]),
                       "--duration")
    assert not (tmp_path / "o").exists()


def test_cli_validate_a_scenario(cli, tmp_path):
    res = cli(["validate", "--scenario", "circle", "--duration", "6", "--cg-x", "0.05", "--out", tmp_path / "c"])
    assert res.rc == 0, res.err
    doc = json.loads((tmp_path / "c" / "metrics.json").read_text())
    assert doc["setup"]["robot"]["cg_x"] == 0.05
    assert "2-s position RMSE" in res.out


def test_a_log_without_twist_uses_the_differenced_poses(drive):
    bare = drive.replace(vx=None, vy=None, wz=None)
    case = case_from_log(bare, noise=Noise(scale=0.0))
    assert case.info["twist_from"] == "differenced poses"
    ref = case_from_log(drive, noise=Noise(scale=0.0))
    # the mean twist over each 20 ms step vs the sampled one: equal up to the step's change
    # of speed (accelerations up to ~2 m/s^2 at command steps -> a few cm/s there)
    assert np.median(np.abs(case.twist - ref.twist)) < 2e-3


def test_measured_log_noise_is_estimated_from_the_poses():
    """A smooth circle sampled at 20 Hz plus known white pose noise: the estimate recovers it (±10 %)."""
    from mjtrack.validate.truth import estimate_noise

    t = np.arange(4000) * 0.05
    true = np.stack([np.sin(0.5 * t), 1 - np.cos(0.5 * t), 0.5 * t], -1)
    std = np.array([0.012, 0.008, math.radians(2.0)])
    meas = true + np.random.default_rng(7).normal(size=true.shape) * std
    twist = np.zeros_like(true)
    case = Case("log", "measured log", t, np.ones(t.size), np.ones(t.size), meas, twist, meas, twist,
                np.repeat(np.arange(40), 100), None, {"twist_from": "differenced poses"}, None, False)
    est = estimate_noise(case)
    np.testing.assert_allclose(est.pose_std, std, rtol=0.1)
    np.testing.assert_allclose(est.twist_std, math.sqrt(2) * std / 0.05, rtol=0.1)
