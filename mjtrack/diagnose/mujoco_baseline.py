"""``diagnose --baseline mujoco``: the MuJoCo robot itself as the baseline of a diagnosis.

What is diagnosed is the simulation: the log is cut into windows (default 2 s, inside its
segments, not overlapping), each one simulated by the MuJoCo roller-chain robot from the
measured state at its start (pose, twist, moving tracks; the states a log does not hold warmed
up over the log's last :data:`mjtrack.windows.WARMUP_S` before it, as calibration does;
:mod:`mjtrack.sim.windows`) under the logged commands, with the simulator settings the robot
description records (a calibrated robot's, :func:`mjtrack.sim.config.sim_config`). The metric is the RMS position error at the window's end, in the measured
start frame (``pos_err_m`` of diagnosis.json). Every candidate effect is an *extension of the MuJoCo
robot* (:data:`CHANGES`): a model field (friction, centre of mass, drive lag, lateral friction of
the anisotropic ground, the motion resistance's force), a rebuilt model (road-wheel load, contact
length), the world (gravity of an inclined plane) or the drive's input (speed scale, dead time,
saturation). Effects already found are
combined with the candidate (a model variant with both fields; the commands clipped and the
gravity tilted as well), except the two ground models with each other.

The folds, the finding test, ties, order and intervals are those of every baseline
(:mod:`mjtrack.diagnose.select`); what is MuJoCo's own is the fit, because every parameter value
costs a pass over the windows: each one-parameter effect is simulated on a grid of 5 values
(:data:`GRIDS`), each window's errors are interpolated between them (:func:`interpolated_errors`)
and the fit minimises their mean on a fine grid (:func:`window_curves`); the held-out windows of
each fold are read off the same interpolation where it follows them (:data:`READ_OFF_GRID`),
else simulated at the fold's estimate.

Derivation and measurements: docs/theory/diagnosis.md, "The MuJoCo baseline".
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
from typing import Callable, Sequence

import mujoco
import numpy as np

from mjtrack.diagnose import stats as st
from mjtrack.diagnose.baseline import Baseline, ModelForm
from mjtrack.diagnose.problem import Problem
from mjtrack.diagnose.vocabulary import Effect
from mjtrack.diagnose.residuals import DriveData
from mjtrack.errors import InputError
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import G, Robot
from mjtrack.models.shear import lateral_shear_ratio_of
from mjtrack.sim.config import SimConfig, sim_config
from mjtrack.sim.drivetrain import drive_of
from mjtrack.sim.rollout import collected_mujoco_warnings
from mjtrack.sim.windows import WindowSim, simulate_windows
from mjtrack.windows import WARMUP_S, drive_params, make_windows, robot_params, without_contradicting

N_BOOT = 1000  # blocked bootstrap replicates of the estimates (the gain test draws its own, stats.N_BOOT)
# The MuJoCo baseline's own error on an effect's size, 1 sigma, as a share of the size |theta - nominal|
# (slope direction: MODEL_REL rad): the RMS relative error of its estimates of the ten hidden effects of
# benchmarks/diagnose_mujoco_baseline.py (60 s MuJoCo logs, seed 1, windows warmed up as here), which
# writes it to benchmarks/results/diagnose_mujoco_baseline.json ("summary": "model_rel"; a
# test holds the two equal to 3 decimals) and checks the intervals with the value measured on the
# other nine effects. A systematic error of the window simulation (e.g. the start state from noisy
# poses) is the same in every block: no resampling shows it.
MODEL_REL = 0.090
MODEL_FORM = ModelForm(MODEL_REL, {}, measured_by="python benchmarks/diagnose_mujoco_baseline.py "
                                                  "(benchmarks/results/diagnose_mujoco_baseline.json)")
SLOPE_STEP = math.sin(0.08)  # central-difference step of the slope's in-plane gravity a = sin(s) u


def _vmax(lg: DriveLog) -> float:
    return float(max(np.abs(lg.v_left_cmd).max(), np.abs(lg.v_right_cmd).max()))


def _turn_max(r: Robot, lg: DriveLog) -> float:
    """The largest half difference of the log's commands (no turn limit binds), or the robot's own limit."""
    v = float(np.abs(lg.v_right_cmd - lg.v_left_cmd).max()) / 2
    return v if r.drive_turn_limit is None else min(v, r.drive_turn_limit)


def _force_limit(r: Robot) -> float:
    """The robot's drive force limit per side [N] (its key, else the simulator's torque limit / R_s)."""
    return drive_of(r, sim_config(None, robot=r)).force_limit


def _own_shear(r: Robot) -> float:
    """The robot's shear modulus K [m] (0: its ground is another)."""
    return float(r.ground["shear_modulus"]) if r.ground.model == "shear" else 0.0


def _own(r: Robot, key: str, default: float) -> float:
    """The robot's own drivetrain value (``drive_lag``, ``drive_delay``, ``track_speed_scale``)."""
    v = drive_params(r)[key]
    return default if v is None else float(v)


