"""Rigid-track Coulomb reference: a planar rigid body on Coulomb point contacts along both tracks.

This is the physics the MuJoCo robot is checked against (after J.Y. Wong, *Theory of Ground
Vehicles*, chapter "Steering of tracked vehicles" / skid-steering kinematics and kinetics, and
Wong & Chiang, "A general theory for skid steering of tracked vehicles on firm ground",
Proc. IMechE D 215, 2001, whose firm-ground limit is pure Coulomb shear).

Contacts. Each track is a line of ``n_points`` points at x_i uniform over [-L/2, L/2]
(midpoint rule, x_i = -L/2 + (i + 1/2) L/n), optionally ``n_across`` points across the
track width w (midpoints of [-w/2, w/2] around y = +-T/2). Left track at y = +T/2.

Sliding velocity. The track surface moves backwards at V_side relative to the body, so the
ground-contact point p_i of a track moves over the ground with
    u_i = (vx - wz*y_i - V_side, vy + wz*x_i)                                          (1)
and its Coulomb friction force is f_i = -mu_side N_i u_i/|u_i|. The body-frame wrench about
the geometric centre is F = sum f_i, Mz = sum (x_i f_iy - y_i f_ix). Because
f_i = -mu N_i grad |u_i|, the wrench is minus the gradient of the convex dissipation
D(vx, vy, wz) = sum mu_i N_i |u_i|: the quasi-static steady state (zero wrench) is the unique
minimiser of D (used as the fallback solver).

Derivation and measurements: docs/theory/coulomb.md, "Implementation notes".
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Callable, NamedTuple

import numpy as np
from scipy import integrate, optimize

from mjtrack.errors import InputError, MjtrackError, SingularMotionError
from mjtrack.io.robot import G, Robot

log = logging.getLogger(__name__)

DEFAULT_N_POINTS = 200
DEFAULT_EPS = 1e-4  # [m/s] time-domain regularisation of the Coulomb sign function
_RESIDUAL_MAX = 1e-10  # steady-state residual accepted (dimensionless, see SteadyState)


class _Contacts:
    """Contact points of both tracks and their Wong loads (internal, built once per call)."""

    def __init__(self, robot: Robot, n_points: int, n_across: int, slope: float = 0.0) -> None:
        if int(n_points) != n_points or n_points < 2:
            raise InputError(f"coulomb: n_points must be an integer >= 2, got {n_points!r}")
        if int(n_across) != n_across or n_across < 1:
            raise InputError(f"coulomb: n_across must be an integer >= 1, got {n_across!r}")
        n, k = int(n_points), int(n_across)
        L, T, w = robot.contact_length, robot.track_gauge, robot.track_width
        self.robot = robot
        if robot.traction == "wheels":  # one point under each axle (module docstring, "Wheels")
            self.xg = np.asarray(robot.axle_positions(), dtype=float)
            n, k = self.xg.size, 1
        else:
            self.xg = -L / 2 + (np.arange(n) + 0.5) * L / n  # midpoint grid along a track
        dy = (-w / 2 + (np.arange(k) + 0.5) * w / k) if k > 1 else np.zeros(1)
        xs = np.tile(self.xg, 2 * k)
        ys = np.concatenate([np.repeat(side * T / 2 + dy, n) for side in (1.0, -1.0)])
        self.x, self.y = xs, ys
        self.left = np.arange(xs.size) < n * k  # first half: left track (y = +T/2)
        self.mu = np.where(self.left, robot.friction_left, robot.friction_right)
        # anisotropic ground: friction rho mu across the track (rho = 1 otherwise), module docstring
        self.rho = robot.ground["lateral_ratio"] if robot.ground.model == "anisotropic" else 1.0
        self.cg = np.array([robot.cg_x, robot.cg_y])
        self.tipped = False  # set when a load centroid had to be clipped to the support
        self._basis = np.stack([np.ones_like(xs), xs, ys], axis=1)  # plate loads: a + b x + c y
        # spring stiffness shares along a track (robot key ``ground``: road wheels concentrate the
        # load; all ones for the other grounds): N_i = w_i max(0, a + b x_i + c y_i)
        self.shares = np.tile(robot.ground.load_shares(self.xg, L), 2 * k)
        self._gram_inv = np.linalg.inv(self._basis.T @ (self.shares[:, None] * self._basis))
        self.g_normal = G * np.cos(slope)  # [m/s^2] gravity normal to the (inclined) ground
        self.static_loads = self.loads(0.0, 0.0)

    def _plate(self, cx: float, cy: float) -> np.ndarray:
        """Loads per unit weight (sum 1) of a rigid plate on tensionless springs of stiffness
        shares s_i at the points with load centroid (cx, cy): s_i max(0, a + b x + c y) (module
        docstring; s = 1 but on the road_wheels ground)."""
        P, s = self._basis, self.shares
        target = np.array([1.0, cx, cy])
        theta = self._gram_inv @ target
        w = P @ theta
        if w.min() >= 0.0 or np.all(s[w < 0.0] == 0.0):
            return s * np.maximum(w, 0.0)
        # semismooth Newton on the convex energy E = sum s max(0, P theta)^2 / 2 - theta . target
        def energy(t):
            return 0.5 * float(np.sum(s * np.maximum(P @ t, 0.0) ** 2)) - float(t @ target)
        for _ in range(100):
            w = P @ theta
            active = w > 0.0
            grad = P[active].T @ (s[active] * w[active]) - target
            if np.max(np.abs(grad)) <= 1e-14:
                break
            step = np.linalg.lstsq(P[active].T @ (s[active, None] * P[active]), grad, rcond=None)[0]
            # Armijo on the energy, with a round-off allowance: near the optimum the energy's
            # decrease falls below its rounding and a strict test would stall the full step
            e0, t = energy(theta), 1.0
            slack = 1e-13 * (1.0 + abs(e0))
            while energy(theta - t * step) > e0 - 0.5 * t * float(grad @ step) + slack and t > 1e-12:
                t *= 0.5
            theta = theta - t * step
        w = s * np.maximum(P @ theta, 0.0)
        return w / w.sum()

    def loads(self, ax: float, ay: float) -> np.ndarray:
        """Normal loads N_i [N] for a friction force per mass (ax, ay) [m/s^2] (eq. 2, 5); on flat
        ground this is the CoM acceleration."""
        r = self.robot
        cx = r.cg_x - r.cg_z * ax / self.g_normal
        cy = r.cg_y - r.cg_z * ay / self.g_normal
        xmax, ymax = 0.999 * self.xg.max(), 0.999 * r.track_gauge / 2
        if abs(cx) > xmax or abs(cy) > ymax:
            log.debug("coulomb: load centroid (%.3g, %.3g) outside the support: clipped", cx, cy)
            self.tipped = True
            cx, cy = float(np.clip(cx, -xmax, xmax)), float(np.clip(cy, -ymax, ymax))
        return r.mass * self.g_normal * self._plate(cx, cy)

    def wrench(self, twist, v_left: float, v_right: float, N: np.ndarray, eps: float) -> np.ndarray:
        """Friction wrench (Fx, Fy, Mz about the geometric centre) [N, N, N m]."""
        vx, vy, wz = twist
        ux = vx - wz * self.y - np.where(self.left, v_left, v_right)
        uy = vy + wz * self.x
        return self._forces(ux, uy, N, eps)

    def _forces(self, ux, uy, N: np.ndarray, eps: float = 0.0) -> np.ndarray:
        """Wrench of the sliding velocities (ux, uy): f_i = -mu_i N_i (ux, rho² uy)/|(ux, rho uy)|,
        the maximum-dissipation force on the friction ellipse (isotropic Coulomb at rho = 1)."""
        r2 = self.rho * self.rho
        nrm = np.sqrt(ux * ux + r2 * uy * uy + eps * eps)
        k = np.where(nrm > 0.0, self.mu * N / np.where(nrm > 0.0, nrm, 1.0), 0.0)
        fx, fy = -k * ux, -k * r2 * uy
        return np.array([fx.sum(), fy.sum(), np.sum(self.x * fy - self.y * fx)])

    def dissipation(self, ux, uy, weights) -> float:
        """D = sum weights_i |(ux, rho uy)|: convex, minus its gradient is the wrench."""
        return float(weights @ np.hypot(ux, self.rho * uy))

    def wrench_icr(self, wz: float, y_l: float, y_r: float, x_c: float, N: np.ndarray) -> np.ndarray:
        """Exact Coulomb wrench written with the ICRs, u_i = wz (y_side - y_i, x_i - x_c) (eq. 1
        with 2.13): free of the cancellation vx - V_side when the tracks run at nearly equal speeds."""
        return self._forces(wz * (np.where(self.left, y_l, y_r) - self.y), wz * (self.x - x_c), N)

    def kinematic_accel(self, twist) -> np.ndarray:
        """Centripetal CoM acceleration of a constant twist, body frame [m/s^2]."""
        vx, vy, wz = twist
        cx, cy = self.cg
        return np.array([-wz * (vy + wz * cx), wz * (vx - wz * cy)])


def contact_wrench(
    robot: Robot,
    vx: float,
    vy: float,
    wz: float,
    v_left: float,
    v_right: float,
    *,
    n_points: int = DEFAULT_N_POINTS,
    n_across: int = 1,
    accel: tuple[float, float] = (0.0, 0.0),
    eps: float = 0.0,
) -> np.ndarray:
    """Body-frame friction wrench (Fx [N], Fy [N], Mz [N m] about the geometric centre), shape (3,).

    ``accel`` is the CoM acceleration [m/s^2] used for the load transfer (2); (0, 0) gives the
    static Wong loads. ``eps`` [m/s] regularises u/|u| (time-domain use only; 0 = exact Coulomb,
    a contact with u_i = 0 then carries no force).
    """
    c = _Contacts(robot, n_points, n_across)
    N = c.loads(*accel) if any(accel) else c.static_loads
    return c.wrench((vx, vy, wz), v_left, v_right, N, eps)


def normal_loads(
    robot: Robot, *, n_points: int = DEFAULT_N_POINTS, n_across: int = 1, accel=(0.0, 0.0)
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Contact points and loads: (x [m], y [m], N [N]), each shape (2 n_points n_across,) on tracks,
    (2 wheels_per_side,) on wheels."""
    c = _Contacts(robot, n_points, n_across)
    return c.x.copy(), c.y.copy(), c.loads(*accel)


