"""The drivetrain identified from a log's measured track speeds (mjtrack.calibrate.drivetrain).

The truth is generated here, sharing no code with mjtrack: each side's set-point built on a 1 ms
grid (scale, the twist controller's limits, the per-side clamp, a ramp, a dead time as a shift of
the grid), its first-order lag by scipy.signal.lsim, sampled at 20 Hz with noise."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from mjtrack.calibrate.drivetrain import fit_chain
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import Robot
from mjtrack.models.drivetrain import Chain, response

TRUTH = {"track_speed_scale": 1.2, "drive_delay_left": 0.05, "drive_delay_right": 0.1, "drive_lag_left": 0.2,
         "drive_lag_right": 0.35, "drive_turn_scale": 0.7, "drive_turn_limit": 0.35, "drive_speed_limit_left": 0.8,
         "drive_accel_limit": 2.0}
RATE = 20.0  # [Hz] the log
FINE = 0.001  # [s] the generator's grid
NOISE = 0.01  # [m/s] measured speed noise


def _truth_log(duration: float, seed: int, truth: dict) -> DriveLog:
    rng = np.random.default_rng(seed)
    n = int(duration * RATE)
    t = np.arange(n) / RATE
    holds = np.repeat(np.arange(n // 30 + 1), rng.integers(30, 70, n // 30 + 1))[:n]  # 1.5-3.5 s per command
    cmd = rng.uniform(-1.0, 1.0, (holds.max() + 1, 2))[holds]
    tf = np.arange(int(duration / FINE)) * FINE
    c = cmd[np.minimum((tf * RATE + 1e-9).astype(int), n - 1)] * truth["track_speed_scale"]
    mean, half = (c[:, 0] + c[:, 1]) / 2, (c[:, 1] - c[:, 0]) / 2 * truth.get("drive_turn_scale", 1.0)
    half = np.clip(half, -truth.get("drive_turn_limit", np.inf), truth.get("drive_turn_limit", np.inf))
    for x, key in ((mean, "drive_mean_accel_limit"), (half, "drive_turn_accel_limit")):  # the twist's ramps
        step = truth.get(key, np.inf) * FINE
        for k in range(1, len(x)):
            x[k] = x[k - 1] + np.clip(x[k] - x[k - 1], -step, step)
    u = np.stack([mean - half, mean + half], -1)
    for i, side in enumerate(("left", "right")):
        lim = truth.get(f"drive_speed_limit_{side}", np.inf)
        u[:, i] = np.clip(u[:, i], -lim, lim)
    a = truth.get("drive_accel_limit", np.inf) * FINE
    ramped = np.zeros_like(u)
    for k in range(1, len(u)):
        ramped[k] = ramped[k - 1] + np.clip(u[k - 1] - ramped[k - 1], -a, a)
    r = np.zeros_like(u)
    for i, side in enumerate(("left", "right")):  # each side's dead time, after its controller
        k = int(round(truth[f"drive_delay_{side}"] / FINE))
        r[k:, i] = ramped[:len(u) - k, i]
    v = np.empty_like(r)
    for i, side in enumerate(("left", "right")):
        tau = truth[f"drive_lag_{side}"]
        _, v[:, i], _ = signal.lsim(([1.0], [tau, 1.0]), r[:, i], tf, interp=False)
    meas = v[(t / FINE + 0.5).astype(int)] + rng.normal(0.0, NOISE, (n, 2))
    zero = np.zeros(n)
    return DriveLog(t=t, v_left_cmd=cmd[:, 0], v_right_cmd=cmd[:, 1], x=zero, y=zero, yaw=zero,
                    v_left=meas[:, 0], v_right=meas[:, 1])


@pytest.mark.slow  # 4 min of log, 11 parameters: about 10 s of CPU
def test_recovers_a_known_chain():
    """Every parameter the truth has comes back within its interval (and within a few per cent);
    the right side's speed limit and the mean limit, which the truth lacks, are not given a number."""
    fit = fit_chain(_truth_log(240.0, 1, TRUTH), Robot())
    for name, value in TRUTH.items():
        assert fit.verdicts[name] == "determined", (name, fit.verdicts[name])
        # within the interval, plus 0.2 % for the chain's 10 ms steps against the generator's 1 ms
        # (its clamps act on a step's mean command: the turn limit came out 0.12 % high, +-0.09 %)
        assert abs(fit.values[name] - value) <= fit.half[name] + 0.002 * value, (name, fit.values[name], fit.half[name])
        assert fit.values[name] == pytest.approx(value, rel=0.1, abs=0.01), name
    for name in ("drive_speed_limit_right", "drive_mean_speed_limit"):
        assert name not in fit.values
        assert fit.verdicts[name].startswith("not determined: never reached"), fit.verdicts[name]
    assert max(fit.rms_after) < 1.3 * NOISE  # what is left is the noise
    assert min(fit.rms_before) > 5 * NOISE


@pytest.mark.slow  # 3 min of log: about 40 s of CPU
def test_recovers_the_twist_controllers_ramps():
    """A controller that ramps the sides' mean and half difference (not each side): both ramps come
    back within their intervals. What the ramps leave is not separable: a per-side ramp at the sum
    of the two (2.1 m/s^2) acts only where both ramp together, and the fit gives it 2.0, and the
    dead time trades with the lag (0.05 s of dead time came back as none and 0.03 lag more), so the
    fitted chain leaves 2.5 x the noise, not the noise."""
    truth = {"track_speed_scale": 1.0, "drive_delay_left": 0.05, "drive_delay_right": 0.05, "drive_lag_left": 0.15,
             "drive_lag_right": 0.15, "drive_mean_accel_limit": 1.5, "drive_turn_accel_limit": 0.6}
    fit = fit_chain(_truth_log(180.0, 4, truth), Robot())
    for name in ("drive_mean_accel_limit", "drive_turn_accel_limit"):
        assert fit.verdicts[name] == "determined", (name, fit.verdicts[name])
        # the interval, plus 0.5 % for the chain's 10 ms steps against the generator's 1 ms
        assert abs(fit.values[name] - truth[name]) <= fit.half[name] + 0.005 * truth[name], (name, fit.values[name])
    assert max(fit.rms_after) < 3 * NOISE


