"""Trajectory tracking: feed-forward plus linear state feedback, thesis section 3.2.3 (eqs. 3.11-3.21).

Reference (x_d, y_d, phi_d) with feed-forward (v_d, w_d) (3.11), from
:class:`~mjtrack.control.feedforward.Reference`.  Error in the robot frame (3.12)-(3.13):
    e1 =  cos(phi)(x_d - x) + sin(phi)(y_d - y)
    e2 = -sin(phi)(x_d - x) + cos(phi)(y_d - y)
    e3 = phi_d - phi   (wrapped)
Differentiating with (1.1) for robot and reference (3.14)-(3.15):
    e1dot = w e2 - v + v_d cos(e3),  e2dot = -w e1 + v_d sin(e3),  e3dot = w_d - w.
With inputs u1 = v_d cos(e3) - v, u2 = w_d - w (3.16)-(3.17) and linearising about e = 0,
u = 0 (3.18)-(3.19):
    edot = A e + B u,  A = [[0, w_d, 0], [-w_d, 0, v_d], [0, 0, 0]],  B = [[1, 0], [0, 0], [0, 1]].
State feedback u = -K e (3.21) makes edot = (A - B K) e; K is chosen by pole placement
(:func:`scipy.signal.place_poles`) so that A - B K has the chosen eigenvalues.  The command is
    v = v_d cos(e3) + (K e)_1,   w = w_d + (K e)_2.
(A, B) is controllable iff (v_d, w_d) != (0, 0) (A B spans e2 only through w_d or v_d); at a
standstill of the reference the gains of the speed ``v_floor`` are used.  A and K vary with
time for a varying (v_d, w_d) (3.20); gains are cached per (v_d, w_d) rounded to 1e-9.
Thesis test: circle R = 0.5 m at v_d = 1 m/s (w_d = 2 rad/s), wrong start pose, dynamic model 1.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import place_poles

from mjtrack.control.feedforward import Reference
from mjtrack.errors import InputError
from mjtrack.models.wheeled.base import wrap

B_MATRIX = np.array([[1.0, 0.0], [0.0, 0.0], [0.0, 1.0]])


def error_matrix(v_d: float, w_d: float) -> np.ndarray:
    """A of (3.19): (3, 3) linearised error dynamics at reference speeds (v_d [m/s], w_d [rad/s])."""
    return np.array([[0.0, w_d, 0.0], [-w_d, 0.0, v_d], [0.0, 0.0, 0.0]])


def tracking_error(pose, pose_d) -> np.ndarray:
    """(3.13): (e1, e2, e3) of ``pose`` w.r.t. the desired ``pose_d``, robot frame [m, m, rad]."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    dx, dy = pose_d[0] - pose[0], pose_d[1] - pose[1]
    return np.array([c * dx + s * dy, -s * dx + c * dy, wrap(pose_d[2] - pose[2])])


def placement_gains(v_d: float, w_d: float, poles) -> np.ndarray:
    """(2, 3) K with eig(A(v_d, w_d) - B K) = ``poles`` (3 values, real part < 0, at most 2 equal)."""
    poles = np.asarray(poles)
    if poles.shape != (3,) or np.any(np.real(poles) >= 0):
        raise InputError(f"placement_gains: need 3 poles with negative real part, got {poles!r}")
    if v_d == 0.0 and w_d == 0.0:
        raise InputError("placement_gains: (A, B) is uncontrollable at v_d = w_d = 0")
    return place_poles(error_matrix(v_d, w_d), B_MATRIX, poles).gain_matrix


class TrajectoryTracker:
    """Feed-forward + pole-placement state feedback (3.21); see the module docstring.

    Args:
        reference: desired trajectory.
        poles: closed-loop eigenvalues of A - B K [1/s].
        v_floor: speed [m/s] whose gains are used while the reference stands still.
    """

    def __init__(self, reference: Reference, *, poles=(-1.0, -2.0, -4.0), v_floor: float = 0.05) -> None:
        self.reference = reference
        self.poles = tuple(poles)
        self.v_floor = v_floor
        placement_gains(1.0, 0.0, self.poles)  # validates the poles once
        self._cache: dict[tuple[float, float], np.ndarray] = {}
        self.last_error = np.zeros(3)

    def reset(self) -> None:
        self.last_error = np.zeros(3)

    def gains(self, v_d: float, w_d: float) -> np.ndarray:
        if abs(v_d) < 1e-9 and abs(w_d) < 1e-9:
            v_d, w_d = self.v_floor, 0.0
        key = (round(v_d, 9), round(w_d, 9))
        if key not in self._cache:
            self._cache[key] = placement_gains(v_d, w_d, self.poles)
        return self._cache[key]

    def command(self, t: float, pose, twist=None) -> tuple[float, float]:
        ref = self.reference.at(t)
        e = tracking_error(pose, ref.pose)
        self.last_error = e
        fb = self.gains(ref.v, ref.w) @ e
        return ref.v * math.cos(e[2]) + float(fb[0]), ref.w + float(fb[1])
