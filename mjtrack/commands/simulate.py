"""Headless MuJoCo rollout of the tracked robot: writes a drive log and its robot description.

Drives the roller-chain robot (mjtrack.sim) with a built-in scenario (--scenario, listed below)
or a command CSV (columns t, v_left_cmd, v_right_cmd; each command
held until the next) and writes LOG.csv (columns t [s], v_left_cmd, v_right_cmd [m/s], x, y [m],
yaw [rad], v_left, v_right, vx, vy [m/s], wz [rad/s]; z [m], roll, pitch [rad] on terrain other
than flat) and LOG.json (the robot used, the terrain under key "terrain" when it is not flat, and
the measurement noise under key "noise" when --noise adds some). The same arguments and seed give
a byte-identical log, noise included.

A robot file's simulator settings (simulator.track_model, n_rollers, timestep: what a calibrated
robot was fitted with) are used; --track-model and --timestep override them. Its
simulator.drive_input 'measured' is noted and not used: a simulated run has no logged track
speeds to follow, so the tracks are driven from the commands.

Time step of the roller chain (without --timestep, nor one in the robot file): 5 ms (smaller on terrain edges), the step at
which calibrate and diagnose simulate a log's windows. With fast commands on short tracks a turn's
x_c (where the tracks slip only along themselves) then sits about v dt behind the rigid-track
Coulomb reference, because MuJoCo's friction opposes the slip one step ahead (`steady` shortens
its step for that): --timestep S with v_max S <= 0.01 L removes it.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mjtrack.commands._common import (add_output_options, add_robot_options, add_terrain_option, bounded,
                                      check_out_file, check_overwrite, command_inputs, robot_from_args, scenario_help,
                                      terrain_from_args)

HELP = "headless MuJoCo rollout: scenario or command CSV -> drive log CSV + robot JSON"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from mjtrack.sim.scenarios import SCENARIOS

    src = parser.add_mutually_exclusive_group(required=True)
    src.add_argument("--scenario", choices=list(SCENARIOS), help=scenario_help("a built-in scenario"))
    src.add_argument("--commands", metavar="CSV", type=Path, help="command table: t, v_left_cmd, v_right_cmd")
    parser.add_argument("--duration", metavar="S", type=bounded("duration"), default=None,
                        help="simulated time [s] (default: the scenario's; the last command time + 1 s for a CSV)")
    parser.add_argument("--seed", type=bounded("seed"), default=0,
                        help="seed of random scenarios and of the measurement noise (default 0)")
    parser.add_argument("--noise", metavar="SPEC", default=None,
                        help="measurement noise added to the log: a preset (none, realistic: the level of the real "
                             "Marmotte, Husky and Warthog logs), then name=value standard deviations that replace "
                             "the preset's (pose_std [m] on x, y; yaw_std [rad]; track_speed_std [m/s] on v_left, "
                             "v_right; velocity_std [m/s] on vx, vy; yaw_rate_std [rad/s] on wz), e.g. "
                             "'realistic,yaw_std=0.01' or 'pose_std=0.02'; recorded in LOG.json under 'noise' "
                             "(default none)")
    parser.add_argument("--log-rate", metavar="HZ", type=bounded("log_rate"), default=50.0,
                        help="log sample rate [Hz], a divisor of the simulation rate (default 50)")
    parser.add_argument("--timestep", metavar="S", type=bounded("timestep"), default=None,
                        help="simulation time step [s] (default 5 ms; see above for fast commands on short tracks)")
    parser.add_argument("--track-model", choices=["rollers", "surfacevel"], default=None,
                        help="MuJoCo track model: sprung roller chain or surfacevel row (default: the robot file's "
                             "simulator.track_model, else rollers)")
    parser.add_argument("--out", metavar="LOG.csv", type=Path, required=True, help="output drive log")
    add_robot_options(parser)
    add_terrain_option(parser)
    add_output_options(parser)


def run(args: argparse.Namespace) -> int:
    from mjtrack.io.logs import robot_path_for, write_log
    from mjtrack.io.robot import write_robot
    from mjtrack.sim.config import robot_sim_settings, sim_config
    from mjtrack.sim.noise import add_noise, log_noise, with_noise_record
    from mjtrack.sim.rollout import drive_log
    from mjtrack.sim.scenarios import read_commands, scenario_commands
    from mjtrack.sim.terrain import with_terrain

    robot = robot_from_args(args)  # an error in the robot file before a clash of output names
    terrain = terrain_from_args(args, args.scenario)
    noise = log_noise(args.noise)
    inputs = command_inputs(args)
    out = check_out_file(args.out, suffixes=(".csv",), inputs=inputs)
    check_overwrite([out, robot_path_for(out)], args.force, inputs)
    config = sim_config(args.track_model, timestep=args.timestep, robot=robot)
    if robot_sim_settings(robot).get("drive_input") == "measured":
        # a simulated run has no logged track speeds to follow: say so rather than drop the key silently
        print("note: the robot file's simulator.drive_input 'measured' applies to logged runs (calibrate, "
              "diagnose); simulate drives the tracks from the commands", file=sys.stderr)
    if args.scenario:
        table, duration = scenario_commands(args.scenario, robot, duration=args.duration, seed=args.seed)
    else:
        table = read_commands(args.commands)
        duration = args.duration if args.duration is not None else float(table[0][-1]) + 1.0
    log = add_noise(drive_log(robot, table, duration=duration, config=config, log_rate=args.log_rate,
                              terrain=terrain), noise, seed=args.seed)
    write_log(log, out)
    write_robot(with_noise_record(with_terrain(robot, terrain), noise, seed=args.seed), robot_path_for(out))
    if not args.quiet:
        print(f"wrote {out} ({len(log.t)} samples, {duration:g} s) and {robot_path_for(out)}")
    return 0
