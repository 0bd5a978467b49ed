"""Shear-displacement ground reference: a rigid track pair on Janosi-Hanamoto shear (steady turning).

The Coulomb reference (:mod:`mjtrack.models.coulomb`) puts the full friction mu N_i on every
sliding contact. On a ground that shears, the stress under a track element builds up with the
shear displacement j the element has accumulated relative to the ground since it touched down
(Janosi & Hanamoto 1961; Wong & Chiang, Proc. IMechE D 215, 2001, for steady skid-steering):

    |f_i| = mu_side N_i (1 - exp(-j_i / K)),   direction -u_i / |u_i|                        (S1)

K the shear modulus [m], u_i the sliding velocity (eq. 1 of the Coulomb reference) and N_i the
same normal loads (Wong's linear law, rigid plate, load transfer). K -> 0 gives Coulomb.

Shear displacement (S2). In a steady turn the body rotates at wz about its ICR C = (x_c, y_c)
(body frame, x_c = -vy/wz, y_c = vx/wz), fixed in the ground. A track element at body position
p = (x, y_s) entered the contact at p_e = (x_e, y_s), x_e = +L/2 when the side's track speed
V_s > 0 (the belt runs rearwards under the body), -L/2 when V_s < 0, t = |x_e - x| / |V_s| ago.
Its touch-down point is the body point p_e then, which is R(-wz t)(p_e - C) about C now, so

    j_i = | (p - C) - R(-wz t) (p_e - C) |                                                    (S2)

exact for any rotation during contact (the integral of the sliding velocity in the ground frame).
A stopped track (V_s = 0) has slid forever: saturated (Coulomb) where it slides.

Wheels (S3). A wheel's tyre is a short track: its load is spread evenly over a contact patch of
``patch_length`` centred under the axle, the elements entering at the patch's front.

Moduli along and across (S6). A tyre's tread or a track's grousers may shear at a different rate
along the belt than across it (a tyre's longitudinal and cornering stiffness differ). With the
robot's ground key ``lateral_shear_ratio`` rho_K the friction builds up with modulus K along x and
rho_K K across (the same displacement j): the limit surface is the ellipse of semi-axes
mu N b_x, mu N b_y, b_x = 1 - exp(-j/K), b_y = 1 - exp(-j/(rho_K K)), and the force the maximum-
dissipation one on it, f = -mu N (b_x^2 u_x, b_y^2 u_y) / |(b_x u_x, b_y u_y)| (the MuJoCo robot's
elliptic cone on the track's tangent frame). rho_K = 1 is (S1); K -> 0 is Coulomb for any rho_K.

Motion resistance (S5). The robot key ``rolling_resistance`` f_r adds, per side, a force
-f_r W_s tanh(v_s / eps) along x at the middle of the side's contact (0, +-T/2), W_s the weight
the side carries at rest and v_s that point's velocity along x (a regularised sign, eps =
``RESISTANCE_EPS``): rolling, bulldozing and tread losses, opposing the motion over the ground.

Derivation, assumptions and measurements: docs/theory/shear.md.
"""

from __future__ import annotations

import logging

import numpy as np
from scipy import optimize

from mjtrack.errors import InputError, MjtrackError
from mjtrack.io.robot import Robot
from mjtrack.models.coulomb import DEFAULT_N_POINTS, SteadyState, normal_loads
from mjtrack.models.coulomb import steady_state as coulomb_steady_state

log = logging.getLogger(__name__)

DEFAULT_PATCH_LENGTH = 0.1  # [m] a tyre's contact patch on firm ground (wheels only)
PATCH_POINTS = 16  # points along a wheel's patch
_RESIDUAL_MAX = 1e-10  # as the Coulomb reference: |balance| / (m g) accepted at the solution
RESISTANCE_EPS = 0.01  # [m/s] regularisation of the motion resistance's sign (S5)


