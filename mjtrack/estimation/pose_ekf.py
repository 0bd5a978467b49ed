"""Pose-augmented parameter EKF for any kinematic model (the structure of eqs. 3.9–3.13).

State s = (x, y, θ, p₁ … p_P): the world pose of the geometric centre and the P parameters of
a :class:`~mjtrack.models.KinematicModel` (MPP slips, ICR parameters, …). Parameters are a random
walk; the pose follows the thesis's Euler step (3.11) (or a midpoint step, below) with the model's body twist
ν(p, u) = (v_x, v_y, ω) at the held command u_{k-1} = (V_L, V_R):

    x_k = x + Δt (cos θ v_x − sin θ v_y),   y_k = y + Δt (sin θ v_x + cos θ v_y),
    θ_k = θ + Δt ω,                          p_k = p.

Jacobian F = ∂f/∂s (3.5), with J = ∂ν/∂p (3 × P) from ``model.twist_jacobian``:

    F = I + Δt · [[0, 0, −sin θ v_x − cos θ v_y, (Rot(θ) J)₀],
                  [0, 0,  cos θ v_x − sin θ v_y, (Rot(θ) J)₁],
                  [0, 0,  0,                      J₂        ],
                  [0 … 0]]                                           (parameter rows: identity)

Measurements (either or both; NaN entries are skipped): the pose (3.12), h = (x, y, θ),
H = [I₃ 0], yaw residual wrapped; and the body twist at the current command, h = ν(p, u_k),
H = [0₃ₓ₃ J(u_k)] (the velocity measurement (3.30) of the virtual-robot filter).

Euler's bias. Exact constant-twist motion displaces the centre along the chord, i.e. along the
heading turned by ωΔt/2 (:func:`mjtrack.geometry.se2_step`: C/S = tan(ωΔt/2)). Fitting Euler
(3.11) to exactly integrated data therefore biases the lateral velocity by v_x·ωΔt/2 —
1.6e-3 m/s at the 4.2 settings (v_x = 0.36 m/s, ω = 0.09 rad/s, Δt = 0.1 s), i.e. 0.26° on α
and 1.8 cm on x_c = −v_y/ω, larger than the noise-limited accuracy. The default
``step="midpoint"`` uses the mid-step heading (relative error O((ωΔt)²), 1e-4 here):

    x_k = x + Δt (cos θ_m v_x − sin θ_m v_y),  y_k = y + Δt (sin θ_m v_x + cos θ_m v_y),
    θ_m = θ + ωΔt/2;

its Jacobian evaluates the θ column at θ_m and adds Δt·(∂Rot(θ_m)/∂θ)(v_x, v_y)·(Δt/2)·J₂ to
the position rows' parameter columns. ``step="euler"`` is the thesis's (3.11).

Noise units: measurement noise as standard deviations ``*_std`` [m, m, rad, m/s, m/s, rad/s];
process noise as random-walk intensities ``q_*_std`` [unit/√s], Q = diag(q²)·Δt, so the result
does not depend on the sampling rate.
"""

from __future__ import annotations

import logging
from typing import Sequence

import numpy as np

from mjtrack.errors import InputError
from mjtrack.estimation.common import FilterResult, History, check_inputs, predict, update
from mjtrack.models import KinematicModel

log = logging.getLogger(__name__)

POSE_NAMES = ("x", "y", "theta")
TWIST_NAMES = ("vx", "vy", "wz")


def transition(model: KinematicModel, s: np.ndarray, v_left: float, v_right: float, dt: float, *, step: str = "midpoint"):
    """Pose step of the augmented state and its Jacobian: returns (f(s), F).

    ``step="euler"`` is (3.11); ``step="midpoint"`` rotates the displacement by the mid-step
    heading θ_m = θ + ω Δt/2 (module docstring).
    """
    n = s.size
    m = model.with_params(s[3:])
    vx, vy, w = m.twist(v_left, v_right)
    J = m.twist_jacobian(v_left, v_right)
    half = 0.5 * dt if step == "midpoint" else 0.0
    th = s[2] + half * w
    c, sn = np.cos(th), np.sin(th)
    fs = s.copy()
    fs[0] += dt * (c * vx - sn * vy)
    fs[1] += dt * (sn * vx + c * vy)
    fs[2] += dt * w
    dth = np.array([-sn * vx - c * vy, c * vx - sn * vy])  # d Rot(th)(vx, vy) / d th
    F = np.eye(n)
    F[0:2, 2] = dt * dth
    F[0, 3:] = dt * (c * J[0] - sn * J[1] + dth[0] * half * J[2])
    F[1, 3:] = dt * (sn * J[0] + c * J[1] + dth[1] * half * J[2])
    F[2, 3:] = dt * J[2]
    return fs, F


def measurement(model: KinematicModel, s: np.ndarray, v_left: float, v_right: float, *, pose: bool, twist: bool):
    """Predicted measurement and its Jacobian: pose (3.12) and/or body twist; returns (h, H)."""
    n = s.size
    hs, Hs = [], []
    if pose:
        hs.append(s[:3])
        Hs.append(np.eye(3, n))
    if twist:
        m = model.with_params(s[3:])
        hs.append(m.twist(v_left, v_right))
        H = np.zeros((3, n))
        H[:, 3:] = m.twist_jacobian(v_left, v_right)
        Hs.append(H)
    return np.concatenate(hs), np.vstack(Hs)


