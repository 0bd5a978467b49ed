"""Windows of a drive log: short stretches inside one segment, each to be predicted from its
measured start state.

A window never crosses a segment boundary (``window`` column); a segment shorter than the
horizon but at least ``min_fraction`` of it still gives one window that ends at its last sample
(the Marmotte log is 432 segments of 1.90-2.06 s). The start state of a window is measured: the
pose at its first sample, the body twist (:func:`start_twists`) and the track speeds
(:func:`start_speeds`); the error of a prediction is taken at its last sample, in the frame of
its measured start pose (:func:`window_errors`).

Derivation and measurements: docs/theory/simulator.md, "Windows of a log".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mjtrack.errors import InputError
from mjtrack.geometry import relative_pose, wrap_angle, world_to_body_velocity
from mjtrack.io.logs import DriveLog

#: [s] history over which calibration and diagnosis warm up a window's hidden states
#: (:func:`mjtrack.sim.windows.warm_states`): on the simulator's own 60 s logs it takes the replay error at 2 s from
#: 0.40 mm RMS (2 mm worst, a start mid-reversal) to 0.0003 mm; 1 s gains nothing more
WARMUP_S = 0.5
#: [m, m, rad] the error a window whose simulation blew up is scored with, in each of along, across
#: and yaw: what its blown-up poses give is the blow-up's own (NaN, or thousands of metres, by chance),
#: and a score that held it would say more of the instability than of the model; the fit's residual
#: of such a window is the same (mjtrack.calibrate.fit)
DIVERGED_ERROR = 3.0


@dataclass(frozen=True)
class WindowSet:
    """Windows of a log: ``starts``/``ends`` (M,) row indices (first and last sample, both in the
    window), ``segment`` (M,) the segment index of each, ``horizon_s`` the nominal horizon [s]."""

    starts: np.ndarray
    ends: np.ndarray
    segment: np.ndarray
    horizon_s: float

    def __len__(self) -> int:
        return int(self.starts.size)

    def subset(self, index) -> "WindowSet":
        """The windows selected by an index array or mask."""
        return WindowSet(self.starts[index], self.ends[index], self.segment[index], self.horizon_s)


def make_windows(log: DriveLog, horizon_s: float = 2.0, *, stride_s: float | None = None,
                 min_fraction: float = 0.9) -> WindowSet:
    """Windows of ``horizon_s`` inside each segment, starting every ``stride_s`` (default: the
    horizon, non-overlapping). A window ends at the first sample at or after start + horizon; a
    segment's last window may end earlier, at its last sample, if that is at least
    ``min_fraction`` of the horizon after the start."""
    if not (horizon_s > 0 and math.isfinite(horizon_s)):
        raise InputError(f"windows: horizon must be a positive number of seconds, got {horizon_s!r}")
    stride = horizon_s if stride_s is None else float(stride_s)
    if not stride > 0:
        raise InputError(f"windows: stride must be > 0 s, got {stride_s!r}")
    starts, ends, segs = [], [], []
    for k, sl in enumerate(log.segment_slices()):
        t = log.t[sl]
        t_next = t[0]
        for i in range(t.size):
            if t[i] < t_next - 1e-9:
                continue
            e = int(np.searchsorted(t, t[i] + horizon_s - 1e-9))
            if e >= t.size:
                if t[-1] - t[i] >= min_fraction * horizon_s - 1e-9:
                    e = t.size - 1
                else:
                    break
            starts.append(sl.start + i)
            ends.append(sl.start + e)
            segs.append(k)
            t_next = t[i] + stride
    return WindowSet(np.array(starts, int), np.array(ends, int), np.array(segs, int), float(horizon_s))


def start_twists(log: DriveLog, ws: WindowSet, *, fit_s: float = 0.3) -> np.ndarray:
    """Body twist (M, 3) at each window's first sample: the log's ``vx, vy, wz`` when present,
    else the derivative at t0 of a quadratic least-squares fit to the poses within ``fit_s``
    seconds (centred on t0 where the segment allows, one-sided at the segment's edges)."""
    if log.has_twist and np.all(np.isfinite(log.vx[ws.starts])):
        return np.stack([log.vx[ws.starts], log.vy[ws.starts], log.wz[ws.starts]], -1).astype(float)
    out = np.zeros((len(ws), 3))
    slices = log.segment_slices()
    for j, (s, k) in enumerate(zip(ws.starts, ws.segment)):
        sl = slices[k]
        t = log.t[sl] - log.t[s]
        yaw = np.unwrap(log.yaw[sl])
        lo, hi = -fit_s / 2, fit_s / 2
        if t[0] > lo:  # near the segment's start: one-sided
            lo, hi = t[0], t[0] + fit_s
        elif t[-1] < hi:
            lo, hi = t[-1] - fit_s, t[-1]
        m = (t >= lo - 1e-9) & (t <= hi + 1e-9)
        if m.sum() < 3:  # too few samples for a quadratic: a straight line through two
            m = np.zeros_like(m)
            i0 = s - sl.start
            m[max(0, min(i0, t.size - 2)):max(0, min(i0, t.size - 2)) + 2] = True
        deg = 2 if m.sum() >= 3 else 1
        d = [np.polyfit(t[m], v[m], deg)[-2] for v in (log.x[sl], log.y[sl], yaw)]
        vx, vy = world_to_body_velocity(log.yaw[s], d[0], d[1])
        out[j] = (vx, vy, d[2])
    return out


def start_speeds(log: DriveLog, ws: WindowSet) -> np.ndarray:
    """Track speeds (M, 2) at each window's first sample: measured when present, else commanded."""
    cmd = np.stack([log.v_left_cmd[ws.starts], log.v_right_cmd[ws.starts]], -1).astype(float)
    if not log.has_track_speeds:
        return cmd
    meas = np.stack([log.v_left[ws.starts], log.v_right[ws.starts]], -1).astype(float)
    return np.where(np.isfinite(meas), meas, cmd)


def window_errors(log: DriveLog, ws: WindowSet, poses: np.ndarray) -> np.ndarray:
    """(P, M, 3) errors at each window's last sample in its measured start frame (along, across,
    yaw) for predicted poses (P, M, K, 3) as :func:`mjtrack.sim.windows.simulate_windows` returns them."""
    n = ws.ends - ws.starts
    M = len(ws)
    pred = poses[:, np.arange(M), n]  # (P, M, 3)
    start = np.stack([log.x[ws.starts], log.y[ws.starts], log.yaw[ws.starts]], -1).astype(float)
    yaw_meas = np.array([log.yaw[ws.starts[j]] + np.sum(wrap_angle(np.diff(log.yaw[ws.starts[j]:ws.ends[j] + 1])))
                         for j in range(M)])
    end = np.stack([log.x[ws.ends], log.y[ws.ends], yaw_meas], -1).astype(float)
    err = relative_pose(start[None], pred) - relative_pose(start, end)[None]
    err[..., 2] = pred[..., 2] - end[:, 2][None]
    return err


def measured_window_poses(log: DriveLog, ws: WindowSet) -> np.ndarray:
    """(M, K, 3) measured poses of each window (yaw unwrapped, NaN beyond its end)."""
    K = int((ws.ends - ws.starts).max()) + 1
    out = np.full((len(ws), K, 3), np.nan)
    for j in range(len(ws)):
        sl = slice(ws.starts[j], ws.ends[j] + 1)
        out[j, :sl.stop - sl.start] = np.column_stack([log.x[sl], log.y[sl], np.unwrap(log.yaw[sl])])
    return out
