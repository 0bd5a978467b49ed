"""Fast surrogate of the tracked robot's skid-steer response, from the rigid-track Coulomb reference.

Derivation (``mjtrack.models.coulomb``). On Coulomb contacts the sliding velocity of the
contact point i is u_i = wz (y_side - y_i, x_i - x_c) written with the ICRs q = (y_l, y_r, x_c)
(eq. 2.13), so the friction forces -mu_i N_i u_i/|u_i| depend on q and sign(wz) only, and they
flip with sign(wz). Hence:

1. Quasi-static (no inertia, flat ground): the balance F = 0, M = 0 fixes q = q0 whatever the
   track speeds and the turn direction. The quasi-static robot *is* MICR (2.14) with constant
   ICRs q0; q0 depends on the load distribution (cg_x, cg_y), the friction ratio mu_L/mu_R and
   L/T, but not on the friction level or the mass.
2. Inertia and slope enter through one body-frame "effective acceleration" of the CoM,
       a_eff = a + g sin(slope) u_up,   a = (-wz (vy + wz c_x), wz (vx - wz c_y))
   (centripetal acceleration of the steady twist; u_up the uphill unit vector in the body
   frame). The steady balance reads  s fs W(q; N(a_eff)) = m a_eff  (s = sign(wz), fs the
   friction scale, N the Wong loads with the load transfer c - h a_eff / g). To first order in
   a_eff / (mu g):
       q = q0 + B_s^transfer a_eff + B_s^inertia a_eff / fs,
   with the 3x2 response matrices B_s computed here by finite differences of full nonlinear
   solves (``_solve_icr``), one pair per turn direction s. B^inertia is the response with the
   load transfer switched off; B^transfer the rest. Friction scale acts *only* through the
   inertia term: it is identifiable only from fast turns (|a|/(mu g) not small).
3. The static effects (cg offsets, friction ratio) change q0; they are tabulated by exact
   quasi-static solves on a grid of the parameter and interpolated (``static_table``).

Derivation and measurements: docs/theory/diagnosis.md, "Surrogate transients".
"""

from __future__ import annotations

import functools
import logging
import math
from dataclasses import dataclass

import numpy as np
from scipy import optimize

from mjtrack.errors import MjtrackError
from mjtrack.io.robot import Robot
from mjtrack.models import coulomb

log = logging.getLogger(__name__)

_N_POINTS = 100  # contact points per track for the surrogate (the ICRs converge as 1/n^2)
_DA = 0.05  # [m/s^2] finite-difference step of the acceleration response


def _residual(robot: Robot, q: np.ndarray, s: float, a: np.ndarray, transfer: bool) -> np.ndarray:
    """Steady balance (coulomb eq. 3) written with the ICRs q and wz = s = +-1, / (m g)."""
    yl, yr, xc = q
    # twist with wz = s and vx = 0: V_L = -s y_l, V_R = -s y_r, vy = -s x_c (eq. 2.13)
    fx, fy, mz = coulomb.contact_wrench(robot, 0.0, -s * xc, s, -s * yl, -s * yr, n_points=_N_POINTS,
                                        accel=tuple(a) if transfer else (0.0, 0.0))
    m = robot.mass
    mc = mz - (robot.cg_x * fy - robot.cg_y * fx)
    return np.array([fx - m * a[0], fy - m * a[1], mc / robot.track_length]) / robot.weight


def _solve_icr(robot: Robot, s: float, a=(0.0, 0.0), *, transfer: bool = True, q0=None) -> np.ndarray:
    """ICRs (y_l, y_r, x_c) [m] of the steady turn with sign(wz) = s under the CoM acceleration a."""
    a = np.asarray(a, dtype=float)
    T = robot.track_gauge
    start = np.array([0.65 * T, -0.65 * T, 0.0]) if q0 is None else np.asarray(q0, float)
    sol = optimize.root(lambda z: _residual(robot, z * T, s, a, transfer), start / T, method="hybr",
                        options={"xtol": 1e-12})
    res = np.max(np.abs(_residual(robot, sol.x * T, s, a, transfer)))
    if not res < 1e-9:
        raise MjtrackError(f"surrogate: no Coulomb steady state for a={a.tolist()} (residual {res:.2g})")
    return sol.x * T


