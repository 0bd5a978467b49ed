"""The one robot builder (mjtrack.sim.chassis): the shared chassis puts the robot's mass and centre
of mass where the Robot says, for every track model plugged in, with or without idlers."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mjtrack.io.robot import Robot
from mjtrack.sim.builder import build_model
from mjtrack.sim.config import SimConfig, surfacevel_config
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


def _inertia_about_com(m: mujoco.MjModel, d: mujoco.MjData, root: int) -> np.ndarray:
    """Inertia tensor of the subtree of ``root`` about its centre of mass, world axes, summed from
    each body's mass, principal moments and frame (not from the builder's formula)."""
    com = d.subtree_com[root]
    total = np.zeros((3, 3))
    for b in range(m.nbody):
        body, inside = b, False
        while body > 0:
            if body == root:
                inside = True
                break
            body = m.body_parentid[body]
        if not inside:
            continue
        R = d.ximat[b].reshape(3, 3)
        r = d.xipos[b] - com
        total += R @ np.diag(m.body_inertia[b]) @ R.T + m.body_mass[b] * (r @ r * np.eye(3) - np.outer(r, r))
    return total


@pytest.mark.parametrize("make", [
    lambda t: build_model(ROBOT, None, t),
    lambda t: build_surfacevel_model(ROBOT, surfacevel_config(), t),
], ids=["rollers", "surfacevel"])
def test_the_robot_has_the_body_axes_as_principal_axes(make):
    """SimConfig.principal_axes: the whole robot's products of inertia about its centre of mass are
    zero (cg off-centre in x, y and z), so a spinning robot feels no pitch or roll moment that its
    description (mass, cg, no products) does not have; the diagonal is the box's plus the
    elements'. With a plain box chassis (principal_axes=False) I_xz = m_el cg_x (cg_z - r) M / m_chassis."""
    m = make(None)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    chassis = m.body("chassis").id
    inertia = _inertia_about_com(m, d, chassis)
    scale = np.max(np.abs(np.diag(inertia)))
    off = inertia - np.diag(np.diag(inertia))
    assert np.max(np.abs(off)) < 1e-12 * scale
    box = build_model(ROBOT, SimConfig(principal_axes=False))
    db = mujoco.MjData(box)
    mujoco.mj_forward(box, db)
    off_box = _inertia_about_com(box, db, box.body("chassis").id)
    m_el = SimConfig().unsprung_fraction * ROBOT.mass
    r = SimConfig().roller_radius
    expected = -m_el * ROBOT.cg_x * (ROBOT.cg_z - r) * ROBOT.mass / (ROBOT.mass - m_el)  # I_xz = -sum m x z
    assert off_box[0, 2] == pytest.approx(expected, rel=1e-6)  # (the belt joints' 2 mg bodies aside)


def test_windows_move_the_products_of_inertia_with_the_cg():
    """A window simulation that moves the centre of mass through the model's fields keeps the
    principal axes on the body axes, as a rebuild would."""
    from mjtrack.sim.windows import WindowSim

    sim = WindowSim(ROBOT, SimConfig())
    m = sim.variant_model({"cg_x": -0.06, "cg_y": 0.05})
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    chassis = m.body("chassis").id
    inertia = _inertia_about_com(m, d, chassis)
    np.testing.assert_allclose(d.subtree_com[chassis] - d.xpos[chassis], [-0.06, 0.05, ROBOT.cg_z], atol=1e-12)
    off = inertia - np.diag(np.diag(inertia))
    assert np.max(np.abs(off)) < 1e-12 * np.max(np.abs(np.diag(inertia)))
    rebuilt = build_model(ROBOT.replace(cg_x=-0.06, cg_y=0.05), SimConfig())
    np.testing.assert_allclose(m.body_ipos[chassis], rebuilt.body_ipos[chassis], atol=1e-12)
    dr = mujoco.MjData(rebuilt)
    mujoco.mj_forward(rebuilt, dr)
    np.testing.assert_allclose(inertia, _inertia_about_com(rebuilt, dr, chassis), rtol=0, atol=1e-12 * np.max(inertia))
