"""MuJoCo confirmation of a finding: re-simulate the log with the nominal and the extended robot.

The surrogate stage names the cause and its parameter; this stage checks it against the physics
the project simulates. The log's commands drive the MuJoCo robot (``mjtrack.sim.simulate``),
once as described and once extended by the finding: a ground effect changes the description
(:func:`mjtrack.diagnose.result.extended_robot`: cg_x, cg_y, mu, mu_left/mu_right), an input
effect transforms the commands first (the surrogate's exact transform, held per sample). Each
segment is simulated from rest; the simulated body twist (vx, vy, wz), interpolated at the
middle of each log step, is the model's twist sequence for the same fixed-horizon windows as the
surrogate stage (:func:`mjtrack.diagnose.residuals.window_errors`). Both runs share everything
else, so their difference is the effect's.

Not held out: the estimate was fitted (by the surrogate) on the whole log. Not confirmable here:
``slope`` (the MuJoCo scene is flat) and ``icr_spread`` (not a physical parameter of the robot).
Limitation: segments start at rest in the simulation; a real segment that starts while moving
(the Marmotte windows) begins with a transient the simulation does not have.
"""

from __future__ import annotations

import logging
import time

import numpy as np

from mjtrack.diagnose import residuals as rs
from mjtrack.diagnose.surrogate.model import Surrogate
from mjtrack.diagnose.result import extended_robot

log = logging.getLogger(__name__)

NOT_CONFIRMABLE = {"slope": "the MuJoCo scene is flat (no slope yet)",
                   "icr_spread": "not a physical parameter of the MuJoCo robot"}


def simulated_twist(robot, data: rs.DriveData, speeds: np.ndarray, *, config=None) -> np.ndarray:
    """Body twist (N, 3) of the MuJoCo robot driven by per-sample track speeds (N, 2), each segment
    from rest, evaluated at the middle of each log step."""
    from mjtrack.sim.builder import build_model
    from mjtrack.sim.config import sim_config
    from mjtrack.sim.rollout import hold_commands, simulate

    config = config or sim_config(None, robot=robot)  # the simulator the description records
    model = build_model(robot, config)
    dt_sim = model.opt.timestep
    out = np.zeros((data.n, 3))
    cuts = np.flatnonzero(data.seg[1:] != data.seg[:-1]) + 1
    for lo, hi in zip(np.r_[0, cuts], np.r_[cuts, data.n]):
        ts = data.t[lo:hi] - data.t[lo]
        duration = float(ts[-1]) + dt_sim
        steps = hold_commands(ts, speeds[lo:hi, 0], speeds[lo:hi, 1], timestep=dt_sim, duration=duration)
        sim = simulate(robot, steps, config=config, log_rate=1.0 / dt_sim, model=model)
        mid = ts + 0.5 * np.diff(np.r_[ts, ts[-1]])
        for j, name in enumerate(("vx", "vy", "wz")):
            out[lo:hi, j] = np.interp(mid, sim["t"], sim[name])
    return out


def confirm(diagnosis, *, config=None) -> dict:
    """MuJoCo gain of the diagnosis's cause (see module docstring); a dict for diagnosis.json."""
    if diagnosis.baseline.name == "mujoco":
        return {"stage": "mujoco", "run": False, "why": "the baseline is the MuJoCo robot: every number is MuJoCo's"}
    if not diagnosis.findings:
        return {"stage": "mujoco", "run": False, "why": "no cause to confirm"}
    best = diagnosis.findings[0]
    name = best.effect.name
    if name in NOT_CONFIRMABLE:
        return {"stage": "mujoco", "run": False, "why": f"{name}: {NOT_CONFIRMABLE[name]}"}
    t0 = time.perf_counter()
    data = diagnosis.data
    robot = diagnosis.robot
    speeds = data.cmd
    estimate = dict(zip(best.effect.params, best.estimate))
    if best.effect.kind == "input":
        ext_robot = robot
        ext_speeds = Surrogate(robot, diagnosis.baseline.name).inputs(data, best.effect, best.estimate)
    else:
        ext_robot, _ = extended_robot(robot, name, estimate)
        ext_speeds = speeds
    dt = data.step_dt()
    errs = {}
    for label, r, v in (("nominal", robot, speeds), ("extended", ext_robot, ext_speeds)):
        tw = simulated_twist(r, data, v, config=config)
        e = rs.window_errors(tw, dt, data.poses, diagnosis.starts, diagnosis.ends)
        errs[label] = float(np.sqrt(np.mean(e[:, 0] ** 2 + e[:, 1] ** 2)))
    before, after = errs["nominal"], errs["extended"]
    result = {"stage": "mujoco", "run": True, "effect": name, "estimate": {k: float(v) for k, v in estimate.items()},
              "metric": "pos_err_m", "horizon_s": diagnosis.horizon_s, "before": before, "after": after,
              "relative": 1.0 - after / before if before > 0 else 0.0, "held_out": False,
              "seconds": time.perf_counter() - t0}
    log.info("MuJoCo confirmation of %s: %.4g -> %.4g m", name, before, after)
    return result
