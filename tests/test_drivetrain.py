"""Drivetrain keys of the robot description (drive_lag, drive_delay, drive_force_limit,
track_speed_scale; per side and the speed and acceleration limits): validation, JSON round trip,
and what both MuJoCo track models make of them.

The expectations are closed forms of the drive (first-order lag: 63 % of a step after one time
constant; dead time: a shift; scale: a factor; force limit: a bounded acceleration; speed limit:
a ceiling; acceleration limit: a ramp of that slope), not code shared with mjtrack.sim.drivetrain
or mjtrack.models.drivetrain."""

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
        (dict(drive_speed_limit=0.0), r"'drive_speed_limit' must be a number in \(0, 100\] m/s or null, got 0\.0"),
        (dict(drive_speed_limit_right=-1.0), r"'drive_speed_limit_right' must be a number in \(0, 100\] m/s"),
        (dict(drive_lag_left=-0.1), r"'drive_lag_left' must be a number in \[0, 10\] s or null, got -0\.1"),
        (dict(drive_delay_right=float("nan")), r"'drive_delay_right' must be a number in \[0, 10\] s or null"),
        (dict(drive_accel_limit=0.0), r"'drive_accel_limit' must be a number in \(0, 1000\] m/s\^2 or null"),
        (dict(drive_turn_accel_limit=0.0), r"'drive_turn_accel_limit' must be a number in \(0, 1000\] m/s\^2"),
        (dict(drive_mean_accel_limit=2e3), r"'drive_mean_accel_limit' must be a number in \(0, 1000\] m/s\^2"),
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


def test_side_and_limit_keys_round_trip(tmp_path):
    """Per-side keys fall back on the both-sides key; unset ones are not written (a description keeps its keys)."""
    data = {"track_gauge": 0.5, "drive_lag": 0.2, "drive_lag_right": 0.3, "drive_delay_left": 0.04,
            "drive_speed_limit": 1.1, "drive_speed_limit_left": 0.9, "drive_accel_limit": None}
    path = tmp_path / "r.json"
    path.write_text(json.dumps(data))
    robot = read_robot(path)
    assert robot.lag_per_side == (0.2, 0.3)
    assert robot.delay_per_side == (0.04, 0.0)
    assert robot.speed_limit_per_side == (0.9, 1.1)
    assert robot.drive_accel_limit is None
    write_robot(robot, tmp_path / "back.json")
    back = json.loads((tmp_path / "back.json").read_text())
    assert read_robot(tmp_path / "back.json") == robot
    assert "drive_accel_limit" not in back and "drive_lag_left" not in back and back["drive_lag_right"] == 0.3
    assert "drive_speed_limit" not in json.loads(json.dumps(Robot().to_dict()))


@pytest.mark.parametrize("model", ["rollers", "surfacevel"])
def test_speed_limit_caps_the_track_speed(model):
    """A step to 0.8 m/s with a 0.5 m/s limit on the left only: the left track settles at the limit,
    the right at the command (the controller clamps its set-point, the servo follows it)."""
    robot = Robot(drive_lag=0.05, drive_speed_limit_left=0.5)
    config = sim_config(model)
    cmd = np.full((int(round(1.0 / config.timestep)), 2), 0.8)
    out = simulate(robot, cmd, config=config, log_rate=100)
    assert out["v_left"][-1] == pytest.approx(0.5, abs=0.01)
    assert out["v_right"][-1] == pytest.approx(0.8, abs=0.01)
    assert out["v_left"].max() < 0.5 + 0.01
    assert out["v_left_cmd"][-1] == 0.8  # the log keeps the commanded speed


@pytest.mark.parametrize("model", ["rollers", "surfacevel"])
def test_per_side_lag_and_delay(model):
    """Left lag 0.1 s, right 0.3 s; right dead time 0.1 s: each side's measured 63 % rise time is
    its own delay + time constant."""
    robot = Robot(drive_lag=0.1, drive_lag_right=0.3, drive_delay_right=0.1)
    config = sim_config(model)
    dt = config.timestep
    cmd = np.zeros((int(round(2.0 / dt)), 2))
    cmd[int(round(0.2 / dt)):] = 0.5
    out = simulate(robot, cmd, config=config, log_rate=100)
    t = out["t"] - 0.2
    assert _rise_63(t, out["v_left"], 0.5) == pytest.approx(0.1, abs=0.02)
    assert _rise_63(t, out["v_right"], 0.5) == pytest.approx(0.4, abs=0.03)
    # during its dead time the right drive holds 0 up to its servo's droop: the left side, already
    # moving, pulls it through the ground (1.3 mm/s measured), so 1 % of the step, not 1e-3
    assert np.all(np.abs(out["v_right"][t < 0.1 - 1e-9]) < 0.005)


