"""Windows of a log (mjtrack.windows: definition, start states, screening rules) simulated by the
MuJoCo robot from the measured state (mjtrack.sim.windows).

The reference logs come from ``mjtrack.sim.drive_log`` (one rollout from rest over the whole log,
the robot built with its parameters in the description); the window simulator restarts the robot
at every window from the logged state and sets per-world parameters on a copy of one compiled
model. Command changes fall on log rows, so a log sampled at 20 Hz holds exactly the commands the
generator used.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mjtrack.errors import InputError
from mjtrack.io.robot import Robot
from mjtrack.sim import SimConfig, drive_log
from mjtrack.sim.windows import WindowSim, drive_setpoints, simulate_windows, window_commands
from mjtrack.windows import make_windows, start_speeds, start_twists

TABLE = (np.array([0.0, 1.3, 3.0, 4.65, 6.1]),
         np.array([0.0, 0.5, -0.4, 0.6, 0.3]),
         np.array([0.0, 0.7, 0.4, -0.2, 0.8]))
DUR = 8.0


@pytest.fixture(scope="module")
def robot():
    return Robot(mu=0.6, cg_x=0.03)


@pytest.fixture(scope="module")
def log(robot):
    return drive_log(robot, TABLE, duration=DUR, log_rate=20.0)


@pytest.fixture(scope="module")
def sim(robot):
    return WindowSim(robot)


def test_windows_respect_segments_and_horizon(log):
    ws = make_windows(log, 2.0)
    assert len(ws) == 4 and np.all(log.t[ws.ends] - log.t[ws.starts] >= 2.0 - 1e-9)
    seg = np.repeat([0, 1], [70, log.n_samples - 70])
    cut = log.replace(window=seg)
    ws2 = make_windows(cut, 2.0, stride_s=1.0)
    for s, e in zip(ws2.starts, ws2.ends):
        assert seg[s] == seg[e]
    # a segment of 1.9 s still gives a window with min_fraction 0.9, not with 0.99
    short = log.slice(0, 39)  # 38 steps of 0.05 s = 1.9 s
    assert len(make_windows(short, 2.0)) == 1
    assert len(make_windows(short, 2.0, min_fraction=0.99)) == 0


def test_window_from_the_logs_own_state_reproduces_the_log(log, sim):
    ws = make_windows(log, 2.0)
    res = simulate_windows(sim, log, ws)
    assert not res.any_diverged
    # every window restarts from the logged state: what is left is the state the log does not
    # hold (suspension deflections, roller spin differences, contact warm start). Measured: at
    # most 0.012 mm at a window's end, 0.0003 deg. With the sensors read one step stale (the
    # state before mj_step integrates) the same windows ran one step behind their log: mm and
    # up to 1 deg, which a calibration then fitted as a drive delay and a friction change.
    assert res.pos_err().max() < 1e-4, res.pos_err()
    assert np.degrees(np.abs(res.errors[..., 2])).max() < 0.01
    # and along the window, not only at its end
    meas = np.stack([log.x, log.y], -1)
    for j, (s, e) in enumerate(zip(ws.starts, ws.ends)):
        d = np.linalg.norm(res.poses[0, j, :e - s + 1, :2] - meas[s:e + 1], axis=-1)
        assert d.max() < 1e-4


def test_a_random_scenario_log_is_replayed_from_its_rows():
    """Switch times off the log grid: the simulated robot is driven by the commands its log's rows
    show (held for whole log periods), so its windows replay it; before, a switch acted up to a log
    period earlier than the log said and a window turned late by the change in yaw rate times that."""
    from mjtrack.sim import scenario_commands

    robot = Robot()
    table, duration = scenario_commands("random_steps", robot, duration=20.0, seed=3)
    lg = drive_log(robot, table, duration=duration)
    res = simulate_windows(WindowSim(robot), lg, make_windows(lg, 2.0))
    err = res.pos_err()[0]
    # measured: median 0.004 mm, worst 0.12 mm over 10 windows (seed 11 of 60 s: worst 2 mm, in a
    # window that starts while the tracks reverse: the contact and drive states the log does not
    # hold); before: RMS 7 mm, worst 30 mm
    assert np.median(err) < 1e-4 and err.max() < 2e-3, err


def test_twist_from_poses_matches_the_logged_twist(log):
    ws = make_windows(log, 2.0, stride_s=0.5)
    fitted = start_twists(log.replace(vx=None, vy=None, wz=None), ws)
    logged = start_twists(log, ws)
    # 0.5 s away from command steps (a quadratic fit does not follow the transient) the fit is close
    steady = np.array([np.ptp(log.v_left_cmd[max(0, s - 10):s + 10]) == 0 and
                       np.ptp(log.v_right_cmd[max(0, s - 10):s + 10]) == 0 for s in ws.starts])
    assert steady.sum() >= 5
    assert np.abs(fitted[steady] - logged[steady]).max() < 0.02


@pytest.mark.parametrize("change", [{"mu": 0.35}, {"mu_left": 0.4}, {"cg_y": -0.05}, {"cg_x": -0.06}])
def test_model_field_variant_equals_a_rebuilt_robot(robot, log, sim, change):
    """A parameter set on the compiled copy gives the rollout of a robot built with it."""
    ws = make_windows(log, 2.0).subset(slice(1, 3))
    a = simulate_windows(sim, log, ws, [change])
    b = simulate_windows(WindowSim(robot.replace(**change)), log, ws)
    np.testing.assert_allclose(a.poses, b.poses, atol=1e-6)


def test_drive_lag_variant_equals_a_lagged_build(robot, log, sim):
    ws = make_windows(log, 2.0).subset(slice(1, 3))
    a = simulate_windows(sim, log, ws, [{"drive_lag": 0.2}])
    for lagged in (WindowSim(robot, SimConfig(lag=0.2), lagged=False), WindowSim(robot.replace(drive_lag=0.2))):
        b = simulate_windows(lagged, log, ws)
        np.testing.assert_allclose(a.poses, b.poses, atol=1e-6)


def test_variants_batch_and_change_the_errors(log, sim):
    ws = make_windows(log, 2.0)
    res = simulate_windows(sim, log, ws, [{}, {"mu": 0.3}, {"drive_delay": 0.3}, {"track_speed_scale": 0.8},
                                          {"drive_force_limit": 20.0}, {"drive_lag": 0.3}], nthread=2)
    rms = res.rms()
    assert rms.shape == (6,)
    assert np.all(rms[1:] > 3 * rms[0]), rms
    # threads do not change results
    one = simulate_windows(sim, log, ws, [{"mu": 0.3}], nthread=1)
    np.testing.assert_array_equal(one.poses[0], res.poses[1])


def test_delay_and_scale_transform_the_commands(log, sim):
    ws = make_windows(log, 2.0)
    before = start_speeds(log, ws)
    ext, pre = window_commands(log, ws, sim.dt, 400, scale=1.0, lead=50)  # from 0.25 s before each start
    assert ws.starts[0] == 0 and pre[0, :50].min() == 1.0 and pre[0, 50:].max() == 0.0 and pre[1:].max() == 0.0
    late = drive_setpoints(sim.robot, log, ws, sim.dt, 400, delays=(0.25, 0.25), scale=0.5, start=before)
    # a window inside the log follows, within the dead time, the log's commands before it
    np.testing.assert_allclose(late[1:], 0.5 * ext[1:, :400])
    # the first starts with the log: within the dead time its drive keeps the speed its track had, not scaled
    np.testing.assert_allclose(late[0, :50], before[0][None].repeat(50, 0))
    np.testing.assert_allclose(late[0, 50:], 0.5 * ext[0, 50:400])
    plain = ext[:, 50:]
    sided = drive_setpoints(sim.robot, log, ws, sim.dt, 400, delays=(0.1, 0.25), scale=1.0, start=before)
    np.testing.assert_allclose(sided[:, 20:, 0], plain[:, :-20, 0])
    np.testing.assert_allclose(sided[:, 50:, 1], plain[:, :-50, 1])


def test_a_window_starts_at_the_set_point_its_tracks_ran_at():
    """A robot whose own controller halves its commands' difference and scales them, started in a
    steady turn at the speeds that controller gives its constant commands, is set those speeds from
    the first step on: during the dead time the drive keeps what the tracks ran at, and the
    controller's output after it is the same. (Holding the start speeds as a *command* through the
    dead time would pass them through the scale and the controller: here set-points of 1.27 and
    1.66 m/s instead of 0.71 and 1.24 for the first 0.2 s, a jolt at every window's start.)"""
    from mjtrack.io.logs import DriveLog

    t = np.arange(41) * 0.05
    c = np.ones_like(t)
    cmd_l, cmd_r = 0.3 * c, 1.0 * c  # scale 1.5: mean 0.975, half difference 0.525 x 0.5 = 0.2625
    want = np.array([0.975 - 0.2625, 0.975 + 0.2625])
    lg = DriveLog(t=t, v_left_cmd=cmd_l, v_right_cmd=cmd_r, x=0 * t, y=0 * t, yaw=0 * t,
                  v_left=want[0] * c, v_right=want[1] * c)
    r = Robot(track_speed_scale=1.5, drive_turn_scale=0.5, drive_delay=0.2)
    ws = make_windows(lg, 2.0)
    u = drive_setpoints(r, lg, ws, 0.005, 400, delays=r.delay_per_side, scale=r.track_speed_scale,
                        start=start_speeds(lg, ws))
    np.testing.assert_allclose(u[0], np.broadcast_to(want, (400, 2)), atol=1e-12)


