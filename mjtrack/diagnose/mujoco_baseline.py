"""``diagnose --baseline mujoco``: the MuJoCo robot itself diagnosed on a measured log.

What is diagnosed is the simulation: the log is cut into windows (default 2 s, inside its
segments), each one simulated by the MuJoCo roller-chain robot from the measured state at its
start (pose, twist, moving tracks; :mod:`mjtrack.sim.windows`) under the logged commands. The
metric is the RMS position error at the window's end, in the measured start frame (CONTRACTS
``pos_err_m``). Every candidate effect is an *extension of the MuJoCo robot* (:data:`EFFECTS`):
a model field (friction, centre of mass, drive lag, lateral friction of the anisotropic ground),
a rebuilt model (road-wheel load), the world (gravity of an inclined plane) or the drive's
input (speed scale, dead time, saturation).

Fit and score, per effect (all numbers are MuJoCo's):

1. every window is simulated at a fixed grid of the effect's parameter (7 values chosen before
   seeing the data, the robot's own "no effect" value among them: a calibrated robot's drive lag,
   dead time, speed scale, centre of mass and friction ratio are where its grids start or centre;
   the centre of mass within +-0.15 L and +-0.15 T of it: beyond L/6 Wong's linear load goes
   negative at one end, the end rollers lift, and windows started from a moving state diverged
   in development runs at 0.2 L);
2. ``n_folds`` contiguous folds of windows (whole segments when there are at least 2K): on each
   fold's training windows the RMS error curve over the grid is minimised (parabola through the
   best grid value and its neighbours), and the fold's windows are simulated again at that
   estimate, so every window is scored by a fit that never saw it; the baseline (no parameter
   fitted) is scored on all windows;
3. the finding test, ties and intervals are those of the surrogate diagnosis
   (:mod:`mjtrack.diagnose.select`, :mod:`mjtrack.diagnose.stats`): a finding needs the one-sided
   95 % lower bound of the held-out relative gain, by blocked bootstrap over blocks of windows
   (at least three horizons: parts of one segment, or short segments pooled whole), above zero and
   the point gain at least ``min_gain``; findings are ordered by held-out error; a finding is tied
   with the first when the bootstrap interval of their difference holds zero or the difference
   is below the floor, or when physics says a drive log cannot separate them
   (:func:`mjtrack.diagnose.select.physical_tie`), and among tied findings the one with fewer
   parameters goes first;
4. the estimate is the minimiser on all windows; its 95 % interval estimate +- t se, with se the
   larger of a blocked bootstrap (:data:`N_BOOT` resamples of the blocks' grid curves, the same
   parabola) and the delete-one-fold jackknife of the fold estimates, and in quadrature the
   baseline's own error on the effect's size (:data:`MODEL_REL`, measured); with ``test`` (a
   second log) the gain is re-measured there at the estimate (``gain.held_out``: that log was
   never fitted).

``slope`` has two parameters: (s, psi) enters through a = sin(s) (cos psi, sin psi); the window
errors (along, across) are linearised in a by central differences (4 extra simulations), a is
fitted by least squares on each fold's training windows, and the held-out windows simulated at
it. Costs (measured by experiments/diagnose_mujoco_baseline.py): about 8 passes over the windows
per effect.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from mjtrack.diagnose import select as sel
from mjtrack.diagnose import stats as st
from mjtrack.errors import InputError
from mjtrack.io.atomic import atomic_write_text, make_output_dir
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import G, Robot
from mjtrack.sim.config import SimConfig
from mjtrack.sim.windows import WindowSet, WindowSim, drive_params, make_windows, simulate_windows

log = logging.getLogger(__name__)

N_BOOT = 1000  # blocked bootstrap replicates of the estimates (the gain test draws its own, stats.N_BOOT)
# The MuJoCo baseline's own error on an effect's size, 1 sigma, as a share of the size |theta - nominal|
# (slope direction: MODEL_REL rad): the RMS relative error of its estimates of the ten hidden effects of
# experiments/diagnose_mujoco_baseline.py (60 s MuJoCo logs, seed 1, which prints it and checks the
# intervals with the value measured on the other nine effects). A systematic error of the window
# simulation (e.g. the start state from noisy poses) is the same in every block: no resampling shows it.
MODEL_REL = 0.068
SLOPE_STEP = math.sin(0.08)  # central-difference step of the slope's in-plane gravity a = sin(s) u


# -- the effects as extensions of the MuJoCo robot -------------------------------------------------
@dataclass(frozen=True)
class MjEffect:
    """A candidate effect: its CONTRACTS §4 name, kind, parameter names, the grid of its
    (first) parameter for a robot and log, and what it changes in the simulation."""

    name: str
    kind: str  # "ground" or "input"
    params: tuple[str, ...]
    grid: Callable[[Robot, DriveLog], np.ndarray] | None
    nominal: Callable[[Robot, DriveLog], float] | None
    meaning: str


def _vmax(lg: DriveLog) -> float:
    return float(max(np.abs(lg.v_left_cmd).max(), np.abs(lg.v_right_cmd).max()))


def _own(r: Robot, key: str, default: float) -> float:
    """The robot's own drivetrain value (``drive_lag``, ``drive_delay``, ``track_speed_scale``)."""
    v = drive_params(r)[key]
    return default if v is None else float(v)


