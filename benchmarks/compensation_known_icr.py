"""Why compensation misses the grid's lane change at 0.5 m/s with the CG behind.

Run: nice python benchmarks/compensation_known_icr.py [--out benchmarks/results/compensation_known_icr.json]

The three cases of ``benchmarks/compensation_grid.py`` where a mode is worse than none (lane
change, centre of gravity 5 cm behind, 0.5 m/s: mu 0.4 seeds 0 and 1, mu 0.8 seed 1) and one
where it gains (mu 0.4 seed 2), each driven with none and, for icr and vir:
  online        the compensation as it is (online estimate from the nominal ICRs);
  known         its estimate replaced by known ICRs (zero covariance, the same trust rule): those
                the online estimator holds at the end of a circle (R 1 m, 1.5 turns, seed 1000)
                on the same ground at the same speed (compensation_grid.known_icr);
  known x_c / known spacing / known ybar
                the online estimate with that one quantity replaced by the known one (its
                covariance kept): which part of the estimate's error does the harm;
  warm start    the online estimator started from the known ICRs (the default prior std), its
                weight still taken against the nominal map.
Then, on the circle, the lane change and the figure-eight (mu 0.4, CG behind, 0.5 m/s, seeds 0-2):
the steady ICRs of the Coulomb reference at the circle's command (MuJoCo's steady ICRs agree
with them) against the ICRs the online estimator identified on that circle in closed loop, both
as a KnownICR through the same trust rule: are the ICRs the loop needs the steady ones?
Prints RMS / maximum cross-track error ratios to none (< 1: better than none). Last, the
Coulomb map (CoulombICRMap) against MuJoCo's steady state: the track speeds it gives for (v, w),
held on the MuJoCo robot, against those of the nominal map (yaw-rate error in %).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from mjtrack.control.compensation import PSI_STD0, CoulombICRMap, track_speeds_from_psi
from mjtrack.control.runs import run_tracking
from mjtrack.estimation.icr_ekf import InverseICR, icr_from_psi
from mjtrack.estimation.online import KnownICR, OnlineICREstimator
from mjtrack.io.robot import Robot
from mjtrack.sim.steady import steady_state as mujoco_steady
from mjtrack.testing.repo import RESULTS

from compensation_grid import known_icr  # noqa: E402  (the grid's: the ICRs after a circle on that ground, seed 1000)

CASES = [(0.4, 0), (0.4, 1), (0.8, 1), (0.4, 2)]  # (mu, seed): lane change, cg_x -0.05, 0.5 m/s
CG, SPEED = -0.05, 0.5
MAP_CASES = [({"mu": 0.4, "cg_x": 0.05}, 0.5, 0.5), ({"mu": 0.8, "cg_x": -0.05}, 1.0, -0.67), ({}, 0.3, 1.0)]


class PartlyKnown:
    """The online estimator with some of (x_c, spacing, ybar) replaced by known values; its
    covariance kept (the interface SlipCompensation uses)."""

    def __init__(self, track_gauge, known_icr, replace):
        self.online = OnlineICREstimator(track_gauge, psi_std0=PSI_STD0)
        y_l, y_r, x_c = known_icr
        self.known = {"x_c": x_c, "spacing": y_l - y_r, "ybar": 0.5 * (y_l + y_r)}
        self.replace = tuple(replace)
        self.twist_std = self.online.twist_std

    @property
    def t(self):
        return self.online.t

    def reset(self, t, pose):
        self.online.reset(t, pose)

    def step(self, t, v_left, v_right, *, pose=None, twist=None):
        self.online.step(t, v_left, v_right, pose=pose, twist=twist)

    def icr(self):
        y_l, y_r, x_c = self.online.icr()
        q = {"x_c": x_c, "spacing": y_l - y_r, "ybar": 0.5 * (y_l + y_r)}
        q.update({k: self.known[k] for k in self.replace})
        return q["ybar"] + 0.5 * q["spacing"], q["ybar"] - 0.5 * q["spacing"], q["x_c"]

    @property
    def psi(self):
        return InverseICR.from_icr(*self.icr()).params

    @property
    def psi_cov(self):
        return self.online.psi_cov


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=RESULTS / "compensation_known_icr.json")
    args = ap.parse_args(argv)
    try:
        os.nice(10)
    except OSError:
        pass
    print(f"load {os.getloadavg()}")
    t0 = time.time()
    rows = []
    for mu, seed in CASES:
        robot = Robot(mu=mu, cg_x=CG)
        k = known_icr(mu, CG, SPEED)
        T = robot.track_gauge
        variants = {
            "online": lambda: None,
            "known": lambda: {"estimator": KnownICR(k)},
            "known x_c": lambda: {"estimator": PartlyKnown(T, k, ("x_c",))},
            "known spacing": lambda: {"estimator": PartlyKnown(T, k, ("spacing",))},
            "known ybar": lambda: {"estimator": PartlyKnown(T, k, ("ybar",))},
            "warm start": lambda: {"estimator": OnlineICREstimator(T, icr0=tuple(k), psi_std0=PSI_STD0)},
        }
        kw = dict(scenario="lane_change", speed=SPEED, seed=seed)
        none = run_tracking(robot, compensation="none", **kw).metrics
        row = {"mu": mu, "seed": seed, "cg_x": CG, "speed": SPEED, "known_icr": k, "none": none, "modes": {}}
        print(f"lane change mu {mu} cg {CG} {SPEED} m/s seed {seed}: none RMS {1e3 * none['rms_cross_track_m']:.2f} mm, "
              f"max {1e3 * none['max_cross_track_m']:.2f} mm; known ICRs (y_l, y_r, x_c) {np.round(k, 3).tolist()}")
        for mode in ("icr", "vir"):
            row["modes"][mode] = {}
            parts = []
            for name, opts in variants.items():
                m = run_tracking(robot, compensation=mode, compensation_options=opts(), **kw).metrics
                r = (m["rms_cross_track_m"] / none["rms_cross_track_m"], m["max_cross_track_m"] / none["max_cross_track_m"])
                row["modes"][mode][name] = {"rms_ratio": r[0], "max_ratio": r[1], "mean_trust_weight": m.get("mean_trust_weight")}
                parts.append(f"{name} {r[0]:.3f},{r[1]:.3f}")
            print(f"  {mode}: " + "  ".join(parts), flush=True)
        rows.append(row)
    robot = Robot(mu=0.4, cg_x=CG)
    steady_psi = CoulombICRMap(robot)(SPEED, SPEED)  # the circle: R 1 m
    steady = [float(a) for a in icr_from_psi(steady_psi)]
    mj = mujoco_steady(robot, *track_speeds_from_psi(SPEED, SPEED, steady_psi))  # the same track speeds on MuJoCo
    mj_icr = [float(mj.y_l), float(mj.y_r), float(mj.x_c)]
    loop = known_icr(0.4, CG, SPEED)
    print(f"steady ICRs at the circle's command: Coulomb reference {np.round(steady, 4).tolist()}, MuJoCo "
          f"{np.round(mj_icr, 4).tolist()}; closed-loop online estimate {np.round(loop, 4).tolist()}")
    paths = []
    for scenario in ("circle", "lane_change", "figure_eight"):
        for seed in (0, 1, 2):
            laps = 1.0 if scenario == "figure_eight" else None
            kw = dict(scenario=scenario, speed=SPEED, seed=seed, laps=laps)
            none = run_tracking(robot, compensation="none", **kw).metrics
            res = {"scenario": scenario, "seed": seed}
            parts = []
            for name, icr in (("steady", steady), ("closed-loop", loop)):
                for mode in ("icr", "vir"):
                    m = run_tracking(robot, compensation=mode, compensation_options={"estimator": KnownICR(icr)}, **kw).metrics
                    r = (m["rms_cross_track_m"] / none["rms_cross_track_m"], m["max_cross_track_m"] / none["max_cross_track_m"])
                    res[f"{name} {mode}"] = {"rms_ratio": r[0], "max_ratio": r[1], "mean_trust_weight": m["mean_trust_weight"]}
                    parts.append(f"{name} {mode} {r[0]:.2f},{r[1]:.2f}")
            paths.append(res)
            print(f"  {scenario:12s} seed {seed}: " + "  ".join(parts), flush=True)
    maps = []
    for desc, v, w in MAP_CASES:
        rb = Robot(**desc)
        err = {}
        for name, psi in (("coulomb", CoulombICRMap(rb)(v, w)), ("nominal", np.array([0.0, 0.0, 1.0 / rb.track_gauge]))):
            st = mujoco_steady(rb, *track_speeds_from_psi(v, w, psi))
            err[name] = {"wz_err_pct": 100 * (st.wz - w) / abs(w), "vx_err_m_s": st.vx - v}
        maps.append({"robot": desc, "v": v, "w": w, **err})
        print(f"map on MuJoCo's steady state, {desc or 'default robot'} at (v, w) = ({v}, {w}): yaw rate "
              f"{err['coulomb']['wz_err_pct']:+.2f} % (Coulomb map), {err['nominal']['wz_err_pct']:+.1f} % (nominal); "
              f"v_x {1e3 * err['coulomb']['vx_err_m_s']:+.2f} mm/s (Coulomb map)")
    print(f"{time.time() - t0:.0f} s, load {os.getloadavg()}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"cases": rows, "steady_icr": steady, "mujoco_steady_icr": mj_icr,
                                    "closed_loop_icr": loop, "paths": paths, "map_on_mujoco": maps},
                                   indent=1) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
