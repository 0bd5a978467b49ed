"""Calibrate the MuJoCo robot to a measured drive log: windows of the log (2 s by default), each
simulated from the measured state at its start (pose, body twist, track speeds) and driven by the
logged commands, first with the robot as described, then with parameters fitted by least squares
(mujoco.sysid) -- friction, centre of mass, contact length, drivetrain lag / delay / speed scale /
force limit, the ground model's parameters. Writes DIR/robot.json (the calibrated robot, usable
with --robot by every command), DIR/calibration.json (parameters, intervals, fixed and assumed
values, errors before/after on the training and test logs, yaw ratio and ICR findings) and
DIR/report.html. With --test the gain is measured on a log the fit never saw.

The robot is TRAIN.json beside the log unless --robot FILE is given. Values the description lacks
are named in calibration.json under "assumed" (a missing track_length is fitted). Bad input (a test
log of another robot, a log too short for one window, an unknown parameter or one outside its
range) exits with status 2, one line, and writes nothing.

Parameters (--params, comma separated): mu, mu_left, mu_right, cg_x, cg_y, track_length,
drive_lag, drive_delay, track_speed_scale, drive_force_limit; with robot key ground
{"model": "anisotropic"}: lateral_ratio; with {"model": "road_wheels"}: concentration, span.
Default: mu, cg_x, cg_y, drive_lag, drive_delay, track_speed_scale, plus track_length when the
robot file lacks it, plus the ground model's parameters.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from mjtrack.commands._common import (add_output_options, add_robot_options, bounded, check_out_dir, check_overwrite,
                                      log_and_robot, test_log_and_robot)

OUTPUTS = ("robot.json", "calibration.json", "report.html")
HELP = "fit the MuJoCo robot to a measured log (windows from the measured state): robot.json + calibration.json + report.html"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("log", metavar="TRAIN.csv", type=Path, help="measured drive log to fit on")
    parser.add_argument("--test", metavar="TEST.csv", type=Path, default=None,
                        help="held-out log of the same robot, scored but never fitted")
    parser.add_argument("--out", metavar="DIR", type=Path, required=True, help="output folder (created if needed)")
    parser.add_argument("--track-model", choices=("rollers", "surfacevel"), default="rollers",
                        help="MuJoCo track model (windows need rollers: surfacevel is refused)")
    parser.add_argument("--params", metavar="NAMES", default=None, help="parameters to fit, comma separated")
    parser.add_argument("--horizon", metavar="S", type=bounded("horizon"), default=2.0, help="window length [s] (default 2)")
    parser.add_argument("--max-iter", metavar="N", type=bounded("iterations"), default=8, help="optimiser iterations (default 8)")
    parser.add_argument("--rollers", metavar="N", type=bounded("rollers"), default=None,
                        help="contact rollers per track in the simulation (default 10; 6 is ~2x faster)")
    parser.add_argument("--threads", metavar="N", type=bounded("threads"), default=2, help="rollout threads (default 2)")
    add_robot_options(parser)
    add_output_options(parser)


def run(args: argparse.Namespace) -> int:
    from mjtrack.calibrate.run import calibrate, check_same_robot, write_outputs

    out = check_out_dir(args.out)
    check_overwrite([out / name for name in OUTPUTS], args.force)
    train, robot = log_and_robot(args)
    test, test_robot = test_log_and_robot(args.test)
    if test_robot is not None:
        check_same_robot(robot, test_robot, str(args.test))
    cal = calibrate(train, robot, test=test, track_model=args.track_model, names=args.params, horizon_s=args.horizon,
                    n_rollers=args.rollers, max_iter=args.max_iter, nthread=args.threads, quiet=args.quiet,
                    train_path=str(args.log), test_path=None if args.test is None else str(args.test))
    write_outputs(cal, out)
    vals = ", ".join(f"{n} = {cal.fit.values[n]:.4g}" for n in cal.names)
    print(f"fitted: {vals}")
    print(f"train {cal.horizon_s:g} s position RMSE {cal.before.rms:.3g} -> {cal.after.rms:.3g} m")
    if cal.test_before is not None:
        print(f"test  {cal.horizon_s:g} s position RMSE {cal.test_before.rms:.3g} -> {cal.test_after.rms:.3g} m (held out)")
    print(cal.sentence)
    print(f"wrote {out / 'robot.json'}, {out / 'calibration.json'} and {out / 'report.html'}")
    return 0
