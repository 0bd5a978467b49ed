"""The surrogate model: the baseline's body twist under the logged commands, extended by effects.

A candidate model = the baseline + one effect of the vocabulary (:mod:`mjtrack.diagnose.vocabulary`)
with its parameters. Two kinds:

* input effects transform the track-speed sequence before the ground model (exact, cheap):
  ``track_speed_scale`` k: V = k V_cmd;  ``drive_lag`` tau: V' = (V_cmd - V)/tau, discretised
  exactly for a command held over each step, V_{k+1} = V_k + (1 - exp(-dt/tau))(V_cmd,k - V_k),
  started at the first command of each segment;  ``drive_delay`` d: V(t) = V_cmd(t - d), the
  held command sequence interpolated linearly (the mean over a step of a delayed held signal),
  held at its first value before the segment start;  ``drive_speed_limit`` v: V = clip(V_cmd, -v, v);
  ``drive_turn_limit`` w: the half difference (V_R - V_L)/2 clipped to +-w, the mean kept (the
  twist stage of :mod:`mjtrack.models.drivetrain`);  ``drive_accel_limit`` a: each track's speed
  moves towards its command at most a per second (the ramp of :mod:`mjtrack.models.drivetrain`,
  from the segment's initial speed), before the scale, with the limits.
* ground effects change the skid-steer response (:mod:`mjtrack.diagnose.surrogate.response`):
  ``cg_x``, ``cg_y``, ``mu_ratio`` move the quasi-static ICRs q0 (tabulated exact Coulomb
  solves); ``friction_scale`` scales the inertial response by 1/fs; ``slope`` (``slope_x``,
  ``slope_y``: sin(angle) x the uphill unit vector in the world frame, calibration's parameters)
  adds g (slope_x, slope_y) turned into the body frame to the effective acceleration, so its
  signature changes along the path with the yaw; the extra effect ``icr_spread`` scales the track
  ICRs (y_l, y_r) -> k (y_l, y_r): more (k > 1) or less skid in turns than modelled, the generic
  symptom of a ground that is not Coulomb-like.

``ground_anisotropy``, ``road_wheels``, ``track_length`` / ``wheelbase`` and ``rolling_resistance``
(contact models and forces the surrogate cannot express) only the MuJoCo robot simulates
(:mod:`mjtrack.diagnose.mujoco_baseline`).

Derivation and measurements: docs/theory/diagnosis.md, "Baselines".
"""

from __future__ import annotations

import numpy as np
from scipy import signal

from mjtrack.diagnose.residuals import DriveData
from mjtrack.diagnose.surrogate import response as sg
from mjtrack.diagnose.vocabulary import Effect
from mjtrack.errors import InputError
from mjtrack.io.robot import G, Robot
from mjtrack.models.drivetrain import ramp, twist


def cg_limit(robot: Robot, axis: str) -> float:
    """[m] the largest centre-of-mass offset along ``axis`` ("x" or "y") the surrogate tabulates
    and fits: 0.3 L, 0.25 T."""
    return 0.3 * robot.track_length if axis == "x" else 0.25 * robot.track_gauge


