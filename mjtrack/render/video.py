"""Offscreen MP4 video of a MuJoCo trajectory: following camera, ground grid, path trail, ICR markers.

Resampling: the video shows simulated time t_k = t_0 + k * speed / fps for
k = 0 .. K-1, K = floor((t_N - t_0) * fps / speed) + 1 (so its duration K / fps is
(t_N - t_0) / speed within one frame). The configuration at t_k is the geodesic
interpolation between the two samples around it: with alpha = (t_k - t_i) / (t_{i+1} - t_i),
q(t_k) = q_i (+) alpha * (q_{i+1} (-) q_i), where (-) is ``mj_differentiatePos`` (velocity that
maps q_i to q_{i+1} in unit time) and (+) ``mj_integratePos``: linear for hinge/slide
joints, a slerp for the quaternions of free and ball joints (a plain linear interpolation
would denormalise them). ICR markers are not interpolated (they jump, and are NaN in
straight driving): each frame shows the last sample at or before t_k.

Writing: imageio's ffmpeg plugin, libx264, yuv420p (which needs even width and height;
``macro_block_size=2`` stops imageio from resizing). The file is written in a temporary
folder beside ``out_path`` under the final extension (ffmpeg picks the container from it)
and renamed at the end, so a failure leaves no partial video.
"""

from __future__ import annotations

import copy
import dataclasses
import logging
import math
import os
import time
from pathlib import Path
from typing import Sequence

import mujoco
import numpy as np

from mjtrack.errors import InputError
from mjtrack.interrupts import deferred
from mjtrack.io.atomic import atomic_path
from mjtrack.progress import Progress
from mjtrack.render import decor
from mjtrack.render.offscreen import OffscreenRenderer

logger = logging.getLogger(__name__)

MAX_TRAIL_POINTS = 600  # trail decimation: bounds the decoration geoms per frame


@dataclasses.dataclass(frozen=True)
class VideoStats:
    """What :func:`render_video` wrote: ``frames`` at ``fps`` [1/s] of ``width`` x ``height`` [px].

    ``render_s`` is the wall time spent in scene update + OpenGL render + pixel read-back,
    ``total_s`` includes interpolation and encoding [s].
    """

    path: Path
    frames: int
    fps: float
    width: int
    height: int
    render_s: float
    total_s: float

    @property
    def duration(self) -> float:
        """Video duration [s]."""
        return self.frames / self.fps


MAX_FRAMES = 216_000  # two hours at 30 frames/s: frames are interpolated up front and encoded one by one


def check_frames(segment_times: Sequence[np.ndarray], *, fps: float, speed: float) -> int:
    """The number of frames a video of these segments (times [s]) takes; refused (InputError with
    the estimate) beyond :data:`MAX_FRAMES`, before any frame is made."""
    if not (math.isfinite(fps) and math.isfinite(speed) and fps > 0 and speed > 0):
        raise InputError(f"render_video: fps and speed must be > 0, got {fps!r} and {speed!r}")
    span = sum(float(t[-1] - t[0]) for t in segment_times if len(t))
    n = sum(math.floor(float(t[-1] - t[0]) * fps / speed + 1e-9) + 1 for t in segment_times if len(t))
    if n > MAX_FRAMES:
        raise InputError(f"a video of {span:.6g} s of log at {fps:g} frames/s and {speed:g}x speed has {n:.3g} frames; "
                         f"at most {MAX_FRAMES:.3g}: raise the playback speed or lower the frame rate")
    return n


def frame_times(times: np.ndarray, *, fps: float, speed: float) -> np.ndarray:
    """Simulated times [s] shown by the video's frames, (K,) (see module docstring)."""
    span = float(times[-1] - times[0])
    count = int(np.floor(span * fps / speed + 1e-9)) + 1
    return times[0] + np.arange(count) * (speed / fps)


