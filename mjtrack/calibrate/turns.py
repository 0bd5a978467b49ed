"""Turning as the log does: the steady turns set what the end poses leave free.

The windowed fit (:mod:`mjtrack.calibrate.fit`) minimises the error of every window's poses. On a
real log its answer can predict the end poses well and still turn unlike the robot: on the shared
Husky log the pose fit's robot turns gently less than the log does, while a robot with another
wheelbase, shear ground and motion resistance fits the training windows' end poses about as well
and turns as the log does in every class (the results page "Calibration"): the end poses leave that
direction free; the steady turns do not.

So when the fitted robot's steady-turn yaw ratio is more than
:data:`mjtrack.calibrate.causes.YAW_CLASS_GAP` from the measured one in a turn class of the
training windows (at least :data:`mjtrack.calibrate.causes.YAW_CLASS_MIN` steady turns), the
*turn candidates* (:func:`turn_candidates`: the contact length or wheelbase, the motion resistance,
the shear ground's modulus and its across / along ratio, those the calibration may move) are
fitted by least squares to the training part's steady-turn measures -- the yaw ratio and the
forward speed ratio of every class with enough steady turns
(:func:`mjtrack.calibrate.measures.turn_measures`) -- from the fitted values, the other parameters
held at theirs. Those other values were found for the contact the pose fit left; so, before the
two robots are compared, the parameters the pose fit changed are fitted again to the end poses with
the turn candidates held (the ``refit`` of :func:`match_turns`, from where they are), and the turn
candidates once more from there. The robot judged is that one, or the first turn-matched robot when
that one is refused and the first is not. The answer replaces the fitted values only when

* it turns as the log does: every such class's yaw ratio within the gap;
* no turn candidate ends on a bound of its range, and no more windows diverge;
* the data speak less against it than against the fit's robot. Each robot is judged by both
  kinds of evidence the training part holds, each in the units of its own scatter, and the two
  added (:func:`evidence`): the steady turns, by the Wald statistic of its yaw classes' medians
  against the measured ones (their bootstrap covariance, the windows of one held command drawn
  together); the end poses, by the square of z, the mean over windows of (the turn-matched robot's
  squared end-position error minus the fit's) over its bootstrap standard deviation, counted
  against the robot it shows worse. Neither kind of evidence is preferred: a turn-matched robot
  the end poses show slightly worse is kept when the turns show the fit's robot far more clearly
  wrong, and refused when the end poses speak more strongly.

Otherwise the fitted values stand and the calibration says which condition failed. When both
robots are shown wrong -- the end poses against the turn-matched robot, the turns against the
fit's -- the end poses and the steady turns ask for different robots, which is what the log shows
that no candidate describes; the summary says so whichever robot is kept.

With a test log, the record also holds both robots' error on it (never fitted): what turning as the
log does costs or gains where the fit did not look.

The 95 % interval of each turn candidate comes from how far the classes' few windows move the
measures: the measured-minus-simulated class medians are bootstrapped over the windows (those of
one held command drawn together, :func:`mjtrack.calibrate.measures.command_runs`), and their
covariance is carried through the least-squares solution's Jacobian; added to it in quadrature, the
optimiser's part (its stopping tolerance :data:`TURN_XTOL`, and how far the classes' mismatch left
at the answer would move each value).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable

import numpy as np

from mjtrack.calibrate.causes import YAW_CLASS_GAP, YAW_CLASS_MIN
from mjtrack.calibrate.measures import command_runs, gap_replicates, measured_speeds, steady_mask, turn_measures
from mjtrack.calibrate.params import EXTENDS_COULOMB, RESISTANCE_START, SHEAR_START, ParamSpec, geometry_name
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import Robot
from mjtrack.windows import WindowSet, commanded_log, measured_window_poses

if TYPE_CHECKING:  # MuJoCo is loaded by the functions that simulate, not by importing calibrate
    from mjtrack.sim.windows import WindowSim

#: least-squares evaluations of the turn fit, each one pass over the training part's steady windows
TURN_EVALS = 40
#: bootstrap replicates of the class medians behind the turn candidates' intervals
TURN_BOOT = 400
#: relative finite-difference step of the turn fit: the class medians move in steps as windows
#: cross one another, so the step must span several of them
TURN_STEP = 0.03
#: the turn fit stops when a step moves no value by more than this share of it: each interval
#: holds that much besides the classes' scatter (the optimiser's part)
TURN_XTOL = 1e-3
#: each refusal of the turn stage in a few words
REFUSED = {"turns": "it does not turn as the log does", "bound": "a turn candidate on a bound of its range",
           "diverges": "more training windows diverge",
           "end_poses": "the end poses speak more against it than the steady turns against the fit's robot"}


def turn_candidates(names: list[str], robot: Robot) -> list[str]:
    """The parameters the turn stage may set: of ``names``, the contact length / wheelbase, the
    motion resistance and the shear modulus, and with the modulus the shear ground's across / along
    ratio (its second parameter: a ratio that only a named modulus lets act)."""
    out = [n for n in (geometry_name(robot), "rolling_resistance", "shear_modulus") if n in names]
    shear_ok = robot.ground.model in ("shear", EXTENDS_COULOMB["shear_modulus"])
    if "shear_modulus" in out and shear_ok:
        out.append("lateral_shear_ratio")
    elif "shear_modulus" in out:
        out.remove("shear_modulus")
    return out


@dataclass
class TurnClasses:
    """The steady-turn measures the turn stage fits: (kind, lo, hi) per class, ``kind`` "yaw" or
    "forward", and the measured values of the training part."""

    classes: list[tuple[str, float, float]]
    measured: np.ndarray

    @property
    def labels(self) -> list[str]:
        return [f"{'yaw ratio' if k == 'yaw' else 'forward speed ratio'} (|turn ratio| {lo:g} to {hi:g})"
                for k, lo, hi in self.classes]

    def yaw(self) -> np.ndarray:
        return np.array([k == "yaw" for k, _, _ in self.classes])


def _values(tm: dict, classes) -> tuple[np.ndarray, list]:
    """The class medians of ``turn_measures`` output, and each class's (windows, values) samples."""
    out, samples = [], []
    for kind, lo, hi in classes:
        got = tm["yaw_ratio_by_class" if kind == "yaw" else "speed_ratio"].get((lo, hi))
        out.append(np.nan if got is None else got[0])
        samples.append(tm["yaw_ratio_samples" if kind == "yaw" else "speed_ratio_samples"].get((lo, hi)))
    return np.array(out, float), samples