def test_unknown_parameter_and_empty_windows_are_refused(log, sim):
    ws = make_windows(log, 2.0)
    with pytest.raises(InputError, match="unknown parameter"):
        simulate_windows(sim, log, ws, [{"grip": 1.0}])
    with pytest.raises(InputError, match="no window"):
        simulate_windows(sim, log, make_windows(log.slice(0, 10), 2.0))


def test_geometry_and_ground_variants_rebuild_the_robot(robot, log, sim):
    ws = make_windows(log, 2.0).subset(slice(1, 3))
    a = simulate_windows(sim, log, ws, [{"track_length": 0.4}])
    b = simulate_windows(WindowSim(robot.replace(track_length=0.4)), log, ws)
    np.testing.assert_allclose(a.poses, b.poses, atol=1e-9)
    aniso = robot.replace(ground={"model": "anisotropic", "lateral_ratio": 0.5})
    c = simulate_windows(WindowSim(aniso), log, ws, [{"lateral_ratio": 0.7}])
    d = simulate_windows(WindowSim(robot.replace(ground={"model": "anisotropic", "lateral_ratio": 0.7})), log, ws)
    # the variant keeps the base robot's rest margins, the rebuild reads its own after a landing
    # whose tangential state the friction and the belt set (test_rest_margins_put_the_rollers_on_
    # the_ground_and_are_idempotent): 1.1e-6 m apart after 2 s with the belt, 3e-11 without
    np.testing.assert_allclose(c.poses, d.poses, atol=1e-5)
    with pytest.raises(InputError, match="anisotropic"):
        simulate_windows(sim, log, ws, [{"lateral_ratio": 0.7}])


