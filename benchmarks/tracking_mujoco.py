"""Slip-compensated trajectory tracking on the MuJoCo robot.

Run: python benchmarks/tracking_mujoco.py [--seeds 0 1 2] [--out benchmarks/results/tracking_mujoco.json]

Robot: default robot with mu = 0.4 and the centre of gravity 0.1·L = 0.05 m forward. Reference:
figure-eight (lemniscate of Gerono, A = 1.5 m, 2 laps, 18.3 m) at 0.5 m/s, and a 1 m circle.
Controllers, the same gains with every compensation:

* ``tracker``: TrajectoryTracker (feed-forward (v_d, w_d) + pole-placement feedback, poles
  -1, -2, -4 1/s) at 25 Hz;
* ``feedforward``: the reference's (v_d, w_d) only (open loop).

Compensations (mjtrack.control.compensation): ``none`` (nominal V_L,R = v -+ w T/2), ``icr``
(inverse ICR map of the online estimate for the feed-forward, feedback on the drift-free body
point), ``vir`` (the same map + the (2.21) heading correction); both weighted by the trust
weight of the estimate (see benchmarks/compensation_grid.py for the grid of cases).
Measurements seen by the controller and estimator: pose and twist with seeded noise (1 cm,
0.01 rad; 0.02 m/s, 0.02 rad/s). Cross-track error: distance of the true centre to the path.
Pass: RMS cross-track with ``vir`` <= 50 % of ``none`` for the tracker on the figure-eight,
every seed.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from mjtrack.control.compensation import MODES
from mjtrack.control.runs import run_tracking
from mjtrack.io.robot import Robot
from mjtrack.testing.repo import RESULTS


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--out", type=Path, default=RESULTS / "tracking_mujoco.json")
    args = ap.parse_args(argv)
    robot = Robot(mu=0.4, cg_x=0.1 * Robot().track_length)
    rows = []
    print(f"robot: mu = {robot.mu}, cg_x = {robot.cg_x} m; metrics in m (RMS / max cross-track, final position error)")
    print(f"{'scenario':13s} {'controller':12s} {'seed':>4s} " + " ".join(f"{m:>22s}" for m in MODES) + "   vir/none  icr/none")
    ok = True
    for scenario in ("figure_eight", "circle"):
        for controller in ("tracker", "feedforward"):
            for seed in args.seeds:
                res = {m: run_tracking(robot, scenario=scenario, compensation=m, controller=controller, seed=seed)
                       for m in MODES}
                met = {m: r.metrics for m, r in res.items()}
                r_vir = met["vir"]["rms_cross_track_m"] / met["none"]["rms_cross_track_m"]
                r_icr = met["icr"]["rms_cross_track_m"] / met["none"]["rms_cross_track_m"]
                est = {m: r.icr_history[-1, 1:].tolist() for m, r in res.items() if len(r.icr_history)}
                rows.append({"scenario": scenario, "controller": controller, "seed": seed, "metrics": met,
                             "ratio_rms_vir_over_none": r_vir, "ratio_rms_icr_over_none": r_icr,
                             "final_icr_estimate": est, "settings": res["none"].settings})
                if scenario == "figure_eight" and controller == "tracker":
                    ok &= r_vir <= 0.5
                print(f"{scenario:13s} {controller:12s} {seed:4d} "
                      + " ".join(f"{met[m]['rms_cross_track_m']:.3f}/{met[m]['max_cross_track_m']:.3f}/{met[m]['final_pos_err_m']:.3f}".rjust(22)
                                 for m in MODES)
                      + f"   {r_vir:8.3f}  {r_icr:8.3f}")
    fig8 = [r for r in rows if r["scenario"] == "figure_eight" and r["controller"] == "tracker"]
    summary = {m: float(np.mean([r["metrics"][m]["rms_cross_track_m"] for r in fig8])) for m in MODES}
    print("figure-eight, tracker, mean RMS over seeds: " + ", ".join(f"{m} {v:.4f} m" for m, v in summary.items())
          + f"; vir/none = {summary['vir'] / summary['none']:.3f}, icr/none = {summary['icr'] / summary['none']:.3f}")
    report = {"robot": robot.to_dict(), "seeds": args.seeds, "runs": rows, "figure_eight_tracker_mean_rms": summary,
              "pass_vir_le_half_none": bool(ok)}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(report, indent=1))
    print(f"pass (vir <= 50 % of none, tracker, figure-eight, every seed): {ok}; wrote {args.out}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
