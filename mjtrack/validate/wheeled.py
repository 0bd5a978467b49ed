"""The wheeled-robot thesis's four models scored on a wheeled robot's log.

On a robot with ``traction: "wheels"`` :func:`mjtrack.validate.validate` also scores the
models of :mod:`mjtrack.models.wheeled` by their prediction error against the horizon, on the
log (the MuJoCo rollout or measured log; not on the MPP analytic truth, which is a tracked
kinematic model's motion):

| key | model | input (held over each sample interval) |
|---|---|---|
| ``kinematic`` | differential drive (1.1)-(1.4) | wheel speeds: the validation's track speeds / r |
| ``dynamic1`` | dynamic model 1 (1.5)-(1.8): inertia, no slip | requested wheel speeds: commanded speeds / r |
| ``dynamic2`` | dynamic model 2 (1.9)-(1.15): wheel spin, slip | requested wheel speeds: commanded speeds / r |
| ``skidsteer4`` | four-wheel skid steer (1.16)-(1.20) | imposed wheel speeds: the validation's track speeds / r |

"The validation's track speeds" are those that drive the kinematic slip models (measured when
the log has them, ``--speeds``); dynamic models 1 and 2 contain their own wheel-speed
regulator, so they get what the drives were asked for, the logged commands.

Windows: the starts and ends of :func:`mjtrack.validate.horizon.window_ends` (the first sample
at or after t_s + h in the same segment), every ``stride``-th sample with at most
``max_starts`` starts (the models are integrated one window at a time by their own RK4 step,
:func:`mjtrack.models.wheeled.base.rk4_step`, so they cost far more than the kinematic slip
models). Each window starts from the logged state at t_s: the pose, the body twist (dynamic 1
keeps v_x and ω, its wheels cannot skid), and for dynamic 2 the wheels' speeds; it integrates
up to the longest horizon, with the log's input of sample k held over [t_k, t_{k+1}), split
into equal RK4 steps no longer than the model's ``max_stable_dt``.

Reference point: the log's pose is the robot's geometric centre. The two-wheel models put
their axle through it (the centre of gravity on the axle); the four-wheel model's reference is
its centre of gravity, cg_x ahead of the centre (p = 1/2 - cg_x/B), so its state starts from
the centre's pose and twist moved to the COG and its prediction is moved back
(:meth:`~mjtrack.models.wheeled.skidsteer4.SkidSteer4.geometric_centre_pose`).

Parameters (:func:`wheeled_predictors`; each model's ``parameters`` and ``assumed`` in the
metrics): from the robot description the gauge T (the models' track b), the wheelbase B
(four-wheel a), the wheel radius r, the mass M, the friction μ (mean of the two sides), cg_x.
Not in the description, and stated:

* yaw inertia J = M (B² + T²)/12 (a uniform plate on the footprint, the package's default);
* the drive (dynamic 1: F_max, K; dynamic 2: T_max, K_T, J_w): the simulator's drive of the
  robot (:func:`mjtrack.sim.drivetrain.drive_of`: the description's ``drive_force_limit`` or the
  mass-scaled default, servo gain kv, reflected drivetrain mass m_t per side):
  F_max = force limit, K = kv r, T_max = F_max r, K_T = kv r², J_w = m_t r²;
* the friction characteristic's slope C (dynamic 2, skid steer): C = μ W / ε, W the mean wheel
  load, ε the slip speed at which the friction saturates, taken from the thesis's four-wheel
  robot (μ W / C of its section 1.2, :data:`SLIP_SPEED`);
* skid steer: load distribution ``static`` (by cg_x); cg_y is not modelled (COG on the centre
  line); a robot with more than two wheels a side is taken as its outer axles.

Scores per model and horizon: median and worst (maximum) over the windows of the position
error [m] and of the absolute heading error [deg], with their RMS and the number of windows;
``best``: per horizon the model with the lowest median position error and the one with the
lowest median heading error.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from mjtrack.geometry import wrap_angle
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import G, Robot
from mjtrack.metrics import HorizonErrors
from mjtrack.models.wheeled import DiffDriveDynamic1, DiffDriveDynamic2, DiffDriveKinematic, SkidSteer4, rk4_step
from mjtrack.sim.config import SimConfig
from mjtrack.sim.drivetrain import drive_of
from mjtrack.validate.horizon import window_ends
from mjtrack.validate.truth import Case

log = logging.getLogger(__name__)

_THESIS_SKID = SkidSteer4()
SLIP_SPEED = _THESIS_SKID.mu * _THESIS_SKID.wheel_load / _THESIS_SKID.stiffness  # ε [m/s] of the thesis's robot
MAX_STARTS = 40  # windows per horizon at most (every stride-th sample)
KEYS = ("kinematic", "dynamic1", "dynamic2", "skidsteer4")


@dataclass(frozen=True, eq=False)
class WheeledPredictor:
    """One thesis model with its parameters and the way it meets the log.

    ``state0(pose, twist, wheel)``: the model's state from the logged pose (x, y, yaw) of the
    centre, body twist (vx, vy, wz) and wheel speeds (ω_L, ω_R) [rad/s]; ``centre(state)``: the
    predicted pose of the centre; ``commanded``: whether the input is the commanded speeds.
    """

    key: str
    label: str
    model: object
    commanded: bool
    input_text: str
    parameters: dict
    assumed: dict
    state0: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]
    centre: Callable[[np.ndarray], np.ndarray]

    @property
    def max_dt(self) -> float:
        """Longest RK4 step [s] (the model's stability limit; infinite for the kinematic model)."""
        return float(getattr(self.model, "max_stable_dt", math.inf))


def _world(pose, twist) -> tuple[float, float]:
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return c * twist[0] - s * twist[1], s * twist[0] + c * twist[1]


def wheeled_predictors(robot: Robot, config: SimConfig | None = None) -> list[WheeledPredictor]:
    """The four models of the module table with the parameters of ``robot`` (module docstring)."""
    T, B, r, M = robot.track_gauge, float(robot.contact_length), robot.wheel_radius, robot.mass
    mu = 0.5 * (robot.friction_left + robot.friction_right)
    J = M * (B**2 + T**2) / 12
    drive = drive_of(robot, config or SimConfig())
    f_max, kv, m_t = drive.force_limit, drive.kv, drive.track_mass
    drive_src = ("the description's drive_force_limit" if robot.drive_force_limit is not None
                 else "the simulator's mass-scaled default drive")
    j_why = "not in the description: M (B² + T²)/12, a uniform plate on the footprint"
    c_why = (f"not in the description: μ W / ε with ε = {SLIP_SPEED:.4g} m/s, the thesis's four-wheel robot's "
             "slip speed at which friction saturates (μ W / C of its section 1.2)")
    w2, w4 = M * G / 2, M * G / 4
    kin = DiffDriveKinematic(track=T, wheel_radius=r)
    d1 = DiffDriveDynamic1(track=T, wheel_radius=r, mass=M, inertia=J, force_max=f_max, gain=kv * r)
    d2 = DiffDriveDynamic2(track=T, wheel_radius=r, mass=M, inertia=J, wheel_inertia=m_t * r**2,
                           torque_max=f_max * r, torque_gain=kv * r**2, stiffness=mu * w2 / SLIP_SPEED, mu=mu,
                           wheel_load=w2)
    p = 0.5 - robot.cg_x / B
    ss = SkidSteer4(wheelbase=B, track=T, cg_ratio=p, wheel_radius=r, mass=M, inertia=J,
                    stiffness=mu * w4 / SLIP_SPEED, mu=mu, wheel_load=w4, load_distribution="static")
    cg = robot.cg_x

    def d2_state(pose, twist, wheel):
        return np.array([*pose, *_world(pose, twist), twist[2], *wheel], dtype=float)

    def ss_state(pose, twist, wheel):
        c, s = math.cos(pose[2]), math.sin(pose[2])
        v = (twist[0], twist[1] + twist[2] * cg)  # the COG's body velocity, cg_x ahead of the centre
        return np.array([pose[0] + cg * c, pose[1] + cg * s, pose[2], *_world(pose, v), twist[2]], dtype=float)

    drive_assumed = {k: f"not in the description: from {drive_src} (kv = {kv:.4g} N s/m, m_t = {m_t:.4g} kg per side)"
                     for k in ("force_max", "gain", "torque_max", "torque_gain", "wheel_inertia")}
    return [
        WheeledPredictor("kinematic", "kinematic differential drive (1.1)-(1.4)", kin, False,
                         "wheel speeds = the validation's track speeds / r",
                         {"track": T, "wheel_radius": r}, {},
                         lambda pose, twist, wheel: np.asarray(pose, float).copy(), lambda x: x[:3]),
        WheeledPredictor("dynamic1", "dynamic model 1 (1.5)-(1.8)", d1, True,
                         "requested wheel speeds = commanded speeds / r",
                         {"track": T, "wheel_radius": r, "mass": M, "inertia": J, "force_max": f_max, "gain": kv * r},
                         {"inertia": j_why, "force_max": drive_assumed["force_max"], "gain": drive_assumed["gain"]},
                         lambda pose, twist, wheel: np.array([*pose, twist[0], twist[2]], dtype=float),
                         lambda x: x[:3]),
        WheeledPredictor("dynamic2", "dynamic model 2 (1.9)-(1.15)", d2, True,
                         "requested wheel speeds = commanded speeds / r",
                         {"track": T, "wheel_radius": r, "mass": M, "inertia": J, "wheel_inertia": d2.wheel_inertia,
                          "torque_max": d2.torque_max, "torque_gain": d2.torque_gain, "stiffness": d2.stiffness,
                          "mu": mu, "wheel_load": w2},
                         {"inertia": j_why, "stiffness": c_why,
                          **{k: drive_assumed[k] for k in ("wheel_inertia", "torque_max", "torque_gain")}},
                         d2_state, lambda x: x[:3]),
        WheeledPredictor("skidsteer4", "four-wheel skid steer (1.16)-(1.20)", ss, False,
                         "imposed wheel speeds = the validation's track speeds / r",
                         {"wheelbase": B, "track": T, "cg_ratio": p, "wheel_radius": r, "mass": M, "inertia": J,
                          "stiffness": ss.stiffness, "mu": mu, "wheel_load": w4, "load_distribution": "static"},
                         {"inertia": j_why, "stiffness": c_why,
                          "cg_ratio": "from cg_x; cg_y not modelled (COG on the centre line)",
                          **({"wheelbase": f"{robot.wheels_per_side} wheels a side taken as the outer two axles"}
                             if robot.wheels_per_side > 2 else {})},
                         ss_state, ss.geometric_centre_pose),
    ]


@dataclass(frozen=True, eq=False)
class WheeledResult:
    """Per model key: horizon [s] -> :class:`~mjtrack.metrics.HorizonErrors`; ``metrics``: the JSON entry."""

    predictors: list[WheeledPredictor]
    errors: dict[str, dict[float, HorizonErrors]]
    metrics: dict = field(default_factory=dict)


def _predict(pred: WheeledPredictor, case: Case, u: np.ndarray, wheel: np.ndarray, s: int,
             ends: list[int]) -> dict[int, np.ndarray]:
    """Poses of the centre at the sample indices ``ends`` of one window starting at sample ``s``."""
    x = pred.state0(case.pose[s], case.twist[s], wheel[s])
    out = {}
    last = max(ends)
    for k in range(s, last):
        dt = float(case.t[k + 1] - case.t[k])
        n = max(1, math.ceil(dt / pred.max_dt - 1e-9))
        for _ in range(n):
            x = rk4_step(pred.model, x, u[k], dt / n)
        if not np.all(np.isfinite(x)):
            break
        if k + 1 in ends:
            out[k + 1] = pred.centre(x)
    return out


def _summary(e: HorizonErrors) -> dict:
    pos, yaw = e.pos_err, np.degrees(np.abs(e.yaw_err))
    if not pos.size:
        return {"pos_median_m": None, "pos_max_m": None, "yaw_median_deg": None, "yaw_max_deg": None,
                "pos_rmse_m": None, "yaw_rmse_deg": None, "n": 0}
    return {"pos_median_m": float(np.median(pos)), "pos_max_m": float(np.max(pos)),
            "yaw_median_deg": float(np.median(yaw)), "yaw_max_deg": float(np.max(yaw)),
            "pos_rmse_m": e.pos_rmse, "yaw_rmse_deg": math.degrees(e.yaw_rmse), "n": int(pos.size)}


def evaluate_wheeled(case: Case, drive: DriveLog, robot: Robot, *, horizons, max_starts: int = MAX_STARTS,
                     config: SimConfig | None = None) -> WheeledResult:
    """Score the four models on ``case`` (the log's case; ``drive`` its log, for the commands).

    A window whose prediction diverges (a non-finite state) scores infinite errors, reported as
    null in JSON and counted in ``diverged``.
    """
    preds = wheeled_predictors(robot, config)
    r = robot.wheel_radius
    measured = np.column_stack([case.v_left, case.v_right]) / r
    commanded = np.column_stack([drive.v_left_cmd, drive.v_right_cmd]).astype(float) / r
    horizons = tuple(sorted(float(h) for h in horizons))
    stride = max(1, int(np.ceil(case.t.size / max_starts)))
    starts = np.arange(0, case.t.size, stride)
    windows = {h: window_ends(case, h, starts) for h in horizons}
    ends_of: dict[int, list[int]] = {}
    for h, (ss, ee) in windows.items():
        for s, e in zip(ss.tolist(), ee.tolist()):
            ends_of.setdefault(s, []).append(e)
    errors, table = {}, {}
    for pred in preds:
        u = commanded if pred.commanded else measured
        poses = {s: _predict(pred, case, u, measured, s, ends) for s, ends in ends_of.items()}
        errors[pred.key] = {}
        diverged = 0
        for h, (ss, ee) in windows.items():
            pred_pose = np.array([poses[s].get(e, np.full(3, np.nan)) for s, e in zip(ss, ee)]).reshape(-1, 3)
            bad = ~np.all(np.isfinite(pred_pose), axis=1)
            diverged = max(diverged, int(bad.sum()))
            meas = case.pose[ee]
            pos = np.where(bad, np.inf, np.hypot(*(pred_pose[:, :2] - meas[:, :2]).T))
            yaw = np.where(bad, np.inf, wrap_angle(np.where(bad, 0.0, pred_pose[:, 2] - meas[:, 2])))
            errors[pred.key][h] = HorizonErrors(h, ss, ee, pos, yaw, pred_pose)
        table[pred.key] = {
            "label": pred.label, "input": pred.input_text, "parameters": pred.parameters, "assumed": pred.assumed,
            "rk4_step_max_s": pred.max_dt if math.isfinite(pred.max_dt) else None, "diverged_windows": diverged,
            "horizons": {f"{h:g}": _summary(e) for h, e in errors[pred.key].items()}}
        log.info("wheeled model %s scored", pred.key)
    best = {}
    for h in horizons:
        row = {k: table[k]["horizons"][f"{h:g}"] for k in table}
        pick = lambda f: min((k for k in row if row[k][f] is not None), key=lambda k: row[k][f], default=None)  # noqa: E731
        best[f"{h:g}"] = {"position": pick("pos_median_m"), "heading": pick("yaw_median_deg"),
                          "position_worst": pick("pos_max_m")}
    metrics = {"reference_point": "the robot's geometric centre (the log's pose)", "starts_stride": stride,
               "slip_speed_m_s": SLIP_SPEED, "models": table, "best": best}
    return WheeledResult(preds, errors, metrics)
