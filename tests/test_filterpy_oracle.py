"""Each filter family of ``mjtrack.estimation`` against filterpy's filters on the same data.

filterpy (an independent implementation of the Kalman filter equations) is the oracle: its
``ExtendedKalmanFilter`` (and ``IMMEstimator`` over two of them) runs the models as they are
written here, from the thesis's equations, with Jacobians by central differences; nothing of
mjtrack's models, Jacobians, predict or update is used on the oracle side. Both filters see the
same seeded drive (a kinematic truth with constant slip, measurement noise from a seeded
generator) and the same settings; each step's posterior state and covariance must agree.

Tolerance: every posterior state within 1e-6 of its standard deviation, every covariance entry
P_ij within 1e-6 sqrt(P_ii P_jj). The two sides differ by the central differences of the oracle's
Jacobians, mjtrack's symmetrisation of P and its Cholesky solve of S where filterpy inverts S:
round-off that the filter's gain carries along (measured at most 1e-7 over these 10 s drives), so
a wrong sign, a missing term or a transposed Jacobian, which move the estimates by a good part of
their standard deviation, fail (the last test shows one).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

filterpy = pytest.importorskip("filterpy")
from filterpy.kalman import ExtendedKalmanFilter, IMMEstimator  # noqa: E402

from mjtrack.estimation import run_icr_ekf, run_slip_ekf, run_vir_filter  # noqa: E402
from mjtrack.estimation.imm import IMMSettings  # noqa: E402

T = 0.4  # track gauge [m]
DT = 0.04  # [s] 25 Hz
N = 250  # samples (10 s)
POSE_STD = (0.01, 0.01, 0.01)
TWIST_STD = (0.02, 0.02, 0.02)
RTOL = 1e-6  # of a standard deviation (module docstring)


# -- the models, from the thesis's equations --------------------------------------------------
def mpp_twist(p, vl, vr):
    """MPP (2.7)-(2.9): track speeds V(1 - s), v_x their mean, w their difference over T, v_y = -v_x tan(alpha)."""
    sl, sr, alpha = p
    ul, ur = vl * (1 - sl), vr * (1 - sr)
    vx = 0.5 * (ul + ur)
    return np.array([vx, -vx * math.tan(alpha), (ur - ul) / T])


def psi_twist(p, vl, vr):
    """The ICR model in psi = (x_c, y_bar, 1)/(y_l - y_r): v_x = V_bar + psi_y dV, v_y = -psi_x dV, w = psi_z dV."""
    px, py, pz = p
    dv = vr - vl
    return np.array([0.5 * (vl + vr) + py * dv, -px * dv, pz * dv])


def step_midpoint(twist_of, s, vl, vr, dt):
    """Pose step with the twist of the parameters at the held command, rotated by the mid-step heading."""
    vx, vy, w = twist_of(s[3:], vl, vr)
    th = s[2] + 0.5 * w * dt
    out = s.copy()
    out[0] += dt * (math.cos(th) * vx - math.sin(th) * vy)
    out[1] += dt * (math.sin(th) * vx + math.cos(th) * vy)
    out[2] += dt * w
    return out


def numjac(f, x, h=1e-6):
    """Central-difference Jacobian of f at x."""
    x = np.asarray(x, float)
    cols = []
    for i in range(x.size):
        d = np.zeros_like(x)
        d[i] = h * max(1.0, abs(x[i]))
        cols.append((f(x + d) - f(x - d)) / (2 * d[i]))
    return np.stack(cols, -1)


def wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


# -- the drive -------------------------------------------------------------------------------
def drive(seed: int = 7):
    """Seeded commands (held 1-2 s, turns both ways), the truth of an MPP robot with constant slip,
    and noisy pose and twist measurements."""
    rng = np.random.default_rng(seed)
    t = np.arange(N) * DT
    vl, vr = np.empty(N), np.empty(N)
    k = 0
    while k < N:
        n = int(rng.integers(25, 50))
        v, w = rng.uniform(0.2, 0.8), rng.uniform(-1.0, 1.0)
        vl[k:k + n], vr[k:k + n] = v - w * T / 2, v + w * T / 2
        k += n
    truth = np.array([0.05, -0.08, math.radians(4.0)])
    pose = np.zeros((N, 3))
    twist = np.zeros((N, 3))
    s = np.zeros(6)
    s[3:] = truth
    for k in range(N):
        twist[k] = mpp_twist(truth, vl[k], vr[k])
        pose[k] = s[:3]
        s = step_midpoint(mpp_twist, s, vl[k], vr[k], DT)
    pose_meas = pose + rng.normal(size=pose.shape) * POSE_STD
    twist_meas = twist + rng.normal(size=twist.shape) * TWIST_STD
    return t, vl, vr, pose_meas, twist_meas


# -- filterpy on the same model --------------------------------------------------------------
class Oracle(ExtendedKalmanFilter):
    """filterpy's EKF with the pose-augmented random-walk model: ``predict((dt, vl, vr))`` moves the
    state through :func:`step_midpoint` and sets F there; ``update(z)`` measures the pose and/or the
    twist at the command set in ``u_meas`` (the yaw residual wrapped)."""

    def __init__(self, twist_of, s0, P0, q2, r_std, *, pose: bool, twist: bool):
        super().__init__(dim_x=6, dim_z=3 * (pose + twist))
        self.twist_of, self.q2, self.use_pose, self.use_twist = twist_of, np.asarray(q2, float), pose, twist
        self.x, self.P = np.array(s0, float), np.array(P0, float)
        self.R = np.diag(np.asarray(r_std, float) ** 2)
        self.u_meas = (0.0, 0.0)

    def predict_x(self, u=0):
        dt, vl, vr = u
        f = lambda s: step_midpoint(self.twist_of, s, vl, vr, dt)  # noqa: E731
        self.F = numjac(f, self.x)
        self.Q = np.diag(self.q2 * dt)
        self.x = f(self.x)

    def h(self, s):
        parts = ([s[:3]] if self.use_pose else []) + ([self.twist_of(s[3:], *self.u_meas)] if self.use_twist else [])
        return np.concatenate(parts)

    def residual_z(self, a, b):
        d = a - b
        if self.use_pose:
            d[2] = wrap(d[2])
        return d

    def update(self, z, R=None):
        super().update(z, lambda s: numjac(self.h, s), self.h, R=R, residual=self.residual_z)


def run_oracle(filt, t, vl, vr, z):
    xs, Ps = [], []
    for k in range(1, t.size):
        filt.predict((t[k] - t[k - 1], vl[k - 1], vr[k - 1]))
        filt.u_meas = (vl[k], vr[k])
        filt.update(z[k])
        xs.append(filt.x.copy())
        Ps.append(filt.P.copy())
    return np.array(xs), np.array(Ps)


def assert_agree(result, xs, Ps, rtol=RTOL):
    """Every step's posterior state within ``rtol`` of its standard deviation, and every covariance
    entry P_ij within ``rtol`` sqrt(P_ii P_jj), filterpy's posterior being the reference."""
    assert result.x_post.shape == xs.shape and result.P_post.shape == Ps.shape
    sd = np.sqrt(np.einsum("kii->ki", Ps))
    worst_x = float(np.max(np.abs(result.x_post - xs) / sd))
    worst_P = float(np.max(np.abs(result.P_post - Ps) / (sd[:, :, None] * sd[:, None, :])))
    assert worst_x <= rtol and worst_P <= rtol, f"state {worst_x:.3g}, covariance {worst_P:.3g} (tolerance {rtol:g})"


