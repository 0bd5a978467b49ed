"""Where the MuJoCo wheels disagreed with point-contact Coulomb theory, and why (measured).

    python benchmarks/wheel_physics.py [--out benchmarks/results]

Three findings behind the wheel model's settings (:class:`mjtrack.sim.builder.WheelSet`), each
measured by switching one setting back (a subclass of the wheels, so the product is untouched):

1. **Gyroscopic roll moment.** The Husky-like robot with split friction (mu 0.5 left, 0.9 right) in a
   turn at 2 m/s, R 2 m (commands 1.7225 / 2.2775 m/s), once with wheel bodies of a solid sphere's
   inertia (``spin_inertia_share`` 1) and once with the default (0.01): the ICRs against the Coulomb
   reference (|error| / (T/2)), the lateral load transfer measured at the contacts (half the
   right-minus-left load) against the reference's rigid-plate loads, and the roll moment it implies
   against the spinning wheels' precession moment sum I_yy w_spin w_z.
2. **Wheel hop under the explicit damper.** The Warthog-like robot (280 kg, 0.3 m wheels) pivoting at
   2 m/s with cg_x = -0.1 B, 6 s at 5 ms: whether it diverges with critical spring damping
   (``max_damping_ratio`` 1) and with the default (0.5), without the gyroscopic inertia, and with
   critical damping and the solid-sphere inertia.
3. **Belt wind-up on straight commands.** The Husky-like robot at 1 m/s on both sides, 6 s from
   rest: yaw rate, lateral speed and the belt springs' forces at the end, with the roller chain's
   noslip settings (40 iterations, tolerance 1e-6) and with the wheels' (``min_noslip_iterations``,
   ``max_noslip_tolerance``).
4. **Rolling wheels.** From ``wheeled_fidelity.json`` (run that first): the cases whose reference
   steady state has a wheel rolling without slipping (an ICR on a wheel: y on the wheel line and
   x_c at an axle), and how far MuJoCo's ICRs are from that wheel (its creep).

Writes ``wheel_physics.json``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path

import mujoco
import numpy as np

from mjtrack.icr import icr_from_twist
from mjtrack.io.robot import G, Robot
from mjtrack.models.coulomb import normal_loads, steady_state
from mjtrack.sim.builder import WheelSet, control_matrix
from mjtrack.sim.chassis import build_robot_model
from mjtrack.sim.config import SimConfig
from mjtrack.sim.rollout import STATE_SPEC, settled_state
from mjtrack.sim.steady import case_timestep
from mjtrack.testing.repo import RESULTS

HUSKY = Robot(traction="wheels", track_gauge=0.555, wheelbase=0.512, sprocket_radius=0.165, track_width=0.11,
              mass=50.0, cg_z=0.2)
WARTHOG = Robot(traction="wheels", track_gauge=1.08, wheelbase=1.1, sprocket_radius=0.3, track_width=0.25,
                mass=280.0, cg_z=0.45, cg_y=0.054)


class GyroWheels(WheelSet):
    """The wheels with bodies of a solid sphere's inertia (the setting before the finding)."""

    spin_inertia_share = 1.0


class CriticalWheels(WheelSet):
    """The wheels with critically damped springs."""

    max_damping_ratio = 1.0


class GyroCriticalWheels(WheelSet):
    spin_inertia_share = 1.0
    max_damping_ratio = 1.0


class RollerNoslipWheels(WheelSet):
    """The wheels with the roller chain's noslip settings."""

    min_noslip_iterations = 0
    max_noslip_tolerance = 1.0


def run_constant(robot: Robot, wheels: WheelSet, command, *, timestep: float, seconds: float):
    """(model, data, diverged at [s] or None) after ``seconds`` at a constant command from rest."""
    model = build_robot_model(robot, SimConfig(timestep=timestep), wheels)
    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, settled_state(model), STATE_SPEC)
    data.ctrl[:] = control_matrix(model) @ np.asarray(command, float)
    for _ in range(int(round(seconds / timestep))):
        mujoco.mj_step(model, data)
        if not np.all(np.isfinite(data.qpos)) or abs(data.qpos[2]) > 1.0:
            return model, data, float(data.time)
    mujoco.mj_forward(model, data)
    return model, data, None