def run_pose_param_ekf(
    model: KinematicModel,
    t,
    v_left,
    v_right,
    *,
    pose_meas=None,
    twist_meas=None,
    pose_std: Sequence[float] = (0.1, 0.1, np.radians(2.0)),
    twist_std: Sequence[float] = (0.05, 0.05, 0.04),
    param_std0: Sequence[float],
    q_param_std: Sequence[float],
    q_pose_std: Sequence[float] = (0.01, 0.01, 0.005),
    pose0=None,
    pose_std0: Sequence[float] | None = None,
    step: str = "midpoint",
    param_bounds: Sequence[tuple[float, float]] | None = None,
    name: str = "pose_param_ekf",
) -> FilterResult:
    """Run the pose-augmented EKF over a drive (see module docstring).

    Args:
        model: the kinematic model; its parameters are the initial guess p₀.
        t: (N,) sample times [s]; v_left, v_right: (N,) commands [m/s], held over [t_k, t_{k+1}).
        pose_meas: (N, 3) measured world pose [m, m, rad] or None; twist_meas: (N, 3) measured
            body twist [m/s, m/s, rad/s] or None. At least one is required.
        param_std0: (P,) std of the initial parameter guess; q_param_std: (P,) random-walk
            intensity [unit/√s]; q_pose_std: (3,) pose process noise [m/√s, m/√s, rad/√s].
        pose0: (3,) initial pose (default: the first pose measurement, else 0);
            pose_std0: its std (default: ``pose_std``).
        step: "midpoint" (default) or "euler" (the thesis's (3.11)).
        param_bounds: optional (P,) (low, high) per parameter: after each update the estimate is
            projected (clipped) into the box — the standard estimate-projection treatment of
            hard parameter constraints, for parameters outside of which the model is undefined
            (e.g. MPP's |alpha| < pi/2). The number of projected steps is in ``info``.
    Returns:
        :class:`FilterResult` of N−1 steps (t[1:]); states (x, y, theta, *model.param_names);
        measurements: pose and/or twist components.
    """
    t, vl, vr, pm, tm = check_inputs(t, v_left, v_right, pose_meas, twist_meas)
    if step not in ("euler", "midpoint"):
        raise InputError(f"{name}: step must be 'euler' or 'midpoint', got {step!r}")
    if pm is None and tm is None:
        raise InputError(f"{name}: needs pose_meas and/or twist_meas")
    p0 = np.asarray(model.params, dtype=float)
    P_ = p0.size
    if pose0 is None:
        pose0 = pm[0] if pm is not None and not np.any(np.isnan(pm[0])) else np.zeros(3)
    pose_std0 = pose_std if pose_std0 is None else pose_std0
    s = np.concatenate([np.asarray(pose0, dtype=float), p0])
    P = np.diag(np.concatenate([np.asarray(pose_std0, float) ** 2, np.asarray(param_std0, float) ** 2]))
    q2 = np.concatenate([np.asarray(q_pose_std, float) ** 2, np.asarray(q_param_std, float) ** 2])
    meas_names, r_std, zs = [], [], []
    if pm is not None:
        meas_names += list(POSE_NAMES)
        r_std += list(pose_std)
        zs.append(pm)
    if tm is not None:
        meas_names += list(TWIST_NAMES)
        r_std += list(twist_std)
        zs.append(tm)
    Z = np.hstack(zs)
    R_full = np.diag(np.asarray(r_std, float) ** 2)
    meas_angles = (2,) if pm is not None else ()
    hist = History(3 + P_, len(meas_names))
    if param_bounds is not None:
        bounds = np.asarray(param_bounds, dtype=float)
        if bounds.shape != (P_, 2) or np.any(bounds[:, 0] >= bounds[:, 1]):
            raise InputError(f"{name}: param_bounds must be {P_} (low, high) pairs with low < high")
    projected = 0
    for k in range(1, t.size):
        dt = t[k] - t[k - 1]
        fs, F = transition(model, s, vl[k - 1], vr[k - 1], dt, step=step)
        s_pr, P_pr = predict(s, P, fs, F, np.diag(q2 * dt))
        h, H = measurement(model, s_pr, vl[k], vr[k], pose=pm is not None, twist=tm is not None)
        mask = ~np.isnan(Z[k])
        if mask.any():
            ang = [i for i in meas_angles if mask[i]]
            ang = [int(np.sum(mask[:i])) for i in ang]
            s, P, e, S, K = update(s_pr, P_pr, Z[k, mask], h[mask], H[mask], R_full[np.ix_(mask, mask)], angle_idx=ang)
            if param_bounds is not None:
                clipped = np.clip(s[3:], bounds[:, 0], bounds[:, 1])
                if np.any(clipped != s[3:]):
                    projected += 1
                    s = np.concatenate([s[:3], clipped])
            hist.add(t[k], s_pr, P_pr, s, P, Z[k], h, mask, e, S, K)
        else:
            s, P = s_pr, P_pr
            hist.add(t[k], s_pr, P_pr, s, P, Z[k], h)
    return hist.result(name, POSE_NAMES + tuple(model.param_names), meas_names, state_angles=(2,),
                       meas_angles=meas_angles, info={"model": model.name, "projected_steps": projected})
