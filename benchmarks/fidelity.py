"""Fidelity of the MuJoCo track models against the rigid-track Coulomb reference.

    python benchmarks/fidelity.py [--out benchmarks/results/fidelity] [--quick]
                                   [--track-model rollers|surfacevel|both]
    python benchmarks/fidelity.py --wide [--quick] [--track-model ...] [--timestep DT]
                                   [--previous-defaults] [--fixed-step]

Both track models (``--track-model both``, the default), each with its measured settings
``mjtrack.sim.config.sim_config(track_model)``: the roller chain (``mjtrack.sim.builder``) and
the moving contact surfaces (``mjtrack.sim.surfacevel``). Same grid, geometries and checks
for both.

Grid: turns of nominal radius R in {pivot, 0.25, 0.5, 1, 2} m at v in {0.3, 0.8}
m/s (pivot: track speeds +-v), turning left and right, driving forward and backward; cg_x in {-0.1, 0, +0.1} L; mu in
{0.4, 0.8}; for the default robot (T = 0.4, L = 0.5 m, 20 kg) and a long-track robot
(T = 0.6, L = 0.9 m, 60 kg, cg_z = 0.2 m). Commands from the nominal model:
w = v/R, V_L = v - w T/2, V_R = v + w T/2.

Each case: 3 s at the constant command, then averages over 2 s (``mjtrack.sim.steady``;
rollers: from the settled rest state, window standard deviation of w reported; surfacevel:
from rest, 5 s run, no window std); ICRs by (2.13) from the window means with the measured
track speeds; reference ``mjtrack.models.coulomb.steady_state`` at the same track speeds.
Pass: |y_l - y_l*|, |y_r - y_r*| <= 0.1 T/2, |x_c - x_c*| <= 0.02 L, each track in ground
contact in >= 99 % of the steps (whole run).

Also measured per model: convergence (halving the time step, doubling the roller/element
count: largest ICR change on the default robot over all radii, cg_x and mu at 0.8 m/s; pass
< 0.03 T/2 and < 0.03 L) and straight driving (|v_x - V|/V < 1 % and lateral drift per metre
< 1 mm/m at 0.3, 0.8, 2 m/s). Writes, into --out, fidelity.json + fidelity.png (rollers),
fidelity_surfacevel.json + fidelity_surfacevel.png and, for both, fidelity_combined.json (the
combined table); prints the tables; exit 1 if any check fails. About 1 min (rollers) + 3 min
(surfacevel) on one core.

``--wide``: 8 robots of 5-150 kg and L/T 0.6-2 (six written out, two drawn with
seed ``WIDE_SEED``; cg_y 0.05 T on every second one), pivot and R = 0.5-10 m at 0.2, 0.7
and 2 m/s (turns with nominal v^2/R above 0.5 mu g left out: the robot slides out), left and
right, forward and reverse, cg_x +-0.1 L: 928 turns (``--quick``: 4 robots, 4 radii, 0.2 and
2 m/s, forward only: 112). Against the Coulomb reference with load transfer; pass = |dy| <=
0.05 T/2, |dx_c| <= 0.02 L, contact >= 99 % and, for the roller chain, halving dt moves y by
< 0.02 T/2, in every case. Prints every case, the worst case of each error with its case,
the medians and the pass counts per (radius, speed); writes fidelity_wide[_quick][_model].json.
Each roller-chain case runs at the step ``SimConfig.step_for`` picks for it (5 ms unless
its largest track speed v gives v dt > 0.01 L; ``timestep`` in its row), and the dt-halving
check halves that step; ``--fixed-step``: every case at 5 ms (the earlier rule), written to
..._fixed_step.json; ``--timestep DT``: every case at DT.
About 10 min (rollers, with the dt-halved rerun) on a loaded 2-core machine.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from mjtrack.io.robot import Robot
from mjtrack.models.coulomb import steady_state as coulomb_steady
from mjtrack.sim.config import TRACK_MODELS, SimConfig, previous_defaults, sim_config
from mjtrack.sim.rollout import drive_log
from mjtrack.sim.steady import case_timestep, steady_batch
from _results import RESULTS

RADII = ("pivot", 0.25, 0.5, 1.0, 2.0)
SPEEDS = (0.3, 0.8)
DIRECTIONS = (1, -1)  # +1 left (CCW), -1 right (CW)
TRAVEL = (1, -1)  # +1 forward, -1 reverse (turns only; a reversed pivot is the mirrored pivot)
CG_FRACTIONS = (-0.1, 0.0, 0.1)
MUS = (0.4, 0.8)
GEOMETRIES = {
    "default": Robot(),
    "long": Robot(track_gauge=0.6, track_length=0.9, mass=60.0, cg_z=0.2),
}
TOL_Y, TOL_X, TOL_CONTACT = 0.10, 0.02, 0.99
TOL_CONV = 0.03  # largest ICR change under refinement, in units of T/2 (y) and L (x_c)
TOL_SPEED, TOL_DRIFT = 0.01, 1.0  # straight driving: |vx - V| / V, lateral drift [mm/m]
STRAIGHT_SPEEDS = (0.3, 0.8, 2.0)
# output files per track model (the roller chain keeps the names it always had)
FILES = {"rollers": "fidelity", "surfacevel": "fidelity_surfacevel"}


def commands_for(robot: Robot, radius, v: float, direction: int, travel: int = 1) -> tuple[float, float]:
    """Nominal track speeds: turn left (+1) / right (-1), driving forward (+1) / backward (-1)."""
    if radius == "pivot":
        return -direction * v, direction * v
    v = travel * v
    w = direction * abs(v) / radius
    return v - w * robot.track_gauge / 2, v + w * robot.track_gauge / 2


def grid_cases(geometry: str, quick: bool):
    base = GEOMETRIES[geometry]
    radii = RADII if not quick else ("pivot", 0.5, 2.0)
    for radius in radii:
        for v in SPEEDS:
            for direction in DIRECTIONS:
                for travel in (TRAVEL if radius != "pivot" else (1,)):
                    for cgf in CG_FRACTIONS:
                        for mu in MUS:
                            robot = base.replace(cg_x=cgf * base.track_length, mu=mu)
                            yield dict(geometry=geometry, radius=radius, v=v, direction=direction, travel=travel,
                                       cg_frac=cgf, mu=mu), robot, commands_for(robot, radius, v, direction, travel)


def run_grid(quick: bool, config: SimConfig) -> list[dict]:
    rows = []
    for geometry in GEOMETRIES:
        cases = list(grid_cases(geometry, quick))
        results = steady_batch([c[1] for c in cases], np.array([c[2] for c in cases]), config=config)
        for (meta, robot, _), res in zip(cases, results):
            ref = coulomb_steady(robot, res.v_left, res.v_right)
            half, L = robot.track_gauge / 2, robot.track_length
            row = dict(meta, **res.to_dict(), ref_y_l=ref.y_l, ref_y_r=ref.y_r, ref_x_c=ref.x_c, ref_wz=ref.wz)
            row["err_y"] = max(abs(res.y_l - ref.y_l), abs(res.y_r - ref.y_r)) / half
            row["err_x"] = abs(res.x_c - ref.x_c) / L
            row["contact_min"] = min(res.contact_left, res.contact_right)
            row["pass"] = bool(row["err_y"] <= TOL_Y and row["err_x"] <= TOL_X and row["contact_min"] >= TOL_CONTACT)
            rows.append(row)
    return rows


def convergence(config: SimConfig) -> dict:
    """Largest ICR change over the default robot's grid at 0.8 m/s (left turns, forward)."""
    base = Robot()
    robots, cmds = [], []
    for radius in RADII:
        for cgf in CG_FRACTIONS:
            for mu in MUS:
                robot = base.replace(cg_x=cgf * base.track_length, mu=mu)
                robots.append(robot)
                cmds.append(commands_for(robot, radius, 0.8, 1))
    cmds = np.array(cmds)
    variants = {"base": config, "half_dt": halved(config),
                "double_rollers": config.replace(n_rollers=2 * config.n_rollers)}
    res = {k: steady_batch(robots, cmds, config=c) for k, c in variants.items()}
    out = {}
    for k in ("half_dt", "double_rollers"):
        dy = max(max(abs(a.y_l - b.y_l), abs(a.y_r - b.y_r)) / (base.track_gauge / 2)
                 for a, b in zip(res["base"], res[k]))
        dx = max(abs(a.x_c - b.x_c) / base.track_length for a, b in zip(res["base"], res[k]))
        out[k] = {"cases": len(robots), "max_dy_over_half_gauge": dy, "max_dx_over_length": dx}
    return out


