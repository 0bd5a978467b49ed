"""A hidden ground extension in a MuJoCo log is found by ``calibrate``.

The log comes from mjtrack/testing/mujoco_effects.py, whose anisotropic ground is its own implementation
(capsule rollers and pair friction written there, not through mjtrack.sim.ground); calibrate
starts from an isotropic-looking lateral ratio (0.9) on a robot built with the anisotropic ground.
"""

from __future__ import annotations

import pytest

from mjtrack.calibrate.run import calibrate
from mjtrack.io.robot import Robot
from mjtrack.testing.mujoco_effects import HIDDEN, ROBOT, make_log


@pytest.mark.slow
def test_calibrate_recovers_the_hidden_lateral_friction():
    lg, _ = make_log("ground_anisotropy", seed=1, duration=40.0)
    robot = Robot.from_dict({**ROBOT.to_dict(), "drive_force_limit": 600.0 / ROBOT.sprocket_radius,
                             "ground": {"model": "anisotropic", "lateral_ratio": 0.9}})
    cal = calibrate(lg, robot, names=["lateral_ratio"], nthread=1)
    truth = HIDDEN["ground_anisotropy"].params["lateral_ratio"]
    assert cal.calibrated.ground.model == "anisotropic"
    assert cal.calibrated.ground["lateral_ratio"] == pytest.approx(truth, abs=0.06)
