"""Wall time of a calibration on the whole shared Marmotte log (target: < 10 min on 2 cores).

    nice -n 10 python benchmarks/bench_calibrate.py [--rollers N] [--max-iter N] [--mu-min X --mu-factor F]

All 432 windows of ../shared/data/marmotte/marmotte_boreal.csv; the starting robot and the fitted
parameters of ``benchmarks/marmotte_calibration.py`` (coulomb ground: mu, cg_x, cg_y, drive lag,
delay, speed scale, contact length); 6 rollers per track, 2 rollout threads, 5 optimiser iterations
(the --quick Marmotte fit reached the same held-out error after 4: 0.086 vs 0.088 m after 9). Prints the wall
time, the windows simulated per second and the machine's load average before and after (the
machine is shared: the load says how much of its 2 cores the run had). --mu-min / --mu-factor set
the Levenberg-Marquardt damping (default mjtrack.calibrate.fit.LM_MU_MIN / LM_MU_FACTOR;
mujoco.minimize's own defaults are 1e-6 / 1.2589).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

from marmotte_calibration import DATA, GROUNDS, starting_robot

from mjtrack.calibrate.run import calibrate
from mjtrack.io import read_log_with_robot
from mjtrack.testing.repo import benchmark_command, default_run_result, printed_result


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rollers", type=int, default=6)
    ap.add_argument("--max-iter", type=int, default=5)
    ap.add_argument("--mu-min", type=float, default=None, help="Levenberg-Marquardt damping after a rejection")
    ap.add_argument("--mu-factor", type=float, default=None, help="its growth per rejected step")
    args = ap.parse_args()
    if not DATA.exists():
        print(f"{DATA} not found (the shared Marmotte data); nothing to do")
        return 0
    log, base = read_log_with_robot(DATA)
    ground, names = GROUNDS["coulomb"]
    robot = starting_robot(base, ground)
    import mjtrack.calibrate.fit as fit_mod

    if args.mu_min is not None:
        fit_mod.LM_MU_MIN = args.mu_min
    if args.mu_factor is not None:
        fit_mod.LM_MU_FACTOR = args.mu_factor
    load0 = os.getloadavg()
    t0 = time.perf_counter()
    cal = calibrate(log, robot, names=names, n_rollers=args.rollers, max_iter=args.max_iter,
                    quiet=not sys.stderr.isatty(), train_path=DATA.name)
    wall = time.perf_counter() - t0
    load1 = os.getloadavg()
    sims = cal.fit.evaluations * len(cal.train_windows)
    print(f"whole log: {len(cal.train_windows)} windows, {len(names)} parameters, {cal.fit.iterations} iterations, "
          f"{cal.fit.evaluations} parameter sets; damping mu_min {fit_mod.LM_MU_MIN:g}, x{fit_mod.LM_MU_FACTOR:g} per rejected step")
    print(f"calibration wall time {wall:.1f} s ({wall / 60:.2f} min; target < 10 min); fit {cal.timings['fit']:.1f} s, "
          f"{sims / cal.fit.sim_seconds:.1f} windows of 2 s simulated per second")
    print(f"2 s position RMSE {cal.before.rms:.4f} -> {cal.after.rms:.4f} m")
    print(f"load average before {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f}, after {load1[0]:.2f} {load1[1]:.2f} "
          f"{load1[2]:.2f} (2 cores; shared machine)")
    return 0


if __name__ == "__main__":
    with printed_result(default_run_result("bench_calibrate.txt"), command=benchmark_command(__file__)):
        status = main()
    sys.exit(status)
