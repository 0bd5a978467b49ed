"""Figures 4.1-4.7 of the tracked-robot thesis, section 4.1 (PNG, matplotlib without pyplot).

Figures are built on :class:`matplotlib.figure.Figure` and rendered by the Agg canvas, so no
display and no global pyplot state are involved. Every figure carries a caption that states the
reconstruction of the command profile (the thesis's fig. 4.1 has no numbers).
"""

from __future__ import annotations

import io
import textwrap
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from mjtrack.io.atomic import atomic_write_bytes
from mjtrack.thesis.ex41 import MODEL_NAMES, Ex41, max_dev_m, virtual_centre_steps

DPI = 110
FLOOR = 1e-17  # [m] exact zeros are drawn here on the log-scale deviation plots
# Styles chosen so that coinciding paths stay visible: wide pale reference, thinner dashed/dotted on top.
STYLE = {
    "nominal": dict(color="0.6", lw=5.0, alpha=0.6, ls="-", label=r"$q_{traj}$ (nominal, 2.1)"),
    "MPP": dict(color="C0", lw=2.5, ls="-", label=r"$q_{MPP}$ (truth)"),
    "MICR": dict(color="C1", lw=1.8, ls="--", label=r"$q_{MICR}$"),
    "MVIR": dict(color="C3", lw=1.6, ls=":", label=r"$q_{MVIR}$"),
    "MICR_finite": dict(color="C2", lw=1.2, ls="-.", label=r"$q_{MICR}$, finite parameters only"),
    "MVIR_finite": dict(color="C2", lw=1.2, ls="-.", label=r"$q_{MVIR}$, finite parameters only"),
}
CASE_TITLES = {
    "no_slip": "no slip",
    "longitudinal_slip": "longitudinal slip of the tracks",
    "lateral_slip": "lateral slip with left-track slip",
}


def _save(fig: Figure, path: Path) -> None:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI)
    atomic_write_bytes(path, buf.getvalue())


def _caption(fig: Figure, text: str) -> None:
    """Put ``text`` under the axes, growing the bottom margin to fit it."""
    width_in, height_in = fig.get_size_inches()
    lines = textwrap.wrap(text, int(width_in * 16))
    fig.text(0.01, 0.008, "\n".join(lines), fontsize=7.5, va="bottom", ha="left", color="0.2")
    caption_in = 0.15 + 0.13 * len(lines)  # 7.5 pt lines with spacing, plus a gap
    fig.subplots_adjust(bottom=min(0.6, (caption_in + 0.6) / height_in))  # 0.6 in for tick and axis labels


def _shade_turn(ax, ex: Ex41) -> None:
    p = ex.path
    ax.axvspan(p.turn_start, p.turn_end, color="0.92", zorder=0)
    ax.axvspan(p.turn_start + p.ramp, p.turn_end - p.ramp, color="0.85", zorder=0, label="turn (dark: pi/6 rad/s)")


def fig_commands(ex: Ex41) -> Figure:
    """Fig. 4.1: the commands V_L, V_R and the nominal yaw rate vs time."""
    fig = Figure(figsize=(9, 6))
    fig.subplots_adjust(left=0.09, right=0.98, top=0.92, bottom=0.17, hspace=0.12)
    ax, ax2 = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    t = ex.path.times
    _shade_turn(ax, ex)
    ax.plot(t, ex.v_left, drawstyle="steps-post", color="C0", lw=2, label="$V_L$ (left track)")
    ax.plot(t, ex.v_right, drawstyle="steps-post", color="C3", lw=2, ls="--", label="$V_R$ (right track)")
    ax.set_ylabel("track speed command [m/s]")
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(alpha=0.3)
    _shade_turn(ax2, ex)
    ax2.plot(t, (ex.v_right - ex.v_left) / ex.path.track_gauge, drawstyle="steps-post", color="k", lw=1.5)
    ax2.set_ylabel(r"nominal $\omega$ [rad/s]")
    ax2.set_xlabel("time t [s]")
    ax2.grid(alpha=0.3)
    fig.suptitle("Fig. 4.1 — commands that drive the nominal robot along a U-shaped path (reconstruction)")
    return fig