# Grids around the robot's own value (its "no effect"), so that a calibrated robot is extended, not
# reset: lag and dead time are added to the robot's own (an extension cannot remove them).
EFFECTS: dict[str, MjEffect] = {e.name: e for e in (
    MjEffect("cg_offset_x", "ground", ("cg_offset_x",),
             lambda r, lg: r.cg_x + r.track_length * np.linspace(-0.15, 0.15, 7),
             lambda r, lg: r.cg_x, "centre of mass x in the MuJoCo chassis (model field)"),
    MjEffect("cg_offset_y", "ground", ("cg_offset_y",),
             lambda r, lg: r.cg_y + r.track_gauge * np.linspace(-0.15, 0.15, 7),
             lambda r, lg: r.cg_y, "centre of mass y in the MuJoCo chassis (model field)"),
    MjEffect("friction_scale", "ground", ("friction_scale",), lambda r, lg: np.geomspace(0.35, 1.6, 7),
             lambda r, lg: 1.0, "both tracks' contact-pair friction times the scale"),
    MjEffect("friction_asymmetry", "ground", ("friction_asymmetry",),
             lambda r, lg: r.friction_left / r.friction_right * np.geomspace(0.4, 2.5, 7),
             lambda r, lg: r.friction_left / r.friction_right, "left-track friction = ratio x right-track friction"),
    MjEffect("track_speed_scale", "input", ("track_speed_scale",),
             lambda r, lg: _own(r, "track_speed_scale", 1.0) * np.linspace(0.7, 1.15, 7),
             lambda r, lg: _own(r, "track_speed_scale", 1.0), "the drives' set-points = scale x command"),
    MjEffect("actuator_lag", "input", ("actuator_lag",),
             lambda r, lg: _own(r, "drive_lag", 0.0) + np.array([0.0, 0.05, 0.1, 0.2, 0.3, 0.45, 0.6]),
             lambda r, lg: _own(r, "drive_lag", 0.0),
             "first-order filter on the drives' set-points (actuator dynamics; time constant)"),
    MjEffect("command_delay", "input", ("command_delay",),
             lambda r, lg: _own(r, "drive_delay", 0.0) + np.array([0.0, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4]),
             lambda r, lg: _own(r, "drive_delay", 0.0), "dead time on the drives' set-points (total)"),
    MjEffect("speed_limit", "input", ("speed_limit",),
             lambda r, lg: _vmax(lg) * np.array([0.3, 0.4, 0.5, 0.6, 0.75, 0.9, 1.0]),
             lambda r, lg: _vmax(lg), "commands clipped at +-limit"),
    MjEffect("slope", "ground", ("slope", "slope_direction"), None, None,
             "gravity of a plane inclined by slope, uphill towards slope_direction (world frame)"),
    MjEffect("ground_anisotropy", "ground", ("lateral_ratio",), lambda r, lg: np.array([0.3, 0.4, 0.5, 0.6, 0.75, 0.9, 1.0]),
             lambda r, lg: 1.0, "anisotropic ground: lateral friction = ratio x longitudinal (capsule rollers)"),
    MjEffect("road_wheels", "ground", ("road_wheel_span",), lambda r, lg: np.array([0.3, 0.4, 0.5, 0.6, 0.75, 0.9, 1.0]),
             lambda r, lg: 1.0, "95 % of the load on 4 road wheels spread over span x the contact length"),
)}
DEFAULT_EFFECTS = tuple(EFFECTS)