# what each effect changes in the MuJoCo robot
CHANGES = {
    "cg_x": "centre of mass x in the MuJoCo chassis (model field)",
    "cg_y": "centre of mass y in the MuJoCo chassis (model field)",
    "friction_scale": "both tracks' contact-pair friction times the scale",
    "mu_ratio": "left-track friction = ratio x right-track friction",
    "track_speed_scale": "the drives' set-points = scale x command",
    "drive_lag": "first-order filter on the drives' set-points (actuator dynamics; time constant)",
    "drive_delay": "dead time on the drives' set-points (total)",
    "drive_speed_limit": "commands clipped at +-limit",
    "drive_turn_limit": "the robot's own twist stage: the half difference of the set-points clipped at +-limit "
                        "(robot key drive_turn_limit)",
    "drive_accel_limit": "the robot's own ramp on each side's set-point (robot key drive_accel_limit)",
    "drive_force_limit": "each side's drive force clipped at +-limit (the actuators' force range, robot key "
                         "drive_force_limit)",
    "slope": "gravity of an inclined plane whose in-plane part is g (slope_x, slope_y) (world frame)",
    "ground_anisotropy": "anisotropic ground: lateral friction = ratio x longitudinal (capsule rollers)",
    "road_wheels": "95 % of the load on 4 road wheels spread over span x the contact length",
    "track_length": "a track's contact length: the robot rebuilt",
    "wheelbase": "a wheeled robot's wheelbase: the robot rebuilt",
    "rolling_resistance": "a force holding each side back by this share of its weight (model actuators)",
    "shear_modulus": "the shear ground: each contact pair's friction set before every 20 ms of the rollout to mu "
                     "(1 - exp(-j/K)) of its state (mjtrack.sim.ground.ShearChunks)",
    "lateral_shear_ratio": "the shear ground's modulus across = ratio x the one along: each pair's friction across and "
                           "along set per chunk on capsule contacts (the track's frame)",
}
UNTESTABLE = {"icr_spread": "not a physical parameter of the MuJoCo robot"}
# effects that are the robot's own speed controller (:func:`mjtrack.models.drivetrain.twist`, ``ramp``):
# simulated by a robot with the key set (:meth:`MujocoBaseline._sim`; a compile, no rebuild of the windows)
CONTROLLER = ("drive_turn_limit", "drive_accel_limit")

# The "no effect" value of each one-parameter effect for a robot and log: around the robot's own
# value, so that a calibrated robot is extended, not reset (lag and dead time add to its own).
NOMINAL: dict[str, Callable[[Robot, DriveLog], float]] = {
    "cg_x": lambda r, lg: r.cg_x,
    "cg_y": lambda r, lg: r.cg_y,
    "friction_scale": lambda r, lg: 1.0,
    "mu_ratio": lambda r, lg: r.friction_left / r.friction_right,
    "track_speed_scale": lambda r, lg: _own(r, "track_speed_scale", 1.0),
    "drive_lag": lambda r, lg: _own(r, "drive_lag", 0.0),
    "drive_delay": lambda r, lg: _own(r, "drive_delay", 0.0),
    "drive_speed_limit": lambda r, lg: _vmax(lg),
    "drive_turn_limit": lambda r, lg: _turn_max(r, lg),
    "drive_accel_limit": lambda r, lg: math.inf if r.drive_accel_limit is None else r.drive_accel_limit,
    "drive_force_limit": lambda r, lg: _force_limit(r),
    "ground_anisotropy": lambda r, lg: 1.0,
    "road_wheels": lambda r, lg: 1.0,
    "track_length": lambda r, lg: r.contact_length,
    "wheelbase": lambda r, lg: r.contact_length,
    "rolling_resistance": lambda r, lg: r.rolling_resistance,
    "shear_modulus": lambda r, lg: _own_shear(r),
    "lateral_shear_ratio": lambda r, lg: lateral_shear_ratio_of(r, None),
}
# the fit's grid of each one-parameter effect (module docstring): 5 values, the robot's own among them
# where it is a value of the effect (a friction scale's 1 is not on its geometric grid)
GRIDS: dict[str, Callable[[Robot, DriveLog], np.ndarray]] = {
    "cg_x": lambda r, lg: r.cg_x + r.contact_length * np.linspace(-0.15, 0.15, 5),
    "cg_y": lambda r, lg: r.cg_y + r.track_gauge * np.linspace(-0.15, 0.15, 5),
    "friction_scale": lambda r, lg: np.array([0.35, 0.5, 0.7, 1.0, 1.6]),  # about geometric, 1 among them
    "mu_ratio": lambda r, lg: r.friction_left / r.friction_right * np.geomspace(0.4, 2.5, 5),
    "track_speed_scale": lambda r, lg: _own(r, "track_speed_scale", 1.0) * np.array([0.7, 0.8, 0.9, 1.0, 1.15]),
    "drive_lag": lambda r, lg: _own(r, "drive_lag", 0.0) + np.array([0.0, 0.05, 0.15, 0.3, 0.6]),
    "drive_delay": lambda r, lg: _own(r, "drive_delay", 0.0) + np.array([0.0, 0.05, 0.1, 0.2, 0.4]),
    "drive_speed_limit": lambda r, lg: _vmax(lg) * np.array([0.3, 0.45, 0.6, 0.8, 1.0]),
    "drive_turn_limit": lambda r, lg: _turn_max(r, lg) * np.array([0.2, 0.35, 0.5, 0.75, 1.0]),
    # a ramp delays a command change dv by about dv / a: from 16 x the fastest command (a 1/16 s delay,
    # below the window's resolution) down to a third of it, geometric (or below the robot's own)
    "drive_accel_limit": lambda r, lg: min(16 * _vmax(lg), r.drive_accel_limit or math.inf)
                                       * np.geomspace(1 / 48, 1, 5),
    # from the robot's own limit down to a fifth of what a side's friction can take (mu m g / 2):
    # above that cap the limit acts through the drivetrain's inertia (a ramp of F / reflected mass),
    # below it also in every skid turn; geometric, the span is decades
    "drive_force_limit": lambda r, lg: np.geomspace(min(0.2 * r.mu * r.mass * G / 2, _force_limit(r)),
                                                    _force_limit(r), 5),
    "ground_anisotropy": lambda r, lg: np.array([0.3, 0.45, 0.6, 0.8, 1.0]),
    "road_wheels": lambda r, lg: np.array([0.3, 0.45, 0.6, 0.8, 1.0]),
    "track_length": lambda r, lg: r.contact_length * np.array([0.7, 0.85, 1.0, 1.2, 1.4]),
    "wheelbase": lambda r, lg: r.contact_length * np.array([0.7, 0.85, 1.0, 1.2, 1.4]),
    "rolling_resistance": lambda r, lg: r.rolling_resistance + np.array([0.0, 0.03, 0.08, 0.15, 0.25]),
    # from Coulomb (K = 0) up, the step growing with K (what K does to a turn flattens as it grows);
    # a robot on the shear ground: around its own K, down to Coulomb
    "shear_modulus": lambda r, lg: (np.array([0.0, 0.005, 0.015, 0.05, 0.2]) if _own_shear(r) == 0.0
                                    else _own_shear(r) * np.array([0.0, 0.5, 1.0, 2.0, 3.0])),
    # around the robot's own ratio, a factor 4 each way, geometric (within the robot file's bounds)
    "lateral_shear_ratio": lambda r, lg: np.clip(lateral_shear_ratio_of(r, None) * np.geomspace(0.25, 4.0, 5), 0.1, 10.0),
}
_SIM_OF = {"ground_anisotropy": "aniso", "road_wheels": "wheels", "lateral_shear_ratio": "framed"}
# grids over decades or ratios: fitted and interpolated in log values
GEOMETRIC = ("drive_accel_limit", "drive_force_limit", "lateral_shear_ratio", "mu_ratio", "friction_scale")
# effects whose held-out errors at a fold's estimate are read off the windows' errors interpolated
# between grid values (:meth:`MujocoBaseline.held_out_errors`): those whose window errors a parabola
# through three grid values follows, measured at the midpoints between grid values (within 4 % of the
# simulated held-out RMS: tests/test_diagnose_mujoco_baseline.py). Not the limits (a window's error has
# a kink where a limit starts to bind; read off the grid it was several times further off), nor the
# friction ratio (several times further off too), nor the shear ground's effects (not measured): those
# are simulated at the estimate. Every one-parameter effect is fitted on that interpolation
# (:func:`window_curves`): the estimate lands where the windows' errors put the minimum, also for a
# limit, whose mean curve a parabola through three grid values misplaces (measured on the force-limit
# log of tests/test_diagnose_drivetrain.py)
READ_OFF_GRID = ("cg_x", "cg_y", "friction_scale", "track_speed_scale", "drive_lag", "drive_delay", "ground_anisotropy",
                 "road_wheels", "track_length", "wheelbase", "rolling_resistance")
