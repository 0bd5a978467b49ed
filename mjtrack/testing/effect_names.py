"""The test generators' effect names and the diagnosis vocabulary's.

The generators (:mod:`mjtrack.testing.diagnose_physics`, :mod:`mjtrack.testing.diagnose_logs`,
:mod:`mjtrack.testing.mujoco_effects`) keep the names of their first version (``cg_offset_x``,
``actuator_lag``, a slope as angle and uphill direction); the diagnosis speaks the robot file's
(``cg_x``, ``drive_lag``, a slope as its components sin(angle) x the uphill unit vector). Written
out here, not imported from :mod:`mjtrack.diagnose`, so that a test's truth shares no code with
what it tests.
"""

from __future__ import annotations

import math

#: the diagnosis vocabulary's name -> the generators' name, where they differ
GENERATOR_NAME = {"cg_x": "cg_offset_x", "cg_y": "cg_offset_y", "mu_ratio": "friction_asymmetry",
                  "drive_lag": "actuator_lag", "drive_delay": "command_delay", "drive_speed_limit": "speed_limit",
                  "drive_turn_limit": "yaw_rate_limit"}
#: the generators' name -> the diagnosis vocabulary's
VOCABULARY_NAME = {g: v for v, g in GENERATOR_NAME.items()}


def generator_name(effect):
    """A vocabulary effect name (or a tuple of them, or None) in the generators' names."""
    if isinstance(effect, tuple):
        return tuple(GENERATOR_NAME.get(e, e) for e in effect)
    return GENERATOR_NAME.get(effect, effect) if effect else effect


def vocabulary_params(params: dict, *, track_gauge: float | None = None) -> dict:
    """Generator parameters {name: value} in the vocabulary's names (a slope as its components; a
    yaw-rate limit [rad/s] as the half-difference limit drive_turn_limit = limit x T / 2 [m/s], which
    needs the robot's ``track_gauge`` T)."""
    out = {VOCABULARY_NAME.get(k, k): v for k, v in params.items()
           if k not in ("slope", "slope_direction", "yaw_rate_limit")}
    if "yaw_rate_limit" in params:
        if track_gauge is None:
            raise ValueError("vocabulary_params: yaw_rate_limit needs the robot's track_gauge")
        out["drive_turn_limit"] = params["yaw_rate_limit"] * track_gauge / 2
    if "slope" in params:
        s, d = params["slope"], params.get("slope_direction", 0.0)
        out["slope_x"], out["slope_y"] = math.sin(s) * math.cos(d), math.sin(s) * math.sin(d)
    return out


__all__ = ["GENERATOR_NAME", "VOCABULARY_NAME", "generator_name", "vocabulary_params"]
