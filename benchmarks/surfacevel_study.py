"""Fidelity of the surfacevel track model (mjtrack.sim.surfacevel) against the Coulomb reference.

Usage:  python benchmarks/surfacevel_study.py [--out FILE.json] [--quick]

Default Robot() (T = 0.4 m, L = 0.5 m, 20 kg, mu 0.8), settings ``surfacevel_config()``.
Sections (each printed as a table, all written to the JSON file):
  turns        pivot turn and nominal radii 0.25, 0.5, 1, 2 m at 0.3 and 0.8 m/s, both directions,
               cg_x in {-0.05, 0, +0.05}: steady ICRs (2.13) vs mjtrack.models.coulomb.steady_state;
               errors of y_l, y_r in units of T/2, of x_c in units of L; contact fraction per track.
  straight     |vx - V| / V and lateral drift per metre travelled.
  convergence  ICR change when the timestep is halved (units of T/2).
  speed        simulation steps per second (plain mj_step loop, pivot turn).
  ablation     the causes: pivot at 0.3 m/s under other contact settings (yaw ratio, contact, loads).
Targets (the fidelity grid's): |dy| < 0.10 T/2, |dx_c| < 0.02 L, contact >= 99 %, |vx - V| < 1 % V,
drift < 1 mm/m, timestep-halving change < 3 %.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time

import mujoco
import numpy as np

from mjtrack.io.atomic import atomic_write_text
from mjtrack.io.robot import Robot
from mjtrack.models.coulomb import steady_state
from mjtrack.sim.config import SimConfig
from mjtrack.sim.surfacevel import (
    build_surfacevel_model,
    element_positions,
    run_steady,
    set_track_speeds,
    surfacevel_config,
)
from mjtrack.testing.repo import RESULTS

DURATION, AVERAGE = 5.0, 2.0  # [s] run length and averaging window of a steady run


def commands(v: float, radius, direction: int, T: float) -> tuple[float, float]:
    """(V_L, V_R) for a pivot turn (radius "pivot") or a nominal radius R [m] (eq. 2.1)."""
    if radius == "pivot":
        return -direction * v, direction * v
    k = direction * T / (2 * radius)
    return v * (1 - k), v * (1 + k)


def turn_row(robot: Robot, config: SimConfig, v: float, radius, direction: int) -> dict:
    vl, vr = commands(v, radius, direction, robot.track_gauge)
    run = run_steady(build_surfacevel_model(robot, config), vl, vr, duration=DURATION, average=AVERAGE)
    ref = steady_state(robot, vl, vr)
    y_l, y_r, x_c = run.icr()
    half, L = robot.track_gauge / 2, robot.track_length
    return dict(v=v, radius=radius, direction=direction, cg_x=robot.cg_x, v_left=vl, v_right=vr,
                y_l=y_l, y_r=y_r, x_c=x_c, ref_y_l=ref.y_l, ref_y_r=ref.y_r, ref_x_c=ref.x_c,
                err_y_l=(y_l - ref.y_l) / half, err_y_r=(y_r - ref.y_r) / half, err_x_c=(x_c - ref.x_c) / L,
                contact_left=run.contact_left, contact_right=run.contact_right, warnings=run.warnings)


def spinup_time(robot: Robot, config: SimConfig, v: float) -> float:
    """Time [s] for straight driving from rest to reach 0.95 V (Coulomb: 0.95 V / (mu g))."""
    model = build_surfacevel_model(robot, config)
    data = mujoco.MjData(model)
    set_track_speeds(model, v, v)
    for k in range(int(3.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
        if data.sensor("body_linvel").data[0] >= 0.95 * v:
            return (k + 1) * model.opt.timestep
    return float("inf")


ROLLER_CONTACT = ("friction_timeconst", "noslip_iterations", "solimp", "impratio", "contact_margin")
SETTINGS = {  # name -> SimConfig changes from surfacevel_config(), compared on the quick turn set
    "recommended": {},
    "weak friction rows (friction_timeconst 0.05 s)": dict(friction_timeconst=0.05),
    "weak friction solref (1 s) + noslip 20": dict(friction_timeconst=1.0, noslip_iterations=20),
    "weak friction solref (1 s), noslip off": dict(friction_timeconst=1.0),
    "weak friction impedance (impratio 1e-4), noslip off": dict(impratio=1e-4),
    "SimConfig() contact defaults (roller chain, now)": {k: getattr(SimConfig(), k) for k in ROLLER_CONTACT},
}


def steps_per_second(config: SimConfig, n: int = 3000, *, rollers: bool = False) -> float:
    """Plain mj_step loop in a pivot turn; ``rollers``: the roller chain (mjtrack.sim.builder) instead."""
    if rollers:
        from mjtrack.sim.builder import build_model

        model = build_model(Robot(), config)
        data = mujoco.MjData(model)
        for i in range(model.nu):  # the builder's drives: drive_<side>[_<k>], ctrl = track speed [m/s]
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, i) or ""
            data.ctrl[i] = -0.3 if name.startswith("drive_left") else 0.3 if name.startswith("drive_right") else 0.0
    else:
        model = build_surfacevel_model(Robot(), config)
        data = mujoco.MjData(model)
        set_track_speeds(model, -0.3, 0.3)
    t0 = time.perf_counter()
    for _ in range(n):
        mujoco.mj_step(model, data)
    return n / (time.perf_counter() - t0)


ABLATION = {  # name -> (SimConfig changes, builder options); MuJoCo's own contact defaults first
    "rigid box x1, pyramidal, mujoco defaults": (
        dict(cone="pyramidal", impratio=1.0, contact_timeconst=0.02, solimp=(0.9, 0.95, 0.001, 0.5, 2),
             friction_timeconst=0.0), dict(element="box", n_elements=1, sprung=False)),
    "rigid box x1, elliptic, mujoco defaults": (
        dict(impratio=1.0, contact_timeconst=0.02, solimp=(0.9, 0.95, 0.001, 0.5, 2), friction_timeconst=0.0),
        dict(element="box", n_elements=1, sprung=False)),
    "rigid spheres x12, pyramidal, mujoco defaults": (
        dict(cone="pyramidal", impratio=1.0, contact_timeconst=0.02, solimp=(0.9, 0.95, 0.001, 0.5, 2),
             friction_timeconst=0.0), dict(sprung=False)),
    "rigid spheres x12, elliptic, mujoco defaults": (
        dict(impratio=1.0, contact_timeconst=0.02, solimp=(0.9, 0.95, 0.001, 0.5, 2), friction_timeconst=0.0),
        dict(sprung=False)),
    "rigid spheres x12, recommended contact": ({}, dict(sprung=False)),
    "sprung spheres x12, mujoco defaults": (
        dict(impratio=1.0, contact_timeconst=0.02, solimp=(0.9, 0.95, 0.001, 0.5, 2), friction_timeconst=0.0), {}),
    "sprung, SimConfig() contact defaults": ({k: getattr(SimConfig(), k) for k in ROLLER_CONTACT}, {}),
    "sprung, weak friction rows (timeconst 0.05 s)": (dict(friction_timeconst=0.05), {}),
    "sprung, solimp dmin 0.95 (SimConfig)": (dict(solimp=SimConfig().solimp), {}),
    "sprung, recommended + noslip 10": (dict(noslip_iterations=10), {}),
    "sprung, recommended, impratio 1": (dict(impratio=1.0), {}),
    "sprung, recommended, pyramidal": (dict(cone="pyramidal"), {}),
    "sprung, recommended (spheres x12)": ({}, {}),
    "sprung, recommended, capsules x12": ({}, dict(element="capsule")),
    "sprung, recommended, boxes x12": ({}, dict(element="box")),
    "sprung, recommended, spheres x24": (dict(n_rollers=24), {}),
}


def ablation_row(name: str, v: float = 0.3) -> dict:
    changes, options = ABLATION[name]
    robot = Robot()
    model = build_surfacevel_model(robot, surfacevel_config(**changes), **options)
    t0 = time.perf_counter()
    run = run_steady(model, -v, v, duration=DURATION, average=AVERAGE)
    wall = time.perf_counter() - t0
    ref = steady_state(robot, -v, v)
    loads = run.loads[run.loads > 0]
    # slip speed |u_i| of each element (coulomb.py eq. 1) and how closely the loads follow it
    x = element_positions(robot, run.loads.shape[1])
    u = np.array([np.hypot(run.vx - run.wz * y - vs, run.vy + run.wz * x)
                  for y, vs in ((robot.track_gauge / 2, -v), (-robot.track_gauge / 2, v))])
    ratio = run.loads / u
    return dict(name=name, yaw_ratio=run.wz / (2 * v / robot.track_gauge),
                ref_yaw_ratio=ref.wz / (2 * v / robot.track_gauge),
                err_y_l=(run.icr()[0] - ref.y_l) / (robot.track_gauge / 2),
                contact=min(run.contact_left, run.contact_right),
                load_max_over_mean=float(run.loads.max() / run.loads.mean()) if loads.size else float("nan"),
                load_min_over_mean=float(run.loads.min() / run.loads.mean()) if loads.size else float("nan"),
                load_per_slip_cv=float(ratio.std() / ratio.mean()) if x.size > 1 else float("nan"),
                load_cv=float(run.loads.std() / run.loads.mean()),
                steps_per_s=DURATION / model.opt.timestep / wall)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(RESULTS / "surfacevel_study.json"))
    ap.add_argument("--quick", action="store_true", help="cg_x = 0 and one direction only")
    args = ap.parse_args(argv)
    logging.getLogger("mjtrack.sim.surfacevel").setLevel(logging.ERROR)  # bad settings are studied on purpose
    config = surfacevel_config()
    cgs = (0.0,) if args.quick else (-0.05, 0.0, 0.05)
    dirs = (1,) if args.quick else (1, -1)
    radii = ("pivot", 0.25, 0.5, 1.0, 2.0)
    result: dict = {"config": config.to_dict(), "duration_s": DURATION, "average_s": AVERAGE}

    print("turns: ICR errors vs Coulomb (y in units of T/2, x_c in units of L)")
    print(f"{'cg_x':>6} {'V':>4} {'R':>6} {'dir':>3} {'y_l':>7} {'ref':>7} {'y_r':>7} {'ref':>7} {'x_c':>7} "
          f"{'ref':>7} {'dy_l':>6} {'dy_r':>6} {'dx_c':>7} {'cont':>6}")
    turns = []
    for cg in cgs:
        robot = Robot(cg_x=cg)
        for v in (0.3, 0.8):
            for radius in radii:
                for d in dirs:
                    r = turn_row(robot, config, v, radius, d)
                    turns.append(r)
                    print(f"{cg:6.2f} {v:4.1f} {str(radius):>6} {d:3d} {r['y_l']:7.3f} {r['ref_y_l']:7.3f} "
                          f"{r['y_r']:7.3f} {r['ref_y_r']:7.3f} {r['x_c']:7.3f} {r['ref_x_c']:7.3f} "
                          f"{r['err_y_l']:6.3f} {r['err_y_r']:6.3f} {r['err_x_c']:7.4f} "
                          f"{min(r['contact_left'], r['contact_right']):6.4f}", flush=True)
    result["turns"] = turns
    worst = dict(err_y=max(max(abs(r["err_y_l"]), abs(r["err_y_r"])) for r in turns),
                 err_x_c=max(abs(r["err_x_c"]) for r in turns),
                 contact=min(min(r["contact_left"], r["contact_right"]) for r in turns),
                 warnings=sum(r["warnings"] for r in turns))
    result["turns_worst"] = worst
    print(f"worst: |dy| {worst['err_y']:.3f} T/2 (target 0.10), |dx_c| {worst['err_x_c']:.4f} L (0.02), "
          f"contact {worst['contact']:.4f} (0.99), warnings {worst['warnings']}")

    print("\nstraight driving")
    straight = []
    for cg in cgs:
        for v in (0.3, 0.8):
            run = run_steady(build_surfacevel_model(Robot(cg_x=cg), config), v, v, duration=DURATION,
                             average=AVERAGE)
            row = dict(cg_x=cg, v=v, speed_err=abs(run.vx - v) / v, drift_m_per_m=run.drift,
                       contact=min(run.contact_left, run.contact_right),
                       spinup_s=spinup_time(Robot(cg_x=cg), config, v), coulomb_spinup_s=0.95 * v / (0.8 * 9.81))
            straight.append(row)
            print(f"cg_x {cg:5.2f} V {v:.1f}: |vx-V|/V {row['speed_err']:.2e}  drift {row['drift_m_per_m']:.2e} m/m  "
                  f"contact {row['contact']:.4f}  t(0.95 V) {row['spinup_s']:.3f} s "
                  f"(Coulomb {row['coulomb_spinup_s']:.3f} s)")
    result["straight"] = straight

    print("\nconvergence: timestep 0.002 -> 0.001 (ICR change in units of T/2)")
    conv = []
    fine = config.replace(timestep=config.timestep / 2)
    for cg in (0.0, 0.05):
        robot = Robot(cg_x=cg)
        for radius in radii:
            a, b = turn_row(robot, config, 0.3, radius, 1), turn_row(robot, fine, 0.3, radius, 1)
            change = max(abs(a[k] - b[k]) for k in ("y_l", "y_r", "x_c")) / (robot.track_gauge / 2)
            conv.append(dict(cg_x=cg, radius=radius, change=change))
            print(f"cg_x {cg:5.2f} R {str(radius):>6}: {change:.4f}")
    result["convergence"] = conv

    sps = steps_per_second(config)
    rc = SimConfig()
    sps_rollers = steps_per_second(rc, rollers=True)
    result["steps_per_s"], result["roller_chain_steps_per_s"] = sps, sps_rollers
    result["realtime_factor"], result["roller_chain_realtime_factor"] = sps * config.timestep, sps_rollers * rc.timestep
    print(f"\nspeed: {sps:.0f} steps/s ({sps * config.timestep:.1f}x real time at dt = {config.timestep} s); "
          f"roller chain (SimConfig()): {sps_rollers:.0f} steps/s ({sps_rollers * rc.timestep:.1f}x real time "
          f"at dt = {rc.timestep} s)")

    print("\nsettings: worst errors over the turns at cg_x = 0, left turns, and spin-up to 0.95 x 0.8 m/s")
    settings = []
    for name, changes in SETTINGS.items():
        cfg = surfacevel_config(**changes)
        rows = [turn_row(Robot(), cfg, v, radius, 1) for v in (0.3, 0.8) for radius in radii]
        r = dict(name=name, changes=changes,
                 err_y=max(max(abs(x["err_y_l"]), abs(x["err_y_r"])) for x in rows),
                 err_x_c=max(abs(x["err_x_c"]) for x in rows),
                 contact=min(min(x["contact_left"], x["contact_right"]) for x in rows),
                 spinup_s=spinup_time(Robot(), cfg, 0.8), steps_per_s=steps_per_second(cfg))
        settings.append(r)
        print(f"{name:48s} |dy| {r['err_y']:.3f} T/2  |dx_c| {r['err_x_c']:.4f} L  contact {r['contact']:.4f}  "
              f"t(0.95 V) {r['spinup_s']:.3f} s  {r['steps_per_s']:.0f} steps/s", flush=True)
    result["settings"] = settings

    ref12, ref200 = steady_state(Robot(), -0.3, 0.3, n_points=12), steady_state(Robot(), -0.3, 0.3)
    T = Robot().track_gauge
    result["discretisation"] = dict(coulomb_yaw_ratio_12=ref12.wz / (0.6 / T), coulomb_yaw_ratio_200=ref200.wz / (0.6 / T),
                                    coulomb_yaw_ratio_track_ends=T**2 / (T**2 + Robot().track_length**2))
    print("\ndiscretisation: Coulomb pivot yaw ratio, 12 midpoints {coulomb_yaw_ratio_12:.4f}, 200 midpoints "
          "{coulomb_yaw_ratio_200:.4f}, loads at the track ends T^2/(T^2+L^2) {coulomb_yaw_ratio_track_ends:.4f}"
          .format(**result["discretisation"]))

    print("\nablation: pivot turn at 0.3 m/s, cg_x = 0 (Coulomb yaw ratio = wz / (2V/T) in 'ref')")
    abl = []
    for name in ABLATION:
        r = ablation_row(name)
        abl.append(r)
        print(f"{name:48s} yaw {r['yaw_ratio']:.3f} (ref {r['ref_yaw_ratio']:.3f})  dy_l {r['err_y_l']:+.3f}  "
              f"contact {r['contact']:.3f}  load max/mean {r['load_max_over_mean']:.2f} "
              f"min/mean {r['load_min_over_mean']:.2f}  cv(load) {r['load_cv']:.2f} cv(load/|u|) "
              f"{r['load_per_slip_cv']:.2f}  {r['steps_per_s']:.0f} steps/s", flush=True)
    result["ablation"] = abl

    atomic_write_text(args.out, json.dumps(result, indent=1, default=float) + "\n")
    print(f"\nwrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
