"""The surrogate baselines: the rigid-track Coulomb surrogate and the kinematic model (2.1).

Both are cheap (one pass over the log costs O(N), :mod:`mjtrack.diagnose.residuals`), so a
window starts at every sample and effects are fitted by nonlinear least squares
(:func:`mjtrack.diagnose.surrogate.fit.fit`); the model and its effects are those of
:class:`mjtrack.diagnose.surrogate.model.Surrogate`. With measured track speeds the input effects
are fitted to the speeds themselves (:meth:`mjtrack.diagnose.baseline.Baseline.speed_residuals`).
"""

from __future__ import annotations

import logging

import numpy as np

from mjtrack.diagnose.baseline import Baseline, ModelForm
from mjtrack.diagnose.problem import Problem
from mjtrack.diagnose.surrogate import fit as fitmod
from mjtrack.diagnose.surrogate.model import Surrogate
from mjtrack.diagnose.vocabulary import Effect
from mjtrack.diagnose import stats as st
from mjtrack.diagnose.problem import concat_logs
from mjtrack.diagnose.residuals import DriveData, window_errors, windows
from mjtrack.errors import InputError
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import Robot

log = logging.getLogger(__name__)

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
#   commands; python benchmarks/diagnose_transient_steps.py --icr-spread prints the RMS): 0.0267.
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
                                   "benchmarks/diagnose_transient_steps.py --icr-spread (icr_spread); python "
                                   "benchmarks/diagnose_transient_steps.py (friction_scale)")

# what each effect changes in the surrogate (:mod:`mjtrack.diagnose.surrogate.model`)
CHANGES = {
    "track_speed_scale": "the track speeds driving the ground model = scale x command",
    "drive_lag": "first-order lag on the track speeds (exact for held commands)",
    "drive_delay": "dead time on the track speeds (the held commands interpolated)",
    "drive_speed_limit": "track speeds clipped at +-limit",
    "drive_accel_limit": "each track speed's ramp towards its command limited to this rate",
    "drive_turn_limit": "the half difference of the track speeds (V_R - V_L)/2 clipped, the mean track speed kept",
    "cg_x": "the quasi-static ICRs (exact Coulomb solves, tabulated) and the centripetal load transfer",
    "cg_y": "the quasi-static ICRs (exact Coulomb solves, tabulated) and the load split of the transient",
    "friction_scale": "the inertial response (as 1/scale) and the friction bounds of the transient",
    "mu_ratio": "the quasi-static ICRs (exact Coulomb solves, tabulated) and the transient's force bounds",
    "slope": "g (slope_x, slope_y) in the body frame added to the effective acceleration",
    "icr_spread": "the track ICRs (y_l, y_r) scaled",
}
# drive effects whose physics the surrogate lacks (the MuJoCo robot simulates them)
UNTESTABLE = {
    "drive_force_limit": "the surrogate imposes the track speeds it is given; a drive that cannot deliver the "
                         "force the ground asks for needs the tracks' own force balance, which only the MuJoCo "
                         "robot has",
}
KINEMATIC_UNTESTABLE = {"friction_scale": "acts only through the inertial response, which the kinematic baseline "
                                          "does not model"}


DEFAULT_HORIZON = 2.0  # [s]


class SurrogateBaseline(Baseline):
    """The Coulomb surrogate ("coulomb") or the kinematic model ("kinematic") of a robot.

    Args:
        robot: the nominal robot description.
        kind: "coulomb" or "kinematic".
        transient: model the friction-limited transient (coulomb only; :class:`Surrogate`).
        causal_speeds: the log's speed-sample timing (:func:`speed_timing`).
    """

    noun = "surrogate"
    model_form = MODEL_FORM
    max_effects = 3

    def __init__(self, robot: Robot, kind: str, *, transient: bool = False, causal_speeds: bool = True) -> None:
        self.surrogate = Surrogate(robot, kind, transient=transient, causal_speeds=causal_speeds)
        self.robot = robot
        self.name = kind
        self.untestable = {**UNTESTABLE, **(KINEMATIC_UNTESTABLE if kind == "kinematic" else {})}
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

    def nominal(self, effect: Effect, problem: Problem) -> np.ndarray:
        data = problem.data
        if effect.name == "drive_speed_limit":
            return np.array([np.max(np.abs(data.cmd))])
        if effect.name == "drive_turn_limit":
            return np.array([np.max(np.abs(data.cmd[:, 1] - data.cmd[:, 0])) / 2])
        return np.array(fitmod.SETTINGS[effect.name].nominal(self.robot), float)

    def errors(self, problem: Problem, windows: np.ndarray, effect: Effect | None = None,
               values=None) -> np.ndarray:
        if effect is None:
            return fitmod.errors(self.surrogate, problem, None, (), windows)[None]
        return np.stack([fitmod.errors(self.surrogate, problem, effect, v, windows) for v in values])

    def fit(self, problem: Problem, effect: Effect, train_folds: np.ndarray, *, covariance: bool = False,
            start: np.ndarray | None = None):
        return fitmod.fit(self, self.surrogate, problem, effect, train_folds, covariance=covariance, start=start)

    def refit_inputs(self, problem: Problem, parts, train_folds: np.ndarray) -> list[np.ndarray]:
        return fitmod.fit_inputs_jointly(self, problem, parts, train_folds)

    def resolution(self, effect: Effect, theta) -> np.ndarray:
        """The optimiser's relative finite-difference step (:data:`mjtrack.diagnose.surrogate.fit.DIFF_STEP`): an
        optimum at a kink of the cost (a dead time fitted to sampled track speeds) is located no
        better."""
        out = fitmod.DIFF_STEP * np.maximum(np.abs(np.asarray(theta, float)), 1e-12)
        return out

    def speeds(self, problem: Problem, parts) -> np.ndarray:
        return self.surrogate.inputs_of(problem.data, list(parts), instant=True)

    def lateral_acceleration(self, problem: Problem) -> float:
        tw = self.surrogate.twist(problem.data, problem.data.cmd)
        return float(np.max(np.abs(tw[:, 0] * tw[:, 2])))

    def nominal_icrs(self) -> np.ndarray:
        return self.surrogate.q_nominal

    def interval_method(self) -> str:
        return ("the block-robust sandwich (a linearised blocked bootstrap over windows; the residuals carry the "
                "surrogate's own error)")


