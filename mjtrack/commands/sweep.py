"""Steady states over a grid of commands and robots, on a dask cluster.

GRID.json is a JSON object of lists; the sweep runs every combination (Cartesian product,
last key fastest). Commands: "v_left_cmd" and "v_right_cmd" [m/s], or "speed" [m/s] and
"turn_radius" [m] (> 0 left, < 0 right, null straight; track speeds by no-slip kinematics
V_L,R = v -/+ (v/R) T/2). Robot keys: track_gauge, track_length, track_width,
sprocket_radius, mass, cg_x, cg_y, cg_z, mu, mu_left, mu_right, drive_lag, drive_delay, drive_force_limit, track_speed_scale
(on top of the robot options).
Example: {"speed": [0.5, 1.0], "turn_radius": [0.5, 1, 2, 4], "mu": [0.4, 0.8]}.

Every case runs on the --terrain ground (default flat). Each case is held for --settle seconds, then averaged over --window seconds, exactly as
`mjtrack steady` does. Writes DIR/sweep.csv (one row per case: case index, grid values,
v_left_cmd, v_right_cmd, measured v_left, v_right, vx, vy, wz, ..., y_l, y_r, x_c, ...; an
empty cell where an ICR is undefined because the robot does not turn), DIR/sweep.json (the
same rows, null for undefined) and DIR/icr_map.png, all three at the end. Rows are appended
to DIR/sweep.partial.csv as cases finish (settings in DIR/sweep.partial.json): run the same
command again after an interruption and only the missing cases run; the partial files go when
the outputs are written. Existing outputs are replaced only with --force (which also starts
over from a partial sweep of other settings). The numbers do not depend on the number of
workers.
"""

from __future__ import annotations

import argparse

from mjtrack.commands._common import (add_output_options, add_robot_options, add_terrain_option, bounded, check_out_dir,
                                      check_overwrite, command_inputs, robot_from_args, terrain_from_args)

ON_INTERRUPT = "the finished cases are kept: run the same command again to resume"
HELP = "steady states over a grid of commands and robots on a dask cluster: sweep.csv, sweep.json, icr_map.png"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--grid", metavar="GRID.json", required=True, help="the grid (see above)")
    parser.add_argument("--out", metavar="DIR", required=True,
                        help="output folder (created; resumed if it holds a sweep.partial.csv)")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--workers", metavar="N", type=bounded("workers"), default=None,
                       help="start a local dask cluster of N worker processes, one thread each (default: CPU count)")
    where.add_argument("--scheduler", metavar="ADDRESS", default=None,
                       help="run on an existing dask cluster, e.g. tcp://10.0.0.5:8786")
    parser.add_argument("--settle", metavar="S", type=bounded("settle"), default=3.0, help="transient time [s] (default 3)")
    parser.add_argument("--window", metavar="S", type=bounded("window"), default=2.0, help="averaging window [s] (default 2)")
    parser.add_argument("--track-model", choices=["rollers", "surfacevel"], default=None,
                        help="MuJoCo track model: sprung roller chain or surfacevel row (default: the robot file's "
                             "simulator.track_model, else rollers)")
    add_terrain_option(parser, scenarios=False)
    add_robot_options(parser)
    add_output_options(parser)


def run(args: argparse.Namespace) -> int:
    from mjtrack.sweep import read_grid, run_sweep
    from mjtrack.sweep.run import OUTPUTS

    base = robot_from_args(args)
    track_model = sweep_track_model(base, args.track_model)
    grid = read_grid(args.grid, base=base)
    out = check_out_dir(args.out)
    check_overwrite([out / name for name in OUTPUTS], args.force, command_inputs(args))
    s = run_sweep(grid, out, workers=args.workers, scheduler=args.scheduler, track_model=track_model,
                  settle_s=args.settle, window_s=args.window, terrain=terrain_from_args(args), quiet=args.quiet,
                  restart=args.force)
    resumed = f", {s.resumed} kept from an earlier run" if s.resumed else ""
    print(f"{s.cases} cases ({s.ran} run on {s.workers} workers in {s.seconds:.1f} s{resumed}): {out}/sweep.csv, "
          f"sweep.json, icr_map.png")
    return 0


def sweep_track_model(robot, given: str | None) -> str:
    """The track model a sweep runs: ``--track-model``, else the robot file's ``simulator.track_model``,
    else rollers. A recorded time step or roller count is refused: a sweep runs each case at the
    step steady picks for it, the same for every robot of the grid, so that its rows compare."""
    from mjtrack.errors import InputError
    from mjtrack.sim.config import robot_sim_settings

    settings = robot_sim_settings(robot)
    fixed = sorted(set(settings) & {"timestep", "n_rollers"})
    if fixed:
        raise InputError(f"the robot's simulator settings {', '.join(fixed)} are not used by sweep (each case runs at "
                         "the step steady picks for it, for every robot of the grid alike): remove them from the "
                         "robot file's 'simulator', or run mjtrack steady, which uses them")
    return given or settings.get("track_model", "rollers")
