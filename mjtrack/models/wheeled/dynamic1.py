"""Dynamic model no. 1 of a differential-drive robot, eqs. (1.5)-(1.8) of the wheeled-robot thesis.

Inertia without friction: the wheels neither slip nor skid, so the body still moves as in
(1.1), but the forward speed v and the yaw rate omega are states driven by the motor forces:

    M vdot     = F_L + F_R                                  (1.5), (1.7)
    J omegadot = (F_R - F_L) b/2                            (1.6), (1.7)
    F_i = K (omega_i,req - omega_i), saturated at |F_i| <= F_max      (1.8)

where omega_i = (v -/+ omega b/2)/r is the wheel speed that the no-slip body motion imposes
(left: minus, right: plus).  Verification (thesis 1.1.2.2): from rest with equal requests
the forces stay saturated at F_max, so v = 2 F_max t / M reaches v_req at t = M v_req/(2 F_max);
opposite constant forces F_R = -F_L give omegadot = (F_R - F_L)(b/2)/J.

State (5,): x [m], y [m], phi [rad], v [m/s], omega [rad/s].
Input (2,): requested wheel speeds (omega_L,req, omega_R,req) [rad/s].
The fastest mode has time constant M r/(2K) (forward) [s]; RK4 is stable for dt < 2.78 of it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mjtrack.models.wheeled.base import check_positive, saturate
from mjtrack.models.wheeled.diffdrive import THESIS_TRACK, THESIS_WHEEL_RADIUS

THESIS_MASS = 0.5  # M [kg]
THESIS_INERTIA = 5e-4  # J [kg m^2]
THESIS_FORCE_MAX = 1.5  # F_max [N] per wheel


@dataclass(frozen=True, kw_only=True)
class DiffDriveDynamic1:
    """Dynamic model 1 (1.5)-(1.8).

    Attributes:
        track: b [m].
        wheel_radius: r [m].
        mass: M [kg].
        inertia: J, yaw moment of inertia about the reference point [kg m^2].
        force_max: F_max, saturation of each wheel's traction force [N].
        gain: K of the wheel-speed P regulator [N s/rad] (not printed legibly; 1.0 chosen so
            that the loop is fast, time constant M r/(2K) = 6 ms, yet not stiff).
    """

    track: float = THESIS_TRACK
    wheel_radius: float = THESIS_WHEEL_RADIUS
    mass: float = THESIS_MASS
    inertia: float = THESIS_INERTIA
    force_max: float = THESIS_FORCE_MAX
    gain: float = 1.0

    is_kinematic = False  # twist() reads the state
    n_state = 5
    n_input = 2
    input_names = ("omega_left_req [rad/s]", "omega_right_req [rad/s]")

    def __post_init__(self) -> None:
        check_positive(
            "DiffDriveDynamic1", track=self.track, wheel_radius=self.wheel_radius, mass=self.mass,
            inertia=self.inertia, force_max=self.force_max, gain=self.gain,
        )

    @property
    def max_stable_dt(self) -> float:
        """Largest RK4 step [s] for which the regulator's modes stay stable, with margin: forward
        rate 2K/(M r), yaw rate K b^2/(2 r J) [1/s] (linear range of (1.8))."""
        rate = max(2.0 * self.gain / (self.mass * self.wheel_radius),
                   self.gain * self.track**2 / (2.0 * self.wheel_radius * self.inertia))
        return 2.5 / rate

    def forces(self, state: np.ndarray, u: np.ndarray) -> tuple[float, float]:
        """(1.8): wheel traction forces (F_L, F_R) [N]."""
        v, omega = state[3], state[4]
        half = 0.5 * self.track * omega
        w_left = (v - half) / self.wheel_radius
        w_right = (v + half) / self.wheel_radius
        f_left = saturate(self.gain * (u[0] - w_left), self.force_max)
        f_right = saturate(self.gain * (u[1] - w_right), self.force_max)
        return f_left, f_right

    def derivative_from_forces(self, state: np.ndarray, f_left: float, f_right: float) -> np.ndarray:
        """(1.1)+(1.7) with given wheel forces [N]."""
        phi, v, omega = state[2], state[3], state[4]
        return np.array([
            v * math.cos(phi),
            v * math.sin(phi),
            omega,
            (f_left + f_right) / self.mass,
            (f_right - f_left) * 0.5 * self.track / self.inertia,
        ])

    def derivative(self, state: np.ndarray, u: np.ndarray) -> np.ndarray:
        return self.derivative_from_forces(state, *self.forces(state, u))

    def initial_state(self, pose) -> np.ndarray:
        return np.concatenate([np.asarray(pose, dtype=float).reshape(3), np.zeros(2)])

    def pose(self, state: np.ndarray) -> np.ndarray:
        return np.array(state[:3], dtype=float)

    def twist(self, state: np.ndarray) -> np.ndarray:
        return np.array([state[3], 0.0, state[4]])
