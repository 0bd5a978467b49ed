"""INDEPENDENT generator of synthetic skid-steer drive logs with hidden effects.

Shares no dynamics code with ``mjtrack`` (not ``mjtrack.models.coulomb``, not the diagnosis
surrogate, not ``mjtrack.geometry``): its own rigid-body simulation with its own contact model
and its own integrator, written for these tests only. It imports ``mjtrack`` only to wrap the
result in a :class:`mjtrack.io.logs.DriveLog` and to describe the nominal robot.

Physics. A rigid body on a plane (possibly inclined), centre of mass (cx, cy, cz) from the
geometric centre, yaw inertia that of a box L x T. Contact: each track is a grid of
``NX`` Gauss-Legendre points along its length x 2 points across its width (wheeled robots:
one point per wheel at (+-L/2, +-T/2)); the normal loads follow a plane pressure law
N_i = w_i (a + b x_i + c y_i) from the three balances (total load m g cos(slope), and the two
moments of the load transfer cz m f, f = CoM acceleration minus the in-plane gravity, from the
previous step), negative loads clipped. Friction per point: regularised Coulomb,
F_i = -mu_s N_i s_i / sqrt(|s_i|^2 + EPS^2), s_i the slip velocity of the ground under the
point relative to the track surface (body velocity at the point minus (V_track, 0)).
Integrator: linearly implicit Euler on the CoM twist (the friction Jacobian in closed form,
stiff sticking handled without tiny steps), step H; the pose by the exact constant-twist
SE(2) step (written out here). Track speeds: the commands through the hidden input effects at
sub-step resolution (held commands, yaw-rate limit, speed limit, dead time, rate limit, exact
first-order lag or force lag, scale); a measured speed at t_k is the one just before t_k
(causal: the command of row k is in force from t_k on).

Implementations of effect families beyond the diagnosis's vocabulary (:data:`OTHER`), each a
physically different version of an effect the diagnosis names:

* ``force_lag`` tau_f [s]: the drive's FORCE lags its demand (current dynamics) and moves the
  belt's inertia M: M V' = F, tau_f F' = Kp (u - V) - F with the speed gain Kp = M / (2 tau_f)
  (damping 0.71), i.e. V = u / (2 tau_f^2 s^2 + 2 tau_f s + 1): a second-order response of mean
  time 2 tau_f, integrated with semi-implicit Euler at the sub-step (the belt is not loaded by
  the ground here);
* ``rate_limit`` [m/s^2]: the track speed moves towards its set-point at most this fast (slew);
* ``force_limit`` [N]: the traction each drive can give: belts massless, each runs at its
  set-point unless the ground's traction at that speed (the sum of its points' longitudinal
  friction, at the current body velocity) exceeds the limit, then at the speed where it equals
  +-limit (solved by bisection every step): a saturation that shows in spins and hard turns;
* ``lateral_ratio`` [-]: anisotropic ground, F_y,i = -ratio mu_s N_i s_y / sqrt(|s_i|^2 + EPS^2)
  (lateral friction ratio x the longitudinal), the Jacobian scaled alike.

Logs: random held commands (2-4 s steps; straight, turns both ways, spins), or the DRIVE
layout (commands held 6 s, logged as 2 s windows of 1.95 s each, every window its own
segment). Pose noise white (XY_STD, YAW_STD), track-speed noise SPEED_STD.
"""

from __future__ import annotations

import numpy as np

from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import Robot

G0 = 9.81
H = 0.005  # [s] integration step
EPS = 0.02  # [m/s] regularisation of the Coulomb law
NX = 10  # Gauss-Legendre points along each track
XY_STD, YAW_STD, SPEED_STD = 0.01, np.radians(0.3), 0.01
VMAX = 1.0

