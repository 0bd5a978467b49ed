"""Prediction error of a kinematic model against a measured path, per horizon.

The standard figure of merit for slip models (and the one ``validate`` and ``diagnose`` use):
start the model at the measured pose at time t_s, drive it with the logged commands for a
horizon h, and compare its pose with the measured pose at t_s + h.

Vectorised by a change of frame: integrate the model once over the whole segment from the
origin (the "odometry path" P). The model's predicted motion from sample s to sample e, in the
frame of the pose at s, is the relative pose of P_e seen from P_s (the composition of the
per-step increments does not depend on where it starts). The prediction is therefore
compose(measured_s, relative_pose(P_s, P_e)) for every start s at once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjtrack.errors import InputError
from mjtrack.geometry import compose, relative_pose, wrap_angle
from mjtrack.models.kinematic import KinematicModel, integrate_twist


@dataclass(frozen=True)
class HorizonErrors:
    """Errors of predictions over one horizon.

    Attributes:
        horizon_s: requested horizon [s].
        start: (M,) sample indices where the predictions start.
        end: (M,) sample indices where they are compared (first sample at or after t_s + h).
        pos_err: (M,) distance between predicted and measured position [m].
        yaw_err: (M,) predicted minus measured yaw, wrapped [rad].
        predicted: (M, 3) predicted poses at ``end``.
    """

    horizon_s: float
    start: np.ndarray
    end: np.ndarray
    pos_err: np.ndarray
    yaw_err: np.ndarray
    predicted: np.ndarray

    @property
    def pos_rmse(self) -> float:
        return float(np.sqrt(np.mean(self.pos_err**2))) if self.pos_err.size else float("nan")

    @property
    def yaw_rmse(self) -> float:
        return float(np.sqrt(np.mean(self.yaw_err**2))) if self.yaw_err.size else float("nan")


def horizon_errors(
    model: KinematicModel,
    t,
    v_left,
    v_right,
    poses,
    horizon_s: float,
    *,
    segments=None,
    stride: int = 1,
) -> HorizonErrors:
    """Prediction errors of ``model`` at one horizon, over all starts (every ``stride``-th sample).

    Args:
        model: kinematic model; its parameters may be per-sample arrays of shape (N,).
        t: (N,) times [s], strictly increasing inside each segment.
        v_left, v_right: (N,) track speeds driving the model [m/s] (commanded or measured).
        poses: (N, 3) measured poses [m, m, rad].
        horizon_s: prediction horizon [s] (> 0).
        segments: optional (N,) segment ids; predictions never cross a segment boundary.
        stride: use every stride-th sample as a start.
    """
    t = np.asarray(t, dtype=float)
    poses = np.asarray(poses, dtype=float)
    n = t.size
    if poses.shape != (n, 3):
        raise InputError(f"horizon_errors: poses must have shape ({n}, 3), got {poses.shape}")
    if not horizon_s > 0:
        raise InputError(f"horizon_errors: horizon must be > 0 s, got {horizon_s}")
    seg = np.zeros(n, dtype=int) if segments is None else np.asarray(segments)
    v_left = np.broadcast_to(np.asarray(v_left, dtype=float), (n,))
    v_right = np.broadcast_to(np.asarray(v_right, dtype=float), (n,))
    twist = np.broadcast_to(model.twist(v_left, v_right), (n, 3))
    starts, ends, preds = [], [], []
    bounds = np.flatnonzero(np.diff(seg) != 0) + 1
    for lo, hi in zip(np.r_[0, bounds], np.r_[bounds, n]):
        if hi - lo < 2:
            continue
        ts = t[lo:hi]
        odo = integrate_twist(np.zeros(3), ts, twist[lo:hi])  # the segment's odometry path
        s = np.arange(0, hi - lo, stride)
        e = np.searchsorted(ts, ts[s] + horizon_s - 1e-9)
        ok = e < hi - lo
        s, e = s[ok], e[ok]
        if s.size == 0:
            continue
        delta = relative_pose(odo[s], odo[e])
        # relative_pose wraps yaw; keep the unwrapped turn for multi-turn horizons
        delta[:, 2] = odo[e, 2] - odo[s, 2]
        preds.append(compose(poses[lo + s], delta))
        starts.append(lo + s)
        ends.append(lo + e)
    if not starts:
        empty = np.zeros(0)
        return HorizonErrors(horizon_s, empty.astype(int), empty.astype(int), empty, empty, np.zeros((0, 3)))
    start, end, pred = np.concatenate(starts), np.concatenate(ends), np.concatenate(preds)
    meas = poses[end]
    return HorizonErrors(
        horizon_s=float(horizon_s),
        start=start,
        end=end,
        pos_err=np.hypot(pred[:, 0] - meas[:, 0], pred[:, 1] - meas[:, 1]),
        yaw_err=wrap_angle(pred[:, 2] - meas[:, 2]),
        predicted=pred,
    )


@dataclass(frozen=True)
class WindowPredictionErrors:
    """Errors of predictions over whole windows, each started from its measured start pose.

    Attributes:
        end: (M,) distance between predicted and measured position at each window's last sample [m].
        mean_distance: (M,) that distance averaged over the window's samples, its start included
            (the metric of DRIVE's authors) [m].
        yaw: (M,) predicted minus measured yaw at the last sample, both continuous from the start [rad].
    """

    end: np.ndarray
    mean_distance: np.ndarray
    yaw: np.ndarray

    @property
    def end_rms(self) -> float:
        """RMS over the windows of the end-of-window position error [m]."""
        return float(np.sqrt(np.mean(self.end ** 2))) if self.end.size else float("nan")

    @property
    def mean_distance_mean(self) -> float:
        """Mean over the windows of the mean position distance over the window [m]."""
        return float(np.mean(self.mean_distance)) if self.mean_distance.size else float("nan")

    @property
    def yaw_rms(self) -> float:
        """RMS over the windows of the end-of-window yaw error [rad]."""
        return float(np.sqrt(np.mean(self.yaw ** 2))) if self.yaw.size else float("nan")

    def summary(self) -> dict:
        return {"windows": int(self.end.size), "end_rms_m": self.end_rms,
                "mean_distance_m": self.mean_distance_mean, "yaw_rms_rad": self.yaw_rms}


def window_prediction_errors(predicted, measured, last) -> WindowPredictionErrors:
    """Errors of predicted poses (M, K, 3) against measured poses (M, K, 3) over windows whose last
    sample is ``last`` (M,) (samples beyond it are ignored; yaws continuous within each window)."""
    predicted, measured = np.asarray(predicted, float), np.asarray(measured, float)
    if predicted.shape != measured.shape or predicted.ndim != 3 or predicted.shape[2] != 3:
        raise InputError(f"window errors: predicted {predicted.shape} and measured {measured.shape} poses must "
                         "both have shape (M, K, 3)")
    last = np.asarray(last, int)
    rows = np.arange(predicted.shape[0])
    inside = np.arange(predicted.shape[1])[None, :] <= last[:, None]
    dist = np.hypot(predicted[..., 0] - measured[..., 0], predicted[..., 1] - measured[..., 1])
    mean = np.sum(np.where(inside, dist, 0.0), axis=1) / (last + 1)
    return WindowPredictionErrors(dist[rows, last], mean, predicted[rows, last, 2] - measured[rows, last, 2])


@dataclass(frozen=True)
class EndRegions:
    """Prediction regions for a window's end position, from the scatter of a model's end errors.

    A window's end error e (measured minus predicted position, in the window's start frame) is
    normalised by the window's length scale, z = e / (scale + ``scale0``); per group of windows
    (``groups``: e.g. turn classes) z has mean ``mean`` and covariance ``cov``, and the region is
    the ellipse of Mahalanobis radius ``radius``: the ``level`` empirical quantile of the training
    windows' radii (the ceil((n + 1) level)-th smallest, which covers a new window of the same kind
    with probability at least ``level``). A group with fewer than ``min_windows`` training windows
    uses the pooled one (key -1).
    """

    level: float
    scale0: float
    mean: dict
    cov: dict
    radius: dict

    def _key(self, g) -> int:
        return int(g) if int(g) in self.radius else -1

    def contains(self, errors, scale, groups) -> np.ndarray:
        """(M,) whether each end error (M, 2) lies in its window's region."""
        errors = np.asarray(errors, float)
        z = errors / (np.asarray(scale, float) + self.scale0)[:, None]
        out = np.empty(len(z), bool)
        for j, g in enumerate(np.asarray(groups)):
            k = self._key(g)
            d = z[j] - self.mean[k]
            out[j] = float(d @ np.linalg.solve(self.cov[k], d)) <= self.radius[k] ** 2
        return out

    def area(self, scale, groups) -> np.ndarray:
        """(M,) each window's region area [m^2]."""
        s = np.asarray(scale, float) + self.scale0
        return np.array([np.pi * self.radius[self._key(g)] ** 2 * np.sqrt(np.linalg.det(self.cov[self._key(g)]))
                         * sj ** 2 for sj, g in zip(s, np.asarray(groups))])