FINE = 161  # points of the fine curve between a grid's ends (:func:`window_curves`)

def can_build(robot: Robot) -> tuple[bool, str]:
    """Whether the MuJoCo robot can be built from the description without assuming its geometry."""
    if robot.provided is None:
        return True, "the robot was given in full (built in code)"
    key = "wheelbase" if robot.traction == "wheels" else "track_length"
    if key in robot.provided:
        return True, f"the robot description gives the contact length ({key}), so the MuJoCo robot can be built"
    return False, (f"the robot description has no '{key}' (contact length): the MuJoCo robot would rest "
                   f"on an assumed geometry; run 'mjtrack calibrate' and pass its robot.json, or give {key}")


def choose_simulator(requested: str, robot: Robot) -> tuple[bool, str]:
    """(use MuJoCo?, why) for ``--baseline`` ``requested`` (auto|mujoco|surrogate|kinematic).
    ``mujoco`` on a robot that cannot be built is refused (InputError); ``auto`` falls back."""
    ok, why = can_build(robot)
    if requested == "mujoco":
        if not ok:
            raise InputError(f"baseline='mujoco': {why}")
        return True, f"requested; {why}"
    if requested == "auto":
        return (True, f"auto: {why}") if ok else (False, f"auto chose the surrogate because {why}")
    return False, f"requested {requested}"


# -- simulation of the effects --------------------------------------------------------------------
def _clip_log(lg: DriveLog, limit: float) -> DriveLog:
    return dataclasses.replace(lg, v_left_cmd=np.clip(lg.v_left_cmd, -limit, limit),
                               v_right_cmd=np.clip(lg.v_right_cmd, -limit, limit))


def _spec(robot: Robot, parts) -> tuple[str, dict, float | None]:
    """What the effects ``parts`` ((Effect, theta) pairs) do to a simulation: (simulator kind,
    window parameters, command clip limit or None). The kind is the ground's ("base", "aniso",
    "wheels"), with the robot-file keys of the controller effects as a tuple ``(ground, ((key,
    value), ...))`` when there are any (:data:`CONTROLLER`)."""
    kind, variant, clip = "base", {}, None
    controller: dict[str, float] = {}
    scale, ratio = None, None
    for eff, theta in parts:
        name, v = eff.name, float(theta[0])
        if name in _SIM_OF:
            if kind not in ("base", _SIM_OF[name]):
                raise InputError("diagnose: the anisotropic ground and road wheels cannot be combined in one MuJoCo robot")
            kind = _SIM_OF[name]
            variant[{"ground_anisotropy": "lateral_ratio", "road_wheels": "span"}.get(name, name)] = v
        elif name == "drive_speed_limit":
            clip = v if clip is None else min(clip, v)
        elif name in CONTROLLER:
            controller[name] = v
        elif name == "slope":
            variant["slope_x"], variant["slope_y"] = float(theta[0]), float(theta[1])
        elif name == "friction_scale":
            scale = v
        elif name == "mu_ratio":
            ratio = v
        elif name in ("track_length", "wheelbase"):
            variant[name] = v
        else:
            variant[{"cg_x": "cg_x", "cg_y": "cg_y", "track_speed_scale": "track_speed_scale",
                     "drive_lag": "drive_lag", "drive_delay": "drive_delay", "drive_force_limit": "drive_force_limit",
                     "rolling_resistance": "rolling_resistance", "shear_modulus": "shear_modulus"}[name]] = v
    if scale is not None or ratio is not None:
        s = 1.0 if scale is None else scale
        left = robot.friction_left if ratio is None else robot.friction_right * ratio
        variant["mu_left"], variant["mu_right"] = left * s, robot.friction_right * s
    if controller:
        return (kind, tuple(sorted(controller.items()))), variant, clip
    return kind, variant, clip


