"""Terrain and drivetrain checks: every number the README's terrain/drivetrain
sections quote.

    python benchmarks/terrain_checks.py [--quick]

1. Drivetrain: 63 % rise time of the measured track speed after a 0.5 m/s step, for drive_lag
   0 and 0.2 s, 5 / 20 / 150 kg, both track models; delay 0.1 s + scale 1.2.
2. Incline: a turning robot on a 0.2 rad incline (uphill +x, and across: +y) for 12 s; the
   Coulomb reference (mjtrack.models.coulomb.rollout with the slope) fed the *measured* track
   speeds of the MuJoCo log; position difference after 12 s over the distance travelled.
3. Steps: final x and z after 6 s at 0.3 and 1.0 m/s towards a 4 cm and a 40 cm step at x 0.6 m.
4. Height field: a seeded 5 cm random field; end-point distance from the flat-ground run.
5. Ice patch: a straight run across a mu 0.1 patch with the left track only (the right track on
   grip): heading change while on the patch against flat ground.
Machine load is printed (shared machine: timings are indicative only).
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
from mjtrack.models.coulomb import plane_to_world, rollout, world_to_plane
from mjtrack.sim.config import sim_config
from mjtrack.sim.rollout import simulate
from mjtrack.sim.terrain import parse_terrain, timestep_for
from _results import benchmark_command, default_run_result, printed_result


def run(robot, spec, v_left, v_right, seconds, model="rollers", log_rate=50.0):
    config = sim_config(model)
    config = config.replace(timestep=timestep_for(config.timestep, parse_terrain(spec)))
    n = int(round(seconds / config.timestep))
    cmd = np.empty((n, 2))
    cmd[:, 0] = v_left(np.arange(n) * config.timestep) if callable(v_left) else v_left
    cmd[:, 1] = v_right(np.arange(n) * config.timestep) if callable(v_right) else v_right
    return simulate(robot, cmd, config=config, terrain=parse_terrain(spec), log_rate=log_rate)


def rise_time(robot, model, v=0.5, t_step=0.2):
    out = run(robot, "flat", lambda t: np.where(t >= t_step, v, 0.0), lambda t: np.where(t >= t_step, v, 0.0),
              2.0, model, log_rate=100.0)
    target = v * robot.track_speed_scale
    return float(np.interp(0.63 * target, out["v_left"], out["t"])) - t_step


def drivetrain():
    print("1. drivetrain: 63 % rise time of the measured track speed after a 0.5 m/s step [s]")
    for model in ("rollers", "surfacevel"):
        for mass in (5.0, 20.0, 150.0):
            r0 = rise_time(Robot(mass=mass), model)
            r2 = rise_time(Robot(mass=mass, drive_lag=0.2), model)
            rd = rise_time(Robot(mass=mass, drive_lag=0.2, drive_delay=0.1, track_speed_scale=1.2), model)
            print(f"   {model:10s} {mass:5.0f} kg: lag 0 -> {r0:.3f}   lag 0.2 -> {r2:.3f}   "
                  f"lag 0.2 + delay 0.1 (scale 1.2) -> {rd:.3f}")


def incline(seconds):
    print(f"2. 0.2 rad incline, turning for {seconds:g} s: MuJoCo vs Coulomb (slope, load transfer) fed the "
          "measured track speeds")
    worst = 0.0
    for direction, label in ((0.0, "uphill +x"), (np.pi / 2, "uphill +y")):
        for (vl, vr) in ((0.3, 0.5), (0.5, 0.3), (0.6, 0.1)):
            for robot in (Robot(), Robot(mass=80.0, track_gauge=0.5, track_length=1.0, cg_z=0.2)):
                spec = f"incline:0.2:{direction}"
                out = run(robot, spec, vl, vr, seconds)
                xy0 = world_to_plane(out["x"][:1], out["y"][:1], out["z"][:1], 0.2, direction)[0]
                ref = rollout(robot, out["t"], out["v_left"], out["v_right"], pose0=(xy0[0], xy0[1], out["yaw"][0]),
                              slope=0.2, slope_direction=direction, n_points=40)
                w = plane_to_world(ref.pose, 0.2, direction)
                err = float(np.hypot(w[-1, 0] - out["x"][-1], w[-1, 1] - out["y"][-1]))
                dist = float(np.sum(np.hypot(np.diff(out["x"]), np.diff(out["y"]))))
                worst = max(worst, err / dist)
                print(f"   {label} {robot.mass:3.0f} kg V=({vl}, {vr}): end-point difference {err:.3f} m over "
                      f"{dist:.2f} m = {100 * err / dist:.1f} %  (yaw MuJoCo {out['yaw'][-1]:+.3f}, "
                      f"Coulomb {w[-1, 2]:+.3f} rad)")
    print(f"   worst: {100 * worst:.1f} % of the distance travelled (done-when: <= 6 %)")


def steps():
    print("3. steps at x = 0.6 m, 6 s of straight driving (robot front idler at x = 0.31 m at the start)")
    for model in ("rollers", "surfacevel"):
        for h in (0.04, 0.4):
            for v in (0.3, 1.0):
                out = run(Robot(), f"step:{h}:0.6", v, v, 6.0, model)
                print(f"   {model:10s} step {h:.2f} m at {v} m/s: final x {out['x'][-1]:.2f} m, z {out['z'][-1]:.3f} m, "
                      f"{'climbed' if out['z'][-1] > h - 0.005 else 'stopped'}")


def hfield():
    rng = np.random.default_rng(7)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bumps.npy"
        np.save(path, rng.random((40, 40)))
        for model in ("rollers", "surfacevel"):
            flat = run(Robot(), "flat", 0.5, 0.3, 6.0, model)
            bumpy = run(Robot(), f"hfield:{path}:6:6:0.05", 0.5, 0.3, 6.0, model)
            d = float(np.hypot(bumpy["x"][-1] - flat["x"][-1], bumpy["y"][-1] - flat["y"][-1]))
            print(f"4. height field (seeded random, 6 x 6 m, 5 cm), {model}: end point {d:.3f} m from the flat run "
                  f"after 6 s, yaw {bumpy['yaw'][-1] - flat['yaw'][-1]:+.3f} rad, z range {np.ptp(bumpy['z']):.3f} m")


def ice():
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "ice.json"
        # an ice strip under the left track only, from x = 1 to 2 m
        path.write_text(json.dumps({"patches": [{"x": 1.5, "y": 0.2, "size_x": 1.0, "size_y": 0.2, "mu": 0.1}]}))
        for model in ("rollers", "surfacevel"):
            flat = run(Robot(), "flat", 0.45, 0.5, 8.0, model)
            icy = run(Robot(), f"patches:{path}", 0.45, 0.5, 8.0, model)
            print(f"5. ice strip (mu 0.1) under the left track, gentle left turn (0.45, 0.5) m/s, {model}: "
                  f"final yaw {icy['yaw'][-1]:+.3f} rad vs {flat['yaw'][-1]:+.3f} on grip; end points "
                  f"{np.hypot(icy['x'][-1] - flat['x'][-1], icy['y'][-1] - flat['y'][-1]):.3f} m apart")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="4 s incline runs instead of 12")
    args = ap.parse_args()
    print(f"machine load (1, 5, 15 min): {os.getloadavg()}")
    t0 = time.perf_counter()
    drivetrain()
    incline(4.0 if args.quick else 12.0)
    steps()
    hfield()
    ice()
    print(f"wall time {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    with printed_result(default_run_result("terrain_checks.txt"), command=benchmark_command(__file__)):
        status = main()
    sys.exit(status)
