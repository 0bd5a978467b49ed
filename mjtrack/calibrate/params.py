"""The parameters ``calibrate`` can fit: names, bounds, resolution, units, starting values.

Names are robot-description keys, the friction ratio ``mu_ratio``, an inclined ground
(``slope_x``, ``slope_y``) or parameters of the robot's ground model (``lateral_ratio`` of
``anisotropic``; ``concentration``, ``span`` of ``road_wheels``). :func:`window_params` turns fitted
values into the parameters of :mod:`mjtrack.sim.windows`, which sets them on the MuJoCo robot.

Friction is fitted as its level and its left/right split: ``mu`` the geometric mean of the two
sides' coefficients, ``mu_ratio`` = mu_left / mu_right, so mu_left = mu sqrt(ratio) and
mu_right = mu / sqrt(ratio). The two act differently -- the split steers every turn, the level
matters only where the motion is friction-limited -- so one can be determined by a log that leaves
the other free (:mod:`mjtrack.calibrate.identify`).

Each parameter has a *resolution*: the change that matters for a prediction. A parameter is
determined by a log when its 95 % interval is narrower than plus or minus its resolution.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mjtrack.errors import InputError
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import G, Robot
from mjtrack.sim.config import SimConfig
from mjtrack.windows.params import WINDOW_PARAMS, drive_params, robot_params


@dataclass(frozen=True)
class ParamSpec:
    """One fittable parameter.

    Attributes:
        name: the parameter's name (a robot key, ``mu_ratio``, ``slope_x``/``slope_y`` or a ground parameter).
        lo, hi: physical bounds of the fit.
        scale: a typical change (the optimiser's unit, so one finite-difference step suits all).
        resolution: the change that matters (half-width below which the log determines it).
        unit: unit of the value.
        kind: what it belongs to: "ground", "contact", "mass", "drive" or "terrain".
        what: one line saying what it is.
    """

    name: str
    lo: float
    hi: float
    scale: float
    resolution: float
    unit: str
    kind: str
    what: str


def _specs(robot: Robot) -> dict[str, ParamSpec]:
    L, T = robot.contact_length, robot.track_gauge  # (a wheeled robot's contact length is its wheelbase)
    # cg bounds: a quarter of the half-length / half-gauge; the roller chain's explicit-Euler step
    # diverged at cg_x = 0.4 L/2 in some transients (tests/test_windows.py)
    cgx, cgy = 0.25 * L / 2, 0.25 * T / 2
    W = robot.mass * G  # a drive's force limit is a share of the weight: 2 % to 5 times it per side
    return {s.name: s for s in (
        ParamSpec("mu", 0.05, 2.0, 0.1, 0.1, "–", "ground", "ground friction (geometric mean of the two sides)"),
        ParamSpec("mu_ratio", 0.2, 5.0, 0.1, 0.05, "–", "ground", "left / right friction"),
        ParamSpec("mu_left", 0.05, 2.0, 0.1, 0.1, "–", "ground", "ground friction of the left side"),
        ParamSpec("mu_right", 0.05, 2.0, 0.1, 0.1, "–", "ground", "ground friction of the right side"),
        ParamSpec("cg_x", -cgx, cgx, 0.02, 0.02 * L, "m", "mass", "centre of mass ahead of the geometric centre"),
        ParamSpec("cg_y", -cgy, cgy, 0.02, 0.02 * T, "m", "mass", "centre of mass left of the geometric centre"),
        ParamSpec("track_length", 0.15, 1.6, 0.1, 0.05 * L, "m", "contact", "track contact length"),
        ParamSpec("wheelbase", 0.1, 3.0, 0.1, 0.05 * L, "m", "contact", "front to rear axle distance (wheeled robot)"),
        ParamSpec("drive_lag", 0.0, 1.5, 0.1, 0.02, "s", "drive", "first-order time constant from command to track speed"),
        # scale 0.01 s: the optimiser's forward difference (FD_EPS of it, 0.5 ms) stays inside one 5 ms
        # time step, across which the residuals have kinks in the delay (mjtrack.calibrate.fit)
        ParamSpec("drive_delay", 0.0, 0.6, 0.01, 0.02, "s", "drive", "dead time from command to track speed"),
        ParamSpec("track_speed_scale", 0.5, 1.5, 0.05, 0.02, "–", "drive", "actual / commanded track speed"),
        ParamSpec("drive_force_limit", 0.02 * W, 5.0 * W, 0.1 * W, 0.05 * W, "N", "drive",
                  "largest force a track drive applies"),
        # resolution 0.01: on a Husky-sized robot it moves the forward speed in a turn by 1-5 %
        ParamSpec("rolling_resistance", 0.0, 0.6, 0.02, 0.01, "–", "ground",
                  "motion resistance: share of each side's weight holding it back"),
        ParamSpec("slope_x", -0.5, 0.5, 0.02, 0.01, "–", "terrain", "sin(slope) x uphill direction's x (log frame)"),
        ParamSpec("slope_y", -0.5, 0.5, 0.02, 0.01, "–", "terrain", "sin(slope) x uphill direction's y (log frame)"),
        ParamSpec("lateral_ratio", 0.05, 1.0, 0.1, 0.05, "–", "ground", "lateral / longitudinal friction (anisotropic ground)"),
        # resolution 5 mm: at K = 0.05 m it moves a four-wheeler's steady ICR y by about 1 % of T/2
        ParamSpec("shear_modulus", 0.0, 0.5, 0.02, 0.005, "m", "ground",
                  "shear modulus K of the shear ground: friction builds up as mu (1 - exp(-j/K)); 0: Coulomb"),
        # resolution 0.1: at K = 0.01 m it moves a four-wheeler's steady yaw ratio by about 0.01
        ParamSpec("lateral_shear_ratio", 0.1, 10.0, 0.5, 0.1, "–", "ground",
                  "shear ground: modulus across the track or tyre / modulus along it; 1: isotropic"),
        ParamSpec("concentration", 0.0, 0.95, 0.1, 0.05, "–", "ground", "share of the load on the road wheels (road_wheels ground)"),
        ParamSpec("span", 0.05, 1.0, 0.1, 0.05, "–", "ground", "road-wheel span / contact length (road_wheels ground)"),
    )}


GROUND_PARAMS = {"anisotropic": ("lateral_ratio",), "road_wheels": ("concentration", "span"), "coulomb": (),
                 "shear": ("shear_modulus", "lateral_shear_ratio")}
#: ground parameters a robot of another ground may fit too (named in --params): K = 0 is the Coulomb ground
EXTENDS_COULOMB = {"shear_modulus": "coulomb", "lateral_shear_ratio": "coulomb"}
#: candidates that need the window simulator built with the track's contact frames
#: (:func:`mjtrack.sim.ground.framed_robot`)
FRAMED_PARAMS = ("lateral_shear_ratio",)
#: every cause a user meets on a drive log, fitted unless --params names others; identifiability,
#: not this list, decides what stays (:mod:`mjtrack.calibrate.identify`). Plus the ground model's
#: parameters, and the slope where the log's poses share one world frame.
DEFAULT_PARAMS = ("mu", "mu_ratio", "cg_x", "cg_y", "track_length", "drive_lag", "drive_delay", "track_speed_scale",
                  "rolling_resistance")
SLOPE_PARAMS = ("slope_x", "slope_y")
#: a wheeled robot on the Coulomb ground also fits ``shear_modulus`` by default: on the shared
#: Warthog log the calibration determines K = 0.02 m and the held-out error and every turn class's
#: yaw ratio improve; on the Husky's it determines K at the Coulomb value
#: (benchmarks/real_robots.py, results page "Calibration"). A tracked robot fits it when named.
#: ``lateral_shear_ratio`` is fitted when named: the Warthog's log determines it and its held-out
#: error falls a little, the Husky's leaves it undetermined and its gentle turns further off
#: (``benchmarks/real_robots.py --lateral``, the same page).
WHEELED_DEFAULTS = ("shear_modulus",)
#: first values of drivetrain keys that the robot file lacks (a value on a bound stalls the fit)
DRIVE_START = {"drive_lag": 0.05, "drive_delay": 0.02, "track_speed_scale": 1.0}
#: first value of a motion resistance the robot file lacks (0 is a bound)
RESISTANCE_START = 0.02
#: [m] first value of a shear modulus fitted on a Coulomb ground: at K = 0 the friction's
#: build-up 1 - exp(-j/K) and its derivative in K vanish, so no fit leaves it
SHEAR_START = 0.02


def chain_specs() -> dict[str, ParamSpec]:
    """The drivetrain chain's parameters (:mod:`mjtrack.models.drivetrain`), fitted by
    :mod:`mjtrack.calibrate.drivetrain` to a log's measured track speeds (command -> measured
    speed), not to its poses. Resolutions: a change that moves a 20 Hz log's predicted speeds by
    about 1 % of a 1 m/s step."""
    return {s.name: s for s in (
        ParamSpec("track_speed_scale", 0.3, 3.0, 0.05, 0.02, "–", "drive", "actual / commanded track speed"),
        *(ParamSpec(f"drive_delay_{side}", 0.0, 0.5, 0.01, 0.01, "s", "drive", f"dead time of the {side} drive")
          for side in ("left", "right")),
        *(ParamSpec(f"drive_lag_{side}", 0.0, 3.0, 0.05, 0.02, "s", "drive", f"time constant of the {side} drive")
          for side in ("left", "right")),
        *(ParamSpec(f"drive_speed_limit_{side}", 0.02, 50.0, 0.05, 0.02, "m/s", "drive",
                    f"speed at which the {side} drive's controller saturates") for side in ("left", "right")),
        ParamSpec("drive_accel_limit", 0.05, 100.0, 0.2, 0.1, "m/s^2", "drive",
                  "largest rate of change of a drive's set-point"),
        ParamSpec("drive_turn_scale", 0.1, 5.0, 0.05, 0.02, "–", "drive",
                  "set-point half difference / commanded one (a twist controller's track separation)"),
        ParamSpec("drive_mean_speed_limit", 0.02, 50.0, 0.05, 0.02, "m/s", "drive",
                  "a twist controller's limit on the two sides' mean speed"),
        ParamSpec("drive_turn_limit", 0.02, 50.0, 0.05, 0.02, "m/s", "drive",
                  "a twist controller's limit on the two sides' half difference"),
        *(ParamSpec(f"drive_{k}_accel_limit", 0.05, 100.0, 0.2, 0.1, "m/s^2", "drive",
                    f"a twist controller's limit on the rate of change of the two sides' {what}")
          for k, what in (("mean", "mean"), ("turn", "half difference"))),
    )}


def specs_for(robot: Robot) -> dict[str, ParamSpec]:
    """Every parameter's spec for this robot (cg bounds and resolutions follow its geometry)."""
    return _specs(robot)


