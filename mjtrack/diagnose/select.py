"""Cross-validated scoring of the candidates, forward selection, ties, and the "none" decision.

The one decision rule of every baseline (:class:`mjtrack.diagnose.baseline.Baseline`): the
baseline simulates the windows and fits an effect's parameters; everything below is the same
whichever it is.

Folds. The log is cut into K contiguous blocks (whole segments when there are at least 2K of
them, else equal blocks of samples; windows never cross a block). For every candidate and fold
k the parameters are fitted on the other K-1 folds and the candidate predicts the windows of
fold k, so every window is scored by a fit that never saw it. The baseline (the nominal model,
plus the effects already found) is not refitted.

Beyond noise. A candidate is a finding when the blocked bootstrap over windows
(:func:`mjtrack.diagnose.stats.gain_test`) puts the one-sided 95 % lower bound of its held-out
relative gain above zero and the point gain is at least ``min_gain`` (a floor that keeps a
surrogate's own approximation error from being read as a cause on long logs). Held-out scoring
is itself the complexity penalty. With measured track speeds an input effect must, in addition,
reduce the held-out track-speed error by the same test over the same blocks (the speeds say
whether the actuators are the cause); an input effect the speeds contradict is refuted even
when it helps the pose error.

Derivation and measurements: docs/theory/diagnosis.md, "Selection rules".
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from mjtrack.diagnose import stats as st
from mjtrack.diagnose.baseline import Baseline
from mjtrack.diagnose.problem import Problem
from mjtrack.diagnose.stats import interval, paired_t, pos_rmse, too_few_blocks
from mjtrack.diagnose.ties import equivalence_note, physical_tie
from mjtrack.diagnose.vocabulary import Effect
from mjtrack.progress import Progress

log = logging.getLogger(__name__)


@dataclass(eq=False)
class CandidateResult:
    """Cross-validation result of one candidate (in one forward-selection step).

    estimate: (P,) full-data fit; fold_estimates: (K, P); interval: (P, 2) 95 % interval;
    fold_before, fold_after: (K,) held-out RMSE of baseline and candidate [m]; before, after:
    pooled held-out RMSE [m]; t_stat: paired t of the fold gains (reported, not the decision);
    gain: the blocked bootstrap test of the held-out gain (the decision); speed_before/after:
    held-out track-speed RMSE [m/s] (input effects with measured speeds), else None; speed_gain:
    its test; passed: beats the baseline beyond noise; why: one line on the decision; tied_with:
    names of findings it cannot be told apart from; tie_notes: the physics of a tie, what would
    separate it; held_out_errors: (M, 3) window errors, each from the fit that did not see it;
    on_top_of: names of the effects already in the baseline of this step; se: (P,) the
    interval's standard error, se_stat its statistical part, se_model the model-form and
    resolution part; nominal: (P,) the effect's no-effect values in the baseline; substitute: the
    finding of the previous step that explains the log as well alone as the model with this
    candidate on top (the candidate is then not a finding; docs/theory/diagnosis.md, "Beyond a first
    effect").
    """

    effect: Effect
    estimate: np.ndarray
    fold_estimates: np.ndarray
    interval: np.ndarray
    fold_before: np.ndarray
    fold_after: np.ndarray
    before: float
    after: float
    t_stat: float
    speed_before: float | None
    speed_after: float | None
    speed_t: float | None
    passed: bool
    why: str
    held_out_errors: np.ndarray
    gain: st.GainTest | None = None
    speed_gain: st.GainTest | None = None
    tied_with: list[str] = field(default_factory=list)
    tie_notes: list[str] = field(default_factory=list)
    on_top_of: tuple[str, ...] = ()
    se: np.ndarray | None = None
    speed_errors: np.ndarray | None = None
    below_floor: str | None = None
    se_stat: np.ndarray | None = None
    se_model: np.ndarray | None = None
    nominal: np.ndarray | None = None
    substitute: str | None = None

    @property
    def relative(self) -> float:
        return 1.0 - self.after / self.before if self.before > 0 else 0.0


def model_se(bl: Baseline, eff: Effect, theta: np.ndarray, problem: Problem) -> np.ndarray:
    """Standard error (P,) of the baseline's own approximation (its
    :class:`mjtrack.diagnose.baseline.ModelForm`); zero for an input effect fitted to measured
    track speeds (an exact transform)."""
    if problem.uses_speeds(eff):
        return np.zeros(len(eff.params))
    return bl.model_form.se(eff.name, theta, bl.nominal(eff, problem))


def score(bl: Baseline, problem: Problem, eff: Effect, *, n_folds: int, min_gain: float, base_err: np.ndarray,
          speed_base: np.ndarray | None = None, bar=None, floor: float | None = None) -> CandidateResult:
    """Fit ``eff`` on every K-1 folds, score it on the fold left out, test the gain (module docstring).

    ``min_gain`` is the floor of the track-speed gain; ``floor`` that of the position gain as a
    share of this problem's baseline RMSE (None: ``min_gain``; :func:`pose_floor`)."""
    floor = min_gain if floor is None else floor
    folds = np.arange(n_folds)
    score_folds = folds if problem.score_folds is None else np.array(problem.score_folds)
    allw = np.arange(problem.starts.size)
    scored = problem.scored
    wblock = problem.window_block[scored]
    ests, after_err = [], np.full_like(base_err, np.nan)
    speed_res = None
    speeds = speed_base is not None and eff.kind == "input"
    if speeds:
        speed_res = np.full(problem.data.n, np.nan)
    train = folds if problem.score_folds is None else folds[~np.isin(folds, score_folds)]
    full, cov = bl.fit(problem, eff, train, covariance=True)
    if bar is not None:
        bar.update()
    for k in score_folds:
        # each fold fit starts from the full-data estimate (the start grid is searched once)
        p = full if problem.score_folds is not None else bl.fit(problem, eff, folds[folds != k], start=full)
        ests.append(p)
        w = allw[problem.fold == k]
        after_err[w] = bl.held_out_errors(problem, w, eff, p)
        if speeds:
            sm = (problem.sample_fold == k) & problem.speed_ok
            r = bl.speed_residuals(problem, eff, p, sm).reshape(-1, 2)
            speed_res[sm] = np.sum(r**2, 1)
        if bar is not None:
            bar.update()
    ests = np.array(ests)
    valid = problem.valid_mask
    fold_before = np.array([pos_rmse(base_err[(problem.fold == k) & valid]) for k in score_folds])
    fold_after = np.array([pos_rmse(after_err[(problem.fold == k) & valid]) for k in score_folds])
    base_err, after_err = base_err[scored], after_err[scored]
    sq_b = np.sum(base_err[:, :2] ** 2, 1)
    sq_a = np.sum(after_err[:, :2] ** 2, 1)
    before, after = pos_rmse(base_err), pos_rmse(after_err)
    gt = st.gain_test(sq_b, sq_a, wblock)
    # the fit resolves the estimate only so far (an optimum at a kink of the cost, e.g. a dead time
    # fitted to sampled speeds, is located no better): in quadrature with the model-form term
    se_fit = np.hypot(model_se(bl, eff, full, problem), bl.resolution(eff, full))
    ivl, se = interval(full, ests, cov, gt.blocks, se_fit)
    se_stat = interval(full, ests, cov, gt.blocks)[1]
    nominal = bl.nominal(eff, problem)
    passed = gt.lower > 0.0 and gt.relative >= floor
    why = (f"held-out position RMSE {before:.3g} -> {after:.3g} m ({100 * gt.relative:.1f} %, one-sided 95 % bound "
           f"{100 * gt.lower:.1f} % by blocked bootstrap over {gt.blocks} blocks of windows; gain floor "
           f"{100 * floor:.0f} %" + (f", {100 * min_gain:.0f} % of the nominal RMSE" if floor != min_gain else "") + ")")
    if not np.isfinite(after):
        bad = int(np.sum(~np.isfinite(sq_a)))
        why = f"the {bl.noun} diverged on {bad} of {sq_a.size} held-out windows"
    resolution = bl.model_form.absolute.get(eff.name, 0.0)
    if passed and resolution > 0.0 and not problem.uses_speeds(eff):
        if np.any((ivl[:, 0] <= nominal) & (nominal <= ivl[:, 1])):
            # the gain is real, but a second physics of the same description differs by as much
            passed = False
            why += (f"; its 95 % interval [{', '.join(f'{a:.4g}, {b:.4g}' for a, b in ivl)}] holds the nominal "
                    f"{', '.join(f'{v:.4g}' for v in nominal)}: within the {bl.noun}'s resolution "
                    f"(+-{st.t_quantile(gt.blocks) * resolution:.3g}: the spread between independent physics "
                    f"of one description); not named")
    sb = sa = stt = sg = below_floor = None
    if speeds:
        ok = problem.speed_ok & np.isfinite(speed_res)
        sblock = problem.speed_block
        sg = st.gain_test(speed_base[ok], speed_res[ok], sblock[ok])
        sb = float(np.sqrt(np.mean(speed_base[ok]) / 2))
        sa = float(np.sqrt(np.mean(speed_res[ok]) / 2))
        why += f"; held-out track-speed RMSE {sb:.3g} -> {sa:.3g} m/s ({100 * sg.relative:.1f} %, bound {100 * sg.lower:.1f} %)"
        if not (sg.lower > 0.0 and sg.relative >= min_gain):
            passed = False
            why += ": refuted, the measured track speeds do not show this effect"
        contra = _contradiction(bl, problem, eff, full)
        if contra:
            passed = False
            why += "; refuted: " + contra
        elif not passed and sg.relative >= min_gain and sg.lower <= 0.0:
            below = too_few_blocks(speed_base[ok], speed_res[ok], sblock[ok], min_gain)
            if below is not None:
                below_floor = _below_floor_note(
                    eff, full, f"the measured track speeds (held-out track-speed RMSE {sb:.3g} -> {sa:.3g} m/s, "
                    f"{100 * sg.relative:.0f} %; position {100 * gt.relative:.1f} %)", below,
                    "A log with more of the commands it acts on would settle it")
    if below_floor is None and not passed and not speeds and gt.relative >= floor and gt.lower <= 0.0:
        # no measured speeds to speak for it (or a ground effect): the pose's own blocks
        below = too_few_blocks(sq_b, sq_a, wblock, floor)
        if below is not None:
            below_floor = _below_floor_note(
                eff, full, f"the pose (held-out position RMSE {before:.3g} -> {after:.3g} m, {100 * gt.relative:.0f} %)",
                below, "A longer log, or one with more of the manoeuvres it acts on, would settle it")
    return CandidateResult(eff, full, ests, ivl, fold_before, fold_after, before, after,
                           paired_t(fold_before, fold_after), sb, sa, stt, passed, why, after_err, gain=gt,
                           speed_gain=sg, on_top_of=tuple(e.name for e, _ in problem.base), se=se,
                           speed_errors=speed_res, below_floor=below_floor, se_stat=se_stat, se_model=se_fit,
                           nominal=nominal)