class Surrogate:
    """Baseline + effect -> per-sample body twist, for one robot and one drive log.

    Args:
        robot: the nominal robot description.
        baseline: "coulomb" or "kinematic" (module docstring).
        transient: model the friction-limited transient after speed changes (coulomb baseline only).
        causal_speeds: a measured speed at t_k is the one just before t_k (True, the MuJoCo logs'
            convention), or already the response to the command of t_k (False); see :meth:`inputs`.
    """

    def __init__(self, robot: Robot, baseline: str, *, transient: bool = False, causal_speeds: bool = True) -> None:
        if baseline not in ("coulomb", "kinematic"):
            raise InputError(f"diagnose: baseline must be 'coulomb' or 'kinematic', got {baseline!r}")
        self.robot = robot
        self.baseline = baseline
        self.transient = bool(transient) and baseline == "coulomb"
        self.causal_speeds = bool(causal_speeds)
        self._transient_cache: dict = {}
        self.resp = sg.ground_response(robot)
        T = robot.track_gauge
        self.q_nominal = self.resp.q0 if baseline == "coulomb" else np.array([T / 2, -T / 2, 0.0])
        lim_x, lim_y = cg_limit(robot, "x"), cg_limit(robot, "y")
        self._tables = {
            "cg_x": ("cg_x", np.linspace(-lim_x, lim_x, 25)),
            "cg_y": ("cg_y", np.linspace(-lim_y, lim_y, 25)),
            "mu_ratio": ("friction_ratio", np.exp(np.linspace(-np.log(3.0), np.log(3.0), 25))),
        }

    def _static_q(self, name: str, value: float) -> np.ndarray:
        field, grid = self._tables[name]
        grid, table = sg.static_table(self.robot, field, grid)
        x = np.log(grid) if name == "mu_ratio" else grid
        v = np.log(value) if name == "mu_ratio" else value
        q = np.array([np.interp(v, x, table[:, i]) for i in range(3)])
        return self.q_nominal + (q - self.resp.q0)

    def effective_speeds(self, data: DriveData, speeds: np.ndarray, params: dict[str, float] | None = None,
                         q: np.ndarray | None = None) -> np.ndarray:
        """Track speeds (N, 2) as the rigid body follows them on its friction
        (:func:`mjtrack.diagnose.surrogate.friction_limited`): per-track force bounds
        b_s = fs mu_s g N_s/(m g), the yaw gain kappa = m T (y_l - y_r)/(4 I) with the box inertia
        I = m (L^2 + T^2)/12 and the ICRs q of the model (default the nominal ones), and the
        turning resistance resist_ratio (b_L + b_R). ``params``: ground-effect parameters by name;
        the friction effects change b (and the resistance with it), cg_y the load split."""
        r = self.robot
        params = params or {}
        mu_l, mu_r = r.friction_left, r.friction_right
        cy = float(params.get("cg_y", r.cg_y))
        if "mu_ratio" in params:
            mu_l = mu_r * float(params["mu_ratio"])
        fs = float(params.get("friction_scale", 1.0))
        mu_l, mu_r = mu_l * fs, mu_r * fs
        T, L = r.track_gauge, r.track_length
        share = float(np.clip(0.5 + cy / T, 0.05, 0.95))  # left track's load share (lever rule)
        b_l, b_r = max(mu_l, 1e-3) * G * share, max(mu_r, 1e-3) * G * (1.0 - share)
        q = self.q_nominal if q is None else q
        kappa = 3.0 * T * float(q[0] - q[1]) / (L * L + T * T)
        key = (hash(speeds.tobytes()), round(b_l, 9), round(b_r, 9), round(kappa, 9), id(data))
        hit = self._transient_cache.get(key)
        if hit is not None:
            return hit
        dt = data.step_dt()
        starts = np.r_[True, data.seg[1:] != data.seg[:-1]]
        # a segment that follows the previous one closely (a DRIVE log's windows) does not start
        # in steady motion: the body carries on from where the previous segment left it, the
        # last command held over the gap (as for the input effects, :func:`_initial`), so the
        # transient after a command change at a window start is modelled
        near = _chained_starts(data)
        if near.size:
            starts[near] = False
            dt = dt.copy()
            dt[near - 1] = data.t[near] - data.t[near - 1]
        out = sg.friction_limited(speeds, dt, starts, b_left=b_l, b_right=b_r, kappa=kappa,
                                  resist=self.resp.resist_ratio * (b_l + b_r))
        if len(self._transient_cache) > 64:
            self._transient_cache.clear()
        self._transient_cache[key] = out
        return out

    # -- inputs -----------------------------------------------------------------------------
    def inputs(self, data: DriveData, effect: Effect | None, theta, *, source: np.ndarray | None = None,
               instant: bool = False) -> np.ndarray:
        """Track speeds (N, 2) [m/s] of one input effect (or none); see :meth:`inputs_of`."""
        return self.inputs_of(data, [] if effect is None else [(effect, theta)], source=source, instant=instant)

    def inputs_of(self, data: DriveData, parts, *, source: np.ndarray | None = None,
                  instant: bool = False) -> np.ndarray:
        """Track speeds (N, 2) [m/s] that drive the ground model: ``source`` (default the commands)
        transformed by the input effects among ``parts`` ((Effect, theta) pairs; ground effects are
        ignored), in the order of :data:`INPUT_ORDER` (the controller's limits on the command, the
        scale, then the actuator's dead time and lag). ``instant``: the speeds at the sample
        times (what a sensor reads) instead of their means over each held step (what drives the
        model). Causal: a row's command is in force from its time on, so the speed sampled at t_k
        is the one just before t_k (the MuJoCo logs' convention, :func:`mjtrack.sim.rollout.simulate`):
        for the static maps (none, scale, limits) the map of the previous command, the segment's
        initial speed at its first sample. With ``causal_speeds=False`` (a log whose speed samples
        already show the command of their row) the static maps apply to the row's own command and
        the delayed command is sampled at t_k - d."""
        v = data.cmd if source is None else source
        inp = sorted(((e, theta) for e, theta in parts if e is not None and e.kind == "input"),
                     key=lambda et: INPUT_ORDER.index(et[0].name))
        instant_causal = instant and self.causal_speeds
        dynamic = [e.name for e, _ in inp if e.name in ("drive_accel_limit", "drive_delay", "drive_lag")]
        init = _initial(data, v)
        for e, theta in inp:
            p = float(theta[0])
            if e.name == "track_speed_scale":
                v = p * v
            elif e.name == "drive_speed_limit":
                v = np.clip(v, -p, p)
            elif e.name == "drive_turn_limit":
                v = twist(v, turn_limit=p)
            elif e.name == "drive_accel_limit":
                last = e.name == dynamic[-1]
                v = _ramp(data, v, p, _initial(data, v), instant=instant and last, causal=self.causal_speeds)
            elif e.name == "drive_delay":
                last = e.name == dynamic[-1]
                v = _delay(data, v, p, _initial(data, v), instant=instant_causal and last)
            elif e.name == "drive_lag":
                v = _lag(data, v, p, _initial(data, v), instant=instant)
            else:  # pragma: no cover
                raise InputError(f"diagnose: unknown input effect {e.name!r}")
        if instant_causal and not dynamic:
            v = _previous(data, v, _initial(data, v) if inp else init)
        return v

    # -- ground -----------------------------------------------------------------------------
    def twist(self, data: DriveData, speeds: np.ndarray, effect: Effect | None = None, theta=()) -> np.ndarray:
        """Body twist (N, 3) of the baseline (+ a ground effect) under track speeds (N, 2)."""
        return self.twist_of(data, speeds, [] if effect is None else [(effect, theta)])

    def twist_of(self, data: DriveData, speeds: np.ndarray, parts) -> np.ndarray:
        """Body twist (N, 3) of the baseline + the ground effects among ``parts`` ((Effect, theta)
        pairs; input effects are ignored) under track speeds (N, 2). Several ground effects add
        their changes of the quasi-static ICRs (first order); each sets its own parameter."""
        r = self.robot
        q_s = self.q_nominal.copy()
        cg = np.array([r.cg_x, r.cg_y])
        fs, slope, inertia = 1.0, None, self.baseline == "coulomb"
        params: dict[str, float] = {}
        for e, theta in parts:
            if e is None or e.kind != "ground":
                continue
            name = e.name
            params[name] = float(theta[0])
            if name in self._tables:
                q_s = q_s + (self._static_q(name, float(theta[0])) - self.q_nominal)
                if name == "cg_x":
                    cg[0] = theta[0]
                elif name == "cg_y":
                    cg[1] = theta[0]
            elif name == "icr_spread":
                q_s = q_s * np.array([theta[0], theta[0], 1.0])
            elif name == "friction_scale":
                fs = float(theta[0])
            elif name == "slope":  # the world-frame in-plane gravity turned into the body frame
                c, s = np.cos(data.poses[:, 2]), np.sin(data.poses[:, 2])
                slope = G * np.stack([c * theta[0] + s * theta[1], c * theta[1] - s * theta[0]], -1)
        if self.transient:
            # the yaw gain of the transient uses the nominal ICR spread unless the effect is the
            # spread itself (a table effect moves it by < 2 %): the transient is then shared
            # (cached) by every evaluation of a fit driven by the same speeds
            speeds = self.effective_speeds(data, speeds, params, q_s if "icr_spread" in params else None)
        vl, vr = speeds[:, 0], speeds[:, 1]
        qs = np.broadcast_to(q_s, (vl.size, 3))
        tw = sg.twist_from_q(qs, vl, vr)
        if not inertia and slope is None:
            return tw
        sign = np.sign(vr - vl)
        for _ in range(2):  # the centripetal acceleration depends on the twist: fixed point
            a = sg.centripetal(tw, cg[0], cg[1]) if inertia else np.zeros((vl.size, 2))
            if slope is not None:
                a = a + slope
            # (kinematic baseline: a is the slope's alone, with its full transfer + inertia response)
            q = self.resp.icr(qs, sign, a, friction_scale=fs)
            tw = sg.twist_from_q(q, vl, vr)
            if not inertia:
                break
        return tw


