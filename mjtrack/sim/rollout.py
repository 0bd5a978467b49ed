"""Headless rollouts of the MuJoCo tracked robot: commands in, drive-log columns out.

All stepping goes through ``mujoco.rollout`` (C loop, optional threads, deterministic: the
same model, initial state and controls give bit-identical states). Commands are two track
speeds per step, expanded to the actuators by :func:`mjtrack.sim.builder.control_matrix`.

Before t = 0 the robot settles for ``settle_s`` with zero command (suspension and contacts
reach their static state), so a log starts at rest. Logged quantities, sampled every
``round(1 / (log_rate * dt))`` steps (the log period must be a multiple of the time step):

* ``x, y`` [m]: the ``centre`` site (geometric centre on the ground); ``yaw`` [rad]: the
  chassis heading, unwrapped (continuous), from the site quaternion;
* ``vx, vy, wz``: velocimeter/gyro of ``centre`` in the chassis frame (for the small
  pitch/roll of the sprung chassis this is the body twist of docs/reference/formats/drive-log.md);
* ``v_left, v_right``: track speeds (tendon velocity sensors, m/s).

A simulation that diverges (NaN, or MuJoCo's automatic reset after a bad acceleration,
seen as time going back) raises :class:`~mjtrack.errors.MjtrackError`.

Size: a rollout is refused before it starts when it would take more than :data:`MAX_STEPS` time
steps or more memory than :func:`rollout_bytes` allows (:func:`check_rollout`). A single long
rollout runs in chunks of :data:`CHUNK_STEPS` steps, each chunk starting from the full state and
the solver's warm start where the previous one ended, so that an interrupt (Ctrl-C) is acted on
between two chunks; the chunks give the bytes of one call.
"""

from __future__ import annotations

import contextlib
import copy
import logging
from dataclasses import dataclass

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout

from mjtrack.errors import InputError, MjtrackError
from mjtrack.io.robot import Robot
from mjtrack.sim.builder import build_model, control_matrix
from mjtrack.sim.config import SimConfig
from mjtrack.sim.drivetrain import drive_commands
from mjtrack.sim.scene import ELEMENT_KINDS
from mjtrack.sim.ground import batch_ground, chunk_ground, ground_stepper
from mjtrack.sim.surfacevel import TrackDrive
from mjtrack.sim.terrain import Terrain, timestep_for

logger = logging.getLogger(__name__)

STATE_SPEC = mujoco.mjtState.mjSTATE_FULLPHYSICS
SETTLE_S = 0.5  # [s] zero-command settling before t = 0
MAX_STEPS = 2_000_000  # steps in one rollout (~2 GB of states and sensors at ~1 kB a step)
MAX_ROLLOUT_BYTES = 2e9  # [bytes] most memory the arrays of one rollout call may take
CHUNK_STEPS = 500  # steps per mujoco.rollout call of a single rollout (~0.1 s of the default robot on one core)


@dataclass(frozen=True)
class SensorMap:
    """Column slices of ``sensordata`` for the quantities a rollout reports."""

    linvel: slice
    angvel: slice
    pos: slice
    quat: slice
    track_speed: tuple[int, int]
    ground_left: int  # column: number of left-track elements in ground contact
    ground_right: int
    elements: int  # contact elements per track

    @classmethod
    def of(cls, model: mujoco.MjModel) -> "SensorMap":
        def sl(name: str) -> slice:
            s = model.sensor(name)
            return slice(int(s.adr[0]), int(s.adr[0] + s.dim[0]))

        return cls(
            linvel=sl("body_linvel"), angvel=sl("body_angvel"), pos=sl("body_pos"), quat=sl("body_quat"),
            track_speed=(int(model.sensor("track_speed_left").adr[0]), int(model.sensor("track_speed_right").adr[0])),
            ground_left=int(model.sensor("ground_left").adr[0]), ground_right=int(model.sensor("ground_right").adr[0]),
            elements=sum(1 for g in range(model.ngeom)
                         if model.geom(g).name.startswith(tuple(f"{k}_left_" for k in ELEMENT_KINDS))),
        )