def turn_classes(lg: DriveLog, ws: WindowSet, robot: Robot) -> TurnClasses | None:
    """The classes of ``ws`` with at least YAW_CLASS_MIN steady turns (yaw ratio) or steady windows
    (forward speed ratio); None without one yaw class."""
    tm = turn_measures(lg, ws, robot, measured_window_poses(lg, ws), measured_speeds(lg, ws))
    classes = ([("yaw", lo, hi) for (lo, hi), (_, n) in tm["yaw_ratio_by_class"].items() if n >= YAW_CLASS_MIN]
               + [("forward", lo, hi) for (lo, hi), (_, n) in tm["speed_ratio"].items() if n >= YAW_CLASS_MIN])
    if not any(k == "yaw" for k, _, _ in classes):
        return None
    return TurnClasses(classes, _values(tm, classes)[0])


@dataclass
class TurnMatch:
    """The turn stage's record (calibration.json ``turns``)."""

    names: list[str]
    labels: list[str]
    measured: list[float]
    fitted: list[float]  # the pose fit's robot
    start: dict[str, float]
    values: dict[str, float] = field(default_factory=dict)
    matched: list[float] = field(default_factory=list)
    intervals: dict[str, tuple[float, float]] = field(default_factory=dict)
    train_rms: tuple[float, float] | None = None  # (the pose fit's, the turn-matched robot's) [m]
    test_rms: tuple[float, float] | None = None  # the same on the test log when there is one (never fitted)
    #: 95 % interval [m^2] of the mean over training windows of the turn-matched robot's squared end
    #: error minus the fit's (windows of one held command drawn together)
    mse_gap_interval: tuple[float, float] | None = None
    on_bound: list[str] = field(default_factory=list)
    evaluations: int = 0
    accepted: bool = False
    why: str = ""
    #: the condition that refused it, in one word: "turns" (no value turns as the log does),
    #: "bound", "diverges" or "end_poses"; None when accepted
    refused_by: str | None = None
    #: the other candidates fitted again to the end poses with the turn candidates held, and the
    #: turn candidates fitted once more from there (None when that did not run); ``kept``: whether
    #: that robot is the one judged above
    refit: dict | None = None
    #: how strongly the data speak against each robot (:func:`evidence`; None when not weighed)
    evidence: dict | None = None
    #: the window parameters of the robot judged above (the fit's others, or the refitted ones)
    params: dict = field(default_factory=dict, repr=False)

    def sentence(self) -> str:
        """The turn stage in words, for the summary."""
        off = "; ".join(f"{lab.removeprefix('yaw ratio (').removesuffix(')')}: measured {m:.3f}, fitted {f:.3f}"
                        for lab, m, f in zip(self.labels, self.measured, self.fitted)
                        if lab.startswith("yaw ratio") and not abs(m - f) <= YAW_CLASS_GAP)
        head = (f" The fit's robot turned unlike the log in the training part's steady turns ({off}); the turn "
                f"candidates ({', '.join(self.names)}) were fitted to its steady turns")
        if self.refit is not None:
            head += (", the other candidates fitted again to the end poses with them held, and the turn candidates "
                     "once more from there")
            if not self.refit["kept"]:
                why = (f"the refit put {', '.join(self.refit['on_bound'])} on a bound of its range"
                       if self.refit["on_bound"] else REFUSED[self.refit["refused_by"]])
                head += f" (that robot was refused: {why}; the first one is judged)"
        if not self.accepted:
            return head + f", and the fit's values stand: {self.why}."
        vals = ", ".join(f"{n} {self.values[n]:.3g}" for n in self.names)
        also = " with the refitted values of the others" if self.refit is not None and self.refit["kept"] else ""
        price = ("" if self.test_rms is None else f" On the test windows, never fitted, the fit's robot erred "
                 f"{self.test_rms[0]:.3g} m, the one that turns as the log does {self.test_rms[1]:.3g} m.")
        return head + f": {vals}, which replace the fit's{also}: {self.why}." + price

    def to_json(self) -> dict:
        return {"candidates": list(self.names), "classes": list(self.labels), "measured": list(self.measured),
                "fitted": list(self.fitted), "start": dict(self.start), "values": dict(self.values),
                "turn_matched": list(self.matched),
                "intervals": {n: list(v) for n, v in self.intervals.items()},
                "train_rms_m": None if self.train_rms is None else {"fitted": self.train_rms[0],
                                                                    "turn_matched": self.train_rms[1]},
                "train_mse_gap_interval_m2": None if self.mse_gap_interval is None else list(self.mse_gap_interval),
                "test_rms_m": None if self.test_rms is None else {"fitted": self.test_rms[0],
                                                                  "turn_matched": self.test_rms[1]},
                "on_bound": list(self.on_bound), "evaluations": int(self.evaluations), "accepted": bool(self.accepted),
                "why": self.why, "refused_by": self.refused_by, "refit": self.refit, "evidence": self.evidence,
                "definition": "the turn candidates fitted to the training part's steady-turn measures when the pose "
                              "fit's robot turns unlike the log; accepted when it turns as the log does and the "
                              "training part's steady turns and end poses together speak less against it than "
                              "against the fit's robot (mjtrack.calibrate.turns)"}


