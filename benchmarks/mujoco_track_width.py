"""Does the MuJoCo robot's turning depend on the description's track width?

    python benchmarks/mujoco_track_width.py

The steady yaw ratio wz / ((V_R - V_L)/T) of the MuJoCo robot (mjtrack.sim.steady, default
settings and track elements) for track widths 0.1 and 0.2 m, on a pivot and a turn, beside the
rigid-track Coulomb reference of the same description (mjtrack.models.coulomb) with a line
contact per track (n_across=1, what the diagnosis surrogate uses) and with 4 contact columns
across the width (n_across=4, the midpoint rule of a uniform pressure across the track). The
default track elements are spheres on each track's centre line, so MuJoCo turns like the line
contact whatever the width; a real track of the same width, uniformly loaded across, turns
less (the lateral friction of the outer columns adds turning resistance).
"""

from __future__ import annotations

import os
import sys

from mjtrack.io.robot import Robot
from mjtrack.models import coulomb
from mjtrack.sim.config import SimConfig
from mjtrack.sim.steady import steady_state
from mjtrack.testing.repo import benchmark_command, default_run_result, printed_result


def main() -> int:
    print(f"load {os.getloadavg()}")
    print(f"{'width':>6s} {'command':>13s} {'MuJoCo':>7s} {'line':>7s} {'4 across':>8s}")
    for width in (0.1, 0.2):
        robot = Robot(track_width=width)
        for vl, vr in ((-0.4, 0.4), (0.2, 0.6)):
            s = steady_state(robot, vl, vr, config=SimConfig())
            scale = (s.v_right - s.v_left) / robot.track_gauge  # the measured track speeds
            line = coulomb.steady_state(robot, s.v_left, s.v_right).twist[2] / scale
            wide = coulomb.steady_state(robot, s.v_left, s.v_right, n_across=4).twist[2] / scale
            print(f"{width:6.2f} ({vl:+.1f}, {vr:+.1f}) {s.wz / scale:7.4f} {line:7.4f} {wide:8.4f}")
    print(f"load {os.getloadavg()}")
    return 0


if __name__ == "__main__":
    with printed_result(default_run_result("mujoco_track_width.txt"), command=benchmark_command(__file__)):
        status = main()
    sys.exit(status)