@pytest.fixture(scope="module")
def data():
    return drive()


def test_slip_ekf_matches_filterpy_on_pose_and_twist(data):
    t, vl, vr, pose, twist = data
    p_std0 = (0.3, 0.3, math.radians(20.0))
    q_p = (1e-2, 1e-2, math.radians(1.0))
    q_pose = (0.005, 0.005, 0.002)
    res = run_slip_ekf(t, vl, vr, track_gauge=T, pose_meas=pose, twist_meas=twist, pose_std=POSE_STD,
                       twist_std=TWIST_STD, param_std0=p_std0, q_param_std=q_p, q_pose_std=q_pose)
    assert res.info["projected_steps"] == 0  # the slip bounds never acted: the oracle has none
    s0 = np.r_[pose[0], 0.0, 0.0, 0.0]
    P0 = np.diag(np.r_[POSE_STD, p_std0] ** 2)
    oracle = Oracle(mpp_twist, s0, P0, np.r_[q_pose, q_p] ** 2, np.r_[POSE_STD, TWIST_STD], pose=True, twist=True)
    xs, Ps = run_oracle(oracle, t, vl, vr, np.hstack([pose, twist]))
    assert_agree(res, xs, Ps)
    assert np.allclose(xs[-1, 3:], [0.05, -0.08, math.radians(4.0)], atol=0.02)  # and both found the truth


PSI_STD0, Q_PSI, Q_POSE = (2.0, 2.0, 4.0), (1e-2, 1e-2, 1e-2), (1e-3, 1e-3, 1e-3)


