"""Open-loop feed-forward along a geometric path, thesis section 3.1 (eqs. 3.1-3.4).

A velocity profile gives the travelled arc length s(t) and speed v(t); the path gives the
parameter u(s) (inverse of (3.2)) and the osculating radius rho(u) (3.1); the commands are

    v_d(t) = v(t),   w_d(t) = v(t)/rho(u(s(t))) = v(t) kappa(u(s(t)))

and the reference pose is (x(u), y(u), atan2(y'(u), x'(u))) at u = u(s(t)).  Driving the
kinematic model (1.1) with (v_d, w_d) from the reference start pose reproduces the path
(tested); from another start pose it does not (thesis fig. 3.1), which is what trajectory
tracking (:mod:`mjtrack.control.tracking`) corrects.

Profiles: :class:`TriangularProfile` (the thesis's: accelerate at ``accel`` to mid-path, then
decelerate at the same rate to stop at the end: duration 2 sqrt(L/a), peak speed sqrt(a L)),
:class:`ConstantSpeedProfile` (e.g. the figure-eight at 0.5 m/s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mjtrack.control.paths import ParametricPath
from mjtrack.errors import InputError


@dataclass(frozen=True)
class TriangularProfile:
    """Accelerate at ``accel`` [m/s^2] to the middle of a path of ``length`` [m], then stop at its end."""

    length: float
    accel: float

    def __post_init__(self) -> None:
        if not (self.length > 0 and self.accel > 0):
            raise InputError(f"TriangularProfile: length and accel must be positive, got {self.length}, {self.accel}")

    @property
    def duration(self) -> float:
        return 2.0 * math.sqrt(self.length / self.accel)

    def speed(self, t: float) -> float:
        """v(t) [m/s]; 0 before the start and after the end."""
        half = 0.5 * self.duration
        if t <= 0 or t >= self.duration:
            return 0.0
        return self.accel * (t if t <= half else self.duration - t)

    def distance(self, t: float) -> float:
        """s(t) [m], clipped to [0, length]."""
        half = 0.5 * self.duration
        if t <= 0:
            return 0.0
        if t >= self.duration:
            return self.length
        if t <= half:
            return 0.5 * self.accel * t * t
        rest = self.duration - t
        return self.length - 0.5 * self.accel * rest * rest


@dataclass(frozen=True)
class ConstantSpeedProfile:
    """Constant ``speed`` [m/s] over ``length`` [m]; stops at the end."""

    length: float
    speed_value: float

    def __post_init__(self) -> None:
        if not (self.length > 0 and self.speed_value > 0):
            raise InputError("ConstantSpeedProfile: length and speed must be positive")

    @property
    def duration(self) -> float:
        return self.length / self.speed_value

    def speed(self, t: float) -> float:
        return self.speed_value if 0 <= t < self.duration else 0.0

    def distance(self, t: float) -> float:
        return min(max(t, 0.0) * self.speed_value, self.length)


@dataclass(frozen=True)
class ReferenceState:
    """Reference at one instant: pose (3,) [m, m, rad], v_d [m/s], w_d [rad/s], s [m]."""

    pose: np.ndarray
    v: float
    w: float
    s: float


@dataclass(frozen=True)
class Reference:
    """A path traversed with a velocity profile: the desired trajectory of (3.11)."""

    path: ParametricPath
    profile: TriangularProfile | ConstantSpeedProfile

    def __post_init__(self) -> None:
        if abs(self.profile.length - self.path.length) > 1e-6 * max(1.0, self.path.length):
            raise InputError(
                f"Reference: the profile covers {self.profile.length:.6g} m but the path is {self.path.length:.6g} m long"
            )

    def at(self, t: float) -> ReferenceState:
        s = self.profile.distance(t)
        u = float(self.path.u_at(s))
        v = self.profile.speed(t)
        x, y = self.path.point(u)
        return ReferenceState(np.array([x, y, float(self.path.heading(u))]), v, v * float(self.path.curvature(u)), s)

    @property
    def duration(self) -> float:
        return self.profile.duration

    def start_pose(self) -> np.ndarray:
        return self.at(0.0).pose


class FeedForward:
    """Open-loop controller: ignores the measurement and commands (v_d(t), w_d(t)) of a reference."""

    def __init__(self, reference: Reference) -> None:
        self.reference = reference

    def reset(self) -> None:
        pass

    def command(self, t: float, pose=None, twist=None) -> tuple[float, float]:
        ref = self.reference.at(t)
        return ref.v, ref.w
