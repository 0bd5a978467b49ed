"""Cross-validated ranking of the candidates, with the "none" decision.

Folds. The log is cut into K contiguous blocks (whole segments when there are at least 2K of
them, else equal blocks of samples; windows never cross a block). For every candidate and fold
k the parameters are fitted on the other K-1 folds and the candidate predicts the windows of
fold k. The baseline is the nominal model, which is not fitted.

Gain. Per fold, g_k = RMSE_baseline,k - RMSE_candidate,k of the position error at the horizon;
the reported gain pools all held-out windows (each predicted by a fit that never saw it):
before = RMSE_baseline, after = RMSE_candidate, relative = 1 - after/before.

Beyond noise. A candidate is a finding when (a) the paired one-sided t-test over folds,
mean(g)/(sd(g)/sqrt(K)), exceeds the 95 % Student quantile with K-1 degrees of freedom, and (b)
the pooled relative gain is at least ``min_gain`` (a floor that keeps a surrogate's own
approximation error from being read as a cause on very long logs). Held-out scoring is itself
the complexity penalty: a parameter fitted to noise does not help on new data. With measured
track speeds an input effect must, in addition, reduce the held-out track-speed error by the
same test (the speeds say whether the actuators are the cause).

Ties. Two findings whose paired per-fold RMSE differences are within noise (|t| below the same
quantile), or whose pooled held-out RMSEs differ by less than the gain floor (min_gain x the
baseline RMSE: a difference too small to be a finding cannot separate two findings either; two
near-identical models give consistent, hence "significant", tiny fold differences) cannot be
told apart: both are listed, each one's evidence says so, and among tied
findings the one with fewer parameters goes first (one-standard-error rule); otherwise findings
are ordered by pooled held-out gain.

Intervals: delete-one-fold jackknife over the K cross-validation fits,
se^2 = (K-1)/K sum (theta_k - mean theta)^2, interval = full-data estimate +- t_{0.975,K-1} se
(angles differenced on the circle).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from mjtrack.diagnose import fit as fitmod
from mjtrack.diagnose.effects import Effect
from mjtrack.progress import Progress

log = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class CandidateResult:
    """Cross-validation result of one candidate.

    estimate: (P,) full-data fit; fold_estimates: (K, P); interval: (P, 2) jackknife interval;
    fold_before, fold_after: (K,) held-out RMSE of baseline and candidate [m]; before, after:
    pooled held-out RMSE [m]; t_stat: paired t of the fold gains; speed_before/after: held-out
    track-speed RMSE [m/s] (input effects with measured speeds), else None; passed: beats the
    baseline beyond noise; why: one line on the decision; tied_with: names of findings it cannot
    be told apart from; held_out_errors: (M, 3) window errors, each from the fit that did not see it.
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
    tied_with: list[str] = field(default_factory=list)

    @property
    def relative(self) -> float:
        return 1.0 - self.after / self.before if self.before > 0 else 0.0


def paired_t(a: np.ndarray, b: np.ndarray) -> float:
    """t statistic of mean(a - b) over folds (inf when all differences are equal and positive)."""
    d = np.asarray(a, float) - np.asarray(b, float)
    sd = float(np.std(d, ddof=1)) if d.size > 1 else 0.0
    m = float(np.mean(d))
    scale = max(float(np.max(np.abs(a))), float(np.max(np.abs(b))), 1e-300)
    if abs(m) <= 1e-12 * scale:  # no difference at all (e.g. the fit stayed at the nominal value)
        return 0.0
    if sd <= 1e-15 * abs(m):
        return float(np.sign(m) * np.inf)
    return m / (sd / np.sqrt(d.size))


def _jackknife(full: np.ndarray, folds: np.ndarray, angular: np.ndarray, t_q: float) -> np.ndarray:
    k = folds.shape[0]
    dev = folds - folds.mean(0)
    if angular.any():
        mean_ang = np.angle(np.exp(1j * folds[:, angular]).mean(0))
        dev[:, angular] = np.angle(np.exp(1j * (folds[:, angular] - mean_ang)))
    se = np.sqrt((k - 1) / k * np.sum(dev**2, 0))
    return np.stack([full - t_q * se, full + t_q * se], -1)


