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

The video is made from the same rollout as the validation (nothing is simulated twice) and, where
two CPUs are free (``workers``), in a second process while the validation runs: the validation is
Python (the filters), the video mostly OpenGL and the encoder, so the two share nothing but the
rollout and the wall time is about the longer of them instead of their sum
(``benchmarks/bench_demo.py`` measures both ways). The video plays at twice the simulated speed and
:data:`DEMO_FPS` frames per second, which shows the manoeuvres smoothly at a fifth fewer frames
than 25 per second would, and is rendered without multisampling (``antialias=False`` of
:func:`~mjtrack.render.render_video`: about half the OpenGL time of a frame; the encoder's
chroma subsampling softens the edges anyway).

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
DEMO_FPS = 20.0  # [frames/s] of the video, at DEMO_SPEED times the simulated speed
DEMO_SPEED = 2.0


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
    video_concurrent: bool = False  # the video was made in a second process while validating
    ran: tuple[str, ...] = ()  # what the demo ran, in words (one line per stage)


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


def default_workers() -> int:
    """The processes the demo uses: two (validation and video side by side) where this process may
    run on two or more CPUs, else one."""
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:  # (no sched_getaffinity outside Linux)
        cpus = os.cpu_count() or 1
    return 2 if cpus >= 2 else 1


def _video_job(log_path: Path, path: Path, width: int, height: int, fps: float, speed: float,
               quiet: bool) -> tuple[int, float]:
    """Render the video of the rollout written at ``log_path`` (with its robot file) to ``path``, in the
    calling process or a worker (which is handed file names, not the rollout): (frames, wall seconds)."""
    from mjtrack.io.logs import read_log_with_robot
    from mjtrack.validate.video import render_log

    tic = time.perf_counter()
    drive, robot = read_log_with_robot(log_path)
    stats = render_log(drive, robot, path, width=width, height=height, fps=fps, speed=speed, quiet=quiet,
                       antialias=False)  # one sample per pixel: half the OpenGL time, the look nearly unchanged
    return stats.frames, time.perf_counter() - tic


def _video_main(argv: list[str]) -> int:
    """The video worker's program (``python -c``; argv: rollout.csv, video.mp4, width, height, fps,
    speed): prints one JSON line, ``{"frames", "seconds"}`` or ``{"unavailable": why}``; any other
    error is a traceback on stderr and exit status 1. SIGTERM (the demo ending it) unwinds it, so
    that its temporary video folder is removed."""
    import json
    import signal
    import sys

    from mjtrack.render import RenderUnavailableError

    signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(128 + signum))
    log_path, path, width, height, fps, speed = argv
    try:
        frames, seconds = _video_job(Path(log_path), Path(path), int(width), int(height), float(fps), float(speed),
                                     True)
    except RenderUnavailableError as exc:
        print(json.dumps({"unavailable": str(exc)}))
        return 0
    print(json.dumps({"frames": frames, "seconds": seconds}))
    return 0


def _start_video_worker(log_path: Path, path: Path, width: int, height: int, fps: float, speed: float):
    """The video worker: a fresh interpreter (never a fork: a process that has rendered before holds
    Mesa's software rasteriser, whose threads a fork leaves behind, and a forked worker waits for them
    for ever in its first ``mjr_readPixels``), in its own session, so that Ctrl-C reaches this process
    alone, which then ends the worker; the watchdog of :mod:`mjtrack.interrupts` kills it too when it
    has to end this process."""
    import subprocess
    import sys

    from mjtrack import interrupts

    here = str(Path(__file__).resolve().parents[1])  # this mjtrack first on the worker's path
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [here, os.environ.get("PYTHONPATH")]))}
    code = "import sys; from mjtrack.demo import _video_main; sys.exit(_video_main(sys.argv[1:]))"
    proc = subprocess.Popen([sys.executable, "-c", code, str(log_path), str(path), str(width), str(height),
                             repr(float(fps)), repr(float(speed))], stdout=subprocess.PIPE, text=True, env=env,
                            start_new_session=True)
    interrupts.add_emergency_cleanup(proc.kill)
    return proc


def _video_result(proc) -> tuple[int, float]:
    """Wait for the worker: (frames, seconds); RenderUnavailableError or MjtrackError as it ended."""
    import json

    from mjtrack.errors import MjtrackError
    from mjtrack.render import RenderUnavailableError

    out, _ = proc.communicate()
    lines = out.strip().splitlines()
    if proc.returncode != 0 or not lines:
        raise MjtrackError(f"the video worker failed (exit status {proc.returncode}; its error is printed above)")
    doc = json.loads(lines[-1])
    if "unavailable" in doc:
        raise RenderUnavailableError(doc["unavailable"])
    return int(doc["frames"]), float(doc["seconds"])


