"""Fidelity of the MuJoCo wheeled robot against the point-contact Coulomb reference.

    python benchmarks/wheeled_fidelity.py [--quick] [--out benchmarks/results]
    python benchmarks/wheeled_fidelity.py --speed [--duration 60] [--repeats 3] [--out benchmarks/results]

The wheeled robot (``traction: "wheels"``, :class:`mjtrack.sim.builder.WheelSet`: sprung
spheres of the wheel radius at the axles, the roller chain's noslip Coulomb friction) in steady
turns, against :func:`mjtrack.models.coulomb.steady_state` on the same robot: one Coulomb point
contact under each axle, the rigid chassis' linear (Wong) load distribution with the CG offset
and the load transfer of the turn, at the wheel speeds MuJoCo measured. Independent physics:
the reference knows nothing of MuJoCo's contacts, springs or solver.

Grid: :data:`ROBOTS` (2 and 3 wheels a side, 12-280 kg, a Husky-like, a Husky with a 30 kg
payload, a Warthog-like, a Jackal-like, two six-wheelers, a wide and a split-friction robot,
cg_y 0.05 T on some) x turns of nominal radius R in :data:`RADII` (pivot: wheel speeds -+v) at
v in :data:`SPEEDS`, left and right, forward and reverse (pivots forward only: a reversed pivot
is the mirrored one) x cg_x in :data:`CG` (fractions of the wheelbase). Commands from the no-slip
kinematics, w = v/R, V_L,R = v -+ w T/2; turns with v^2/R above 0.5 mu g are left out (the
robot slides out: no steady turn). Each case: :data:`SETTLE_S` at the constant command (the
mass-scaled drive spins a 280 kg robot's 0.3 m wheels up to 2 m/s in about 3 s), then the mean over
2 s (:func:`mjtrack.sim.steady.steady_batch`, each case at the step ``SimConfig.step_for`` picks for
its wheelbase and speeds; ``timestep`` in its row), the ICRs by (2.13) with the measured wheel
speeds; then again with the step halved (:meth:`SimConfig.halved`).

Pass (every case): |y_l - y_l*|, |y_r - y_r*|, |x_c - x_c*| <= 0.05 T/2 (``err``), halving the
step moves each ICR by < 0.02 T/2 (``dt_err``), each side has a wheel on the ground in >= 99 %
of the steps, and the window is steady (standard deviation of wz <= 0.1 % of |wz|). Prints the worst cases and medians; writes ``wheeled_fidelity[_quick].json`` with
every row, the summary, the command and the machine load; exit status 1 if a case fails. Also
reported: x_c's error less v_x dt (``err_x_c_horizon``), the offset of the friction rows' horizon
(assets/README.md), to show what is left beside it.
``--quick``: :data:`QUICK` (a subset for the tests).

**Speed** (``--speed``): simulated seconds per wall-clock second on one core. A Husky-sized robot (:data:`HUSKY`: 50 kg, 4 wheels of 0.165 m,
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
from mjtrack.models.coulomb import steady_state as coulomb_steady
from mjtrack.sim.builder import build_model, control_matrix
from mjtrack.sim.config import SimConfig
from mjtrack.sim.rollout import hold_commands, run_batch, settled_state, simulate
from mjtrack.sim.scenarios import scenario_commands
from mjtrack.sim.steady import case_timestep, steady_batch
from _results import RESULTS



def wheeled(**keys) -> Robot:
    return Robot(traction="wheels", **keys)


HUSKY = wheeled(track_gauge=0.555, wheelbase=0.512, sprocket_radius=0.165, track_width=0.11, mass=50.0, cg_z=0.2)
# robots: (2 or 3 wheels a side; masses 12-280 kg; B/T 0.5-1.5)
ROBOTS: dict[str, Robot] = {
    "husky": HUSKY,
    "husky_payload": HUSKY.replace(mass=80.0, cg_z=0.25),  # a 30 kg payload on top
    "warthog": wheeled(track_gauge=1.08, wheelbase=1.1, sprocket_radius=0.3, track_width=0.25, mass=280.0, cg_z=0.45,
                       cg_y=0.054),
    "jackal": wheeled(track_gauge=0.37, wheelbase=0.262, sprocket_radius=0.098, track_width=0.05, mass=17.0, cg_z=0.1),
    "six_wheeler": wheeled(track_gauge=0.8, wheelbase=1.0, sprocket_radius=0.2, track_width=0.15, mass=150.0,
                           cg_z=0.35, wheels_per_side=3),
    "six_wheeler_small": wheeled(track_gauge=0.4, wheelbase=0.6, sprocket_radius=0.08, track_width=0.05, mass=12.0,
                                 cg_z=0.1, wheels_per_side=3, cg_y=0.02),
    "wide": wheeled(track_gauge=0.9, wheelbase=0.45, sprocket_radius=0.2, track_width=0.12, mass=80.0, cg_z=0.25,
                    mu=0.6),
    "split_mu": HUSKY.replace(mu_left=0.5, mu_right=0.9),  # friction per side
}
RADII = ("pivot", 0.5, 1.0, 2.0, 5.0, 10.0)  # [m]
SPEEDS = (0.2, 0.7, 2.0)  # [m/s]
CG = (-0.1, 0.0, 0.1)  # cg_x / wheelbase
DIRECTIONS = (1, -1)  # +1 left (CCW), -1 right
TRAVEL = (1, -1)  # +1 forward, -1 reverse
QUICK = dict(robots=("husky", "warthog", "six_wheeler", "jackal"), radii=("pivot", 1.0, 10.0), speeds=(0.2, 2.0),
             cg=(-0.1, 0.1), directions=(1,), travel=(1,))
TOL_ERR, TOL_DT, TOL_CONTACT = 0.05, 0.02, 0.99  # T/2, T/2 (dt halving), share of steps
TOL_STEADY = 1e-3  # window std of wz / |wz|
SETTLE_S = 5.0  # [s] at the command before the 2 s window
MAX_LATERAL_ACCEL = 0.5  # [mu g] nominal v^2/R above this: no steady turn


def commands_for(robot: Robot, radius, v: float, direction: int, travel: int) -> tuple[float, float]:
    """(V_L, V_R) [m/s] of a nominal turn (no-slip kinematics), or a pivot at wheel speeds -+v."""
    if radius == "pivot":
        return -direction * v, direction * v
    w = direction * v / radius
    half = w * robot.track_gauge / 2
    return travel * (v - half), travel * (v + half)


def cases(quick: bool):
    """(meta, robot, (V_L, V_R)) of every case of the grid (module docstring)."""
    sel = QUICK if quick else dict(robots=tuple(ROBOTS), radii=RADII, speeds=SPEEDS, cg=CG, directions=DIRECTIONS,
                                   travel=TRAVEL)
    for name in sel["robots"]:
        base = ROBOTS[name]
        mu = min(base.friction_left, base.friction_right)
        for radius in sel["radii"]:
            for v in sel["speeds"]:
                if radius != "pivot" and v * v / radius > MAX_LATERAL_ACCEL * 9.81 * mu:
                    continue
                for direction in sel["directions"]:
                    for travel in (sel["travel"] if radius != "pivot" else (1,)):
                        for cgf in sel["cg"]:
                            robot = base.replace(cg_x=round(cgf * base.contact_length, 6))
                            meta = dict(robot=name, radius=radius, v=v, direction=direction, travel=travel, cg_frac=cgf,
                                        wheels_per_side=robot.wheels_per_side, mass=robot.mass, T=robot.track_gauge,
                                        B=robot.contact_length)
                            yield meta, robot, commands_for(robot, radius, v, direction, travel)


def _icr_change(a, b) -> float:
    return max(abs(a.y_l - b.y_l), abs(a.y_r - b.y_r), abs(a.x_c - b.x_c))


def run(quick: bool, config: SimConfig | None = None) -> list[dict]:
    """Every case against the Coulomb reference, with the dt-halving change (module docstring)."""
    config = config or SimConfig()
    groups: dict[str, list] = {}
    for c in cases(quick):
        groups.setdefault(c[0]["robot"], []).append(c)
    rows = []
    for group in groups.values():
        robots, cmds = [c[1] for c in group], np.array([c[2] for c in group])
        base = steady_batch(robots, cmds, config=config, settle_s=SETTLE_S)
        fine = steady_batch(robots, cmds, config=config.halved(), settle_s=SETTLE_S)
        for (meta, robot, cmd), res, f in zip(group, base, fine):
            half = robot.track_gauge / 2
            row = dict(meta, **res.to_dict(), timestep=case_timestep(config, robot, cmd))
            try:
                ref = coulomb_steady(robot, res.v_left, res.v_right)
                row.update(ref_y_l=ref.y_l, ref_y_r=ref.y_r, ref_x_c=ref.x_c, ref_wz=ref.wz,
                           err_y_l=abs(res.y_l - ref.y_l) / half, err_y_r=abs(res.y_r - ref.y_r) / half,
                           err_x_c=abs(res.x_c - ref.x_c) / half)
                row["err"] = max(row["err_y_l"], row["err_y_r"], row["err_x_c"])
                # less the friction rows' horizon: the noslip friction opposes the slip one step
                # ahead, which puts x_c v_x dt ahead of Coulomb (assets/README.md)
                row["err_x_c_horizon"] = abs(res.x_c - ref.x_c - res.vx * row["timestep"]) / half
            except Exception as exc:  # noqa: BLE001 -- no reference steady state (tip-over): a failure
                row.update(ref_error=str(exc), err=float("nan"))
            row["dt_err"] = _icr_change(res, f) / half
            row["contact_min"] = min(res.contact_left, res.contact_right)
            row["steady"] = bool(res.wz_std <= TOL_STEADY * abs(res.wz))
            row["pass"] = bool(row["err"] <= TOL_ERR and row["dt_err"] < TOL_DT and row["contact_min"] >= TOL_CONTACT
                               and row["steady"])
            rows.append(row)
    return rows


CASE_KEYS = ("robot", "radius", "v", "direction", "travel", "cg_frac", "wheels_per_side", "mass", "T", "B", "timestep")


def summary(rows: list[dict]) -> dict:
    """Pass count, worst case (with the case) and median of each error; NaN counts as worst."""
    def worst(key):
        r = max(rows, key=lambda r: np.inf if not np.isfinite(r[key]) else r[key])
        return {"value": r[key], "case": {k: r[k] for k in CASE_KEYS}}

    out = {"cases": len(rows), "passed": sum(r["pass"] for r in rows),
           "no_reference": sum("ref_error" in r for r in rows), "min_contact": min(r["contact_min"] for r in rows),
           "unsteady": sum(not r["steady"] for r in rows)}
    for key in ("err", "err_y_l", "err_y_r", "err_x_c", "err_x_c_horizon", "dt_err"):
        vals = [r.get(key, float("nan")) for r in rows]
        out[f"worst_{key}"] = worst(key) if key in ("err", "dt_err") else float(np.nanmax(vals))
        out[f"median_{key}"] = float(np.nanmedian(vals))
    by_robot: dict[str, list[int]] = {}
    for r in rows:
        cell = by_robot.setdefault(r["robot"], [0, 0])
        cell[0] += bool(r["pass"])
        cell[1] += 1
    out["passed_by_robot"] = {k: f"{a}/{b}" for k, (a, b) in by_robot.items()}
    return out


def write_result(doc: dict, path: Path) -> None:
    """The result file: the header indented, one line per row (a diff shows the rows that moved)."""
    head = json.dumps({k: v for k, v in doc.items() if k != "rows"}, indent=1, default=float)
    rows = ",\n".join("  " + json.dumps(r, default=float) for r in doc["rows"])
    path.write_text(head[:-2] + ',\n "rows": [\n' + rows + "\n ]\n}\n")


# ----------------------------------------------------------------- speed
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


def speed_main(args) -> int:
    """``--speed``: the real-time factors (module docstring); writes ``wheeled_speed.json``."""
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
    doc = {"command": "python benchmarks/wheeled_fidelity.py --speed" + "".join(
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



def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="the quick subset (QUICK)")
    ap.add_argument("--speed", action="store_true", help="the speed runs instead of the fidelity grid")
    ap.add_argument("--duration", type=float, default=60.0, help="--speed: simulated seconds (default 60)")
    ap.add_argument("--repeats", type=int, default=3, help="--speed: timings of each (default 3)")
    ap.add_argument("--out", type=Path, default=RESULTS, help="folder of the result file")
    args = ap.parse_args(argv)
    if args.speed:
        return speed_main(args)
    load_before = os.getloadavg()
    tic = time.perf_counter()
    rows = run(args.quick)
    wall = time.perf_counter() - tic
    summ = summary(rows)
    for r in rows:
        print(f"{r['robot']:18s} {r['wheels_per_side']}w {r['mass']:5.0f} kg R {str(r['radius']):>5s} v {r['v']:3.1f} "
              f"dir {r['direction']:+d} fwd {r['travel']:+d} cg {r['cg_frac']:+.1f}B  err {r['err']:.4f}  "
              f"dt {r['dt_err']:.4f}  contact {r['contact_min']:.3f}{'' if r['pass'] else '  FAIL'}")
    print(json.dumps(summ, indent=1))
    print(f"{summ['passed']}/{summ['cases']} pass; worst {summ['worst_err']['value']:.4f} T/2, median "
          f"{summ['median_err']:.4f} T/2; dt halving worst {summ['worst_dt_err']['value']:.4f} T/2; {wall:.0f} s wall, "
          f"load average {os.getloadavg()[0]:.2f}")
    doc = {"command": "python benchmarks/wheeled_fidelity.py" + (" --quick" if args.quick else ""),
           "tolerances": {"err_over_half_gauge": TOL_ERR, "dt_halving_over_half_gauge": TOL_DT,
                          "contact": TOL_CONTACT, "wz_std_over_wz": TOL_STEADY}, "settle_s": SETTLE_S,
           "robots": {k: v.to_dict() for k, v in ROBOTS.items()},
           "summary": summ, "wall_s": wall, "load_average_before": load_before, "load_average_after": os.getloadavg(),
           "machine": {"cpus": os.cpu_count(), "python": platform.python_version()}, "rows": rows}
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / ("wheeled_fidelity_quick.json" if args.quick else "wheeled_fidelity.json")
    write_result(doc, path)
    print(f"wrote {path}")
    return 0 if summ["passed"] == summ["cases"] else 1


if __name__ == "__main__":
    sys.exit(main())
