"""Steady-state twist and ICRs of the MuJoCo robot under constant track speeds.

Holds (V_L, V_R) for --settle seconds, then averages the body twist and the measured track
speeds over --window seconds; ICRs from the means (null when driving straight).
Prints JSON: vx, vy, wz, y_l, y_r, x_c plus the window standard deviations, the measured
track speeds and the ground-contact fractions of each track.

Time step of the roller chain: 5 ms, divided by the smallest integer k that keeps
max|V| dt <= 0.01 L (MuJoCo's friction opposes the slip one step ahead, which puts a turn's x_c
about v dt behind the rigid-track Coulomb reference): a 0.5 m track runs at 5 ms up to 1 m/s, a
0.18 m one at 2 m/s at 0.83 ms; and that keeps mu g dt <= 5 |w| L/2, w the commanded turn rate
(so that one step's friction does not overshoot the slip of a gentle turn; at most 8 divisions,
a gentler turn runs at 0.625 ms with a warning): a 5 kg robot with a 0.18 m track at
R 10 m and 0.2 m/s runs at 1 ms.
"""

from __future__ import annotations

import argparse
import json

from mjtrack.commands._common import add_robot_options, add_terrain_option, bounded, robot_from_args, terrain_from_args

HELP = "steady-state twist and ICRs of the MuJoCo robot under constant track speeds (JSON)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--v-left", metavar="A", type=bounded("speed"), required=True, help="left track speed [m/s]")
    parser.add_argument("--v-right", metavar="B", type=bounded("speed"), required=True, help="right track speed [m/s]")
    parser.add_argument("--settle", metavar="S", type=bounded("settle"), default=3.0, help="transient time [s] (default 3)")
    parser.add_argument("--window", metavar="S", type=bounded("window"), default=2.0, help="averaging window [s] (default 2)")
    parser.add_argument("--track-model", choices=["rollers", "surfacevel"], default="rollers",
                        help="MuJoCo track model: sprung roller chain (default) or surfacevel row")
    parser.add_argument("--json", action="store_true", help="print JSON (the only output format; accepted for clarity)")
    add_robot_options(parser)
    add_terrain_option(parser, scenarios=False)


def run(args: argparse.Namespace) -> int:
    from mjtrack.sim.config import sim_config
    from mjtrack.sim.steady import steady_state

    robot = robot_from_args(args)
    result = steady_state(robot, args.v_left, args.v_right, config=sim_config(args.track_model),
                          settle_s=args.settle, window_s=args.window, terrain=terrain_from_args(args))
    print(json.dumps(result.to_dict(), indent=2))
    return 0
