"""ICR estimation, eqs. (3.14)–(3.22), and an improved filter that works for both turn directions.

**The thesis's filter** (:func:`run_icr_ekf_thesis`). The track ICRs are functions of six
parameters q = (q₁ … q₆) through two regressors of the commands (3.14),

    a = |(V_L − V_R)(V_L + V_R)|,  b = |(V_L − V_R)/(V_L + V_R)|,
    y_l = T/2 + q₁a + q₂b,  y_r = −T/2 + q₃a + q₄b,  x_c = q₅a + q₆b;

q is a random walk (3.18), A = I (3.22); the measurement (3.20) is the world pose increment
over Δt, predicted with the Euler step (3.17) of the MICR model (3.15):
Δq̂ = Δt·Rot(θ_{k-1})·ν_MICR(y_l, y_r, x_c; V_L, V_R). We take the increment between two
measured poses, z_k = p_k ⊖ p_{k-1} (noise covariance 2R, consecutive increments correlated,
which the thesis's filter ignores), and θ_{k-1} from the measured yaw.
H = Δt·Rot₃(θ)·(∂ν/∂(y_l, y_r, x_c))·G with G = [[a b 0 0 0 0], [0 0 a b 0 0], [0 0 0 0 a b]].
Singularities: b is infinite at V_L + V_R = 0 (spin turns): such a step cannot be predicted
and is skipped (``updated = False``, logged) or raised (``on_singular="raise"``).

Derivation and measurements: docs/theory/filters.md, "ICR EKF: both turn directions".
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import ClassVar, Literal, Sequence

import numpy as np

from mjtrack.errors import InputError, SingularMotionError
from mjtrack.estimation.common import FilterResult, History, check_inputs, predict, residual, update
from mjtrack.estimation.pose_ekf import run_pose_param_ekf
from mjtrack.geometry import rot2
from mjtrack.models import MICR, KinematicModel

log = logging.getLogger(__name__)

THESIS_PARAM_NAMES = ("q1", "q2", "q3", "q4", "q5", "q6")


@dataclass(frozen=True)
class InverseICR(KinematicModel):
    """MICR in the linear parametrisation ψ = (x_c, ȳ, 1)/(y_l − y_r) [-, -, 1/m] (module docstring)."""

    psi_x: float
    psi_y: float
    psi_z: float
    name: ClassVar[str] = "MICR-inverse"
    param_names: ClassVar[tuple[str, ...]] = ("psi_x", "psi_y", "psi_z")

    @classmethod
    def from_icr(cls, y_l, y_r, x_c) -> "InverseICR":
        d = np.asarray(y_l, float) - np.asarray(y_r, float)
        if np.any(d == 0):
            raise SingularMotionError("InverseICR: y_l == y_r has no finite psi")
        return cls(np.asarray(x_c) / d, 0.5 * (np.asarray(y_l) + np.asarray(y_r)) / d, 1.0 / d)

    @classmethod
    def nominal(cls, track_gauge: float) -> "InverseICR":
        return cls(0.0, 0.0, 1.0 / track_gauge)

    def twist(self, v_left, v_right) -> np.ndarray:
        vl, vr, px, py, pz = np.broadcast_arrays(*(np.asarray(a, float) for a in (v_left, v_right, self.psi_x, self.psi_y, self.psi_z)))
        dv = vr - vl
        return np.stack([(vl + vr) / 2.0 + py * dv, -px * dv, pz * dv], -1)

    def twist_jacobian(self, v_left, v_right) -> np.ndarray:
        vl, vr, px = np.broadcast_arrays(np.asarray(v_left, float), np.asarray(v_right, float), np.asarray(self.psi_x, float))
        dv, z = vr - vl, np.zeros_like(vl)
        return np.stack([np.stack([z, -dv, z], -1), np.stack([dv, z, z], -1), np.stack([z, z, dv], -1)], -1)


def icr_from_psi(psi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(y_l, y_r, x_c) [m] from ψ (..., 3); ψ_z = 0 (ICRs at infinity) raises."""
    psi = np.asarray(psi, float)
    if np.any(psi[..., 2] == 0):
        raise SingularMotionError("ICRs at infinity: psi_z == 0")
    return (psi[..., 1] + 0.5) / psi[..., 2], (psi[..., 1] - 0.5) / psi[..., 2], psi[..., 0] / psi[..., 2]