def interpolate_qpos(model: mujoco.MjModel, qpos_traj: np.ndarray, times: np.ndarray,
                     t_query: np.ndarray) -> np.ndarray:
    """Configurations at ``t_query`` (K,) [s], (K, nq), geodesic between samples (module docstring)."""
    n = len(times)
    out = np.empty((len(t_query), model.nq))
    qvel = np.empty(model.nv)
    for k, t in enumerate(t_query):
        i = int(np.clip(np.searchsorted(times, t, side="right") - 1, 0, max(n - 2, 0)))
        q = qpos_traj[i].copy()
        if n > 1:
            alpha = (t - times[i]) / (times[i + 1] - times[i])
            mujoco.mj_differentiatePos(model, qvel, 1.0, qpos_traj[i], qpos_traj[i + 1])
            mujoco.mj_integratePos(model, q, qvel, float(alpha))
        out[k] = q
    return out


def _segment_bounds(segment_starts, n: int) -> list[int]:
    """[0, start_1, ..., n]: sample index bounds of the segments (InputError if not increasing in 1..n-1)."""
    starts = sorted({int(i) for i in (segment_starts or [])} - {0})
    if any(not 0 < i < n for i in starts):
        raise InputError(f"render_video: segment_starts must lie in 1..{n - 1}, got {list(segment_starts)}")
    return [0, *starts, n]


def track_travel_from_speeds(times: np.ndarray, v_left: np.ndarray, v_right: np.ndarray) -> np.ndarray:
    """(N, 2) belt travel [m] of the left and right tracks, ∫ V dt by the trapezoid rule from 0."""
    t = np.asarray(times, dtype=float)
    v = np.column_stack([np.asarray(v_left, dtype=float), np.asarray(v_right, dtype=float)])
    v = np.where(np.isfinite(v), v, 0.0)
    out = np.zeros_like(v)
    out[1:] = np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t)[:, None], axis=0)
    return out


def turn_wheels(model: mujoco.MjModel, qpos_traj: np.ndarray, track_travel: np.ndarray, radius: float) -> np.ndarray:
    """Configurations (N, nq): ``qpos_traj`` with every rolling hinge ``roll_<side>_<i>`` at its side's
    travel (N, 2) [m] over ``radius`` [m], so that the wheels of a wheeled robot (or the rollers)
    turn as the log's track speeds say."""
    out = np.array(qpos_traj, dtype=float)
    for j in range(model.njnt):
        name = model.joint(j).name
        for k, side in enumerate(("left", "right")):
            if name.startswith(f"roll_{side}_") and model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE:
                out[:, model.jnt_qposadr[j]] = np.asarray(track_travel, dtype=float)[:, k] / radius
    return out


def clock_text(t: float, speed: float, label: str = "") -> str:
    """The text drawn on a frame: simulated time and playback speed, e.g. ``t = 12.3 s   x1.0``."""
    speed_txt = f"{speed:.2f}".rstrip("0").rstrip(".") if speed != int(speed) else f"{speed:.1f}"
    return f"{label}{'   ' if label else ''}t = {t:.1f} s   x{speed_txt} playback"


