"""Matplotlib figures of a validation (each returns a Figure; the report embeds and closes it).

Colours are fixed per predictor so that every figure reads the same way; oracles are dashed.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from mjtrack.io.robot import side_word
from mjtrack.validate.evaluate import CaseResult
from mjtrack.validate.wheeled import WheeledResult

COLORS = {"truth": "black", "nominal": "tab:gray", "mpp_slip_ekf": "tab:blue", "micr_icr_ekf": "tab:orange",
          "mvir_vir_filter": "tab:green", "mpp_fit": "tab:purple", "micr_own_icr": "tab:red"}
FILTER_KEYS = {"slip_ekf": "mpp_slip_ekf", "icr_ekf": "micr_icr_ekf", "vir_filter": "mvir_vir_filter"}


def _style(p) -> dict:
    return {"color": COLORS.get(p.key, "k"), "ls": "--" if not p.causal else "-", "label": p.label}


def horizon_figure(results: dict[str, CaseResult]) -> Figure:
    """Position and heading RMSE against the horizon, one column per truth."""
    fig = Figure(figsize=(10, 6.5))
    axes = fig.subplots(2, len(results), squeeze=False, sharex=True)
    for j, (name, res) in enumerate(results.items()):
        for p in res.predictors:
            hs = sorted(res.errors[p.key])
            pos = [res.errors[p.key][h].pos_rmse for h in hs]
            yaw = [math.degrees(res.errors[p.key][h].yaw_rmse) for h in hs]
            axes[0, j].plot(hs, pos, marker="o", **_style(p))
            axes[1, j].plot(hs, yaw, marker="o", **_style(p))
        axes[0, j].set_title(f"truth: {res.case.title}")
        axes[0, j].set_ylabel("position RMSE [m]")
        axes[1, j].set_ylabel("heading RMSE [deg]")
        axes[1, j].set_xlabel("prediction horizon [s]")
        for ax in axes[:, j]:
            ax.set_yscale("log")
            ax.grid(True, which="both", alpha=0.3)
    axes[0, -1].legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    return fig


WHEELED_COLORS = {"kinematic": "tab:gray", "dynamic1": "tab:blue", "dynamic2": "tab:orange", "skidsteer4": "tab:red"}


def wheeled_figure(res: WheeledResult) -> Figure:
    """The wheeled models' position and heading errors against the horizon: median (solid) and worst (dashed)."""
    fig = Figure(figsize=(10, 6.5))
    axes = fig.subplots(2, 1, sharex=True)
    for p in res.predictors:
        rows = res.metrics["models"][p.key]["horizons"]
        hs = sorted(rows, key=float)
        x = [float(h) for h in hs]
        color = WHEELED_COLORS.get(p.key, "k")
        for ax, f in zip(axes, ("pos", "yaw")):
            unit = "m" if f == "pos" else "deg"
            med = [rows[h][f"{f}_median_{unit}"] for h in hs]
            worst = [rows[h][f"{f}_max_{unit}"] for h in hs]
            ax.plot(x, [np.nan if v is None else v for v in med], marker="o", color=color, label=f"{p.label}, median")
            ax.plot(x, [np.nan if v is None else v for v in worst], marker=".", ls="--", color=color,
                    label=f"{p.label}, worst")
    axes[0].set_ylabel("position error [m]")
    axes[1].set_ylabel("heading error [deg]")
    axes[1].set_xlabel("prediction horizon [s]")
    for ax in axes:
        ax.set_yscale("log")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7, loc="lower right", ncol=2)
    fig.tight_layout()
    return fig


def paths_figure(res: CaseResult) -> Figure:
    """True path and each predictor's open-loop path over the whole log (top view)."""
    fig = Figure(figsize=(10, 6))
    ax = fig.subplots()
    c = res.case
    ax.plot(c.pose[:, 0], c.pose[:, 1], color="k", lw=3, alpha=0.6, zorder=5, label=f"truth ({c.title})")
    ax.plot(c.pose[0, 0], c.pose[0, 1], "ko", ms=7)
    lo, hi = c.pose[:, :2].min(0), c.pose[:, :2].max(0)
    span = max(float(np.max(hi - lo)), 0.5)
    for p in res.predictors:
        xy = res.paths[p.key]
        ax.plot(xy[:, 0], xy[:, 1], lw=1.5, **_style(p))
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlim(lo[0] - 0.3 * span, hi[0] + 0.3 * span)  # keep the truth in view when a model runs away
    ax.set_ylim(lo[1] - 0.3 * span, hi[1] + 0.3 * span)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    return fig