@dataclass(frozen=True)
class GroundResponse:
    """First-order Coulomb response of one robot (see module docstring).

    q0: (3,) quasi-static ICRs (y_l, y_r, x_c) [m].
    b_transfer, b_inertia: (2, 3, 2) dq/da_eff [m per m/s^2]; index 0 for wz > 0, 1 for wz < 0.
    resist_ratio: turning resistance / available track force [-]: the differential longitudinal
        track force (F_R - F_L) s of the quasi-static turn over sum mu_s N_s (item 4).
    """

    q0: np.ndarray
    b_transfer: np.ndarray
    b_inertia: np.ndarray
    resist_ratio: float = 0.0

    def icr(self, q_static: np.ndarray, wz_sign: np.ndarray, a_eff: np.ndarray, *, friction_scale=1.0,
            inertia: bool = True) -> np.ndarray:
        """ICRs (N, 3) for static ICRs q_static (N, 3), sign(wz) (N,), a_eff (N, 2) [m/s^2]."""
        k = (wz_sign < 0).astype(int)
        resp = self.b_transfer[k] + (self.b_inertia[k] / friction_scale if inertia else 0.0)
        return q_static + np.einsum("nij,nj->ni", resp, a_eff)


def _key(robot: Robot) -> tuple:
    return (robot.track_gauge, robot.track_length, robot.mass, robot.cg_x, robot.cg_y, robot.cg_z,
            robot.friction_left, robot.friction_right, robot.ground)


@functools.lru_cache(maxsize=16)
def _response_cached(key: tuple) -> GroundResponse:
    T, L, m, cx, cy, cz, mul, mur, ground = key
    robot = Robot(track_gauge=T, track_length=L, mass=m, cg_x=cx, cg_y=cy, cg_z=cz, mu=mur, mu_left=mul, mu_right=mur,
                  ground=ground)
    q0 = np.array(coulomb.steady_state(robot, 0.0, 1.0, inertial=False, n_points=_N_POINTS).icr)
    bt = np.zeros((2, 3, 2))
    bi = np.zeros((2, 3, 2))
    for k, s in enumerate((1.0, -1.0)):
        for j in range(2):
            da = np.zeros(2)
            da[j] = _DA
            for transfer, out in ((True, bt), (False, bi)):
                qp = _solve_icr(robot, s, da, transfer=transfer, q0=q0)
                qm = _solve_icr(robot, s, -da, transfer=transfer, q0=q0)
                out[k, :, j] = (qp - qm) / (2 * _DA)
    return GroundResponse(q0=q0, b_transfer=bt - bi, b_inertia=bi, resist_ratio=_resist_ratio(robot, q0))


def _resist_ratio(robot: Robot, q0: np.ndarray) -> float:
    """(F_R - F_L) s / sum mu_s N_s in the quasi-static turn, mean over both turn directions: the
    moment (T/2)(F_R - F_L) the tracks' longitudinal forces must supply against the lateral
    friction (the wrench is linear in each track's mu: one track's share is the wrench with the
    other's mu set to ~0)."""
    yl, yr, xc = q0
    out = []
    for s in (1.0, -1.0):
        fx = []
        for side in ("left", "right"):
            other = "mu_right" if side == "left" else "mu_left"
            r = robot.replace(mu_left=robot.friction_left, mu_right=robot.friction_right).replace(**{other: 1e-12})
            fx.append(coulomb.contact_wrench(r, 0.0, -s * xc, s, -s * yl, -s * yr, n_points=_N_POINTS)[0])
        out.append(s * (fx[1] - fx[0]))
    return float(np.mean(out)) / (robot.weight * 0.5 * (robot.friction_left + robot.friction_right))


def ground_response(robot: Robot) -> GroundResponse:
    """The first-order Coulomb response of ``robot`` (cached per robot)."""
    return _response_cached(_key(robot))


@functools.lru_cache(maxsize=64)
def _static_cached(key: tuple, field: str, values: tuple) -> tuple[np.ndarray, np.ndarray]:
    T, L, m, cx, cy, cz, mul, mur, ground = key
    kept, out = [], []
    for v in values:
        kw = dict(track_gauge=T, track_length=L, mass=m, cg_x=cx, cg_y=cy, cg_z=cz, mu=mur, mu_left=mul, mu_right=mur,
                  ground=ground)
        if field == "friction_ratio":
            kw["mu_left"] = v * mur
        else:
            kw[field] = v
        try:  # the library solver has the robust fallbacks (shortened contact at large cg offsets)
            out.append(coulomb.steady_state(Robot(**kw), 0.0, 1.0, inertial=False, n_points=_N_POINTS).icr)
        except MjtrackError:  # a nearly unloaded track: no steady state, leave the value out
            log.debug("surrogate: no quasi-static solution for %s = %g", field, v)
            continue
        kept.append(v)
    return np.array(kept), np.array(out)


