"""The MuJoCo robot on many windows of a drive log, each started from the measured state.

A long open-loop rollout of a real log drifts away after a few seconds, and any fit to it
stalls (measured: a whole-log fit of a pushed box stopped at mu 0.665 for a truth of 0.55;
the same fit over windows started from the measured state found the truth). So the robot is
simulated over short windows of the log (default 2 s), each one:

* **started from the measured state** at its first sample: the pose (x, y, yaw; height,
  pitch and roll from the robot settled at rest); the body twist from the log's ``vx, vy, wz``
  when present, else from the poses by a local quadratic least-squares fit (a smoothed finite
  difference over ``fit_s`` seconds, centred where the segment allows, one-sided at its
  start); the tracks already moving: every roller hinge (every wheel of a wheeled robot) turns at
  the measured track speed (``v_left``, ``v_right``; the command when they are missing), and a
  lagged drive's set-point starts there too;
* **driven by the logged commands** (zero-order hold: a row's command is in force until the
  next row), transformed by the drivetrain parameters that are not model fields
  (``track_speed_scale`` multiplies them, the robot's own controller stages reshape them, and
  ``drive_delay`` shifts what comes out: within the dead time a window's drive follows the log's
  commands before it, and before its segment's first row it keeps the speed its track had at the
  start, whatever the scale and the controller);
* **kept inside one segment** (``window`` column): a window never crosses a segment boundary;
  a segment shorter than the horizon but at least ``min_fraction`` of it still gives one window
  that ends at its last sample (the Marmotte log is 432 segments of 1.90-2.06 s).

The windows, their start states and errors, the screening rules and the window parameters are
:mod:`mjtrack.windows` (no MuJoCo); this module only simulates them.

Derivation and measurements: docs/theory/simulator.md, "Windows of a log".
"""

from __future__ import annotations

import copy
import logging
import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import mujoco
import numpy as np

from mjtrack.errors import InputError, MjtrackError
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import MAX_RESISTANCE, G, Robot
from mjtrack.sim.builder import apply_rest_margins, build_model, control_matrix, track_model_for
from mjtrack.sim.chassis import (chassis_mass_properties, resistance_forces, set_body_inertia, set_resistance,
                                 set_rest_springs)
from mjtrack.sim.config import SimConfig
from mjtrack.sim.drivetrain import controller_stages
from mjtrack.sim.ground import chunk_ground, framed_robot
from mjtrack.sim.rollout import STATE_SPEC, SensorMap, aligned_rollout, collected_mujoco_warnings, settled_state, yaw_of
from mjtrack.windows.define import DIVERGED_ERROR, WindowSet, start_speeds, start_twists, window_errors
from mjtrack.windows.params import WINDOW_PARAMS, drive_params, geometry_robot, robot_params, slope_of

logger = logging.getLogger(__name__)

MIN_LAG = 1e-4  # [s] a lag this short acts as none (the filtered drive needs lag > 0)
DIVERGED_SPEED = 20.0  # [m/s] a tracked robot's body this fast has left the physics (explicit-Euler blow-up)
CHUNK = 48  # windows per rollout call (bounds the state output's memory)