def _gap_cov(meas_samples, sim_samples, groups: np.ndarray, n_boot: int = TURN_BOOT, seed: int = 0) -> np.ndarray:
    """Bootstrap covariance (C, C) of the classes' measured-minus-simulated medians
    (:func:`mjtrack.calibrate.measures.gap_replicates`, the windows of one label drawn together)."""
    out = gap_replicates(list(zip(meas_samples, sim_samples)), groups=groups, n_boot=n_boot, seed=seed)
    ok = np.all(np.isfinite(out), axis=1)
    return np.cov(out[ok].T) if ok.sum() > 2 else np.full((len(meas_samples),) * 2, np.nan)


def _mse_gap_means(a: np.ndarray, b: np.ndarray, groups: np.ndarray, n_boot: int = TURN_BOOT,
                   seed: int = 0) -> np.ndarray:
    """Bootstrap replicates (n_boot,) of mean(a^2 - b^2) over windows, two robots' end errors (M,)
    of the same windows, the windows of one label of ``groups`` (M,) drawn together."""
    d = a ** 2 - b ** 2
    label = np.unique(np.asarray(groups), return_inverse=True)[1].ravel()
    n = int(label.max()) + 1
    sums, counts = np.bincount(label, d, n), np.bincount(label, minlength=n).astype(float)
    draws = np.random.default_rng(seed).multinomial(n, np.full(n, 1.0 / n), size=n_boot)
    return (draws @ sums) / (draws @ counts)


