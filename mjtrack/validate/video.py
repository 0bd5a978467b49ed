"""Videos of a drive log: the MuJoCo robot replayed from the logged poses, and a GIF of model paths.

The MP4 places the MuJoCo model's chassis at each logged pose (``qpos_from_poses``: planar
pose, the chassis at its rest height, the other joints at rest), so any log — simulated or
measured — can be shown. The camera follows the robot, its path so far is trailed on the
ground, and the log's own ICRs (2.13) of the left track, right track and body are drawn on
the ground where the true |ω| ≥ ``wz_min`` (they run off to infinity in straight driving).
A log driven on terrain (its robot description records it) is shown on that terrain, the chassis
at the logged height, roll and pitch. A log with several segments shows them one after the other (each with its own start and
trail, its number on screen); the GIF shows the first segment. The tracks are drawn as belts
whose grousers move with the logged track speeds, a wheeled robot's wheels turn with them; time
and playback speed are on every frame.

The GIF is a top view of the true path and the open-loop paths of the nominal model and of
the online filter models (:mod:`mjtrack.validate.predictors`).
"""

from __future__ import annotations

import logging
import os

import numpy as np

from mjtrack.icr import icr_from_twist
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import Robot
from mjtrack.validate.evaluate import ICR_HORIZON, WZ_MIN
from mjtrack.validate.horizon import dead_reckoning
from mjtrack.validate.predictors import build_predictors, run_filters
from mjtrack.validate.truth import Case, Noise, case_from_log

log = logging.getLogger(__name__)


def first_segment(drive: DriveLog) -> DriveLog:
    slices = drive.segment_slices()
    if len(slices) > 1:
        log.warning("%s has %d segments; showing the first", drive.source or "drive log", len(slices))
    return drive[slices[0]]


def render_log(drive: DriveLog, robot: Robot, out_path: str | os.PathLike, *, width: int = 640, height: int = 480,
               fps: float = 30.0, speed: float = 1.0, wz_min: float = WZ_MIN, quiet: bool = False,
               antialias: bool = True):
    """Render ``drive`` (every segment, one after the other) to the MP4 ``out_path``; returns
    :class:`~mjtrack.render.VideoStats`. The belts move with the log's track speeds (measured
    where the log has them, else the commands), integrated per segment. ``antialias``: as
    :func:`~mjtrack.render.render_video`'s.

    Raises :class:`~mjtrack.render.RenderUnavailableError` when no offscreen OpenGL works here.
    """
    import mujoco

    from mjtrack.render import icr_markers, qpos_from_poses, render_video, track_travel_from_speeds, turn_wheels
    from mjtrack.render.decor import belt_geometry, icr_labels
    from mjtrack.sim.builder import build_model

    case = case_from_log(drive, noise=Noise(scale=0.0))
    terrain = log_terrain(robot)
    model = build_model(robot, terrain=terrain)
    chassis = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "chassis")
    wheeled = robot.traction == "wheels"
    belts = [] if wheeled else belt_geometry(model, chassis, width=robot.track_width, radius=robot.sprocket_radius)
    lifted = drive.z is not None and len(drive.z) == len(case.t)  # a log on terrain: 3-D pose
    qpos = qpos_from_poses(model, case.pose, **({"z": drive.z, "roll": drive.roll, "pitch": drive.pitch} if lifted else {}))
    icr = icr_from_twist(*case.twist.T, case.v_left, case.v_right, wz_min=wz_min, on_singular="mask")
    starts = (np.flatnonzero(case.segments[1:] != case.segments[:-1]) + 1).tolist()
    travel = np.zeros((len(case.t), 2))
    for a, b in zip([0, *starts], [*starts, len(case.t)]):
        travel[a:b] = track_travel_from_speeds(case.t[a:b], case.v_left[a:b], case.v_right[a:b])
    if wheeled:
        qpos = turn_wheels(model, qpos, travel, robot.wheel_radius)
    return render_video(model, qpos, case.t, out_path, width=width, height=height, fps=fps, speed=speed,
                        icr=icr_markers(case.pose, icr), icr_labels=icr_labels(robot.traction), track_travel=travel, belts=belts,
                        segment_starts=starts, antialias=antialias, progress=not quiet)


def log_terrain(robot: Robot):
    """The terrain a log was driven on: its robot description's ``terrain`` (recorded by
    ``mjtrack simulate``; rebuilt from its spec), else flat."""
    from mjtrack.sim.terrain import Terrain, parse_terrain

    recorded = robot.extra.get("terrain")
    if isinstance(recorded, dict) and isinstance(recorded.get("spec"), str):
        return parse_terrain(recorded["spec"])
    return Terrain()


def model_paths(case: Case, robot: Robot) -> dict[str, np.ndarray]:
    """{label: (N, 3) poses}: the truth and the open-loop paths of the nominal and online filter models."""
    preds = build_predictors(case, robot.track_gauge, run_filters(case, robot.track_gauge))
    paths = {"truth": case.pose}
    for p in preds:
        if p.causal:
            path = dead_reckoning(p.template, p.params(ICR_HORIZON), case)
            if np.all(np.isfinite(path)):  # a filter that failed has no path
                paths[p.label] = path
    return paths


def animate_log(drive: DriveLog, robot: Robot, out_path: str | os.PathLike, *, fps: float = 15.0,
                speed: float = 1.0, seed: int = 0):
    """Animated GIF of the model paths of ``drive`` (first segment); returns the AnimationStats."""
    from mjtrack.render import animate_paths

    case = case_from_log(first_segment(drive), seed=seed)
    paths = model_paths(case, robot)
    max_frames = 1500
    duration = float(case.t[-1] - case.t[0])
    speed = max(speed, duration * fps / (max_frames - 2))  # a long log plays faster rather than failing
    return animate_paths(case.t, paths, out_path, fps=fps, speed=speed,
                         footprint=(robot.contact_length, robot.track_gauge + robot.track_width),
                         title="true path and open-loop model paths", max_frames=max_frames)
