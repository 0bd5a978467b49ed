"""Where the fit starts: what the log itself suggests, not the description's defaults.

A description as shipped with a log often gives the gauge and the sprocket radius only; every other
key is a default (a 0.5 m track contact on a robot of any size). A fit started there can end in a
local minimum that depends on the default, so two users with two descriptions of the same robot
get two answers. The log carries a first answer for the parameter that shapes every turn, the
contact length (``track_length``, a wheeled robot's ``wheelbase``): its steady turns' yaw ratio

    r = w_z / ((v_R - v_L) / T)

(the yaw rate over the ideal one of the measured track speeds; 1 without slip, smaller the more the
contact resists turning). On Coulomb ground r falls monotonically as the contact lengthens at a
given gauge (the resisting moment grows with L while the driving one stays with T; docs/theory,
"Steady turning"), so the length at which the Coulomb reference (:mod:`mjtrack.models.coulomb`, the
description with only the length changed) predicts the measured median r over the log's steady
turns is a start that does not depend on the described length. :func:`suggested_start` finds it by
Brent's method on the reference and says why, or why not (no steady turn in the log; the ratio beyond
what any length in the fit's range gives: then the nearer end, marked).

Only a start: the fit moves it like any other, and its interval says what the log determines.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize

from mjtrack.calibrate.measures import turn_measures
from mjtrack.calibrate.params import ParamSpec, geometry_name
from mjtrack.errors import MjtrackError
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import Robot
from mjtrack.models import coulomb
from mjtrack.windows.define import WindowSet

#: steady turns the reference is evaluated at: the log's at evenly spaced quantiles of their yaw
#: ratio (a median needs a spread, not every turn; each costs a Coulomb steady state per length)
MAX_TURNS = 7
#: contact points per side of the reference (enough for a yaw ratio to 1e-3 at these lengths)
N_POINTS = 24
#: the root's tolerance on the length [m]: a start, well inside any resolution of the fit
XTOL = 0.005


@dataclass(frozen=True)
class Suggestion:
    """A start value and why (or why not: ``value`` None)."""

    value: float | None
    why: str
    measured_ratio: float | None = None
    turns: int = 0


def _window_ratios(lg: DriveLog, ws: WindowSet, robot: Robot, poses: np.ndarray, speeds: np.ndarray):
    """Per steady turning window: its yaw ratio and mean measured track speeds (as calibrate measures
    them, :func:`mjtrack.calibrate.measures.turn_measures`)."""
    ratios, v = [], []
    for j in range(len(ws)):
        r = turn_measures(lg, ws.subset([j]), robot, poses[[j]], speeds[[j]])["yaw_ratio"]
        if np.isfinite(r):
            n = ws.ends[j] - ws.starts[j]
            ratios.append(r)
            v.append(np.nanmean(speeds[j, :n + 1], axis=0))
    return np.array(ratios), np.array(v).reshape(-1, 2)


def reference_ratio(robot: Robot, v: np.ndarray) -> float:
    """The Coulomb reference's median yaw ratio over track speed pairs v (M, 2) (NaN where none)."""
    out = []
    for vl, vr in v:
        try:
            s = coulomb.steady_state(robot, float(vl), float(vr), n_points=N_POINTS)
        except MjtrackError:  # no steady state (centripetal force beyond friction): not a turn it can make
            continue
        out.append(s.wz / ((vr - vl) / robot.track_gauge))
    return float(np.median(out)) if out else float("nan")


def suggested_length(lg: DriveLog, ws: WindowSet, robot: Robot, poses: np.ndarray, speeds: np.ndarray,
                     spec: ParamSpec) -> Suggestion:
    """The contact length at which the Coulomb reference turns as the log's steady turns do (module
    docstring), within ``spec``'s range."""
    key = geometry_name(robot)
    ratios, v = _window_ratios(lg, ws, robot, poses, speeds)
    if len(ratios) < 3:
        return Suggestion(None, f"{key}: the log has {len(ratios)} steady turn(s); the described value is the start")
    target = float(np.median(ratios))
    order = np.argsort(ratios)
    v = v[order[np.unique(np.linspace(0, len(v) - 1, min(MAX_TURNS, len(v))).round().astype(int))]]

    def ratio_at(length: float) -> float:
        return reference_ratio(robot.replace(**{key: length}), v)

    lo, hi = spec.lo, spec.hi
    r_lo, r_hi = ratio_at(lo), ratio_at(hi)
    if not (np.isfinite(r_lo) and np.isfinite(r_hi)):
        return Suggestion(None, f"{key}: the Coulomb reference has no steady state at the log's turns", target,
                          len(ratios))
    if target >= r_lo or target <= r_hi:  # beyond what any length in range gives: the nearer end
        end = lo if target >= r_lo else hi
        return Suggestion(end, f"{key}: the log's steady yaw ratio {target:.3f} over {len(ratios)} turns is beyond "
                               f"the Coulomb reference's range [{r_hi:.3f}, {r_lo:.3f}] for {key} in [{lo:g}, {hi:g}] "
                               f"m; start at the nearer end", target, len(ratios))
    try:  # r falls as the length grows (module docstring): one root in [lo, hi]
        value = float(optimize.brentq(lambda length: ratio_at(length) - target, lo, hi, xtol=XTOL))
    except ValueError:  # a NaN inside the range (no steady state there)
        return Suggestion(None, f"{key}: the Coulomb reference has no steady state at some of the log's turns",
                          target, len(ratios))
    return Suggestion(value, f"{key}: {value:.3g} m, where the Coulomb reference turns as the log's {len(ratios)} "
                             f"steady turns do (yaw ratio {target:.3f})", target, len(ratios))


def suggested_start(lg: DriveLog, ws: WindowSet, robot: Robot, names: list[str], specs: dict[str, ParamSpec],
                    poses: np.ndarray, speeds: np.ndarray) -> dict[str, Suggestion]:
    """What the log suggests for the fitted ``names`` it can say something about (module docstring)."""
    key = geometry_name(robot)
    if key not in names:
        return {}
    return {key: suggested_length(lg, ws, robot, poses, speeds, specs[key])}


__all__ = ["Suggestion", "reference_ratio", "suggested_length", "suggested_start"]
