"""The controller interface, input adapters and the closed-loop simulation.

A controller maps (time t [s], measured pose (x, y, yaw) [m, m, rad], optionally the measured
body twist (vx, vy, wz)) to a body command (v [m/s], w [rad/s]) (:class:`Controller`).
An adapter turns (v, w) into a particular model's inputs:

* :class:`WheelSpeedAdapter` (differential drive, skid steer): (1.3)-(1.4),
  omega_L = (v - w b/2)/r, omega_R = (v + w b/2)/r [rad/s];
* :class:`TrackSpeedAdapter` (tracked robots): V_L = v - w T/2, V_R = v + w T/2 [m/s];
* :class:`AckermannAdapter`: the steering angle that gives yaw rate w at speed v,
  tan(theta) = l w / v (both drives: (1.22) and (1.23) share phidot = v_B tan(theta)/l), and
  the drive speed, v_B for rear drive, v_B/cos(theta) for front drive.

:func:`run_closed_loop` samples the controller every ``dt`` and holds its command while the
plant integrates ``substeps`` RK4 steps of ``dt/substeps`` (zero-order hold).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from mjtrack.errors import InputError
from mjtrack.models.wheeled.base import WheeledModel, rk4_step


class Controller(Protocol):
    """Maps a measurement to a body command (v [m/s], w [rad/s])."""

    def command(self, t: float, pose: np.ndarray, twist: np.ndarray | None = None) -> tuple[float, float]: ...

    def reset(self) -> None: ...


class Adapter(Protocol):
    """Turns a body command (v, w) into a model input vector."""

    def __call__(self, v: float, w: float) -> np.ndarray: ...


@dataclass(frozen=True)
class WheelSpeedAdapter:
    """(v, w) -> wheel angular speeds (omega_L, omega_R) [rad/s]; track b [m], wheel radius r [m]."""

    track: float
    wheel_radius: float

    def __call__(self, v: float, w: float) -> np.ndarray:
        half = 0.5 * self.track * w
        return np.array([(v - half) / self.wheel_radius, (v + half) / self.wheel_radius])


@dataclass(frozen=True)
class TrackSpeedAdapter:
    """(v, w) -> track speeds (V_L, V_R) = (v - w T/2, v + w T/2) [m/s]; gauge T [m]."""

    track_gauge: float

    def __call__(self, v: float, w: float) -> np.ndarray:
        half = 0.5 * self.track_gauge * w
        return np.array([v - half, v + half])


@dataclass(frozen=True)
class AckermannAdapter:
    """(v, w) -> (drive speed [m/s], steering angle [rad]) for the bicycle model.

    theta = atan(l w / v), clipped to +-max_steer; at |v| < ``min_speed`` the car cannot turn
    on the spot and the steering goes to +-max_steer in the sense of w (v keeps its value).
    """

    wheelbase: float
    max_steer: float
    drive: str = "rear"
    min_speed: float = 1e-6

    def __call__(self, v: float, w: float) -> np.ndarray:
        if abs(v) < self.min_speed:
            theta = math.copysign(self.max_steer, w) if w != 0 else 0.0
        else:
            theta = math.atan(self.wheelbase * w / v)
        theta = min(max(theta, -self.max_steer), self.max_steer)
        speed = v if self.drive == "rear" else v / math.cos(theta)
        return np.array([speed, theta])


def adapter_for(model) -> Adapter:
    """The natural adapter of a model: track speeds (has ``track_gauge``), speed + steering
    (Ackermann: ``drive``, ``wheelbase``, ``max_steer``) or wheel speeds (``track``, ``wheel_radius``)."""
    if hasattr(model, "track_gauge"):
        return TrackSpeedAdapter(model.track_gauge)
    if hasattr(model, "drive") and hasattr(model, "wheelbase") and hasattr(model, "max_steer"):
        return AckermannAdapter(model.wheelbase, model.max_steer, model.drive)
    if hasattr(model, "track") and hasattr(model, "wheel_radius"):
        return WheelSpeedAdapter(model.track, model.wheel_radius)
    raise InputError(f"adapter_for: no adapter known for {type(model).__name__}")


@dataclass(frozen=True)
class Plant:
    """A model with the adapter that feeds it body commands."""

    model: WheeledModel
    adapter: Adapter

    @classmethod
    def of(cls, model) -> Plant:
        return cls(model, adapter_for(model))


@dataclass(frozen=True)
class ClosedLoopResult:
    """Time series of a closed-loop run, N samples at the controller rate.

    Attributes:
        t: (N,) [s]; states: (N, n_state); poses: (N, 3) [m, m, rad];
        commands: (N, 2) body command (v, w) computed at t[k] and held until t[k+1];
        inputs: (N, n_input) the adapted model inputs.
    """

    t: np.ndarray
    states: np.ndarray
    poses: np.ndarray
    commands: np.ndarray
    inputs: np.ndarray
    info: dict = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        n = self.t.shape[0]
        if any(a.shape[0] != n for a in (self.states, self.poses, self.commands, self.inputs)):
            raise InputError("ClosedLoopResult: all series need the same number of samples")
        if n > 1 and not np.all(np.diff(self.t) > 0):
            raise InputError("ClosedLoopResult: time must increase")


def _measured_twist(model, state, u_prev) -> np.ndarray:
    return model.twist(state, u_prev) if model.is_kinematic else model.twist(state)


def run_closed_loop(
    plant: Plant,
    controller: Controller,
    duration: float,
    dt: float,
    *,
    pose0=None,
    state0=None,
    substeps: int = 1,
    measure: Callable[[float, np.ndarray], np.ndarray] | None = None,
) -> ClosedLoopResult:
    """Simulate ``controller`` driving ``plant`` for ``duration`` [s] at controller period ``dt`` [s].

    Args:
        plant: model + adapter.
        controller: any :class:`Controller`; ``reset()`` is called first.
        duration, dt: run length and controller sampling period [s].
        pose0: start pose (x, y, yaw) of a robot at rest; or give the full ``state0``.
        substeps: RK4 steps per controller period (for stiff models: dt/substeps <= max_stable_dt).
        measure: optional ``measure(t, pose) -> pose`` (e.g. adds seeded noise); default exact.

    Returns:
        :class:`ClosedLoopResult`.
    """
    if (pose0 is None) == (state0 is None):
        raise InputError("run_closed_loop: give exactly one of pose0 and state0")
    if not (dt > 0 and duration > 0 and substeps >= 1):
        raise InputError(f"run_closed_loop: need dt > 0, duration > 0, substeps >= 1 (dt={dt}, duration={duration})")
    model = plant.model
    state = np.asarray(model.initial_state(pose0) if state0 is None else state0, dtype=float)
    n = int(round(duration / dt))
    t = np.arange(n + 1) * dt
    states = np.empty((n + 1, model.n_state))
    commands = np.empty((n + 1, 2))
    inputs = np.empty((n + 1, model.n_input))
    controller.reset()
    h = dt / substeps
    u = np.zeros(model.n_input)
    for k in range(n + 1):
        states[k] = state
        pose = model.pose(state)
        if measure is not None:
            pose = measure(t[k], pose)
        v, w = controller.command(float(t[k]), pose, _measured_twist(model, state, u))
        commands[k] = (v, w)
        u = plant.adapter(v, w)
        inputs[k] = u
        if k < n:
            for _ in range(substeps):
                state = rk4_step(model, state, u, h)
    poses = np.array([model.pose(s) for s in states])
    return ClosedLoopResult(t, states, poses, commands, inputs)
