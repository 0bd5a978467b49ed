"""Decorations drawn into a rendered scene: ground grid, path trail, point markers, camera framing.

All of them assume flat ground at z = 0 (the floor of :func:`mjtrack.sim.builder.add_scene`)
and are drawn a few millimetres above it so that they do not z-fight with the plane.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from mjtrack.render.offscreen import OffscreenRenderer

GROUND_LIFT = 0.004  # [m] height of grid, trail and markers above the z = 0 ground
GRID_RGBA = (0.25, 0.25, 0.3, 0.6)
TRAIL_RGBA = (0.05, 0.35, 0.95, 1.0)
MARKER_RGBA = (0.9, 0.1, 0.6, 1.0)
_LINE = mujoco.mjtGeom.mjGEOM_LINE
_SPHERE = mujoco.mjtGeom.mjGEOM_SPHERE


def draw_grid(renderer: OffscreenRenderer, centre, *, spacing: float, half_size: float) -> None:
    """Grid lines every ``spacing`` [m] over a square of ``half_size`` [m] around ``centre`` (x, y).

    The lines sit at multiples of ``spacing`` in the world frame (snapped), so they stay
    fixed to the ground while a following camera moves: they show the robot's motion.
    """
    n = int(math.ceil(half_size / spacing))
    cx = round(float(centre[0]) / spacing) * spacing
    cy = round(float(centre[1]) / spacing) * spacing
    lo_x, hi_x = cx - n * spacing, cx + n * spacing
    lo_y, hi_y = cy - n * spacing, cy + n * spacing
    z = GROUND_LIFT / 2
    for i in range(-n, n + 1):
        x, y = cx + i * spacing, cy + i * spacing
        renderer.add_connector(_LINE, 1.0, (x, lo_y, z), (x, hi_y, z), GRID_RGBA)
        renderer.add_connector(_LINE, 1.0, (lo_x, y, z), (hi_x, y, z), GRID_RGBA)


def draw_polyline(renderer: OffscreenRenderer, points: np.ndarray, *, width_px: float, rgba=TRAIL_RGBA) -> None:
    """Line segments through ``points`` (M, 2) [m], on the ground; stops quietly when the scene is full."""
    if len(points) < 2:
        return
    z = GROUND_LIFT
    for a, b in zip(points[:-1], points[1:]):
        if not renderer.add_connector(_LINE, width_px, (a[0], a[1], z), (b[0], b[1], z), rgba):
            return


def draw_markers(renderer: OffscreenRenderer, points: np.ndarray, origin, *, radius: float,
                 rgba=MARKER_RGBA) -> None:
    """A sphere at each finite point of ``points`` (K, 3) [m], joined by a thin line to ``origin`` (x, y).

    Points with a NaN or infinite coordinate (e.g. ICRs in straight driving) are skipped.
    """
    z_line = GROUND_LIFT
    for p in points:
        if not np.all(np.isfinite(p)):
            continue
        centre = (p[0], p[1], max(p[2], 0.0) + radius)
        renderer.add_geom(_SPHERE, (radius, radius, radius), centre, rgba)
        renderer.add_connector(_LINE, 1.0, (origin[0], origin[1], z_line), (p[0], p[1], z_line), rgba)


def subtree_radius(model: mujoco.MjModel, data: mujoco.MjData, body_id: int) -> float:
    """Radius [m] of a sphere about the body's origin holding every non-plane geom of its subtree."""
    in_subtree = np.zeros(model.nbody, dtype=bool)
    for b in range(model.nbody):  # parents precede children in MuJoCo's body order
        in_subtree[b] = b == body_id or (b > 0 and in_subtree[model.body_parentid[b]])
    radius = 0.0
    for g in range(model.ngeom):
        if in_subtree[model.geom_bodyid[g]] and model.geom_type[g] != mujoco.mjtGeom.mjGEOM_PLANE:
            offset = np.linalg.norm(data.geom_xpos[g] - data.xpos[body_id])
            radius = max(radius, offset + model.geom_rbound[g])
    return radius


def fit_distance(model: mujoco.MjModel, half_extent: float, *, margin: float = 1.3) -> float:
    """Free-camera distance [m] at which a sphere of ``half_extent`` [m] fills the vertical view."""
    half_fov = math.radians(model.vis.global_.fovy) / 2
    return margin * half_extent / math.tan(half_fov)


def body_to_world_points(poses: np.ndarray, points: np.ndarray) -> np.ndarray:
    """World points (N, K, 3) [m] (z = 0) of body-frame points (N, K, 2) at planar poses (N, 3).

    p_world = (x, y) + R(yaw) p_body; NaN body points stay NaN (not drawn).
    """
    poses = np.asarray(poses, dtype=float)
    points = np.asarray(points, dtype=float)
    c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
    px, py = points[..., 0], points[..., 1]
    out = np.zeros(points.shape[:2] + (3,))
    out[..., 0] = poses[:, 0:1] + c * px - s * py
    out[..., 1] = poses[:, 1:2] + s * px + c * py
    return out


def icr_markers(poses: np.ndarray, icr) -> np.ndarray:
    """World positions (N, 3, 3) of the left-track, right-track and body ICRs for ``render_video(icr=...)``.

    ``icr``: anything with body-frame arrays ``x_c, y_l, y_r, y_c`` of shape (N,) [m], e.g.
    :class:`mjtrack.icr.ICR` from ``icr_from_twist(..., on_singular="mask")`` (NaN in
    straight driving: no marker). The three ICRs share x_c (eq. 2.13).
    """
    x_c = np.asarray(icr.x_c, dtype=float)
    body = np.stack([np.stack([x_c, np.asarray(y, dtype=float)], axis=-1)
                     for y in (icr.y_l, icr.y_r, icr.y_c)], axis=1)
    return body_to_world_points(poses, body)
