"""The drivetrain response: a side's track (wheel) speed command -> its track speed, in numpy.

Per side, in the order a real drive applies them:

    c --(x s)--> twist stage --> clip(., +-v_max) --(rate limit a_max)--(dead time d)--> r --(lag tau)--> V

* ``s`` (``track_speed_scale``): actual / commanded speed, the calibration of the conversion from
  command to motor speed (a wheel radius, an encoder count); it scales what the controller is
  asked for, so the limits below are in track speeds, the units the log's measured speeds are in;
* ``d`` (``drive_delay``, per side ``drive_delay_left/right``): transport and processing delay.
  A pure time shift commutes with every other stage (they are time-invariant), so where it sits
  changes nothing with equal delays; it is applied per side after the controller's stages (a
  shift of the ramp's input would be lost in its clip, and the twist stage sees both sides'
  commands together, as a controller receives them);
* the twist stage (``drive_turn_scale`` k, ``drive_mean_speed_limit`` V, ``drive_turn_limit`` W;
  its ramps ``drive_mean_accel_limit`` A_m, ``drive_turn_accel_limit`` A_d):
  many robots' controllers take a body twist (v, omega), not two track speeds, and limit it
  before they split it between the sides (ROS ``diff_drive_controller``, Clearpath firmware:
  linear and angular speed limits; an effective track separation other than the gauge). In
  track speeds: the mean m = (c_l + c_r)/2 is clipped to +-V, the half difference
  d = (c_r - c_l)/2 is multiplied by k and clipped to +-W, then m moves towards its target at
  most A_m per second and d at most A_d (a controller's linear and angular acceleration limits),
  and the sides are m -+ d. k = 1 and no V, W, A_m, A_d: the stage does nothing;
* ``v_max`` (``drive_speed_limit[_left/_right]``): the robot's own speed controller clamps the
  set-point to what its motors can reach (a Clearpath or Roboteq firmware limit), so a command
  above it gives a track speed at the limit, reached as the lag reaches any set-point;
* ``a_max`` (``drive_accel_limit``): the controller's ramp: its set-point moves towards the
  clamped command at most ``a_max`` per second (applied after the clamp: the ramp is what the
  controller does with the set-point it accepted);
* ``tau`` (``drive_lag``, per side ``drive_lag_left/right``): the closed speed loop's response
  to its set-point, first order, exact discretisation V_{k+1} = r_{k+1} + (V_k - r_{k+1})
  exp(-h/tau) (the set-point of a step acts in that step, as MuJoCo's ``actearly`` filter).

What follows in the MuJoCo robot (the servo with its force limit, the ground's traction on the
track) is :mod:`mjtrack.sim.drivetrain`'s; it feeds MuJoCo the set-point sequence
:func:`setpoints` returns and realises the lag in the actuators. Identification from a log's
measured speeds: :mod:`mjtrack.calibrate.drivetrain`. Theory: docs/theory/simulator.md, "The
track drives".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mjtrack.errors import InputError
from mjtrack.io.robot import Robot


@dataclass(frozen=True)
class Chain:
    """The drivetrain of both sides (SI units); each per-side field is (left, right).

    ``speed_limit`` entries and ``accel_limit`` are None for no limit.
    """

    scale: float = 1.0
    delay: tuple[float, float] = (0.0, 0.0)
    speed_limit: tuple[float | None, float | None] = (None, None)
    accel_limit: float | None = None
    lag: tuple[float, float] = (0.0, 0.0)
    turn_scale: float = 1.0
    mean_limit: float | None = None
    turn_limit: float | None = None
    mean_accel_limit: float | None = None
    turn_accel_limit: float | None = None

    @classmethod
    def of_robot(cls, robot: Robot) -> "Chain":
        """The chain a robot description sets (per-side keys win over both-sides keys)."""
        return cls(scale=robot.track_speed_scale, delay=robot.delay_per_side,
                   speed_limit=robot.speed_limit_per_side, accel_limit=robot.drive_accel_limit,
                   lag=robot.lag_per_side, turn_scale=robot.drive_turn_scale,
                   mean_limit=robot.drive_mean_speed_limit, turn_limit=robot.drive_turn_limit,
                   mean_accel_limit=robot.drive_mean_accel_limit, turn_accel_limit=robot.drive_turn_accel_limit)


def delay_steps(delay: float, timestep: float) -> int:
    """A dead time in whole time steps (round to nearest)."""
    return int(round(delay / timestep))


def twist(u: np.ndarray, turn_scale: float = 1.0, mean_limit: float | None = None,
          turn_limit: float | None = None) -> np.ndarray:
    """The twist stage on u (..., 2): the sides' mean clipped to +-``mean_limit``, their half
    difference times ``turn_scale`` clipped to +-``turn_limit`` (None: no limit)."""
    if turn_scale == 1.0 and mean_limit is None and turn_limit is None:
        return u
    m = 0.5 * (u[..., 0] + u[..., 1])
    d = 0.5 * (u[..., 1] - u[..., 0]) * turn_scale
    if mean_limit is not None:
        m = np.clip(m, -mean_limit, mean_limit)
    if turn_limit is not None:
        d = np.clip(d, -turn_limit, turn_limit)
    return np.stack([m - d, m + d], axis=-1)


def twist_ramp(u: np.ndarray, mean_accel_limit: float | None, turn_accel_limit: float | None, h: float,
               start: np.ndarray | float = 0.0) -> np.ndarray:
    """The twist controller's ramps on u (N, ..., 2): the sides' mean moves towards its target at
    most ``mean_accel_limit`` per second, their half difference at most ``turn_accel_limit``
    (:func:`ramp` on each, from the mean and half difference of ``start`` (..., 2)); None: no ramp."""
    if mean_accel_limit is None and turn_accel_limit is None:
        return u
    start = np.broadcast_to(np.asarray(start, dtype=float), u.shape[1:])
    m = ramp(0.5 * (u[..., 0] + u[..., 1]), mean_accel_limit, h, 0.5 * (start[..., 0] + start[..., 1]))
    d = ramp(0.5 * (u[..., 1] - u[..., 0]), turn_accel_limit, h, 0.5 * (start[..., 1] - start[..., 0]))
    return np.stack([m - d, m + d], axis=-1)


def clamp(u: np.ndarray, limits: tuple[float | None, float | None]) -> np.ndarray:
    """u (..., 2) with each side's set-point clipped to +-its speed limit (None: unchanged)."""
    if limits[0] is None and limits[1] is None:
        return u
    lim = np.array([np.inf if v is None else v for v in limits])
    return np.clip(u, -lim, lim)