def can_build(robot: Robot) -> tuple[bool, str]:
    """Whether the MuJoCo robot can be built from the description without assuming its geometry."""
    if robot.provided is None:
        return True, "the robot was given in full (built in code)"
    if "track_length" in robot.provided:
        return True, "the robot description gives the track contact length, so the MuJoCo robot can be built"
    return False, ("the robot description has no 'track_length' (contact length): the MuJoCo robot would rest "
                   "on an assumed geometry; run 'mjtrack calibrate' and pass its robot.json, or give track_length")


def choose_simulator(requested: str, robot: Robot) -> tuple[bool, str]:
    """(use MuJoCo?, why) for ``--baseline`` ``requested`` (auto|mujoco|surrogate|kinematic).
    ``mujoco`` on a robot that cannot be built is refused (InputError); ``auto`` falls back."""
    ok, why = can_build(robot)
    if requested == "mujoco":
        if not ok:
            raise InputError(f"--baseline mujoco: {why}")
        return True, f"requested; {why}"
    if requested == "auto":
        return (True, f"auto: {why}") if ok else (False, f"auto chose the surrogate because {why}")
    return False, f"requested {requested}"


# -- simulation of the effects --------------------------------------------------------------------
class _Sloped(WindowSim):
    """The window simulator with gravity of an inclined plane (the log's x, y in the plane)."""

    slope_a = (0.0, 0.0)  # a = sin(s) (cos psi, sin psi): uphill unit vector times sin(slope)

    def variant_model(self, params):
        m = super().variant_model(params)
        ax, ay = self.slope_a
        m.opt.gravity[:] = (-G * ax, -G * ay, -G * math.sqrt(max(0.0, 1.0 - ax * ax - ay * ay)))
        return m

    def settled(self, model, key):
        return super().settled(model, tuple(key) + tuple(self.slope_a))


def _clip_log(lg: DriveLog, limit: float) -> DriveLog:
    return dataclasses.replace(lg, v_left_cmd=np.clip(lg.v_left_cmd, -limit, limit),
                               v_right_cmd=np.clip(lg.v_right_cmd, -limit, limit))


@dataclass
class _Context:
    log: DriveLog
    robot: Robot
    ws: WindowSet
    config: SimConfig
    nthread: int
    tick: Callable[[int], None]
    sims: dict = field(default_factory=dict)

    def sim(self, kind: str) -> WindowSim:
        if kind not in self.sims:
            r = self.robot
            if kind == "aniso":
                ground = r.ground if r.ground.model == "anisotropic" else {"model": "anisotropic", "lateral_ratio": 1.0}
                self.sims[kind] = WindowSim(r.replace(ground=ground), self.config)
            elif kind == "wheels":
                self.sims[kind] = WindowSim(r.replace(ground={"model": "road_wheels", "wheels": 4,
                                                               "concentration": 0.95, "span": 1.0}), self.config)
            else:
                self.sims[kind] = _Sloped(r, self.config)
        return self.sims[kind]

    def run(self, sim, variants, index, lg=None) -> np.ndarray:
        """Errors (P, m, 3) of the windows ``index`` under the variants."""
        ws = self.ws.subset(index)
        res = simulate_windows(sim, lg or self.log, ws, variants, nthread=self.nthread)
        self.tick(len(variants) * len(ws))
        err = res.errors.copy()
        err[res.diverged] = np.nan
        return err


def _variant(effect: str, value: float, robot: Robot) -> dict:
    if effect == "cg_offset_x":
        return {"cg_x": value}
    if effect == "cg_offset_y":
        return {"cg_y": value}
    if effect == "friction_scale":
        return {"mu_left": robot.friction_left * value, "mu_right": robot.friction_right * value}
    if effect == "friction_asymmetry":
        return {"mu_left": robot.friction_right * value, "mu_right": robot.friction_right}
    if effect == "track_speed_scale":
        return {"track_speed_scale": value}
    if effect == "actuator_lag":
        return {"drive_lag": value}
    if effect == "command_delay":
        return {"drive_delay": value}
    if effect == "ground_anisotropy":
        return {"lateral_ratio": value}
    if effect == "road_wheels":
        return {"span": value}
    raise ValueError(effect)


_SIM_OF = {"ground_anisotropy": "aniso", "road_wheels": "wheels"}


def _errors(ctx: _Context, effect: str, values: Sequence[float], index) -> np.ndarray:
    """(G, m, 3) window errors of the windows ``index`` at each value of a 1-parameter effect."""
    if effect == "speed_limit":
        return np.concatenate([ctx.run(ctx.sim("base"), [{}], index, _clip_log(ctx.log, v)) for v in values])
    sim = ctx.sim(_SIM_OF.get(effect, "base"))
    return ctx.run(sim, [_variant(effect, float(v), ctx.robot) for v in values], index)


