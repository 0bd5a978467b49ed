"""The main job on built-in defaults: ``mjtrack demo --out DIR``.

Stages (each timed, :class:`DemoResult` ``stage_s``):

1. **rollout** — the default robot with its centre of gravity 5 cm ahead of the geometric
   centre (``cg_x = +0.05 m``) drives a seeded sequence of everyday manoeuvres
   (:func:`demo_commands`) in MuJoCo; written as ``DIR/rollout.csv`` + ``DIR/rollout.json``
   (a log and robot that ``mjtrack validate`` and ``mjtrack render`` accept).
2. **validate** — :func:`mjtrack.validate.validate`: ICRs, the four kinematic models and the
   three filters against the rollout and against the MPP analytic truth;
   ``DIR/report.html`` and ``DIR/metrics.json``.
3. **video** — ``DIR/video.mp4``: the rollout replayed offscreen, camera following the robot,
   path trail and ICRs on the ground (skipped with a warning where no offscreen OpenGL
   exists: :class:`~mjtrack.render.RenderUnavailableError`).

``robot`` (default :data:`DEMO_ROBOT`) runs the demo on another robot, tracked or wheeled.
``terrain`` (a :class:`~mjtrack.sim.terrain.Terrain`, default flat) runs the same manoeuvres on
other ground; it is recorded in ``rollout.json`` (key ``terrain``) and drawn in the video. The
kinematic models stay planar: on a slope or steps the validation shows how far they get.

The manoeuvres: each held 3–5 s, a forward or backward speed |v| in [0.2, 0.6] m/s and a
nominal turn radius of 0.5–3 m either way, or straight (one in five). Spin turns are left
out on purpose: while v_x ≈ 0 the MPP model cannot express the sideways velocity that a
centre-of-gravity offset produces, and the slip EKF's α runs off to ±90° (``mjtrack validate
--scenario random_steps`` shows it); the demo shows the everyday case.
"""

from __future__ import annotations

import logging
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mjtrack.io.robot import Robot

log = logging.getLogger(__name__)

DEMO_ROBOT = Robot().replace(cg_x=0.05)
DEMO_DURATION = 60.0  # [s]


@dataclass(frozen=True)
class DemoResult:
    """Paths written, headline metrics and timings [s] of :func:`run_demo`."""

    out_dir: Path
    report: Path
    metrics: Path
    log: Path
    video: Path | None
    headline: dict
    stage_s: dict = field(default_factory=dict)
    wall_s: float = 0.0
    video_skipped: str | None = None


def demo_commands(robot: Robot, *, duration: float = DEMO_DURATION, seed: int = 0
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Command table (t, V_L, V_R) [s, m/s, m/s] of seeded everyday manoeuvres (module docstring)."""
    rng = np.random.default_rng(seed)
    t, vl, vr, ts = [], [], [], 0.0
    while ts < duration:
        v = rng.uniform(0.2, 0.6) * (1 if rng.uniform() < 0.8 else -1)
        if rng.uniform() < 0.2:
            w = 0.0
        else:
            w = v / (rng.uniform(0.5, 3.0) * rng.choice([-1.0, 1.0]))
        half = w * robot.track_gauge / 2
        t.append(ts)
        vl.append(v - half)
        vr.append(v + half)
        ts += rng.uniform(3.0, 5.0)
    return np.array(t), np.array(vl), np.array(vr)


def run_demo(out_dir: str | os.PathLike, *, duration: float = DEMO_DURATION, seed: int = 0, video: bool = True,
             video_size: tuple[int, int] = (640, 480), fps: float = 25.0, speed: float = 2.0,
             quiet: bool = False, terrain=None, robot: Robot | None = None) -> DemoResult:
    """Run the demo into ``out_dir`` (created); see the module docstring. ``robot``: the robot
    simulated (default :data:`DEMO_ROBOT`)."""
    from mjtrack.io.atomic import make_output_dir
    from mjtrack.io.logs import robot_path_for, write_log
    from mjtrack.io.robot import write_robot
    from mjtrack.progress import Progress
    from mjtrack.render import RenderUnavailableError
    from mjtrack.sim.config import sim_config
    from mjtrack.sim.rollout import drive_log
    from mjtrack.sim.terrain import Terrain, with_terrain
    from mjtrack.validate import validate
    from mjtrack.validate.video import render_log

    start = time.perf_counter()
    out = Path(out_dir)
    make_output_dir(out)
    terrain = terrain or Terrain()
    given = robot is not None
    robot = with_terrain(robot if given else DEMO_ROBOT, terrain)
    stage_s = {}

    tic = time.perf_counter()
    with Progress(1, label="rollout", quiet=quiet) as bar:
        drive = drive_log(robot, demo_commands(robot, duration=duration, seed=seed), duration=duration, terrain=terrain,
                          config=sim_config(None, robot=robot))  # a calibrated robot's own simulator settings
        log_path = out / "rollout.csv"
        write_log(drive, log_path)
        write_robot(robot, robot_path_for(log_path))
        bar.update(note=f"{duration:g} s simulated")
    stage_s["rollout"] = time.perf_counter() - tic

    tic = time.perf_counter()
    ground = "" if terrain.is_flat else f" on terrain {terrain.spec}"
    which = (f"the given robot on {robot.traction} (T {robot.track_gauge:g} m, {robot.mass:g} kg, cg_x {robot.cg_x:+g} m)"
             if given else f"the default robot with cg_x = +{robot.cg_x:g} m")
    source = f"simulated log of {which}{ground}: seeded everyday manoeuvres (seed {seed}, {duration:g} s; mjtrack demo)"
    val = validate(drive.replace(source=str(log_path)), robot, out, source=source, seed=seed, quiet=quiet)
    stage_s["validate"] = time.perf_counter() - tic

    video_path, skipped = None, None
    if video:
        tic = time.perf_counter()
        try:
            render_log(drive, robot, out / "video.mp4", width=video_size[0], height=video_size[1], fps=fps,
                       speed=speed, quiet=quiet)
            video_path = out / "video.mp4"
        except RenderUnavailableError as exc:
            skipped = str(exc)
            log.warning("video skipped: %s", exc)
        stage_s["video"] = time.perf_counter() - tic
    return DemoResult(out, val.report_path, val.metrics_path, log_path, video_path, val.metrics["headline"],
                      stage_s, time.perf_counter() - start, skipped)
