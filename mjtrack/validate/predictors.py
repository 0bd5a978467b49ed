"""The predictors a validation scores: a kinematic model plus where its parameters come from.

| key | model | parameters |
|---|---|---|
| ``nominal`` | (2.1) | none (the track gauge) |
| ``mpp_slip_ekf`` | MPP (2.9) | slip EKF, online: the estimate after the measurement at t_s |
| ``micr_icr_ekf`` | MICR (2.14) | improved ICR EKF, online |
| ``mvir_vir_filter`` | MVIR | improved VIR filter, online |
| ``mpp_fit`` | MPP | least-squares fit to the truth's own twist over each prediction window (oracle) |
| ``micr_own_icr`` | MICR = MVIR | the truth's own ICRs (2.13): least-squares fit over each prediction window (oracle) |

Online predictors are causal: a prediction starting at sample s uses the parameters the
filter had after the measurement at s, held over the horizon. The filters run with adaptive
process noise (``adaptive="imm"``, :mod:`mjtrack.estimation.imm`) and carry their parameters
across the segments (windows) of a log (:func:`_run_segments`). The oracles are not causal:
they fit the best *constant* parameters to the true motion inside the window they then
predict, so they bound what any constant-parameter model of their family can do over that
horizon (the per-sample own ICRs would reproduce the true twist exactly and bound nothing).

Derivation and measurements: docs/theory/filters.md, "Predictors: measurements and window fits".
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Callable

import numpy as np

from mjtrack.errors import MjtrackError
from mjtrack.estimation.icr_ekf import InverseICR, run_icr_ekf
from mjtrack.estimation.slip_ekf import run_slip_ekf
from mjtrack.estimation.vir_filter import run_vir_filter
from mjtrack.models import MPP, KinematicModel, Nominal
from mjtrack.validate.truth import Case, Noise

log = logging.getLogger(__name__)

RIDGE_SPEED = 0.001  # [m/s] excitation below which a window fit falls back to the nominal


@dataclass(frozen=True, eq=False)
class Predictor:
    """A model and the parameters to use for a prediction starting at each sample.

    ``params(h)`` returns (N, P) parameters of ``template`` for horizon h [s] (online
    predictors ignore h); ``causal`` is False for the oracles.
    """

    key: str
    label: str
    model: str
    source: str
    template: KinematicModel
    params: Callable[[float], np.ndarray]
    causal: bool
    filter_name: str | None = None


@dataclass(frozen=True, eq=False)
class FilterRun:
    """Per-sample posterior parameters (N, P) of one filter over all segments (row s: after z_s).

    ``results`` holds each segment's :class:`~mjtrack.estimation.common.FilterResult` (its NIS and
    covariances; empty if the filter failed), ``starts`` the sample index where each began.
    """

    name: str
    param_names: tuple[str, ...]
    params: np.ndarray
    measures: str
    error: str | None = None
    results: tuple = ()
    starts: tuple = ()


def _run_segments(case: Case, run, p0: np.ndarray, cov0: np.ndarray, q2: np.ndarray, names: tuple[str, ...],
                  name: str, measures: str, *, carry: bool = True) -> FilterRun:
    """Run a filter over the segments of ``case``; a filter that fails leaves NaN parameters.

    ``carry``: the segments (windows) of one log are one robot, so each segment starts from the
    previous one's final parameter estimate and covariance, the covariance grown by the slow random
    walk over the gap, Δ = t_start − t_end_prev (P ← P + diag(q²)·Δ, the filter's own model of
    how parameters drift when nothing is measured); only the pose restarts (from the segment's first
    measurement). Without ``carry`` every segment restarts from (``p0``, ``cov0``).

    A failure (e.g. the slip EKF's α leaving (−π/2, π/2), which happens when the MPP model must
    explain a sideways velocity while v_x ≈ 0) is a finding of the validation, not a crash: it
    is logged and reported, and the predictor scores NaN.
    """
    out = np.empty((case.t.size, p0.size))
    results, starts = [], []
    p, P, t_end = np.asarray(p0, float), np.asarray(cov0, float), None
    for sl in case.segment_slices():
        if carry and t_end is not None:
            P = P + np.diag(q2) * max(0.0, float(case.t[sl.start] - t_end))
        elif not carry:
            p, P = np.asarray(p0, float), np.asarray(cov0, float)
        out[sl.start] = p
        if sl.stop - sl.start < 2:
            out[sl] = p
            continue
        try:
            res = run(case.t[sl], case.v_left[sl], case.v_right[sl], case.pose_meas[sl], case.twist_meas[sl], p, P)
        except MjtrackError as exc:
            log.warning("%s failed on the %s truth: %s", name, case.name, exc)
            return FilterRun(name, names, np.full_like(out, np.nan), measures, str(exc))
        out[sl.start + 1:sl.stop] = res.x_post[:, 3:]
        results.append(res)
        starts.append(sl.start)
        p, P, t_end = res.x_post[-1, 3:].copy(), res.P_post[-1, 3:, 3:].copy(), float(case.t[sl.stop - 1])
    return FilterRun(name, names, out, measures, None, tuple(results), tuple(starts))


# process-noise intensities of the filters as validate runs them (the run_* defaults; adaptive = IMM
# pair whose slow mode is this)
Q_SLIP = np.array([1e-3, 1e-3, np.radians(0.05)]) ** 2
Q_PSI = np.full(3, 1e-3) ** 2
SLIP_STD0 = np.array([0.3, 0.3, np.radians(20.0)])
PSI_STD0 = np.array([2.0, 2.0, 4.0])


def run_filters(case: Case, track_gauge: float, *, noise: Noise = Noise(), adaptive="imm",
                carry: bool = True) -> dict[str, FilterRun]:
    """The three improved filters on ``case`` (measurements: module docstring).

    ``adaptive``: "imm" (default: slow/fast IMM pair, :mod:`mjtrack.estimation.imm`) or None (one
    random walk, as printed); ``carry``: carry the parameters across segments (:func:`_run_segments`).
    """
    T = track_gauge
    ps, ts = np.asarray(noise.pose_std), np.asarray(noise.twist_std)
    psi0 = InverseICR.nominal(T).params
    kw = dict(pose_std=ps, twist_std=ts, adaptive=adaptive)
    return {
        "slip_ekf": _run_segments(case, lambda t, vl, vr, pm, tm, p, P: run_slip_ekf(
            t, vl, vr, track_gauge=T, pose_meas=pm, twist_meas=tm, params0=p, param_cov0=P, **kw),
            np.zeros(3), np.diag(SLIP_STD0**2), Q_SLIP, MPP.param_names, "slip_ekf", "pose + twist", carry=carry),
        "icr_ekf": _run_segments(case, lambda t, vl, vr, pm, tm, p, P: run_icr_ekf(
            t, vl, vr, track_gauge=T, pose_meas=pm, psi0=p, psi_cov0=P, **kw),
            psi0, np.diag(PSI_STD0**2), Q_PSI, InverseICR.param_names, "icr_ekf", "pose", carry=carry),
        "vir_filter": _run_segments(case, lambda t, vl, vr, pm, tm, p, P: run_vir_filter(
            t, vl, vr, track_gauge=T, twist_meas=tm, pose0=pm[0], psi0=p, psi_cov0=P, **kw),
            psi0, np.diag(PSI_STD0**2), Q_PSI, InverseICR.param_names, "vir_filter", "twist", carry=carry),
    }


def _window_sums(case: Case, values: np.ndarray, horizon: float) -> np.ndarray:
    """Σ dt·values over the window [t_s, t_s + h) of every start s (within its segment): (N, ...)."""
    n = case.t.size
    dt = np.zeros(n)
    end = np.empty(n, dtype=int)
    for sl in case.segment_slices():
        ts = case.t[sl]
        dt[sl.start:sl.stop - 1] = np.diff(ts)
        end[sl] = sl.start + np.minimum(np.searchsorted(ts, ts + horizon - 1e-9), ts.size - 1)
    cs = np.concatenate([np.zeros((1,) + values.shape[1:]), np.cumsum(dt.reshape((-1,) + (1,) * (values.ndim - 1)) * values, axis=0)])
    return cs[end] - cs[np.arange(n)]


def fit_icr_windows(case: Case, track_gauge: float, horizon: float) -> np.ndarray:
    """ψ (N, 3) of the best constant MICR over each window [t_s, t_s + h) (module docstring)."""
    vl, vr = case.v_left, case.v_right
    dv, vbar = vr - vl, (vl + vr) / 2
    r = np.stack([-case.twist[:, 1], case.twist[:, 0] - vbar, case.twist[:, 2]], -1)
    sums = _window_sums(case, np.column_stack([dv[:, None] * r, dv**2]), horizon)
    lam = RIDGE_SPEED**2 * horizon
    psi0 = np.array([0.0, 0.0, 1.0 / track_gauge])
    return (sums[:, :3] + lam * psi0) / (sums[:, 3:4] + lam)


def fit_mpp_windows(case: Case, track_gauge: float, horizon: float) -> np.ndarray:
    """(s_left, s_right, alpha) (N, 3) of the best constant MPP over each window (module docstring)."""
    vl, vr = case.v_left, case.v_right
    vx, vy, wz = case.twist.T
    u_l, u_r = vx - wz * track_gauge / 2, vx + wz * track_gauge / 2
    cols = np.column_stack([vl * u_l, vl**2, vr * u_r, vr**2, vl * vy, vr * vy, vl * vl, vl * vr, vr * vr])
    s = _window_sums(case, cols, horizon)
    lam = RIDGE_SPEED**2 * horizon
    a_l = (s[:, 0] + lam) / (s[:, 1] + lam)
    a_r = (s[:, 2] + lam) / (s[:, 3] + lam)
    num = a_l / 2 * s[:, 4] + a_r / 2 * s[:, 5]
    den = a_l**2 / 4 * s[:, 6] + a_l * a_r / 2 * s[:, 7] + a_r**2 / 4 * s[:, 8]
    alpha = np.arctan(-num / (den + lam))
    return np.column_stack([1 - a_l, 1 - a_r, alpha])


def build_predictors(case: Case, track_gauge: float, filters: dict[str, FilterRun]) -> list[Predictor]:
    """The predictors of the module table for one case."""
    T = track_gauge
    n = case.t.size
    const = lambda p: (lambda h: np.broadcast_to(np.asarray(p, float), (n, np.size(p))))  # noqa: E731
    return [
        Predictor("nominal", "nominal", "nominal", "no parameters (2.1)", Nominal(T), const([T]), True),
        Predictor("mpp_slip_ekf", "MPP · slip EKF", "MPP", "slip EKF (online)", MPP(T),
                  lambda h: filters["slip_ekf"].params, True, "slip_ekf"),
        Predictor("micr_icr_ekf", "MICR · ICR EKF", "MICR", "ICR EKF (online)", InverseICR.nominal(T),
                  lambda h: filters["icr_ekf"].params, True, "icr_ekf"),
        Predictor("mvir_vir_filter", "MVIR · VIR filter", "MVIR", "VIR filter (online)", InverseICR.nominal(T),
                  lambda h: filters["vir_filter"].params, True, "vir_filter"),
        Predictor("mpp_fit", "MPP · fit to true motion (oracle)", "MPP", "window fit to the true twist (oracle)",
                  MPP(T), lambda h: fit_mpp_windows(case, T, h), False),
        Predictor("micr_own_icr", "MICR/MVIR · own ICRs (oracle)", "MICR", "window fit of the own ICRs (eq. (2.13) of [Mendaluk]; oracle)",
                  InverseICR.nominal(T), lambda h: fit_icr_windows(case, T, h), False),
    ]