def _slope_errors(ctx: _Context, points: Sequence[tuple[float, float]], index) -> np.ndarray:
    sim = ctx.sim("base")
    out = []
    for a in points:
        sim.slope_a = (float(a[0]), float(a[1]))
        out.append(ctx.run(sim, [{}], index))
    sim.slope_a = (0.0, 0.0)
    return np.concatenate(out)


# -- statistics -------------------------------------------------------------------------------------
def _sq(err: np.ndarray) -> np.ndarray:
    """Squared position error of (..., 3) window errors (NaN for a diverged window)."""
    return err[..., 0] ** 2 + err[..., 1] ** 2


def _vertex(grid: np.ndarray, curve: np.ndarray) -> float:
    """Minimiser of a curve sampled on a grid: the parabola through the best value and its neighbours."""
    k = int(np.argmin(np.where(np.isfinite(curve), curve, np.inf)))
    if k == 0 or k == grid.size - 1 or not np.all(np.isfinite(curve[k - 1:k + 2])):
        return float(grid[k])
    x, y = grid[k - 1:k + 2], curve[k - 1:k + 2]
    a = np.polyfit(x, y, 2)
    if a[0] <= 0:
        return float(grid[k])
    return float(np.clip(-a[1] / (2 * a[0]), x[0], x[2]))


@dataclass
class _Scoring:
    """Folds, blocks and bootstrap draws of the windows, shared by every candidate of a diagnosis.

    ``fold`` (M,): contiguous folds of windows (whole segments when there are enough);
    ``block`` (M,): blocks of the blocked bootstrap (:func:`mjtrack.diagnose.stats.sample_blocks`:
    at least three horizons; a long segment cut at the folds and into blocks, short segments pooled
    whole); ``ok`` (M,): windows
    whose baseline did not diverge (the only ones scored); ``draws``: the bootstrap replicates as
    window indices (each block's windows repeated as often as the block is drawn)."""

    fold: np.ndarray
    block: np.ndarray
    ok: np.ndarray
    draws: list

    @classmethod
    def of(cls, lg: DriveLog, ws: WindowSet, n_folds: int, ok: np.ndarray, seed: int) -> "_Scoring":
        m = len(ws)
        fold = st.contiguous_folds(m, n_folds, np.unique(ws.segment, return_inverse=True)[1])
        seg = np.empty(lg.t.size, dtype=np.int64)
        for k, sl in enumerate(lg.segment_slices()):
            seg[sl] = k
        window_of = np.clip(np.searchsorted(ws.starts, np.arange(lg.t.size), side="right") - 1, 0, m - 1)
        block = st.sample_blocks(lg.t, seg * n_folds + fold[window_of], ws.horizon_s)[ws.starts]
        block = np.unique(block, return_inverse=True)[1]
        counts = st.boot_counts(int(block.max()) + 1, N_BOOT, seed).astype(int)
        idx = np.flatnonzero(ok)
        draws = [np.repeat(idx, c[block[idx]]) for c in counts]
        return cls(fold, block, ok, draws)

    @property
    def n_blocks(self) -> int:
        return int(np.unique(self.block[self.ok]).size)


@dataclass
class Candidate:
    """One effect fitted and scored with MuJoCo.

    ``held_err`` (M, 3): each window's error from the fit that did not see its fold; ``gain``: the
    blocked bootstrap test of the held-out gain (the decision); ``fold_estimates`` (K, P);
    ``se_stat`` (P,): the larger of the blocked-bootstrap and the delete-one-fold jackknife standard
    errors; ``se_model`` (P,): the baseline's own error on the effect's size (:data:`MODEL_REL`)."""

    effect: MjEffect
    estimate: tuple[float, ...]
    interval: tuple[tuple[float, float], ...]
    before: float
    after: float
    gain: st.GainTest
    held_err: np.ndarray
    fold_estimates: np.ndarray
    se_stat: np.ndarray
    se_model: np.ndarray
    passed: bool = False
    why: str = ""
    tied_with: list[str] = field(default_factory=list)
    tie_notes: list[str] = field(default_factory=list)
    test: dict | None = None

    @property
    def relative(self) -> float:
        return 1.0 - self.after / self.before if self.before > 0 else 0.0


