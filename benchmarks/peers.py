"""Three real robots against the field's peer models, on the same held-out windows.

    python benchmarks/peers.py [--robots marmotte,husky,warthog] [--calibrated husky:DIR ...]

For each shared DRIVE log (../shared/data/, BSD-3; see each folder's README):

* **reproduction**: DRIVE (mjtrack.models.peers) fitted on every window of the whole log, its
  powertrain time constants, dead times and slip weights set against those the authors' code gives
  on the same log (``AUTHORS``), fitted twice: on the authors' nominal 20 Hz clock (every window's
  samples taken 0.05 s apart, as their code takes them) and on the log's own times;
* **peers on held-out windows**: train on the first 70 % of the log's segments, test on the last
  30 % (``SPLIT``, the same for all three robots), 2 s windows (``make_windows``), the windows
  the ground cannot explain (``without_contradicting``) left out of both parts for every model and
  counted. Models: DRIVE as its authors fit it (dead time on the plateau their optimiser stays on)
  and with its dead time fitted; the ideal differential drive from the commands and from the
  measured track speeds; the ICR model with a speed scale, fitted on the training windows, from the
  measured speeds and from the commands. Metrics per model: end-of-window RMS position error, the
  mean over windows of the mean position distance over the window, the end-of-window yaw RMS, and
  the steady-turn yaw ratio per turn class against the measured one;
* **what the gyro says** (``gyro_evidence``), where the log has one: the steady-turn yaw ratio per
  turn class from the poses and from the gyro, and, at command steps, how long before the ideal yaw
  rate of the measured track speeds the gyro's rate gets half-way to its new value;
* ``--calibrated ROBOT:DIR``: the calibration directory's robot.json simulated by MuJoCo on the same
  test windows (from each window's measured state, the commands as drive input unless the robot's
  ``simulator.drive_input`` says measured), one more row.

Writes benchmarks/results/peers.json and prints the tables and the machine's load.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from mjtrack.calibrate.measures import TURN_CLASSES, turn_measures
from mjtrack.windows import turn_ratio
from mjtrack.io import read_log_with_robot
from mjtrack.metrics import fit_end_regions, window_prediction_errors
from mjtrack.models import peers
from mjtrack.windows import left_out_counts, make_windows, measured_window_poses, without_contradicting

import real_robots as _real  # the same split, data folder and JSON values as the calibration of the real robots

DATA, split, _plain = _real.DATA, _real.split, _real._plain
HERE = Path(__file__).resolve().parent

RESULT = HERE / "results" / "peers.json"
SPLIT = (0.7, 0.3)
HORIZON_S = 2.0
LOGS = {"marmotte": DATA / "marmotte" / "marmotte_boreal.csv", "husky": DATA / "husky" / "husky_drive.csv",
        "warthog": DATA / "warthog" / "warthog_drive.csv"}
#: what the authors' code gives, trained on all of each shared log: time constants and dead times
#: (left, right) [s], slip weights on [vx]; [vx wz]; [vx wz, vx, wz]
AUTHORS = {
    "husky": {"tau": [1.87, 1.71], "delay": [0.067, 0.067],
              "slip_weights": {"x": [-0.155], "y": [0.056], "yaw": [0.013, -0.004, 0.811]}},
    "warthog": {"tau": [1.32, 1.08], "delay": [0.059, 0.057],
                "slip_weights": {"x": [0.274], "y": [0.076], "yaw": [-0.008, 0.006, 0.606]}},
    "marmotte": {"tau": [0.37, 0.41], "delay": [0.057, 0.050],
                 "slip_weights": {"x": [0.118], "y": [0.039], "yaw": [-0.039, 0.011, -0.001]}},
}
#: the authors' DRIVE on the last 30 % of each run (not in the shared folder: other windows than
#: ours), with their metric: end-of-window RMS [m], mean distance over the window [m], windows
AUTHORS_HELD_OUT = {"husky": (0.451, 0.188, 183), "warthog": (1.235, 0.506, 108), "marmotte": (0.307, 0.125, 186)}


def window_arrays(log, ws) -> dict:
    """The windows of ``log`` as NaN-padded arrays (M, K, ...): commands, measured speeds, poses
    (yaw continuous), times, the gyro; ``last`` (M,) each window's last sample, ``dt`` (M,) its mean
    period, ``step`` (M,) whether it starts with a command step (the log's ``steady`` column is 0)."""
    last = ws.ends - ws.starts
    M, K = len(ws), int(last.max()) + 1

    def take(col):
        out = np.full((M, K), np.nan)
        for j, (s, e) in enumerate(zip(ws.starts, ws.ends)):
            out[j, :e - s + 1] = col[s:e + 1]
        return out

    t = take(log.t)
    steady = np.asarray(log.extra["steady"])[ws.starts] == 1 if "steady" in log.extra else np.ones(M, bool)
    return {"cmd": np.stack([take(log.v_left_cmd), take(log.v_right_cmd)], -1),
            "meas": np.stack([take(log.v_left), take(log.v_right)], -1),
            "poses": measured_window_poses(log, ws), "t": t - t[:, :1],
            "gyro": take(np.asarray(log.extra["wz_imu"], float)) if "wz_imu" in log.extra else None,
            "last": last, "dt": (log.t[ws.ends] - log.t[ws.starts]) / last, "step": ~steady}


def window_nanmeans(x: np.ndarray, last: np.ndarray) -> np.ndarray:
    """Mean of each window's samples of the NaN-padded ``x`` (M, K, ...) up to its last sample,
    missing samples left out: (M, ...)."""
    return np.array([np.nanmean(x[j, :last[j] + 1], axis=0) for j in range(len(last))])


def gyro_sign(a: dict) -> float:
    """+1 when the gyro turns the way the poses' yaw does, -1 when it is mounted the other way
    round (the sign of their correlation over every sample)."""
    yr = np.diff(a["poses"][..., 2], axis=1) / np.diff(a["t"], axis=1)
    g = a["gyro"][:, :-1]
    ok = np.isfinite(yr) & np.isfinite(g)
    return float(np.sign(np.sum(g[ok] * yr[ok])))


def measured_body(a: dict, sign: float, *, nominal_clock: bool = False) -> np.ndarray:
    t = np.where(np.isfinite(a["t"]), np.arange(a["t"].shape[1]) * 0.05, np.nan) if nominal_clock else a["t"]
    return peers.body_velocities(a["poses"], t, None if a["gyro"] is None else sign * a["gyro"])


def fit_on(a: dict, gauge: float, sign: float, *, delay=peers.AUTHORS_DELAY, nominal_clock=False) -> peers.Drive:
    dt = np.full(len(a["dt"]), 0.05) if nominal_clock else a["dt"]
    return peers.fit_drive(a["cmd"], a["meas"], measured_body(a, sign, nominal_clock=nominal_clock), dt, gauge,
                           step=a["step"], steady=~a["step"], delay=delay)


def reproduction(log, gauge: float, name: str) -> dict:
    """DRIVE on every window of the whole log, on the nominal clock and the log's own, beside the
    authors' values; ``ratio``: ours over theirs, per value."""
    a = window_arrays(log, make_windows(log, HORIZON_S))
    sign = gyro_sign(a)
    out = {"windows": len(a["last"]), "gyro_sign": sign, "authors": AUTHORS.get(name)}
    for key, nominal in (("nominal_clock", True), ("log_clock", False)):
        d = fit_on(a, gauge, sign, nominal_clock=nominal).to_json()
        out[key] = {k: d[k] for k in ("tau", "delay", "slip_weights", "bounds")}
    free = fit_on(a, gauge, sign, delay=None).to_json()
    out["dead_time_fitted"] = {k: free[k] for k in ("tau", "delay")}
    return out


def yaw_ratios(lg, ws, robot, a: dict, poses: dict) -> dict:
    """Steady-turn yaw ratio (calibrate's turn_measures) per turn class of the measured track speeds,
    measured and for every model's predicted poses (None where no steady turn counts), every model's
    over the measured track speeds: what it predicts of the turn, its drives' error included (calibrate
    divides a simulation's yaw rate by the simulation's own track speeds)."""
    def ratio(ws_, p, m=slice(None)):
        r = turn_measures(lg, ws_, robot, p[m], a["meas"][m])
        return (None if not np.isfinite(r["yaw_ratio"]) else r["yaw_ratio"]), r["yaw_windows"]

    v = window_nanmeans(a["meas"], a["last"])
    turn = np.abs(turn_ratio(v))
    out = {}
    for lo, hi in TURN_CLASSES:
        m = (turn >= lo) & ((turn < hi) | (hi >= 1.0))
        if not m.any():
            continue
        sub = ws.subset(m)
        measured, n = ratio(sub, a["poses"], m)
        out[f"{lo:g}-{hi:g}"] = {"windows": n, "measured": measured, **{k: ratio(sub, p, m)[0] for k, p in poses.items()}}
    measured, n = ratio(ws, a["poses"])
    return {"all": {"windows": n, "measured": measured, **{k: ratio(ws, p)[0] for k, p in poses.items()}}, **out}


#: |change| [rad/s] of a step window's yaw rate, from its first sample to its last half second, below
#: which :func:`gyro_evidence` does not time the step (too small a change to find its half-way point)
STEP_MIN_CHANGE = 0.4


def _half_way(t: np.ndarray, x: np.ndarray) -> float:
    """Time [s] at which ``x`` (one window) first gets half-way from its first sample to the mean of
    its last half second, linearly between samples; NaN for a change under :data:`STEP_MIN_CHANGE`."""
    ok = np.isfinite(t) & np.isfinite(x)
    t, x = t[ok], x[ok]
    end = x[t >= t[-1] - 0.5].mean()
    if abs(end - x[0]) < STEP_MIN_CHANGE:
        return float("nan")
    f = (x - x[0]) / (end - x[0])
    k = int(np.argmax(f >= 0.5))
    if k == 0:
        return float("nan")
    return float(t[k - 1] + (0.5 - f[k - 1]) / (f[k] - f[k - 1]) * (t[k] - t[k - 1]))


#: the largest shift [samples] :func:`xcorr_lead` tries either way
XCORR_SHIFT = 10


def xcorr_lead(t: np.ndarray, x: np.ndarray, ref: np.ndarray, max_shift: int = XCORR_SHIFT) -> float:
    """How far [s] the signal ``x`` runs ahead of ``ref`` (both (M, K), windows of one log on its
    sample grid ``t`` (M, K)): the shift k of the highest correlation between x(t) and ref(t + k),
    over every window's pairs at once (the windows' means removed), refined by a parabola through
    the peak and its neighbours, times the median sample step. Positive: ``x`` changes first."""
    def corr(k: int) -> float:
        a, b = (x[:, :x.shape[1] - k], ref[:, k:]) if k >= 0 else (x[:, -k:], ref[:, :ref.shape[1] + k])
        ok = np.isfinite(a) & np.isfinite(b)  # pairs both signals have; each window's mean over them removed
        a, b = (np.nan_to_num(v - np.nanmean(v, axis=1, keepdims=True)) for v in (np.where(ok, a, np.nan),
                                                                                np.where(ok, b, np.nan)))
        return float((a * b).sum() / np.sqrt((a * a).sum() * (b * b).sum()))

    ks = np.arange(-max_shift, max_shift + 1)
    c = np.array([corr(int(k)) for k in ks])
    i = int(np.nanargmax(c))
    frac = 0.0
    if 0 < i < len(ks) - 1 and (c[i - 1] - 2 * c[i] + c[i + 1]) < 0:
        frac = 0.5 * (c[i - 1] - c[i + 1]) / (c[i - 1] - 2 * c[i] + c[i + 1])
    step = float(np.nanmedian(np.diff(t, axis=1)))
    return float((ks[i] + frac) * step)


def gyro_evidence(lg, ws, robot, a: dict, sign: float) -> dict:
    """What the log's gyro says beside its poses and its measured track speeds: per turn class
    (calibrate's classes, of the measured track speeds) the steady-turn yaw ratio from the poses
    (calibrate's turn_measures, as in the tables above) and from the gyro (the median over the same
    steady turns of the window's mean gyro rate over (v_R - v_L)/T of its mean measured speeds);
    and, over the windows that start with a command step, when the gyro's yaw rate gets half-way to
    its new value against when the ideal yaw rate of the measured track speeds does (a body cannot
    turn before its wheels: a gyro ahead says the measured speeds are dated late); and, over every
    window, how far the gyro's yaw rate and the poses' (their yaw differentiated) run ahead of that
    ideal rate (:func:`xcorr_lead`): the clocks of the three sensors against one another, the poses
    being what calibrate fits."""
    from mjtrack.calibrate.measures import STEADY_MIN_WZ, steady_mask
    from mjtrack.windows import commanded_log

    gauge = robot.track_gauge
    last = a["last"]
    v = window_nanmeans(a["meas"], last)
    wnom = (v[:, 1] - v[:, 0]) / gauge
    gyro = sign * window_nanmeans(a["gyro"], last)
    use = steady_mask(commanded_log(lg), ws) & (np.abs(wnom) >= STEADY_MIN_WZ)
    turn = np.abs(turn_ratio(v))
    poses = turn_measures(lg, ws, robot, a["poses"], a["meas"])["yaw_ratio_by_class"]
    classes = {}
    for lo, hi in TURN_CLASSES:
        m = use & (turn >= lo) & ((turn < hi) | (hi >= 1.0))
        if m.sum() >= 3:
            classes[f"{lo:g}-{hi:g}"] = {"windows": int(m.sum()), "poses": poses.get((lo, hi), (None,))[0],
                                         "gyro": float(np.median(gyro[m] / wnom[m]))}
    ideal = (a["meas"][..., 1] - a["meas"][..., 0]) / gauge
    lead = np.array([_half_way(a["t"][j], ideal[j]) - _half_way(a["t"][j], sign * a["gyro"][j])
                     for j in np.flatnonzero(a["step"])])
    lead = lead[np.isfinite(lead)]
    steps = {"windows": int(a["step"].sum()), "timed": int(lead.size), "min_change_rad_s": STEP_MIN_CHANGE}
    if lead.size:
        steps.update(zip(("gyro_lead_q25_s", "gyro_lead_median_s", "gyro_lead_q75_s"),
                         (float(x) for x in np.percentile(lead, [25, 50, 75]))))
    pose_rate = np.gradient(a["poses"][..., 2], axis=1) / np.maximum(np.gradient(a["t"], axis=1), 1e-9)
    leads = {"gyro_ahead_s": xcorr_lead(a["t"], sign * a["gyro"], ideal),
             "poses_ahead_s": xcorr_lead(a["t"], pose_rate, ideal), "max_shift_samples": XCORR_SHIFT}
    return {"yaw_ratio_by_class": classes, "steps": steps, "xcorr": leads}


def _speeds(a: dict) -> np.ndarray:
    """Measured track speeds, the commands where a sample has none."""
    return np.where(np.isfinite(a["meas"]), a["meas"], a["cmd"])


def end_errors(a: dict, poses: np.ndarray) -> np.ndarray:
    """(M, 2) measured minus predicted end position of each window, in its measured start frame."""
    rows = np.arange(len(a["last"]))
    d = a["poses"][rows, a["last"], :2] - poses[rows, a["last"], :2]
    yaw0 = a["poses"][:, 0, 2]
    return np.stack([np.cos(yaw0) * d[:, 0] + np.sin(yaw0) * d[:, 1], -np.sin(yaw0) * d[:, 0] + np.cos(yaw0) * d[:, 1]],
                    -1)


#: the twist controller's ramps (mjtrack.models.drivetrain), which the wheel-speed comparison
#: leaves out of one chain to measure what they add
TWIST_RAMPS = ("drive_mean_accel_limit", "drive_turn_accel_limit")
REGIME_MARGIN = 0.3  # [m/s] a side's command this far from its start speed makes a step window's regime
HALF_DIFFERENCE_CLASSES = ((0.0, 0.5), (0.5, 1.5), (1.5, float("inf")))  # [m/s] small, medium, large turns


def speed_window_arrays(a: dict):
    """The windows ``a`` (:func:`window_arrays`) as the drivetrain's SpeedWindows: no history before
    a window (the chain starts from the measured speeds at its first sample, as DRIVE does), the
    rows after the first with measured speeds fitted, NaN padding continued at the window's period
    and ignored."""
    from mjtrack.calibrate.drivetrain import SpeedWindows

    M, K = a["t"].shape
    k = np.arange(K)[None, :]
    inside = k <= a["last"][:, None]
    t = np.where(inside, a["t"], (k - a["last"][:, None]) * a["dt"][:, None] + a["t"][np.arange(M), a["last"]][:, None])
    last_cmd = a["cmd"][np.arange(M), a["last"]]
    cmd = np.where(inside[..., None], a["cmd"], last_cmd[:, None])
    valid = inside & (k >= 1) & np.all(np.isfinite(a["meas"]), -1)
    return SpeedWindows(t=t, cmd=cmd, meas=np.nan_to_num(a["meas"]), valid=valid, v0=_speeds(a)[:, 0])


def wheel_speeds(train_log, robot, a: dict, drive: peers.Drive) -> dict:
    """What each model of the drives predicts of the measured track speeds on the test windows
    ``a``, from their commands and the measured speeds at each window's start: DRIVE's powertrain,
    and the drivetrain chain (mjtrack.calibrate.drivetrain.fit_chain) fitted on the training part,
    with and without the twist controller's ramps. RMS of measured minus predicted [m/s] per side,
    over all rows after each window's first, in the windows that start with a command step
    (``step``: per side, the command ahead of the start speed by more than :data:`REGIME_MARGIN`, ``accelerating``,
    behind it in the same direction, ``braking``, or of the other sign, ``reversing``) and in the
    windows whose command has held since before them (``steady``); the steady windows' mean
    residual of the two sides' mean and half difference, by the commanded half difference
    (:data:`HALF_DIFFERENCE_CLASSES`)."""
    from mjtrack.calibrate.drivetrain import fit_chain, predict

    sw = speed_window_arrays(a)
    fits = {"chain": fit_chain(train_log, robot), "chain_without_twist_ramps": fit_chain(train_log, robot,
                                                                                          without=TWIST_RAMPS)}
    pred = {k: predict(sw, f.values) for k, f in fits.items()}
    pred["drive"] = drive.track_speeds(sw.cmd, sw.v0, a["dt"], a["step"])
    c0, v0 = sw.cmd[:, 0], sw.v0
    ahead = np.sign(c0) == np.sign(v0)
    side_regimes = {"accelerating": ahead & (np.abs(c0) > np.abs(v0) + REGIME_MARGIN),
                    "braking": ahead & (np.abs(c0) < np.abs(v0) - REGIME_MARGIN),
                    "reversing": ~ahead & (np.abs(c0 - v0) > REGIME_MARGIN)}

    def rms(d, rows):
        d = d[rows & sw.valid]
        return float(np.sqrt(np.mean(d ** 2))) if d.size else None

    out = {"half_difference_classes_m_s": [list(b) for b in HALF_DIFFERENCE_CLASSES],
           "regime_margin_m_s": REGIME_MARGIN,
           "windows": {"step": int(a["step"].sum()), "steady": int((~a["step"]).sum())},
           "chains": {k: {"values": f.values, "verdicts": f.verdicts} for k, f in fits.items()}, "models": {}}
    half_cmd = 0.5 * np.abs(c0[:, 1] - c0[:, 0])
    classes = dict(zip(("small", "medium", "large"), HALF_DIFFERENCE_CLASSES))
    for k, p in pred.items():
        d = sw.meas - p
        m = {"all": [rms(d[..., i], np.ones_like(sw.valid)) for i in range(2)],
             "step": [rms(d[..., i], np.repeat(a["step"][:, None], sw.valid.shape[1], 1)) for i in range(2)],
             "steady": [rms(d[..., i], np.repeat(~a["step"][:, None], sw.valid.shape[1], 1)) for i in range(2)]}
        for name, sel in side_regimes.items():
            m[name] = [rms(d[..., i], np.repeat((sel[:, i] & a["step"])[:, None], sw.valid.shape[1], 1))
                       for i in range(2)]
            out["windows"][name] = [int((sel[:, i] & a["step"]).sum()) for i in range(2)]
        late = sw.valid & (sw.t >= 1.0) & ~a["step"][:, None]  # the second half of steady windows
        sgn = np.sign(c0[:, 1] - c0[:, 0])[:, None]
        by_turn = {}
        for cls, (lo, hi) in classes.items():
            rows = late & ((half_cmd >= lo) & (half_cmd < hi))[:, None]
            by_turn[cls] = {
                "windows": int(rows.any(1).sum()),
                "mean_speed_bias": float(np.mean(0.5 * (d[..., 0] + d[..., 1])[rows])) if rows.any() else None,
                "half_difference_bias": float(np.mean((0.5 * (d[..., 1] - d[..., 0]) * sgn)[rows])) if rows.any()
                else None}
        m["steady_by_commanded_half_difference"] = by_turn
        out["models"][k] = m
    return out


def region_scale_groups(a: dict) -> tuple[np.ndarray, np.ndarray]:
    """Each window's length scale [m] (the path of its mean commanded track speed: what a planner
    knows) and turn class (index into calibrate's classes of |turn ratio| of its mean commands)."""
    c = window_nanmeans(a["cmd"], a["last"])
    scale = 0.5 * (np.abs(c[:, 0]) + np.abs(c[:, 1])) * a["dt"] * a["last"]
    turn = np.abs(turn_ratio(c))
    groups = np.array([next(i for i, (lo, hi) in enumerate(TURN_CLASSES) if t < hi or hi >= 1.0) for t in turn])
    return scale, groups


def end_regions(train: dict, train_poses, test: dict, test_poses, level: float = 0.9) -> dict:
    """A model's 90 % end-position regions (mjtrack.metrics.fit_end_regions) fitted on the scatter
    of its training windows' end errors, per turn class of the commands and growing with the
    commanded path; their coverage of the held-out windows' measured ends, and their mean area."""
    reg = fit_end_regions(end_errors(train, train_poses), *region_scale_groups(train), level=level)
    s, g = region_scale_groups(test)
    inside = reg.contains(end_errors(test, test_poses), s, g)
    return {"level": level, "coverage": float(inside.mean()), "windows": int(inside.size),
            "train_coverage": float(reg.contains(end_errors(train, train_poses), *region_scale_groups(train)).mean()),
            "mean_area_m2": float(np.mean(reg.area(s, g))),
            "per_class": {f"{lo:g}-{hi:g}": {"windows": int((g == i).sum()),
                                             "coverage": float(inside[g == i].mean()) if (g == i).any() else None}
                          for i, (lo, hi) in enumerate(TURN_CLASSES)}}


def calibrated_poses(directory: Path, part, tws, *, setting_only: bool = False):
    """(M, K, 3) poses of the calibration's robot.json simulated by MuJoCo on the windows ``tws`` of
    ``part``, and the drive input it follows; with ``setting_only`` only the drive input."""
    from mjtrack.io.robot import read_robot
    from mjtrack.sim.config import robot_sim_settings, sim_config
    from mjtrack.sim.windows import WindowSim, simulate_windows
    from mjtrack.windows import WARMUP_S, measured_drive_log

    robot = read_robot(directory / "robot.json")
    drive_input = robot_sim_settings(robot).get("drive_input", "commanded")
    if setting_only:
        return drive_input
    lg = measured_drive_log(part, "log part") if drive_input == "measured" else part
    cal = json.loads((directory / "calibration.json").read_text()) if (directory / "calibration.json").exists() else {}
    ground = {k: cal.get("parameters", {})[k] for k in ("slope_x", "slope_y") if k in cal.get("parameters", {})}
    res = simulate_windows(WindowSim(robot, sim_config(None, robot=robot), resisted=True), lg, tws, [ground],
                           warmup_s=WARMUP_S)
    if res.diverged[0].any():  # said, not hidden: a blown-up window's poses are the blow-up's
        print(f"  {directory.name}: {int(res.diverged[0].sum())} of {len(tws)} windows diverged", flush=True)
    return res.poses[0], drive_input


def run_robot(name: str, calibrated: dict[str, Path]) -> dict:
    log, robot = read_log_with_robot(LOGS[name])
    gauge = robot.track_gauge
    out = {"traction": robot.traction, "gauge": gauge, "reproduction": reproduction(log, gauge, name)}
    sign = out["reproduction"]["gyro_sign"]
    parts = split(log, *SPLIT)
    kept, left = [], {}
    for label, lg in zip(("train", "test"), parts):
        every = make_windows(lg, HORIZON_S)
        ws, rows = without_contradicting(lg, every, gauge)
        kept.append(ws)
        left[label] = {"windows": len(every), "kept": len(ws), "left_out": len(rows), "why": left_out_counts(rows),
                       "t0": [r["t0"] for r in rows]}
    train, test = (window_arrays(lg, ws) for lg, ws in zip(parts, kept))
    drive = fit_on(train, gauge, sign)
    drive_free = fit_on(train, gauge, sign, delay=None)
    icr_meas = peers.fit_icr(_speeds(train), train["poses"], train["dt"], train["last"], gauge)
    icr_cmd = peers.fit_icr(train["cmd"], train["poses"], train["dt"], train["last"], gauge)

    def predicted(a: dict, part: int) -> dict:
        meas = _speeds(a)
        twists = {
            "drive": drive.twist(a["cmd"], meas[:, 0], a["dt"], a["step"]),
            "drive_dead_time_fitted": drive_free.twist(a["cmd"], meas[:, 0], a["dt"], a["step"]),
            "ideal_commands": peers.ideal_twist(a["cmd"], gauge),
            "ideal_measured": peers.ideal_twist(meas, gauge),
            "icr_measured": icr_meas.twist(meas),
            "icr_commands": icr_cmd.twist(a["cmd"]),
        }
        out = {k: peers.integrate_windows(a["poses"][:, 0], tw, a["dt"]) for k, tw in twists.items()}
        if name in calibrated:
            sim = calibrated_poses(calibrated[name], parts[part], kept[part])[0]
            out["calibrated_mujoco"] = sim[:, :a["poses"].shape[1]]
        return out

    t0 = time.time()
    poses = predicted(test, 1)
    fitted = predicted(train, 0)
    if name in calibrated:
        out["calibrated"] = {"directory": str(calibrated[name].relative_to(HERE.parent)),
                             "drive_input": calibrated_poses(calibrated[name], None, None, setting_only=True),
                             "seconds": time.time() - t0}
    out["regions"] = {k: end_regions(train, fitted[k], test, poses[k]) for k in poses}
    a = test
    models = {k: window_prediction_errors(p, a["poses"], a["last"]).summary() for k, p in poses.items()}
    out.update({
        "split": {"train": SPLIT[0], "test": SPLIT[1]}, "horizon_s": HORIZON_S, "windows": left,
        "drive": drive.to_json(), "drive_dead_time_fitted": drive_free.to_json(),
        "icr_measured": vars(icr_meas), "icr_commands": vars(icr_cmd),
        "models": models, "yaw_ratio": yaw_ratios(parts[1], kept[1], robot, a, poses),
        "authors_held_out": dict(zip(("end_rms_m", "mean_distance_m", "windows"), AUTHORS_HELD_OUT[name])),
    })
    if np.isfinite(a["meas"]).any():
        out["wheel_speeds"] = wheel_speeds(parts[0], robot, a, drive)
    if a["gyro"] is not None and np.isfinite(a["meas"]).any():
        out["gyro_evidence"] = {label: gyro_evidence(lg, ws, robot, arr, sign)
                                for label, lg, ws, arr in zip(("train", "test"), parts, kept, (train, test))}
    return out


def _f3(v) -> str:
    return "n/a" if v is None else f"{v:.3f}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robots", default=",".join(LOGS))
    ap.add_argument("--calibrated", action="append", default=[], metavar="ROBOT:DIR",
                    help="score a calibration directory's robot.json (MuJoCo) on the same test windows")
    args = ap.parse_args(argv)
    calibrated = {}
    for c in args.calibrated:
        name, _, d = c.partition(":")
        if name not in LOGS or not (Path(d) / "robot.json").exists():
            ap.error(f"--calibrated {c}: expected ROBOT:DIR with ROBOT one of {', '.join(LOGS)} and DIR holding robot.json")
        calibrated[name] = Path(d).resolve()
    load0 = os.getloadavg()
    stored = json.loads(RESULT.read_text()) if RESULT.exists() else {}
    robots = stored.get("robots", {})
    for name in args.robots.split(","):
        if not LOGS[name].exists():
            print(f"{LOGS[name]} not found (the shared data); skipped")
            continue
        t0 = time.time()
        r = robots[name] = run_robot(name, calibrated)
        r["seconds"] = time.time() - t0
        rep = r["reproduction"]
        print(f"\n== {name} ({r['seconds']:.0f} s); gyro sign {rep['gyro_sign']:+.0f}")
        for key in ("authors", "nominal_clock", "log_clock"):
            x = rep[key]
            print(f"  {key:14s} tau {np.round(x['tau'], 3)}  delay {np.round(x['delay'], 3)}  "
                  + "  ".join(f"{k} {np.round(v, 3)}" for k, v in x["slip_weights"].items()))
        print(f"  dead time fitted: tau {np.round(rep['dead_time_fitted']['tau'], 3)}, "
              f"delay {np.round(rep['dead_time_fitted']['delay'], 3)}")
        w = r["windows"]
        print(f"  windows: train {w['train']['kept']} of {w['train']['windows']}, test {w['test']['kept']} of "
              f"{w['test']['windows']} (left out: {w['test']['why'] or 'none'})")
        for k, m in r["models"].items():
            y = r["yaw_ratio"]["all"]
            g = r["regions"][k]
            print(f"  {k:24s} end RMS {m['end_rms_m']:.3f} m  mean distance {m['mean_distance_m']:.3f} m  "
                  f"yaw RMS {m['yaw_rms_rad']:.3f} rad  yaw ratio {_f3(y[k])} (measured {_f3(y['measured'])})  "
                  f"90 % regions cover {g['coverage']:.3f} (train {g['train_coverage']:.3f}), "
                  f"mean area {g['mean_area_m2']:.3f} m2")
        for part, ev in r.get("gyro_evidence", {}).items():
            st = ev["steps"]
            print(f"  gyro, {part}: steady yaw ratio poses / gyro "
                  + "; ".join(f"{c} {_f3(v['poses'])} / {_f3(v['gyro'])} ({v['windows']})"
                              for c, v in ev["yaw_ratio_by_class"].items())
                  + (f"; gyro ahead of the measured speeds at {st['timed']} steps by {st['gyro_lead_median_s']:+.3f} s "
                     f"(median)" if "gyro_lead_median_s" in st else "")
                  + (f"; by cross-correlation gyro {ev['xcorr']['gyro_ahead_s']:+.3f} s, poses "
                     f"{ev['xcorr']['poses_ahead_s']:+.3f} s ahead of the measured speeds" if "xcorr" in ev else ""))
        RESULT.parent.mkdir(parents=True, exist_ok=True)
        RESULT.write_text(json.dumps({"command": "python benchmarks/peers.py " + " ".join(sys.argv[1:] if argv is None
                                                                                          else argv),
                                      "robots": robots, "load_before": load0[0], "load_after": os.getloadavg()[0]},
                                     indent=1, default=_plain) + "\n")
    print(f"\nload average before {load0}, after {os.getloadavg()} ({os.cpu_count()} cores)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
