"""Slip-parameter EKF, eqs. (3.9)–(3.13) of the tracked-robot thesis.

State (3.9) q_e = (x, y, θ, s_L, s_R, α); the slips are a random walk (3.10)/(3.11); the pose
follows the Euler step (3.11) of the MPP model (2.9) (with the /2 of its first row, see
:mod:`mjtrack.models.kinematic`); the measurement is the pose (3.12), innovation (3.13) with the
yaw residual wrapped. This is :func:`~mjtrack.estimation.pose_ekf.run_pose_param_ekf` with the
MPP model: its Jacobian F (3.5) is written out there and uses ``MPP.twist_jacobian``:

    ∂ν/∂s_L = (−V_L/2,  V_L tan α / 2,  V_L/T),   ∂ν/∂s_R = (−V_R/2, V_R tan α / 2, −V_R/T),
    ∂ν/∂α   = (0, −v_x / cos² α, 0).

Observability: with pose measurements the filter sees v_x, v_y and ω through the pose
increments; (v_x, ω) fix the two actual track speeds, hence s_L and s_R whenever V_L, V_R ≠ 0,
and v_y = −v_x tan α fixes α whenever v_x ≠ 0. In straight driving with equal slips nothing is
lost either (the map (s_L, s_R) -> (v_x, ω) is invertible for V_L, V_R ≠ 0).

A twist measurement can be added (``twist_meas``); the thesis's filter uses the pose only.

Limits of the model, and how the filter survives them: MPP ties the lateral velocity to the
forward one, v_y = −v_x tan α. In a turn on the spot (v_x ≈ 0) a robot whose centre of gravity
is off the geometric centre still moves sideways, which MPP can only express with |α| → 90°,
where the model is undefined. The filter therefore projects α into
[−ALPHA_MAX, ALPHA_MAX] after each update (``info["projected_steps"]`` counts how often);
the residual lateral motion stays unexplained — a structural limit of MPP that the ICR and
virtual-robot models do not have.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from mjtrack.estimation.common import FilterResult
from mjtrack.estimation.imm import IMMSettings, imm_settings
from mjtrack.estimation.model_error import ModelErrorSettings
from mjtrack.estimation.pose_ekf import run_pose_param_ekf
from mjtrack.models import MPP

PARAM_NAMES = MPP.param_names  # ("s_left", "s_right", "alpha")
ALPHA_MAX = np.radians(85.0)  # [rad] bound of the slip angle estimate (MPP is undefined at 90 deg)
# IMM pair for adaptive="imm" (tuned on the default robot only, benchmarks/filter_consistency.py):
# the slips' fast mode is 100x the slow intensity (0.1 /sqrt(s), 5 deg/sqrt(s) on alpha at the
# defaults) with 3x the measurement std, and the pose process noise is smaller than the single
# EKF's (the fast mode, not the pose, absorbs what MPP does not describe)
SLIP_IMM = IMMSettings(fast_factor=100.0, fast_meas_factor=3.0)
Q_POSE_STD = (0.005, 0.005, 0.002)  # [m/sqrt(s), m/sqrt(s), rad/sqrt(s)] single EKF
Q_POSE_STD_IMM = (0.002, 0.002, 0.0008)  # with adaptive="imm"
# model-error term with adaptive="imm" (mjtrack.estimation.model_error; chosen on the two
# 'tuning' cases of benchmarks/filter_consistency.py only): the slips' covariance is matched to
# the twist innovations (0.5-s average, acting when the average NIS is 2.33 sigma above its mean),
# and when that gate stays open for 0.5 s the parameters restart from the inverse of the mean
# twist of the last 0.2 s (mpp_from_twist; tuning case NEES/dof 2.0-2.8 -> 1.2-1.5);
# alpha is left out of the matching (the restart sets it too): in a spin turn whose v_x changes sign MPP's alpha passes its pole (+-90 deg),
# and a freer alpha ran into the projection bound and stuck there, the slips compensating
# (tuning case, 3 noise seeds: alpha rmse 0.70 rad, parameter NEES/dof 233-244 with alpha matched
# as well; 230-250 also when alpha was matched only while |v_x| >= 0.1 or 0.2 m/s; with alpha
# matched and moved to the other end of the chart when that fits the twist better, 1.25 on one
# seed but still 226-238 on the other two: the slips turn v_x to +0.01 m/s to suit alpha = +85 deg)
SLIP_MODEL_ERROR = ModelErrorSettings(window_s=0.5, gate_z=2.33, params=(0, 1), restart_after_s=0.5,
                                      restart_window_s=0.2, steady_tol=0.02)
V_MIN = 0.05  # [m/s] |V_L|, |V_R|, |v_x| below which the MPP parameters of a twist are not defined


def mpp_from_twist(track_gauge: float, twist, v_left: float, v_right: float, *, v_min: float = V_MIN):
    """MPP's (s_L, s_R, α) that produce the body twist (v_x, v_y, ω) at track speeds (V_L, V_R).

    Inverse of (2.9): the actual track speeds are u_L,R = v_x ∓ ωT/2, so s = 1 − u/V, and
    tan α = −v_y/v_x. None where |V_L|, |V_R| or |v_x| < ``v_min`` (not defined there).
    """
    vx, vy, w = (float(a) for a in twist)
    if min(abs(v_left), abs(v_right), abs(vx)) < v_min:
        return None
    T = track_gauge
    return np.array([1.0 - (vx - w * T / 2) / v_left, 1.0 - (vx + w * T / 2) / v_right, np.arctan(-vy / vx)])
SLIP_MAX = 5.0  # [-] bound of the slip estimates (|s| > 1 means a track turning against its command)


def run_slip_ekf(
    t,
    v_left,
    v_right,
    *,
    track_gauge: float,
    pose_meas,
    twist_meas=None,
    pose_std: Sequence[float] = (0.1, 0.1, np.radians(2.0)),
    twist_std: Sequence[float] = (0.05, 0.05, 0.04),
    params0: Sequence[float] = (0.0, 0.0, 0.0),
    param_std0: Sequence[float] = (0.3, 0.3, np.radians(20.0)),
    q_param_std: Sequence[float] = (1e-3, 1e-3, np.radians(0.05)),
    q_pose_std: Sequence[float] | None = None,
    pose0=None,
    pose_std0=None,
    adaptive=None,
    param_cov0=None,
    model_error="auto",
) -> FilterResult:
    """Slip EKF over a drive.

    Args:
        t: (N,) [s]; v_left, v_right: (N,) commanded track speeds [m/s].
        track_gauge: T [m].
        pose_meas: (N, 3) measured pose [m, m, rad]; twist_meas: optional (N, 3) body twist.
        pose_std, twist_std: measurement noise std [m, m, rad] / [m/s, m/s, rad/s].
        params0: initial (s_L, s_R, α) [-, -, rad] (default: no slip); param_std0: their std.
        q_param_std: random-walk intensity [1/√s, 1/√s, rad/√s]; q_pose_std: pose process
            noise [m/√s, m/√s, rad/√s] (covers Euler's error and unmodelled motion; default
            :data:`Q_POSE_STD`, with ``adaptive`` :data:`Q_POSE_STD_IMM`).
        adaptive: None, "imm" or :class:`~mjtrack.estimation.imm.IMMSettings` (slow/fast IMM pair,
            :mod:`mjtrack.estimation.imm`); param_cov0: (3, 3) initial covariance overriding
            ``param_std0``.
        model_error: "auto" (default: :data:`SLIP_MODEL_ERROR` with ``adaptive``, none without),
            None, True or a :class:`~mjtrack.estimation.model_error.ModelErrorSettings`: covariance
            matching of the slips' covariance on the twist innovations
            (:mod:`mjtrack.estimation.model_error`). It needs ``twist_meas``; the thesis filter
            (``adaptive=None``) is unchanged.
    Returns:
        :class:`FilterResult` with states (x, y, theta, s_left, s_right, alpha).
    """
    model = MPP(track_gauge, *params0)
    imm = imm_settings(adaptive, SLIP_IMM)
    if q_pose_std is None:
        q_pose_std = Q_POSE_STD if imm is None else Q_POSE_STD_IMM
    if isinstance(model_error, str) and model_error == "auto":
        model_error = None if imm is None else SLIP_MODEL_ERROR
    return run_pose_param_ekf(
        model, t, v_left, v_right, pose_meas=pose_meas, twist_meas=twist_meas, pose_std=pose_std,
        twist_std=twist_std, param_std0=param_std0, q_param_std=q_param_std, q_pose_std=q_pose_std,
        pose0=pose0, pose_std0=pose_std0, name="slip_ekf", adaptive=imm,
        param_cov0=param_cov0, model_error=model_error,
        twist_inverse=lambda tw, vl, vr: mpp_from_twist(track_gauge, tw, vl, vr),
        param_bounds=[(-SLIP_MAX, SLIP_MAX), (-SLIP_MAX, SLIP_MAX), (-ALPHA_MAX, ALPHA_MAX)],
    )