def _vertex(grid: np.ndarray, curve: np.ndarray) -> float:
    """Minimiser of a curve sampled on a grid: the parabola through the best value and its neighbours
    (the three end values when the best is at an end: a minimum between the last two grid values
    makes the end value the best), its vertex kept within those three."""
    k = int(np.argmin(np.where(np.isfinite(curve), curve, np.inf)))
    lo = min(max(k - 1, 0), grid.size - 3)
    if grid.size < 3 or not np.all(np.isfinite(curve[lo:lo + 3])):
        return float(grid[k])
    x, y = grid[lo:lo + 3], curve[lo:lo + 3]
    a = np.polyfit(x, y, 2)
    if a[0] <= 0:
        return float(grid[k])
    return float(np.clip(-a[1] / (2 * a[0]), x[0], x[2]))


def interpolated_errors(x: np.ndarray, err: np.ndarray, v: float) -> np.ndarray:
    """Window errors (M, C) at ``v`` from their values ``err`` (G, M, C) at the ascending grid ``x``
    (G >= 3): each component on the parabola through three grid values around v, the pair whose
    outer value is nearer first; a window whose three values are not all finite takes the other
    triple around v, else NaN. Exact at a grid value."""
    hit = np.flatnonzero(x == v)
    if hit.size:
        return err[hit[0]].copy()
    i = int(np.clip(np.searchsorted(x, v), 1, x.size - 1))  # v in [x[i-1], x[i]]
    triples = sorted((c for c in (i - 2, i - 1) if 0 <= c <= x.size - 3),
                     key=lambda c: abs((x[c] if c == i - 2 else x[c + 2]) - v))
    out = np.full(err.shape[1:], np.nan)
    todo = np.ones(err.shape[1], bool)
    for j in triples:
        n = x[j:j + 3]
        w = np.array([np.prod([(v - n[m]) / (n[k] - n[m]) for m in range(3) if m != k]) for k in range(3)])
        ok = todo & np.isfinite(err[j:j + 3]).all(axis=(0, 2))
        out[ok] = np.tensordot(w, err[j:j + 3][:, ok], axes=1)
        todo &= ~ok
    return out