def _candidate(ctx: "_Context", sc: _Scoring, eff: MjEffect, base_err: np.ndarray, held: np.ndarray, est,
               fold_est: np.ndarray, boots: np.ndarray) -> Candidate:
    """Score a fitted effect: the gain test over blocks and the 95 % interval (module docstring)."""
    ok = sc.ok
    gt = st.gain_test(_sq(base_err[ok]), _sq(held[ok]), sc.block[ok])
    est = np.asarray(est, float)
    angular = np.array([n == "slope_direction" for n in eff.params])
    dev = boots - est
    dev[:, angular] = np.angle(np.exp(1j * dev[:, angular]))
    cov = np.diag(np.mean(dev ** 2, axis=0))  # bootstrap variance around the estimate
    if eff.name == "slope":
        size = np.array([abs(est[0]), 1.0])  # the direction: MODEL_REL rad
    else:
        size = np.abs(est - np.array([eff.nominal(ctx.robot, ctx.log)]))
    se_model = MODEL_REL * size
    _, se = sel.interval(est, fold_est, cov, angular, sc.n_blocks)  # statistical only
    ivl, _ = sel.interval(est, fold_est, cov, angular, sc.n_blocks, se_model)
    return Candidate(eff, tuple(float(v) for v in est), tuple((float(a), float(b)) for a, b in ivl),
                     st.pos_rmse(base_err[ok]), st.pos_rmse(held[ok]), gt, held, fold_est, se, se_model)


def _fit_1d(ctx: "_Context", sc: _Scoring, eff: MjEffect, base_err: np.ndarray) -> Candidate:
    grid = np.asarray(eff.grid(ctx.robot, ctx.log), float)
    m = base_err.shape[0]
    allidx = np.arange(m)
    sq = _sq(_errors(ctx, eff.name, grid, allidx))  # (G, M)
    sq = np.where(np.isfinite(sq) | ~sc.ok, sq, np.inf)  # a diverged variant: infinitely bad
    held = np.full((m, 3), np.nan)
    fold_est = []
    for f in np.unique(sc.fold):
        train, test = (sc.fold != f) & sc.ok, sc.fold == f
        est = _vertex(grid, np.mean(sq[:, train], axis=1))
        fold_est.append([est])
        held[test] = _errors(ctx, eff.name, [est], allidx[test])[0]
    est = _vertex(grid, np.mean(sq[:, sc.ok], axis=1))
    boots = np.array([[_vertex(grid, np.mean(sq[:, idx], axis=1))] for idx in sc.draws])
    return _candidate(ctx, sc, eff, base_err, held, [est], np.array(fold_est), boots)


def _slope_a(E0: np.ndarray, J: np.ndarray, idx) -> np.ndarray:
    """Least-squares a (2,) from errors E0 (M, 2) + J (M, 2, 2) a = 0 over the windows ``idx``."""
    A = J[idx].reshape(-1, 2)
    b = -E0[idx].reshape(-1)
    ok = np.isfinite(A).all(axis=1) & np.isfinite(b)
    a, *_ = np.linalg.lstsq(A[ok], b[ok], rcond=None)
    n = np.hypot(*a)
    return a if n < 0.5 else a * 0.5 / n  # at most 30 deg


def _fit_slope(ctx: "_Context", sc: _Scoring, eff: MjEffect, base_err: np.ndarray) -> Candidate:
    m = base_err.shape[0]
    allidx = np.arange(m)
    h = SLOPE_STEP
    e = _slope_errors(ctx, [(h, 0.0), (-h, 0.0), (0.0, h), (0.0, -h)], allidx)[..., :2]  # (4, M, 2)
    J = np.stack([(e[0] - e[1]) / (2 * h), (e[2] - e[3]) / (2 * h)], axis=-1)  # (M, 2, 2)
    E0 = base_err[:, :2]
    held = np.full((m, 3), np.nan)

    def to_params(v):
        return math.asin(min(1.0, math.hypot(*v))), math.atan2(v[1], v[0])

    fold_est = []
    for f in np.unique(sc.fold):
        train, test = np.flatnonzero((sc.fold != f) & sc.ok), sc.fold == f
        a = _slope_a(E0, J, train)
        fold_est.append(to_params(a))
        held[test] = _slope_errors(ctx, [tuple(a)], allidx[test])[0]
    est = to_params(_slope_a(E0, J, np.flatnonzero(sc.ok)))
    boots = np.array([to_params(_slope_a(E0, J, idx)) for idx in sc.draws])
    return _candidate(ctx, sc, eff, base_err, held, est, np.array(fold_est), boots)


