"""Closed-loop driving of the MuJoCo tracked robot by a controller at a control rate.

:func:`run_mujoco_loop` builds the robot (:func:`mjtrack.sim.builder.build_model`), lets it
settle at rest (:func:`mjtrack.sim.rollout.settled_state`) and then, every ``control_dt``:

1. reads the sensors: pose of the ``centre`` site (x, y, heading) and the body twist
   (velocimeter / gyro, chassis frame) and the track speeds (encoders: sprocket speed × radius),
   the same columns as a drive log (:func:`mjtrack.sim.rollout.log_columns`); optionally adds
   seeded Gaussian noise;
2. calls ``policy(t, pose, twist, u_prev, track_speed)`` for the track speeds (V_L, V_R) [m/s] (a controller
   with an adapter or a slip compensation, :mod:`mjtrack.control.compensation`);
3. holds them (zero-order hold, through :func:`mjtrack.sim.builder.control_matrix`) for
   ``round(control_dt / timestep)`` ``mujoco.mj_step`` calls.

Frames: the robot settles at the MuJoCo origin; poses are reported in a world frame in which
the settled pose is ``pose0``: p = compose(pose0, relative_pose(p_settled, p_mujoco))
(:mod:`mjtrack.geometry`), so a run can start on any reference start pose without moving the
model. The body twist is frame-independent.

Timing: the sample at t_k = k·control_dt is read *before* the command u_k is applied; u_k acts
over [t_k, t_{k+1}). ``u_prev`` passed to the policy at t_k is u_{k−1}, the command that produced
the measured motion (what an online estimator needs).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import mujoco
import numpy as np

from mjtrack.errors import InputError, MjtrackError
from mjtrack.geometry import compose, relative_pose
from mjtrack.io.robot import Robot
from mjtrack.sim.builder import build_model, control_matrix
from mjtrack.sim.config import SimConfig
from mjtrack.sim.ground import chunk_ground
from mjtrack.sim.rollout import MAX_STEPS, STATE_SPEC, SensorMap, settled_state, yaw_of
from mjtrack.sim.terrain import Terrain, timestep_for

log = logging.getLogger(__name__)

Policy = Callable[[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray], "tuple[float, float] | np.ndarray"]


@dataclass(frozen=True, eq=False)
class MujocoLoopResult:
    """N samples of a closed-loop MuJoCo run at the control rate.

    Attributes:
        t: (N,) [s]; poses: (N, 3) true pose [m, m, rad] (yaw unwrapped) in the run's frame;
        twists: (N, 3) true body twist [m/s, m/s, rad/s]; measured_poses / measured_twists:
        (N, 3) what the policy saw (with noise, if any); track_cmd: (N, 2) commanded (V_L, V_R)
        [m/s] from t_k (the last row is never applied); track_speed: (N, 2) measured track speeds.
    """

    t: np.ndarray
    poses: np.ndarray
    twists: np.ndarray
    measured_poses: np.ndarray
    measured_twists: np.ndarray
    track_cmd: np.ndarray
    track_speed: np.ndarray
    info: dict = field(default_factory=dict)


class MujocoTrackedPlant:
    """The MuJoCo tracked robot as a steppable plant (see module docstring).

    Args:
        robot: robot description; config: simulation settings (default :class:`SimConfig`).
        pose0: (3,) pose [m, m, rad] that the settled robot has in the reported frame.
        terrain: ground under the robot (default flat); on steps and height fields the time step
            is cut to :data:`mjtrack.sim.terrain.EDGE_TIMESTEP` (:func:`~mjtrack.sim.terrain.timestep_for`).
            Poses stay planar (x, y, heading of the ``centre`` site).
    """

    def __init__(self, robot: Robot, *, config: SimConfig | None = None, pose0=(0.0, 0.0, 0.0),
                 terrain: Terrain | None = None) -> None:
        self.robot = robot
        config = config or SimConfig()
        self.config = config.replace(timestep=timestep_for(config.timestep, terrain))
        self.terrain = terrain
        self.model = build_model(robot, self.config, terrain)
        self.data = mujoco.MjData(self.model)
        self.smap = SensorMap.of(self.model)
        self.B = control_matrix(self.model)
        # the shear ground's friction, set every few steps from the state as in a rollout (sim.ground)
        self.ground = chunk_ground(self.model, robot, self.config)
        self.pose0 = np.asarray(pose0, float).reshape(3)
        self.reset()

    def reset(self) -> None:
        """Back to the settled rest state at t = 0."""
        if self.ground is not None:  # the Coulomb friction the model was built with, as at rest
            self.model.pair_friction[self.ground.pairs, :2] = self.ground.mu[:, None]
        mujoco.mj_setState(self.model, self.data, settled_state(self.model), STATE_SPEC)
        mujoco.mj_forward(self.model, self.data)
        self._steps = 0
        self._origin = self._raw_pose()
        self._yaw_prev = float(self.pose0[2])

    def _raw_pose(self) -> np.ndarray:
        s = self.data.sensordata
        p = s[self.smap.pos]
        return np.array([p[0], p[1], float(yaw_of(s[self.smap.quat]))])

    @property
    def time(self) -> float:
        return float(self.data.time)

    def pose(self) -> np.ndarray:
        """(3,) pose in the run's frame, yaw continuous across calls."""
        p = compose(self.pose0, relative_pose(self._origin, self._raw_pose()))
        p[2] = self._yaw_prev + math.remainder(p[2] - self._yaw_prev, 2 * math.pi)
        self._yaw_prev = float(p[2])
        return p

    def twist(self) -> np.ndarray:
        """(3,) body twist (vx, vy, wz) of the centre [m/s, m/s, rad/s]."""
        s = self.data.sensordata
        return np.array([s[self.smap.linvel][0], s[self.smap.linvel][1], s[self.smap.angvel][2]])

    def track_speeds(self) -> np.ndarray:
        s = self.data.sensordata
        return np.array([s[self.smap.track_speed[0]], s[self.smap.track_speed[1]]])

    def advance(self, v_left: float, v_right: float, duration: float) -> None:
        """Hold (V_L, V_R) [m/s] for ``duration`` [s] (a whole number of time steps)."""
        n = int(round(duration / self.model.opt.timestep))
        if n < 1 or abs(n * self.model.opt.timestep - duration) > 1e-9 * max(1.0, duration):
            raise InputError(f"control period {duration} s must be a multiple of the time step {self.model.opt.timestep} s")
        self.data.ctrl[:] = self.B @ np.array([v_left, v_right], float)
        for _ in range(n):
            if self.ground is not None and self._steps % self.ground.every == 0:
                state = np.empty(mujoco.mj_stateSize(self.model, STATE_SPEC))
                mujoco.mj_getState(self.model, self.data, state, STATE_SPEC)
                self.ground.apply([self.model], state[None])
            mujoco.mj_step(self.model, self.data)
            self._steps += 1
        # mj_step evaluates the sensors before it integrates: without a forward pass the
        # controller would read the state one time step old (mjtrack.sim.rollout.aligned_rollout)
        mujoco.mj_forward(self.model, self.data)
        if not np.all(np.isfinite(self.data.qpos)):
            raise MjtrackError("simulation diverged (non-finite state); reduce the time step")


