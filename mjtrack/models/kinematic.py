"""Kinematic models of a tracked robot: nominal (2.1), MPP (2.7/2.9), MICR (2.15), MVIR.

Every model is a frozen dataclass of its parameters with one interface:

* ``twist(v_left, v_right) -> (..., 3)`` body twist (vx, vy, wz) of the geometric centre
  [m/s, m/s, rad/s] from the track speeds [m/s];
* ``twist_jacobian(v_left, v_right) -> (..., 3, P)`` d twist / d parameters, in the order of
  ``param_names`` (hand-derived; tested against finite differences);
* ``params -> (..., P)`` and ``with_params(p)`` to move between the model and a vector.

Parameters may be scalars or arrays that broadcast with the speeds (e.g. one value per
command sample for a time-varying slip schedule). :func:`integrate` turns a command
sequence into a path for any model.

MPP (2.7), (2.9): with the actual track speeds V_Lr = V_L(1 - s_L), V_Rr = V_R(1 - s_R),
    vx = (V_Lr + V_Rr)/2,  wz = (V_Rr - V_Lr)/T,  vy = -vx·tan(alpha).
The printed first row of (2.9) divides by T; it is /2 (with s_L = s_R = alpha = 0 the model
must reduce to (2.1), tested). The no-slip line sits at x_c = -vy/wz = vx·tan(alpha)/wz: in a
forward left turn alpha > 0 moves it forward and pushes the centre to the outside of the turn
(the thesis's statement). Because vy does not change sign with the turn, the same alpha moves it
backwards in a right turn: a physical forward shift of the no-slip line (e.g. a centre of
gravity ahead of the geometric centre) is an alpha with the sign of vx·wz. The slip s is the
model parameter defined by V_r = V(1 - s); see :func:`mjtrack.icr.slip_ratio` for the
sign-safe ratio measured from data.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from mjtrack.errors import InputError
from mjtrack.geometry import euler_step, sinc_terms
from mjtrack.icr import twist_from_icr


def _arrays(*values):
    return np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in values))


class KinematicModel:
    """Base of the kinematic models (see module docstring)."""

    name: ClassVar[str]
    param_names: ClassVar[tuple[str, ...]]

    def twist(self, v_left, v_right) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def twist_jacobian(self, v_left, v_right) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    @property
    def params(self) -> np.ndarray:
        return np.stack(np.broadcast_arrays(*(np.asarray(getattr(self, n), dtype=float) for n in self.param_names)), -1)

    def with_params(self, p) -> "KinematicModel":
        p = np.asarray(p, dtype=float)
        if p.shape[-1] != len(self.param_names):
            raise InputError(f"{self.name}: expected {len(self.param_names)} parameters {self.param_names}, got shape {p.shape}")
        return dataclasses.replace(self, **{n: p[..., i] for i, n in enumerate(self.param_names)})


@dataclass(frozen=True)
class Nominal(KinematicModel):
    """(2.1): no-slip differential drive, vx = (V_R+V_L)/2, vy = 0, wz = (V_R-V_L)/T."""

    track_gauge: float
    name: ClassVar[str] = "nominal"
    param_names: ClassVar[tuple[str, ...]] = ("track_gauge",)

    def __post_init__(self):
        if np.any(np.asarray(self.track_gauge) <= 0):
            raise InputError(f"nominal: track_gauge must be > 0, got {self.track_gauge}")

    def twist(self, v_left, v_right) -> np.ndarray:
        vl, vr, t = _arrays(v_left, v_right, self.track_gauge)
        return np.stack([(vl + vr) / 2.0, np.zeros_like(vl), (vr - vl) / t], -1)

    def twist_jacobian(self, v_left, v_right) -> np.ndarray:
        vl, vr, t = _arrays(v_left, v_right, self.track_gauge)
        z = np.zeros_like(vl)
        return np.stack([z, z, -(vr - vl) / t**2], -1)[..., None]


@dataclass(frozen=True)
class MPP(KinematicModel):
    """Slip-parameter model (2.7), (2.9): longitudinal slips s_left, s_right [-], lateral slip alpha [rad]."""

    track_gauge: float
    s_left: float = 0.0
    s_right: float = 0.0
    alpha: float = 0.0
    name: ClassVar[str] = "MPP"
    param_names: ClassVar[tuple[str, ...]] = ("s_left", "s_right", "alpha")

    def __post_init__(self):
        if np.any(np.asarray(self.track_gauge) <= 0):
            raise InputError(f"MPP: track_gauge must be > 0, got {self.track_gauge}")
        if np.any(np.abs(np.asarray(self.alpha)) >= np.pi / 2):
            raise InputError(f"MPP: |alpha| must be < pi/2, got {self.alpha}")

    def twist(self, v_left, v_right) -> np.ndarray:
        vl, vr, t, sl, sr, a = _arrays(v_left, v_right, self.track_gauge, self.s_left, self.s_right, self.alpha)
        vlr, vrr = vl * (1.0 - sl), vr * (1.0 - sr)
        vx = (vlr + vrr) / 2.0
        return np.stack([vx, -vx * np.tan(a), (vrr - vlr) / t], -1)

    def twist_jacobian(self, v_left, v_right) -> np.ndarray:
        vl, vr, t, sl, sr, a = _arrays(v_left, v_right, self.track_gauge, self.s_left, self.s_right, self.alpha)
        vx = (vl * (1.0 - sl) + vr * (1.0 - sr)) / 2.0
        ta = np.tan(a)
        z = np.zeros_like(vl)
        d_sl = np.stack([-vl / 2.0, vl / 2.0 * ta, vl / t], -1)
        d_sr = np.stack([-vr / 2.0, vr / 2.0 * ta, -vr / t], -1)
        d_a = np.stack([z, -vx / np.cos(a) ** 2, z], -1)
        return np.stack([d_sl, d_sr, d_a], -1)


@dataclass(frozen=True)
class MICR(KinematicModel):
    """ICR model (2.14)–(2.15): track ICRs y_l, y_r and their common x_c [m]."""

    y_l: float
    y_r: float
    x_c: float = 0.0
    name: ClassVar[str] = "MICR"
    param_names: ClassVar[tuple[str, ...]] = ("y_l", "y_r", "x_c")

    @classmethod
    def nominal(cls, track_gauge: float) -> "MICR":
        """y_l = -y_r = T/2, x_c = 0: reduces to (2.1)."""
        return cls(track_gauge / 2.0, -track_gauge / 2.0, 0.0)

    def twist(self, v_left, v_right) -> np.ndarray:
        return twist_from_icr(self.y_l, self.y_r, self.x_c, v_left, v_right)

    def twist_jacobian(self, v_left, v_right) -> np.ndarray:
        vl, vr, yl, yr, xc = _arrays(v_left, v_right, self.y_l, self.y_r, self.x_c)
        d = yl - yr
        dv = vr - vl
        k = dv / d**2
        w = dv / d
        z = np.zeros_like(vl)
        d_yl = np.stack([-yr * k, xc * k, -k], -1)
        d_yr = np.stack([yl * k, -xc * k, k], -1)
        d_xc = np.stack([z, -w, z], -1)
        return np.stack([d_yl, d_yr, d_xc], -1)


@dataclass(frozen=True)
class MVIR(KinematicModel):
    """Virtual wheeled robot: centre (x_o, y_o) in the robot frame and wheel distance ``track`` [m].

    wz = (V_R - V_L)/track, vx = (V_L + V_R)/2 + wz·y_o, vy = -wz·x_o (see mjtrack.icr for the
    derivation and the sign defect of the printed (2.17)).
    """

    x_o: float
    y_o: float
    track: float
    name: ClassVar[str] = "MVIR"
    param_names: ClassVar[tuple[str, ...]] = ("x_o", "y_o", "track")

    @classmethod
    def nominal(cls, track_gauge: float) -> "MVIR":
        return cls(0.0, 0.0, track_gauge)

    def twist(self, v_left, v_right) -> np.ndarray:
        vl, vr, xo, yo, tv = _arrays(v_left, v_right, self.x_o, self.y_o, self.track)
        w = (vr - vl) / tv
        return np.stack([(vl + vr) / 2.0 + w * yo, -w * xo, w], -1)

    def twist_jacobian(self, v_left, v_right) -> np.ndarray:
        vl, vr, xo, yo, tv = _arrays(v_left, v_right, self.x_o, self.y_o, self.track)
        w = (vr - vl) / tv
        dw = -(vr - vl) / tv**2
        z = np.zeros_like(vl)
        return np.stack([np.stack([z, -w, z], -1), np.stack([w, z, z], -1), np.stack([yo * dw, -xo * dw, dw], -1)], -1)


MODELS: dict[str, type[KinematicModel]] = {m.name: m for m in (Nominal, MPP, MICR, MVIR)}


def integrate(model: KinematicModel, pose0, t, v_left, v_right, *, method: str = "exact") -> np.ndarray:
    """Integrate the pose of ``model`` over a command sequence (zero-order hold).

    The command (and the model parameters, if they are arrays) of sample k is held over
    [t_k, t_{k+1}). See :func:`integrate_twist` for the methods.

    Args:
        model: any :class:`KinematicModel`.
        pose0: (3,) initial pose [m, m, rad].
        t: (N,) strictly increasing sample times [s].
        v_left, v_right: (N,) track speeds [m/s].
    Returns:
        (N, 3) poses at the sample times; row 0 is pose0; yaw continuous (not wrapped).
    """
    t = np.asarray(t, dtype=float)
    twist = np.broadcast_to(model.twist(v_left, v_right), (t.size, 3))
    return integrate_twist(pose0, t, twist, method=method)


def integrate_twist(pose0, t, twist, *, method: str = "exact") -> np.ndarray:
    """Integrate a sequence of body twists (N, 3), twist k held over [t_k, t_{k+1}).

    ``method="exact"`` composes exact constant-twist SE(2) steps — vectorised: the yaw is the
    cumulative sum of wz·dt and each step's body-frame displacement is rotated by the yaw at
    its start; ``method="euler"`` uses the thesis's first-order step (3.11).
    Returns (N, 3) poses; row 0 is pose0; yaw continuous.
    """
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size < 1:
        raise InputError("integrate: t must be a 1-D array with at least one sample")
    dt = np.diff(t)
    if np.any(dt <= 0):
        raise InputError(f"integrate: time not strictly increasing at sample {int(np.flatnonzero(dt <= 0)[0]) + 1}")
    twist = np.asarray(twist, dtype=float)
    if twist.shape != (t.size, 3):
        raise InputError(f"integrate: twist must have shape ({t.size}, 3), got {twist.shape}")
    twist = twist[:-1]
    pose0 = np.asarray(pose0, dtype=float)
    if method == "euler":
        poses = np.empty((t.size, 3))
        poses[0] = pose0
        for k in range(t.size - 1):
            poses[k + 1] = euler_step(poses[k], twist[k], dt[k])
        return poses
    if method != "exact":
        raise InputError(f"integrate: method must be 'exact' or 'euler', got {method!r}")
    dyaw = twist[:, 2] * dt
    yaw = pose0[2] + np.concatenate([[0.0], np.cumsum(dyaw)])
    s, c = sinc_terms(dyaw)
    dxb = dt * (s * twist[:, 0] - c * twist[:, 1])
    dyb = dt * (c * twist[:, 0] + s * twist[:, 1])
    cy, sy = np.cos(yaw[:-1]), np.sin(yaw[:-1])
    x = pose0[0] + np.concatenate([[0.0], np.cumsum(cy * dxb - sy * dyb)])
    y = pose0[1] + np.concatenate([[0.0], np.cumsum(sy * dxb + cy * dyb)])
    return np.stack([x, y, yaw], -1)
