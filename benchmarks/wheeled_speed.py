"""Speed of the MuJoCo wheeled robot on one core: simulated seconds per wall-clock second.

    python benchmarks/wheeled_speed.py [--duration 60] [--repeats 3] [--out benchmarks/results]

A Husky-sized robot (the ``husky`` of benchmarks/wheeled_fidelity.py: 50 kg, 4 wheels of 0.165 m,
gauge 0.555 m, wheelbase 0.512 m) with the default settings (5 ms step) drives ``--duration``
seconds of seeded random steps (the ``random_steps`` scenario's commands), three ways:

* ``rollout``: the C loop of ``mujoco.rollout`` on one thread (:func:`mjtrack.sim.rollout.run_batch`,
  what ``simulate``, ``steady``, ``sweep``, windows and calibration use);
* ``mj_step``: a Python loop of ``mujoco.mj_step`` (what the closed-loop plant of ``track`` does);
* ``simulate``: :func:`mjtrack.sim.rollout.simulate` end to end (build, settle, rollout, log columns).

The default tracked robot (20 rollers) runs the same commands in the same run, so that the ratio
survives a loaded machine. Each is timed ``--repeats`` times (wall and CPU time of this process);
the real-time factor is the simulated time over the best wall time, and over the CPU time. Prints
the machine load (``os.getloadavg``) before and after: the machine is shared, and wall time on a
loaded core overstates the cost: the one-core speed is the CPU-time factor (the rollout runs on
one thread), the wall-time factor is what a loaded machine gave. Writes ``wheeled_speed.json``;
exit status 1 when the Husky's rollout is slower than 100x real time in CPU time.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import mujoco
import numpy as np

from mjtrack.io.robot import Robot
from mjtrack.sim.builder import build_model, control_matrix
from mjtrack.sim.config import SimConfig
from mjtrack.sim.rollout import hold_commands, run_batch, settled_state, simulate
from mjtrack.sim.scenarios import scenario_commands
from _results import RESULTS

HUSKY = Robot(traction="wheels", track_gauge=0.555, wheelbase=0.512, sprocket_radius=0.165, track_width=0.11,
              mass=50.0, cg_z=0.2)
TARGET = 100.0  # [x real time] on one core


def timed(fn, repeats: int) -> dict:
    walls, cpus = [], []
    for _ in range(repeats):
        w0, c0 = time.perf_counter(), time.process_time()
        fn()
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
    return {"wall_s": walls, "cpu_s": cpus}


def measure(robot: Robot, commands: np.ndarray, duration: float, repeats: int) -> dict:
    config = SimConfig()
    model = build_model(robot, config)
    s0 = settled_state(model)
    out = {"timestep": float(model.opt.timestep), "nv": int(model.nv), "contacts": int(model.npair)}
    out["rollout"] = timed(lambda: run_batch([model], commands[None], state0=s0[None], nthread=1), repeats)
    B = control_matrix(model)

    def loop():
        data = mujoco.MjData(model)
        mujoco.mj_setState(model, data, s0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        for u in commands:
            data.ctrl[:] = B @ u
            mujoco.mj_step(model, data)

    out["mj_step"] = timed(loop, repeats)
    out["simulate"] = timed(lambda: simulate(robot, commands, config=config), repeats)
    for k in ("rollout", "mj_step", "simulate"):
        out[k]["realtime_factor_wall"] = duration / min(out[k]["wall_s"])
        out[k]["realtime_factor_cpu"] = duration / min(out[k]["cpu_s"])
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--duration", type=float, default=60.0, help="simulated seconds (default 60)")
    ap.add_argument("--repeats", type=int, default=3, help="timings of each (default 3)")
    ap.add_argument("--out", type=Path, default=RESULTS, help="folder of the result file")
    args = ap.parse_args(argv)
    dt = SimConfig().timestep
    table, _ = scenario_commands("random_steps", HUSKY, duration=args.duration, seed=0)
    commands = hold_commands(*table, timestep=dt, duration=args.duration)
    load_before = os.getloadavg()
    print(f"load average before: {load_before[0]:.2f} {load_before[1]:.2f} {load_before[2]:.2f} "
          f"({os.cpu_count()} CPUs)")
    results = {name: measure(robot, commands, args.duration, args.repeats)
               for name, robot in (("husky_wheels", HUSKY), ("default_tracks", Robot()))}
    load_after = os.getloadavg()
    for name, res in results.items():
        print(f"{name}: dt {res['timestep'] * 1000:g} ms, {res['contacts']} contacts; " + "; ".join(
            f"{k} {res[k]['realtime_factor_wall']:.0f}x real time (wall), {res[k]['realtime_factor_cpu']:.0f}x (CPU)"
            for k in ("rollout", "mj_step", "simulate")))
    husky = results["husky_wheels"]["rollout"]["realtime_factor_cpu"]
    print(f"load average after: {load_after[0]:.2f} {load_after[1]:.2f} {load_after[2]:.2f}")
    print(f"Husky-sized robot, one core: {husky:.0f}x real time in CPU time, "
          f"{results['husky_wheels']['rollout']['realtime_factor_wall']:.0f}x in wall time at this load "
          f"(target {TARGET:g}x)")
    doc = {"command": "python benchmarks/wheeled_speed.py" + "".join(
               f" --{k} {v}" for k, v in (("duration", args.duration), ("repeats", args.repeats))),
           "duration_s": args.duration, "target_realtime_factor": TARGET, "robots": {"husky_wheels": HUSKY.to_dict()},
           "load_average_before": load_before, "load_average_after": load_after,
           "machine": {"cpus": os.cpu_count(), "python": platform.python_version(), "mujoco": mujoco.__version__,
                       "processor": platform.processor() or platform.machine()},
           "results": results}
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "wheeled_speed.json"
    path.write_text(json.dumps(doc, indent=1) + "\n")
    print(f"wrote {path}")
    return 0 if husky >= TARGET else 1


if __name__ == "__main__":
    sys.exit(main())
