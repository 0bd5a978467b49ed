"""Common interface of the wheeled-robot models and their fixed-step RK4 integrator.

Every model of :mod:`mjtrack.models.wheeled` is a frozen, validating dataclass with

* ``is_kinematic``: True for the kinematic models, whose twist is set by the input, so that
  their ``twist(state, u)`` takes the input; the dynamic models' ``twist(state)`` reads the state;
* ``n_state`` / ``n_input`` and ``input_names`` (what the input vector means and its units),
* ``derivative(state, u) -> state_dot``: the right-hand side of the model's ODE,
  ``state``: (n_state,), ``u``: (n_input,), both SI units;
* ``initial_state(pose) -> state``: the robot at rest at ``pose`` = (x, y, yaw);
* ``pose(state) -> (3,)``: (x, y, yaw) of the model's reference point in the world frame;
* ``twist(state) -> (3,)``: body twist (vx, vy, wz) of that point in the robot frame.

Integration: :func:`rk4_step` is the classical fixed-step Runge-Kutta method with the input
held constant over the step (zero-order hold, what a digital controller does).  A fixed step
is chosen over ``scipy.integrate.solve_ivp`` because the models contain saturations (motor
force/torque limits, the friction characteristic) whose kinks make adaptive solvers take
many rejected steps, and because closed-loop control is sampled at a fixed rate anyway.
The friction models (dynamic model 2, skid-steer) are stiff: their fastest mode is the wheel
slip mode with rate ``r**2 * C / J_w`` [1/s]; RK4 is stable for ``dt * rate < 2.78``.
Each stiff model documents ``max_stable_dt``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Protocol

import numpy as np

from mjtrack.errors import InputError


class WheeledModel(Protocol):
    """What every model of this package provides (see the module docstring)."""

    is_kinematic: bool
    n_state: int
    n_input: int
    input_names: tuple[str, ...]

    def derivative(self, state: np.ndarray, u: np.ndarray) -> np.ndarray: ...

    def initial_state(self, pose) -> np.ndarray: ...

    def pose(self, state: np.ndarray) -> np.ndarray: ...

    def twist(self, state: np.ndarray) -> np.ndarray: ...


class PlanarKinematic:
    """Shared part of the kinematic models: the state is the pose (x, y, yaw) and the input
    sets the body twist. A subclass defines ``body_twist(u) -> (vx, vy, wz)`` [m/s, m/s, rad/s]."""

    is_kinematic = True  # twist() needs the input u
    n_state = 3

    def body_twist(self, u) -> tuple[float, float, float]:  # pragma: no cover - abstract
        raise NotImplementedError

    def derivative(self, state: np.ndarray, u: np.ndarray) -> np.ndarray:
        vx, vy, wz = self.body_twist(u)
        c, s = math.cos(state[2]), math.sin(state[2])
        return np.array([c * vx - s * vy, s * vx + c * vy, wz])

    def initial_state(self, pose) -> np.ndarray:
        return np.array(pose, dtype=float).reshape(3)

    def pose(self, state: np.ndarray) -> np.ndarray:
        return np.array(state[:3], dtype=float)

    def twist(self, state: np.ndarray, u: np.ndarray | None = None) -> np.ndarray:
        """Body twist set by the input ``u`` (zero if None)."""
        if u is None:
            return np.zeros(3)
        return np.array(self.body_twist(u), dtype=float)


def rk4(f: Callable[[np.ndarray], np.ndarray], state: np.ndarray, dt: float) -> np.ndarray:
    """One classical RK4 step of the autonomous ODE state' = f(state) over ``dt`` [s]."""
    k1 = f(state)
    k2 = f(state + 0.5 * dt * k1)
    k3 = f(state + 0.5 * dt * k2)
    k4 = f(state + dt * k3)
    return state + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def rk4_step(model: WheeledModel, state: np.ndarray, u, dt: float) -> np.ndarray:
    """One classical RK4 step of ``model`` from ``state`` with input ``u`` held for ``dt`` [s]."""
    u = np.asarray(u, dtype=float)
    return rk4(lambda x: model.derivative(x, u), state, dt)


def simulate(
    model: WheeledModel,
    state0,
    u_of_t: Callable[[float, np.ndarray], np.ndarray],
    *,
    duration: float,
    dt: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Open-loop simulation with a fixed RK4 step.

    Args:
        model: any :class:`WheeledModel`.
        state0: (n_state,) initial state.
        u_of_t: ``u_of_t(t, state) -> (n_input,)`` input held over each step.
        duration: simulated time [s].
        dt: step [s].

    Returns:
        ``(t, states)``: t (N,) [s] and states (N, n_state), N = round(duration/dt) + 1.
    """
    if not (dt > 0 and duration > 0 and math.isfinite(dt) and math.isfinite(duration)):
        raise InputError(f"simulate: need positive finite dt and duration, got dt={dt}, duration={duration}")
    n = int(round(duration / dt))
    t = np.arange(n + 1) * dt
    states = np.empty((n + 1, model.n_state))
    states[0] = np.asarray(state0, dtype=float)
    for k in range(n):
        states[k + 1] = rk4_step(model, states[k], u_of_t(t[k], states[k]), dt)
    return t, states


def wrap(a: float) -> float:
    """Scalar angle wrapped to [-pi, pi) [rad] (float version of geometry.wrap_angle)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def check_positive(owner: str, **values: float) -> None:
    """Raise InputError unless every value is a finite number > 0."""
    for name, value in values.items():
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise InputError(f"{owner}: '{name}' must be a positive number, got {value!r}")


def saturate(x: float, limit: float) -> float:
    """Clip x to [-limit, limit]."""
    return min(max(x, -limit), limit)


def wheel_friction(v_long: float, v_lat: float, *, stiffness: float, limit: float) -> tuple[float, float]:
    """Friction force on a wheel from its contact-patch slip, eqs. (1.13)-(1.15) / (1.18)-(1.20).

    The slip velocity of the wheel surface relative to the ground has a longitudinal part
    ``v_long = r*omega_wheel - v_F`` (positive: the wheel spins faster than it travels, so the
    ground pushes the wheel forward) and a lateral part ``-v_S`` (the contact point slides
    sideways with v_S, friction opposes it).  The magnitude follows fig. 1.8:
    ``P = C*|v|`` for ``|v| < eps = mu*W/C`` and ``P = mu*W`` above, and is split along the
    slip direction.  In the linear range this is exactly ``(F, S) = C*(v_long, -v_S)``.

    Args:
        v_long: r*omega - v_F [m/s].
        v_lat: lateral velocity v_S of the contact point [m/s].
        stiffness: C [N s/m].
        limit: mu*W [N].

    Returns:
        (F, S): longitudinal (forward) and lateral (left) force on the robot [N].
    """
    speed = math.hypot(v_long, v_lat)
    if stiffness * speed <= limit:
        return stiffness * v_long, -stiffness * v_lat
    scale = limit / speed
    return scale * v_long, -scale * v_lat
