"""Offscreen MuJoCo video of a drive log (or of a scenario rollout), no display needed.

The robot is placed at the log's poses (any log: simulated or measured), the camera follows
it, its path is trailed on the ground and the log's own ICRs of the left track, right track
and body (from its body twist and track speeds) are drawn on the ground while it turns, in
three colours that a legend in the top-right corner names. Each track is drawn as a belt whose
grousers advance with the log's track speeds (measured where logged, else commanded); every
frame shows the time and the playback speed. A log simulated on terrain (recorded in its
JSON) is shown on that terrain at the logged height, roll and pitch. A log with several
segments plays them one after the other. --gif FILE.gif also writes an animated top view of
the true path and the open-loop paths of the nominal model and of the models whose
parameters the filters estimate online (first segment).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from mjtrack.commands._common import (OPTION_BOUNDS, add_output_options, bounded, check_out_file, check_overwrite,
                                      check_robot_file, command_inputs)
from mjtrack.commands.validate import add_source_arguments, source_from_args

HELP = "offscreen MuJoCo video (MP4) of a log or scenario, with path trail and ICRs; optional GIF of model paths"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_source_arguments(parser)
    parser.add_argument("--out", metavar="FILE.mp4", type=Path, required=True, help="output video")
    parser.add_argument("--width", type=bounded("width"), default=640,
                        help=f"frame width [px], even, in {OPTION_BOUNDS['width'].text()} (default 640)")
    parser.add_argument("--height", type=bounded("height"), default=480,
                        help=f"frame height [px], even, in {OPTION_BOUNDS['height'].text()} (default 480)")
    parser.add_argument("--fps", type=bounded("fps"), default=30.0, help="frames per second (default 30)")
    parser.add_argument("--speed", type=bounded("playback"), default=1.0,
                        help="playback speed, 1 = real time, 2 = twice as fast; shown on every frame (default 1)")
    parser.add_argument("--gif", metavar="FILE.gif", type=Path, default=None,
                        help="also write an animated plot of the true and model paths")
    add_output_options(parser)


def run(args: argparse.Namespace) -> int:
    from mjtrack.validate.video import animate_log, render_log

    check_robot_file(args)
    inputs = command_inputs(args)
    out = check_out_file(args.out, suffixes=(".mp4",), inputs=inputs)
    gif = check_out_file(args.gif, suffixes=(".gif",), inputs=inputs) if args.gif else None
    check_overwrite([out, *([gif] if gif else [])], args.force, inputs)
    from mjtrack.render.video import check_frames

    def frames(duration: float) -> None:  # a video too long is refused before the scenario is simulated
        check_frames([[0.0, duration]], fps=args.fps, speed=args.speed)

    drive, robot, _, _ = source_from_args(args, before_rollout=frames)
    stats = render_log(drive, robot, out, width=args.width, height=args.height, fps=args.fps, speed=args.speed,
                       quiet=args.quiet)
    print(f"wrote {out} ({stats.frames} frames, {stats.duration:.1f} s, {stats.width}x{stats.height})")
    if gif is not None:
        animate_log(drive, robot, gif, seed=args.seed, speed=args.speed)
        print(f"wrote {gif}")
    return 0
