"""Why the calibrated robot predicts better: the changes that carry the gain, measured.

A *cause* is one changed parameter, or a group of changed parameters that the fit cannot move
independently (|correlation| of their estimates at least :data:`COUPLED`), together with the
parameters the log cannot tell apart from them (ties, :mod:`mjtrack.calibrate.identify`). For each
cause two simulations of the windows the fit used are scored: the calibrated robot with the cause's
parameters back at their described values (``share``: the fraction of the improvement lost) and
the described robot with only the cause's changes (``gain_alone``: its relative improvement).
Causes are ordered by ``share``; the summary sentence is built from them, never from a template of
what usually goes wrong. No change, no cause: ``causes`` is empty and the summary says so.

Plausibility. A fitted value that ends on a bound of its range (within one resolution of it), a
95 % interval that reaches a bound (the log does not keep the value off it), an effective geometry
far from the described one (a contact length or wheelbase more than :data:`GEOMETRY_RATIO` times
or less than 1 / :data:`GEOMETRY_RATIO` of the described), or a drive force limit above what the
ground can transmit (:func:`traction_limit`: a limit above the friction force of the side that
carries more weight cannot bound the force on the robot, only how fast a wheel spins against sliding
ground) is not the robot's: the fit has pushed a
candidate to stand in for something none of them describes. Such a cause is reported as "the log
shows something no candidate describes, which acts like ...", never as a cause, the summary says
so, and :func:`not_explained` lists it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from mjtrack.calibrate.rounds import ROUNDS_HINT
from mjtrack.io.robot import G, Robot

COUPLED = 0.7  # |correlation| above which changed parameters form one cause
#: effective / described contact length or wheelbase beyond which (or below 1 / it) the geometry is
#: not the robot's (a Husky's 0.51 m wheelbase fitted to 1.02 m: the fit stands in for something else)
GEOMETRY_RATIO = 1.5
GEOMETRY = ("track_length", "wheelbase")


@dataclass
class Cause:
    """One cause: its parameters (changed ones first, then those tied to them), their described
    and calibrated values, ``share`` and ``gain_alone`` (see the module docstring), and a sentence."""

    parameters: list[str]
    changed: dict[str, tuple[float, float]]
    tied: list[str]
    share: float
    gain_alone: float
    sentence: str
    implausible: list[str] = field(default_factory=list)  # why its values are not the robot's (module docstring)

    @property
    def plausible(self) -> bool:
        return not self.implausible

    def to_json(self) -> dict:
        return {"parameters": self.parameters, "share": self.share, "gain_alone": self.gain_alone,
                "changes": {k: {"described": a, "calibrated": b} for k, (a, b) in self.changed.items()},
                "tied": self.tied, "sentence": self.sentence, "plausible": self.plausible,
                "implausible": self.implausible}


def on_bound(value: float, lo: float, hi: float, resolution: float) -> bool:
    """Whether ``value`` ended within one ``resolution`` of a bound of its range [lo, hi] (a bound at
    0 is physics, not a limit of the search: no lag, no resistance)."""
    return value >= hi - resolution or (lo != 0 and value <= lo + resolution)


def implausibility(name: str, value: float, described: float,
                   bounds: tuple[float, float, float] | None,
                   interval: tuple[float, float] | None = None, traction: float | None = None,
                   traction_note: str = "") -> str | None:
    """Why a fitted ``value`` is not the robot's, in words, or None (module docstring);
    ``bounds``: (low, high, resolution) of its range; ``interval``: its 95 % interval;
    ``traction``: the largest force [N] the ground transmits under one side (:func:`traction_limit`);
    ``traction_note``: the defaults it rests on (:func:`traction_defaults`); every reason that
    applies, joined by "; "."""
    why = []
    if bounds is not None:
        lo, hi, res = bounds
        if on_bound(value, lo, hi, res):
            why.append(f"{name} ended on its bound, {value:.3g} (range {lo:.3g} to {hi:.3g})")
        elif interval is not None and (interval[1] >= hi - res or (lo != 0 and interval[0] <= lo + res)):
            edge = hi if interval[1] >= hi - res else lo
            why.append(f"{name}'s 95 % interval, {interval[0]:.3g} to {interval[1]:.3g}, reaches its bound {edge:.3g}: "
                       "the log does not keep it off the bound")
    if name in GEOMETRY and described > 0 and not 1 / GEOMETRY_RATIO <= value / described <= GEOMETRY_RATIO:
        why.append(f"{name} {value:.3g} m is {value / described:.2f} times the described {described:.3g} m "
                   f"(beyond {1 / GEOMETRY_RATIO:.2f} to {GEOMETRY_RATIO:g})")
    if name == "drive_force_limit" and traction is not None and value > traction:
        why.append(f"drive_force_limit {value:.3g} N is above what the ground can transmit under a side, "
                   f"{traction:.3g} N (friction times the side's share of the weight{traction_note}): a limit above "
                   "it cannot bound the force on the robot, only how fast a wheel spins against sliding ground")
    return "; ".join(why) or None


def traction_limit(robot: Robot, values: dict[str, float]) -> float:
    """The largest traction force [N] the ground transmits under one side on level ground:
    max over the sides of mu_side x the side's share of the weight m g (1/2 + cg_y / T for the left,
    1/2 - cg_y / T for the right), with the friction and the centre of mass of ``values`` where they
    are there (``mu``/``mu_ratio`` or ``mu_left``/``mu_right``, ``cg_y``), else the robot's."""
    left, right = _side_friction(robot, values)
    share = min(1.0, max(0.0, 0.5 + values.get("cg_y", robot.cg_y) / robot.track_gauge))
    return float(robot.mass * G * max(left * share, right * (1.0 - share)))


