"""A diagnosis problem (:class:`Problem`: a log's windows, folds and blocks, the baseline and the
effects already found) and the surrogate baselines' parameter estimation by nonlinear least squares.

Objective. Ground effects (and input effects when the log has no track speeds) are fitted to
the fixed-horizon prediction errors of the training windows: the residual of a window is its
error in the start frame (along, across [m], yaw x T/2 [m]) -- the same prediction the ranking
scores, so the fit minimises what is later measured on held-out data. When the log has
measured track speeds, the ground model is driven by them (an input effect cannot leak into a
ground estimate) and input effects are fitted to the speeds themselves (residual: transformed
command minus measured speed, both tracks), which is direct and far better conditioned.

Method. Multi-start (each effect's start grid, the cheapest start kept) then
``scipy.optimize.least_squares`` (trust-region reflective, bounds, finite-difference
Jacobian). Intervals are not taken from the Jacobian: the windows overlap and their errors are
strongly correlated, so (J^T J)^-1 s^2 would be far too narrow. :mod:`mjtrack.diagnose.select`
uses the delete-one-fold jackknife of the cross-validation fits instead.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy import optimize

from mjtrack.diagnose.baseline import Baseline
from mjtrack.diagnose.effects import Effect
from mjtrack.diagnose.residuals import DriveData, window_errors
from mjtrack.diagnose.stats import pos_rmse, sandwich  # noqa: F401  (pos_rmse: fit.pos_rmse for callers)

log = logging.getLogger(__name__)

# relative finite-difference step of the Jacobian: also the resolution of an optimum at a kink of
# the cost (a dead time fitted to sampled speeds has a V-shaped cost, kinks one sample apart), so
# the intervals include it (:func:`mjtrack.diagnose.select.score`)
DIFF_STEP = 1e-3


@dataclass(frozen=True)
class Problem:
    """Everything a fit needs, computed once per log.

    data: the drive data; baseline: the model extended by the effects (:class:`Baseline`);
    horizon_s [s]; dt: (N,) hold times [s];
    starts, ends: (M,) windows; fold: (M,) fold of each window; sample_fold: (N,) fold of each
    sample; fit_windows: (F,) indices into the windows used for fitting (a stride of them);
    measured: (N, 2) measured track speeds with missing values replaced by the command, or None;
    speed_ok: (N,) samples with both speeds measured; base: effects with fixed parameters that
    are part of the baseline ((Effect, theta) pairs: forward selection tests the others on top
    of those already found); sample_block: (N,) block ids for the intervals
    (:func:`mjtrack.diagnose.stats.sample_blocks`), None = one block per fold; score_folds: the
    folds that are scored, each by the fit on all others (None: every fold, cross-validation;
    (0,): a test log in fold 0, fitted on fold 1); valid: (M,) windows whose baseline prediction
    exists (a simulator's may diverge: those are neither fitted nor scored), None = all.
    """

    data: DriveData
    baseline: Baseline
    horizon_s: float
    dt: np.ndarray
    starts: np.ndarray
    ends: np.ndarray
    fold: np.ndarray
    sample_fold: np.ndarray
    fit_windows: np.ndarray
    measured: np.ndarray | None
    speed_ok: np.ndarray | None
    base: tuple = ()
    sample_block: np.ndarray | None = None
    score_folds: tuple | None = None
    valid: np.ndarray | None = None

    @property
    def valid_mask(self) -> np.ndarray:
        """(M,) bool: :attr:`valid`, all True when None."""
        return np.ones(self.starts.size, bool) if self.valid is None else self.valid

    @property
    def scored(self) -> np.ndarray:
        """(M,) bool: the valid windows that are scored (all, or those of ``score_folds``: a test log)."""
        if self.score_folds is None:
            return self.valid_mask
        return np.isin(self.fold, self.score_folds) & self.valid_mask

    @property
    def window_block(self) -> np.ndarray:
        """(M,) block of each window (that of its start sample)."""
        blocks = self.sample_block if self.sample_block is not None else self.sample_fold
        return blocks[self.starts]

    @property
    def yaw_scale(self) -> float:
        return self.baseline.robot.track_gauge / 2


def twist(problem: Problem, effect: Effect | None, theta, *, drive: str = "command") -> np.ndarray:
    """Body twist (N, 3) of baseline (+ base effects) + effect, driven by the commands (through the
    input effects, if any) or, for fitting ground effects, by the measured speeds (with causal
    speed samples, :func:`mjtrack.diagnose.run.speed_timing`, step k runs at the speed sampled at
    t_k+1: the one sampled at t_k is still the previous step's)."""
    s = problem.baseline.surrogate
    parts = ([(effect, theta)] if effect is not None else []) + list(problem.base)
    if drive == "measured" and problem.measured is not None and (effect is None or effect.kind == "ground"):
        speeds = problem.measured
        if s.causal_speeds:  # a speed sampled at t_k is the one just before t_k: step k runs at the next sample's
            speeds = _next_in_segment(problem.data.seg, speeds)
    else:
        speeds = s.inputs_of(problem.data, parts)
    return s.twist_of(problem.data, speeds, parts)


def _next_in_segment(seg: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(N, 2) the next sample's value inside each segment, the sample's own at each segment end."""
    out = v.copy()
    same = seg[1:] == seg[:-1]
    out[:-1][same] = v[1:][same]
    return out


def errors(problem: Problem, effect: Effect | None, theta, windows: np.ndarray, *, drive: str = "command") -> np.ndarray:
    """Window errors (W, 3) (along, across [m], yaw [rad]) of baseline + effect on ``windows``."""
    tw = twist(problem, effect, theta, drive=drive)
    return window_errors(tw, problem.dt, problem.data.poses, problem.starts[windows], problem.ends[windows])


def speed_residuals(problem: Problem, effect: Effect, theta, samples: np.ndarray) -> np.ndarray:
    """Transformed command minus measured track speed [m/s] on ``samples`` (boolean (N,)), flattened."""
    parts = [(e, p) for e, p in problem.base if e.kind == "input"] + [(effect, theta)]
    v = problem.baseline.speeds(problem, parts)
    return (v[samples] - problem.data.meas[samples]).ravel()


def uses_speeds(problem: Problem, effect: Effect) -> bool:
    """Input effects are fitted to the measured track speeds when the log has them."""
    return effect.kind == "input" and problem.speed_ok is not None and bool(problem.speed_ok.any())


def fit(problem: Problem, effect: Effect, train_folds: np.ndarray, *, covariance: bool = False,
        start: np.ndarray | None = None):
    """Least-squares estimate (P,) of the effect's parameters on the folds ``train_folds``; with
    ``covariance`` also its block-robust covariance (P, P) (:func:`mjtrack.diagnose.stats.sandwich`,
    the blocks of :attr:`Problem.window_block`; NaN where the estimate sits on a bound). ``start``:
    one start (e.g. the full-data estimate for the fold fits) instead of the effect's start grid."""
    robot = problem.baseline.robot
    lo, hi = (np.asarray(b, float) for b in effect.bounds(robot))
    if uses_speeds(problem, effect):
        samples = np.isin(problem.sample_fold, train_folds) & problem.speed_ok
        sblock = problem.sample_block if problem.sample_block is not None else problem.sample_fold
        row_block = np.repeat(sblock[samples], 2)

        def resid(p):
            return speed_residuals(problem, effect, p, samples)
    else:
        w = problem.fit_windows[np.isin(problem.fold[problem.fit_windows], train_folds)]
        ell = problem.yaw_scale
        row_block = np.repeat(problem.window_block[w], 3)

        def resid(p):
            e = errors(problem, effect, p, w, drive="measured")
            e[:, 2] *= ell
            return e.ravel()

    starts = np.asarray(effect.starts(robot, problem.data) if start is None else [start], float)
    inner_lo = np.where(np.isfinite(lo), lo + 1e-6 * (1 + np.abs(np.where(np.isfinite(lo), lo, 0))), -np.inf)
    inner_hi = np.where(np.isfinite(hi), hi - 1e-6 * (1 + np.abs(np.where(np.isfinite(hi), hi, 0))), np.inf)
    starts = np.clip(starts, inner_lo, inner_hi)
    costs = [float(np.sum(resid(p) ** 2)) for p in starts] if len(starts) > 1 else [0.0]
    x0 = starts[int(np.argmin(costs))]
    res = optimize.least_squares(resid, x0, bounds=(lo, hi), method="trf", x_scale="jac", diff_step=DIFF_STEP,
                                 xtol=1e-6, ftol=1e-8, max_nfev=60)
    p = res.x
    log.debug("fit %s on folds %s: %s (cost %.4g, %d evaluations)", effect.name, list(train_folds), p, res.cost, res.nfev)
    if not covariance:
        return p
    cov = sandwich(res.jac, res.fun, row_block)
    at_bound = (np.abs(res.x - lo) < 1e-6 * (1 + np.abs(lo))) | (np.abs(res.x - hi) < 1e-6 * (1 + np.abs(hi)))
    cov[at_bound, :] = np.nan
    cov[:, at_bound] = np.nan
    return p, cov


def fit_inputs_jointly(problem: Problem, parts: list, train_folds: np.ndarray) -> list[np.ndarray]:
    """Joint least-squares estimates of several input effects ((Effect, theta) start pairs) fitted
    to the measured track speeds of ``train_folds`` (the other effects of ``problem.base`` fixed):
    coupled effects (a scale and a limit, a lag and a delay) are not separable one at a time."""
    effects = [e for e, _ in parts]
    sizes = [len(e.params) for e in effects]
    robot = problem.baseline.robot
    lo = np.concatenate([np.asarray(e.bounds(robot)[0], float) for e in effects])
    hi = np.concatenate([np.asarray(e.bounds(robot)[1], float) for e in effects])
    x0 = np.concatenate([np.asarray(t, float) for _, t in parts])
    x0 = np.clip(x0, np.where(np.isfinite(lo), lo + 1e-6, -np.inf), np.where(np.isfinite(hi), hi - 1e-6, np.inf))
    samples = np.isin(problem.sample_fold, train_folds) & problem.speed_ok
    fixed = [(e, p) for e, p in problem.base if e.kind == "input" and e not in effects]

    def split(x):
        return np.split(x, np.cumsum(sizes)[:-1])

    def resid(x):
        v = problem.baseline.speeds(problem, fixed + list(zip(effects, split(x))))
        return (v[samples] - problem.data.meas[samples]).ravel()

    res = optimize.least_squares(resid, x0, bounds=(lo, hi), method="trf", x_scale="jac", diff_step=DIFF_STEP,
                                 xtol=1e-6, ftol=1e-8, max_nfev=100)
    return split(res.x)