# the controller's limits, the scale (linear: it commutes with the dead time and the lag), then the
# dynamics, whose speed before a segment start is the measured one when the log has it (already
# limited and scaled: nothing after it may transform it again)
INPUT_ORDER = ("drive_turn_limit", "drive_speed_limit", "drive_accel_limit", "track_speed_scale", "drive_delay",
               "drive_lag")


_LOOP_MAX = 400  # segments up to this many samples use the exact recursion, longer ones lfilter


def _segments(data: DriveData):
    cuts = np.flatnonzero(data.seg[1:] != data.seg[:-1]) + 1
    return zip(np.r_[0, cuts], np.r_[cuts, data.n])


def _chained_starts(data: DriveData) -> np.ndarray:
    """Indices of the segment starts that follow the previous segment's end within 2.5 sample
    periods (a log cut into windows, such as DRIVE's 2 s windows of 1.95 s, where the robot kept
    driving between them): the motion carries on across such a start."""
    starts = np.flatnonzero(np.r_[False, data.seg[1:] != data.seg[:-1]])
    if not starts.size:
        return starts
    same = data.seg[1:] == data.seg[:-1]
    dt = float(np.median(np.diff(data.t)[same])) if same.any() else 0.0
    gap = data.t[starts] - data.t[starts - 1]
    return starts[(gap > 0) & (gap <= 2.5 * dt)]


