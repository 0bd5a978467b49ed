"""Posture (pose) control in polar coordinates, thesis section 3.2.1.2 (eqs. 3.7-3.10), after Siegwart.

Goal pose (x_g, y_g, gamma).  With dx = x_g - x, dy = y_g - y:
    rho = sqrt(dx^2 + dy^2),  alpha = wrap(-theta + atan2(dy, dx)),  beta = wrap(gamma - theta - alpha)  (3.7)
(alpha: goal bearing in the robot frame; beta: minus the angle of the line robot->goal seen
from the goal's frame).  The kinematics (1.1) in these coordinates (3.8), for |alpha| < pi/2:
    rhodot = -v cos(alpha),  alphadot = v sin(alpha)/rho - w,  betadot = -v sin(alpha)/rho
and the law (3.9) v = k_rho rho, w = k_alpha alpha + k_beta beta gives the closed loop (3.10),
whose linearisation about 0 is stable for k_rho > 0, k_beta < 0, k_alpha > k_rho (checked at
construction; Siegwart's strong condition k_alpha + 5/3 k_beta - 2/pi k_rho > 0 is logged).

Goal behind the robot (alpha not in (-pi/2, pi/2] at the start): drive backwards.  A robot
reversing with heading theta is a forward robot with heading theta' = theta + pi, speed
v' = -v, w' = w, whose goal heading is gamma' = gamma + pi; its coordinates are
alpha' = wrap(alpha + pi), beta' = wrap(gamma' - theta' - alpha') = wrap(beta + pi), so the
command is v = -k_rho rho, w = k_alpha alpha' + k_beta beta'.  The direction is chosen once,
at the first command after :meth:`reset` (switching it while moving would chatter).

Moving goal: ``goal`` may be a function t -> (x, y, gamma), a pose that moves along a path
(the thesis applies the law to a static goal only).  The law is unchanged; the robot then trails
the goal by the distance at which v = k_rho rho equals the goal's speed, and it does not stop.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import KW_ONLY, dataclass

from mjtrack.errors import InputError
from mjtrack.models.wheeled.base import wrap

log = logging.getLogger(__name__)


def polar_error(pose, goal) -> tuple[float, float, float]:
    """(3.7): (rho [m], alpha [rad], beta [rad]) of ``pose`` relative to ``goal`` = (x, y, gamma)."""
    dx, dy = goal[0] - pose[0], goal[1] - pose[1]
    rho = math.hypot(dx, dy)
    alpha = wrap(math.atan2(dy, dx) - pose[2])
    beta = wrap(goal[2] - pose[2] - alpha)
    return rho, alpha, beta


@dataclass
class PolarPostureController:
    """Polar-coordinate posture controller (3.9); see the module docstring.

    Attributes:
        goal: (x, y, gamma) [m, m, rad], or a function t -> (x, y, gamma) for a moving goal.
        k_rho [1/s], k_alpha [1/s], k_beta [1/s]: gains.  Default: Siegwart's (3, 8, -1.5).
            The thesis prints k_alpha = 8 and k_beta = -?.5 (Siegwart's) but k_rho = "?.6" with
            digits lost; k_rho = 0.6 would leave a slow closed-loop pole (the (alpha, beta)
            block has lambda^2 + (k_alpha - k_rho) lambda - k_rho k_beta, i.e. -0.12 1/s), so the
            default keeps Siegwart's k_rho = 3 (poles -1.4, -3.6 and -k_rho).
        allow_reverse: drive backwards to a goal behind the robot.
        v_max: optional speed limit [m/s] (scales v and w together, keeping the path).
        position_tol [m], heading_tol [rad]: inside both the command is (0, 0).
    """

    goal: tuple[float, float, float] | Callable[[float], tuple[float, float, float]]
    _: KW_ONLY
    k_rho: float = 3.0
    k_alpha: float = 8.0
    k_beta: float = -1.5
    allow_reverse: bool = True
    v_max: float = math.inf
    position_tol: float = 1e-3
    heading_tol: float = 1e-3

    def __post_init__(self) -> None:
        if not (self.k_rho > 0 and self.k_beta < 0 and self.k_alpha > self.k_rho):
            raise InputError(
                f"PolarPostureController: need k_rho > 0, k_beta < 0, k_alpha > k_rho "
                f"(got {self.k_rho}, {self.k_alpha}, {self.k_beta})"
            )
        if self.k_alpha + 5.0 / 3.0 * self.k_beta - 2.0 / math.pi * self.k_rho <= 0:
            log.warning("posture gains do not meet Siegwart's strong stability condition")
        self.reset()

    def reset(self) -> None:
        self._reverse: bool | None = None

    def goal_at(self, t: float) -> tuple[float, float, float]:
        """The goal pose at time t [s]."""
        return tuple(self.goal(t)) if callable(self.goal) else self.goal

    def command(self, t: float, pose, twist=None) -> tuple[float, float]:
        goal = self.goal_at(t)
        rho, alpha, beta = polar_error(pose, goal)
        if (not callable(self.goal) and rho < self.position_tol
                and abs(wrap(goal[2] - pose[2])) < self.heading_tol):
            return 0.0, 0.0
        if self._reverse is None:
            self._reverse = self.allow_reverse and not (-0.5 * math.pi < alpha <= 0.5 * math.pi)
        sign = 1.0
        if self._reverse:
            alpha, beta, sign = wrap(alpha + math.pi), wrap(beta + math.pi), -1.0
        v = sign * self.k_rho * rho
        w = self.k_alpha * alpha + self.k_beta * beta
        if abs(v) > self.v_max:
            scale = self.v_max / abs(v)
            v, w = v * scale, w * scale
        return v, w
