"""The wheeled-robot thesis's four models against the wheeled MuJoCo robot: prediction error by horizon.

    python benchmarks/wheeled_models.py [--duration 30] [--max-starts 40] [--seed 0]

Two robots of public size (the specifications benchmarks/real_robots.py cites): a Husky-sized
robot (50 kg, gauge 0.555 m, wheelbase 0.512 m, wheel radius 0.165 m) and a Warthog-sized one
(260 kg, gauge 1.08 m, wheelbase 0.92 m, wheel radius 0.3 m, centre of mass 0.015 m behind the
centre), two wheels a side, the description's default friction μ = 0.8, on two MuJoCo rollouts
each: the seeded ``random_steps`` scenario (``--duration`` s) and the ``circle`` scenario
(20 s). Each log goes through ``mjtrack.validate.validate`` at horizons 0.25, 0.5, 1 and 2 s;
the result keeps its ``wheeled_models`` entry (median and worst position and heading error of the
kinematic differential drive, dynamic models 1 and 2 and the four-wheel skid steer, the best per
horizon, the parameters each model got and which of them the description lacks), plus what the
ranking rests on: the log's yaw rate over the no-slip yaw rate (V_R − V_L)/T (median over the
samples with |V_R − V_L| ≥ 0.1 m/s), and the skid steer's slow-spin ratio b²/(a² + b²).

Writes benchmarks/results/wheeled_models.json with the command and the load average before and
after (the errors do not depend on the load; the run time does).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from mjtrack.io.robot import Robot
from mjtrack.sim.rollout import drive_log
from mjtrack.sim.scenarios import scenario_commands
from _results import RESULTS
from mjtrack.validate import Noise, validate
from mjtrack.validate.wheeled import KEYS

HORIZONS = (0.25, 0.5, 1.0, 2.0)  # [s]
TURNING = 0.1  # [m/s] |V_R - V_L| above which a sample's yaw-rate ratio is counted
ROBOTS = {
    "husky": Robot(traction="wheels", track_gauge=0.555, wheelbase=0.512, sprocket_radius=0.165, track_width=0.11,
                   mass=50.0, cg_z=0.2),
    "warthog": Robot(traction="wheels", track_gauge=1.08, wheelbase=0.92, sprocket_radius=0.3, track_width=0.25,
                     mass=260.0, cg_x=-0.015, cg_z=0.35),
}


def yaw_rate_ratio(drive, robot: Robot) -> float:
    """Median of ω T/(V_R − V_L) over the samples with |V_R − V_L| ≥ :data:`TURNING` (measured speeds)."""
    dv = np.asarray(drive.v_right) - np.asarray(drive.v_left)
    turning = np.abs(dv) >= TURNING
    return float(np.median(np.asarray(drive.wz)[turning] * robot.track_gauge / dv[turning])) if turning.any() else None


def run_case(robot: Robot, scenario: str, duration: float | None, seed: int, max_starts: int) -> dict:
    table, dur = scenario_commands(scenario, robot, duration=duration, seed=seed)
    drive = drive_log(robot, table, duration=dur)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        val = validate(drive, robot, tmp, horizons=HORIZONS, noise=Noise(scale=0.0), seed=seed, quiet=True,
                       wheeled_max_starts=max_starts, source=f"MuJoCo rollout of '{scenario}'")
    a, b = robot.contact_length, robot.track_gauge
    return {"scenario": scenario, "duration_s": dur, "seed": seed, "samples": int(drive.n_samples),
            "validate_wall_s": time.perf_counter() - t0,
            "yaw_rate_over_no_slip_median": yaw_rate_ratio(drive, robot),
            "skid_steer_slow_spin_ratio": b**2 / (a**2 + b**2),
            "wheeled_models": val.metrics["wheeled_models"]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--duration", type=float, default=30.0, help="random_steps duration [s] (default 30)")
    ap.add_argument("--max-starts", type=int, default=40, help="windows per horizon at most (default 40)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the random steps (default 0)")
    ap.add_argument("--out", type=Path, default=RESULTS, help="folder of the result file")
    args = ap.parse_args(argv)
    load_before = os.getloadavg()
    print(f"load average before: {load_before[0]:.2f} {load_before[1]:.2f} {load_before[2]:.2f} ({os.cpu_count()} CPUs)")
    cases = {}
    for name, robot in ROBOTS.items():
        for scenario, duration in (("random_steps", args.duration), ("circle", None)):
            key = f"{name}_{scenario}"
            cases[key] = run_case(robot, scenario, duration, args.seed, args.max_starts)
            wm = cases[key]["wheeled_models"]
            print(f"{key}: yaw rate / no-slip rate {cases[key]['yaw_rate_over_no_slip_median']:.3g}, "
                  f"validate {cases[key]['validate_wall_s']:.0f} s")
            for k in KEYS:
                print(f"  {k:11s} " + "  ".join(
                    f"{h} s: {r['pos_median_m']:.3g}/{r['pos_max_m']:.3g} m {r['yaw_median_deg']:.3g}/"
                    f"{r['yaw_max_deg']:.3g} deg" for h, r in wm["models"][k]["horizons"].items()))
            print("  best median position: " + ", ".join(f"{h} s {b['position']}" for h, b in wm["best"].items()))
    load_after = os.getloadavg()
    print(f"load average after: {load_after[0]:.2f} {load_after[1]:.2f} {load_after[2]:.2f}")
    doc = {"command": "python benchmarks/wheeled_models.py" + "".join(
               f" --{k} {v}" for k, v in (("duration", args.duration), ("max-starts", args.max_starts),
                                          ("seed", args.seed))),
           "horizons_s": list(HORIZONS), "robots": {k: r.to_dict() for k, r in ROBOTS.items()},
           "load_average_before": load_before, "load_average_after": load_after, "cpus": os.cpu_count(),
           "cases": cases}
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "wheeled_models.json"
    path.write_text(json.dumps(doc, indent=1, allow_nan=False) + "\n")
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