def choose_baseline(robot: Robot) -> str:
    """"coulomb" when the description gives the contact length (or was built in code), else "kinematic"."""
    return "coulomb" if robot.provided is None or "track_length" in robot.provided else "kinematic"


def make_baseline(name: str, robot: Robot, data: DriveData, starts: np.ndarray, ends: np.ndarray, *,
                  transient: bool | str = "auto") -> tuple[SurrogateBaseline, str, list[str]]:
    """The surrogate baseline of ``name``: returns (model, why it was chosen, notes).

    ``name``: "surrogate" (the rigid-track Coulomb surrogate when the description gives the contact
    length, else the kinematic model, said in a note), "kinematic" (the kinematic model 2.1), or
    "auto" (the MuJoCo robot could not be built: as "surrogate"). ``transient``: see :func:`diagnose`."""
    if name not in ("auto", "surrogate", "kinematic"):
        raise InputError(f"diagnose: unknown surrogate baseline {name!r} (known: auto, surrogate, kinematic)")
    notes = []
    if name == "kinematic":
        base, why = "kinematic", "kinematic: requested"
    else:
        base = choose_baseline(robot)
        why = (f"{name}: the rigid-track Coulomb surrogate (the description gives the contact length)" if base == "coulomb"
               else f"{name}: the kinematic model (the description lacks the contact length the Coulomb surrogate needs)")
    causal = speed_timing(data)
    model = SurrogateBaseline(robot, base, transient=transient is True, causal_speeds=causal)
    if transient == "auto" and base == "coulomb":
        with_tr = SurrogateBaseline(robot, base, transient=True, causal_speeds=causal)
        rmse = [float(np.sqrt(np.mean(np.sum(window_errors(m.surrogate.twist(data, data.cmd), data.step_dt(),
                                                                  data.poses, starts, ends)[:, :2] ** 2, 1))))
                for m in (model, with_tr)]
        if rmse[1] < rmse[0]:
            model = with_tr
        log.debug("diagnose: baseline without / with transients %.4g / %.4g m", *rmse)
    if model.transient:
        notes.append("the baseline includes the friction-limited transient after speed changes (the rigid body "
                     "follows its tracks as fast as the track friction lets it, straight and in yaw)"
                     + (f": it predicts this log better than the steady-state baseline ({rmse[1]:.3g} vs {rmse[0]:.3g} m)"
                        if transient == "auto" else ""))
    if base == "kinematic" and name != "kinematic":
        notes.append("the robot description lacks " + ", ".join(k for k in ("track_length", "mass", "mu")
                                                                 if robot.provided is not None and k not in robot.provided)
                     + f": the baseline is the kinematic model (2.1); ground effects use the Coulomb response of an "
                       f"assumed contact length L = {robot.track_length:g} m")
    return model, why, notes


def choose_horizon(data: DriveData, requested: float | str = "auto") -> tuple[float, str | None]:
    """The prediction horizon [s] and a note when it was adapted to the log.

    A number is used as given. "auto": 2 s when the segments allow it, else the longest horizon
    the segments allow: 3/4 of the median segment length (every segment then starts windows at a
    quarter of its samples; e.g. 1.45 s for the 1.95 s segments of a DRIVE log), rounded down
    to 0.05 s."""
    if requested != "auto":
        return float(requested), None
    cuts = np.flatnonzero(data.seg[1:] != data.seg[:-1]) + 1
    lens = np.array([data.t[hi - 1] - data.t[lo] for lo, hi in zip(np.r_[0, cuts], np.r_[cuts, data.n])])
    allowed = 0.75 * float(np.median(lens))
    if allowed >= DEFAULT_HORIZON:
        return DEFAULT_HORIZON, None
    h = max(np.floor(allowed / 0.05) * 0.05, 0.05)
    return float(h), (f"horizon {h:g} s instead of {DEFAULT_HORIZON:g} s: the log's segments are {np.median(lens):.3g} s "
                      f"long (median of {lens.size}); the longest horizon they allow is 3/4 of that, so that every "
                      "segment starts windows at a quarter of its samples")