def test_delayed_commands_are_continuous_in_the_delay(log, sim):
    ws = make_windows(log, 2.0)
    before = start_speeds(log, ws)
    d = np.linspace(0.1, 0.12, 41)
    c = np.array([drive_setpoints(sim.robot, log, ws, sim.dt, 400, delays=(x, x), scale=1.0, start=before) for x in d])
    jumps = np.abs(np.diff(c, axis=0)).max()
    # 0.5 ms of delay moves a command step by a tenth of a 5 ms step: at most 10 % of the step
    # size (plain holding would jump by the whole step)
    assert jumps < 0.11 * np.abs(np.diff(c[0], axis=1)).max()


def test_diverged_windows_are_scored_without_flooding_stderr(log, sim, capfd, caplog):
    """A centre of mass 0.19 m to the side of a 0.4 m gauge makes the robot diverge at 5 ms, while it
    settles or in every window: all its windows are scored as diverged, none raises, and MuJoCo's
    "huge value in QACC" warnings are collected (a debug line here; the caller that runs many
    such batches, calibrate or diagnose, logs one summary line)."""
    import logging

    from mjtrack.sim.rollout import summarised_mujoco_warnings

    ws = make_windows(log, 2.0)
    with caplog.at_level(logging.DEBUG, logger="mjtrack"):
        with summarised_mujoco_warnings("test batch"):
            res = simulate_windows(sim, log, ws, [{"cg_y": 0.19}, {}])
    assert res.diverged[0].all() and not res.diverged[1].any()
    assert "QACC" not in capfd.readouterr().err
    assert any("diverged" in r.getMessage() and "QACC" in r.getMessage() for r in caplog.records)
    summary = [r for r in caplog.records if r.getMessage().startswith("test batch: MuJoCo warned")]
    assert len(summary) == 1 and summary[0].levelno == logging.WARNING


