"""Animated top view (GIF) of several planar paths with robot footprints, for reports.

Each path is a pose sequence (x, y, yaw) [m, m, rad] sampled at common times. Frames are
resampled like the videos (:func:`mjtrack.render.video.frame_times`): frame k shows time
t_0 + k * speed / fps. Poses are interpolated linearly in x, y and in the unwrapped yaw
(``np.unwrap``, so a wrap from +pi to -pi between two samples does not spin the footprint).

Each frame draws, per path: the path travelled so far (``trail``; the full path faintly
as well), the robot footprint (a length x width rectangle centred on the pose, rotated by
yaw) and its heading (a line from the centre to the front edge). The plot is drawn with
matplotlib's Agg canvas (no display, no pyplot state) and the frames are written by
Pillow as a looping GIF, atomically (temporary file renamed at the end).
"""

from __future__ import annotations

import dataclasses
import logging
import os
from pathlib import Path
from typing import Mapping

import numpy as np

from mjtrack.errors import InputError
from mjtrack.io.atomic import atomic_path
from mjtrack.render.video import check_frames, frame_times

logger = logging.getLogger(__name__)


@dataclasses.dataclass(frozen=True)
class AnimationStats:
    """What :func:`animate_paths` wrote: ``frames`` at ``fps`` [1/s]."""

    path: Path
    frames: int
    fps: float


def _check(times, paths, out_path, fps, speed, max_frames):
    times = np.asarray(times, dtype=float)
    if times.ndim != 1 or len(times) < 2 or not np.all(np.isfinite(times)):
        raise InputError(f"animate_paths: times must be a finite (N,) array with N >= 2, got shape {times.shape}")
    bad = np.flatnonzero(np.diff(times) <= 0)
    if bad.size:
        raise InputError(f"animate_paths: times must be strictly increasing (sample {bad[0] + 1})")
    if not paths:
        raise InputError("animate_paths: no paths given")
    checked = {}
    for name, poses in paths.items():
        poses = np.asarray(poses, dtype=float)
        if poses.shape != (len(times), 3):
            raise InputError(f"animate_paths: path {name!r} must have shape ({len(times)}, 3), got {poses.shape}")
        if not np.all(np.isfinite(poses)):
            raise InputError(f"animate_paths: path {name!r} has non-finite poses")
        checked[str(name)] = poses
    if not (np.isfinite(fps) and fps > 0 and np.isfinite(speed) and speed > 0):
        raise InputError(f"animate_paths: fps and speed must be positive, got fps={fps}, speed={speed}")
    if Path(out_path).suffix.lower() != ".gif":
        raise InputError(f"animate_paths: output must be a .gif file, got {out_path}")
    check_frames([times], fps=fps, speed=speed)  # before the frame times are allocated
    t_frames = frame_times(times, fps=fps, speed=speed)
    if len(t_frames) > max_frames:
        raise InputError(f"animate_paths: {len(t_frames)} frames > max_frames={max_frames}; "
                         "raise speed or lower fps")
    return times, checked, t_frames


def footprint_corners(pose, length: float, width: float) -> np.ndarray:
    """Corners (4, 2) [m] of a length x width rectangle centred on ``pose`` = (x, y, yaw)."""
    x, y, yaw = pose
    local = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * [length / 2, width / 2]
    c, s = np.cos(yaw), np.sin(yaw)
    return local @ np.array([[c, s], [-s, c]]) + [x, y]


def animate_paths(
    times: np.ndarray,
    paths: Mapping[str, np.ndarray],
    out_path: str | os.PathLike,
    *,
    fps: float = 15.0,
    speed: float = 1.0,
    trail: bool = True,
    footprint: tuple[float, float] | None = None,
    size_px: tuple[int, int] = (640, 480),
    title: str = "",
    max_frames: int = 1500,
) -> AnimationStats:
    """Write an animated top view of ``paths`` ({name: (N, 3) poses}) at ``times`` (N,) [s] as a GIF.

    Args:
        fps: frames per second of the GIF; speed: playback speed (2 = twice as fast).
        trail: draw each path up to the current time (the whole path is always drawn faintly).
        footprint: robot (length, width) [m]; default 6 % of the paths' extent, width 0.8 x length.
        size_px: image (width, height) [px].
        title: text shown above the current time.
        max_frames: refuse to write more frames than this (raise speed instead).

    Raises:
        InputError: shapes, times, non-finite poses, extension, too many frames.
    """
    times, paths, t_frames = _check(times, paths, out_path, fps, speed, max_frames)
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Polygon
    from PIL import Image

    xy = np.concatenate([p[:, :2] for p in paths.values()])
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    span = max(float(np.max(hi - lo)), 1e-3)
    length, width = footprint if footprint is not None else (0.06 * span, 0.048 * span)
    pad = 0.08 * span + max(length, width)

    frames_xy = {}
    for name, poses in paths.items():
        yaw = np.unwrap(poses[:, 2])
        frames_xy[name] = np.column_stack([np.interp(t_frames, times, poses[:, 0]),
                                           np.interp(t_frames, times, poses[:, 1]),
                                           np.interp(t_frames, times, yaw)])

    dpi = 100
    fig = Figure(figsize=(size_px[0] / dpi, size_px[1] / dpi), dpi=dpi)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.set_aspect("equal", adjustable="box")
    centre, half = (lo + hi) / 2, (hi - lo) / 2 + pad
    ratio = size_px[0] / size_px[1]  # widen the shorter side so the equal-aspect box fills the figure
    half = np.array([max(half[0], half[1] * ratio), max(half[1], half[0] / ratio)])
    ax.set_xlim(centre[0] - half[0], centre[0] + half[0])
    ax.set_ylim(centre[1] - half[1], centre[1] + half[1])
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, alpha=0.3)
    artists = []
    for i, (name, poses) in enumerate(paths.items()):
        color = f"C{i % 10}"
        ax.plot(poses[:, 0], poses[:, 1], color=color, alpha=0.25, lw=1)
        (line,) = ax.plot([], [], color=color, lw=2, label=name)
        body = Polygon(np.zeros((4, 2)), closed=True, facecolor=color, edgecolor="k", alpha=0.6, lw=1)
        ax.add_patch(body)
        (heading,) = ax.plot([], [], color="k", lw=1.5)
        artists.append((name, line, body, heading))
    ax.legend(loc="upper right", fontsize="small")
    clock = ax.set_title(f"{title}  t = 0.00 s")  # placeholder text so that the layout leaves room
    fig.tight_layout()

    images = []
    for k, t in enumerate(t_frames):
        for name, line, body, heading in artists:
            path = frames_xy[name]
            if trail:
                line.set_data(path[: k + 1, 0], path[: k + 1, 1])
            pose = path[k]
            body.set_xy(footprint_corners(pose, length, width))
            nose = pose[:2] + length / 2 * np.array([np.cos(pose[2]), np.sin(pose[2])])
            heading.set_data([pose[0], nose[0]], [pose[1], nose[1]])
        clock.set_text(f"{title}  t = {t:.2f} s" if title else f"t = {t:.2f} s")
        canvas.draw()
        rgba = np.asarray(canvas.buffer_rgba())
        images.append(Image.fromarray(rgba[:, :, :3].copy()))
    with atomic_path(out_path) as tmp:
        images[0].save(tmp, format="GIF", save_all=True, append_images=images[1:],
                       duration=round(1000 / fps), loop=0)
    logger.info("wrote %s: %d frames", out_path, len(images))
    return AnimationStats(Path(out_path), len(images), float(fps))