# -- the diagnosis --------------------------------------------------------------------------------
@dataclass
class MujocoDiagnosis:
    """Result of :func:`diagnose_mujoco`; ``to_json()`` is diagnosis.json (CONTRACTS §4 + extras)."""

    log_path: str
    samples: int
    duration_s: float
    robot: Robot
    horizon_s: float
    n_windows: int
    n_folds: int
    before: float
    candidates: list[Candidate]
    choice: dict
    test: dict | None = None
    timings: dict = field(default_factory=dict)
    diverged: int = 0
    n_blocks: int = 0

    confirmation = None  # the surrogate's --confirm stage: this diagnosis is MuJoCo throughout

    @property
    def findings(self) -> list[Candidate]:
        return [c for c in self.candidates if c.passed]

    def summary(self) -> str:
        """The lines a terminal shows: simulator, cause(s) with estimates and held-out gains."""
        where = "test-log" if self.test is not None else "held-out"
        lines = [f"baseline: MuJoCo robot ({self.choice.get('why', '')})"]
        if not self.findings:
            lines.append(f"cause: none; MuJoCo {self.horizon_s:g} s position RMSE {self.before:.3g} m")
        for i, c in enumerate(self.findings):
            est = ", ".join(f"{n} = {v:.4g}" for n, v in zip(c.effect.params, c.estimate))
            g = self._gain(c)
            lines.append(f"{'cause' if i == 0 else 'also'}: {c.effect.name} ({est})"
                         + (f" [indistinguishable here from {', '.join(c.tied_with)}]" if c.tied_with else "")
                         + f"; {where} {self.horizon_s:g} s position RMSE {g['before']:.3g} -> {g['after']:.3g} m")
        return "\n".join(lines)

    @property
    def cause(self) -> str:
        return self.findings[0].effect.name if self.findings else "none"

    def model_text(self) -> str:
        g = self.robot.ground.to_dict()
        return (f"MuJoCo roller-chain robot as described (T {self.robot.track_gauge:g} m, L {self.robot.track_length:g} m, "
                f"{self.robot.mass:g} kg, mu {self.robot.mu:g}, ground {g['model']}), each {self.horizon_s:g} s window "
                "simulated from the measured state under the logged commands")

    def evidence(self, c: Candidate) -> str:
        est = ", ".join(f"{n} = {v:.4g} [{a:.4g}, {b:.4g}]" for n, v, (a, b) in zip(c.effect.params, c.estimate, c.interval))
        text = (f"MuJoCo extended by {c.effect.name} ({c.effect.meaning}) with {est} removes {100 * c.relative:.0f} % "
                f"of the {self.horizon_s:g} s position error on held-out windows ({c.before:.3g} -> {c.after:.3g} m, "
                f"one-sided 95 % bound {100 * c.gain.lower:.0f} % by blocked bootstrap over {c.gain.blocks} blocks of "
                f"{self.n_windows} windows, {self.n_folds} folds)")
        if c.test is not None:
            text += f"; on the test log {c.test['before']:.3g} -> {c.test['after']:.3g} m"
        if c.tied_with:
            text += (f"; cannot be told apart from {', '.join(c.tied_with)} on this log "
                     + (f"({'; '.join(c.tie_notes)})" if c.tie_notes else "(held-out gains equal within noise)"))
        return text + "."

    def _gain(self, c: Candidate) -> dict:
        if c.test is not None:
            return {"metric": "pos_err_m", "before": c.test["before"], "after": c.test["after"],
                    "relative": c.test["relative"], "held_out": True}
        return {"metric": "pos_err_m", "before": c.before, "after": c.after, "relative": c.relative, "held_out": True}

    def to_json(self) -> dict:
        def fnd(c: Candidate) -> dict:
            out = {"effect": c.effect.name,
                   "estimate": {n: float(v) for n, v in zip(c.effect.params, c.estimate)},
                   "interval": {n: [float(a), float(b)] for n, (a, b) in zip(c.effect.params, c.interval)},
                   "gain": self._gain(c), "evidence": self.evidence(c)}
            if c.test is not None:
                out["cross_validation"] = {"before": c.before, "after": c.after, "relative": c.relative}
            return out

        base_value = self.test["before"] if self.test is not None else self.before
        out = {
            "log": self.log_path, "samples": self.samples, "duration_s": self.duration_s,
            "baseline": {"model": self.model_text(), "metric": "pos_err_m", "horizon_s": self.horizon_s,
                         "value": float(base_value), "simulator": "mujoco", "choice": self.choice},
            "cause": self.cause,
            "findings": [fnd(c) for c in self.findings],
            "candidates": [{"effect": c.effect.name, "kind": c.effect.kind, "finding": c.passed,
                            "estimate": {n: float(v) for n, v in zip(c.effect.params, c.estimate)},
                            "interval": {n: [float(a), float(b)] for n, (a, b) in zip(c.effect.params, c.interval)},
                            "before": c.before, "after": c.after, "relative": c.relative,
                            "gain_lower_95": c.gain.lower, "decision": c.why} for c in self.candidates],
            "method": {
                "windows": f"{self.n_windows} windows of {self.horizon_s:g} s, each simulated by MuJoCo from the measured state",
                "gain": f"RMS position error at the windows' end, held out over {self.n_folds} contiguous folds "
                        "(each fold's estimate fitted on the other folds, its windows simulated again at it)",
                "finding": "one-sided 95 % lower bound of the held-out relative gain above zero (blocked bootstrap "
                           "over blocks of windows) and a gain of at least the floor",
                "interval": f"95 %, estimate +- t se, se the larger of a blocked bootstrap over windows ({N_BOOT} "
                            "resamples of the MuJoCo error curves) and the delete-one-fold jackknife, with the "
                            f"MuJoCo baseline's own error ({100 * MODEL_REL:.1f} % of the effect's size) in quadrature",
            },
            "timings_s": {k: round(v, 2) for k, v in self.timings.items()},
            "diverged_windows": self.diverged,
        }
        if self.test is not None:
            out["test_log"] = self.test["log"]
            out["baseline"]["cross_validation_value"] = float(self.before)
        return out


