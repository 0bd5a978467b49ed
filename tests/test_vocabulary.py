"""One name per physical quantity across calibration.json, diagnosis.json, the robot file and the API.

The names are collected from where each output takes them: calibration's parameter catalogue
(``mjtrack.calibrate.params``), diagnosis's effect vocabulary (``mjtrack.diagnose.EFFECTS``), the
robot-file reference (``docs/reference/formats/robot-file.md`` with its key table) and the
``mjtrack.io.robot.Robot`` fields, and the parameters of the public API's functions
(``mjtrack.api``). Each name is mapped below, by hand, to the physical quantity it stands for
(or marked as not a quantity: an option, a structure); the test fails when a name is not mapped
(say what it is) or when one quantity has two names.
"""

from __future__ import annotations

import dataclasses
import inspect
import re
from collections import defaultdict
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs" / "reference" / "formats"

#: name -> the physical quantity it stands for
QUANTITY = {
    # geometry
    "track_gauge": "distance between the left and right contact centre lines",
    "track_length": "length of a track's ground contact",
    "track_width": "width of a track's ground contact",
    "wheelbase": "front to rear axle distance of a wheeled robot",
    "wheels_per_side": "wheels on each side of a wheeled robot",
    "sprocket_radius": "radius turning a drive's angular speed into ground speed",
    # mass
    "mass": "total mass",
    "cg_x": "centre of mass ahead of the geometric centre",
    "cg_y": "centre of mass left of the geometric centre",
    "cg_z": "centre of mass height",
    # ground
    "mu": "ground friction coefficient",
    "mu_left": "left side's ground friction coefficient",
    "mu_right": "right side's ground friction coefficient",
    "mu_ratio": "left over right ground friction",
    "friction_scale": "ground friction over the described friction",
    "rolling_resistance": "motion resistance as a share of the carried weight",
    "lateral_ratio": "lateral over longitudinal friction of the contact",
    "concentration": "share of the weight on the road wheels",
    "span": "road-wheel span over the contact length",
    "wheels": "road wheels carrying the concentrated load",
    "icr_spread": "track ICR spread over the modelled spread",
    "slope_x": "in-plane gravity per g along the world x (sin slope times the uphill x)",
    "slope_y": "in-plane gravity per g along the world y (sin slope times the uphill y)",
    # drivetrain
    "drive_lag": "first-order time constant from command to track speed",
    "drive_delay": "dead time from command to track speed",
    "drive_force_limit": "largest traction force of one drive",
    "drive_speed_limit": "speed at which a side's speed controller saturates",
    "track_speed_scale": "actual over commanded track speed",
    # the per-side drivetrain keys and the acceleration limit (robot file, from 0.3)
    "drive_speed_limit_left": "speed at which the left side's speed controller saturates",
    "drive_speed_limit_right": "speed at which the right side's speed controller saturates",
    "drive_lag_left": "left side's time constant from command to track speed",
    "drive_lag_right": "right side's time constant from command to track speed",
    "drive_delay_left": "left side's dead time from command to track speed",
    "drive_delay_right": "right side's dead time from command to track speed",
    "drive_accel_limit": "largest track acceleration of a drive",
    # what a speed controller that commands the body twist does (robot file, from 0.3)
    "drive_turn_scale": "actual over commanded half difference of the track speeds",
    "drive_mean_speed_limit": "speed at which the controller saturates the mean of the track speeds",
    "drive_turn_limit": "half difference of the track speeds at which the controller saturates it",
    "drive_mean_accel_limit": "largest rate of change the controller gives the mean of the track speeds",
    "drive_turn_accel_limit": "largest rate of change the controller gives the half difference of the track speeds",
    # the shear-displacement ground
    "shear_modulus": "shear displacement over which the ground's shear stress builds up (Janosi-Hanamoto K)",
    "lateral_shear_ratio": "the shear modulus across the track or tyre over the one along it",
    # simulation and logs
    "timestep": "simulation time step",
    "n_rollers": "rollers per track of the simulated chain",
    "log_rate": "log sample rate",
    "duration": "log duration",
    "horizon_s": "prediction window length",
    "settle_s": "time a steady state is given to settle",
    "window_s": "time a steady state is averaged over",
    "v_left": "left track speed",
    "v_right": "right track speed",
    "wz_min": "least yaw rate of a turn",
    "noise_scale": "measurement noise over the preset's",
}
#: names that are not physical quantities: options, structures, data
NOT_A_QUANTITY = {
    "ground", "simulator", "traction", "terrain", "extra", "provided", "model", "track_model", "drive_input",
    "log", "robot", "test_log", "params", "effects", "baseline", "scenario", "commands", "seed", "quiet", "out_dir",
    "max_iter", "rounds", "fit_windows", "n_folds", "speeds", "inertial", "load_transfer",
    # effects whose quantity is their parameter's: a ground model switched on, an incline
    "ground_anisotropy", "road_wheels", "slope",
    # a ground model's name (its parameter is the quantity) and the measurement noise record of a log
    "shear", "noise",
}
#: a second name the robot file reads on purpose, with why (listed so that no other one slips in)
ALIASES = {"wheel_radius": ("sprocket_radius", "the robot file reads sprocket_radius under a wheeled robot's "
                                                "name for it; the description holds one value")}


