"""Sweep grids: a JSON object of lists whose Cartesian product is the set of cases.

Keys (JSON object order is the order of the product and of the CSV columns; the last key
varies fastest):

* commands, one of two forms:
  - ``v_left_cmd``, ``v_right_cmd``: track speed commands [m/s];
  - ``speed``, ``turn_radius``: speed of the geometric centre [m/s] and commanded turn radius
    [m] (> 0 turns left, < 0 right, ``null`` drives straight), turned into track speeds by the
    no-slip kinematics of the case's robot: w = speed / R, V_L = speed - w T/2,
    V_R = speed + w T/2 (T the track gauge). The *measured* ICRs then show how far slip moves
    the robot away from this nominal turn.
* robot keys (any number of them): ``track_gauge``, ``track_length``, ``track_width``,
  ``sprocket_radius``, ``mass``, ``cg_x``, ``cg_y``, ``cg_z``, ``mu``, ``mu_left``, ``mu_right``,
  the drivetrain keys ``drive_lag``, ``drive_delay``, ``drive_force_limit``, ``track_speed_scale``
  and, for a wheeled base robot, ``wheelbase`` and ``wheels_per_side``; each case's robot is the
  base robot with these fields replaced.

Every value is a list (a single value is a list of one: ``[0.5]``). Bad grids raise
:class:`~mjtrack.errors.InputError` naming the file, the key and the bad entry, before any work;
a grid file is at most :data:`MAX_FILE_BYTES` and nested two deep (an object of lists).
"""

from __future__ import annotations

import itertools
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mjtrack.errors import InputError
from mjtrack.io.jsonfile import read_json
from mjtrack.io.robot import Robot

COMMAND_FORMS: tuple[tuple[str, str], ...] = (("v_left_cmd", "v_right_cmd"), ("speed", "turn_radius"))
ROBOT_KEYS: tuple[str, ...] = (
    "track_gauge", "track_length", "track_width", "sprocket_radius", "mass",
    "cg_x", "cg_y", "cg_z", "mu", "mu_left", "mu_right",
    "drive_lag", "drive_delay", "drive_force_limit", "track_speed_scale", "wheelbase", "wheels_per_side",
)
MAX_SPEED = 100.0  # [m/s] a track speed above this is not a ground robot (same bound as drive logs)
MAX_RADIUS = 1e6  # [m] coordinate bound of drive logs; use null for straight driving
MAX_CASES = 100_000  # beyond this a grid is a typo, not a study (about a day on one core)
MAX_FILE_BYTES = 1 << 20  # [bytes] MAX_CASES cases need far fewer values than a megabyte holds


@dataclass(frozen=True)
class Case:
    """One sweep case: its index in the product, grid values, robot and track commands [m/s]."""

    index: int
    values: tuple[tuple[str, float | None], ...]
    robot: Robot
    v_left_cmd: float
    v_right_cmd: float


@dataclass(frozen=True)
class Grid:
    """A validated grid: its keys and lists (file order), the command form and all cases."""

    axes: tuple[tuple[str, tuple[float | None, ...]], ...]
    form: tuple[str, str]
    cases: tuple[Case, ...]
    source: str

    @property
    def keys(self) -> tuple[str, ...]:
        return tuple(k for k, _ in self.axes)

    def to_dict(self) -> dict[str, list[float | None]]:
        return {k: list(v) for k, v in self.axes}


def read_grid(path: str | os.PathLike, base: Robot | None = None) -> Grid:
    """Read and validate a grid JSON file (see the module docstring)."""
    path = Path(path)
    data = read_json(path, what="grid", max_bytes=MAX_FILE_BYTES, max_depth=2)
    return grid_from_dict(data, base=base, source=str(path))