class WindowSim:
    """One compiled robot (roller chain, or the wheels of a wheeled robot) and what it needs to
    start windows.

    ``lagged``: compile the drives with a first-order filter even if the robot has no lag, so
    that variants may set one (a lag of 0 is then simulated as :data:`MIN_LAG`).
    ``resisted``: compile the motion resistance's actuators even if the robot has none, so that
    variants may set ``rolling_resistance`` (at 0 they apply no force).
    ``framed``: compile the contacts with the track's tangent frames
    (:func:`mjtrack.sim.ground.framed_robot`), so that variants may set ``lateral_shear_ratio``.
    """

    def __init__(self, robot: Robot, config: SimConfig | None = None, *, lagged: bool = True,
                 resisted: bool = False, framed: bool = False) -> None:
        config = config or SimConfig()
        if config.track_model != "rollers":
            raise InputError("windows: only the 'rollers' track model can be batched through mujoco.rollout "
                             "(the surfacevel model sets its track speeds from Python every step)")
        lag = drive_params(robot)["drive_lag"] or 0.0
        if lagged or lag > 0:
            config = config.replace(lag=max(lag, MIN_LAG))
        self.robot, self.config = robot, config
        self.tracks = track_model_for(robot, config)
        built = self.tracks.configure(robot, config)  # the settings the model is built with
        self.built_config = built
        resisted = resisted or robot.rolling_resistance > 0
        # built with some resistance so that the actuators exist; every variant sets its own (and
        # framed: with the track's contact frames; each variant's shear friction is set per chunk)
        built_robot = framed_robot(robot) if framed else robot
        self.model = build_model(built_robot.replace(rolling_resistance=max(robot.rolling_resistance, 0.1))
                                 if resisted else built_robot, config)
        self.framed = framed
        m = self.model
        self.dt = float(m.opt.timestep)
        self.smap = SensorMap.of(m)
        self.B = control_matrix(m)
        self.drives = np.flatnonzero(self.B.any(axis=1))
        # the side of each actuator state (the drives' filtered set-points)
        self.side_of_act = np.array([int(np.argmax(self.B[a])) for a in range(m.nu) if m.actuator_actnum[a] > 0], int)
        self.resisted = resisted
        jroot = m.joint("root")
        self.qadr, self.vadr = int(jroot.qposadr[0]), int(jroot.dofadr[0])
        # the rollers' (wheels') spin dofs of each side, with the side's belt joint where it has one
        # (they all move at the track speed, in m/s over the roller or wheel radius)
        self.roll_dofs = [np.array([int(m.joint(f"roll_{s}_{i}").dofadr[0]) for i in range(built.n_rollers)])
                          for s in ("left", "right")]
        belts = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, f"belt_{s}") for s in ("left", "right")]
        self.belt_dofs = [np.array([m.jnt_dofadr[j]] if j >= 0 else [], int) for j in belts]
        self.roller_radius = built.roller_radius
        chassis = m.body("chassis")
        self.chassis_id = int(chassis.id)
        self.cg_site = int(m.site("cg").id)
        self.pair_side = np.array([0 if m.pair(i).name.startswith("contact_left") else 1 for i in range(m.npair)])
        self._settled: dict[tuple, np.ndarray] = {}
        self._builds: dict[tuple, "WindowSim"] = {}
        self._lagged = lagged

    def for_params(self, params: Mapping[str, float | None]) -> "WindowSim":
        """The simulator of the robot with the structural parameters of ``params`` (this one when
        they are unchanged; rebuilt once per distinct geometry, the last few kept)."""
        robot = geometry_robot(self.robot, params)
        if robot is self.robot:
            return self
        key = (robot.track_length, robot.wheelbase, robot.ground.params)
        if key not in self._builds:
            if len(self._builds) >= 24:
                self._builds.pop(next(iter(self._builds)))
            self._builds[key] = WindowSim(robot, self.config, lagged=self._lagged, resisted=self.resisted,
                                          framed=self.framed)
        return self._builds[key]

    # -- variants ---------------------------------------------------------------------------------
    def variant_model(self, params: Mapping[str, float | None]) -> mujoco.MjModel:
        """A copy of the compiled model with the model-field parameters of ``params`` set."""
        m = copy.copy(self.model)
        robot = self.robot
        mu = params.get("mu")
        rho = params.get("lateral_ratio")
        if rho is not None and self.robot.ground.model != "anisotropic":
            raise InputError("windows: 'lateral_ratio' needs a robot built with the anisotropic ground "
                             "(robot key ground: {\"model\": \"anisotropic\"})")
        if rho is None and self.robot.ground.model == "anisotropic":
            rho = self.robot.ground["lateral_ratio"]
        if rho is not None and not 0 < rho <= 1.5:
            raise InputError(f"windows: 'lateral_ratio' must be in (0, 1.5], got {rho!r}")
        for side, key in ((0, "mu_left"), (1, "mu_right")):
            v = params.get(key)
            v = v if v is not None else mu
            if v is not None:
                if not v > 0:
                    raise InputError(f"windows: friction '{key}' must be > 0, got {v!r}")
                # first tangent: across the track for the anisotropic ground's capsules
                m.pair_friction[self.pair_side == side, 0] = v * (rho if rho is not None else 1.0)
                m.pair_friction[self.pair_side == side, 1] = v
        if params.get("cg_x") is not None or params.get("cg_y") is not None:
            cg = np.array([params.get("cg_x", robot.cg_x) if params.get("cg_x") is not None else robot.cg_x,
                           params.get("cg_y", robot.cg_y) if params.get("cg_y") is not None else robot.cg_y])
            if abs(cg[0]) >= robot.contact_length / 2 or abs(cg[1]) >= robot.track_gauge / 2:
                raise InputError(f"windows: centre of mass {cg.tolist()} lies outside the {robot.traction}")
            moved = robot.replace(cg_x=float(cg[0]), cg_y=float(cg[1]))
            _, ipos, full = chassis_mass_properties(moved, self.built_config, self.tracks)
            m.body_ipos[self.chassis_id] = ipos
            set_body_inertia(m, self.chassis_id, full)  # products of inertia follow the cg
            m.site_pos[self.cg_site, :2] = cg
            if robot.ground.model != "road_wheels":  # (road wheels keep their own springs)
                set_rest_springs(m, moved, self.config)
            # quantities the compiler derives from the mass distribution (constraint scaling
            # through body_invweight0 / dof_invweight0): recomputed as a rebuild would
            mujoco.mj_setConst(m, mujoco.MjData(m))
            if self.config.rest_margin:  # (WindowSim runs the roller chain and the wheels only)
                apply_rest_margins(m)  # the rest penetrations follow the loads, as a rebuild's
        lag = params.get("drive_lag")
        if lag is not None:
            if lag < 0:
                raise InputError(f"windows: drive_lag must be >= 0 s, got {lag!r}")
            m.actuator_dynprm[self.drives, 0] = max(float(lag), MIN_LAG)
        flim = params.get("drive_force_limit")
        if flim is not None:
            if not flim > 0:
                raise InputError(f"windows: drive_force_limit must be > 0 N, got {flim!r}")
            per = float(flim) / len(self.roll_dofs[0])
            m.actuator_forcerange[self.drives] = [-per, per]
        if self.resisted:
            c = params.get("rolling_resistance")
            c = robot.rolling_resistance if c is None else float(c)
            if not 0 <= c <= MAX_RESISTANCE:
                raise InputError(f"windows: rolling_resistance must be in [0, {MAX_RESISTANCE:g}], got {c!r}")
            cg_y = params.get("cg_y")
            set_resistance(m, resistance_forces(robot if cg_y is None else robot.replace(cg_y=float(cg_y)), c))
        elif params.get("rolling_resistance"):
            raise InputError("windows: rolling_resistance needs a window simulator built with resistance "
                             "(WindowSim(..., resisted=True))")
        ax, ay = slope_of(params)
        if ax or ay:
            m.opt.gravity[:] = (-G * ax, -G * ay, -G * math.sqrt(1.0 - ax * ax - ay * ay))
        return m

    def settled(self, model: mujoco.MjModel, key: tuple) -> np.ndarray:
        """Rest state of a variant (cached by the values that change it: the centre of mass)."""
        if key not in self._settled:
            self._settled[key] = settled_state(model)
        return self._settled[key]

    def initial_states(self, model: mujoco.MjModel, rest: np.ndarray, poses: np.ndarray, twists: np.ndarray,
                       speeds: np.ndarray) -> np.ndarray:
        """Full physics states (M, nstate): the rest state moved to ``poses`` (M, 3), moving with
        body ``twists`` (M, 3), tracks turning at ``speeds`` (M, 2) and drives set to them."""
        data = mujoco.MjData(model)
        mujoco.mj_setState(model, data, rest, STATE_SPEC)
        q_rest = data.qpos[self.qadr + 3:self.qadr + 7].copy()
        qpos0, act0 = data.qpos.copy(), data.act.copy()
        out = np.empty((poses.shape[0], rest.size))
        r = self.roller_radius
        for j in range(poses.shape[0]):
            x, y, yaw = poses[j]
            data.qpos[:] = qpos0
            data.qvel[:] = 0.0
            data.qpos[self.qadr:self.qadr + 2] = (x, y)
            qy = np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])
            quat = np.empty(4)
            mujoco.mju_mulQuat(quat, qy, q_rest)
            data.qpos[self.qadr + 3:self.qadr + 7] = quat
            vx, vy, wz = twists[j]
            c, s = math.cos(yaw), math.sin(yaw)
            data.qvel[self.vadr:self.vadr + 3] = (c * vx - s * vy, s * vx + c * vy, 0.0)  # world frame
            data.qvel[self.vadr + 3:self.vadr + 6] = (0.0, 0.0, wz)  # body frame (yaw-rate about body z)
            for side in (0, 1):
                data.qvel[self.roll_dofs[side]] = speeds[j, side] / r
                data.qvel[self.belt_dofs[side]] = speeds[j, side] / r  # the belt joint: radius r too
            if data.act.size:
                data.act[:] = speeds[j, self.side_of_act] if act0.size == self.side_of_act.size else act0
            data.time = 0.0
            mujoco.mj_getState(model, data, out[j], STATE_SPEC)
        return out


    def pinned(self, model: mujoco.MjModel, state: np.ndarray, pose: np.ndarray, twist: np.ndarray,
               data: mujoco.MjData | None = None) -> np.ndarray:
        """``state`` (nstate,) moved to the planar ``pose`` (x, y, yaw) and ``twist`` (vx, vy, wz),
        every other state kept: height, roll, pitch and their rates, the tracks, the drives.
        ``data``: a scratch MjData of ``model`` (allocating one per window cost more than the
        rest of this function)."""
        data = mujoco.MjData(model) if data is None else data
        mujoco.mj_setState(model, data, state, STATE_SPEC)
        q = data.qpos[self.qadr + 3:self.qadr + 7].copy()
        turn = float(pose[2]) - float(yaw_of(q))
        qz = np.array([math.cos(turn / 2), 0.0, 0.0, math.sin(turn / 2)])
        quat = np.empty(4)
        mujoco.mju_mulQuat(quat, qz, q)  # a turn about the world vertical
        data.qpos[self.qadr + 3:self.qadr + 7] = quat
        data.qpos[self.qadr:self.qadr + 2] = pose[:2]
        c, s = math.cos(pose[2]), math.sin(pose[2])
        vx, vy, wz = twist
        data.qvel[self.vadr:self.vadr + 2] = (c * vx - s * vy, s * vx + c * vy)
        data.qvel[self.vadr + 5] = wz
        out = np.empty_like(state)
        mujoco.mj_getState(model, data, out, STATE_SPEC)
        return out


