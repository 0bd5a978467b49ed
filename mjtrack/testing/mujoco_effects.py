"""GENERATOR of MuJoCo drive logs with one hidden effect, for the diagnosis tests.

Kept apart from the diagnosis code on purpose: nothing here comes from ``mjtrack.diagnose``
(the diagnosis must not know which effect was injected, nor reuse the generator's transforms).
The ground truth is the MuJoCo tracked robot (``mjtrack.sim``): its contacts, suspension, drive
servos and inertia, not the Coulomb surrogate the diagnosis fits.

How each effect of docs/reference/formats/diagnosis-json.md is injected (``HIDDEN`` holds the injected values):

* ground effects change the simulated robot or its world:
  ``cg_offset_x`` / ``cg_offset_y``: Robot.cg_x / cg_y;  ``friction_scale`` k: Robot.mu = k mu;
  ``friction_asymmetry`` r: mu_left = r mu, mu_right = mu;  ``slope`` s with ``slope_direction``
  psi: the world is the inclined plane's own frame, so gravity gets an in-plane part pointing
  downhill, g = G (-sin s cos psi, -sin s sin psi, -cos s) (``model.opt.gravity``): the uphill
  unit vector is (cos psi, sin psi) in the world xy plane, the normal load is G cos s.
* ``ground_anisotropy`` rho (a ground beyond isotropic Coulomb): lateral friction rho mu, longitudinal
  mu, in each track's frame. Implemented HERE, not through ``mjtrack.sim.ground``: the robot's spec
  (builder without the ground hook) gets capsule rollers of half-length 2 mm whose axis is the spin
  axis (MuJoCo's capsule-plane contact frame follows the capsule axis) and pair friction
  (rho mu, mu) written by :func:`anisotropic_model`.
* input effects transform the per-step (dt = 5 ms) commands before the simulation, while the
  LOG keeps the commanded speeds (the measured track speeds, when logged, are the simulation's):
  ``track_speed_scale`` k: k V;  ``actuator_lag`` tau: y_{k+1} = y_k + (1 - exp(-dt/tau))(V_k - y_k),
  y_0 = 0 (exact for a command held over each step; the robot starts at rest);
  ``command_delay`` d: V shifted by round(d/dt) steps, zero before (at rest);
  ``speed_limit`` v: clip(V, -v, v).

Derivation and measurements: docs/theory/diagnosis.md, "Test logs with a hidden effect".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import G, Robot
from mjtrack.sim.builder import ROLLER_CHAIN, build_model, build_spec
from mjtrack.sim.chassis import add_scene
from mjtrack.sim.config import SimConfig
from mjtrack.sim.rollout import hold_commands, simulate

ROBOT = Robot()  # the nominal robot the diagnosis is given
LOG_DT = 0.05  # [s] 20 Hz log
VMAX = 0.8  # [m/s] largest commanded track speed
XY_STD, YAW_STD, SPEED_STD = 0.01, np.radians(0.3), 0.01
# Drives that follow their set-point (the nominal model's premise: track speed = command): the
# default 60 N m sprocket torque moves the 200 kg reflected drivetrain mass at only ~4.8 m/s^2,
# a ramp of 0.17 s per 0.8 m/s that the diagnosis rightly reads as an actuator defect
# (benchmarks/diagnose_mujoco_effects.py --default-drives); 600 N m gives ~48 m/s^2.
DRIVES = SimConfig(torque_limit=600.0)


@dataclass(frozen=True)
class Hidden:
    """One injected effect: its name in diagnosis.json, kind and parameter values."""

    name: str
    kind: str  # "ground" or "input"
    params: dict


HIDDEN: dict[str, Hidden] = {h.name: h for h in (
    Hidden("cg_offset_x", "ground", {"cg_offset_x": 0.05}),
    Hidden("cg_offset_y", "ground", {"cg_offset_y": -0.04}),
    Hidden("friction_scale", "ground", {"friction_scale": 0.5}),
    Hidden("friction_asymmetry", "ground", {"friction_asymmetry": 0.6}),
    Hidden("slope", "ground", {"slope": np.radians(8.0), "slope_direction": 0.8}),
    Hidden("track_speed_scale", "input", {"track_speed_scale": 0.85}),
    Hidden("actuator_lag", "input", {"actuator_lag": 0.3}),
    Hidden("command_delay", "input", {"command_delay": 0.2}),
    Hidden("speed_limit", "input", {"speed_limit": 0.4}),
    Hidden("ground_anisotropy", "model", {"lateral_ratio": 0.5}),
)}


def commands(rng: np.random.Generator, duration: float, dt: float = LOG_DT):
    """Held random track-speed commands (t, v_left, v_right), (n,) each, n = round(duration/dt).

    Each step lasts U(1.5, 3) s: 20 % straight, else a turn V_inner = k V_outer with k ~ U(-1, 0.9)
    (k = -1 a spin), the outer track left or right at random; |V_outer| ~ U(0.2, 0.8) m/s,
    backwards one time in four.
    """
    n = int(round(duration / dt))
    t = np.arange(n) * dt
    vl, vr = np.empty(n), np.empty(n)
    k = 0
    while k < n:
        m = int(round(rng.uniform(1.5, 3.0) / dt))
        v = rng.uniform(0.2, VMAX) * (-1.0 if rng.random() < 0.25 else 1.0)
        a, b = (v, v) if rng.random() < 0.2 else (v, v * rng.uniform(-1.0, 0.9))
        if rng.random() < 0.5:
            a, b = b, a
        vl[k:k + m], vr[k:k + m] = a, b
        k += m
    return t, vl, vr


def apply_input(steps: np.ndarray, hidden: Hidden | None, dt: float) -> np.ndarray:
    """The track-speed set-points (nstep, 2) [m/s] that the drives receive for per-step commands
    ``steps`` (nstep, 2) under an input effect (module docstring); unchanged otherwise."""
    if hidden is None or hidden.kind != "input":
        return steps
    p = hidden.params
    if hidden.name == "track_speed_scale":
        return p["track_speed_scale"] * steps
    if hidden.name == "speed_limit":
        return np.clip(steps, -p["speed_limit"], p["speed_limit"])
    if hidden.name == "command_delay":
        shift = int(round(p["command_delay"] / dt))
        return np.concatenate([np.zeros((shift, 2)), steps[: steps.shape[0] - shift]])
    if hidden.name == "actuator_lag":
        a = -np.expm1(-dt / p["actuator_lag"])
        y = np.zeros_like(steps)
        for k in range(1, steps.shape[0]):
            y[k] = y[k - 1] + a * (steps[k - 1] - y[k - 1])
        return y
    raise ValueError(f"unknown input effect {hidden.name}")


def robot_with(hidden: Hidden | None, robot: Robot = ROBOT) -> Robot:
    """The simulated robot: the nominal one with a ground effect's description change."""
    if hidden is None:
        return robot
    p = hidden.params
    if hidden.name == "cg_offset_x":
        return robot.replace(cg_x=p["cg_offset_x"])
    if hidden.name == "cg_offset_y":
        return robot.replace(cg_y=p["cg_offset_y"])
    if hidden.name == "friction_scale":
        return robot.replace(mu=robot.mu * p["friction_scale"])
    if hidden.name == "friction_asymmetry":
        return robot.replace(mu_left=robot.mu * p["friction_asymmetry"], mu_right=robot.mu)
    return robot


