"""``icr_map.png``: where the ICRs of a sweep lie, against turn radius and speed.

Three rows of panels, the simulated ICR coordinates y_l, y_r (left/right track ICR, lateral,
[m]) and x_c (longitudinal shift of the vehicle ICR, [m]); the x axis is the *commanded* turn
radius (the no-slip radius of the track commands), one line per commanded speed (colour);
one column per combination of the other grid keys (friction, centre of mass, mass, ...).
Dashed lines mark the no-slip ICRs (y_l = +T/2, y_r = -T/2, x_c = 0): the distance of a line
from them is the slip. Cases where the robot does not turn (undefined ICRs) are left out and
counted in the title.
"""

from __future__ import annotations

import math
from collections import defaultdict
from typing import Any, Sequence

from mjtrack.io.robot import side_word
from mjtrack.sweep.grid import Grid, nominal_turn

ICR_ROWS = (("y_l", "left-track ICR y_l [m]"), ("y_r", "right-track ICR y_r [m]"),
            ("x_c", "ICR shift x_c [m]"))


def icr_rows(traction: str = "tracks") -> tuple[tuple[str, str], ...]:
    """:data:`ICR_ROWS` for a robot on ``traction`` (a wheeled robot's side ICRs are its wheels')."""
    side = side_word(traction)
    return (("y_l", f"left-{side} ICR y_l [m]"), ("y_r", f"right-{side} ICR y_r [m]"), ICR_ROWS[2])
MAX_COLUMNS = 6


def _fmt(v: Any) -> str:
    return "straight" if v is None else f"{v:g}"


def icr_map_png(records: Sequence[dict[str, Any]], grid: Grid) -> bytes:
    """The map of ``records`` (sweep rows as dicts) as PNG bytes."""
    import io

    import matplotlib.pyplot as plt

    fig = icr_map_figure(records, grid)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()


def _plain_log_formatter(**kwargs):
    """Log-axis tick labels as plain numbers (0.5, 1, 2, 10), not 10^0 or 2x10^0: matplotlib's
    own choice of which ticks to label, each written with ``g``."""
    from matplotlib import ticker

    class PlainLog(ticker.LogFormatterSciNotation):
        def __call__(self, x, pos=None):
            return f"{x:g}" if super().__call__(x, pos) else ""

    return PlainLog(**kwargs)


def icr_map_figure(records: Sequence[dict[str, Any]], grid: Grid):
    """The map of ``records`` as a matplotlib figure (the caller closes it)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib import cm, colors

    facet_keys = [k for k in grid.keys if k not in grid.form]
    tractions = {c.robot.traction for c in grid.cases}
    rows = icr_rows(next(iter(tractions))) if len(tractions) == 1 else (
        ("y_l", "left ICR y_l [m]"), ("y_r", "right ICR y_r [m]"), ICR_ROWS[2])
    facets: dict[tuple, list[tuple[float, float, dict[str, Any], float]]] = defaultdict(list)
    undefined = 0
    for rec in records:
        case = grid.cases[int(rec["case"])]
        speed, radius = nominal_turn(case.v_left_cmd, case.v_right_cmd, case.robot.track_gauge)
        if radius is None or any(rec.get(k) is None for k, _ in rows):
            undefined += 1
            continue
        facets[tuple(rec.get(k) for k in facet_keys)].append((speed, radius, rec, case.robot.track_gauge))
    keys = sorted(facets, key=lambda t: tuple(-math.inf if v is None else v for v in t)) or [()]
    ncol = min(len(keys), MAX_COLUMNS)
    blocks = math.ceil(len(keys) / ncol)
    fig, axes = plt.subplots(3 * blocks, ncol, figsize=(3.2 * ncol + 1.2, 2.4 * 3 * blocks + 0.8),
                             squeeze=False, sharex=True, sharey="row", layout="constrained")
    speeds = sorted({round(s, 9) for pts in facets.values() for s, *_ in pts}) or [0.0]
    norm = colors.Normalize(min(speeds), max(speeds) if max(speeds) > min(speeds) else min(speeds) + 1)
    cmap = matplotlib.colormaps["viridis"]
    radii = [r for pts in facets.values() for _, r, *_ in pts]
    for f, key in enumerate(keys):
        b, c = divmod(f, ncol)
        pts = facets.get(key, [])
        by_speed: dict[float, list] = defaultdict(list)
        for s, r, rec, gauge in pts:
            by_speed[round(s, 9)].append((r, rec, gauge))
        for row, (name, label) in enumerate(rows):
            ax = axes[3 * b + row, c]
            for s, items in sorted(by_speed.items()):
                items.sort(key=lambda it: it[0])
                ax.plot([it[0] for it in items], [it[1][name] for it in items], "o-", ms=3, lw=1.2,
                        color=cmap(norm(s)))
            gauges = {g for *_, g in pts} or {None}
            for gauge in gauges:
                ref = {"y_l": None if gauge is None else gauge / 2,
                       "y_r": None if gauge is None else -gauge / 2, "x_c": 0.0}[name]
                if ref is not None:
                    ax.axhline(ref, color="0.4", ls="--", lw=0.8)
            if radii and min(radii) > 0:
                ax.set_xscale("log")
            elif radii:
                ax.set_xscale("symlog", linthresh=min(abs(r) for r in radii))
            if radii:
                ax.xaxis.set_major_formatter(_plain_log_formatter())
                ax.xaxis.set_minor_formatter(_plain_log_formatter(labelOnlyBase=False))
            ax.grid(True, which="both", alpha=0.3)
            if c == 0:
                ax.set_ylabel(label)
            if row == 0:
                ax.set_title(", ".join(f"{k}={_fmt(v)}" for k, v in zip(facet_keys, key)) or "all cases",
                             fontsize=9)
            if row == 2 and b == blocks - 1:
                ax.set_xlabel("commanded turn radius [m]")
    for f in range(len(keys), blocks * ncol):
        b, c = divmod(f, ncol)
        for row in range(3):
            axes[3 * b + row, c].set_visible(False)
    note = f"\n{undefined} straight or spot-turn cases have no ICRs and are not shown" if undefined else ""
    if len(speeds) > 1:
        sm = cm.ScalarMappable(norm=norm, cmap=cmap)
        fig.colorbar(sm, ax=axes, label="commanded speed [m/s]", shrink=0.6)
    else:  # one speed: a colour bar would span speeds never commanded
        note += f"\ncommanded speed {speeds[0]:g} m/s" if records else ""
    fig.suptitle(f"Simulated ICRs of {len(records)} steady states (dashed: no-slip ICRs){note}", fontsize=10)
    return fig
