"""Steady-state twist and ICRs of the MuJoCo robot under constant track speeds.

Method (honest steady state): from the settled rest state, hold (V_L, V_R) constant for
``settle_s`` (transients: track spin-up, yaw acceleration, suspension pitch), then average
the sensors over the next ``window_s`` and report the standard deviation over the window
too. The ICRs follow from the window means by (2.13) via :func:`mjtrack.icr.icr_from_twist`
using the *measured* track speeds (what a robot's encoders give):
    y_l = (v_x - V_L)/w,  y_r = (v_x - V_R)/w,  x_c = -v_y/w;
where the robot does not turn (|w| T/2 < ``TURN_TOL`` max(|V_L|, |V_R|): straight motion, or a
track whose friction cannot turn the robot) the ICRs are NaN (null in JSON) and
``icr_undefined`` says why; not an error.

Contact persistence is reported per track as the fraction of steps in the whole run (settle
+ window) in which the track had at least one roller on the ground, and as the fraction of
(roller, step) pairs in contact in the window.

Batches of cases run through ``mujoco.rollout`` (one model per case: different robots of
the same size signature, e.g. other cg or friction, share one batch).
"""

from __future__ import annotations

import logging
import math
from dataclasses import asdict, dataclass
from typing import Sequence

import numpy as np

from mjtrack.errors import InputError, SingularMotionError
from mjtrack.icr import icr_from_twist
from mjtrack.io.robot import Robot
from mjtrack.sim.builder import build_model
from mjtrack.sim.config import MAX_STEP_DIVISIONS, SimConfig
from mjtrack.sim.drivetrain import drive_commands
from mjtrack.sim.ground import chunk_ground, ground_stepper
from mjtrack.sim.surfacevel import run_steady
from mjtrack.sim.terrain import Terrain, timestep_for
from mjtrack.sim.rollout import MAX_STEPS, SensorMap, run_batch, settled_state

logger = logging.getLogger(__name__)

WZ_STRAIGHT = 1e-5  # [rad/s] below this the run counts as straight (ICRs NaN): 1e-5 rad/s is
# an ICR 100 km away at 1 m/s, and numerical yaw drift in straight runs is ~1e-6 rad/s
TURN_TOL = 1e-3  # [-] the robot does not turn when |wz| T/2 < TURN_TOL max(|V_L|, |V_R|): the ICRs
# would lie beyond 1000 T/2 (e.g. a low-friction track that cannot resist the other one: before,
# steady printed y_l = -31473 m for mu_left 0.05 / mu_right 1 under (0.3, 0.5) m/s)
SETTLE_DRIFT = 0.02  # [-] the window is a steady state when the halves' mean v_x, v_y and w_z T/2 differ
# by at most this share of the larger commanded track speed (a run still speeding up, or tipping, does not)
SETTLE_S = 3.0  # [s] constant-command time before the averaging window
WINDOW_S = 2.0  # [s] averaging window


@dataclass(frozen=True)
class SteadyResult:
    """Window statistics of one constant-command run (SI units; std over the window)."""

    v_left_cmd: float
    v_right_cmd: float
    v_left: float
    v_right: float
    vx: float
    vy: float
    wz: float
    vx_std: float
    vy_std: float
    wz_std: float
    y_l: float
    y_r: float
    x_c: float
    contact_left: float
    contact_right: float
    roller_contact: float
    icr_undefined: str | None = None  # why y_l, y_r, x_c are null (None when they are defined)
    unsettled: str | None = None  # why the window is not a steady state (None when it is, or not checked)

    def to_dict(self) -> dict[str, float]:
        return {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in asdict(self).items()}


def steady_batch(
    robots: Sequence[Robot],
    commands: np.ndarray,
    *,
    config: SimConfig | None = None,
    settle_s: float = SETTLE_S,
    window_s: float = WINDOW_S,
    nthread: int = 1,
    terrain: Terrain | None = None,
) -> list[SteadyResult]:
    """Steady states of robots[i] under commands[i] = (V_L, V_R) [m/s]; (nbatch, 2) commands.

    The robots may differ in cg, friction, mass or geometry, and in traction and wheel count.
    Each case runs at the step :meth:`SimConfig.step_for` gives for its own robot and command
    (cases that share a step and a model structure share a rollout), so that a case's result does
    not depend on the batch it is in.
    """
    config = config or SimConfig()
    commands = np.atleast_2d(np.asarray(commands, dtype=float))
    check_steady(robots, commands, config=config, settle_s=settle_s, window_s=window_s, terrain=terrain)
    config = config.replace(timestep=timestep_for(config.timestep, terrain))  # smaller on edges
    if config.track_model == "surfacevel":
        return [_surfacevel(r, c, config, settle_s, window_s, terrain) for r, c in zip(robots, commands)]
    groups: dict[tuple, list[int]] = {}
    capped = 0
    for i, (r, c) in enumerate(zip(robots, commands)):
        # one rollout per step and model size (a wheel count changes the model's size)
        groups.setdefault((case_timestep(config, r, c), r.traction, r.wheels_per_side), []).append(i)
        _, turn_rate, mu = _turn(r, c)
        capped += config.slip_divisions(r.contact_length, turn_rate, mu) > MAX_STEP_DIVISIONS
    if capped:
        logger.warning("%d of %d steady case(s) turn so gently that the slip budget asks for more than %d "
                       "divisions of the %g s step; they run at %g s and their ICRs may move when dt is halved "
                       "(SimConfig.slip_budget)", capped, len(robots), MAX_STEP_DIVISIONS, config.timestep,
                       config.timestep / MAX_STEP_DIVISIONS)
    out: list[SteadyResult] = [None] * len(robots)  # type: ignore[list-item]
    for (step, _, _), idx in groups.items():
        for i, res in zip(idx, _steady_rollout([robots[i] for i in idx], commands[idx], config.replace(timestep=step),
                                               settle_s, window_s, nthread, terrain)):
            out[i] = res
    return out