@pytest.mark.parametrize("model", ["rollers", "surfacevel"])
def test_accel_limit_ramps_the_track_speed(model):
    """No lag, a 1 m/s^2 ramp: a step to 0.6 m/s gives a track speed that rises at 1 m/s^2 (half
    way at 0.3 s after the step) and reaches 0.6 m/s 0.6 s after it."""
    robot = Robot(drive_accel_limit=1.0)
    config = sim_config(model)
    dt = config.timestep
    cmd = np.zeros((int(round(1.2 / dt)), 2))
    cmd[int(round(0.2 / dt)):] = 0.6
    out = simulate(robot, cmd, config=config, log_rate=100)
    t, v = out["t"] - 0.2, out["v_left"]
    mid = (t > 0.1) & (t < 0.5)
    slope = np.polyfit(t[mid], v[mid], 1)[0]
    assert slope == pytest.approx(1.0, rel=0.03)
    assert float(np.interp(0.3, v, t)) == pytest.approx(0.3, abs=0.02)
    assert v[-1] == pytest.approx(0.6, abs=0.005)


@pytest.mark.parametrize("model", ["rollers", "surfacevel"])
def test_unset_keys_drive_as_before(model):
    """Without the new keys a rollout is the MuJoCo robot fed the scaled commands shifted by the
    dead time (the drive of before, written out here), bit for bit; per-side keys equal to the
    both-sides ones change nothing."""
    from mjtrack.sim.builder import build_model
    from mjtrack.sim.rollout import run_batch, settled_state

    robot = Robot(drive_lag=0.1, drive_delay=0.05, track_speed_scale=1.2)
    config = sim_config(model)
    dt = config.timestep
    rng = np.random.default_rng(3)
    cmd = np.repeat(rng.uniform(-0.6, 0.6, (6, 2)), int(round(0.2 / dt)), axis=0)
    out = simulate(robot, cmd, config=config, log_rate=100)
    same = simulate(robot.replace(drive_lag_left=0.1, drive_lag_right=0.1, drive_delay_left=0.05,
                                  drive_delay_right=0.05), cmd, config=config, log_rate=100)
    for k in out:
        assert np.array_equal(out[k], same[k]), k
    if model != "rollers":
        return
    k = int(round(0.05 / dt))
    driven = np.concatenate([np.zeros((k, 2)), (cmd * 1.2)[:-k]])
    m = build_model(robot, config)
    _, sens = run_batch([m], driven[None], state0=settled_state(m)[None], keep_states=False)
    adr = int(m.sensor("body_pos").adr[0])
    stride = int(round(0.01 / dt))
    assert np.array_equal(out["x"][1:], sens[0, stride - 1::stride, adr])


def test_window_simulator_drives_through_the_robots_controller():
    """The window simulator (calibrate, diagnose) clamps and ramps as the robot's controller does:
    a window commanded 0.9 m/s from rest with a 0.5 m/s limit and a 1 m/s^2 ramp reaches 0.25 m/s
    at 0.25 s and runs at the limit; without the keys it reaches the command."""
    from mjtrack.io.logs import DriveLog
    from mjtrack.sim.windows import WindowSim, simulate_windows
    from mjtrack.windows import make_windows

    t = np.arange(0.0, 2.0001, 0.05)
    z = np.zeros_like(t)
    log = DriveLog(t=t, v_left_cmd=z + 0.9, v_right_cmd=z + 0.9, x=z, y=z, yaw=z, v_left=z, v_right=z)
    ws = make_windows(log, 2.0)
    limited = Robot(drive_speed_limit=0.5, drive_accel_limit=1.0)
    speeds = simulate_windows(WindowSim(limited), log, ws).speeds[0, 0]
    assert np.interp(0.25, t, speeds[:, 0]) == pytest.approx(0.25, abs=0.02)
    assert speeds[-1] == pytest.approx([0.5, 0.5], abs=0.01)
    free = simulate_windows(WindowSim(Robot()), log, ws).speeds[0, 0]
    assert free[-1] == pytest.approx([0.9, 0.9], abs=0.01)