def _initial(data: DriveData, v: np.ndarray) -> np.ndarray:
    """(N, 2) track speeds before/at each segment start: measured where the log has them (a
    segment may start while the tracks still run at the previous command); else the previous
    segment's last value when it ended just before (a gap of at most 2.5 sample periods: logs cut
    into windows, such as DRIVE's 2 s windows of 1.95 s, where the robot kept driving between
    them), else the command."""
    out = v
    near = _chained_starts(data)
    if near.size:
        out = v.copy()
        out[near] = v[near - 1]
    if data.meas is None:
        return out
    return np.where(np.isfinite(data.meas), data.meas, out)


def _previous(data: DriveData, v: np.ndarray, init: np.ndarray) -> np.ndarray:
    """(N, 2) the previous sample's value inside each segment, ``init`` at each segment start."""
    out = np.empty_like(v)
    out[1:] = v[:-1]
    starts = np.r_[True, data.seg[1:] != data.seg[:-1]]
    out[starts] = init[starts]
    return out


def _delay(data: DriveData, v: np.ndarray, d: float, init: np.ndarray, *, instant: bool = False) -> np.ndarray:
    """Delayed held commands; before the segment start the tracks keep their initial speed.

    By default the mean over each step [t_k, t_k+1) of the delayed held signal (what drives the
    model): the held sequence interpolated linearly at t_k - d. ``instant=True``: what a speed
    sensor samples at t_k, the signal just before t_k (the command of a row is in force from its
    time on, so it cannot show in that row's measurement; the same causal convention as
    :func:`_lag`'s ``instant`` and as the MuJoCo logs): the mean over the previous step, i.e. the
    interpolation at t_k - h_{k-1} - d (a sample's speed at d = 0 is the previous command).
    """
    out = np.empty_like(v)
    for lo, hi in _segments(data):
        ts = data.t[lo:hi]
        at = ts - d
        if instant and hi - lo > 1:
            at = at - np.r_[ts[1] - ts[0], np.diff(ts)]
        # the step means of the held signal are its linear interpolation; before the segment the
        # tracks run at the initial speed: one more held step [t0 - h0, t0) at init, so that a
        # window that straddles t0 mixes the two (d -> 0 gives the first command, not init)
        h0 = ts[1] - ts[0] if hi - lo > 1 else 1.0
        grid = np.r_[ts[0] - h0, ts]
        for j in range(2):
            out[lo:hi, j] = np.interp(at, grid, np.r_[init[lo, j], v[lo:hi, j]], left=init[lo, j])
    return out


