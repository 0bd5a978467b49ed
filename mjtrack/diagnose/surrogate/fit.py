"""The surrogate baselines' parameter estimation by nonlinear least squares.

Objective. Ground effects (and input effects when the log has no track speeds) are fitted to
the fixed-horizon prediction errors of the training windows: the residual of a window is its
error in the start frame (along, across [m], yaw x T/2 [m]) -- the same prediction the ranking
scores, so the fit minimises what is later measured on held-out data. When the log has
measured track speeds, the ground model is driven by them (an input effect cannot leak into a
ground estimate) and input effects are fitted to the speeds themselves (residual: transformed
command minus measured speed, both tracks), which is direct and far better conditioned.

Method. Multi-start (each effect's start grid, :data:`SETTINGS`, the cheapest start kept) then
``scipy.optimize.least_squares`` (trust-region reflective, bounds, finite-difference
Jacobian). Intervals are not taken from the Jacobian alone: the windows overlap and their errors
are strongly correlated, so (J^T J)^-1 s^2 would be far too narrow; the covariance is the
block-robust sandwich (:func:`mjtrack.diagnose.stats.cluster_sandwich`), and
:mod:`mjtrack.diagnose.select` takes the larger of it and the delete-one-fold jackknife.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy import optimize

from mjtrack.diagnose.baseline import Baseline
from mjtrack.diagnose.problem import Problem
from mjtrack.diagnose.residuals import DriveData, window_errors
from mjtrack.diagnose.stats import cluster_sandwich
from mjtrack.diagnose.surrogate.model import Surrogate, cg_limit
from mjtrack.diagnose.vocabulary import Effect
from mjtrack.io.robot import Robot

log = logging.getLogger(__name__)

# relative finite-difference step of the Jacobian: also the resolution of an optimum at a kink of
# the cost (a dead time fitted to sampled speeds has a V-shaped cost, kinks one sample apart), so
# the intervals include it (:meth:`mjtrack.diagnose.surrogate.SurrogateBaseline.resolution`)
DIFF_STEP = 1e-3
SLOPE_MAX = float(np.sin(0.5))  # [-] slope components up to a 0.5 rad (29 deg) incline


@dataclass(frozen=True)
class FitSettings:
    """How the surrogate fits one effect: ``nominal(robot)`` its no-effect values (P,),
    ``bounds(robot)`` ((P,), (P,)) and ``starts(robot, data)`` its start grid (S, P)."""

    nominal: Callable[[Robot], tuple]
    bounds: Callable[[Robot], tuple]
    starts: Callable[[Robot, DriveData], np.ndarray]


def _grid(*values) -> Callable:
    return lambda robot, data: np.array(values, float).reshape(len(values), -1)


#: the surrogate's fit of each effect it simulates
SETTINGS: dict[str, FitSettings] = {
    "track_speed_scale": FitSettings(lambda r: (1.0,), lambda r: ((0.3,), (3.0,)), _grid(0.8, 0.95, 1.05, 1.25)),
    "drive_lag": FitSettings(lambda r: (0.0,), lambda r: ((1e-3,), (3.0,)),
                             _grid(0.02, 0.05, 0.1, 0.2, 0.4, 0.8, 1.6)),
    # the fit to sampled speeds is V-shaped one sample wide: start on a grid of one sample
    "drive_delay": FitSettings(lambda r: (0.0,), lambda r: ((0.0,), (2.0,)),
                               lambda r, d: np.arange(0.0, 1.0, max(float(np.median(np.diff(d.t))), 0.01))
                               .reshape(-1, 1)),
    "drive_speed_limit": FitSettings(lambda r: (np.inf,), lambda r: ((0.02,), (np.inf,)),
                                     lambda r, d: np.quantile(np.abs(d.cmd), [0.5, 0.7, 0.85, 0.95]).reshape(-1, 1)),
    "drive_turn_limit": FitSettings(lambda r: (np.inf,), lambda r: ((0.01,), (np.inf,)),
                                    lambda r, d: np.quantile(np.abs(d.cmd[:, 1] - d.cmd[:, 0]) / 2,
                                                             [0.5, 0.7, 0.85, 0.95]).reshape(-1, 1) + 1e-3),
    # a ramp of 1/8 s to 4 s for the log's largest command
    "drive_accel_limit": FitSettings(lambda r: (np.inf,), lambda r: ((0.01,), (np.inf,)),
                                     lambda r, d: np.max(np.abs(d.cmd)) * np.array([[0.25], [1.0], [2.0], [8.0]])),
    "cg_x": FitSettings(lambda r: (r.cg_x,), lambda r: ((-cg_limit(r, "x"),), (cg_limit(r, "x"),)),
                        lambda r, d: np.array([[-0.1], [-0.03], [0.03], [0.1]]) * r.track_length),
    "cg_y": FitSettings(lambda r: (r.cg_y,), lambda r: ((-cg_limit(r, "y"),), (cg_limit(r, "y"),)),
                        lambda r, d: np.array([[-0.15], [-0.05], [0.05], [0.15]]) * r.track_gauge),
    "friction_scale": FitSettings(lambda r: (1.0,), lambda r: ((0.05,), (20.0,)), _grid(0.3, 0.7, 1.5, 3.0)),
    "mu_ratio": FitSettings(lambda r: (r.friction_left / r.friction_right,), lambda r: ((1 / 3,), (3.0,)),
                            _grid(0.5, 0.8, 1.25, 2.0)),
    "slope": FitSettings(lambda r: (0.0, 0.0), lambda r: ((-SLOPE_MAX, -SLOPE_MAX), (SLOPE_MAX, SLOPE_MAX)),
                         lambda r, d: np.array([[np.sin(s) * np.cos(a), np.sin(s) * np.sin(a)]
                                                for s in (0.05, 0.15) for a in np.arange(8) * np.pi / 4])),
    "icr_spread": FitSettings(lambda r: (1.0,), lambda r: ((0.3,), (4.0,)), _grid(0.7, 0.9, 1.1, 1.4)),
}


def twist(model: Surrogate, problem: Problem, effect: Effect | None, theta, *, drive: str = "command") -> np.ndarray:
    """Body twist (N, 3) of baseline (+ base effects) + effect, driven by the commands (through the
    input effects, if any) or, for fitting ground effects, by the measured speeds (with causal
    speed samples, :func:`mjtrack.diagnose.run.speed_timing`, step k runs at the speed sampled at
    t_k+1: the one sampled at t_k is still the previous step's)."""
    s = model
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


def errors(model: Surrogate, problem: Problem, effect: Effect | None, theta, windows: np.ndarray, *,
           drive: str = "command") -> np.ndarray:
    """Window errors (W, 3) (along, across [m], yaw [rad]) of baseline + effect on ``windows``."""
    tw = twist(model, problem, effect, theta, drive=drive)
    return window_errors(tw, problem.dt, problem.data.poses, problem.starts[windows], problem.ends[windows])


def fit(bl: Baseline, model: Surrogate, problem: Problem, effect: Effect, train_folds: np.ndarray, *,
        covariance: bool = False, start: np.ndarray | None = None):
    """Least-squares estimate (P,) of the effect's parameters on the folds ``train_folds`` for the
    baseline ``bl`` whose surrogate is ``model``; with ``covariance`` also its block-robust
    covariance (P, P) (:func:`mjtrack.diagnose.stats.cluster_sandwich`, the blocks of
    :attr:`Problem.window_block`; NaN where the estimate sits on a bound). ``start``: one start
    (e.g. the full-data estimate for the fold fits) instead of the effect's start grid."""
    robot = bl.robot
    settings = SETTINGS[effect.name]
    lo, hi = (np.asarray(b, float) for b in settings.bounds(robot))
    if problem.uses_speeds(effect):
        samples = np.isin(problem.sample_fold, train_folds) & problem.speed_ok
        row_block = np.repeat(problem.speed_block[samples], 2)

        def resid(p):
            return bl.speed_residuals(problem, effect, p, samples)
    else:
        w = problem.fit_windows[np.isin(problem.fold[problem.fit_windows], train_folds)]
        ell = problem.yaw_scale
        row_block = np.repeat(problem.window_block[w], 3)

        def resid(p):
            e = errors(model, problem, effect, p, w, drive="measured")
            e[:, 2] *= ell
            return e.ravel()

    starts = np.asarray(settings.starts(robot, problem.data) if start is None else [start], float)
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
    cov = cluster_sandwich(res.jac, res.fun, row_block)
    at_bound = (np.abs(res.x - lo) < 1e-6 * (1 + np.abs(lo))) | (np.abs(res.x - hi) < 1e-6 * (1 + np.abs(hi)))
    cov[at_bound, :] = np.nan
    cov[:, at_bound] = np.nan
    return p, cov


def fit_inputs_jointly(bl: Baseline, problem: Problem, parts: list, train_folds: np.ndarray) -> list[np.ndarray]:
    """Joint least-squares estimates of several input effects ((Effect, theta) start pairs) fitted
    to the measured track speeds of ``train_folds`` (the other effects of ``problem.base`` fixed):
    coupled effects (a scale and a limit, a lag and a delay) are not separable one at a time."""
    effects = [e for e, _ in parts]
    sizes = [len(e.params) for e in effects]
    bounds = [SETTINGS[e.name].bounds(bl.robot) for e in effects]
    lo = np.concatenate([np.asarray(b[0], float) for b in bounds])
    hi = np.concatenate([np.asarray(b[1], float) for b in bounds])
    x0 = np.concatenate([np.asarray(t, float) for _, t in parts])
    x0 = np.clip(x0, np.where(np.isfinite(lo), lo + 1e-6, -np.inf), np.where(np.isfinite(hi), hi - 1e-6, np.inf))
    samples = np.isin(problem.sample_fold, train_folds) & problem.speed_ok
    fixed = [(e, p) for e, p in problem.base if e.kind == "input" and e not in effects]

    def split(x):
        return np.split(x, np.cumsum(sizes)[:-1])

    def resid(x):
        v = bl.speeds(problem, fixed + list(zip(effects, split(x))))
        return (v[samples] - problem.data.meas[samples]).ravel()

    res = optimize.least_squares(resid, x0, bounds=(lo, hi), method="trf", x_scale="jac", diff_step=DIFF_STEP,
                                 xtol=1e-6, ftol=1e-8, max_nfev=100)
    return split(res.x)
