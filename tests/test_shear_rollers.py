"""The shear ground on the roller chain and on the wheels (batched rollouts, friction set each chunk):
its Coulomb limit and its reference (mjtrack.models.shear) in steady turns."""

from __future__ import annotations

import numpy as np
import pytest

from mjtrack.io.robot import Robot
from mjtrack.models import shear
from mjtrack.sim.config import SimConfig
from mjtrack.sim.steady import steady_state

WHEELED = Robot(traction="wheels", track_gauge=0.55, wheelbase=0.51, sprocket_radius=0.165, mass=50.0, cg_z=0.2)


def _icr(robot, vl, vr):
    s = steady_state(robot, vl, vr, config=SimConfig())
    return np.array([s.y_l, s.y_r, s.x_c])


def test_batched_shear_displacement_is_the_scalar_one_row_by_row():
    rng = np.random.default_rng(3)
    x = rng.uniform(-0.3, 0.3, 12)
    y = np.where(np.arange(12) < 6, 0.2, -0.2)
    xe = np.tile([0.3, -0.3], (12, 1))
    twists = rng.normal(0.0, 0.5, (5, 3))
    twists[1, 2] = 0.0  # a translation
    V = rng.normal(0.0, 0.6, (5, 2))
    V[2, 0] = 0.0  # a stopped side
    Vp = np.where(y[None] > 0, V[:, :1], V[:, 1:])
    batched = shear.shear_displacement(x, y, xe, Vp, (twists[:, :1], twists[:, 1:2], twists[:, 2:]))
    for k in range(5):
        assert np.array_equal(batched[k], shear.shear_displacement(x, y, xe, Vp[k], tuple(twists[k])))


def _shear(robot, K):
    return robot.replace(ground={"model": "shear", "shear_modulus": K})


@pytest.mark.parametrize("robot", [Robot(), WHEELED], ids=["roller chain", "wheels"])
def test_vanishing_shear_modulus_is_the_coulomb_robot(robot):
    half = robot.track_gauge / 2
    for vl, vr in ((0.2, 0.6), (-0.5, 0.5)):
        d = np.abs(_icr(_shear(robot, 1e-4), vl, vr) - _icr(robot, vl, vr))
        assert d.max() <= 0.005 * half, (vl, vr, d / half)  # the criterion of benchmarks/ground_selection.py


def test_roller_chain_agrees_with_the_shear_reference():
    robot = _shear(Robot(), 0.1)
    for vl, vr in ((0.2, 0.6), (0.5, 0.7)):
        ref = np.array(shear.steady_state(robot, vl, vr, n_points=SimConfig().n_rollers).icr)
        assert np.abs(_icr(robot, vl, vr) - ref).max() <= 0.02 * robot.track_gauge / 2


def test_wheels_agree_with_the_point_contact_reference_and_with_the_patch_in_y():
    # a MuJoCo wheel touches at one point: its ICRs are the reference's with the wheel's patch sliding as
    # the point under its axle; against the patch's own directions the y ICRs still agree, x_c not
    # (docs/theory/shear.md, "In MuJoCo": up to 0.04 T/2 on the fidelity grid)
    robot = _shear(WHEELED, 0.1)
    half = robot.track_gauge / 2
    for vl, vr in ((0.2, 0.6), (0.5, 0.7)):
        got = _icr(robot, vl, vr)
        point = np.array(shear.steady_state(robot, vl, vr, point_contact=True).icr)
        patch = np.array(shear.steady_state(robot, vl, vr).icr)
        assert np.abs(got - point).max() <= 0.02 * half
        assert np.abs(got - patch)[:2].max() <= 0.02 * half
        assert np.abs(point - patch)[2] > 0.02 * half  # the one-point contact is what moves x_c


def test_a_tracked_reference_is_its_own_point_contact():
    robot = _shear(Robot(), 0.05)
    a = shear.steady_state(robot, 0.2, 0.6).icr
    b = shear.steady_state(robot, 0.2, 0.6, point_contact=True).icr
    assert np.array_equal(a, b)


def test_the_control_plant_sets_the_shear_friction_as_a_rollout_does():
    # a closed loop on the shear ground turns as the open-loop rollout of the same commands
    from mjtrack.control.mujoco_plant import MujocoTrackedPlant
    from mjtrack.sim.rollout import simulate

    robot = _shear(WHEELED, 0.05)
    plant = MujocoTrackedPlant(robot)
    for _ in range(40):
        plant.advance(0.2, 0.6, 0.05)
    log = simulate(robot, np.tile([0.2, 0.6], (400, 1)), log_rate=20.0)
    assert plant.pose()[2] == pytest.approx(log["yaw"][-1], abs=2e-3)
    coulomb = simulate(WHEELED, np.tile([0.2, 0.6], (400, 1)), log_rate=20.0)
    assert abs(coulomb["yaw"][-1] - log["yaw"][-1]) > 0.05  # the shear changes the turn
