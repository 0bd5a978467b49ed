"""Measurements on a log's windows that calibrate reports beside the fit: which windows are steady
turns, their yaw ratio and ICRs, the forward speed ratio by turn class, the measured track speeds.

The same measures are taken on the logged windows and on the simulated ones, so that calibrate
can say how far the described and the calibrated robot turn from the log.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from mjtrack.geometry import relative_pose, sinc_terms
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import Robot
from mjtrack.windows import (WindowSet, commanded_log, turn_ratio)

if TYPE_CHECKING:  # MuJoCo is loaded by the functions that simulate, not by importing calibrate
    pass

STEADY_MIN_WZ = 0.3  # [rad/s] nominal yaw rate below which a window's yaw ratio is not used
ICR_MIN_TURN = 0.3  # |turn ratio| below which a window's ICRs are not used (they diverge)
SPEED_MIN = 0.1  # [m/s] |mean track speed| below which a window's forward speed ratio is not used
#: |turn ratio| classes of the forward speed ratio: straight, turning, sharp turns
TURN_CLASSES = ((0.0, 0.15), (0.15, 0.5), (0.5, 1.0))


def _chord_twist(p0: np.ndarray, p1: np.ndarray, dur: np.ndarray) -> np.ndarray:
    """Mean body twist (M, 3) of the constant-twist arc from poses p0 to p1 (M, 3) in dur (M,) s."""
    rel = relative_pose(p0, p1)
    rel[:, 2] = p1[:, 2] - p0[:, 2]
    s, c = sinc_terms(rel[:, 2])
    den = (s * s + c * c) * dur
    return np.stack([(s * rel[:, 0] + c * rel[:, 1]) / den, (-c * rel[:, 0] + s * rel[:, 1]) / den,
                     rel[:, 2] / dur], -1)


def steady_mask(lg: DriveLog, ws: WindowSet) -> np.ndarray:
    """Windows whose commands do not change (and, when the log has a ``steady`` column, marked 1)."""
    ok = np.array([np.ptp(lg.v_left_cmd[s:e + 1]) < 1e-6 and np.ptp(lg.v_right_cmd[s:e + 1]) < 1e-6
                   for s, e in zip(ws.starts, ws.ends)])
    if "steady" in lg.extra:
        ok &= np.asarray(lg.extra["steady"])[ws.starts] == 1
    return ok


def turn_measures(lg: DriveLog, ws: WindowSet, robot: Robot, poses: np.ndarray, speeds: np.ndarray) -> dict:
    """Yaw ratio and ICRs of steady windows from window poses (M, K, 3) and track speeds (M, K, 2).

    yaw ratio: median over steady windows with |nominal yaw rate| >= STEADY_MIN_WZ of the
    window's yaw rate / ((v_R - v_L) / T) (mean track speeds of the window), also per |turn ratio|
    class (:data:`TURN_CLASSES`, where a class has at least 3 such windows); ICRs (2.13) from the
    window's chord twist where |turn ratio| >= ICR_MIN_TURN, medians per turn direction; forward
    speed ratio: median of the chord's forward speed / the mean track speed per |turn ratio| class
    (:data:`TURN_CLASSES`), where |mean track speed| >= SPEED_MIN -- 1 without longitudinal slip; a
    real robot falls behind its tracks in turns when the ground resists its motion. Per class, the
    windows and their values behind each median: ``yaw_ratio_samples``, ``speed_ratio_samples``.
    """
    n = ws.ends - ws.starts
    M = len(ws)
    p0, p1 = poses[:, 0], poses[np.arange(M), n]
    dur = lg.t[ws.ends] - lg.t[ws.starts]
    tw = _chord_twist(p0, p1, dur)
    v = np.array([np.nanmean(speeds[j, :n[j] + 1], axis=0) for j in range(M)])
    wnom = (v[:, 1] - v[:, 0]) / robot.track_gauge
    steady = steady_mask(commanded_log(lg), ws)
    use = steady & (np.abs(wnom) >= STEADY_MIN_WZ)
    ratio = float(np.median(tw[use, 2] / wnom[use])) if use.any() else float("nan")
    turn = turn_ratio(v)
    keep = steady & (np.abs(turn) >= ICR_MIN_TURN) & (np.abs(tw[:, 2]) > 1e-3)
    icr = {}
    for sign, name in ((1, "left"), (-1, "right")):
        m = keep & (np.sign(tw[:, 2]) == sign)
        if m.sum() >= 3:
            wz = tw[m, 2]
            icr[name] = {"y_l": float(np.median((tw[m, 0] - v[m, 0]) / wz)),
                         "y_r": float(np.median((tw[m, 0] - v[m, 1]) / wz)),
                         "x_c": float(np.median(-tw[m, 1] / wz)), "windows": int(m.sum())}
    vm = v.mean(axis=1)
    fwd, fwd_samples = {}, {}
    for lo, hi in TURN_CLASSES:
        m = steady & (np.abs(vm) >= SPEED_MIN) & (np.abs(turn) >= lo) & ((np.abs(turn) < hi) | (hi >= 1.0))
        if m.sum() >= 3:
            fwd[(lo, hi)] = (float(np.median(tw[m, 0] / vm[m])), int(m.sum()))
            fwd_samples[(lo, hi)] = (np.flatnonzero(m), tw[m, 0] / vm[m])
    yaw_by_class, samples = {}, {}
    for lo, hi in TURN_CLASSES:
        m = use & (np.abs(turn) >= lo) & ((np.abs(turn) < hi) | (hi >= 1.0))
        if m.sum() >= 3:
            values = tw[m, 2] / wnom[m]
            yaw_by_class[(lo, hi)] = (float(np.median(values)), int(m.sum()))
            samples[(lo, hi)] = (np.flatnonzero(m), values)
    return {"yaw_ratio": ratio, "yaw_windows": int(use.sum()), "icr": icr, "speed_ratio": fwd,
            "yaw_ratio_by_class": yaw_by_class, "yaw_ratio_samples": samples, "speed_ratio_samples": fwd_samples}


GAP_BOOT = 2000  # bootstrap replicates of a class's yaw-ratio gap (:func:`class_gap_interval`)


def command_runs(lg: DriveLog, ws: WindowSet) -> np.ndarray:
    """A label (M,) per window: consecutive windows that start on the same logged command share one
    (the windows of one held command step: the DRIVE protocol's logs hold each step for 6 s, two
    or three 2 s windows, whose errors the same ground and the same drive state make alike)."""
    cmd = commanded_log(lg)
    c = np.stack([cmd.v_left_cmd[ws.starts], cmd.v_right_cmd[ws.starts]], -1).astype(float)
    new = np.ones(len(ws), bool)
    new[1:] = np.any(np.abs(np.diff(c, axis=0)) > 1e-9, axis=1)
    return np.cumsum(new) - 1


def gap_replicates(pairs, *, groups: np.ndarray | None = None, n_boot: int = GAP_BOOT, seed: int = 0) -> np.ndarray:
    """Bootstrap replicates (n_boot, C) of median(a) - median(b) for each of C pairs (a, b) of
    per-window samples of one log's windows, each (window indices, values) as :func:`turn_measures`
    keeps them per class (None: a NaN column). Every replicate draws the windows of all the samples
    at once, with replacement, a window keeping its value in every sample where it has one, so that
    the columns' covariance is the classes' own; ``groups``: a label per window index of the log
    (e.g. :func:`command_runs`), the windows of one label drawn together, as one. NaN where a draw
    leaves a sample empty."""
    windows = np.unique(np.concatenate([x[0] for pair in pairs for x in pair if x is not None]))
    label = np.arange(windows.size) if groups is None else np.unique(np.asarray(groups)[windows],
                                                                    return_inverse=True)[1].ravel()
    n_groups = int(label.max()) + 1
    rng = np.random.default_rng(seed)
    counts = rng.multinomial(n_groups, np.full(n_groups, 1.0 / n_groups), size=n_boot)
    out = np.full((n_boot, len(pairs)), np.nan)
    for col, (a, b) in enumerate(pairs):
        if a is None or b is None:
            continue
        ka, kb = label[np.searchsorted(windows, a[0])], label[np.searchsorted(windows, b[0])]
        for r, c in enumerate(counts):
            ra, rb = np.repeat(a[1], c[ka]), np.repeat(b[1], c[kb])
            if ra.size and rb.size:
                out[r, col] = np.median(ra) - np.median(rb)
    return out


def class_gap_interval(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray], *,
                       groups: np.ndarray | None = None, level: float = 0.95, n_boot: int = GAP_BOOT,
                       seed: int = 0) -> tuple[float, float] | None:
    """Percentile bootstrap interval of median(a) - median(b), two per-window samples of one log's
    windows (:func:`gap_replicates`: how much the class's few windows alone can move the gap; the
    windows of one label of ``groups`` drawn together, so that windows that are not independent do
    not count as independent evidence). None when either sample is empty."""
    if len(a[0]) == 0 or len(b[0]) == 0:
        return None
    gaps = gap_replicates([(a, b)], groups=groups, n_boot=n_boot, seed=seed)[:, 0]
    gaps = gaps[np.isfinite(gaps)]
    if not gaps.size:
        return None
    lo, hi = np.percentile(gaps, [50 * (1 - level), 50 * (1 + level)])
    return float(lo), float(hi)


def measured_speeds(lg: DriveLog, ws: WindowSet) -> np.ndarray:
    """(M, K, 2) measured (else commanded) track speeds of each window, NaN beyond its end."""
    K = int((ws.ends - ws.starts).max()) + 1
    out = np.full((len(ws), K, 2), np.nan)
    for j, (s, e) in enumerate(zip(ws.starts, ws.ends)):
        sl = slice(s, e + 1)
        v = np.stack([lg.v_left_cmd[sl], lg.v_right_cmd[sl]], -1)
        if lg.has_track_speeds:
            meas = np.stack([lg.v_left[sl], lg.v_right[sl]], -1)
            v = np.where(np.isfinite(meas), meas, v)
        out[j, :e - s + 1] = v
    return out