def window_curves(x: np.ndarray, err: np.ndarray, valid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A fine grid (F,) from the first to the last value of ``x`` (G,) and each window's squared
    position error on it (F, M), from its errors ``err`` (G, M, 3) interpolated between grid values
    (:func:`interpolated_errors`; a valid window that cannot be: infinitely bad, as a diverged
    simulation on the grid is). The mean curve of some windows then has its minimum where their
    errors do, not where a parabola through three values of the mean puts it: on a coarse grid the
    two differ when the curve is not a parabola over that span."""
    fine = np.linspace(x[0], x[-1], FINE)
    sq = np.stack([_sq(interpolated_errors(x, err, float(v))) for v in fine])
    return fine, np.where(np.isfinite(sq) | ~valid, sq, np.inf)


def unexplored_se(x: np.ndarray, curve: np.ndarray, nodes: np.ndarray, est: float, *, geometric: bool) -> float:
    """A standard error that reaches across a grid step the fit could not enter.

    ``x`` is the fine curve's abscissa and ``curve`` its mean squared error, infinite where some window
    cannot be interpolated (a simulation on the grid value beyond diverged); ``nodes`` are the grid
    values; all three in the values the effect is fitted in (log values when ``geometric``). Where the
    estimate ``est`` (in the effect's own values) stops next to such a point, the log has not ruled out
    the values up to the grid value beyond it: the distance to that grid value over 1.96, so that the
    95 % interval reaches it. 0 where no such point borders the estimate.
    """
    v = math.log(est) if geometric else est
    back = math.exp if geometric else float
    k = int(np.argmin(np.abs(x - v)))
    se = 0.0
    for side in (-1, 1):
        j = k + side
        if 0 <= j < x.size and not np.isfinite(curve[j]):
            # the step that holds x[j]: its far end (an estimate on a grid value itself takes the step
            # beyond it, not that value)
            beyond = nodes[nodes >= x[j]] if side > 0 else nodes[nodes <= x[j]]
            if beyond.size:
                edge = beyond.min() if side > 0 else beyond.max()
                se = max(se, abs(back(edge) - est) / 1.96)
    return se


def _slope_a(E0: np.ndarray, J: np.ndarray, idx) -> np.ndarray:
    """Least-squares a (2,) from errors E0 (M, 2) + J (M, 2, 2) a = 0 over the windows ``idx``."""
    A = J[idx].reshape(-1, 2)
    b = -E0[idx].reshape(-1)
    ok = np.isfinite(A).all(axis=1) & np.isfinite(b)
    a, *_ = np.linalg.lstsq(A[ok], b[ok], rcond=None)
    n = np.hypot(*a)
    return a if n < 0.5 else a * 0.5 / n  # at most 30 deg


def _sq(err: np.ndarray) -> np.ndarray:
    """Squared position error of (..., 3) window errors (NaN for a diverged window)."""
    return err[..., 0] ** 2 + err[..., 1] ** 2


class MujocoBaseline(Baseline):
    """The MuJoCo robot of ``robot`` on the windows of ``log`` (module docstring).

    Args:
        robot: the robot description (the MuJoCo robot is built from it).
        log: the drive log (with a test log: both, concatenated; :meth:`problem` says which part
            is scored).
        horizon_s: window length [s].
        config: simulator settings (default: those the robot description records, else the defaults).
        nthread: threads of ``mujoco.rollout`` (results do not depend on it).
        seed: seed of the bootstrap draws.
    """

    name = "mujoco"
    noun = "MuJoCo robot"
    model_form = MODEL_FORM
    # a forward-selection step costs ~8 window passes per remaining candidate: the second (a lag
    # beside a dead time, say) only when the first leaves more than the pose noise can explain
    max_effects = 2
    free_steps = 1
    untestable = UNTESTABLE
    transient = False

    def __init__(self, robot: Robot, log: DriveLog, *, horizon_s: float = 2.0, config: SimConfig | None = None,
                 nthread: int = 2, seed: int = 0) -> None:
        self.robot, self.log = robot, log
        # the contact length under the robot file's key of its traction (the other one is not its own)
        other = "track_length" if robot.traction == "wheels" else "wheelbase"
        self.vocabulary = {n: c for n, c in CHANGES.items() if n != other}
        if robot.traction == "wheels":  # the road-wheel ground spreads a track's load; a wheel's is at its axle
            self.untestable = {**UNTESTABLE, "road_wheels": "a wheeled robot carries its load at its axles"}
            del self.vocabulary["road_wheels"]
        if robot.ground.model not in ("shear", "coulomb"):  # (on the Coulomb ground: beside shear_modulus)
            self.untestable = {**self.untestable, "lateral_shear_ratio": "the ratio of moduli belongs to the shear "
                                                                         f"ground, not the {robot.ground.model} one"}
            del self.vocabulary["lateral_shear_ratio"]
        self.config = config or sim_config(None, robot=robot)
        self.nthread, self.seed = nthread, seed
        # windows the ground cannot explain (poses against the tracks, a robot held still by something the
        # simulation lacks) are not an effect of the catalogue: left out, as calibrate does
        self.ws, self.left_out = without_contradicting(log, make_windows(log, horizon_s), robot.track_gauge)
        self.horizon_s = float(horizon_s)
        self._sims: dict[str, WindowSim] = {}
        self.warnings: list[dict] = []  # MuJoCo warnings: {"window", "simulation", "warning"} (:meth:`_run`)
        self._cache: dict[tuple, object] = {}
        # each window's errors (3,) by (simulation key, window) (:meth:`_simulation_key`), NaN when it
        # diverged or warned: a simulation asked for again is not run again
        self._done: dict[tuple, np.ndarray] = {}

    # -- the problem --------------------------------------------------------------------------------
    def problem(self, n_folds: int, *, n_train: int | None = None) -> Problem:
        """The windows, folds and blocks of the log: ``n_folds`` contiguous folds of windows (whole
        segments when there are at least 2K); with ``n_train`` (the first ``n_train`` samples are the
        log fitted on, the rest a test log): fold 1 fitted, fold 0 scored."""
        lg, ws = self.log, self.ws
        m = len(ws)
        src = lg.source or "drive log"
        data = DriveData.from_log(lg)
        if n_train is None:
            if m < 2 * n_folds:
                raise InputError(f"{src}: {m} windows of {ws.horizon_s:g} s; the MuJoCo diagnosis needs at least "
                                 f"{2 * n_folds} ({n_folds} folds)")
            fold = st.contiguous_folds(m, n_folds, np.unique(ws.segment, return_inverse=True)[1])
            window_of = np.clip(np.searchsorted(ws.starts, np.arange(data.n), side="right") - 1, 0, m - 1)
            sample_fold = fold[window_of]
            k, score_folds = n_folds, None
        else:
            fold = (ws.starts < n_train).astype(np.int64)
            if fold.all() or not fold.any():
                raise InputError(f"{src}: no window of {ws.horizon_s:g} s in the "
                                 + ("test log" if fold.all() else "log fitted on"))
            sample_fold = (np.arange(data.n) < n_train).astype(np.int64)
            k, score_folds = 2, (0,)
        problem = Problem(data=data, horizon_s=ws.horizon_s, dt=data.step_dt(), yaw_scale=self.robot.track_gauge / 2,
                          starts=ws.starts,
                          ends=ws.ends, fold=fold, sample_fold=sample_fold,
                          fit_windows=np.flatnonzero(~np.isin(fold, score_folds or ())), measured=None,
                          speed_ok=None, sample_block=st.sample_blocks(data.t, data.seg * k + sample_fold, ws.horizon_s),
                          score_folds=score_folds)
        base = self.errors(problem, np.arange(m))[0]
        return dataclasses.replace(problem, valid=np.isfinite(_sq(base)))

    # -- Baseline -----------------------------------------------------------------------------------
    def describe(self) -> str:
        r = self.robot
        body = (f"wheeled robot as described ({r.wheels_per_side} wheels a side, T {r.track_gauge:g} m, "
                f"wheelbase {r.contact_length:g} m, " if r.traction == "wheels" else
                f"roller-chain robot as described (T {r.track_gauge:g} m, L {r.track_length:g} m, ")
        return (f"MuJoCo {body}"
                f"{r.mass:g} kg, mu {r.mu:g}, ground {r.ground.to_dict()['model']}), each {self.horizon_s:g} s window "
                "simulated from the measured state under the logged commands")

    def nominal(self, effect: Effect, problem: Problem) -> np.ndarray:
        if effect.name == "slope":
            return np.zeros(2)
        return np.array([NOMINAL[effect.name](self.robot, self.log)])

    def default_effects(self) -> list[str]:
        """The vocabulary's effects, the shear modulus only for a robot on the shear ground (on another
        ground it is tested when named: its grid is a sixteenth more rollouts); the ratio of the shear
        ground's moduli only when named (its contacts on the track's frames are another simulator)."""
        out = [n for n in super().default_effects() if n != "lateral_shear_ratio"]  # named only (calibrate's too)
        return out if self.robot.ground.model == "shear" else [n for n in out if n != "shear_modulus"]

    def simulator_warnings(self) -> list[dict]:
        return list(self.warnings)

    def interval_method(self) -> str:
        return f"a blocked bootstrap over windows ({N_BOOT} resamples of the MuJoCo fit)"

    def _sim(self, kind) -> WindowSim:
        # every simulator carries the motion resistance's actuators (as calibration's), so that the
        # rolling_resistance effect is a window parameter; at the robot's own 0 they apply no force.
        # A controller effect is the robot with its key set (kind (ground, keys), :func:`_spec`): the
        # windows' commands pass through the robot's own controller stages
        # (mjtrack.sim.drivetrain.controller_stages), as a calibrated robot's would
        if kind not in self._sims:
            ground, keys = kind if isinstance(kind, tuple) else (kind, ())
            r = self.robot.replace(**dict(keys)) if keys else self.robot
            if len(self._sims) > 24:  # one per controller value of a fit: the oldest of those dropped
                self._sims.pop(next(k for k in self._sims if isinstance(k, tuple)))
            if ground == "aniso":
                g = r.ground if r.ground.model == "anisotropic" else {"model": "anisotropic", "lateral_ratio": 1.0}
                self._sims[kind] = WindowSim(r.replace(ground=g), self.config, resisted=True)
            elif ground == "framed":  # the contacts on the track's frames: each variant sets its ratio
                self._sims[kind] = WindowSim(r, self.config, resisted=True, framed=True)
            elif ground == "wheels":
                self._sims[kind] = WindowSim(r.replace(ground={"model": "road_wheels", "wheels": 4,
                                                               "concentration": 0.95, "span": 1.0}), self.config,
                                             resisted=True)
            else:
                self._sims[kind] = WindowSim(r, self.config, resisted=True)
        return self._sims[kind]

    def _run(self, windows: np.ndarray, specs: Sequence[tuple], labels: Sequence[str]) -> np.ndarray:
        """Errors (V, W, 3) of the windows under each simulation spec (:func:`_spec`, named by
        ``labels`` in the warnings' record); consecutive specs that differ only in window
        parameters are one batch. A window whose simulation diverged, or made MuJoCo warn (an
        unstable step: MuJoCo resets the state and carries on, so the prediction is not the
        robot's), is NaN; each warning is recorded with its window (:attr:`warnings`)."""
        windows = np.asarray(windows)
        ws = self.ws.subset(windows)
        out, i = [], 0
        while i < len(specs):
            kind, _, clip = specs[i]
            j = i
            while j < len(specs) and (specs[j][0], specs[j][2]) == (kind, clip):
                j += 1
            err = np.full((j - i, windows.size, 3), np.nan)
            keys = [self._simulation_key(specs[v]) for v in range(i, j)]
            todo = [v for v in range(j - i) if not all((keys[v], int(w)) in self._done for w in windows)]
            for v in range(j - i):
                if v not in todo:  # simulated before: the same model, commands and start on these windows
                    err[v] = [self._done[keys[v], int(w)] for w in windows]
            if todo:
                lg = self.log if clip is None else _clip_log(self.log, clip)
                variants = [specs[i + v][1] for v in todo]
                with collected_mujoco_warnings() as messages:
                    res = simulate_windows(self._sim(kind), lg, ws, variants, nthread=self.nthread, warmup_s=WARMUP_S)
                new = res.errors.copy()
                new[res.diverged] = np.nan
                if messages:
                    located = self._locate(kind, lg, windows, variants)
                    for w, v, message in located:
                        new[v, int(np.flatnonzero(windows == w)[0])] = np.nan
                        self.warnings.append({"window": int(w), "simulation": labels[i + todo[v]],
                                              "warning": message.strip()})
                    if not located:  # raised while preparing the simulation (e.g. settling the robot), not in a window
                        self.warnings.append({"window": None, "simulation": ", ".join(labels[i + v] for v in todo),
                                              "warning": messages[0].strip()})
                for n, v in enumerate(todo):
                    err[v] = new[n]
                    for k, w in enumerate(windows):
                        self._done[keys[v], int(w)] = new[n, k]
            out.append(err)
            i = j
        return np.concatenate(out)

    def expected_windows(self, problem: Problem, effects: Sequence[Effect]) -> int:
        """Windows a forward-selection step over ``effects`` is expected to simulate on ``problem``:
        each one-parameter effect its grid on the fit windows (less the grid values that are the
        baseline's own simulation, :meth:`_simulation_key`) and its folds' estimates on the scored
        windows (only those off the grid where the estimates are read off it, :data:`READ_OFF_GRID`),
        the slope its four central differences and the same. An estimate: a fold's estimate on a
        grid value costs nothing."""
        n_fit, n_scored = int(problem.fit_windows.size), int(np.count_nonzero(problem.scored))
        # scored windows the grid does not run over (a test log's): simulated at every estimate
        n_off = int(np.count_nonzero(problem.scored & ~np.isin(np.arange(problem.starts.size), problem.fit_windows)))
        base = list(problem.base)
        kind0 = _spec(self.robot, base)[0]
        key0 = self._simulation_key(_spec(self.robot, base))
        total = 0
        for eff in effects:
            if eff.name == "slope":
                total += 4 * n_fit + n_scored
                continue
            new = 0
            for v in np.asarray(GRIDS[eff.name](self.robot, self.log), float):
                spec = _spec(self.robot, base + [(eff, np.array([v]))])
                # another simulator kind is another simulation (its key would compile it now)
                new += spec[0] != kind0 or self._simulation_key(spec) != key0
            total += new * n_fit + (n_off if eff.name in READ_OFF_GRID else n_scored)
        return total

    def _simulation_key(self, spec: tuple) -> tuple:
        """What makes a window's simulation: the simulator kind, every window parameter (the
        variant over the simulator's robot, as :func:`simulate_windows` merges them) and the
        command clip. Two specs with one key simulate every window alike (a grid value equal to
        the robot's own, a fold's estimate on a grid value), so a window is simulated once."""
        kind, variant, clip = spec
        sim_robot = self._sim(kind).robot
        # a parameter the robot leaves unset is the simulator's own value: named as that value, so that
        # a variant which sets it to that value is the same simulation (the model fields are equal:
        # tests/test_diagnose_mujoco_baseline.py), and so is a clip at or above every command (np.clip
        # returns the commands unchanged)
        own = {"mu_left": sim_robot.friction_left, "mu_right": sim_robot.friction_right, "drive_lag": 0.0,
               "drive_force_limit": _force_limit(sim_robot)}
        merged = {**robot_params(sim_robot), **variant}
        merged = {k: own[k] if v is None and k in own else v for k, v in merged.items()}
        if clip is not None and clip >= _vmax(self.log):
            clip = None
        return kind, tuple(sorted((k, None if v is None else float(v)) for k, v in merged.items())), clip

    def _locate(self, kind: str, lg: DriveLog, windows: np.ndarray, variants: list) -> list[tuple[int, int, str]]:
        """(window, variant index, first warning) of every simulation among ``windows`` x
        ``variants`` that makes MuJoCo warn, found by simulating halves of the windows again
        (windows are independent and the physics deterministic), each leaf window variant by
        variant. A pass over the windows per halving: only ever run when a batch warned."""
        def warns(w, vs):
            with _quiet_warnings() as m:
                simulate_windows(self._sim(kind), lg, self.ws.subset(w), vs, nthread=self.nthread, warmup_s=WARMUP_S)
            return m

        if windows.size == 1:
            if len(variants) == 1:
                m = warns(windows, variants)
                return [(int(windows[0]), 0, m[0])] if m else []
            return [(int(windows[0]), v, m[0]) for v in range(len(variants)) for m in [warns(windows, [variants[v]])]
                    if m]
        out = []
        for half in np.array_split(windows, 2):
            if warns(half, variants):
                out += self._locate(kind, lg, half, variants)
        return out

    def errors(self, problem: Problem, windows: np.ndarray, effect: Effect | None = None, values=None) -> np.ndarray:
        windows = np.asarray(windows)
        whole = windows.size == len(self.ws) and effect is None
        key = ("base", _base_key(problem))
        if whole and key in self._cache:
            return self._cache[key]
        base = list(problem.base)
        on = "".join(f" + {e.name}" for e, _ in base)
        if effect is None:
            specs, labels = [_spec(self.robot, base)], ["baseline" + on]
        else:
            values = [np.atleast_1d(np.asarray(v, float)) for v in values]
            specs = [_spec(self.robot, base + [(effect, v)]) for v in values]
            labels = [f"baseline{on} + {effect.name} = {', '.join(f'{x:.4g}' for x in v)}" for v in values]
        out = self._run(windows, specs, labels)
        if whole:
            self._cache[key] = out
        return out

    def _train(self, problem: Problem, train_folds) -> np.ndarray:
        """(M,) the valid windows of the folds ``train_folds`` among the problem's fit windows."""
        fit = np.zeros(problem.starts.size, bool)
        fit[problem.fit_windows] = True
        return fit & np.isin(problem.fold, train_folds) & problem.valid_mask

    def _draws(self, problem: Problem, train: np.ndarray) -> list[np.ndarray]:
        """The bootstrap replicates of the training windows (each block's windows repeated as often
        as the block is drawn; the blocks of :attr:`Problem.window_block`, seeded)."""
        block = np.unique(problem.window_block, return_inverse=True)[1]
        counts = st.boot_counts(int(block.max()) + 1, N_BOOT, self.seed).astype(int)
        idx = np.flatnonzero(train)
        return [np.repeat(idx, c[block[idx]]) for c in counts]

    def fit(self, problem: Problem, effect: Effect, train_folds: np.ndarray, *, covariance: bool = False,
            start: np.ndarray | None = None):
        train = self._train(problem, train_folds)
        if effect.name == "slope":
            E0, J = self._slope_jacobian(problem)

            def solve(idx):
                return _slope_a(E0, J, idx)
        else:
            x, sq = self._fine(problem, effect)  # (log values on a geometric grid)
            back = np.exp if effect.name in GEOMETRIC else float

            def solve(idx):
                return np.array([back(_vertex(x, np.mean(sq[:, idx], axis=1)))])
        est = solve(np.flatnonzero(train))
        if not covariance:
            return est
        # a draw that took no training block (a short log of few blocks) has no fit: left out, not the
        # grid's first value that an all-NaN curve's minimiser would give
        boots = np.array([solve(idx) for idx in self._draws(problem, train) if idx.size])
        dev = boots - est
        var = np.mean(dev ** 2, axis=0)  # bootstrap variance around the estimate
        if effect.name != "slope":
            var = np.maximum(var, self._unexplored(problem, effect, train, float(est[0])) ** 2)
        return est, np.diag(var)

    def _unexplored(self, problem: Problem, effect: Effect, train: np.ndarray, est: float) -> float:
        """:func:`unexplored_se` of the training windows' fine curve around the estimate."""
        x, sq = self._fine(problem, effect)
        curve = np.mean(sq[:, np.flatnonzero(train)], axis=1)
        nodes = self._grid_errors(problem, effect)[0]
        return unexplored_se(x, curve, nodes, est, geometric=effect.name in GEOMETRIC)

    def _grid_errors(self, problem: Problem, effect: Effect) -> tuple[np.ndarray, np.ndarray]:
        """The effect's grid (:data:`GRIDS`) in the values it is fitted in (log values on a geometric
        grid; a grid clipped at a bound loses its repeated end) and the fit windows' errors at each
        grid value (G, M, 3; NaN for the other windows and for a diverged simulation), simulated once."""
        key = ("grid errors", effect.name, _base_key(problem))
        if key not in self._cache:
            grid = np.asarray(GRIDS[effect.name](self.robot, self.log), float)
            x, first = np.unique(np.log(grid) if effect.name in GEOMETRIC else grid, return_index=True)
            err = np.full((x.size, problem.starts.size, 3), np.nan)
            w = problem.fit_windows
            err[:, w] = self.errors(problem, w, effect, grid[first][:, None])
            self._cache[key] = (x, err)
        return self._cache[key]

    def _fine(self, problem: Problem, effect: Effect) -> tuple[np.ndarray, np.ndarray]:
        """The fine curves of the effect's windows (:func:`window_curves`), cached."""
        key = ("fine", effect.name, _base_key(problem))
        if key not in self._cache:
            self._cache[key] = window_curves(*self._grid_errors(problem, effect), problem.valid_mask)
        return self._cache[key]

    def held_out_errors(self, problem: Problem, windows: np.ndarray, effect: Effect, theta) -> np.ndarray:
        """The held-out windows' errors at a fold's estimate, read off their own errors on the
        effect's grid where the fit simulated them there (every fold of a K-fold diagnosis: the
        grid runs over all windows, and the fold's estimate was fitted on the others), by the
        interpolation the fit used (:func:`interpolated_errors`). The effects not in
        :data:`READ_OFF_GRID`, a window that cannot be interpolated (a diverged simulation on both
        triples around the estimate) and the windows of a test log (never on the grid) are
        simulated at the estimate."""
        windows = np.asarray(windows)
        if (effect.name not in READ_OFF_GRID or ("grid errors", effect.name, _base_key(problem)) not in self._cache
                or not np.isin(windows, problem.fit_windows).all()):
            return super().held_out_errors(problem, windows, effect, theta)
        x, err = self._grid_errors(problem, effect)
        v = float(theta[0])
        out = interpolated_errors(x, err[:, windows], math.log(v) if effect.name in GEOMETRIC else v)
        again = ~np.isfinite(out).all(axis=1)
        if again.any():
            out[again] = self.errors(problem, windows[again], effect, [theta])[0]
        return out

    def _slope_jacobian(self, problem: Problem) -> tuple[np.ndarray, np.ndarray]:
        """Baseline errors E0 (M, 2) and their derivatives J (M, 2, 2) in a (central differences)."""
        key = ("slope", _base_key(problem))
        if key not in self._cache:
            h = SLOPE_STEP
            m = problem.starts.size
            base = list(problem.base)
            kind, variant, clip = _spec(self.robot, base)
            specs = [(kind, {**variant, "slope_x": a[0], "slope_y": a[1]}, clip)
                     for a in ((h, 0.0), (-h, 0.0), (0.0, h), (0.0, -h))]
            w = problem.fit_windows
            e = np.full((4, m, 2), np.nan)
            e[:, w] = self._run(w, specs, [f"slope_x, slope_y = {a[0]:.3g}, {a[1]:.3g} (slope fit)"
                                           for a in ((h, 0.0), (-h, 0.0), (0.0, h), (0.0, -h))])[..., :2]
            J = np.stack([(e[0] - e[1]) / (2 * h), (e[2] - e[3]) / (2 * h)], axis=-1)
            self._cache[key] = (self.errors(problem, np.arange(m))[0][:, :2], J)
        return self._cache[key]


@contextlib.contextmanager
def _quiet_warnings():
    """MuJoCo's warnings collected (yielded) and not passed on: a re-simulation that locates a
    warning (:meth:`MujocoBaseline._locate`) must not count it twice in an outer summary."""
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(None)  # the outer collectors hidden while these are collected
    try:
        with collected_mujoco_warnings() as messages:
            yield messages
    finally:
        mujoco.set_mju_user_warning(previous)


def _base_key(problem: Problem) -> tuple:
    return tuple((e.name, tuple(float(v) for v in theta)) for e, theta in problem.base)


__all__ = ["CHANGES", "GRIDS", "MODEL_REL", "MujocoBaseline", "N_BOOT", "NOMINAL", "READ_OFF_GRID",
           "can_build", "choose_simulator", "interpolated_errors", "unexplored_se", "window_curves"]
