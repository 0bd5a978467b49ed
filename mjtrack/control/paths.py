"""Geometric paths for the controllers: smooth parametric curves and polylines.

A :class:`ParametricPath` is r(u) = (x(u), y(u)), u in [u_start, u_end], with its first and
second derivatives.  From them (thesis 3.1.1):

    osculating-circle radius (3.1)  rho(u) = (x'^2 + y'^2)^(3/2) / (x' y'' - y' x'')
    arc length (3.2)                s(u) = integral_{u_start}^{u} sqrt(x'^2 + y'^2) du

rho is signed (positive: the path turns left); :meth:`ParametricPath.curvature` returns
kappa = 1/rho, which stays finite on straight parts.  s(u) is tabulated once on a fine grid
(composite Simpson on each cell pair, ``n_table`` cells) and inverted by interpolation, which
replaces the thesis's analytic inversion x = x(s) (3.3) and works for any parametric path.

A :class:`Polyline` is the line that the line-following robot senses (thesis 3.2.2.1).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from mjtrack.errors import InputError

Fn = Callable[[np.ndarray], np.ndarray]


class ParametricPath:
    """Smooth planar path r(u) with derivatives; see the module docstring.

    Args:
        x, y, dx, dy, ddx, ddy: vectorised functions of u.
        u_start, u_end: parameter range.
        n_table: cells of the arc-length table.
    """

    def __init__(self, x: Fn, y: Fn, dx: Fn, dy: Fn, ddx: Fn, ddy: Fn, *, u_start: float, u_end: float,
                 n_table: int = 4000) -> None:
        if not u_end > u_start:
            raise InputError(f"ParametricPath: need u_end > u_start, got {u_start}, {u_end}")
        self._f = (x, y, dx, dy, ddx, ddy)
        self.u_start, self.u_end = float(u_start), float(u_end)
        u = np.linspace(self.u_start, self.u_end, 2 * n_table + 1)
        speed = np.hypot(dx(u), dy(u))
        if np.any(speed <= 0):
            raise InputError("ParametricPath: the parametrisation is singular (|r'(u)| = 0)")
        # Simpson on pairs of cells gives s at even nodes; odd nodes by trapezoid refinement.
        h = u[1] - u[0]
        pair = h / 3 * (speed[0:-2:2] + 4 * speed[1:-1:2] + speed[2::2])
        s_even = np.concatenate([[0.0], np.cumsum(pair)])
        self._u_table = u[::2]
        self._s_table = s_even
        self.length = float(s_even[-1])

    def point(self, u) -> np.ndarray:
        """(…, 2) position [m]."""
        return np.stack([self._f[0](np.asarray(u, float)), self._f[1](np.asarray(u, float))], -1)

    def heading(self, u) -> np.ndarray:
        """Tangent direction atan2(y', x') [rad]."""
        u = np.asarray(u, float)
        return np.arctan2(self._f[3](u), self._f[2](u))

    def curvature(self, u) -> np.ndarray:
        """Signed curvature kappa = 1/rho (3.1) [1/m]."""
        u = np.asarray(u, float)
        dx, dy, ddx, ddy = (f(u) for f in self._f[2:])
        return (dx * ddy - dy * ddx) / np.hypot(dx, dy) ** 3

    def radius(self, u) -> np.ndarray:
        """Signed osculating-circle radius rho(u) (3.1) [m]; inf on straight parts."""
        with np.errstate(divide="ignore"):
            return 1.0 / self.curvature(u)

    def arc_length(self, u) -> np.ndarray:
        """s(u) (3.2) [m], interpolated linearly in the Simpson table."""
        return np.interp(u, self._u_table, self._s_table)

    def u_at(self, s) -> np.ndarray:
        """Inverse of s(u): the parameter at arc length s [m] (clipped to the path)."""
        return np.interp(s, self._s_table, self._u_table)

    def pose_at(self, s: float) -> np.ndarray:
        """(x [m], y [m], heading [rad]) at arc length ``s`` [m]; before the start and past the end
        the path is continued along its end tangents (a goal that runs ahead of the robot on the
        path does not stop short of the end)."""
        s = float(s)
        edge = min(max(s, 0.0), self.length)
        u = float(self.u_at(edge))
        x, y = self.point(u)
        h = float(self.heading(u))
        extra = s - edge
        return np.array([x + extra * math.cos(h), y + extra * math.sin(h), h])

    def polyline(self, *, spacing: float = 0.01) -> Polyline:
        """The path as a :class:`Polyline` with vertices every ``spacing`` [m] of arc length (a
        chord of a circle of radius R then lies spacing^2/(8 R) inside it)."""
        if not spacing > 0:
            raise InputError(f"ParametricPath.polyline: spacing must be positive, got {spacing}")
        s = np.linspace(0.0, self.length, max(2, int(math.ceil(self.length / spacing)) + 1))
        return Polyline(self.point(self.u_at(s)))


def circle_path(*, centre=(0.0, 0.0), radius: float = 1.0, start_angle: float = -math.pi / 2,
                turns: float = 1.0, ccw: bool = True) -> ParametricPath:
    """Circle of ``radius`` [m] about ``centre``, starting at polar angle ``start_angle`` [rad]."""
    if not radius > 0:
        raise InputError(f"circle_path: radius must be positive, got {radius}")
    cx, cy = centre
    sgn = 1.0 if ccw else -1.0
    a0 = start_angle
    return ParametricPath(
        lambda u: cx + radius * np.cos(a0 + sgn * u), lambda u: cy + radius * np.sin(a0 + sgn * u),
        lambda u: -sgn * radius * np.sin(a0 + sgn * u), lambda u: sgn * radius * np.cos(a0 + sgn * u),
        lambda u: -radius * np.cos(a0 + sgn * u), lambda u: -radius * np.sin(a0 + sgn * u),
        u_start=0.0, u_end=2 * math.pi * turns,
    )


def figure_eight_path(*, size: float = 1.0, centre=(0.0, 0.0), laps: float = 1.0) -> ParametricPath:
    """Lemniscate of Gerono x = A sin u, y = (A/2) sin 2u, u in [0, 2 pi laps]; A = ``size`` [m].

    Starts at the crossing point heading +45 degrees; the first lobe (x > 0) is driven clockwise,
    the second counter-clockwise.  |r'(u)|^2 = A^2 (cos^2 u + cos^2 2u) never vanishes, so kappa
    is finite everywhere; at the lobe tips (u = pi/2, 3 pi/2) kappa = -1/A and +1/A.
    """
    if not size > 0:
        raise InputError(f"figure_eight_path: size must be positive, got {size}")
    cx, cy = centre
    a = size
    return ParametricPath(
        lambda u: cx + a * np.sin(u), lambda u: cy + 0.5 * a * np.sin(2 * u),
        lambda u: a * np.cos(u), lambda u: a * np.cos(2 * u),
        lambda u: -a * np.sin(u), lambda u: -2 * a * np.sin(2 * u),
        u_start=0.0, u_end=2 * math.pi * laps,
    )


def lane_change_path(*, shift: float = 1.0, length: float = 3.0, lead_in: float = 1.5, lead_out: float = 1.5,
                     start=(0.0, 0.0)) -> ParametricPath:
    """Straight ``lead_in`` [m], a lateral shift of ``shift`` [m] (left if positive) over ``length`` [m]
    of travel along x, straight ``lead_out`` [m]; heading 0 at both ends.

    Shift profile y = h (σ − sin(2π σ)/(2π)), σ = (x − lead_in)/length in [0, 1]: y' = (h/ℓ)(1 − cos 2πσ)
    and y'' = (2π h/ℓ²) sin 2πσ vanish at both ends, so the curvature is continuous (no step in
    the yaw-rate command, unlike a cosine blend); it turns left then right (or the reverse for a
    negative shift); y'' peaks at 2π h/ℓ² (σ = 1/4, 3/4), the curvature y''/(1 + y'²)^1.5 at
    0.617 1/m for h = 1 m, ℓ = 3 m (radius 1.6 m).
    """
    if not (length > 0 and lead_in >= 0 and lead_out >= 0):
        raise InputError(f"lane_change_path: need length > 0, lead_in and lead_out >= 0, got {length}, {lead_in}, {lead_out}")
    x0, y0 = start
    h, ell, two_pi = float(shift), float(length), 2 * math.pi

    def sig(u):
        return np.clip((np.asarray(u, float) - x0 - lead_in) / ell, 0.0, 1.0)

    return ParametricPath(
        lambda u: np.asarray(u, float), lambda u: y0 + h * (sig(u) - np.sin(two_pi * sig(u)) / two_pi),
        lambda u: np.ones_like(np.asarray(u, float)), lambda u: h / ell * (1 - np.cos(two_pi * sig(u))),
        lambda u: np.zeros_like(np.asarray(u, float)), lambda u: two_pi * h / ell**2 * np.sin(two_pi * sig(u)),
        u_start=x0, u_end=x0 + lead_in + ell + lead_out,
    )


@dataclass(frozen=True)
class Polyline:
    """A line on the floor: (N, 2) vertices [m], N >= 2, no zero-length segment."""

    points: np.ndarray

    def __post_init__(self) -> None:
        pts = np.asarray(self.points, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 2 or pts.shape[0] < 2:
            raise InputError(f"Polyline: points must have shape (N >= 2, 2), got {pts.shape}")
        if np.any(np.hypot(*np.diff(pts, axis=0).T) <= 0):
            raise InputError("Polyline: two consecutive vertices coincide")
        object.__setattr__(self, "points", pts)

    def closest(self, p, *, near: float | None = None, window: float = math.inf) -> tuple[float, float, int]:
        """(signed distance [m], arc length at the foot point [m], segment index) of point p.

        Sign: positive when p lies to the left of the line's direction of travel.
        With ``near`` [m], only the segments that reach within ``window`` [m] of that arc length
        are searched: on a line that crosses or retraces itself (a figure-eight, several laps)
        the part being followed is then not confused with another one passing close by.
        """
        p = np.asarray(p, dtype=float)
        a, b = self.points[:-1], self.points[1:]
        d = b - a
        seg_len2 = np.sum(d * d, axis=1)
        lam = np.clip(np.sum((p - a) * d, axis=1) / seg_len2, 0.0, 1.0)
        foot = a + lam[:, None] * d
        dist = np.hypot(*(p - foot).T)
        seg_start = np.concatenate([[0.0], np.cumsum(np.sqrt(seg_len2))[:-1]])
        if near is not None and math.isfinite(window):
            outside = (seg_start + np.sqrt(seg_len2) < near - window) | (seg_start > near + window)
            if not np.all(outside):
                dist = np.where(outside, np.inf, dist)
        i = int(np.argmin(dist))
        cross = d[i, 0] * (p[1] - a[i, 1]) - d[i, 1] * (p[0] - a[i, 0])
        return (math.copysign(float(dist[i]), cross if cross != 0 else 1.0),
                float(seg_start[i] + lam[i] * math.sqrt(seg_len2[i])), i)

    @property
    def length(self) -> float:
        return float(np.sum(np.hypot(*np.diff(self.points, axis=0).T)))
