"""The five controllers of the wheeled-robot thesis set up to follow a tracking scenario's path.

The thesis tests each controller on its own task (a static or moving goal, a goal pose, a line
on the floor, a circle to track). To compare them on one task, each is given a reference
:class:`~mjtrack.control.feedforward.Reference` (a path driven at a speed profile) in the way it
can use it; all of them then ask for a body command (v, w) that an adapter turns into the inputs
of the plant (track or wheel speeds), so that the same controller drives a kinematic model and
the MuJoCo robot, tracked or wheeled.

| name | controller | what it is given |
|---|---|---|
| ``feedforward`` | :class:`~mjtrack.control.feedforward.FeedForward` (3.1)-(3.4) | the reference's (v_d, w_d); open loop |
| ``pole_placement`` | :class:`~mjtrack.control.tracking.TrajectoryTracker` (3.11)-(3.21) | the reference pose and (v_d, w_d) at t; poles (-1, -2, -4) 1/s |
| ``reactive`` | :class:`~mjtrack.control.reactive.ReactiveController` (3.5)-(3.6) | a moving goal: the path point :data:`REACTIVE_LEAD` ahead of the reference's s(t), kept at that distance by the thesis's PI regulator |
| ``posture`` | :class:`~mjtrack.control.posture.PolarPostureController` (3.7)-(3.10) | a moving goal pose: the path pose v_d/k_rho ahead of s(t) |
| ``line_following`` | :class:`~mjtrack.control.line_following.LineFollower` (3.2.2.1) | the path as a line on the floor, followed at the reference speed |

Why these set-ups. The reactive and posture laws steer to a point; a goal that runs ahead on the
path turns them into path followers (the thesis itself drives the reactive law after a goal
moving on a circle). The reactive goal leads by its set distance, so that the PI regulator holds
the robot where the reference is; the posture law's speed v = k_rho rho equals the reference
speed at rho = v_d/k_rho, so the goal pose leads by that much. Both cut curves by about
lead^2/(2R) (a chord of a circle of radius R). The line follower has no clock: it drives at the
reference speed and falls behind the reference by what its wiggles cost.

Derivation and measurements: docs/theory/wheeled.md, "Path controllers: constants and progress".
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mjtrack.control.feedforward import FeedForward, Reference
from mjtrack.control.line_following import LineFollower
from mjtrack.control.posture import PolarPostureController
from mjtrack.control.reactive import ReactiveController
from mjtrack.control.tracking import TrajectoryTracker
from mjtrack.errors import InputError

THESIS_CONTROLLERS = ("feedforward", "pole_placement", "reactive", "posture", "line_following")
"""The five controllers of the thesis's chapter 3, in its order."""

DESCRIPTIONS = {
    "feedforward": "the feed-forward (eqs. 3.1-3.4 of [Jonszta]): the reference's speed and yaw rate, open loop",
    "pole_placement": "the trajectory tracker (eqs. 3.11-3.21 of [Jonszta]): feed-forward plus state feedback on the "
                      "error to the reference pose, gains by pole placement",
    "reactive": "the reactive law (eqs. 3.5-3.6 of [Jonszta]) chasing a goal that runs ahead on the path, with the PI "
                "distance regulator of a moving goal",
    "posture": "the polar posture law (eqs. 3.7-3.10 of [Jonszta]) chasing a goal pose that runs ahead on the path",
    "line_following": "the two-sensor line follower (section 3.2.2.1 of [Jonszta]) on the path as a line, at the reference "
                      "speed",
}

POLES = (-1.0, -2.0, -4.0)  # [1/s] the thesis's eigenvalues of A - B K
REACTIVE_LEAD = 0.2  # [m] the goal's lead on the path and the PI regulator's set distance
REACTIVE_PI = (2.0, 1.0)  # (K_P [1/s], K_I [1/s^2]) of the distance regulator
REACTIVE_GAINS = {"fov": math.pi / 4, "b": 5.0, "c": 0.0, "d": 0.8}  # thesis 3.2.1.1.1 (fov: gamma chosen)
SPEED_LIMIT = 1.0  # [m/s] v_max of the reactive regulator and of the posture law
# the line follower: sensors 0.3 m ahead, 5 cm apart, a 5 cm tape (one sensor over it: half the
# turn rate), W = 3 rad/s (twice the figure-eight's peak yaw rate at 0.5 m/s, 1.6 rad/s, as the
# slipping robots turn at a fraction of the commanded rate); with the sensors 0.15-0.2 m ahead
# the wheeled robot's bang-bang oscillation grows until it loses the line
# (benchmarks/controllers.py records it)
LINE_SENSORS = {"sensor_ahead": 0.3, "sensor_spacing": 0.05, "line_width": 0.05, "turn_rate": 3.0,
                "search_window": 1.0}
