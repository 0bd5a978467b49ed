"""Tracking runs of the slip-compensated controllers: on the MuJoCo robot and on the kinematic
model, with the path references of the tracking scenarios and their cross-track metrics.

The compensation itself (the inverse ICR map, the VIR heading correction, the trust weight) is
:mod:`mjtrack.control.compensation`; this module drives it along a reference and scores the run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mjtrack.control.compensation import (COMPENSABLE, CONTROLLERS, REFERENCE_MAPS, CoulombICRMap,
                                          CorrectedReference, SlipCompensation)
from mjtrack.control.feedforward import Reference
from mjtrack.errors import InputError

TRACK_SCENARIOS: dict[str, dict] = {
    "figure_eight": {"path": "figure_eight", "size": 1.5, "laps": 2.0, "speed": 0.5,
                     "text": "lemniscate of Gerono, A = 1.5 m (tip radius 1.5 m), 2 laps at 0.5 m/s"},
    "circle": {"path": "circle", "size": 1.0, "laps": 1.5, "speed": 0.5,
               "text": "circle of radius 1 m, 1.5 turns CCW at 0.5 m/s"},
    "lane_change": {"path": "lane_change", "size": 1.0, "laps": 1.0, "speed": 0.5,
                    "text": "1.5 m straight, 1 m shift to the left over 3 m (continuous curvature, peak 0.62 1/m), "
                            "1.5 m straight, at 0.5 m/s"},
}


def scenario_reference(name: str, *, speed: float | None = None, laps: float | None = None) -> Reference:
    """The :class:`Reference` of a tracking scenario (:data:`TRACK_SCENARIOS`)."""
    from mjtrack.control.feedforward import ConstantSpeedProfile
    from mjtrack.control.paths import circle_path, figure_eight_path, lane_change_path

    if name not in TRACK_SCENARIOS:
        raise InputError(f"unknown tracking scenario {name!r}; choose one of {', '.join(TRACK_SCENARIOS)}")
    sc = TRACK_SCENARIOS[name]
    laps = sc["laps"] if laps is None else float(laps)
    speed = sc["speed"] if speed is None else float(speed)
    if not (laps > 0 and speed > 0):
        raise InputError(f"tracking scenario: laps and speed must be positive, got {laps}, {speed}")
    if sc["path"] == "figure_eight":
        path = figure_eight_path(size=sc["size"], laps=laps)
    elif sc["path"] == "lane_change":  # laps scale the manoeuvre's length (a longer, gentler shift)
        path = lane_change_path(shift=sc["size"], length=3.0 * laps)
    else:
        path = circle_path(radius=sc["size"], turns=laps)
    return Reference(path, ConstantSpeedProfile(path.length, speed))


def cross_track_errors(reference: Reference, positions: np.ndarray, *, t=None, progress: bool = False,
                       window_m: float = 1.5, spacing_m: float = 1e-3) -> np.ndarray:
    """(N,) distance [m] of each position (N, 2+) to the reference path.

    The path is sampled every ``spacing_m`` of arc length (distance error <= spacing²/(8 R)) and
    continued along its end tangents for ``window_m`` beyond both ends.
    Without ``t`` or ``progress``: the nearest point of the whole path. With ``t`` (N,) [s]: the
    nearest point whose arc length is within ``window_m`` of the reference's s(t) — on a
    self-crossing path (figure-eight) the other branch near the crossing is then not mistaken for
    the path being followed (it would make the error drop to 0 there). With ``progress``: the
    same, within ``window_m`` of the robot's own progress, the arc length of the previous
    position's nearest point (from the path's start), for a controller without a clock (a line
    follower falls behind the reference's s(t)); the positions must be consecutive samples.
    """
    from scipy.spatial import cKDTree

    if progress and t is not None:
        raise InputError("cross_track_errors: give t or progress, not both")
    path = reference.path
    s = np.linspace(0.0, path.length, max(2, int(math.ceil(path.length / spacing_m)) + 1))
    pts = path.point(path.u_at(s))
    # Both ends continue along their tangents for window_m: a robot a little past the end of an
    # open path (or short of its start) is measured sideways, not by its along-track distance
    # to the end point.
    ext = np.arange(1, int(math.ceil(window_m / spacing_m)) + 1) * spacing_m
    h0, h1 = float(path.heading(path.u_start)), float(path.heading(path.u_end))
    pre = pts[0] - ext[::-1, None] * np.array([math.cos(h0), math.sin(h0)])
    post = pts[-1] + ext[:, None] * np.array([math.cos(h1), math.sin(h1)])
    pts = np.concatenate([pre, pts, post])
    s = np.concatenate([-ext[::-1], s, path.length + ext])
    xy = np.asarray(positions, float)[:, :2]
    if t is None and not progress:
        return cKDTree(pts).query(xy)[0]
    s_ref = None if progress else np.array([reference.profile.distance(float(tk)) for tk in np.asarray(t, float)])
    out = np.empty(len(xy))
    at = 0.0
    for k in range(len(xy)):
        centre = at if progress else s_ref[k]
        lo, hi = np.searchsorted(s, centre - window_m), np.searchsorted(s, centre + window_m, side="right")
        d = pts[lo:hi] - xy[k]
        d2 = np.einsum("ij,ij->i", d, d)
        j = int(np.argmin(d2))
        out[k] = math.sqrt(d2[j])
        at = float(s[lo + j])
    return out


def tracking_metrics(reference: Reference, t: np.ndarray, poses: np.ndarray, *, clocked: bool = True) -> dict:
    """rms_cross_track_m, max_cross_track_m (:func:`cross_track_errors` near the reference's s(t),
    or near the robot's own progress when not ``clocked``) and final_pos_err_m (distance to the
    reference's end position at the last sample) of a run: times t (N,) [s], poses (N, 3)."""
    ct = cross_track_errors(reference, poses, t=t) if clocked else cross_track_errors(reference, poses, progress=True)
    end = reference.at(reference.duration).pose
    return {"rms_cross_track_m": float(np.sqrt(np.mean(ct**2))), "max_cross_track_m": float(np.max(ct)),
            "final_pos_err_m": float(math.hypot(poses[-1, 0] - end[0], poses[-1, 1] - end[1]))}


@dataclass(frozen=True, eq=False)
class TrackingResult:
    """A tracking run: the loop's samples, the reference, metrics and the ICR estimates.

    ``metrics``: rms_cross_track_m, max_cross_track_m (over the whole run; distance to the path
    near the reference's current arc length, :func:`cross_track_errors`), final_pos_err_m
    (distance to the reference position at the end). ``icr_history``: (M, 4) rows
    (t, y_l, y_r, x_c) of the online estimate (empty for mode "none").
    """

    loop: object
    reference: Reference
    metrics: dict
    icr_history: np.ndarray
    settings: dict
    applied_icr_history: np.ndarray | None = None


def run_tracking(
    robot,
    *,
    scenario: str = "figure_eight",
    compensation: str = "icr",
    controller: str = "tracker",
    poles=(-1.0, -2.0, -4.0),
    control_dt: float = 0.04,
    speed: float | None = None,
    laps: float | None = None,
    pose_noise=(0.01, 0.01, 0.01),
    twist_noise=(0.02, 0.02, 0.02),
    track_speed_noise: float = 0.01,
    seed: int = 0,
    config=None,
    compensation_options: dict | None = None,
    terrain=None,
    reference_map: str = "nominal",
    map_robot=None,
    controller_options: dict | None = None,
) -> TrackingResult:
    """Track a scenario's reference with the MuJoCo robot (:mod:`mjtrack.control.mujoco_plant`).

    Args:
        robot: :class:`~mjtrack.io.robot.Robot`.
        compensation: "none", "icr" or "vir" (module docstring); the controller and its gains
            are the same for all three. Only controllers with a feed-forward from the reference
            ("tracker", "feedforward", "pole_placement") can be compensated.
        controller: "tracker" (feed-forward + pole-placement feedback, (3.11)-(3.21), ``poles``)
            or one of the thesis's five (:data:`~mjtrack.control.path_controllers.THESIS_CONTROLLERS`,
            set up by :func:`~mjtrack.control.path_controllers.path_controller`; "pole_placement"
            is the same law as "tracker", "feedforward" the open loop: the reference's (v_d, w_d)).
        control_dt: control period [s]; pose_noise / twist_noise: seeded measurement noise std
            seen by the controller and the estimator.
        terrain: :class:`~mjtrack.sim.terrain.Terrain` under the robot (default flat); the
            reference path is followed in the horizontal plane.
        reference_map: "nominal" (the compensation starts from the nominal ICRs) or "coulomb"
            (from the Coulomb reference's steady ICRs of the description, :class:`CoulombICRMap`).
        map_robot: the description the "coulomb" map is computed from (default ``robot``; another
            one to study a mis-described robot).
        controller_options: set-up constants of a thesis controller that differ from the defaults
            (``options`` of :func:`~mjtrack.control.path_controllers.path_controller`).
    Returns:
        :class:`TrackingResult`.
    """
    from mjtrack.control.mujoco_plant import check_loop, run_mujoco_loop
    from mjtrack.control.path_controllers import path_controller

    if controller not in CONTROLLERS:
        raise InputError(f"controller must be one of {', '.join(CONTROLLERS)}, got {controller!r}")
    if compensation != "none" and controller not in COMPENSABLE:
        raise InputError(f"controller {controller!r} has no feed-forward from the reference to compensate; "
                         f"compensation must be 'none' (got {compensation!r})")
    if reference_map not in REFERENCE_MAPS:
        raise InputError(f"reference_map must be one of {', '.join(REFERENCE_MAPS)}, got {reference_map!r}")
    if reference_map == "coulomb" and terrain is not None and not terrain.is_flat:
        raise InputError("reference_map 'coulomb' is the steady state on flat ground; it does not model "
                         f"terrain {terrain.spec!r}")
    reference = scenario_reference(scenario, speed=speed, laps=laps)
    check_loop(reference.duration, control_dt, config=config, terrain=terrain,
               what=f"the reference ({reference.path.length:.4g} m at {reference.profile.speed_value:g} m/s)")
    ref_map = CoulombICRMap(map_robot or robot) if reference_map == "coulomb" else None  # unused by "none"
    comp = SlipCompensation(robot.track_gauge, compensation, track_length=robot.contact_length, poles=poles,
                            reference_map=ref_map, **(compensation_options or {}))
    ref = CorrectedReference(reference, comp)
    setup = path_controller("pole_placement" if controller == "tracker" else controller,
                            ref if controller in COMPENSABLE else reference, poles=poles, options=controller_options)
    ctrl = setup.controller
    ctrl.reset()

    def policy(t, pose, twist, u_prev, track_speed):
        comp.observe(t, u_prev, pose, twist, track_speed)
        v, w = ctrl.command(t, comp.control_pose(pose), twist)
        r = ref.at(t)
        return comp.track_speeds(v, w, feedforward=(r.v, r.w))

    duration = reference.duration
    loop = run_mujoco_loop(robot, policy, duration, control_dt=control_dt, pose0=reference.start_pose(), config=config,
                           pose_noise=tuple(pose_noise), twist_noise=tuple(twist_noise),
                           track_speed_noise=track_speed_noise, seed=seed, terrain=terrain)
    metrics = tracking_metrics(reference, loop.t, loop.poses, clocked=setup.clocked)
    if comp.weight_history:
        metrics["mean_trust_weight"] = float(np.mean([wgt for _, wgt in comp.weight_history]))
    hist = np.array(comp.history, float).reshape(-1, 4)
    applied = np.array(comp.applied_history, float).reshape(-1, 4)
    settings = {"scenario": scenario, "compensation": compensation, "controller": controller,
                "poles": [float(p) for p in poles], "control_dt": control_dt, "duration_s": duration,
                "speed_m_s": reference.profile.speed_value, "path_length_m": reference.path.length,
                "pose_noise": list(pose_noise), "twist_noise": list(twist_noise),
                "track_speed_noise": track_speed_noise, "seed": seed, "compensation_options": dict(compensation_options or {}),
                "reference_map": reference_map if compensation != "none" else "nominal",
                "controller_settings": setup.settings,
                "cross_track_near": "reference s(t)" if setup.clocked else "own progress",
                "terrain": "flat" if terrain is None or terrain.is_flat else terrain.spec}
    return TrackingResult(loop, reference, metrics, hist, settings, applied)


def run_kinematic_tracking(
    robot,
    *,
    scenario: str = "figure_eight",
    controller: str = "pole_placement",
    poles=(-1.0, -2.0, -4.0),
    control_dt: float = 0.04,
    speed: float | None = None,
    laps: float | None = None,
    controller_options: dict | None = None,
) -> TrackingResult:
    """A thesis controller on the robot's no-slip kinematic model, for comparison with
    :func:`run_tracking` on the MuJoCo robot: the same reference, start pose, controller set-up,
    control period (zero-order hold) and cross-track error; exact measurements.

    The model: a wheeled robot's is the thesis's differential drive (1.1)-(1.4) with its gauge and
    wheel radius (:class:`~mjtrack.models.wheeled.DiffDriveKinematic`, wheel-speed adapter), a
    tracked robot's the nominal model (2.1) (:class:`~mjtrack.control.tracked.TrackedKinematic`,
    track-speed adapter); both move as a unicycle.

    Args:
        robot: :class:`~mjtrack.io.robot.Robot`.
        controller: one of :data:`~mjtrack.control.path_controllers.THESIS_CONTROLLERS` or "tracker".
        controller_options: as :func:`run_tracking`.
    Returns:
        :class:`TrackingResult` whose ``loop`` is a :class:`~mjtrack.control.interface.ClosedLoopResult`.
    """
    from mjtrack.control.interface import Plant, run_closed_loop
    from mjtrack.control.path_controllers import path_controller
    from mjtrack.control.tracked import TrackedKinematic
    from mjtrack.models.kinematic import Nominal
    from mjtrack.models.wheeled import DiffDriveKinematic

    if controller not in CONTROLLERS:
        raise InputError(f"controller must be one of {', '.join(CONTROLLERS)}, got {controller!r}")
    if not control_dt > 0:
        raise InputError(f"control_dt must be positive, got {control_dt!r}")
    reference = scenario_reference(scenario, speed=speed, laps=laps)
    setup = path_controller("pole_placement" if controller == "tracker" else controller, reference, poles=poles,
                            options=controller_options)
    if robot.traction == "wheels":
        model = DiffDriveKinematic(track=robot.track_gauge, wheel_radius=robot.sprocket_radius)
    else:
        model = TrackedKinematic(Nominal(robot.track_gauge), robot.track_gauge)
    loop = run_closed_loop(Plant.of(model), setup.controller, reference.duration, control_dt,
                           pose0=reference.start_pose())
    settings = {"scenario": scenario, "controller": controller, "plant": type(model).__name__,
                "control_dt": control_dt, "duration_s": reference.duration, "speed_m_s": reference.profile.speed_value,
                "path_length_m": reference.path.length, "controller_settings": setup.settings,
                "cross_track_near": "reference s(t)" if setup.clocked else "own progress"}
    return TrackingResult(loop, reference, tracking_metrics(reference, loop.t, loop.poses, clocked=setup.clocked),
                          np.zeros((0, 4)), settings)
