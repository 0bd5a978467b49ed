"""Four-wheel skid-steer dynamic model, eqs. (1.16)-(1.20) of the wheeled-robot thesis.

Four wheels of radius r on two rigid axles, wheelbase a, track b; the centre of gravity (COG,
the reference point) lies on the centre line at p*a behind the front axle.  Wheel positions
relative to the COG (robot frame, x forward, y left):

    FL (+p a, +b/2),  RL (-(1-p) a, +b/2),  RR (-(1-p) a, -b/2),  FR (+p a, -b/2).

As in the thesis (fig. 1.16) the wheel speeds are imposed: omega_i = the requested speed of
its side (the motors are stiff), so the model has no wheel spin states.  Contact velocities
(1.17) of wheel i at (x_i, y_i):
    v_F,i = v_x - y_i phidot           (left wheels: - b/2 phidot, right: + b/2 phidot)
    v_S,i = v_y + x_i phidot           (front: + p a phidot, rear: - (1-p) a phidot)
with (v_x, v_y) the COG velocity in the robot frame.  Friction (1.18)-(1.20) as in dynamic
model 2 (:func:`~mjtrack.models.wheeled.base.wheel_friction`): slip (r omega_i - v_F,i, -v_S,i),
magnitude C|slip| up to mu W.  Body (1.16), world frame:
    M xddot = sum F_i cos(phi) - sum S_i sin(phi),   M yddot = sum F_i sin(phi) + sum S_i cos(phi)
    J phiddot = sum_i (x_i S_i - y_i F_i)
              = (F_RR + F_FR - F_FL - F_RL) b/2 + (S_FL + S_FR) p a - (S_RL + S_RR)(1-p) a.
Wheel loads: ``load_distribution="equal"`` gives every wheel W (as the thesis: W = M g/4);
``"static"`` distributes the weight by the COG position, front wheels 2(1-p) W, rear wheels
2p W (mean W), and scales each wheel's stiffness C and limit mu W_i with its load (slip
stiffness proportional to normal load).

State (6,): x, y [m] (COG), phi [rad], xdot, ydot [m/s], phidot [rad/s].
Input (2,): wheel speeds of the left and right side (omega_L, omega_R) [rad/s].

Derivation and measurements: docs/theory/wheeled.md, "Four-wheel skid steer: properties".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mjtrack.errors import InputError
from mjtrack.models.wheeled.base import check_positive, wheel_friction
from mjtrack.models.wheeled.dynamic2 import THESIS_MU

# Thesis constants (section 1.2).  Legible: M = 59 kg, W = 144.7 N (= M g/4), mu = 0.6,
# C = 5e3 N s/m, b = 0.4 m, p = 0.54.  Dropped digits: a printed ",5" -> 0.5 m; r printed ",5"
# -> 0.15 m; J printed with no digit left -> 2.0 kg m^2 (= M (a^2 + b^2)/12 of a uniform box).
WHEELS = ("FL", "RL", "RR", "FR")


@dataclass(frozen=True, kw_only=True)
class SkidSteer4:
    """Four-wheel skid-steer dynamics (1.16)-(1.20); see the module docstring.

    Attributes:
        wheelbase: a [m] (0 allowed: both axles coincide); track: b [m];
        cg_ratio: p, COG distance behind the front axle divided by a [-], 0 <= p <= 1;
        wheel_radius: r [m]; mass: M [kg]; inertia: J about the COG [kg m^2];
        stiffness: C [N s/m]; mu [-]; wheel_load: W, mean load per wheel [N];
        load_distribution: "equal" (thesis) or "static" (by the COG position, see above).
    """

    wheelbase: float = 0.5
    track: float = 0.4
    cg_ratio: float = 0.54
    wheel_radius: float = 0.15
    mass: float = 59.0
    inertia: float = 2.0
    stiffness: float = 5e3
    mu: float = THESIS_MU
    wheel_load: float = 144.7
    load_distribution: str = "equal"

    is_kinematic = False  # twist() reads the state
    n_state = 6
    n_input = 2
    input_names = ("omega_left [rad/s]", "omega_right [rad/s]")

    def __post_init__(self) -> None:
        check_positive(
            "SkidSteer4", track=self.track, wheel_radius=self.wheel_radius, mass=self.mass,
            inertia=self.inertia, stiffness=self.stiffness, mu=self.mu, wheel_load=self.wheel_load,
        )
        if not (math.isfinite(self.wheelbase) and self.wheelbase >= 0):
            raise InputError(f"SkidSteer4: 'wheelbase' must be >= 0, got {self.wheelbase!r}")
        if not (0.0 <= self.cg_ratio <= 1.0):
            raise InputError(f"SkidSteer4: 'cg_ratio' must lie in [0, 1], got {self.cg_ratio!r}")
        if self.load_distribution not in ("equal", "static"):
            raise InputError(f"SkidSteer4: 'load_distribution' must be 'equal' or 'static', got {self.load_distribution!r}")

    @property
    def load_factors(self) -> np.ndarray:
        """(4,) wheel load / W for FL, RL, RR, FR [-] (mean 1)."""
        if self.load_distribution == "equal":
            return np.ones(4)
        front, rear = 2.0 * (1.0 - self.cg_ratio), 2.0 * self.cg_ratio
        return np.array([front, rear, rear, front])

    @property
    def wheel_positions(self) -> np.ndarray:
        """(4, 2) positions (x_i, y_i) of FL, RL, RR, FR relative to the COG [m]."""
        front, rear, half = self.cg_ratio * self.wheelbase, -(1.0 - self.cg_ratio) * self.wheelbase, 0.5 * self.track
        return np.array([[front, half], [rear, half], [rear, -half], [front, -half]])

    @property
    def max_stable_dt(self) -> float:
        """Largest RK4 step [s] keeping the fastest friction mode stable, with margin."""
        arm2 = float(np.max(np.sum(self.wheel_positions**2, axis=1)))
        k = float(np.max(self.load_factors))
        return 2.5 / (k * self.stiffness * (4.0 / self.mass + 4.0 * arm2 / self.inertia))

    def contact_forces(self, state: np.ndarray, u: np.ndarray) -> np.ndarray:
        """(1.17)-(1.20): (4, 2) friction forces (F_i, S_i) on FL, RL, RR, FR, robot frame [N]."""
        phi, xd, yd, phid = state[2], state[3], state[4], state[5]
        c, s = math.cos(phi), math.sin(phi)
        vx, vy = xd * c + yd * s, -xd * s + yd * c
        out = np.empty((4, 2))
        for i, ((xi, yi), k) in enumerate(zip(self.wheel_positions, self.load_factors)):
            omega = u[0] if yi > 0 else u[1]
            out[i] = wheel_friction(self.wheel_radius * omega - (vx - yi * phid), vy + xi * phid,
                                    stiffness=k * self.stiffness, limit=k * self.mu * self.wheel_load)
        return out

    def derivative(self, state: np.ndarray, u: np.ndarray) -> np.ndarray:
        forces = self.contact_forces(state, u)
        pos = self.wheel_positions
        f_sum, s_sum = forces[:, 0].sum(), forces[:, 1].sum()
        moment = float(np.sum(pos[:, 0] * forces[:, 1] - pos[:, 1] * forces[:, 0]))
        c, s = math.cos(state[2]), math.sin(state[2])
        return np.array([
            state[3], state[4], state[5],
            (f_sum * c - s_sum * s) / self.mass,
            (f_sum * s + s_sum * c) / self.mass,
            moment / self.inertia,
        ])

    def initial_state(self, pose) -> np.ndarray:
        return np.concatenate([np.asarray(pose, dtype=float).reshape(3), np.zeros(3)])

    def pose(self, state: np.ndarray) -> np.ndarray:
        return np.array(state[:3], dtype=float)

    def twist(self, state: np.ndarray) -> np.ndarray:
        c, s = math.cos(state[2]), math.sin(state[2])
        return np.array([state[3] * c + state[4] * s, -state[3] * s + state[4] * c, state[5]])

    def geometric_centre_pose(self, state: np.ndarray) -> np.ndarray:
        """Pose of the geometric centre, (p - 1/2) a ahead of the COG [m, m, rad]."""
        d = (self.cg_ratio - 0.5) * self.wheelbase
        return np.array([state[0] + d * math.cos(state[2]), state[1] + d * math.sin(state[2]), state[2]])
