"""The track drives of the MuJoCo robot: the robot's drivetrain keys turned into simulation terms.

A track drive, for either track model, is

    command c --(x track_speed_scale)--(dead time drive_delay)--(first-order lag drive_lag)--> u
    m_t dV/dt = F - F_g,   F = clip(kv (u - V), +-F_max)

with u the servo set-point, V the track speed, F_g the ground's traction on the track,
m_t the drivetrain inertia reflected to the track surface (``SimConfig.track_mass``), kv the
servo gain and F_max the traction force limit per track (``Robot.drive_force_limit``, default
``SimConfig.torque_limit / R_s``).

The lag is MuJoCo's exact first-order filter on the actuators (roller chain) or the same
exact discretisation in :class:`mjtrack.sim.surfacevel.TrackDrive`; the delay and the scale
are applied to the per-step command sequence (:func:`drive_commands`), so they are exact to
the time step for both models, and the logged commands stay the commanded ones.

Derivation and measurements: docs/theory/simulator.md, "The track drives".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjtrack.io.robot import Robot
from mjtrack.sim.config import SimConfig


@dataclass(frozen=True)
class Drive:
    """Simulation terms of one track drive (SI units): see the module docstring."""

    lag: float  # [s] first-order time constant command -> set-point
    force_limit: float  # [N] traction force limit per track
    kv: float  # [N/(m/s)] servo gain per track
    track_mass: float  # [kg] reflected drivetrain inertia per track


def drive_of(robot: Robot, config: SimConfig) -> Drive:
    """The drive of ``robot`` under ``config`` (mass scaling applied, robot keys win).

    ``SimConfig.lag`` is a simulator-side lag kept for older settings; the robot's ``drive_lag``
    replaces it when non-zero.
    """
    scaled = config.for_robot_mass(robot.mass)
    force_limit = robot.drive_force_limit
    if force_limit is None:
        force_limit = scaled.torque_limit / robot.sprocket_radius
    return Drive(lag=robot.drive_lag or config.lag, force_limit=float(force_limit), kv=scaled.kv,
                 track_mass=scaled.track_mass)


def delay_steps(robot: Robot, timestep: float) -> int:
    """``drive_delay`` in whole time steps (round to nearest)."""
    return int(round(robot.drive_delay / timestep))


def drive_commands(robot: Robot, commands: np.ndarray, timestep: float) -> np.ndarray:
    """The per-step commands (nstep, 2) [m/s] as the drives see them: scaled by
    ``track_speed_scale`` and shifted by ``drive_delay`` (zero command before t = 0: the robot
    starts at rest)."""
    out = np.asarray(commands, dtype=float) * robot.track_speed_scale
    k = delay_steps(robot, timestep)
    if k > 0:
        out = np.concatenate([np.zeros((min(k, len(out)),) + out.shape[1:]), out[:max(len(out) - k, 0)]])
    return out
