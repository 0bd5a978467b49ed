"""The MuJoCo robot calibrated on three real robots' logs: Marmotte (tracked), Husky and Warthog
(wheeled skid-steer), from the DRIVE data in ../shared/data/ (BSD-3; see each folder's README).

    python benchmarks/real_robots.py [--robots marmotte,husky,warthog] [--rollers 6]

For each robot: its log's description plus the public specification of what the log does not give
(every such value named, with its source, under ``assumed`` in calibration.json), calibrated with
calibrate's default candidates on the first part of the log and scored on the next part, never
fitted: Marmotte trains on the first 50 % of its windows and tests on the next 20 %; Husky and
Warthog train on the first 70 % and test on the remaining 30 % of what the shared folder holds.
Writes benchmarks/results/real_robots.json: per robot the held-out 2 s position error before and
after, the steady-turn yaw ratio measured and simulated (before, after) on the test part, every
candidate's value, interval and whether the log determines it, the causes and the summary; the
calibrated robot.json and calibration.json go to benchmarks/results/real_robots/. Prints the same
and the machine's load.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from mjtrack.calibrate.run import calibrate, write_outputs
from mjtrack.io import read_log_with_robot
from mjtrack.io.robot import Robot

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[1] / "shared" / "data"
RESULT = HERE / "results" / "real_robots.json"
OUTPUTS = HERE / "results" / "real_robots"

SUBT = "osrf/subt submitted_models/ctu_cras_norlab_marmotte_sensor_config_1"
HUSKY = "husky/husky_description urdf/husky.urdf.xacro"
WARTHOG = "warthog-cpr/warthog warthog_description/urdf/warthog_params.xacro"
ROBOTS = {
    "marmotte": {
        "log": DATA / "marmotte" / "marmotte_boreal.csv", "split": (0.5, 0.2),
        "public": {
            "mass": (52.0, f"public specification, about 52 kg ({SUBT}/specifications.md)"),
            "track_length": (0.72, f"public model: road wheels at x = +-0.36 m, contact 0.72 m ({SUBT}/model.sdf)"),
            "cg_x": (0.016, f"public model: 10.4 kg sensor rack 0.08 m ahead of the 41 kg chassis ({SUBT}/model.sdf)"),
            "cg_z": (0.155, f"public model: wheel centres 0.129 m above ground, rack 0.13 m higher ({SUBT}/model.sdf)"),
            "mu": (0.5, "no public value: start value"),
        }},
    "husky": {
        "log": DATA / "husky" / "husky_drive.csv", "split": (0.7, 0.3),
        "public": {
            "mass": (50.0, "public specification of the Clearpath Husky A200, 50 kg"),
            "wheelbase": (0.512, f"public model: wheelbase 0.512 m ({HUSKY})"),
            "cg_z": (0.2, "assumed: about the height of the chassis' middle"),
            "mu": (0.5, "no public value: start value"),
        }},
    "warthog": {
        "log": DATA / "warthog" / "warthog_drive.csv", "split": (0.7, 0.3),
        "public": {
            "mass": (260.0, f"public model: chassis 100 kg + two rocker units 50 kg + four wheels 15 kg ({WARTHOG})"),
            "wheelbase": (0.92, f"public model: axles at +-0.46 m ({WARTHOG})"),
            "cg_x": (-0.015, f"public model: the chassis 0.04 m behind the axles' centre ({WARTHOG})"),
            "cg_z": (0.35, "assumed: about the height of the chassis' middle"),
            "mu": (0.5, "no public value: start value"),
        }},
}


def split(log, first: float, second: float):
    """Rows of the first ``first`` share of the segments, and of the next ``second`` share."""
    sl = log.segment_slices()
    n = len(sl)
    a, b = int(round(first * n)), min(n, int(round((first + second) * n)))
    return log.slice(sl[0].start, sl[a - 1].stop), log.slice(sl[a].start, sl[b - 1].stop)


def starting_robot(base: Robot, public: dict) -> Robot:
    d = base.to_dict()
    for k, (v, why) in public.items():
        d[k] = v
        d[f"source_{k}"] = why
    for k in ("mu_left", "mu_right"):
        d.pop(k, None)
    return Robot.from_dict(d, source="starting robot")


def run_robot(name: str, spec: dict, *, rollers: int) -> dict:
    log, base = read_log_with_robot(spec["log"])
    train, test = split(log, *spec["split"])
    robot = starting_robot(base, spec["public"])
    t0 = time.time()
    cal = calibrate(train, robot, test=test, n_rollers=rollers, quiet=not sys.stderr.isatty(),
                    train_path=f"{spec['log'].name} (first {100 * spec['split'][0]:.0f} %)",
                    test_path=f"{spec['log'].name} (next {100 * spec['split'][1]:.0f} %)")
    wall = time.time() - t0
    out = OUTPUTS / name
    write_outputs(cal, out)
    cj = cal.to_json()
    yaw = next(f for f in cj["findings"] if f["what"] == "yaw ratio" and f["part"] == "test")
    return {"traction": robot.traction,
            "windows": {"train": len(cal.train_windows), "test": len(cal.test_windows)},
            "test": cj["test"], "train": cj["train"],
            "yaw_ratio": {"measured": yaw["measured"], "before": yaw["simulated_before"], "after": yaw["simulated_after"],
                          "windows": yaw["windows"]},
            "parameters": cj["parameters"], "intervals": cj["intervals"], "determined": cj["determined"],
            "described": cj["described"], "causes": cj["causes"], "summary": cj["summary"],
            "assumed": cj["assumed"], "seconds": wall}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robots", default=",".join(ROBOTS))
    ap.add_argument("--rollers", type=int, default=6, help="contact rollers per track (tracked robots; default 6)")
    args = ap.parse_args(argv)
    load0 = os.getloadavg()
    old = json.loads(RESULT.read_text()) if RESULT.exists() else {}
    robots = old.get("robots", {})
    for name in args.robots.split(","):
        spec = ROBOTS[name]
        if not spec["log"].exists():
            print(f"{spec['log']} not found (the shared data); skipped")
            continue
        r = run_robot(name, spec, rollers=args.rollers)
        robots[name] = r
        t, y = r["test"], r["yaw_ratio"]
        print(f"\n== {name}: {r['windows']['train']} training windows, {r['windows']['test']} test windows, "
              f"{r['seconds']:.0f} s")
        print(f"  test 2 s position RMSE {t['before']:.4f} -> {t['after']:.4f} m ({100 * t['relative']:.1f} % lower)")
        print(f"  test yaw ratio: measured {y['measured']:.3f}, simulated {y['before']:.3f} -> {y['after']:.3f}")
        for n, v in r["determined"].items():
            iv = r["intervals"].get(n)
            print(f"  {n:18s} {r['described'][n]:8.4g} -> {r['parameters'][n]:8.4g} "
                  f"{'' if iv is None else f'[{iv[0]:.4g}, {iv[1]:.4g}]':24s} "
                  f"{'determined' if v['determined'] else 'NOT determined'}, {'changed' if v['changed'] else 'kept'}")
        print(f"  {r['summary']}")
        RESULT.parent.mkdir(parents=True, exist_ok=True)
        RESULT.write_text(json.dumps({"robots": robots, "rollers": args.rollers, "load_before": load0,
                                      "load_after": os.getloadavg()}, indent=1, default=_plain) + "\n")
    print(f"\nload average before {load0}, after {os.getloadavg()} ({os.cpu_count()} cores)")
    return 0


def _plain(o):
    if isinstance(o, np.generic):
        return o.item()
    raise TypeError(type(o).__name__)


if __name__ == "__main__":
    raise SystemExit(main())