def _side_friction(robot: Robot, values: dict[str, float]) -> tuple[float, float]:
    """(left, right) friction of ``values`` (``mu``/``mu_ratio`` or ``mu_left``/``mu_right``) where
    they are there, else the robot's."""
    left, right = robot.friction_left, robot.friction_right
    if "mu_left" in values or "mu_right" in values:
        return values.get("mu_left", left), values.get("mu_right", right)
    if "mu" in values or "mu_ratio" in values:
        mu = values.get("mu", math.sqrt(left * right))
        ratio = values.get("mu_ratio", left / right)
        return mu * math.sqrt(ratio), mu / math.sqrt(ratio)
    return left, right


def traction_defaults(robot: Robot, values: dict[str, float]) -> str:
    """", with the default ... that the description does not give" for the values
    :func:`traction_limit` takes from defaults (the mass; the friction when it was not fitted), so
    that a force limit called implausible by a weight nobody described says so; "" when none."""
    if robot.provided is None:
        return ""
    # the friction was fitted when the values move a side's friction off the robot's own (a candidate
    # the log left at its description is still the default)
    fitted_mu = any(not math.isclose(a, b, rel_tol=1e-9) for a, b in
                    zip(_side_friction(robot, values), (robot.friction_left, robot.friction_right)))
    missing = [f"mass {robot.mass:g} kg"] if "mass" not in robot.provided else []
    if not fitted_mu and not {"mu", "mu_left", "mu_right"} & robot.provided:
        missing.append(f"friction {robot.mu:g}")
    return f", with the default {' and '.join(missing)} that the description does not give" if missing else ""


def groups(names: list[str], corr: np.ndarray) -> list[list[str]]:
    """Connected components of ``names`` under |corr| >= :data:`COUPLED`."""
    n = len(names)
    label = list(range(n))

    def find(i):
        while label[i] != i:
            label[i] = label[label[i]]
            i = label[i]
        return i

    for i in range(n):
        for j in range(i + 1, n):
            if abs(corr[i, j]) >= COUPLED:
                label[find(i)] = find(j)
    out: dict[int, list[str]] = {}
    for i in range(n):
        out.setdefault(find(i), []).append(names[i])
    return list(out.values())


