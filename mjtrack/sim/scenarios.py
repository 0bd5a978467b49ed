"""Scenario registry: named track-speed command tables for headless rollouts.

A scenario is a function ``(robot, duration, rng) -> (t, v_left, v_right)`` giving a
piecewise-constant command table (commands held from t[k] to t[k+1]) [s, m/s, m/s]. Turns
are specified kinematically (nominal model (2.1): V_L = v - w T/2, V_R = v + w T/2) from
the robot's gauge; the simulated robot then turns less than commanded, which is the slip
the models of the project describe.

| name | what |
|---|---|
| ``straight`` | 0.5 m/s on both tracks |
| ``circle`` | v = 0.5 m/s on a nominal 1 m radius, CCW |
| ``pivot`` | V_L = -0.4, V_R = +0.4 m/s (turn on the spot, CCW) |
| ``u_path`` | the thesis's U path: straight 0.5 m/s, half turn at pi/6 rad/s (6 s), straight back; 27 s |
| ``random_steps`` | seeded DRIVE-like steps: (V_L, V_R) uniform in [-1, 1] m/s, each held 2-4 s |
| ``slope_traverse`` | 0.5 m/s straight across a 0.2 rad incline (uphill +y): the robot drifts and yaws downhill |
| ``hill_climb`` | 0.5 m/s straight up a 0.25 rad incline (uphill +x) |
| ``step_climb`` | 0.4 m/s straight onto a 4 cm step at x = 1 m |
| ``ice_patch`` | v = 0.5 m/s on a nominal 2 m radius (CCW) crossing a mu 0.1 strip (x 1-3 m): friction changes mid-run |

Terrain scenarios carry their terrain (``Scenario.terrain``); a ``--terrain`` given on the
command line replaces it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from mjtrack.errors import InputError
from mjtrack.io.robot import Robot
from mjtrack.sim.terrain import Patch, Step, Terrain

CommandTable = tuple[np.ndarray, np.ndarray, np.ndarray]


@dataclass(frozen=True)
class Scenario:
    """A registered scenario: its command generator and default duration [s]."""

    name: str
    description: str
    duration: float
    make: Callable[[Robot, float, np.random.Generator], CommandTable]
    terrain: Terrain = Terrain()


def _const(vl: float, vr: float) -> CommandTable:
    return np.array([0.0]), np.array([vl]), np.array([vr])


def nominal_speeds(robot: Robot, v: float, wz: float) -> tuple[float, float]:
    """Track speeds (V_L, V_R) [m/s] of the nominal model (2.1) for a twist (v, wz)."""
    half = robot.track_gauge / 2
    return v - wz * half, v + wz * half


def _straight(robot: Robot, duration: float, rng: np.random.Generator) -> CommandTable:
    return _const(0.5, 0.5)


def _circle(robot: Robot, duration: float, rng: np.random.Generator) -> CommandTable:
    return _const(*nominal_speeds(robot, 0.5, 0.5 / 1.0))


def _pivot(robot: Robot, duration: float, rng: np.random.Generator) -> CommandTable:
    return _const(-0.4, 0.4)


def _u_path(robot: Robot, duration: float, rng: np.random.Generator) -> CommandTable:
    """Straight, half turn at pi/6 rad/s (pi / (pi/6) = 6 s), straight: 10.5 + 6 + 10.5 s."""
    v, w = 0.5, math.pi / 6
    t_turn = math.pi / w
    t1 = 10.5
    vl, vr = nominal_speeds(robot, v, w)
    return np.array([0.0, t1, t1 + t_turn]), np.array([v, vl, v]), np.array([v, vr, v])


def _random_steps(robot: Robot, duration: float, rng: np.random.Generator) -> CommandTable:
    t, ts = [], 0.0
    while ts < duration:
        t.append(ts)
        ts += rng.uniform(2.0, 4.0)
    n = len(t)
    return np.array(t), rng.uniform(-1.0, 1.0, n), rng.uniform(-1.0, 1.0, n)


def _ice_patch(robot: Robot, duration: float, rng: np.random.Generator) -> CommandTable:
    return _const(*nominal_speeds(robot, 0.5, 0.5 / 2.0))


ICE_STRIP = Terrain(patches=(Patch(x=2.0, y=2.0, size_x=2.0, size_y=8.0, mu=0.1),), spec="ice_patch")


SCENARIOS: dict[str, Scenario] = {
    s.name: s
    for s in (
        Scenario("straight", "0.5 m/s on both tracks", 10.0, _straight),
        Scenario("circle", "v = 0.5 m/s on a nominal 1 m radius, CCW", 20.0, _circle),
        Scenario("pivot", "V_L = -0.4, V_R = 0.4 m/s: turn on the spot", 10.0, _pivot),
        Scenario("u_path", "thesis U path: straight, half turn at pi/6 rad/s, straight", 27.0, _u_path),
        Scenario("random_steps", "seeded random (V_L, V_R) steps in [-1, 1] m/s held 2-4 s", 60.0,
                 _random_steps),
        Scenario("slope_traverse", "0.5 m/s across a 0.2 rad incline (uphill +y)", 20.0, _straight,
                 Terrain(angle=0.2, direction=math.pi / 2, spec="incline:0.2:1.5707963267948966")),
        Scenario("hill_climb", "0.5 m/s up a 0.25 rad incline", 10.0, _straight,
                 Terrain(angle=0.25, spec="incline:0.25")),
        Scenario("step_climb", "0.4 m/s onto a 4 cm step at x = 1 m", 10.0, lambda r, d, g: _const(0.4, 0.4),
                 Terrain(steps=(Step(height=0.04, x=1.0),), spec="step:0.04:1.0")),
        Scenario("ice_patch", "v = 0.5 m/s on a nominal 2 m radius crossing a mu 0.1 strip (x 1-3 m)", 30.0,
                 _ice_patch, ICE_STRIP),
    )
}


def scenario_commands(name: str, robot: Robot, *, duration: float | None = None, seed: int = 0
                      ) -> tuple[CommandTable, float]:
    """Command table (t, v_left, v_right) of a registered scenario and its duration [s]."""
    if name not in SCENARIOS:
        raise InputError(f"unknown scenario {name!r}; choose one of {', '.join(SCENARIOS)}")
    sc = SCENARIOS[name]
    duration = sc.duration if duration is None else float(duration)
    if not (math.isfinite(duration) and duration > 0):
        raise InputError(f"duration must be a positive number of seconds, got {duration!r}")
    return sc.make(robot, duration, np.random.default_rng(seed)), duration


def read_commands(path) -> CommandTable:
    """Command table from a CSV with columns ``t, v_left_cmd, v_right_cmd`` (others ignored).

    Time must be finite and strictly increasing, speeds finite; bad input raises
    :class:`InputError` naming the file, the column and the line.
    """
    import csv
    from pathlib import Path

    path = Path(path)
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            rows = [r for r in csv.reader(fh) if r and any(c.strip() for c in r)]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise InputError(f"{path}: cannot read commands ({getattr(exc, 'strerror', None) or exc})") from None
    if len(rows) < 2:
        raise InputError(f"{path}: no command rows")
    header = [c.strip() for c in rows[0]]
    cols = {}
    for name in ("t", "v_left_cmd", "v_right_cmd"):
        if name not in header:
            raise InputError(f"{path}: missing column '{name}'")
        j = header.index(name)
        values = []
        for k, row in enumerate(rows[1:]):
            try:
                v = float(row[j])
            except (IndexError, ValueError):
                raise InputError(f"{path}: line {k + 2}, column '{name}': not a number") from None
            if not math.isfinite(v):
                raise InputError(f"{path}: line {k + 2}, column '{name}': not finite")
            values.append(v)
        cols[name] = np.array(values)
    bad = np.nonzero(np.diff(cols["t"]) <= 0)[0]
    if len(bad):
        raise InputError(f"{path}: line {bad[0] + 3}, column 't': time not strictly increasing")
    return cols["t"], cols["v_left_cmd"], cols["v_right_cmd"]
