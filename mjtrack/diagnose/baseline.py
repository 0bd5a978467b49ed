"""What a diagnosis needs from the model it diagnoses: the :class:`Baseline` interface.

A baseline is the nominal model of a robot on one log: it predicts the log's windows (a window
starts at a measured state and runs open loop under the logged commands for the horizon), and
it can be *extended* by a candidate effect of the public vocabulary
(:data:`mjtrack.diagnose.vocabulary.EFFECTS`) at parameter values, many values in one call (a
simulator batches them). Everything else -- the folds, the fits' held-out scores, the finding
test, ties and order, the intervals, the result and its outputs -- is the same for every baseline
(:mod:`mjtrack.diagnose.select`, :mod:`mjtrack.diagnose.result`, :mod:`mjtrack.diagnose.report`).

Implemented by :class:`mjtrack.diagnose.surrogate.SurrogateBaseline` (the rigid-track
Coulomb surrogate and the kinematic model: cheap, windows at every sample, least-squares fits)
and :class:`mjtrack.diagnose.mujoco_baseline.MujocoBaseline` (the MuJoCo robot: a pass over the
windows per parameter value, non-overlapping windows, fits on a fixed grid of values).

Model-form error (:class:`ModelForm`). No resampling of one log shows a baseline's own
systematic error on an effect's size: it is the same in every block. Each baseline therefore
carries it, measured on logs whose truth is known, as two 1-sigma terms added in quadrature to
an estimate's statistical standard error: a relative one, ``rel`` x |estimate - nominal| (the
RMS of |estimate - truth| / |truth - nominal| over the effects of a battery; for ``slope``, a
vector, ``rel`` x its length on each component), and an absolute one per
effect in the effect's units (how far two independent physics of one robot description lie
apart on a clean log, which does not shrink with the effect's size). ``measured_by`` names the
script that measured them and the result file it wrote.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from mjtrack.diagnose.problem import Problem
from mjtrack.diagnose.vocabulary import EFFECTS, Effect
from mjtrack.io.robot import Robot


#: limits whose "no effect" is no limit at all (nominal +inf or far above what binds): what they change
#: in a motion goes as 1/limit (a ramp's delay dv / a, the time a force limit adds to a change of
#: momentum), so their size is measured in 1/limit
RECIPROCAL = ("drive_accel_limit", "drive_force_limit")


@dataclass(frozen=True)
class ModelForm:
    """A baseline's own error on an effect's size (module docstring).

    Args:
        rel: 1-sigma error as a share of the effect's size |theta - nominal| [-].
        absolute: 1-sigma error per effect name, in the effect's own units (missing: 0).
        measured_by: the command that measured the values and the result file it wrote.
    """

    rel: float
    absolute: Mapping[str, float] = field(default_factory=dict)
    measured_by: str = ""

    def se(self, effect: str, theta, nominal) -> np.ndarray:
        """Standard error (P,) of the baseline's own approximation at ``theta`` (P,) for an effect
        whose no-effect values are ``nominal`` (P,): the relative and absolute terms in quadrature."""
        theta = np.asarray(theta, float)
        nominal = np.asarray(nominal, float)
        if effect in RECIPROCAL:  # the size in 1/theta, back in theta's units: theta |1 - theta / nominal|
            size = np.abs(theta * (1.0 - theta / nominal))
        else:
            size = np.abs(theta - nominal)
        if effect == "slope":  # a vector: its size and its direction each off by rel, on both components
            size = np.full(size.shape, float(np.hypot(*size)))
        rel = self.rel * np.where(np.isfinite(size), size, 0.0)
        return np.hypot(rel, self.absolute.get(effect, 0.0))


class Baseline(abc.ABC):
    """The model a diagnosis extends and scores (module docstring).

    Attributes:
        name: "coulomb", "kinematic" or "mujoco" (diagnosis.json ``baseline.simulator``).
        noun: how text names it ("surrogate", "MuJoCo robot").
        robot: the nominal robot description.
        vocabulary: the effects it can simulate: effect name -> what the effect changes in it.
        untestable: effects of the public vocabulary it cannot test on this log, with the reason.
        model_form: its own error on an effect's size (:class:`ModelForm`).
        max_effects: forward-selection steps it affords by default (each costs a pass over every
            remaining candidate).
        transient: whether it models the friction-limited transient after speed changes.
        free_steps: forward-selection steps taken whatever the error left; the others (up to
            ``max_effects``) only when it can still hold a finding beyond the pose noise (None: all
            steps are free).
    """

    name: str
    noun: str
    robot: Robot
    vocabulary: Mapping[str, str]
    untestable: Mapping[str, str]
    model_form: ModelForm
    max_effects: int
    transient: bool = False
    free_steps: int | None = None

    @abc.abstractmethod
    def describe(self) -> str:
        """One sentence: what is simulated and how (diagnosis.json ``baseline.model``)."""

    @abc.abstractmethod
    def nominal(self, effect: Effect, problem: Problem) -> np.ndarray:
        """The effect's no-effect parameter values (P,) in this baseline (e.g. the robot's own
        drive lag, or the log's largest command for a speed limit)."""

    @abc.abstractmethod
    def errors(self, problem: Problem, windows: np.ndarray, effect: Effect | None = None,
               values=None) -> np.ndarray:
        """Window errors (V, W, 3) (along, across [m], yaw [rad], in each window's measured start
        frame) of the windows ``windows`` (W,) (indices into ``problem.starts``) under the
        baseline with ``problem.base`` and, unless ``effect`` is None, the effect at each of the V
        parameter vectors ``values`` (V, P); effect None: (1, W, 3). NaN: a diverged window."""

    @abc.abstractmethod
    def fit(self, problem: Problem, effect: Effect, train_folds: np.ndarray, *, covariance: bool = False,
            start: np.ndarray | None = None):
        """The effect's estimate (P,) fitted on the folds ``train_folds``; with ``covariance`` also
        its statistical covariance (P, P) (NaN where it cannot be had). ``start``: where to start
        (the full-data estimate, for the fold fits)."""

    def default_effects(self) -> list[str]:
        """The effects a diagnosis tests by default: those of the public vocabulary it can simulate
        or says why it cannot, in the vocabulary's order."""
        return [n for n in EFFECTS if n in self.vocabulary or n in self.untestable]

    def resolution(self, effect: Effect, theta) -> np.ndarray:
        """Standard error (P,) of locating the optimum by the fit itself (default none)."""
        return np.zeros(len(effect.params))

    def speeds(self, problem: Problem, parts) -> np.ndarray | None:
        """Track speeds (N, 2) [m/s] the model predicts at the sample times under the input effects
        among ``parts`` ((Effect, theta) pairs), or None when it does not model them apart."""
        return None

    def held_out_errors(self, problem: Problem, windows: np.ndarray, effect: Effect, theta) -> np.ndarray:
        """Window errors (W, 3) of the held-out windows ``windows`` under the effect at a fold's
        estimate ``theta`` (P,): by default :meth:`errors` at that value."""
        return self.errors(problem, windows, effect, [theta])[0]

    def speed_residuals(self, problem: Problem, effect: Effect, theta, samples: np.ndarray) -> np.ndarray:
        """Predicted minus measured track speed [m/s] on ``samples`` (boolean (N,)), flattened, under
        the input effects of ``problem.base`` and ``effect`` at ``theta`` (a model of the speeds
        needed: :meth:`speeds`)."""
        parts = [(e, p) for e, p in problem.base if e.kind == "input"] + [(effect, theta)]
        v = self.speeds(problem, parts)
        return (v[samples] - problem.data.meas[samples]).ravel()

    def refit_inputs(self, problem: Problem, parts, train_folds: np.ndarray) -> list[np.ndarray]:
        """Estimates of several input effects ((Effect, theta) start pairs) fitted together on the
        folds ``train_folds`` (coupled effects, a lag and a delay, are not separable one at a
        time); by default their estimates as they are."""
        return [np.asarray(theta, float) for _, theta in parts]

    def simulator_warnings(self) -> list[dict]:
        """The simulator's warnings so far, each ``{"window": index into the problem's windows, or
        None when raised outside a window, "simulation": what was simulated, "warning": its text}``;
        a simulation that warned counts as diverged (empty for a model that simulates nothing)."""
        return []

    def lateral_acceleration(self, problem: Problem) -> float | None:
        """The largest lateral acceleration |vx wz| [m/s^2] of its nominal prediction of the log (a
        friction level shows only where it is high enough), or None when it does not say."""
        return None

    def nominal_icrs(self) -> np.ndarray | None:
        """Its quasi-static ICRs (y_l, y_r, x_c) [m], for the report, or None."""
        return None

    def interval_method(self) -> str:
        """How the statistical part of an interval is had (diagnosis.json ``method.interval``)."""
        return ""

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"


__all__ = ["Baseline", "ModelForm"]