def _below_floor_note(eff, full, evidence: str, below: tuple[int, int, int], remedy: str) -> str:
    """The verdict's sentence for an effect that ``evidence`` suggests in too few blocks
    (``below`` = (blocks showing it, blocks, blocks needed), :func:`_too_few_blocks`)."""
    k, n_blocks, need = below
    return (f"{eff.name} = {', '.join(f'{v:.4g}' for v in full)} is suggested by {evidence} but only {k} of the "
            f"log's {n_blocks} blocks show it, and a blocked bootstrap cannot establish an effect from fewer than "
            f"{need}: not reported as a cause. {remedy}")


def _contradiction(bl: Baseline, problem: Problem, eff: Effect, theta) -> str | None:
    """A limit the measured speeds exceed: most samples commanded beyond it measure beyond it
    by more than 5 % (a saturation cannot be exceeded), or None."""
    if eff.name not in ("drive_speed_limit", "drive_turn_limit") or not np.isfinite(theta[0]):
        return None
    ok = problem.speed_ok
    cmd, meas = problem.data.cmd[ok], problem.data.meas[ok]
    if eff.name == "drive_speed_limit":
        over = np.abs(cmd) > theta[0]
        beyond = over & (np.abs(meas) > 1.05 * theta[0])
        unit = "m/s"
    else:
        over = np.abs(cmd[:, 1] - cmd[:, 0]) / 2 > theta[0]
        beyond = over & (np.abs(meas[:, 1] - meas[:, 0]) / 2 > 1.05 * theta[0])
        unit = "m/s (half difference)"
    if over.sum() >= 10 and beyond.sum() > 0.5 * over.sum():
        return (f"{100 * beyond.sum() / over.sum():.0f} % of the samples commanded beyond {theta[0]:.3g} {unit} "
                f"measure more than 5 % beyond it")
    return None