def slope_gravity(slope: float, direction: float) -> np.ndarray:
    """Gravity (3,) [m/s^2] in the frame of a plane inclined by ``slope`` [rad], uphill towards
    the world direction ``direction`` [rad]."""
    s = np.sin(slope)
    return G * np.array([-s * np.cos(direction), -s * np.sin(direction), -np.cos(slope)])


def anisotropic_model(robot: Robot, config: SimConfig, lateral_ratio: float):
    """The MuJoCo robot on a ground with lateral friction ``lateral_ratio`` x mu (own implementation)."""
    import mujoco

    spec = add_scene(build_spec(robot, config), robot, config, tracks=ROLLER_CHAIN)
    for geom in spec.geoms:
        if geom.name.startswith("roller_"):
            geom.type = mujoco.mjtGeom.mjGEOM_CAPSULE
            geom.size = [config.roller_radius, 0.002, 0.0]
            geom.quat = [np.sqrt(0.5), -np.sqrt(0.5), 0.0, 0.0]  # capsule axis along the spin axis (y)
    for pair in spec.pairs:
        mu = pair.friction[1]
        pair.friction = [lateral_ratio * mu, mu, 0.0, 0.0, 0.0]
    return spec.compile()


def make_log(effect: str | None, *, seed: int = 0, duration: float = 120.0, speeds: bool = False,
             config: SimConfig | None = None) -> tuple[DriveLog, Robot]:
    """A MuJoCo log with ``effect`` hidden (None = clean); returns (log, nominal robot).

    ``duration`` [s] of driving at 20 Hz; ``speeds``: log the simulated track speeds (noisy);
    ``config``: the simulation settings (default :data:`DRIVES`).
    """
    hidden = HIDDEN[effect] if effect is not None else None
    rng = np.random.default_rng(seed)
    config = config or DRIVES
    t, vl, vr = commands(rng, duration)
    steps = hold_commands(t, vl, vr, timestep=config.timestep, duration=t[-1] + LOG_DT)
    drive = apply_input(steps, hidden, config.timestep)
    robot = robot_with(hidden, ROBOT)
    if hidden is not None and hidden.kind == "model":
        model = anisotropic_model(robot, config, hidden.params["lateral_ratio"])
    else:
        model = build_model(robot, config)
    if hidden is not None and hidden.name == "slope":
        model.opt.gravity[:] = slope_gravity(hidden.params["slope"], hidden.params["slope_direction"])
    out = simulate(robot, drive, config=config, log_rate=1.0 / LOG_DT, model=model)
    n = t.size
    noise = rng.normal(0.0, 1.0, (n, 3)) * [XY_STD, XY_STD, YAW_STD]
    cols = {"t": t, "v_left_cmd": vl, "v_right_cmd": vr, "x": out["x"][:n] + noise[:, 0],
            "y": out["y"][:n] + noise[:, 1], "yaw": out["yaw"][:n] + noise[:, 2]}
    if speeds:
        cols["v_left"] = out["v_left"][:n] + rng.normal(0.0, SPEED_STD, n)
        cols["v_right"] = out["v_right"][:n] + rng.normal(0.0, SPEED_STD, n)
    tag = effect or "clean"
    return DriveLog.from_columns(cols, source=f"mujoco-{tag}-{'speeds' if speeds else 'pose'}-{seed}.csv"), ROBOT
