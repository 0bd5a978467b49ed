"""Ground models of the MuJoCo robot (mjtrack.sim.ground) against an independent steady balance.

The oracle (mjtrack/testing/ground_balance.py) is a quadrature of the force and yaw-moment balance of a
rigid two-track vehicle with the ground's load distribution and friction law written out on its
own; MuJoCo's steady turns (mjtrack.sim.steady) must give the same yaw ratio.
"""

from __future__ import annotations

import json
import math

import mujoco
import numpy as np
import pytest

from mjtrack.errors import InputError
from mjtrack.io.robot import Ground, Robot, read_robot
from mjtrack.sim.builder import build_model
from mjtrack.sim.config import SimConfig
from mjtrack.sim.ground import load_shares
from mjtrack.sim.steady import steady_state
from mjtrack.testing.ground_balance import yaw_ratio

ROBOT = Robot()  # T 0.4, L 0.5, mu 0.8


def test_ground_key_round_trip_and_defaults(tmp_path):
    r = Robot(ground={"model": "anisotropic", "lateral_ratio": 0.4})
    assert r.ground == Ground("anisotropic", (("lateral_ratio", 0.4),))
    path = tmp_path / "r.json"
    path.write_text(json.dumps(r.to_dict()))
    back = read_robot(path)
    assert back == r and back.ground["lateral_ratio"] == 0.4
    assert Robot().to_dict()["ground"] == {"model": "coulomb"}
    rw = Robot(ground={"model": "road_wheels"})  # defaults filled in
    assert rw.ground.to_dict() == {"model": "road_wheels", "concentration": 0.8, "span": 1.0, "wheels": 4.0}
    assert Robot(ground="anisotropic").ground["lateral_ratio"] == 0.5


@pytest.mark.parametrize("ground, match", [
    ({"model": "ice"}, "must be one of"),
    ({"model": "anisotropic", "lateral_ratio": 1.5}, r"in \[0.05, 1.0\]"),
    ({"model": "anisotropic", "mu_lateral": 0.3}, "has no parameter 'mu_lateral'"),
    ({"model": "road_wheels", "wheels": 2.5}, "whole number"),
    ([1, 2], "must be an object"),
])
def test_ground_key_bad_input_names_file(tmp_path, ground, match):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps({"track_gauge": 0.4, "ground": ground}))
    with pytest.raises(InputError, match=match) as err:
        read_robot(path)
    assert str(path) in str(err.value)


def test_ground_needs_the_roller_chain():
    with pytest.raises(InputError, match="roller chain only"):
        build_model(Robot(ground="anisotropic"), SimConfig(track_model="surfacevel"))


def test_load_shares_keep_the_load_and_its_moment():
    x = -0.25 + (np.arange(10) + 0.5) * 0.05
    w = load_shares(Robot(ground={"model": "road_wheels", "wheels": 3, "concentration": 0.9, "span": 0.6}), x)
    assert w.sum() == pytest.approx(10.0) and w.min() == pytest.approx(0.1)
    # hat interpolation keeps each wheel's moment: sum w x = N (1-c) mean(x) + N c mean(X_j) = 0 here
    assert (w * x).sum() == pytest.approx(0.0, abs=1e-12)
    assert np.array_equal(load_shares(ROBOT, x), np.ones(10))


def test_capsule_contact_frame_turns_with_the_body():
    """Why the anisotropic ground uses capsules: the first tangent of a capsule-plane contact is
    the capsule's axis at every yaw (a sphere's stays on the world axes)."""
    for yaw in (0.0, 0.7, 2.0):
        model = build_model(Robot(ground="anisotropic"))
        data = mujoco.MjData(model)
        data.qpos[3:7] = [math.cos(yaw / 2), 0, 0, math.sin(yaw / 2)]
        data.qpos[2] = -1e-4  # touch the ground
        mujoco.mj_forward(model, data)
        assert data.ncon > 0
        body_y = np.array([-math.sin(yaw), math.cos(yaw), 0.0])
        for c in data.contact[: data.ncon]:
            assert abs(c.frame[3:6] @ body_y) == pytest.approx(1.0, abs=1e-6)