class ShearContacts:
    """Contact points, their entry points and loads of a robot on the shear ground.

    ``x``, ``y`` (n,) [m] body-frame contact points, ``x_entry`` (n, 2) the point's track front
    (column 0, used when its side runs forwards) and rear (column 1), ``left`` (n,) bool, ``mu``
    (n,) friction per point, ``share`` (n,) the share of its Coulomb reference point's load,
    ``parent`` (n,) that point's index in :func:`mjtrack.models.coulomb.normal_loads`, and
    ``x_slide`` (n,) where each point slides and its force acts: ``x``, or with ``point_contact`` (a
    wheel touching at one point, as MuJoCo's sphere) its axle's x.
    """

    def __init__(self, robot: Robot, *, n_points: int = DEFAULT_N_POINTS, patch_length: float | None = None,
                 point_contact: bool = False) -> None:
        self.robot = robot
        self.n_points = n_points
        x0, y0, _ = normal_loads(robot, n_points=n_points)
        left0 = y0 > 0
        if robot.traction == "wheels":
            lp = DEFAULT_PATCH_LENGTH if patch_length is None else float(patch_length)
            if not (np.isfinite(lp) and lp > 0):
                raise InputError(f"shear: patch_length must be a positive number of metres, got {patch_length!r}")
            s = (np.arange(PATCH_POINTS) + 0.5) / PATCH_POINTS - 0.5  # midpoints of the patch, in units of lp
            self.parent = np.repeat(np.arange(x0.size), PATCH_POINTS)
            self.x = x0[self.parent] + np.tile(s * lp, x0.size)
            front, rear = x0[self.parent] + lp / 2, x0[self.parent] - lp / 2
            self.share = np.full(self.x.size, 1.0 / PATCH_POINTS)
        else:
            self.parent = np.arange(x0.size)
            self.x = x0.copy()
            L = robot.contact_length
            front, rear = np.full(x0.size, L / 2), np.full(x0.size, -L / 2)
            self.share = np.ones(x0.size)
        self.x_entry = np.stack([front, rear], axis=1)
        # where each point slides and its force acts: itself, or (a wheel touching at one point, as
        # MuJoCo's sphere does) under its axle, the patch giving only the shear it has built up
        self.x_slide = x0[self.parent] if point_contact else self.x
        self.y = y0[self.parent]
        self.left = left0[self.parent]
        self.mu = np.where(self.left, robot.friction_left, robot.friction_right)

    def loads(self, accel=(0.0, 0.0)) -> np.ndarray:
        """N (n,) [N]: the Coulomb reference's loads for the friction force per mass ``accel``."""
        _, _, N0 = normal_loads(self.robot, n_points=self.n_points, accel=tuple(accel))
        return N0[self.parent] * self.share

    def displacement(self, vx: float, vy: float, wz: float, v_left: float, v_right: float) -> np.ndarray:
        """j (n,) [m]: each point's shear displacement (S2); inf on a stopped side."""
        V = np.where(self.left, v_left, v_right)
        return shear_displacement(self.x, self.y, self.x_entry, V, (vx, vy, wz))

    def wrench(self, vx: float, vy: float, wz: float, v_left: float, v_right: float, N: np.ndarray,
               shear_modulus: float, lateral_shear_ratio: float = 1.0) -> np.ndarray:
        """(Fx, Fy, Mz) [N, N, N m] about the geometric centre of the shear forces (S1, S6)."""
        V = np.where(self.left, v_left, v_right)
        ux, uy = vx - wz * self.y - V, vy + wz * self.x_slide
        nrm = np.hypot(ux, uy)
        return self._forces(ux, uy, nrm, self.displacement(vx, vy, wz, v_left, v_right), N, shear_modulus,
                            lateral_shear_ratio)

    def wrench_icr(self, wz: float, y_l: float, y_r: float, x_c: float, v_left: float, v_right: float,
                   N: np.ndarray, shear_modulus: float, lateral_shear_ratio: float = 1.0) -> np.ndarray:
        """The same wrench written with the ICRs (u_i = wz (y_side - y_i, x_i - x_c)), free of the
        cancellation vx - V_side at nearly equal track speeds."""
        ux = wz * (np.where(self.left, y_l, y_r) - self.y)
        uy = wz * (self.x_slide - x_c)
        vx = v_left + wz * y_l
        return self._forces(ux, uy, np.hypot(ux, uy), self.displacement(vx, -wz * x_c, wz, v_left, v_right),
                            N, shear_modulus, lateral_shear_ratio)

    def _forces(self, ux, uy, nrm, j, N, K: float, ratio: float = 1.0) -> np.ndarray:
        build = shear_factor(j, K)
        if ratio == 1.0:  # (S1)
            k = np.where(nrm > 0.0, self.mu * N * build / np.where(nrm > 0.0, nrm, 1.0), 0.0)
            fx, fy = -k * ux, -k * uy
        else:  # (S6): the maximum-dissipation force on the ellipse of semi-axes mu N (b_x, b_y)
            across = shear_factor(j, ratio * K)
            den = np.hypot(build * ux, across * uy)
            k = np.where(den > 0.0, self.mu * N / np.where(den > 0.0, den, 1.0), 0.0)
            fx, fy = -k * build ** 2 * ux, -k * across ** 2 * uy
        return np.array([fx.sum(), fy.sum(), np.sum(self.x_slide * fy - self.y * fx)])