def halved(config: SimConfig) -> SimConfig:
    """The config whose step is half the one ``config`` runs each case at (:meth:`SimConfig.halved`)."""
    return config.halved()


def straight(config: SimConfig) -> list[dict]:
    out = []
    for v in STRAIGHT_SPEEDS:
        log = drive_log(Robot(), (np.array([0.0]), np.array([v]), np.array([v])), duration=10.0, config=config)
        k = log.t >= 3.0  # after the start transient
        V = float(np.mean(log.v_left[k] + log.v_right[k]) / 2)
        dist = float(np.hypot(log.x[-1] - log.x[0], log.y[-1] - log.y[0]))
        out.append({"v_cmd": v, "V_measured": V, "vx": float(np.mean(log.vx[k])),
                    "rel_speed_err": float(abs(np.mean(log.vx[k]) - V) / V),
                    "drift_mm_per_m": 1000 * float(abs(log.y[-1] - log.y[0])) / dist})
    return out


# --- the wider grid ---------------------------------------------------------------------
# Robots spanning 5-150 kg and L/T 0.6-2: four corners and two cases of interest written out,
# two more drawn from a seeded generator (same seed, same robots). cg_z = 0.25 min(T, L): a
# squat vehicle (0.3 T flipped the 5 kg, L = 0.18 m robot backwards when its tracks spun up
# to 2 m/s with the cg 0.1 L aft -- real, but no steady turn); friction mu 0.8 unless drawn.
WIDE_SEED = 11
WIDE_RADII = ("pivot", 0.5, 1.0, 2.0, 5.0, 10.0)
WIDE_SPEEDS = (0.2, 0.7, 2.0)
WIDE_CG = (-0.1, 0.1)  # cg_x / L
WIDE_CG_Y = 0.05  # cg_y / T on every second robot: a lateral offset makes left and right differ
TOL_WIDE_Y, TOL_WIDE_X, TOL_WIDE_DT = 0.05, 0.02, 0.02  # T/2, L, T/2 (dt halving)
# --holdout: robots and turns that no setting was tuned on (the belt and the slip budget
# were tuned on the wide grid): drawn robots, other radii, speeds and cg offsets, same tolerances
HOLDOUT_SEED = 2026
HOLDOUT_RADII = ("pivot", 0.7, 3.0, 7.0)
HOLDOUT_SPEEDS = (0.35, 1.2)
HOLDOUT_CG = (-0.07, 0.05)
MAX_LATERAL_ACCEL = 0.5  # [g mu] nominal v^2/R above this: the robot slides out, no steady turn


