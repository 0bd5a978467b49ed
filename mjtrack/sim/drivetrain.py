"""The track drives of the MuJoCo robot: the robot's drivetrain keys turned into simulation terms.

A track drive, for either track model, is

    command c --(x track_speed_scale)--(dead time drive_delay)--(first-order lag drive_lag)--> u
    m_t dV/dt = F - F_g,   F = clip(kv (u - V), +-F_max)

with u the servo set-point, V the track speed, F_g the ground's traction on the track,
m_t the drivetrain inertia reflected to the track surface (``SimConfig.track_mass``), kv the
servo gain and F_max the traction force limit per track (``Robot.drive_force_limit``, default
``SimConfig.torque_limit / R_s``).

Defaults that scale with the robot (``SimConfig.for_robot_mass``): m_t, kv and F_max are given
for a 20 kg robot (200 kg, 3e4 N s/m, 1000 N at R_s = 0.06 m) and scaled by
s = max(1, m / 20 kg). Hence, for every robot from 20 kg up,

* the servo time constant of a track alone, m_t / kv = 6.7 ms, and with the half robot it
  pushes, (m_t + m/2) / kv <= 7 ms, is the same: a step command is reached in the same time;
* the servo droop at full traction, mu m g / 2 / kv <= 2.6 mm/s (mu 0.8), is the same relative
  to the commands: heavy robots no longer lose commanded speed difference in gentle turns
  (with one drive for all, a 150 kg robot's droop was 7.5x larger);
* the force-limited spin-up acceleration F_max / (m_t + m/2) = 4.76 m/s^2 is the same;
* the explicit-Euler margin kv dt / m_t = 0.75 (< 1.5) does not depend on the mass.

Robots lighter than 20 kg keep the 20 kg drive (scaled down, a 5 kg robot's gentle turns
missed Coulomb by more: ``SimConfig.drive_reference_mass``). With ``drive_lag`` 0 the set-point
is the command and the track speed follows it within the servo time constant, or at the
force-limited acceleration when F_max is reached.

The lag is MuJoCo's exact first-order filter on the actuators (roller chain) or the same
exact discretisation in :class:`mjtrack.sim.surfacevel.TrackDrive`; the delay and the scale
are applied to the per-step command sequence (:func:`drive_commands`), so they are exact to
the time step for both models, and the logged commands stay the commanded ones.
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