def digits(value: float, described: float, least: int) -> int:
    """Significant digits, from ``least`` up to 6, at which ``value`` and ``described`` print differently."""
    for n in range(least, 7):
        if f"{value:.{n}g}" != f"{described:.{n}g}":
            return n
    return max(least, 6)


def phrase(name: str, value: float, described: float, *, wheels: bool = False, measured: bool = False) -> str:
    """What a change of one parameter says of the robot, in words (``wheels``: a wheeled one;
    ``measured``: its simulated drives followed the measured track speeds, not the commands)."""
    runner = "wheels" if wheels else "tracks"
    # enough digits that the value and the description read differently ("0.8 m, not 0.8 m" says nothing)
    n, n2, n4 = (digits(value, described, least) for least in (3, 2, 4))
    if name == "cg_x":
        return (f"its centre of mass is {abs(value):.{n}g} m {'ahead of' if value > 0 else 'behind'} the geometric "
                f"centre (described {described:+.{n}g} m)")
    if name == "cg_y":
        return (f"its centre of mass is {abs(value):.{n}g} m {'left' if value > 0 else 'right'} of the centre line "
                f"(described {described:+.{n}g} m)")
    if name == "mu":
        return f"its ground's friction is {value:.{n}g}, not {described:.{n}g}"
    if name == "mu_ratio":
        return (f"its left side grips {value:.{n}g} times as much as its right (described {described:.{n}g}): "
                "the ground differs under the two sides")
    if name in ("mu_left", "mu_right"):
        return f"its {name[3:]} side's friction is {value:.{n}g}, not {described:.{n}g}"
    if name == "track_length":
        more = "less" if value > described else "more"
        return (f"its ground contact is {value:.{n}g} m long, not {described:.{n}g} m: the simulated contact resists "
                f"turning {more} than the real one")
    if name == "wheelbase":
        return f"its wheelbase acts as {value:.{n}g} m, not {described:.{n}g} m"
    if name == "drive_lag":
        return f"its drives reach a command with a {value:.{n}g} s lag (described {described:.{n}g} s)"
    if name == "drive_delay":
        return f"its drives act {value:.{n}g} s after a command (described {described:.{n}g} s)"
    if name == "track_speed_scale" and measured:
        return (f"its {runner} roll on an effective radius of {value:.{n}g} times the nominal one (described "
                f"{described:.{n}g})")
    if name == "track_speed_scale":
        return f"its {runner} run at {value:.{n}g} of the commanded speed (described {described:.{n}g})"
    if name == "drive_force_limit":
        return f"its drives saturate at {value:.{n}g} N (described {described:.{n}g} N)"
    if name == "lateral_ratio":
        return f"its ground resists sideways slip {value:.{n}g} times as much as forward slip (described {described:.{n}g})"
    if name == "rolling_resistance":
        return (f"its ground holds each side back with {value:.{n2}g} of the weight it carries (described "
                f"{described:.{n2}g}): in turns the robot falls behind its {runner}")
    if name == "shear_modulus":
        return (f"its ground's friction builds up with slip as a shear ground's of modulus {value:.{n}g} m (described "
                f"{described:.{n}g} m{', Coulomb' if described == 0 else ''}): its slip depends on the turn")
    if name == "lateral_shear_ratio":
        return (f"the shear modulus across its {runner} is {value:.{n}g} times the one along them (described "
                f"{described:.{n}g}): their sideways grip builds up {'more slowly' if value > 1 else 'faster'} with "
                "slip than their forward grip")
    if name in ("concentration", "span"):
        return f"its load sits on its road wheels differently ({name} {value:.{n}g}, described {described:.{n}g})"
    return f"{name} is {value:.{n4}g}, not {described:.{n4}g}"


def slope_phrase(ax: float, ay: float) -> str:
    s = math.degrees(math.asin(min(1.0, math.hypot(ax, ay))))
    d = math.degrees(math.atan2(ay, ax))
    return f"it drove on ground inclined {s:.2g} deg, uphill towards {d:.0f} deg in the log's frame"