@dataclass(frozen=True)
class SteadyState:
    """Constant body twist under constant track speeds, with its ICRs (eq. 2.13).

    vx, vy [m/s], wz [rad/s]: body twist of the geometric centre. ``icr`` = (y_l, y_r, x_c) [m]
    as solved (free of the cancellation in (vx - V)/wz), None for straight motion (wz == 0);
    the properties ``y_l``, ``y_r``, ``x_c``, ``y_c`` then raise :class:`SingularMotionError`.
    ``residual`` = max(|F_x - m a_x|, |F_y - m a_y|, |M_c|/L) / (m g) at the solution
    (dimensionless).
    """

    vx: float
    vy: float
    wz: float
    v_left: float
    v_right: float
    residual: float
    inertial: bool
    load_transfer: bool
    n_points: int
    icr: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        if not all(np.isfinite([self.vx, self.vy, self.wz, self.residual])):
            raise MjtrackError("SteadyState: non-finite twist or residual")
        if (self.icr is None) != (self.wz == 0.0):
            raise MjtrackError("SteadyState: icr must be given exactly when wz != 0")
        if self.icr is not None and not (len(self.icr) == 3 and np.all(np.isfinite(self.icr))):
            raise MjtrackError("SteadyState: icr must be 3 finite numbers")

    @property
    def straight(self) -> bool:
        """True for straight motion (wz == 0): the ICRs are at infinity."""
        return self.wz == 0.0

    def _get(self, k: int, name: str) -> float:
        if self.icr is None:
            raise SingularMotionError(f"steady state: {name} undefined for straight motion (wz = 0)")
        return float(self.icr[k])

    @property
    def y_l(self) -> float:
        return self._get(0, "y_l")

    @property
    def y_r(self) -> float:
        return self._get(1, "y_r")

    @property
    def x_c(self) -> float:
        return self._get(2, "x_c")

    @property
    def y_c(self) -> float:
        if self.straight:
            raise SingularMotionError("steady state: y_c undefined for straight motion (wz = 0)")
        return self.vx / self.wz

    @property
    def twist(self) -> np.ndarray:
        return np.array([self.vx, self.vy, self.wz])


