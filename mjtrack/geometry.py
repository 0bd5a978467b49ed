"""Planar frames and rigid motions, eqs. (2.2)–(2.3) of the tracked-robot thesis.

Pose q = (x, y, yaw) of the robot's geometric centre in the world frame; body twist
(vx, vy, wz) in the robot frame (x forward, y left, yaw counter-clockwise). The world
velocity is Rot(yaw)·(vx, vy) (2.3) and yaw-rate wz.

All functions broadcast over leading axes: a pose or twist array has shape (..., 3).
"""

from __future__ import annotations

import numpy as np

_SMALL_ANGLE = 1e-4  # below this |wz*dt| [rad] the SE(2) step uses its Taylor series


def rot2(theta: np.ndarray | float) -> np.ndarray:
    """Rotation matrix Rot(theta), shape (..., 2, 2)."""
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


def wrap_angle(a: np.ndarray | float) -> np.ndarray:
    """Wrap an angle [rad] to the interval [-pi, pi)."""
    return (np.asarray(a) + np.pi) % (2.0 * np.pi) - np.pi


def body_to_world_velocity(yaw, vx, vy) -> tuple[np.ndarray, np.ndarray]:
    """(2.3): world-frame velocity (xdot, ydot) of the centre from the body velocity."""
    c, s = np.cos(yaw), np.sin(yaw)
    return c * vx - s * vy, s * vx + c * vy


def world_to_body_velocity(yaw, xdot, ydot) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of (2.3): body-frame velocity (vx, vy) from the world velocity."""
    c, s = np.cos(yaw), np.sin(yaw)
    return c * xdot + s * ydot, -s * xdot + c * ydot


def sinc_terms(phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """S = sin(phi)/phi and C = (1 - cos(phi))/phi, with series near phi = 0."""
    phi = np.asarray(phi, dtype=float)
    small = np.abs(phi) < _SMALL_ANGLE
    safe = np.where(small, 1.0, phi)
    p2 = phi * phi
    s = np.where(small, 1.0 - p2 / 6.0 + p2 * p2 / 120.0, np.sin(safe) / safe)
    c = np.where(small, phi / 2.0 - phi * p2 / 24.0 + phi * p2 * p2 / 720.0, (1.0 - np.cos(safe)) / safe)
    return s, c


def se2_step(pose: np.ndarray, twist: np.ndarray, dt) -> np.ndarray:
    """Exact pose after holding a constant body twist for ``dt`` seconds.

    The displacement in the starting body frame is ∫_0^dt Rot(wz s)(vx, vy) ds
    = dt·[[S, -C], [C, S]]·(vx, vy) with S = sin(phi)/phi, C = (1-cos(phi))/phi, phi = wz·dt.
    Straight motion (phi -> 0) is handled by the Taylor series, so there is no singularity.

    Args:
        pose: (..., 3) [m, m, rad].
        twist: (..., 3) body twist [m/s, m/s, rad/s].
        dt: step [s], scalar or broadcastable to (...).
    Returns:
        (..., 3) pose; the yaw is not wrapped (continuous).
    """
    pose = np.asarray(pose, dtype=float)
    twist = np.asarray(twist, dtype=float)
    vx, vy, wz = twist[..., 0], twist[..., 1], twist[..., 2]
    phi = wz * dt
    s, c = sinc_terms(phi)
    dxb = dt * (s * vx - c * vy)
    dyb = dt * (c * vx + s * vy)
    dxw, dyw = body_to_world_velocity(pose[..., 2], dxb, dyb)
    return np.stack([pose[..., 0] + dxw, pose[..., 1] + dyw, pose[..., 2] + phi], -1)


def euler_step(pose: np.ndarray, twist: np.ndarray, dt) -> np.ndarray:
    """First-order (Euler) pose step (3.11): q + dt·(Rot(yaw)(vx, vy), wz)."""
    pose = np.asarray(pose, dtype=float)
    twist = np.asarray(twist, dtype=float)
    xd, yd = body_to_world_velocity(pose[..., 2], twist[..., 0], twist[..., 1])
    return np.stack([pose[..., 0] + dt * xd, pose[..., 1] + dt * yd, pose[..., 2] + dt * twist[..., 2]], -1)


def relative_pose(pose_a: np.ndarray, pose_b: np.ndarray) -> np.ndarray:
    """Pose of b expressed in the frame of a (the body-frame increment a -> b), yaw wrapped."""
    pose_a = np.asarray(pose_a, dtype=float)
    pose_b = np.asarray(pose_b, dtype=float)
    dx, dy = world_to_body_velocity(pose_a[..., 2], pose_b[..., 0] - pose_a[..., 0], pose_b[..., 1] - pose_a[..., 1])
    return np.stack([dx, dy, wrap_angle(pose_b[..., 2] - pose_a[..., 2])], -1)


def compose(pose_a: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """Inverse of :func:`relative_pose`: the world pose of ``delta`` given in the frame of a."""
    pose_a = np.asarray(pose_a, dtype=float)
    delta = np.asarray(delta, dtype=float)
    dx, dy = body_to_world_velocity(pose_a[..., 2], delta[..., 0], delta[..., 1])
    return np.stack([pose_a[..., 0] + dx, pose_a[..., 1] + dy, pose_a[..., 2] + delta[..., 2]], -1)