def _check_inputs(model, qpos_traj, times, out_path, width, height, fps, speed, follow_body, icr,
                  segment_starts=None, track_travel=None):
    """Validated arrays and ids; raises InputError with a one-line message."""
    if not isinstance(model, mujoco.MjModel):
        raise InputError(f"render_video: model must be a mujoco.MjModel, got {type(model).__name__}")
    qpos_traj = np.asarray(qpos_traj, dtype=float)
    times = np.asarray(times, dtype=float)
    if qpos_traj.ndim != 2 or qpos_traj.shape[1] != model.nq:
        raise InputError(f"render_video: qpos_traj must have shape (N, nq={model.nq}), got {qpos_traj.shape}")
    if times.ndim != 1 or len(times) != len(qpos_traj):
        raise InputError(f"render_video: times must have shape ({len(qpos_traj)},), got {times.shape}")
    if len(times) < 2:
        raise InputError("render_video: need at least 2 samples")
    if not (np.all(np.isfinite(times)) and np.all(np.isfinite(qpos_traj))):
        raise InputError("render_video: times and qpos_traj must be finite")
    bounds = _segment_bounds(segment_starts, len(times))
    steps = np.diff(times)
    steps[np.asarray(bounds[1:-1], int) - 1] = 1.0  # a segment may start at any time
    bad = np.flatnonzero(steps <= 0)
    if bad.size:
        raise InputError(f"render_video: times must be strictly increasing within a segment (sample {bad[0] + 1}: "
                         f"{times[bad[0] + 1]:g} after {times[bad[0]]:g})")
    if any(b - a < 2 for a, b in zip(bounds[:-1], bounds[1:])):
        raise InputError("render_video: every segment needs at least 2 samples")
    if track_travel is not None:
        track_travel = np.asarray(track_travel, dtype=float)
        if track_travel.shape != (len(times), 2) or not np.all(np.isfinite(track_travel)):
            raise InputError(f"render_video: track_travel must be finite with shape ({len(times)}, 2), "
                             f"got {track_travel.shape}")
    for name, value in (("width", width), ("height", height)):
        if int(value) != value or value < 2 or value % 2:
            raise InputError(f"render_video: {name} must be an even number of pixels >= 2 "
                             f"(libx264/yuv420p), got {value}")
    if not (np.isfinite(fps) and fps > 0 and np.isfinite(speed) and speed > 0):
        raise InputError(f"render_video: fps and speed must be positive, got fps={fps}, speed={speed}")
    if Path(out_path).suffix.lower() != ".mp4":
        raise InputError(f"render_video: output must be a .mp4 file, got {out_path}")
    body_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, follow_body)
    if body_id < 0:
        names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(1, model.nbody)]
        raise InputError(f"render_video: no body named {follow_body!r} (bodies: {', '.join(map(str, names[:12]))})")
    if icr is not None:
        icr = np.asarray(icr, dtype=float)
        if icr.ndim == 2:
            icr = icr[:, None, :]
        if icr.ndim != 3 or icr.shape[0] != len(times) or icr.shape[2] not in (2, 3):
            raise InputError(f"render_video: icr must have shape (N={len(times)}, 2|3) or (N, K, 2|3), "
                             f"got {np.shape(icr)}")
        if icr.shape[2] == 2:
            icr = np.concatenate([icr, np.zeros(icr.shape[:2] + (1,))], axis=2)
    return qpos_traj, times, body_id, icr, bounds, track_travel