def gyroscopic() -> dict:
    robot = HUSKY.replace(mu_left=0.5, mu_right=0.9)
    cmd = (1.7225, 2.2775)
    dt = case_timestep(SimConfig(), robot, cmd)
    out = {"robot": robot.to_dict(), "command": cmd, "timestep": dt}
    for label, wheels in (("solid_sphere_inertia", GyroWheels()), ("default", WheelSet())):
        model, data, bad = run_constant(robot, wheels, cmd, timestep=dt, seconds=6.0)
        lin, ang = data.sensor("body_linvel").data, data.sensor("body_angvel").data
        vl, vr = float(data.sensor("track_speed_left").data[0]), float(data.sensor("track_speed_right").data[0])
        icr = icr_from_twist(lin[0], lin[1], ang[2], vl, vr)
        ref = steady_state(robot, vl, vr)
        half = robot.track_gauge / 2
        f6, loads = np.zeros(6), {"left": 0.0, "right": 0.0}
        for i in range(data.ncon):
            mujoco.mj_contactForce(model, data, i, f6)
            c = data.contact[i]
            name = model.geom(c.geom2 if model.geom(c.geom2).name.startswith("wheel_") else c.geom1).name
            loads[name.split("_")[1]] += f6[0]
        x, y, N = normal_loads(robot, accel=(-ang[2] * (lin[1] + ang[2] * robot.cg_x), ang[2] * lin[0]))
        ref_transfer = float((N[y < 0].sum() - N[y > 0].sum()) / 2)
        transfer = (loads["right"] - loads["left"]) / 2
        spin = sum(data.qvel[model.joint(f"roll_{s}_{i}").dofadr[0]]
                   * model.body_inertia[model.body(f"wheel_{s}_{i}").id][1]
                   for s in ("left", "right") for i in range(robot.wheels_per_side))
        out[label] = {
            "diverged_at": bad, "icr": [float(icr.y_l), float(icr.y_r), float(icr.x_c)], "ref_icr": list(ref.icr),
            "err_over_half_gauge": max(abs(a - b) for a, b in zip((icr.y_l, icr.y_r, icr.x_c), ref.icr)) / half,
            "lateral_load_transfer_N": transfer, "ref_lateral_load_transfer_N": ref_transfer,
            "load_transfer_ratio": transfer / ref_transfer,
            "extra_roll_moment_Nm": (transfer - ref_transfer) * robot.track_gauge,
            "precession_moment_Nm": float(spin * ang[2]),
        }
    return out


def wheel_hop() -> dict:
    robot = WARTHOG.replace(cg_x=-0.11)
    out = {"robot": robot.to_dict(), "command": (-2.0, 2.0), "timestep": 0.005, "seconds": 6.0}
    for label, wheels in (("critical_damping", CriticalWheels()), ("default", WheelSet()),
                          ("critical_damping_solid_sphere_inertia", GyroCriticalWheels())):
        model, data, bad = run_constant(robot, wheels, (-2.0, 2.0), timestep=0.005, seconds=6.0)
        j = model.joint("susp_left_0").id
        c, m = float(model.dof_damping[model.jnt_dofadr[j]]), float(model.body_mass[model.jnt_bodyid[j]])
        out[label] = {"diverged_at": bad, "c_dt_over_m": c * 0.005 / m,
                      "wz": None if bad else float(data.sensor("body_angvel").data[2])}
    return out


def wind_up() -> dict:
    out = {"robot": HUSKY.to_dict(), "command": (1.0, 1.0), "seconds": 6.0}
    for label, wheels in (("roller_chain_noslip", RollerNoslipWheels()), ("default", WheelSet())):
        model, data, bad = run_constant(HUSKY, wheels, (1.0, 1.0), timestep=0.005, seconds=6.0)
        belts = {model.tendon(t).name: float(-model.tendon_stiffness[t] * data.ten_length[t])
                 for t in range(model.ntendon) if model.tendon(t).name.startswith("belt_")}
        out[label] = {"diverged_at": bad, "noslip_iterations": int(model.opt.noslip_iterations),
                      "noslip_tolerance": float(model.opt.noslip_tolerance),
                      "wz": float(data.sensor("body_angvel").data[2]), "vy": float(data.sensor("body_linvel").data[1]),
                      "belt_spring_force_N": belts, "mu_N_per_wheel": HUSKY.mu * HUSKY.weight / 4}
    return out


def rolling(fidelity: Path) -> dict | None:
    if not fidelity.exists():
        return None
    rows = json.loads(fidelity.read_text())["rows"]
    out = {"source": fidelity.name, "cases": len(rows), "rolling": 0, "axle": 0, "one_wheel": 0, "creep_m": [],
           "worst_err_rolling": 0.0}
    for r in rows:
        if "ref_y_l" not in r:
            continue
        half, xa = r["T"] / 2, r["B"] / 2
        axles = np.linspace(-xa, xa, r["wheels_per_side"])
        at_axle = np.min(np.abs(axles - r["ref_x_c"])) < 1e-9
        on_left, on_right = abs(r["ref_y_l"] - half) < 1e-9, abs(r["ref_y_r"] + half) < 1e-9
        if at_axle and (on_left or on_right):
            out["rolling"] += 1
            out["axle" if on_left and on_right else "one_wheel"] += 1
            y = r["y_l"] if on_left else r["y_r"]
            out["creep_m"].append(math.hypot(y - (half if on_left else -half), r["x_c"] - r["ref_x_c"]))
            out["worst_err_rolling"] = max(out["worst_err_rolling"], r["err"])
    out["max_creep_m"] = max(out.pop("creep_m"), default=None)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=RESULTS, help="folder of the result file (and of wheeled_fidelity.json)")
    args = ap.parse_args(argv)
    doc = {"command": "python benchmarks/wheel_physics.py", "load_average": os.getloadavg(), "g": G,
           "gyroscopic": gyroscopic(), "wheel_hop": wheel_hop(), "wind_up": wind_up(),
           "rolling": rolling(args.out / "wheeled_fidelity.json")}
    print(json.dumps(doc, indent=1))
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "wheel_physics.json"
    path.write_text(json.dumps(doc, indent=1) + "\n")
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
