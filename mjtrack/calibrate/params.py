"""The parameters ``calibrate`` can fit: names, bounds, units, starting values.

Names are robot-description keys (CONTRACTS §2) or parameters of the robot's ground model
(``lateral_ratio`` of ``anisotropic``; ``concentration``, ``span`` of ``road_wheels``). How each one
reaches the MuJoCo robot: :mod:`mjtrack.sim.windows` (model fields, commands, or a rebuild).
"""

from __future__ import annotations

from dataclasses import dataclass

from mjtrack.errors import InputError
from mjtrack.io.robot import Robot
from mjtrack.sim.config import SimConfig
from mjtrack.sim.windows import WINDOW_PARAMS, drive_params, robot_params


@dataclass(frozen=True)
class ParamSpec:
    """One fittable parameter: bounds [lo, hi], a typical change (the optimiser's scale), unit, meaning."""

    name: str
    lo: float
    hi: float
    scale: float
    unit: str
    what: str


def _specs(robot: Robot, L: float) -> dict[str, ParamSpec]:
    # cg bounds: a quarter of the half-length / half-gauge; the roller chain's explicit-Euler step
    # diverged at cg_x = 0.4 L/2 in some transients (measured, tests/test_windows.py notes)
    cgx, cgy = 0.25 * L / 2, 0.25 * robot.track_gauge / 2
    return {s.name: s for s in (
        ParamSpec("mu", 0.05, 2.0, 0.1, "–", "ground friction, both tracks"),
        ParamSpec("mu_left", 0.05, 2.0, 0.1, "–", "ground friction of the left track"),
        ParamSpec("mu_right", 0.05, 2.0, 0.1, "–", "ground friction of the right track"),
        ParamSpec("cg_x", -cgx, cgx, 0.02, "m", "centre of mass ahead of the geometric centre"),
        ParamSpec("cg_y", -cgy, cgy, 0.02, "m", "centre of mass left of the geometric centre"),
        ParamSpec("track_length", 0.15, 1.6, 0.1, "m", "track contact length"),
        ParamSpec("wheelbase", 0.1, 3.0, 0.1, "m", "front to rear axle distance (wheeled robot)"),
        ParamSpec("drive_lag", 0.0, 1.5, 0.1, "s", "first-order time constant from command to track speed"),
        ParamSpec("drive_delay", 0.0, 0.6, 0.05, "s", "dead time from command to track speed"),
        ParamSpec("track_speed_scale", 0.5, 1.5, 0.05, "–", "actual / commanded track speed"),
        ParamSpec("drive_force_limit", 5.0, 5000.0, 50.0, "N", "largest force a track drive applies"),
        ParamSpec("lateral_ratio", 0.05, 1.0, 0.1, "–", "lateral / longitudinal friction (anisotropic ground)"),
        ParamSpec("concentration", 0.0, 0.95, 0.1, "–", "share of the load on the road wheels (road_wheels ground)"),
        ParamSpec("span", 0.05, 1.0, 0.1, "–", "road-wheel span / contact length (road_wheels ground)"),
    )}


GROUND_PARAMS = {"anisotropic": ("lateral_ratio",), "road_wheels": ("concentration", "span"), "coulomb": ()}
#: fitted unless --params says otherwise (plus track_length when the robot file lacks it, and the
#: parameters of the robot's ground model)
DEFAULT_PARAMS = ("mu", "cg_x", "cg_y", "drive_lag", "drive_delay", "track_speed_scale")
#: first values of drivetrain keys that the robot file lacks (a value on a bound stalls the fit)
DRIVE_START = {"drive_lag": 0.05, "drive_delay": 0.02, "track_speed_scale": 1.0}


def specs_for(robot: Robot) -> dict[str, ParamSpec]:
    """Every parameter's spec for this robot (cg bounds follow its contact length)."""
    return _specs(robot, robot.contact_length)


def geometry_name(robot: Robot) -> str:
    """The robot key of its contact length: ``track_length``, or a wheeled robot's ``wheelbase``."""
    return "wheelbase" if robot.traction == "wheels" else "track_length"


def default_names(robot: Robot) -> list[str]:
    """The parameters fitted when none are named."""
    names = list(DEFAULT_PARAMS)
    if robot.provided is not None and geometry_name(robot) not in robot.provided:
        names.append(geometry_name(robot))
    names.extend(GROUND_PARAMS.get(robot.ground.model, ()))
    return names


def parse_names(text: str | None, robot: Robot) -> list[str]:
    """``--params a,b,c`` checked against the catalogue and the robot's ground model."""
    if text is None:
        return default_names(robot)
    names = [n.strip() for n in text.split(",") if n.strip()]
    specs = specs_for(robot)
    if not names:
        raise InputError("--params: no parameter named")
    for n in names:
        if n not in specs:
            raise InputError(f"--params: unknown parameter {n!r}; known: {', '.join(specs)}")
        if n in ("track_length", "wheelbase") and n != geometry_name(robot):
            raise InputError(f"--params: {n!r} is not the contact length of a robot on {robot.traction}; "
                             f"fit {geometry_name(robot)!r}")
        for model, ps in GROUND_PARAMS.items():
            if n in ps and robot.ground.model != model:
                raise InputError(f"--params: {n!r} belongs to the {model!r} ground; the robot's ground is "
                                 f"{robot.ground.model!r} (set robot key ground: {{\"model\": \"{model}\"}})")
    if len(set(names)) != len(names):
        raise InputError(f"--params: a parameter is named twice: {text!r}")
    if "mu" in names and ({"mu_left", "mu_right"} & set(names)):
        raise InputError("--params: fit either 'mu' or 'mu_left'/'mu_right', not both")
    assert set(names) <= set(WINDOW_PARAMS)
    return names


def start_values(robot: Robot, names: list[str], config: SimConfig) -> dict[str, float]:
    """First value of each fitted parameter: the robot's, else a neutral one; refused off its bounds."""
    current = robot_params(robot)
    drive = drive_params(robot)
    specs = specs_for(robot)
    out = {}
    for n in names:
        v = current.get(n)
        if n in ("mu_left", "mu_right") and v is None:
            v = robot.mu
        given = robot.provided is None or n in robot.provided
        if n in DRIVE_START and (drive.get(n) is None or not given):
            v = DRIVE_START[n]
        if n == "drive_force_limit" and v is None:
            from mjtrack.sim.drivetrain import drive_of

            v = drive_of(robot, config).force_limit
        s = specs[n]
        if v is None or not s.lo <= v <= s.hi:
            raise InputError(f"robot: {n} = {v!r} is outside the range calibrate fits in [{s.lo:g}, {s.hi:g}] {s.unit}")
        out[n] = float(v)
    return out