def _number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def grid_from_dict(data: Any, *, base: Robot | None = None, source: str = "grid") -> Grid:
    """Validate a grid given as a dict (JSON object) and expand it into cases."""
    base = base or Robot()
    if not isinstance(data, dict) or not data:
        raise InputError(f"{source}: expected a non-empty JSON object of lists, e.g. "
                         '{"speed": [0.5, 1.0], "turn_radius": [0.5, 1, 2], "mu": [0.5, 0.8]}')
    allowed = set(ROBOT_KEYS) | {k for form in COMMAND_FORMS for k in form}
    unknown = [k for k in data if k not in allowed]
    if unknown:
        raise InputError(f"{source}: unknown key {unknown[0]!r}; allowed: "
                         f"{', '.join(k for form in COMMAND_FORMS for k in form)}, {', '.join(ROBOT_KEYS)}")
    forms = [form for form in COMMAND_FORMS if any(k in data for k in form)]
    if len(forms) != 1 or not all(k in data for k in forms[0]):
        raise InputError(f"{source}: give the commands as both 'v_left_cmd' and 'v_right_cmd', "
                         "or as both 'speed' and 'turn_radius' (not a mix)")
    form = forms[0]
    axes = []
    for key, raw in data.items():
        if not isinstance(raw, list):
            raise InputError(f"{source}: key {key!r}: expected a list of values, got {raw!r}"[:300]
                             + (f" (write [{raw!r}] for one value)" if _number(raw) or raw is None else ""))
        values = raw
        if not values:
            raise InputError(f"{source}: key {key!r}: empty list")
        for j, v in enumerate(values):
            if v is None and key == "turn_radius":
                continue  # straight
            if not _number(v):
                what = "a finite number or null (straight)" if key == "turn_radius" else "a finite number"
                raise InputError(f"{source}: key {key!r}, entry {j}: expected {what}, got {v!r}")
            if key in ("v_left_cmd", "v_right_cmd", "speed") and abs(v) > MAX_SPEED:
                raise InputError(f"{source}: key {key!r}, entry {j}: {v!r} m/s is beyond a plausible "
                                 f"track speed (|v| <= {MAX_SPEED:g} m/s)")
            if key == "turn_radius" and not 0 < abs(v) <= MAX_RADIUS:
                raise InputError(f"{source}: key 'turn_radius', entry {j}: {v!r} m; need 0 < |R| <= "
                                 f"{MAX_RADIUS:g} m (null for straight; give v_left_cmd/v_right_cmd for a spot turn)")
        axes.append((key, tuple(None if v is None else float(v) for v in values)))
    n = math.prod(len(v) for _, v in axes)
    if n > MAX_CASES:
        raise InputError(f"{source}: {n} cases; at most {MAX_CASES} in one sweep")
    cases = [_case(i, dict(zip((k for k, _ in axes), combo)), form, base, source)
             for i, combo in enumerate(itertools.product(*(v for _, v in axes)))]
    return Grid(axes=tuple(axes), form=form, cases=tuple(cases), source=source)


def _case(index: int, values: dict[str, float | None], form: tuple[str, str], base: Robot, source: str) -> Case:
    changes = {k: v for k, v in values.items() if k in ROBOT_KEYS}
    try:
        robot = base.replace(**changes) if changes else base
    except InputError as exc:
        raise InputError(f"{source}: case {index} ({_describe(values)}): {exc}") from None
    if form == COMMAND_FORMS[0]:
        vl, vr = float(values["v_left_cmd"]), float(values["v_right_cmd"])
    else:
        vl, vr = track_commands(float(values["speed"]), values["turn_radius"], robot.track_gauge)
        if max(abs(vl), abs(vr)) > MAX_SPEED:
            raise InputError(f"{source}: case {index} ({_describe(values)}): track speeds ({vl:.4g}, {vr:.4g}) "
                             f"m/s are beyond a plausible track speed (|v| <= {MAX_SPEED:g} m/s)")
    return Case(index=index, values=tuple(values.items()), robot=robot, v_left_cmd=vl, v_right_cmd=vr)


def track_commands(speed: float, turn_radius: float | None, track_gauge: float) -> tuple[float, float]:
    """No-slip track speeds (V_L, V_R) [m/s] for a centre speed [m/s] on a turn radius [m]
    (> 0 left; ``None`` straight): w = v/R, V_L,R = v -/+ w T/2."""
    if turn_radius is None:
        return speed, speed
    w = speed / turn_radius
    return speed - w * track_gauge / 2, speed + w * track_gauge / 2


def nominal_turn(v_left: float, v_right: float, track_gauge: float) -> tuple[float, float | None]:
    """Inverse of :func:`track_commands`: (centre speed, turn radius or ``None`` if straight
    or a spot turn) of track speeds under no slip."""
    speed = (v_left + v_right) / 2
    w = (v_right - v_left) / track_gauge
    if w == 0 or speed == 0:
        return speed, None
    return speed, speed / w


def _describe(values: dict[str, float | None]) -> str:
    return ", ".join(f"{k}={v}" for k, v in values.items())
