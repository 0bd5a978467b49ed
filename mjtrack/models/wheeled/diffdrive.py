"""Kinematic model of a differential-drive robot, eqs. (1.1)-(1.4) of the wheeled-robot thesis.

Two driven wheels of radius r on a common axle, track (wheel distance) b; the reference
point is the axle centre (the thesis's COG, assumed on the axle).  No slip:

    v = (v_R + v_L)/2,  omega = (v_R - v_L)/b            (1.2)
    v_i = r * omega_i                                        (1.4)
    xdot = v cos(phi),  ydot = v sin(phi),  phidot = omega   (1.1)

and the inverse (1.3): v_R = v + omega b/2, v_L = v - omega b/2.
Verification (thesis 1.1.1.1): constant v, omega drive a circle of radius v/omega in 2 pi/omega.

State (3,): x [m], y [m], phi [rad].  Input (2,): wheel angular speeds (omega_L, omega_R) [rad/s].
"""

from __future__ import annotations

from dataclasses import dataclass


from mjtrack.models.wheeled.base import PlanarKinematic, check_positive

# Thesis constants of the small (robot-soccer) differential-drive chassis, section 1.1.
# The text extraction dropped the digits 0, 1, 2; the values below are the readings that make
# the thesis's own worked numbers consistent (see tests/test_wheeled.py).
THESIS_TRACK = 0.065  # b [m]
THESIS_WHEEL_RADIUS = 0.025  # r [m]


def wheel_speeds(v: float, omega: float, *, track: float, wheel_radius: float) -> tuple[float, float]:
    """(1.3)+(1.4): wheel angular speeds (omega_L, omega_R) [rad/s] for body (v [m/s], omega [rad/s])."""
    half = 0.5 * track * omega
    return (v - half) / wheel_radius, (v + half) / wheel_radius


def body_speeds(omega_left: float, omega_right: float, *, track: float, wheel_radius: float) -> tuple[float, float]:
    """(1.2)+(1.4): body (v [m/s], omega [rad/s]) from wheel angular speeds [rad/s]."""
    v_left, v_right = wheel_radius * omega_left, wheel_radius * omega_right
    return 0.5 * (v_right + v_left), (v_right - v_left) / track


@dataclass(frozen=True, kw_only=True)
class DiffDriveKinematic(PlanarKinematic):
    """No-slip differential drive (1.1)-(1.4).

    Attributes:
        track: b, distance between the wheels [m].
        wheel_radius: r [m].
    """

    track: float = THESIS_TRACK
    wheel_radius: float = THESIS_WHEEL_RADIUS

    n_input = 2
    input_names = ("omega_left [rad/s]", "omega_right [rad/s]")

    def __post_init__(self) -> None:
        check_positive("DiffDriveKinematic", track=self.track, wheel_radius=self.wheel_radius)

    def body_twist(self, u) -> tuple[float, float, float]:
        """(v, 0, omega) from the wheel speeds u = (omega_left, omega_right) [rad/s]."""
        v, omega = body_speeds(u[0], u[1], track=self.track, wheel_radius=self.wheel_radius)
        return v, 0.0, omega