def fig_paths(ex: Ex41, case: str, number: str) -> Figure:
    """Figs. 4.2/4.4/4.6: (a) MPP, (b) MICR, (c) MVIR paths against q_traj; (d) deviations vs t."""
    r = ex.results[case]
    p = r.paths
    fig = Figure(figsize=(11, 9.5))
    fig.subplots_adjust(left=0.07, right=0.98, top=0.92, bottom=0.12, hspace=0.28, wspace=0.2)
    axes = fig.subplots(2, 2)
    for ax, name, tag in zip(axes.flat[:3], MODEL_NAMES, "abc"):
        shown = ["nominal", "MPP"] if name == "MPP" else ["nominal", "MPP", name]
        if name != "MPP" and r.unrepresentable.any():
            shown.append(name + "_finite")
        for key in shown:
            ax.plot(p[key][:, 0], p[key][:, 1], **STYLE[key])
        ax.plot(0.0, 0.0, "ko", ms=5, label="start")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"({tag}) model {name}", fontsize=10)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=7.5)
    ax = axes[1, 1]
    t = ex.path.times
    for name in ("MICR", "MVIR"):
        d = np.hypot(*(p[name][:, :2] - p["MPP"][:, :2]).T)
        ax.semilogy(t, np.maximum(d, FLOOR), color=STYLE[name]["color"], ls=STYLE[name]["ls"], lw=1.5,
                    label=f"|{name} - MPP|")
    if r.unrepresentable.any():
        d = np.hypot(*(p["MICR_finite"][:, :2] - p["MPP"][:, :2]).T)
        ax.semilogy(t, np.maximum(d, FLOOR), **{**STYLE["MICR_finite"], "label": "|MICR, MVIR finite - MPP|"})
    d = np.hypot(*(p["MPP"][:, :2] - p["nominal"][:, :2]).T)
    ax.semilogy(t, np.maximum(d, FLOOR), color="0.4", lw=1.5, label="|MPP - nominal|")
    ax.axhline(1e-9, color="k", lw=0.8, ls="-.", label="1e-9 m")
    ax.set_ylim(FLOOR / 3, 30)
    ax.set_title(f"(d) position deviation (exact zeros drawn at {FLOOR:g} m)", fontsize=10)
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("distance [m]")
    ax.grid(alpha=0.3, which="both")
    ax.legend(loc="lower right", fontsize=7.5)
    fig.suptitle(f"Fig. {number} — paths of the models, {CASE_TITLES[case]}: "
                 f"max distance between MPP, MICR, MVIR = {max_dev_m(r):.2e} m")
    return fig


def fig_slips(ex: Ex41, case: str, number: str) -> Figure:
    """Figs. 4.3/4.5: the MPP slip parameters s_L, s_R [-] and alpha [rad] vs time."""
    c = ex.results[case].case
    fig = Figure(figsize=(9, 5))
    fig.subplots_adjust(left=0.09, right=0.9, top=0.9, bottom=0.2)
    ax = fig.subplots()
    t = ex.path.times
    _shade_turn(ax, ex)
    ax.plot(t, c.s_left, drawstyle="steps-post", color="C0", lw=2.5, label="$s_L$ (left track)")
    ax.plot(t, c.s_right, drawstyle="steps-post", color="C3", lw=2, ls="--", label="$s_R$ (right track)")
    ax.set_ylim(-0.01, 0.15)
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("longitudinal slip $s$ [-]")
    ax.grid(alpha=0.3)
    ax2 = ax.twinx()
    ax2.plot(t, c.alpha, drawstyle="steps-post", color="C2", lw=1.8, ls="-.", label=r"$\alpha$ (lateral slip angle)")
    ax2.set_ylabel(r"lateral slip angle $\alpha$ [rad]", color="C2")
    top = max(0.3, 1.15 * float(np.max(c.alpha)))
    ax2.set_ylim(-top * 0.01 / 0.15, top)  # zero at the same height as on the left axis
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, loc="upper left", fontsize=8)
    fig.suptitle(f"Fig. {number} — MPP slip parameters, {CASE_TITLES[case]}")
    return fig