def _twist_ramped(t):
    """Closed form of a step from rest to (left, right) = (0.3, 0.9) m/s through a twist controller
    whose mean ramps at 1 m/s^2 and half difference at 0.25 m/s^2: the mean reaches 0.6 m/s at
    0.6 s, the half difference 0.3 m/s at 1.2 s, so the left side overshoots to 0.45 m/s at 0.6 s
    and comes back down to 0.3 m/s."""
    m, d = np.minimum(t, 0.6), np.minimum(0.25 * t, 0.3)
    return np.stack([m - d, m + d], -1)


def test_twist_ramps_shape_the_set_points():
    """The numpy chain's set-points against the closed form (a step's set-point is the ramp's mean
    over the step: its value at the step's middle); without the ramps the set-point is the command."""
    from mjtrack.models.drivetrain import Chain, setpoints

    h = 0.01
    cmd = np.tile([0.3, 0.9], (200, 1))
    out = setpoints(Chain(mean_accel_limit=1.0, turn_accel_limit=0.25), cmd, h)
    assert np.allclose(out, _twist_ramped((np.arange(200) + 0.5) * h), atol=1e-12)
    assert out[:, 0].max() == pytest.approx(0.45, abs=0.005)
    assert np.array_equal(setpoints(Chain(), cmd, h), cmd)


@pytest.mark.parametrize("model", ["rollers", "surfacevel"])
def test_twist_ramps_drive_the_simulator(model):
    """The MuJoCo robot's track speeds follow the closed form of the twist controller's ramps (no
    lag): the left side's overshoot and the final speeds, within the servo's following error."""
    robot = Robot(drive_mean_accel_limit=1.0, drive_turn_accel_limit=0.25)
    config = sim_config(model)
    cmd = np.tile([0.3, 0.9], (int(round(1.6 / config.timestep)), 1))
    out = simulate(robot, cmd, config=config, log_rate=100)
    v = np.stack([out["v_left"], out["v_right"]], -1)
    expected = _twist_ramped(out["t"])
    # 0.01 m/s: the servo's following error while it accelerates the track's inertia against the
    # ground (the roller chain's largest, 0.008 m/s, is in its first steps, the robot settling)
    assert np.max(np.abs(v - expected)) < 0.01
    assert v[-1] == pytest.approx([0.3, 0.9], abs=0.005)
    assert v[:, 0].max() == pytest.approx(0.45, abs=0.005)


def test_window_simulator_applies_each_sides_dead_time():
    """A robot file's drive_delay_left / drive_delay_right reach the window simulator: from rest
    under a 0.6 m/s step, the left track (0.3 s dead time) is still near rest at 0.25 s while the
    right (none) is well under way; a variant that moves drive_delay moves both sides to it."""
    from mjtrack.io.logs import DriveLog
    from mjtrack.sim.windows import WindowSim, simulate_windows
    from mjtrack.windows import make_windows

    t = np.arange(0.0, 2.0001, 0.05)
    z = np.zeros_like(t)
    log = DriveLog(t=t, v_left_cmd=z + 0.6, v_right_cmd=z + 0.6, x=z, y=z, yaw=z, v_left=z, v_right=z)
    ws = make_windows(log, 2.0)
    robot = Robot(drive_delay_left=0.3, drive_delay_right=0.0)
    sim = WindowSim(robot)
    own, moved = simulate_windows(sim, log, ws, [{}, {"drive_delay": 0.3}]).speeds[:, 0]
    left, right = np.interp(0.25, t, own[:, 0]), np.interp(0.25, t, own[:, 1])
    assert left < 0.05 < 0.3 < right
    assert own[-1] == pytest.approx([0.6, 0.6], abs=0.02)  # both arrive; only the left later
    assert np.interp(0.25, t, moved[:, 1]) < 0.05  # one fitted dead time for both sides