def geometry_name(robot: Robot) -> str:
    """The robot key of its contact length: ``track_length``, or a wheeled robot's ``wheelbase``."""
    return "wheelbase" if robot.traction == "wheels" else "track_length"


def one_frame(log: DriveLog) -> bool:
    """Whether the log's segments share one world frame (a slope there means something): False when
    every segment starts at the origin with zero heading (each window in its own frame, as the
    DRIVE data of wheeled robots)."""
    starts = [sl.start for sl in log.segment_slices()]
    if len(starts) < 2:
        return True
    p = np.stack([log.x[starts], log.y[starts], log.yaw[starts]], -1)
    return bool(np.any(np.abs(p) > 1e-9))


def default_names(robot: Robot, log: DriveLog | None = None) -> list[str]:
    """The parameters fitted when none are named."""
    names = [geometry_name(robot) if n == "track_length" else n for n in DEFAULT_PARAMS]
    if log is not None and one_frame(log):
        names.extend(SLOPE_PARAMS)
    names.extend(n for n in GROUND_PARAMS.get(robot.ground.model, ()) if n not in FRAMED_PARAMS)  # (named only)
    if robot.traction == "wheels" and robot.ground.model == "coulomb":
        names.extend(WHEELED_DEFAULTS)
    return names


def parse_names(text: str | None, robot: Robot, log: DriveLog | None = None) -> list[str]:
    """``--params a,b,c`` checked against the catalogue and the robot's ground model."""
    if text is None:
        return default_names(robot, log)
    names = [n.strip() for n in text.split(",") if n.strip()]
    specs = specs_for(robot)
    if not names:
        raise InputError("params: no parameter named")
    for n in names:
        if n not in specs:
            raise InputError(f"params: unknown parameter {n!r}; known: {', '.join(specs)}")
        if n in ("track_length", "wheelbase") and n != geometry_name(robot):
            raise InputError(f"params: {n!r} is not the contact length of a robot on {robot.traction}; "
                             f"fit {geometry_name(robot)!r}")
        for model, ps in GROUND_PARAMS.items():
            if n in ps and robot.ground.model != model and robot.ground.model != EXTENDS_COULOMB.get(n):
                raise InputError(f"params: {n!r} belongs to the {model!r} ground; the robot's ground is "
                                 f"{robot.ground.model!r} (set robot key ground: {{\"model\": \"{model}\"}})")
    if len(set(names)) != len(names):
        raise InputError(f"params: a parameter is named twice: {text!r}")
    if ("lateral_shear_ratio" in names and "shear_modulus" not in names
            and not (robot.ground.model == "shear" and robot.ground["shear_modulus"] > 0)):
        raise InputError("params: 'lateral_shear_ratio' acts only on a shear ground of modulus above 0: name "
                         "shear_modulus too, or describe the robot on the shear ground (robot key ground: "
                         "{\"model\": \"shear\", \"shear_modulus\": K})")
    if ({"mu", "mu_ratio"} & set(names)) and ({"mu_left", "mu_right"} & set(names)):
        raise InputError("params: fit friction either as 'mu'/'mu_ratio' or as 'mu_left'/'mu_right', not both")
    return names