def fit_end_regions(errors, scale, groups, *, level: float = 0.9, scale0: float = 0.1,
                    min_windows: int = 20) -> EndRegions:
    """:class:`EndRegions` from training windows' end errors (M, 2) [m], length scales (M,) [m] and
    group labels (M,) (non-negative integers)."""
    errors, scale, groups = np.asarray(errors, float), np.asarray(scale, float), np.asarray(groups, int)
    if errors.ndim != 2 or errors.shape[1] != 2 or len(errors) < 3:
        raise InputError(f"end regions: need end errors of shape (M >= 3, 2), got {errors.shape}")
    if not 0 < level < 1:
        raise InputError(f"end regions: level must be in (0, 1), got {level}")
    z = errors / (scale + scale0)[:, None]
    mean, cov, radius = {}, {}, {}
    for g in [-1, *sorted(set(groups.tolist()))]:
        m = np.ones(len(z), bool) if g == -1 else groups == g
        if g != -1 and m.sum() < min_windows:
            continue
        mu = z[m].mean(axis=0)
        c = np.cov(z[m].T) + 1e-12 * np.eye(2)
        d = np.sqrt(np.einsum("ij,jk,ik->i", z[m] - mu, np.linalg.inv(c), z[m] - mu))
        k = min(int(np.ceil((m.sum() + 1) * level)), int(m.sum())) - 1
        mean[g], cov[g], radius[g] = mu, c, float(np.sort(d)[k])
    return EndRegions(float(level), float(scale0), mean, cov, radius)
