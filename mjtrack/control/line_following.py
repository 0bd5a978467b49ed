"""Reactive line following with two sensors ahead of the axle, thesis section 3.2.2.1.

Two point sensors sit ``sensor_ahead`` (d) in front of the reference point (axle centre of a
differential drive, rear-axle centre B of a car), ``sensor_spacing`` (c) apart, one on each
side of the centre line.  Each reports on which side of the line (a :class:`Polyline`) it is:
+1 left of the line's direction of travel, -1 right, 0 over the line (within half the line
width; the thesis's line is infinitely thin, width 0).  The law, at constant speed v:

    w = -W (s_L + s_R)/2,   except (s_L, s_R) = (-1, +1) (robot facing backwards): w = W

i.e. line between the sensors -> straight; both sensors left of the line -> turn right at the
turn rate W; both right -> turn left; one sensor over the line -> half rate.  For an Ackermann
car use W = v tan(theta_max)/l: the adapter then steers theta_max (bang-bang steering, as in
the thesis).  A smaller spacing c follows the line more closely but decides the side later
(thesis fig. 3.20).  The robot stops (v = w = 0) when the sensors' midpoint has reached the
end of the line.

A line that crosses or retraces itself (a figure-eight, several laps) is ambiguous to a sensor
model that reads the side of the *nearest* line: near the crossing the other branch is
nearest.  With a finite ``search_window`` the follower keeps the arc length its sensors have
reached (from the line's start) and reads only the part of the line within the window of it,
as a real sensor sees only the tape under it.
"""

from __future__ import annotations

import math
from dataclasses import KW_ONLY, dataclass

import numpy as np

from mjtrack.control.paths import Polyline
from mjtrack.errors import InputError


@dataclass
class LineFollower:
    """Two-sensor bang-bang line follower; see the module docstring.

    Attributes:
        line: the path on the floor.
        speed: v [m/s]; turn_rate: W [rad/s]; sensor_ahead: d [m]; sensor_spacing: c [m];
        line_width: [m] (0: infinitely thin);
        search_window: [m] of arc length around the progress within which the line is read
            (default: the whole line, as the thesis).
    """

    line: Polyline
    _: KW_ONLY
    speed: float = 0.3
    turn_rate: float = 3.0
    sensor_ahead: float = 0.04
    sensor_spacing: float = 0.02
    line_width: float = 0.0
    search_window: float = math.inf

    def __post_init__(self) -> None:
        if not (self.speed > 0 and self.turn_rate > 0 and self.sensor_ahead >= 0 and self.sensor_spacing > 0
                and self.line_width >= 0 and self.search_window > 0):
            raise InputError("LineFollower: need speed, turn_rate, sensor_spacing, search_window > 0 and "
                             "sensor_ahead, line_width >= 0")
        self.reset()

    def reset(self) -> None:
        self._progress = 0.0  # arc length [m] of the sensors' midpoint's foot point

    def sensor_points(self, pose) -> np.ndarray:
        """(2, 2) world positions of the left and right sensors [m]."""
        c, s = math.cos(pose[2]), math.sin(pose[2])
        half = 0.5 * self.sensor_spacing
        base = np.array([pose[0] + self.sensor_ahead * c, pose[1] + self.sensor_ahead * s])
        side = np.array([-s, c]) * half
        return np.stack([base + side, base - side])

    def read(self, pose) -> tuple[int, int]:
        """Sensor readings (s_L, s_R), each in {-1, 0, +1}."""
        out = []
        for p in self.sensor_points(pose):
            dist = self.line.closest(p, near=self._progress, window=self.search_window)[0]
            out.append(0 if abs(dist) <= 0.5 * self.line_width else (1 if dist > 0 else -1))
        return out[0], out[1]

    def command(self, t: float, pose, twist=None) -> tuple[float, float]:
        mid = self.sensor_points(pose).mean(axis=0)
        self._progress = self.line.closest(mid, near=self._progress, window=self.search_window)[1]
        if self._progress >= self.line.length - 1e-9:
            return 0.0, 0.0
        s_left, s_right = self.read(pose)
        if (s_left, s_right) == (-1, 1):
            return self.speed, self.turn_rate
        return self.speed, -self.turn_rate * 0.5 * (s_left + s_right)
