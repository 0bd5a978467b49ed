"""GENERATOR of synthetic drive logs with one hidden effect, for the diagnosis tests.

Kept apart from the diagnosis code on purpose: it shares none of ``mjtrack.diagnose`` (the
diagnosis must not know which effect was injected, nor reuse the generator's physics). The
ground truth is the rigid-track Coulomb steady state, solved exactly (nonlinear, inertial, load
transfer) by ``mjtrack.models.coulomb.steady_state`` -- or, on a slope, by this module's own
root-finder on ``coulomb.contact_wrench`` with the in-plane gravity and cos(slope) normal load --
while the diagnosis uses a first-order surrogate of it. Input effects act on the track speeds
at 10 sub-steps per sample, exactly (held commands: exponential lag, held delayed commands,
clipping); the twist between grid speeds is interpolated from a table of exact solves.
Pose noise: white, 1 cm in x, y and 0.3 deg in yaw; track-speed noise 0.01 m/s.

The tests at the bottom check the generator itself (exactness against the library solver).
"""

from __future__ import annotations

import functools

import numpy as np
from scipy import interpolate, optimize

from mjtrack.geometry import se2_step
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import G, Robot
from mjtrack.models import coulomb

ROBOT = Robot()  # the nominal robot of the synthetic logs (full description)
VMAX = 1.0
SUB = 10
XY_STD, YAW_STD, SPEED_STD = 0.01, np.radians(0.3), 0.01

HIDDEN = {  # effect -> (parameters, what the robot/inputs become)
    "cg_offset_x": {"cg_offset_x": 0.06},
    "cg_offset_y": {"cg_offset_y": -0.05},
    "friction_scale": {"friction_scale": 0.35},
    "friction_asymmetry": {"friction_asymmetry": 0.6},
    "track_speed_scale": {"track_speed_scale": 0.85},
    "actuator_lag": {"actuator_lag": 0.3},
    "command_delay": {"command_delay": 0.25},
    "speed_limit": {"speed_limit": 0.6},
    "slope": {"slope": 0.12, "slope_direction": 0.8},
}


def commands(rng: np.random.Generator, duration: float, dt: float, *, turning: bool = True):
    """Held random commands (2-4 s steps): straight runs, turns both ways, spins."""
    t = np.arange(0.0, duration, dt)
    vl, vr = np.empty_like(t), np.empty_like(t)
    k = 0
    while k < t.size:
        n = int(rng.uniform(2.0, 4.0) / dt)
        kind = rng.integers(4) if turning else 0
        v = rng.uniform(0.2, VMAX) * rng.choice([1, 1, 1, -1])
        if kind == 0:
            a = b = v
        elif kind == 3:
            a = rng.uniform(0.3, VMAX) * rng.choice([-1, 1])
            b = -a
        else:
            a, b = v, v * rng.uniform(-0.3, 0.7)
            if rng.random() < 0.5:
                a, b = b, a
        vl[k:k + n], vr[k:k + n] = a, b
        k += n
    return t, vl, vr


def _robot_with(effect: str | None, p: dict) -> Robot:
    if effect == "cg_offset_x":
        return ROBOT.replace(cg_x=p["cg_offset_x"])
    if effect == "cg_offset_y":
        return ROBOT.replace(cg_y=p["cg_offset_y"])
    if effect == "friction_scale":
        return ROBOT.replace(mu=ROBOT.mu * p["friction_scale"])
    if effect == "friction_asymmetry":
        return ROBOT.replace(mu_left=ROBOT.mu * p["friction_asymmetry"], mu_right=ROBOT.mu)
    return ROBOT


@functools.lru_cache(maxsize=None)
def _exact(robot: Robot, vl: float, vr: float) -> np.ndarray:
    return coulomb.steady_state(robot, vl, vr).twist


@functools.lru_cache(maxsize=4)
def _table(robot: Robot, step: float = 0.05):
    g = np.arange(-VMAX - step, VMAX + 1.5 * step, step)
    tw = np.array([[_exact(robot, float(a), float(b)) for b in g] for a in g])
    return [interpolate.RegularGridInterpolator((g, g), tw[..., i]) for i in range(3)]


def _slope_twist(robot: Robot, vl: float, vr: float, a_up: np.ndarray, q0) -> tuple[np.ndarray, np.ndarray]:
    """Exact steady twist on a slope: friction = m (a + g sin(s) u_up), loads with the same
    tilt, friction limit mu cos(s) (a_up = g sin(s) u_up in the body frame; cos folded in mu)."""
    if vl == vr:
        return np.array([vl, 0.0, 0.0]), q0
    T, m = robot.track_gauge, robot.mass

    def tw(q):
        yl, yr, xc = q * T
        wz = (vr - vl) / (yl - yr)
        return np.array([(yl * vr - yr * vl) / (yl - yr), -xc * wz, wz])

    def res(q):
        z = tw(q)
        a = np.array([-z[2] * (z[1] + z[2] * robot.cg_x), z[2] * (z[0] - z[2] * robot.cg_y)]) + a_up
        fx, fy, mz = coulomb.contact_wrench(robot, *z, vl, vr, accel=tuple(a), n_points=100)
        mc = mz - (robot.cg_x * fy - robot.cg_y * fx)
        return np.array([fx - m * a[0], fy - m * a[1], mc / robot.track_length]) / robot.weight

    sol = optimize.root(res, q0, method="hybr", options={"xtol": 1e-10})
    assert np.max(np.abs(res(sol.x))) < 1e-8
    return tw(sol.x), sol.x