def ramp(u: np.ndarray, accel_limit: float | None, h: float, start: np.ndarray | float = 0.0) -> np.ndarray:
    """The rate-limited set-point of target set-points u (N, ...): r_{k+1} = r_k +
    clip(u_k - r_k, +-a_max h) from r_0 = ``start``; returns the mean over each step,
    (r_k + r_{k+1}) / 2 (the ramp is linear inside a step: r_{k+1} held over the step would run
    half a step ahead, and a dead time fitted to it half a step long). ``accel_limit`` None: u itself."""
    if accel_limit is None:
        return u
    if not accel_limit > 0:
        raise InputError(f"drivetrain: acceleration limit must be > 0 m/s^2, got {accel_limit!r}")
    step = accel_limit * h
    out = np.empty_like(u)
    r = np.broadcast_to(np.asarray(start, dtype=float), u.shape[1:]).copy()
    for k in range(u.shape[0]):
        r_next = r + np.clip(u[k] - r, -step, step)
        out[k] = 0.5 * (r + r_next)
        r = r_next
    return out


def lag(r: np.ndarray, tau: np.ndarray | float, h: float, start: np.ndarray | float = 0.0) -> np.ndarray:
    """Track speeds V (N, ...) after each step of set-points r (N, ...) through first-order lags
    ``tau`` (broadcast on the last axes; 0: none), exact for a set-point held over each step,
    from V_0 = ``start``."""
    tau = np.asarray(tau, dtype=float)
    a = np.where(tau > 0, np.exp(-h / np.where(tau > 0, tau, 1.0)), 0.0)
    out = np.empty_like(r)
    v = np.broadcast_to(np.asarray(start, dtype=float), r.shape[1:]).copy()
    for k in range(r.shape[0]):
        v = r[k] + (v - r[k]) * a
        out[k] = v
    return out


def setpoints(chain: Chain, commands: np.ndarray, timestep: float, start: np.ndarray | float = 0.0) -> np.ndarray:
    """The set-points (nstep, 2) [m/s] a simulator's drives receive from per-step commands
    (nstep, 2): scaled, through the twist stage, clamped to each side's speed limit, ramped by the
    acceleration limit, each side shifted by its dead time in whole steps. Before t = 0 the drives
    were at ``start`` (2,) and commanded so (default: at rest). What is left -- the lag -- is the
    simulator's. Null limits, equal delays, at rest: ``commands * scale`` shifted, exactly."""
    start = np.broadcast_to(np.asarray(start, dtype=float), (2,))
    out = np.asarray(commands, dtype=float) * chain.scale
    out = twist(out, chain.turn_scale, chain.mean_limit, chain.turn_limit)
    out = twist_ramp(out, chain.mean_accel_limit, chain.turn_accel_limit, timestep, start)
    out = ramp(clamp(out, chain.speed_limit), chain.accel_limit, timestep, start)
    ks = [delay_steps(d, timestep) for d in chain.delay]
    if ks[0] == ks[1] and start[0] == start[1]:
        return _shift(out, ks[0], start[0])
    return np.stack([_shift(out[:, i], k, start[i]) for i, k in enumerate(ks)], axis=1)