def wide_robots() -> dict[str, Robot]:
    fixed = {  # (mass, T, L/T)
        "5kg_long": (5.0, 0.2, 2.0), "5kg_wide": (5.0, 0.3, 0.6), "150kg_wide": (150.0, 0.8, 0.6),
        "150kg_long": (150.0, 0.6, 2.0), "80kg_issue11": (80.0, 0.5, 2.0), "150kg_issue11": (150.0, 0.8, 0.75),
    }
    robots = {}
    for i, (name, (m, T, ratio)) in enumerate(fixed.items()):
        robots[name] = Robot(mass=m, track_gauge=T, track_length=round(ratio * T, 3), cg_z=0.25 * min(T, ratio * T),
                             cg_y=WIDE_CG_Y * T if i % 2 else 0.0)
    rng = np.random.default_rng(WIDE_SEED)
    for i in range(2):
        m, T, ratio = float(rng.uniform(5, 150)), float(rng.uniform(0.2, 0.8)), float(rng.uniform(0.6, 2.0))
        mu = float(rng.uniform(0.4, 1.0))
        robots[f"drawn{i}"] = Robot(mass=round(m, 1), track_gauge=round(T, 3), track_length=round(ratio * T, 3),
                                    cg_z=round(0.25 * min(T, ratio * T), 3), mu=round(mu, 2), cg_y=WIDE_CG_Y * T if i % 2 else 0.0)
    return robots


