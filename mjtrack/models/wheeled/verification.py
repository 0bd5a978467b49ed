"""The wheeled-robot thesis's own verification cases, run on the models of this package.

:func:`thesis_checks` simulates each case and returns, for each, the value the thesis
predicts in closed form and the value the simulation gives, with the tolerance that the
difference must meet (why that tolerance: in ``note``).  ``python -m
mjtrack.models.wheeled.verification`` writes the table to stdout (about 1 s).

Cases (thesis section, closed form):
  1.1.1.1  differential drive, v = 1 m/s, w = 1 rad/s: circle R = v/w, period 2 pi/w;
  1.1.2.2  dynamic model 1: straight start to 2 m/s at t = M v/(2 F_max); +-1 N spin-up
           omegadot = (F_R - F_L)(b/2)/J, phi(1 s) = omegadot/2;
  1.1.2.4  dynamic model 2 on R = 0.2 m accelerating at 0.5 m/s^2: leaves the circle at
           t = omega* R/a, omega*^2 = sqrt((mu W_tot)^2 - (M a)^2)/(M R);
  1.2.1    skid steer: straight start to 1 m/s at t = M v/(4 mu W); slow spin turn at
           b^2/(a^2 + b^2) of the no-slip rate about the geometric centre;
  1.3.x    Ackermann, theta = 30 deg: circle of the driven wheel l/tan(theta) (rear), l/sin(theta) (front).
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass

import numpy as np

from mjtrack.models.wheeled.ackermann import Ackermann
from mjtrack.models.wheeled.base import rk4, simulate
from mjtrack.models.wheeled.diffdrive import DiffDriveKinematic, wheel_speeds
from mjtrack.models.wheeled.dynamic1 import DiffDriveDynamic1
from mjtrack.models.wheeled.dynamic2 import DiffDriveDynamic2
from mjtrack.models.wheeled.skidsteer4 import SkidSteer4


@dataclass(frozen=True)
class Check:
    """One verification: ``predicted`` (closed form) vs ``measured`` (simulation), in ``unit``."""

    name: str
    predicted: float
    measured: float
    tolerance: float
    unit: str
    note: str = ""

    @property
    def passed(self) -> bool:
        return abs(self.measured - self.predicted) <= self.tolerance


def _first(t: np.ndarray, mask: np.ndarray) -> float:
    idx = np.flatnonzero(mask)
    return float(t[idx[0]]) if idx.size else math.nan


def _diffdrive_circle() -> list[Check]:
    m = DiffDriveKinematic()
    u = np.array(wheel_speeds(1.0, 1.0, track=m.track, wheel_radius=m.wheel_radius))
    t, s = simulate(m, m.initial_state((0, 0, 0)), lambda t, x: u, duration=2 * math.pi, dt=2 * math.pi / 400)
    radius = float(np.max(np.hypot(s[:, 0], s[:, 1] - 1.0)))
    closure = float(np.hypot(*s[-1, :2]))
    return [
        Check("diffdrive circle radius", 1.0, radius, 1e-9, "m", "RK4 error only"),
        Check("diffdrive back at start after 2 pi s", 0.0, closure, 1e-9, "m", "RK4 error only"),
    ]


def _dynamic1() -> list[Check]:
    m = DiffDriveDynamic1()
    v_req = 2.0
    u = np.array(wheel_speeds(v_req, 0.0, track=m.track, wheel_radius=m.wheel_radius))
    t, s = simulate(m, m.initial_state((0, 0, 0)), lambda t, x: u, duration=0.5, dt=1e-4)
    t99 = _first(t, s[:, 3] >= 0.99 * v_req)
    spin = m.initial_state((0, 0, 0))
    dt = 1e-3
    for _ in range(1000):
        spin = rk4(lambda x: m.derivative_from_forces(x, -1.0, 1.0), spin, dt)
    rate = 2.0 * 0.5 * m.track / m.inertia
    return [
        Check("dynamic1 straight start reaches 99% of 2 m/s", m.mass * v_req / (2 * m.force_max), t99, 0.01, "s",
              "after saturation: first-order tail, time constant M r/(2K) = 6 ms"),
        Check("dynamic1 +-1 N yaw rate at 1 s", rate, float(spin[4]), 1e-9, "rad/s"),
        Check("dynamic1 +-1 N yaw angle at 1 s", rate / 2, float(spin[2]), 1e-9, "rad"),
    ]


def _dynamic2() -> list[Check]:
    m = DiffDriveDynamic2()
    radius, accel = 0.2, 0.5
    s_max = math.sqrt((2 * m.mu * m.wheel_load) ** 2 - (m.mass * accel) ** 2)
    t_pred = math.sqrt(s_max / (m.mass * radius)) * radius / accel

    def u_of_t(t, x):
        v = accel * t
        return np.array(wheel_speeds(v, v / radius, track=m.track, wheel_radius=m.wheel_radius))

    t, s = simulate(m, m.initial_state((0, 0, 0)), u_of_t, duration=t_pred + 0.6, dt=m.max_stable_dt)
    dist = np.hypot(s[:, 0], s[:, 1] - radius)
    lateral = np.array([abs(m.twist(x)[1]) for x in s])
    eps = m.mu * m.wheel_load / m.stiffness
    return [
        Check("dynamic2 lateral friction saturates (leaves circle)", t_pred, _first(t, lateral > eps), 0.02 * t_pred, "s",
              "onset of the skid; wheel-speed loop and yaw inertia shift it slightly"),
        Check("dynamic2 1 cm off the circle", t_pred, _first(t, dist > radius + 0.01), 0.3, "s",
              "the outward drift grows like (2 v a/R) tau^3/6 after the onset"),
    ]


def _skidsteer() -> list[Check]:
    m = SkidSteer4()
    u = np.full(2, 1.0 / m.wheel_radius)
    t, s = simulate(m, m.initial_state((0, 0, 0)), lambda t, x: u, duration=0.3, dt=m.max_stable_dt / 2)
    t99 = _first(t, s[:, 3] >= 0.99)
    big = 0.02
    t2, s2 = simulate(m, m.initial_state((0, 0, 0)), lambda t, x: np.array([-big, big]), duration=1.0, dt=m.max_stable_dt)
    tw = m.twist(s2[-1])
    a, b = m.wheelbase, m.track
    nominal = 2 * m.wheel_radius * big / b
    return [
        Check("skid steer straight start reaches 99% of 1 m/s", m.mass / (4 * m.mu * m.wheel_load), t99, 0.005, "s",
              "linear-friction tail at rate 4C/M"),
        Check("skid steer slow spin: yaw rate / no-slip rate", b**2 / (a**2 + b**2), float(tw[2] / nominal), 1e-4, "-"),
        Check("skid steer slow spin: centre ahead of COG", (m.cg_ratio - 0.5) * a, float(-tw[1] / tw[2]), 1e-4, "m"),
    ]


def _ackermann() -> list[Check]:
    out = []
    theta, speed = math.pi / 6, 0.2
    for drive in ("rear", "front"):
        m = Ackermann(drive=drive)
        v_b, omega = m.body_rates((speed, theta))
        period = 2 * math.pi / omega
        t, s = simulate(m, m.initial_state((0, 0, 0)), lambda t, x: np.array([speed, theta]), duration=period, dt=period / 500)
        r_b = v_b / omega
        pts = s[:, :2] if drive == "rear" else s[:, :2] + m.wheelbase * np.stack([np.cos(s[:, 2]), np.sin(s[:, 2])], 1)
        measured = float(np.mean(np.hypot(pts[:, 0], pts[:, 1] - r_b)))
        predicted = m.wheelbase / (math.tan(theta) if drive == "rear" else math.sin(theta))
        out.append(Check(f"ackermann {drive} drive circle radius", predicted, measured, 1e-9, "m"))
        out.append(Check(f"ackermann {drive} drive lap time", 2 * math.pi * predicted / speed, period, 1e-9, "s"))
    return out


def thesis_checks() -> list[Check]:
    """Run every verification case of the thesis's chapter 1 (about 1 s)."""
    return _diffdrive_circle() + _dynamic1() + _dynamic2() + _skidsteer() + _ackermann()


def main() -> int:
    checks = thesis_checks()
    out = sys.stdout
    out.write(f"{'check':55s} {'predicted':>11s} {'measured':>11s} {'tol':>8s} unit ok\n")
    for c in checks:
        out.write(f"{c.name:55s} {c.predicted:11.5g} {c.measured:11.5g} {c.tolerance:8.2g} {c.unit:4s} {'yes' if c.passed else 'NO'}\n")
    return 0 if all(c.passed for c in checks) else 1


if __name__ == "__main__":
    raise SystemExit(main())
