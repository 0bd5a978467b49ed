"""Simplified tracked-vehicle dynamics, eqs. (2.4)-(2.6) (after Dar & Longoria 2010), corrected.

Equations (body frame, geometric centre = centre of mass, uniform load; cg offsets ignored):
    m (vx' - wz vy) = F_L + F_R - R_L - R_R
    m (vy' + wz vx) = f_l
    I wz'           = (F_R - R_R) T/2 - (F_L - R_L) T/2 - M_r
The left sides are the CoM acceleration in robot-frame components (what (2.4) calls the
robot-frame x'', y''). Defects of the print: (2.6) uses b for one lever arm where the gauge T
is meant, and its world-frame form drops the (F - R) sin(theta) term of y''; (2.5) prints
M_r = -sgn(wz) ..., which with the "- M_r" of (2.4) would drive the rotation: the resisting
moment is M_r = +sgn(wz) ... (derived below, tested against the Coulomb reference).

Turning-resistance moment (2.5), re-derived. Each track carries m g/2 spread uniformly over its
contact length L, so both tracks together give a lateral friction load per unit length
q = mu_y m g / L. A body point at x slides laterally at vy + wz x = wz (x - d), zero on the
no-slip line x = d = -vy/wz; lateral friction per unit length is -q sgn(wz (x - d)). About the
geometric centre
    Mz = -q sgn(wz) int_{-L/2}^{L/2} x sgn(x - d) dx = -q sgn(wz) (L^2/4 - d^2),
so with I wz' = ... - M_r:
    M_r = sgn(wz) mu_y (m g / L) (L^2/4 - d^2),    |d| <= L/2,                          (2.5')
i.e. the printed l is the track length L (not a link length) and the d^2 enters with a minus
sign. For |d| > L/2 the track slides one way throughout and M_r = 0 (d clipped to +-L/2).
The same distribution gives the net lateral force f_l = 2 mu_y m g sgn(wz) d / L.

Derivation and measurements: docs/theory/tracked.md, "Dynamics in the time domain".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjtrack.errors import InputError
from mjtrack.io.robot import Robot
from mjtrack.models.coulomb import CoulombRollout, integrate_held_inputs


def _mu_y(robot: Robot, mu_y: float | None) -> float:
    mu = robot.mu if mu_y is None else float(mu_y)
    if not (np.isfinite(mu) and mu > 0):
        raise InputError(f"dynamics: mu_y must be a positive number, got {mu_y!r}")
    return mu


def turning_resistance_moment(robot: Robot, wz: float, d: float, *, mu_y: float | None = None) -> float:
    """M_r [N m] of eq. (2.5'): sgn(wz) mu_y (m g / L)(L^2/4 - d^2), d [m] clipped to +-L/2."""
    L = robot.track_length
    dc = float(np.clip(d, -L / 2, L / 2))
    return float(np.sign(wz)) * _mu_y(robot, mu_y) * robot.weight / L * (L * L / 4 - dc * dc)


def lateral_friction_force(robot: Robot, wz: float, d: float, *, mu_y: float | None = None) -> float:
    """Net lateral friction f_l [N] of the same distribution: 2 mu_y m g sgn(wz) d / L (d clipped)."""
    L = robot.track_length
    dc = float(np.clip(d, -L / 2, L / 2))
    return 2.0 * _mu_y(robot, mu_y) * robot.weight * float(np.sign(wz)) * dc / L


@dataclass(frozen=True)
class TrackedDynamics:
    """Parameters of the simplified dynamics (module docstring).

    mu_y: lateral friction [-] (None: robot.mu). inertia: yaw inertia [kg m^2] (None: uniform
    L x T box, m (L^2 + T^2)/12). traction_eps, lateral_eps: regularisation speeds [m/s].
    rolling_resistance: coefficient [-]. n_points: stations along the tracks for f_l, M_r.
    """

    robot: Robot
    mu_y: float | None = None
    inertia: float | None = None
    rolling_resistance: float = 0.0
    traction_eps: float = 0.05
    lateral_eps: float = 1e-3
    n_points: int = 200

    def __post_init__(self) -> None:
        _mu_y(self.robot, self.mu_y)
        for name in ("traction_eps", "lateral_eps"):
            if not getattr(self, name) > 0:
                raise InputError(f"TrackedDynamics: {name} must be > 0, got {getattr(self, name)!r}")
        if not self.rolling_resistance >= 0:
            raise InputError(f"TrackedDynamics: rolling_resistance must be >= 0, got {self.rolling_resistance!r}")
        if self.inertia is not None and not self.inertia > 0:
            raise InputError(f"TrackedDynamics: inertia must be > 0, got {self.inertia!r}")
        if int(self.n_points) != self.n_points or self.n_points < 2:
            raise InputError(f"TrackedDynamics: n_points must be an integer >= 2, got {self.n_points!r}")

    @property
    def yaw_inertia(self) -> float:
        r = self.robot
        return self.inertia if self.inertia is not None else r.mass * (r.track_length**2 + r.track_gauge**2) / 12

    @property
    def track_loads(self) -> tuple[float, float]:
        """(N_L, N_R) [N] by the lever rule."""
        r = self.robot
        return r.weight * (0.5 + r.cg_y / r.track_gauge), r.weight * (0.5 - r.cg_y / r.track_gauge)

    def lateral(self, vy: float, wz: float) -> tuple[float, float]:
        """(f_l [N], M_r [N m]) from the regularised lateral-friction distribution (midpoint rule)."""
        r = self.robot
        L, n = r.track_length, int(self.n_points)
        x = -L / 2 + (np.arange(n) + 0.5) * L / n
        u = vy + wz * x
        f = -_mu_y(r, self.mu_y) * r.weight / L * u / np.sqrt(u * u + self.lateral_eps**2) * (L / n)
        return float(f.sum()), -float(x @ f)

    def traction(self, vx: float, wz: float, v_left: float, v_right: float) -> tuple[float, float]:
        """Traction law: (F_L, F_R) [N] from track speeds [m/s] (module docstring)."""
        mu, T, e = self.robot.mu, self.robot.track_gauge, self.traction_eps
        out = []
        for V, vc, N in zip((v_left, v_right), (vx - wz * T / 2, vx + wz * T / 2), self.track_loads):
            s = V - vc
            out.append(mu * N * s / np.sqrt(s * s + e * e))
        return out[0], out[1]

    def derivative(self, state: np.ndarray, f_left: float, f_right: float) -> np.ndarray:
        """d/dt of state (x, y, yaw, vx, vy, wz) for traction forces f_left, f_right [N]."""
        _, _, yaw, vx, vy, wz = state
        r = self.robot
        m, T = r.mass, r.track_gauge
        rl, rr = (
            self.rolling_resistance * N * v / np.sqrt(v * v + self.traction_eps**2)
            for N, v in zip(self.track_loads, (vx - wz * T / 2, vx + wz * T / 2))
        )
        f_l, M_r = self.lateral(vy, wz)
        co, si = np.cos(yaw), np.sin(yaw)
        return np.array([
            co * vx - si * vy,
            si * vx + co * vy,
            wz,
            (f_left + f_right - rl - rr) / m + wz * vy,
            f_l / m - wz * vx,
            ((f_right - rr) * T / 2 - (f_left - rl) * T / 2 - M_r) / self.yaw_inertia,
        ])


def simulate(
    model: TrackedDynamics,
    t,
    *,
    forces=None,
    v_left=None,
    v_right=None,
    pose0=(0.0, 0.0, 0.0),
    twist0=(0.0, 0.0, 0.0),
    rtol: float = 1e-8,
    atol: float = 1e-10,
    method: str = "LSODA",
) -> CoulombRollout:
    """Integrate the simplified dynamics over the times t (n,) [s].

    Give either ``forces=(F_L, F_R)`` [N] or ``v_left``, ``v_right`` [m/s] (traction law);
    each a number, samples shaped like t (zero-order hold) or a callable of t.
    Returns (t, pose (n, 3), twist (n, 3)) as :class:`CoulombRollout`.
    """
    s0 = np.concatenate([np.asarray(pose0, float), np.asarray(twist0, float)])
    if s0.shape != (6,):
        raise InputError("simulate: pose0 and twist0 must be 3 numbers each")
    if (forces is None) == (v_left is None or v_right is None):
        raise InputError("simulate: give either forces=(F_L, F_R) or both v_left and v_right")
    if forces is not None:
        inputs = tuple(forces)
        if len(inputs) != 2:
            raise InputError("simulate: forces must be a pair (F_L, F_R)")

        def rhs(_t, s, fl, fr):
            return model.derivative(s, fl, fr)
    else:
        inputs = (v_left, v_right)

        def rhs(_t, s, vl, vr):
            return model.derivative(s, *model.traction(s[3], s[5], vl, vr))

    out = integrate_held_inputs(rhs, t, inputs, s0, what="simulate", method=method, rtol=rtol, atol=atol)
    t = np.asarray(t, dtype=float)
    return CoulombRollout(t=t.copy(), pose=out[:, :3].copy(), twist=out[:, 3:].copy())
