"""A SECOND independent generator of skid-steer drive logs: bristle friction and a driven belt.

Written from scratch for the diagnosis tests; it shares no code with ``mjtrack.diagnose``,
``mjtrack.sim``, ``mjtrack.models``, ``mjtrack.geometry`` nor with the first generator
(:mod:`mjtrack.testing.diagnose_physics`), and differs from the latter in every physical part
below. It imports ``mjtrack`` only for :class:`mjtrack.io.logs.DriveLog` and
:class:`mjtrack.io.robot.Robot` (the nominal description, read for T, L, mass, cg, cg_z, mu).

Body. A rigid body in the plane, state: pose (x, y, yaw) of the geometric centre in the world,
velocity (u, v, r) of the centre of mass in the body frame; yaw inertia m (L^2 + T^2) / 12.
Integrator: symplectic (semi-implicit) Euler with step H: the velocities first (Newton-Euler in
the rotating body frame, u' = Fx/m + r v, v' = Fy/m - r u, r' = Mz/I), then the pose with the
new velocities.

Contact. Each track is ONE row of ``NP`` points at the midpoints of ``NP`` equal pieces of its
length (y = +-T/2), each carrying the load of its piece. Loads: per side the lever rule across
the gauge (plus the lateral load transfer), along the track a linear pressure whose gradient
carries the longitudinal offset of the centre of mass and the pitch load transfer (negative
loads clipped, the side's load kept); the load transfer follows the contact force per mass
through a first-order suspension lag ``SUSP_TAU``.
Friction per point: a Dahl / LuGre bristle, a deflection state z (2,) per point (along,
across the track) obeying z' = s - |s| z / DELTA (s: slip velocity of the ground point under it
relative to the belt), integrated exactly over a step with s frozen; force on the body
F = -(mu N / DELTA) (z + TAU_B exp(-(|s| / V_DAMP)^2) z') per component (the damping acts in
pre-sliding only, so a sliding point's force never exceeds its Coulomb bound), with mu = (mu_x, mu_y) the longitudinal and
lateral coefficients. In steady sliding z = DELTA s / |s| and F = -N (mu_x s_x, mu_y s_y) / |s|:
Coulomb for mu_x = mu_y ("Coulomb ground"), an orthotropic Coulomb law otherwise ("anisotropic
ground", ``lateral_ratio`` = mu_y / mu_x); below sliding it is elastic (pre-sliding
displacement DELTA), so the ground's response has its own small compliance.

Drives. Each track's belt is a mass ``M_DRIVE`` (the reflected inertia of motor, gearbox,
sprocket and belt) driven by the motor force F_m and held back by the traction the ground puts
on it (the sum of its points' longitudinal forces): M_DRIVE V' = F_m - sum F_x. A digital speed
controller ticking every ``CTRL_DT`` samples the held command; a PI speed loop
F_cmd = Kp (V_set - V) + I (integrator clamped while saturated) is saturated at the drive's
force limit, and the motor force follows it (instantly, or through the current lag below).
Nominal drive: Kp = M_DRIVE OMEGA_C, I' = Kp OMEGA_C / 4 (V_set - V), a force limit no
manoeuvre reaches.

Effect implementations (``params`` of :func:`make_log`; each documents its physics):

* ``lag`` [s]: a first-order lag on the speed SET-POINT (a filtered reference), the loop
  unchanged;
* ``force_lag`` [s]: the motor FORCE lags the controller's demand, F_m' = (F_cmd - F_m) / tau_f
  (current / torque dynamics); the speed loop is retuned to stay damped,
  Kp = M_DRIVE / (2 tau_f) (zeta 0.71 on the belt alone), so the belt speed answers a set-point
  step as a second-order system of mean time 2 tau_f, and it sags under the ground's load (a
  slower loop rejects the traction more slowly);
* ``dead_time`` [s]: the controller reads the command ``dead_time`` late (a transport delay of
  its input, quantised to its tick ``CTRL_DT``);
* ``rate_limit`` [m/s^2]: the set-point moves towards the command at most this fast (a slew
  limit of the reference);
* ``force_limit`` [N]: the motor force saturates at +-this (per track): it limits the belt's
  acceleration (M_DRIVE + load) and the traction a turn demands;
* ``friction_asymmetry`` [-]: mu of the left track = ratio x mu of the right track;
* ``lateral_ratio`` [-]: mu_y = ratio x mu_x on both tracks (anisotropic ground);
* ``cg_offset_x``, ``cg_offset_y`` [m]: the centre of mass moved from the description's.

Logs: held random body commands (forward speed and yaw rate, 1.5-4 s) turned into track
commands, sampled at ``rate``; a pose at t_k is the body's at t_k; a measured track speed at t_k
is the belt's at t_k (the command of row k is applied from t_k on); pose noise white
(``pose_std`` in x and y, YAW_STD), track-speed noise SPEED_STD.
"""

