"""Slip-compensated trajectory tracking of the tracked robot (issue 7).

A controller (:class:`~mjtrack.control.tracking.TrajectoryTracker` or the open-loop
:class:`~mjtrack.control.feedforward.FeedForward`) asks for a body command (v, w) of the
geometric centre. Without compensation the nominal adapter (2.1) V_L,R = v ∓ w T/2 turns it into
track speeds; the slipping robot then turns slower than asked (y_l − y_r > T) and drifts
sideways (v_y = −x_c ω). Two compensations, both fed by the online ψ-estimator
(:class:`~mjtrack.estimation.online.OnlineICREstimator`, ψ = (x_c, ȳ, 1)/(y_l − y_r)):

**ICR feed-forward** (``"icr"``): invert the MICR model (2.14). From
ω = (V_R − V_L)/(y_l − y_r) and v_x = (y_l V_R − y_r V_L)/(y_l − y_r), the 2 × 2 linear system
[[−1, 1], [−y_r, y_l]] (V_L, V_R)ᵀ = (w (y_l − y_r), v (y_l − y_r))ᵀ has determinant
−(y_l − y_r) ≠ 0 and the solution

    V_L = v − w y_l,   V_R = v − w y_r            (substitute back: ω = w, v_x = v).

In ψ, which stays finite for either sign of y_l − y_r: ΔV = V_R − V_L = w/ψ_z,
V̄ = (V_L + V_R)/2 = v − ψ_y ΔV (:func:`track_speeds_from_psi`). The lateral drift
v_y = −x_c w cannot be commanded; the feedback has to absorb it.

**Virtual-robot correction** (``"vir"``, 2.21). The tracked robot moves like a no-slip
differential drive with centre O' = (x_o, y_o) and wheel distance T_v (its wheels on the
track ICRs, x_o = x_c, y_o ± T_v/2 = y_l,r), so its speed map is the same inversion. O' moves
along the heading, the geometric centre does not: its velocity (v_x, −x_o ω) points at the
course angle β = atan2(−x_o ω, v_x) off the heading (:func:`mjtrack.icr.course_angle`). For the
centre to move along the desired path tangent θ_d at speed V, the heading must be θ_d − β:
(2.21) α = asin(x_o ω / V), corrected reference (x_d, y_d, θ_d + α) with forward speed
v_x = V cos α and ω unchanged (:class:`CorrectedReference`; α is clipped to ±``max_alpha``).

Guards: the estimate is used only with ψ_z ≥ ``psi_z_min`` (y_l − y_r ≤ 1/psi_z_min, default
5 T); otherwise (not yet excited, diverged) the nominal map is used and it is logged once.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace

import numpy as np

from mjtrack.control.feedforward import Reference, ReferenceState
from mjtrack.errors import InputError
from mjtrack.estimation.online import OnlineICREstimator

log = logging.getLogger(__name__)

MODES = ("none", "icr", "vir")
# Prior std of psi around the nominal robot (0, 0, 1/T): informative, so that the start of a
# run (the robot accelerating from rest, which no kinematic model describes) cannot throw the
# estimate far off (with the batch filters' (2, 2, 4) psi_y reached 12 within 0.1 s).
PSI_STD0 = (0.2, 0.2, 0.5)


def inverse_micr(v: float, w: float, y_l: float, y_r: float) -> np.ndarray:
    """Track speeds (V_L, V_R) [m/s] that make the MICR robot move with (v_x, ω) = (v, w)."""
    if y_l == y_r:
        raise InputError("inverse_micr: y_l == y_r, the yaw rate cannot be set")
    return np.array([v - w * y_l, v - w * y_r])


def track_speeds_from_psi(v: float, w: float, psi) -> np.ndarray:
    """(V_L, V_R) [m/s] of :func:`inverse_micr` in the ψ chart: ΔV = w/ψ_z, V̄ = v − ψ_y ΔV."""
    if psi[2] == 0:
        raise InputError("track_speeds_from_psi: psi_z == 0, the yaw rate cannot be set")
    dv = w / psi[2]
    vbar = v - psi[1] * dv
    return np.array([vbar - 0.5 * dv, vbar + 0.5 * dv])


def heading_correction(x_o: float, v: float, w: float, *, max_alpha: float = 0.5) -> float:
    """(2.21) α = asin(x_o ω / V) [rad], clipped to ±max_alpha; 0 at V = 0."""
    if v == 0:
        return 0.0
    return float(np.clip(math.asin(float(np.clip(x_o * w / abs(v), -1.0, 1.0))), -max_alpha, max_alpha))


class SlipCompensation:
    """Maps body commands to track speeds, with the chosen compensation (module docstring).

    Args:
        track_gauge: T [m].
        mode: "none", "icr" or "vir".
        estimator: the online estimator (default: :class:`OnlineICREstimator` with its defaults
            and the prior std :data:`PSI_STD0`; unused for "none").
        psi_z_min: smallest ψ_z [1/m] trusted (default 0.2 / T).
        max_alpha: clip of the heading correction [rad].
    """

    def __init__(self, track_gauge: float, mode: str = "icr", *, estimator: OnlineICREstimator | None = None,
                 psi_z_min: float | None = None, max_alpha: float = 0.5) -> None:
        if mode not in MODES:
            raise InputError(f"compensation must be one of {', '.join(MODES)}, got {mode!r}")
        self.track_gauge = float(track_gauge)
        self.mode = mode
        self.estimator = None if mode == "none" else (estimator or OnlineICREstimator(track_gauge, psi_std0=PSI_STD0))
        self.psi_z_min = 0.2 / track_gauge if psi_z_min is None else float(psi_z_min)
        self.max_alpha = max_alpha
        self._started = False
        self._warned = False
        self.history: list[tuple[float, float, float, float]] = []  # (t, y_l, y_r, x_c)

    def observe(self, t: float, u_prev, pose, twist) -> None:
        """Feed one measurement (pose, twist at t; u_prev the track speeds held before t)."""
        if self.estimator is None:
            return
        if not self._started:
            self.estimator.reset(t, pose)
            self._started = True
        else:
            self.estimator.step(t, float(u_prev[0]), float(u_prev[1]), pose=pose, twist=twist)
        self.history.append((t, *self.estimator.icr()))

    def _psi(self) -> np.ndarray | None:
        if self.estimator is None or not self._started:
            return None
        psi = self.estimator.psi
        if not (np.all(np.isfinite(psi)) and psi[2] >= self.psi_z_min):
            if not self._warned:
                log.info("slip compensation: estimate psi = %s not trusted (psi_z < %.3g); nominal map used", psi, self.psi_z_min)
                self._warned = True
            return None
        return psi

    def track_speeds(self, v: float, w: float) -> np.ndarray:
        """(V_L, V_R) [m/s] for the body command (v, w)."""
        psi = self._psi()
        if psi is None:
            half = 0.5 * self.track_gauge * w
            return np.array([v - half, v + half])
        return track_speeds_from_psi(v, w, psi)

    def heading_offset(self, v: float, w: float) -> float:
        """(2.21) α [rad] for the reference speeds (0 unless mode "vir")."""
        psi = self._psi()
        if self.mode != "vir" or psi is None:
            return 0.0
        return heading_correction(psi[0] / psi[2], v, w, max_alpha=self.max_alpha)


@dataclass(frozen=True)
class CorrectedReference:
    """A :class:`Reference` with the (2.21) heading correction of a compensation applied."""

    reference: Reference
    compensation: SlipCompensation

    def at(self, t: float) -> ReferenceState:
        ref = self.reference.at(t)
        a = self.compensation.heading_offset(ref.v, ref.w)
        if a == 0.0:
            return ref
        pose = ref.pose.copy()
        pose[2] += a
        return replace(ref, pose=pose, v=ref.v * math.cos(a))

    @property
    def duration(self) -> float:
        return self.reference.duration

    def start_pose(self) -> np.ndarray:
        return self.reference.start_pose()


# --- tracking runs on the MuJoCo robot -----------------------------------------------------

TRACK_SCENARIOS: dict[str, dict] = {
    "figure_eight": {"path": "figure_eight", "size": 1.5, "laps": 2.0, "speed": 0.5,
                     "text": "lemniscate of Gerono, A = 1.5 m (tip radius 1.5 m), 2 laps at 0.5 m/s"},
    "circle": {"path": "circle", "size": 1.0, "laps": 1.5, "speed": 0.5,
               "text": "circle of radius 1 m, 1.5 turns CCW at 0.5 m/s"},
}


def scenario_reference(name: str, *, speed: float | None = None, laps: float | None = None) -> Reference:
    """The :class:`Reference` of a tracking scenario (:data:`TRACK_SCENARIOS`)."""
    from mjtrack.control.feedforward import ConstantSpeedProfile
    from mjtrack.control.paths import circle_path, figure_eight_path

    if name not in TRACK_SCENARIOS:
        raise InputError(f"unknown tracking scenario {name!r}; choose one of {', '.join(TRACK_SCENARIOS)}")
    sc = TRACK_SCENARIOS[name]
    laps = sc["laps"] if laps is None else float(laps)
    speed = sc["speed"] if speed is None else float(speed)
    if not (laps > 0 and speed > 0):
        raise InputError(f"tracking scenario: laps and speed must be positive, got {laps}, {speed}")
    if sc["path"] == "figure_eight":
        path = figure_eight_path(size=sc["size"], laps=laps)
    else:
        path = circle_path(radius=sc["size"], turns=laps)
    return Reference(path, ConstantSpeedProfile(path.length, speed))


def cross_track_errors(reference: Reference, positions: np.ndarray, *, t=None, window_m: float = 1.5,
                       spacing_m: float = 1e-3) -> np.ndarray:
    """(N,) distance [m] of each position (N, 2+) to the reference path.

    The path is sampled every ``spacing_m`` of arc length (distance error <= spacing²/(8 R)).
    Without ``t``: the nearest point of the whole path. With ``t`` (N,) [s]: the nearest point
    whose arc length is within ``window_m`` of the reference's s(t) — on a self-crossing path
    (figure-eight) the other branch near the crossing is then not mistaken for the path being
    followed (it would make the error drop to 0 there).
    """
    from scipy.spatial import cKDTree

    path = reference.path
    s = np.linspace(0.0, path.length, max(2, int(math.ceil(path.length / spacing_m)) + 1))
    pts = path.point(path.u_at(s))
    xy = np.asarray(positions, float)[:, :2]
    if t is None:
        return cKDTree(pts).query(xy)[0]
    s_ref = np.array([reference.profile.distance(float(tk)) for tk in np.asarray(t, float)])
    lo = np.searchsorted(s, s_ref - window_m)
    hi = np.searchsorted(s, s_ref + window_m, side="right")
    out = np.empty(len(xy))
    for k in range(len(xy)):
        d = pts[lo[k]:hi[k]] - xy[k]
        out[k] = np.sqrt(np.min(np.einsum("ij,ij->i", d, d)))
    return out


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
    seed: int = 0,
    config=None,
) -> TrackingResult:
    """Track a scenario's reference with the MuJoCo robot (:mod:`mjtrack.control.mujoco_plant`).

    Args:
        robot: :class:`~mjtrack.io.robot.Robot`.
        compensation: "none", "icr" or "vir" (module docstring); the controller and its gains
            are the same for all three.
        controller: "tracker" (feed-forward + pole-placement feedback, (3.11)-(3.21), ``poles``)
            or "feedforward" (open loop: the reference's (v_d, w_d) only).
        control_dt: control period [s]; pose_noise / twist_noise: seeded measurement noise std
            seen by the controller and the estimator.
    Returns:
        :class:`TrackingResult`.
    """
    from mjtrack.control.feedforward import FeedForward
    from mjtrack.control.mujoco_plant import run_mujoco_loop
    from mjtrack.control.tracking import TrajectoryTracker

    if controller not in ("tracker", "feedforward"):
        raise InputError(f"controller must be 'tracker' or 'feedforward', got {controller!r}")
    reference = scenario_reference(scenario, speed=speed, laps=laps)
    comp = SlipCompensation(robot.track_gauge, compensation)
    ref = CorrectedReference(reference, comp)
    ctrl = TrajectoryTracker(ref, poles=poles) if controller == "tracker" else FeedForward(ref)
    ctrl.reset()

    def policy(t, pose, twist, u_prev):
        comp.observe(t, u_prev, pose, twist)
        v, w = ctrl.command(t, pose, twist)
        return comp.track_speeds(v, w)

    duration = reference.duration
    loop = run_mujoco_loop(robot, policy, duration, control_dt=control_dt, pose0=reference.start_pose(), config=config,
                           pose_noise=tuple(pose_noise), twist_noise=tuple(twist_noise), seed=seed)
    ct = cross_track_errors(reference, loop.poses, t=loop.t)
    end = reference.at(duration).pose
    metrics = {
        "rms_cross_track_m": float(np.sqrt(np.mean(ct**2))),
        "max_cross_track_m": float(np.max(ct)),
        "final_pos_err_m": float(math.hypot(loop.poses[-1, 0] - end[0], loop.poses[-1, 1] - end[1])),
    }
    hist = np.array(comp.history, float).reshape(-1, 4)
    settings = {"scenario": scenario, "compensation": compensation, "controller": controller,
                "poles": [float(p) for p in poles], "control_dt": control_dt, "duration_s": duration,
                "speed_m_s": reference.profile.speed_value, "path_length_m": reference.path.length,
                "pose_noise": list(pose_noise), "twist_noise": list(twist_noise), "seed": seed}
    return TrackingResult(loop, reference, metrics, hist, settings)
