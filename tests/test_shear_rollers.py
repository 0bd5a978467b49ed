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


def _wheeled_logs(truth, seconds=(30.0, 20.0)):
    from mjtrack.api import simulate_log

    return [simulate_log(truth, scenario="random_steps", duration=d, seed=s, log_rate=20.0)
            for d, s in zip(seconds, (1, 2))]


def test_calibrate_finds_a_shear_ground_from_a_coulomb_description():
    # the shear modulus as a candidate of a robot described on the Coulomb ground (K = 0): the fit
    # starts it off 0 (the error is flat in K there), the interval covers the hidden K, the calibrated
    # robot's ground is shear, and the cause says so
    from mjtrack.calibrate.run import calibrate

    train, test = _wheeled_logs(_shear(WHEELED, 0.05))
    cal = calibrate(train, WHEELED, test=test, names=["mu", "shear_modulus"])
    lo, hi = cal.verdicts["shear_modulus"].interval
    assert lo <= 0.05 <= hi and hi - lo < 0.01
    assert cal.changed == ["shear_modulus"]
    assert cal.calibrated.ground.model == "shear"
    assert cal.calibrated.ground["shear_modulus"] == pytest.approx(0.05, abs=1e-3)
    assert "shear ground" in cal.sentence
    assert cal.test_after.rms < 0.01 * cal.test_before.rms


def test_calibrate_leaves_a_coulomb_ground_coulomb():
    from mjtrack.calibrate.run import calibrate

    train, test = _wheeled_logs(WHEELED)
    cal = calibrate(train, WHEELED, test=test, names=["mu", "shear_modulus"])
    assert "shear_modulus" not in cal.changed and cal.calibrated.ground.model == "coulomb"


def test_shear_modulus_is_refused_on_other_grounds_and_below_zero():
    from mjtrack.calibrate.params import parse_names
    from mjtrack.errors import InputError
    from mjtrack.sim.windows import WindowSim, simulate_windows
    from mjtrack.windows import make_windows

    with pytest.raises(InputError, match="belongs to the 'shear' ground"):
        parse_names("mu,shear_modulus", Robot(ground={"model": "anisotropic", "lateral_ratio": 0.5}))
    assert parse_names("mu,shear_modulus", Robot()) == ["mu", "shear_modulus"]
    lg = _wheeled_logs(WHEELED, (6.0,))[0]
    with pytest.raises(InputError, match="shear_modulus must be a number >= 0"):
        simulate_windows(WindowSim(WHEELED), lg, make_windows(lg, 2.0), [{"shear_modulus": -0.1}])


def test_diagnose_names_a_hidden_shear_ground():
    # the MuJoCo diagnosis of a wheeled robot described on the Coulomb ground, its log from the
    # shear ground: the shear modulus is named (asked for: on a Coulomb robot it is not a default
    # effect) ahead of a friction change, its interval covers the truth, and the extended robot
    # stands on the shear ground
    from mjtrack.diagnose import diagnose
    from mjtrack.diagnose.result import extended_robot

    train, test = _wheeled_logs(_shear(WHEELED, 0.05), (40.0, 20.0))
    d = diagnose(train, WHEELED, baseline="mujoco", effects=["shear_modulus", "friction_scale"], test_log=test)
    assert d.cause == "shear_modulus", d.summary()
    (lo, hi), = d.findings[0].interval
    assert lo <= 0.05 <= hi
    robot, rest = extended_robot(WHEELED, "shear_modulus", {"shear_modulus": float(d.findings[0].estimate[0])})
    assert robot.ground.model == "shear" and not rest


def test_a_wheeled_robot_fits_the_shear_modulus_by_default_a_tracked_one_when_named():
    from mjtrack.calibrate.params import default_names

    assert "shear_modulus" in default_names(WHEELED)
    assert "shear_modulus" not in default_names(Robot())
    assert default_names(_shear(Robot(), 0.05)).count("shear_modulus") == 1  # its ground's own parameter
    assert default_names(_shear(WHEELED, 0.05)).count("shear_modulus") == 1


def test_the_steady_turn_does_not_hang_on_how_often_the_friction_is_set(monkeypatch):
    # the chunk's first state stands for its SHEAR_UPDATE_S: in a steady turn the ICRs are those of
    # a friction set every step (docs/theory/shear.md, "In MuJoCo")
    import mjtrack.sim.ground as ground

    robot = _shear(WHEELED, 0.1)
    icr = {}
    for every in (0.005, ground.SHEAR_UPDATE_S, 0.05):
        monkeypatch.setattr(ground, "SHEAR_UPDATE_S", every)
        icr[every] = _icr(robot, 0.5, 0.7)
    for got in icr.values():
        assert np.abs(got - icr[0.005]).max() <= 1e-3 * robot.track_gauge / 2