def sentence_of(params: list[str], values: dict[str, float], described: dict[str, float], tied: list[str],
                wheels: bool = False, measured: bool = False) -> str:
    parts = []
    if "slope_x" in params and "slope_y" in params:
        parts.append(slope_phrase(values["slope_x"], values["slope_y"]))
    else:  # one component: the other is in another cause's sentence, and the whole slope is not this one's
        parts += [f"its ground rises along the log's {n[-1]} axis (sine of the slope {values[n]:.3g}, described "
                  f"{described[n]:.3g})" for n in ("slope_x", "slope_y") if n in params]
    parts += [phrase(n, values[n], described[n], wheels=wheels, measured=measured) for n in params
              if n not in ("slope_x", "slope_y")]
    text = "; ".join(parts)
    if tied:
        text += f" (or, equally well on this log, a change of {', '.join(tied)})"
    return text


def _score_distinct(score: Callable[[list[dict[str, float]]], np.ndarray],
                    variants: list[dict[str, float]]) -> np.ndarray:
    """``score(variants)`` with each distinct parameter set simulated once (with two groups, one
    group's "without" is the other's "alone"): the simulations are deterministic, so the scores are
    the same numbers."""
    keys = [tuple(sorted(v.items())) for v in variants]
    distinct = list(dict.fromkeys(keys))
    rms = np.asarray(score([dict(k) for k in distinct]), float)
    return rms[[distinct.index(k) for k in keys]]


def find_causes(changed: list[str], values: dict[str, float], described: dict[str, float], corr: np.ndarray,
                ties: dict[str, list[str]], score: Callable[[list[dict[str, float]]], np.ndarray],
                rms_before: float, rms_after: float, *, wheels: bool = False,
                measured: bool = False, bounds: dict[str, tuple[float, float, float]] | None = None,
                intervals: dict[str, tuple[float, float] | None] | None = None,
                robot: Robot | None = None) -> list[Cause]:
    """The causes of the improvement ``rms_before`` -> ``rms_after`` (module docstring).

    Args:
        changed: the parameters the calibration changed, in the order of ``corr``'s rows.
        values, described: calibrated and described values of at least ``changed``.
        corr: (n, n) correlation of the changed parameters' estimates.
        ties: parameter -> the parameters it carries the combination with.
        score: RMS position error [m] of the training windows for each of a list of parameter
            sets (each a full set of the calibrated parameters' values).
        rms_before, rms_after: the described and the calibrated robot's RMS error [m].
        wheels: the robot is wheeled (its sentences speak of wheels, not tracks).
        measured: the simulated drives followed the measured track speeds (a speed scale is then
            an effective rolling radius).
        bounds: parameter -> (low, high, resolution) of its range, for the plausibility check.
        intervals: parameter -> its 95 % interval, for the same check.
        robot: the described robot, whose weight and friction say what the ground can transmit
            (:func:`traction_limit`, with the calibrated friction and centre of mass).
    """
    if not changed:
        return []
    gs = groups(changed, corr)
    full = {n: values[n] for n in changed}
    variants = []
    for g in gs:
        variants.append({**full, **{n: described[n] for n in g}})  # without the cause
        variants.append({**{n: described[n] for n in changed}, **{n: values[n] for n in g}})  # the cause alone
    rms = _score_distinct(score, variants)
    gain = rms_before - rms_after
    traction = None if robot is None else traction_limit(robot, values)
    note = "" if robot is None else traction_defaults(robot, values)
    out = []
    for k, g in enumerate(gs):
        without, alone = float(rms[2 * k]), float(rms[2 * k + 1])
        tied = sorted({t for n in g for t in ties.get(n, [])})
        why = [w for n in g if (w := implausibility(n, values[n], described[n], (bounds or {}).get(n),
                                                    (intervals or {}).get(n), traction, note))]
        sentence = sentence_of(g, values, described, tied, wheels, measured)
        if why:
            sentence = f"the log shows something no candidate describes, which acts like this: {sentence} ({'; '.join(why)})"
        out.append(Cause(parameters=g + tied, changed={n: (described[n], values[n]) for n in g}, tied=tied,
                         share=(without - rms_after) / gain if gain > 0 else 0.0,
                         gain_alone=1.0 - alone / rms_before if rms_before > 0 else 0.0,
                         sentence=sentence, implausible=why))
    out.sort(key=lambda c: -c.share)
    return out