from __future__ import annotations

import math

import numpy as np

from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import Robot

GRAVITY = 9.81  # [m/s^2]
H = 0.002  # [s] integration step
NP = 8  # contact points per track
DELTA = 0.004  # [m] bristle pre-sliding displacement
TAU_B = 0.02  # [s] bristle damping time (sigma_1 / sigma_0) at rest
V_DAMP = 0.02  # [m/s] slip speed over which the bristle damping fades (sigma_1 exp(-(|s|/V_DAMP)^2))
SUSP_TAU = 0.05  # [s] time constant with which the load transfer follows the accelerations
M_DRIVE = 100.0  # [kg] reflected inertia of one drive (motor and gearbox seen at the belt)
OMEGA_C = 60.0  # [rad/s] bandwidth of the nominal speed loop
CTRL_DT = 0.01  # [s] controller tick
NOMINAL_FORCE_LIMIT = 1e5  # [N] a limit no manoeuvre reaches
YAW_STD, SPEED_STD = math.radians(0.3), 0.01
POSE_STD = 0.005  # [m] default pose noise in x and y
VMAX = 1.0  # [m/s] largest track command

PARAMS = ("lag", "force_lag", "dead_time", "rate_limit", "force_limit", "friction_asymmetry", "lateral_ratio",
          "cg_offset_x", "cg_offset_y")


def body_commands(rng: np.random.Generator, duration: float, dt: float, gauge: float, *, vmax: float = VMAX):
    """Held random body commands (forward speed, yaw rate) over 1.5-4 s turned into track commands
    (V_L, V_R) = (v - w T/2, v + w T/2), scaled into [-vmax, vmax]; returns (t, v_left, v_right)."""
    t = np.arange(0.0, duration, dt)
    vl, vr = np.empty_like(t), np.empty_like(t)
    k = 0
    while k < t.size:
        n = max(1, int(round(rng.uniform(1.5, 4.0) / dt)))
        mode = rng.random()
        if mode < 0.25:  # straight, forward or back
            v, w = rng.uniform(0.2, vmax) * (1 if rng.random() < 0.7 else -1), 0.0
        elif mode < 0.45:  # turn on the spot
            v, w = 0.0, rng.uniform(0.8, 2.0 * vmax / gauge) * rng.choice([-1, 1])
        else:  # a curve
            v = rng.uniform(0.15, vmax) * (1 if rng.random() < 0.8 else -1)
            w = rng.uniform(0.3, 2.5) * rng.choice([-1, 1])
        a, b = v - w * gauge / 2, v + w * gauge / 2
        big = max(abs(a), abs(b))
        if big > vmax:
            a, b = a * vmax / big, b * vmax / big
        vl[k:k + n], vr[k:k + n] = a, b
        k += n
    return t, vl, vr