@contextlib.contextmanager
def collected_mujoco_warnings():
    """Collect MuJoCo's warnings in a list (yielded) instead of printing them to stderr; the
    previous handler is restored. A diverging rollout prints one "Nan, Inf or huge value in QACC"
    per window, thousands in a calibration whose line search tries extreme values; the callers
    count diverged windows themselves and log one summary line. Nested collections all see a
    warning (an outer one, e.g. :func:`summarised_mujoco_warnings` around a whole fit, counts what
    each inner one collects)."""
    messages: list[str] = []
    previous = mujoco.get_mju_user_warning()
    forward = previous if getattr(previous, "_collects_mujoco_warnings", False) else None

    def collect(message: str) -> None:
        messages.append(message)
        if forward is not None:
            forward(message)

    collect._collects_mujoco_warnings = True  # type: ignore[attr-defined]
    mujoco.set_mju_user_warning(collect)
    try:
        yield messages
    finally:
        mujoco.set_mju_user_warning(previous)


@contextlib.contextmanager
def summarised_mujoco_warnings(what: str, log: logging.Logger | None = None):
    """MuJoCo's warnings during ``what`` (e.g. "diagnose run.csv") collected and, when there were
    any, logged as one warning line at the end: how many and the first. Yields the list of messages."""
    with collected_mujoco_warnings() as messages:
        yield messages
    if messages:
        (log or logger).warning("%s: MuJoCo warned %d times (first: %s)", what, len(messages), messages[0].strip())


def initial_state(model: mujoco.MjModel) -> np.ndarray:
    """Full physics state (nstate,) of the model at rest in its reference configuration."""
    data = mujoco.MjData(model)
    mujoco.mj_resetData(model, data)
    mujoco.mj_forward(model, data)
    state = np.empty(mujoco.mj_stateSize(model, STATE_SPEC))
    mujoco.mj_getState(model, data, state, STATE_SPEC)
    return state


def rollout_bytes(model: mujoco.MjModel, nbatch: int, nstep: int, *, keep_states: bool = True) -> float:
    """Memory [bytes] of the arrays of a rollout: controls (given and extended), sensordata and,
    with ``keep_states``, the state after every step (float64)."""
    per_step = 2 * model.nu + model.nsensordata
    if keep_states:
        per_step += mujoco.mj_stateSize(model, STATE_SPEC)
    return 8.0 * nbatch * nstep * per_step


def check_rollout(model: mujoco.MjModel, nbatch: int, nstep: int, *, keep_states: bool = True) -> None:
    """Refuse, before any work, a rollout of more than :data:`MAX_STEPS` steps or one whose arrays
    would need more than :data:`MAX_ROLLOUT_BYTES` or the memory available now (InputError with
    the estimate)."""
    from mjtrack.resources import available_memory, gigabytes

    dt = model.opt.timestep
    if nstep > MAX_STEPS:
        raise InputError(f"a rollout of {nstep * dt:.6g} s at the {dt:g} s time step is {nstep:.3g} time steps; "
                         f"one rollout takes at most {MAX_STEPS:.3g} ({MAX_STEPS * dt:.6g} s)")
    need = rollout_bytes(model, nbatch, nstep, keep_states=keep_states)
    available = available_memory()
    limit = MAX_ROLLOUT_BYTES if available is None else min(MAX_ROLLOUT_BYTES, 0.8 * available)
    if need > limit:
        raise InputError(f"a rollout of {nbatch} x {nstep} time steps ({nstep * dt:.6g} s at {dt:g} s) needs about "
                         f"{gigabytes(need)} of memory; at most {gigabytes(limit)} here")


