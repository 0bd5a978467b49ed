"""The field's peer models of a skid-steer robot, predicting whole windows from their start.

Every peer works on windows held as arrays: M windows of K samples each (``cmd``: (M, K, 2)
left/right commanded track speeds [m/s]; ``meas``: (M, K, 2) measured track speeds; ``dt``: (M,)
each window's sample period [s]). A peer returns the body twist (M, K, 3) it predicts at each
sample; :func:`integrate_windows` turns twists into poses from each window's measured start pose,
the one integration every peer shares (exact SE(2) steps, sample k's twist held over
[t_k, t_k+1)).

* **Ideal differential drive**: vx = (V_L + V_R)/2, vy = 0, wz = (V_R - V_L)/T
  (:class:`~mjtrack.models.kinematic.Nominal`) on the commands or on the measured speeds.
* **Kinematic ICR model** (:class:`IcrPeer`): the ICR model (2.14)-(2.15) of
  :class:`~mjtrack.models.kinematic.MICR` on the track speeds times a speed scale k; y_l, y_r,
  x_c, k fitted on training windows (:func:`fit_icr`).
* **DRIVE** (Baril et al., "DRIVE: Data-driven Robot Input Vector Exploration", ICRA 2024;
  :class:`Drive`, :func:`fit_drive`): per side a bounded first-order powertrain with dead time
  turns the commands into track speeds, the ideal differential drive turns those into a body
  twist, and three Bayesian linear regressions remove the body-velocity slip predicted from it.

The derivation of DRIVE as implemented here, and what it takes from the authors' description:
docs/theory/peers.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize

from mjtrack.errors import InputError
from mjtrack.geometry import se2_step, world_to_body_velocity
from mjtrack.models.kinematic import MICR, Nominal

#: DRIVE's slip features, as functions of the ideal differential drive's twist (vx, wz): the
#: longitudinal slip on [vx], the lateral slip on [vx wz] (the centripetal acceleration), the yaw
#: slip on [vx wz, vx, wz]
SLIP_FEATURES = {"x": ("vx",), "y": ("vx*wz",), "yaw": ("vx*wz", "vx", "wz")}
#: prior precision of every slip weight [1 / weight^2]: the authors' prior (covariance 1e12 times
#: the identity) is this weak, so the posterior mean is the least-squares fit
PRIOR_PRECISION = 1e-12
TAU_BOUNDS = (0.0, 5.0)  # [s] the powertrain's time constant, searched above one sample period
DELAY_BOUNDS = (0.0, 0.5)  # [s] its dead time, when fitted
#: [s] the dead time of DRIVE as its authors fit it: their loss holds the command for every 20 Hz
#: update whose elapsed time is at most the dead time, so it is flat between multiples of 0.05 s
#: and their optimiser (Nelder-Mead from 0.05 s) stays on the plateau it starts on, 0.05 to 0.1 s,
#: which holds the speed for the first update; in :func:`delayed_input`'s continuous terms that is
#: one sample period (docs/theory/peers.md, "Dead time")
AUTHORS_DELAY = 0.05
#: smoothing of the poses before the measured body velocity is differenced (scipy's
#: make_smoothing_spline lam, time in seconds from the window's start), as the authors' slip data
SMOOTHING = 0.8


def _windows_arrays(cmd, dt) -> tuple[np.ndarray, np.ndarray]:
    cmd = np.asarray(cmd, float)
    if cmd.ndim != 3 or cmd.shape[2] != 2:
        raise InputError(f"peers: track speeds must have shape (M, K, 2), got {cmd.shape}")
    dt = np.broadcast_to(np.asarray(dt, float), (cmd.shape[0],))
    if not np.all(dt > 0):
        raise InputError("peers: every window's sample period must be > 0 s")
    return cmd, dt


def ideal_twist(speeds, gauge: float) -> np.ndarray:
    """(..., 3) twist of the ideal differential drive of track gauge ``gauge`` [m] from track
    speeds (..., 2) [m/s]."""
    speeds = np.asarray(speeds, float)
    return Nominal(gauge).twist(speeds[..., 0], speeds[..., 1])


def integrate_windows(pose0, twist, dt) -> np.ndarray:
    """(M, K, 3) poses of M windows from their start poses ``pose0`` (M, 3) under body twists
    ``twist`` (M, K, 3) (sample k held over one period ``dt`` (M,) [s]); row 0 is the start pose,
    yaw continuous."""
    twist = np.asarray(twist, float)
    M, K = twist.shape[:2]
    dt = np.broadcast_to(np.asarray(dt, float), (M,))
    out = np.empty((M, K, 3))
    out[:, 0] = pose = np.asarray(pose0, float)
    for k in range(K - 1):
        pose = se2_step(pose, twist[:, k], dt)
        out[:, k + 1] = pose
    return out


# -- the powertrain --------------------------------------------------------------------------------
def delayed_input(cmd, pre, delay: float, dt) -> np.ndarray:
    """(M, K) input of a powertrain of dead time ``delay`` [s] over each sample period: the mean
    of the command delayed by ``delay`` over [t_k, t_k + dt) (commands ``cmd`` (M, K) held for one
    period each; before the window's first sample the input is ``pre`` (M,)). Continuous in the
    delay, and plain holding when the delay is a whole number of periods."""
    cmd = np.asarray(cmd, float)
    M, K = cmd.shape
    dt = np.broadcast_to(np.asarray(dt, float), (M,))
    steps = np.maximum(float(delay), 0.0) / dt  # the delay in periods, per window
    m = np.floor(steps).astype(int)
    f = steps - m
    padded = np.concatenate([np.repeat(np.asarray(pre, float)[:, None], K + 1, axis=1), cmd], axis=1)
    k = np.arange(K)[None, :]
    i_new = np.clip(k - m[:, None], -(K + 1), K - 1) + K + 1  # index of c[k - m] in padded
    i_old = i_new - 1
    rows = np.arange(M)[:, None]
    return f[:, None] * padded[rows, i_old] + (1.0 - f[:, None]) * padded[rows, i_new]


def powertrain_speeds(cmd, v0, pre, tau: float, delay: float, lo: float, hi: float, dt) -> np.ndarray:
    """(M, K) track speeds of DRIVE's bounded first-order powertrain, one side: from the measured
    speed ``v0`` (M,) at the window's first sample, v[k+1] = clip(v[k] + (dt / tau) (u[k] - v[k]),
    lo, hi) with u the delayed command (:func:`delayed_input`) -- the authors' 20 Hz update, its
    time constant ``tau`` [s], dead time ``delay`` [s], bounds ``lo``, ``hi`` [m/s] the
    extremes of the measured speeds."""
    if not tau > 0:
        raise InputError(f"DRIVE: the powertrain's time constant must be > 0 s, got {tau!r}")
    u = delayed_input(cmd, pre, delay, dt)
    M, K = u.shape
    a = np.minimum(np.broadcast_to(np.asarray(dt, float), (M,)) / tau, 1.0)
    v = np.empty((M, K))
    v[:, 0] = np.asarray(v0, float)
    for k in range(K - 1):
        v[:, k + 1] = np.clip(v[:, k] + a * (u[:, k] - v[:, k]), lo, hi)
    return v


def fit_powertrain(cmd, meas, pre, dt, lo: float, hi: float, *, delay: float | None = None
                   ) -> tuple[float, float, float]:
    """(tau, delay, cost) of one side's powertrain fitted to windows that start with a command
    step: the sum over their samples of |predicted - measured| speed (the authors' loss). With
    ``delay`` [s] given, only the time constant is fitted; with None the dead time is fitted too,
    over a grid of delays (every 10 ms) with the best time constant for each, then refined jointly."""
    cmd, meas = np.asarray(cmd, float), np.asarray(meas, float)
    v0 = meas[:, 0]

    def cost(tau, d):
        return float(np.nansum(np.abs(powertrain_speeds(cmd, v0, pre, tau, d, lo, hi, dt) - meas)))

    tau_lo = float(np.max(dt)) * 1.0001  # below one period the update overshoots
    grid = [float(delay)] if delay is not None else np.arange(DELAY_BOUNDS[0], DELAY_BOUNDS[1] + 1e-9, 0.01)
    best = (np.inf, 0.0, 0.0)
    for d in grid:  # on the grid the time constant to 1 ms; the joint refinement polishes both
        r = optimize.minimize_scalar(lambda tau: cost(tau, d), bounds=(tau_lo, TAU_BOUNDS[1]), method="bounded",
                                     options={"xatol": 1e-5 if delay is not None else 1e-3})
        if r.fun < best[0]:
            best = (float(r.fun), float(r.x), float(d))
    if delay is None:
        r = optimize.minimize(lambda p: cost(*p), [best[1], best[2]], method="Nelder-Mead",
                              bounds=[(tau_lo, TAU_BOUNDS[1]), DELAY_BOUNDS], options={"xatol": 1e-5, "fatol": 1e-9})
        if r.fun < best[0]:
            best = (float(r.fun), float(r.x[0]), float(r.x[1]))
    return best[1], best[2], best[0]


# -- the slip regressions --------------------------------------------------------------------------
def slip_features(twist) -> dict[str, np.ndarray]:
    """DRIVE's features (:data:`SLIP_FEATURES`), each (..., F), of ideal twists (..., 3)."""
    twist = np.asarray(twist, float)
    vx, wz = twist[..., 0], twist[..., 2]
    cols = {"vx": vx, "wz": wz, "vx*wz": vx * wz}
    return {k: np.stack([cols[c] for c in names], -1) for k, names in SLIP_FEATURES.items()}


@dataclass(frozen=True)
class LinearPosterior:
    """A Bayesian linear regression y = X w + e, e ~ N(0, s^2), of zero prior mean: the posterior
    mean ``weights`` (F,), ``covariance`` (F, F) of the weights in units of s^2, the residual
    variance ``noise_var`` s^2 and the samples ``n`` it was fitted on."""

    weights: np.ndarray
    covariance: np.ndarray
    noise_var: float
    n: int

    def predict(self, X) -> tuple[np.ndarray, np.ndarray]:
        """Mean and variance of y at features X (..., F): the variance is s^2 (1 + x' C x)."""
        X = np.asarray(X, float)
        var = self.noise_var * (1.0 + np.einsum("...i,ij,...j->...", X, self.covariance, X))
        return X @ self.weights, var


def bayesian_linear(X, y, prior_precision: float = PRIOR_PRECISION) -> LinearPosterior:
    """The posterior of :class:`LinearPosterior` for features X (N, F) and targets y (N,): C =
    (lambda I + X'X)^-1, w = C X'y, s^2 the mean squared residual."""
    X, y = np.asarray(X, float), np.asarray(y, float)
    ok = np.all(np.isfinite(X), axis=1) & np.isfinite(y)
    X, y = X[ok], y[ok]
    if X.shape[0] <= X.shape[1]:
        raise InputError(f"DRIVE: a slip regression needs more than {X.shape[1]} samples, got {X.shape[0]}")
    C = np.linalg.inv(prior_precision * np.eye(X.shape[1]) + X.T @ X)
    w = C @ (X.T @ y)
    return LinearPosterior(w, C, float(np.mean((y - X @ w) ** 2)), int(X.shape[0]))


def body_velocities(poses, t, yaw_rate=None, *, smoothing: float | None = SMOOTHING) -> np.ndarray:
    """(M, K, 3) measured body twists of windows from their poses (M, K, 3) at times ``t`` (M, K)
    [s] (NaN beyond a window's end): each coordinate smoothed over the window by a cubic smoothing
    spline of penalty ``smoothing`` (None: not smoothed), then the displacement to the next sample
    in the body frame of the current one over the period (the last sample repeats the one before);
    the yaw rate is ``yaw_rate`` (M, K) (a gyro) when given, else the same difference of the yaw."""
    from scipy.interpolate import make_smoothing_spline

    poses, t = np.array(poses, float), np.asarray(t, float)
    out = np.full(poses.shape, np.nan)
    for j in range(poses.shape[0]):
        ok = np.isfinite(t[j]) & np.all(np.isfinite(poses[j]), axis=1)
        tj, p = t[j, ok] - t[j, ok][0], poses[j, ok]
        if tj.size < 2:
            continue
        if smoothing is not None and tj.size >= 5:
            p = np.stack([make_smoothing_spline(tj, p[:, c], lam=smoothing)(tj) for c in range(3)], -1)
        dt, d = np.diff(tj), np.diff(p, axis=0)
        vx, vy = world_to_body_velocity(p[:-1, 2], d[:, 0] / dt, d[:, 1] / dt)
        v = np.stack([vx, vy, d[:, 2] / dt], -1)
        out[j, np.flatnonzero(ok)] = np.concatenate([v, v[-1:]])
    if yaw_rate is not None:
        out[..., 2] = np.where(np.isfinite(out[..., 2]), np.asarray(yaw_rate, float), np.nan)
    return out


# -- DRIVE -----------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Drive:
    """DRIVE's model of one robot (module docstring): per side (left, right) the powertrain's time
    constant ``tau`` [s], dead time ``delay`` [s] and speed bounds ``bounds`` ((lo, hi) [m/s]); the
    slip regressions ``slip`` (``"x"``, ``"y"``, ``"yaw"``: :class:`LinearPosterior` on
    :data:`SLIP_FEATURES`); the track gauge [m] of its ideal differential drive."""

    gauge: float
    tau: tuple[float, float]
    delay: tuple[float, float]
    bounds: tuple[tuple[float, float], tuple[float, float]]
    slip: dict

    def track_speeds(self, cmd, v0, dt, step) -> np.ndarray:
        """(M, K, 2) track speeds from commands (M, K, 2): in a window that starts with a command
        step (``step`` (M,) bool) the powertrain from the measured speeds ``v0`` (M, 2) at its start,
        the speed held through the dead time; in the others the powertrain has settled on the
        command held in the bounds (the authors' ideal velocities of the windows after a step)."""
        cmd, dt = _windows_arrays(cmd, dt)
        v0, step = np.asarray(v0, float), np.asarray(step, bool)
        out = np.clip(cmd, [b[0] for b in self.bounds], [b[1] for b in self.bounds])
        if step.any():
            out[step] = np.stack([powertrain_speeds(cmd[step][..., i], v0[step][:, i], v0[step][:, i], self.tau[i],
                                                    self.delay[i], *self.bounds[i], dt[step]) for i in range(2)], -1)
        return out

    def slip_of(self, ideal) -> np.ndarray:
        """(..., 3) predicted body-velocity slip (ideal minus actual) at ideal twists (..., 3)."""
        f = slip_features(ideal)
        s = [self.slip[k].predict(f[k])[0] for k in ("x", "y", "yaw")]
        return np.stack(s, -1)

    def twist(self, cmd, v0, dt, step) -> np.ndarray:
        """(M, K, 3) predicted body twists: the ideal twist of the track speeds (:meth:`track_speeds`)
        less the slip."""
        ideal = ideal_twist(self.track_speeds(cmd, v0, dt, step), self.gauge)
        return ideal - self.slip_of(ideal)

    def to_json(self) -> dict:
        return {"gauge": self.gauge, "tau": list(self.tau), "delay": list(self.delay),
                "bounds": [list(b) for b in self.bounds],
                "slip_weights": {k: [float(w) for w in p.weights] for k, p in self.slip.items()},
                "slip_noise_std": {k: float(np.sqrt(p.noise_var)) for k, p in self.slip.items()}}


def fit_drive(cmd, meas, body, dt, gauge: float, *, step, steady,
              delay: float | None = AUTHORS_DELAY) -> Drive:
    """DRIVE fitted to windows: commands ``cmd`` and measured track speeds ``meas`` (M, K, 2), the
    measured body twists ``body`` (M, K, 3) (:func:`body_velocities`), periods ``dt`` (M,).

    ``step`` (M,) bool: windows that start with a command step -- each side's powertrain is fitted
    on them (:func:`fit_powertrain`; dead time ``delay``, or fitted when None), with its bounds the
    extremes of the measured speeds; ``steady`` (M,) bool: windows whose command has held since
    before their start -- the slip regressions are fitted on their samples, the slip being the
    ideal twist of the commands held in the bounds less the measured twist (the powertrain's steady
    state: the authors' targets)."""
    cmd, dt = _windows_arrays(cmd, dt)
    meas = np.asarray(meas, float)
    step, steady = np.asarray(step, bool), np.asarray(steady, bool)
    if not step.any() or not steady.any():
        raise InputError("DRIVE: fitting needs windows that start with a command step and steady windows")
    bounds, tau, delays = [], [], []
    for i in range(2):
        b = (float(np.nanmin(meas[..., i])), float(np.nanmax(meas[..., i])))
        # the speed before the step is held through the dead time
        t, d, _ = fit_powertrain(cmd[step][..., i], meas[step][..., i], meas[step][:, 0, i], dt[step], *b, delay=delay)
        bounds.append(b), tau.append(t), delays.append(d)
    held = np.clip(cmd[steady], [b[0] for b in bounds], [b[1] for b in bounds])
    ideal = ideal_twist(held, gauge)
    slip = ideal - np.asarray(body, float)[steady]
    f = slip_features(ideal)
    fits = {k: bayesian_linear(f[k].reshape(-1, f[k].shape[-1]), slip[..., j].ravel())
            for j, k in enumerate(("x", "y", "yaw"))}
    return Drive(float(gauge), tuple(tau), tuple(delays), tuple(bounds), fits)


# -- the kinematic ICR model -----------------------------------------------------------------------
@dataclass(frozen=True)
class IcrPeer:
    """The ICR kinematic model (:class:`~mjtrack.models.kinematic.MICR`: track ICRs ``y_l``, ``y_r``
    and ``x_c`` [m]) on the track speeds times ``scale`` (an effective rolling radius over the
    described one)."""

    y_l: float
    y_r: float
    x_c: float
    scale: float = 1.0

    def twist(self, speeds) -> np.ndarray:
        """(..., 3) body twist from track speeds (..., 2) [m/s]."""
        speeds = np.asarray(speeds, float) * self.scale
        return MICR(self.y_l, self.y_r, self.x_c).twist(speeds[..., 0], speeds[..., 1])


def fit_icr(speeds, poses, dt, n, gauge: float) -> IcrPeer:
    """The :class:`IcrPeer` whose windows' end positions (sample ``n`` (M,) of each), predicted from
    each window's measured start pose under track speeds (M, K, 2), are nearest (least squares, in
    each window's start frame) to the measured ends in ``poses`` (M, K, 3); starts from the ideal
    differential drive."""
    speeds, poses = np.asarray(speeds, float), np.asarray(poses, float)
    rows, n = np.arange(poses.shape[0]), np.asarray(n, int)
    end = poses[rows, n]

    def residuals(p):
        pred = integrate_windows(poses[:, 0], IcrPeer(*p).twist(speeds), dt)[rows, n]
        dx, dy = world_to_body_velocity(poses[:, 0, 2], pred[:, 0] - end[:, 0], pred[:, 1] - end[:, 1])
        return np.concatenate([dx, dy])

    h = 0.5 * gauge
    r = optimize.least_squares(residuals, [h, -h, 0.0, 1.0],
                               bounds=([0.05 * h, -20 * h, -5 * h, 0.2], [20 * h, -0.05 * h, 5 * h, 5.0]))
    return IcrPeer(*(float(v) for v in r.x))


__all__ = ["AUTHORS_DELAY", "DELAY_BOUNDS", "SMOOTHING", "Drive", "IcrPeer", "LinearPosterior", "PRIOR_PRECISION", "SLIP_FEATURES", "TAU_BOUNDS",
           "bayesian_linear", "body_velocities", "delayed_input", "fit_drive", "fit_icr", "fit_powertrain",
           "ideal_twist", "integrate_windows", "powertrain_speeds", "slip_features"]
