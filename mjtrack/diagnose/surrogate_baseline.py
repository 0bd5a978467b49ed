"""The surrogate baselines: the rigid-track Coulomb surrogate and the kinematic model (2.1).

Both are cheap (one pass over the log costs O(N), :mod:`mjtrack.diagnose.residuals`), so a
window starts at every sample and effects are fitted by nonlinear least squares
(:func:`mjtrack.diagnose.fit.fit`); the model and its effects are those of
:class:`mjtrack.diagnose.effects.Surrogate`. With measured track speeds the input effects are fitted
to the speeds themselves (:func:`mjtrack.diagnose.fit.speed_residuals`).
"""

from __future__ import annotations

import numpy as np

from mjtrack.diagnose import fit as fitmod
from mjtrack.diagnose.baseline import Baseline, ModelForm
from mjtrack.diagnose.effects import Effect, Surrogate
from mjtrack.io.robot import Robot

# The surrogate's own error on an effect's size, 1 sigma, as a share of the size |theta - nominal|:
# the RMS relative error of the 16 estimates of the MuJoCo matrix of benchmarks/diagnose_mujoco_effects.py
# (an independent physics; benchmarks/results/diagnose_mujoco_effects.json; python
# benchmarks/diagnose_benchmark.py prints it).
MODEL_REL = 0.071

# The surrogate's ABSOLUTE model-form error, 1 sigma, in the effect's own units: how far apart two
# independent physics of ONE robot description lie on a clean log, which does not shrink with the
# effect's size. 1 sigma = the RMS of the measured gaps (as MODEL_REL is an RMS), taken over every
# geometry and manoeuvre measured (the gaps are one-signed biases; the RMS carries mean and spread):
# - icr_spread: the benchmark's generator (mjtrack/testing/diagnose_physics.py, at its settings) turns with a
#   wider steady ICR spread than the Coulomb reference of the description the surrogate's q0 come
#   from: +3.68 +3.68 +1.69 / +3.27 +3.28 +1.60 / +1.84 +1.85 +1.85 % (small / large / wheeled x 3
#   commands; python benchmarks/generator_spread.py prints the RMS): 0.0267.
# - friction_scale: the generator's yaw transients are faster than the Coulomb rollout's (the
#   surrogate's rigid-body reference); friction_scale shortens every transient as 1/fs, so a dead
#   time ratio r = generator / coulomb reads as fs = 1/r: r = 0.890 0.935 0.887 0.938 (small),
#   0.900 0.954 0.918 0.951 (large), 0.806 0.856 0.907 0.930 (wheeled as a 0.97 m track) over the 4
#   distinct steps (python benchmarks/diagnose_transient_steps.py --skip-logs), 1/r - 1 = 0.05-0.24:
#   RMS 0.118 (python benchmarks/diagnose_transient_steps.py prints it).
# - every other effect: 0 (speed effects are fitted to measured speeds, an exact transform; the
#   others' truth is transformed exactly by both physics).
MODEL_ABS = {"icr_spread": 0.0267, "friction_scale": 0.118}

MODEL_FORM = ModelForm(MODEL_REL, MODEL_ABS,
                       measured_by="python benchmarks/diagnose_benchmark.py (rel, from "
                                   "benchmarks/results/diagnose_mujoco_effects.json); python "
                                   "benchmarks/generator_spread.py (icr_spread); python "
                                   "benchmarks/diagnose_transient_steps.py (friction_scale)")

# what each effect changes in the surrogate (:mod:`mjtrack.diagnose.effects`)
CHANGES = {
    "track_speed_scale": "the track speeds driving the ground model = scale x command",
    "drive_lag": "first-order lag on the track speeds (exact for held commands)",
    "drive_delay": "dead time on the track speeds (the held commands interpolated)",
    "drive_speed_limit": "track speeds clipped at +-limit",
    "yaw_rate_limit": "the commanded yaw rate (V_R - V_L)/T clipped, the mean track speed kept",
    "cg_x": "the quasi-static ICRs (exact Coulomb solves, tabulated) and the centripetal load transfer",
    "cg_y": "the quasi-static ICRs (exact Coulomb solves, tabulated) and the load split of the transient",
    "friction_scale": "the inertial response (as 1/scale) and the friction bounds of the transient",
    "mu_ratio": "the quasi-static ICRs (exact Coulomb solves, tabulated) and the transient's force bounds",
    "slope": "g (slope_x, slope_y) in the body frame added to the effective acceleration",
    "icr_spread": "the track ICRs (y_l, y_r) scaled",
}
KINEMATIC_UNTESTABLE = {"friction_scale": "acts only through the inertial response, which the kinematic baseline "
                                          "does not model"}