def _shift(x: np.ndarray, k: int, fill: float) -> np.ndarray:
    """x delayed by k rows, ``fill`` before."""
    if k <= 0:
        return x
    return np.concatenate([np.full((min(k, len(x)),) + x.shape[1:], fill), x[:max(len(x) - k, 0)]])


def response(chain: Chain, commands: np.ndarray, timestep: float, start: np.ndarray | float = 0.0) -> np.ndarray:
    """Track speeds (nstep, 2) after each step of per-step commands (nstep, 2): the whole chain
    (:func:`setpoints`, then the lag), the drives at ``start`` before t = 0 (a stiff servo: the
    speed is the lagged set-point)."""
    return lag(setpoints(chain, commands, timestep, start), np.array(chain.lag), timestep, start)


def window_response(t: np.ndarray, cmd: np.ndarray, v0: np.ndarray, *, scale: float, delay: np.ndarray,
                    speed_limit: np.ndarray, accel_limit: float, tau: np.ndarray, turn_scale: float = 1.0,
                    mean_limit: float = math.inf, turn_limit: float = math.inf, mean_accel_limit: float = math.inf,
                    turn_accel_limit: float = math.inf, substeps: int = 5) -> np.ndarray:
    """Track speeds predicted at the rows of M windows of a log, each started from its measured speed.

    Args:
        t: (M, K) row times, increasing in each window; the prediction starts at its first row
            (rows before the part the caller fits warm the drive up); rows past a window's end
            are predicted and ignored by the caller.
        cmd: (M, K, 2) commands of the rows, each in force until the next row.
        v0: (M, 2) measured speeds at each window's first row; the drive's set-point and speed
            start there, and before it the drive was commanded v0 / scale.
        scale, accel_limit: both sides (``accel_limit`` inf: none); delay, speed_limit, tau: (2,)
            per side (``speed_limit`` inf: none); turn_scale, mean_limit, turn_limit: the twist
            stage (limits inf: none).
        substeps: integration steps per median row period.

    The dead time, a time shift of time-invariant stages, is applied to the output by linear
    interpolation between steps, so the prediction is continuous in it (a shift of the input
    would be lost in the ramp's clip) and least squares can move it.
    """
    M, K = t.shape
    t = t - t[:, :1]
    periods = np.diff(t, axis=1)
    h = float(np.median(periods[periods > 0])) / substeps if K > 1 else 0.01
    N = int(math.ceil(float(np.max(t)) / h)) + 1
    grid = np.arange(N + 1) * h
    # the integral F of the held command from each window's first row, at the delayed grid times,
    # for all windows at once: window j's times offset by j * span make one increasing sequence
    span = float(np.max(t) - np.min(t)) + grid[-1] + 1.0
    off = np.arange(M)[:, None] * span
    tf = (t + off).ravel()
    first = np.arange(M)[:, None] * K
    u = np.empty((N, M, 2))
    e = grid[None, :] + off  # (M, N + 1)
    idx = np.maximum(np.searchsorted(tf, e.ravel(), side="right").reshape(e.shape) - 1, first)
    for i in range(2):
        c = cmd[..., i]
        F_rows = np.concatenate([np.zeros((M, 1)), np.cumsum(c[:, :-1] * periods, axis=1)], axis=1).ravel()
        F = F_rows[idx] + c.ravel()[idx] * (e - tf[idx])
        u[:, :, i] = (np.diff(F, axis=1) / h).T  # the mean of the held command over each step
    u = twist(u * scale, turn_scale, None if math.isinf(mean_limit) else mean_limit,
              None if math.isinf(turn_limit) else turn_limit)
    u = twist_ramp(u, None if math.isinf(mean_accel_limit) else mean_accel_limit,
                   None if math.isinf(turn_accel_limit) else turn_accel_limit, h, v0)
    u = np.clip(u, -speed_limit, speed_limit)
    r = ramp(u, None if not math.isfinite(accel_limit) else accel_limit, h, v0)
    v = lag(r, tau, h, v0)
    v = np.concatenate([v0[None], v])  # (N + 1, M, 2) at the grid
    out = np.empty((M, K, 2))
    jj = np.arange(M)[:, None]
    for i in range(2):  # the dead time: each side's speed read d earlier (v0 before the start)
        k = np.clip((t - delay[i]) / h, 0, N)
        k0 = np.minimum(np.floor(k).astype(int), N - 1)
        w = k - k0
        out[..., i] = v[k0, jj, i] * (1 - w) + v[k0 + 1, jj, i] * w
    return out


__all__ = ["Chain", "clamp", "delay_steps", "lag", "ramp", "response", "setpoints", "twist", "window_response"]
