"""The filters on the real Marmotte log, restarted per window (the earlier procedure) and carried across windows.

Run: nice -n 10 python benchmarks/filters_marmotte.py [--log ../shared/data/marmotte/marmotte_boreal.csv]

The Marmotte log (BSD-3, not in the repo) is 432 windows of 2 s of one robot. ``mjtrack validate``
used to restart every filter at each window, so no filter ever converged on it. Now the filters
carry their parameter estimate and covariance from one window to the next (the covariance grown
by the slow random walk over the gap) and restart only the pose; they also run with adaptive
process noise (IMM, :mod:`mjtrack.estimation.imm`). Printed per variant: the 2-s position RMSE of
each predictor on the log (the validate metric: predictions from the logged pose with the
filter's parameters at the start, measured track speeds, scored against the logged poses) and
each filter's NIS/dof, with the filters' R set to validate's default noise (σ 1 cm, 0.5°,
0.02 m/s, 0.01 rad/s: far below this log's, whose twist is differenced from 20 Hz poses) or
estimated from the log itself (:func:`mjtrack.validate.truth.estimate_noise`, what validate
now does on a measured log).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from mjtrack.estimation.consistency import per_dof
from mjtrack.io.logs import read_log, robot_path_for
from mjtrack.io.robot import read_robot
from mjtrack.validate import evaluate as ev
from mjtrack.validate import predictors as pr
from mjtrack.validate.truth import Noise, case_from_log, estimate_noise
from mjtrack.testing.repo import benchmark_command, default_run_result, printed_result

DEFAULT_LOG = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "marmotte" / "marmotte_boreal.csv"


def run(log_path: Path, carry: bool, adaptive, estimated_r: bool) -> dict:
    drive = read_log(log_path)
    robot = read_robot(robot_path_for(log_path))
    case = case_from_log(drive, noise=Noise(scale=0.0), title="measured log", noise_free=False)
    noise = estimate_noise(case) if estimated_r else Noise()
    original = pr.run_filters
    pr_run = lambda c, T, noise=Noise(): original(c, T, noise=noise, adaptive=adaptive, carry=carry)  # noqa: E731
    ev.run_filters = pr_run
    try:
        res = ev.evaluate_case(case, robot.track_gauge, horizons=(2.0,), noise=noise)
    finally:
        ev.run_filters = original
    return res.metrics


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--log", type=Path, default=DEFAULT_LOG)
    args = ap.parse_args(argv)
    if not args.log.exists():
        print(f"{args.log} not found: the Marmotte data is not in the repository (../shared/data/marmotte/)")
        return 2
    print(f"load average {os.getloadavg()}")
    for label, carry, adaptive, est in (("restart per window, single EKF, default R (earlier procedure)",
                                         False, None, False),
                                        ("carried across windows, IMM, default R", True, "imm", False),
                                        ("carried across windows, IMM, R estimated from the log (validate now)", True,
                                         "imm", True)):
        m = run(args.log, carry, adaptive, est)
        pos = {k: v["horizons"]["2"]["pos_rmse_m"] for k, v in m["predictors"].items()}
        nis = {k: per_dof(f["consistency"])[0] for k, f in m["filters"].items()}
        print(f"{label}:\n  2-s position RMSE [m]: " + ", ".join(f"{k} {v:.4f}" for k, v in pos.items()))
        print("  NIS/dof: " + ", ".join(f"{k} {v:.2f}" for k, v in nis.items())
              + "  final: " + "; ".join(f"{k} " + ", ".join(f"{n}={x:.3g}" for n, x in f["final"].items())
                                        for k, f in m["filters"].items()))
    return 0


if __name__ == "__main__":
    with printed_result(default_run_result("filters_marmotte.txt"), command=benchmark_command(__file__)):
        status = main()
    sys.exit(status)