def diagnose_mujoco(lg: DriveLog, robot: Robot, *, horizon_s: float = 2.0, n_folds: int = 5,
                    min_gain: float = 0.03, effects: Sequence[str] | None = None, test: DriveLog | None = None,
                    config: SimConfig | None = None, nthread: int = 2, quiet: bool = True, seed: int = 0,
                    choice: dict | None = None) -> MujocoDiagnosis:
    """Diagnose the MuJoCo robot on a log (module docstring). ``effects``: names of :data:`EFFECTS`
    to test (default all); ``test``: a second log of the same robot on which gains are re-measured."""
    from mjtrack.progress import Progress

    t0 = time.perf_counter()
    names = list(effects) if effects is not None else list(DEFAULT_EFFECTS)
    unknown = [n for n in names if n not in EFFECTS]
    if unknown:
        raise InputError(f"diagnose: unknown effect(s) {unknown}; known: {', '.join(EFFECTS)}")
    ok, why = can_build(robot)
    ws = make_windows(lg, horizon_s)
    if len(ws) < 2 * n_folds:
        raise InputError(f"{lg.source or 'drive log'}: {len(ws)} windows of {horizon_s:g} s; the MuJoCo diagnosis "
                         f"needs at least {2 * n_folds} ({n_folds} folds)")
    config = config or SimConfig()
    m = len(ws)
    passes = 1 + sum(6 if n == "slope" else 8 for n in names)
    with Progress(passes * m, label="diagnose (MuJoCo)", quiet=quiet) as bar:
        ctx = _Context(lg, robot, ws, config, nthread, bar.update)
        base_err = ctx.run(ctx.sim("base"), [{}], np.arange(m))[0]
        ok = np.isfinite(_sq(base_err))
        sc = _Scoring.of(lg, ws, n_folds, ok, seed)
        cands = [(_fit_slope if name == "slope" else _fit_1d)(ctx, sc, EFFECTS[name], base_err) for name in names]
    _decide(cands, min_gain, _sq(base_err[ok]), sc, robot)
    diag = MujocoDiagnosis(log_path=lg.source or "", samples=int(lg.t.size), duration_s=_duration(lg), robot=robot,
                           horizon_s=horizon_s, n_windows=m, n_folds=n_folds, before=st.pos_rmse(base_err[ok]),
                           candidates=cands, choice=choice or {"requested": "mujoco", "chosen": "mujoco", "why": why},
                           diverged=int(np.sum(~ok)), n_blocks=sc.n_blocks)
    if test is not None:
        diag.test = _score_test(test, robot, config, horizon_s, diag.findings, nthread)
    diag.timings["total"] = time.perf_counter() - t0
    return diag


def _duration(lg: DriveLog) -> float:
    return float(sum(lg.t[s][-1] - lg.t[s][0] for s in lg.segment_slices()))


