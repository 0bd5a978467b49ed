"""Synthetic drive logs with named hidden effects, for the diagnosis tests and benchmarks.

The physics is :mod:`mjtrack.testing.diagnose_physics`: an independent rigid-body simulation
with its own contact discretisation (Gauss-Legendre grids, regularised Coulomb friction,
plane-pressure load transfer) and its own integrator; it shares no code with
``mjtrack.models.coulomb`` nor with the diagnosis surrogate, so the diagnosis tests check the
physics, not the fit. This module keeps the interface the diagnosis tests use (an effect name,
or a tuple of names, with the magnitudes of ``HIDDEN``).
"""

from __future__ import annotations

from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import Robot
from mjtrack.testing.diagnose_physics import GEOMETRIES
from mjtrack.testing.diagnose_physics import make_log as make_physics_log

ROBOT = GEOMETRIES["small"][0]  # the nominal robot of the synthetic logs (full description)

HIDDEN = {  # effect -> its parameters in the synthetic logs
    "cg_offset_x": {"cg_offset_x": 0.06},
    "cg_offset_y": {"cg_offset_y": -0.05},
    "friction_scale": {"friction_scale": 0.35},
    "friction_asymmetry": {"friction_asymmetry": 0.6},
    "track_speed_scale": {"track_speed_scale": 0.85},
    "actuator_lag": {"actuator_lag": 0.3},
    "command_delay": {"command_delay": 0.25},
    "speed_limit": {"speed_limit": 0.6},
    "slope": {"slope": 0.12, "slope_direction": 0.8},
    "yaw_rate_limit": {"yaw_rate_limit": 1.5},
}


def make_log(effect: str | tuple | None, *, seed: int = 0, duration: float = 240.0, dt: float = 0.05,
             speeds: bool = False, turning: bool = True, geometry: str = "small",
             layout: str = "continuous") -> tuple[DriveLog, Robot]:
    """A log of the nominal robot with ``effect`` hidden (None = clean; a tuple = several
    effects at once); returns (log, nominal robot)."""
    names = effect if isinstance(effect, tuple) else (effect,)
    params = {k: v for n in names if n for k, v in HIDDEN[n].items()}
    return make_physics_log(params, geometry=geometry, seed=seed, duration=duration, rate=1.0 / dt, speeds=speeds,
                            turning=turning, layout=layout)
