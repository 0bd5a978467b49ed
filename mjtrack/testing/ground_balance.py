"""INDEPENDENT steady-state balance of a rigid two-track vehicle on a given ground (test oracle).

Shares no code with ``mjtrack.models.coulomb`` nor with ``mjtrack.sim.ground``: the contact is
quadrature (midpoint rule, ``M`` points per track) of a continuous load along each track line plus
point loads (road wheels), and the friction law is written out here. Steady state: the body twist
(vx, vy, wz) at which the ground's forces on both tracks sum to zero force and zero yaw moment
about the geometric centre (no drawbar pull, no inertia: the centre of mass on the centre).

Friction law at a contact point whose track material slides over the ground at u = (u_x, u_y)
(track frame): the maximum-dissipation force on the ellipse (f_x / mu)^2 + (f_y / (rho mu))^2
<= f_n^2, i.e. f = -f_n (mu^2 u_x, rho^2 mu^2 u_y) / sqrt(mu^2 u_x^2 + rho^2 mu^2 u_y^2); rho = 1 is
isotropic Coulomb. u = (vx - wz y - V_side, vy + wz x) at the point (x, y = +-T/2).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import fsolve

M = 400  # quadrature points per track for the spread load


def contact_points(L: float, *, wheels: int = 0, concentration: float = 0.0, span: float = 1.0):
    """(x, load fraction) of one track: (1 - c) spread uniformly over L, c on ``wheels`` equal
    point loads at span * (-L/2 + (j + 1/2) L / wheels). Fractions sum to 1."""
    x = -L / 2 + (np.arange(M) + 0.5) * L / M
    w = np.full(M, (1.0 - concentration) / M)
    if wheels:
        xw = span * (-L / 2 + (np.arange(wheels) + 0.5) * L / wheels)
        x = np.concatenate([x, xw])
        w = np.concatenate([w, np.full(wheels, concentration / wheels)])
    return x, w


def steady_twist(v_left: float, v_right: float, T: float, L: float, *, rho: float = 1.0, eps: float = 1e-9,
                 **load) -> np.ndarray:
    """(vx, vy, wz) of the steady state under track speeds (v_left, v_right) [m/s]."""
    x, w = contact_points(L, **load)

    def forces(z):
        vx, vy, wz = z
        total = np.zeros(3)
        for y, V in ((T / 2, v_left), (-T / 2, v_right)):
            ux = vx - wz * y - V
            uy = vy + wz * x
            norm = np.sqrt(ux**2 + (rho * uy) ** 2 + eps**2)
            fx = -w * ux / norm
            fy = -w * rho**2 * uy / norm
            total += [fx.sum(), fy.sum(), (x * fy - y * fx).sum()]
        return total

    guess = [(v_left + v_right) / 2, 0.0, 0.9 * (v_right - v_left) / T]
    z, info, ok, msg = fsolve(forces, guess, full_output=True, xtol=1e-12)
    if ok != 1 or np.abs(forces(z)).max() > 1e-7:
        raise RuntimeError(f"balance did not converge: {msg}")
    return z


def yaw_ratio(v_left: float, v_right: float, T: float, L: float, **kw) -> float:
    """wz / ((v_right - v_left) / T) at the steady state."""
    return float(steady_twist(v_left, v_right, T, L, **kw)[2] / ((v_right - v_left) / T))
