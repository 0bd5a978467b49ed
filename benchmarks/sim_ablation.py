"""Why the MuJoCo roller chain needs each of its settings: one change at a time.

    python benchmarks/sim_ablation.py [--out benchmarks/results/sim_ablation.json]

Cases (steady state, ``mjtrack.sim.steady``, vs ``mjtrack.models.coulomb``):
  pivot     default robot, V = -+0.5 m/s, mu 0.8
  wide_cg   default robot, nominal R = 2 m at 0.3 m/s, cg_x = -0.1 L, mu 0.8
  tight_cg  default robot, nominal R = 0.5 m at 0.8 m/s, cg_x = +0.1 L, mu 0.4
  long_cg   long robot (T 0.6, L 0.9 m, 60 kg), R = 1 m at 0.3 m/s, cg_x = -0.1 L, mu 0.8
Reported per variant and case: err_y = max |y - y*| / (T/2), err_x = |x_c - x_c*| / L, the
fraction of (roller, step) pairs in ground contact in the window, and the window std of w.
Variants: the final settings, then each cause put back alone. Also prints the MjSpec
``ipos`` pitfall (a body given explicit inertia but no ipos).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import mujoco
import numpy as np

from fidelity import GEOMETRIES, commands_for

from mjtrack.models.coulomb import steady_state as coulomb_steady
from mjtrack.sim.config import SimConfig
from mjtrack.sim.steady import steady_batch
from mjtrack.testing.repo import RESULTS

CASES = {
    "pivot": ("default", "pivot", 0.5, 0.0, 0.8),
    "wide_cg": ("default", 2.0, 0.3, -0.1, 0.8),
    "tight_cg": ("default", 0.5, 0.8, 0.1, 0.4),
    "long_cg": ("long", 1.0, 0.3, -0.1, 0.8),
}
VARIANTS = {
    "final": {},
    "mujoco_default_contacts": dict(impratio=1.0, noslip_iterations=0, solimp=(0.9, 0.95, 0.001, 0.5, 2.0),
                                    contact_timeconst=0.02, friction_timeconst=0.02, integrator="implicitfast"),
    "friction_in_main_solve": dict(impratio=10.0, noslip_iterations=0),
    "friction_in_main_solve+noslip": dict(impratio=10.0),
    "slow_friction_solref": dict(impratio=10.0, friction_timeconst=1.0),
    "pyramidal_cone": dict(cone="pyramidal"),
    "implicit_damping": dict(integrator="implicitfast"),
    "soft_drivetrain(implicit)": dict(track_mass=10.0, kv=3000.0, integrator="implicitfast"),
    "stiff_suspension(implicit)": dict(suspension_deflection=0.0005, integrator="implicitfast"),
    "suspension_d_1cm": dict(suspension_deflection=0.01),
    "suspension_d_2cm": dict(suspension_deflection=0.02),
}


def run() -> dict:
    robots, cmds = [], []
    for geometry, radius, v, cgf, mu in CASES.values():
        base = GEOMETRIES[geometry]
        robot = base.replace(cg_x=cgf * base.track_length, mu=mu)
        robots.append(robot)
        cmds.append(commands_for(robot, radius, v, 1))
    out = {}
    for name, changes in VARIANTS.items():
        try:
            results = steady_batch(robots, np.array(cmds), config=SimConfig(**{"lag_budget": None, **changes}), settle_s=3.0, window_s=2.0)
        except Exception as exc:  # a variant that diverges is a result too
            out[name] = {"error": str(exc)}
            continue
        row = {}
        for case, robot, res in zip(CASES, robots, results):
            ref = coulomb_steady(robot, res.v_left, res.v_right)
            row[case] = {
                "err_y": max(abs(res.y_l - ref.y_l), abs(res.y_r - ref.y_r)) / (robot.track_gauge / 2),
                "err_x": abs(res.x_c - ref.x_c) / robot.track_length,
                "roller_contact": res.roller_contact, "wz_std": res.wz_std,
            }
        out[name] = row
    return out


def contact_forces(changes: dict, seconds: float = 3.0) -> dict:
    """Pivot of the default robot: normal loads and friction direction of every contact at the end."""
    from mjtrack.io.robot import Robot
    from mjtrack.sim.builder import build_model, control_matrix

    cfg = SimConfig(**{"lag_budget": None, **changes})
    m = build_model(Robot(), cfg)
    d = mujoco.MjData(m)
    d.ctrl[:] = control_matrix(m) @ [-0.5, 0.5]
    for _ in range(int(round(seconds / cfg.timestep))):
        mujoco.mj_step(m, d)
    mujoco.mj_forward(m, d)
    fn, cos = [], []
    for i in range(d.ncon):
        a = d.contact[i].efc_address
        f, v = d.efc_force[a:a + 3], d.efc_vel[a:a + 3]
        fn.append(float(f[0]))
        cos.append(float(-(f[1] * v[1] + f[2] * v[2]) / (np.hypot(*f[1:]) * np.hypot(*v[1:]))))
    return {"contacts": d.ncon, "of": 2 * cfg.n_rollers, "load_min": min(fn), "load_max": max(fn),
            "load_due": Robot().weight / (2 * cfg.n_rollers), "min_cos_friction_vs_slip": min(cos)}


def ipos_pitfall() -> list[float]:
    spec = mujoco.MjSpec()
    b = spec.worldbody.add_body(name="b", pos=[0.3, 0.2, 0.1])
    b.explicitinertial = True
    b.mass = 1.0
    b.inertia = [1e-3] * 3
    b.add_joint(name="j", type=mujoco.mjtJoint.mjJNT_HINGE)
    return spec.compile().body("b").ipos.tolist()


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=RESULTS / "sim_ablation.json")
    args = p.parse_args(argv)
    res = run()
    print(f"{'variant':32s} " + " ".join(f"{c:>28s}" for c in CASES))
    print(f"{'':32s} " + " ".join(f"{'errY  errX  contact wzstd':>28s}" for _ in CASES))
    for name, row in res.items():
        if "error" in row:
            print(f"{name:32s} {row['error']}")
            continue
        print(f"{name:32s} " + " ".join(
            f"{r['err_y']:6.3f} {r['err_x']:5.3f} {r['roller_contact']:6.3f} {r['wz_std']:6.3f}" for r in row.values()))
    forces = {name: contact_forces(VARIANTS[name]) for name in ("final", "mujoco_default_contacts",
                                                                 "stiff_suspension(implicit)")}
    for name, f in forces.items():
        print(f"pivot contact forces, {name}: {f['contacts']}/{f['of']} contacts, loads {f['load_min']:.2f}-"
              f"{f['load_max']:.2f} N (due {f['load_due']:.2f}), min cos(friction, -slip) "
              f"{f['min_cos_friction_vs_slip']:.3f}")
    ipos = ipos_pitfall()
    print(f"MjSpec body at pos (0.3, 0.2, 0.1) with explicit inertia and no ipos: compiled ipos = {ipos}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"variants": VARIANTS, "results": res, "ipos_unset_compiles_to": ipos, "pivot_contact_forces": forces,
                                    "command": "python benchmarks/sim_ablation.py"}, indent=1, default=str) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