_SLOPE_CACHE: dict = {}


def make_log(effect: str | tuple | None, *, seed: int = 0, duration: float = 240.0, dt: float = 0.05,
             speeds: bool = False, turning: bool = True) -> tuple[DriveLog, Robot]:
    """A log of the nominal robot with ``effect`` hidden (None = clean; a tuple = one input effect
    and one ground effect together); returns (log, nominal robot)."""
    rng = np.random.default_rng(seed)
    names = effect if isinstance(effect, tuple) else (effect,)
    p = {k: v for n in names for k, v in HIDDEN.get(n, {}).items()}
    is_ = lambda name: name in names  # noqa: E731
    ground = next((n for n in names if n in ("cg_offset_x", "cg_offset_y", "friction_scale", "friction_asymmetry",
                                             "slope")), None)
    t, cl, cr = commands(rng, duration, dt, turning=turning)
    h = dt / SUB
    tf = t[0] + np.arange(t.size * SUB) * h
    idx = np.arange(tf.size) // SUB
    ul, ur = cl[idx], cr[idx]
    if is_("command_delay"):
        j = np.clip(np.searchsorted(t, tf - p["command_delay"] + 1e-9, side="right") - 1, 0, t.size - 1)
        ul, ur = cl[j], cr[j]
    if is_("track_speed_scale"):
        ul, ur = ul * p["track_speed_scale"], ur * p["track_speed_scale"]
    if is_("speed_limit"):
        ul, ur = np.clip(ul, -p["speed_limit"], p["speed_limit"]), np.clip(ur, -p["speed_limit"], p["speed_limit"])
    if is_("actuator_lag"):
        a = 1.0 - np.exp(-h / p["actuator_lag"])
        xl, xr = np.empty_like(ul), np.empty_like(ur)
        xl[0], xr[0] = ul[0], ur[0]
        for k in range(1, tf.size):  # exact for commands held over each sub-step
            xl[k] = xl[k - 1] + a * (ul[k - 1] - xl[k - 1])
            xr[k] = xr[k - 1] + a * (ur[k - 1] - xr[k - 1])
        ul, ur = xl, xr
    robot = _robot_with(ground, p)
    pose = np.zeros(3)
    poses = np.empty((t.size, 3))
    if ground == "slope":
        r_mu = robot.replace(mu=robot.mu * np.cos(p["slope"]))
        q = np.array([0.65, -0.65, 0.0])
        cache = _SLOPE_CACHE.setdefault((r_mu, p["slope"]), {})
    elif ground is not None and len(names) == 1:  # held commands: few distinct speeds, exact solves
        twists = np.array([_exact(robot, float(a), float(b)) for a, b in zip(ul, ur)])
    else:
        table = _table(robot)
        pts = np.stack([ul, ur], -1)
        twists = np.stack([f(pts) for f in table], -1)
    for k in range(tf.size):
        if k % SUB == 0:
            poses[k // SUB] = pose
        if ground == "slope":
            ang = p["slope_direction"] - pose[2]
            a_up = G * np.sin(p["slope"]) * np.array([np.cos(ang), np.sin(ang)])
            key = (ul[k], ur[k], round(float(ang % (2 * np.pi)) / 0.02))  # heading to 0.01 rad
            if key not in cache:
                cache[key], q = _slope_twist(r_mu, float(ul[k]), float(ur[k]), a_up, q)
            twist = cache[key]
        else:
            twist = twists[k]
        pose = se2_step(pose, twist, h)
    cols = {"t": t, "v_left_cmd": cl, "v_right_cmd": cr,
            "x": poses[:, 0] + rng.normal(0, XY_STD, t.size), "y": poses[:, 1] + rng.normal(0, XY_STD, t.size),
            "yaw": poses[:, 2] + rng.normal(0, YAW_STD, t.size)}
    if speeds:
        cols["v_left"] = ul[::SUB] + rng.normal(0, SPEED_STD, t.size)
        cols["v_right"] = ur[::SUB] + rng.normal(0, SPEED_STD, t.size)
    tag = "+".join(n for n in names if n) or "clean"
    return DriveLog.from_columns(cols, source=f"synthetic-{tag}-{seed}.csv"), ROBOT


# -- tests of the generator itself --------------------------------------------------------
def test_generator_is_seeded_and_clean_log_follows_coulomb():
    a, _ = make_log(None, seed=3, duration=20.0)
    b, _ = make_log(None, seed=3, duration=20.0)
    assert a == b
    vl, vr = a.v_left_cmd, a.v_right_cmd
    k = int(np.argmax(np.abs(vr - vl) > 0.2))  # a turning command: the table matches the exact solve
    pts = np.array([[vl[k] + 0.013, vr[k] - 0.021]])
    tw = np.array([f(pts)[0] for f in _table(ROBOT)])
    np.testing.assert_allclose(tw, _exact(ROBOT, *pts[0]), atol=3e-3)


def test_slope_solver_reduces_to_library_on_flat_ground():
    tw, _ = _slope_twist(ROBOT, 0.2, 0.7, np.zeros(2), np.array([0.65, -0.65, 0.0]))
    # 100 contact points here, 200 in the library: the discretisation differs by ~1e-5
    np.testing.assert_allclose(tw, _exact(ROBOT, 0.2, 0.7), atol=5e-5)