def _rank(found: list[CandidateResult], robot, problem, base_err, min_gain: float,
          floor: float | None = None) -> list[CandidateResult]:
    """Order the findings of one step and mark ties (module docstring); ``floor``: the position
    gain floor as a share of this step's baseline RMSE (None: ``min_gain``; :func:`pose_floor`),
    ``min_gain`` that of the track speeds."""
    floor = min_gain if floor is None else floor
    found = sorted(found, key=lambda r: r.after)
    if not found:
        return found
    sblock = problem.speed_block
    if len(found) > 1 and speed_order(found[0], found[1], sblock, min_gain) == 1:
        sq0 = np.sum(base_err[problem.scored][:, :2] ** 2, 1)
        d, lo, hi = st.difference_test(sq0, np.sum(found[0].held_out_errors[:, :2] ** 2, 1),
                                       np.sum(found[1].held_out_errors[:, :2] ** 2, 1), problem.window_block[problem.scored])
        if not (lo > 0.0 and d >= floor):  # tied on the pose: the measured speeds rank them
            found[0], found[1] = found[1], found[0]
    top = found[0]
    sq0 = np.sum(base_err[problem.scored][:, :2] ** 2, 1)
    sq_top = np.sum(top.held_out_errors[:, :2] ** 2, 1)
    for r in found[1:]:
        why = physical_tie(robot, top, r)
        if why is not None:
            top.tie_notes.append(why)
            r.tie_notes.append(why)
        else:
            d, lo, hi = st.difference_test(sq0, sq_top, np.sum(r.held_out_errors[:, :2] ** 2, 1),
                                               problem.window_block[problem.scored])
            if not (lo > 0.0 and d >= floor):
                why = "held-out gains equal within noise"
        if why is not None and not r.tie_notes and speed_order(top, r, sblock, min_gain) == -1:
            why = None  # tied on the pose, but the measured track speeds tell them apart
            top.tie_notes.append(f"ties with {r.effect.name} on the pose error, but the measured track speeds "
                                 f"favour {top.effect.name} ({top.speed_after:.3g} vs {r.speed_after:.3g} m/s)")
        if why is not None:
            note = equivalence_note(robot, top, r) if not r.tie_notes else None
            if note is not None:  # tied by the data, and the physics says why
                top.tie_notes.append(note)
                r.tie_notes.append(note)
            r.tied_with.append(top.effect.name)
            top.tied_with.append(r.effect.name)
    tied = [r for r in found if r is top or top.effect.name in r.tied_with]
    tied.sort(key=lambda r: (len(r.effect.params), r.after))
    found.remove(tied[0])
    found.insert(0, tied[0])
    return found


