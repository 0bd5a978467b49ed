"""Drivetrain keys of the robot description (drive_lag, drive_delay, drive_force_limit,
track_speed_scale): validation, JSON round trip, and what both MuJoCo track models make of them.

The expectations are closed forms of the drive (first-order lag: 63 % of a step after one time
constant; dead time: a shift; scale: a factor; force limit: a bounded acceleration), not code
shared with mjtrack.sim.drivetrain."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mjtrack.errors import InputError
from mjtrack.io.robot import Robot, read_robot, write_robot
from mjtrack.sim.config import sim_config
from mjtrack.sim.rollout import simulate


@pytest.mark.parametrize(
    "fields, pattern",
    [
        (dict(drive_lag=-0.1), r"'drive_lag' must be a number in \[0, 10\] s, got -0\.1"),
        (dict(drive_lag=float("inf")), r"'drive_lag' must be a number in \[0, 10\] s"),
        (dict(drive_delay=11.0), r"'drive_delay' must be a number in \[0, 10\] s, got 11\.0"),
        (dict(drive_force_limit=0.0), r"'drive_force_limit' must be a positive number \(N per track\) or null"),
        (dict(drive_force_limit=float("nan")), r"'drive_force_limit' must be a positive number"),
        (dict(track_speed_scale=0.0), r"'track_speed_scale' must be a number in \(0, 10\], got 0\.0"),
    ],
)
def test_drive_keys_refuse_bad_values(fields, pattern):
    with pytest.raises(InputError, match=r"^robot: " + pattern):
        Robot(**fields)


def test_drive_keys_round_trip(tmp_path):
    data = {"track_gauge": 0.5, "drive_lag": 0.2, "drive_delay": 0.05, "drive_force_limit": 400,
            "track_speed_scale": 0.95}
    path = tmp_path / "r.json"
    path.write_text(json.dumps(data))
    robot = read_robot(path)
    assert (robot.drive_lag, robot.drive_delay, robot.drive_force_limit, robot.track_speed_scale) == (
        0.2, 0.05, 400.0, 0.95)
    write_robot(robot, tmp_path / "back.json")
    assert read_robot(tmp_path / "back.json") == robot
    assert json.loads((tmp_path / "back.json").read_text())["drive_force_limit"] == 400.0
    null = dict(data, drive_force_limit=None)
    assert Robot.from_dict(null).drive_force_limit is None


def test_drive_key_error_names_the_file(tmp_path):
    path = tmp_path / "r.json"
    path.write_text('{"track_gauge": 0.5, "drive_delay": -1}')
    with pytest.raises(InputError, match=r"r\.json: 'drive_delay' must be a number in \[0, 10\] s, got -1\.0$"):
        read_robot(path)


def _step_response(robot: Robot, model: str, *, v=0.5, t_step=0.2, duration=1.2):
    config = sim_config(model)
    dt = config.timestep
    cmd = np.zeros((int(round(duration / dt)), 2))
    cmd[int(round(t_step / dt)):] = v
    out = simulate(robot, cmd, config=config, log_rate=100)
    return out["t"] - t_step, out["v_left"], out


def _rise_63(t, v, target):
    return float(np.interp(0.63 * target, v, t))  # v rises monotonically after the step


@pytest.mark.parametrize("model", ["rollers", "surfacevel"])
def test_drive_lag_sets_the_measured_rise_time(model):
    """Done-when: drive_lag 0.2 s gives a measured 63 % rise time of 0.2 +- 0.03 s."""
    t, v, _ = _step_response(Robot(drive_lag=0.2), model)
    assert _rise_63(t, v, 0.5) == pytest.approx(0.2, abs=0.03)


@pytest.mark.parametrize("model", ["rollers", "surfacevel"])
def test_delay_and_scale(model):
    robot = Robot(drive_lag=0.2, drive_delay=0.1, track_speed_scale=1.2)
    t, v, out = _step_response(robot, model, duration=2.0)  # 8.5 lag time constants after the delay
    assert _rise_63(t, v, 0.6) == pytest.approx(0.3, abs=0.03)
    assert v[-1] == pytest.approx(0.6, rel=0.01)
    assert np.all(np.abs(v[t < 0.1 - 1e-9]) < 1e-3)  # nothing moves during the dead time
    assert out["v_left_cmd"][-1] == 0.5  # the log keeps the commanded speed


@pytest.mark.parametrize("model", ["rollers", "surfacevel"])
def test_force_limit_bounds_the_spin_up(model):
    """Lag 0: the track follows as fast as the force limit allows; a limit 10x lower spins up
    ~10x more slowly (force-limited acceleration F / (m_t + m/2))."""
    fast = _rise_63(*_step_response(Robot(), model)[:2], 0.5)
    slow = _rise_63(*_step_response(Robot(drive_force_limit=100.0), model)[:2], 0.5)
    assert fast < 0.1
    assert slow / fast == pytest.approx(10, rel=0.25)


def test_drive_scales_with_mass():
    """A 150 kg robot reaches a step command as fast as a 20 kg one (drive scaled with mass)."""
    light = _rise_63(*_step_response(Robot(mass=20.0, drive_lag=0.1), "rollers")[:2], 0.5)
    heavy = _rise_63(*_step_response(Robot(mass=150.0, drive_lag=0.1), "rollers")[:2], 0.5)
    assert heavy == pytest.approx(light, abs=0.01)