def described_values(robot: Robot, names: list[str], config: SimConfig) -> dict[str, float]:
    """Each parameter's value in the description (its default where the description lacks it)."""
    current = robot_params(robot)
    drive = drive_params(robot)
    out = {}
    for n in names:
        if n == "mu":
            v = math.sqrt(robot.friction_left * robot.friction_right)
        elif n == "mu_ratio":
            v = robot.friction_left / robot.friction_right
        elif n in ("mu_left", "mu_right"):
            v = robot.friction_left if n == "mu_left" else robot.friction_right
        elif n in DRIVE_START:
            v = drive.get(n)
            v = {"drive_lag": 0.0, "drive_delay": 0.0, "track_speed_scale": 1.0}[n] if v is None else v
        elif n == "drive_force_limit":
            from mjtrack.sim.drivetrain import drive_of

            v = current.get(n) or drive_of(robot, config).force_limit
        elif n == "shear_modulus":
            v = current.get(n) or 0.0  # a Coulomb ground: K = 0
        elif n == "lateral_shear_ratio":
            v = current.get(n) or 1.0  # a Coulomb ground: isotropic
        else:
            v = current.get(n)
        out[n] = float(v)
    return out


def start_values(robot: Robot, names: list[str], config: SimConfig) -> dict[str, float]:
    """First value of each fitted parameter: the described one, moved off a bound it sits on for
    the drivetrain keys the description lacks; refused off its bounds."""
    described = described_values(robot, names, config)
    specs = specs_for(robot)
    out = {}
    for n in names:
        v = described[n]
        given = robot.provided is None or n in robot.provided
        if n in DRIVE_START and (drive_params(robot).get(n) is None or not given):
            v = DRIVE_START[n]
        if n == "rolling_resistance" and (not given or v == 0.0):
            v = RESISTANCE_START
        if n == "shear_modulus" and v == 0.0:  # K = 0 is a bound where the error is flat in K
            v = SHEAR_START
        s = specs[n]
        if n == "drive_force_limit" and (drive_params(robot).get(n) is None or not given) and v > s.hi:
            # the simulator's default limit (a torque over the sprocket radius) is beyond 5 times a
            # light robot's weight: start halfway up the range, still above what any ground transmits
            v = s.hi / 2
        if not s.lo <= v <= s.hi:
            raise InputError(f"robot: {n} = {v!r} is outside the range calibrate fits in [{s.lo:g}, {s.hi:g}] {s.unit}")
        out[n] = float(v)
    return out


def window_params(values: dict[str, float], robot: Robot) -> dict[str, float]:
    """The :mod:`mjtrack.windows.params` parameters of fitted ``values`` (friction level and split
    become the two sides' coefficients)."""
    out = {k: v for k, v in values.items() if k not in ("mu", "mu_ratio")}
    if "mu" in values or "mu_ratio" in values:
        mu = values.get("mu", math.sqrt(robot.friction_left * robot.friction_right))
        ratio = values.get("mu_ratio", robot.friction_left / robot.friction_right)
        out["mu_left"], out["mu_right"] = mu * math.sqrt(ratio), mu / math.sqrt(ratio)
    assert set(out) <= set(WINDOW_PARAMS), sorted(set(out) - set(WINDOW_PARAMS))
    return out
