"""Measurement noise of simulated logs (mjtrack.sim.noise, simulate --noise): the deviations asked
for, seeded to the byte, recorded beside the log, and measured back from a log."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

import mjtrack
from mjtrack.errors import InputError
from mjtrack.io.logs import DriveLog, log_to_csv_text, read_log
from mjtrack.sim.noise import CHANNELS, PRESETS, add_noise, log_noise, measured_noise
from support.cli import assert_usage_error, run_cli

DATA = Path(__file__).parent / "data"


def _smooth_log(n: int = 20_000, dt: float = 0.05, seed: int = 1) -> DriveLog:
    """A robot on circles of commands held 6 s each (as the DRIVE logs), every channel smooth."""
    t = np.arange(n) * dt
    step = (t // 6.0).astype(int)
    rng = np.random.default_rng(seed)
    levels = rng.uniform(-1.0, 1.0, size=(step.max() + 1, 2))
    vl, vr = levels[step, 0], levels[step, 1]
    v, w = (vl + vr) / 2, (vr - vl) / 0.5
    yaw = np.cumsum(w) * dt
    x, y = np.cumsum(v * np.cos(yaw)) * dt, np.cumsum(v * np.sin(yaw)) * dt
    return DriveLog(t=t, v_left_cmd=vl, v_right_cmd=vr, x=x, y=y, yaw=yaw, v_left=vl.copy(), v_right=vr.copy(),
                    vx=v.copy(), vy=np.zeros(n), wz=w.copy())


SPEC = {"pose_std": 0.02, "yaw_std": 0.03, "track_speed_std": 0.05, "velocity_std": 0.04, "yaw_rate_std": 0.06}


def test_each_channel_gets_the_deviation_asked_for():
    clean = _smooth_log()
    noisy = add_noise(clean, SPEC, seed=3)
    for name, (columns, _, _) in CHANNELS.items():
        for column in columns:
            error = getattr(noisy, column) - getattr(clean, column)
            # sample std of 20 000 draws: relative spread 1/sqrt(2n) = 0.5 %; 3 % is six of them
            assert np.std(error) == pytest.approx(SPEC[name], rel=0.03), column
            assert abs(np.mean(error)) < 4 * SPEC[name] / math.sqrt(clean.n_samples), column
    assert np.array_equal(noisy.v_left_cmd, clean.v_left_cmd) and np.array_equal(noisy.t, clean.t)
    assert abs(np.corrcoef(noisy.x - clean.x, noisy.y - clean.y)[0, 1]) < 0.03  # independent channels


def test_same_seed_same_bytes_and_one_channel_leaves_the_others_alone():
    clean = _smooth_log(n=500)
    one, two = add_noise(clean, "realistic", seed=7), add_noise(clean, "realistic", seed=7)
    assert log_to_csv_text(one) == log_to_csv_text(two)
    assert log_to_csv_text(add_noise(clean, "realistic", seed=8)) != log_to_csv_text(one)
    quieter = add_noise(clean, "realistic,yaw_std=0", seed=7)
    assert np.array_equal(quieter.yaw, clean.yaw)
    assert np.array_equal(quieter.x, one.x) and np.array_equal(quieter.wz, one.wz)
    assert add_noise(clean, "none", seed=7) is clean


@pytest.mark.parametrize("spec, match", [
    ("loud", "unknown preset 'loud'"), ("realistic,foo=1", r"unknown channel\(s\) foo"),
    ("pose_std=-1", r"pose_std must be a number in \[0, 10\] m"), ("pose_std=x", "is not a number"),
    ("pose_std=0.1,realistic", "the preset comes first"), ({"yaw_std": 4.0}, r"yaw_std must be .* \[0, 3\.14"),
])
def test_bad_noise_is_refused(spec, match):
    with pytest.raises(InputError, match=match):
        log_noise(spec)


def test_measured_noise_recovers_white_noise_of_a_known_deviation():
    """Noise drawn here, independently of add_noise, on the smooth log: the estimator gives it back."""
    clean = _smooth_log()
    rng = np.random.default_rng(11)
    sigma = {"x": 0.01, "yaw": 0.04, "v_left": 0.02, "wz": 0.03}
    noisy = DriveLog(**{**{k: getattr(clean, k) for k in ("t", "v_left_cmd", "v_right_cmd", "x", "y", "yaw",
                                                            "v_left", "v_right", "vx", "vy", "wz")},
                        **{k: getattr(clean, k) + s * rng.standard_normal(clean.n_samples) for k, s in sigma.items()}})
    measured = measured_noise(noisy, tuple(sigma))
    for column, s in sigma.items():
        # MAD of ~19 000 differences: ~1 % spread; the smooth motion adds < 1 % at 20 Hz
        assert measured[column] == pytest.approx(s, rel=0.05), column
    assert measured_noise(clean, ("v_left",))["v_left"] == 0.0  # held commands: nothing to measure


def test_the_realistic_preset_is_the_level_of_a_real_log():
    """The Marmotte excerpt (120 rows of the boreal trail, one of the three logs the preset is the
    middle of): each channel within a factor 4 of what it measures (a short excerpt of one log, so
    only the order of magnitude is checked here)."""
    log = read_log(DATA / "marmotte_excerpt.csv")
    measured = measured_noise(log, ("x", "y", "yaw", "v_left", "v_right", "wz_imu"))
    real = PRESETS["realistic"]
    pairs = [(real.pose_std, measured["x"]), (real.pose_std, measured["y"]), (real.yaw_std, measured["yaw"]),
             (real.track_speed_std, measured["v_left"]), (real.track_speed_std, measured["v_right"]),
             (real.yaw_rate_std, measured["wz_imu"])]
    for preset, value in pairs:
        assert preset / 4 <= value <= preset * 4, (preset, value)


def test_simulate_noise_is_recorded_and_is_the_api(tmp_path):
    out = tmp_path / "noisy.csv"
    res = run_cli(["simulate", "--scenario", "circle", "--duration", "1", "--seed", "5",
                   "--noise", "realistic,yaw_std=0.01", "--out", out, "-q"])
    assert res.rc == 0, res.err
    record = json.loads(out.with_suffix(".json").read_text())["noise"]
    assert record == {**PRESETS["realistic"].to_dict(), "yaw_std": 0.01, "seed": 5}
    api = mjtrack.simulate_log(mjtrack.Robot(), scenario="circle", duration=1.0, seed=5,
                               noise={"preset": "realistic", "yaw_std": 0.01})
    assert log_to_csv_text(api) == out.read_text()
    clean = mjtrack.simulate_log(mjtrack.Robot(), scenario="circle", duration=1.0, seed=5)
    assert np.std(api.x - clean.x) == pytest.approx(0.01, rel=0.5)  # 51 rows: a loose check of the level
    # a clean log made from the noisy log's description does not inherit its record
    again = tmp_path / "clean.csv"
    assert run_cli(["simulate", "--scenario", "circle", "--duration", "1", "--robot", out.with_suffix(".json"),
                    "--out", again, "-q"]).rc == 0
    assert "noise" not in json.loads(again.with_suffix(".json").read_text())
    assert_usage_error(run_cli(["simulate", "--scenario", "circle", "--noise", "loud", "--out", tmp_path / "x.csv"]),
                       "unknown preset 'loud'")
