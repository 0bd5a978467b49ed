"""Virtual-robot (MVIR) centre estimation, eqs. (3.23)–(3.31), and a stable replacement.

Conventions (:mod:`mjtrack.icr`): the virtual robot has centre O' = (x_o, y_o) in the robot
frame and wheel distance T_v, x_o = −v_y/ω, y_o = (v_x − V̄)/ω, T_v = (V_R − V_L)/ω with
V̄ = (V_L + V_R)/2; its wheels sit on the track ICRs.

**Unit sphere (3.23)–(3.26), signs corrected.** (x_o, y_o, 1) = (−v_y, v_x − V̄, ω)/ω, so the
point of the unit sphere on the ray through (x_o, y_o, 1) is

    S = (−v_y, v_x − V̄, ω)/l,   l = √((v_x − V̄)² + v_y² + ω²),   x_o = S_x/S_z, y_o = S_y/S_z,

with S_z of the sign of ω (the thesis's two tangent planes, fig. 3.1: one hemisphere per turn
direction; the ratio is the same on both). The printed (3.23) has S_x = v_y/l and
S_y = (V_R + V_L − 2v_x)/l, which through (3.25) give x_o = +v_y/ω and y_o = −2·(the correct
y_o): sign and factor defects, corrected here so that only the filter's own behaviour is
compared. Inverting, (3.27) becomes v_x = V̄ + l S_y, v_y = −l S_x, ω = l S_z.

Derivation and measurements: docs/theory/filters.md, "Virtual-robot filters".
"""

from __future__ import annotations

import logging
from typing import Literal, Sequence

import numpy as np

from mjtrack.errors import InputError, SingularMotionError
from mjtrack.estimation.common import FilterResult, History, check_inputs, predict, update
from mjtrack.estimation.icr_ekf import InverseICR
from mjtrack.estimation.pose_ekf import run_pose_param_ekf
from mjtrack.icr import centre_from_sphere, sphere_from_centre

log = logging.getLogger(__name__)

THESIS_STATE_NAMES = ("vx", "vy", "wz", "Sx", "Sy", "Sz")
_M = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
L_MIN = 1e-9  # below this l the sphere point is undefined (nominal straight motion)


def sphere_from_twist(vx, vy, wz, v_left, v_right) -> np.ndarray:
    """Signed-hemisphere sphere point S (..., 3) of a motion (module docstring)."""
    vb = 0.5 * (np.asarray(v_left, float) + np.asarray(v_right, float))
    u = np.stack(np.broadcast_arrays(-np.asarray(vy, float), np.asarray(vx, float) - vb, np.asarray(wz, float)), -1)
    n = np.linalg.norm(u, axis=-1, keepdims=True)
    if np.any(n < L_MIN):
        raise SingularMotionError("sphere point undefined: the motion is nominal straight driving (l = 0)")
    return u / n


def thesis_transition(s: np.ndarray, v_bar: float, dt: float, *, transition: str):
    """f and F of the thesis's filter; ``transition`` "printed" (3.28) or "intended"."""
    F = np.eye(6)
    fs = s.copy()
    if transition == "printed":
        fs[:3] = dt * s[:3]
        F[:3, :3] = dt * np.eye(3)
        return fs, F
    d = np.array([s[0] - v_bar, s[1], s[2]])
    l = float(np.linalg.norm(d))
    if l < L_MIN:
        raise SingularMotionError("vir_thesis: l = 0, the sphere point is undefined")
    S = s[3:]
    fs[:3] = np.array([v_bar, 0.0, 0.0]) + l * (_M @ S)
    F[:3, :3] = np.outer(_M @ S, d / l)
    F[:3, 3:] = l * _M
    return fs, F