def _robot_file_keys() -> set[str]:
    text = (DOCS / "_robot_keys.md").read_text() + (DOCS / "robot-file.md").read_text()
    keys = set()
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("|") and len(cells) > 1:
            # the key table: first cell the key; the ground models' table: model, then parameter
            for cell in cells[:2]:
                keys.update(re.fullmatch(r"`(\w+)`", cell).groups() if re.fullmatch(r"`(\w+)`", cell) else ())
    return keys - {"coulomb", "road_wheels", "anisotropic"}  # ground model names (values, not keys)


def _names() -> dict[str, set[str]]:
    """Where each name is used: source -> names."""
    from mjtrack import api
    from mjtrack.calibrate.params import specs_for
    from mjtrack.diagnose import EFFECTS
    from mjtrack.io.robot import Robot

    tracked, wheeled = Robot(), Robot(traction="wheels", track_gauge=0.55, wheelbase=0.5)
    out = {
        "calibration.json": set(specs_for(tracked)) | set(specs_for(wheeled)),
        "diagnosis.json": {n for e in EFFECTS.values() for n in (e.name, *e.params)},
        "robot file": _robot_file_keys() | {f.name for f in dataclasses.fields(Robot)},
        "API": set(),
    }
    for name, obj in vars(api).items():
        if inspect.isfunction(obj) and obj.__module__ == api.__name__ and not name.startswith("_"):
            out["API"] |= set(inspect.signature(obj).parameters)
    assert out["API"], "no function of mjtrack.api found"
    return out


def second_names(names: dict[str, set[str]], quantity: dict[str, str]) -> dict[str, list[str]]:
    """Quantity -> its names, for every quantity named more than once."""
    by_quantity = defaultdict(set)
    for used in names.values():
        for n in used:
            if n in quantity:
                by_quantity[quantity[n]].add(n)
    return {q: sorted(ns) for q, ns in by_quantity.items() if len(ns) > 1}


def test_every_name_is_a_known_quantity_or_not_a_quantity():
    unknown = {src: sorted(n for n in used if n not in QUANTITY and n not in NOT_A_QUANTITY and n not in ALIASES)
               for src, used in _names().items()}
    assert not any(unknown.values()), f"map these names to their quantity in QUANTITY (or NOT_A_QUANTITY): {unknown}"


def test_one_name_per_quantity():
    names = _names()
    assert second_names(names, QUANTITY) == {}
    for alias, (key, _) in ALIASES.items():  # an alias is only ever the robot file's
        assert alias in names["robot file"] and key in names["robot file"]
        assert all(alias not in used for src, used in names.items() if src != "robot file"), alias


def test_a_second_name_is_caught():
    # the names diagnosis used before 0.3, beside calibration's: each quantity twice
    old = {"cg_offset_x": QUANTITY["cg_x"], "friction_asymmetry": QUANTITY["mu_ratio"],
           "actuator_lag": QUANTITY["drive_lag"], "command_delay": QUANTITY["drive_delay"]}
    names = _names()
    names["diagnosis.json"] = names["diagnosis.json"] | set(old)
    found = second_names(names, {**QUANTITY, **old})
    assert found[QUANTITY["cg_x"]] == ["cg_offset_x", "cg_x"] and len(found) == 4


@pytest.mark.parametrize("effect", ["cg_x", "mu_ratio", "drive_lag", "drive_delay", "drive_speed_limit",
                                    "track_speed_scale", "rolling_resistance"])
def test_an_effect_with_a_robot_or_calibration_name_takes_it(effect):
    from mjtrack.diagnose import EFFECTS

    assert EFFECTS[effect].params == (effect,)