def _straight(v_track: float, v_body: float, decel: float = 0.0, n: int = 41, dt: float = 0.05):
    """A log along +x at yaw 0 (poses written by hand): tracks at ``v_track``; the body starts at
    ``v_body`` and slows at ``decel`` [m/s^2] until it stops."""
    from mjtrack.io.logs import DriveLog

    t = np.arange(n) * dt
    z = np.zeros(n)
    stop = abs(v_body) / decel if decel > 0 else np.inf
    tt = np.minimum(t, stop)
    x = np.sign(v_body) * (abs(v_body) * tt - 0.5 * decel * tt ** 2)
    return DriveLog(t=t, v_left_cmd=z + v_track, v_right_cmd=z + v_track, v_left=z + v_track, v_right=z + v_track,
                    x=x, y=z, yaw=z)


@pytest.mark.parametrize("v_track, v_body, decel, flagged", [
    (1.0, 0.9, 0.0, False),    # slip shortens the path
    (-1.0, -0.4, 0.0, False),  # reversing, both ways agree
    (1.0, -0.9, 0.0, True),    # 0.9 m a half against the tracks, not slowing down: no ground does that
    (-1.5, 0.4, 0.0, False),   # 0.4 m a half against: under 0.5 m (noise, a push)
    (0.05, -0.6, 0.0, True),   # creeping forward, the body 0.6 m a half back
    (-1.0, 3.0, 2.0, False),   # coasting at 3 m/s against reversed tracks, braked at 0.2 g: 0.25 m in the 2nd half
    (-1.0, 3.0, 0.7, False),   # braked at 0.07 g from 3 m/s: 2.65 m then 1.95 m
    (-1.0, 3.0, 0.3, True),    # braked at 0.03 g: 2.85 m then 2.55 m, less braking than the rule's 0.05 g (its limit)
    (-3.0, 2.0, 1.0, False),   # braked at 0.1 g from 2 m/s: 1.5 m then 0.5 m
])
def test_windows_whose_poses_move_against_the_tracks_are_found(v_track, v_body, decel, flagged):
    from mjtrack.windows import contradicting_windows

    lg = _straight(v_track, v_body, decel)
    ws = make_windows(lg, 2.0)
    assert len(ws) == 1
    rows = contradicting_windows(lg, ws)
    assert bool(rows) == flagged
    if rows:
        assert rows[0]["track_path_m"] == pytest.approx([v_track, v_track])
        x = lambda t: np.sign(v_body) * (abs(v_body) * t - 0.5 * decel * t ** 2)  # (never stopped when flagged)
        assert rows[0]["body_path_m"] == pytest.approx([x(1.0) - x(0.0), x(2.0) - x(1.0)])


def test_against_the_tracks_is_measured_along_the_body_heading():
    """Reversing while facing -x: the world x grows, the body goes backwards with its tracks."""
    from mjtrack.io.logs import DriveLog
    from mjtrack.windows import contradicting_windows

    t = np.arange(41) * 0.05
    z = np.zeros(41)
    lg = DriveLog(t=t, v_left_cmd=z - 1.0, v_right_cmd=z - 1.0, x=0.9 * t, y=z, yaw=z + np.pi)
    assert contradicting_windows(lg, make_windows(lg, 2.0)) == []
    lg2 = lg.replace(yaw=z)  # the same poses facing +x: 1.8 m forward on tracks driving backwards
    assert len(contradicting_windows(lg2, make_windows(lg2, 2.0))) == 1


def test_tracks_that_reverse_mid_window_flag_nothing():
    """Tracks forward then backward, the body coasting forward throughout: the tracks do not push
    one way over the window, so a body against them in the second half is not a contradiction."""
    from mjtrack.io.logs import DriveLog
    from mjtrack.windows import contradicting_windows

    t = np.arange(41) * 0.05
    z = np.zeros(41)
    v = np.where(t < 1.0, 1.0, -1.0)
    lg = DriveLog(t=t, v_left_cmd=v, v_right_cmd=v, v_left=v, v_right=v, x=1.0 * t, y=z, yaw=z)
    assert contradicting_windows(lg, make_windows(lg, 2.0)) == []


GAUGE = 0.5


def _turning(v_left: float, v_right: float, wz, vx=0.0, n: int = 41, dt: float = 0.05):
    """A log whose body turns about its centre at yaw rate ``wz`` [rad/s] (a number, or a function of
    time) while moving at ``vx`` [m/s] along +x (a number, or a function giving the path x(t)), its
    tracks at ``v_left``, ``v_right`` (poses written by hand)."""
    from mjtrack.io.logs import DriveLog

    t = np.arange(n) * dt
    z = np.zeros(n)
    yaw = wz(t) if callable(wz) else wz * t
    x = vx(t) if callable(vx) else vx * t
    return DriveLog(t=t, v_left_cmd=z + v_left, v_right_cmd=z + v_right, v_left=z + v_left, v_right=z + v_right,
                    x=x, y=z, yaw=yaw)


