"""Benchmark of ``mjtrack diagnose``: stage timings on 10 minutes of 20 Hz data (12000 samples).

    python benchmarks/bench_diagnose.py [--effect cg_offset_x] [--minutes 10] [--no-speeds]
                                         [--marmotte PATH.csv] [--horizon S]

The synthetic log comes from the tests' independent generator (mjtrack/testing/diagnose_physics.py: its
own rigid-body Coulomb simulation, pose noise); the budget is 30 s for the whole diagnosis on
the surrogate baseline (read, forward selection over every effect, write the report). With
--marmotte it also runs the real Marmotte log and prints its findings. Prints the machine load.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

from mjtrack.diagnose import diagnose, write_outputs
from mjtrack.io.logs import read_log_with_robot, write_log
from mjtrack.io.robot import write_robot
from mjtrack.testing.diagnose_logs import HIDDEN, make_log
from _results import benchmark_command, default_run_result, printed_result


BUDGET_S = 30.0


def run(path: Path, out: Path, horizon) -> float:
    t0 = time.perf_counter()
    log, robot = read_log_with_robot(path)
    t1 = time.perf_counter()
    d = diagnose(log, robot, horizon_s=horizon, baseline="surrogate")
    t2 = time.perf_counter()
    write_outputs(d, out)
    t3 = time.perf_counter()
    total = t3 - t0
    print(f"  {path.name}: {d.samples} samples, {int(d.data.seg[-1]) + 1} segments, {d.starts.size} windows "
          f"at {d.horizon_s:g} s, baseline '{d.baseline.name}' RMSE {d.before:.4g} m")
    print(f"  read {t1 - t0:6.2f} s | prepare {d.timings['prepare']:6.2f} s | selection "
          f"{d.timings['selection']:6.2f} s ({len(d.steps)} steps) | report "
          f"{t3 - t2:6.2f} s | total {total:6.2f} s "
          f"({'within' if total < BUDGET_S else 'OVER'} the {BUDGET_S:.0f} s budget)")
    print("  " + d.summary().replace("\n", "\n  "))
    for step in d.steps:
        print(f"  step on top of {' + '.join(step.base) or 'the nominal model'} (baseline {step.before:.4g} m):")
        _table(step.results)
    print(f"  load {os.getloadavg()}")
    return total


def _table(results) -> None:
    for r in results:
        est = ", ".join(f"{n}={v:.4g}" for n, v in zip(r.effect.params, r.estimate))
        iv = ", ".join(f"[{a:.4g}, {b:.4g}]" for a, b in r.interval)
        print(f"    {'*' if r.passed else ' '} {r.effect.name:19s} {est:42s} {iv:34s} gain {100 * r.relative:6.1f} % "
              f"bound {100 * r.gain.lower:6.1f} %" + (f"  speed RMSE {r.speed_before:.3f}->{r.speed_after:.3f}" if r.speed_after else "")
              + (f"  tied with {r.tied_with}" if r.tied_with else ""))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--effect", default="cg_offset_x", choices=sorted(HIDDEN) + ["none"])
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--no-speeds", action="store_true")
    ap.add_argument("--horizon", default="auto", help="seconds, or auto (default)")
    ap.add_argument("--marmotte", type=Path, default=None, help="also run this real log (CSV with its JSON)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        t0 = time.perf_counter()
        effect = None if args.effect == "none" else args.effect
        log, robot = make_log(effect, seed=42, duration=60.0 * args.minutes, speeds=not args.no_speeds)
        path = tmp / "synthetic.csv"
        write_log(log, path)
        write_robot(robot, path.with_suffix(".json"))
        print(f"synthetic log, hidden {args.effect} {HIDDEN.get(effect, '')}: generated in "
              f"{time.perf_counter() - t0:.1f} s (not part of the budget)")
        horizon = args.horizon if args.horizon == "auto" else float(args.horizon)
        total = run(path, tmp / "out", horizon)
        if args.marmotte is not None:
            print("real log:")
            run(args.marmotte, tmp / "marmotte", horizon)
    return 0 if total < BUDGET_S else 1


if __name__ == "__main__":
    with printed_result(default_run_result("bench_diagnose.txt"), command=benchmark_command(__file__)):
        status = main()
    sys.exit(status)