def holdout_robots() -> dict[str, Robot]:
    """Two light robots written out (the draws happen to be 31-136 kg, and gentle turns of light
    robots were the hard cases) and six drawn with HOLDOUT_SEED: 5-150 kg, T 0.2-0.8 m, L/T 0.6-2,
    mu 0.4-1, cg_z 0.15-0.35 min(T, L), cg_y within +-0.05 T."""
    rng = np.random.default_rng(HOLDOUT_SEED)
    robots = {"8kg_long": Robot(mass=8.0, track_gauge=0.25, track_length=0.4, cg_z=0.06, mu=0.7, cg_y=0.005),
              "12kg_square": Robot(mass=12.0, track_gauge=0.35, track_length=0.3, cg_z=0.08, mu=0.9, cg_y=-0.007)}
    for i in range(6):
        m, T, ratio = float(rng.uniform(5, 150)), float(rng.uniform(0.2, 0.8)), float(rng.uniform(0.6, 2.0))
        mu, hz, cy = float(rng.uniform(0.4, 1.0)), float(rng.uniform(0.15, 0.35)), float(rng.uniform(-0.05, 0.05))
        L = round(ratio * T, 3)
        robots[f"holdout{i}"] = Robot(mass=round(m, 1), track_gauge=round(T, 3), track_length=L,
                                      cg_z=round(hz * min(T, L), 3), mu=round(mu, 2), cg_y=round(cy * T, 4))
    return robots


def wide_cases(quick: bool, holdout: bool = False):
    robots = holdout_robots() if holdout else wide_robots()
    names = list(robots)[:3] + list(robots)[-1:] if quick else list(robots)
    radii = HOLDOUT_RADII if holdout else ("pivot", 1.0, 5.0, 10.0) if quick else WIDE_RADII
    speeds = HOLDOUT_SPEEDS if holdout else (0.2, 2.0) if quick else WIDE_SPEEDS
    cgs = HOLDOUT_CG if holdout else WIDE_CG
    for name in names:
        base = robots[name]
        for radius in radii:
            for v in speeds:
                if radius != "pivot" and v * v / radius > MAX_LATERAL_ACCEL * 9.81 * base.mu:
                    continue
                for direction in DIRECTIONS:
                    for travel in (TRAVEL if radius != "pivot" and not quick else (1,)):
                        for cgf in cgs:
                            robot = base.replace(cg_x=cgf * base.track_length)
                            yield (dict(geometry=name, radius=radius, v=v, direction=direction, travel=travel,
                                        cg_frac=cgf, mu=robot.mu, mass=robot.mass, T=robot.track_gauge,
                                        L=robot.track_length), robot, commands_for(robot, radius, v, direction, travel))


def _by_robot(cases: list) -> dict[str, list]:
    groups: dict[str, list] = {}
    for c in cases:
        groups.setdefault(c[0]["geometry"], []).append(c)
    return groups


def run_wide(quick: bool, config: SimConfig, *, half_dt: bool, holdout: bool = False) -> list[dict]:
    """Every wide case against the Coulomb reference (with load transfer); with ``half_dt`` also
    the ICR change when each case's time step is halved (:func:`halved`). Each case runs at the
    step :func:`mjtrack.sim.steady.case_timestep` gives it (``timestep`` in its row)."""
    rows = []
    for name, cases in _by_robot(list(wide_cases(quick, holdout))).items():
        robots, cmds = [c[1] for c in cases], np.array([c[2] for c in cases])
        results = steady_batch(robots, cmds, config=config)
        fine = steady_batch(robots, cmds, config=halved(config)) if half_dt else None
        for k, ((meta, robot, cmd), res) in enumerate(zip(cases, results)):
            half, L = robot.track_gauge / 2, robot.track_length
            row = dict(meta, **res.to_dict(), timestep=case_timestep(config, robot, cmd))
            try:
                ref = coulomb_steady(robot, res.v_left, res.v_right)
                row.update(ref_y_l=ref.y_l, ref_y_r=ref.y_r, ref_x_c=ref.x_c,
                           err_y=max(abs(res.y_l - ref.y_l), abs(res.y_r - ref.y_r)) / half,
                           err_x=abs(res.x_c - ref.x_c) / L)
            except Exception as exc:  # noqa: BLE001 -- no reference steady state (tip-over, straight)
                row.update(ref_error=str(exc), err_y=float("nan"), err_x=float("nan"))
            if fine is not None:
                f = fine[k]
                row["dt_dy"] = max(abs(res.y_l - f.y_l), abs(res.y_r - f.y_r)) / half
                row["dt_dx"] = abs(res.x_c - f.x_c) / L
            row["contact_min"] = min(res.contact_left, res.contact_right)
            # lateral slip speed at the track ends, |w| L/2: what the time-stepped friction must resolve
            row["end_slip"] = abs(res.wz) * L / 2
            row["pass"] = bool(row["err_y"] <= TOL_WIDE_Y and row["err_x"] <= TOL_WIDE_X
                               and row["contact_min"] >= TOL_CONTACT
                               and (fine is None or row["dt_dy"] < TOL_WIDE_DT))
            rows.append(row)
    return rows