def shear_displacement(x: np.ndarray, y: np.ndarray, x_entry: np.ndarray, v_side: np.ndarray, twist) -> np.ndarray:
    """j (n,) [m] of (S2): the shear displacement of the track elements now at body points (x, y)
    (n,) [m] whose side runs at v_side (n,) [m/s] relative to the body, with ``x_entry`` (n, 2) the
    front and rear ends of their contact, in the steady turn of body twist (vx, vy, wz); inf on a
    stopped side (it has slid for ever). Batched: twist components of shape (M, 1) and v_side (M, n)
    give j (M, n), each row in its own twist."""
    vx, vy, wz = (np.asarray(v, dtype=float) for v in twist)
    V = np.asarray(v_side, dtype=float)
    xe = np.where(V >= 0.0, x_entry[:, 0], x_entry[:, 1])
    moving = V != 0.0
    t = np.where(moving, np.abs(xe - x) / np.where(moving, np.abs(V), 1.0), 0.0)
    turning = wz != 0.0
    w = np.where(turning, wz, 1.0)
    cx, cy = -vy / w, vx / w
    px, py = x - cx, y - cy
    ex, ey = xe - cx, y - cy
    c, s = np.cos(w * t), np.sin(-w * t)
    rotated = np.hypot(px - (c * ex - s * ey), py - (s * ex + c * ey))
    j = np.where(turning, rotated, np.hypot(vx - V, vy) * t)  # translation: the element slid at u for t
    return np.where(moving, j, np.inf)


def shear_factor(j: np.ndarray, shear_modulus: float) -> np.ndarray:
    """1 - exp(-j/K) of (S1): the share of Coulomb's friction built up at shear displacement j
    [m]; 1 wherever j > 0 at K = 0, 0 at j = 0."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        build = np.ones_like(j) if shear_modulus == 0.0 else -np.expm1(-j / shear_modulus)
    return np.where(j > 0.0, build, 0.0)


def shear_modulus_of(robot: Robot, shear_modulus: float | None) -> float:
    """K [m]: the argument, else the robot's ground parameter ``shear_modulus``."""
    if shear_modulus is None:
        if robot.ground.model != "shear":
            raise InputError("shear: give shear_modulus, or a robot whose ground is {\"model\": \"shear\", ...}")
        shear_modulus = robot.ground["shear_modulus"]
    K = float(shear_modulus)
    if not (np.isfinite(K) and K >= 0.0):
        raise InputError(f"shear: shear_modulus must be a number >= 0 [m], got {shear_modulus!r}")
    return K


def lateral_shear_ratio_of(robot: Robot, lateral_shear_ratio: float | None) -> float:
    """rho_K of (S6): the argument, else the robot's shear ground's ``lateral_shear_ratio`` (1 on
    another ground)."""
    if lateral_shear_ratio is None:
        return float(robot.ground["lateral_shear_ratio"]) if robot.ground.model == "shear" else 1.0
    r = float(lateral_shear_ratio)
    if not (np.isfinite(r) and r > 0.0):
        raise InputError(f"shear: lateral_shear_ratio must be a number > 0, got {lateral_shear_ratio!r}")
    return r


def contact_wrench(robot: Robot, vx: float, vy: float, wz: float, v_left: float, v_right: float, *,
                   shear_modulus: float | None = None, n_points: int = DEFAULT_N_POINTS,
                   patch_length: float | None = None, accel=(0.0, 0.0),
                   lateral_shear_ratio: float | None = None) -> np.ndarray:
    """Body-frame shear wrench (Fx [N], Fy [N], Mz [N m] about the geometric centre), shape (3,),
    at the twist (vx, vy, wz) in a steady turn (the shear displacements (S2) assume it), with the
    loads of the CoM acceleration ``accel`` [m/s^2]."""
    K = shear_modulus_of(robot, shear_modulus)
    c = ShearContacts(robot, n_points=n_points, patch_length=patch_length)
    return c.wrench(vx, vy, wz, float(v_left), float(v_right), c.loads(accel), K,
                    lateral_shear_ratio_of(robot, lateral_shear_ratio))