def run_batch(
    models: list[mujoco.MjModel],
    commands: np.ndarray,
    *,
    state0: np.ndarray | None = None,
    nthread: int = 1,
    keep_states: bool = True,
    grounds=None,
) -> tuple[np.ndarray | None, np.ndarray]:
    """Roll out track-speed commands on a batch of models (same size signature).

    Args:
        models: nbatch models (or one, tiled).
        commands: (nbatch or 1, nstep, 2) track speed commands [m/s], held for each step.
        state0: (nbatch or 1, nstate) initial states; default each model's rest state.
        nthread: threads for ``mujoco.rollout`` (results do not depend on it).
        keep_states: return the state after every step (else None in its place: a long rollout
            then keeps only its sensors).
        grounds: each model's per-chunk ground (:func:`mjtrack.sim.ground.chunk_ground`, None for
            none), one per model (or one, tiled).
    Returns:
        state (nbatch, nstep, nstate) after each step (or None), sensordata (nbatch, nstep, nsensordata).
    Raises:
        InputError: a rollout too long or too large for the machine (:func:`check_rollout`).
    """
    commands = np.asarray(commands, dtype=float)
    if commands.ndim != 3 or commands.shape[2] != 2:
        raise InputError(f"rollout: commands must have shape (nbatch, nstep, 2), got {commands.shape}")
    nbatch_all = max(len(models), commands.shape[0], 1 if state0 is None else np.atleast_2d(state0).shape[0])
    check_rollout(models[0], nbatch_all, commands.shape[1], keep_states=keep_states)
    B = control_matrix(models[0])
    control = np.ascontiguousarray(commands @ B.T)
    if state0 is None:
        state0 = np.stack([initial_state(m) for m in models])
    state0 = np.atleast_2d(state0)
    nbatch = max(len(models), control.shape[0], state0.shape[0])
    model_arg = models if len(models) > 1 else models[0]
    datas = [mujoco.MjData(models[0]) for _ in range(max(1, nthread))]
    state, sensordata = aligned_rollout(model_arg, datas if nthread > 1 else datas[0],
                                        np.repeat(state0, nbatch // state0.shape[0], axis=0),
                                        np.repeat(control, nbatch // control.shape[0], axis=0),
                                        keep_states=keep_states, ground=grounds)
    _check(state, sensordata)
    return state, sensordata


def aligned_rollout(model_arg, data_arg, state0: np.ndarray, control: np.ndarray, *, keep_states: bool = True,
                    chunk_steps: int = CHUNK_STEPS, ground=None) -> tuple[np.ndarray | None, np.ndarray]:
    """``mujoco.rollout.rollout`` with each step's sensors read at the state that step reached.

    ``mj_step`` evaluates the sensors in its forward pass, *before* it integrates, so the
    sensordata that ``mujoco.rollout`` returns beside the state after step k belong to the state
    before it: one time step stale. A log sampled from them would carry every pose at t - dt
    under the label t, and a window replayed from a logged pose would run one step behind its
    log (a yaw error of wz dt from the first step on). The rollout here takes one more step with
    the last control and returns, beside the state after step k, the sensors that step k + 1
    evaluated at it.

    Args:
        model_arg, data_arg: as ``mujoco.rollout.rollout`` takes them (one or per-batch models;
            one MjData, or one per thread).
        state0: (nbatch, nstate) initial states (``mjSTATE_FULLPHYSICS``).
        control: (nbatch, nstep, nu) controls, each held for one step.
        keep_states: return the states (else None in their place).
        chunk_steps: a single rollout (nbatch 1) longer than this runs in chunks of this many
            steps (module docstring; the bytes do not depend on it).
        ground: what sets each rollout's model before each of its chunks (the shear ground:
            :func:`mjtrack.sim.ground.chunk_ground`), one for all rollouts or one per rollout (None:
            nothing); every rollout then runs on its own copy of its model, in chunks of the
            ground's ``every`` steps.
    Returns:
        state (nbatch, nstep, nstate) after each step (or None); sensordata (nbatch, nstep,
        nsensordata) of those states.
    """
    control = np.asarray(control, dtype=float)
    extended = np.concatenate([control, control[:, -1:]], axis=1)
    grounds = None if ground is None else batch_ground(ground, control.shape[0])
    if grounds is not None:
        return _ground_rollout(model_arg, data_arg, np.atleast_2d(state0), extended, grounds, keep_states)
    if control.shape[0] > 1 or extended.shape[1] <= chunk_steps:
        # a batch runs in one call: the solver's warm start of each case is not returned, so a
        # batch cannot be cut in time without changing its bytes (batches are short: windows, steady cases)
        # threads: one pool kept for the process (starting one per call cost a window's Python overhead)
        pooled = isinstance(data_arg, (list, tuple)) and len(data_arg) > 1
        state, sensordata = mj_rollout.rollout(model_arg, data_arg, state0, np.ascontiguousarray(extended),
                                               persistent_pool=pooled)
        return (state[:, :-1] if keep_states else None), sensordata[:, 1:]
    model = model_arg if isinstance(model_arg, mujoco.MjModel) else model_arg[0]
    data = data_arg if isinstance(data_arg, mujoco.MjData) else data_arg[0]
    nstep, total = control.shape[1], extended.shape[1]
    states = np.empty((1, nstep, mujoco.mj_stateSize(model, STATE_SPEC))) if keep_states else None
    sensordata = np.empty((1, nstep, model.nsensordata))
    start, warm = np.atleast_2d(state0), None
    for lo in range(0, total, chunk_steps):
        hi = min(total, lo + chunk_steps)
        # raw step g gives the state after step g and the sensors of the state before it (after g - 1)
        st, sd = mj_rollout.rollout(model, data, start, np.ascontiguousarray(extended[:, lo:hi]),
                                    initial_warmstart=warm)
        if states is not None:
            states[:, lo:min(hi, nstep)] = st[:, :min(hi, nstep) - lo]
        first = max(lo, 1)
        sensordata[:, first - 1:hi - 1] = sd[:, first - lo:]
        start, warm = st[:, -1], data.qacc_warmstart.copy()[None]
    return states, sensordata


def _ground_rollout(model_arg, data_arg, state0: np.ndarray, extended: np.ndarray, grounds,
                    keep_states: bool) -> tuple[np.ndarray | None, np.ndarray]:
    """:func:`aligned_rollout` of ``extended`` controls (the last step repeated) with a ground that
    sets each rollout's own model copy before each chunk of ``grounds.every`` steps (the solver's
    warm start of a batch is not returned, so each chunk starts cold: part of this ground's model)."""
    nbatch, total = extended.shape[:2]
    models = model_arg if isinstance(model_arg, (list, tuple)) else [model_arg]
    models = [copy.copy(m) for m in (models * nbatch if len(models) == 1 else models)]
    pooled = isinstance(data_arg, (list, tuple)) and len(data_arg) > 1
    nstate = mujoco.mj_stateSize(models[0], STATE_SPEC)
    states = np.empty((nbatch, total, nstate)) if keep_states else None
    sensordata = np.empty((nbatch, total, models[0].nsensordata))
    start = np.repeat(state0, nbatch // state0.shape[0], axis=0)
    for lo in range(0, total, grounds.every):
        hi = min(total, lo + grounds.every)
        grounds.apply(models, start)
        st, sd = mj_rollout.rollout(models, data_arg, start, np.ascontiguousarray(extended[:, lo:hi]),
                                    persistent_pool=pooled)
        if states is not None:
            states[:, lo:hi] = st
        sensordata[:, lo:hi] = sd
        start = st[:, -1]
    return (states[:, :-1] if keep_states else None), sensordata[:, 1:]


def _check(state: np.ndarray | None, sensordata: np.ndarray) -> None:
    if not np.all(np.isfinite(sensordata)) or (state is not None and not np.all(np.isfinite(state))):
        raise MjtrackError("simulation diverged (non-finite state); reduce the time step")
    if state is None:
        return
    t = state[..., 0]
    if np.any(np.diff(t, axis=-1) <= 0):
        raise MjtrackError("simulation diverged (MuJoCo reset the state); reduce the time step")


def settled_state(model: mujoco.MjModel, *, settle_s: float = SETTLE_S) -> np.ndarray:
    """State (nstate,) after ``settle_s`` at rest with zero command, time reset to 0."""
    nstep = max(1, int(round(settle_s / model.opt.timestep)))
    state, _ = run_batch([model], np.zeros((1, nstep, 2)))
    s = state[0, -1].copy()
    s[0] = 0.0  # mjSTATE_TIME comes first in the full physics state
    return s


def steps_per_sample(timestep: float, log_rate: float) -> int:
    """Integer steps per log sample; refuses a log period that is not a multiple of dt."""
    if not log_rate > 0:
        raise InputError(f"log rate must be positive, got {log_rate!r}")
    k = 1.0 / (log_rate * timestep)
    if abs(k - round(k)) > 1e-6 or round(k) < 1:
        raise InputError(
            f"log rate {log_rate} Hz: the log period must be a multiple of the time step {timestep} s"
        )
    return int(round(k))


def yaw_of(quat: np.ndarray) -> np.ndarray:
    """Heading [rad] of quaternions (..., 4) (w, x, y, z): the angle of the body x axis in xy."""
    w, x, y, z = np.moveaxis(quat, -1, 0)
    return np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def roll_pitch_of(quat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Roll and pitch [rad] of quaternions (..., 4): Z-Y-X Euler angles after the heading
    (:func:`yaw_of`); pitch positive nose down (rotation about body y), roll positive left side up."""
    w, x, y, z = np.moveaxis(quat, -1, 0)
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    return roll, pitch


def log_columns(sensordata: np.ndarray, commands: np.ndarray, smap: SensorMap, *, timestep: float,
                stride: int) -> dict[str, np.ndarray]:
    """Drive-log columns (docs/reference/formats/drive-log.md) from one rollout's sensordata (nstep, nsensordata).

    Sample j is the state after step (j+1)*stride - 1, i.e. at t = (j+1) * stride * dt. The
    command columns are filled in by :func:`simulate` (see :func:`_commands_in_force`). A first
    row at t = 0 (the settled rest state) is prepended by :func:`simulate`.
    """
    idx = np.arange(stride - 1, sensordata.shape[0], stride)
    s = sensordata[idx]
    return {
        "t": (idx + 1) * timestep,
        "v_left_cmd": commands[idx, 0],
        "v_right_cmd": commands[idx, 1],
        "x": s[:, smap.pos][:, 0],
        "y": s[:, smap.pos][:, 1],
        "yaw": yaw_of(s[:, smap.quat]),
        "v_left": s[:, smap.track_speed[0]],
        "v_right": s[:, smap.track_speed[1]],
        "vx": s[:, smap.linvel][:, 0],
        "vy": s[:, smap.linvel][:, 1],
        "wz": s[:, smap.angvel][:, 2],
        "z": s[:, smap.pos][:, 2],
        "roll": roll_pitch_of(s[:, smap.quat])[0],
        "pitch": roll_pitch_of(s[:, smap.quat])[1],
    }


def hold_commands(t_cmd: np.ndarray, v_left: np.ndarray, v_right: np.ndarray, *, timestep: float,
                  duration: float) -> np.ndarray:
    """Zero-order hold of a command table onto the steps: (nstep, 2) [m/s].

    Step k (from t = k dt to (k+1) dt) gets the last command with t_cmd <= k dt (the first
    command before t_cmd[0]).
    """
    t_cmd = np.asarray(t_cmd, dtype=float)
    if t_cmd.ndim != 1 or len(t_cmd) == 0 or np.any(np.diff(t_cmd) <= 0):
        raise InputError("commands: time must be a non-empty, strictly increasing column")
    nstep = int(round(duration / timestep))
    if nstep < 1:
        raise InputError(f"duration {duration} s is shorter than one time step")
    if nstep > MAX_STEPS:  # a rollout keeps every step's state (~1 kB): refuse before allocating
        raise InputError(f"duration {duration:g} s is {nstep} time steps; one rollout takes at most "
                         f"{MAX_STEPS} ({MAX_STEPS * timestep:g} s)")
    tk = np.arange(nstep) * timestep
    i = np.clip(np.searchsorted(t_cmd, tk + 1e-9 * timestep, side="right") - 1, 0, len(t_cmd) - 1)
    return np.stack([np.asarray(v_left, float)[i], np.asarray(v_right, float)[i]], axis=1)


def simulate(
    robot: Robot,
    commands: np.ndarray,
    *,
    config: SimConfig | None = None,
    log_rate: float = 50.0,
    model: mujoco.MjModel | None = None,
    terrain: Terrain | None = None,
) -> dict[str, np.ndarray]:
    """Roll out per-step commands (nstep, 2) [m/s] from rest; drive-log columns at ``log_rate``.

    Returns a dict of (nsample,) arrays with the columns t, v_left_cmd, v_right_cmd, x, y, yaw,
    v_left, v_right, vx, vy, wz, and z, roll, pitch on a terrain other than flat; the first row
    is the settled rest state at t = 0. On terrain with edges use a time step of at most
    :data:`mjtrack.sim.terrain.EDGE_TIMESTEP` (:func:`drive_log` and ``steady`` do so themselves).

    The commands are held for whole log periods (:func:`log_rate_commands`): the robot is driven
    by exactly what its log's rows say, each row's command in force until the next row.
    """
    config = config or SimConfig()
    terrain = terrain or Terrain()
    dt = model.opt.timestep if model is not None else config.timestep
    commands = log_rate_commands(commands, steps_per_sample(dt, log_rate))
    if config.track_model == "surfacevel":
        return _terrain_columns(_simulate_surfacevel(robot, commands, config=config, log_rate=log_rate,
                                                     terrain=terrain), terrain)
    model = model or build_model(robot, config, terrain)
    stride = steps_per_sample(model.opt.timestep, log_rate)
    s0 = settled_state(model)
    driven = drive_commands(robot, commands, model.opt.timestep)  # speed scale and dead time
    _, sensordata = run_batch([model], driven[None], state0=s0[None], keep_states=False,
                              grounds=[chunk_ground(model, robot, config)])
    cols = log_columns(sensordata[0], commands, SensorMap.of(model), timestep=model.opt.timestep, stride=stride)
    first = _rest_row(model, s0)
    out = {k: np.concatenate([[first[k]], v]) for k, v in cols.items()}
    out["yaw"] = np.unwrap(out["yaw"])
    return _terrain_columns(_commands_in_force(out, commands, stride), terrain)


def log_rate_commands(commands: np.ndarray, stride: int) -> np.ndarray:
    """Per-step commands (nstep, 2) held for whole log periods of ``stride`` steps: step k gets
    the command of step stride * floor(k / stride).

    A log records the command at its rows only, and its convention is that a row's command is in
    force until the next row. A command that changed between two rows (a scenario's random switch
    time, a command table off the log grid) would otherwise act up to a log period before the log
    says it does: a window of the log replayed from its rows then turns a few steps late (a yaw
    error of the change in yaw rate times that time).
    """
    commands = np.asarray(commands, dtype=float)
    k = np.arange(commands.shape[0])
    return commands[(k // stride) * stride]


def _terrain_columns(out: dict[str, np.ndarray], terrain: Terrain) -> dict[str, np.ndarray]:
    """z, roll, pitch are logged on terrain only (flat logs keep their columns)."""
    if terrain.is_flat:
        for k in ("z", "roll", "pitch"):
            out.pop(k, None)
    return out


def _commands_in_force(out: dict[str, np.ndarray], commands: np.ndarray, stride: int) -> dict[str, np.ndarray]:
    """Log convention: a row's command is the one in force from its time t on (zero-order hold
    over [t_j, t_j+1)), the convention of :func:`mjtrack.models.integrate` and of the filters.

    Row j (t = j·stride·dt) therefore gets the command of step j·stride; the last row, after
    the final step, repeats the last command.
    """
    n = out["t"].size
    idx = np.minimum(np.arange(n) * stride, len(commands) - 1)
    out["v_left_cmd"] = commands[idx, 0].copy()
    out["v_right_cmd"] = commands[idx, 1].copy()
    return out


def _simulate_surfacevel(robot: Robot, commands: np.ndarray, *, config: SimConfig, log_rate: float,
                         terrain: Terrain) -> dict[str, np.ndarray]:
    """The surfacevel track model (:mod:`mjtrack.sim.surfacevel`): a Python step loop, because
    its track speeds are model fields set every step by its ``TrackDrive`` (no actuators, so
    ``mujoco.rollout`` cannot drive it). Same columns and sampling as :func:`simulate`; the
    track speeds logged are the drive's."""
    model = build_model(robot, config, terrain)
    stride = steps_per_sample(model.opt.timestep, log_rate)
    data = mujoco.MjData(model)
    drive = TrackDrive(model, robot, config, ground=ground_stepper(model, robot, config))
    for _ in range(int(round(SETTLE_S / model.opt.timestep))):
        drive.step(data, 0.0, 0.0)
    smap = {n: int(model.sensor(n).adr[0]) for n in ("body_linvel", "body_angvel", "body_pos", "body_quat")}
    rows = []

    def row(t: float, cmd) -> list[float]:
        s = data.sensordata
        p, q = smap["body_pos"], smap["body_quat"]
        roll, pitch = roll_pitch_of(s[q:q + 4])
        return [t, cmd[0], cmd[1], s[p], s[p + 1], float(yaw_of(s[q:q + 4])), drive.speeds[0], drive.speeds[1],
                s[smap["body_linvel"]], s[smap["body_linvel"] + 1], s[smap["body_angvel"] + 2],
                s[p + 2], float(roll), float(pitch)]

    mujoco.mj_forward(model, data)
    rows.append(row(0.0, (0.0, 0.0)))
    driven = drive_commands(robot, commands, model.opt.timestep)  # speed scale and dead time
    for k, cmd in enumerate(commands):
        drive.step(data, *driven[k])
        if (k + 1) % stride == 0:
            mujoco.mj_forward(model, data)  # the sensors of the state reached (aligned_rollout)
            rows.append(row((k + 1) * model.opt.timestep, cmd))
    a = np.array(rows)
    if not np.all(np.isfinite(a)):
        raise MjtrackError("surfacevel simulation diverged (non-finite state)")
    names = ("t", "v_left_cmd", "v_right_cmd", "x", "y", "yaw", "v_left", "v_right", "vx", "vy", "wz", "z", "roll",
             "pitch")
    out = {n: a[:, i] for i, n in enumerate(names)}
    out["yaw"] = np.unwrap(out["yaw"])
    return _commands_in_force(out, commands, stride)


def _rest_row(model: mujoco.MjModel, state: np.ndarray) -> dict[str, float]:
    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, state, STATE_SPEC)
    mujoco.mj_forward(model, data)
    smap = SensorMap.of(model)
    s = data.sensordata
    roll, pitch = roll_pitch_of(s[smap.quat])
    return {"z": s[smap.pos][2], "roll": float(roll), "pitch": float(pitch), "t": 0.0, "v_left_cmd": 0.0, "v_right_cmd": 0.0, "x": s[smap.pos][0], "y": s[smap.pos][1],
            "yaw": float(yaw_of(s[smap.quat])), "v_left": s[smap.track_speed[0]],
            "v_right": s[smap.track_speed[1]], "vx": s[smap.linvel][0], "vy": s[smap.linvel][1],
            "wz": s[smap.angvel][2]}


def drive_log(robot: Robot, table: tuple[np.ndarray, np.ndarray, np.ndarray], *, duration: float,
              config: SimConfig | None = None, log_rate: float = 50.0, terrain: Terrain | None = None):
    """Roll out a command table (t, v_left, v_right) held for ``duration`` [s]: a DriveLog.

    At ``config.timestep`` (smaller on terrain edges), not at the step of ``config.lag_budget``:
    calibration and MuJoCo-baseline diagnosis simulate a log's windows at the fixed step, so a log
    made here is simulated as they simulate it."""
    from mjtrack.io.logs import DriveLog

    config = config or SimConfig()
    config = config.replace(timestep=timestep_for(config.timestep, terrain))  # smaller on edges
    commands = hold_commands(*table, timestep=config.timestep, duration=duration)
    return DriveLog.from_columns(simulate(robot, commands, config=config, log_rate=log_rate, terrain=terrain))


def log_icrs(log, *, wz_min: float = 1e-3):
    """ICRs (2.13) of every row of a simulated DriveLog, via :func:`mjtrack.icr.icr_from_twist`.

    Uses the logged twist and the *measured* track speeds; rows with |wz| < ``wz_min``
    [rad/s] (straight driving, rest) are masked (``valid`` False, NaN ICRs).
    """
    from mjtrack.icr import icr_from_twist

    return icr_from_twist(log.vx, log.vy, log.wz, log.v_left, log.v_right, wz_min=wz_min, on_singular="mask")