def _steady_residual(c: _Contacts, z, icr, mass_scale: float, load_transfer: bool) -> np.ndarray:
    """Residual of eq. (3) for the twist z = (vx, vy, wz) with ICRs icr = (y_l, y_r, x_c)."""
    r = c.robot
    acc = c.kinematic_accel(z) * (mass_scale > 0)
    N = c.loads(*acc) if (load_transfer and mass_scale > 0) else c.static_loads
    Fx, Fy, Mz = c.wrench_icr(z[2], *icr, N)
    m = r.mass * mass_scale
    Mc = Mz - (r.cg_x * Fy - r.cg_y * Fx)
    return np.array([Fx - m * acc[0], Fy - m * acc[1], Mc / r.contact_length]) / r.weight


def steady_state(
    robot: Robot,
    v_left: float,
    v_right: float,
    *,
    inertial: bool = True,
    load_transfer: bool = True,
    n_points: int = DEFAULT_N_POINTS,
    n_across: int = 1,
    tol: float = 1e-12,
) -> SteadyState:
    """Steady twist for constant track speeds v_left, v_right [m/s] (exact Coulomb law, eq. 3).

    ``tol`` is the solver's relative step tolerance; the result is refused (MjtrackError) unless
    its residual is <= 1e-10. Raises MjtrackError when no steady state exists (e.g. the
    centripetal force would exceed the friction).
    """
    vl, vr = float(v_left), float(v_right)
    if not (np.isfinite(vl) and np.isfinite(vr)):
        raise InputError(f"steady_state: track speeds must be finite, got {v_left!r}, {v_right!r}")
    c = _Contacts(robot, n_points, n_across)
    meta = dict(v_left=vl, v_right=vr, inertial=inertial, load_transfer=load_transfer, n_points=n_points)
    if vl == vr:  # u_i = 0 everywhere: zero friction is admissible, no centripetal force
        return SteadyState(vx=vl, vy=0.0, wz=0.0, residual=0.0, **meta)
    T = robot.track_gauge
    ms = 1.0 if inertial else 0.0

    def twist_of(q: np.ndarray) -> np.ndarray:  # eq. (2.14), ICRs q = (y_l, y_r, x_c) / T
        yl, yr, xc = q * T
        wz = (vr - vl) / (yl - yr)
        return np.array([(yl * vr - yr * vl) / (yl - yr), -xc * wz, wz])

    def icr_of(z: np.ndarray) -> np.ndarray:  # eq. (2.13), scaled by 1/T
        return np.array([z[0] - vl, z[0] - vr, -z[1]]) / z[2] / T

    def resid(q: np.ndarray, mass_scale: float = ms) -> float:
        return float(np.max(np.abs(_steady_residual(c, twist_of(q), q * T, mass_scale, load_transfer))))

    def solve(q0: np.ndarray, mass_scale: float) -> np.ndarray:
        # Unknowns: the ICRs, O(T) whatever the speeds (well scaled even for wz -> 0).
        fun = lambda q: _steady_residual(c, twist_of(q), q * T, mass_scale, load_transfer)  # noqa: E731
        with np.errstate(divide="ignore", invalid="ignore"):
            return optimize.root(fun, q0, method="hybr", options={"xtol": tol}).x

    q = solve(np.array([0.65, -0.65, 0.0]), ms)  # nominal-like start: wz ~ 0.77 nominal
    with np.errstate(divide="ignore", invalid="ignore"):
        z = twist_of(q)
    if not (np.all(np.isfinite(z)) and resid(q) <= _RESIDUAL_MAX) and robot.traction == "wheels":
        rolling = _rolling_states(c, vl, vr, ms, load_transfer, tol)
        if rolling:
            if len(rolling) > 1:
                log.warning("steady_state: %d steady states with rolling wheels at v_left=%s, v_right=%s; the first "
                            "is returned", len(rolling), vl, vr)
            z, icr, res = rolling[0]
            return SteadyState(vx=float(z[0]), vy=float(z[1]), wz=float(z[2]), residual=res, icr=icr, **meta)
    if not (np.all(np.isfinite(z)) and resid(q) <= _RESIDUAL_MAX):
        log.info("steady_state: direct solve failed; fallback (dissipation minimum, continuation)")
        scale = max(abs(vl), abs(vr))
        weights = c.static_loads * c.mu / robot.weight  # quasi-static: minimise the convex D
        vside = np.where(c.left, vl, vr)

        def dissipation(p: np.ndarray) -> float:
            vx, vy, wz = p * np.array([scale, scale, scale / T])
            return c.dissipation(vx - wz * c.y - vside, vy + wz * c.x, weights) / scale

        p0 = np.array([(vl + vr) / 2 / scale, 0.0, 0.7 * (vr - vl) / scale])
        p = optimize.minimize(dissipation, p0, method="Nelder-Mead",
                              options={"xatol": 1e-12, "fatol": 1e-15, "maxiter": 20000}).x
        q = solve(icr_of(p * np.array([scale, scale, scale / T])), 0.0)
        if inertial:  # continuation in the mass from the quasi-static solution
            for lam in np.linspace(0.1, 1.0, 10):
                q = solve(q, float(lam))
        z = twist_of(q)
    c.tipped = False
    res = resid(q) if np.all(np.isfinite(z)) else np.inf
    if not res <= _RESIDUAL_MAX:
        raise MjtrackError(
            f"steady_state: no steady state found for v_left={vl}, v_right={vr} (residual {res:.2g})"
        )
    if c.tipped:
        raise MjtrackError(f"steady_state: the robot would tip over at v_left={vl}, v_right={vr}")
    icr = tuple(float(v) for v in q * T)
    return SteadyState(vx=float(z[0]), vy=float(z[1]), wz=float(z[2]), residual=res, icr=icr, **meta)