def wide_summary(rows: list[dict]) -> dict:
    """Worst case (with its case), median and pass count; NaN errors count as failures."""
    def worst(key):
        vals = [r for r in rows if key in r]
        if not vals:
            return None
        r = max(vals, key=lambda r: np.inf if not np.isfinite(r[key]) else r[key])
        return {"value": r[key], "case": {k: r[k] for k in ("geometry", "radius", "v", "direction", "travel",
                                                             "cg_frac", "mass", "T", "L")}}
    out = {"cases": len(rows), "passed": sum(r["pass"] for r in rows),
           "no_reference": sum("ref_error" in r for r in rows)}
    for key in ("err_y", "err_x", "dt_dy", "dt_dx"):
        vals = [r[key] for r in rows if key in r]
        if vals:
            out[f"worst_{key}"] = worst(key)
            out[f"median_{key}"] = float(np.nanmedian(vals))
    out["min_contact"] = min(r["contact_min"] for r in rows)
    # where it fails: the commanded track speed difference v T / R sets the slip speeds
    fails = [r for r in rows if not r["pass"]]
    out["failing_radii"] = sorted({str(r["radius"]) for r in fails})
    out["failing_speeds"] = sorted({r["v"] for r in fails})
    # pass counts per (radius, speed): where on the grid it fails
    table: dict[str, list[int]] = {}
    for r in rows:
        cell = table.setdefault(f"R {r['radius']} v {r['v']}", [0, 0])
        cell[0] += bool(r["pass"])
        cell[1] += 1
    out["passed_by_radius_speed"] = {k: f"{a}/{b}" for k, (a, b) in table.items()}
    return out


def print_wide(track_model: str, rows: list[dict], summary: dict) -> None:
    print(f"\n=== wide grid, track model {track_model} (errors: y in T/2, x_c in L) ===")
    print(f"{'robot':14s} {'kg':>5s} {'T':>5s} {'L':>5s} {'R':>6s} {'v':>4s} {'dir':>3s} {'fwd':>3s} {'cg/L':>5s} "
          f"{'errY':>7s} {'errX':>7s} {'dt/2 dY':>8s} {'cont':>5s}")
    for r in rows:
        dt = f"{r['dt_dy']:8.4f}" if "dt_dy" in r else f"{'-':>8s}"
        print(f"{r['geometry']:14s} {r['mass']:5.0f} {r['T']:5.2f} {r['L']:5.2f} {str(r['radius']):>6s} {r['v']:4.1f} "
              f"{r['direction']:3d} {r['travel']:3d} {r['cg_frac']:5.2f} {r['err_y']:7.4f} {r['err_x']:7.4f} {dt} "
              f"{r['contact_min']:5.3f}{'' if r['pass'] else '  FAIL'}")
    print("summary:", json.dumps(summary, indent=1, default=_json_default))


