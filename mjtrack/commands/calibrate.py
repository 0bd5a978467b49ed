"""Calibrate the MuJoCo robot to a measured drive log: windows of the log (2 s by default), each
simulated from the measured state at its start (pose, body twist, track speeds; hidden states warmed
up over the log's past where its segment allows) and driven by the logged commands, first with the
robot as described, then with parameters fitted by least squares (mujoco.sysid): friction level and
left/right ratio, centre of mass, contact length, drive lag, delay and speed scale, a slope, the
ground model's parameters. What the log does not determine, and what it does not need changed,
keeps its described value and calibration.json says why (key "determined"); every interval is a
95 % interval that includes the fit simulator's own error; "causes" measures what each change
explains. When the fitted robot turns unlike the log's steady turns (yaw ratio more than 0.03 off
in a class of the training windows), the contact length, motion resistance and shear ground among
the parameters are fitted to those turns and replace the fit's values when the training part's
steady turns and end poses together speak less against that robot than against the fit's
(calibration.json "method" "turns" says what happened and why). Writes DIR/robot.json (the calibrated robot with the simulator settings of the fit, usable
with --robot by every command), DIR/calibration.json and DIR/report.html. With --test the gain is
measured on a log the fit never saw.

The robot is TRAIN.json beside the log unless --robot FILE is given. Values the description lacks
are named in calibration.json under "assumed". Bad input (a test log of another robot, a log too
short for one window, an unknown parameter or one outside its range) exits with status 2, one line,
and writes nothing.

Parameters (--params, comma separated): mu, mu_ratio (left / right friction), cg_x, cg_y,
track_length, drive_lag, drive_delay, track_speed_scale, rolling_resistance, slope_x, slope_y (sin of the slope times
the uphill direction in the log's frame), drive_force_limit, mu_left, mu_right (instead of mu and
mu_ratio); with robot key ground {"model": "anisotropic"}: lateral_ratio; with
{"model": "road_wheels"}: concentration, span; with {"model": "shear"} or the default Coulomb
ground: shear_modulus (K of the shear ground, 0 is Coulomb; a robot calibrated to K > 0 stands on
the shear ground), lateral_shear_ratio (the shear modulus across the tracks or tyres over the one
along them; 1 is isotropic; named beside shear_modulus or on a shear ground of K > 0). Default: mu, mu_ratio, cg_x, cg_y, track_length,
drive_lag, drive_delay, track_speed_scale, plus slope_x, slope_y when the log's segments share one
world frame, plus the ground model's parameters (on the shear ground: shear_modulus), plus
rolling_resistance (the ground holding each side back by a share of its weight), plus shear_modulus
for a wheeled robot on the Coulomb ground (its tyres' shear: 0 keeps it Coulomb). A long log is fitted on --fit-windows windows spread over it.
Windows the ground cannot explain are left out of the fit and of every score unless
--keep-contradicting is given: poses that move against the tracks (a jumped localisation, a speed of
the wrong sign), and a robot held still while a track runs under it (an obstacle, a rut).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from mjtrack.calibrate.rounds import MAX_ROUNDS, MAX_ROUNDS_LIMIT
from mjtrack.calibrate.run import FIT_WINDOWS
from mjtrack.commands._common import (add_output_options, add_robot_options, bounded, check_out_dir, check_overwrite,
                                      command_inputs, log_and_robot, test_log_and_robot)

OUTPUTS = ("robot.json", "calibration.json", "report.html")

HELP = "fit the MuJoCo robot to a measured log (windows from the measured state): robot.json + calibration.json + report.html"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("log", metavar="TRAIN.csv", type=Path, help="measured drive log to fit on")
    parser.add_argument("--test", metavar="TEST.csv", type=Path, default=None,
                        help="held-out log of the same robot, scored but never fitted")
    parser.add_argument("--out", metavar="DIR", type=Path, required=True, help="output folder (created if needed)")
    parser.add_argument("--params", metavar="NAMES", default=None, help="parameters to fit, comma separated")
    parser.add_argument("--horizon", metavar="S", type=bounded("horizon"), default=2.0, help="window length [s] (default 2)")
    parser.add_argument("--max-iter", metavar="N", type=bounded("iterations"), default=8, help="optimiser iterations (default 8)")
    parser.add_argument("--rounds", metavar="N", type=bounded("rounds"), default=MAX_ROUNDS,
                        help=f"at most N refits after the first fit, each after what the log determines is decided "
                             f"again (0 to {MAX_ROUNDS_LIMIT}, default {MAX_ROUNDS}); when they run out before the fit settles, the "
                             "summary names what the log points at that the fit did not reach. Each round costs "
                             "about one refit")
    parser.add_argument("--rollers", metavar="N", type=bounded("rollers"), default=None,
                        help="contact rollers per track in the simulation (default: the robot file's simulator "
                             "setting, else 10; 6 is ~2x faster); recorded in robot.json")
    parser.add_argument("--drive-input", choices=["auto", "commanded", "measured", "fitted"], default="auto",
                        help="what the simulated drives follow. auto (default): fitted when the log's measured track "
                             "speeds (not copies of the commands) show the robot's own speed controller capping the "
                             "commands (a side's speed, the turn or the mean speed saturates) and --params names "
                             "neither drive_lag nor drive_delay, else commanded. commanded: the logged commands (the "
                             "drive's lag, delay and speed scale are fitted to the poses too). fitted: the commands "
                             "through a drivetrain fitted first to the logged track speeds (speed controller limits, "
                             "ramp, per-side lag and dead time), then the contact as with measured; the calibrated "
                             "robot carries the drivetrain and is driven by its commands. measured: the logged track "
                             "speeds, for the contact alone (the contact, the speed scale, then the effective rolling "
                             "radius over the nominal one, and the drives' force limit, which bounds how fast they "
                             "follow the measured speeds, are fitted). The mode used, and why, is printed and written "
                             "to calibration.json (drive_input_mode, drive_input_why)")
    parser.add_argument("--fit-windows", metavar="N", type=bounded("fit_windows", {"all": None}), default=FIT_WINDOWS,
                        help=f"windows the fit uses, spread evenly over the log (default {FIT_WINDOWS}; 'all': every "
                             "window). The errors before and after use every window, the causes the fit's; a fit's time "
                             "grows with its windows, its intervals narrow with their square root")
    parser.add_argument("--keep-contradicting", action="store_true",
                        help="keep the windows the ground cannot explain (by default they are left out of the fit "
                             "and of every score, with a warning, and listed in calibration.json under left_out): a "
                             "body that keeps moving against its tracks without slowing down (a wrong pose or speed "
                             "record), and a body held still while a track runs at least 0.5 m under it (something the "
                             "simulation does not have holds it: an obstacle, a rut)")
    parser.add_argument("--threads", metavar="N", type=bounded("threads"), default=2, help="rollout threads (default 2)")
    add_robot_options(parser)
    add_output_options(parser)


def run(args: argparse.Namespace) -> int:
    from mjtrack.calibrate.result import write_outputs
    from mjtrack.calibrate.run import calibrate
    from mjtrack.io.robot import check_same_robot

    train, robot = log_and_robot(args)
    test, test_robot = test_log_and_robot(args.test)
    out = check_out_dir(args.out)
    check_overwrite([out / name for name in OUTPUTS], args.force, command_inputs(args))
    if test_robot is not None:
        check_same_robot(robot, test_robot, str(args.test))
    cal = calibrate(train, robot, test=test, names=args.params, horizon_s=args.horizon,
                    n_rollers=args.rollers, max_iter=args.max_iter, nthread=args.threads, quiet=args.quiet,
                    drive_input=args.drive_input, fit_windows=args.fit_windows,
                    keep_contradicting=args.keep_contradicting, rounds=args.rounds,
                    train_path=str(args.log), test_path=None if args.test is None else str(args.test))
    write_outputs(cal, out)
    changed = ", ".join(f"{n} {cal.described[n]:.4g} -> {cal.values[n]:.4g}" for n in cal.changed) or "nothing"
    kept = [n for n in cal.names if not cal.verdicts[n].changed]
    print(f"drive input: {cal.drive_input_mode} ({cal.drive_input_why})")
    print(f"changed: {changed}")
    if kept:
        undetermined = [n for n in kept if not cal.verdicts[n].determined]
        print(f"kept as described: {', '.join(kept)}"
              + (f" (not determined by this log: {', '.join(undetermined)})" if undetermined else ""))
    print(f"train {cal.horizon_s:g} s position RMSE {cal.before.rms:.3g} -> {cal.after.rms:.3g} m")
    if cal.test_before is not None:
        print(f"test  {cal.horizon_s:g} s position RMSE {cal.test_before.rms:.3g} -> {cal.test_after.rms:.3g} m (held out)")
    print(cal.sentence)
    print(f"wrote {out / 'robot.json'}, {out / 'calibration.json'} and {out / 'report.html'}")
    return 0
