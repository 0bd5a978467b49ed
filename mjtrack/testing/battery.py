"""The calibration self-consistency battery: MuJoCo logs with one known change each.

Each case is a robot *description* (what a user would write) and the *truth* the log was made with:
the description plus one change -- a centre-of-mass offset (x or y), a drive lag, a dead time, both,
a friction difference between the sides, a longer contact, a speed scale, an inclined ground, a
motion resistance (the ground holding each side back by a share of its weight), or nothing. The logs are made by ``mjtrack.sim.drive_log`` (the MuJoCo robot built with the truth, one
rollout from rest, the ground tilted for the slope) from seeded random track-speed steps; the
calibration then sees the log and the description only. The truth is written here, in the
calibration's own terms (friction as level and left/right ratio, a slope as sin(slope) times the
uphill direction), independently of ``mjtrack.calibrate``.

Geometries: ``small`` (T 0.3 m, L 0.35 m, 8 kg, mu 1.0), ``default`` (T 0.4, L 0.5, 20 kg, 0.8),
``large`` (T 0.6, L 0.8, 60 kg, 0.6).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import Robot

GEOMETRIES = {
    "small": {"track_gauge": 0.3, "track_length": 0.35, "mass": 8.0, "mu": 1.0},
    "default": {"track_gauge": 0.4, "track_length": 0.5, "mass": 20.0, "mu": 0.8},
    "large": {"track_gauge": 0.6, "track_length": 0.8, "mass": 60.0, "mu": 0.6},
}
SLOPE = (0.05, 0.7)  # [rad] incline and uphill direction of the slope case
CHANGES = ("clean", "cg_x", "cg_y", "drive_lag", "drive_delay", "lag_delay", "friction_asymmetry", "track_length",
           "track_speed_scale", "slope", "rolling_resistance")
LOG_RATE = 50.0  # [Hz]
VMAX = 0.9  # [m/s] largest commanded track speed


@dataclass(frozen=True)
class Case:
    """One battery case: its name, the description, the truth's robot keys, the terrain spec of the
    log, and the truth in the calibration's parameters (``truth``); ``cause``: the parameters one of
    which must lead the causes (empty: nothing must change)."""

    geometry: str
    change: str
    described: dict
    true_keys: dict
    terrain: str | None
    truth: dict[str, float]
    cause: tuple[str, ...] = field(default=())

    @property
    def name(self) -> str:
        return f"{self.geometry}/{self.change}"


def case(geometry: str, change: str) -> Case:
    """The case of ``change`` on ``geometry`` (module docstring)."""
    d = dict(GEOMETRIES[geometry])
    L, T, mu = d["track_length"], d["track_gauge"], d["mu"]
    keys: dict = {}
    terrain = None
    cause: tuple[str, ...] = ()
    if change == "cg_x":
        keys, cause = {"cg_x": 0.1 * L}, ("cg_x",)
    elif change == "cg_y":
        keys, cause = {"cg_y": -0.1 * T}, ("cg_y", "mu_ratio")
    elif change == "drive_lag":
        keys, cause = {"drive_lag": 0.15}, ("drive_lag",)
    elif change == "drive_delay":
        keys, cause = {"drive_delay": 0.1}, ("drive_delay",)
    elif change == "lag_delay":
        keys, cause = {"drive_lag": 0.1, "drive_delay": 0.08}, ("drive_lag", "drive_delay")
    elif change == "friction_asymmetry":
        keys, cause = {"mu_left": 0.6 * mu, "mu_right": mu}, ("mu_ratio", "cg_y")
    elif change == "track_length":
        keys, cause = {"track_length": 1.24 * L}, ("track_length",)
    elif change == "track_speed_scale":
        keys, cause = {"track_speed_scale": 0.92}, ("track_speed_scale",)
    elif change == "slope":
        s, psi = SLOPE
        terrain, cause = f"incline:{s}:{psi}", ("slope_x", "slope_y")
    elif change == "rolling_resistance":
        keys, cause = {"rolling_resistance": 0.15 * mu}, ("rolling_resistance",)
    elif change != "clean":
        raise ValueError(f"unknown change {change!r}; known: {', '.join(CHANGES)}")
    full = {**d, **keys}
    ml, mr = full.get("mu_left", full["mu"]), full.get("mu_right", full["mu"])
    truth = {"mu": math.sqrt(ml * mr), "mu_ratio": ml / mr, "cg_x": full.get("cg_x", 0.0),
             "cg_y": full.get("cg_y", 0.0), "track_length": full["track_length"],
             "drive_lag": full.get("drive_lag", 0.0), "drive_delay": full.get("drive_delay", 0.0),
             "track_speed_scale": full.get("track_speed_scale", 1.0), "slope_x": 0.0, "slope_y": 0.0,
             "rolling_resistance": full.get("rolling_resistance", 0.0)}
    if change == "slope":
        s, psi = SLOPE
        truth["slope_x"], truth["slope_y"] = math.sin(s) * math.cos(psi), math.sin(s) * math.sin(psi)
    return Case(geometry, change, d, keys, terrain, truth, cause)


def commands(duration: float, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Seeded random track-speed steps held 1-3 s on the log grid, |V| <= :data:`VMAX`: straight runs,
    turns both ways and spins."""
    rng = np.random.default_rng(seed)
    t, rows = 0.0, []
    while t < duration:
        kind = rng.integers(4)
        v = rng.uniform(-VMAX, VMAX, 2)
        if kind == 0:  # straight
            v[1] = v[0]
        elif kind == 1:  # spin
            v[1] = -v[0]
        rows.append((t, *v))
        t += round(rng.uniform(1.0, 3.0) * LOG_RATE) / LOG_RATE
    a = np.array(rows)
    return a[:, 0], a[:, 1], a[:, 2]


def make_log(c: Case, *, duration: float, seed: int, noise: str | None = None) -> DriveLog:
    """The MuJoCo log of the case's truth (module docstring); with ``noise`` (a preset of
    :func:`mjtrack.sim.noise.log_noise`, e.g. ``"realistic"``) its measured channels carry that
    white measurement noise, drawn from the log's own seed."""
    from mjtrack.sim import drive_log
    from mjtrack.sim.noise import add_noise
    from mjtrack.sim.terrain import parse_terrain

    truth = Robot.from_dict({**c.described, **c.true_keys})
    terrain = parse_terrain(c.terrain) if c.terrain else None
    log = drive_log(truth, commands(duration, seed), duration=duration, log_rate=LOG_RATE, terrain=terrain)
    return add_noise(log, noise, seed=seed) if noise else log


def described_robot(c: Case) -> Robot:
    return Robot.from_dict(dict(c.described))


__all__ = ["CHANGES", "GEOMETRIES", "Case", "case", "commands", "described_robot", "make_log"]
