"""Yaw ratio per turn class (mjtrack.calibrate.measures.turn_measures) on a log written here:
each 2 s segment a steady turn at constant track speeds whose body turns at a ratio k of the
nominal yaw rate (v_R - v_L) / T, k chosen per |turn ratio| class; the poses are the exact arcs."""

from __future__ import annotations

import numpy as np

from mjtrack.calibrate.measures import turn_measures
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import Robot
from mjtrack.windows import make_windows
from mjtrack.windows.define import measured_window_poses

GAUGE = 0.5
RATE = 20.0
# (v_left, v_right) [m/s] -> |turn ratio| |v_R - v_L| / (|v_L| + |v_R|), and the ratio k the body turns at
TURNS = {(0.5, 0.8): 0.9,    # 0.23: class 0.15 to 0.5
         (0.2, 0.9): 0.7,    # 0.64: class 0.5 to 1
         (-0.4, 0.4): 0.5}   # 1.0:  class 0.5 to 1 (a spin): median of its class with the one above


def _log(repeats: int = 4) -> DriveLog:
    cols = {k: [] for k in ("t", "vl", "vr", "x", "y", "yaw", "w")}
    t_local = np.arange(int(2.0 * RATE) + 1) / RATE
    seg = 0
    for _ in range(repeats):
        for (vl, vr), k in TURNS.items():
            vx, wz = (vl + vr) / 2, k * (vr - vl) / GAUGE
            cols["x"].append(vx / wz * np.sin(wz * t_local))
            cols["y"].append(vx / wz * (1 - np.cos(wz * t_local)))
            cols["yaw"].append(wz * t_local)
            cols["t"].append(seg * 10.0 + t_local)
            cols["vl"].append(np.full_like(t_local, vl))
            cols["vr"].append(np.full_like(t_local, vr))
            cols["w"].append(np.full(t_local.size, seg))
            seg += 1
    c = {k: np.concatenate(v) for k, v in cols.items()}
    return DriveLog(t=c["t"], v_left_cmd=c["vl"], v_right_cmd=c["vr"], x=c["x"], y=c["y"], yaw=c["yaw"],
                    v_left=c["vl"], v_right=c["vr"], window=c["w"].astype(np.int64))


def test_the_yaw_ratio_per_turn_class_is_the_median_of_its_steady_turns():
    lg = _log()
    ws = make_windows(lg, 2.0)
    speeds = np.stack([[np.column_stack([lg.v_left[s:e + 1], lg.v_right[s:e + 1]])] for s, e in
                       zip(ws.starts, ws.ends)])[:, 0]
    m = turn_measures(lg, ws, Robot(track_gauge=GAUGE), measured_window_poses(lg, ws), speeds)
    by = m["yaw_ratio_by_class"]
    assert set(by) == {(0.15, 0.5), (0.5, 1.0)}  # no straight windows
    assert by[(0.15, 0.5)][1] == 4 and abs(by[(0.15, 0.5)][0] - 0.9) < 1e-9
    assert by[(0.5, 1.0)][1] == 8 and abs(by[(0.5, 1.0)][0] - 0.6) < 1e-9  # median of 0.7 x 4 and 0.5 x 4
    assert abs(m["yaw_ratio"] - 0.7) < 1e-9  # all 12: four 0.9, four 0.7, four 0.5


def test_the_class_samples_are_the_windows_of_each_class():
    lg = _log()
    ws = make_windows(lg, 2.0)
    m = turn_measures(lg, ws, Robot(track_gauge=GAUGE), measured_window_poses(lg, ws),
                      np.stack([lg.v_left, lg.v_right], -1)[ws.starts[:, None] + np.arange(41)])
    for cls, (idx, values) in m["yaw_ratio_samples"].items():
        assert len(idx) == m["yaw_ratio_by_class"][cls][1] and np.median(values) == m["yaw_ratio_by_class"][cls][0]


def test_class_gap_interval_on_known_samples():
    """A constant shift is the interval itself; equal samples give [0, 0]; the same seed the same
    interval; and on draws from two normal distributions the 95 % interval of the difference of
    medians covers the true difference in about 95 of 100 trials (not fewer than 85)."""
    from mjtrack.calibrate.measures import class_gap_interval

    idx = np.arange(12)
    v = np.linspace(0.4, 0.6, 12)
    assert np.allclose(class_gap_interval((idx, v + 0.05), (idx, v)), (0.05, 0.05), atol=1e-12)
    assert class_gap_interval((idx, v), (idx, v)) == (0.0, 0.0)
    assert class_gap_interval((idx, v), (idx[:3], v[:3])) == class_gap_interval((idx, v), (idx[:3], v[:3]))
    assert class_gap_interval((idx[:0], v[:0]), (idx, v)) is None
    rng = np.random.default_rng(7)
    covered = 0
    for trial in range(100):
        a = rng.normal(0.50, 0.05, 30)
        b = rng.normal(0.45, 0.05, 30)  # the same windows, independent errors
        lo, hi = class_gap_interval((np.arange(30), a), (np.arange(30), b), n_boot=400, seed=trial)
        covered += lo <= 0.05 <= hi
    assert covered >= 85


def test_class_gap_interval_draws_the_windows_of_one_command_together():
    """Every window logged twice (two windows of one held command): drawn one by one, the copies
    count as independent evidence and the interval narrows; drawn by command, the interval is that
    of the single windows exactly (the median of a sample with every value doubled is its median,
    and the draws of the labels are the same draws)."""
    from mjtrack.calibrate.measures import class_gap_interval

    rng = np.random.default_rng(3)
    a, b = rng.normal(0.48, 0.05, 14), rng.normal(0.42, 0.05, 14)
    single = class_gap_interval((np.arange(14), a), (np.arange(14), b))
    idx2 = np.arange(28)
    pairs = (idx2, np.repeat(a, 2)), (idx2, np.repeat(b, 2))
    loose = class_gap_interval(*pairs)
    grouped = class_gap_interval(*pairs, groups=idx2 // 2)
    assert grouped == single
    assert loose[1] - loose[0] < 0.85 * (single[1] - single[0])


def test_command_runs_label_the_windows_of_one_held_command():
    from mjtrack.calibrate.measures import command_runs
    from mjtrack.io.logs import DriveLog
    from mjtrack.windows import make_windows

    t = np.arange(120) * 0.05
    cmd_l = np.where(t < 4.0, 0.5, -0.3)
    lg = DriveLog(t=t, v_left_cmd=cmd_l, v_right_cmd=np.full_like(t, 0.8), x=0 * t, y=0 * t, yaw=0 * t)
    ws = make_windows(lg, 2.0, stride_s=2.0)
    runs = command_runs(lg, ws)
    starts = t[ws.starts]
    assert np.array_equal(runs, (starts >= 4.0).astype(int)), (starts, runs)