def psi_oracle(pose0, *, pose: bool, q_psi=Q_PSI, r_scale: float = 1.0, twist_of=psi_twist) -> Oracle:
    """The oracle of the psi filters, started from the nominal psi = (0, 0, 1/T) at ``pose0``."""
    r_std = r_scale * np.asarray(POSE_STD if pose else TWIST_STD)
    return Oracle(twist_of, np.r_[pose0, 0.0, 0.0, 1.0 / T], np.diag(np.r_[POSE_STD, PSI_STD0] ** 2),
                  np.r_[Q_POSE, q_psi] ** 2, r_std, pose=pose, twist=not pose)


def test_icr_ekf_matches_filterpy_on_pose(data):
    t, vl, vr, pose, _ = data
    res = run_icr_ekf(t, vl, vr, track_gauge=T, pose_meas=pose, pose_std=POSE_STD, psi_std0=PSI_STD0,
                      q_psi_std=Q_PSI, q_pose_std=Q_POSE)
    assert_agree(res, *run_oracle(psi_oracle(pose[0], pose=True), t, vl, vr, pose))


def test_vir_filter_matches_filterpy_on_twist(data):
    t, vl, vr, pose, twist = data
    res = run_vir_filter(t, vl, vr, track_gauge=T, twist_meas=twist, pose0=pose[0], pose_std=POSE_STD,
                         twist_std=TWIST_STD, psi_std0=PSI_STD0, q_psi_std=Q_PSI, q_pose_std=Q_POSE)
    assert_agree(res, *run_oracle(psi_oracle(pose[0], pose=False), t, vl, vr, twist))


def test_adaptive_icr_ekf_matches_filterpy_imm_of_two_ekfs(data):
    """adaptive="imm": a slow and a fast mode (parameter walk c times faster, measurement noise r
    times larger), the mode chain's switching probabilities over a step from the dwell times and
    the change of command. filterpy's IMMEstimator mixes, predicts, weighs and combines."""
    t, vl, vr, pose, _ = data
    c, r, dwell, prior, u_c = 100.0, 3.0, (1000.0, 1.0), (0.5, 0.5), 0.2
    q_psi = (1e-3, 1e-3, 1e-3)
    res = run_icr_ekf(t, vl, vr, track_gauge=T, pose_meas=pose, pose_std=POSE_STD, psi_std0=PSI_STD0,
                      q_psi_std=q_psi, q_pose_std=Q_POSE,
                      adaptive=IMMSettings(fast_factor=c, fast_meas_factor=r, dwell_s=dwell, prior=prior,
                                           command_scale=u_c))
    slow = psi_oracle(pose[0], pose=True, q_psi=q_psi)
    fast = psi_oracle(pose[0], pose=True, q_psi=c * np.asarray(q_psi), r_scale=r)
    imm = IMMEstimator([slow, fast], np.array(prior), np.eye(2))
    xs, Ps, fast_prob = [], [], []
    u_last = None
    for k in range(1, t.size):
        dt = t[k] - t[k - 1]
        u = np.array([vl[k - 1], vr[k - 1]])
        du = 0.0 if u_last is None else float(np.hypot(*(u - u_last)))
        u_last = u
        stay = np.exp(-np.array([dt / dwell[0] + du / u_c, dt / dwell[1]]))
        imm.M = np.array([[stay[0], 1 - stay[0]], [1 - stay[1], stay[1]]])
        imm._compute_mixing_probabilities()  # the chain changes with the command: mix with this step's M
        imm.predict((dt, vl[k - 1], vr[k - 1]))
        for f in imm.filters:
            f.u_meas = (vl[k], vr[k])
        imm.update(pose[k])
        xs.append(imm.x.copy())
        Ps.append(imm.P.copy())
        fast_prob.append(imm.mu[1])
    xs, Ps = np.array(xs), np.array(Ps)
    assert_agree(res, xs, Ps)
    np.testing.assert_allclose(res.mode_prob, fast_prob, rtol=0, atol=RTOL)
    assert 0.0 < min(fast_prob) and max(fast_prob) > 0.5  # both modes took part


def test_the_comparison_fails_on_a_wrong_model(data):
    """The check can fail: the ICR EKF against an oracle whose twist has the sign of v_y flipped."""
    t, vl, vr, pose, _ = data
    res = run_icr_ekf(t, vl, vr, track_gauge=T, pose_meas=pose, pose_std=POSE_STD, psi_std0=PSI_STD0,
                      q_psi_std=Q_PSI, q_pose_std=Q_POSE)
    wrong = lambda p, a, b: psi_twist(p, a, b) * np.array([1.0, -1.0, 1.0])  # noqa: E731
    xs, Ps = run_oracle(psi_oracle(pose[0], pose=True, twist_of=wrong), t, vl, vr, pose)
    with pytest.raises(AssertionError):
        assert_agree(res, xs, Ps)