def icr_figure(res: CaseResult, wz_min: float, traction: str = "tracks") -> Figure:
    """ICRs over time: the truth's own (2.13) vs those implied by each filter's estimate (the side
    ICRs named after what carries a side of a robot on ``traction``)."""
    fig = Figure(figsize=(10, 7.5))
    axes = fig.subplots(3, 1, sharex=True)
    c = res.case
    valid = res.icr_true.valid
    by_key = {p.key: p for p in res.predictors}
    side = side_word(traction)
    for ax, f, name in zip(axes, ("y_l", "y_r", "x_c"), (f"left-{side} ICR y_l [m]", f"right-{side} ICR y_r [m]",
                                                          "ICR x_c [m]")):
        true = np.where(valid, getattr(res.icr_true, f), np.nan)
        ax.plot(c.t, true, ".", color="k", ms=2.5, label="truth's own ICRs (eq. (2.13) of [Mendaluk])")
        for key in ("mpp_slip_ekf", "micr_icr_ekf", "mvir_vir_filter"):
            est = np.where(valid, getattr(res.icrs[key], f), np.nan)
            ax.plot(c.t, est, lw=1.2, **_style(by_key[key]))
        finite = true[np.isfinite(true)]
        if finite.size:
            lo, hi = np.percentile(finite, [2, 98])
            pad = max(0.5 * (hi - lo), 0.2)
            ax.set_ylim(lo - pad, hi + pad)
        ax.set_ylabel(name)
        ax.grid(True, alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="upper center", ncol=4, fontsize=9, markerscale=3)
    axes[-1].set_xlabel(f"time [s]  (samples with true |ω| < {wz_min:g} rad/s left out: ICRs at infinity)")
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    return fig


def mpp_params_figure(res: CaseResult) -> Figure:
    """Slip EKF estimates (s_L, s_R, α) over time against the MPP truth's known values."""
    fig = Figure(figsize=(10, 6))
    axes = fig.subplots(3, 1, sharex=True)
    f = res.filters["slip_ekf"]
    truth = res.case.truth_params or {}
    for i, (ax, key, unit) in enumerate(zip(axes, ("s_left", "s_right", "alpha"), ("[-]", "[-]", "[deg]"))):
        scale = 180 / math.pi if key == "alpha" else 1.0
        ax.plot(res.case.t, f.params[:, i] * scale, color=COLORS["mpp_slip_ekf"], label="slip EKF estimate")
        if key in truth:
            ax.axhline(truth[key] * scale, color="k", ls="--", label="truth")
        ax.set_ylabel(f"{key} {unit}")
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("time [s]")
    fig.tight_layout()
    return fig


NIS_AVG_S = 1.0  # [s] moving-average window of the NIS curves


def nis_figure(res: CaseResult) -> Figure:
    """NIS over time of each filter (dots: per step; line: 1-s moving mean) with the χ² 95 % bands.

    Light band: a single step's 95 % band (χ²(m) quantiles); dark band: the band of the moving mean
    of that many independent steps. A consistent filter's dots scatter inside the light band and its
    mean stays near m (dashed).
    """
    from mjtrack.estimation.common import chi2_band

    keys = [k for k in FILTER_KEYS if k in res.filters and res.filters[k].results]
    fig = Figure(figsize=(10, 2.4 * max(1, len(keys)) + 0.8))
    axes = np.atleast_1d(fig.subplots(max(1, len(keys)), 1, sharex=True, squeeze=False)[:, 0])
    for ax, key in zip(axes, keys):
        run = res.filters[key]
        t = np.concatenate([r.t for r in run.results])
        nis = np.concatenate([r.nis() for r in run.results])
        dof = len(run.results[0].meas_names)
        dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
        w = max(1, int(round(NIS_AVG_S / dt)))
        good = np.isfinite(nis)
        filled = np.where(good, nis, 0.0)
        cnt = np.convolve(good.astype(float), np.ones(w), "same")
        mean = np.convolve(filled, np.ones(w), "same") / np.maximum(cnt, 1)
        lo1, hi1 = chi2_band(dof)
        low, hiw = chi2_band(dof, w)
        ax.axhspan(lo1, hi1, color="0.9", zorder=0, label=f"95 % band of one step, χ²({dof})")
        ax.axhspan(low, hiw, color="0.75", zorder=0, label=f"95 % band of a {NIS_AVG_S:g}-s mean")
        ax.axhline(dof, color="k", ls="--", lw=0.8)
        ax.plot(t[good], nis[good], ".", ms=1.5, color=COLORS[FILTER_KEYS[key]], alpha=0.35)
        ax.plot(t, np.where(cnt > 0, mean, np.nan), color=COLORS[FILTER_KEYS[key]], lw=1.4,
                label=f"{key}: {NIS_AVG_S:g}-s mean NIS")
        ax.set_yscale("log")
        ax.set_ylim(max(1e-2, lo1 / 3), max(hi1 * 10, np.nanpercentile(nis, 99.5) * 1.5 if good.any() else 10))
        ax.set_ylabel(f"NIS ({run.measures})")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="upper right", ncol=3)
    axes[-1].set_xlabel("time [s]")
    fig.tight_layout()
    return fig
