"""Decorations drawn into a rendered scene: ground grid, path trail, point markers, camera framing,
track belts with moving grousers; and a legend image blended into the frames.

All of them assume flat ground at z = 0 (the floor of :func:`mjtrack.sim.chassis.add_scene`)
and are drawn a few millimetres above it so that they do not z-fight with the plane.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from mjtrack.io.robot import side_word
from mjtrack.render.offscreen import OffscreenRenderer

GROUND_LIFT = 0.004  # [m] height of grid, trail and markers above the z = 0 ground
GRID_RGBA = (0.25, 0.25, 0.3, 0.6)
TRAIL_RGBA = (0.05, 0.35, 0.95, 1.0)
MARKER_RGBA = (0.9, 0.1, 0.6, 1.0)
# One colour per ICR of :func:`icr_markers` (left track, right track, body), so that the legend can
# tell them apart; a single point set (K = 1) keeps MARKER_RGBA.
ICR_RGBA = (MARKER_RGBA, (0.5, 0.2, 0.95, 1.0), (0.1, 0.7, 0.3, 1.0))
ICR_LABELS = ("ICR left track", "ICR right track", "ICR body")


def icr_labels(traction: str = "tracks") -> tuple[str, str, str]:
    """The legend's names of the three ICRs for a robot on ``traction`` ("tracks" or "wheels":
    a wheeled robot's side ICRs are those of its left and right wheels)."""
    side = side_word(traction)
    return (f"ICR left {side}", f"ICR right {side}", ICR_LABELS[2])
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
    """Line segments through ``points`` (M, 2) on the z = 0 ground or (M, 3) on the ground at their
    own height (a body's path on terrain) [m]; stops quietly when the scene is full."""
    if len(points) < 2:
        return
    points = np.asarray(points, dtype=float)
    z = points[:, 2] + GROUND_LIFT if points.shape[1] > 2 else np.full(len(points), GROUND_LIFT)
    for i in range(len(points) - 1):
        a, b = points[i], points[i + 1]
        if not renderer.add_connector(_LINE, width_px, (a[0], a[1], z[i]), (b[0], b[1], z[i + 1]), rgba):
            return


def draw_markers(renderer: OffscreenRenderer, points: np.ndarray, origin, *, radius: float,
                 rgba=ICR_RGBA) -> None:
    """A sphere at each finite point of ``points`` (K, 3) [m], joined by a thin line to ``origin`` (x, y).

    Point k has colour ``rgba[k % len(rgba)]``. Points with a NaN or infinite coordinate (e.g. ICRs
    in straight driving) are skipped.
    """
    z_line = GROUND_LIFT
    for k, p in enumerate(points):
        if not np.all(np.isfinite(p)):
            continue
        colour = rgba[k % len(rgba)]
        centre = (p[0], p[1], max(p[2], 0.0) + radius)
        renderer.add_geom(_SPHERE, (radius, radius, radius), centre, colour)
        renderer.add_connector(_LINE, 1.0, (origin[0], origin[1], z_line), (p[0], p[1], z_line), colour)


def legend_image(labels, rgba=ICR_RGBA, *, height_px: int) -> np.ndarray:
    """(h, w, 4) float RGBA image in [0, 1] of a legend: a marker and a line in ``rgba[k]`` beside
    ``labels[k]``, on a light box; sized for frames ``height_px`` high (font ~ 1/32 of it).

    Drawn once with matplotlib (MuJoCo's overlay font has one colour) and blended into every
    frame by :func:`blend_top_right`.
    """
    import io

    from matplotlib.figure import Figure
    from matplotlib.image import imread
    from matplotlib.lines import Line2D

    font_pt = max(8.0, height_px / 32) * 72 / 100  # [pt] at 100 dpi: about height/32 pixels
    fig = Figure(figsize=(4, 2), dpi=100)
    handles = [Line2D([], [], color=rgba[k % len(rgba)][:3], marker="o", linewidth=1.5,
                      markersize=font_pt * 0.8) for k in range(len(labels))]
    fig.legend(handles, list(labels), loc="center", fontsize=font_pt, framealpha=0.85,
               facecolor="white", edgecolor="0.5", handlelength=1.6, borderpad=0.4, labelspacing=0.3)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100, bbox_inches="tight", pad_inches=0.0, transparent=True)
    buf.seek(0)
    return imread(buf)


def blend_top_right(frame: np.ndarray, image: np.ndarray, *, margin_px: int = 6) -> np.ndarray:
    """``frame`` (H, W, 3) uint8 with the RGBA ``image`` (values in [0, 1]) alpha-blended into its
    top-right corner, ``margin_px`` from the edges (cropped to the frame); a new array."""
    out = frame.copy()
    h = min(image.shape[0], frame.shape[0] - margin_px)
    w = min(image.shape[1], frame.shape[1] - margin_px)
    if h <= 0 or w <= 0:
        return out
    x0 = frame.shape[1] - margin_px - w
    patch = image[:h, :w]
    alpha = patch[..., 3:4]
    region = out[margin_px:margin_px + h, x0:x0 + w].astype(float)
    blended = (1 - alpha) * region + alpha * 255 * patch[..., :3]
    out[margin_px:margin_px + h, x0:x0 + w] = np.rint(blended).astype(np.uint8)
    return out