def fig_virtual_centre(ex: Ex41, case: str = "lateral_slip") -> Figure:
    """Fig. 4.7: the MVIR virtual centre (x_o, y_o) vs time and its trace in the world."""
    r = ex.results[case]
    v, q = r.virtual_raw, r.paths["MPP"]
    t = ex.path.times
    fig = Figure(figsize=(12, 5.5))
    fig.subplots_adjust(left=0.07, right=0.98, top=0.88, wspace=0.3)
    ax, axw = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.3, 1]})
    _shade_turn(ax, ex)
    ax.plot(t, v["x_o"], color="C1", lw=2, label="$x_o$ (forward)")
    ax.plot(t, v["y_o"], color="C4", lw=2, ls="--", label="$y_o$ (left)")
    ax.plot(t, v["track"], color="0.3", lw=1.2, ls="-.", label="$T_v$ (virtual wheel distance)")
    steps = np.flatnonzero(np.diff(r.case.alpha) != 0) + 1
    for k in steps:
        ax.axvline(t[k], color="C2", lw=0.8, ls=":")
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("virtual robot, robot frame [m]")
    ax.set_title(r"(a) $x_o$, $y_o$ jump where $\alpha$ steps (dotted)", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", fontsize=8)
    c, s = np.cos(q[:, 2]), np.sin(q[:, 2])
    ox, oy = q[:, 0] + c * v["x_o"] - s * v["y_o"], q[:, 1] + s * v["x_o"] + c * v["y_o"]
    axw.plot(q[:, 0], q[:, 1], **STYLE["MPP"])
    axw.plot(ox, oy, color="C1", lw=1.3, label="virtual centre O' (MVIR)")
    for k in steps:
        axw.plot([ox[k - 1], ox[k]], [oy[k - 1], oy[k]], "C2-", lw=2)
        axw.plot(ox[k], oy[k], "C2o", ms=4)
    axw.plot([], [], "C2-o", ms=4, label=r"jump when $\alpha$ steps")
    axw.set_aspect("equal", adjustable="datalim")
    axw.set_xlabel("x [m]")
    axw.set_ylabel("y [m]")
    axw.set_title("(b) the robot centre and the virtual centre in the world", fontsize=10)
    axw.grid(alpha=0.3)
    axw.legend(loc="center right", fontsize=8)
    fig.suptitle("Fig. 4.7 — the MVIR virtual centre jumps at the start and end of the rotation at pi/6 rad/s")
    return fig


def _method_text(r) -> str:
    n, k_inf, k_un = r.regular.size, int(r.straight.sum()), int(r.unrepresentable.sum())
    text = (f"MICR/MVIR parameters from the MPP twist by (2.13) per sample ({int(r.regular.sum())} of {n} samples); "
            f"nominal parameters on {k_inf} straight samples where wz = 0 and MPP moves nominally (exact).")
    if k_un:
        text += (f" On {k_un} samples no finite MICR/MVIR parameters reproduce MPP (equal commands while MPP rotates, "
                 "(2.14) is 0/0): q_MICR, q_MVIR use the MPP twist there (continuous extension, the thesis's reading); "
                 "dash-dot: the models with nominal parameters there, which drive straight.")
    return text


def plot_ex41(ex: Ex41, out_dir: Path) -> dict:
    """Write figs. 4.1-4.7 as PNG into ``out_dir``; return {number: {"file", "caption"}}."""
    recon = ex.path.describe()["description"]
    lat = ex.results["lateral_slip"]
    steps = virtual_centre_steps(ex.path, lat)
    jumps = "; ".join(
        f"t = {s['t_s']:g} s: x_o {s['before']['x_o']:.3f} -> {s['after']['x_o']:.3f} m, "
        f"y_o {s['before']['y_o']:.3f} -> {s['after']['y_o']:.3f} m"
        for s in steps if s["jump_m"] is not None
    ) or "alpha does not step"
    degenerate = int(np.sum(lat.virtual_raw["track"] == 0))
    jumps += (f". On {degenerate} samples (equal commands, MPP rotating) T_v = 0 and the virtual robot is "
              "degenerate ((2.18) is 0/0) although its centre (2.16) is defined")
    specs = [
        ("4.1", "fig4_1_commands.png", fig_commands(ex), "Track speed commands V_L, V_R (top) and the nominal yaw rate (bottom)."),
    ]
    for case, path_no, slip_no in (("no_slip", "4.2", None), ("longitudinal_slip", "4.4", "4.3"), ("lateral_slip", "4.6", "4.5")):
        desc = ex.results[case].case.description
        if slip_no:
            specs.append((slip_no, f"fig{slip_no.replace('.', '_')}_slip_{case}.png", fig_slips(ex, case, slip_no),
                          f"MPP slip parameters, {desc}."))
        specs.append((path_no, f"fig{path_no.replace('.', '_')}_paths_{case}.png", fig_paths(ex, case, path_no),
                      f"Paths of the geometric centre, {desc}. {_method_text(ex.results[case])}"))
    specs.append(("4.7", "fig4_7_virtual_centre.png", fig_virtual_centre(ex),
                  f"MVIR virtual centre, lateral-slip case; {jumps}."))
    specs.sort(key=lambda s: s[0])
    out = {}
    for number, name, fig, text in specs:
        caption = f"{text} Reconstruction: {recon}."
        _caption(fig, caption)
        _save(fig, Path(out_dir) / name)
        out[number] = {"file": name, "caption": caption}
    return out