def steady_state(robot: Robot, v_left: float, v_right: float, *, shear_modulus: float | None = None,
                 inertial: bool = True, load_transfer: bool = True, n_points: int = DEFAULT_N_POINTS,
                 patch_length: float | None = None, start: SteadyState | None = None,
                 tol: float = 1e-12, point_contact: bool = False,
                 lateral_shear_ratio: float | None = None) -> SteadyState:
    """Steady twist and ICRs for constant track speeds v_left, v_right [m/s] on the shear ground (S4).

    ``shear_modulus`` K [m] (default: the robot's ground parameter); K = 0 is the Coulomb
    reference's law. Balance as the Coulomb reference's eq. (3) (centripetal force and load
    transfer when ``inertial``/``load_transfer``), solved in the ICR coordinates from the Coulomb
    steady state, then by continuation in K when the direct solve fails. Raises MjtrackError
    when no solution with a residual <= 1e-10 m g is found. ``start``: a turning steady state of
    the same speeds to start from (default: the Coulomb reference's, solved here). ``point_contact``
    (wheels): each wheel touches at one point under its axle, as MuJoCo's sphere does: every point
    of its patch slides as that point and its force acts there, with the shear the patch built up
    (docs/theory/shear.md, "In MuJoCo"). ``lateral_shear_ratio``: rho_K of (S6) (default the
    robot's ground parameter, 1 on another ground).
    """
    K = shear_modulus_of(robot, shear_modulus)
    rho = lateral_shear_ratio_of(robot, lateral_shear_ratio)
    vl, vr = float(v_left), float(v_right)
    if not (np.isfinite(vl) and np.isfinite(vr)):
        raise InputError(f"shear: track speeds must be finite, got {v_left!r}, {v_right!r}")
    meta = dict(v_left=vl, v_right=vr, inertial=inertial, load_transfer=load_transfer, n_points=n_points)
    if vl == vr:
        return SteadyState(vx=vl, vy=0.0, wz=0.0, residual=0.0, **meta)
    c = ShearContacts(robot, n_points=n_points, patch_length=patch_length, point_contact=point_contact)
    T, m = robot.track_gauge, robot.mass * (1.0 if inertial else 0.0)
    N_static = c.loads()
    side_y = np.array([T / 2, -T / 2])
    # motion resistance (robot key rolling_resistance): f_r times the weight each side carries at rest
    resist = robot.rolling_resistance * robot.weight * (0.5 + np.array([1.0, -1.0]) * robot.cg_y / T)

    def twist_of(q):  # eq. (2.14), ICRs q = (y_l, y_r, x_c) / T
        yl, yr, xc = q * T
        wz = (vr - vl) / (yl - yr)
        return np.array([(yl * vr - yr * vl) / (yl - yr), -xc * wz, wz])

    def balance(q, k: float) -> np.ndarray:
        vx, vy, wz = twist_of(q)
        cx, cy = robot.cg_x, robot.cg_y
        acc = np.array([-wz * (vy + wz * cx), wz * (vx - wz * cy)]) if m > 0 else np.zeros(2)
        N = c.loads(acc) if (load_transfer and m > 0) else N_static
        Fx, Fy, Mz = c.wrench_icr(wz, *(q * T), vl, vr, N, k, rho)
        if resist.any():  # (S5): at (0, y_s), against that point's velocity along x, v_s + wz (y_icr_s - y_s)
            ground_v = np.array([vl, vr]) + wz * (q[:2] * T - side_y)
            fx = -resist * np.tanh(ground_v / RESISTANCE_EPS)
            Fx, Mz = Fx + fx.sum(), Mz - float(side_y @ fx)
        return np.array([Fx - m * acc[0], Fy - m * acc[1], (Mz - (cx * Fy - cy * Fx)) / robot.contact_length]) / robot.weight

    def solve(q0, k: float) -> tuple[np.ndarray, float]:
        with np.errstate(divide="ignore", invalid="ignore"):
            q = optimize.root(balance, q0, args=(k,), method="hybr", options={"xtol": tol}).x
            r = balance(q, k)
        res = float(np.max(np.abs(r))) if np.all(np.isfinite(r)) else np.inf
        return q, res

    if start is None or start.icr is None:
        start = coulomb_steady_state(robot, vl, vr, inertial=inertial, load_transfer=load_transfer, n_points=n_points)
    q0 = np.array(start.icr) / T
    q, res = solve(q0, K)
    if not res <= _RESIDUAL_MAX and K > 0:
        log.info("shear: direct solve failed at K=%g; continuation from the Coulomb state", K)
        q = q0
        for k in np.geomspace(K * 1e-3, K, 25):
            q, res = solve(q, float(k))
    if not res <= _RESIDUAL_MAX:
        raise MjtrackError(f"shear: no steady state found for v_left={vl}, v_right={vr}, K={K} (residual {res:.2g})")
    z = twist_of(q)
    icr = tuple(float(v) for v in q * T)
    return SteadyState(vx=float(z[0]), vy=float(z[1]), wz=float(z[2]), residual=res, icr=icr, **meta)


def yaw_ratio(state: SteadyState, track_gauge: float) -> float:
    """wz / ((v_right - v_left) / T) of a steady state (1 without slip)."""
    return state.wz / ((state.v_right - state.v_left) / track_gauge)
