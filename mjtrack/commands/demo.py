"""The main job on built-in defaults, end to end (15 to 90 seconds on 2 cores, depending on
their load: benchmarks/bench_demo.py).

A simulated log of the default robot with its centre of gravity 5 cm ahead of the geometric
centre (cg_x = +0.05 m) driving seeded everyday manoeuvres; its ICRs; the nominal, MPP, MICR
and MVIR models with their filters validated against the rollout and against an MPP
analytic truth; DIR/report.html, DIR/metrics.json, DIR/video.mp4, and the rollout itself
(DIR/rollout.csv + rollout.json, for mjtrack validate / render). --terrain runs the same
manoeuvres on sloped, stepped, rough or patchy ground (recorded in rollout.json; the video shows it);
--robot FILE (and the robot options, on top of the default robot without it) another robot, tracked
or wheeled.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from mjtrack.commands._common import (ROBOT_OPTIONS, TERRAIN_HELP, add_output_options, add_robot_options,
                                      check_out_dir, check_overwrite, command_inputs, robot_from_args, terrain_from_args)

OUTPUTS = ("report.html", "metrics.json", "rollout.csv", "rollout.json", "video.mp4")

HELP = "the main job on defaults: a simulated log, all models and filters validated, report, video"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", metavar="DIR", type=Path, required=True,
                        help="output folder (created if missing)")
    parser.add_argument("--no-video", action="store_true", help="skip the video")
    parser.add_argument("--terrain", metavar="SPEC", default=None, help=TERRAIN_HELP + " (default flat)")
    add_robot_options(parser)
    add_output_options(parser)


def run(args: argparse.Namespace) -> int:
    from mjtrack.demo import DEMO_ROBOT, run_demo

    given = args.robot is not None or any(getattr(args, k, None) is not None for k in ROBOT_OPTIONS)
    robot = robot_from_args(args, DEMO_ROBOT) if given else None  # robot file errors before name clashes
    out = check_out_dir(args.out)
    check_overwrite([out / name for name in OUTPUTS], args.force, command_inputs(args))
    res = run_demo(out, video=not args.no_video, quiet=args.quiet, terrain=terrain_from_args(args), robot=robot)
    head = res.headline
    if not args.quiet:
        for line in res.ran:
            print(f"ran {line}")
        for truth, table in head["pos_rmse_m"].items():
            row = ", ".join(f"{k} {v:.3g}" if v is not None else f"{k} failed" for k, v in table.items())
            print(f"{head['horizon_s']:g}-s position RMSE [m] on the {'MPP truth' if truth == 'mpp' else 'simulated log'}: {row}")
    print(f"report:  {res.report}")
    print(f"metrics: {res.metrics}")
    print(f"rollout: {res.log} (robot: {res.log.with_suffix('.json').name})")
    if res.video is not None:
        print(f"video:   {res.video}")
    elif res.video_skipped:
        print(f"video:   skipped ({res.video_skipped})")
    print(f"done in {res.wall_s:.0f} s")
    return 0