def share_words(share: float) -> str:
    """A cause's share in words. Above 100 %: without it the other changes leave the robot worse than
    described (they compensate for it), which a percentage above 100 says less plainly."""
    if share > 1.0:
        return "without it the other changes are worse than the description"
    return f"{100 * share:.0f} % of the improvement"


def alone_words(gain_alone: float) -> str:
    """What a cause does alone, in words: a negative gain (the change helps only together with the
    others) said as such, not as a negative share removed."""
    if gain_alone >= 0:
        return f"alone it removes {100 * gain_alone:.0f} % of the error"
    return f"alone it raises the error by {-100 * gain_alone:.0f} %: it helps only with the other changes"


def summary(causes: list[Cause], rms: tuple[float, float], *, where: str, yaw: tuple[float, float] | None,
            undetermined: list[str] | None = None, unsettled: dict[str, str] | None = None,
            unsettled_implausible: dict[str, tuple[str, str]] | None = None,
            sent_back: list[str] | None = None) -> str:
    """The calibration's one-paragraph conclusion, from its measured causes (``undetermined``: the
    candidates the log does not determine; ``unsettled``: name -> the value, in words, the log points
    at for the candidates the fit's rounds did not reach, which kept their described values;
    ``unsettled_implausible``: name -> (that value in words, why it cannot be the robot's,
    :func:`implausibility`) for such candidates whose value would not be plausible: said, never as
    something the log points at; ``sent_back``: fitted candidates the last decision would have sent
    back to their described values when the rounds ran out, whose values are the last fit's)."""
    text = _summary(causes, rms, where=where, yaw=yaw, undetermined=undetermined)
    if unsettled:
        text += (" The log also points at " + ", ".join(f"{n} {v}" for n, v in unsettled.items())
                 + f", which the fit did not reach within its rounds ({ROUNDS_HINT}): "
                 + ("it keeps its described value" if len(unsettled) == 1 else "they keep their described values")
                 + ", which the log does not confirm.")
    for n, (v, why) in (unsettled_implausible or {}).items():
        text += (f" The log also moves {n} towards {v}, which the fit did not reach within its rounds and which "
                 f"cannot be the robot's ({why}): not a cause; it keeps its described value.")
    if sent_back:
        text += (f" The fit's rounds ran out before its decisions settled: the last decision would send "
                 f"{', '.join(sent_back)} back to "
                 f"{'its described value' if len(sent_back) == 1 else 'their described values'} ({ROUNDS_HINT}); "
                 "the values given are the last fit's.")
    return text