def static_table(robot: Robot, field: str, values) -> tuple[np.ndarray, np.ndarray]:
    """Quasi-static ICRs (G', 3) [m] with ``field`` (cg_x, cg_y or friction_ratio = mu_L/mu_R) set
    to each of ``values`` (absolute values, not offsets); returns (values kept (G',), ICRs):
    values without a solution (a nearly unloaded track) are left out."""
    return _static_cached(_key(robot), field, tuple(float(v) for v in values))


def accel_limited(u: np.ndarray, dt: np.ndarray, a: float, starts: np.ndarray) -> np.ndarray:
    """One mode ramping at a fixed rate (the straight-start case of :func:`friction_limited`):
    per-step means (N,) of a speed that follows the held targets u (N,) [m/s] at most at ``a``
    [m/s^2]; dt (N,) step lengths [s]; ``starts`` (N,) bool, segment starts (the speed is at its
    target there: a segment is assumed to start in steady motion).

    The state y_k (speed at t_k) moves towards u_k over step k by at most a h_k; the mean over
    the step is y_k + s a h/2 while ramping, u_k - d tau/(2 h) when it arrives after tau = |d|/a.
    Only jumps larger than a h_k start a ramp (a smaller change settles within the step and is
    left as is), so the cost is the number of ramps, not of samples.
    """
    out = np.array(u, dtype=float)
    n = out.size
    lim = a * dt
    jump = np.abs(np.diff(out, prepend=out[:1]))
    jump[starts] = 0.0
    done = -1
    for k0 in np.flatnonzero(jump > lim):
        if k0 <= done:
            continue
        y = float(u[k0 - 1])
        k = k0
        while k < n and (k == k0 or not starts[k]):
            d, h = float(u[k]) - y, float(dt[k])
            if abs(d) > a * h:
                step = np.copysign(a * h, d)
                out[k] = y + 0.5 * step
                y += step
                k += 1
                continue
            out[k] = u[k] - d * (abs(d) / a) / (2 * h) if h > 0 else u[k]
            break
        done = k
    return out


_TOL = 1e-9  # [m/s] an effective track speed this close to its command has arrived
_MAX_EVENTS = 12  # contact-mode switches followed within one step (2-3 in practice)


def _mode_accels(eL, eR, vL, vR, bL, bR, kappa, resist):
    """Accelerations (eL', eR') [m/s^2] of the effective track speeds (:func:`friction_limited`).

    A track whose speed differs from its command slides: force b sign(v - e). A track at its
    command holds it with the force that keeps e' = 0, if that is within its bound (else it
    slides at the bound). The lateral friction resists the yaw with ``resist`` sign(d) while
    d = (eR - eL)/2 != 0, and up to ``resist`` (static) at d = 0."""
    gl, gr = vL - eL, vR - eR
    sl, sr = abs(gl) > _TOL, abs(gr) > _TOL
    if not (sl or sr):
        return 0.0, 0.0
    d = 0.5 * (eR - eL)
    turning = abs(d) > _TOL
    fl = math.copysign(bL, gl) if sl else 0.0
    fr = math.copysign(bR, gr) if sr else 0.0
    if sl and sr:
        m = math.copysign(resist, d) if turning else min(max(fr - fl, -resist), resist)
    else:  # one track holds its speed
        fo, b = (fr, bL) if sr else (fl, bR)
        if not turning:
            if 2.0 * abs(fo) <= resist and abs(fo) <= b:
                return 0.0, 0.0  # static yaw (d' = 0) and f_held = -f_other (c' = 0): nothing moves
            s = fo if sr else -fo  # the yaw starts the way the sliding track turns the body
        else:
            s = d
        m = math.copysign(resist, s)
        # held L: eL' = fL (1 + k) + fR (1 - k) + k m = 0;  held R: eR' = fR (1 + k) + fL (1 - k) - k m = 0
        if sr:
            fl = min(max(((kappa - 1.0) * fo - kappa * m) / (1.0 + kappa), -b), b)
        else:
            fr = min(max(((kappa - 1.0) * fo + kappa * m) / (1.0 + kappa), -b), b)
    dd = kappa * (fr - fl - m)
    cc = fl + fr
    return cc - dd, cc + dd