def _in_subtree(model: mujoco.MjModel, body_id: int) -> np.ndarray:
    """(nbody,) bool: the body and its descendants."""
    in_subtree = np.zeros(model.nbody, dtype=bool)
    for b in range(model.nbody):  # parents precede children in MuJoCo's body order
        in_subtree[b] = b == body_id or (b > 0 and in_subtree[model.body_parentid[b]])
    return in_subtree


def subtree_radius(model: mujoco.MjModel, data: mujoco.MjData, body_id: int) -> float:
    """Radius [m] of a sphere about the body's origin holding every non-plane geom of its subtree."""
    in_subtree = _in_subtree(model, body_id)
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
    straight driving: no marker). The three ICRs share x_c (eq. (2.13) of [Mendaluk]); their order is
    :data:`ICR_LABELS`.
    """
    x_c = np.asarray(icr.x_c, dtype=float)
    body = np.stack([np.stack([x_c, np.asarray(y, dtype=float)], axis=-1)
                     for y in (icr.y_l, icr.y_r, icr.y_c)], axis=1)
    return body_to_world_points(poses, body)


# --- track belts -----------------------------------------------------------------------------

BELT_RGBA = (0.12, 0.12, 0.13, 1.0)
GROUSER_RGBA = (0.95, 0.75, 0.1, 1.0)
FRAME_RGBA = (0.28, 0.29, 0.31, 1.0)
WHEEL_RGBA = (0.55, 0.55, 0.58, 1.0)
_BOX = mujoco.mjtGeom.mjGEOM_BOX
_CYLINDER = mujoco.mjtGeom.mjGEOM_CYLINDER
_WHEEL_AXES = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])  # local z (the axle) along body y


@dataclass(frozen=True)
class BeltGeometry:
    """One track belt in the frame of the body that carries it: a stadium in the x-z plane.

    The belt runs along the bottom from the front (x_front) to the rear (x_rear) at height
    ``z_bottom``, round a rear arc of radius ``radius``, forwards along the top and round the
    front arc; material moves in that sense at the track speed, so that its bottom run is still
    on the ground when the robot drives forwards without slip. Arc length s is measured from
    the front end of the bottom run; perimeter 2 (x_front − x_rear) + 2 π radius.
    """

    y: float
    x_front: float
    x_rear: float
    z_bottom: float
    radius: float
    width: float
    thickness: float = 0.008
    grouser_pitch: float = 0.05

    @property
    def straight(self) -> float:
        return self.x_front - self.x_rear

    @property
    def perimeter(self) -> float:
        return 2 * self.straight + 2 * math.pi * self.radius

    def point(self, s) -> tuple[np.ndarray, np.ndarray]:
        """Body-frame points (K, 3) of the belt's centre line at arc lengths ``s`` (K,) and unit tangents (K, 3)."""
        s = np.mod(np.asarray(s, float), self.perimeter)
        a, r, zc = self.straight, self.radius, self.z_bottom + self.radius
        half = math.pi * r
        p, tng = np.zeros((len(s), 3)), np.zeros((len(s), 3))
        p[:, 1] = self.y
        bottom, rear, top = s < a, (s >= a) & (s < a + half), (s >= a + half) & (s < 2 * a + half)
        front = s >= 2 * a + half
        p[bottom, 0], p[bottom, 2], tng[bottom, 0] = self.x_front - s[bottom], self.z_bottom, -1.0
        phi = (s[rear] - a) / r  # 0 at the bottom, pi at the top, round the rear centre
        p[rear, 0], p[rear, 2] = self.x_rear - r * np.sin(phi), zc - r * np.cos(phi)
        tng[rear, 0], tng[rear, 2] = -np.cos(phi), np.sin(phi)
        p[top, 0], p[top, 2], tng[top, 0] = self.x_rear + (s[top] - a - half), zc + r, 1.0
        phi = (s[front] - 2 * a - half) / r  # 0 at the top, pi at the bottom, round the front centre
        p[front, 0], p[front, 2] = self.x_front + r * np.sin(phi), zc + r * np.cos(phi)
        tng[front, 0], tng[front, 2] = np.cos(phi), -np.sin(phi)
        return p, tng


def roller_geoms(model: mujoco.MjModel, body_id: int) -> list[int]:
    """Sphere geoms of the bodies below ``body_id``: the rollers that :func:`belt_geometry` wraps."""
    in_subtree = _in_subtree(model, body_id)
    return [g for g in range(model.ngeom)
            if in_subtree[model.geom_bodyid[g]] and model.geom_bodyid[g] != body_id
            and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_SPHERE]