def run_wide_study(quick: bool, out: Path, command: str, models, timestep: float | None = None,
                   previous: bool = False, fixed_step: bool = False, holdout: bool = False) -> bool:
    """The wide grid for each track model (dt halving for the roller chain); writes fidelity_wide.json
    (``timestep``: another time step than the model's default, named in the file)."""
    robots = holdout_robots() if holdout else wide_robots()
    doc = {"command": command, "seed": HOLDOUT_SEED if holdout else WIDE_SEED,
           "robots": {k: r.to_dict() for k, r in robots.items()},
           "tolerances": {"y": TOL_WIDE_Y, "x": TOL_WIDE_X, "dt_halving_y": TOL_WIDE_DT, "contact": TOL_CONTACT}}
    ok = True
    for m in models:
        t0 = time.perf_counter()
        config = sim_config(m, timestep=timestep)
        if previous and m == "rollers":
            config = previous_defaults().replace(timestep=config.timestep)
        if fixed_step:
            config = config.replace(lag_budget=None, slip_budget=None)
        rows = run_wide(quick, config, half_dt=(m == "rollers"), holdout=holdout)
        summary = wide_summary(rows)
        summary["elapsed_s"] = time.perf_counter() - t0
        print_wide(m, rows, summary)
        doc[m] = {"config": config.to_dict(), "summary": summary, "cases": rows}
        ok = ok and (m != "rollers" or summary["passed"] == summary["cases"])
    path = out / ("fidelity_wide" + ("_holdout" if holdout else "") + ("_quick" if quick else "") + ("" if len(models) > 1 else f"_{models[0]}")
                  + (f"_dt{timestep:g}" if timestep else "") + ("_previous" if previous else "")
                  + ("_fixed_step" if fixed_step else "") + ".json")
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(doc, indent=1, default=_json_default) + "\n")
    tmp.replace(path)
    print(f"wrote {path}")
    return ok


def figure(rows: list[dict], path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(13, 4))
    for ax, key, ref, label in ((axes[0], "y_l", "ref_y_l", "y_l [m]"), (axes[1], "y_r", "ref_y_r", "y_r [m]"),
                                (axes[2], "x_c", "ref_x_c", "x_c [m]")):
        for geometry, marker in zip(GEOMETRIES, "ox"):
            sel = [r for r in rows if r["geometry"] == geometry]
            ax.plot([r[ref] for r in sel], [r[key] for r in sel], marker, ms=4, label=geometry, alpha=0.7)
        lim = [min(min(r[ref], r[key]) for r in rows), max(max(r[ref], r[key]) for r in rows)]
        ax.plot(lim, lim, "k-", lw=0.8)
        ax.set_xlabel(f"Coulomb reference {label}")
        ax.set_ylabel(f"MuJoCo {label}")
        ax.legend()
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def summarise(rows: list[dict], conv: dict, straight_rows: list[dict]) -> dict:
    """Per geometry: cases, passed, worst errors, contact; plus the convergence/straight verdicts."""
    summary = {}
    for geometry in GEOMETRIES:
        sel = [r for r in rows if r["geometry"] == geometry]
        wz_std = [r["wz_std"] for r in sel if r["wz_std"] is not None]
        summary[geometry] = {
            "cases": len(sel), "passed": sum(r["pass"] for r in sel),
            "max_err_y_over_half_gauge": max(r["err_y"] for r in sel),
            "max_err_x_over_length": max(r["err_x"] for r in sel),
            "min_contact_fraction": min(r["contact_min"] for r in sel),
            "max_wz_std": max(wz_std) if wz_std else None,  # None: not measured (surfacevel)
        }
    summary["convergence_pass"] = all(c["max_dy_over_half_gauge"] < TOL_CONV and c["max_dx_over_length"] < TOL_CONV
                                      for c in conv.values())
    summary["straight_pass"] = all(s["rel_speed_err"] < TOL_SPEED and s["drift_mm_per_m"] < TOL_DRIFT
                                   for s in straight_rows)
    return summary


