"""Speed of the MuJoCo track models, old settings against new in one run.

    python benchmarks/bench_sim.py [--compare] [--quick] [--out benchmarks/results/bench_sim.json]
    python benchmarks/bench_sim.py --gpu [...]   # MuJoCo Warp on a GPU against the CPU (benchmarks/_gpu.py)

1. Real-time factor of the default robot: one 20 s ``random_steps`` rollout through
   ``mujoco.rollout`` on one thread (the library path of ``mjtrack simulate``), median of 5.
2. Where a step's time goes: MuJoCo's own per-stage timers (``MjData.timer``; cProfile sees
   one opaque C call) over 2 s of a turn, per step, and the solver iterations per step.
3. Steps per second against the roller count (one thread, turn command, median of 5) and the
   cost of N rollers relative to 10.
4. A batch of 64 rollouts (2 s each, random constant commands) through ``mujoco.rollout``
   with 1 and with 2 threads, median of 5 each; speed-up = t(1 thread) / t(2 threads).
5. The ``surfacevel`` model (its own settings, Python step loop) on the same turn.

``--compare`` times the previous roller defaults (``mjtrack.sim.config.previous_defaults``)
and the current ones side by side, repeats interleaved, so that the ratio new/old is measured
under the same load. The machine's load average is printed before and after: on a shared
machine absolute numbers move with the load, ratios much less. The real-time factor is also
given per CPU second of this process (``time.process_time``): on an oversubscribed machine
wall time includes waiting for a core, CPU time much less (cache sharing still slows it).
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
from mjtrack.sim.builder import build_model, control_matrix
from mjtrack.sim.config import SimConfig, previous_defaults, sim_config
from mjtrack.sim.rollout import STATE_SPEC, hold_commands, run_batch, settled_state
from mjtrack.sim.scenarios import scenario_commands
from _results import RESULTS

REPEATS = 5
TURN = (0.3, 0.6)  # [m/s] (V_L, V_R): a turn of nominal radius 0.4 m for the default robot
STAGES = ("POSITION", "POS_KINEMATICS", "POS_INERTIA", "POS_COLLISION", "POS_MAKE", "POS_PROJECT",
          "VELOCITY", "ACTUATION", "CONSTRAINT", "ADVANCE")


def _interleaved(fns: dict, repeats: int = REPEATS, *, cpu: dict | None = None) -> dict:
    """Median wall time of each callable, repeats interleaved (same load for all); with ``cpu``
    (a dict) also the median CPU time of this process per call, into cpu[k]."""
    times = {k: [] for k in fns}
    cpus = {k: [] for k in fns}
    for _ in range(repeats):
        for k, fn in fns.items():
            c0, t0 = time.process_time(), time.perf_counter()
            fn()
            times[k].append(time.perf_counter() - t0)
            cpus[k].append(time.process_time() - c0)
    if cpu is not None:
        cpu.update({k: statistics.median(v) for k, v in cpus.items()})
    return {k: statistics.median(v) for k, v in times.items()}


def realtime_factor(configs: dict[str, SimConfig], duration: float = 20.0) -> dict:
    robot = Robot()
    table, _ = scenario_commands("random_steps", robot, seed=0)
    fns, nsteps = {}, {}
    for name, cfg in configs.items():
        model = build_model(robot, cfg)
        cmds = hold_commands(*table, timestep=cfg.timestep, duration=duration)[None]
        s0 = settled_state(model)[None]
        nsteps[name] = cmds.shape[1]
        fns[name] = (lambda m=model, c=cmds, s=s0: run_batch([m], c, state0=s))
    cpu: dict = {}
    wall = _interleaved(fns, cpu=cpu)
    # per CPU second: what one core gives when this process has it to itself (the machine is shared)
    return {k: {"sim_seconds": duration, "wall_seconds": t, "realtime_factor": duration / t,
                "cpu_seconds": cpu[k], "realtime_factor_per_cpu_second": duration / cpu[k],
                "steps_per_second": nsteps[k] / t, "timestep": configs[k].timestep} for k, t in wall.items()}


def stage_profile(cfg: SimConfig, robot: Robot | None = None, seconds: float = 2.0) -> dict:
    """Per-stage time per step [ms] from MuJoCo's timers, over ``seconds`` of the TURN command."""
    robot = robot or Robot()
    model = build_model(robot, cfg)
    data = mujoco.MjData(model)
    nstep = int(round(seconds / cfg.timestep))
    if cfg.track_model == "surfacevel":
        from mjtrack.sim.surfacevel import set_track_speeds

        set_track_speeds(model, *TURN)
        mujoco.mj_forward(model, data)
    else:
        mujoco.mj_setState(model, data, settled_state(model), STATE_SPEC)
        data.ctrl[:] = control_matrix(model) @ np.array(TURN)
    for _ in range(nstep // 4):  # past the start transient
        mujoco.mj_step(model, data)
    state = np.empty(mujoco.mj_stateSize(model, STATE_SPEC))
    mujoco.mj_getState(model, data, state, STATE_SPEC)
    best = None
    for _ in range(3):  # the same stretch three times; keep the fastest (least disturbed) pass
        mujoco.mj_setState(model, data, state, STATE_SPEC)
        for t in data.timer:
            t.duration, t.number = 0.0, 0
        iters = 0
        for _ in range(nstep):
            mujoco.mj_step(model, data)
            iters += int(data.solver_niter[0])
        timers = {mujoco.mjtTimer(i).name.removeprefix("mjTIMER_"): data.timer[i].duration
                  for i in range(len(data.timer))}
        if best is None or timers["STEP"] < best["STEP"]:
            best = timers
    timers = best
    out = {"step_ms": 1e3 * timers["STEP"] / nstep, "nv": model.nv, "nefc": int(data.nefc), "ncon": int(data.ncon),
           "solver_iterations_per_step": iters / nstep}
    out.update({f"{k.lower()}_ms": 1e3 * timers[k] / nstep for k in STAGES})
    return out


def steps_vs_rollers(configs: dict[str, SimConfig], counts=(10, 16, 20, 30, 40), seconds: float = 2.0) -> dict:
    fns, nsteps = {}, {}
    for name, base in configs.items():
        for n in counts:
            cfg = base.replace(n_rollers=n)
            model = build_model(Robot(), cfg)
            nstep = int(round(seconds / cfg.timestep))
            cmds = np.tile(TURN, (1, nstep, 1))
            s0 = settled_state(model)[None]
            nsteps[(name, n)] = nstep
            fns[(name, n)] = (lambda m=model, c=cmds, s=s0: run_batch([m], c, state0=s))
    cpu: dict = {}
    wall = _interleaved(fns, cpu=cpu)
    out = {}
    for name in configs:
        rows = []
        for n in counts:
            t, c = wall[(name, n)], cpu[(name, n)]
            # cost from CPU time: on a shared machine wall time adds waiting for a core
            rows.append({"n_rollers": n, "steps_per_second": nsteps[(name, n)] / t, "realtime_factor": seconds / t,
                         "realtime_factor_per_cpu_second": seconds / c, "cost_vs_10": c / cpu[(name, counts[0])]})
        out[name] = rows
    return out


def batch_speedup(cfg: SimConfig, nbatch: int = 64, seconds: float = 2.0) -> dict:
    model = build_model(Robot(), cfg)
    rng = np.random.default_rng(0)
    nstep = int(round(seconds / cfg.timestep))
    cmds = np.repeat(rng.uniform(-1, 1, (nbatch, 1, 2)), nstep, axis=1)
    s0 = np.repeat(settled_state(model)[None], nbatch, axis=0)
    cpu0 = time.process_time()
    wall = _interleaved({n: (lambda n=n: run_batch([model], cmds, state0=s0, nthread=n)) for n in (1, 2)})
    cpu = (time.process_time() - cpu0) / REPEATS
    return {"nbatch": nbatch, "steps_each": nstep, "wall_seconds_1_thread": wall[1], "wall_seconds_2_thread": wall[2],
            "speedup": wall[1] / wall[2], "cpu_seconds_per_repeat_both": cpu}


def surfacevel_speed(seconds: float = 2.0) -> dict:
    """The surfacevel model's steps/s through its Python step loop (TrackDrive)."""
    from mjtrack.sim.surfacevel import TrackDrive

    robot, cfg = Robot(), sim_config("surfacevel")
    model = build_model(robot, cfg)
    nstep = int(round(seconds / cfg.timestep))

    def run() -> None:
        data = mujoco.MjData(model)
        drive = TrackDrive(model, robot, cfg)
        for _ in range(nstep):
            drive.step(data, *TURN)

    t = _interleaved({"surfacevel": run})["surfacevel"]
    return {"timestep": cfg.timestep, "n_elements": cfg.n_rollers, "steps_per_second": nstep / t,
            "realtime_factor": seconds / t}


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else list(argv)
    if "--gpu" in args:  # a machine with a CUDA device and mujoco_warp: its own options
        import _gpu

        args.remove("--gpu")
        return _gpu.main(args)
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=RESULTS / "bench_sim.json")
    p.add_argument("--compare", action="store_true",
                   help="time the previous roller defaults beside the current ones (same run, interleaved)")
    p.add_argument("--quick", action="store_true", help="fewer roller counts, no batch or surfacevel timing")
    args = p.parse_args(argv)
    configs = {"new": SimConfig()}
    if args.compare:
        configs = {"old": previous_defaults(), **configs}
    load_before = os.getloadavg()
    rtf = realtime_factor(configs)
    profile = {k: stage_profile(c) for k, c in configs.items()}
    rollers = steps_vs_rollers(configs, counts=(10, 20, 40) if args.quick else (10, 16, 20, 30, 40))
    batch = None if args.quick else batch_speedup(configs["new"])
    surf = None
    if not args.quick:
        surf = surfacevel_speed()
        surf["profile"] = stage_profile(sim_config("surfacevel"))
    load_after = os.getloadavg()

    print(f"mujoco {mujoco.__version__}, {os.cpu_count()} cores, load average (1/5/15 min) before "
          f"{'/'.join(f'{x:.2f}' for x in load_before)}, after {'/'.join(f'{x:.2f}' for x in load_after)}")
    for name, r in rtf.items():
        c = configs[name]
        print(f"{name:4s} default robot (dt {c.timestep} s, {c.n_rollers} rollers/track, {c.solver}, noslip "
              f"{c.noslip_iterations}): {r['realtime_factor']:.0f}x real time ({r['steps_per_second']:.0f} steps/s, "
              f"median of {REPEATS}); {r['realtime_factor_per_cpu_second']:.0f}x per CPU second")
    if args.compare:
        print(f"new / old speed: {rtf['new']['realtime_factor'] / rtf['old']['realtime_factor']:.2f}x wall, "
              f"{rtf['new']['realtime_factor_per_cpu_second'] / rtf['old']['realtime_factor_per_cpu_second']:.2f}x CPU")
    print("\nper step [ms] (MuJoCo timers, default robot turning; fastest of 3 passes):")
    print(f"{'':6s} {'step':>7s} " + " ".join(f"{s.lower():>11s}" for s in STAGES) + "  solver it/step  nefc")
    rows = dict(profile, **({"surfacevel": surf["profile"]} if surf else {}))
    for name, pr in rows.items():
        print(f"{name:6s} {pr['step_ms']:7.4f} " + " ".join(f"{pr[s.lower() + '_ms']:11.4f}" for s in STAGES)
              + f"  {pr['solver_iterations_per_step']:14.2f}  {pr['nefc']:4d}")
    print("\nrollers/track " + "  ".join(f"{name + ' steps/s':>14s} {'x real':>6s} {'x/CPU s':>7s} {'cost/10':>7s}"
                                         for name in rollers) + "   (cost: CPU time relative to 10 rollers)")
    for i, n in enumerate(rollers["new"]):
        print(f"{n['n_rollers']:13d} " + "  ".join(
            f"{rollers[k][i]['steps_per_second']:14.0f} {rollers[k][i]['realtime_factor']:6.1f} "
            f"{rollers[k][i]['realtime_factor_per_cpu_second']:7.1f} {rollers[k][i]['cost_vs_10']:7.2f}"
            for k in rollers))
    if batch:
        print(f"\nbatch of {batch['nbatch']} x {batch['steps_each']} steps (new): 1 thread {batch['wall_seconds_1_thread']:.2f} s, "
              f"2 threads {batch['wall_seconds_2_thread']:.2f} s, speed-up {batch['speedup']:.2f}")
    if surf:
        print(f"surfacevel (dt {surf['timestep']} s, {surf['n_elements']} elements/track, Python step loop): "
              f"{surf['steps_per_second']:.0f} steps/s, {surf['realtime_factor']:.1f}x real time; "
              f"rollers (new) / surfacevel real-time factor: {rtf['new']['realtime_factor'] / surf['realtime_factor']:.1f}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_suffix(".tmp")
    tmp.write_text(json.dumps({"realtime": rtf, "profile": profile, "rollers": rollers, "batch": batch,
                               "surfacevel": surf, "configs": {k: c.to_dict() for k, c in configs.items()},
                               "loadavg_before": load_before, "loadavg_after": load_after,
                               "command": "python benchmarks/bench_sim.py" + " --compare" * args.compare
                               + " --quick" * args.quick}, indent=1) + "\n")
    tmp.replace(args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
