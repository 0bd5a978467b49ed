"""The window parameters: what a window simulation may vary, and their values for a robot.

The names are those of the robot description (``mu_left``, ``cg_x``, ``drive_lag``, ...) plus the
ground's own (``lateral_ratio``, ``concentration``, ``span``) and the log's incline (``slope_x``,
``slope_y``). :mod:`mjtrack.sim.windows` sets them on the MuJoCo robot; calibration and diagnosis
map their own quantities onto them here, without loading MuJoCo.
"""

from __future__ import annotations

import math
from typing import Mapping

from mjtrack.errors import InputError
from mjtrack.io.robot import Robot

#: parameters that :meth:`mjtrack.sim.windows.WindowSim.variant_model` sets on a compiled model (``lateral_ratio``: the
#: anisotropic ground's lateral / longitudinal friction, on a robot built with that ground;
#: ``slope_x``, ``slope_y``: an inclined ground as the gravity of the plane, a = sin(slope) times
#: the uphill unit vector in the log's world frame, the log's x, y read as in-plane coordinates;
#: ``shear_modulus``: the shear ground's K, its friction set before each chunk of a rollout by
#: :class:`mjtrack.sim.ground.ShearChunks`, 0 the Coulomb ground, on a robot of either ground;
#: ``lateral_shear_ratio``: its modulus across over the one along, on a robot built with the
#: track's contact frames, :func:`mjtrack.sim.ground.framed_robot`)
MODEL_PARAMS = ("mu", "mu_left", "mu_right", "cg_x", "cg_y", "drive_lag", "drive_force_limit", "lateral_ratio",
                "slope_x", "slope_y", "rolling_resistance", "shear_modulus", "lateral_shear_ratio")
#: parameters applied to the commands
COMMAND_PARAMS = ("drive_delay", "track_speed_scale")
#: parameters that change the model's structure: a robot rebuilt per distinct value (contact
#: length: a track's, a wheeled robot's wheelbase; the road-wheel ground's load concentration and span)
GEOMETRY_PARAMS = ("track_length", "wheelbase", "concentration", "span")
WINDOW_PARAMS = MODEL_PARAMS + COMMAND_PARAMS + GEOMETRY_PARAMS
#: drivetrain keys of the robot description; None: as the model was built (no delay, no scale)
DRIVE_DEFAULTS = {"drive_lag": None, "drive_delay": None, "drive_force_limit": None, "track_speed_scale": None}


def drive_params(robot: Robot) -> dict[str, float | None]:
    """The robot's drivetrain keys (attributes or description keys), None where absent."""
    out = {}
    for k in DRIVE_DEFAULTS:
        v = getattr(robot, k, None)
        if v is None:
            v = robot.extra.get(k)
        out[k] = None if v is None else float(v)
    if not out["drive_lag"]:  # 0: no lag of the robot's own; the model keeps the lag it was built with
        out["drive_lag"] = None
    return out


def robot_params(robot: Robot) -> dict[str, float | None]:
    """Every window parameter's value for ``robot`` as described (the baseline variant)."""
    g = dict(robot.ground.params)
    return {"mu": robot.mu, "mu_left": robot.mu_left, "mu_right": robot.mu_right,
            "cg_x": robot.cg_x, "cg_y": robot.cg_y, **drive_params(robot), "track_length": robot.track_length,
            "wheelbase": robot.wheelbase, "lateral_ratio": g.get("lateral_ratio"), "concentration": g.get("concentration"),
            "span": g.get("span"), "slope_x": 0.0, "slope_y": 0.0, "rolling_resistance": robot.rolling_resistance,
            "shear_modulus": g.get("shear_modulus"), "lateral_shear_ratio": g.get("lateral_shear_ratio")}


def slope_of(params: Mapping[str, float | None]) -> tuple[float, float]:
    """The in-plane gravity direction (a_x, a_y) = sin(slope) (cos dir, sin dir) of ``params``
    (0 where absent); InputError when it is not a plane's (|a| >= sin 60 deg)."""
    ax, ay = float(params.get("slope_x") or 0.0), float(params.get("slope_y") or 0.0)
    if not (math.isfinite(ax) and math.isfinite(ay)) or math.hypot(ax, ay) >= math.sin(math.radians(60)):
        raise InputError(f"windows: slope (slope_x, slope_y) = ({ax!r}, {ay!r}) is not an incline below 60 deg")
    return ax, ay


def geometry_robot(robot: Robot, params: Mapping[str, float | None]) -> Robot:
    """``robot`` with the structural parameters of ``params`` (:data:`GEOMETRY_PARAMS`) applied."""
    changes: dict = {}
    if params.get("track_length") is not None and params["track_length"] != robot.track_length:
        if robot.traction == "wheels":
            raise InputError("windows: a wheeled robot has no track length; its contact length is 'wheelbase'")
        changes["track_length"] = float(params["track_length"])
    if params.get("wheelbase") is not None and params["wheelbase"] != robot.wheelbase:
        if robot.traction != "wheels":
            raise InputError("windows: 'wheelbase' needs a wheeled robot (robot key traction: \"wheels\")")
        changes["wheelbase"] = float(params["wheelbase"])
    ground = dict(robot.ground.params)
    new = {k: float(params[k]) for k in ("concentration", "span") if params.get(k) is not None}
    if new:
        if robot.ground.model != "road_wheels":
            raise InputError(f"windows: {sorted(new)} need a robot built with the road_wheels ground "
                             "(robot key ground: {\"model\": \"road_wheels\"})")
        if any(ground[k] != v for k, v in new.items()):
            changes["ground"] = type(robot.ground)(robot.ground.model, tuple({**ground, **new}.items()))
    return robot.replace(**changes) if changes else robot
