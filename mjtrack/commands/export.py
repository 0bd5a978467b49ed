"""Export a drive log for other tools.

--format tum writes the log's poses as evo's TUM trajectory format: one line per row,
"t x y z qx qy qz qw" (space separated, no header; quaternion of yaw, pitch, roll; z, roll and
pitch from the log's columns of those names when it has them, else 0). Compare two
trajectories with, e.g., `evo_ape tum truth.txt estimate.txt`.
"""

from __future__ import annotations

import argparse

from mjtrack.commands._common import add_force_option, check_out_file, check_overwrite

HELP = "export a drive log's poses for other tools (tum: 't x y z qx qy qz qw', as evo reads)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("log", metavar="LOG.csv", help="drive log (CSV: t, v_left_cmd, v_right_cmd, x, y, yaw, ...)")
    parser.add_argument("--format", choices=["tum"], required=True, help="output format")
    parser.add_argument("--out", metavar="FILE", required=True, help="output file (written atomically)")
    add_force_option(parser)


def run(args: argparse.Namespace) -> int:
    from mjtrack.io.logs import read_log
    from mjtrack.io.tum import write_tum

    log = read_log(args.log)
    out = check_out_file(args.out, inputs=[args.log])
    check_overwrite([out], args.force, [args.log])
    write_tum(log, out)
    return 0
