"""Calibrate the MuJoCo robot on the real Marmotte log: the sim-to-real numbers README quotes.

    nice -n 10 python benchmarks/marmotte_calibration.py [--quick] [--grounds coulomb,anisotropic,road_wheels]

Training data: the first 50 % of ../shared/data/marmotte/marmotte_boreal.csv (its 2 s windows, in
order); test data: the next 20 %, never used in a fit. Starting robot (honest geometry, every value
named): the log's description (track_gauge 0.5927 m, sprocket_radius 0.1167 m) plus the public
specification of the Marmotte as submitted to the DARPA SubT virtual repository (osrf/subt,
submitted_models/ctu_cras_norlab_marmotte_sensor_config_1: specifications.md "approximately 52 kg
(41 kg the HD2 chassis, 11 kg the sensor rig)"; model.sdf: road wheels at x = +-0.36 and +-0.12 m,
radius 0.129 m, i.e. a 0.72 m track contact; sensor rack of 10.4 kg centred 0.08 m ahead of the
chassis centre, giving cg_x = 0.016 m and a cg height of about 0.155 m). Friction: no public value;
mu starts at 0.5 and is fitted. The drivetrain starts ideal (no lag, delay, scale) and is fitted.

For each ground model (robot key ``ground``) calibrate's default candidates are fitted (friction
level and ratio, centre of mass, contact length, lag, delay, speed scale, slope), plus the ground's
own: ``coulomb`` (rigid track), ``anisotropic`` (lateral/longitudinal friction ratio), ``road_wheels``
(4 road wheels: load concentration and span); what the log does not determine keeps its starting
value. Prints, per ground: the test 2 s position RMSE before / after and its relative gain, the
steady-turn yaw ratio measured and simulated on the test part, every parameter with its interval
and whether the log determines it, the causes and the summary. Writes calibration.json + robot.json per ground under
benchmarks/results/marmotte_calibration/ and the reports under /tmp/marmotte_calibration/.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import time
from pathlib import Path

import numpy as np

from mjtrack.calibrate.run import calibrate, write_outputs
from mjtrack.io import read_log_with_robot
from mjtrack.io.robot import Robot
from mjtrack.testing.repo import RESULTS

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "marmotte" / "marmotte_boreal.csv"
CALIBRATIONS = RESULTS / "marmotte_calibration"
REPORTS = Path("/tmp/marmotte_calibration")

SUBT = "osrf/subt submitted_models/ctu_cras_norlab_marmotte_sensor_config_1"
PUBLIC = {
    "mass": (52.0, f"public specification, about 52 kg (41 kg HD2 chassis + 11 kg sensor rig; {SUBT}/specifications.md)"),
    "track_length": (0.72, f"public model: road wheels at x = +-0.36 m, contact 0.72 m ({SUBT}/model.sdf)"),
    "cg_x": (0.016, f"public model: 10.4 kg sensor rack 0.08 m ahead of the 41 kg chassis centre ({SUBT}/model.sdf)"),
    "cg_z": (0.155, f"public model: wheel centres 0.129 m above ground, rack 0.13 m higher ({SUBT}/model.sdf)"),
    "mu": (0.5, "no public value: start value, fitted"),
}
GROUNDS = {
    "coulomb": {"model": "coulomb"},
    "anisotropic": {"model": "anisotropic", "lateral_ratio": 0.7},
    "road_wheels": {"model": "road_wheels", "wheels": 4, "concentration": 0.8, "span": 0.8},
}


def split(log, first: float, second: float):
    """Rows of the first ``first`` share of the segments, and of the next ``second`` share."""
    sl = log.segment_slices()
    n = len(sl)
    a, b = int(round(first * n)), int(round((first + second) * n))
    return log.slice(sl[0].start, sl[a - 1].stop), log.slice(sl[a].start, sl[b - 1].stop)


def starting_robot(base: Robot, ground: dict) -> Robot:
    d = base.to_dict()
    for k, (v, why) in PUBLIC.items():
        d[k] = v
        d[f"source_{k}"] = why
    d["ground"] = ground
    for k in ("mu_left", "mu_right"):
        d.pop(k, None)
    return Robot.from_dict(d, source="marmotte starting robot")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="every 4th training window and 4 iterations (development)")
    ap.add_argument("--grounds", default="coulomb,anisotropic", help="comma separated ground models to fit")
    ap.add_argument("--rollers", type=int, default=6, help="rollers per track (default 6)")
    ap.add_argument("--max-iter", type=int, default=8)
    args = ap.parse_args()
    if not DATA.exists():
        print(f"{DATA} not found (the shared Marmotte data); nothing to do")
        return 0
    log, base = read_log_with_robot(DATA)
    train, test = split(log, 0.5, 0.2)
    if args.quick:
        keep = train.segment_slices()[::4]
        train = train[np.concatenate([np.arange(s.start, s.stop) for s in keep])]
    print(f"{DATA.name}: {len(log.segment_slices())} windows; train {len(train.segment_slices())} (first 50 %), "
          f"test {len(test.segment_slices())} (next 20 %); load average {os.getloadavg()}")
    CALIBRATIONS.mkdir(parents=True, exist_ok=True)
    summary = {}
    for name in args.grounds.split(","):
        robot = starting_robot(base, GROUNDS[name])
        t0 = time.time()
        cal = calibrate(train, robot, test=test, n_rollers=args.rollers,
                        max_iter=4 if args.quick else args.max_iter, quiet=not sys.stderr.isatty(),
                        train_path=f"{DATA.name} (first 50 %)", test_path=f"{DATA.name} (next 20 %)")
        wall = time.time() - t0
        out = REPORTS / name
        if out.exists():
            shutil.rmtree(out)
        write_outputs(cal, out)
        if not args.quick:
            for f in ("calibration.json", "robot.json"):
                shutil.copy(out / f, CALIBRATIONS / f"{name}_{f}")
        cj = cal.to_json()
        yaw = next(f for f in cj["findings"] if f["what"] == "yaw ratio" and f["part"] == "test")
        print(f"\n== ground {name}: candidates {', '.join(cal.names)} ({wall:.0f} s, load {os.getloadavg()[0]:.2f})")
        for n in cal.names:
            v = cal.verdicts[n]
            iv = "" if v.interval is None else f"[{v.interval[0]:.4g}, {v.interval[1]:.4g}]"
            print(f"  {n:18s} {cal.described[n]:8.4g} -> {cal.values[n]:8.4g}  {iv:24s} "
                  f"{'determined' if v.determined else 'NOT determined'}, {'changed' if v.changed else 'kept'}")
        for c in cal.causes:
            print(f"  cause {', '.join(c.parameters)}: share {c.share:.2f}, alone {c.gain_alone:.2f}")
        t = cj["test"]
        print(f"  train 2 s position RMSE {cal.before.rms:.4f} -> {cal.after.rms:.4f} m")
        print(f"  TEST  2 s position RMSE {t['before']:.4f} -> {t['after']:.4f} m: {100 * t['relative']:.1f} % lower "
              f"(target >= 40 %)")
        print(f"  test yaw ratio: measured {yaw['measured']:.3f}, simulated before {yaw['simulated_before']:.3f}, "
              f"after {yaw['simulated_after']:.3f} (|after - measured| = {abs(yaw['simulated_after'] - yaw['measured']):.3f}, "
              f"target <= 0.05; {yaw['windows']} steady windows)")
        print(f"  {cal.sentence}")
        summary[name] = {"test_before": t["before"], "test_after": t["after"], "relative": t["relative"],
                         "yaw_measured": yaw["measured"], "yaw_before": yaw["simulated_before"],
                         "yaw_after": yaw["simulated_after"], "seconds": wall,
                         "parameters": cal.values, "determined": {n: v.to_json() for n, v in cal.verdicts.items()},
                         "intervals": {n: v.interval for n, v in cal.verdicts.items()},
                         "causes": [c.to_json() for c in cal.causes]}
    if not args.quick:
        (CALIBRATIONS / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