class SurrogateBaseline(Baseline):
    """The Coulomb surrogate ("coulomb") or the kinematic model ("kinematic") of a robot.

    Args:
        robot: the nominal robot description.
        kind: "coulomb" or "kinematic".
        transient: model the friction-limited transient (coulomb only; :class:`Surrogate`).
        causal_speeds: the log's speed-sample timing (:func:`mjtrack.diagnose.run.speed_timing`).
    """

    noun = "surrogate"
    model_form = MODEL_FORM
    max_effects = 3

    def __init__(self, robot: Robot, kind: str, *, transient: bool = False, causal_speeds: bool = True) -> None:
        self.surrogate = Surrogate(robot, kind, transient=transient, causal_speeds=causal_speeds)
        self.robot = robot
        self.name = kind
        self.untestable = dict(KINEMATIC_UNTESTABLE) if kind == "kinematic" else {}
        self.vocabulary = {n: c for n, c in CHANGES.items() if n not in self.untestable}

    @property
    def transient(self) -> bool:
        return self.surrogate.transient

    def describe(self) -> str:
        if self.name == "coulomb":
            return ("nominal robot, rigid-track Coulomb steady-state surrogate (quasi-static ICRs + first-order "
                    "inertial response" + (" + friction-limited transients" if self.transient else "")
                    + "), driven by the commanded track speeds")
        return "nominal kinematic model (2.1), driven by the commanded track speeds"

    def nominal(self, effect: Effect, problem: fitmod.Problem) -> np.ndarray:
        data = problem.data
        if effect.name == "drive_speed_limit":
            return np.array([np.max(np.abs(data.cmd))])
        if effect.name == "yaw_rate_limit":
            return np.array([np.max(np.abs(data.cmd[:, 1] - data.cmd[:, 0])) / self.robot.track_gauge])
        return np.array(effect.nominal(self.robot), float)

    def errors(self, problem: fitmod.Problem, windows: np.ndarray, effect: Effect | None = None,
               values=None) -> np.ndarray:
        if effect is None:
            return fitmod.errors(problem, None, (), windows)[None]
        return np.stack([fitmod.errors(problem, effect, v, windows) for v in values])

    def fit(self, problem: fitmod.Problem, effect: Effect, train_folds: np.ndarray, *, covariance: bool = False,
            start: np.ndarray | None = None):
        return fitmod.fit(problem, effect, train_folds, covariance=covariance, start=start)

    def resolution(self, effect: Effect, theta) -> np.ndarray:
        """The optimiser's relative finite-difference step (:data:`mjtrack.diagnose.fit.DIFF_STEP`): an
        optimum at a kink of the cost (a dead time fitted to sampled track speeds) is located no
        better."""
        out = fitmod.DIFF_STEP * np.maximum(np.abs(np.asarray(theta, float)), 1e-12)
        return out

    def speeds(self, problem: fitmod.Problem, parts) -> np.ndarray:
        return self.surrogate.inputs_of(problem.data, list(parts), instant=True)

    def lateral_acceleration(self, problem: fitmod.Problem) -> float:
        tw = self.surrogate.twist(problem.data, problem.data.cmd)
        return float(np.max(np.abs(tw[:, 0] * tw[:, 2])))

    def nominal_icrs(self) -> np.ndarray:
        return self.surrogate.q_nominal

    def interval_method(self) -> str:
        return ("the block-robust sandwich (a linearised blocked bootstrap over windows; the residuals carry the "
                "surrogate's own error)")


__all__ = ["CHANGES", "MODEL_ABS", "MODEL_FORM", "MODEL_REL", "SurrogateBaseline"]
