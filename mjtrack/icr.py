"""Instantaneous centres of rotation (ICRs), the virtual wheeled robot, slip ratios.

Conventions (as in the tracked-robot thesis, Mendaluk 2019; docs/theory/tracked.md): robot
frame x forward, y left; left track at y = +T/2, right at
y = -T/2; V_L, V_R the track surface speeds relative to the body (positive forward);
body twist (vx, vy, wz) of the geometric centre.

ICRs from motion, eq. (2.13) (Lu, Xiong & Guo 2016). The body-fixed point p moves with
(vx - wz·p_y, vy + wz·p_x); the body's ICR is where this vanishes,
    y_c = vx/wz,  x_c = -vy/wz.
The surface of the left track at p moves over the ground with (vx - wz·p_y - V_L, vy + wz·p_x):
it is at rest at y_l = (vx - V_L)/wz (and x = x_c); likewise y_r = (vx - V_R)/wz.
The three ICRs share x_c = x_l = x_r.

Inverse, eq. (2.14): from y_l - y_r = (V_R - V_L)/wz,
    wz = (V_R - V_L)/(y_l - y_r),  vx = (y_l V_R - y_r V_L)/(y_l - y_r),
    vy = -x_c·wz = (V_L - V_R)·x_c/(y_l - y_r).

Straight motion: at wz = 0 the ICRs lie at infinity. :func:`icr_from_twist` therefore
refuses |wz| < ``wz_min`` with :class:`SingularMotionError` (``on_singular="raise"``, the
default) or, with ``on_singular="mask"``, returns NaN there together with a boolean
``valid`` mask: the caller sees explicitly which samples carry ICRs.

Derivation and measurements: docs/theory/tracked.md, "The virtual wheeled robot".
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from mjtrack.errors import InputError, SingularMotionError

WZ_MIN = 1e-9  # [rad/s] default |wz| below which the ICRs are treated as at infinity


@dataclass(frozen=True)
class ICR:
    """ICRs of a motion, eq. (2.13). Arrays of a common shape [m].

    ``valid`` is False where ``|wz| < wz_min``; the other fields are NaN there.
    """

    y_l: np.ndarray
    y_r: np.ndarray
    x_c: np.ndarray
    y_c: np.ndarray
    valid: np.ndarray


def _check_singular(wz: np.ndarray, wz_min: float, on_singular: str, what: str) -> np.ndarray:
    if on_singular not in ("raise", "mask"):
        raise InputError(f"on_singular must be 'raise' or 'mask', got {on_singular!r}")
    valid = np.abs(wz) >= wz_min
    if on_singular == "raise" and not np.all(valid):
        first = int(np.flatnonzero(~valid.ravel())[0])
        raise SingularMotionError(
            f"{what} undefined for straight motion: |wz| = {abs(wz.ravel()[first]):.3g} rad/s < {wz_min:g} "
            f"at sample {first} (the ICRs lie at infinity); use on_singular='mask' to get a validity mask"
        )
    return valid


def icr_from_twist(
    vx, vy, wz, v_left, v_right, *, wz_min: float = WZ_MIN, on_singular: Literal["raise", "mask"] = "raise"
) -> ICR:
    """ICRs (2.13) from the body twist [m/s, m/s, rad/s] and track speeds [m/s] (broadcast)."""
    vx, vy, wz, v_left, v_right = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (vx, vy, wz, v_left, v_right)))
    valid = _check_singular(wz, wz_min, on_singular, "ICRs")
    w = np.where(valid, wz, np.nan)
    return ICR(
        y_l=(vx - v_left) / w,
        y_r=(vx - v_right) / w,
        x_c=-vy / w,
        y_c=vx / w,
        valid=valid,
    )


def twist_from_icr(y_l, y_r, x_c, v_left, v_right) -> np.ndarray:
    """Body twist (2.14) from the ICRs [m] and the track speeds [m/s]; shape (..., 3).

    Raises :class:`SingularMotionError` where y_l == y_r (the two track ICRs coincide, so the
    yaw rate is undefined).
    """
    y_l, y_r, x_c, v_left, v_right = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (y_l, y_r, x_c, v_left, v_right)))
    d = y_l - y_r
    if np.any(d == 0):
        raise SingularMotionError("twist undefined: the left and right track ICRs coincide (y_l == y_r)")
    wz = (v_right - v_left) / d
    vx = (y_l * v_right - y_r * v_left) / d
    vy = -x_c * wz
    return np.stack([vx, vy, wz], -1)


@dataclass(frozen=True)
class VirtualRobot:
    """Virtual wheeled robot (MVIR): centre (x_o, y_o) in the robot frame [m], wheel distance [m]."""

    x_o: np.ndarray
    y_o: np.ndarray
    track: np.ndarray
    valid: np.ndarray


def virtual_robot_from_twist(
    vx, vy, wz, v_left, v_right, *, wz_min: float = WZ_MIN, on_singular: Literal["raise", "mask"] = "raise"
) -> VirtualRobot:
    """Virtual-robot parameters (2.16)–(2.20) with consistent signs (see module docstring)."""
    vx, vy, wz, v_left, v_right = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (vx, vy, wz, v_left, v_right)))
    valid = _check_singular(wz, wz_min, on_singular, "virtual-robot parameters")
    w = np.where(valid, wz, np.nan)
    return VirtualRobot(
        x_o=-vy / w,
        y_o=(2.0 * vx - v_left - v_right) / (2.0 * w),
        track=(v_right - v_left) / w,
        valid=valid,
    )


def virtual_robot_from_icr(y_l, y_r, x_c) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x_o, y_o, T_v) of the virtual robot whose wheels sit on the track ICRs."""
    y_l, y_r, x_c = (np.asarray(a, dtype=float) for a in (y_l, y_r, x_c))
    return x_c, 0.5 * (y_l + y_r), y_l - y_r


