"""Speed of the MuJoCo roller-chain robot.

    python experiments/bench_sim.py [--out experiments/results/bench_sim.json]

1. Real-time factor of the default robot: one 20 s ``random_steps`` rollout through
   ``mujoco.rollout`` on one thread (the library path of ``mjtrack simulate``), median of 5.
2. A batch of 64 rollouts (2 s each, random constant commands) through ``mujoco.rollout``
   with 1 and with 2 threads, median of 5 each; speed-up = t(1 thread) / t(2 threads).
3. Steps per second against the roller count (one thread, pivot command, median of 5).
The machine has 2 cores shared with other jobs: the load average is printed with the
results because a busy second core lowers the 2-thread speed-up.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

import mujoco
import numpy as np

from mjtrack.io.robot import Robot
from mjtrack.sim.builder import build_model
from mjtrack.sim.config import SimConfig
from mjtrack.sim.rollout import hold_commands, run_batch, settled_state
from mjtrack.sim.scenarios import scenario_commands

REPEATS = 5


def _median_time(fn) -> float:
    times = []
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def realtime_factor() -> dict:
    robot, cfg = Robot(), SimConfig()
    model = build_model(robot, cfg)
    table, _ = scenario_commands("random_steps", robot, seed=0)
    duration = 20.0
    cmds = hold_commands(*table, timestep=cfg.timestep, duration=duration)[None]
    s0 = settled_state(model)[None]
    t = _median_time(lambda: run_batch([model], cmds, state0=s0))
    return {"sim_seconds": duration, "wall_seconds": t, "realtime_factor": duration / t,
            "steps_per_second": cmds.shape[1] / t}


def batch_speedup(nbatch: int = 64, seconds: float = 2.0) -> dict:
    robot, cfg = Robot(), SimConfig()
    model = build_model(robot, cfg)
    rng = np.random.default_rng(0)
    nstep = int(round(seconds / cfg.timestep))
    cmds = np.repeat(rng.uniform(-1, 1, (nbatch, 1, 2)), nstep, axis=1)
    s0 = np.repeat(settled_state(model)[None], nbatch, axis=0)
    out = {}
    for nthread in (1, 2):
        cpu0 = time.process_time()
        out[f"wall_seconds_{nthread}_thread"] = _median_time(lambda: run_batch([model], cmds, state0=s0,
                                                                               nthread=nthread))
        # CPU seconds of this process per repeat: equal for 1 and 2 threads means the threads
        # did not add work; a wall-clock speed-up then depends only on a free second core
        out[f"cpu_seconds_{nthread}_thread"] = (time.process_time() - cpu0) / REPEATS
    out["speedup"] = out["wall_seconds_1_thread"] / out["wall_seconds_2_thread"]
    out["nbatch"], out["steps_each"] = nbatch, nstep
    return out


def steps_vs_rollers(counts=(10, 16, 20, 30, 40), seconds: float = 2.0) -> list[dict]:
    rows = []
    for n in counts:
        cfg = SimConfig(n_rollers=n)
        model = build_model(Robot(), cfg)
        nstep = int(round(seconds / cfg.timestep))
        cmds = np.tile([-0.5, 0.5], (1, nstep, 1))
        s0 = settled_state(model)[None]
        t = _median_time(lambda: run_batch([model], cmds, state0=s0))
        rows.append({"n_rollers": n, "nv": model.nv, "steps_per_second": nstep / t,
                     "realtime_factor": seconds / t})
    return rows


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=Path("experiments/results/bench_sim.json"))
    args = p.parse_args(argv)
    load_before = os.getloadavg()
    rtf = realtime_factor()
    batch = batch_speedup()
    rollers = steps_vs_rollers()
    load_after = os.getloadavg()
    print(f"mujoco {mujoco.__version__}, {os.cpu_count()} cores, load average before {load_before[0]:.2f}, "
          f"after {load_after[0]:.2f}")
    print(f"default robot (timestep {SimConfig().timestep} s, {SimConfig().n_rollers} rollers/track): "
          f"{rtf['realtime_factor']:.0f}x real time ({rtf['steps_per_second']:.0f} steps/s, median of {REPEATS})")
    print(f"batch of {batch['nbatch']} x {batch['steps_each']} steps: 1 thread {batch['wall_seconds_1_thread']:.2f} s, "
          f"2 threads {batch['wall_seconds_2_thread']:.2f} s, speed-up {batch['speedup']:.2f} "
          f"(CPU s per run: {batch['cpu_seconds_1_thread']:.2f} / {batch['cpu_seconds_2_thread']:.2f})")
    print("rollers/track   nv   steps/s   x real time")
    for r in rollers:
        print(f"{r['n_rollers']:13d} {r['nv']:4d} {r['steps_per_second']:9.0f} {r['realtime_factor']:10.1f}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"realtime": rtf, "batch": batch, "rollers": rollers,
                                    "loadavg_before": load_before, "loadavg_after": load_after,
                                    "command": "python experiments/bench_sim.py"}, indent=1) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