def _summary(causes: list[Cause], rms: tuple[float, float], *, where: str, yaw: tuple[float, float] | None,
             undetermined: list[str] | None) -> str:
    before, after = rms
    if not causes and undetermined:
        text = (f"Nothing the log determines needs to change. It does not determine {', '.join(undetermined)}: "
                "they keep their described values, and calibration cannot say whether they are right")
        if yaw is not None and all(np.isfinite(yaw)):
            text += f" (steady-turn yaw ratio: measured {yaw[0]:.2f}, described robot {yaw[1]:.2f})"
        return text + (f". {where.capitalize()} 2 s position error {before:.3g} m; what remains of it has causes "
                       "this log cannot attribute to them.")
    if not causes:
        return (f"Nothing needs to change: the described robot predicts this log within what the log determines "
                f"({where} 2 s position error {before:.3g} m); no parameter differs from its description by more "
                "than its interval.")
    first = causes[0]
    if after >= before or (first.share <= 0 and first.gain_alone <= 0):
        # the fit moved something, but nothing it moved lowers the error: no candidate is the cause
        return (f"No candidate explains the error: calibration changed "
                f"{', '.join(p for c in causes for p in c.changed)} ({first.sentence}), but the {where} 2 s "
                f"position error went from {before:.3g} m to {after:.3g} m. The simulation errs for a reason none "
                "of the candidates describes; do not read the changed values as the robot's.")
    named = [c for c in causes if c.plausible]
    unexplained = [c for c in causes if not c.plausible and c.share >= 0.1]
    if named and (named[0].share > 0 or named[0].gain_alone > 0):
        first = named[0]
        text = f"The described MuJoCo robot erred mostly because {first.sentence}"
        text += f" ({share_words(first.share)}; {alone_words(first.gain_alone)})"
        more = [c for c in named[1:] if c.share >= 0.1]
        if more:
            text += "; also " + "; ".join(f"{c.sentence} ({share_words(c.share)})" for c in more)
        if unexplained:
            text += ". Besides, " + "; ".join(f"{c.sentence} ({share_words(c.share)})" for c in unexplained)
    else:
        text = ("No candidate the fit moved plausibly explains the error: "
                + "; ".join(f"{c.sentence} ({share_words(c.share)})" for c in (unexplained or causes[:1]))
                + ". Do not read these values as the robot's")
    if yaw is not None and all(np.isfinite(yaw)):
        text += f". Steady-turn yaw ratio: measured {yaw[0]:.2f}, described robot {yaw[1]:.2f}"
    return text + f". {where.capitalize()} 2 s position error {before:.3g} m before, {after:.3g} m after calibration."


#: a calibrated robot whose simulated track speeds are this much (relative RMS) further from the
#: measured ones than the described robot's contradicts them (below: the simulator's own rounding)
SPEED_WORSE = 0.005
#: commands reaching this many times the largest measured track speed show drives that saturate
SATURATED = 1.2


def not_explained(causes: list[Cause], speeds: dict | None = None) -> list[dict]:
    """What the log shows that no candidate describes (calibration.json ``not_explained``): each
    implausible cause (``acts_like``: its sentence; ``why``: why its values are not the robot's;
    ``share``), and, from ``speeds`` (:meth:`mjtrack.calibrate.result.Calibration.simulated_wheel_speeds`),
    a calibrated robot whose simulated track speeds are further from the measured than the
    described robot's."""
    out = [{"what": "a change no candidate describes", "parameters": c.parameters, "acts_like": c.sentence,
            "why": c.implausible, "share": c.share} for c in causes if not c.plausible]
    worse = speeds_worse(speeds)
    if worse:
        out.append({"what": "simulated track speeds further from the measured after calibration",
                    "parameters": [], "acts_like": worse, "why": [], "share": None})
    return out


#: a calibrated robot whose steady-turn yaw ratio is this far from the measured one in a turn class
#: does not turn as the log does there (a 2 s turn then ends 3 % of its nominal rotation off)
YAW_CLASS_GAP = 0.03
#: steady turns a class needs before its yaw ratio is held against the calibrated robot's
YAW_CLASS_MIN = 10


def yaw_class_gaps(findings: list[dict]) -> str:
    """The sentence saying in which |turn ratio| classes (with at least :data:`YAW_CLASS_MIN`
    steady turns, on the test part when there is one) the calibrated robot's steady-turn yaw ratio
    is more than :data:`YAW_CLASS_GAP` from the measured one, else ""."""
    rows = [f for f in findings if "turn_class" in f and f["what"].startswith("yaw ratio")]
    part = "test" if any(f["part"] == "test" for f in rows) else "train"
    off = [f for f in rows if f["part"] == part and f["windows"] >= YAW_CLASS_MIN
           and f["simulated_after"] is not None and f["measured"] is not None
           and abs(f["simulated_after"] - f["measured"]) > YAW_CLASS_GAP]  # null: no steady turn simulated there
    if not off:
        return ""
    each = "; ".join(f"|turn ratio| {f['turn_class'][0]:g} to {f['turn_class'][1]:g}: measured {f['measured']:.3f}, "
                     f"calibrated {f['simulated_after']:.3f} over {f['windows']} steady turns" for f in off)
    # not "no candidate can": the turn stage (mjtrack.calibrate.turns) may have found values that turn
    # as the training windows do and been refused, or the test windows may turn otherwise
    return (f"the calibrated robot turns unlike the log in a turn class "
            f"({part} windows; {each}; more than {YAW_CLASS_GAP:g} apart)")