def _friction_step(eL, eR, vL, vR, h, bL, bR, kappa, resist):
    """Advance (eL, eR) over one held step of length h [s]; returns (eL, eR, mean eL, mean eR)."""
    sL = sR = 0.0
    left = h
    for _ in range(_MAX_EVENTS):
        aL, aR = _mode_accels(eL, eR, vL, vR, bL, bR, kappa, resist)
        if aL == 0.0 and aR == 0.0:
            break
        tau, event = left, 0
        gap = vL - eL
        if gap * aL > 0.0 and gap / aL < tau:
            tau, event = gap / aL, 1
        gap = vR - eR
        if gap * aR > 0.0 and gap / aR < tau:
            tau, event = gap / aR, 2
        d, dd = eR - eL, aR - aL
        if d * dd < 0.0 and abs(d) > 2 * _TOL and -d / dd < tau:
            tau, event = -d / dd, 3
        sL += (eL + 0.5 * aL * tau) * tau
        sR += (eR + 0.5 * aR * tau) * tau
        eL += aL * tau
        eR += aR * tau
        left -= tau
        if event == 1:
            eL = vL
        elif event == 2:
            eR = vR
        elif event == 3:
            eL = eR = 0.5 * (eL + eR)
        if left <= 0.0:
            break
    sL += eL * left
    sR += eR * left
    return eL, eR, sL / h, sR / h


def friction_limited(u: np.ndarray, dt: np.ndarray, starts: np.ndarray, *, b_left: float, b_right: float,
                     kappa: float, resist: float) -> np.ndarray:
    """Per-step means (N, 2) of the effective track speeds (e_L, e_R) that follow the held
    commands u (N, 2) [m/s] as far as the track friction lets the rigid body follow; dt (N,)
    step lengths [s]; ``starts`` (N,) bool segment starts (steady motion there).

    Reduced rigid-body model (derivation in the module docstring, item 4): with c = (e_L + e_R)/2,
    d = (e_R - e_L)/2 and per-mass track forces f_s in [-b_s, b_s] [m/s^2],
        c' = f_L + f_R,     d' = kappa (f_R - f_L - resist sign(d)),
    a sliding track (e_s != u_s) pulls with b_s sign(u_s - e_s), a track at its command holds
    it (e_s' = 0) within its bound. Integrated exactly (piecewise-constant accelerations between
    mode switches); only the samples after a change larger than b_min h / 2 are simulated (a
    smaller one is left as a step: it settles within the step, mean error Delta^2 / (2 a h) with
    a >= ~1.1 b_min the slowest track acceleration (the turn entry), <= 0.12 b_min h, 0.02 m/s
    over one 0.05 s step at mu = 0.8), so the cost is the number of ramps, not of samples.
    """
    u = np.asarray(u, dtype=float)
    out = u.copy()
    n = u.shape[0]
    # like accel_limited, a change that settles early in its step is left as is (measured speeds
    # jitter at every sample, an input lag smooths them): only jumps beyond half the slowest
    # track's reach start a ramp
    lim = 0.5 * min(b_left, b_right) * np.asarray(dt, dtype=float)
    change = (np.max(np.abs(np.diff(u, axis=0, prepend=u[:1])), axis=1) > lim) & ~starts
    done = -1
    for k0 in np.flatnonzero(change):
        if k0 <= done:
            continue
        eL, eR = float(u[k0 - 1, 0]), float(u[k0 - 1, 1])
        k = k0
        while k < n and (k == k0 or not starts[k]):
            vL, vR, h = float(u[k, 0]), float(u[k, 1]), float(dt[k])
            if h <= 0.0:
                eL, eR = vL, vR
                k += 1
                continue
            eL, eR, out[k, 0], out[k, 1] = _friction_step(eL, eR, vL, vR, h, b_left, b_right, kappa, resist)
            if abs(eL - vL) <= _TOL and abs(eR - vR) <= _TOL:
                break
            k += 1
        done = k
    return out


def twist_from_q(q: np.ndarray, v_left: np.ndarray, v_right: np.ndarray) -> np.ndarray:
    """Eq. (2.14) for per-sample ICRs q (N, 3): body twist (N, 3)."""
    yl, yr, xc = q[:, 0], q[:, 1], q[:, 2]
    d = yl - yr
    wz = (v_right - v_left) / d
    return np.stack([(yl * v_right - yr * v_left) / d, -xc * wz, wz], -1)


def centripetal(twist: np.ndarray, cg_x, cg_y) -> np.ndarray:
    """Body-frame CoM acceleration (N, 2) [m/s^2] of the steady twist (N, 3)."""
    vx, vy, wz = twist[:, 0], twist[:, 1], twist[:, 2]
    return np.stack([-wz * (vy + wz * cg_x), wz * (vx - wz * cg_y)], -1)


__all__ = ["GroundResponse", "ground_response", "static_table", "accel_limited", "friction_limited", "twist_from_q",
           "centripetal"]
