"""The effect vocabulary speaks the robot file's names; the names it replaced are still read, with a
deprecation warning (effects to test, an older diagnosis.json); the slope's angle and direction stay
readable beside its components."""

from __future__ import annotations

import math

import pytest

from mjtrack.diagnose import EFFECTS, diagnose
from mjtrack.diagnose.vocabulary import canonical_effects, slope_angle, upgrade_diagnosis
from mjtrack.errors import InputError
from mjtrack.testing.diagnose_logs import make_log


def test_old_effect_names_are_read_with_a_deprecation_warning():
    with pytest.warns(DeprecationWarning, match="cg_offset_x is now cg_x"):
        assert canonical_effects(["cg_offset_x", "slope", "command_delay"], EFFECTS) == ["cg_x", "slope", "drive_delay"]
    with pytest.raises(InputError, match="unknown effect"):
        canonical_effects(["teleport"], EFFECTS)


def test_diagnose_takes_an_old_name_and_answers_in_the_new_one():
    log, robot = make_log("cg_offset_x", seed=2, duration=60.0)  # the generator's own name for it
    with pytest.warns(DeprecationWarning, match="cg_offset_x is now cg_x"):
        d = diagnose(log, robot, baseline="surrogate", effects=["cg_offset_x", "actuator_lag"], max_effects=1)
    assert d.cause == "cg_x"
    js = d.to_json()
    assert js["findings"][0]["estimate"].keys() == {"cg_x"}
    assert {c["effect"] for c in js["candidates"]} == {"cg_x", "drive_lag"}


def test_slope_angle_of_its_components():
    s, d = 0.12, -2.5
    a = slope_angle(math.sin(s) * math.cos(d), math.sin(s) * math.sin(d))
    assert a["slope"] == pytest.approx(s) and a["slope_direction"] == pytest.approx(d)
    assert slope_angle(0.0, 0.0) == {"slope": 0.0, "slope_direction": 0.0}


def test_an_older_diagnosis_json_is_read_in_todays_names():
    old = {"cause": "friction_asymmetry",
           "findings": [{"effect": "friction_asymmetry", "estimate": {"friction_asymmetry": 0.6},
                         "interval": {"friction_asymmetry": [0.5, 0.7]}, "tied_with": ["cg_offset_y"]},
                        {"effect": "slope", "estimate": {"slope": 0.1, "slope_direction": 0.5},
                         "interval": {"slope": [0.05, 0.15], "slope_direction": [0.2, 0.8]}}],
           "candidates": [{"effect": "road_wheels", "estimate": {"road_wheel_span": 0.5}}],
           "steps": [{"on_top_of": [], "added": "friction_asymmetry", "candidates": []}],
           "not_tested": {"speed_limit": "why"}}
    with pytest.warns(DeprecationWarning, match="older effect names"):
        new = upgrade_diagnosis(old)
    assert new["cause"] == "mu_ratio" and new["findings"][0]["estimate"] == {"mu_ratio": 0.6}
    assert new["findings"][0]["interval"] == {"mu_ratio": [0.5, 0.7]} and new["findings"][0]["tied_with"] == ["cg_y"]
    slope = new["findings"][1]
    assert slope["estimate"] == pytest.approx({"slope_x": math.sin(0.1) * math.cos(0.5),
                                               "slope_y": math.sin(0.1) * math.sin(0.5)})
    assert slope["derived"] == {"slope": 0.1, "slope_direction": 0.5}
    assert new["candidates"][0]["estimate"] == {"span": 0.5}
    assert new["steps"][0]["added"] == "mu_ratio" and new["not_tested"] == {"drive_speed_limit": "why"}
    assert old["cause"] == "friction_asymmetry"  # a copy
    current = {"cause": "mu_ratio", "findings": [{"effect": "mu_ratio", "estimate": {"mu_ratio": 0.6}}]}
    assert upgrade_diagnosis(current) is current


def test_the_yaw_rate_limit_is_read_as_the_robot_files_turn_limit_in_its_units():
    # yaw_rate_limit limited (V_R - V_L) / T [rad/s]; drive_turn_limit limits (V_R - V_L) / 2 [m/s]
    with pytest.warns(DeprecationWarning, match="yaw_rate_limit is now drive_turn_limit"):
        assert canonical_effects(["yaw_rate_limit"], EFFECTS) == ["drive_turn_limit"]
    old = {"cause": "yaw_rate_limit",
           "findings": [{"effect": "yaw_rate_limit", "estimate": {"yaw_rate_limit": 1.5},
                         "interval": {"yaw_rate_limit": [1.2, None]}}]}
    with pytest.raises(InputError, match="track_gauge"):
        upgrade_diagnosis(old)
    robot = make_log("cg_offset_x", seed=2, duration=10.0)[1]
    with pytest.warns(DeprecationWarning, match="older effect names"):
        new = upgrade_diagnosis(old, robot=robot)
    half = robot.track_gauge / 2
    assert new["cause"] == "drive_turn_limit"
    assert new["findings"][0]["estimate"] == pytest.approx({"drive_turn_limit": 1.5 * half})
    assert new["findings"][0]["interval"]["drive_turn_limit"] == [pytest.approx(1.2 * half), None]