ROLLING_STARTS = (0.5, 0.25, 0.75, 1.0)  # yaw-rate starts of a one-wheel rolling state / the ideal one


def _inside_cone(c: _Contacts, i: int, f: np.ndarray, N: float) -> bool:
    """Whether force f (2,) lies in contact i's friction set: the ellipse (f_x / mu)^2 + (f_y / (rho mu))^2
    <= N^2 (a disc on isotropic ground), with a round-off allowance."""
    mu = c.mu[i] * N
    return bool(mu > 0 and (f[0] / mu) ** 2 + (f[1] / (c.rho * mu)) ** 2 <= 1.0 + 1e-9)


def _rolling_states(c: _Contacts, vl: float, vr: float, mass_scale: float, load_transfer: bool, tol: float
                    ) -> list[tuple[np.ndarray, tuple[float, float, float], float]]:
    """Steady states of a wheeled robot in which wheels roll without slipping (module docstring,
    "Rolling wheels"): (twist, ICRs (y_l, y_r, x_c), residual) of each admissible one, axles first.

    A wheel j that sticks (u_j = 0) carries any force in its friction set, so it is an unknown f_j
    instead of -mu N u/|u|. One wheel: the twist turns about it, (V_j + wz y_j, -wz x_j, wz), and
    (wz, f_j) solve the three balance equations (3). Both wheels of an axle (left j, right k at x_a):
    the twist is fixed, wz = (V_R - V_L)/(y_j - y_k), vx = V_L + wz y_j, vy = -wz x_a; the balance fixes
    f_jx, f_kx and f_jy + f_ky, and the split t of f_jy - f_ky is free: admissible when some t puts
    both forces in their friction sets (an interval intersection). Two wheels of one side cannot both
    stick in a turn (their u_y = vy + wz x differ)."""
    r = c.robot
    m = r.mass * mass_scale
    side_v = np.where(c.left, vl, vr)
    out: list = []

    def loads_for(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        acc = c.kinematic_accel(z) * (mass_scale > 0)
        return acc, (c.loads(*acc) if (load_transfer and mass_scale > 0) else c.static_loads)

    def others(z: np.ndarray, N: np.ndarray, stuck: list[int]) -> np.ndarray:
        Nm = N.copy()
        Nm[stuck] = 0.0  # the rolling wheels' forces are unknowns
        return c.wrench(z, vl, vr, Nm, 0.0)

    for xa in np.unique(c.x):
        j = int(np.flatnonzero(c.left & (c.x == xa))[0])
        k = int(np.flatnonzero(~c.left & (c.x == xa))[0])
        wz = (side_v[j] - side_v[k]) / (c.y[k] - c.y[j])
        if wz == 0.0:
            continue
        z = np.array([side_v[j] + wz * c.y[j], -wz * xa, wz])
        acc, N = loads_for(z)
        Fo = others(z, N, [j, k])
        sx, sy = m * acc[0] - Fo[0], m * acc[1] - Fo[1]  # f_j + f_k
        mz = r.cg_x * m * acc[1] - r.cg_y * m * acc[0] - Fo[2] - xa * sy  # = -y_j f_jx - y_k f_kx
        fjx = (mz + c.y[k] * sx) / (c.y[k] - c.y[j])
        fkx = sx - fjx
        lim = []
        for i, fx in ((j, fjx), (k, fkx)):
            mu = c.mu[i] * N[i]
            lim.append(c.rho * mu * np.sqrt(1.0 - (fx / mu) ** 2) if mu > 0 and abs(fx) <= mu else -1.0)
        lo, hi = max(-sy / 2 - lim[0], sy / 2 - lim[1]), min(-sy / 2 + lim[0], sy / 2 + lim[1])
        if min(lim) >= 0.0 and lo <= hi + 1e-12 * r.weight:
            out.append((z, (float(c.y[j]), float(c.y[k]), float(xa)), 0.0))
    T, scale = r.track_gauge, max(abs(vl), abs(vr))
    for j in range(c.x.size):
        def twist(q, j=j):
            wz = q[0] * scale / T
            return np.array([side_v[j] + wz * c.y[j], -wz * c.x[j], wz])

        def fun(q, j=j):
            z = twist(q)
            acc, N = loads_for(z)
            F = others(z, N, [j])
            fx, fy = q[1] * r.weight, q[2] * r.weight
            Fx, Fy = F[0] + fx, F[1] + fy
            Mz = F[2] + c.x[j] * fy - c.y[j] * fx
            Mc = Mz - (r.cg_x * Fy - r.cg_y * Fx)
            return np.array([Fx - m * acc[0], Fy - m * acc[1], Mc / r.contact_length]) / r.weight

        for share in ROLLING_STARTS:  # yaw rate starts: shares of the ideal (V_R - V_L)/T
            with np.errstate(divide="ignore", invalid="ignore"):
                q = optimize.root(fun, np.array([share * (vr - vl) / scale, 0.0, 0.0]), method="hybr",
                                  options={"xtol": tol}).x
            res = float(np.max(np.abs(fun(q))))
            z = twist(q)
            if not (res <= _RESIDUAL_MAX and z[2] != 0.0):
                continue
            _, N = loads_for(z)
            if _inside_cone(c, j, q[1:] * r.weight, N[j]):
                out.append((z, ((z[0] - vl) / z[2], (z[0] - vr) / z[2], -z[1] / z[2]), res))
                break
    c.tipped = False
    return out


class PivotTurn(NamedTuple):
    """Closed-form quasi-static pivot turn: yaw rate [rad/s] and track ICRs [m]."""

    wz: float
    y_l: float
    y_r: float


def pivot_turn_closed_form(robot: Robot, v: float) -> PivotTurn:
    """Pivot turn V_L = -v, V_R = +v with uniform load and no inertia, from eq. (4) by brentq.

    Line contacts (track width ignored), continuous load (the limit n_points -> infinity).
    Requires cg_x = cg_y = 0 and equal friction on both tracks (else InputError).
    """
    if robot.cg_x != 0.0 or robot.cg_y != 0.0 or robot.friction_left != robot.friction_right:
        raise InputError("pivot_turn_closed_form: needs cg_x = cg_y = 0 and equal track friction")
    v = float(v)
    if not np.isfinite(v) or v == 0.0:
        raise InputError(f"pivot_turn_closed_form: v must be finite and non-zero, got {v!r}")
    T, h = robot.track_gauge, robot.track_length / 2

    def g(r: float) -> float:  # eq. (4) divided by c, with V = 1 and wz = r * 2/T
        c = 2.0 * r / T
        a = r - 1.0
        if a == 0.0:
            return h * h
        A = np.arcsinh(c * h / abs(a))
        s = np.hypot(a, c * h)
        return (h * s - a * a * A / c + T * a * A) / c

    ratio = optimize.brentq(g, 1e-9, 1.0, xtol=1e-16, rtol=4 * np.finfo(float).eps)
    wz = ratio * 2.0 * v / T
    return PivotTurn(wz=wz, y_l=v / wz, y_r=-v / wz)


def incline_rotation(angle: float, direction: float) -> np.ndarray:
    """3x3 rotation from the inclined plane's frame to the world (module docstring, "Slopes"):
    the world rotated about the horizontal axis (-sin D, cos D, 0) by -angle."""
    k = np.array([-np.sin(direction), np.cos(direction), 0.0])
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(-angle) * K + (1 - np.cos(-angle)) * K @ K  # Rodrigues


def plane_to_world(pose: np.ndarray, angle: float, direction: float) -> np.ndarray:
    """Plane-frame poses (n, 3) (x, y, yaw) -> world (n, 4): horizontal x, y, heading of the body
    x axis projected on the horizontal plane, and height z."""
    pose = np.atleast_2d(pose)
    R = incline_rotation(angle, direction)
    p = np.stack([pose[:, 0], pose[:, 1], np.zeros(len(pose))], axis=1) @ R.T
    h = np.stack([np.cos(pose[:, 2]), np.sin(pose[:, 2]), np.zeros(len(pose))], axis=1) @ R.T
    return np.stack([p[:, 0], p[:, 1], np.unwrap(np.arctan2(h[:, 1], h[:, 0])), p[:, 2]], axis=1)


def world_to_plane(x: np.ndarray, y: np.ndarray, z: np.ndarray, angle: float, direction: float) -> np.ndarray:
    """World positions (n,) x, y, z -> plane-frame positions (n, 2) (inverse of :func:`plane_to_world`)."""
    p = np.stack([x, y, z], axis=1) @ incline_rotation(angle, direction)
    return p[:, :2]


# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class CoulombRollout:
    """Time-domain result: t (n,) [s]; pose (n, 3) x, y [m], yaw [rad] of the geometric centre
    (world frame, yaw unwrapped); twist (n, 3) vx, vy [m/s], wz [rad/s] in the body frame."""

    t: np.ndarray
    pose: np.ndarray
    twist: np.ndarray

    def __post_init__(self) -> None:
        n = self.t.shape[0]
        if self.pose.shape != (n, 3) or self.twist.shape != (n, 3):
            raise MjtrackError("CoulombRollout: pose and twist must have shape (len(t), 3)")


def _as_input(value, t: np.ndarray, name: str) -> Callable[[float], float] | np.ndarray:
    if callable(value):
        return value
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        arr = np.full(t.shape, float(arr))
    if arr.shape != t.shape or not np.all(np.isfinite(arr)):
        raise InputError(f"{name} must be a callable, a number or finite samples shaped like t")
    return arr


def integrate_held_inputs(rhs, t, inputs, s0, *, what: str = "rollout", **solve_ivp_kw) -> np.ndarray:
    """Integrate s' = rhs(t, s, *u(t)) and return the states at the times t, shape (n, len(s0)).

    ``inputs``: numbers, samples shaped like t (zero-order hold: u(t) = u[k] on [t[k], t[k+1])),
    or callables u(t). With samples only, each constant segment is integrated on its own so
    that the integrator never steps over a jump. Shared by the time-domain models.
    """
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size < 2 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise InputError(f"{what}: t must be a 1-D, finite, strictly increasing array of >= 2 times")
    u = [_as_input(v, t, f"{what}: input {i}") for i, v in enumerate(inputs)]
    s0 = np.asarray(s0, dtype=float)
    if not np.all(np.isfinite(s0)):
        raise InputError(f"{what}: initial state must be finite")
    if any(callable(v) for v in u):
        def held(v, tt):
            return float(v(tt)) if callable(v) else float(v[min(np.searchsorted(t, tt, "right") - 1, t.size - 1)])

        sol = integrate.solve_ivp(lambda tt, s: rhs(tt, s, *(held(v, tt) for v in u)),
                                  (t[0], t[-1]), s0, t_eval=t, **solve_ivp_kw)
        if not sol.success:
            raise MjtrackError(f"{what}: integration failed ({sol.message})")
        return sol.y.T
    jumps = np.zeros(t.size - 1, dtype=bool)
    for v in u:
        jumps |= np.diff(v) != 0
    bounds = np.concatenate([[0], np.flatnonzero(jumps) + 1, [t.size - 1]])
    out = np.empty((t.size, s0.size))
    out[0] = s0
    for a, b in zip(bounds[:-1], bounds[1:]):
        if b <= a:
            continue
        sol = integrate.solve_ivp(rhs, (t[a], t[b]), out[a], t_eval=t[a:b + 1],
                                  args=tuple(float(v[a]) for v in u), **solve_ivp_kw)
        if not sol.success:
            raise MjtrackError(f"{what}: integration failed at t={t[a]:.3g} s ({sol.message})")
        out[a:b + 1] = sol.y.T
    return out


_TRANSFER_TOL = 1e-9 * G  # [m/s^2] residual of the load-transfer fixed point (rollout)


def _settle_transfer(fmap, f0: np.ndarray, unsettled: list, max_steps: int = 12) -> np.ndarray:
    """f with f = fmap(f) (the friction force per mass that the loads it causes produce), by
    Newton's method with a forward-difference Jacobian; counts a failure in ``unsettled``."""
    f = np.asarray(f0, float)
    for _ in range(max_steps):
        r = fmap(f) - f
        if np.max(np.abs(r)) <= _TRANSFER_TOL:
            return f
        h = 1e-6 * (1.0 + np.abs(f))
        J = np.empty((2, 2))
        for k in range(2):
            e = np.zeros(2)
            e[k] = h[k]
            J[:, k] = (fmap(f + e) - (f + e) - r) / h[k]
        try:
            f = f - np.linalg.solve(J, r)
        except np.linalg.LinAlgError:
            f = f + r  # a fixed-point step
    unsettled[0] += 1
    return f


def rollout(
    robot: Robot,
    t,
    v_left,
    v_right,
    *,
    pose0=(0.0, 0.0, 0.0),
    twist0=(0.0, 0.0, 0.0),
    rtol: float = 1e-8,
    atol: float = 1e-10,
    n_points: int = DEFAULT_N_POINTS,
    n_across: int = 1,
    eps: float = DEFAULT_EPS,
    inertia: float | None = None,
    load_transfer: bool = True,
    load_iterations: int | None = None,
    method: str = "LSODA",
    slope: float = 0.0,
    slope_direction: float = 0.0,
) -> CoulombRollout:
    """Integrate the rigid body on Coulomb contacts over the sample times t (n,) [s].

    On a slope (``slope`` [rad], rising along the world direction ``slope_direction`` [rad]) the
    pose is in the inclined plane's frame (module docstring, "Slopes"; :func:`plane_to_world`).

    v_left, v_right [m/s]: numbers, samples (n,) held constant from t[k] to t[k+1] (zero-order
    hold), or callables f(t). ``inertia``: yaw inertia about the CoM [kg m^2], default a uniform
    L x T box m (L^2 + T^2)/12. ``eps`` [m/s] regularises the Coulomb sign (module docstring).
    """
    t = np.asarray(t, dtype=float)
    if eps <= 0:
        raise InputError(f"rollout: eps must be > 0 (time-domain regularisation), got {eps!r}")
    if not (np.isfinite(slope) and abs(slope) < np.pi / 2 and np.isfinite(slope_direction)):
        raise InputError(f"rollout: slope must be finite and below pi/2, got {slope!r}")
    c = _Contacts(robot, n_points, n_across, slope)
    m = robot.mass
    g_up = G * np.sin(slope) * np.array([np.cos(slope_direction), np.sin(slope_direction)])  # plane frame
    I = inertia if inertia is not None else m * (robot.contact_length**2 + robot.track_gauge**2) / 12
    if not I > 0:
        raise InputError(f"rollout: inertia must be > 0, got {inertia!r}")
    cx, cy = c.cg
    unsettled = [0]  # evaluations whose load transfer did not settle

    def rhs(_t: float, s: np.ndarray, vl: float, vr: float) -> np.ndarray:
        _, _, yaw, vx, vy, wz = s
        tw = s[3:]
        co, si = np.cos(yaw), np.sin(yaw)
        gx, gy = -(co * g_up[0] + si * g_up[1]), -(-si * g_up[0] + co * g_up[1])  # g_t, body frame
        if load_transfer:
            acc = c.kinematic_accel(tw) - np.array([gx, gy])  # friction per mass, kinematic guess
            if load_iterations is None:
                acc = _settle_transfer(lambda f: c.wrench(tw, vl, vr, c.loads(*f), eps)[:2] / m, acc, unsettled)
            else:
                for _ in range(load_iterations):
                    acc = c.wrench(tw, vl, vr, c.loads(*acc), eps)[:2] / m
            N = c.loads(*acc)
        else:
            N = c.static_loads
        Fx, Fy, Mz = c.wrench(tw, vl, vr, N, eps)
        wdot = (Mz - (cx * Fy - cy * Fx)) / I  # gravity acts at the CoM: no moment about it
        vcx, vcy = vx - wz * cy, vy + wz * cx
        return np.array([
            co * vx - si * vy, si * vx + co * vy, wz,
            Fx / m + gx + wdot * cy + wz * vcy, Fy / m + gy - wdot * cx - wz * vcx, wdot,
        ])

    s0 = np.concatenate([np.asarray(pose0, float), np.asarray(twist0, float)])
    if s0.shape != (6,) or not np.all(np.isfinite(s0)):
        raise InputError("rollout: pose0 and twist0 must be 3 finite numbers each")
    out = integrate_held_inputs(rhs, t, (v_left, v_right), s0, what="rollout",
                                method=method, rtol=rtol, atol=atol)
    if c.tipped:
        log.warning("rollout: the load centroid left the support (tip-over); loads were clipped")
    if unsettled[0]:
        log.warning("rollout: the load transfer did not settle in %d evaluations (residual above %.1g m/s^2)",
                    unsettled[0], _TRANSFER_TOL)
    return CoulombRollout(t=t.copy(), pose=out[:, :3].copy(), twist=out[:, 3:].copy())