def run_model(track_model: str, quick: bool, out: Path, command: str) -> dict:
    """The whole study for one track model: prints its tables, writes its JSON and figure."""
    config = sim_config(track_model)
    t0 = time.perf_counter()
    rows = run_grid(quick, config)
    conv = convergence(config)
    straight_rows = straight(config)
    elapsed = time.perf_counter() - t0

    print(f"\n=== track model: {track_model} ===")
    print(f"{'geom':8s} {'R':>6s} {'v':>4s} {'dir':>3s} {'fwd':>3s} {'cg/L':>5s} {'mu':>4s} {'y_l':>7s} {'ref':>7s} {'y_r':>7s} "
          f"{'ref':>7s} {'x_c':>7s} {'ref':>7s} {'errY':>5s} {'errX':>6s} {'wz_std':>7s} {'cont':>5s}")
    for r in rows:
        wz_std = f"{r['wz_std']:7.4f}" if r["wz_std"] is not None else f"{'-':>7s}"
        print(f"{r['geometry']:8s} {str(r['radius']):>6s} {r['v']:4.1f} {r['direction']:3d} {r['travel']:3d} {r['cg_frac']:5.2f} "
              f"{r['mu']:4.1f} {r['y_l']:7.4f} {r['ref_y_l']:7.4f} {r['y_r']:7.4f} {r['ref_y_r']:7.4f} "
              f"{r['x_c']:7.4f} {r['ref_x_c']:7.4f} {r['err_y']:5.3f} {r['err_x']:6.4f} {wz_std} "
              f"{r['contact_min']:5.3f}{'' if r['pass'] else '  FAIL'}")
    summary = summarise(rows, conv, straight_rows)
    print("\nsummary:", json.dumps(summary, indent=1))
    print("convergence (largest ICR change):", json.dumps(conv))
    print("straight driving:")
    for s in straight_rows:
        print(f"  v_cmd {s['v_cmd']:.1f}: V {s['V_measured']:.4f} vx {s['vx']:.4f} |vx-V|/V {s['rel_speed_err']:.2e} "
              f"drift {s['drift_mm_per_m']:.3g} mm/m")
    print(f"elapsed {elapsed:.1f} s")
    doc = {"track_model": track_model, "config": config.to_dict(),
           "tolerances": {"y": TOL_Y, "x": TOL_X, "contact": TOL_CONTACT, "convergence": TOL_CONV,
                          "speed": TOL_SPEED, "drift_mm_per_m": TOL_DRIFT},
           "summary": summary, "convergence": conv, "straight": straight_rows, "cases": rows,
           "elapsed_s": elapsed, "command": command}
    stem = out / FILES[track_model]
    stem.with_suffix(".json").write_text(json.dumps(doc, indent=1, default=_json_default) + "\n")
    figure(rows, stem.with_suffix(".png"),
           "Steady-state ICRs: MuJoCo roller chain vs rigid-track Coulomb reference" if track_model == "rollers"
           else f"Steady-state ICRs: MuJoCo {track_model} tracks vs rigid-track Coulomb reference")
    print(f"wrote {stem.with_suffix('.json')} and {stem.with_suffix('.png')}")
    return doc


def combined_table(docs: dict[str, dict]) -> list[dict]:
    """One row per (track model, geometry): the fidelity grid's numbers side by side."""
    table = []
    for track_model, doc in docs.items():
        conv, st = doc["convergence"], doc["straight"]
        for geometry in GEOMETRIES:
            s = doc["summary"][geometry]
            table.append({
                "track_model": track_model, "geometry": geometry, "cases": s["cases"], "passed": s["passed"],
                "max_err_y_over_half_gauge": s["max_err_y_over_half_gauge"],
                "max_err_x_over_length": s["max_err_x_over_length"],
                "min_contact_fraction": s["min_contact_fraction"],
                # convergence and straight driving are measured on the default robot only
                "conv_half_dt_dy": conv["half_dt"]["max_dy_over_half_gauge"] if geometry == "default" else None,
                "conv_half_dt_dx": conv["half_dt"]["max_dx_over_length"] if geometry == "default" else None,
                "conv_2n_dy": conv["double_rollers"]["max_dy_over_half_gauge"] if geometry == "default" else None,
                "conv_2n_dx": conv["double_rollers"]["max_dx_over_length"] if geometry == "default" else None,
                "straight_max_rel_speed_err": max(x["rel_speed_err"] for x in st) if geometry == "default" else None,
                "straight_max_drift_mm_per_m": max(x["drift_mm_per_m"] for x in st) if geometry == "default" else None,
                "elapsed_s": doc["elapsed_s"],
            })
    return table