def speed_order(a: CandidateResult, b: CandidateResult, block: np.ndarray, min_gain: float) -> int:
    """-1 when a's held-out track-speed errors are smaller than b's beyond noise (blocked bootstrap
    interval of the difference excludes zero and it exceeds the floor), 1 when b's are, 0 when
    the speeds cannot tell (or are missing)."""
    if a.speed_errors is None or b.speed_errors is None:
        return 0
    ok = np.isfinite(a.speed_errors) & np.isfinite(b.speed_errors)
    if ok.sum() < 10:
        return 0
    d, lo, hi = st.difference_test(b.speed_errors[ok], a.speed_errors[ok], b.speed_errors[ok], block[ok])
    if lo > 0 and d >= min_gain:
        return -1
    if hi < 0 and -d >= min_gain:
        return 1
    return 0


@dataclass
class Step:
    """One forward-selection step: the effects already in the baseline (names), its held-out RMSE
    [m] and every candidate's result, findings first (the first is the one added)."""

    base: tuple[str, ...]
    before: float
    results: list[CandidateResult]

    @property
    def chosen(self) -> CandidateResult | None:
        return self.results[0] if self.results and self.results[0].passed else None


def _speed_base(bl: Baseline, problem: Problem) -> np.ndarray | None:
    """(N,) squared track-speed errors of the problem's baseline (NaN where not measured), or None."""
    if problem.speed_ok is None or not problem.speed_ok.any():
        return None
    v = bl.speeds(problem, list(problem.base))
    return np.where(problem.speed_ok, np.sum((v - problem.data.meas) ** 2, 1), np.nan)