def belt_geometry(model: mujoco.MjModel, body_id: int, *, width: float | None = None,
                  radius: float | None = None) -> list[BeltGeometry]:
    """Belts (left, right) wrapped round the sphere geoms (rollers) of ``body_id``'s subtree, one per
    side of the body's x-z plane, at the model's reference configuration ``qpos0``.

    ``radius``: the belt's end radius (default: half the height from the rollers' bottoms to
    their tops, at least the roller radius); ``width``: default the roller diameter. Empty
    when the subtree has no sphere geoms on both sides.
    """
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    rot = data.xmat[body_id].reshape(3, 3)
    spheres = roller_geoms(model, body_id)
    if not spheres:
        return []
    local = np.array([rot.T @ (data.geom_xpos[g] - data.xpos[body_id]) for g in spheres])
    r = model.geom_size[spheres, 0]
    belts = []
    for side in (1.0, -1.0):  # left (+y) first
        sel = np.sign(local[:, 1]) == side
        if not np.any(sel):
            return []
        x, z, rs = local[sel, 0], local[sel, 2], r[sel]
        lo, hi = float(np.min(z - rs)), float(np.max(z + rs))
        rad = radius if radius is not None else max(0.5 * (hi - lo), float(np.max(rs)))
        x_lo, x_hi = float(np.min(x - rs)) + rad, float(np.max(x + rs)) - rad
        if x_hi <= x_lo:
            x_lo = x_hi = 0.5 * (x_lo + x_hi)
        belts.append(BeltGeometry(y=float(np.mean(local[sel, 1])), x_front=x_hi, x_rear=x_lo, z_bottom=lo,
                                  radius=rad, width=width if width is not None else 2 * float(np.max(rs))))
    return belts


def _frame(tangent: np.ndarray) -> np.ndarray:
    """Body-frame rotation (3, 3) with columns tangent, lateral (0, 1, 0), outward normal."""
    t = tangent / np.linalg.norm(tangent)
    return np.column_stack([t, [0.0, 1.0, 0.0], [-t[2], 0.0, t[0]]])


def draw_belt(renderer: OffscreenRenderer, belt: BeltGeometry, xpos, xmat, travel: float, *,
              arc_segments: int = 10) -> None:
    """Draw ``belt`` on the body at (xpos (3,), xmat (9,)): the band as boxes along its outline
    and grousers every ``grouser_pitch`` whose positions advance with the belt's ``travel`` [m]
    (∫ track speed dt), so the belt is seen to move."""
    rot = np.asarray(xmat, float).reshape(3, 3)
    pos = np.asarray(xpos, float)
    a, r = belt.straight, belt.radius
    half = math.pi * r
    # band: the two straight runs, and each arc in arc_segments chords
    pieces = [(0.5 * a, a), (a + half + 0.5 * a, a)]
    step = half / arc_segments
    chord = 2 * r * math.sin(0.5 * step / r) if r > 0 else step
    for start in (a, 2 * a + half):
        pieces += [(start + (i + 0.5) * step, chord) for i in range(arc_segments)]
    s_mid = np.array([p[0] for p in pieces])
    pts, tng = belt.point(s_mid)
    for (s, length), p, t in zip(pieces, pts, tng):
        if length <= 0:
            continue
        if r > 0 and (a <= s < a + half or s >= 2 * a + half):  # the chord lies inside the arc
            p = p + (1 - math.cos(0.5 * step / r)) * r * _frame(t)[:, 2] * -1
        mat = rot @ _frame(t)
        size = (0.5 * length + 0.002, 0.5 * belt.width, 0.5 * belt.thickness)
        if not renderer.add_geom(_BOX, size, pos + rot @ p, BELT_RGBA, mat=mat):
            return
    # the track's side frame between the runs and a wheel (sprocket / idler) in each end arc
    centre = np.array([0.5 * (belt.x_front + belt.x_rear), belt.y, belt.z_bottom + r])
    renderer.add_geom(_BOX, (0.5 * a, 0.45 * belt.width, 0.8 * r), pos + rot @ centre, FRAME_RGBA, mat=rot)
    axle = rot @ _WHEEL_AXES
    for x in (belt.x_front, belt.x_rear):
        renderer.add_geom(_CYLINDER, (0.85 * r, 0.47 * belt.width, 0.0), pos + rot @ np.array([x, belt.y, belt.z_bottom + r]),
                          WHEEL_RGBA, mat=axle)
    n = max(1, int(round(belt.perimeter / belt.grouser_pitch)))
    pitch = belt.perimeter / n  # a whole number of grousers: the pattern closes on itself
    s = np.arange(n) * pitch + travel
    pts, tng = belt.point(s)
    h = 1.5 * belt.thickness
    for p, t in zip(pts, tng):
        fr = _frame(t)
        centre = p + fr[:, 2] * (0.5 * belt.thickness + 0.5 * h)
        if not renderer.add_geom(_BOX, (0.15 * pitch, 0.5 * belt.width, 0.5 * h), pos + rot @ centre,
                                 GROUSER_RGBA, mat=rot @ fr):
            return