def warm_states(sim: WindowSim, model: mujoco.MjModel, log: DriveLog, ws: WindowSet, rest: np.ndarray,
                state0: np.ndarray, twists: np.ndarray, warmup_s: float, *, delays: tuple[float, float], scale: float,
                datas: list, ground=None) -> np.ndarray:
    """Start states (M, nstate) whose hidden states come from the log's own past: each window's
    robot is started ``warmup_s`` earlier (at most from its segment's start) from the logged state
    there, driven by the logged commands up to the window's start, and then moved to the logged
    pose and twist (:meth:`WindowSim.pinned`). The states a log does not hold -- suspension
    deflections under load transfer, each roller's and belt's speed, the drives' filter -- are then
    those the robot's recent history gives, not those of a robot at rest. Windows at a segment's
    start keep ``state0``. ``ground``: the model's per-chunk ground (:func:`chunk_ground`), or None."""
    out = state0.copy()
    slices = log.segment_slices()
    first = np.array([slices[k].start for k in ws.segment])
    wstart = np.array([max(f, f + int(np.searchsorted(log.t[f:s + 1], log.t[s] - warmup_s - 1e-9)))
                       for f, s in zip(first, ws.starts)])
    nsteps = np.round((log.t[ws.starts] - log.t[wstart]) / sim.dt).astype(int)
    for n in np.unique(nsteps[nsteps > 0]):
        g = np.flatnonzero(nsteps == n)
        wws = WindowSet(wstart[g], ws.starts[g], ws.segment[g], warmup_s)
        p0 = np.stack([log.x[wws.starts], log.y[wws.starts], log.yaw[wws.starts]], -1).astype(float)
        sp0 = start_speeds(log, wws)
        st = sim.initial_states(model, rest, p0, start_twists(log, wws), sp0)
        cmds = drive_setpoints(sim.robot, log, wws, sim.dt, int(n), delays=delays, scale=scale, start=sp0)
        states, _ = aligned_rollout([model] * g.size, datas if len(datas) > 1 else datas[0], st, cmds @ sim.B.T,
                                    ground=ground)
        scratch = mujoco.MjData(model)
        for i, j in enumerate(g):
            end = states[i, -1]
            if np.all(np.isfinite(end)):
                pose = np.array([log.x[ws.starts[j]], log.y[ws.starts[j]], log.yaw[ws.starts[j]]], float)
                out[j] = sim.pinned(model, end, pose, twists[j], scratch)
    return out