GEOMETRIES = {  # name -> (robot description given to the diagnosis, contact kind)
    "small": (Robot(), "tracks"),
    "large": (Robot(track_gauge=0.6, track_length=0.9, track_width=0.15, mass=80.0, cg_z=0.25, mu=0.7), "tracks"),
    # a wheeled skid-steer robot: 4 wheels at (+-0.25, +-0.275). Its description gives the
    # contact length of the continuous track that turns like it (0.97 m), calibrated once on a
    # separate clean log (seed 999, 120 s: the fitted icr_spread is 1.12 at 0.866 m, 0.86 at 1.1 m,
    # and no effect passes at 0.97 m), as an engineer would calibrate a wheeled robot's effective
    # contact before diagnosing it; the benchmark's logs use other seeds
    "wheeled": (Robot(track_gauge=0.55, track_length=0.97, track_width=0.1, mass=50.0, cg_z=0.2, mu=0.6), "wheels"),
}
WHEELBASE = 0.5

INPUT = ("yaw_rate_limit", "speed_limit", "command_delay", "actuator_lag", "track_speed_scale")
GROUND = ("cg_offset_x", "cg_offset_y", "friction_scale", "friction_asymmetry", "slope")
# implementations of effect families outside the diagnosis's own vocabulary (module docstring)
OTHER = ("force_lag", "rate_limit", "force_limit", "lateral_ratio")


def commands(rng: np.random.Generator, duration: float, dt: float, *, turning: bool = True, hold=(2.0, 4.0),
             vmax: float = VMAX):
    """Held random commands: straight runs, turns both ways, spins; returns (t, v_left, v_right)."""
    t = np.arange(0.0, duration, dt)
    vl, vr = np.empty_like(t), np.empty_like(t)
    k = 0
    while k < t.size:
        n = max(1, int(round(rng.uniform(*hold) / dt)))
        kind = rng.integers(4) if turning else 0
        v = rng.uniform(0.2, vmax) * rng.choice([1, 1, 1, -1])
        if kind == 0:
            a = b = v
        elif kind == 3:
            a = rng.uniform(0.3, vmax) * rng.choice([-1, 1])
            b = -a
        else:
            a, b = v, v * rng.uniform(-0.3, 0.7)
            if rng.random() < 0.5:
                a, b = b, a
        vl[k:k + n], vr[k:k + n] = a, b
        k += n
    return t, vl, vr


def _contact(robot: Robot, kind: str):
    """Contact points (P, 2) in the body frame (from the geometric centre), weights (P,), side (P,) 0 L / 1 R."""
    T = robot.track_gauge
    if kind == "wheels":
        a = WHEELBASE / 2
        pts = np.array([[a, T / 2], [-a, T / 2], [a, -T / 2], [-a, -T / 2]])
        return pts, np.ones(4), np.array([0, 0, 1, 1])
    xg, wg = np.polynomial.legendre.leggauss(NX)
    xs = xg * robot.track_length / 2
    pts, w, side = [], [], []
    for s, yc in ((0, T / 2), (1, -T / 2)):
        for dy in (-robot.track_width / 4, robot.track_width / 4):
            for x, ww in zip(xs, wg):
                pts.append([x, yc + dy])
                w.append(ww)
                side.append(s)
    return np.array(pts), np.array(w), np.array(side)


def _loads(pts, w, total, cg, cz, m, f):
    """Plane pressure law N_i = w_i (a + b x_i + c y_i): sum N = total, sum N (x - cx) = -cz m f_x,
    sum N (y - cy) = -cz m f_y; negative loads clipped and the rest rescaled."""
    A = np.stack([w, w * pts[:, 0], w * pts[:, 1]], 1)  # N = A @ (a, b, c)
    M = np.stack([A.sum(0), (A * (pts[:, 0] - cg[0])[:, None]).sum(0), (A * (pts[:, 1] - cg[1])[:, None]).sum(0)])
    rhs = np.array([total, -cz * m * f[0], -cz * m * f[1]])
    n = A @ np.linalg.lstsq(M, rhs, rcond=None)[0]
    n = np.clip(n, 0.0, None)
    return n * total / max(n.sum(), 1e-12)


