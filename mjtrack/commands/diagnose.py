"""Diagnose a measured drive log: where the nominal model departs from the measurement, the cause
(an effect of the vocabulary, named as the robot file names its quantity -- cg_x, cg_y,
friction_scale, mu_ratio, track_speed_scale, drive_lag, drive_delay, drive_speed_limit, slope,
icr_spread, drive_turn_limit, drive_accel_limit, and with the MuJoCo baseline ground_anisotropy,
road_wheels, track_length or wheelbase, rolling_resistance, drive_force_limit, shear_modulus (by default on a
robot of the shear ground, named with --effects on another), lateral_shear_ratio (named with --effects) --
or "none"), its estimate with an
interval and the prediction error it removes on held-out data. Writes DIR/diagnosis.json and DIR/report.html.

The robot is LOG.json beside the log unless --robot FILE is given; the other robot options
override single fields. With --confirm the cause is checked in MuJoCo: the log re-simulated
with the MuJoCo robot, nominal and extended by the cause. With --test LOG2 the model is fitted on
LOG and scored on LOG2 (same robot; LOG2.json, when it exists, must describe the same robot).
Effects are found by forward selection (several at once when the data show them); the verdict
flags effects the log cannot tell apart and error that stays unexplained. On a terminal (unless
-q) a bar shows the candidates scored and the time left; with the MuJoCo baseline each step
first says how many windows it will simulate and about how long that takes. Bad input (log,
robot, options) exits with status 2, one line, and writes nothing.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mjtrack.commands._common import (add_output_options, add_robot_options, bounded, check_out_dir, check_overwrite,
                                      command_inputs, log_and_robot, test_log_and_robot)

HELP = "what the nominal model gets wrong on a measured log, the cause and its gain: report.html + diagnosis.json"


def _horizon(text: str):
    return "auto" if text == "auto" else bounded("horizon")(text)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("log", metavar="LOG.csv", type=Path,
                        help="measured drive log (CSV with columns t [s], v_left_cmd, v_right_cmd [m/s], x, y [m], "
                             "yaw [rad]; optional v_left, v_right, vx, vy, wz, window)")
    parser.add_argument("--out", metavar="DIR", type=Path, required=True, help="output folder (created if needed)")
    parser.add_argument("--horizon", metavar="S", type=_horizon, default="auto",
                        help="prediction horizon of the windows [s], or 'auto' (default): 2 s, or the longest the "
                             "log's segments allow (3/4 of the median segment) when they are shorter, with a note")
    parser.add_argument("--folds", metavar="K", type=bounded("folds"), default=5,
                        help="cross-validation folds, at most half the log's samples (default 5)")
    parser.add_argument("--confirm", action="store_true",
                        help="re-simulate the log with the MuJoCo robot, nominal and extended by the cause "
                             "(surrogate and kinematic baselines; the mujoco baseline is MuJoCo throughout)")
    # the names of mjtrack.diagnose.run.BASELINES (which validates them again), spelled here so that
    # building the parser does not import the diagnosis (scipy) for every command
    parser.add_argument("--baseline", choices=("auto", "mujoco", "surrogate", "kinematic"), default="auto",
                        help="what is diagnosed: 'mujoco' (the MuJoCo robot itself: windows simulated from the "
                             "measured state, every candidate effect an extension of the MuJoCo robot, gains measured "
                             "by MuJoCo on held-out windows; needs track_length in the robot file, e.g. a robot.json "
                             "from 'mjtrack calibrate'), 'surrogate' (the rigid-track Coulomb surrogate of the robot, "
                             "or the kinematic model when the description lacks the contact length), 'kinematic' (the "
                             "kinematic skid-steer model), 'auto' (default: mujoco when the robot can be built, else "
                             "surrogate; diagnosis.json and the report say which it chose and why)")
    parser.add_argument("--drive-input", choices=["commanded", "measured"], default=None,
                        help="with the mujoco baseline, the simulated drives follow the logged commands or the "
                             "measured track speeds (v_left, v_right; for robots whose own speed controller does not "
                             "do what it is commanded). Default: what the robot file says (simulator.drive_input, "
                             "which 'mjtrack calibrate --drive-input measured' writes), else the commands")
    parser.add_argument("--test", metavar="LOG2", type=Path, default=None,
                        help="fit on LOG, score on LOG2 (a log of the same robot) instead of cross-validating")
    add_robot_options(parser)
    add_output_options(parser)


def run(args: argparse.Namespace) -> int:
    from mjtrack.diagnose import diagnose, write_outputs

    drive_log, robot = log_and_robot(args)
    test_log, test_robot = test_log_and_robot(args.test)
    out = check_out_dir(args.out)
    check_overwrite([out / "diagnosis.json", out / "report.html"], args.force, command_inputs(args))
    result = diagnose(drive_log, robot, horizon_s=args.horizon, n_folds=args.folds, confirm=args.confirm,
                      quiet=args.quiet, baseline=args.baseline, test_log=test_log, test_robot=test_robot,
                      drive_input=args.drive_input)
    write_outputs(result, out)
    print(result.summary())
    conf = result.confirmation
    if conf is not None:
        print(f"MuJoCo: {conf['before']:.3g} -> {conf['after']:.3g} m" if conf.get("run") else f"MuJoCo: not run ({conf['why']})")
    print(f"wrote {out / 'diagnosis.json'} and {out / 'report.html'}", file=sys.stdout)
    return 0
