"""Consistency of a filter run: NIS and parameter NEES summaries, and truth parameters from a twist.

A filter is consistent when its errors are as large as its covariances say:

* NIS_k = ε_kᵀ S_k⁻¹ ε_k (innovation ε, its covariance S) is χ²(m), m the number of measured
  components; ``nis_mean / nis_dof`` should be ≈ 1 (the innovation needs no truth).
* NEES_k = e_kᵀ P_k⁻¹ e_k over the parameter block (e = true − estimated parameters, P the
  filter's marginal posterior covariance of the parameters) is χ²(P); ``nees_mean / nees_dof`` ≈ 1.
  It needs true parameters.

``band95`` is the two-sided 95 % band of a *single step's* value (χ² quantiles): the band the
report draws around NIS over time. The mean of N independent χ²(d) values is χ²(N·d)/N, so the
mean per degree of freedom of a consistent filter lies, with probability 95 %, in
χ²⁻¹(0.025, N·d)/(N·d) .. χ²⁻¹(0.975, N·d)/(N·d) (:func:`mean_band`). :func:`pooled` judges a
filter's runs (seeds) by that one rule: the mean over every sample of every run, against the
interval for their total number. The samples are independent for NIS (a consistent filter's
innovations are white); the estimation errors of NEES are correlated from step to step, so for
NEES the interval is narrower than the mean's real spread and a value outside it is a flag to
look at, not a proof of inconsistency.

**True parameters of a physical truth** (a MuJoCo rollout, or any noise-free twist with the
track speeds that drive the filter). The ψ parametrisation's own value at a sample is exact:
from v_x = V̄ + ψ_y ΔV, v_y = −ψ_x ΔV, ω = ψ_z ΔV,

    ψ_own = (−v_y, v_x − V̄, ω)/ΔV,   ΔV = V_R − V_L,  V̄ = (V_L + V_R)/2   (:func:`own_psi`)

(the own ICRs (2.13) in the ψ chart), undefined where |ΔV| is small (straight driving: ψ does
not act on the motion there). MPP's own slips: u_L,R = v_x ∓ ωT/2 are the actual track speeds,
s = 1 − u/V, tan α = −v_y/v_x (:func:`own_slips`), undefined where |V_L|, |V_R| or |v_x| is small.
Per sample these carry the drives' transient after each change of command (the twist and the
track speeds respond at different rates), which no kinematic model describes. As in
``benchmarks/filter_consistency.py --accuracy``, the truth of a constant-command stretch is therefore the
*mean* of the per-sample own values over its steady part (from ``settle_s`` after the command
changed to the next change), and NEES is evaluated on those steady parts only
(:func:`steady_truth`).
"""

from __future__ import annotations

import math

import numpy as np

from mjtrack.estimation.common import FilterResult, chi2_band

DV_MIN = 0.05  # [m/s] |V_R - V_L| below which ψ is not defined by the motion
V_MIN = 0.05  # [m/s] |V_L|, |V_R|, |v_x| below which the MPP slips are not defined


def own_psi(twist: np.ndarray, v_left: np.ndarray, v_right: np.ndarray, *, dv_min: float = DV_MIN) -> np.ndarray:
    """ψ (N, 3) of each sample's own motion (module docstring); NaN where |ΔV| < ``dv_min``."""
    vx, vy, wz = np.asarray(twist, float).T
    vl, vr = np.asarray(v_left, float), np.asarray(v_right, float)
    dv = vr - vl
    ok = np.abs(dv) >= dv_min
    safe = np.where(ok, dv, 1.0)
    out = np.stack([-vy / safe, (vx - 0.5 * (vl + vr)) / safe, wz / safe], -1)
    out[~ok] = np.nan
    return out


def own_slips(twist: np.ndarray, v_left: np.ndarray, v_right: np.ndarray, track_gauge: float, *,
              v_min: float = V_MIN) -> np.ndarray:
    """MPP (s_L, s_R, α) (N, 3) of each sample's own motion; NaN where undefined (module docstring)."""
    vx, vy, wz = np.asarray(twist, float).T
    vl, vr = np.asarray(v_left, float), np.asarray(v_right, float)
    ok = (np.abs(vl) >= v_min) & (np.abs(vr) >= v_min) & (np.abs(vx) >= v_min)
    sl = lambda a: np.where(ok, a, 1.0)  # noqa: E731
    out = np.stack([1 - (vx - wz * track_gauge / 2) / sl(vl), 1 - (vx + wz * track_gauge / 2) / sl(vr),
                    np.arctan(-vy / sl(vx))], -1)
    out[~ok] = np.nan
    return out


def command_stretches(t: np.ndarray, v_left_cmd: np.ndarray, v_right_cmd: np.ndarray, segments=None) -> np.ndarray:
    """(N,) id of the constant-command stretch of each sample (a new id at each change or segment)."""
    vl, vr = np.asarray(v_left_cmd, float), np.asarray(v_right_cmd, float)
    change = np.r_[False, (np.diff(vl) != 0) | (np.diff(vr) != 0)]
    if segments is not None:
        change |= np.r_[False, np.diff(np.asarray(segments)) != 0]
    return np.cumsum(change)


def steady_truth(t: np.ndarray, values: np.ndarray, stretch: np.ndarray, *, settle_s: float = 1.0,
                 min_samples: int = 3) -> np.ndarray:
    """Per-sample truth (N, P): the mean of ``values`` over the steady part of its stretch, NaN elsewhere.

    The steady part of a stretch is t ≥ (its first time) + ``settle_s``; stretches with fewer than
    ``min_samples`` steady samples with all values defined give NaN.
    """
    t = np.asarray(t, float)
    values = np.asarray(values, float)
    out = np.full_like(values, np.nan)
    for sid in np.unique(stretch):
        idx = np.flatnonzero(stretch == sid)
        steady = idx[t[idx] >= t[idx[0]] + settle_s - 1e-9]
        good = steady[np.all(np.isfinite(values[steady]), axis=1)]
        if good.size >= min_samples:
            out[steady] = values[good].mean(0)
    return out