@dataclass(frozen=True)
class WindowResult:
    """Rollouts of M windows under P parameter sets.

    ``poses``: (P, M, K, 3) predicted poses (x, y, yaw unwrapped) at the log's sample times of
    each window (K = longest window's samples; NaN beyond a window's end); ``errors``: (P, M, 3)
    along, across [m] and yaw [rad] error at each window's last sample in the frame of its
    measured start pose; ``speeds``: (P, M, K, 2) simulated track speeds at the same times;
    ``diverged``: (P, M) windows whose simulation blew up (body speed above
    :data:`DIVERGED_SPEED`, or not finite; their poses are kept as they came out, their errors are
    :data:`mjtrack.windows.define.DIVERGED_ERROR` in every component).
    """

    poses: np.ndarray
    errors: np.ndarray
    speeds: np.ndarray
    diverged: np.ndarray

    @property
    def any_diverged(self) -> bool:
        return bool(self.diverged.any())

    def pos_err(self) -> np.ndarray:
        """(P, M) horizon position errors [m]."""
        return np.hypot(self.errors[..., 0], self.errors[..., 1])

    def rms(self) -> np.ndarray:
        """(P,) RMS horizon position error over the windows [m] (``pos_err_m`` of calibration.json)."""
        return np.sqrt(np.mean(self.pos_err() ** 2, axis=1))


