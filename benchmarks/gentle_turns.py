"""Why the roller chain misses Coulomb in gentle turns (the fidelity script's wide grid), measured.

    python benchmarks/gentle_turns.py [--out benchmarks/results/gentle_turns.json]

In a turn of radius R at speed v the tracks slip by |w| (y - T/2) longitudinally and |w| x
laterally: at R 10 m and 0.2 m/s for the 5 kg, T 0.2 / L 0.4 m robot of the wide grid that is
0.5-2 mm/s, so the ICRs y = (v_x - V)/w move by 0.05 T/2 (5 mm) for a velocity error of
0.1 mm/s. Each section isolates one candidate cause on that robot (cg 0.1 L forward, turning
left, forward) and on the wide grid's 80 kg robot, with steady states as ``benchmarks/fidelity.py``
measures them (3 s settle, 2 s mean, ICRs from the measured track speeds, Coulomb reference with
load transfer at those speeds):

1. **Is the friction Coulomb at each contact?** After the settle, for every roller contact:
   |f_t| / (mu f_n) and the cosine between the friction force and the contact point's slip
   velocity (relative to the ground, from the roller body's velocity at the contact point).
2. **Time step or contact softness?** ICR error at dt 5, 2.5, 1.25 ms, and at dt 2.5 ms with
   the contact (normal) and friction time constants held at 2 x 5 ms (``contact_timeconst``,
   ``friction_timeconst``): if the error follows the time constants, it is the soft contact.
3. **Where the contact point sits.** MuJoCo puts a sphere-plane contact half-way into the
   penetration, at r - d/2 from the roller axis, so the ground sees a roller turning at w_r
   move at w_r (r - d/2) while the track-speed sensor reports w_r r. Printed: the mean of
   w_r (r + dist/2) minus the mean of w_r r per track (the belt-speed offset the ground sees),
   the straight-line speed error |v_x - V| / V, and the ICR error, without and with the rest
   margins (``SimConfig.rest_margin``, :func:`mjtrack.sim.builder.apply_rest_margins`).
4. **What the margins leave: a pitched chassis.** With the centre of mass off-centre the
   chassis used to rest pitched on equal springs, so the slides lean: the noslip pass's
   longitudinal friction then has a component along them that the main solve never saw, and
   the rollers sink (inner track) or rise (outer) in a turn. Printed: the in-turn penetrations
   and the ICR errors with the chassis pitched (``level_chassis=False``) and level (default).
5. **x_c: drive compliance and the time step.** The rollers' servos let their surface speeds
   spread by F_i / (kv/N) along a track; near x_c, where the slip is mostly longitudinal, this
   bends the friction directions. Printed: x_c against Coulomb for the 80 kg robot (cg +-0.1 L,
   R 10 m at 0.2 m/s) with the servos alone (no belt, the earlier default), a 10x
   stiffer one (kv and track_mass x10: the same kv dt / track_mass), the equality-coupled chain
   and the belt of section 8 (10 ms, default; 8 and 20 ms); and at 2 m/s (cg 0) the x_c offset
   against v tc/2, tc the friction rows' time constant (2 dt by default, the least MuJoCo
   allows): the friction rows' reference acceleration -v_slip/(tc/2) makes the friction oppose
   the slip predicted tc/2 ahead, which the turn has rotated by w tc/2 in the world-fixed
   contact frame, so the steady state sits v tc/2 off the Coulomb one along x. RK4 does not
   change it (the contact solve, not the integrator); a longer friction time constant does.

7. **How much of the commanded speed difference the drive delivers, and a PI drive.** Each
   roller's servo is proportional (force kv/N (u - v)): under the turn's longitudinal friction
   the tracks run F/kv off their commands. Printed for the three robots at R 10 m and 0.2 m/s
   (cg +-0.1 L): the measured V_R - V_L over the commanded one and the x_c error, with the
   proportional drive without the belt (the earlier default), with the belt (the default:
   x_c follows Coulomb, the delivered share is the same, the ICRs use the measured
   speeds) and with a probe PI drive (no belt; this script only: a second actuator per roller,
   force kv/(N Ti) (integral of u - r q), Ti 0.05 s, each limited as the servo is and both
   under one joint-level force limit ``actfrcrange``); and each drive's speed 3 s after a
   0 -> 1 m/s step of the default robot (MuJoCo actuators have one activation, so the PI
   integral cannot be clamped relative to the roller's position: it winds up while the drive
   saturates and then holds the speed F/kv high).

8. **The belt, and what sets the step of a gentle turn.** Since section 5 every
   roller's surface is tied by a spring to a belt joint of its track (``SimConfig.belt_timeconst``,
   10 ms): the rollers then run at one speed, as on a belt. Printed: section 5's x_c with it (and
   at 8 and 20 ms), and, for the 5 kg wide robot (cg -0.1 L, R 10 m, 0.2 m/s), the ICR error at
   dt 5 ... 0.625 ms and at 1.25 ms with the friction or the contact time constant held at 10 ms:
   the error follows the friction rows' time constant (2 dt), not dt or the contact's. Then for 4
   robots x 3 gentle turns x cg +-0.1 L at dt 5, 2.5, 1.25 ms: the worst dt-halving change per bin
   of r = mu g dt / (|w| L/2), one step's friction velocity change over the lateral slip at the
   track ends; ``SimConfig.slip_budget`` 5 keeps r <= 5.
9. **Fast pivots and tight turns with the cg off-centre.** The 5 kg long robot (cg
   +0.1 L) pivoting at 0.2-2 m/s with a plain box chassis (before) and with the chassis inertia
   that keeps the robot's principal axes on the body axes (default): the elements at height r
   and the chassis above them made I_xz != 0, and a spin w gave a pitch moment w^2 I_xz that the
   Coulomb reference (a rigid body with principal axes on the body axes) does not have. And the
   150 kg long robot (cg_y 0.05 T, cg_x -0.1 L) at R 2 m, 2 m/s reversing against the reference
   with the rigid-plate loads (default) and with the per-track Wong loads of an earlier form
   (a c_x c_y x y twist term that a rigid chassis on springs cannot carry; this script
   only), with cg_y 0.05 T and 0.

6. **A log's twist against its poses.** Semi-implicit Euler moves the pose with the step's new
   velocity while the sensors report the step-start one, so the twist in a log and the body
   velocity of its poses (central differences in the mid-sample frame, logged at 200 Hz) differ
   sideways by w dt v / 2 in a steady turn (default robot, 2 m/s commanded, 0.2 rad/s nominal).

About 4 min on one core (sections 8 and 9: 3 min).
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import mujoco
import numpy as np

from fidelity import commands_for, wide_robots

from mjtrack.io.robot import G
from mjtrack.models.coulomb import steady_state as coulomb
from mjtrack.sim.builder import build_model, control_matrix
from mjtrack.sim.config import SimConfig
from mjtrack.sim.rollout import STATE_SPEC, drive_log, settled_state
from mjtrack.sim.steady import steady_batch
from mjtrack.testing.repo import RESULTS


def FixedStep(**changes) -> SimConfig:  # noqa: N802 -- a SimConfig, named for what it pins
    """SimConfig at the stated fixed step: every run here is about a mechanism at a given dt, so
    the step rules (SimConfig.lag_budget, slip_budget, added after sections 1-7) must not change
    the step."""
    return SimConfig(**{"lag_budget": None, "slip_budget": None, **changes})


ROBOTS = ("5kg_long", "80kg_issue11")
TURNS = ((5.0, 0.2), (10.0, 0.2), (10.0, 2.0))  # (R [m], v [m/s])


def robot_of(name: str):
    r = wide_robots()[name]
    return r.replace(cg_x=0.1 * r.track_length)


def icr_errors(name: str, config: SimConfig) -> list[dict]:
    """|dy| / (T/2) and |dx_c| / L against Coulomb for the TURNS (left, forward)."""
    robot = robot_of(name)
    cmds = np.array([commands_for(robot, R, v, 1, 1) for R, v in TURNS])
    res = steady_batch([robot] * len(TURNS), cmds, config=config)
    out = []
    for (R, v), s in zip(TURNS, res):
        ref = coulomb(robot, s.v_left, s.v_right)
        out.append({"R": R, "v": v, "err_y": max(abs(s.y_l - ref.y_l), abs(s.y_r - ref.y_r)) / (robot.track_gauge / 2),
                    "err_x": abs(s.x_c - ref.x_c) / robot.track_length, "y_l": s.y_l, "y_r": s.y_r,
                    "ref_y_l": ref.y_l, "ref_y_r": ref.y_r})
    return out


def _turning(name: str, config: SimConfig, R: float, v: float):
    robot = robot_of(name)
    model = build_model(robot, config)
    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, settled_state(model), STATE_SPEC)
    data.ctrl[:] = control_matrix(model) @ np.array(commands_for(robot, R, v, 1, 1))
    for _ in range(int(round(3.0 / model.opt.timestep))):
        mujoco.mj_step(model, data)
    return robot, model, data


def _roller_of(model, c) -> str:
    return next(model.geom(g).name for g in (c.geom1, c.geom2) if model.geom(g).name.startswith("roller_"))


def contact_friction(name: str, R: float = 10.0, v: float = 0.2) -> dict:
    """Section 1: per-contact saturation and alignment with the slip, after the settle."""
    robot, model, data = _turning(name, FixedStep(), R, v)
    mujoco.mj_step(model, data)
    sat, cosines, slips = [], [], []
    f6, vel = np.zeros(6), np.zeros(6)
    for i in range(data.ncon):
        c = data.contact[i]
        body = model.geom_bodyid[c.geom1] if model.geom_bodyid[c.geom1] != 0 else model.geom_bodyid[c.geom2]
        mujoco.mj_contactForce(model, data, i, f6)
        mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, body, vel, 0)
        vp = vel[3:] + np.cross(vel[:3], c.pos - data.xipos[body])  # contact point of the roller, world
        slip = (c.frame.reshape(3, 3) @ vp)[1:]
        ft = f6[1:3]
        mu = robot.mu
        sat.append(float(np.linalg.norm(ft) / (mu * f6[0])))
        cosines.append(float(ft @ slip / (np.linalg.norm(ft) * np.linalg.norm(slip) + 1e-15)))
        slips.append(float(1000 * np.linalg.norm(slip)))
    return {"R": R, "v": v, "saturation_min": min(sat), "saturation_max": max(sat),
            "cos_friction_slip_max": max(cosines), "slip_mm_s_min": min(slips), "slip_mm_s_max": max(slips)}


def belt_offsets(name: str, config: SimConfig, R: float = 10.0, v: float = 0.2) -> dict:
    """Section 3/4: belt-speed offset the ground sees, in-turn penetrations, roller spread."""
    _, model, data = _turning(name, config, R, v)
    r = config.roller_radius
    n = config.n_rollers
    spin = {s: np.zeros(n) for s in ("left", "right")}
    dist = {s: np.zeros(n) for s in ("left", "right")}
    steps = int(round(1.0 / model.opt.timestep))
    for _ in range(steps):
        mujoco.mj_step(model, data)
        d = {}
        for i in range(data.ncon):
            d[_roller_of(model, data.contact[i])] = data.contact[i].dist
        for s in spin:
            spin[s] += np.array([data.joint(f"roll_{s}_{i}").qvel[0] for i in range(n)]) / steps
            dist[s] += np.array([d.get(f"roller_{s}_{i}", np.nan) for i in range(n)]) / steps
    out = {}
    for s in spin:
        seen = np.mean(spin[s] * (r + dist[s] / 2))
        reported = np.mean(spin[s] * r)
        surf = 1000 * spin[s] * r
        out[s] = {"belt_offset_mm_s": float(1000 * (seen - reported)),
                  "dist_um_min": float(1e6 * np.min(dist[s])), "dist_um_max": float(1e6 * np.max(dist[s])),
                  "roller_speed_spread_mm_s": float(np.ptp(surf))}
    return out


def x_c_study() -> dict:
    """Section 5 (the wide grid's 80 kg robot)."""
    base = wide_robots()["80kg_issue11"]
    out: dict = {"drive": [], "time_step": []}
    drives = {"servos only (no belt)": FixedStep(belt_timeconst=None),
              "10x stiffer drive, no belt": FixedStep(belt_timeconst=None, kv=10 * FixedStep().kv,
                                                      track_mass=10 * FixedStep().track_mass),
              "equality-coupled chain": FixedStep(coupling="equality"),
              "belt 10 ms (default)": FixedStep(),
              "belt 8 ms": FixedStep(belt_timeconst=0.008),
              "belt 20 ms": FixedStep(belt_timeconst=0.02)}
    robots = [base.replace(cg_x=c * base.track_length) for c in (-0.1, 0.1)]
    cmds = np.array([commands_for(r, 10.0, 0.2, 1, 1) for r in robots])
    for label, cfg in drives.items():
        for cgf, r, s in zip((-0.1, 0.1), robots, steady_batch(robots, cmds, config=cfg)):
            ref = coulomb(r, s.v_left, s.v_right)
            out["drive"].append({"drive": label, "cg_frac": cgf, "x_c_mm": 1000 * s.x_c, "ref_x_c_mm": 1000 * ref.x_c,
                                 "err_x": abs(s.x_c - ref.x_c) / r.track_length})
    cmd = np.array([commands_for(base, 10.0, 2.0, 1, 1)])
    for label, cfg in (("dt 5 ms", FixedStep()), ("dt 5 ms, RK4", FixedStep(integrator="RK4")),
                       ("dt 5 ms, friction tc 20 ms", FixedStep(friction_timeconst=0.02)),
                       ("dt 2.5 ms", FixedStep(timestep=0.0025)),
                       ("dt 2.5 ms, friction tc 10 ms", FixedStep(timestep=0.0025, friction_timeconst=0.01))):
        s = steady_batch([base], cmd, config=cfg)[0]
        ref = coulomb(base, s.v_left, s.v_right)
        tc = cfg.friction_timeconst or 2 * cfg.timestep
        out["time_step"].append({"case": label, "dt": cfg.timestep, "friction_timeconst": tc,
                                 "offset_mm": 1000 * (s.x_c - ref.x_c), "v_tc_half_mm": 1000 * 2.0 * tc / 2})
    return out


def twist_against_poses(v: float = 2.0, w: float = 0.2) -> dict:
    """Section 6: mean lateral body velocity of the log's twist and of its poses."""
    from mjtrack.io.robot import Robot

    robot = Robot()
    half = robot.track_gauge / 2
    log = drive_log(robot, (np.array([0.0]), np.array([v - w * half]), np.array([v + w * half])),
                    duration=8.0, log_rate=200.0, config=FixedStep())
    k = log.t >= 3.0
    t, x, y, yaw = log.t[k], log.x[k], log.y[k], np.unwrap(log.yaw[k])
    dt = np.diff(t)
    mid = (yaw[1:] + yaw[:-1]) / 2
    vy_pose = -np.sin(mid) * np.diff(x) / dt + np.cos(mid) * np.diff(y) / dt
    dt_sim = FixedStep().timestep
    return {"vy_twist": float(np.mean(log.vy[k])), "vy_poses": float(np.mean(vy_pose)),
            "half_w_dt_v": float(0.5 * np.mean(log.wz[k]) * dt_sim * np.mean(log.vx[k]))}


PI_TI = 0.05  # [s] integral time of the probe PI drive (section 7)


def _pi_model(robot, config: SimConfig, terrain=None):
    """Section 7: the roller chain with a PI drive (probe; not in the library)."""
    from mjtrack.sim.builder import ROLLER_CHAIN
    from mjtrack.sim.chassis import build_robot_scene

    config = ROLLER_CHAIN.configure(robot, config)
    spec = build_robot_scene(robot, config, ROLLER_CHAIN, terrain)
    for act in list(spec.actuators):
        if not act.name.startswith("drive_"):
            continue
        ki, fmax = act.gainprm[0] / PI_TI, act.forcerange[1]
        a = spec.add_actuator(name=act.name + "_int", target=act.target, trntype=act.trntype)
        a.gear[0] = act.gear[0]
        a.dyntype = mujoco.mjtDyn.mjDYN_INTEGRATOR  # activation = integral of the command [m]
        a.gaintype, a.gainprm[0] = mujoco.mjtGain.mjGAIN_FIXED, ki
        a.biastype = mujoco.mjtBias.mjBIAS_AFFINE
        a.biasprm[:3] = [0.0, -ki, 0.0]  # - ki x (roller surface position r q)
        # its own limit too: without it the wound-up integral overpowers the proportional part
        # under the joint limit and the speed cycles between 0.2 and 1.9 m/s (measured)
        a.forcelimited, a.forcerange = mujoco.mjtLimited.mjLIMITED_TRUE, [-fmax, fmax]
        joint = spec.joint(act.target)  # one limit on the sum of both actuators' forces
        joint.actfrclimited, joint.actfrcrange = mujoco.mjtLimited.mjLIMITED_TRUE, [-fmax * act.gear[0], fmax * act.gear[0]]
    return ROLLER_CHAIN.finish_model(spec.compile(), config)


def drive_study() -> dict:
    """Section 7: share of the commanded speed difference delivered, and x_c, P against PI drive."""
    import mjtrack.sim.rollout as rollout_module
    import mjtrack.sim.steady as steady_module
    from mjtrack.io.robot import Robot

    out: dict = {"turns": [], "step": {}}
    drives = {"P, no belt": FixedStep(belt_timeconst=None), "P + belt (default)": FixedStep(),
              "PI probe, no belt": FixedStep(belt_timeconst=None)}
    for label, cfg in drives.items():
        patched = {m: m.build_model for m in (steady_module, rollout_module)}
        if label.startswith("PI"):
            for m in patched:
                m.build_model = _pi_model
        try:
            for name in ("80kg_issue11", "150kg_long", "5kg_long"):
                base = wide_robots()[name]
                robots = [base.replace(cg_x=c * base.track_length) for c in (-0.1, 0.1)]
                cmds = np.array([commands_for(r, 10.0, 0.2, 1, 1) for r in robots])
                for cgf, r, c, s in zip((-0.1, 0.1), robots, cmds, steady_batch(robots, cmds, config=cfg)):
                    ref = coulomb(r, s.v_left, s.v_right)
                    out["turns"].append({"drive": label, "robot": name, "cg_frac": cgf,
                                         "delivered": (s.v_right - s.v_left) / (c[1] - c[0]),
                                         "err_x": abs(s.x_c - ref.x_c) / r.track_length})
            log = drive_log(Robot(), (np.array([0.0, 2.0]), np.array([0.0, 1.0]), np.array([0.0, 1.0])), duration=5.0,
                            config=cfg, log_rate=100.0)
            out["step"][label] = float((log.v_left[-1] + log.v_right[-1]) / 2)
        finally:
            for m, fn in patched.items():
                m.build_model = fn
    return out


SLIP_ROBOTS = ("5kg_wide", "5kg_long", "150kg_wide", "80kg_issue11")
SLIP_TURNS = ((10.0, 0.2), (5.0, 0.2), (10.0, 0.7))


def _errors(robot, s, f=None) -> dict:
    ref = coulomb(robot, s.v_left, s.v_right)
    half = robot.track_gauge / 2
    row = {"err_y": max(abs(s.y_l - ref.y_l), abs(s.y_r - ref.y_r)) / half,
           "err_x": abs(s.x_c - ref.x_c) / robot.track_length}
    if f is not None:
        row["dt_dy"] = max(abs(s.y_l - f.y_l), abs(s.y_r - f.y_r)) / half
    return row


def slip_budget_study() -> dict:
    """Section 8: what sets the time step of gentle turns (belt on)."""
    out: dict = {"time_constants": [], "ratio": []}
    base = wide_robots()["5kg_wide"]
    robot = base.replace(cg_x=-0.1 * base.track_length)
    cmd = np.array([commands_for(robot, 10.0, 0.2, 1, 1)])
    for label, cfg in (("dt 5 ms", FixedStep()), ("dt 2.5 ms", FixedStep(timestep=0.0025)),
                       ("dt 1.25 ms", FixedStep(timestep=0.00125)), ("dt 0.625 ms", FixedStep(timestep=0.000625)),
                       ("dt 1.25 ms, friction tc 10 ms", FixedStep(timestep=0.00125, friction_timeconst=0.01)),
                       ("dt 1.25 ms, contact tc 10 ms", FixedStep(timestep=0.00125, contact_timeconst=0.01)),
                       ("dt 5 ms, no belt", FixedStep(belt_timeconst=None)),
                       ("dt 1.25 ms, no belt", FixedStep(timestep=0.00125, belt_timeconst=None))):
        s = steady_batch([robot], cmd, config=cfg)[0]
        out["time_constants"].append({"case": label, **_errors(robot, s)})
    steps = (0.005, 0.0025, 0.00125, 0.000625)
    for name in SLIP_ROBOTS:
        b = wide_robots()[name]
        robots = [b.replace(cg_x=c * b.track_length) for c in (-0.1, 0.1)]
        for R, v in SLIP_TURNS:
            cmds = np.array([commands_for(r, R, v, 1, 1) for r in robots])
            res = {dt: steady_batch(robots, cmds, config=FixedStep(timestep=dt)) for dt in steps}
            for k, r in enumerate(robots):
                w = abs(cmds[k][1] - cmds[k][0]) / r.track_gauge
                for dt in steps[:-1]:
                    ratio = r.mu * G * dt / (w * r.track_length / 2)
                    out["ratio"].append({"robot": name, "R": R, "v": v, "cg_frac": r.cg_x / r.track_length, "dt": dt,
                                         "ratio": ratio, **_errors(r, res[dt][k], res[dt / 2][k])})
    return out


def _wong_per_track_loads(self, ax: float, ay: float) -> np.ndarray:
    """Section 9: the reference's loads in an earlier form (script only): each track its own Wong
    distribution with the common centroid c_x, split by the lever rule (no lift-off handling:
    the cases here keep every point loaded)."""
    r = self.robot
    cx = r.cg_x - r.cg_z * ax / self.g_normal
    cy = r.cg_y - r.cg_z * ay / self.g_normal
    along = 1.0 + cx * self.xg / np.mean(self.xg**2)
    side = np.where(self.left, 0.5 + cy / r.track_gauge, 0.5 - cy / r.track_gauge)
    return r.mass * self.g_normal * side * np.tile(along / along.sum(), 2 * self.k) / self.k


def inertia_and_loads() -> dict:
    """Section 9: fast pivots and fast tight turns of robots with an off-centre cg."""
    import mjtrack.models.coulomb as coulomb_module

    out: dict = {"pivots": [], "loads": []}
    base = wide_robots()["5kg_long"]
    robot = base.replace(cg_x=0.1 * base.track_length)
    speeds = (0.2, 0.7, 1.4, 2.0)
    cmds = np.array([commands_for(robot, "pivot", v, 1, 1) for v in speeds])
    for label, cfg in (("box chassis (before)", SimConfig(principal_axes=False)), ("principal axes (default)", SimConfig())):
        for v, s in zip(speeds, steady_batch([robot] * len(speeds), cmds, config=cfg)):
            out["pivots"].append({"chassis": label, "v": v, "wz": s.wz, **_errors(robot, s)})
    big = wide_robots()["150kg_long"]
    for cg_y in (big.cg_y, 0.0):
        r = big.replace(cg_x=-0.1 * big.track_length, cg_y=cg_y)
        s = steady_batch([r], np.array([commands_for(r, 2.0, 2.0, 1, -1)]), config=SimConfig())[0]
        row = {"cg_y": cg_y, "plate": _errors(r, s)}
        saved = coulomb_module._Contacts.loads
        coulomb_module._Contacts.loads = _wong_per_track_loads
        try:
            row["per_track_wong"] = _errors(r, s)
        finally:
            coulomb_module._Contacts.loads = saved
        out["loads"].append(row)
    return out


def straight_speed_error(config: SimConfig, v: float = 0.8) -> float:
    from mjtrack.io.robot import Robot

    log = drive_log(Robot(), (np.array([0.0]), np.array([v]), np.array([v])), duration=5.0, config=config)
    k = log.t >= 2.0
    V = float(np.mean(log.v_left[k] + log.v_right[k]) / 2)
    return float(abs(np.mean(log.vx[k]) - V) / V)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=RESULTS / "gentle_turns.json")
    args = p.parse_args(argv)
    print(f"load average before: {os.getloadavg()}")
    doc: dict = {"turns": TURNS, "robots": ROBOTS}

    print("\n1. friction at each roller contact (5 kg, R 10 m, 0.2 m/s, margins on)")
    doc["contact_friction"] = cf = contact_friction("5kg_long")
    print(f"   |f_t|/(mu f_n) {cf['saturation_min']:.4f}-{cf['saturation_max']:.4f}; cos(friction, slip) <= "
          f"{cf['cos_friction_slip_max']:+.4f}; slips {cf['slip_mm_s_min']:.2f}-{cf['slip_mm_s_max']:.2f} mm/s")

    print("\n2.-4. ICR error |dy|/(T/2) per turn (R m, v m/s) -- time step, contact softness, rest margins, level chassis")
    variants = {
        "dt 5 ms, no margins": FixedStep(rest_margin=False, level_chassis=False),
        "dt 2.5 ms, no margins": FixedStep(rest_margin=False, level_chassis=False, timestep=0.0025),
        "dt 1.25 ms, no margins": FixedStep(rest_margin=False, level_chassis=False, timestep=0.00125),
        "dt 2.5 ms, contact+friction tc 10 ms, no margins": FixedStep(rest_margin=False, level_chassis=False, timestep=0.0025,
                                                                     contact_timeconst=0.01, friction_timeconst=0.01),
        "dt 2.5 ms, contact tc 10 ms, no margins": FixedStep(rest_margin=False, level_chassis=False, timestep=0.0025,
                                                             contact_timeconst=0.01),
        "dt 5 ms, margins, pitched chassis": FixedStep(level_chassis=False),
        "dt 2.5 ms, margins, pitched chassis": FixedStep(level_chassis=False, timestep=0.0025),
        "dt 1.25 ms, margins, pitched chassis": FixedStep(level_chassis=False, timestep=0.00125),
        "dt 5 ms, margins, level chassis (default)": FixedStep(),
        "dt 2.5 ms, margins, level chassis": FixedStep(timestep=0.0025),
    }
    doc["icr_errors"] = {}
    for name in ROBOTS:
        for label, cfg in variants.items():
            rows = icr_errors(name, cfg)
            doc["icr_errors"][f"{name} | {label}"] = rows
            print(f"   {name:13s} {label:50s} " + "  ".join(f"R{r['R']:g}/{r['v']:g}: {r['err_y']:.3f}" for r in rows))

    print("\n3./4. belt speed the ground sees minus the track-speed sensor, R 10 m at 0.2 m/s [mm/s]")
    doc["belt_offsets"] = {}
    for name in ROBOTS:
        for label, cfg in (("no margins, dt 5 ms", FixedStep(rest_margin=False, level_chassis=False)),
                           ("no margins, dt 2.5 ms", FixedStep(rest_margin=False, level_chassis=False, timestep=0.0025)),
                           ("margins, pitched, dt 5 ms", FixedStep(level_chassis=False)),
                           ("margins, level, dt 5 ms", FixedStep())):
            b = belt_offsets(name, cfg)
            doc["belt_offsets"][f"{name} | {label}"] = b
            print(f"   {name:13s} {label:22s} left {b['left']['belt_offset_mm_s']:+.3f}  right "
                  f"{b['right']['belt_offset_mm_s']:+.3f}; penetration (dist) left {b['left']['dist_um_min']:.1f}.."
                  f"{b['left']['dist_um_max']:.1f} um, right {b['right']['dist_um_min']:.1f}..{b['right']['dist_um_max']:.1f} um; "
                  f"roller speed spread {b['left']['roller_speed_spread_mm_s']:.2f} / {b['right']['roller_speed_spread_mm_s']:.2f} mm/s")
    doc["straight_speed_error"] = {"no margins": straight_speed_error(FixedStep(rest_margin=False, level_chassis=False)),
                                   "margins": straight_speed_error(FixedStep())}
    print(f"\n   straight line at 0.8 m/s, |v_x - V|/V: no margins {doc['straight_speed_error']['no margins']:.2e}, "
          f"margins {doc['straight_speed_error']['margins']:.2e}")
    print("\n5. x_c against Coulomb [mm] (80 kg, T 0.5 / L 1.0 m)")
    doc["x_c"] = xc = x_c_study()
    for row in xc["drive"]:
        print(f"   R 10 m, 0.2 m/s, cg {row['cg_frac']:+.1f} L, {row['drive']:28s} x_c {row['x_c_mm']:7.1f}  Coulomb "
              f"{row['ref_x_c_mm']:7.1f}  error {row['err_x']:.4f} L")
    for row in xc["time_step"]:
        print(f"   R 10 m, 2 m/s, cg 0, {row['case']:30s}: x_c - Coulomb {row['offset_mm']:+6.2f} mm; "
              f"v x (friction time constant)/2 = {row['v_tc_half_mm']:.1f} mm")
    doc["twist_against_poses"] = tp = twist_against_poses()
    print(f"\n6. steady turn at 2 m/s: lateral velocity of the log's twist {1000 * tp['vy_twist']:+.3f} mm/s, of its "
          f"poses {1000 * tp['vy_poses']:+.3f} mm/s (difference {1000 * (tp['vy_poses'] - tp['vy_twist']):+.3f}; "
          f"w dt v / 2 = {1000 * tp['half_w_dt_v']:.3f} mm/s)")
    print("\n7. drive: share of the commanded V_R - V_L delivered and x_c error, R 10 m at 0.2 m/s")
    doc["drive"] = dr = drive_study()
    for row in dr["turns"]:
        print(f"   {row['drive']:18s} {row['robot']:13s} cg {row['cg_frac']:+.1f} L: delivered {row['delivered']:.3f}, "
              f"x_c error {row['err_x']:.4f} L")
    print("   speed 3 s after a 0 -> 1 m/s step (default robot): " + ", ".join(f"{k} {v:.4f} m/s" for k, v in dr["step"].items()))
    print("\n8. what sets the step of a gentle turn (5 kg wide robot, cg -0.1 L, R 10 m, 0.2 m/s, belt on unless said)")
    doc["slip_budget"] = sb = slip_budget_study()
    for row in sb["time_constants"]:
        print(f"   {row['case']:32s} |dy| {row['err_y']:.4f} T/2, |dx_c| {row['err_x']:.4f} L")
    print("   dt-halving change |dy| against r = mu g dt / (|w| L/2) (4 robots x 3 gentle turns x cg +-0.1 L):")
    for lo, hi in ((0, 2.5), (2.5, 5.0), (5.0, 7.5), (7.5, 12.0), (12.0, 1e9)):
        sel = [x for x in sb["ratio"] if lo <= x["ratio"] < hi]
        if sel:
            print(f"     r in [{lo:g}, {hi:g}): {len(sel):2d} cases, worst dt-halving |dy| {max(x['dt_dy'] for x in sel):.4f} T/2, "
                  f"worst |dy| {max(x['err_y'] for x in sel):.4f} T/2")
    print("\n9. fast pivots and tight turns with the cg off-centre: chassis inertia and the reference's loads")
    doc["inertia_and_loads"] = il = inertia_and_loads()
    for row in il["pivots"]:
        print(f"   5 kg long, cg +0.1 L, pivot {row['v']:.1f} m/s (w {row['wz']:5.2f} rad/s), {row['chassis']:25s}: "
              f"|dy| {row['err_y']:.4f} T/2")
    for row in il["loads"]:
        print(f"   150 kg long, cg_y {row['cg_y']:.3f} m, cg_x -0.1 L, R 2 m at 2 m/s reversing: |dy| against the plate loads "
              f"{row['plate']['err_y']:.4f} T/2, against per-track Wong loads {row['per_track_wong']['err_y']:.4f} T/2")
    print(f"\nload average after: {os.getloadavg()}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(doc, indent=1) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
