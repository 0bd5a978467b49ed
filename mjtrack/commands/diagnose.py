"""Diagnose a measured drive log: where the nominal model departs from the measurement, the cause
(one of the effects cg_offset_x, cg_offset_y, friction_scale, friction_asymmetry,
track_speed_scale, actuator_lag, command_delay, speed_limit, slope, or "none"), its estimate with an interval and the
prediction error it removes on held-out data. Writes DIR/diagnosis.json and DIR/report.html.

The robot is LOG.json beside the log unless --robot FILE is given; the other robot options
override single fields. With --confirm the cause is checked in MuJoCo: the log re-simulated
with the MuJoCo robot, nominal and extended by the cause. Bad input (log, robot, options) exits with status 2, one line, and
writes nothing.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mjtrack.commands._common import (add_output_options, add_robot_options, check_out_dir, finite_float, int_at_least,
                                      robot_from_args)
from mjtrack.errors import InputError

HELP = "what the nominal model gets wrong on a measured log, the cause and its gain: report.html + diagnosis.json"


def _positive(text: str) -> float:
    value = finite_float(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text!r}")
    return value


_folds = int_at_least(3)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("log", metavar="LOG.csv", type=Path,
                        help="measured drive log (CSV with columns t [s], v_left_cmd, v_right_cmd [m/s], x, y [m], "
                             "yaw [rad]; optional v_left, v_right, vx, vy, wz, window)")
    parser.add_argument("--out", metavar="DIR", type=Path, required=True, help="output folder (created if needed)")
    parser.add_argument("--horizon", metavar="S", type=_positive, default=2.0,
                        help="prediction horizon of the windows [s] (default 2)")
    parser.add_argument("--folds", metavar="K", type=_folds, default=5, help="cross-validation folds (default 5)")
    parser.add_argument("--confirm", action="store_true",
                        help="re-simulate the log with the MuJoCo robot, nominal and extended by the cause")
    add_robot_options(parser)
    add_output_options(parser)


def run(args: argparse.Namespace) -> int:
    from mjtrack.diagnose import diagnose, write_outputs
    from mjtrack.io.logs import read_log, robot_path_for
    from mjtrack.io.robot import read_robot

    out = check_out_dir(args.out)
    drive_log = read_log(args.log)
    base = None
    if args.robot is None:
        path = robot_path_for(args.log)
        if not path.exists():
            raise InputError(f"{args.log}: no robot description: {path} does not exist and no --robot FILE was given "
                             "(a robot JSON with at least 'track_gauge' is required)")
        base = read_robot(path)
    robot = robot_from_args(args, base)
    result = diagnose(drive_log, robot, horizon_s=args.horizon, n_folds=args.folds, confirm=args.confirm,
                      quiet=args.quiet)
    write_outputs(result, out)
    best = result.findings[0] if result.findings else None
    line = f"cause: {result.cause}"
    if best is not None:
        est = ", ".join(f"{n} = {v:.4g}" for n, v in zip(best.effect.params, best.estimate))
        line += f" ({est}); held-out {result.horizon_s:g} s position RMSE {best.before:.3g} -> {best.after:.3g} m"
    else:
        line += f"; nominal {result.horizon_s:g} s position RMSE {result.before:.3g} m"
    print(line)
    conf = result.confirmation
    if conf is not None:
        print(f"MuJoCo: {conf['before']:.3g} -> {conf['after']:.3g} m" if conf.get("run") else f"MuJoCo: not run ({conf['why']})")
    print(f"wrote {out / 'diagnosis.json'} and {out / 'report.html'}", file=sys.stdout)
    return 0
