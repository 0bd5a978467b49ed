"""Ground models of the MuJoCo robot: yaw ratio on the Marmotte geometry, and their cost in speed.

    python benchmarks/ground_models.py [--out benchmarks/results/ground_models.json]

1. Steady pivot yaw ratio wz / ((V_R - V_L) / T) on the Marmotte's gauge (T = 0.5927 m, its
   published value; contact length L unknown, so 0.4 - 0.8 m): MuJoCo (mjtrack.sim.steady, the
   roller chain with the ground model) beside the independent quadrature of the steady balance
   (mjtrack/testing/ground_balance.py), for the coulomb ground, the anisotropic ground at the lateral
   ratio that gives the measured 0.96 (found on the quadrature), and road wheels (4 wheels,
   95 % of the load) at the span that gives 0.96.
2. Speed: steps per second of a 10 s random-steps rollout (one thread, median of 3) per model.
The machine is shared: the load average is printed with the timings.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from pathlib import Path

from scipy.optimize import brentq

from mjtrack.io.robot import Robot
from mjtrack.sim.builder import build_model
from mjtrack.sim.config import SimConfig
from mjtrack.sim.rollout import hold_commands, run_batch, settled_state
from mjtrack.sim.scenarios import scenario_commands
from mjtrack.sim.steady import steady_state
from mjtrack.testing.ground_balance import yaw_ratio
from mjtrack.testing.repo import RESULTS


T_MARMOTTE = 0.592723  # [m] marmotte_boreal.json
R_MARMOTTE = 0.116702  # [m] sprocket radius, marmotte_boreal.json
MEASURED = 0.96  # yaw ratio of the real Marmotte (steady windows of the shared log)
PIVOT = (-0.4, 0.4)


def _mujoco_ratio(robot: Robot) -> float:
    s = steady_state(robot, *PIVOT, config=SimConfig(torque_limit=600.0))
    return s.wz / ((s.v_right - s.v_left) / robot.track_gauge)


def marmotte_table() -> list[dict]:
    rows = []
    for L in (0.4, 0.5, 0.6, 0.8):
        base = Robot(track_gauge=T_MARMOTTE, track_length=L, sprocket_radius=R_MARMOTTE)
        rho = brentq(lambda r: yaw_ratio(*PIVOT, T_MARMOTTE, L, rho=r) - MEASURED, 0.05, 1.0, xtol=1e-4)
        span = brentq(lambda s: yaw_ratio(*PIVOT, T_MARMOTTE, L, wheels=4, concentration=0.95, span=s) - MEASURED,
                      0.05, 1.0, xtol=1e-4)
        cases = [
            ({"model": "coulomb"}, {}),
            ({"model": "anisotropic", "lateral_ratio": round(rho, 3)}, {"rho": round(rho, 3)}),
            ({"model": "road_wheels", "wheels": 4, "concentration": 0.95, "span": round(span, 3)},
             {"wheels": 4, "concentration": 0.95, "span": round(span, 3)}),
        ]
        for ground, kw in cases:
            rows.append({"track_length": L, "ground": ground,
                         "yaw_ratio_quadrature": yaw_ratio(*PIVOT, T_MARMOTTE, L, **kw),
                         "yaw_ratio_mujoco": _mujoco_ratio(base.replace(ground=ground))})
    return rows


def speed() -> dict:
    out = {}
    cfg = SimConfig()
    for name, ground in (("coulomb", "coulomb"), ("anisotropic", {"model": "anisotropic", "lateral_ratio": 0.5}),
                         ("road_wheels", {"model": "road_wheels", "span": 0.5})):
        robot = Robot(ground=ground)
        model = build_model(robot, cfg)
        table, _ = scenario_commands("random_steps", robot, seed=0)
        cmds = hold_commands(*table, timestep=cfg.timestep, duration=10.0)[None]
        s0 = settled_state(model)[None]
        times = []
        for _ in range(3):
            t0 = time.perf_counter()
            run_batch([model], cmds, state0=s0)
            times.append(time.perf_counter() - t0)
        out[name] = {"steps_per_second": cmds.shape[1] / statistics.median(times)}
    base = out["coulomb"]["steps_per_second"]
    for v in out.values():
        v["relative_to_coulomb"] = v["steps_per_second"] / base
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=str(RESULTS / "ground_models.json"))
    args = ap.parse_args(argv)
    rows = marmotte_table()
    print(f"Pivot yaw ratio on the Marmotte gauge T = {T_MARMOTTE} m (measured: {MEASURED})")
    print(f"{'L [m]':>6}  {'ground':<62} {'quadrature':>10} {'MuJoCo':>8}")
    for r in rows:
        g = ", ".join(f"{k}={v}" for k, v in r["ground"].items())
        print(f"{r['track_length']:>6.2f}  {g:<62} {r['yaw_ratio_quadrature']:>10.3f} {r['yaw_ratio_mujoco']:>8.3f}")
    worst = max(abs(r["yaw_ratio_quadrature"] - r["yaw_ratio_mujoco"]) for r in rows)
    print(f"worst |MuJoCo - quadrature| = {worst:.4f}")
    sp = speed()
    load = os.getloadavg()
    print(f"speed (10 s random steps, 1 thread, load average {load[0]:.2f}):")
    for k, v in sp.items():
        print(f"  {k:<12} {v['steps_per_second']:8.0f} steps/s  ({v['relative_to_coulomb']:.2f} x coulomb)")
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps({"marmotte": rows, "worst_abs_diff": worst, "speed": sp,
                                          "load_average": load}, indent=2) + "\n")


if __name__ == "__main__":
    main()