def render_video(
    model: mujoco.MjModel,
    qpos_traj: np.ndarray,
    times: np.ndarray,
    out_path: str | os.PathLike,
    *,
    width: int = 640,
    height: int = 480,
    fps: float = 30.0,
    speed: float = 1.0,
    follow_body: str = "chassis",
    follow: bool = True,
    distance: float | None = None,
    azimuth: float = 135.0,
    elevation: float = -30.0,
    grid: float | None = 0.5,
    trail: bool = True,
    icr: np.ndarray | None = None,
    icr_labels: Sequence[str] | None = None,
    track_travel: np.ndarray | None = None,
    belts: bool | Sequence[decor.BeltGeometry] = True,
    clock: bool = True,
    segment_starts=None,
    shadows: bool = False,
    antialias: bool = True,
    progress: bool | Progress = True,
) -> VideoStats:
    """Render ``qpos_traj`` (N, nq) sampled at ``times`` (N,) [s] to the MP4 ``out_path``.

    Args:
        width, height: frame size [px], even.
        fps: frames per second of the video; speed: playback speed (1 = real time, 2 = twice
            as fast); written on every frame with the time when ``clock``.
        follow_body: body whose path is trailed and that the camera looks at.
        follow: the camera moves with the body (fixed orientation, so the world grid slides
            under it); ``False``: one fixed camera framing the whole path.
        distance: camera distance [m]; default: fit the body's subtree (following) or the path.
        azimuth, elevation: camera direction [deg], MuJoCo free-camera convention.
        grid: spacing [m] of grid lines on the z = 0 ground (terrain above it hides them); ``None``: none.
        trail: draw the body's path so far, at the body origin's height.
        icr: optional world-frame points (N, 2|3) or (N, K, 2|3) [m] drawn as markers (NaN: none).
        icr_labels: names of the K points, shown in a legend in the top-right corner (e.g. ``ICR_LABELS``).
        track_travel: (N, 2) belt travel [m] of the left and right tracks; the grousers move by it.
        belts: draw a belt round each side's rollers instead of them (``True``: default geometry,
            or the (left, right) :class:`decor.BeltGeometry`).
        clock: write "t = … s   x… playback" (and the segment) in the top-left corner.
        segment_starts: sample indices where a new segment begins: the segments are shown one
            after the other, each with its own trail.
        shadows: render shadows (about 3-5x slower with Mesa's software rasteriser).
        antialias: multisample the frames as the model asks (``vis.quality.offsamples``); ``False``
            renders one sample per pixel, which with Mesa's software rasteriser halves the OpenGL
            time of a 640 x 480 frame (benchmarks/bench_demo.py) and only roughens thin lines a little.
        progress: show a progress line on a terminal (or update the given :class:`Progress`).

    Returns:
        :class:`VideoStats`.

    Raises:
        InputError: inconsistent shapes, times not increasing, unknown body, odd size, bad path.
        RenderUnavailableError: no offscreen OpenGL backend works here.
    """
    start = time.perf_counter()
    qpos_traj, times, body_id, icr, bounds, track_travel = _check_inputs(
        model, qpos_traj, times, out_path, width, height, fps, speed, follow_body, icr, segment_starts, track_travel)
    import imageio.v2 as imageio  # heavy; only needed here

    if isinstance(belts, bool):
        belt_list = decor.belt_geometry(model, body_id) if belts else []
    else:
        belt_list = list(belts)
    if belt_list or (not antialias and model.vis.quality.offsamples):  # a copy: the caller's model is not changed
        model = copy.copy(model)
        for g in decor.roller_geoms(model, body_id) if belt_list else ():  # the belts replace the rollers on screen
            model.geom_rgba[g, 3] = 0.0
        if not antialias:
            model.vis.quality.offsamples = 0
    check_frames([times[a:b] for a, b in zip(bounds[:-1], bounds[1:])], fps=fps, speed=speed)
    segments = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        t_seg = times[a:b]
        t_frames = frame_times(t_seg, fps=fps, speed=speed)
        q_frames = interpolate_qpos(model, qpos_traj[a:b], t_seg, t_frames)
        travel = None if track_travel is None else np.column_stack(
            [np.interp(t_frames, t_seg, track_travel[a:b, i]) for i in range(2)])
        icr_index = a + np.clip(np.searchsorted(t_seg, t_frames, side="right") - 1, 0, b - a - 1)
        segments.append((t_frames, q_frames, travel, icr_index))
    n_frames = sum(len(seg[0]) for seg in segments)
    data = mujoco.MjData(model)
    body_pos = []
    for _, q_frames, _, _ in segments:
        pos = np.empty((len(q_frames), 3))
        for k, q in enumerate(q_frames):
            data.qpos[:] = q
            mujoco.mj_kinematics(model, data)
            pos[k] = data.xpos[body_id]
        body_pos.append(pos)
    data.qpos[:] = segments[0][1][0]
    mujoco.mj_kinematics(model, data)
    size = max(decor.subtree_radius(model, data, body_id), 0.05)
    trail_stride = max(1, int(np.ceil(max(len(seg[0]) for seg in segments) / MAX_TRAIL_POINTS)))

    legend = None if icr is None or not icr_labels else decor.legend_image(icr_labels, height_px=height)
    bar = progress if isinstance(progress, Progress) else Progress(n_frames, label="render", quiet=not progress)
    render_s = 0.0
    with OffscreenRenderer(model, width=width, height=height) as renderer, atomic_path(out_path) as tmp:
        cam = renderer.camera
        cam.azimuth, cam.elevation = azimuth, elevation
        if follow:
            cam.distance = distance or decor.fit_distance(model, 3.0 * size)
        else:
            every = np.vstack(body_pos)
            lo, hi = every.min(axis=0), every.max(axis=0)
            cam.lookat[:] = (lo + hi) / 2
            cam.distance = distance or decor.fit_distance(model, max(np.linalg.norm(hi - lo) / 2, 3.0 * size))
        grid_half = 1.5 * cam.distance
        writer = imageio.get_writer(
            tmp, format="FFMPEG", mode="I", fps=fps, codec="libx264", pixelformat="yuv420p",
            macro_block_size=2, ffmpeg_log_level="error", output_params=["-preset", "veryfast"])
        try:
            for j, ((t_frames, q_frames, travel, icr_index), pos) in enumerate(zip(segments, body_pos)):
                label = f"segment {j + 1}/{len(segments)}" if len(segments) > 1 else ""
                for k, q in enumerate(q_frames):
                    data.qpos[:] = q
                    mujoco.mj_kinematics(model, data)
                    mujoco.mj_comPos(model, data)
                    mujoco.mj_camlight(model, data)
                    if follow:
                        cam.lookat[:] = pos[k]
                    tic = time.perf_counter()
                    renderer.update_scene(data)
                    renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = shadows
                    if grid:
                        decor.draw_grid(renderer, cam.lookat, spacing=grid, half_size=grid_half)
                    if trail:
                        points = np.vstack([pos[: k + 1 : trail_stride], pos[k]])  # at the body's height
                        decor.draw_polyline(renderer, points, width_px=max(2.0, height / 100))
                    if icr is not None:
                        decor.draw_markers(renderer, icr[icr_index[k]], pos[k], radius=0.15 * size)
                    for i, belt in enumerate(belt_list):
                        decor.draw_belt(renderer, belt, data.xpos[body_id], data.xmat[body_id],
                                        0.0 if travel is None else float(travel[k, i]))
                    frame = renderer.render(clock_text(float(t_frames[k]), speed, label) if clock else None)
                    if legend is not None:
                        frame = decor.blend_top_right(frame, legend)
                    render_s += time.perf_counter() - tic
                    with deferred():  # a frame half written to ffmpeg makes it print errors
                        writer.append_data(frame)
                    bar.update()
        finally:
            writer.close()
            if bar is not progress:
                bar.close()
    stats = VideoStats(Path(out_path), n_frames, float(fps), width, height, render_s,
                       time.perf_counter() - start)
    logger.info("wrote %s: %d frames %dx%d, %.1f frames/s rendered", out_path, stats.frames, width, height,
                stats.frames / max(render_s, 1e-9))
    return stats


