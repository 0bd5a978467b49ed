"""The fit of calibrate and its rounds of decisions: every candidate fitted from its start, then,
until it settles, what the log determines and needs changed decided again for every candidate
(:mod:`mjtrack.calibrate.identify`) and the kept ones fitted again; the model-form sources of the
fit's simulator measured where it ends (a finer simulator, a longer warm-up).

A decision that moves the point by less than the optimiser's own tolerance (:data:`REUSE_TOL`
of every kept parameter's half-width and of every parameter's resolution) from where the last
central-difference Jacobian was taken is not refitted: the residuals there are simulated once, the
Jacobian and the model-form sources are kept, and the decision stands when the Gauss-Newton step
left there is itself within the tolerance (:func:`near_decision`). A refit from such a point would
stop where it starts, and the change of the Jacobian over the move is second order in it.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from mjtrack.calibrate.identify import Linearised, ModelFormSource, Verdict, final_verdicts, fmt_value, select
from mjtrack.calibrate.params import specs_for, window_params
from mjtrack.io.logs import DriveLog
from mjtrack.sim.config import SimConfig
from mjtrack.windows import WindowSet

if TYPE_CHECKING:  # MuJoCo is loaded by the functions that simulate, not by importing calibrate
    from mjtrack.calibrate.fit import FitResult
    from mjtrack.sim.windows import WindowSim

log = logging.getLogger(__name__)

#: refits after the first fit, each after what the log determines was decided again (calibrate's
#: default ``rounds``; more let a fit that has not settled reach what the log points at, at the cost
#: of one refit each)
MAX_ROUNDS = 3
MAX_ROUNDS_LIMIT = 20  # the most a user may ask for
ROUNDS_HINT = "more rounds, --rounds, let it go further"  # said where the rounds ran out
#: refits of the guard's second attempt (after a blow-up on a window the fit did not use): it starts
#: from the first attempt's settled decision, which the added windows move only a little
GUARD_ROUNDS = 1
STEP_TOL = 0.25  # the fit has converged when the remaining Gauss-Newton step is below this share of every half-width
#: a decision whose point lies within this share of every kept parameter's half-width (and of every
#: parameter's resolution) of the point the last Jacobian was taken at keeps that Jacobian and its
#: model-form sources: the refit would start where the optimiser's own tolerance (STEP_TOL) already
#: ends it, and the Jacobian's change over such a step is second order (tests/test_calibrate_speed.py)
REUSE_TOL = STEP_TOL


#: passes over the fit windows that the model-form sources cost, in windows simulated (a finer
#: simulator and a longer warm-up; each counted once, though the finer one takes about twice as long)
MODEL_FORM_PASSES = 2


class Meter:
    """calibrate's progress on stderr (a TTY, unless quiet): windows simulated out of those
    expected, the stage and round as the bar's note, and once the robot as described is scored
    (its rate measured), a line saying how long the whole is expected to take."""

    def __init__(self, quiet: bool) -> None:
        from mjtrack.progress import Progress

        self.bar = Progress(total=None, label="calibrate", quiet=quiet)
        self.tail = 0  # windows expected after the fit (every training window, the test's, the causes')
        self.simulated = 0  # windows simulated so far, every stage (calibration.json method.simulated_windows)

    def windows(self, n: int) -> None:
        self.simulated += n
        self.bar.update(n)

    def stage(self, note: str, remaining: float | None = None) -> None:
        """Now in ``note``; ``remaining``: windows still expected from here on, all stages."""
        if remaining is not None:
            self.bar.total = self.bar.count + max(1, int(round(remaining)))
        self.bar.label = f"calibrate: {note}"  # first on the line: a narrow terminal cuts the end
        self.bar.redraw()  # every stage shown, however soon after the last redraw it starts

    def say(self, text: str) -> None:
        log.info(text)
        self.bar.say(text)

    def close(self) -> None:
        self.bar.close()


def expected_passes(n: int, starts: float, max_iter: int, refit_iter: int, rounds: int = 1) -> int:
    """Passes over the fit windows that the fit of ``n`` candidates is expected to take: the
    multi-start (``starts`` passes, :func:`mjtrack.calibrate.fit.multistart_passes`), the first fit
    (a forward difference, then about one pass per iteration and one rejected step in two,
    :class:`mjtrack.calibrate.fit.SecantJacobian`), the central differences at its end, the
    model-form sources, and ``rounds`` refits (:func:`round_passes`)."""
    first = int(round(starts)) + 2 + (n + 1) + int(1.5 * max_iter) + (2 * n + 1) + MODEL_FORM_PASSES
    return first + rounds * round_passes(n, refit_iter)


def round_passes(n: int, refit_iter: int) -> int:
    """Passes of one refit of a few (two) of ``n`` candidates: its start and forward difference,
    its iterations, the central differences of the refitted ones (one-sided for the others) and the
    model-form sources at its end."""
    return 2 + 2 + int(1.5 * refit_iter) + (n + 3) + MODEL_FORM_PASSES


def model_form_sources(obj, values: dict[str, float], resid: np.ndarray, jac: np.ndarray, config: SimConfig, *,
                       refine: bool = True) -> tuple[list[ModelFormSource], dict[str, float]]:
    """The model-form sources at ``values`` (the fit's residuals ``resid``, Jacobian ``jac``):

    * ``simulator``: the residuals of a finer simulator (time step halved, at least the default
      roller count) minus the fit's -- what the discretisation of the fit's robot costs;
    * ``warm_up``: the residuals with twice the warm-up of the hidden states minus the fit's -- what
      is left of the start state that the log does not hold.

    Returns the sources (g = J^T (r_other - r)) and each one's RMS residual change [m]."""
    from mjtrack.sim.windows import WindowSim

    robot = obj.sim.robot
    wp = window_params({**values, **obj.held}, robot)
    out, size = [], {}
    if refine:
        finer = config.replace(timestep=config.timestep / 2, n_rollers=max(config.n_rollers, SimConfig().n_rollers))
        r_fine = obj.residuals_of([wp], one=True, sim=WindowSim(robot, finer, resisted=obj.sim.resisted,
                                                                       framed=obj.sim.framed))
        out.append(ModelFormSource("simulator", jac.T @ (r_fine - resid)))
        size["simulator"] = float(np.sqrt(np.sum((r_fine - resid) ** 2)))
    if obj.warmup_s > 0:
        r_warm = obj.residuals_of([wp], one=True, warmup_s=2 * obj.warmup_s)
        out.append(ModelFormSource("warm_up", jac.T @ (r_warm - resid)))
        size["warm_up"] = float(np.sqrt(np.sum((r_warm - resid) ** 2)))
    return out, size


@dataclass
class Fitter:
    """The fit's settings and simulator (the fit and its rounds of decisions)."""

    sim: WindowSim
    train: DriveLog
    names: list[str]
    described: dict[str, float]
    config: SimConfig
    max_iter: int
    nthread: int
    warmup_s: float
    meter: Meter
    rounds: int = MAX_ROUNDS
    #: candidates whose value the description does not give (a default stands in for it)
    undescribed: tuple[str, ...] = ()
    #: parameters held at these values besides ``names`` (:attr:`mjtrack.calibrate.fit.Objective.held`)
    held: dict[str, float] = field(default_factory=dict)
    specs: dict = field(init=False)
    floors: dict[str, float] = field(init=False)

    def __post_init__(self) -> None:
        self.specs = specs_for(self.sim.robot)
        self.floors = {n: self.sim.dt for n in ("drive_lag", "drive_delay")}  # timing is resolved to one step at best

    @property
    def refit_iter(self) -> int:
        return max(3, self.max_iter // 2)

    def objective(self, fws: WindowSet, names: list[str]):
        from mjtrack.calibrate.fit import objective

        return objective(self.sim, self.train, fws, names, nthread=self.nthread, warmup_s=self.warmup_s,
                         progress=self.meter.windows, held=self.held)

    def scaled(self, point: dict[str, float]) -> np.ndarray:
        return np.array([point[n] / self.specs[n].scale for n in self.names])

    def linearised(self, obj, theta, jac, resid, sources, names=None) -> Linearised:
        return Linearised(names=list(self.names if names is None else names), theta=theta, jac=jac, resid=resid,
                          rows_per_window=obj.rows_per_window, specs=self.specs, model_form=sources,
                          floors=self.floors)


@dataclass
class Fitted:
    """One attempt of the fit: the first fit, the verdicts of every candidate, the values, the
    final linearisation of the kept parameters and their uncertainty."""

    result: FitResult
    refit: FitResult | None
    verdicts: dict[str, Verdict]
    values: dict[str, float]
    model_form: dict
    u: object
    lin: Linearised | None
    ties: dict[str, list[str]]
    fws: WindowSet


@dataclass
class Linearisation:
    """The objective of every candidate linearised at the current point: the residuals there, the
    Jacobian (central differences at ``taken_at``: the point itself unless it was kept from a point
    within :data:`REUSE_TOL` of it, :func:`near_decision`) and the model-form sources measured with
    it (None until measured)."""

    point: dict[str, float]
    resid: np.ndarray
    jac: np.ndarray
    free: list[str]
    taken_at: dict[str, float] | None = None
    sources: tuple | None = None

    def __post_init__(self) -> None:
        if self.taken_at is None:
            self.taken_at = dict(self.point)


def first_fit(fx: Fitter, obj, fws: WindowSet, start_at: dict[str, float], only: list[str] | None,
               on_iter) -> tuple[FitResult, Linearisation]:
    """Every candidate fitted from ``start_at`` (several starts); or, for the guard's second
    attempt, only the parameters ``only`` a first attempt changed, then every candidate linearised
    at that point (the others at their described value)."""
    from mjtrack.calibrate.fit import central_jacobian, fit

    if only is None:
        result = fit(obj, start_at, max_iter=fx.max_iter, multistart=True, on_iter=on_iter)
        return result, Linearisation(dict(result.values), result.resid, result.jac, list(fx.names))
    result = fit(fx.objective(fws, only), {n: start_at[n] for n in only}, max_iter=fx.refit_iter,
                 multistart=False, on_iter=on_iter, final_jacobian=False)
    point = {**fx.described, **result.values}
    resid, jac = central_jacobian(obj, fx.scaled(point), central=np.array([n in only for n in fx.names]))
    return result, Linearisation(point, resid, jac, list(only))


def decision_rounds(fx: Fitter, obj, fws: WindowSet, cur: Linearisation, rounds: int, on_iter):
    """Until it settles (at most ``rounds`` refits): every candidate linearised at the current
    point, what the log determines and needs changed decided again for all of them, the kept ones
    fitted again. Returns the last decision, the linearisation it was made at, the model-form
    sources there (and their sizes), and the refits."""
    from mjtrack.calibrate.fit import central_jacobian, fit

    fits: list[FitResult] = []
    for round_ in range(rounds + 1):
        fx.meter.stage(f"round {round_ + 1}")
        if cur.sources is None:
            cur.sources = model_form_sources(obj, cur.point, cur.resid, cur.jac, fx.config)
        sources, size = cur.sources
        theta = fx.scaled(cur.point)
        lin = fx.linearised(obj, theta, cur.jac, cur.resid, sources)
        converged = settled(lin, [fx.names.index(n) for n in cur.free])
        ahead = fx.linearised(obj, theta, cur.jac, cur.resid, sources)
        ahead.advance()
        sel = select(ahead, fx.described)
        if (sel.free == cur.free and converged) or not sel.free or round_ == rounds:
            return sel, cur, theta, sources, size, fits
        free = sel.free
        begin = {n: float(np.clip(sel.values[n], fx.specs[n].lo, fx.specs[n].hi)) for n in free}
        near = near_decision(fx, obj, lin, cur, {**fx.described, **begin}, free)
        if near is not None:  # the decision changes nothing the optimiser could resolve: no refit
            cur = near
            continue
        fx.meter.stage(f"round {round_ + 1} refit",
                       round_passes(len(fx.names), fx.refit_iter) * len(fws) + fx.meter.tail)
        fr = fit(fx.objective(fws, free), begin, max_iter=fx.refit_iter, multistart=False, on_iter=on_iter,
                 final_jacobian=False)  # linearised below with every candidate
        fits.append(fr)
        point = {**fx.described, **fr.values}
        resid, jac = central_jacobian(obj, fx.scaled(point), central=np.array([n in free for n in fx.names]))
        cur = Linearisation(point, resid, jac, list(free))
    raise AssertionError("unreachable: the last round returns")


def settled(lin: Linearised, idx: list[int]) -> bool:
    """Whether the Gauss-Newton step left for the parameters ``idx`` (the others held) is below
    :data:`STEP_TOL` of each one's half-width."""
    rest = np.abs(lin.step(idx)[idx]) * lin.scales[idx]
    return bool(np.all(rest <= STEP_TOL * lin.uncertainty(idx).half))


def reuse_tolerance(lin: Linearised, free: list[str]) -> dict[str, float]:
    """How far a point may lie from where ``lin``'s Jacobian was taken for the Jacobian to be kept:
    :data:`REUSE_TOL` of each parameter's resolution, and of the half-width the parameters
    ``free`` get there (the intervals the verdicts would give them)."""
    tol = {n: REUSE_TOL * lin.specs[n].resolution for n in lin.names}
    if free:
        idx = [lin.names.index(n) for n in free]
        for n, h in zip(free, lin.uncertainty(idx).half):
            tol[n] = min(tol[n], REUSE_TOL * float(h))
    return tol


def near_decision(fx: Fitter, obj, lin: Linearised, cur: Linearisation, point: dict[str, float],
                  free: list[str]) -> Linearisation | None:
    """The linearisation at ``point`` (the next decision: ``free`` at their linearised optimum, the
    others at their description) with the Jacobian and model-form sources of ``cur`` kept, when
    ``point`` lies within :func:`reuse_tolerance` of where they were taken and the step left there
    is within the optimiser's tolerance (:func:`settled`); else None (the decision needs a refit).
    Costs one pass (the residuals at ``point``) when the point is near, none otherwise."""
    tol = reuse_tolerance(lin, free)
    if any(abs(point[n] - cur.taken_at[n]) > tol[n] for n in fx.names):
        return None
    resid = obj.residuals(fx.scaled(point))
    sources, _ = cur.sources
    there = fx.linearised(obj, fx.scaled(point), cur.jac, resid, sources)
    if not settled(there, [fx.names.index(n) for n in free]):
        return None
    log.info("calibrate: the decision moves the point within the optimiser's tolerance; the Jacobian of %s is kept",
             ", ".join(f"{n} = {fmt_value(v, fx.specs[n].unit)}" for n, v in cur.taken_at.items() if n in free))
    return Linearisation(dict(point), resid, cur.jac, list(free), taken_at=cur.taken_at, sources=cur.sources)


def settle_verdicts(fx: Fitter, obj, sel, cur: Linearisation, theta: np.ndarray, sources, size, rounds: int):
    """The verdicts: those the last decision sent back to their description, and, unless it sent
    back every one, the fitted ones at the current point (when the rounds ran out first, the last
    fit stands as fitted). Returns verdicts, values, model_form, uncertainty, linearisation, ties."""
    names, specs, described = fx.names, fx.specs, fx.described
    kept = [] if not sel.free else cur.free
    verdicts: dict[str, Verdict] = {n: v for n, v in sel.verdicts.items() if n not in kept}
    # the rounds ran out while the last decision freed a parameter the last fit had not moved:
    # it is determined, but no fit reached its value, so it stays at its description and says so
    for n in sel.free:
        if n not in kept:
            s = specs[n]
            verdicts[n] = Verdict(n, True, False, described[n], described[n], None,
                                  f"the log points at {fmt_value(sel.values[n], s.unit)} (linearised), but the "
                                  f"fit did not settle within {rounds} rounds ({ROUNDS_HINT}); it stays at its described "
                                  f"value {fmt_value(described[n], s.unit)}, which the log does not confirm",
                                  points_at=float(sel.values[n]))
    # a tie of the last decision holds only where that decision was fitted: when the rounds ran out
    # with its partner still free in the last fit, the partner has its own value and verdict
    ties = {k: [t for t in v if t not in kept] for k, v in sel.ties.items() if k in kept}
    ties = {k: v for k, v in ties.items() if v}
    values = {**described}
    if not kept:
        return verdicts, values, {}, None, None, ties
    kidx = [names.index(n) for n in kept]
    klin = fx.linearised(obj, theta[kidx], cur.jac[:, kidx], cur.resid,
                         [ModelFormSource(m.name, m.g[kidx]) for m in sources], names=kept)
    final, u, rest = final_verdicts(klin, described, ties, allow_for=allowed_for(fx, obj, sel, cur, theta, sources, kept))
    for n in kept:  # the rounds ran out while the last decision would send it back: said, not hidden
        if n not in sel.free and final[n].changed:
            final[n].reason += (f"; the fit's last decision would send it back to its described value, but its "
                                f"{rounds} rounds ran out first ({ROUNDS_HINT}): this is the last fit's value")
            final[n].unsettled = True
    verdicts.update(final)
    values.update({n: cur.point[n] for n in kept})
    model_form = {"residual_change_m": size,
                  "shift": {src_: {n: float(v) for n, v in zip(kept, sh)} for src_, sh in u.shifts.items()},
                  "optimiser": {n: float(v) for n, v in zip(kept, rest)}}
    return verdicts, values, model_form, u, klin, ties


def allowed_for(fx: Fitter, obj, sel, cur: Linearisation, theta: np.ndarray, sources, kept: list[str]
                ) -> tuple[list[str], np.ndarray] | None:
    """The candidates the kept ones' intervals must allow for, and the kept ones' half-widths
    (physical) with them fitted too: those the log does not determine (sent back on their own, not
    traded with another) whose value the description does not give. Held at a default, such a
    parameter is an assumption, not information, and what the kept ones could be with it anywhere
    the log allows belongs in their intervals (identify's module docstring). None when there are none."""
    extra = [n for n in fx.undescribed if n in sel.verdicts and n not in kept and not sel.verdicts[n].determined
             and sel.verdicts[n].interval is None and not sel.verdicts[n].tied_with]
    if not extra or not kept:
        return None
    idx = [fx.names.index(n) for n in kept + extra]
    wide = fx.linearised(obj, theta[idx], cur.jac[:, idx], cur.resid,
                         [ModelFormSource(m.name, m.g[idx]) for m in sources], names=kept + extra)
    return extra, wide.uncertainty(list(range(len(idx)))).half[:len(kept)]


def fit_attempt(fx: Fitter, fws: WindowSet, start_at: dict[str, float], only: list[str] | None = None,
                note: str = "guard refit", rounds: int | None = None) -> Fitted:
    """One attempt: the first fit, the rounds of decisions, the verdicts (``only``: the parameters
    fitted again from ``start_at`` in a second attempt -- the guard's, see :func:`_guarded_fit`, or
    the turn stage's -- said as ``note`` in the progress; ``rounds``: its rounds of decisions,
    default GUARD_ROUNDS for a second attempt, the calibration's for a first)."""
    obj = fx.objective(fws, fx.names)
    if rounds is None:
        rounds = fx.rounds if only is None else GUARD_ROUNDS
    fx.meter.stage("fit" if only is None else note)
    result, cur = first_fit(fx, obj, fws, start_at, only, None)
    sel, cur, theta, sources, size, fits = decision_rounds(fx, obj, fws, cur, rounds, None)
    verdicts, values, model_form, u, lin, ties = settle_verdicts(fx, obj, sel, cur, theta, sources, size, rounds)
    return Fitted(result=result, refit=fits[-1] if fits else None, verdicts=verdicts, values=values,
                   model_form=model_form, u=u, lin=lin, ties=ties, fws=fws)
