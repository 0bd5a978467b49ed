"""The ICR map of the default robot: a 1 000-case `mjtrack sweep`, timed.

    python benchmarks/icr_map.py [--workers 2] [--out benchmarks/results/icr_map]

Grid: 10 commanded speeds (0.2 .. 2.0 m/s) x 20 commanded turn radii (0.25 .. 20 m, log-spaced,
left turns) x 5 friction coefficients (0.3 .. 1.1), the default robot otherwise, each case held
3 s then averaged over 2 s exactly as `mjtrack steady` does. Prints the wall time of the whole
sweep (cluster start-up and figure included) and the machine's load average, the range
of the measured ICRs and their medians on slow turns. Run again on a finished OUT, it runs
no case (resume) and prints the same ICR numbers. Writes OUT/sweep.csv, OUT/sweep.json and OUT/icr_map.png (README shows it).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import sys
import time
from pathlib import Path

import numpy as np
from mjtrack.testing.repo import RESULTS

GRID = {
    "speed": [round(0.2 * k, 1) for k in range(1, 11)],
    "turn_radius": [float(f"{r:.3g}") for r in np.geomspace(0.25, 20.0, 20)],
    "mu": [0.3, 0.5, 0.7, 0.9, 1.1],
}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, default=RESULTS / "icr_map")
    args = ap.parse_args()
    from mjtrack.sweep import grid_from_dict, run_sweep

    grid = grid_from_dict(GRID, source="benchmarks/icr_map.py")
    load0 = os.getloadavg()
    t0 = time.monotonic()
    s = run_sweep(grid, args.out, workers=args.workers, quiet=not sys.stderr.isatty())
    wall = time.monotonic() - t0
    load1 = os.getloadavg()
    with open(args.out / "sweep.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    # a case whose robot hardly turns has no ICRs (column icr_undefined says why): left out
    undefined = [r for r in rows if r["y_l"] == ""]
    rows = [r for r in rows if r["y_l"] != ""]
    y_l = np.array([float(r["y_l"]) for r in rows])
    y_r = np.array([float(r["y_r"]) for r in rows])
    x_c = np.array([float(r["x_c"]) for r in rows])
    summary = {"cases": s.cases, "ran": s.ran, "resumed": s.resumed, "workers": s.workers, "wall_seconds": wall,
               "sweep_seconds": s.run_seconds, "loadavg_before": load0, "loadavg_after": load1,
               "cpu_count": os.cpu_count(), "y_l_range": [y_l.min(), y_l.max()], "y_r_range": [y_r.min(), y_r.max()],
               "x_c_range": [x_c.min(), x_c.max()], "grid": GRID,
               "icr_undefined": [{k: r[k] for k in ("case", "speed", "turn_radius", "mu", "icr_undefined")}
                                 for r in undefined]}
    (args.out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    print(f"load average (1, 5, 15 min): before {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f}, "
          f"after {load1[0]:.2f} {load1[1]:.2f} {load1[2]:.2f} on {os.cpu_count()} cores")
    print(f"{s.cases} cases ({s.ran} run now, {s.resumed} resumed) on {s.workers} workers: {wall:.1f} s wall "
          f"({s.run_seconds:.1f} s running cases)")
    for r in undefined:
        print(f"case {r['case']} (speed {r['speed']} m/s, R {r['turn_radius']} m, mu {r['mu']}): no ICRs, "
              f"{r['icr_undefined']}")
    print(f"y_l {y_l.min():.4f} .. {y_l.max():.4f} m, y_r {y_r.min():.4f} .. {y_r.max():.4f} m, "
          f"x_c {x_c.min():.4f} .. {x_c.max():.4f} m (default robot: T/2 = 0.2 m)")
    slow = np.array([float(r["speed"]) <= 0.4 and float(r["turn_radius"]) <= 5 for r in rows])
    print(f"slow turns (speed <= 0.4 m/s, R <= 5 m, {slow.sum()} cases): median y_l {np.median(y_l[slow]):.4f} m, "
          f"y_r {np.median(y_r[slow]):.4f} m, x_c {np.median(x_c[slow]):.4f} m")
    return 0


if __name__ == "__main__":
    sys.exit(main())