def test_a_log_that_never_saturates_shows_no_limit():
    """Commands within every limit: the chain's limits are not determined; the lag and the dead
    time still are, and the described robot's limits are kept."""
    truth = {"track_speed_scale": 1.0, "drive_delay_left": 0.08, "drive_delay_right": 0.08, "drive_lag_left": 0.3,
             "drive_lag_right": 0.3}
    fit = fit_chain(_truth_log(60.0, 2, truth), Robot(drive_speed_limit=3.0))
    for name in ("drive_speed_limit_left", "drive_speed_limit_right", "drive_accel_limit", "drive_turn_limit",
                 "drive_mean_speed_limit", "drive_mean_accel_limit", "drive_turn_accel_limit"):
        assert name not in fit.values and fit.verdicts[name].startswith("not determined"), name
    assert fit.values["drive_lag_left"] == pytest.approx(0.3, abs=0.03)
    assert fit.values["drive_delay_right"] == pytest.approx(0.08, abs=0.015)
    assert fit.robot(Robot(drive_speed_limit=3.0)).speed_limit_per_side == (3.0, 3.0)


def test_chain_response_matches_the_generator():
    """The numpy chain (mjtrack.models.drivetrain.response) on the generator's 1 ms grid, every
    stage at once: what is left against the generated speeds is the generator's noise."""
    log = _truth_log(30.0, 3, TRUTH)
    chain = Chain(scale=1.2, delay=(0.05, 0.1), speed_limit=(0.8, None), accel_limit=2.0, lag=(0.2, 0.35),
                  turn_scale=0.7, turn_limit=0.35)
    per_row = int(round(1 / (RATE * FINE)))
    v = response(chain, np.repeat(np.stack([log.v_left_cmd, log.v_right_cmd], -1), per_row, axis=0), FINE)
    d = v[np.arange(log.t.size - 1) * per_row + per_row - 1] - np.stack([log.v_left, log.v_right], -1)[1:]
    assert np.sqrt(np.mean(d ** 2)) == pytest.approx(NOISE, rel=0.1)
    assert np.max(np.abs(d)) < 5 * NOISE


def test_calibrate_fits_the_drives_to_the_measured_speeds_first(monkeypatch):
    """--drive-input fitted: the contact's fit gets the log driven by the speeds the fitted chain
    predicts from its commands (within the noise of the measured ones), a robot without a
    drivetrain and no drive timing to fit; the calibrated robot carries the chain, its speeds times
    the rolling radius ratio the contact's fit found."""
    from types import SimpleNamespace

    import mjtrack.calibrate.run as run
    from mjtrack.errors import InputError

    seen = {}

    def fake(train, robot, **kw):
        seen.update(kw, train=train, robot=robot)
        calibrated = robot.replace(track_speed_scale=1.1, mu=0.5, extra={"simulator": {"drive_input": "measured"}})
        return SimpleNamespace(values={"track_speed_scale": 1.1}, changed=["track_speed_scale"], sentence="",
                               calibrated=calibrated, robot=robot, drive_input=kw["drive_input"],
                               evidence=lambda: "")

    monkeypatch.setattr(run, "_calibrate", fake)
    lg = _truth_log(40.0, 4, TRUTH)
    cal = run.calibrate(lg, Robot(drive_lag=0.5), drive_input="fitted")
    driven = np.stack([seen["train"].v_left_cmd, seen["train"].v_right_cmd], -1)[1:]
    assert np.sqrt(np.mean((driven - np.stack([lg.v_left, lg.v_right], -1)[1:]) ** 2)) < 2 * NOISE
    assert np.array_equal(seen["train"].extra["logged_v_left_cmd"], lg.v_left_cmd)
    assert "drive_lag" not in seen["names"] and "drive_delay" not in seen["names"]
    # the contact's fit is --drive-input measured's on the predicted speeds; the calibrated robot
    # is driven by its commands (no simulator drive_input recorded)
    assert seen["robot"].lag_per_side == (0.0, 0.0) and seen["drive_input"] == "measured"
    assert cal.drive_input == "commanded" and "drive_input" not in cal.calibrated.extra["simulator"]
    chain = cal.drivetrain.values
    assert cal.robot.drive_lag == 0.5  # the description as given
    assert cal.calibrated.mu == 0.5
    assert cal.calibrated.track_speed_scale == pytest.approx(1.1 * chain["track_speed_scale"])
    assert cal.calibrated.speed_limit_per_side[0] == pytest.approx(1.1 * chain["drive_speed_limit_left"])
    assert cal.calibrated.lag_per_side == pytest.approx((chain["drive_lag_left"], chain["drive_lag_right"]))
    assert cal.sentence.startswith("The drives were fitted first to the log's measured track speeds")
    with pytest.raises(InputError, match="measured track speeds"):
        run.calibrate(DriveLog(t=lg.t, v_left_cmd=lg.v_left_cmd, v_right_cmd=lg.v_right_cmd, x=lg.x, y=lg.y,
                               yaw=lg.yaw), Robot(), drive_input="fitted")
