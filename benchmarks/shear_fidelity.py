"""The MuJoCo robot on the shear ground against its reference, and its Coulomb limit.

    python benchmarks/shear_fidelity.py

For the default robot (T 0.4, L 0.5 m, 20 kg) and the long-track robot of benchmarks/fidelity.py
(T 0.6, L 0.9 m, 60 kg), on the surfacevel track model with its settings
(:func:`mjtrack.sim.config.surfacevel_config`): steady turns from a pivot to a gentle one, slow
and fast, both directions, on the shear ground (``{"model": "shear", "shear_modulus": K}``)
for several K; each case's steady ICRs (:func:`mjtrack.sim.steady.steady_state`) against the
shear reference's (:func:`mjtrack.models.shear.steady_state`, the model's 12 elements as its
contact points). The limit: the same turns at K = 1e-4 m against the MuJoCo robot on the
Coulomb ground. Errors over half the gauge T/2 (the ICR x_c also over the contact length L).
Pass: every ICR within 0.02 T/2 of the reference, and within 0.005 T/2 of the Coulomb robot in
the limit. Writes benchmarks/results/shear_fidelity.json; prints the same and the load.
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from mjtrack.io.robot import Robot
from mjtrack.models import shear
from mjtrack.sim.config import surfacevel_config
from mjtrack.sim.steady import steady_state

RESULT = Path(__file__).resolve().parent / "results" / "shear_fidelity.json"
GEOMETRIES = {"default": Robot(), "long": Robot(track_gauge=0.6, track_length=0.9, mass=60.0, cg_z=0.2)}
SPEEDS = [(-0.5, 0.5), (0.0, 0.6), (0.2, 0.6), (0.6, 0.2), (0.5, 0.7), (1.0, 1.4)]
MODULI = (0.01, 0.03, 0.1)  # [m]
LIMIT_K = 1e-4  # [m]
TOLERANCE = 0.02  # of T/2, against the reference
LIMIT_TOLERANCE = 0.005  # of T/2, against the Coulomb robot


def icr(robot: Robot, vl: float, vr: float, config) -> np.ndarray:
    s = steady_state(robot, vl, vr, config=config)
    return np.array([s.y_l, s.y_r, s.x_c])


def main() -> int:
    load0 = os.getloadavg()
    config = surfacevel_config()
    t0 = time.time()
    cases, limit = [], []
    for geometry, base in GEOMETRIES.items():
        half, L = base.track_gauge / 2, base.track_length
        for vl, vr in SPEEDS:
            for K in MODULI:
                robot = base.replace(ground={"model": "shear", "shear_modulus": K})
                got = icr(robot, vl, vr, config)
                ref = np.array(shear.steady_state(robot, vl, vr, n_points=config.n_rollers).icr)
                err = np.abs(got - ref)
                cases.append({"geometry": geometry, "v_left": vl, "v_right": vr, "shear_modulus": K,
                              "mujoco": got.tolist(), "reference": ref.tolist(),
                              "err_over_half_gauge": float(err.max() / half), "err_x_over_length": float(err[2] / L),
                              "passed": bool(err.max() <= TOLERANCE * half)})
                print(f"{geometry:8s} ({vl:+.1f}, {vr:+.1f}) K={K:<5g} mujoco {np.round(got, 4)} reference "
                      f"{np.round(ref, 4)}  max err {err.max() / half:.4f} T/2", flush=True)
            coulomb_robot = icr(base, vl, vr, config)
            near = icr(base.replace(ground={"model": "shear", "shear_modulus": LIMIT_K}), vl, vr, config)
            d = np.abs(near - coulomb_robot)
            limit.append({"geometry": geometry, "v_left": vl, "v_right": vr, "shear_modulus": LIMIT_K,
                          "shear": near.tolist(), "coulomb": coulomb_robot.tolist(),
                          "diff_over_half_gauge": float(d.max() / half),
                          "passed": bool(d.max() <= LIMIT_TOLERANCE * half)})
            print(f"{geometry:8s} ({vl:+.1f}, {vr:+.1f}) K={LIMIT_K:g} vs the Coulomb robot: {d.max() / half:.5f} T/2",
                  flush=True)
    summary = {"cases": len(cases), "passed": sum(c["passed"] for c in cases),
               "max_err_over_half_gauge": max(c["err_over_half_gauge"] for c in cases),
               "max_err_x_over_length": max(c["err_x_over_length"] for c in cases),
               "limit_cases": len(limit), "limit_passed": sum(c["passed"] for c in limit),
               "limit_max_diff_over_half_gauge": max(c["diff_over_half_gauge"] for c in limit)}
    RESULT.parent.mkdir(parents=True, exist_ok=True)
    RESULT.write_text(json.dumps({"command": "python benchmarks/shear_fidelity.py " + " ".join(sys.argv[1:]),
                                  "track_model": "surfacevel", "n_elements": config.n_rollers,
                                  "tolerance_over_half_gauge": TOLERANCE, "limit_tolerance_over_half_gauge": LIMIT_TOLERANCE,
                                  "summary": summary, "cases": cases, "limit": limit, "elapsed_s": time.time() - t0,
                                  "load_before": load0, "load_after": os.getloadavg()}, indent=1) + "\n")
    print(f"{summary['passed']}/{summary['cases']} within {TOLERANCE} T/2 (worst {summary['max_err_over_half_gauge']:.4f}); "
          f"limit {summary['limit_passed']}/{summary['limit_cases']} within {LIMIT_TOLERANCE} T/2 (worst "
          f"{summary['limit_max_diff_over_half_gauge']:.5f}); {time.time() - t0:.0f} s; load {load0[0]:.2f} -> "
          f"{os.getloadavg()[0]:.2f}")
    return 0 if summary["passed"] == summary["cases"] and summary["limit_passed"] == summary["limit_cases"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
