"""Symptoms: where and how a model's predictions depart from the measured path.

Fixed-horizon prediction errors for any per-sample twist sequence, by the trick of
:mod:`mjtrack.metrics`: integrate the twist once over the whole log (the "odometry path" P, with
zero increments across segment boundaries), then the prediction from sample s to sample e is
compose(measured_s, relative_pose(P_s, P_e)); it never crosses a segment because windows are
only formed inside one segment. One pass costs O(N), so a fit can afford hundreds of passes.

Errors of a window are expressed in the frame of its measured start pose: ``along`` (forward,
+ = the model went too far), ``across`` (left, + = the model ended left of the measurement) and
``yaw`` (model minus measurement, wrapped). Binned against the commanded turn ratio
(V_R - V_L)/(|V_L| + |V_R|) (-1 spin right, 0 straight, +1 spin left), the commanded speed and
time, they show the symptom; the measured ICRs of the windows (eq. 2.13 on the window's mean
twist and mean track speeds) show it in the terms of the skid-steer models.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjtrack.errors import InputError
from mjtrack.geometry import compose, relative_pose, wrap_angle
from mjtrack.geometry import sinc_terms as _sinc_terms
from mjtrack.io.logs import DriveLog
from mjtrack.windows.bins import BinTable, bin_errors, turn_ratio, window_means  # noqa: F401 (diagnose reads them here)


@dataclass(frozen=True)
class DriveData:
    """The arrays of a drive log that diagnosis uses.

    t: (N,) [s]; seg: (N,) int segment ids (contiguous runs); cmd: (N, 2) commanded (V_L, V_R)
    [m/s]; meas: (N, 2) measured track speeds [m/s] (NaN where missing) or None; poses: (N, 3)
    measured (x, y, yaw) [m, m, rad], yaw unwrapped inside each segment.
    """

    t: np.ndarray
    seg: np.ndarray
    cmd: np.ndarray
    meas: np.ndarray | None
    poses: np.ndarray

    @classmethod
    def from_log(cls, log: DriveLog) -> "DriveData":
        n = log.n_samples
        seg = np.zeros(n, dtype=np.int64)
        for k, sl in enumerate(log.segment_slices()):
            seg[sl] = k
        yaw = np.array(log.yaw, dtype=float)
        for sl in log.segment_slices():
            yaw[sl] = np.unwrap(yaw[sl])
        meas = None
        if log.has_track_speeds:
            meas = np.stack([log.v_left, log.v_right], -1).astype(float)
            if not np.isfinite(meas).any():
                meas = None
        return cls(t=np.asarray(log.t, float), seg=seg, cmd=np.stack([log.v_left_cmd, log.v_right_cmd], -1).astype(float),
                   meas=meas, poses=np.stack([log.x, log.y, yaw], -1))

    @property
    def n(self) -> int:
        return int(self.t.size)

    def step_dt(self) -> np.ndarray:
        """(N,) hold time of each sample's twist: t[k+1]-t[k] inside a segment, 0 at segment ends."""
        dt = np.zeros(self.n)
        same = self.seg[1:] == self.seg[:-1]
        dt[:-1] = np.where(same, np.diff(self.t), 0.0)
        return dt


def odometry(twist: np.ndarray, dt: np.ndarray) -> np.ndarray:
    """Integrate body twists (N, 3) held for dt (N,) [s] from the origin (exact SE(2) steps): (N, 3)."""
    tw, h = twist[:-1], dt[:-1]
    dyaw = tw[:, 2] * h
    yaw = np.concatenate([[0.0], np.cumsum(dyaw)])
    s, c = _sinc_terms(dyaw)
    dxb = h * (s * tw[:, 0] - c * tw[:, 1])
    dyb = h * (c * tw[:, 0] + s * tw[:, 1])
    cy, sy = np.cos(yaw[:-1]), np.sin(yaw[:-1])
    x = np.concatenate([[0.0], np.cumsum(cy * dxb - sy * dyb)])
    y = np.concatenate([[0.0], np.cumsum(sy * dxb + cy * dyb)])
    return np.stack([x, y, yaw], -1)


def windows(t: np.ndarray, groups: np.ndarray, horizon_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Starts and ends (M,) of all windows of length >= horizon_s inside one group (contiguous ids):
    end = first sample at or after t_start + horizon."""
    if not horizon_s > 0:
        raise InputError(f"diagnose: horizon must be > 0 s, got {horizon_s}")
    n = t.size
    cuts = np.flatnonzero(groups[1:] != groups[:-1]) + 1
    starts, ends = [], []
    for lo, hi in zip(np.r_[0, cuts], np.r_[cuts, n]):
        ts = t[lo:hi]
        e = np.searchsorted(ts, ts + horizon_s - 1e-9)
        ok = e < hi - lo
        starts.append(lo + np.flatnonzero(ok))
        ends.append(lo + e[ok])
    return np.concatenate(starts).astype(int), np.concatenate(ends).astype(int)


def window_errors(twist: np.ndarray, dt: np.ndarray, poses: np.ndarray, starts: np.ndarray,
                  ends: np.ndarray) -> np.ndarray:
    """Errors (M, 3) of the windows' predictions in the start frame: (along, across [m], yaw [rad])."""
    odo = odometry(twist, dt)
    delta = relative_pose(odo[starts], odo[ends])
    delta[:, 2] = odo[ends, 2] - odo[starts, 2]
    pred = compose(poses[starts], delta)
    err = relative_pose(poses[starts], pred) - relative_pose(poses[starts], poses[ends])
    err[:, 2] = wrap_angle(pred[:, 2] - poses[ends, 2])
    return err


def measured_icr(data: DriveData, starts: np.ndarray, ends: np.ndarray, speeds: np.ndarray, *,
                 min_turn: float = 0.3) -> dict[str, np.ndarray]:
    """ICRs (2.13) of the windows whose measured turn is large enough, from their mean twist.

    The mean twist of a window is its measured relative pose divided by its duration (the chord,
    a good approximation while the turn over the window is below ~1 rad). Windows with |turn
    ratio| < ``min_turn`` are left out (the ICRs diverge in straight driving).
    Returns arrays ``y_l, y_r, x_c`` [m], ``wz`` [rad/s] and ``turn`` (the turn ratio) per kept window.
    """
    dur = data.t[ends] - data.t[starts]
    rel = relative_pose(data.poses[starts], data.poses[ends])
    rel[:, 2] = data.poses[ends, 2] - data.poses[starts, 2]
    s, c = _sinc_terms(rel[:, 2])
    # invert the constant-twist step: (dx, dy) = dur * [[S, -C], [C, S]] (vx, vy)
    den = (s * s + c * c) * dur
    vx = (s * rel[:, 0] + c * rel[:, 1]) / den
    vy = (-c * rel[:, 0] + s * rel[:, 1]) / den
    wz = rel[:, 2] / dur
    v = window_means(speeds, starts, ends)
    turn = turn_ratio(v)
    change = np.concatenate([[0], np.cumsum(np.any(np.abs(np.diff(data.cmd, axis=0)) > 1e-6, axis=1))])
    steady = change[ends - 1] - change[starts] == 0
    keep = (np.abs(turn) >= min_turn) & (np.abs(wz) > 1e-3) & steady
    wz, vx, vy, v, turn = wz[keep], vx[keep], vy[keep], v[keep], turn[keep]
    return {"y_l": (vx - v[:, 0]) / wz, "y_r": (vx - v[:, 1]) / wz, "x_c": -vy / wz, "wz": wz, "turn": turn}