def window_commands(log: DriveLog, ws: WindowSet, dt: float, nstep: int, *, scale: float,
                    lead: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Per-step track-speed commands (M, lead + nstep, 2) of each window, scaled, from ``lead`` steps
    before its start, and the share (M, lead + nstep) of each step that lies before its segment's
    first row, where the log has no command (0 there). Each step gets the mean of the held command
    over its part inside the segment (exact integral of the log's zero-order hold), so that a row
    that does not fall on the step grid moves the steps continuously."""
    slices = log.segment_slices()
    out = np.zeros((len(ws), lead + nstep, 2))
    pre = np.zeros((len(ws), lead + nstep))
    edges = (np.arange(lead + nstep + 1) - lead) * dt  # step k covers [edges[k], edges[k+1]) after the window's start
    for j, (s, k) in enumerate(zip(ws.starts, ws.segment)):
        sl = slices[k]
        t = np.asarray(log.t[sl], float) - log.t[s]
        cmd = np.stack([log.v_left_cmd[sl], log.v_right_cmd[sl]], -1).astype(float)
        # integral of the held command from t[0]: F(t_i) at the rows, linear in between, 0 before t[0]
        F_rows = np.concatenate([np.zeros((1, 2)), np.cumsum(cmd[:-1] * np.diff(t)[:, None], axis=0)])
        e = np.maximum(edges, t[0])
        i = np.clip(np.searchsorted(t, e, side="right") - 1, 0, t.size - 1)
        F = F_rows[i] + cmd[i] * (e - t[i])[:, None]
        pre[j] = np.clip((t[0] - edges[:-1]) / dt, 0.0, 1.0)
        inside = np.maximum((1.0 - pre[j]) * dt, 1e-300)
        out[j] = np.diff(F, axis=0) / inside[:, None]
    return out * scale, pre


def side_delays(robot: Robot, params: Mapping[str, float | None], delay: float) -> tuple[float, float]:
    """Each side's dead time [s]: the robot's ``drive_delay_left`` / ``drive_delay_right`` while the
    variant keeps the robot's ``drive_delay``; a variant that moves ``drive_delay`` moves both sides
    to it (the fitted candidate is one dead time)."""
    own = params.get("drive_delay") is None or float(params["drive_delay"]) == float(robot.drive_delay)
    return tuple(robot.delay_per_side) if own else (delay, delay)


def drive_setpoints(robot: Robot, log: DriveLog, ws: WindowSet, dt: float, nstep: int, *, delays: tuple[float, float],
                    scale: float, start: np.ndarray) -> np.ndarray:
    """The set-points (M, nstep, 2) the drives' lags follow in each window: the log's commands
    (:func:`window_commands`, scaled), through the robot's own controller
    (:func:`mjtrack.sim.drivetrain.controller_stages`, its ramps starting at ``start`` (M, 2), the
    track speeds at the window's start), then each side's dead time: step k gets the mean over
    [k dt - d, (k+1) dt - d) of the controller's output, continuous in d (a finite-difference
    derivative with respect to the delay is not zero between step multiples). Where that reaches
    before the window's start the output comes from the log's commands there; before the segment's
    first row, where the log has none, it is ``start`` itself: a drive that was running at those
    speeds kept its set-point. The dead time acts on the controller's output, as in the drivetrain
    model the calibration fits (:func:`mjtrack.models.drivetrain.window_response`): the start speeds
    held as a *command* would pass through the speed scale and the controller's stages, and a robot
    whose controller reshapes its commands (the Husky's halves their difference) would start every
    window at a segment's start with a set-point its tracks were not running at."""
    lead = int(math.ceil(max(delays) / dt - 1e-9)) + 1
    u, pre = window_commands(log, ws, dt, nstep, scale=scale, lead=lead)
    start = np.asarray(start, float)
    first = np.sum(pre >= 1.0 - 1e-12, axis=1)  # steps wholly before the segment's first row lead the sequence
    out = np.empty_like(u)
    for f in np.unique(first):
        g = first == f
        out[g, :f] = start[g][:, None]
        out[g, f:] = controller_stages(robot, u[g, f:], dt, start[g])  # the robot's own speed controller
    out = pre[..., None] * start[:, None] + (1.0 - pre[..., None]) * out  # the step holding the segment's start
    shifted = np.empty((len(ws), nstep, 2))
    for i, d in enumerate(delays):
        whole = int(math.floor(d / dt + 1e-9))
        frac = max(d / dt - whole, 0.0)
        k = lead + np.arange(nstep) - whole
        shifted[..., i] = (1.0 - frac) * out[:, k, i] + frac * out[:, k - 1, i]
    return shifted


def simulate_windows(sim: WindowSim, log: DriveLog, ws: WindowSet,
                     variants: Sequence[Mapping[str, float | None]] | None = None, *,
                     nthread: int = 1, twists: np.ndarray | None = None, progress=None,
                     warmup_s: float = 0.0) -> WindowResult:
    """Roll out every window of ``ws`` under every parameter set of ``variants`` (default: the
    robot as described); see the module docstring for the initial state and the commands.

    Args:
        sim: the compiled robot (:class:`WindowSim`).
        log, ws: the log and its windows (:func:`make_windows`).
        variants: P dicts of window parameters (:data:`WINDOW_PARAMS`); missing keys keep the
            robot's values. Unknown names raise InputError.
        nthread: threads for ``mujoco.rollout`` (results do not depend on it).
        twists: (M, 3) start twists (default :func:`start_twists`).
        progress: optional callable(done, total) called after each rollout chunk.
        warmup_s: > 0: each window's hidden states warmed up over this much of the log before it
            (:func:`warm_states`); 0: the robot's rest state moved to the logged state.
    """
    if len(ws) == 0:
        raise InputError(f"{log.source or 'drive log'}: no window of {ws.horizon_s:g} s fits in any segment")
    base = robot_params(sim.robot)
    variants = [dict(base)] if variants is None else [{**base, **{k: v for k, v in p.items()}} for p in variants]
    for p in variants:
        unknown = set(p) - set(WINDOW_PARAMS)
        if unknown:
            raise InputError(f"windows: unknown parameter(s) {sorted(unknown)}; known: {', '.join(WINDOW_PARAMS)}")
    poses0 = np.stack([log.x[ws.starts], log.y[ws.starts], log.yaw[ws.starts]], -1).astype(float)
    twists = start_twists(log, ws) if twists is None else np.asarray(twists, float)
    speeds0 = start_speeds(log, ws)
    rel_t = log.t[ws.ends] - log.t[ws.starts]
    nstep = int(math.ceil(float(rel_t.max()) / sim.dt - 1e-6)) + 1
    K = int((ws.ends - ws.starts).max()) + 1
    # sample index of each log time in the rollout output (state after step k is at (k+1) dt)
    P, M = len(variants), len(ws)
    poses = np.full((P, M, K, 3), np.nan)
    speeds = np.full((P, M, K, 2), np.nan)
    diverged = np.zeros((P, M), bool)
    idx = np.full((M, K), -2, int)  # -2: beyond the window's end
    for j in range(M):
        tj = log.t[ws.starts[j]:ws.ends[j] + 1] - log.t[ws.starts[j]]
        idx[j, :tj.size] = np.clip(np.round(tj / sim.dt).astype(int) - 1, -1, nstep - 1)
    datas = [mujoco.MjData(sim.model) for _ in range(max(1, nthread))]
    total, done = P * M, 0
    with collected_mujoco_warnings() as warned:
        for p, params in enumerate(variants):
            vsim = sim.for_params(params)
            model = vsim.variant_model(params)
            key = (params.get("cg_x"), params.get("cg_y"), *slope_of(params))
            try:
                rest = vsim.settled(model, key)
            except MjtrackError:  # a variant that cannot even stand (cg at the edge of the support)
                diverged[p] = True  # diverges in every window: scored so, its poses stay NaN
                done += M
                if progress is not None:
                    progress(done, total)
                continue
            state0 = vsim.initial_states(model, rest, poses0, twists, speeds0)
            scale = 1.0 if params.get("track_speed_scale") is None else float(params["track_speed_scale"])
            delay = float(params.get("drive_delay") or 0.0)
            if delay < 0 or not scale > 0:
                raise InputError(f"windows: drive_delay must be >= 0 and track_speed_scale > 0, got {delay!r}, {scale!r}")
            # the shear ground's friction, set per chunk (the robot's own, or the variant's K; 0: Coulomb)
            ground = chunk_ground(model, vsim.robot, vsim.config, params.get("shear_modulus"),
                                  params.get("lateral_shear_ratio"))
            delays = side_delays(vsim.robot, params, delay)
            if warmup_s > 0:
                state0 = warm_states(vsim, model, log, ws, rest, state0, twists, warmup_s, delays=delays, scale=scale,
                                     datas=datas, ground=ground)
            cmds = drive_setpoints(vsim.robot, log, ws, sim.dt, nstep, delays=delays, scale=scale, start=speeds0)
            control = cmds @ sim.B.T
            for lo in range(0, M, CHUNK):
                hi = min(M, lo + CHUNK)
                _, sens = aligned_rollout([model] * (hi - lo), datas if nthread > 1 else datas[0],
                                          state0[lo:hi], control[lo:hi], ground=ground)
                bad = ~np.all(np.isfinite(sens), axis=(1, 2))
                lin = sens[:, :, sim.smap.linvel]
                bad |= np.nanmax(np.abs(np.nan_to_num(lin, nan=np.inf)), axis=(1, 2)) > DIVERGED_SPEED
                diverged[p, lo:hi] = bad
                for j in range(lo, hi):
                    ii = idx[j][idx[j] >= -1]
                    n = ii.size
                    s = sens[j - lo]
                    pos = s[:, sim.smap.pos]
                    yaw = yaw_of(s[:, sim.smap.quat])
                    ts = s[:, list(sim.smap.track_speed)]
                    body = np.concatenate([[poses0[j]], np.column_stack([pos[:, :2], yaw])])
                    body[:, 2] = np.unwrap(body[:, 2])
                    poses[p, j, :n] = body[ii + 1]
                    speeds[p, j, :n] = np.concatenate([[speeds0[j]], ts])[ii + 1]
                done += hi - lo
                if progress is not None:
                    progress(done, total)
    if warned:  # one line per call; a caller that makes many calls summarises them (summarised_mujoco_warnings)
        logger.debug("windows: %d of %d rollouts diverged (MuJoCo warned %d times, e.g. %r); scored as diverged",
                    int(diverged.sum()), P * M, len(warned), warned[0])
    errors = window_errors(log, ws, poses)
    errors[diverged] = DIVERGED_ERROR
    return WindowResult(poses=poses, errors=errors, speeds=speeds, diverged=diverged)


__all__ = ["MIN_LAG", "WindowResult", "WindowSim", "drive_setpoints", "simulate_windows", "warm_states",
           "window_commands"]