def run_vir_thesis(
    t,
    v_left,
    v_right,
    *,
    twist_meas,
    transition: Literal["printed", "intended"] = "printed",
    twist_std: Sequence[float] = (0.05, 0.05, 0.04),
    S0: Sequence[float] | None = None,
    S_std0: float = 0.5,
    q_v_std: Sequence[float] = (0.05, 0.05, 0.05),
    q_S_std: float = 0.02,
) -> FilterResult:
    """The thesis's virtual-robot EKF (module docstring); states (vx, vy, wz, Sx, Sy, Sz).

    Args:
        t: (N,) [s]; v_left, v_right: (N,) [m/s]; twist_meas: (N, 3) measured body twist.
        transition: "printed" ((3.28) as printed) or "intended" (velocity through (3.27)).
        S0: initial sphere point (default: the real centre, S = (0, 0, 1)); S_std0: its std.
        q_v_std: velocity random-walk intensity [m/s/√s, m/s/√s, rad/s/√s]; q_S_std [1/√s].
    """
    t, vl, vr, tm = check_inputs(t, v_left, v_right, twist_meas)
    if transition not in ("printed", "intended"):
        raise InputError(f"vir_thesis: transition must be 'printed' or 'intended', got {transition!r}")
    S0 = sphere_from_centre(0.0, 0.0) if S0 is None else np.asarray(S0, float)
    s = np.concatenate([np.where(np.isnan(tm[0]), 0.0, tm[0]), S0])
    P = np.diag(np.concatenate([np.asarray(twist_std, float) ** 2, np.full(3, S_std0**2)]))
    q2 = np.concatenate([np.asarray(q_v_std, float) ** 2, np.full(3, q_S_std**2)])
    R = np.diag(np.asarray(twist_std, float) ** 2)
    H = np.eye(3, 6)
    hist = History(6, 3)
    for k in range(1, t.size):
        dt = t[k] - t[k - 1]
        fs, F = thesis_transition(s, 0.5 * (vl[k - 1] + vr[k - 1]), dt, transition=transition)
        s_pr, P_pr = predict(s, P, fs, F, np.diag(q2 * dt))
        mask = ~np.isnan(tm[k])
        if mask.any():
            s, P, e, S, K = update(s_pr, P_pr, tm[k, mask], s_pr[:3][mask], H[mask], R[np.ix_(mask, mask)])
            hist.add(t[k], s_pr, P_pr, s, P, tm[k], s_pr[:3], mask, e, S, K)
        else:
            s, P = s_pr, P_pr
            hist.add(t[k], s_pr, P_pr, s, P, tm[k], s_pr[:3])
    return hist.result(f"vir_thesis_{transition}", THESIS_STATE_NAMES, ("vx", "vy", "wz"), info={"transition": transition})


def centre_from_thesis_state(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(x_o, y_o) [m] from states (..., 6) of :func:`run_vir_thesis` (ratio of S; S_z = 0 raises)."""
    return centre_from_sphere(np.asarray(x, float)[..., 3:])


def virtual_from_psi(psi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x_o, y_o, T_v) [m] from ψ (..., 3) of :func:`run_vir_filter`; ψ_z = 0 raises."""
    psi = np.asarray(psi, float)
    if np.any(psi[..., 2] == 0):
        raise SingularMotionError("virtual robot at infinity: psi_z == 0")
    return psi[..., 0] / psi[..., 2], psi[..., 1] / psi[..., 2], 1.0 / psi[..., 2]


def sphere_from_psi(psi: np.ndarray) -> np.ndarray:
    """The unit-sphere point S = ψ/|ψ| (..., 3) of the thesis, S_z of the sign of ψ_z."""
    psi = np.asarray(psi, float)
    return psi / np.linalg.norm(psi, axis=-1, keepdims=True)


def run_vir_filter(
    t,
    v_left,
    v_right,
    *,
    track_gauge: float,
    twist_meas=None,
    pose_meas=None,
    pose_std: Sequence[float] = (0.1, 0.1, np.radians(2.0)),
    twist_std: Sequence[float] = (0.05, 0.05, 0.04),
    centre0: Sequence[float] = (0.0, 0.0),
    psi_std0: Sequence[float] = (2.0, 2.0, 4.0),
    q_psi_std: Sequence[float] = (1e-3, 1e-3, 1e-3),
    q_pose_std: Sequence[float] = (1e-3, 1e-3, 1e-3),
    pose0=None,
    adaptive=None,
    psi0: Sequence[float] | None = None,
    psi_cov0=None,
) -> FilterResult:
    """Stable virtual-robot filter on ψ = (x_o, y_o, 1)/T_v (module docstring).

    Args:
        track_gauge: T [m], the initial T_v; centre0: initial (x_o, y_o) [m].
        twist_meas / pose_meas: (N, 3) measured body twist / world pose (at least one).
        psi_std0: std of the initial ψ; q_psi_std: its random-walk intensity [unit/√s].
        adaptive: None, "imm" or :class:`~mjtrack.estimation.imm.IMMSettings` (as
            :func:`~mjtrack.estimation.icr_ekf.run_icr_ekf`); psi0, psi_cov0: initial ψ and its
            covariance, overriding ``centre0`` / ``psi_std0``.
    Returns:
        :class:`FilterResult` with states (x, y, theta, psi_x, psi_y, psi_z); use
        :func:`virtual_from_psi` for (x_o, y_o, T_v).
    """
    model = InverseICR(centre0[0] / track_gauge, centre0[1] / track_gauge, 1.0 / track_gauge)
    if psi0 is not None:
        model = InverseICR(*np.asarray(psi0, float))
    return run_pose_param_ekf(
        model, t, v_left, v_right, pose_meas=pose_meas, twist_meas=twist_meas, pose_std=pose_std,
        twist_std=twist_std, param_std0=psi_std0, q_param_std=q_psi_std, q_pose_std=q_pose_std, pose0=pose0,
        name="vir_filter", adaptive=adaptive, param_cov0=psi_cov0,
    )
