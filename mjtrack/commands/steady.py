"""Steady-state twist and ICRs of the MuJoCo robot under constant track speeds.

Holds (V_L, V_R) for --settle seconds, then averages the body twist and the measured track
speeds over --window seconds; ICRs from the means (null when driving straight).
Prints a table of vx, vy, wz, y_l, y_r, x_c, the window standard deviations, the measured
track speeds and the ground-contact fractions of each track; --json prints the same as JSON
(null ICRs with the reason under icr_undefined). A window whose two halves differ by more than
2 % of the command is not a steady state: both say so (unsettled; a warning on stderr), and a
longer --settle helps.

A robot file's simulator settings (simulator.track_model, n_rollers, timestep: what a calibrated
robot was fitted with) are used; --track-model overrides the model (the recorded timestep applies
to its own model only).

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
import sys

from mjtrack.commands._common import (add_robot_options, add_terrain_option, bounded, option_words, robot_from_args,
                                      terrain_from_args)

HELP = "steady-state twist and ICRs of the MuJoCo robot under constant track speeds (table, or --json)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--v-left", metavar="A", type=bounded("speed"), required=True, help="left track (wheel side) speed [m/s]")
    parser.add_argument("--v-right", metavar="B", type=bounded("speed"), required=True, help="right track (wheel side) speed [m/s]")
    parser.add_argument("--settle", metavar="S", type=bounded("settle"), default=3.0, help="transient time [s] (default 3)")
    parser.add_argument("--window", metavar="S", type=bounded("window"), default=2.0, help="averaging window [s] (default 2)")
    parser.add_argument("--track-model", choices=["rollers", "surfacevel"], default=None,
                        help="MuJoCo track model: sprung roller chain or surfacevel row (default: the robot file's "
                             "simulator.track_model, else rollers)")
    parser.add_argument("--json", action="store_true", help="print JSON instead of the table")
    add_robot_options(parser)
    add_terrain_option(parser, scenarios=False)


def run(args: argparse.Namespace) -> int:
    from mjtrack.sim.config import sim_config
    from mjtrack.sim.steady import steady_state

    robot = robot_from_args(args)
    result = steady_state(robot, args.v_left, args.v_right, config=sim_config(args.track_model, robot=robot),
                          settle_s=args.settle, window_s=args.window, terrain=terrain_from_args(args))
    if result.unsettled:
        print(f"mjtrack steady: warning: {option_words(result.unsettled)}", file=sys.stderr)
    print(json.dumps(result.to_dict(), indent=2) if args.json else steady_table(result.to_dict(), robot.traction))
    return 0


# (key, label, unit) of the table's rows, in the order printed (a wheeled robot's in :func:`_rows`)
_ROWS = (("v_left_cmd", "commanded left track speed", "m/s"), ("v_right_cmd", "commanded right track speed", "m/s"),
         ("v_left", "measured left track speed", "m/s"), ("v_right", "measured right track speed", "m/s"),
         ("vx", "vx (std)", "m/s"), ("vy", "vy (std)", "m/s"), ("wz", "wz (std)", "rad/s"),
         ("y_l", "y_l, left-track ICR", "m"), ("y_r", "y_r, right-track ICR", "m"), ("x_c", "x_c, ICR ahead", "m"),
         ("contact_left", "left track in contact", "share of steps"),
         ("contact_right", "right track in contact", "share of steps"),
         ("roller_contact", "rollers in contact", "share in the window"))


def _rows(traction: str) -> tuple[tuple[str, str, str], ...]:
    """:data:`_ROWS` in the words of a robot on ``traction`` (wheels, not tracks and rollers)."""
    if traction != "wheels":
        return _ROWS
    words = {"track speed": "wheel speed", "track ICR": "wheels ICR", "track in contact": "wheels in contact",
             "rollers in contact": "wheels in contact"}
    out = []
    for key, label, unit in _ROWS:
        for a, b in words.items():
            label = label.replace(a, b)
        out.append((key, label, unit))
    return tuple(out)


def steady_table(values: dict, traction: str = "tracks") -> str:
    """The steady state as aligned text rows (``--json`` prints ``values`` as they are), in the words
    of a robot on ``traction``."""
    lines = []
    for key, label, unit in _rows(traction):
        value = values[key]
        text = "null" if value is None else f"{value:.6g}"
        std = values.get(f"{key}_std")
        if std is not None:
            text += f" ({std:.2g})"
        lines.append(f"{label:<28} {text:>22} {unit}")
    for key in ("icr_undefined", "unsettled"):
        if values.get(key):
            lines.append(f"{key}: {values[key]}")
    return "\n".join(lines)