def qpos_from_poses(model: mujoco.MjModel, poses: np.ndarray, *, body: str = "chassis",
                    z=None, roll=None, pitch=None) -> np.ndarray:
    """Configurations (N, nq) placing ``body``'s free joint at planar ``poses`` (N, 3) = (x, y, yaw) [m, rad].

    For rendering a log or a kinematic model's path: the other joints keep ``model.qpos0``.
    The body's height is ``z`` [m] (a number or (N,); default: its height in ``qpos0``); its
    orientation the Z-Y-X Euler angles yaw, ``pitch``, ``roll`` [rad] ((N,) or None for 0,
    the convention of a log on terrain: pitch positive nose down, roll positive left side up),
    q = q_z(yaw) q_y(pitch) q_x(roll).
    """
    poses = np.asarray(poses, dtype=float)
    if poses.ndim != 2 or poses.shape[1] != 3:
        raise InputError(f"qpos_from_poses: poses must have shape (N, 3), got {poses.shape}")
    body_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body)
    if body_id < 0:
        raise InputError(f"qpos_from_poses: no body named {body!r}")
    jnt = model.body_jntadr[body_id]
    if model.body_jntnum[body_id] < 1 or model.jnt_type[jnt] != mujoco.mjtJoint.mjJNT_FREE:
        raise InputError(f"qpos_from_poses: body {body!r} has no free joint")
    adr = model.jnt_qposadr[jnt]
    n = len(poses)
    angles = []
    for name, value in (("roll", roll), ("pitch", pitch)):
        a = np.zeros(n) if value is None else np.broadcast_to(np.asarray(value, dtype=float), (n,))
        if not np.all(np.isfinite(a)):
            raise InputError(f"qpos_from_poses: {name} must be finite")
        angles.append(a)
    r, p, y = angles[0] / 2, angles[1] / 2, poses[:, 2] / 2
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    qpos = np.tile(model.qpos0, (n, 1))
    qpos[:, adr] = poses[:, 0]
    qpos[:, adr + 1] = poses[:, 1]
    qpos[:, adr + 2] = model.qpos0[adr + 2] if z is None else np.broadcast_to(np.asarray(z, dtype=float), (n,))
    qpos[:, adr + 3] = cy * cp * cr + sy * sp * sr
    qpos[:, adr + 4] = cy * cp * sr - sy * sp * cr
    qpos[:, adr + 5] = cy * sp * cr + sy * cp * sr
    qpos[:, adr + 6] = sy * cp * cr - cy * sp * sr
    return qpos