class _Drives:
    """The two track drives (left, right): set-point shaping, PI speed loop, motor force, belt."""

    def __init__(self, p: dict, v0: np.ndarray) -> None:
        self.lag = p.get("lag")
        self.rate = p.get("rate_limit")
        self.tau_f = p.get("force_lag")
        self.fmax = p.get("force_limit", NOMINAL_FORCE_LIMIT)
        wc = OMEGA_C if self.tau_f is None else min(OMEGA_C, 1.0 / (2.0 * self.tau_f))
        self.kp = M_DRIVE * wc
        self.ki = self.kp * wc / 4.0
        self.ref = v0.copy()  # rate-limited reference
        self.vset = v0.copy()  # lagged set-point
        self.v = v0.copy()  # belt speeds
        self.integ = np.zeros(2)
        self.fm = np.zeros(2)

    def step(self, cmd: np.ndarray, traction: np.ndarray) -> np.ndarray:
        """Advance one step H under the controller's input ``cmd`` (2,) and the ground's traction
        on the belts (2,) [N]; returns the belt speeds (2,) used during the step."""
        if self.rate is None:
            self.ref = cmd.copy()
        else:
            self.ref = self.ref + np.clip(cmd - self.ref, -self.rate * H, self.rate * H)
        if self.lag is None:
            self.vset = self.ref
        else:
            self.vset = self.vset + (1.0 - math.exp(-H / self.lag)) * (self.ref - self.vset)
        err = self.vset - self.v
        demand = self.kp * err + self.integ
        sat = np.clip(demand, -self.fmax, self.fmax)
        free = demand == sat
        self.integ = np.where(free, self.integ + self.ki * err * H, np.clip(self.integ, -self.fmax, self.fmax))
        if self.tau_f is None:
            self.fm = sat
        else:
            self.fm = self.fm + (1.0 - math.exp(-H / self.tau_f)) * (sat - self.fm)
        used = self.v.copy()
        self.v = self.v + H * (self.fm - traction) / M_DRIVE
        return used


def _points(robot: Robot) -> tuple[np.ndarray, np.ndarray]:
    """Contact points (2 NP, 2) from the geometric centre (left track first) and their side (0 L, 1 R)."""
    xs = -robot.track_length / 2 + (np.arange(NP) + 0.5) * robot.track_length / NP
    pts = np.concatenate([np.stack([xs, np.full(NP, robot.track_gauge / 2)], 1),
                          np.stack([xs, np.full(NP, -robot.track_gauge / 2)], 1)])
    return pts, np.repeat([0, 1], NP)


def _loads(robot: Robot, pts: np.ndarray, cg: tuple[float, float], acc: np.ndarray) -> np.ndarray:
    """Point loads (2 NP,) [N] under the contact force per mass ``acc`` (2,) (body frame)."""
    m, T, L = robot.mass, robot.track_gauge, robot.track_length
    cx, cy = cg
    cz = robot.cg_z
    w = m * GRAVITY
    left = w * (T / 2 + cy) / T - m * acc[1] * cz / T  # lever rule across the gauge, lateral transfer
    side = np.array([left, w - left])
    side = np.clip(side, 0.0, w)
    side *= w / side.sum()
    # along a side: p(x) = side / L + g x, the pitch moment sum N x = w cx - cz m a_x shared by the sides
    xs = pts[:NP, 0]
    piece = L / NP
    # sum over both sides of (side_s / NP + g piece x_i) x_i = w cx - cz m a_x  ->  g
    g = (w * cx - cz * m * acc[0]) / (2.0 * piece * float(np.sum(xs * xs)))
    out = []
    for s in (0, 1):
        n = side[s] / NP + g * piece * xs
        n = np.clip(n, 0.0, None)
        out.append(n * side[s] / max(n.sum(), 1e-12))
    return np.concatenate(out)