def nis_nees(result: FilterResult, param_true: np.ndarray | None = None, *,
             param_slice: slice = slice(3, None)) -> tuple[np.ndarray, np.ndarray]:
    """(NIS (N,), parameter NEES (N,)) of one run; NaN where no update / no truth (rows of NaN in ``param_true``)."""
    nis = result.nis()
    nees = np.full(result.t.size, np.nan)
    if param_true is not None:
        idx = list(range(result.x_post.shape[1]))[param_slice]
        pt = np.asarray(param_true, float)
        good = np.all(np.isfinite(pt), axis=1)
        full = np.array(result.x_post, float)
        full[:, idx] = np.where(good[:, None], pt, full[:, idx])
        nees = np.where(good, result.nees(full, idx=idx), np.nan)
    return nis, nees


def summary(result, param_true=None, *, t_from: float | None = None, param_slice: slice = slice(3, None)) -> dict:
    """``{nis_mean, nis_dof, nees_mean, nees_dof, band95, n_nis, n_nees}`` of one run or several.

    Args:
        result: a :class:`FilterResult` (N steps) or a sequence of them (segments of one log).
        param_true: (N, P) true parameters per step (NaN rows are left out), a sequence of them
            (one per result), or None (no truth: ``nees_mean`` is None).
        t_from: steps before this time [s] are left out of both means (initial convergence).
        param_slice: the parameter block of the state (default: after the pose).
    """
    results = [result] if isinstance(result, FilterResult) else list(result)
    truths = [param_true] if isinstance(result, FilterResult) else (
        [None] * len(results) if param_true is None else list(param_true))
    nis_all, nees_all, dofs = [], [], []
    for r, pt in zip(results, truths):
        nis, nees = nis_nees(r, pt, param_slice=param_slice)
        keep = np.ones(r.t.size, bool) if t_from is None else r.t >= t_from - 1e-9
        nis_all.append(nis[keep])
        nees_all.append(nees[keep])
        ok = keep & np.isfinite(nis)
        dofs.append(np.sum(np.isfinite(r.innovation[ok]), axis=1))
    nis, nees = np.concatenate(nis_all or [np.zeros(0)]), np.concatenate(nees_all or [np.zeros(0)])
    dofs = np.concatenate(dofs or [np.zeros(0)])
    dof = int(np.median(dofs)) if dofs.size else (len(results[0].meas_names) if results else 0)
    n_par = len(results[0].state_names[param_slice]) if results else 0
    ok_nis, ok_nees = np.isfinite(nis), np.isfinite(nees)
    have_truth = param_true is not None
    return {"nis_mean": float(np.mean(nis[ok_nis])) if ok_nis.any() else None, "nis_dof": dof,
            "nees_mean": float(np.mean(nees[ok_nees])) if have_truth and ok_nees.any() else None, "nees_dof": n_par,
            "band95": {"nis": list(chi2_band(dof)) if dof else None, "nees": list(chi2_band(n_par)) if n_par else None},
            "n_nis": int(ok_nis.sum()), "n_nees": int(ok_nees.sum())}


def per_dof(c: dict) -> tuple[float, float]:
    """(nis_mean / nis_dof, nees_mean / nees_dof), NaN where missing."""
    nis = c["nis_mean"] / c["nis_dof"] if c.get("nis_mean") is not None else math.nan
    nees = c["nees_mean"] / c["nees_dof"] if c.get("nees_mean") is not None else math.nan
    return nis, nees


def mean_band(dof: int, samples: int, p: float = 0.95) -> tuple[float, float]:
    """Two-sided ``p`` interval of the mean per degree of freedom of ``samples`` independent χ²(``dof``)
    values: χ²⁻¹((1 ∓ p)/2, samples·dof) / (samples·dof)."""
    lo, hi = chi2_band(dof, samples, p)
    return lo / dof, hi / dof


def pooled(runs: list[dict], p: float = 0.95) -> dict:
    """One filter's runs (:func:`summary` of each seed) judged by one rule (module docstring).

    Returns:
        ``{nis_per_dof, nis_samples, nis_band, nis_inside, nees_..., pass}``: for NIS and NEES the mean
        per degree of freedom over every sample of every run, the number of samples, the ``p``
        interval of :func:`mean_band` for that number (None without truth) and whether the mean
        lies inside it; ``pass``: both inside (NEES only where there is truth).
    """
    out: dict = {}
    ok = True
    for q in ("nis", "nees"):
        have = [r for r in runs if r.get(f"{q}_mean") is not None and r[f"n_{q}"] > 0]
        if not have:
            out.update({f"{q}_per_dof": None, f"{q}_samples": 0, f"{q}_band": None, f"{q}_inside": None})
            continue
        dof = have[0][f"{q}_dof"]
        n = sum(r[f"n_{q}"] for r in have)
        mean = sum(r[f"{q}_mean"] * r[f"n_{q}"] for r in have) / (n * dof)
        band = mean_band(dof, n, p)
        inside = bool(band[0] <= mean <= band[1])
        out.update({f"{q}_per_dof": mean, f"{q}_samples": n, f"{q}_band": list(band), f"{q}_inside": inside})
        ok &= inside
    out["pass"] = bool(ok)
    return out