def evaluate(problem: fitmod.Problem, effects: list[Effect], *, n_folds: int, min_gain: float,
             quiet: bool = True) -> tuple[dict, list[CandidateResult]]:
    """Cross-validate every effect; returns (baseline summary, results ordered as findings first)."""
    folds = np.arange(n_folds)
    allw = np.arange(problem.starts.size)
    base_err = fitmod.errors(problem, None, (), allw)
    fold_before = np.array([fitmod.pos_rmse(base_err[problem.fold == k]) for k in folds])
    before = fitmod.pos_rmse(base_err)
    t_q = float(stats.t.ppf(0.95, n_folds - 1))
    t_q2 = float(stats.t.ppf(0.975, n_folds - 1))
    speeds = problem.speed_ok is not None and problem.speed_ok.any()
    if speeds:
        cmd_err = problem.surrogate.inputs(problem.data, None, (), instant=True) - problem.data.meas
        speed_fold_before = np.array([np.sqrt(np.mean(cmd_err[(problem.sample_fold == k) & problem.speed_ok] ** 2))
                                      for k in folds])
    results = []
    with Progress(total=len(effects) * (n_folds + 1), label="candidates", quiet=quiet) as bar:
        for eff in effects:
            ests, after_err, fold_after, speed_after = [], np.empty_like(base_err), [], []
            for k in folds:
                p = fitmod.fit(problem, eff, folds[folds != k])
                ests.append(p)
                w = allw[problem.fold == k]
                after_err[w] = fitmod.errors(problem, eff, p, w)
                fold_after.append(fitmod.pos_rmse(after_err[w]))
                if speeds and eff.kind == "input":
                    sm = (problem.sample_fold == k) & problem.speed_ok
                    speed_after.append(np.sqrt(np.mean(fitmod.speed_residuals(problem, eff, p, sm) ** 2)))
                bar.update()
            full = fitmod.fit(problem, eff, folds)
            bar.update()
            ests = np.array(ests)
            angular = np.array([n == "slope_direction" for n in eff.params])
            fold_after = np.array(fold_after)
            after = fitmod.pos_rmse(after_err)
            t_stat = paired_t(fold_before, fold_after)
            rel = 1.0 - after / before if before > 0 else 0.0
            sb = sa = st = None
            passed = t_stat > t_q and rel >= min_gain
            why = (f"held-out position RMSE {before:.3g} -> {after:.3g} m ({100 * rel:.1f} %), paired t over "
                   f"{n_folds} folds = {t_stat:.2f} (threshold {t_q:.2f}, gain floor {100 * min_gain:.0f} %)")
            if speeds and eff.kind == "input":
                sb, sa = float(np.sqrt(np.mean(speed_fold_before**2))), float(np.sqrt(np.mean(np.square(speed_after))))
                st = paired_t(speed_fold_before, np.array(speed_after))
                why += f"; held-out track-speed RMSE {sb:.3g} -> {sa:.3g} m/s (t = {st:.2f})"
                if not (st > t_q and sa < 0.97 * sb):
                    passed = False
                    why += ": the measured track speeds do not show this effect"
            results.append(CandidateResult(eff, full, ests, _jackknife(full, ests, angular, t_q2), fold_before,
                                           fold_after, before, after, t_stat, sb, sa, st, passed, why, after_err))
    found = sorted([r for r in results if r.passed], key=lambda r: r.after)
    if found:
        top = found[0]
        for r in found[1:]:
            # within noise, or a difference below the gain floor (which no finding may be made of)
            if abs(paired_t(r.fold_after, top.fold_after)) < t_q or r.after - top.after < min_gain * before:
                r.tied_with.append(top.effect.name)
                top.tied_with.append(r.effect.name)
        # one-standard-error rule: a simpler tied finding goes first
        simpler = [r for r in found if r is top or top.effect.name in r.tied_with]
        simpler.sort(key=lambda r: (len(r.effect.params), r.after))
        first = simpler[0]
        found.remove(first)
        found.insert(0, first)
    rest = sorted([r for r in results if not r.passed], key=lambda r: r.after)
    baseline = {"before": before, "fold_before": fold_before, "errors": base_err}
    return baseline, found + rest