def steady_steps(robot: Robot, command, *, config: SimConfig, settle_s: float, window_s: float,
                 terrain: Terrain | None = None) -> tuple[int, float]:
    """(time steps, time step [s]) of one steady case, computed without building anything."""
    config = config.replace(timestep=timestep_for(config.timestep, terrain))
    dt = config.timestep if config.track_model == "surfacevel" else case_timestep(config, robot, command)
    return int(round(settle_s / dt)) + int(round(window_s / dt)), dt


def check_steady(robots: Sequence[Robot], commands, *, config: SimConfig, settle_s: float, window_s: float,
                 terrain: Terrain | None = None, batch: int = 1) -> None:
    """Refuse, before any work, steady cases whose rollouts would be too long: ``batch`` cases of
    one rollout call together take at most :data:`~mjtrack.sim.rollout.MAX_STEPS` time steps.

    Raises:
        InputError: naming the case, its steps and the settle and window times.
    """
    if not (math.isfinite(settle_s) and math.isfinite(window_s) and settle_s >= 0 and window_s > 0):
        raise InputError(f"settle_s must be >= 0 and window_s > 0 seconds, got {settle_s!r} and {window_s!r}")
    for i, (r, c) in enumerate(zip(robots, np.atleast_2d(np.asarray(commands, dtype=float)))):
        n, dt = steady_steps(r, c, config=config, settle_s=settle_s, window_s=window_s, terrain=terrain)
        if n * batch > MAX_STEPS:
            which = f"case {i}: " if len(robots) > 1 else ""
            per = f" per case in a batch of {batch}" if batch > 1 else ""
            raise InputError(f"{which}settle_s {settle_s:g} s + window_s {window_s:g} s at the {dt:g} s time step are "
                             f"{n:.3g} time steps; at most {MAX_STEPS // batch:.3g}{per} "
                             f"({MAX_STEPS // batch * dt:.6g} s)")


def _turn(robot: Robot, command) -> tuple[np.ndarray, float, float]:
    """(scaled track speeds, nominal turn rate (V_R - V_L) / T, larger track friction) of a case."""
    v = np.asarray(command, dtype=float) * robot.track_speed_scale
    return v, float(v[1] - v[0]) / robot.track_gauge, max(robot.friction_left, robot.friction_right)


def case_timestep(config: SimConfig, robot: Robot, command) -> float:
    """The step [s] a steady case runs at (flat ground): ``config.step_for`` for the robot's contact
    length (track length, or wheelbase), the larger commanded track speed, the nominal turn rate (V_R - V_L) / T and the larger
    track friction, after the robot's speed scale."""
    v, turn_rate, mu = _turn(robot, command)
    return config.step_for(robot.contact_length, float(np.max(np.abs(v))), turn_rate, mu).timestep


def _steady_rollout(robots: Sequence[Robot], commands: np.ndarray, config: SimConfig, settle_s: float,
                    window_s: float, nthread: int, terrain: Terrain | None) -> list[SteadyResult]:
    """The roller chain's steady states of one batch at ``config.timestep``."""
    models = [build_model(r, config, terrain) for r in robots]
    dt = models[0].opt.timestep
    n_settle, n_window = int(round(settle_s / dt)), int(round(window_s / dt))
    s0 = np.stack([settled_state(m) for m in models])
    ctrl = np.stack([drive_commands(r, np.repeat(c[None], n_settle + n_window, axis=0), dt)
                     for r, c in zip(robots, commands)])  # each robot's speed scale and dead time
    _, sensordata = run_batch(models, ctrl, state0=s0, nthread=nthread, keep_states=False,
                              grounds=[chunk_ground(m, r, config) for m, r in zip(models, robots)])
    smap = SensorMap.of(models[0])
    return [_stats(sensordata[i], commands[i], smap, n_settle, robots[i].track_gauge / 2)
            for i in range(len(models))]