def run_demo(out_dir: str | os.PathLike, *, duration: float = DEMO_DURATION, seed: int = 0, video: bool = True,
             video_size: tuple[int, int] = (640, 480), fps: float = DEMO_FPS, speed: float = DEMO_SPEED,
             quiet: bool = False, terrain=None, robot: Robot | None = None, workers: int | None = None) -> DemoResult:
    """Run the demo into ``out_dir`` (created); see the module docstring. ``robot``: the robot
    simulated (default :data:`DEMO_ROBOT`); ``workers``: 2 makes the video in a second process while
    validating, 1 one after the other (default :func:`default_workers`)."""
    from mjtrack.io.atomic import current as current_transaction
    from mjtrack.io.atomic import make_output_dir
    from mjtrack.io.logs import robot_path_for, write_log
    from mjtrack.io.robot import write_robot
    from mjtrack.progress import Progress
    from mjtrack.render import RenderUnavailableError
    from mjtrack.sim.config import sim_config
    from mjtrack.sim.rollout import drive_log
    from mjtrack.sim.terrain import Terrain, with_terrain
    from mjtrack.validate import validate
    from mjtrack.validate.run import N_PREDICTORS

    start = time.perf_counter()
    out = Path(out_dir)
    make_output_dir(out)
    terrain = terrain or Terrain()
    given = robot is not None
    robot = with_terrain(robot if given else DEMO_ROBOT, terrain)
    workers = default_workers() if workers is None else int(workers)
    stage_s = {}

    tic = time.perf_counter()
    commands = demo_commands(robot, duration=duration, seed=seed)
    with Progress(1, label="rollout", quiet=quiet) as bar:
        drive = drive_log(robot, commands, duration=duration, terrain=terrain,
                          config=sim_config(None, robot=robot))  # a calibrated robot's own simulator settings
        log_path = out / "rollout.csv"
        write_log(drive, log_path)
        write_robot(robot, robot_path_for(log_path))
        bar.update(note=f"{duration:g} s simulated")
    stage_s["rollout"] = time.perf_counter() - tic

    video_path, skipped, frames = out / "video.mp4", None, None
    video_args = (log_path, video_path, video_size[0], video_size[1], fps, speed)
    pending = None
    video_tic = time.perf_counter()
    if video and workers > 1:
        pending = _start_video_worker(*video_args)  # quiet: the validation's bar has the terminal
    try:
        tic = time.perf_counter()
        ground = "" if terrain.is_flat else f" on terrain {terrain.spec}"
        which = (f"the given robot on {robot.traction} (T {robot.track_gauge:g} m, {robot.mass:g} kg, "
                 f"cg_x {robot.cg_x:+g} m)" if given else f"the default robot with cg_x = +{robot.cg_x:g} m")
        source = (f"simulated log of {which}{ground}: seeded everyday manoeuvres (seed {seed}, {duration:g} s; "
                  "mjtrack demo)")
        val = validate(drive.replace(source=str(log_path)), robot, out, source=source, seed=seed, quiet=quiet)
        stage_s["validate"] = time.perf_counter() - tic
        if video:
            try:
                if pending is not None:
                    frames, stage_s["video"] = _video_result(pending)
                    tx = current_transaction()
                    if tx is not None:  # the worker wrote into its own copy of the command's transaction
                        tx.record(video_path)
                else:
                    video_tic = time.perf_counter()
                    frames, stage_s["video"] = _video_job(*video_args, quiet)
            except RenderUnavailableError as exc:
                video_path, skipped = None, str(exc)
                log.warning("video skipped: %s", exc)
                stage_s["video"] = time.perf_counter() - video_tic
        else:
            video_path = None
    finally:
        if pending is not None and pending.poll() is None:  # an error or an interrupt: stop the video
            pending.terminate()
            pending.wait()
    ran = [f"rollout: {duration:g} s of {len(commands[0])} seeded manoeuvres simulated in MuJoCo "
           f"({drive.n_samples} samples)",
           f"validate: {N_PREDICTORS} predictors (nominal, MPP, MICR, MVIR models; slip EKF, ICR EKF, VIR filter; "
           f"two oracle fits) on {len(val.results)} truths (the rollout and the MPP truth)"]
    if frames is not None:
        where = "in a second process while validating" if pending is not None else "after validating"
        ran.append(f"video: {frames} frames of {video_size[0]}x{video_size[1]} at {fps:g} frames/s "
                   f"({speed:g}x playback), rendered {where}")
    return DemoResult(out, val.report_path, val.metrics_path, log_path, video_path, val.metrics["headline"],
                      stage_s, time.perf_counter() - start, skipped, pending is not None and frames is not None,
                      tuple(ran))
