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

Noise units: measurement noise as standard deviations ``*_std`` [m, m, rad, m/s, m/s, rad/s];
process noise as random-walk intensities ``q_*_std`` [unit/√s], Q = diag(q²)·Δt, so the result
does not depend on the sampling rate.

Derivation and measurements: docs/theory/filters.md, "Pose EKF: bias and adaptivity".
"""

from __future__ import annotations

import logging
from typing import Sequence

import numpy as np

from mjtrack.errors import InputError
from mjtrack.estimation.common import FilterResult, History, check_inputs, predict, residual, update
from mjtrack.estimation.imm import IMMSettings, combine, imm_settings, log_likelihood, mix, posterior_probabilities
from mjtrack.estimation.model_error import CovarianceMatching, ModelErrorSettings, model_error_settings, scale_param_block
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
    if not hs:
        return np.zeros(0), np.zeros((0, n))
    return np.concatenate(hs), np.vstack(Hs)


class PoseParamFilter:
    """One pose-augmented parameter filter advanced a step at a time (single EKF or IMM pair).

    Used by :func:`run_pose_param_ekf` (batch) and :class:`~mjtrack.estimation.online.OnlineICREstimator`
    (online), so both run the same arithmetic.

    Args:
        model: the kinematic model (its parameters are not used: the state carries them).
        s0: (3 + P,) initial state; P0: its covariance.
        q2: (3 + P,) process-noise intensities squared [unit²/s] (Q = diag(q2)·Δt).
        step: "midpoint" or "euler".
        adaptive: None, "imm" or :class:`~mjtrack.estimation.imm.IMMSettings`.
        param_bounds: optional (P, 2) box the parameters are projected into after each update.
        model_error: None, True/"matching" or :class:`~mjtrack.estimation.model_error.ModelErrorSettings`:
            before each prediction the parameter covariance is scaled by the covariance-matching
            factor λ ≥ 1 of :mod:`mjtrack.estimation.model_error`, found from the twist innovations
            (None: no scaling; without a twist measurement λ stays 1).
        twist_inverse: optional ``f(twist (3,), v_left, v_right) -> params (P,) or None``, the
            model's parameters that produce a given twist (None where they are not defined); with
            ``model_error.restart_after_s`` the filter restarts its parameters from it when the
            twist innovations have stayed too large that long (:mod:`~mjtrack.estimation.model_error`).
        param_var_max: (P,) variances the model-error term never scales a parameter above (its
            restart is capped there too); None: no cap.
    """

    def __init__(self, model: KinematicModel, s0, P0, q2, *, step: str = "midpoint", adaptive=None,
                 param_bounds=None, model_error=None, twist_inverse=None, param_var_max=None):
        self.model = model
        self.step_kind = step
        self.imm: IMMSettings | None = imm_settings(adaptive)
        self.model_error: ModelErrorSettings | None = model_error_settings(model_error)
        self._me = None if self.model_error is None else CovarianceMatching(self.model_error)
        self.twist_inverse = twist_inverse
        self.param_var_max = None if param_var_max is None else np.asarray(param_var_max, float)
        self.restarts = 0
        self.q2 = np.asarray(q2, float)
        self.bounds = None if param_bounds is None else np.asarray(param_bounds, float)
        self.projected = 0
        self._noise_mix = 1.0
        self.reset(s0, P0)

    def reset(self, s0, P0, mode_prob=None) -> None:
        """Restart from (s0, P0); mode probabilities from ``mode_prob`` or the IMM prior."""
        s0, P0 = np.asarray(s0, float).copy(), np.asarray(P0, float).copy()
        self.s, self.P = s0, P0
        self.u_last = None
        self._recent: list[tuple[float, np.ndarray, np.ndarray]] = []  # (dt, twist z, u) of the last steps
        self._innov: list[tuple[float, np.ndarray]] = []  # (dt, twist innovation / √S_ii) while the gate is open
        if self._me is not None:
            self._me.reset()
        if self.imm is not None:
            self.xs, self.Ps = [s0.copy(), s0.copy()], [P0.copy(), P0.copy()]
            self.mu = np.asarray(self.imm.prior if mode_prob is None else mode_prob, float).copy()

    def _q2(self, mode: int) -> np.ndarray:
        if mode == 0:
            return self.q2
        q2 = self.q2.copy()
        q2[3:] *= self.imm.fast_factor**2
        return q2

    def _project(self, s: np.ndarray) -> np.ndarray:
        if self.bounds is None:
            return s
        clipped = np.clip(s[3:], self.bounds[:, 0], self.bounds[:, 1])
        if np.any(clipped != s[3:]):
            self.projected += 1
            return np.concatenate([s[:3], clipped])
        return s

    def _one(self, s, P, q2, dt, u_pred, u_meas, z, R, pose, twist, mask, ang):
        fs, F = transition(self.model, s, u_pred[0], u_pred[1], dt, step=self.step_kind)
        s_pr, P_pr = predict(s, P, fs, F, np.diag(q2 * dt))
        h, H = measurement(self.model, s_pr, u_meas[0], u_meas[1], pose=pose, twist=twist)
        if not mask.any():
            return s_pr, P_pr, h, s_pr, P_pr, None
        s1, P1, e, S, K = update(s_pr, P_pr, z[mask], h[mask], H[mask], R[np.ix_(mask, mask)], angle_idx=ang)
        return s_pr, P_pr, h, self._project(s1), P1, (e, S, K)

    def step(self, dt: float, u_pred, u_meas, z, R, *, pose: bool, twist: bool, meas_angles=()):
        """Advance by ``dt`` [s] with command ``u_pred`` held, update with ``z`` (NaN: missing).

        ``u_meas`` is the command at which a twist measurement is predicted; R the (m, m) noise
        covariance of the full measurement vector (pose and/or twist components).
        Returns (s_prior, P_prior, z_pred, mask, (e, S, K) or None); the posterior is ``self.s, self.P``.
        """
        z = np.asarray(z, float)
        mask = ~np.isnan(z)
        ang = [int(np.sum(mask[:i])) for i in meas_angles if mask[i]]
        if self._me is not None and self._me.factor() > 1.0:
            lam, which = self._me.factor(), self.model_error.params
            cap = self.param_var_max
            if self.imm is None:
                self.P = scale_param_block(self.P, lam, params=which, var_max=cap)
            else:
                self.Ps = [scale_param_block(Pj, lam, params=which, var_max=cap) for Pj in self.Ps]
        out = self._step(dt, u_pred, u_meas, z, R, pose, twist, mask, ang)
        if self._me is not None and twist and out[4] is not None:
            e, S, _ = out[4]
            tw = np.zeros(z.size, bool)
            tw[z.size - 3:] = True
            sel = tw[mask]  # twist components among those present
            noise = 1.0 if self.imm is None else self._noise_mix
            self._me.observe(dt, e[sel], S[np.ix_(sel, sel)], np.diag(np.asarray(R, float))[mask][sel], noise)
            if self.model_error.restart_after_s is not None and self.twist_inverse is not None:
                en = e[sel] / np.sqrt(np.diag(S)[sel])
                if self._me.gate_open and en.size == 3:
                    self._innov.append((dt, en))
                else:
                    self._innov = []
                self._maybe_restart(dt, z[z.size - 3:], u_meas, np.diag(np.asarray(R, float))[z.size - 3:])
        return out

    def _maybe_restart(self, dt: float, zt: np.ndarray, u, r_tw: np.ndarray) -> None:
        """Restart the parameters from the inverse of the recent mean twist (model_error docstring)."""
        me = self.model_error
        self._recent.append((dt, np.asarray(zt, float), np.asarray(u, float)))
        total = 0.0
        for i in range(len(self._recent) - 1, -1, -1):
            total += self._recent[i][0]
            if total >= me.restart_window_s - 1e-9:
                self._recent = self._recent[i:]
                break
        if self._me.open_s < me.restart_after_s - 1e-9 or total < me.restart_window_s - 1e-9:
            return
        # a misfit of the parameters biases the innovations; a measurement noise larger than R does not
        en = np.array([r[1] for r in self._innov])
        if len(en) < 3:
            return
        tstat = np.abs(en.mean(0)) / np.maximum(en.std(0, ddof=1), 1e-12) * np.sqrt(len(en))
        if tstat.max() < me.restart_t:
            return
        zs = np.array([r[1] for r in self._recent])
        us = np.array([r[2] for r in self._recent])
        if not np.all(np.isfinite(zs)) or np.ptp(us, axis=0).max() > me.steady_tol:
            return
        u_mean = us.mean(0)
        p = self.twist_inverse(zs.mean(0), u_mean[0], u_mean[1])
        if p is None:
            return
        p = np.asarray(p, float)
        if self.bounds is not None:
            p = np.clip(p, self.bounds[:, 0], self.bounds[:, 1])
        J = self.model.with_params(p).twist_jacobian(u_mean[0], u_mean[1])
        try:
            Jinv = np.linalg.inv(J)
        except np.linalg.LinAlgError:
            return
        Pp = Jinv @ np.diag(r_tw) @ Jinv.T / len(self._recent)
        if not np.all(np.isfinite(Pp)) or not np.all(np.isfinite(p)):
            return
        if self.param_var_max is not None:  # no more uncertain than a fresh start
            sd = np.sqrt(np.diag(Pp))
            f = np.minimum(1.0, np.sqrt(self.param_var_max) / np.where(sd > 0, sd, 1.0))
            Pp = Pp * np.outer(f, f)

        def restart(s, P):
            s, P = s.copy(), P.copy()
            s[3:] = p
            P[3:, :] = 0.0
            P[:, 3:] = 0.0
            P[3:, 3:] = 0.5 * (Pp + Pp.T)
            return s, P

        if self.imm is None:
            self.s, self.P = restart(self.s, self.P)
        else:
            for j in range(len(self.xs)):
                self.xs[j], self.Ps[j] = restart(self.xs[j], self.Ps[j])
            self.s, self.P = combine(self.xs, self.Ps, self.mu)
        self._me.reset()
        self._recent = []
        self._innov = []
        self.restarts += 1

    @property
    def param_cov_factor(self) -> float | None:
        """λ of the model-error term for the next step (None without one)."""
        return None if self._me is None else self._me.factor()

    def _step(self, dt, u_pred, u_meas, z, R, pose, twist, mask, ang):
        if self.imm is None:
            s_pr, P_pr, h, self.s, self.P, upd = self._one(self.s, self.P, self.q2, dt, u_pred, u_meas, z, R, pose,
                                                          twist, mask, ang)
            return s_pr, P_pr, h, mask, upd
        u_now = np.asarray(u_pred, float)
        du = 0.0 if self.u_last is None else float(np.hypot(*(u_now - self.u_last)))
        self.u_last = u_now
        pi = self.imm.transition_matrix(dt, du)
        x0, P0, cbar = mix(self.xs, self.Ps, self.mu, pi)
        Rs = (R, R * self.imm.fast_meas_factor**2)
        self._noise_mix = float(cbar[0] + cbar[1] * self.imm.fast_meas_factor**2)  # noise part of the mixed S
        outs = [self._one(x0[j], P0[j], self._q2(j), dt, u_pred, u_meas, z, Rs[j], pose, twist, mask, ang)
                for j in range(2)]
        s_pr, P_pr = combine([o[0] for o in outs], [o[1] for o in outs], cbar)
        hs = [o[2] for o in outs]
        h = sum(c * hj for c, hj in zip(cbar, hs))
        self.xs, self.Ps = [o[3] for o in outs], [o[4] for o in outs]
        if not mask.any():
            self.mu = cbar
            self.s, self.P = combine(self.xs, self.Ps, self.mu)
            return s_pr, P_pr, h, mask, None
        self.mu = posterior_probabilities([log_likelihood(o[5][0], o[5][1]) for o in outs], cbar)
        self.s, self.P = combine(self.xs, self.Ps, self.mu)
        hm = [hj[mask] for hj in hs]
        e = residual(z[mask], h[mask], ang)
        dh = [residual(hj, h[mask], ang) for hj in hm]
        S = sum(c * (o[5][1] + np.outer(d, d)) for c, o, d in zip(cbar, outs, dh))
        K = sum(m * o[5][2] for m, o in zip(self.mu, outs))
        return s_pr, P_pr, h, mask, (e, 0.5 * (S + S.T), K)


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
    adaptive=None,
    param_cov0=None,
    model_error=None,
    twist_inverse=None,
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
        param_bounds: optional (P,) (low, high) per parameter: each update is clipped into the box
            (e.g. MPP's |alpha| < pi/2); ``info`` counts the projected steps.
        adaptive: None (one EKF), "imm" or an :class:`~mjtrack.estimation.imm.IMMSettings`
            (slow/fast IMM pair, :mod:`mjtrack.estimation.imm`); the result's ``mode_prob``
            holds P(fast) per step.
        param_cov0: optional (P, P) initial parameter covariance (overrides ``param_std0``; used to
            carry a filter's estimate from one window of a log to the next).
        model_error: None, True/"matching" or a :class:`~mjtrack.estimation.model_error.ModelErrorSettings`:
            the parameter covariance scaled by the matching factor λ ≥ 1 when the twist innovations
            exceed S; ``info["model_error"]`` counts inflated steps and restarts.
        twist_inverse: optional ``f(twist, v_left, v_right) -> params or None`` (the model's
            inverse) for the restart of :mod:`mjtrack.estimation.model_error`.
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
    if param_cov0 is not None:
        P[3:, 3:] = np.asarray(param_cov0, float)
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
    bounds = None
    if param_bounds is not None:
        bounds = np.asarray(param_bounds, dtype=float)
        if bounds.shape != (P_, 2) or np.any(bounds[:, 0] >= bounds[:, 1]):
            raise InputError(f"{name}: param_bounds must be {P_} (low, high) pairs with low < high")
    filt = PoseParamFilter(model, s, P, q2, step=step, adaptive=adaptive, param_bounds=bounds, model_error=model_error,
                           twist_inverse=twist_inverse, param_var_max=np.asarray(param_std0, float) ** 2)
    lam_n = 0
    for k in range(1, t.size):
        if filt.model_error is not None:
            lam_n += int(filt.param_cov_factor > 1.0)
        s_pr, P_pr, h, mask, upd = filt.step(t[k] - t[k - 1], (vl[k - 1], vr[k - 1]), (vl[k], vr[k]), Z[k], R_full,
                                             pose=pm is not None, twist=tm is not None, meas_angles=meas_angles)
        mode = None if filt.imm is None else filt.mu[1]
        if upd is None:
            hist.add(t[k], s_pr, P_pr, filt.s, filt.P, Z[k], h, mode_prob=mode)
        else:
            hist.add(t[k], s_pr, P_pr, filt.s, filt.P, Z[k], h, mask, *upd, mode_prob=mode)
    info = {"model": model.name, "projected_steps": filt.projected}
    if filt.imm is not None:
        info["adaptive"] = {"kind": "imm", **filt.imm.to_dict()}
    if filt.model_error is not None:
        info["model_error"] = {**filt.model_error.to_dict(), "inflated_steps": lam_n, "restarts": filt.restarts}
    return hist.result(name, POSE_NAMES + tuple(model.param_names), meas_names, state_angles=(2,),
                       meas_angles=meas_angles, info=info)