def pose_floor(min_gain: float, nominal_rmse: float | None, base_rmse: float) -> float:
    """The position gain floor of a step as a share of its baseline RMSE ``base_rmse`` [m]:
    ``min_gain`` of the nominal model's RMSE ``nominal_rmse`` [m] (None: this step's baseline is
    the nominal model), never below ``min_gain`` (docs/theory/diagnosis.md, "Beyond a first effect")."""
    if nominal_rmse is None or not (base_rmse > 0.0) or not np.isfinite(nominal_rmse):
        return min_gain
    return max(min_gain, min_gain * nominal_rmse / base_rmse)


def _no_substitute(r: CandidateResult, rivals: list[CandidateResult], nominal_sq: np.ndarray, block: np.ndarray,
                   min_gain: float) -> None:
    """Unpass ``r`` when a rival (a finding of the previous step, a model with one effect fewer)
    explains the log as well alone: the model with ``r`` must beat each by the floor beyond noise
    (docs/theory/diagnosis.md, "Beyond a first effect")."""
    sq = np.sum(r.held_out_errors[:, :2] ** 2, 1)
    for rv in rivals:
        d, lo, hi = st.difference_test(nominal_sq, sq, np.sum(rv.held_out_errors[:, :2] ** 2, 1), block)
        if lo > 0.0 and d >= min_gain:
            continue
        model = " + ".join(r.on_top_of + (r.effect.name,))
        r.passed, r.substitute = False, rv.effect.name
        r.why += (f"; not named: {rv.effect.name} alone (held-out RMSE {rv.after:.3g} m) explains the log as well as "
                  f"{model} ({r.after:.3g} m): the difference is {100 * d:.1f} % of the nominal RMSE, 95 % interval "
                  f"[{100 * lo:.1f}, {100 * hi:.1f}] %, floor {100 * min_gain:.0f} %")
        return


def evaluate(bl: Baseline, problem: Problem, effects: list[Effect], *, n_folds: int, min_gain: float,
             quiet: bool = True, nominal: np.ndarray | None = None,
             rivals: list[CandidateResult] = (), intro: str | None = None) -> tuple[dict, list[CandidateResult]]:
    """Score every effect against the problem's baseline; returns (baseline summary, results
    ordered as findings first, ties marked).

    ``nominal``: (M,) the nominal model's window errors (M, 3) on the scored windows when the
    problem's baseline already holds effects (the gain floor is a share of its RMSE), None when
    it is the nominal model; ``rivals``: the previous step's findings, each of which a finding
    here must beat (docs/theory/diagnosis.md, "Beyond a first effect"); ``intro``: a line said above
    the progress bar as it starts (how long the step is expected to take)."""
    allw = np.arange(problem.starts.size)
    base_err = bl.errors(problem, allw)[0]
    speed_base = _speed_base(bl, problem)
    before = pos_rmse(base_err[problem.scored])
    floor = pose_floor(min_gain, None if nominal is None else pos_rmse(nominal), before)
    results = []
    with Progress(total=len(effects) * (n_folds + 1), label="candidates", quiet=quiet) as bar:
        if intro:
            bar.say(intro)
        for eff in effects:
            results.append(score(bl, problem, eff, n_folds=n_folds, min_gain=min_gain, base_err=base_err,
                                 speed_base=speed_base, bar=bar, floor=floor))
    if rivals and nominal is not None:
        nominal_sq = np.sum(nominal[:, :2] ** 2, 1)
        for r in results:
            if r.passed:
                _no_substitute(r, list(rivals), nominal_sq, problem.window_block[problem.scored], min_gain)
    found = _rank([r for r in results if r.passed], bl.robot, problem, base_err, min_gain, floor)
    rest = sorted([r for r in results if not r.passed], key=lambda r: r.after)
    return {"before": before, "errors": base_err, "floor": floor}, found + rest


