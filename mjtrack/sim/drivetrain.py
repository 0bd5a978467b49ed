"""The track drives of the MuJoCo robot: the robot's drivetrain keys turned into simulation terms.

A track drive, for either track model, is

    command c --(x track_speed_scale)--(dead time drive_delay)--(clamp +-drive_speed_limit)
              --(ramp drive_accel_limit)--(first-order lag drive_lag)--> u
    m_t dV/dt = F - F_g,   F = clip(kv (u - V), +-F_max)

with u the servo set-point, V the track speed, F_g the ground's traction on the track,
m_t the drivetrain inertia reflected to the track surface (``SimConfig.track_mass``), kv the
servo gain and F_max the traction force limit per track (``Robot.drive_force_limit``, default
``SimConfig.torque_limit / R_s``).

(per side: ``drive_delay_left/right``, ``drive_speed_limit_left/right``, ``drive_lag_left/right``).
The chain up to the lag is :mod:`mjtrack.models.drivetrain`'s, applied to the per-step command
sequence (:func:`drive_commands`), so it is exact to the time step for both models and the
logged commands stay the commanded ones; the lag is MuJoCo's exact first-order filter on each
side's actuators (roller chain) or the same exact discretisation in
:class:`mjtrack.sim.surfacevel.TrackDrive`.

Derivation and measurements: docs/theory/simulator.md, "The track drives".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjtrack.io.robot import Robot
from mjtrack.models.drivetrain import Chain, clamp, ramp, setpoints, twist, twist_ramp
from mjtrack.sim.config import SimConfig


@dataclass(frozen=True)
class Drive:
    """Simulation terms of one track drive (SI units): see the module docstring."""

    lags: tuple[float, float]  # [s] first-order time constant command -> set-point, (left, right)
    force_limit: float  # [N] traction force limit per track
    kv: float  # [N/(m/s)] servo gain per track
    track_mass: float  # [kg] reflected drivetrain inertia per track


def drive_of(robot: Robot, config: SimConfig) -> Drive:
    """The drive of ``robot`` under ``config`` (mass scaling applied, robot keys win).

    ``SimConfig.lag`` is a simulator-side lag kept for older settings; a side's lag
    (``drive_lag_left/right``, else ``drive_lag``) replaces it when non-zero.
    """
    scaled = config.for_robot_mass(robot.mass)
    force_limit = robot.drive_force_limit
    if force_limit is None:
        force_limit = scaled.torque_limit / robot.sprocket_radius
    return Drive(lags=tuple(lag or config.lag for lag in robot.lag_per_side), force_limit=float(force_limit), kv=scaled.kv,
                 track_mass=scaled.track_mass)


def drive_commands(robot: Robot, commands: np.ndarray, timestep: float) -> np.ndarray:
    """The per-step set-points (nstep, 2) [m/s] the drives' lags receive from per-step commands:
    :func:`mjtrack.models.drivetrain.setpoints` of the robot's chain (scale, dead time, speed
    limit, acceleration limit; zero command before t = 0: the robot starts at rest)."""
    return setpoints(Chain.of_robot(robot), commands, timestep)


def controller_stages(robot: Robot, commands: np.ndarray, timestep: float, start: np.ndarray) -> np.ndarray:
    """Per-step commands (M, nstep, 2) of M windows, already scaled and delayed, through the
    robot's own controller: twist stage and its ramps, speed clamp and ramp
    (:mod:`mjtrack.models.drivetrain`; the ramps start at ``start`` (M, 2), the measured speeds).
    Unchanged without those keys."""
    chain = Chain.of_robot(robot)
    out = twist(commands, chain.turn_scale, chain.mean_limit, chain.turn_limit)
    if chain.mean_accel_limit is not None or chain.turn_accel_limit is not None:
        out = twist_ramp(np.swapaxes(out, 0, 1), chain.mean_accel_limit, chain.turn_accel_limit, timestep,
                         start).swapaxes(0, 1)
    out = clamp(out, chain.speed_limit)
    if chain.accel_limit is not None:
        out = ramp(np.swapaxes(out, 0, 1), chain.accel_limit, timestep, start).swapaxes(0, 1)
    return out