def _ramp(data: DriveData, v: np.ndarray, a: float, init: np.ndarray, *, instant: bool = False,
          causal: bool = True) -> np.ndarray:
    """The controller's ramp (the set-points r_k of :func:`mjtrack.models.drivetrain.ramp`, each
    segment at its median step h) from ``init`` at each segment start. By default the exact mean over
    each held step: u - (u - r_k)|u - r_k| / (2 a h) when the ramp reaches the command u within the
    step, else (r_k + r_k+1)/2 (a log's step is long: the ramp's own mean assumes it never arrives
    inside one); a = inf is no ramp. ``instant``: the set-point a sensor samples at t_k, the one
    before step k's command acts (``causal``), else the one after it."""
    if not np.isfinite(a):
        return v
    out = np.empty_like(v)
    for lo, hi in _segments(data):
        h = float(np.median(np.diff(data.t[lo:hi]))) if hi - lo > 1 else 1.0
        u = v[lo:hi]
        means = ramp(u, a, h, init[lo])
        r = np.empty((hi - lo + 1, 2))  # the step means (r_k + r_k+1)/2 give r_k+1 = 2 m_k - r_k
        r[0] = init[lo]
        for k in range(hi - lo):
            r[k + 1] = 2.0 * means[k] - r[k]
        if instant:
            out[lo:hi] = r[:-1] if causal else r[1:]
            continue
        gap = u - r[:-1]
        out[lo:hi] = np.where(np.abs(gap) <= a * h, u - gap * np.abs(gap) / (2.0 * a * h), means)
    return out


def _lag(data: DriveData, v: np.ndarray, tau: float, init: np.ndarray, *, instant: bool = False) -> np.ndarray:
    """First-order lag, exact for held inputs; vectorised across segments (padded), looped over time.

    y_k is the track speed at t_k; the twist of step k is held over [t_k, t_k+1), so by default
    the mean speed over the step is returned, u_k + (y_k - u_k)(tau/h)(1 - exp(-h/tau));
    ``instant=True`` returns y_k itself (what a speed sensor samples at t_k). ``init`` (N, 2):
    y at each segment start is init[start].
    """
    bounds = list(_segments(data))
    length = max(hi - lo for lo, hi in bounds)
    nseg = len(bounds)
    u = np.zeros((nseg, length, 2))
    h_tau = np.zeros((nseg, length))
    dt = data.step_dt()
    for i, (lo, hi) in enumerate(bounds):
        u[i, : hi - lo] = v[lo:hi]
        h_tau[i, : hi - lo] = dt[lo:hi] / tau
    alpha = -np.expm1(-h_tau)
    # zeros, not empty: the long-segment filter below writes each segment's own samples only, and the
    # padding beyond a shorter segment's end (discarded) must not hold whatever was in memory (an inf
    # there made numpy warn in the mean-speed step below)
    y = np.zeros_like(u)
    y[:, 0] = init[[lo for lo, _ in bounds]]
    if length <= _LOOP_MAX:  # short segments: exact recursion, vectorised across segments
        for k in range(1, length):
            y[:, k] = y[:, k - 1] + alpha[:, k - 1, None] * (u[:, k - 1] - y[:, k - 1])
    else:  # long segments: IIR filter with the segment's median step (exact when dt is uniform)
        for i, (lo, hi) in enumerate(bounds):
            a = float(np.median(alpha[i, : hi - lo - 1])) if hi - lo > 1 else 1.0
            for j in range(2):
                # y_k = (1-a) y_{k-1} + a u_{k-1}: filter of the input delayed by one step
                y[i, 1 : hi - lo, j] = signal.lfilter([a], [1.0, -(1 - a)], u[i, : hi - lo - 1, j],
                                                      zi=np.array([(1 - a) * y[i, 0, j]]))[0]
    if not instant:
        frac = np.where(h_tau > 1e-12, alpha / np.where(h_tau > 1e-12, h_tau, 1.0), 1.0)
        y = u + (y - u) * frac[..., None]
    out = np.empty_like(v)
    for i, (lo, hi) in enumerate(bounds):
        out[lo:hi] = y[i, : hi - lo]
    return out