def _tie_substitutes(top: CandidateResult, results: list[CandidateResult], rivals: list[CandidateResult]) -> None:
    """A step that named nothing because a rival explained the log as well alone as ``top`` with
    a candidate on top: the log cannot tell ``top`` from that rival; both say so."""
    by_name = {rv.effect.name: rv for rv in rivals}
    for r in results:
        rv = by_name.get(r.substitute)
        if rv is None or rv.effect.name in top.tied_with:
            continue
        note = (f"{rv.effect.name} alone explains the log as well as {top.effect.name} with {r.effect.name} on top "
                f"({rv.after:.3g} vs {r.after:.3g} m held-out RMSE, equal within noise): the log cannot tell "
                f"{top.effect.name} from {rv.effect.name}")
        top.tied_with.append(rv.effect.name)
        rv.tied_with.append(top.effect.name)
        top.tie_notes.append(note)
        rv.tie_notes.append(note)


def forward_select(bl: Baseline, problem: Problem, effects: list[Effect], *, n_folds: int, min_gain: float,
                   max_effects: int = 3, quiet: bool = True, free_steps: int | None = None,
                   noise: float = 0.0, intro: Callable[[Problem, list[Effect]], str | None] | None = None
                   ) -> tuple[list[Step], list[CandidateResult]]:
    """Forward selection over all effects (module docstring). Returns the steps and the final
    findings (the chosen effects refitted each with the others fixed, in the order found, each
    followed by the findings tied with it).

    ``free_steps``: after this many findings a further step is taken only when the residual can
    still hold a finding (:func:`residual_left`, with ``noise`` [m] the pose noise's share of a
    window's error); None: always (up to ``max_effects``). ``intro(problem, effects)``: the line each
    step says as it starts (:func:`evaluate`)."""
    steps: list[Step] = []
    chosen: list[CandidateResult] = []
    remaining = list(effects)
    current = problem
    nominal, nominal_rmse, rivals = None, None, []
    while remaining and len(chosen) < max_effects:
        summary, results = evaluate(bl, current, remaining, n_folds=n_folds, min_gain=min_gain, quiet=quiet,
                                    nominal=nominal, rivals=rivals,
                                    intro=None if intro is None else intro(current, remaining))
        if nominal is None:
            nominal, nominal_rmse = summary["errors"][problem.scored], summary["before"]
        steps.append(Step(tuple(e.name for e, _ in current.base), summary["before"], results))
        best = steps[-1].chosen
        if best is None:
            if chosen:
                _tie_substitutes(chosen[-1], results, rivals)
            break
        rivals = [r for r in results if r.passed and r is not best]
        chosen.append(best)
        if free_steps is not None and len(chosen) >= free_steps and not residual_left(best, nominal_rmse, noise,
                                                                                        min_gain):
            log.debug("forward selection: %s leaves %.3g m, no more than the pose noise and the gain floor: "
                      "no further step", best.effect.name, best.after)
            break
        drop = {best.effect.name} | {r.effect.name for r in results if r.tie_notes and best.effect.name in r.tied_with}
        remaining = [e for e in remaining if e.name not in drop]
        current = dataclasses.replace(current, base=current.base + ((best.effect, best.estimate),))
    while len(chosen) > 1:  # refits, each with the others fixed; drop one that no longer passes
        inputs = [c for c in chosen if problem.uses_speeds(c.effect)]
        if len(inputs) > 1:  # coupled input effects: fitted jointly to the measured speeds first
            thetas = bl.refit_inputs(problem, [(c.effect, c.estimate) for c in inputs], np.arange(n_folds))
            for c, th in zip(inputs, thetas):
                c.estimate = th
        for _ in range(2):  # two rounds of refits (Gauss-Seidel), the second scores the final estimates
            rescored = []
            for i, r in enumerate(chosen):
                others = tuple((c.effect, c.estimate) for j, c in enumerate(chosen) if j != i)
                p = dataclasses.replace(problem, base=others)
                base_err = bl.errors(p, np.arange(p.starts.size))[0]
                floor = pose_floor(min_gain, nominal_rmse, pos_rmse(base_err[p.scored]))
                new = score(bl, p, r.effect, n_folds=n_folds, min_gain=min_gain, base_err=base_err,
                            speed_base=_speed_base(bl, p), floor=floor)
                new.tied_with, new.tie_notes = r.tied_with, r.tie_notes
                chosen[i] = new
                rescored.append(new)
        weak = [i for i, n in enumerate(rescored) if not n.passed]
        if not weak:
            break
        drop = min(weak, key=lambda i: rescored[i].relative)
        log.debug("forward selection: %s no longer passes on top of the others (%s): dropped",
                  chosen[drop].effect.name, rescored[drop].why)
        chosen.pop(drop)
    return steps, chosen


