"""Reactive point-to-point control with a field of view, thesis section 3.2.1.1 (eqs. 3.5-3.6).

psi = wrap(atan2(y_g - y, x_g - x) - yaw) is the bearing of the goal in the robot frame.
Inside the field of view |psi| <= gamma (3.5):   v = A cos(psi),  w = b sin(psi);
outside (3.6):                                    v = c,           w = d sign(psi).
A is the constant ``a``, or the output of a regulator on the goal distance rho:
* static goal, P regulator: A = K_R rho, limited to v_max, so the robot slows down and stops
  at the goal (thesis: without it the robot overshoots the goal and turns back, fig. 3.5);
* moving goal, PI regulator on e = rho - rho_set: A = K_P e + K_I int e dt, limited to
  [0, v_max] with conditional integration (no wind-up while saturated), so the robot keeps the
  set distance rho_set behind the goal.
For an Ackermann car the thesis uses the same law with the front-wheel angle theta in place of
w (``steering_wheelbase=l``): theta = b sin(psi) or d sign(psi); it is returned as the yaw rate
w = v tan(theta)/l so that :class:`~mjtrack.control.interface.AckermannAdapter` turns it back
into theta.  A differential drive may use c = 0 (turn on the spot until the goal is in view);
a car needs c > 0.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import KW_ONLY, dataclass

import numpy as np

from mjtrack.errors import InputError
from mjtrack.models.wheeled.base import wrap


@dataclass
class ReactiveController:
    """Field-of-view reactive controller (3.5)-(3.6); see the module docstring.

    Attributes:
        goal: (x, y) [m] or a function t -> (x, y) for a moving goal.
        fov: gamma, half-angle of the field of view [rad].
        a: forward speed gain inside the view [m/s] (used when no regulator is set).
        b: turn gain inside the view [rad/s] (or [rad] with ``steering_wheelbase``).
        c: forward speed outside the view [m/s].
        d: turn rate outside the view [rad/s] (or [rad]).
        distance_gain: K_R (static goal) or K_P (with ``set_distance``) [1/s]; None: constant a.
        integral_gain: K_I [1/s^2] of the PI regulator (moving goal).
        set_distance: rho_set [m] kept from the goal.
        v_max: limit of the regulator output A [m/s].
        stop_radius: at a static goal closer than this [m] the command is (0, 0).
        steering_wheelbase: l [m] of an Ackermann car, see the module docstring.
    """

    goal: tuple[float, float] | Callable[[float], tuple[float, float]]
    _: KW_ONLY
    fov: float = math.pi / 4
    a: float = 1.0
    b: float = 5.0
    c: float = 0.0
    d: float = 0.8
    distance_gain: float | None = None
    integral_gain: float = 0.0
    set_distance: float = 0.0
    v_max: float = math.inf
    stop_radius: float = 0.01
    steering_wheelbase: float | None = None

    def __post_init__(self) -> None:
        if not 0 < self.fov <= math.pi:
            raise InputError(f"ReactiveController: fov must lie in (0, pi], got {self.fov}")
        if self.v_max <= 0 or self.set_distance < 0 or self.integral_gain < 0:
            raise InputError("ReactiveController: need v_max > 0, set_distance >= 0, integral_gain >= 0")
        self.reset()

    def reset(self) -> None:
        self._integral = 0.0
        self._t_prev: float | None = None

    def goal_at(self, t: float) -> np.ndarray:
        return np.asarray(self.goal(t) if callable(self.goal) else self.goal, dtype=float)

    def _speed_gain(self, t: float, rho: float) -> float:
        if self.distance_gain is None:
            return self.a
        e = rho - self.set_distance
        dt = 0.0 if self._t_prev is None else t - self._t_prev
        self._t_prev = t
        raw = self.distance_gain * e + self.integral_gain * self._integral
        out = min(max(raw, 0.0), self.v_max)
        if out == raw or (raw > self.v_max and e < 0) or (raw < 0 and e > 0):
            self._integral += e * dt  # integrate unless it would deepen the saturation
        return min(max(self.distance_gain * e + self.integral_gain * self._integral, 0.0), self.v_max)

    def command(self, t: float, pose, twist=None) -> tuple[float, float]:
        g = self.goal_at(t)
        dx, dy = g[0] - pose[0], g[1] - pose[1]
        rho = math.hypot(dx, dy)
        if not callable(self.goal) and rho < self.stop_radius:
            return 0.0, 0.0
        psi = wrap(math.atan2(dy, dx) - pose[2])
        gain = self._speed_gain(t, rho)
        if abs(psi) <= self.fov:
            v, turn = gain * math.cos(psi), self.b * math.sin(psi)
        else:
            v, turn = self.c, math.copysign(self.d, psi)
        if self.steering_wheelbase is None:
            return v, turn
        return v, v * math.tan(turn) / self.steering_wheelbase if abs(turn) < 0.5 * math.pi else 0.0
