"""Wall time of a calibration on the whole shared Marmotte log (target: < 10 min on 2 cores).

    nice -n 10 python benchmarks/bench_calibrate.py [--rollers N] [--max-iter N]

All 432 windows of ../shared/data/marmotte/marmotte_boreal.csv; the Marmotte's starting robot of
``benchmarks/real_robots.py`` (coulomb ground), calibrate's defaults (candidates, rounds,
iterations, the fit on ``FIT_WINDOWS`` windows spread over the log, every window scored before and
after, the causes on every window); 6 rollers per track, as ``benchmarks/real_robots.py``. Prints the wall time, the windows simulated per second and the
machine's load average before and after (the machine is shared: the load says how much of its
2 cores the run had), and writes benchmarks/results/bench_calibrate.json.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

from real_robots import ROBOTS, starting_robot

from mjtrack.calibrate.run import calibrate
from mjtrack.io import read_log_with_robot

OUT = Path(__file__).resolve().parent / "results" / "bench_calibrate.json"
DATA = ROBOTS["marmotte"]["log"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rollers", type=int, default=6)
    ap.add_argument("--max-iter", type=int, default=8, help="optimiser iterations (calibrate's default 8)")
    args = ap.parse_args()
    if not DATA.exists():
        print(f"{DATA} not found (the shared Marmotte data); nothing to do")
        return 0
    log, base = read_log_with_robot(DATA)
    robot = starting_robot(base, ROBOTS["marmotte"]["public"])
    load0 = os.getloadavg()
    t0 = time.perf_counter()
    cal = calibrate(log, robot, n_rollers=args.rollers, max_iter=args.max_iter,
                    quiet=not sys.stderr.isatty(), train_path=DATA.name)
    wall = time.perf_counter() - t0
    load1 = os.getloadavg()
    fits = [cal.fit] + ([cal.refit] if cal.refit is not None else [])
    sets = sum(f.evaluations for f in fits)
    sims = sets * len(cal.fitted_windows)
    sim_s = sum(f.sim_seconds for f in fits)
    print(f"whole log: {len(cal.train_windows)} windows ({len(cal.fitted_windows)} fitted), {len(cal.names)} candidates, "
          f"{len(cal.changed)} changed, "
          f"fits {[f.iterations for f in fits]} iterations, {sets} parameter sets (fits only)")
    print(f"calibration wall time {wall:.1f} s ({wall / 60:.2f} min; target < 10 min); fit {cal.timings['fit']:.1f} s, "
          f"{sims / max(sim_s, 1e-9):.1f} windows of 2 s simulated per second")
    print(f"2 s position RMSE {cal.before.rms:.4f} -> {cal.after.rms:.4f} m")
    print(f"load average before {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f}, after {load1[0]:.2f} {load1[1]:.2f} "
          f"{load1[2]:.2f} ({os.cpu_count()} CPUs; shared machine)")
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps({"command": "python benchmarks/bench_calibrate.py " + " ".join(sys.argv[1:]),
                               "windows": len(cal.train_windows), "fit_windows": len(cal.fitted_windows),
                               "candidates": cal.names, "changed": cal.changed,
                               "wall_s": wall, "minutes": wall / 60, "target_minutes": 10, "timings_s": cal.timings,
                               "rollers": args.rollers, "parameter_sets": sets,
                               "windows_per_second": sims / max(sim_s, 1e-9),
                               "diverged": [cal.before.diverged, cal.after.diverged],
                               "max_iter": args.max_iter, "rms_before": cal.before.rms, "rms_after": cal.after.rms,
                               "load_before": load0, "load_after": load1}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