CASES = [  # (ground, (v_left, v_right)): pivots and turns; each needs ~0.2 s of MuJoCo
    ({"model": "coulomb"}, (-0.3, 0.3)),
    ({"model": "anisotropic", "lateral_ratio": 0.5}, (-0.3, 0.3)),
    ({"model": "anisotropic", "lateral_ratio": 0.5}, (0.5, 0.1)),
    ({"model": "anisotropic", "lateral_ratio": 0.3}, (0.2, 0.6)),
    ({"model": "road_wheels", "wheels": 4, "concentration": 0.9, "span": 0.5}, (-0.3, 0.3)),
    ({"model": "road_wheels", "wheels": 2, "concentration": 0.8, "span": 0.7}, (0.6, 0.2)),
]


@pytest.mark.parametrize("ground, speeds", CASES)
def test_mujoco_yaw_ratio_matches_independent_balance(ground, speeds):
    robot = Robot(ground=ground)
    s = steady_state(robot, *speeds)
    measured = s.wz / ((s.v_right - s.v_left) / robot.track_gauge)
    g = robot.ground
    if g.model == "anisotropic":
        kw = {"rho": g["lateral_ratio"]}
    elif g.model == "road_wheels":
        kw = {"wheels": int(g["wheels"]), "concentration": g["concentration"], "span": g["span"]}
    else:
        kw = {}
    expected = yaw_ratio(s.v_left, s.v_right, robot.track_gauge, robot.track_length, **kw)
    # 0.01: MuJoCo's roller chain on the coulomb ground is within 0.03 T/2 of the Coulomb ICRs
    # (assets/README.md, fidelity grid), i.e. about 1 % in yaw ratio; the rollers (10 per track)
    # also sample the wheel loads by linear interpolation.
    assert measured == pytest.approx(expected, abs=0.01)
    assert s.roller_contact >= 0.999 * (2 if g.model == "anisotropic" else 1)


def test_lower_lateral_friction_turns_more():
    """Anisotropy is what moves the yaw ratio: rho 0.5 turns ~25 % faster than rho 1 in MuJoCo."""
    iso = steady_state(Robot(ground={"model": "anisotropic", "lateral_ratio": 1.0}), -0.3, 0.3)
    aniso = steady_state(Robot(ground={"model": "anisotropic", "lateral_ratio": 0.5}), -0.3, 0.3)
    coul = steady_state(ROBOT, -0.3, 0.3)
    assert iso.wz == pytest.approx(coul.wz, rel=0.005)  # the capsule alone changes nothing
    assert aniso.wz > 1.2 * iso.wz


@pytest.mark.parametrize("ground, speeds", CASES)
def test_coulomb_reference_honours_the_ground(ground, speeds):
    """The Coulomb reference (mjtrack.models.coulomb: plate loads weighted by the road-wheel
    shares, the friction ellipse of the anisotropic ground) against the same independent
    quadrature: both are quasi-static balances with the cg on the centre, so they differ only by
    discretisation (200 points per track, a wheel's point load split between its two neighbours;
    the quadrature keeps it a point): 1e-4 in yaw ratio (measured: 2e-5 at most)."""
    from mjtrack.testing.ground_balance import steady_twist

    from mjtrack.models import coulomb

    robot = Robot(ground=ground)
    s = coulomb.steady_state(robot, *speeds, inertial=False)
    g = robot.ground
    kw = ({"rho": g["lateral_ratio"]} if g.model == "anisotropic" else
          {"wheels": int(g["wheels"]), "concentration": g["concentration"], "span": g["span"]}
          if g.model == "road_wheels" else {})
    vx, vy, wz = steady_twist(*speeds, robot.track_gauge, robot.track_length, **kw)
    T = robot.track_gauge
    assert s.wz * T / (speeds[1] - speeds[0]) == pytest.approx(wz * T / (speeds[1] - speeds[0]), abs=1e-4)
    assert s.vx == pytest.approx(vx, abs=1e-4 * max(map(abs, speeds)))
    # and the ground matters: the plain Coulomb track turns otherwise (0.01 in yaw ratio at least)
    if not g.is_default:
        plain = coulomb.steady_state(Robot(), *speeds, inertial=False)
        assert abs(plain.wz - s.wz) > 0.01 * abs(speeds[1] - speeds[0]) / T