def _percentile_interval(means: np.ndarray, level: float = 0.95) -> tuple[float, float]:
    """The percentile interval of bootstrap replicates at ``level``."""
    lo, hi = np.percentile(means, [50 * (1 - level), 50 * (1 + level)])
    return float(lo), float(hi)


def _mse_gap_interval(a: np.ndarray, b: np.ndarray, groups: np.ndarray, level: float = 0.95,
                      n_boot: int = TURN_BOOT, seed: int = 0) -> tuple[float, float]:
    """Percentile bootstrap interval of mean(a^2 - b^2) over windows (:func:`_mse_gap_means`)."""
    return _percentile_interval(_mse_gap_means(a, b, groups, n_boot, seed), level)


def turn_wald(gap: np.ndarray, cov: np.ndarray) -> float:
    """How strongly the steady turns speak against a robot: gap' cov^-1 gap, its classes' measured
    minus simulated medians ``gap`` (C,) with their covariance ``cov`` (C, C) (a pseudo-inverse where
    classes share windows); NaN when either is not finite."""
    gap, cov = np.asarray(gap, float), np.asarray(cov, float)
    if gap.size == 0 or not (np.all(np.isfinite(gap)) and np.all(np.isfinite(cov))):
        return math.nan
    return float(gap @ np.linalg.pinv(cov) @ gap)


def evidence(turns_fit: float, turns_matched: float, z: float) -> tuple[float, float]:
    """The evidence against (the fit's robot, the turn-matched robot): each one's Wald statistic of
    the steady turns plus z^2 of the end poses where they show it the worse one (``z``: the mean
    squared end-error difference, turn-matched minus fit's, over its bootstrap standard deviation;
    +inf when every draw shows the turn-matched robot worse by the same amount). Two statistics in
    the units of their own scatter, added as independent chi-square terms: the steady windows are
    among those whose end poses are scored, which this sum counts twice."""
    return turns_fit + max(-z, 0.0) ** 2, turns_matched + max(z, 0.0) ** 2


def _gap_z(means: np.ndarray) -> float:
    """z of the bootstrap replicates of a mean difference: their mean over their standard deviation."""
    m, sd = float(np.mean(means)), float(np.std(means, ddof=1))
    if sd > 0.0:
        return m / sd
    return 0.0 if m == 0.0 else math.copysign(math.inf, m)


@dataclass
class _Outcome:
    """One robot the turn stage tried: the window parameters it starts from (``base``), the turn
    candidates' values fitted there, and how it fares (:func:`_judge`)."""

    base: dict[str, float]
    values: dict[str, float]
    matched: np.ndarray
    intervals: dict[str, tuple[float, float]]
    on_bound: list[str]
    evaluations: int
    jac: np.ndarray | None = None  # of the class measures in the turn candidates, at the answer
    train_rms: tuple[float, float] = (math.nan, math.nan)
    gap: tuple[float, float] = (math.nan, math.nan)
    wald: float = math.nan  # how strongly the steady turns speak against it (:func:`turn_wald`)
    evidence: dict | None = None
    refused_by: str | None = None
    why: str = ""

    @property
    def params(self) -> dict[str, float]:
        return {**self.base, **self.values}

    def record(self) -> dict:
        """Its values and how it fared, as ``method.turns.refit`` holds them."""
        return {"values": dict(self.values), "train_rms_m": self.train_rms[1],
                "train_mse_gap_interval_m2": list(self.gap), "evidence": self.evidence, "refused_by": self.refused_by}


