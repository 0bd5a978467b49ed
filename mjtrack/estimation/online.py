"""Step-by-step (online) ICR / virtual-robot estimation for use inside a control loop.

The batch filters (:func:`~mjtrack.estimation.icr_ekf.run_icr_ekf`,
:func:`~mjtrack.estimation.vir_filter.run_vir_filter`) run the pose-augmented EKF of
:mod:`mjtrack.estimation.pose_ekf` over a whole log. A controller needs the estimate *now*:
:class:`OnlineICREstimator` holds the EKF state s = (x, y, θ, ψ_x, ψ_y, ψ_z) and advances it
one measurement at a time with the same transition and measurement functions
(:func:`~mjtrack.estimation.pose_ekf.transition`, :func:`~mjtrack.estimation.pose_ekf.measurement`)
and the same predict/update (:mod:`mjtrack.estimation.common`), so a sequence of
:meth:`OnlineICREstimator.step` calls reproduces the batch filter exactly (tested).

ψ = (x_c, ȳ, 1)/(y_l − y_r) is the linear parametrisation of the MICR/MVIR twist
(:class:`~mjtrack.estimation.icr_ekf.InverseICR`): v_x = V̄ + ψ_y ΔV, v_y = −ψ_x ΔV,
ω = ψ_z ΔV, with V̄ = (V_L + V_R)/2 and ΔV = V_R − V_L. The ICRs are y_l,r = (ψ_y ± ½)/ψ_z,
x_c = ψ_x/ψ_z and the virtual robot x_o = x_c, y_o = ψ_y/ψ_z, T_v = 1/ψ_z.

Timing convention of :meth:`step`: ``v_left, v_right`` is the command held over the interval
that ended at ``t`` (u_{k−1} in (3.6)); it drives the prediction from the previous step and is
the command at which the measured twist at ``t`` is predicted (in a zero-order-hold loop the
twist measured at t_k is produced by u_{k−1}). The batch filter predicts with the command of
sample k−1 but predicts the twist of sample k with the command of sample k; with
piecewise-constant commands the two conventions differ only at the samples where the command
changes, and with pose measurements alone they coincide (tested: identical states).
"""

from __future__ import annotations

import logging
from typing import Sequence

import numpy as np

from mjtrack.errors import InputError
from mjtrack.estimation.icr_ekf import InverseICR, icr_from_psi
from mjtrack.estimation.imm import IMMSettings, imm_settings
from mjtrack.estimation.pose_ekf import PoseParamFilter

log = logging.getLogger(__name__)

Q_PSI_STD = (0.01, 0.01, 0.01)  # [unit/sqrt(s)] random walk of the single EKF (default)
# adaptive="imm": slow mode 1e-3, fast mode 300x that (0.3 /sqrt(s)) -- the batch filters' IMM
# (mjtrack.estimation.imm); the slow mode keeps the estimate still between ground changes
Q_PSI_STD_IMM = (1e-3, 1e-3, 1e-3)
ONLINE_IMM = IMMSettings()


