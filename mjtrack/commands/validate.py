"""Model-vs-physics validation of the kinematic models and their filters.

Input: a drive log (LOG.csv, with LOG.json or --robot for the robot) or a simulated log of a
built-in scenario (--scenario NAME, robot options, --duration, --seed). For each kinematic
model (nominal, MPP, MICR, MVIR) with parameters from the filters run online on the log
(slip EKF -> MPP, improved ICR EKF -> MICR, improved VIR filter -> MVIR) and from the log's
own ICRs (from its body twist and track speeds) as an upper bound, it scores predictions over
0.5, 1, 2 and 5 s against the log and against an MPP analytic truth with known slips (section 4.2 of [Mendaluk]) on the same commands.
The filters see seeded Gaussian measurement noise (--noise-scale, 0 = none); errors are
scored against the noise-free truth. The filters adapt their process noise (a slow and a fast
random walk of their parameters), carry their parameters across the windows of a log (only
the pose restarts), and on a log read from a file take its measurement noise estimated from the log.
Writes DIR/report.html (self-contained: verdicts, setup, definitions, figures, filter
consistency with NIS over time) and DIR/metrics.json (the same numbers; per filter and truth
consistency: nis_mean, nis_dof, nees_mean (null on a log read from a file), nees_dof, band95).
On a wheeled robot (robot key traction: "wheels") it also scores the four models of the wheeled-robot thesis [Jonszta] (docs: references)
on the log: the kinematic differential drive and the four-wheel skid steer driven by the
wheel speeds, dynamic models 1 and 2 by the commanded wheel speeds (their own regulator), each
from the logged state at every window start; metrics.json gets the median and worst position and
heading error per model and horizon and the best model per horizon (wheeled_models), the report a
table and an error-against-horizon figure. Parameters missing from the description (yaw
inertia, drive, friction slope) are stated in both.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from mjtrack.commands._common import (add_output_options, add_robot_options, add_terrain_option, bounded, check_out_dir,
                                      check_overwrite, check_robot_file, command_inputs, robot_config, robot_from_args, scenario_help, terrain_from_args)
from mjtrack.errors import InputError

HELP = "model-vs-physics validation of the kinematic models and filters: report.html + metrics.json"


def add_source_arguments(parser: argparse.ArgumentParser) -> None:
    """``LOG.csv | --scenario NAME`` with ``--duration``, ``--seed`` and the robot options."""
    from mjtrack.sim.scenarios import SCENARIOS

    parser.add_argument("log", metavar="LOG.csv", type=Path, nargs="?", default=None,
                        help="drive log (CSV: t, v_left_cmd, v_right_cmd, x, y, yaw, ...); its robot is LOG.json "
                             "beside it or --robot FILE")
    parser.add_argument("--scenario", choices=list(SCENARIOS), default=None,
                        help=scenario_help("instead of a log: a simulated log of a built-in scenario"))
    parser.add_argument("--duration", metavar="S", type=bounded("duration"), default=None,
                        help="scenario duration [s] (default: the scenario's)")
    parser.add_argument("--seed", type=bounded("seed"), default=0,
                        help="seed of random scenarios and of the noise (default 0)")
    add_robot_options(parser)
    add_terrain_option(parser)


def source_from_args(args: argparse.Namespace, *, before_rollout=None):
    """(DriveLog, Robot, words, truth title) from ``LOG.csv`` or ``--scenario``; bad combinations raise InputError.

    ``before_rollout(duration)``: called with a scenario's duration [s] before it is simulated
    (a caller's own work estimate, so that it refuses before the rollout is spent)."""
    from mjtrack.io.logs import read_log, robot_path_for
    from mjtrack.io.robot import read_robot

    if (args.log is None) == (args.scenario is None):
        raise InputError("give either LOG.csv or --scenario NAME (exactly one)")
    if args.scenario is not None:
        from mjtrack.sim.rollout import drive_log
        from mjtrack.sim.scenarios import scenario_commands

        robot = robot_from_args(args)
        table, duration = scenario_commands(args.scenario, robot, duration=args.duration, seed=args.seed)
        words = f"simulated log of the scenario '{args.scenario}' ({duration:g} s, seed {args.seed})"
        terrain = terrain_from_args(args, args.scenario)
        if before_rollout is not None:
            before_rollout(duration)
        if not terrain.is_flat:
            words += f" on terrain {terrain.spec}"
        return (drive_log(robot, table, duration=duration, terrain=terrain, config=robot_config(robot)), robot, words,
                SIMULATED)
    if args.duration is not None:
        raise InputError("--duration applies to --scenario only, not to a log")
    if getattr(args, "terrain", None) is not None:
        raise InputError("--terrain applies to --scenario only (a log was driven on its own terrain)")
    drive = read_log(args.log)
    json_path = robot_path_for(args.log)
    base = read_robot(json_path) if json_path.exists() else None
    if base is None and args.robot is None and args.track_gauge is None:
        raise InputError(f"{args.log}: no robot description: {json_path} does not exist and neither --robot FILE "
                         "nor --track-gauge was given")
    return drive, robot_from_args(args, base=base), f"drive log {args.log}", LOGGED


# the log as a truth in the report: one word for a log simulated here, one for a log read from a
# file (a real robot's, or a simulated one with noise added: either way its own noise is estimated)
SIMULATED, LOGGED = "simulated log", "logged motion"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_source_arguments(parser)
    parser.add_argument("--speeds", choices=["auto", "measured", "cmd"], default="auto",
                        help="track speeds that drive the models: measured (logged v_left, v_right), commanded, "
                             "or auto = measured when the log has them (default)")
    parser.add_argument("--noise-scale", metavar="X", type=bounded("noise_scale"), default=1.0,
                        help="scale of the seeded measurement noise given to the filters (1 = σ 1 cm, 0.5°, "
                             "0.02 m/s, 0.01 rad/s; 0 = none; default 1)")
    parser.add_argument("--out", metavar="DIR", type=Path, required=True,
                        help="output folder for report.html and metrics.json (created if missing)")
    add_output_options(parser)


def run(args: argparse.Namespace) -> int:
    from mjtrack.validate import Noise, validate
    from mjtrack.validate.run import METRICS_NAME, REPORT_NAME

    check_robot_file(args)
    out = check_out_dir(args.out)
    check_overwrite([out / REPORT_NAME, out / METRICS_NAME], args.force, command_inputs(args))
    noise = Noise(scale=args.noise_scale)
    drive, robot, words, title = source_from_args(args)
    val = validate(drive, robot, out, source=words, truth_title=title, noise=noise, seed=args.seed, speeds=args.speeds,
                   quiet=args.quiet, log_noise_free=title == SIMULATED)
    if not args.quiet:
        head = val.metrics["headline"]
        for truth, table in head["pos_rmse_m"].items():
            row = ", ".join(f"{k} {v:.3g}" if v is not None else f"{k} failed" for k, v in table.items())
            print(f"{head['horizon_s']:g}-s position RMSE [m] on the {'MPP truth' if truth == 'mpp' else title}: {row}")
    print(f"wrote {val.report_path} and {val.metrics_path}")
    return 0