def _decide(cands: list[Candidate], min_gain: float, base_sq: np.ndarray, sc: _Scoring, robot: Robot) -> None:
    """Findings, their order and ties, by the rules of the surrogate diagnosis (module docstring)."""
    for c in cands:
        g = c.gain
        text = (f"held-out position RMSE {c.before:.3g} -> {c.after:.3g} m ({100 * g.relative:.1f} %, one-sided 95 % "
                f"bound {100 * g.lower:.1f} % by blocked bootstrap over {g.blocks} blocks of windows; gain floor "
                f"{100 * min_gain:.0f} %)")
        if not np.isfinite(c.after):
            bad = int(np.sum(~np.isfinite(_sq(c.held_err[sc.ok]))))
            c.why = f"MuJoCo diverged on {bad} of {int(sc.ok.sum())} held-out windows"
        elif g.relative < min_gain:
            c.why = f"{text}: below the floor"
        elif g.lower <= 0.0:
            c.why = f"{text}: not beyond noise"
        else:
            c.passed, c.why = True, text
    cands.sort(key=lambda c: (not c.passed, c.after))
    found = [c for c in cands if c.passed]
    if not found:
        return
    top, block = found[0], sc.block[sc.ok]
    for r in found[1:]:
        why = sel.physical_tie(robot, top, r)
        if why is not None:
            top.tie_notes.append(why)
            r.tie_notes.append(why)
        else:
            d, lo, _ = st.difference_test(base_sq, _sq(top.held_err[sc.ok]), _sq(r.held_err[sc.ok]), block)
            if not (lo > 0.0 and d >= min_gain):
                why = "held-out gains equal within noise"
        if why is not None:
            r.tied_with.append(top.effect.name)
            top.tied_with.append(r.effect.name)
    tied = sorted([c for c in found if c is top or top.effect.name in c.tied_with],
                  key=lambda c: (len(c.effect.params), c.after))  # fewer parameters first among equals
    cands.remove(tied[0])
    cands.insert(0, tied[0])


def _score_test(test: DriveLog, robot: Robot, config: SimConfig, horizon_s: float, findings, nthread) -> dict:
    ws = make_windows(test, horizon_s)
    if len(ws) == 0:
        raise InputError(f"{test.source or 'test log'}: no window of {horizon_s:g} s fits in any segment")
    ctx = _Context(test, robot, ws, config, nthread, lambda n: None)
    allidx = np.arange(len(ws))
    before = st.pos_rmse(ctx.run(ctx.sim("base"), [{}], allidx)[0])
    for c in findings:
        if c.effect.name == "slope":
            s, psi = c.estimate
            err = _slope_errors(ctx, [(math.sin(s) * math.cos(psi), math.sin(s) * math.sin(psi))], allidx)
        else:
            err = _errors(ctx, c.effect.name, [c.estimate[0]], allidx)
        after = st.pos_rmse(err[0])
        c.test = {"before": before, "after": after, "relative": 1.0 - after / before if before > 0 else 0.0}
    return {"log": test.source or "", "before": before, "windows": len(ws)}


def write_mujoco_outputs(diag: MujocoDiagnosis, out: str | Path) -> None:
    """DIR/diagnosis.json and DIR/report.html (atomic writes)."""
    from mjtrack.report.html import Report

    out = Path(out)
    make_output_dir(out)
    data = diag.to_json()
    rep = Report(title="MuJoCo robot diagnosed on a measured log",
                 intro=f"Log {diag.log_path}: {diag.samples} samples, {diag.n_windows} windows. Baseline: {diag.model_text()}. "
                       f"Chosen because {diag.choice.get('why', '')}.")
    sec = rep.section("Cause")
    if diag.findings:
        sec.verdict(diag.evidence(diag.findings[0]))
    else:
        sec.verdict(f"No extension of the MuJoCo robot beats it on held-out windows (baseline {diag.before:.3g} m).", warn=True)
    rows = [[c.effect.name, ", ".join(f"{n}={v:.4g}" for n, v in zip(c.effect.params, c.estimate)), c.before, c.after,
             100 * c.relative, 100 * c.gain.lower, c.why] for c in diag.candidates]
    rep.section("Candidates (all numbers simulated by MuJoCo)").table(
        ["effect", "estimate", "before [m]", "held-out after [m]", "gain [%]", "95 % lower bound [%]", "decision"], rows)
    rep.write(out / "report.html")
    atomic_write_text(out / "diagnosis.json", json.dumps(data, indent=2) + "\n")