MIN_CONTROL_PERIODS = 10  # a closed loop shorter than this has nothing to show


def check_loop(duration: float, control_dt: float, *, config: SimConfig | None = None, terrain: Terrain | None = None,
               what: str = "the run") -> None:
    """Refuse, before any work, a closed-loop run shorter than :data:`MIN_CONTROL_PERIODS` control
    periods or longer than :data:`~mjtrack.sim.rollout.MAX_STEPS` time steps (``what`` names it)."""
    if not (math.isfinite(duration) and math.isfinite(control_dt) and duration > 0 and control_dt > 0):
        raise InputError(f"{what}: need a duration > 0 and a control period > 0, got {duration}, {control_dt}")
    if duration < MIN_CONTROL_PERIODS * control_dt:
        raise InputError(f"{what} lasts {duration:.3g} s, less than {MIN_CONTROL_PERIODS} control periods of "
                         f"{control_dt:g} s")
    dt = timestep_for((config or SimConfig()).timestep, terrain)
    if duration / dt > MAX_STEPS:
        raise InputError(f"{what} lasts {duration:.6g} s, {duration / dt:.3g} time steps of {dt:g} s; at most "
                         f"{MAX_STEPS:.3g} ({MAX_STEPS * dt:.6g} s)")


def run_mujoco_loop(
    robot: Robot,
    policy: Policy,
    duration: float,
    *,
    control_dt: float = 0.04,
    pose0=(0.0, 0.0, 0.0),
    config: SimConfig | None = None,
    pose_noise: tuple[float, float, float] = (0.0, 0.0, 0.0),
    twist_noise: tuple[float, float, float] = (0.0, 0.0, 0.0),
    track_speed_noise: float = 0.0,
    seed: int = 0,
    terrain: Terrain | None = None,
) -> MujocoLoopResult:
    """Drive the MuJoCo robot with ``policy`` for ``duration`` [s] (module docstring).

    Args:
        policy: ``policy(t, pose, twist, u_prev, track_speed) -> (V_L, V_R)`` [m/s]; ``track_speed``
            is the measured (V_L, V_R) at t.
        control_dt: control period [s], a multiple of the simulation time step.
        pose0: start pose in the reported frame.
        pose_noise, twist_noise, track_speed_noise: std of seeded Gaussian noise on what the
            policy sees (track speeds: both tracks; drawn after pose and twist, so a run without
            it sees the same pose and twist noise as before).
        terrain: ground under the robot (default flat, :class:`MujocoTrackedPlant`).
    Returns:
        :class:`MujocoLoopResult` with N = round(duration / control_dt) + 1 samples.
    """
    check_loop(duration, control_dt, config=config, terrain=terrain, what="run_mujoco_loop: the run")
    plant = MujocoTrackedPlant(robot, config=config, pose0=pose0, terrain=terrain)
    rng = np.random.default_rng(seed)
    n = int(round(duration / control_dt))
    rows = {k: np.zeros((n + 1, 3)) for k in ("poses", "twists", "measured_poses", "measured_twists")}
    cmd, speed = np.zeros((n + 1, 2)), np.zeros((n + 1, 2))
    u_prev = np.zeros(2)
    for k in range(n + 1):
        t = k * control_dt
        pose, twist = plant.pose(), plant.twist()
        mp = pose + rng.normal(size=3) * np.asarray(pose_noise)
        mt = twist + rng.normal(size=3) * np.asarray(twist_noise)
        rows["poses"][k], rows["twists"][k], rows["measured_poses"][k], rows["measured_twists"][k] = pose, twist, mp, mt
        speed[k] = plant.track_speeds()
        ms = speed[k] + (rng.normal(size=2) * track_speed_noise if track_speed_noise else 0.0)
        u = np.asarray(policy(t, mp, mt, u_prev.copy(), ms), float).reshape(2)
        if not np.all(np.isfinite(u)):
            raise MjtrackError(f"run_mujoco_loop: the policy returned non-finite track speeds {u} at t = {t:g} s")
        cmd[k] = u
        if k < n:
            plant.advance(u[0], u[1], control_dt)
        u_prev = u
    return MujocoLoopResult(np.arange(n + 1) * control_dt, rows["poses"], rows["twists"], rows["measured_poses"],
                            rows["measured_twists"], cmd, speed,
                            info={"control_dt": control_dt, "timestep": float(plant.model.opt.timestep),
                                  "pose_noise": list(pose_noise), "twist_noise": list(twist_noise),
                                  "track_speed_noise": track_speed_noise, "seed": seed,
                                  **({"terrain": terrain.to_dict()} if terrain is not None and not terrain.is_flat else {})})