def match_turns(sim: WindowSim, train: DriveLog, ws: WindowSet, robot: Robot, fitted: dict[str, float],
                names: list[str], specs: dict[str, ParamSpec], *, fitted_errors: np.ndarray, fitted_diverged: int,
                fitted_poses: np.ndarray, fitted_speeds: np.ndarray, nthread: int, warmup_s: float,
                score: Callable[[dict[str, float]], tuple[np.ndarray, int]],
                refit: Callable[[dict[str, float]], tuple[dict[str, float], list[str]] | None] | None = None,
                progress: Callable[[int], None] | None = None) -> TurnMatch | None:
    """The turn stage (module docstring) on the training windows ``ws`` of ``train``.

    Args:
        sim: the window simulator (built with the contact frames when ``lateral_shear_ratio`` is
            among ``names``).
        fitted: the pose fit's window parameters (:func:`mjtrack.calibrate.params.window_params`).
        names: the turn candidates (:func:`turn_candidates`).
        fitted_errors, fitted_diverged: the pose fit's end-position error [m] of every training
            window (M,) and its diverged windows.
        fitted_poses, fitted_speeds: its simulated poses and speeds of every training window.
        score: window parameters -> (end-position error of every training window (M,) [m], diverged windows).
        refit: the turn candidates' values -> (the window parameters of the other candidates fitted
            again to the end poses with those held, the refitted values that ended on a bound of
            their range where the fit's did not: that robot is then refused), or None when there is
            nothing to refit; without it the other parameters stay at the pose fit's values.
        progress: called with the windows simulated after each pass.

    Returns None when no class has enough steady turns or the fitted robot already turns as the
    log does in every class; else the record, ``accepted`` saying whether its values replace the fit's.
    """
    tc = turn_classes(train, ws, robot)
    if tc is None or not names:
        return None
    fit_now, _ = _values(turn_measures(train, ws, robot, fitted_poses, fitted_speeds), tc.classes)
    gaps = np.abs(fit_now - tc.measured)[tc.yaw()]
    if np.all(np.isfinite(gaps) & (gaps <= YAW_CLASS_GAP)):
        return None
    steady_idx = np.flatnonzero(steady_mask(commanded_log(train), ws))
    steady = ws.subset(steady_idx)
    own = dict(robot.ground.params) if robot.ground.model == "shear" else {}
    first = {n: fitted.get(n) for n in names}
    first[geometry_name(robot)] = fitted.get(geometry_name(robot), getattr(robot, geometry_name(robot)))
    if "rolling_resistance" in names:
        first["rolling_resistance"] = max(fitted.get("rolling_resistance") or robot.rolling_resistance, RESISTANCE_START)
    if "shear_modulus" in names:
        first["shear_modulus"] = fitted.get("shear_modulus") or own.get("shear_modulus") or SHEAR_START
        first["lateral_shear_ratio"] = fitted.get("lateral_shear_ratio") or own.get("lateral_shear_ratio", 1.0)
    lo = np.array([specs[n].lo for n in names])
    hi = np.array([specs[n].hi for n in names])
    x0 = np.clip(np.array([float(first[n]) for n in names]), lo, hi)
    rec = TurnMatch(names=list(names), labels=tc.labels, measured=[float(v) for v in tc.measured],
                    fitted=[float(v) for v in fit_now], start=dict(zip(names, map(float, x0))))
    meas_tm = turn_measures(train, steady, robot, measured_window_poses(train, steady), measured_speeds(train, steady))
    meas_samples = _values(meas_tm, tc.classes)[1]
    fitted_errors = np.asarray(fitted_errors, float)
    runs = command_runs(train, ws)
    # how strongly the steady turns speak against the fit's robot, on the same windows as the others'
    yaw = tc.yaw()
    fit_medians, fit_samples = _values(turn_measures(train, steady, robot, np.asarray(fitted_poses)[steady_idx],
                                                     np.asarray(fitted_speeds)[steady_idx]), tc.classes)
    fit_cov = _gap_cov(meas_samples, fit_samples, command_runs(train, steady))
    fit_wald = turn_wald((tc.measured - fit_medians)[yaw], fit_cov[np.ix_(yaw, yaw)])

    def turn_fit(base: dict[str, float], x_start: np.ndarray, jac: np.ndarray | None = None) -> _Outcome:
        """The turn candidates fitted to the steady turns from ``x_start``, the others at ``base``
        (``jac``: the Jacobian to use throughout instead of finite differences)."""
        from scipy.optimize import least_squares

        from mjtrack.sim.windows import simulate_windows

        seen: dict[bytes, tuple[np.ndarray, list]] = {}

        def measures(x: np.ndarray) -> tuple[np.ndarray, list]:
            key = np.asarray(x, float).tobytes()
            if key not in seen:  # the optimiser's last point is measured again for its samples
                res = simulate_windows(sim, train, steady, [{**base, **dict(zip(names, map(float, x)))}],
                                       nthread=nthread, warmup_s=warmup_s)
                if progress is not None:
                    progress(len(steady))
                if len(seen) >= 8:
                    seen.pop(next(iter(seen)))
                seen[key] = _values(turn_measures(train, steady, robot, res.poses[0], res.speeds[0]), tc.classes)
            return seen[key]

        def residual(x: np.ndarray) -> np.ndarray:
            r = measures(x)[0] - tc.measured
            return np.where(np.isfinite(r), r, 1.0)  # a class with no steady turn simulated: far off

        how = dict(diff_step=TURN_STEP) if jac is None else dict(jac=lambda x: jac)
        sol = least_squares(residual, x_start, bounds=(lo, hi), x_scale="jac", max_nfev=TURN_EVALS,
                            xtol=TURN_XTOL, **how)
        values = dict(zip(names, map(float, sol.x)))
        matched, sim_samples = measures(sol.x)
        out = _Outcome(base=dict(base), values=values, matched=matched, intervals={}, evaluations=int(sol.nfev),
                       on_bound=[n for n in names
                                 if min(values[n] - specs[n].lo, specs[n].hi - values[n]) <= 1e-3 * specs[n].scale])
        # intervals: the class medians' bootstrap covariance through the solution's Jacobian
        cov = _gap_cov(meas_samples, sim_samples, command_runs(train, steady))
        J = out.jac = np.asarray(sol.jac, float)
        out.wald = turn_wald((tc.measured - matched)[yaw], cov[np.ix_(yaw, yaw)])
        if np.all(np.isfinite(cov)) and np.all(np.isfinite(J)):
            P = np.linalg.pinv(J)
            stat = 1.96 * np.sqrt(np.clip(np.diag(P @ cov @ P.T), 0.0, None))
            # the optimiser's part: its stopping tolerance, and how far the mismatch left would move each value
            opt = TURN_XTOL * np.abs(sol.x) + np.abs(P @ sol.fun)
            half = np.hypot(stat, opt)
            out.intervals = {n: (max(values[n] - h, specs[n].lo), min(values[n] + h, specs[n].hi))
                             for n, h in zip(names, half)}
        _judge(out, tc, score, fitted_errors, fitted_diverged, runs, fit_wald)
        return out

    plain = turn_fit(dict(fitted), x0)
    chosen, again = plain, None
    got = refit(plain.values) if refit is not None and plain.refused_by in (None, "end_poses") else None
    if got is not None:
        base, bound = got
        if not bound:
            # the turn candidates once more, from where they were; the others moved a little, so the
            # first fit's Jacobian stands in for finite differences at every step
            again = turn_fit(base, np.array([plain.values[n] for n in names]),
                             jac=plain.jac if np.all(np.isfinite(plain.jac)) else None)
            if again.refused_by is None or plain.refused_by is not None:
                chosen = again
        mine = (again.record() if again is not None else  # refused for its bounds before the turns were fitted
                {"values": None, "train_rms_m": None, "train_mse_gap_interval_m2": None, "refused_by": "bound"})
        rec.refit = {"base": {k: float(v) for k, v in base.items()}, "kept": chosen is again, "on_bound": list(bound),
                     **mine, "plain": plain.record()}
    rec.values, rec.matched, rec.intervals = chosen.values, [float(v) for v in chosen.matched], chosen.intervals
    rec.on_bound, rec.train_rms, rec.mse_gap_interval = chosen.on_bound, chosen.train_rms, chosen.gap
    rec.evaluations = plain.evaluations + (0 if again is None else again.evaluations)
    rec.accepted, rec.refused_by, rec.why = chosen.refused_by is None, chosen.refused_by, chosen.why
    rec.evidence = chosen.evidence
    rec.params = chosen.params
    return rec


