"""Fixed-horizon prediction errors with parameters that change from one start to the next.

For a start sample s and horizon h, let e be the first sample at or after t_s + h in the same
segment (starts without one are dropped). The prediction holds the parameters p_s of the
predictor, starts at the *true* pose q_s and integrates the model's twist
ν(p_s; V_L,k, V_R,k) exactly (SE(2) steps, command k held over [t_k, t_{k+1})) up to t_e:

    q̂_e = q_s ∘ Π_{k=s}^{e-1} exp(Δt_k ν_k),   pos_err = |q̂_e,xy − q_e,xy|,  yaw_err = wrap(θ̂_e − θ_e).

With constant parameters this is :func:`mjtrack.metrics.horizon_errors` (tested); per-start
parameters rule out its single odometry pass, so the starts are batched instead: all starts
with the same number of steps K are stepped together, K vectorised SE(2) steps.
"""

from __future__ import annotations

import numpy as np

from mjtrack.geometry import se2_step, wrap_angle
from mjtrack.metrics import HorizonErrors
from mjtrack.models import KinematicModel, integrate_twist
from mjtrack.validate.truth import Case


def starts_for(case: Case, *, max_starts: int = 400) -> np.ndarray:
    """Every ``stride``-th sample, stride = ceil(N / max_starts)."""
    stride = max(1, int(np.ceil(case.t.size / max_starts)))
    return np.arange(0, case.t.size, stride)


def window_ends(case: Case, horizon_s: float, starts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(starts, ends) of the windows over ``horizon_s`` [s]: for each start s, the first sample e at
    or after t_s + h in the same segment; starts without one are dropped (module docstring)."""
    n = case.t.size
    seg_end = np.empty(n, dtype=int)
    ends = np.empty(n, dtype=int)
    for sl in case.segment_slices():
        ts = case.t[sl]
        seg_end[sl] = sl.stop
        ends[sl] = sl.start + np.searchsorted(ts, ts + horizon_s - 1e-9)
    starts = np.asarray(starts, dtype=int)
    kept = starts[ends[starts] < seg_end[starts]]
    return kept, ends[kept]


def horizon_errors_per_start(template: KinematicModel, params: np.ndarray, case: Case, horizon_s: float,
                             *, starts: np.ndarray | None = None) -> HorizonErrors:
    """Prediction errors at ``horizon_s`` [s] with parameters ``params`` (N, P) of ``template``.

    Returns a :class:`~mjtrack.metrics.HorizonErrors` (starts, ends, errors, predicted poses).
    """
    n = case.t.size
    starts = np.arange(n) if starts is None else np.asarray(starts, dtype=int)
    params = np.broadcast_to(np.asarray(params, float), (n, len(template.param_names)))
    s_all, e_all = window_ends(case, horizon_s, starts)
    out_s, out_e, out_pred = [], [], []
    for k in np.unique(e_all - s_all):
        s = s_all[e_all - s_all == k]
        idx = s[:, None] + np.arange(k)  # (M, K) steps
        model = template.with_params(params[s][:, None, :])
        twist = model.twist(case.v_left[idx], case.v_right[idx])  # (M, K, 3)
        dt = case.t[idx + 1] - case.t[idx]
        pose = case.pose[s].copy()
        for j in range(k):
            pose = se2_step(pose, twist[:, j], dt[:, j])
        out_s.append(s)
        out_e.append(s + k)
        out_pred.append(pose)
    if not out_s:
        z = np.zeros(0)
        return HorizonErrors(float(horizon_s), z.astype(int), z.astype(int), z, z, np.zeros((0, 3)))
    s, e, pred = (np.concatenate(a) for a in (out_s, out_e, out_pred))
    order = np.argsort(s)
    s, e, pred = s[order], e[order], pred[order]
    meas = case.pose[e]
    return HorizonErrors(float(horizon_s), s, e, np.hypot(*(pred[:, :2] - meas[:, :2]).T),
                         wrap_angle(pred[:, 2] - meas[:, 2]), pred)


def dead_reckoning(template: KinematicModel, params: np.ndarray, case: Case) -> np.ndarray:
    """Open-loop path (N, 3) over each segment from its true start pose, parameters p_k driving step k."""
    params = np.broadcast_to(np.asarray(params, float), (case.t.size, len(template.param_names)))
    twist = template.with_params(params).twist(case.v_left, case.v_right)
    out = np.empty_like(case.pose)
    for sl in case.segment_slices():
        out[sl] = integrate_twist(case.pose[sl][0], case.t[sl], twist[sl])
    return out


def model_twist(template: KinematicModel, params: np.ndarray, case: Case) -> np.ndarray:
    """Twist (N, 3) of the predictor at each sample's own parameters and commands."""
    params = np.broadcast_to(np.asarray(params, float), (case.t.size, len(template.param_names)))
    return template.with_params(params).twist(case.v_left, case.v_right)