def speed_timing(data: DriveData) -> bool:
    """Whether a log's measured track speed at t_k is the one just before t_k (True: causal, the
    command of row k in force from t_k on cannot show in it) or already the response to the row's
    command (False). The log format does not say; physical speeds are continuous, so a speed
    sampled at t_k is causal, but loggers that write the command after reading the sensors, and
    synthetic steady-state logs, give the other. The one under which the nominal model (speed =
    command) fits the measured speeds better is kept: parameter-free, the command changes decide
    it (True when the log has no speeds). Note the ambiguity it resolves: a dead time d logged
    one way is a dead time d - dt logged the other way; no data can tell those apart.
    """
    if data.meas is None:
        return True
    same_seg = np.r_[False, data.seg[1:] == data.seg[:-1]]
    ok = same_seg & np.all(np.isfinite(data.meas), axis=1) & np.r_[False, np.all(np.isfinite(data.meas[:-1]), axis=1)]
    if not ok.any():
        return True
    prev = np.r_[data.cmd[:1], data.cmd[:-1]]
    return bool(np.mean((data.meas[ok] - prev[ok]) ** 2) <= np.mean((data.meas[ok] - data.cmd[ok]) ** 2))


def surrogate_problem(log_: DriveLog, robot: Robot, *, horizon_s, n_folds, baseline, max_fit_windows, transient,
                      test_log) -> tuple[SurrogateBaseline, Problem, list[str], str]:
    """The surrogate baseline and its problem (windows starting at every sample, folds of samples;
    with a test log: the log fold 1, the test log fold 0), its notes and why its model was chosen."""
    src = log_.source or "drive log"
    train_n = log_.n_samples
    data = DriveData.from_log(log_ if test_log is None else concat_logs(log_, test_log))
    horizon_s, horizon_note = choose_horizon(DriveData.from_log(log_), horizon_s)
    if test_log is not None:
        sample_fold = (np.arange(data.n) < train_n).astype(np.int64)
        n_folds_used = 2
    else:
        sample_fold = st.contiguous_folds(data.n, n_folds, data.seg)
        n_folds_used = n_folds
    if windows(data.t, data.seg, horizon_s)[0].size == 0:
        longest = max(float(data.t[data.seg == k][-1] - data.t[data.seg == k][0]) for k in np.unique(data.seg))
        raise InputError(f"{src}: no segment is as long as the {horizon_s:g} s horizon (longest {longest:.3g} s): "
                         "no prediction can be checked, nothing can be identified")
    starts, ends = windows(data.t, data.seg * n_folds_used + sample_fold, horizon_s)
    fold = sample_fold[starts]
    missing = sorted(set(range(n_folds_used)) - set(fold.tolist()))
    if missing:
        if test_log is not None:
            which = test_log.source or "test log" if 0 in missing else src
            raise InputError(f"{which}: no segment is as long as the {horizon_s:g} s horizon: nothing to "
                             + ("score on" if 0 in missing else "fit on"))
        raise InputError(f"{src}: too short to cross-validate at a {horizon_s:g} s horizon: fold(s) {missing} of "
                         f"{n_folds} hold no complete window (give a longer log or a shorter horizon_s)")
    stride = max(1, int(np.ceil(starts.size / max_fit_windows)))
    measured = speed_ok = None
    if data.meas is not None:
        speed_ok = np.all(np.isfinite(data.meas), axis=1)
        measured = np.where(np.isfinite(data.meas), data.meas, data.cmd)
    model, why, notes = make_baseline(baseline, robot, data, starts, ends, transient=transient)
    if horizon_note:
        notes.insert(0, horizon_note)
    if data.meas is not None:
        notes.append("measured track speeds present: input effects are fitted to them and must reduce their held-out "
                     "error (an input effect they contradict is refuted), ground effects are fitted with the model "
                     "driven by them; a speed sample at t is taken as "
                     + ("the speed just before the command of its row (causal)" if model.surrogate.causal_speeds else
                        "already the response to the command of its row (it fits the speeds better)"))
    sample_block = st.sample_blocks(data.t, data.seg * n_folds_used + sample_fold, horizon_s)
    problem = Problem(data=data, horizon_s=float(horizon_s), dt=data.step_dt(), yaw_scale=robot.track_gauge / 2,
                      starts=starts,
                      ends=ends, fold=fold, sample_fold=sample_fold, fit_windows=np.arange(0, starts.size, stride),
                      measured=measured, speed_ok=speed_ok, sample_block=sample_block,
                      score_folds=(0,) if test_log is not None else None)
    return model, problem, notes, why


__all__ = ["CHANGES", "DEFAULT_HORIZON", "MODEL_ABS", "MODEL_FORM", "MODEL_REL", "SurrogateBaseline", "choose_baseline",
           "choose_horizon", "make_baseline", "speed_timing", "surrogate_problem"]