@pytest.mark.parametrize("v_left, v_right, wz, vx, flagged", [
    (-1.0, 1.0, 1.6, 0.0, False),     # spin turn at yaw ratio 0.4: the points under the tracks move 0.4 m a second
    (-1.0, 1.0, 0.0, 0.0, True),      # tracks spin 1 m a half, the body does not move
    (-1.0, 1.0, 0.32, 0.0, True),     # the points move 0.08 m a half: under a tenth of the tracks' path
    (-1.0, 1.0, 0.48, 0.0, False),    # they move 0.12 m a half: over a tenth
    (-0.4, 0.4, 0.0, 0.0, False),     # 0.4 m a half: under the 0.5 m the rule needs
    (0.0, 1.0, 0.0, 0.0, True),       # one track still, the other runs, the body held
    (0.0, 1.0, 0.9, 0.225, False),    # the same tracks pivoting the body at yaw ratio 0.45
    (1.0, 1.0, 0.0, lambda t: 0.5 * 0.05 * 9.81 * t ** 2, False),  # on ice (0.05 g) from rest: 0.25 m, then 0.74 m
    (1.0, 1.0, 0.0, lambda t: 0.5 * 0.01 * 9.81 * t ** 2, True),   # at 0.01 g: 0.05 m in the 1st half (the rule's limit)
    (-1.0, 1.0, lambda t: 1.6 * np.minimum(t, 1.0), 0.0, True),    # turning in the 1st half, held in the 2nd
    (0.8, 0.8, 0.0, lambda t: -0.25 * np.sin(np.pi * t), False),     # reversing: 0.25 m back and return in each half
])
def test_windows_in_which_the_robot_is_held_still_are_found(v_left, v_right, wz, vx, flagged):
    from mjtrack.windows import stuck_windows

    lg = _turning(v_left, v_right, wz, vx)
    ws = make_windows(lg, 2.0)
    assert len(ws) == 1
    rows = stuck_windows(lg, ws, GAUGE)
    assert bool(rows) == flagged
    yaw = lambda t: wz(t) if callable(wz) else wz * t
    x = lambda t: vx(t) if callable(vx) else vx * t
    # how far the two points at +-gauge/2 across the body get from where they were at each half's
    # start (the farthest of the log's samples, 0.05 s apart), written out
    moved = []
    for a, b in ((0.0, 1.0), (1.0, 2.0)):
        tt = np.linspace(a, b, 21)
        d = [np.hypot(x(tt) - x(a) - y * (np.sin(yaw(tt)) - np.sin(yaw(a))), y * (np.cos(yaw(tt)) - np.cos(yaw(a))))
             for y in (GAUGE / 2, -GAUGE / 2)]
        moved.append(max(float(np.max(k)) for k in d))
    if rows:
        assert rows[0]["track_path_m"] == pytest.approx([max(abs(v_left), abs(v_right))] * 2)
        assert rows[0]["body_path_m"] == pytest.approx(moved)


def test_a_window_both_rules_find_is_left_out_once_and_listed_in_time_order():
    from mjtrack.io.logs import DriveLog
    from mjtrack.windows import without_contradicting

    pieces = [_turning(-1.0, 1.0, 1.6), _straight(1.0, -0.9), _turning(-1.0, 1.0, 0.0)]  # fine, against, held
    cols = {k: np.concatenate([getattr(p, k) for p in pieces])
            for k in ("v_left_cmd", "v_right_cmd", "v_left", "v_right", "x", "y", "yaw")}
    cols["t"] = np.concatenate([p.t + 10.0 * i for i, p in enumerate(pieces)])
    cols["window"] = np.repeat(np.arange(3), [p.n_samples for p in pieces])
    lg = DriveLog.from_columns(cols)
    ws = make_windows(lg, 2.0)
    assert len(ws) == 3
    kept, rows = without_contradicting(lg, ws, GAUGE)
    assert kept.starts.tolist() == [ws.starts[0]]
    assert [r["kind"] for r in rows] == ["against", "stuck"]
    assert [r["t0"] for r in rows] == [float(lg.t[ws.starts[1]]), float(lg.t[ws.starts[2]])]