def speeds_worse(speeds: dict | None) -> str:
    """The sentence saying the calibrated robot's simulated track speeds are further from the
    measured than the described robot's (by more than :data:`SPEED_WORSE`), else ""."""
    if not speeds:
        return ""
    part = "test" if "test" in speeds else "train"
    b, a = speeds[part]["before"], speeds[part]["after"]
    rb, ra = math.hypot(b["left"], b["right"]), math.hypot(a["left"], a["right"])
    if not ra > rb * (1.0 + SPEED_WORSE):
        return ""
    return (f"the calibrated robot's simulated track speeds are further from the measured ones than the described "
            f"robot's ({part} windows, RMS left / right {b['left']:.3g} / {b['right']:.3g} m/s before, "
            f"{a['left']:.3g} / {a['right']:.3g} m/s after): its drivetrain contradicts the measured speeds")


def saturation_words(command_peak: tuple[float, float], measured_peak: tuple[float, float],
                     limits: tuple[float | None, float | None] = (None, None),
                     scale: tuple[float, float] = (1.0, 1.0)) -> str:
    """The drives' saturation in words, from the largest |command| and |measured speed| of each
    side [m/s] (the measurement that shows it), the speed limits fitted to the measured speeds
    where there are, and the measured over commanded speed the lower commands show (``scale``: a
    robot whose tracks run at 0.8 of every command does not saturate); "" when the commands, so
    scaled, stay within :data:`SATURATED` times the largest measured speeds."""
    if not any(k * c > SATURATED * m for k, c, m in zip(scale, command_peak, measured_peak)):
        return ""
    text = (f"its drives saturate: the measured track speeds never exceed {measured_peak[0]:.3g} / "
            f"{measured_peak[1]:.3g} m/s (left / right) while the commands reach {command_peak[0]:.3g} / "
            f"{command_peak[1]:.3g} m/s")
    if any(abs(k - 1.0) > 0.05 for k in scale):
        text += f" (lower commands give {scale[0]:.2g} / {scale[1]:.2g} times their speed)"
    if all(v is not None for v in limits):
        text += f"; fitted speed limits {limits[0]:.3g} / {limits[1]:.3g} m/s"
    return text


def cap_words(what: str, command_peak: float, measured_peak: float, scale: float = 1.0,
              limit: float | None = None) -> str:
    """A speed controller's cap on one combination of the two sides (``what``: "the turn", the
    half difference of the track speeds, or "the mean speed") in words, from the largest |command|
    and |measured| value of it [m/s], the measured over commanded value the lower commands show
    and the limit fitted to the measured speeds where there is one; "" when the commands, so
    scaled, stay within :data:`SATURATED` times the largest measured value."""
    if not scale * command_peak > SATURATED * measured_peak:
        return ""
    quantity = "half difference of the track speeds" if what == "the turn" else "mean of the track speeds"
    text = f"its speed controller caps {what}: the measured {quantity} never exceeds {measured_peak:.3g} m/s"
    if abs(scale - 1.0) > 0.05:
        text += (f", where the commands' peak, {command_peak:.3g} m/s, at the {scale:.2g} times theirs that lower "
                 f"commands give, asks for {scale * command_peak:.3g} m/s")
    else:
        text += f" while the commands' reaches {command_peak:.3g} m/s"
    if limit is not None:
        text += f"; fitted limit {limit:.3g} m/s"
    return text


__all__ = ["COUPLED", "GEOMETRY_RATIO", "SATURATED", "SPEED_WORSE", "YAW_CLASS_GAP", "YAW_CLASS_MIN", "Cause", "cap_words",
           "find_causes", "groups", "implausibility", "not_explained", "on_bound", "saturation_words", "speeds_worse", "summary",
           "traction_defaults", "traction_limit", "yaw_class_gaps"]