def thesis_regressors(v_left, v_right) -> tuple[np.ndarray, np.ndarray]:
    """(a, b) of (3.14); b is inf where V_L + V_R = 0."""
    vl, vr = np.asarray(v_left, float), np.asarray(v_right, float)
    s = vl + vr
    with np.errstate(divide="ignore", invalid="ignore"):
        b = np.where(s == 0, np.inf, np.abs((vl - vr) / np.where(s == 0, 1.0, s)))
    return np.abs((vl - vr) * s), b


def icr_from_thesis_params(q, v_left, v_right, *, track_gauge: float):
    """(y_l, y_r, x_c) [m] of (3.14) for parameters q (..., 6) and commands (broadcast)."""
    q = np.asarray(q, float)
    a, b = thesis_regressors(v_left, v_right)
    return (track_gauge / 2 + q[..., 0] * a + q[..., 1] * b, -track_gauge / 2 + q[..., 2] * a + q[..., 3] * b,
            q[..., 4] * a + q[..., 5] * b)


def thesis_increment(q, v_left, v_right, yaw, dt, *, track_gauge: float):
    """Predicted world pose increment (3.17)/(3.21) and its Jacobian ∂/∂q (3 × 6)."""
    a, b = thesis_regressors(v_left, v_right)
    yl, yr, xc = icr_from_thesis_params(q, v_left, v_right, track_gauge=track_gauge)
    m = MICR(float(yl), float(yr), float(xc))
    nu = m.twist(v_left, v_right)
    J = m.twist_jacobian(v_left, v_right)
    G = np.array([[a, b, 0, 0, 0, 0], [0, 0, a, b, 0, 0], [0, 0, 0, 0, a, b]], float)
    R3 = np.eye(3)
    R3[:2, :2] = rot2(yaw)
    return dt * R3 @ nu, dt * R3 @ J @ G


def run_icr_ekf_thesis(
    t,
    v_left,
    v_right,
    *,
    track_gauge: float,
    pose_meas,
    pose_std: Sequence[float] = (0.1, 0.1, np.radians(2.0)),
    q0: Sequence[float] = (0.0,) * 6,
    q_std0: float | Sequence[float] = 10.0,
    q_rw_std: float | Sequence[float] = 0.1,
    sum_min: float = 1e-3,
    on_singular: Literal["skip", "raise"] = "skip",
) -> FilterResult:
    """The thesis's ICR EKF (3.14)–(3.22) (module docstring).

    Args:
        t: (N,) [s]; v_left, v_right: (N,) commands [m/s]; pose_meas: (N, 3) [m, m, rad].
        track_gauge: T [m]; pose_std: pose noise std (increments get twice the variance).
        q0: initial q (default 0: nominal ICRs); q_std0: its std; q_rw_std: random-walk
            intensity [unit/√s]. The units of q are m/(m/s)² (q₁, q₃, q₅) and m (q₂, q₄, q₆).
        sum_min: |V_L + V_R| [m/s] below which b is treated as singular.
        on_singular: "skip" the step (logged) or "raise" :class:`SingularMotionError`.
    Returns:
        :class:`FilterResult` with states q1..q6, measurements (dx, dy, dtheta).
    """
    t, vl, vr, pm = check_inputs(t, v_left, v_right, pose_meas)
    if on_singular not in ("skip", "raise"):
        raise InputError(f"on_singular must be 'skip' or 'raise', got {on_singular!r}")
    q = np.asarray(q0, float).copy()
    P = np.eye(6) * np.broadcast_to(np.asarray(q_std0, float) ** 2, (6,))
    q2 = np.broadcast_to(np.asarray(q_rw_std, float) ** 2, (6,))
    R = 2.0 * np.diag(np.asarray(pose_std, float) ** 2)
    hist = History(6, 3)
    skipped = 0
    for k in range(1, t.size):
        dt = t[k] - t[k - 1]
        q_pr, P_pr = predict(q, P, q, np.eye(6), np.diag(q2 * dt))  # (3.22)
        z = residual(pm[k], pm[k - 1], (2,))
        singular = abs(vl[k - 1] + vr[k - 1]) < sum_min
        h = np.full(3, np.nan)
        if not singular:
            try:
                h, H = thesis_increment(q_pr, vl[k - 1], vr[k - 1], pm[k - 1, 2], dt, track_gauge=track_gauge)
            except SingularMotionError:
                singular = True
        if singular or np.any(np.isnan(z)):
            if singular and on_singular == "raise":
                raise SingularMotionError(f"icr_ekf_thesis: singular regressors or y_l == y_r at t = {t[k]:g} s (V_L + V_R = {vl[k - 1] + vr[k - 1]:.3g} m/s)")
            skipped += int(singular)
            q, P = q_pr, P_pr
            hist.add(t[k], q_pr, P_pr, q, P, z, h)
            continue
        q, P, e, S, K = update(q_pr, P_pr, z, h, H, R, angle_idx=(2,))
        hist.add(t[k], q_pr, P_pr, q, P, z, h, None, e, S, K)
    if skipped:
        log.warning("icr_ekf_thesis: %d of %d steps skipped (V_L + V_R ~ 0 or y_l == y_r: the regressors of (3.14) are singular)", skipped, t.size - 1)
    return hist.result("icr_ekf_thesis", THESIS_PARAM_NAMES, ("dx", "dy", "dtheta"), meas_angles=(2,),
                       info={"track_gauge": track_gauge, "skipped": skipped})