def print_combined(table: list[dict]) -> None:
    def f(x, fmt):
        return format(x, fmt) if x is not None else "-"

    print("\n=== combined (errors: max over the grid; conv and straight: default robot, max over cases/speeds) ===")
    print(f"{'model':10s} {'geom':8s} {'pass':>9s} {'errY/(T/2)':>10s} {'errX/L':>7s} {'contact':>7s} "
          f"{'dt/2 dY':>8s} {'dt/2 dX':>8s} {'2N dY':>7s} {'2N dX':>7s} {'|vx-V|/V':>9s} {'drift':>7s}")
    for r in table:
        print(f"{r['track_model']:10s} {r['geometry']:8s} {r['passed']:4d}/{r['cases']:<4d} "
              f"{r['max_err_y_over_half_gauge']:10.4f} {r['max_err_x_over_length']:7.4f} {r['min_contact_fraction']:7.4f} "
              f"{f(r['conv_half_dt_dy'], '8.4f'):>8s} {f(r['conv_half_dt_dx'], '8.4f'):>8s} "
              f"{f(r['conv_2n_dy'], '7.4f'):>7s} {f(r['conv_2n_dx'], '7.4f'):>7s} "
              f"{f(r['straight_max_rel_speed_err'], '9.2e'):>9s} {f(r['straight_max_drift_mm_per_m'], '7.3f'):>7s}")
    print("(drift in mm/m; dt/2, 2N: largest ICR change when halving the time step / doubling the elements)")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=RESULTS / "fidelity")
    p.add_argument("--quick", action="store_true", help="3 radii instead of 5 (--wide: 4 robots, 4 radii, 2 speeds)")
    p.add_argument("--wide", action="store_true",
                   help="the wider grid instead (8 robots of 5-150 kg and L/T 0.6-2, radii to 10 m, 0.2-2 m/s, "
                        "both turn directions, forward and reverse, cg_x +-0.1 L; tolerances 0.05 T/2, 0.02 L, "
                        "dt halving < 0.02 T/2 for the roller chain); writes fidelity_wide.json")
    p.add_argument("--previous-defaults", action="store_true",
                   help="--wide only: the roller chain with its settings before the speed study")
    p.add_argument("--timestep", type=float, default=None,
                   help="--wide only: run at this time step [s] instead of each model's default")
    p.add_argument("--fixed-step", action="store_true",
                   help="--wide only: every case at the model's time step (no lag budget, the earlier rule: "
                        "fast cases of short robots then have x_c v dt off Coulomb; the gentle-turns study)")
    p.add_argument("--holdout", action="store_true",
                   help="--wide only: two light robots and six drawn with another seed, radii 0.7/3/7 m and pivots, 0.35 and "
                        "1.2 m/s, cg_x -0.07/+0.05 L (nothing was tuned on them); writes fidelity_wide_holdout_*.json")
    p.add_argument("--track-model", choices=(*TRACK_MODELS, "both"), default="both",
                   help="which MuJoCo track model(s) to measure (default both)")
    args = p.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    if args.timestep is not None and not (args.wide and args.timestep > 0):
        p.error("--timestep needs --wide and a positive value")
    if args.fixed_step and not args.wide:
        p.error("--fixed-step needs --wide")
    if args.holdout and (not args.wide or args.quick):
        p.error("--holdout needs --wide (and no --quick)")
    command = "python benchmarks/fidelity.py" + (" --wide" if args.wide else "") + (" --quick" if args.quick else "") + (
        f" --timestep {args.timestep:g}" if args.timestep else "") + (
        " --fixed-step" if args.fixed_step else "") + (" --previous-defaults" if args.previous_defaults else "") + (
        " --holdout" if args.holdout else "") + (
        f" --track-model {args.track_model}" if args.track_model != "both" else "")
    models = TRACK_MODELS if args.track_model == "both" else (args.track_model,)
    if args.wide:
        return 0 if run_wide_study(args.quick, args.out, command, models, args.timestep, args.previous_defaults,
                                   args.fixed_step, args.holdout) else 1
    docs = {m: run_model(m, args.quick, args.out, command) for m in models}
    table = combined_table(docs)
    print_combined(table)
    ok = all(d["summary"][g]["passed"] == d["summary"][g]["cases"] for d in docs.values() for g in GEOMETRIES)
    ok = ok and all(d["summary"]["convergence_pass"] and d["summary"]["straight_pass"] for d in docs.values())
    if len(docs) > 1:
        path = args.out / "fidelity_combined.json"
        path.write_text(json.dumps({"command": command, "all_pass": ok, "table": table}, indent=1,
                                   default=_json_default) + "\n")
        print(f"wrote {path}")
    return 0 if ok else 1


def _json_default(x):
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    raise TypeError(type(x))


if __name__ == "__main__":
    sys.exit(main())