LINE_SPACING = 0.01  # [m] vertices of the line
# k_rho of the posture law. The thesis prints "?,6" with the digit lost (0.6, 1.6 or 2.6: the
# extraction dropped 0, 1 and 2); 1.6 is taken. Siegwart's k_rho = 3 (the static-goal default of
# mjtrack.control.posture) puts the goal only v/k_rho = 0.17 m ahead at 0.5 m/s, where 1 cm of
# position noise turns the bearing by degrees: the wheeled MuJoCo robot then loses the path
# (benchmarks/controllers.py records it); at 1.6 the goal leads by 0.31 m
POSTURE_K_RHO = 1.6


@dataclass(frozen=True, eq=False)
class PathController:
    """A controller set up for a reference, with what describes the set-up.

    Attributes:
        name: one of :data:`THESIS_CONTROLLERS`.
        controller: the :class:`~mjtrack.control.interface.Controller`.
        clocked: True when the robot should be at the reference's s(t) (module docstring).
        settings: the set-up's constants (JSON-ready).
    """

    name: str
    controller: object
    clocked: bool
    settings: dict = field(default_factory=dict)


def cruise_speed(reference: Reference, *, samples: int = 201) -> float:
    """The reference's highest speed [m/s] (sampled over its duration)."""
    return max(reference.profile.speed(t) for t in np.linspace(0.0, reference.duration, samples))


def path_controller(name: str, reference: Reference, *, poles=POLES, options: dict | None = None) -> PathController:
    """Set up the thesis controller ``name`` to follow ``reference`` (module docstring).

    ``feedforward`` and ``pole_placement`` use only ``reference.at(t)`` (any object with it, e.g.
    a heading-corrected reference of a slip compensation); the others its path and profile.
    ``options`` replaces set-up constants, for studies of their effect: entries of
    :data:`LINE_SENSORS` (line follower) or ``k_rho`` (posture, default :data:`POSTURE_K_RHO`).

    Raises:
        InputError: unknown name, or an option the controller does not have.
    """
    options = dict(options or {})
    allowed = {"line_following": set(LINE_SENSORS), "posture": {"k_rho"}}.get(name, set())
    if not set(options) <= allowed:
        raise InputError(f"controller {name!r} has no option {sorted(set(options) - allowed)} "
                         f"(options: {sorted(allowed) or 'none'})")
    if name == "feedforward":
        return PathController(name, FeedForward(reference), True, {})
    if name == "pole_placement":
        return PathController(name, TrajectoryTracker(reference, poles=poles), True,
                              {"poles": [float(p) for p in poles]})
    path = reference.path  # the reference's clock and path (the first two need only its at(t))
    if name == "reactive":
        def goal(t: float) -> tuple[float, float]:
            x, y, _ = path.pose_at(reference.profile.distance(t) + REACTIVE_LEAD)
            return x, y

        kp, ki = REACTIVE_PI
        ctrl = ReactiveController(goal, distance_gain=kp, integral_gain=ki, set_distance=REACTIVE_LEAD,
                                  v_max=SPEED_LIMIT, **REACTIVE_GAINS)
        return PathController(name, ctrl, True, {"lead_m": REACTIVE_LEAD, "k_p": kp, "k_i": ki,
                                                 "v_max": SPEED_LIMIT, **REACTIVE_GAINS})
    if name == "posture":
        def goal_pose(t: float) -> tuple[float, float, float]:
            return tuple(float(v) for v in path.pose_at(reference.profile.distance(t) + lead))

        ctrl = PolarPostureController(goal_pose, k_rho=options.get("k_rho", POSTURE_K_RHO), v_max=SPEED_LIMIT)
        lead = cruise_speed(reference) / ctrl.k_rho  # read by goal_pose at call time
        return PathController(name, ctrl, True, {"lead_m": lead, "k_rho": ctrl.k_rho, "k_alpha": ctrl.k_alpha,
                                                 "k_beta": ctrl.k_beta, "v_max": SPEED_LIMIT})
    if name == "line_following":
        speed = cruise_speed(reference)
        sensors = {**LINE_SENSORS, **options}
        ctrl = LineFollower(path.polyline(spacing=LINE_SPACING), speed=speed, **sensors)
        return PathController(name, ctrl, False, {"speed_m_s": speed, **sensors})
    raise InputError(f"unknown controller {name!r}; choose one of {', '.join(THESIS_CONTROLLERS)}")