def test_on_coulomb_ground_the_body_under_sliding_tracks_moves_more_than_the_stuck_rule_allows():
    """The stuck rule's premise (mjtrack.windows.STUCK_WHY), checked on the independent steady
    balance of Coulomb ground (mjtrack.testing.ground_balance): for track lengths up to four times
    the gauge, spread and point loads, straight, turning, pivot and spin turns, the points under the
    tracks' centres move at least 0.16 times the faster track's speed, above the rule's 0.1."""
    from mjtrack.windows.screen import STUCK_SHARE
    from mjtrack.testing.ground_balance import steady_twist

    T = 1.0
    shares = []
    for L in (0.3, 1.0, 2.0, 4.0):
        for load in ({}, {"wheels": 2, "concentration": 1.0, "span": 0.99}):
            for v_left, v_right in ((1.0, 1.0), (0.5, 1.0), (0.0, 1.0), (-0.2, 1.0), (-1.0, 1.0)):
                try:
                    vx, vy, wz = steady_twist(v_left, v_right, T, L, eps=1e-6, **load)
                except RuntimeError:  # the point-load balance of a spin turn has no smooth root at some L
                    continue
                moved = max(np.hypot(vx - wz * y, vy) for y in (T / 2, -T / 2))
                shares.append(moved / max(abs(v_left), abs(v_right)))
    assert len(shares) >= 36
    assert min(shares) >= 0.16 > STUCK_SHARE


def test_a_lagged_reversal_of_the_simulated_robot_is_not_taken_for_a_stuck_robot():
    """The battery's drive-lag log reverses at t = 58.24 s: the tracks run 0.63 m in that half while
    the body goes back 0.27 m and returns; the body was never still."""
    from mjtrack.windows import stuck_windows
    from mjtrack.testing.battery import case, described_robot, make_log

    c = case("default", "drive_lag")
    lg = make_log(c, duration=60.0, seed=12)
    ws = make_windows(lg, 2.0)
    assert float(lg.t[ws.starts[-1]]) == pytest.approx(58.0)
    assert stuck_windows(lg, ws, described_robot(c).track_gauge) == []


@pytest.mark.slow
def test_no_window_of_the_simulators_own_logs_is_taken_for_a_stuck_robot():
    """Every log of the calibration battery (three geometries, every change, both seeds)."""
    from mjtrack.windows import without_contradicting
    from mjtrack.testing.battery import CHANGES, GEOMETRIES, case, described_robot, make_log

    for g in GEOMETRIES:
        for change in CHANGES:
            c = case(g, change)
            for seed in (11, 12):
                lg = make_log(c, duration=60.0, seed=seed)
                _, rows = without_contradicting(lg, make_windows(lg, 2.0), described_robot(c).track_gauge)
                assert rows == [], (g, change, seed)


def test_the_window_layer_and_calibration_import_without_mujoco_or_diagnose():
    """One fresh interpreter imports, in turn, the window layer, calibration and the window
    simulator, and says after each which of MuJoCo and the diagnosis it holds."""
    import mjtrack

    steps = ["mjtrack.windows", "mjtrack.calibrate, mjtrack.calibrate.params, mjtrack.calibrate.identify, "
             "mjtrack.calibrate.causes, mjtrack.calibrate.run", "mjtrack.sim.windows"]
    code = "import sys\n" + "".join(
        f"import {m}\nprint(' '.join(n for n in ('mujoco', 'mjtrack.diagnose') if n in sys.modules) or '-')\n"
        for m in steps)
    root = str(Path(mjtrack.__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [root, os.environ.get("PYTHONPATH")]))}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env)
    # the last line shows that the probe sees MuJoCo where it is loaded: the window simulator needs it
    assert out.stdout.split("\n")[:3] == ["-", "-", "mujoco"]


def test_a_window_that_blew_up_is_scored_with_the_fixed_error(log, sim):
    """A robot that cannot stand (centre of mass at the edge of its support) diverges in every
    window: each is scored with DIVERGED_ERROR in every component, whatever its blown-up poses
    say, so that a score over windows does not carry the blow-up's own numbers."""
    from mjtrack.windows.define import DIVERGED_ERROR

    ws = make_windows(log, 2.0)
    res = simulate_windows(sim, log, ws, [{"cg_y": 0.19}, {}])
    assert res.diverged[0].all() and not res.diverged[1].any()
    assert np.all(res.errors[0] == DIVERGED_ERROR)
    assert np.all(np.abs(res.errors[1]) < 0.05)
    np.testing.assert_allclose(res.rms()[0], np.hypot(DIVERGED_ERROR, DIVERGED_ERROR))