def simulate(robot: Robot, t: np.ndarray, cl: np.ndarray, cr: np.ndarray, params: dict | None = None):
    """Drive the robot with track commands (cl, cr) held from the times ``t`` (the log's rows).

    Returns poses (N, 3) of the geometric centre and belt speeds (N, 2) at the rows' times."""
    p = dict(params or {})
    unknown = set(p) - set(PARAMS)
    if unknown:
        raise ValueError(f"bristle_physics: unknown effect parameter(s) {sorted(unknown)}")
    dt = float(t[1] - t[0])
    sub = int(round(dt / H))
    n_steps = t.size * sub
    pts, side = _points(robot)
    cg = (robot.cg_x + p.get("cg_offset_x", 0.0), robot.cg_y + p.get("cg_offset_y", 0.0))
    rel = pts - np.array(cg)
    mu_r = robot.mu
    mu_l = robot.mu * p.get("friction_asymmetry", 1.0)
    mu_x = np.where(side == 0, mu_l, mu_r)
    mu_y = mu_x * p.get("lateral_ratio", 1.0)
    m = robot.mass
    inertia = m * (robot.track_length ** 2 + robot.track_gauge ** 2) / 12.0
    # the controller's input at every step: the command of the row in force at its last tick,
    # read dead_time late
    ticks = np.floor(np.arange(n_steps) * H / CTRL_DT + 1e-9) * CTRL_DT - p.get("dead_time", 0.0)
    row = np.clip(np.searchsorted(t, ticks + 1e-9, side="right") - 1, 0, t.size - 1)
    cmd = np.stack([cl[row], cr[row]], 1)
    drives = _Drives(p, cmd[0])
    u, v, r = 0.5 * (cmd[0, 0] + cmd[0, 1]), 0.0, (cmd[0, 1] - cmd[0, 0]) / robot.track_gauge
    x = y = yaw = 0.0
    z = np.zeros((2 * NP, 2))
    acc = np.zeros(2)
    traction = np.zeros(2)
    a_susp = 1.0 - math.exp(-H / SUSP_TAU)
    poses = np.empty((t.size, 3))
    belts = np.empty((t.size, 2))
    for k in range(n_steps):
        if k % sub == 0:
            poses[k // sub] = (x, y, yaw)
            belts[k // sub] = drives.v
        vb = drives.step(cmd[k], traction)
        n = _loads(robot, pts, cg, acc)
        sx = u - r * rel[:, 1] - vb[side]
        sy = v + r * rel[:, 0]
        speed = np.sqrt(sx * sx + sy * sy)
        moving = speed > 1e-9
        decay = np.exp(-speed * H / DELTA)
        zss = np.where(moving[:, None], DELTA * np.stack([sx, sy], 1) / np.where(moving, speed, 1.0)[:, None], 0.0)
        z_new = np.where(moving[:, None], zss + (z - zss) * decay[:, None], z)
        zdot = (z_new - z) / H
        z = z_new
        damp = TAU_B * np.exp(-(speed / V_DAMP) ** 2)  # bristle damping in pre-sliding only
        fx = -(mu_x * n / DELTA) * (z[:, 0] + damp * zdot[:, 0])
        fy = -(mu_y * n / DELTA) * (z[:, 1] + damp * zdot[:, 1])
        traction = np.array([fx[:NP].sum(), fx[NP:].sum()])
        Fx, Fy = fx.sum(), fy.sum()
        Mz = float(np.sum(rel[:, 0] * fy - rel[:, 1] * fx))
        u, v, r = u + H * (Fx / m + r * v), v + H * (Fy / m - r * u), r + H * Mz / inertia
        acc = acc + a_susp * (np.array([Fx, Fy]) / m - acc)
        # the geometric centre's velocity in the world, with the new velocities
        gx, gy = u + r * cg[1], v - r * cg[0]
        c, s = math.cos(yaw), math.sin(yaw)
        x, y, yaw = x + H * (c * gx - s * gy), y + H * (s * gx + c * gy), yaw + H * r
    return poses, belts


def make_log(params: dict | None = None, *, robot: Robot | None = None, seed: int = 0, duration: float = 60.0,
             rate: float = 20.0, pose_std: float = POSE_STD, speeds: bool = False) -> tuple[DriveLog, Robot]:
    """A log of ``robot`` (default: :class:`Robot` ()) with the hidden effect implementations
    ``params`` (module docstring; {} or None: clean). Returns (log, the nominal description)."""
    robot = Robot() if robot is None else robot
    rng = np.random.default_rng(seed)
    t, cl, cr = body_commands(rng, duration, 1.0 / rate, robot.track_gauge)
    poses, belts = simulate(robot, t, cl, cr, params)
    cols = {"t": t, "v_left_cmd": cl, "v_right_cmd": cr,
            "x": poses[:, 0] + rng.normal(0, pose_std, t.size), "y": poses[:, 1] + rng.normal(0, pose_std, t.size),
            "yaw": poses[:, 2] + rng.normal(0, YAW_STD, t.size)}
    if speeds:
        cols["v_left"] = belts[:, 0] + rng.normal(0, SPEED_STD, t.size)
        cols["v_right"] = belts[:, 1] + rng.normal(0, SPEED_STD, t.size)
    tag = "+".join(f"{k}={v:g}" for k, v in sorted((params or {}).items())) or "clean"
    return DriveLog.from_columns(cols, source=f"bristle-{tag}-{seed}.csv"), robot


__all__ = ["PARAMS", "body_commands", "make_log", "simulate"]
