"""The slip EKF's adaptive filter on more random-step drives of the tuning robot.

Run: nice -n 10 python benchmarks/slip_ekf_drives.py [--seeds 3 4 5]

A check that the model-error settings of :mod:`mjtrack.estimation.slip_ekf` (chosen on the
``tuning`` cases of ``benchmarks/filter_consistency.py``, command seed 1) are not fitted to that one
drive: the same robot (default size, 20 kg, μ 0.8, CG 5 cm forward) driven by random steps with
other command seeds, 60 s, the measurements, truth and NIS/NEES summaries of
``filter_consistency.py``; the slip EKF with ``adaptive="imm"`` without (``model_error=None``) and
with the model-error term (the default), three noise seeds each. Pass band as there.
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np

import filter_consistency as fc

from mjtrack.estimation import consistency as cons
from mjtrack.estimation import run_slip_ekf
from mjtrack.io.robot import Robot
from mjtrack.sim.rollout import drive_log
from mjtrack.sim.scenarios import scenario_commands
from mjtrack.testing.repo import benchmark_command, default_run_result, printed_result


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[3, 4, 5], help="command seeds of the random steps")
    args = ap.parse_args(argv)
    print(f"load average {os.getloadavg()}")
    robot = Robot(cg_x=0.05)
    ok_all = True
    for cs in args.seeds:
        table, dur = scenario_commands("random_steps", robot, duration=60.0, seed=cs)
        log = drive_log(robot, table, duration=dur, log_rate=fc.LOG_RATE)
        truth = fc.truths(log, robot)["slip_ekf"]
        for label, me in (("IMM only", None), ("IMM + model error", "auto")):
            vals = []
            for seed in fc.SEEDS:
                pose, twist = fc.measurements(log, seed)
                r = run_slip_ekf(log.t, log.v_left, log.v_right, track_gauge=robot.track_gauge, pose_meas=pose,
                                 twist_meas=twist, pose_std=fc.POSE_STD, twist_std=fc.TWIST_STD, adaptive="imm",
                                 model_error=me)
                vals.append(cons.per_dof(cons.summary(r, truth[1:], t_from=fc.T_FROM)))
            v = np.array(vals)
            ok = bool(np.all((v[:, 0] >= fc.NIS_BAND[0]) & (v[:, 0] <= fc.NIS_BAND[1]))
                      and np.all((v[:, 1] >= fc.NEES_BAND[0]) & (v[:, 1] <= fc.NEES_BAND[1])))
            if me is not None:
                ok_all &= ok
            print(f"command seed {cs}  {label:18s} NIS/dof {np.round(v[:, 0], 2).tolist()}  NEES/dof "
                  f"{np.round(v[:, 1], 2).tolist()}  {'pass' if ok else 'FAIL'}")
    print(f"all pass (with the model-error term): {ok_all}")
    return 0 if ok_all else 1


if __name__ == "__main__":
    with printed_result(default_run_result("slip_ekf_drives.txt"), command=benchmark_command(__file__)):
        status = main()
    sys.exit(status)