def _limited_belts(vb: np.ndarray, px: np.ndarray, py: np.ndarray, bound: np.ndarray, side: np.ndarray,
                   limit: float) -> np.ndarray:
    """Belt speeds (2,) under a drive force limit: each belt runs at its set-point ``vb`` unless the
    traction that needs (the sum of its points' longitudinal friction, points moving at (px, py),
    Coulomb bounds ``bound``) exceeds ``limit``; then at the speed whose traction is +-limit (the
    traction rises monotonically with the belt speed: bisection)."""
    out = vb.astype(float).copy()
    for s_ in (0, 1):
        on = side == s_
        x, y, b = px[on], py[on], bound[on]

        def traction(speed):
            sx = x - speed
            return float(np.sum(b * (-sx) / np.sqrt(sx * sx + y * y + EPS * EPS)))

        need = traction(vb[s_])
        if abs(need) <= limit:
            continue
        target = np.sign(need) * limit
        lo, hi = (vb[s_] - 2.0 * VMAX - 1.0, vb[s_]) if need > 0 else (vb[s_], vb[s_] + 2.0 * VMAX + 1.0)
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            if traction(mid) > target:
                hi = mid
            else:
                lo = mid
        out[s_] = 0.5 * (lo + hi)
    return out


def simulate(robot: Robot, kind: str, t_cmd: np.ndarray, v_track: np.ndarray, *, cg=(0.0, 0.0), mu=(0.8, 0.8),
             slope=0.0, slope_dir=0.0, lateral_ratio: float = 1.0, force_limit: float | None = None,
             belts: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Integrate the body under track speeds v_track (S, 2) given at sub-step times t_cmd (S,)
    (spacing H). Returns poses (S, 3) of the geometric centre and the twists (S, 3) (vx, vy, wz)
    of the geometric centre, both at the sub-step times.

    ``lateral_ratio``: lateral / longitudinal friction coefficient (anisotropic ground, module
    docstring); ``force_limit`` [N]: the traction each drive can give (massless belts; module
    docstring), None: unlimited; ``belts`` (S, 2): filled with the belt speeds actually run."""
    pts, w, side = _contact(robot, kind)
    m = robot.mass
    inertia = m * (robot.track_length**2 + robot.track_gauge**2) / 12.0
    cx, cy = cg
    cz = robot.cg_z
    mu_p = np.where(side == 0, mu[0], mu[1])
    rel = pts - np.array([cx, cy])  # points from the CoM
    n_steps = t_cmd.size
    poses = np.zeros((n_steps, 3))
    twists = np.zeros((n_steps, 3))
    v0 = 0.5 * (v_track[0, 0] + v_track[0, 1])
    z = np.array([v0, 0.0, 0.0])  # CoM twist (u, v, w) in the body frame
    pose = np.zeros(3)
    f_prev = np.zeros(2)
    total = m * G0 * np.cos(slope)
    for k in range(n_steps):
        yaw = pose[2]
        ang = slope_dir - yaw  # uphill direction in the body frame
        g_pl = -G0 * np.sin(slope) * np.array([np.cos(ang), np.sin(ang)])  # in-plane gravity, body frame
        n = _loads(pts, w, total, (cx, cy), cz, m, f_prev)
        u, v, wz = z
        vb = v_track[k]
        if force_limit is not None:
            vb = _limited_belts(vb, u - wz * rel[:, 1], v + wz * rel[:, 0], mu_p * n, side, force_limit)
        if belts is not None:
            belts[k] = vb
        belt = np.where(side == 0, vb[0], vb[1])
        sx = u - wz * rel[:, 1] - belt
        sy = v + wz * rel[:, 0]
        r = np.sqrt(sx * sx + sy * sy + EPS * EPS)
        c = mu_p * n / r
        fx, fy = -c * sx, -lateral_ratio * c * sy
        F = np.array([fx.sum(), fy.sum(), (rel[:, 0] * fy - rel[:, 1] * fx).sum()])
        # d(f_i)/d(s_i) = -mu N (I/r - s s^T / r^3); ds/dz = [[1, 0, -ry], [0, 1, rx]]
        c3 = mu_p * n / r**3
        kxx = -(c - c3 * sx * sx)
        kyy = -(c - c3 * sy * sy)
        kxy = c3 * sx * sy
        jx = np.stack([kxx, kxy, -kxx * rel[:, 1] + kxy * rel[:, 0]], 1)  # d fx / d z
        jy = lateral_ratio * np.stack([kxy, kyy, -kxy * rel[:, 1] + kyy * rel[:, 0]], 1)  # d fy / d z
        J = np.stack([jx.sum(0), jy.sum(0), (rel[:, 0, None] * jy - rel[:, 1, None] * jx).sum(0)])
        minv = np.array([1 / m, 1 / m, 1 / inertia])
        rhs = F * minv + np.array([wz * v + g_pl[0], -wz * u + g_pl[1], 0.0])
        A = np.eye(3) - H * minv[:, None] * J
        dz = np.linalg.solve(A, H * rhs)
        z = z + dz
        f_prev = F[:2] / m  # specific contact force = CoM acceleration minus in-plane gravity
        # the twist of the geometric centre, then the exact constant-twist pose step
        vx, vy, om = z[0] + z[2] * cy, z[1] - z[2] * cx, z[2]
        poses[k] = pose
        twists[k] = (vx, vy, om)
        th = om * H
        if abs(th) > 1e-9:
            s_, c_ = np.sin(th) / th, (1 - np.cos(th)) / th
        else:
            s_, c_ = 1 - th * th / 6, th / 2
        dxb, dyb = H * (s_ * vx - c_ * vy), H * (c_ * vx + s_ * vy)
        cyw, syw = np.cos(yaw), np.sin(yaw)
        pose = np.array([pose[0] + cyw * dxb - syw * dyb, pose[1] + syw * dxb + cyw * dyb, yaw + th])
    return poses, twists


def track_speeds(t_fine: np.ndarray, t: np.ndarray, cl: np.ndarray, cr: np.ndarray, p: dict, gauge: float):
    """Actual track speeds (S, 2) at the sub-step times through the hidden input effects."""
    j = np.clip(np.searchsorted(t, t_fine + 1e-9, side="right") - 1, 0, t.size - 1)
    if "command_delay" in p:
        j = np.clip(np.searchsorted(t, t_fine - p["command_delay"] + 1e-9, side="right") - 1, 0, t.size - 1)
    u = np.stack([cl[j], cr[j]], -1)
    if "yaw_rate_limit" in p:
        lim = p["yaw_rate_limit"] * gauge
        mean, half = u.mean(1), 0.5 * np.clip(u[:, 1] - u[:, 0], -lim, lim)
        u = np.stack([mean - half, mean + half], -1)
    if "speed_limit" in p:
        u = np.clip(u, -p["speed_limit"], p["speed_limit"])
    if "rate_limit" in p:  # slew limit of the track speed
        y = np.empty_like(u)
        y[0] = u[0]
        step = p["rate_limit"] * H
        for k in range(1, u.shape[0]):
            y[k] = y[k - 1] + np.clip(u[k - 1] - y[k - 1], -step, step)
        u = y
    if "actuator_lag" in p:
        a = 1.0 - np.exp(-H / p["actuator_lag"])
        y = np.empty_like(u)
        y[0] = u[0]
        for k in range(1, u.shape[0]):
            y[k] = y[k - 1] + a * (u[k - 1] - y[k - 1])
        u = y
    if "force_lag" in p:  # belt inertia M under a lagging drive force (module docstring)
        tf = p["force_lag"]
        y, acc = np.empty_like(u), np.zeros(2)
        y[0] = u[0]
        for k in range(1, u.shape[0]):
            acc = acc + H * ((u[k - 1] - y[k - 1]) / (2.0 * tf) - acc) / tf
            y[k] = y[k - 1] + H * acc
        u = y
    if "track_speed_scale" in p:
        u = u * p["track_speed_scale"]
    return u


def make_log(params: dict | None = None, *, geometry: str = "small", seed: int = 0, duration: float = 240.0,
             rate: float = 20.0, speeds: bool = False, turning: bool = True, layout: str = "continuous",
             vmax: float = VMAX, true_speeds: bool = False, robot: Robot | None = None, pose_std: float = XY_STD):
    """A log of the geometry's robot with hidden effect parameters ``params`` (names of the
    effect vocabulary, e.g. {"cg_offset_x": 0.05, "actuator_lag": 0.2}; {} or None = clean).
    ``layout``: "continuous" (one segment) or "drive" (2 s windows of 1.95 s, separate segments,
    commands held 6 s). Returns (log, the nominal robot description); with ``true_speeds`` also
    the noise-free track speeds (N, 2) at the log's rows, with the hidden input effects and
    without them (what shows where an input effect acts). ``robot``: a tracked robot described
    otherwise than the geometry's (e.g. another mass); ``pose_std`` [m]: the pose noise in x and y."""
    p = dict(params or {})
    unknown = set(p) - set(INPUT) - set(GROUND) - set(OTHER) - {"slope_direction"}
    assert not unknown, unknown
    robot, kind = GEOMETRIES[geometry] if robot is None else (robot, "tracks")
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate
    hold = (6.0, 6.0) if layout == "drive" else (2.0, 4.0)
    t, cl, cr = commands(rng, duration, dt, turning=turning, hold=hold, vmax=vmax)
    sub = max(1, int(round(dt / H)))
    t_fine = t[0] + np.arange(t.size * sub) * (dt / sub)
    v = track_speeds(t_fine, t, cl, cr, p, robot.track_gauge)
    cg = (robot.cg_x + p.get("cg_offset_x", 0.0), robot.cg_y + p.get("cg_offset_y", 0.0))
    mu_r = robot.mu * p.get("friction_scale", 1.0)
    mu_l = mu_r * p.get("friction_asymmetry", 1.0)
    belts = np.empty_like(v) if "force_limit" in p else None
    poses, _ = simulate(robot, kind, t_fine, v, cg=cg, mu=(mu_l, mu_r), slope=p.get("slope", 0.0),
                        slope_dir=p.get("slope_direction", 0.0), lateral_ratio=p.get("lateral_ratio", 1.0),
                        force_limit=p.get("force_limit"), belts=belts)
    v = v if belts is None else belts
    poses = poses[::sub]
    # a speed sample at t_k is the speed just before t_k (the command of row k is in force from
    # t_k on and cannot show in it yet): its left limit. Behind a first-order lag the speed is
    # continuous, its value at t_k (the lag state, driven by the inputs before t_k); otherwise it
    # is held, and its left limit is the value of the sub-step before
    k = np.arange(t.size) * sub
    vs = v[k] if {"actuator_lag", "force_lag", "rate_limit"} & set(p) else v[np.maximum(k - 1, 0)]
    v_nominal = track_speeds(t_fine, t, cl, cr, {}, robot.track_gauge)[np.maximum(k - 1, 0)]
    cols = {"t": t, "v_left_cmd": cl, "v_right_cmd": cr,
            "x": poses[:, 0] + rng.normal(0, pose_std, t.size), "y": poses[:, 1] + rng.normal(0, pose_std, t.size),
            "yaw": poses[:, 2] + rng.normal(0, YAW_STD, t.size)}
    if speeds:
        cols["v_left"] = vs[:, 0] + rng.normal(0, SPEED_STD, t.size)
        cols["v_right"] = vs[:, 1] + rng.normal(0, SPEED_STD, t.size)
    if layout == "drive":
        per = int(round(2.0 / dt))
        win = np.arange(t.size) // per
        keep = (np.arange(t.size) % per) != per - 1  # 1.95 s of every 2 s window
        cols = {k: c[keep] for k, c in cols.items()}
        cols["window"] = win[keep]
        vs, v_nominal = vs[keep], v_nominal[keep]
    tag = "+".join(f"{k}={v:g}" for k, v in sorted(p.items())) or "clean"
    log = DriveLog.from_columns(cols, source=f"physics-{geometry}-{tag}-{seed}.csv")
    return (log, robot, vs, v_nominal) if true_speeds else (log, robot)
