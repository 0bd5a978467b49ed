"""The one same-robot check of a test log's description (mjtrack.io.robot.check_same_robot)."""

from __future__ import annotations

import pytest

from mjtrack.errors import InputError
from mjtrack.io.robot import Robot, check_same_robot

TRAIN = Robot.from_dict({"track_gauge": 0.5, "track_length": 0.6, "mass": 40.0, "mu": 0.7})


def test_the_same_description_and_round_off_pass():
    check_same_robot(TRAIN, Robot.from_dict(TRAIN.to_dict()), "test.json")  # every key given, all equal
    # a gauge converted from millimetres, and one printed with 7 digits
    check_same_robot(TRAIN, Robot.from_dict({"track_gauge": 500.0 / 1000.0 * (1 + 1e-15)}), "test.json")
    check_same_robot(TRAIN, Robot.from_dict({"track_gauge": 0.5000001}), "test.json")


def test_a_key_the_test_description_omits_is_not_compared():
    # the test description relies on the default track_length (0.5) and mass: it says nothing of them
    check_same_robot(TRAIN, Robot.from_dict({"track_gauge": 0.5, "mu": 0.7}), "test.json")


@pytest.mark.parametrize("key, value", [("track_gauge", 0.501), ("sprocket_radius", 0.07), ("mass", 45.0),
                                        ("cg_x", 0.01), ("mu", 0.5), ("traction", "wheels")])
def test_another_value_is_refused_with_both_values(key, value):
    other = {"track_gauge": 0.5, key: value}
    if value == "wheels":
        other["wheelbase"] = 0.4
    with pytest.raises(InputError, match=rf"test\.json: recorded with another robot \({key} "):
        check_same_robot(TRAIN, Robot.from_dict(other), "test.json")


def test_default_of_the_training_robot_counts_and_a_side_friction_is_read_as_mu():
    # the training robot uses the default sprocket radius 0.06: a test description giving 0.08 differs
    with pytest.raises(InputError, match=r"sprocket_radius 0.08 in its description, 0.06 for the training log"):
        check_same_robot(TRAIN, Robot.from_dict({"track_gauge": 0.5, "sprocket_radius": 0.08}), "t")
    # mu_left null on one side and equal to mu on the other: the same friction
    check_same_robot(TRAIN, Robot.from_dict({"track_gauge": 0.5, "mu": 0.7, "mu_left": 0.7, "mu_right": None}), "t")
    with pytest.raises(InputError, match="mu_right 0.6 in its description, 0.7 for"):
        check_same_robot(TRAIN, Robot.from_dict({"track_gauge": 0.5, "mu": 0.7, "mu_right": 0.6}), "t")
