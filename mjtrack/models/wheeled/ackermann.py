"""Ackermann-steered car kinematics, eqs. (1.21)-(1.23) of the wheeled-robot thesis.

Bicycle simplification: the two front wheels are replaced by one steered wheel at angle theta,
the rear wheels by one wheel; reference point B = the rear-axle centre; wheelbase l, track b.

Rear drive (1.22), input rear-wheel speed v:
    xdot = v cos(phi),  ydot = v sin(phi),  phidot = v tan(theta)/l
Front drive (1.23), input front-wheel speed v_p (along the steered wheel):
    xdot = v_p cos(theta) cos(phi),  ydot = v_p cos(theta) sin(phi),  phidot = v_p sin(theta)/l
Both follow from B moving along the body x axis (no lateral slip of the rear wheel) and the
front wheel, l ahead, moving along its own heading: v_front = v_B / cos(theta), phidot =
v_front sin(theta)/l.  Circles (verification 1.3.1.1 / 1.3.2.1): B turns on radius
R = l/tan(theta); the front wheel on l/sin(theta).  Inner/outer real steering angles for a
turn of radius R about the rear-axle line (1.21): theta_in = atan(l/(R - b/2)),
theta_out = atan(l/(R + b/2)).

State (3,): x, y [m] of B, phi [rad].  Input (2,): (speed [m/s], steering angle theta [rad]).
"""

from __future__ import annotations

import math
from dataclasses import dataclass


from mjtrack.errors import InputError
from mjtrack.models.wheeled.base import PlanarKinematic, check_positive

THESIS_WHEELBASE = 0.3  # l [m]
THESIS_TRACK = 0.15  # b [m] (printed ",5")


def steering_angles(radius: float, *, wheelbase: float, track: float) -> tuple[float, float]:
    """(1.21): (inner, outer) front-wheel steering angles [rad] for a turn radius R > b/2 [m]."""
    if not radius > 0.5 * track:
        raise InputError(f"steering_angles: radius must exceed half the track {0.5 * track}, got {radius}")
    return math.atan(wheelbase / (radius - 0.5 * track)), math.atan(wheelbase / (radius + 0.5 * track))


@dataclass(frozen=True, kw_only=True)
class Ackermann(PlanarKinematic):
    """Kinematic Ackermann car (1.22) (``drive="rear"``) or (1.23) (``drive="front"``).

    Attributes:
        wheelbase: l [m]; track: b [m]; drive: "rear" or "front";
        max_steer: |theta| limit [rad], applied to the input (< pi/2).
    """

    wheelbase: float = THESIS_WHEELBASE
    track: float = THESIS_TRACK
    drive: str = "rear"
    max_steer: float = math.radians(40.0)

    n_input = 2
    input_names = ("speed [m/s]", "steer [rad]")

    def __post_init__(self) -> None:
        check_positive("Ackermann", wheelbase=self.wheelbase, track=self.track, max_steer=self.max_steer)
        if self.drive not in ("rear", "front"):
            raise InputError(f"Ackermann: 'drive' must be 'rear' or 'front', got {self.drive!r}")
        if self.max_steer >= 0.5 * math.pi:
            raise InputError(f"Ackermann: 'max_steer' must be below pi/2, got {self.max_steer}")

    def body_rates(self, u) -> tuple[float, float]:
        """(v_B [m/s], phidot [rad/s]) for input u = (speed, steer)."""
        speed = float(u[0])
        theta = min(max(float(u[1]), -self.max_steer), self.max_steer)
        if self.drive == "rear":
            return speed, speed * math.tan(theta) / self.wheelbase
        return speed * math.cos(theta), speed * math.sin(theta) / self.wheelbase

    def turn_radius(self, steer: float) -> float:
        """Radius [m] of the circle of B for steering angle theta: l/tan(theta)."""
        return self.wheelbase / math.tan(steer)

    def body_twist(self, u) -> tuple[float, float, float]:
        """Body twist (v_B, 0, phidot) of B for input u = (speed, steer)."""
        v, omega = self.body_rates(u)
        return v, 0.0, omega
