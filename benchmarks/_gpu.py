"""Batched rollouts of the MuJoCo robots on a GPU (MuJoCo Warp) against the CPU (``mujoco.rollout``):
the ``--gpu`` mode of benchmarks/bench_sim.py.

    python benchmarks/bench_sim.py --gpu [--worlds 64,512,4096] [--steps 400] [--device cuda:0]
                                         [--out FILE]

Needs ``mujoco_warp`` and ``warp-lang`` (not dependencies of mjtrack) and a CUDA device; without
them it says so and exits 2. Three models, built by mjtrack as every command builds them: the
tracked robot with the roller chain (the model calibrate and diagnose simulate), the tracked robot
with surface-velocity tracks (``SimConfig(track_model="surfacevel")``) and a wheeled robot. For
each, N worlds start from the robot settled at rest, each driven by its own constant command pair
(seeded, uniform in +-1 m/s a side; the surfacevel tracks take one pair for every world, since
their speed is a model field); T steps of the model's own time step.

* CPU: ``mujoco.rollout`` with every CPU thread, timed after a warm-up call on min(N,
  ``--cpu-worlds``) worlds, its throughput taken for the N (it is flat once every thread has
  several worlds); as built, and adapted as the GPU needs (below);
* GPU: ``mujoco_warp.step`` on N worlds in a captured CUDA graph (``warp.ScopedCapture``) of
  ``--graph`` steps, launched T / graph times, timed after the capture and one warm-up launch;
* agreement: after T steps, the chassis position of the first worlds on the GPU against the CPU
  (the same model, state and commands: a difference is the two implementations', not the robot's);
* capacity: contacts and constraints per world on the CPU, what the GPU was given, and whether
  it overflowed;
* the model as built is offered to ``mujoco_warp.put_model`` first: what it refuses is recorded
  (``gpu_as_built``), and the model is adapted to what it runs (``adapted``: the PGS solver ->
  Newton, the automatic reset back on; the noslip pass kept unless ``--drop-noslip``);
  ``adaptation_shift_m`` is what the adaptation alone does to the motion on the CPU (the chassis
  position after T steps).

Writes benchmarks/results/gpu_rollout.json (or --out): per model and world count the steps per
second of each, the ratio, the agreement and the machine (GPU name, CPU threads, versions).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
import traceback
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
RESULT = HERE / "results" / "gpu_rollout.json"


def models():
    """(name, MjModel, B (nu, 2) or None, surfacevel geom ids or None), built by mjtrack."""
    from mjtrack.io.robot import Robot
    from mjtrack.sim.builder import build_model, control_matrix
    from mjtrack.sim.config import SimConfig
    from mjtrack.sim.surfacevel import surfacevel_config, track_geom_ids

    tracked = Robot()
    wheeled = Robot(traction="wheels", track_gauge=0.55, wheelbase=0.5, mass=50.0)
    out = []
    m = build_model(tracked, SimConfig())
    out.append(("tracked, roller chain", m, control_matrix(m), None))
    m = build_model(tracked, surfacevel_config())
    out.append(("tracked, surfacevel", m, None, track_geom_ids(m)))
    m = build_model(wheeled, SimConfig())
    out.append(("wheeled", m, control_matrix(m), None))
    return out


def adapted(m, drop_noslip: bool = False):
    """A copy of ``m`` with what MuJoCo Warp refuses changed to what it runs (each change named): the
    PGS solver -> Newton (the noslip pass, which carries the friction, kept unless ``drop_noslip``),
    MuJoCo's automatic reset on a bad state back on."""
    import copy

    import mujoco

    a, changes = copy.copy(m), []
    if a.opt.solver == mujoco.mjtSolver.mjSOL_PGS:
        a.opt.solver = mujoco.mjtSolver.mjSOL_NEWTON
        changes.append("solver PGS -> Newton")
    if a.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_AUTORESET:
        a.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)
        changes.append("automatic reset on a bad state back on")
    if drop_noslip and a.opt.noslip_iterations:  # --drop-noslip: cheaper, but the friction goes with it
        a.opt.noslip_iterations = 0
        changes.append("no noslip iterations")
    return a, changes


