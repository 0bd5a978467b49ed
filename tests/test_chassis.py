"""The one robot builder (mjtrack.sim.chassis): the shared chassis puts the robot's mass and centre
of mass where the Robot says, for every track model plugged in, with or without idlers."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mjtrack.io.robot import Robot
from mjtrack.sim.builder import build_model
from mjtrack.sim.config import surfacevel_config
from mjtrack.sim.surfacevel import build_surfacevel_model
from mjtrack.sim.terrain import Step, Terrain

ROBOT = Robot(cg_x=0.04, cg_y=-0.03, cg_z=0.1, mass=25.0)
STEP = Terrain(steps=(Step(height=0.05, x=1.0),), spec="step:0.05:1")  # idlers are built


@pytest.mark.parametrize("make", [
    lambda t: build_model(ROBOT, None, t),
    lambda t: build_surfacevel_model(ROBOT, surfacevel_config(), t),
    lambda t: build_surfacevel_model(ROBOT, surfacevel_config(), t, element="capsule", n_elements=7),
    lambda t: build_surfacevel_model(ROBOT, surfacevel_config(), t, element="box", n_elements=1, sprung=False),
], ids=["rollers", "surfacevel", "surfacevel-capsules", "surfacevel-rigid-box"])
@pytest.mark.parametrize("terrain", [None, STEP], ids=["flat", "idlers"])
def test_mass_and_centre_of_mass_match_the_robot(make, terrain):
    m = make(terrain)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)  # qpos0: every suspension slide at its nominal (q = 0) position
    chassis = m.body("chassis").id
    assert m.body_subtreemass[chassis] == pytest.approx(ROBOT.mass, rel=1e-12)
    # chassis frame = world frame at qpos0 only on the flat; on the step terrain the robot is lifted
    com = d.subtree_com[chassis] - d.xpos[chassis]
    np.testing.assert_allclose(com, [ROBOT.cg_x, ROBOT.cg_y, ROBOT.cg_z], atol=1e-12)
    assert ("idler_front" in [m.body(i).name for i in range(m.nbody)]) == (terrain is not None)