class OnlineICREstimator:
    """Online pose-augmented EKF on ψ (module docstring); one :meth:`step` per measurement.

    Args:
        track_gauge: T [m]; the initial guess is the nominal robot (ψ = (0, 0, 1/T)) unless
            ``icr0`` = (y_l, y_r, x_c) [m] is given.
        pose_std, twist_std: measurement noise std [m, m, rad] / [m/s, m/s, rad/s].
        psi_std0: std of the initial ψ [-, -, 1/m]; q_psi_std: its random-walk intensity
            [unit/√s] (default 0.01; with ``adaptive`` the slow mode's, default 1e-3); q_pose_std: pose process noise [m/√s, m/√s, rad/√s].
        step: "midpoint" or "euler" pose prediction (see pose_ekf).
        adaptive: None (one EKF with ``q_psi_std``, the default), "imm" or an
            :class:`~mjtrack.estimation.imm.IMMSettings`: a slow/fast IMM pair whose slow mode
            has ``q_psi_std`` (:mod:`mjtrack.estimation.imm`) — recovers within about a second
            from a change of the ground while staying smooth when nothing changes.
    """

    state_names = ("x", "y", "theta", "psi_x", "psi_y", "psi_z")

    def __init__(
        self,
        track_gauge: float,
        *,
        icr0: Sequence[float] | None = None,
        pose_std: Sequence[float] = (0.01, 0.01, 0.01),
        twist_std: Sequence[float] = (0.02, 0.02, 0.02),
        psi_std0: Sequence[float] = (2.0, 2.0, 4.0),
        q_psi_std: Sequence[float] | None = None,
        q_pose_std: Sequence[float] = (1e-3, 1e-3, 1e-3),
        step: str = "midpoint",
        adaptive=None,
    ) -> None:
        if not track_gauge > 0:
            raise InputError(f"OnlineICREstimator: track_gauge must be positive, got {track_gauge!r}")
        if step not in ("midpoint", "euler"):
            raise InputError(f"OnlineICREstimator: step must be 'midpoint' or 'euler', got {step!r}")
        self.track_gauge = float(track_gauge)
        self.model = InverseICR.nominal(track_gauge) if icr0 is None else InverseICR.from_icr(*icr0)
        self.pose_std = np.asarray(pose_std, float)
        self.twist_std = np.asarray(twist_std, float)
        self.psi_std0 = np.asarray(psi_std0, float)
        imm = imm_settings(adaptive, ONLINE_IMM)
        if q_psi_std is None:
            q_psi_std = Q_PSI_STD if imm is None else Q_PSI_STD_IMM
        self.q2 = np.concatenate([np.asarray(q_pose_std, float) ** 2, np.asarray(q_psi_std, float) ** 2])
        self.step_kind = step
        self.t: float | None = None
        self.filter = PoseParamFilter(self.model, np.zeros(6), np.eye(6), self.q2, step=step, adaptive=imm)
        self.n_updates = 0

    @property
    def s(self) -> np.ndarray:
        """Current state (x, y, θ, ψ_x, ψ_y, ψ_z)."""
        return self.filter.s

    @property
    def P(self) -> np.ndarray:
        """Current state covariance (6, 6)."""
        return self.filter.P

    @property
    def mode_prob(self) -> float | None:
        """Probability of the fast mode (adaptive estimator), else None."""
        return None if self.filter.imm is None else float(self.filter.mu[1])

    def reset(self, t: float, pose) -> None:
        """Start at time ``t`` [s] from a measured ``pose`` (3,) with the initial ψ guess."""
        self.t = float(t)
        self.filter.reset(np.concatenate([np.asarray(pose, float).reshape(3), self.model.params]),
                          np.diag(np.concatenate([self.pose_std**2, self.psi_std0**2])))
        self.n_updates = 0

    def step(self, t: float, v_left: float, v_right: float, *, pose=None, twist=None) -> None:
        """Predict to ``t`` with the command held since the last step, then update.

        Args:
            t: time [s] (> the previous step's).
            v_left, v_right: track speeds [m/s] held over the interval ending at t.
            pose: (3,) measured pose or None; twist: (3,) measured body twist or None.
                NaN components are skipped.
        """
        if self.t is None:
            raise InputError("OnlineICREstimator: call reset(t, pose) first")
        dt = float(t) - self.t
        if not dt > 0:
            raise InputError(f"OnlineICREstimator: time must increase (t = {t}, previous {self.t})")
        self.t = float(t)
        has_pose, has_twist = pose is not None, twist is not None
        z = np.concatenate([np.asarray(a, float).reshape(3) for a in (pose, twist) if a is not None]) \
            if (has_pose or has_twist) else np.zeros(0)
        r_std = np.concatenate([a for a, given in ((self.pose_std, has_pose), (self.twist_std, has_twist)) if given]) \
            if (has_pose or has_twist) else np.zeros(0)
        u = (v_left, v_right)
        *_, upd = self.filter.step(dt, u, u, z, np.diag(r_std**2), pose=has_pose, twist=has_twist,
                                   meas_angles=(2,) if has_pose else ())
        self.n_updates += upd is not None

    @property
    def psi(self) -> np.ndarray:
        """Current ψ (3,) [-, -, 1/m]."""
        return self.s[3:].copy()

    @property
    def psi_cov(self) -> np.ndarray:
        """Current covariance of ψ (3, 3)."""
        return self.P[3:, 3:].copy()

    def icr(self) -> tuple[float, float, float]:
        """Current (y_l, y_r, x_c) [m]; ψ_z = 0 (ICRs at infinity) gives infinities."""
        px, py, pz = self.s[3:]
        with np.errstate(divide="ignore", invalid="ignore"):
            return float((py + 0.5) / pz), float((py - 0.5) / pz), float(px / pz)

    def virtual_robot(self) -> tuple[float, float, float]:
        """Current (x_o, y_o, T_v) [m] of the virtual wheeled robot."""
        px, py, pz = self.s[3:]
        with np.errstate(divide="ignore", invalid="ignore"):
            return float(px / pz), float(py / pz), float(1.0 / pz)


class KnownICR:
    """Known ICRs in the interface of :class:`OnlineICREstimator` (what
    :class:`~mjtrack.control.compensation.SlipCompensation` uses): ψ fixed, zero covariance.

    For studies of compensation with an exact or a borrowed estimate (e.g. the ICRs identified
    on another path): the compensation's trust rule still applies (with zero covariance its
    weight is the share κ of the nominal map's twist misfit the ICRs explain).

    Args:
        icr: (y_l, y_r, x_c) [m], y_l != y_r.
        twist_std: the twist noise std the trust rule normalises residuals by.
    """

    def __init__(self, icr: Sequence[float], *, twist_std: Sequence[float] = (0.02, 0.02, 0.02)) -> None:
        y_l, y_r, x_c = (float(a) for a in icr)
        if not (np.isfinite([y_l, y_r, x_c]).all() and y_l != y_r):
            raise InputError(f"KnownICR: need finite ICRs with y_l != y_r, got {tuple(icr)}")
        self.model = InverseICR.from_icr(y_l, y_r, x_c)
        self.twist_std = np.asarray(twist_std, float)
        self.t: float | None = None

    def reset(self, t: float, pose) -> None:
        self.t = float(t)

    def step(self, t: float, v_left: float, v_right: float, *, pose=None, twist=None) -> None:
        self.t = float(t)

    @property
    def psi(self) -> np.ndarray:
        return np.asarray(self.model.params, float).copy()

    @property
    def psi_cov(self) -> np.ndarray:
        return np.zeros((3, 3))

    def icr(self) -> tuple[float, float, float]:
        y_l, y_r, x_c = icr_from_psi(self.psi)
        return float(y_l), float(y_r), float(x_c)
