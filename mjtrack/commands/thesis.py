"""Reproduce the chapter-4 experiments of the tracked-robot thesis [Mendaluk] (docs: references).

Section 4.1 of [Mendaluk]: the MPP, MICR and MVIR kinematic models driven along the reconstructed
U-shaped path of its fig. 4.1 of [Mendaluk] in three slip cases (none, longitudinal, lateral).
Writes its figures 4.1-4.7 of [Mendaluk] as PNG and DIR/thesis.json (per case: max_dev_m, the
largest distance between the MPP, MICR and MVIR paths; nominal_dev_m; final poses; the
reconstruction parameters; figure files and captions). Section 4.2 of [Mendaluk]: the slip, ICR and
virtual-robot filters, as printed and improved, on MPP truth (V = 0.4 m/s, w = -7 deg/s, s_L = 0.2,
alpha = 15 deg); its figures 4.8-4.14 of [Mendaluk] and, per filter, param_error_final,
converged_after_s and pred_err_ratio. Takes a few seconds, no MuJoCo.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from mjtrack.commands._common import add_output_options, check_out_dir, check_overwrite

HELP = "reproduce the chapter-4 experiments of the tracked-robot thesis [Mendaluk] (figures + thesis.json)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", metavar="DIR", type=Path, required=True,
                        help="output folder for thesis.json and the PNG figures (created if missing)")
    add_output_options(parser)


def run(args: argparse.Namespace) -> int:
    out = check_out_dir(args.out)
    from mjtrack.thesis.run import JSON_NAME, run_thesis  # matplotlib only when the command runs

    check_overwrite([out / JSON_NAME], args.force)

    doc = run_thesis(out, quiet=args.quiet)
    if not args.quiet:
        for key in doc["sections"]:
            cases = {k: v for k, v in doc[key].items() if isinstance(v, dict) and "max_dev_m" in v}
            for name, entry in cases.items():
                extra = f" (finite parameters only: {entry['max_dev_finite_m']:.3g} m)" if "max_dev_finite_m" in entry else ""
                print(f"{key} {name}: max_dev_m = {entry['max_dev_m']:.3g} m{extra}")
        print(f"wrote {out / JSON_NAME} and {len(doc['figures'])} figures")
    return 0