def course_angle(vx, vy) -> np.ndarray:
    """Direction of travel of the geometric centre relative to the heading [rad]: atan2(vy, vx).

    The thesis's trajectory correction (2.21), alpha = asin(x_o'·w/V), is this angle up to
    its sign convention: with vy = -w·x_o and |v| the centre's speed, sin(course) = -x_o·w/|v|.
    The path of the centre is tangent to yaw + course_angle.
    """
    return np.arctan2(vy, vx)


def slip_ratio(commanded, actual) -> np.ndarray:
    """Sign-safe longitudinal slip of a track (replaces the thesis's (2.8)).

    s = (V - V_r)/V_m, where V_m is whichever of V (commanded) and V_r (actual) has the larger
    magnitude, kept with its sign. For forward driving this is the thesis's
    (V - V_r)/max(V, V_r); it is odd under reversing both speeds, so a reversing track in
    traction also gets s > 0; s in [-1, 1] when V and V_r share a sign (s > 0: traction
    slip, s < 0: skid). s = 0 when both speeds are 0. The MPP model's parameter is defined by
    V_r = V·(1 - s), which equals this ratio whenever |V_r| <= |V|.
    """
    v, vr = np.broadcast_arrays(np.asarray(commanded, dtype=float), np.asarray(actual, dtype=float))
    vm = np.where(np.abs(v) >= np.abs(vr), v, vr)
    safe = np.where(vm == 0, 1.0, vm)
    return np.where(vm == 0, 0.0, (v - vr) / safe)


def sphere_from_centre(x_o, y_o) -> np.ndarray:
    """Unit-sphere parametrisation (3.23)–(3.26): S = (x_o, y_o, 1)/sqrt(x_o²+y_o²+1), S_z > 0."""
    x_o, y_o = np.broadcast_arrays(np.asarray(x_o, dtype=float), np.asarray(y_o, dtype=float))
    n = np.sqrt(x_o * x_o + y_o * y_o + 1.0)
    return np.stack([x_o / n, y_o / n, 1.0 / n], -1)


def centre_from_sphere(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of :func:`sphere_from_centre`: (x_o, y_o) = (S_x/S_z, S_y/S_z).

    S need not be normalised (the ratio is scale-free). S_z = 0 (a centre at infinity) raises
    :class:`SingularMotionError`.
    """
    s = np.asarray(s, dtype=float)
    if np.any(s[..., 2] == 0):
        raise SingularMotionError("virtual centre at infinity: S_z == 0")
    return s[..., 0] / s[..., 2], s[..., 1] / s[..., 2]