def first_cause(step: Step, problem: Problem, base_err: np.ndarray, keep: np.ndarray,
                min_gain: float) -> tuple[str, float | None]:
    """The effect a step names when only the scored windows ``keep`` ((S,) bool over the scored
    windows) are scored, by the gain rule alone (one-sided 95 % bound above zero, gain at least
    ``min_gain``; a candidate diverged on one of them is out), and its held-out gain; ("none",
    None) when none passes. ``base_err``: (S, 3) the step's baseline errors on the scored windows.
    Used to say whether leaving windows out changes the answer, with the same rule on both sides."""
    block = problem.window_block[problem.scored][keep]
    sq_b = np.sum(base_err[keep][:, :2] ** 2, 1)
    best = ("none", None, np.inf)
    for r in step.results:
        sq_a = np.sum(r.held_out_errors[keep][:, :2] ** 2, 1)
        if not (np.all(np.isfinite(sq_a)) and np.all(np.isfinite(sq_b))):
            continue
        gt = st.gain_test(sq_b, sq_a, block)
        if gt.lower > 0.0 and gt.relative >= min_gain and sq_a.sum() < best[2]:
            best = (r.effect.name, gt.relative, float(sq_a.sum()))
    return best[0], best[1]


def residual_left(best: CandidateResult, nominal_rmse: float, noise: float, min_gain: float) -> bool:
    """Whether the error a finding leaves can hold another: a further effect must remove at least
    the gain floor, ``min_gain`` of the nominal RMSE (:func:`pose_floor`), and no model removes
    the pose noise, so the held-out RMSE left [m] must exceed the noise's ``noise`` [m] by more."""
    return best.after - noise > min_gain * nominal_rmse


def all_findings(steps: list[Step], chosen: list[CandidateResult]) -> list[CandidateResult]:
    """The effects found (``chosen``, in the order found), each followed by the findings of its
    step tied with it."""
    out = []
    for c in chosen:
        out.append(c)
        step = next((s for s in steps if s.chosen is not None and s.chosen.effect.name == c.effect.name), None)
        if step is not None:
            out.extend(r for r in step.results[1:] if r.passed and c.effect.name in r.tied_with)
    return out


__all__ = ["CandidateResult", "Step", "score", "evaluate", "pose_floor", "forward_select", "all_findings", "speed_order",
           "first_cause", "residual_left"]
