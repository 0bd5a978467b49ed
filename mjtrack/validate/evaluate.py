"""Score every predictor on one truth: horizon errors, open-loop paths, ICR tracking.

Numbers (all on the noise-free truth, see :mod:`mjtrack.validate.truth`):

* ``pos_rmse_m`` / ``yaw_rmse_deg`` at horizon h: root mean square over the starts of the
  position distance [m] / wrapped heading difference [deg] between the h-second prediction
  (:mod:`mjtrack.validate.horizon`) and the true pose; ``n`` starts.
* ``final_drift_m``: distance between the open-loop (dead-reckoned) path of the whole log and
  the true final position, summed over segments.
* ``icr_error_m`` (filters and oracles): median absolute difference over the samples where the true |ω| ≥ ``wz_min``
  and t ≥ t_0 + ``settle_s`` of the difference between the ICRs (y_l, y_r, x_c) implied by the
  predictor's parameters at that sample and the truth's own ICRs (2.13); both are computed
  from twists with the same track speeds. The median, because the own ICRs spike for a moment at
  every change of command (the twist and the speeds respond at different rates).
* ``param_error_final`` (MPP truth, slip EKF): |estimate − truth| of (s_L, s_R, α) at the end.
* ``consistency`` (each filter): ``{nis_mean, nis_dof, nees_mean, nees_dof, band95, n_nis, n_nees}``
  (:mod:`mjtrack.estimation.consistency`) over the steps after the settling time. NEES is against
  the truth's own parameters: on the MPP truth the known slips (slip EKF) and the exact per-sample
  ψ_own = (−v_y, v_x − V̄, ω)/ΔV (ICR EKF, VIR filter); on a simulated log the mean of the
  per-sample own values over the steady part of each constant-command stretch (1 s after the
  command changed on); null on a measured log (no noise-free truth).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from mjtrack.estimation import consistency as cons
from mjtrack.icr import ICR, icr_from_twist
from mjtrack.metrics import HorizonErrors
from mjtrack.progress import Progress
from mjtrack.validate.horizon import dead_reckoning, horizon_errors_per_start, model_twist, starts_for
from mjtrack.validate.predictors import FilterRun, Predictor, build_predictors, run_filters
from mjtrack.validate.truth import Case, Noise

log = logging.getLogger(__name__)

HORIZONS = (0.5, 1.0, 2.0, 5.0)  # [s]
WZ_MIN = 0.05  # [rad/s] |ω| below which ICRs are not compared (they run off to infinity)
ICR_HORIZON = 2.0  # [s] window of the oracle ICR traces
STEADY_S = 1.0  # [s] after a command change before a simulated log's own parameters count as truth


@dataclass(frozen=True, eq=False)
class CaseResult:
    """Everything computed on one truth."""

    case: Case
    predictors: list[Predictor]
    filters: dict[str, FilterRun]
    errors: dict[str, dict[float, HorizonErrors]]
    paths: dict[str, np.ndarray]
    icr_true: ICR
    icrs: dict[str, ICR]
    metrics: dict


def _icr(twist: np.ndarray, case: Case, wz_min: float) -> ICR:
    return icr_from_twist(*twist.T, case.v_left, case.v_right, wz_min=wz_min, on_singular="mask")


def param_truth(case: Case, filter_name: str, track_gauge: float) -> np.ndarray | None:
    """(N, P) true parameters of a filter on ``case`` (module docstring), None without a truth."""
    if not case.noise_free:
        return None
    if case.truth_params is not None:
        if filter_name == "slip_ekf":
            p = [case.truth_params[k] for k in ("s_left", "s_right", "alpha")]
            return np.broadcast_to(np.asarray(p, float), (case.t.size, 3)).copy()
        return cons.own_psi(case.twist, case.v_left, case.v_right)
    own = (cons.own_slips(case.twist, case.v_left, case.v_right, track_gauge) if filter_name == "slip_ekf"
           else cons.own_psi(case.twist, case.v_left, case.v_right))
    stretch = case.stretch if case.stretch is not None else case.segments
    return cons.steady_truth(case.t, own, stretch, settle_s=STEADY_S)


def filter_consistency(case: Case, run: FilterRun, track_gauge: float, t_from: float) -> dict:
    """The ``consistency`` entry of one filter on ``case`` (module docstring)."""
    if not run.results:
        return {"nis_mean": None, "nis_dof": None, "nees_mean": None, "nees_dof": len(run.param_names),
                "band95": None, "n_nis": 0, "n_nees": 0}
    truth = param_truth(case, run.name, track_gauge)
    parts = None
    if truth is not None:
        # result row j of a segment starting at sample s is sample s + 1 + j
        parts = [truth[s + 1:s + 1 + r.t.size] for r, s in zip(run.results, run.starts)]
    return cons.summary(run.results, parts, t_from=t_from)


def _median_abs(a: np.ndarray) -> float:
    a = a[np.isfinite(a)]
    return float(np.median(np.abs(a))) if a.size else float("nan")


def evaluate_case(case: Case, track_gauge: float, *, horizons=HORIZONS, noise: Noise = Noise(),
                  wz_min: float = WZ_MIN, settle_s: float | None = None, bar: Progress | None = None) -> CaseResult:
    """Run the filters and score all predictors on ``case``; ``bar`` is advanced once per predictor."""
    filters = run_filters(case, track_gauge, noise=noise)
    if bar is not None:
        bar.update(note=f"{case.name}: filters done")
    predictors = build_predictors(case, track_gauge, filters)
    starts = starts_for(case)
    t0 = case.t[0]
    settle_s = min(5.0, 0.2 * (case.t[-1] - t0)) if settle_s is None else settle_s
    icr_true = _icr(case.twist, case, wz_min)
    cmp_mask = icr_true.valid & (case.t >= t0 + settle_s)
    errors, paths, icrs, table = {}, {}, {}, {}
    for p in predictors:
        errors[p.key] = {h: horizon_errors_per_start(p.template, p.params(h), case, h, starts=starts) for h in horizons}
        p_icr = p.params(ICR_HORIZON)
        paths[p.key] = dead_reckoning(p.template, p_icr, case)
        icrs[p.key] = _icr(model_twist(p.template, p_icr, case), case, wz_min)
        drift = sum(float(np.hypot(*(paths[p.key][sl][-1, :2] - case.pose[sl][-1, :2]))) for sl in case.segment_slices())
        entry = {
            "label": p.label, "model": p.model, "parameters_from": p.source, "causal": p.causal,
            "horizons": {f"{h:g}": {"pos_rmse_m": e.pos_rmse, "yaw_rmse_deg": math.degrees(e.yaw_rmse),
                                    "n": int(e.pos_err.size)} for h, e in errors[p.key].items()},
            "final_drift_m": drift,
        }
        if p.filter_name is not None and filters[p.filter_name].error:
            entry["failed"] = f"{p.filter_name} failed: {filters[p.filter_name].error}"
        if p.key != "nominal":
            diffs = [getattr(icrs[p.key], f)[cmp_mask] - getattr(icr_true, f)[cmp_mask] for f in ("y_l", "y_r", "x_c")]
            entry["icr_error_m"] = {f: _median_abs(d) for f, d in zip(("y_l", "y_r", "x_c"), diffs)}
        table[p.key] = entry
        if bar is not None:
            bar.update(note=f"{case.name}: {p.label}")
    metrics = {
        "title": case.title, "samples": int(case.t.size), "duration_s": float(case.t[-1] - t0),
        "icr_samples_compared": int(cmp_mask.sum()), "settle_s": settle_s,
        "predictors": table,
        "filters": {k: {"measures": f.measures, "final": dict(zip(f.param_names, map(float, f.params[-1]))),
                        "failed": f.error, "adaptive": f.results[0].info.get("adaptive") if f.results else None,
                        "consistency": filter_consistency(case, f, track_gauge, t0 + settle_s)}
                    for k, f in filters.items()},
    }
    if case.truth_params is not None:
        metrics["truth_params"] = dict(case.truth_params)
        est = filters["slip_ekf"].params[-1]
        metrics["filters"]["slip_ekf"]["param_error_final"] = {
            k: float(abs(est[i] - case.truth_params[k])) for i, k in enumerate(("s_left", "s_right", "alpha"))}
    return CaseResult(case, predictors, filters, errors, paths, icr_true, icrs, metrics)
