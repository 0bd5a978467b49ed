"""Dynamic model no. 2 of a differential-drive robot, eqs. (1.9)-(1.15) of the wheeled-robot thesis.

A planar rigid body (mass M, yaw inertia J about its centre of gravity, which lies on the
wheel axle midway between the wheels) on two wheels with their own spin dynamics and a
friction contact that can slip and skid.

Body, world frame (1.9):
    M xddot = sum_i F_i cos(phi) - sum_i S_i sin(phi)
    M yddot = sum_i F_i sin(phi) + sum_i S_i cos(phi)
    J phiddot = (F_R - F_L) b/2
  F_i: longitudinal (forward) friction force on wheel i, S_i: lateral (left) force.
Wheels (1.10)-(1.11):  J_w omegadot_i = T_i - r F_i,  T_i = K_T (omega_i,req - omega_i)
  saturated at |T_i| <= T_max.
Contact velocities (1.12), robot frame, left wheel at y = +b/2:
    v_F,L = xdot cos(phi) + ydot sin(phi) - phidot b/2
    v_F,R = xdot cos(phi) + ydot sin(phi) + phidot b/2
    v_S   = -xdot sin(phi) + ydot cos(phi)          (same for both wheels: they lie on the axle)
Friction (1.13)-(1.15): slip velocity (r omega_i - v_F,i, -v_S) of the wheel surface on the
ground, magnitude P = C |slip| up to mu W (fig. 1.8), split along the slip direction; see
:func:`mjtrack.models.wheeled.base.wheel_friction`.  The thesis prints the split as
F = P v_P/v, S = P v_S/v without signs; the signs here make friction oppose sliding.

State (8,): x, y [m], phi [rad], xdot, ydot [m/s], phidot [rad/s], omega_L, omega_R [rad/s].
Input (2,): requested wheel speeds (omega_L,req, omega_R,req) [rad/s].
Stiff: the wheel-slip mode decays at about C (r^2/J_w + 2/M + b^2/(4J)) [1/s]; use
``dt <= max_stable_dt`` with RK4.

Derivation and measurements: docs/theory/wheeled.md, "Dynamic model 2: verification".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mjtrack.models.wheeled.base import check_positive, saturate, wheel_friction
from mjtrack.models.wheeled.diffdrive import THESIS_TRACK, THESIS_WHEEL_RADIUS
from mjtrack.models.wheeled.dynamic1 import THESIS_INERTIA, THESIS_MASS

# Thesis constants (section 1.1).  Printed legibly: mu = 0.6, W = 2.45 N (= M g/2),
# T_max = 0.0375 N m (= r F_max).  Dropped digits: J_w printed ",75e-5" -> 1.75e-5 chosen;
# C printed "3" -> 300 N s/m chosen (a 3 then zeros; 300 keeps the pre-skid lateral creep of
# the circle test below 5 mm while the model stays cheap to integrate).
THESIS_WHEEL_INERTIA = 1.75e-5  # J_w [kg m^2]
THESIS_TORQUE_MAX = 0.0375  # T_max [N m]
THESIS_STIFFNESS = 300.0  # C [N s/m]
THESIS_MU = 0.6
THESIS_WHEEL_LOAD = 2.45  # W [N] per wheel


@dataclass(frozen=True, kw_only=True)
class DiffDriveDynamic2:
    """Dynamic model 2 (1.9)-(1.15); attributes in SI units (see the module docstring).

    Attributes:
        track: b [m]; wheel_radius: r [m]; mass: M [kg]; inertia: J [kg m^2];
        wheel_inertia: J_w [kg m^2]; torque_max: T_max [N m];
        torque_gain: K_T of the wheel-speed P regulator [N m s/rad] (not legible; 0.01 chosen,
            wheel-loop time constant J_w/K_T = 1.75 ms);
        stiffness: C [N s/m]; mu: friction coefficient [-]; wheel_load: W per wheel [N].
    """

    track: float = THESIS_TRACK
    wheel_radius: float = THESIS_WHEEL_RADIUS
    mass: float = THESIS_MASS
    inertia: float = THESIS_INERTIA
    wheel_inertia: float = THESIS_WHEEL_INERTIA
    torque_max: float = THESIS_TORQUE_MAX
    torque_gain: float = 0.01
    stiffness: float = THESIS_STIFFNESS
    mu: float = THESIS_MU
    wheel_load: float = THESIS_WHEEL_LOAD

    is_kinematic = False  # twist() reads the state
    n_state = 8
    n_input = 2
    input_names = ("omega_left_req [rad/s]", "omega_right_req [rad/s]")

    def __post_init__(self) -> None:
        check_positive("DiffDriveDynamic2", **{k: getattr(self, k) for k in self.__dataclass_fields__})

    @property
    def max_stable_dt(self) -> float:
        """Largest RK4 step [s] for which the fastest (wheel-slip) mode stays stable, with margin."""
        rate = self.stiffness * (
            self.wheel_radius**2 / self.wheel_inertia + 2.0 / self.mass + self.track**2 / (4.0 * self.inertia)
        )
        return 2.5 / rate

    def contact_forces(self, state: np.ndarray) -> tuple[float, float, float, float]:
        """(1.12)-(1.15): friction forces (F_L, S_L, F_R, S_R) on the robot, robot frame [N]."""
        phi, xd, yd, phid, w_left, w_right = state[2], state[3], state[4], state[5], state[6], state[7]
        c, s = math.cos(phi), math.sin(phi)
        v_fwd = xd * c + yd * s
        v_lat = -xd * s + yd * c
        half = 0.5 * self.track * phid
        limit = self.mu * self.wheel_load
        f_l, s_l = wheel_friction(self.wheel_radius * w_left - (v_fwd - half), v_lat,
                                  stiffness=self.stiffness, limit=limit)
        f_r, s_r = wheel_friction(self.wheel_radius * w_right - (v_fwd + half), v_lat,
                                  stiffness=self.stiffness, limit=limit)
        return f_l, s_l, f_r, s_r

    def derivative(self, state: np.ndarray, u: np.ndarray) -> np.ndarray:
        phi = state[2]
        c, s = math.cos(phi), math.sin(phi)
        f_l, s_l, f_r, s_r = self.contact_forces(state)
        f_sum, s_sum = f_l + f_r, s_l + s_r
        t_l = saturate(self.torque_gain * (u[0] - state[6]), self.torque_max)
        t_r = saturate(self.torque_gain * (u[1] - state[7]), self.torque_max)
        return np.array([
            state[3],
            state[4],
            state[5],
            (f_sum * c - s_sum * s) / self.mass,
            (f_sum * s + s_sum * c) / self.mass,
            (f_r - f_l) * 0.5 * self.track / self.inertia,
            (t_l - self.wheel_radius * f_l) / self.wheel_inertia,
            (t_r - self.wheel_radius * f_r) / self.wheel_inertia,
        ])

    def initial_state(self, pose) -> np.ndarray:
        return np.concatenate([np.asarray(pose, dtype=float).reshape(3), np.zeros(5)])

    def pose(self, state: np.ndarray) -> np.ndarray:
        return np.array(state[:3], dtype=float)

    def twist(self, state: np.ndarray) -> np.ndarray:
        c, s = math.cos(state[2]), math.sin(state[2])
        return np.array([state[3] * c + state[4] * s, -state[3] * s + state[4] * c, state[5]])