def _judge(out: _Outcome, tc: TurnClasses, score, fitted_errors: np.ndarray, fitted_diverged: int,
           runs: np.ndarray, fit_wald: float) -> None:
    """Score the robot of ``out`` on every training window and decide (module docstring): it
    replaces the fit's robot when it turns as the log does, no value is on a bound, no more windows
    diverge and the data speak less against it than against the fit's robot (``fit_wald``: the
    steady turns' Wald statistic of the fit's robot)."""
    errors, diverged = score(out.params)
    errors = np.asarray(errors, float)
    fitted_rms, rms = (float(np.sqrt(np.mean(e ** 2))) for e in (fitted_errors, errors))
    out.train_rms = (fitted_rms, rms)
    means = _mse_gap_means(errors, fitted_errors, runs)  # one set of draws: the interval and z
    gap = out.gap = _percentile_interval(means)
    z = _gap_z(means) if np.all(np.isfinite(means)) else math.inf
    against = evidence(fit_wald, out.wald, z)
    weighed = all(math.isfinite(v) for v in (fit_wald, out.wald))
    if weighed:
        out.evidence = {"chi2_fit": against[0], "chi2_turn_matched": against[1], "turns_wald_fit": fit_wald,
                        "turns_wald_turn_matched": out.wald, "end_poses_z": z,
                        "definition": "against each robot, the Wald statistic of its yaw classes' medians against "
                                      "the measured ones plus z^2 of the end poses where they show it the worse "
                                      "one (z: the turn-matched robot's mean squared end error minus the fit's over "
                                      "its bootstrap standard deviation)"}
    poses = (f"{rms:.4g} m against {fitted_rms:.4g} m; the mean squared error's difference lies in "
             f"[{gap[0]:.3g}, {gap[1]:.3g}] m^2")
    yaw_ok = bool(np.all(np.isfinite(out.matched[tc.yaw()])
                         & (np.abs(out.matched - tc.measured)[tc.yaw()] <= YAW_CLASS_GAP)))
    if not yaw_ok:
        out.refused_by = "turns"
        out.why = "no value of the turn candidates makes it turn as the log does in every class"
    elif out.on_bound:
        out.refused_by = "bound"
        out.why = f"turning as the log does takes {', '.join(out.on_bound)} to a bound of its range"
    elif diverged > fitted_diverged:
        out.refused_by = "diverges"
        out.why = f"the robot that turns as the log does diverges in {diverged - fitted_diverged} more training windows"
    elif not math.isfinite(rms) or (against[1] > against[0] if weighed else not gap[0] <= 0.0):
        out.refused_by = "end_poses"
        out.why = (f"the training windows' end poses show the fit's robot better ({poses})"
                   + (f", and speak more strongly against the robot that turns as the log does than the steady "
                      f"turns against the fit's (chi-square {against[1]:.3g} against {against[0]:.3g})"
                      if weighed else ""))
    elif not weighed or gap[0] <= 0.0:
        out.why = (f"it turns as the log does, and the training windows' end poses cannot tell it from the fit's "
                   f"robot or prefer it ({poses})")
    else:
        out.why = (f"it turns as the log does; the training windows' end poses show the fit's robot better "
                   f"({poses}), but the steady turns speak more strongly against the fit's robot (chi-square "
                   f"{against[0]:.3g} against {against[1]:.3g}): the end poses and the steady turns ask for "
                   f"different robots, and the one the data speak less against is kept")


__all__ = ["TURN_BOOT", "TURN_EVALS", "TURN_STEP", "TURN_XTOL", "TurnClasses", "TurnMatch", "evidence", "match_turns",
           "turn_candidates", "turn_classes", "turn_wald"]