def unsettled_reason(lin: np.ndarray, ang: np.ndarray, cmd, half_gauge: float) -> str | None:
    """Why a window of body velocities (n, 3) is not a steady state, or None: the means of its two
    halves differ in v_x, v_y or w_z T/2 by more than :data:`SETTLE_DRIFT` of the larger command."""
    half = len(lin) // 2
    if half == 0:
        return None
    scale = max(float(np.max(np.abs(cmd))), 1e-3)
    first = np.array([*lin[:half, :2].mean(axis=0), ang[:half, 2].mean() * half_gauge])
    second = np.array([*lin[half:, :2].mean(axis=0), ang[half:, 2].mean() * half_gauge])
    drift = np.abs(second - first)
    worst = int(np.argmax(drift))
    if drift[worst] <= SETTLE_DRIFT * scale:
        return None
    name = ("v_x", "v_y", "w_z T/2")[worst]
    return (f"not settled: the window's second half differs from its first in {name} by {drift[worst]:.3g} m/s, "
            f"more than {SETTLE_DRIFT:g} of the command ({scale:g} m/s); lengthen settle_s")


def icrs_or_reason(vx: float, vy: float, wz: float, v_left: float, v_right: float, half_gauge: float
                   ) -> tuple[float, float, float, str | None]:
    """(y_l, y_r, x_c, None) by (2.13), or (NaN, NaN, NaN, reason) where the robot does not turn."""
    v_max = max(abs(v_left), abs(v_right))
    if v_max == 0 and abs(wz) < WZ_STRAIGHT:
        return math.nan, math.nan, math.nan, "the robot is at rest"
    if abs(wz) < WZ_STRAIGHT or abs(wz) * half_gauge < TURN_TOL * v_max:
        return (math.nan, math.nan, math.nan,
                f"the robot does not turn (|wz| = {abs(wz):.2g} rad/s: |wz| T/2 < {TURN_TOL:g} max|V|, "
                "ICRs beyond 1000 T/2)")
    try:
        icr = icr_from_twist(vx, vy, wz, v_left, v_right, wz_min=WZ_STRAIGHT)
    except SingularMotionError as exc:
        return math.nan, math.nan, math.nan, str(exc)
    return float(icr.y_l), float(icr.y_r), float(icr.x_c), None


def _stats(sd: np.ndarray, cmd: np.ndarray, smap: SensorMap, n_settle: int, half_gauge: float) -> SteadyResult:
    w = sd[n_settle:]
    lin, ang = w[:, smap.linvel], w[:, smap.angvel]
    vl, vr = w[:, smap.track_speed[0]], w[:, smap.track_speed[1]]
    vx, vy, wz = lin[:, 0].mean(), lin[:, 1].mean(), ang[:, 2].mean()
    y_l, y_r, x_c, reason = icrs_or_reason(vx, vy, wz, vl.mean(), vr.mean(), half_gauge)
    gl, gr = sd[:, smap.ground_left], sd[:, smap.ground_right]
    return SteadyResult(
        v_left_cmd=float(cmd[0]), v_right_cmd=float(cmd[1]), v_left=float(vl.mean()), v_right=float(vr.mean()),
        vx=float(vx), vy=float(vy), wz=float(wz),
        vx_std=float(lin[:, 0].std()), vy_std=float(lin[:, 1].std()), wz_std=float(ang[:, 2].std()),
        y_l=y_l, y_r=y_r, x_c=x_c,
        contact_left=float((gl > 0).mean()), contact_right=float((gr > 0).mean()),
        roller_contact=float((gl[n_settle:] + gr[n_settle:]).mean() / (2 * smap.elements)),
        icr_undefined=reason, unsettled=unsettled_reason(lin, ang, cmd, half_gauge),
    )


def _surfacevel(robot: Robot, cmd: np.ndarray, config: SimConfig, settle_s: float, window_s: float,
                terrain: Terrain | None) -> SteadyResult:
    """The surfacevel track model through its own ``run_steady`` (kinematic track speeds: the
    commands; no window standard deviations, reported as NaN; roller_contact as the mean of
    the per-track fractions)."""
    scale = robot.track_speed_scale  # kinematic tracks: the scaled commands are the speeds
    model = build_model(robot, config, terrain)
    run = run_steady(model, scale * float(cmd[0]), scale * float(cmd[1]), duration=settle_s + window_s,
                     average=window_s, ground=ground_stepper(model, robot, config))
    y_l, y_r, x_c, reason = icrs_or_reason(run.vx, run.vy, run.wz, run.v_left, run.v_right, robot.track_gauge / 2)
    nan = math.nan
    return SteadyResult(
        v_left_cmd=float(cmd[0]), v_right_cmd=float(cmd[1]), v_left=run.v_left, v_right=run.v_right,
        vx=run.vx, vy=run.vy, wz=run.wz, vx_std=nan, vy_std=nan, wz_std=nan, y_l=y_l, y_r=y_r, x_c=x_c,
        contact_left=run.contact_left, contact_right=run.contact_right,
        roller_contact=(run.contact_left + run.contact_right) / 2, icr_undefined=reason,
    )


def steady_state(robot: Robot, v_left: float, v_right: float, *, config: SimConfig | None = None,
                 settle_s: float = SETTLE_S, window_s: float = WINDOW_S, terrain: Terrain | None = None
                 ) -> SteadyResult:
    """Steady state of one robot under constant track speeds (see the module docstring)."""
    return steady_batch([robot], [[v_left, v_right]], config=config, settle_s=settle_s, window_s=window_s,
                        terrain=terrain)[0]