def run_icr_ekf(
    t,
    v_left,
    v_right,
    *,
    track_gauge: float,
    pose_meas=None,
    twist_meas=None,
    pose_std: Sequence[float] = (0.1, 0.1, np.radians(2.0)),
    twist_std: Sequence[float] = (0.05, 0.05, 0.04),
    icr0: Sequence[float] | None = None,
    psi_std0: Sequence[float] = (2.0, 2.0, 4.0),
    q_psi_std: Sequence[float] = (1e-3, 1e-3, 1e-3),
    q_pose_std: Sequence[float] = (1e-3, 1e-3, 1e-3),
    pose0=None,
    name: str = "icr_ekf",
    adaptive=None,
    psi0: Sequence[float] | None = None,
    psi_cov0=None,
) -> FilterResult:
    """Improved ICR EKF: pose-augmented EKF on ψ (module docstring).

    Args:
        icr0: initial (y_l, y_r, x_c) [m] (default nominal: T/2, −T/2, 0); psi_std0: std of
            the initial ψ [-, -, 1/m]; q_psi_std: random-walk intensity of ψ [unit/√s].
        adaptive: None (one EKF), "imm" or :class:`~mjtrack.estimation.imm.IMMSettings` (slow/fast
            IMM pair whose slow mode has ``q_psi_std``, :mod:`mjtrack.estimation.imm`).
        psi0, psi_cov0: initial ψ and its (3, 3) covariance, overriding ``icr0`` / ``psi_std0``
            (a filter carried over from an earlier window of the same robot).
        Others as :func:`~mjtrack.estimation.slip_ekf.run_slip_ekf`.
    Returns:
        :class:`FilterResult` with states (x, y, theta, psi_x, psi_y, psi_z); use
        :func:`icr_from_psi` on ``x_post[:, 3:]`` for the ICRs.
    """
    model = InverseICR.nominal(track_gauge) if icr0 is None else InverseICR.from_icr(*icr0)
    if psi0 is not None:
        model = InverseICR(*np.asarray(psi0, float))
    return run_pose_param_ekf(
        model, t, v_left, v_right, pose_meas=pose_meas, twist_meas=twist_meas, pose_std=pose_std,
        twist_std=twist_std, param_std0=psi_std0, q_param_std=q_psi_std, q_pose_std=q_pose_std, pose0=pose0,
        name=name, adaptive=adaptive, param_cov0=psi_cov0,
    )
