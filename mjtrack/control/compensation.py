"""Slip-compensated trajectory tracking of the tracked robot.

A controller (:class:`~mjtrack.control.tracking.TrajectoryTracker` or the open-loop
:class:`~mjtrack.control.feedforward.FeedForward`) asks for a body command (v, w) of the
geometric centre. Without compensation the nominal adapter (2.1) V_L,R = v ∓ w T/2 turns it into
track speeds; the slipping robot then turns slower than asked (y_l − y_r > T) and drifts
sideways (v_y = −x_c ω). Two compensations ("icr", "vir"), both fed by the online ψ-estimator
(:class:`~mjtrack.estimation.online.OnlineICREstimator`, ψ = (x_c, ȳ, 1)/(y_l − y_r)):

**Inverse ICR map**: invert the MICR model (2.14). From
ω = (V_R − V_L)/(y_l − y_r) and v_x = (y_l V_R − y_r V_L)/(y_l − y_r), the 2 × 2 linear system
[[−1, 1], [−y_r, y_l]] (V_L, V_R)ᵀ = (w (y_l − y_r), v (y_l − y_r))ᵀ has determinant
−(y_l − y_r) ≠ 0 and the solution

    V_L = v − w y_l,   V_R = v − w y_r            (substitute back: ω = w, v_x = v).

In ψ, which stays finite for either sign of y_l − y_r: ΔV = V_R − V_L = w/ψ_z,
V̄ = (V_L + V_R)/2 = v − ψ_y ΔV (:func:`track_speeds_from_psi`). The lateral drift
v_y = −x_c w cannot be commanded.

Derivation and measurements: docs/theory/compensation.md, "The compensation design".
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace

import numpy as np

from mjtrack.control.feedforward import Reference, ReferenceState
from mjtrack.errors import InputError, MjtrackError
from mjtrack.estimation.icr_ekf import InverseICR, icr_from_psi
from mjtrack.estimation.online import OnlineICREstimator
from mjtrack.models.coulomb import steady_state as coulomb_steady_state

log = logging.getLogger(__name__)

MODES = ("none", "icr", "vir")
# the controllers mjtrack.control.runs.run_tracking drives: the project's slip-compensated tracker and the thesis's five
CONTROLLERS = ("tracker", "feedforward", "pole_placement", "reactive", "posture", "line_following")
COMPENSABLE = ("tracker", "feedforward", "pole_placement")  # those with a feed-forward from the reference
REFERENCE_MAPS = ("nominal", "coulomb")
# Prior std of psi around the nominal robot (0, 0, 1/T): informative, so that the start of a
# run (the robot accelerating from rest, which no kinematic model describes) cannot throw the
# estimate far off (with the batch filters' (2, 2, 4) psi_y reached 12 within 0.1 s).
PSI_STD0 = (0.2, 0.2, 0.5)
# Inflation of the estimator's psi std in the trust weight: the pose-fed ICR EKF is
# over-confident on MuJoCo data (parameter NEES 22.6 for 3 states: sqrt(22.6/3) = 2.7).
TRUST_SCALE = 1.0
# Physically admissible ICRs of a tracked robot, in units of the gauge T and the track length L:
# T <= y_l - y_r (slip only moves the track ICRs outwards; 0.8 T leaves room for estimator noise),
# y_l - y_r <= 4 T, |ybar| <= T/2, |x_c| <= L/2. An estimate outside is not used at all.
SPACING_RANGE = (0.8, 4.0)
# Time constant [s] of the running means of the twist residuals (module docstring, "trust").
FIT_TAU = 1.0
WEIGHT_RISE_TAUS = 2.0


def admissible_psi(psi, track_gauge: float, track_length: float) -> bool:
    """Whether ψ describes physically possible ICRs of a tracked robot (:data:`SPACING_RANGE`,
    |ȳ| <= T/2, |x_c| <= L/2)."""
    if not (np.all(np.isfinite(psi)) and psi[2] > 0):
        return False
    spacing, ybar, x_c = 1.0 / psi[2], psi[1] / psi[2], psi[0] / psi[2]
    lo, hi = SPACING_RANGE
    return (lo * track_gauge <= spacing <= hi * track_gauge and abs(ybar) <= 0.5 * track_gauge
            and abs(x_c) <= 0.5 * track_length)


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


def velocity_deviation(psi_used, psi_true, w: float) -> np.ndarray:
    """(δv_x, δy, δω): how the plant's motion departs from what a compensated controller expects.

    The controller commands (v, w) through the map of ``psi_used`` (:func:`track_speeds_from_psi`,
    ΔV = w/ψu_z) and expects the drift-free point (x_cu, 0), x_cu = ψu_x/ψu_z, to move with
    (v, 0) and the body to turn at w. A robot whose true parameter is ``psi_true`` gives
    δv_x = w (ψt_y − ψu_y)/ψu_z, δy = w (ψt_z x_cu − ψt_x)/ψu_z (sideways velocity of that
    point), δω = w (ψt_z/ψu_z − 1). ``psi_used`` = nominal (0, 0, 1/T) is no compensation.
    """
    pu, pt = np.asarray(psi_used, float), np.asarray(psi_true, float)
    k = w / pu[2]
    x_cu = pu[0] / pu[2]
    return np.array([k * (pt[1] - pu[1]), k * (pt[2] * x_cu - pt[0]), k * (pt[2] - pu[2])])


def static_error_map(v_d: float, w_d: float, poles, fb_deviation=(0.0, 0.0, 0.0)) -> np.ndarray:
    """(3, 3) map S from a constant velocity deviation δ to the tracker's steady error e* = S δ.

    The error dynamics (3.14) of the tracker, linearised about e = 0, with the plant moving δ
    off what it expects: ė = (A − B K) e − δ. The feedback's own yaw command k₂ᵀe moves the
    plant off as well, by ``fb_deviation`` d per unit of w (:func:`velocity_deviation` at
    w = 1 of the map the feedback goes through): ė = (A − B K − d k₂ᵀ) e − δ, so
    e* = (A − B K − d k₂ᵀ)⁻¹ δ; e*_2, the sideways error in the robot frame, is the steady
    cross-track error.
    """
    from mjtrack.control.tracking import B_MATRIX, error_matrix, placement_gains

    K = placement_gains(v_d, w_d, poles)
    return np.linalg.inv(error_matrix(v_d, w_d) - B_MATRIX @ K - np.outer(np.asarray(fb_deviation, float), K[1]))


def trust_weight(psi, psi_cov, psi_nominal, v_d: float, w_d: float, *, poles=(-1.0, -2.0, -4.0),
                 scale: float = TRUST_SCALE, feedback_psi_z: float | None = None) -> float:
    """Scalar weight λ in [0, 1] of the compensation ψ₀ + λ (ψ̂ − ψ₀) (derivation below).

    With the truth ψ and the estimate ψ̂ = ψ + ε, ε ~ N(0, P), the steady cross-track error of
    the compensated tracker is, to first order, E(λ) = (1 − λ) E₀ − λ gᵀε: E₀ the error without
    compensation predicted with ψ̂ (row 2 of :func:`static_error_map` times
    :func:`velocity_deviation` of the feed-forward (v_d, w_d), the feedback going through the
    nominal map in both cases), g its sensitivity to the estimate's error. Its expected square
    (1 − λ)² E₀² + λ² gᵀPg is smallest at λ = E₀² / (E₀² + gᵀPg) (P inflated by ``scale``²
    for an over-confident filter). To first order a blend along the whole correction never
    raises the predicted error above none's ((1 − λ) |E₀| <= |E₀|); correcting one part alone
    can — with the centre of gravity behind, the yaw deficit (outwards) and the sideways drift
    (inwards) partly cancel, and correcting the yaw alone leaves the drift. Beyond
    first order (δ is nonlinear in ψ) a partial blend can also be worse where E₀ ≈ 0 through
    such a cancellation; there λ ≈ 0.
    λ is evaluated at the reference's (v_d, w_d) with |w_d| floored at 0.1 rad/s (all δ scale
    with w; the floor keeps λ defined on straight stretches, where it does not act).
    With a reference map other than the nominal one (:class:`CoulombICRMap`), ``psi_nominal``
    is that map's ψ: E₀ is the error of the feed-forward through it, the feedback going through
    the nominal map (ψ_z = ``feedback_psi_z``, default ``psi_nominal``'s) about its drift-free point.
    """
    v_d = max(abs(v_d), 0.05)
    w_d = math.copysign(max(abs(w_d), 0.1), w_d if w_d != 0 else 1.0)
    psi, psi_nominal = np.asarray(psi, float), np.asarray(psi_nominal, float)
    fb_z = psi_nominal[2] if feedback_psi_z is None else float(feedback_psi_z)
    d_none = velocity_deviation(psi_nominal, psi, 1.0)
    d_none_fb = velocity_deviation(np.array([psi_nominal[0] / psi_nominal[2] * fb_z, 0.0, fb_z]), psi, 1.0)
    e0 = float(static_error_map(v_d, w_d, poles, d_none_fb)[1] @ d_none) * w_d
    # compensated: feed-forward through psi (no deviation at the truth psi), feedback through the
    # nominal map about the drift-free point (x_c, 0)
    x_c = psi[0] / psi[2]
    d_fb = velocity_deviation(np.array([x_c * fb_z, 0.0, fb_z]), psi, 1.0)
    jac = (w_d / psi[2]) * np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, x_c], [0.0, 0.0, 1.0]])  # ∂δ/∂ψ_true at ψ̂
    g = static_error_map(v_d, w_d, poles, d_fb)[1] @ jac
    var = scale**2 * float(g @ np.asarray(psi_cov, float) @ g)
    return e0 * e0 / (e0 * e0 + var) if e0 * e0 + var > 0 else 0.0


class CoulombICRMap:
    """ψ of the Coulomb reference's steady ICRs at a body command: the physics of the robot's
    description (mass, centre of gravity, friction, geometry; :func:`mjtrack.models.coulomb.steady_state`)
    as the map a compensation starts from, in place of the nominal one.

    For a command (v, w) the track speeds that give it are found by fixed-point iteration:
    (V_L, V_R) = :func:`inverse_micr` (v, w, ICRs), ICRs = the steady ICRs at (V_L, V_R), from the
    nominal ICRs, ``iterations`` times (the ICRs move little with the track speeds: 3 iterations
    agree with 8 to 2e-5 m and reproduce the command in the reference's own physics to 1e-5 m/s,
    rad/s on the default robot and μ 0.4 with the CG ±5 cm; the latter tested). |v| is floored at 0.05 m/s and |w| at
    ``w_floor`` (a straight uses the ICRs of a gentle left turn; on a straight ΔV = 0 and only x_c
    acts, through the control point). Results are cached on (v, w) rounded to 1e-3. Where no
    steady state exists (the turn needs more friction than there is) or its ICRs are not
    physically admissible for a kinematic map (:func:`admissible_psi`; e.g. x_c beyond L/2 when
    the robot slides out of a fast tight turn), the nominal ψ is returned and logged once: the
    map does not extrapolate a sliding robot.
    """

    def __init__(self, robot, *, iterations: int = 3, w_floor: float = 0.05) -> None:
        self.robot = robot
        self.iterations = int(iterations)
        self.w_floor = float(w_floor)
        self._cache: dict[tuple[float, float], np.ndarray] = {}
        self._warned = False
        self.nominal = np.array([0.0, 0.0, 1.0 / robot.track_gauge])

    def __call__(self, v: float, w: float) -> np.ndarray:
        v = math.copysign(max(abs(v), 0.05), v if v != 0 else 1.0)
        w = math.copysign(max(abs(w), self.w_floor), w if w != 0 else 1.0)
        key = (round(v, 3), round(w, 3))
        psi = self._cache.get(key)
        if psi is None:
            half = 0.5 * self.robot.track_gauge
            y_l, y_r, x_c = half, -half, 0.0
            try:
                for _ in range(self.iterations):
                    y_l, y_r, x_c = coulomb_steady_state(self.robot, *inverse_micr(key[0], key[1], y_l, y_r)).icr
                psi = InverseICR.from_icr(y_l, y_r, x_c).params
                if not admissible_psi(psi, self.robot.track_gauge, self.robot.contact_length):
                    raise MjtrackError(f"steady ICRs (y_l, y_r, x_c) = ({y_l:.3f}, {y_r:.3f}, {x_c:.3f}) m not admissible")
            except MjtrackError as exc:
                if not self._warned:
                    log.info("CoulombICRMap: no usable steady state for (v, w) = %s (%s); nominal map used", key, exc)
                    self._warned = True
                psi = self.nominal
            self._cache[key] = np.asarray(psi, float)
        return self._cache[key].copy()


class SlipCompensation:
    """Maps body commands to track speeds, with the chosen compensation (module docstring).

    Args:
        track_gauge: T [m].
        mode: "none", "icr" or "vir".
        estimator: the online estimator (default: :class:`OnlineICREstimator` with its defaults
            and the prior std :data:`PSI_STD0`; unused for "none").
        track_length: L [m] of the admissible-ICR box (|x_c| <= L/2; default T).
        trust_scale: σ inflation of :func:`trust_weight` (0: use the estimate as it is, the
            behaviour of the first version).
        poles: the tracker's poles, for the predicted static error in :func:`trust_weight`.
        max_alpha: clip of the heading correction [rad].
        estimator_input: "measured" (the estimator is fed the measured track speeds when
            :meth:`observe` gets them, else the commands) or "command" (always the commands).
        drift_free_point: mode "icr" only: the feedback acts on the drift-free point
            (:meth:`control_pose`); False: on the centre (the first version, for ablation).
        split_feedback: the feedback's correction goes through the nominal map
            (:meth:`track_speeds`); False: the whole command through the compensated one.
        reference_map: callable (v, w) -> ψ, the map used at weight 0 in place of the nominal
            one (e.g. :class:`CoulombICRMap` of the robot's description), evaluated at the
            reference's (v_d, w_d); the estimate is blended against it, ψ_ref + λ (ψ̂ − ψ_ref),
            with λ and κ taken against it. The feedback still goes through the nominal map.
        weight_rise_taus: λ rises at most 1/(weight_rise_taus · FIT_TAU) per second (ablation;
            default :data:`WEIGHT_RISE_TAUS`).
    """

    def __init__(self, track_gauge: float, mode: str = "icr", *, estimator: OnlineICREstimator | None = None,
                 track_length: float | None = None, trust_scale: float = TRUST_SCALE, max_alpha: float = 0.5,
                 estimator_input: str = "measured", drift_free_point: bool = True, split_feedback: bool = True,
                 poles=(-1.0, -2.0, -4.0), reference_map=None, weight_rise_taus: float = WEIGHT_RISE_TAUS) -> None:
        if mode not in MODES:
            raise InputError(f"compensation must be one of {', '.join(MODES)}, got {mode!r}")
        if estimator_input not in ("measured", "command"):
            raise InputError(f"estimator_input must be 'measured' or 'command', got {estimator_input!r}")
        self.track_gauge = float(track_gauge)
        self.track_length = self.track_gauge if track_length is None else float(track_length)
        self.mode = mode
        self.estimator = None if mode == "none" else (estimator or OnlineICREstimator(track_gauge, psi_std0=PSI_STD0))
        self.psi_nominal = np.array([0.0, 0.0, 1.0 / self.track_gauge])
        self.trust_scale = float(trust_scale)
        self.max_alpha = max_alpha
        self.estimator_input = estimator_input
        self.drift_free_point = bool(drift_free_point)
        self.split_feedback = bool(split_feedback)
        self._started = False
        self._warned = False
        self._applied = self.psi_nominal.copy()
        self.poles = tuple(poles)
        self.weight = 0.0
        self.nis_mean = 1.0
        self._fit_est = self._fit_nom = 0.0
        self._t_weight: float | None = None
        self._last_command = (0.0, 0.0)
        self.history: list[tuple[float, float, float, float]] = []  # (t, y_l, y_r, x_c) of the estimate
        self.applied_history: list[tuple[float, float, float, float]] = []  # (t, y_l, y_r, x_c) applied
        self.weight_history: list[tuple[float, float]] = []  # (t, λ)
        self.reference_map = reference_map if mode != "none" else None
        if not weight_rise_taus > 0:
            raise InputError(f"weight_rise_taus must be positive, got {weight_rise_taus!r}")
        self.weight_rise_taus = float(weight_rise_taus)

    def psi_reference(self) -> np.ndarray:
        """The map used at weight 0: the reference map at the last feed-forward (v_d, w_d), or the
        nominal ψ (no reference map, or no command yet)."""
        if self.reference_map is None or self._last_command == (0.0, 0.0):
            return self.psi_nominal.copy()
        return np.asarray(self.reference_map(*self._last_command), float)

    def observe(self, t: float, u_prev, pose, twist, track_speed=None) -> None:
        """Feed one measurement: pose, twist at t; u_prev the track speeds commanded before t;
        track_speed the measured track speeds at t (encoders), fed to the estimator in place of
        the command when given (mode "measured"), so that the drive's lag is not read as slip."""
        if self.estimator is None:
            return
        if not self._started:
            self.estimator.reset(t, pose)
            self._started = True
        else:
            u = u_prev if (track_speed is None or self.estimator_input == "command") else track_speed
            if twist is not None:
                self._track_consistency(t - self.estimator.t, u, twist)
            self.estimator.step(t, float(u[0]), float(u[1]), pose=pose, twist=twist)
        self._applied = self._trusted_psi()
        self.history.append((t, *self.estimator.icr()))
        self.weight_history.append((t, self.weight))
        self.applied_history.append((t, *map(float, icr_from_psi(self._applied))))

    def _track_consistency(self, dt: float, u, twist) -> None:
        """Running means (time constant :data:`FIT_TAU`) of the twist residuals of the estimate
        and of the nominal map, and of the estimate's NIS per dof (module docstring)."""
        twist = np.asarray(twist, float)
        if not np.all(np.isfinite(twist)):
            return
        r_std2 = np.asarray(self.estimator.twist_std, float) ** 2
        est, nom = InverseICR(*self.estimator.psi), InverseICR(*self.psi_reference())
        vl, vr = float(u[0]), float(u[1])
        r = twist - est.twist(vl, vr)
        r0 = twist - nom.twist(vl, vr)
        J = est.twist_jacobian(vl, vr)
        S = J @ self.estimator.psi_cov @ J.T + np.diag(r_std2)
        a = min(1.0, dt / FIT_TAU)
        self.nis_mean += a * (float(r @ np.linalg.solve(S, r)) / 3.0 - self.nis_mean)
        self._fit_est += a * (float(np.sum(r * r / r_std2)) - self._fit_est)
        self._fit_nom += a * (float(np.sum(r0 * r0 / r_std2)) - self._fit_nom)

    @property
    def explained(self) -> float:
        """κ = 1 − (residual of the estimate)/(residual of the nominal map), clipped to [0, 1]:
        the share of the nominal map's twist misfit that the estimate explains (recent FIT_TAU)."""
        if not self._fit_nom > 0:
            return 0.0
        return float(np.clip(1.0 - self._fit_est / self._fit_nom, 0.0, 1.0))

    def admissible(self, psi) -> bool:
        """Whether ψ describes physically possible ICRs (:func:`admissible_psi` with this T and L)."""
        return admissible_psi(psi, self.track_gauge, self.track_length)

    def _trusted_psi(self) -> np.ndarray:
        psi, ref = self.estimator.psi, self.psi_reference()
        if not self.admissible(psi):
            if not self._warned:
                log.info("slip compensation: estimate psi = %s outside the admissible ICRs; reference map used", psi)
                self._warned = True
            self.weight, self._t_weight = 0.0, self.estimator.t
            return ref
        v, w = self._last_command
        scale = self.trust_scale * math.sqrt(max(1.0, self.nis_mean))
        lam = self.explained * trust_weight(psi, self.estimator.psi_cov, ref, v, w, poles=self.poles, scale=scale,
                                            feedback_psi_z=self.psi_nominal[2])
        # the weight falls at once but rises no faster than the evidence for it accumulates
        # (the residual means lag by FIT_TAU): at most 1/(weight_rise_taus · FIT_TAU) per second
        dt = self.estimator.t - self._t_weight if self._t_weight is not None else 0.0
        self._t_weight = self.estimator.t
        self.weight = min(lam, self.weight + dt / (self.weight_rise_taus * FIT_TAU))
        return ref + self.weight * (psi - ref)

    @property
    def psi_applied(self) -> np.ndarray:
        """The ψ the maps use now: nominal for "none" and before the first estimate."""
        return self._applied.copy()

    def track_speeds(self, v: float, w: float, feedforward: tuple[float, float] | None = None) -> np.ndarray:
        """(V_L, V_R) [m/s] for the body command (v, w).

        With ``feedforward`` = (v_d, w_d), the part of the command (v, w) that comes from the
        reference: only it goes through the compensated map, the feedback's correction
        (v − v_d, w − w_d) through the nominal one (``split_feedback``, module docstring).
        """
        self._last_command = (float(v), float(w)) if feedforward is None else tuple(map(float, feedforward))
        if feedforward is None or not self.split_feedback:
            return track_speeds_from_psi(v, w, self._applied)
        v_d, w_d = feedforward
        return track_speeds_from_psi(v_d, w_d, self._applied) + track_speeds_from_psi(v - v_d, w - w_d, self.psi_nominal)

    def control_pose(self, pose) -> np.ndarray:
        """The pose the feedback acts on. Mode "icr": the point (x_c, 0) of the body on the line
        of the ICRs, whose velocity under the inverse-MICR map is (v, 0) — no sideways drift,
        a unicycle for the tracker; otherwise the geometric centre."""
        pose = np.asarray(pose, float)
        if self.mode != "icr" or not self.drift_free_point:
            return pose
        x_c = self._applied[0] / self._applied[2]
        return np.array([pose[0] + x_c * math.cos(pose[2]), pose[1] + x_c * math.sin(pose[2]), pose[2]])

    def heading_offset(self, v: float, w: float) -> float:
        """(2.21) α [rad] for the reference speeds (0 unless mode "vir")."""
        if self.mode != "vir":
            return 0.0
        return heading_correction(self._applied[0] / self._applied[2], v, w, max_alpha=self.max_alpha)


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
