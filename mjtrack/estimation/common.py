"""Bookkeeping shared by the parameter filters of the tracked-robot thesis (Mendaluk 2019, eqs. 3.4–3.8).

One EKF step k (time t_k, command u_{k-1} held over [t_{k-1}, t_k)):

    predict  x⁻ = f(x⁺_{k-1}, u_{k-1}),      P⁻ = F P⁺_{k-1} Fᵀ + Q              (3.6)
    update   ε = z_k ⊖ h(x⁻),  S = H P⁻ Hᵀ + R,  K = P⁻ Hᵀ S⁻¹,  x⁺ = x⁻ + K ε
             P⁺ = (I − K H) P⁻ (I − K H)ᵀ + K R Kᵀ                               (3.7)/(3.8)

The Joseph form (3.8) is printed with −K R Kᵀ; the correct sign is +: with ε's covariance S,
Cov(x⁺ − x) = (I − KH) P⁻ (I − KH)ᵀ + K R Kᵀ for *any* gain K, both terms positive
semi-definite. :func:`update` writes this out (one Cholesky factorisation of S per step, no
throw-away filter object); ⊖ is the component-wise difference with the angle components
wrapped to [−π, π) (:func:`residual`), so a yaw measured as +179° against a prediction of −179°
gives +2°, not +358°.

Every filter returns a :class:`FilterResult` holding per step the prior and posterior state and
covariance, the measurement, its prediction, the innovation, S and K, so that consistency can
be checked: NEES_k = e_kᵀ P_k⁻¹ e_k (e the state error, angle wrapped) is χ²(n) and
NIS_k = ε_kᵀ S_k⁻¹ ε_k is χ²(m) for a consistent filter. Averaged over M independent runs,
M·mean(NEES_k) is χ²(M·n), which gives the two-sided band of :func:`chi2_band`.

Missing measurements: a NaN component of z_k is left out of that step's update (the stored
innovation is NaN there); a step with no component, or one the filter skips (singular
regressors), has ``updated[k] = False`` and posterior = prior.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
from scipy import linalg, stats

from mjtrack.errors import InputError
from mjtrack.geometry import relative_pose, wrap_angle

log = logging.getLogger(__name__)


def residual(a: np.ndarray, b: np.ndarray, angle_idx: Sequence[int] = ()) -> np.ndarray:
    """a ⊖ b: a − b with the components in ``angle_idx`` wrapped to [−π, π)."""
    d = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
    if len(angle_idx):
        d = d.copy()
        idx = list(angle_idx)
        d[..., idx] = wrap_angle(d[..., idx])
    return d


def predict(x: np.ndarray, P: np.ndarray, fx: np.ndarray, F: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """EKF prediction (3.6): returns (f(x), F P Fᵀ + Q); ``fx`` = f(x) and F = ∂f/∂x at x."""
    P1 = F @ P @ F.T + Q
    return np.asarray(fx, dtype=float), 0.5 * (P1 + P1.T)


def update(x, P, z, zpred, H, R, *, angle_idx: Sequence[int] = ()):
    """EKF update (3.7) with the Joseph covariance (3.8, sign corrected).

    Args:
        x: (n,) prior state; P: (n, n) prior covariance.
        z: (m,) measurement; zpred: (m,) h(x); H: (m, n) ∂h/∂x; R: (m, m) noise covariance.
        angle_idx: measurement components that are angles (residual wrapped).
    Returns:
        (x⁺, P⁺, ε, S, K): K = P Hᵀ S⁻¹ from a Cholesky solve of S = H P Hᵀ + R.
    """
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    H = np.asarray(H, dtype=float)
    e = residual(z, zpred, angle_idx)
    PHt = P @ H.T
    S = H @ PHt + R
    S = 0.5 * (S + S.T)
    K = linalg.cho_solve(linalg.cho_factor(S), PHt.T).T
    IKH = np.eye(x.size) - K @ H
    P1 = IKH @ P @ IKH.T + K @ R @ K.T
    return x + K @ e, 0.5 * (P1 + P1.T), e, S, K


@dataclass(frozen=True, eq=False)
class FilterResult:
    """History of one filter run over N steps (n states, m measurement components).

    Attributes:
        name: filter name.
        t: (N,) step times [s].
        state_names: (n,) names; meas_names: (m,) names.
        x_prior, x_post: (N, n) state before / after the update.
        P_prior, P_post: (N, n, n).
        z, z_pred: (N, m) measurement and its prediction h(x_prior) (NaN where missing).
        innovation: (N, m) z ⊖ z_pred (NaN where missing); S: (N, m, m); K: (N, n, m)
            (NaN rows/columns for missing components; all NaN where not updated).
        updated: (N,) bool, False where the step had no update.
        state_angles / meas_angles: indices of angle components (wrapped in errors).
        info: free-form extras (e.g. the filter's settings), JSON-friendly.
        mode_prob: (N,) probability of the fast mode of an adaptive (IMM) filter, else None.
    """

    name: str
    t: np.ndarray
    state_names: tuple[str, ...]
    meas_names: tuple[str, ...]
    x_prior: np.ndarray
    x_post: np.ndarray
    P_prior: np.ndarray
    P_post: np.ndarray
    z: np.ndarray
    z_pred: np.ndarray
    innovation: np.ndarray
    S: np.ndarray
    K: np.ndarray
    updated: np.ndarray
    state_angles: tuple[int, ...] = ()
    meas_angles: tuple[int, ...] = ()
    info: dict = field(default_factory=dict)
    mode_prob: np.ndarray | None = None

    def __post_init__(self):
        N, n, m = len(self.t), len(self.state_names), len(self.meas_names)
        shapes = {"x_prior": (N, n), "x_post": (N, n), "P_prior": (N, n, n), "P_post": (N, n, n),
                  "z": (N, m), "z_pred": (N, m), "innovation": (N, m), "S": (N, m, m), "K": (N, n, m),
                  "updated": (N,)}
        for key, shape in shapes.items():
            if getattr(self, key).shape != shape:
                raise InputError(f"FilterResult {self.name}: {key} has shape {getattr(self, key).shape}, expected {shape}")

    def index(self, name: str) -> int:
        """Column of the state called ``name``."""
        return self.state_names.index(name)

    def nis(self) -> np.ndarray:
        """(N,) normalised innovation squared εᵀ S⁻¹ ε over the components present (NaN if none)."""
        out = np.full(len(self.t), np.nan)
        for k in np.flatnonzero(self.updated):
            ok = ~np.isnan(self.innovation[k])
            e = self.innovation[k, ok]
            out[k] = e @ np.linalg.solve(self.S[k][np.ix_(ok, ok)], e)
        return out

    def nees(self, x_true: np.ndarray, *, which: str = "post", idx: Sequence[int] | None = None) -> np.ndarray:
        """(N,) normalised estimation error squared against the true states (N, n).

        ``idx`` restricts to a subset of states (their marginal covariance is used).
        """
        x = self.x_post if which == "post" else self.x_prior
        P = self.P_post if which == "post" else self.P_prior
        idx = list(range(x.shape[1])) if idx is None else list(idx)
        e = residual(np.asarray(x_true, dtype=float), x, self.state_angles)[:, idx]
        Ps = P[:, idx][:, :, idx]
        return np.einsum("ki,ki->k", e, np.linalg.solve(Ps, e[..., None])[..., 0])


class History:
    """Collects the per-step quantities of a run and freezes them into a :class:`FilterResult`."""

    def __init__(self, n: int, m: int):
        self.n, self.m = n, m
        self.rows: list[tuple] = []
        self.modes: list = []

    def add(self, t, x_prior, P_prior, x_post, P_post, z, z_pred, mask=None, innovation=None, S=None, K=None,
            mode_prob=None):
        """Record one step; ``mask`` (m,) marks the measurement components used (None: all)."""
        m, n = self.m, self.n
        mask = np.ones(m, bool) if mask is None else np.asarray(mask, bool)
        full_e, full_S, full_K = np.full(m, np.nan), np.full((m, m), np.nan), np.full((n, m), np.nan)
        updated = innovation is not None
        if updated:
            full_e[mask] = innovation
            full_S[np.ix_(mask, mask)] = S
            full_K[:, mask] = K
        self.rows.append((t, x_prior, P_prior, x_post, P_post, z, z_pred, full_e, full_S, full_K, updated))
        self.modes.append(mode_prob)

    def result(self, name, state_names, meas_names, *, state_angles=(), meas_angles=(), info=None) -> FilterResult:
        cols = list(zip(*self.rows)) if self.rows else [[] for _ in range(11)]
        arr = [np.asarray(c, dtype=float) for c in cols[:10]]
        n, m = self.n, self.m
        empty = [(0,), (0, n), (0, n, n), (0, n), (0, n, n), (0, m), (0, m), (0, m), (0, m, m), (0, n, m)]
        arr = [a if len(self.rows) else np.zeros(s) for a, s in zip(arr, empty)]
        return FilterResult(name, arr[0], tuple(state_names), tuple(meas_names), arr[1], arr[3], arr[2], arr[4],
                            arr[5], arr[6], arr[7], arr[8], arr[9], np.asarray(cols[10], bool),
                            tuple(state_angles), tuple(meas_angles), dict(info or {}),
                            None if not self.modes or self.modes[0] is None else np.asarray(self.modes, float))


def chi2_band(dof: int, runs: int = 1, p: float = 0.95) -> tuple[float, float]:
    """Two-sided ``p`` band of the mean of ``runs`` independent χ²(dof) values (NEES/NIS averages)."""
    lo = stats.chi2.ppf((1 - p) / 2, dof * runs) / runs
    hi = stats.chi2.ppf((1 + p) / 2, dof * runs) / runs
    return float(lo), float(hi)


def twist_from_poses(t: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """Body twist (N-1, 3) from consecutive poses (N, 3): relative pose over dt (first order).

    For logs that carry no twist columns; row k is the mean twist over [t_k, t_{k+1}).
    """
    t = np.asarray(t, dtype=float)
    dt = np.diff(t)
    if np.any(dt <= 0):
        raise InputError("twist_from_poses: time not strictly increasing")
    return relative_pose(poses[:-1], poses[1:]) / dt[:, None]


def check_inputs(t, v_left, v_right, *arrays) -> tuple[np.ndarray, ...]:
    """Validate the common inputs of the filters; returns them as float arrays."""
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size < 2:
        raise InputError("filter: t must be 1-D with at least 2 samples")
    if np.any(np.diff(t) <= 0):
        raise InputError(f"filter: time not strictly increasing at sample {int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1}")
    vl, vr = (np.broadcast_to(np.asarray(v, dtype=float), t.shape) for v in (v_left, v_right))
    out = [t, vl, vr]
    for a in arrays:
        if a is None:
            out.append(None)
            continue
        a = np.asarray(a, dtype=float)
        if a.shape != (t.size, 3):
            raise InputError(f"filter: measurement array has shape {a.shape}, expected ({t.size}, 3)")
        out.append(a)
    return tuple(out)


@dataclass(frozen=True, eq=False)
class FilterInputs:
    """What every filter takes: (N,) t [s], V_L, V_R [m/s]; (N, 3) pose [m, m, rad] and twist or None."""

    t: np.ndarray
    v_left: np.ndarray
    v_right: np.ndarray
    pose_meas: np.ndarray
    twist_meas: np.ndarray | None


def inputs_from_log(log_, *, speeds: str = "cmd") -> list[FilterInputs]:
    """Filter inputs from a :class:`~mjtrack.io.logs.DriveLog`, one per segment (window).

    ``speeds="cmd"`` uses the commanded track speeds, ``"measured"`` the measured ones (refused
    if the log has none). The twist is None when the log has no ``vx, vy, wz``; NaN samples
    stay NaN (the filters skip them).
    """
    if speeds not in ("cmd", "measured"):
        raise InputError(f"inputs_from_log: speeds must be 'cmd' or 'measured', got {speeds!r}")
    out = []
    for seg in log_.segments():
        if speeds == "measured":
            if seg.v_left is None or seg.v_right is None:
                raise InputError(f"{seg.source or 'drive log'}: no measured track speeds (columns 'v_left', 'v_right')")
            vl, vr = seg.v_left, seg.v_right
        else:
            vl, vr = seg.v_left_cmd, seg.v_right_cmd
        twist = None if seg.vx is None or seg.vy is None or seg.wz is None else np.stack([seg.vx, seg.vy, seg.wz], -1)
        out.append(FilterInputs(np.asarray(seg.t, float), np.asarray(vl, float), np.asarray(vr, float),
                                np.stack([seg.x, seg.y, seg.yaw], -1).astype(float), twist))
    return out