def cpu_run(m, state0, ctrl, steps: int, nthread: int) -> tuple[float, np.ndarray, dict]:
    """Seconds of one timed mujoco.rollout of len(ctrl) worlds x steps, the final states, capacity."""
    import mujoco
    from mujoco import rollout

    n = ctrl.shape[0]
    init = np.repeat(state0[None], n, axis=0)
    control = np.repeat(ctrl[:, None, :], steps, axis=1) if m.nu else None
    datas = [mujoco.MjData(m) for _ in range(nthread)]
    rollout.rollout(m, datas, init[:min(n, nthread)], None if control is None else control[:min(n, nthread), :10],
                    nstep=10)  # warm-up
    t0 = time.perf_counter()
    state, _ = rollout.rollout(m, datas, init, control, nstep=steps)
    dt = time.perf_counter() - t0
    # contacts and constraints per world, sampled along one world's run
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, state0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    ncon = nefc = 0
    for k in range(steps):
        if m.nu:
            d.ctrl[:] = ctrl[0]
        mujoco.mj_step(m, d)
        ncon, nefc = max(ncon, d.ncon), max(nefc, d.nefc)
    return dt, state[:, -1], {"ncon_max": int(ncon), "nefc_max": int(nefc)}


def gpu_run(m, state0, ctrl, steps: int, graph: int, cap: dict, device: str) -> tuple[float, np.ndarray, dict]:
    """Seconds of T steps of len(ctrl) worlds on the GPU (captured graphs), final qpos, capacity."""
    import mujoco
    import mujoco_warp as mjw
    import warp as wp

    n = ctrl.shape[0]
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, state0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    mujoco.mj_forward(m, d)
    nconmax = max(8, 2 * cap["ncon_max"])
    njmax = max(16, 2 * cap["nefc_max"])
    with wp.ScopedDevice(device):
        wm = mjw.put_model(m)
        wd = mjw.put_data(m, d, nworld=n, nconmax=nconmax, njmax=njmax)
        if m.nu:
            wd.ctrl.assign(wp.array(ctrl.astype(np.float32), dtype=wd.ctrl.dtype))
        mjw.step(wm, wd)  # compile the kernels
        wp.synchronize()
        try:
            with wp.ScopedCapture() as capture:
                for _ in range(graph):
                    mjw.step(wm, wd)
            launch, captured = (lambda: wp.capture_launch(capture.graph)), True
        except Exception:  # noqa: BLE001 - a device without graphs (warp's CPU): the plain loop
            def launch():
                for _ in range(graph):
                    mjw.step(wm, wd)
            captured = False
        launch()  # warm-up launch
        wp.synchronize()
        launches = max(1, steps // graph)
        t0 = time.perf_counter()
        for _ in range(launches):
            launch()
        wp.synchronize()
        dt = time.perf_counter() - t0
        qpos = wd.qpos.numpy()
        info = {"nconmax_per_world": nconmax, "njmax_per_world": njmax, "steps_run": launches * graph + graph + 1,
                "graph": captured}
        for name in ("nacon", "ncon"):
            if hasattr(wd, name):
                info[name + "_end"] = int(np.asarray(getattr(wd, name).numpy()).max())
        if hasattr(wd, "nefc"):
            info["nefc_end_max"] = int(np.asarray(wd.nefc.numpy()).max())
    return dt * steps / (launches * graph), qpos, info


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="bench_sim.py --gpu", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--worlds", default="64,512,4096")
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--graph", type=int, default=50, help="steps per captured graph (default 50)")
    ap.add_argument("--cpu-worlds", type=int, default=512,
                    help="worlds the CPU is timed on (its throughput scaled to N; default 512)")
    ap.add_argument("--device", default="cuda:0", help="cuda:0 (default), or cpu: warp's CPU device (a check of "
                    "what MuJoCo Warp accepts and of its agreement, without a GPU; its times mean nothing)")
    ap.add_argument("--drop-noslip", action="store_true",
                    help="also take out the noslip pass (it carries the friction: the motion changes, see shift)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=RESULT)
    args = ap.parse_args(argv)
    try:
        import mujoco
        import mujoco_warp
        import warp as wp
    except ImportError as e:
        print(f"bench_sim.py --gpu: {e}: needs mujoco_warp and warp-lang", file=sys.stderr)
        return 2
    wp.init()
    dev = wp.get_device(args.device)
    machine = {"gpu": dev.name, "cpu_threads": os.cpu_count(), "platform": platform.platform(),
               "python": platform.python_version(), "mujoco": mujoco.__version__, "warp": wp.__version__,
               "mujoco_warp": getattr(mujoco_warp, "__version__", "unknown"), "load_before": os.getloadavg()}
    print(json.dumps(machine), flush=True)
    from mjtrack.sim.rollout import settled_state
    from mjtrack.sim.surfacevel import set_track_speeds

    rng = np.random.default_rng(args.seed)
    worlds = [int(w) for w in args.worlds.split(",")]
    nthread = os.cpu_count() or 1
    results = []
    for name, m, B, ids in models():
        state0 = settled_state(m)
        for n in worlds:
            cmd = rng.uniform(-1.0, 1.0, size=(n, 2))
            if ids is not None:  # one track speed pair for every world: a model field
                set_track_speeds(m, *cmd[0], ids=ids)
                cmd[:] = cmd[0]
            ctrl = cmd @ B.T if B is not None else np.zeros((n, m.nu))
            row = {"model": name, "worlds": n, "steps": args.steps, "timestep": m.opt.timestep, "nv": m.nv,
                   "ngeom": m.ngeom, "nu": m.nu}
            nc = min(n, args.cpu_worlds)  # the CPU's throughput is flat beyond a few worlds a thread
            row["cpu_worlds"] = nc
            try:
                t_cpu, s_cpu, cap = cpu_run(m, state0, ctrl[:nc], args.steps, nthread)
                t_cpu *= n / nc  # the time the N worlds take at the measured throughput
                row.update(cpu_s=t_cpu, cpu_steps_per_s=n * args.steps / t_cpu, **cap)
                k = min(nc, 8)
                row["cpu_path_original_m"] = float(np.max(np.linalg.norm(s_cpu[:k, 1:3] - state0[1:3][None], axis=1)))
            except Exception as e:  # noqa: BLE001 - recorded, the other rows still run
                row["cpu_error"] = f"{type(e).__name__}: {e}"
                print(traceback.format_exc(), file=sys.stderr)
                results.append(row)
                continue
            try:  # the model as mjtrack builds it
                mujoco_warp.put_model(m)
                row["gpu_as_built"] = "accepted"
            except Exception as e:  # noqa: BLE001 - what MuJoCo Warp refuses is the finding
                row["gpu_as_built"] = f"{type(e).__name__}: {e}"[:500]
            a, changes = adapted(m, args.drop_noslip)
            row["adapted"] = changes
            try:
                t_cpu_a, s_cpu_a, cap_a = cpu_run(a, state0, ctrl[:nc], args.steps, nthread)
                t_cpu_a *= n / nc
                row.update(cpu_adapted_s=t_cpu_a, cpu_adapted_steps_per_s=n * args.steps / t_cpu_a)
                # what the adaptation alone does to the physics: CPU original against CPU adapted
                row["adaptation_shift_m"] = float(np.max(np.linalg.norm(s_cpu_a[:k, 1:3] - s_cpu[:k, 1:3], axis=1)))
                t_gpu, qpos, info = gpu_run(a, state0, ctrl, args.steps, args.graph,
                                            {k2: max(cap[k2], cap_a[k2]) for k2 in cap}, args.device)
                row.update(gpu_s=t_gpu, gpu_steps_per_s=n * args.steps / t_gpu, speedup=t_cpu / t_gpu,
                           speedup_same_model=t_cpu_a / t_gpu, **info)
                # agreement after the same number of steps: the CPU rerun for the GPU's step count
                _, s_same, _ = cpu_run(a, state0, ctrl[:k], info["steps_run"], min(k, nthread))
                qpos_cpu = s_same[:, 1:1 + m.nq]  # full physics state: time, qpos, ...
                row["agreement_m"] = float(np.max(np.linalg.norm(qpos[:k, :2] - qpos_cpu[:, :2], axis=1)))
                row["cpu_path_m"] = float(np.max(np.linalg.norm(qpos_cpu[:, :2] - state0[1:3][None], axis=1)))
            except Exception as e:  # noqa: BLE001
                row["gpu_error"] = f"{type(e).__name__}: {e}"[:2000]
                print(traceback.format_exc(), file=sys.stderr)
            print(json.dumps(row), flush=True)
            results.append(row)
            args.out.parent.mkdir(parents=True, exist_ok=True)
            args.out.write_text(json.dumps({"command": "python benchmarks/bench_sim.py --gpu " + " ".join(
                sys.argv[1:] if argv is None else argv), "machine": machine, "rows": results}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
