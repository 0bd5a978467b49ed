"""Plausibility in calibrate's causes: a value on its bound, an interval reaching a bound, an
effective geometry far from the described one or a drive force limit above what the ground can
transmit is reported as something no candidate describes, never named as a cause; what the
measured track speeds show (the MuJoCo robot's own wheel-speed error, saturated drives) in words.

The calibration results are constructed (the Husky's commanded fit of the shared log: mu on its
upper bound, the wheelbase doubled; the Warthog's drive force limit of 1.12e4 N), the scores and the
expected forces worked out by hand."""

from __future__ import annotations

import numpy as np
import pytest

from mjtrack.calibrate.causes import (cap_words, find_causes, implausibility, not_explained, saturation_words, speeds_worse,
                                     summary, traction_limit)
from mjtrack.io.robot import Robot

BOUNDS = {"mu": (0.05, 2.0, 0.1), "wheelbase": (0.1, 3.0, 0.05 * 0.51), "cg_x": (-0.06, 0.06, 0.01),
          "drive_lag": (0.0, 1.5, 0.02)}


def _causes(values, described, rms_of):
    changed = list(values)
    return find_causes(changed, values, described, np.eye(len(changed)), {}, lambda vs: np.array([rms_of(v) for v in vs]),
                       0.461, 0.331, wheels=True, bounds=BOUNDS)


def test_rules():
    assert implausibility("mu", 2.0, 0.8, BOUNDS["mu"]).startswith("mu ended on its bound")
    assert implausibility("mu", 1.85, 0.8, BOUNDS["mu"]) is None  # more than a resolution inside
    assert "2.00 times the described" in implausibility("wheelbase", 1.02, 0.51, BOUNDS["wheelbase"])
    assert implausibility("wheelbase", 0.63, 0.51, BOUNDS["wheelbase"]) is None  # 1.24 times: a geometry
    assert implausibility("drive_lag", 0.01, 0.0, BOUNDS["drive_lag"]) is None  # a lag near 0 is physics


def test_implausible_changes_are_not_named_as_causes():
    values = {"mu": 2.0, "wheelbase": 1.02, "cg_x": 0.01}
    described = {"mu": 0.8, "wheelbase": 0.51, "cg_x": 0.0}

    def rms_of(v):  # each change's part of the gain, by hand: mu 0.06, wheelbase 0.05, cg_x 0.02
        return 0.461 - sum(g for n, g in (("mu", 0.06), ("wheelbase", 0.05), ("cg_x", 0.02)) if v[n] == values[n])

    causes = _causes(values, described, rms_of)
    by = {c.parameters[0]: c for c in causes}
    assert not by["mu"].plausible and not by["wheelbase"].plausible and by["cg_x"].plausible
    assert by["mu"].sentence.startswith("the log shows something no candidate describes, which acts like")
    text = summary(causes, (0.461, 0.331), where="training", yaw=(0.43, 0.22))
    assert text.startswith("The described MuJoCo robot erred mostly because its centre of mass"), text
    assert "Besides, the log shows something no candidate describes" in text
    assert "mu ended on its bound" in text and "2.00 times the described" in text
    assert by["mu"].to_json()["plausible"] is False


def test_only_implausible_changes_say_no_candidate_explains():
    values, described = {"mu": 2.0}, {"mu": 0.8}
    causes = _causes(values, described, lambda v: 0.331 if v["mu"] == 2.0 else 0.461)
    text = summary(causes, (0.461, 0.331), where="training", yaw=None)
    assert text.startswith("No candidate the fit moved plausibly explains the error: the log shows something"), text
    assert "Do not read these values as the robot's" in text


def test_an_interval_reaching_a_bound_is_not_the_robots():
    # the Husky's cg_y: fitted inside the range, but its interval runs to the range's edge
    bounds = (-0.069375, 0.069375, 0.02 * 0.555)
    why = implausibility("cg_y", -0.05, 0.0, bounds, interval=(-0.069375, 0.016))
    assert why is not None and "95 % interval" in why and "reaches its bound -0.0694" in why
    assert implausibility("cg_y", -0.03, 0.0, bounds, interval=(-0.045, -0.015)) is None
    # an interval reaching a bound at 0 is physics (no lag, no resistance), not the edge of the search
    assert implausibility("drive_delay", 0.003, 0.0, (0.0, 0.6, 0.02), interval=(0.0, 0.006)) is None
    hi = implausibility("drive_force_limit", 9000.0, 1000.0, (45.0, 11200.0, 112.0), interval=(4000.0, 11300.0))
    assert hi is not None and "reaches its bound 1.12e+04" in hi


def test_traction_limit_is_friction_times_the_heavier_sides_weight():
    g = 9.81  # the expected forces by hand: mu x m g x the side's share of the weight
    robot = Robot(mass=228.0, mu=0.9, track_gauge=1.08, traction="wheels", wheelbase=1.1)
    assert abs(traction_limit(robot, {}) - 0.9 * 228.0 * g / 2) < 1e-6 * 1000
    # the centre of mass 0.108 m left: the left side carries 0.6 of the weight
    assert abs(traction_limit(robot, {"cg_y": 0.108}) - 0.9 * 228.0 * g * 0.6) < 1e-3
    # calibrated friction: level 0.5, left grips 4 times the right: mu_left 1.0, mu_right 0.25
    assert abs(traction_limit(robot, {"mu": 0.5, "mu_ratio": 4.0}) - 1.0 * 228.0 * g / 2) < 1e-3
    assert abs(traction_limit(robot, {"mu_left": 0.2, "mu_right": 0.6, "cg_y": -0.108})
               - 0.6 * 228.0 * g * 0.6) < 1e-3


def test_a_force_limit_the_ground_cannot_reach_is_not_named_as_saturation():
    """The Warthog's fitted drive_force_limit, 1.12e4 N, is far above the 1e3 N a side's friction
    transmits: it never binds on the motion, so it is not named as the drives saturating."""
    robot = Robot(mass=228.0, mu=0.9, track_gauge=1.08, traction="wheels", wheelbase=1.1)
    bounds = {"drive_force_limit": (0.02 * 228 * 9.81, 5 * 228 * 9.81, 0.05 * 228 * 9.81),
              "rolling_resistance": (0.0, 0.6, 0.01)}
    values = {"drive_force_limit": 1.0e4, "rolling_resistance": 0.2}
    described = {"drive_force_limit": 1000.0, "rolling_resistance": 0.0}

    def rms_of(v):  # force limit 0.15 of the gain, resistance 0.1, by hand
        return 1.493 - sum(g for n, g in (("drive_force_limit", 0.15), ("rolling_resistance", 0.1))
                           if v[n] == values[n])

    causes = find_causes(list(values), values, described, np.eye(2), {}, lambda vs: np.array([rms_of(v) for v in vs]),
                         1.493, 1.243, wheels=True, bounds=bounds, robot=robot,
                         intervals={"drive_force_limit": (9000.0, 11183.0), "rolling_resistance": (0.18, 0.22)})
    by = {c.parameters[0]: c for c in causes}
    assert not by["drive_force_limit"].plausible and by["rolling_resistance"].plausible
    why = by["drive_force_limit"].implausible[0]  # every reason that applies: its interval reaches the top too
    assert "above what the ground can transmit under a side, 1.01e+03 N" in why and "reaches its bound" in why
    text = summary(causes, (1.493, 1.243), where="held-out", yaw=None)
    assert text.startswith("The described MuJoCo robot erred mostly because its ground holds each side back"), text
    assert "Besides, the log shows something no candidate describes" in text
    # the same limit below what the ground transmits is a cause
    low = find_causes(["drive_force_limit"], {"drive_force_limit": 800.0}, described, np.eye(1), {},
                      lambda vs: np.array([1.3 if v["drive_force_limit"] == 800.0 else 1.493 for v in vs]), 1.493, 1.3,
                      wheels=True, bounds=bounds, robot=robot, intervals={"drive_force_limit": (700.0, 900.0)})
    assert low[0].plausible
    rows = not_explained(causes)
    assert [r["parameters"] for r in rows] == [["drive_force_limit"]] and rows[0]["why"] == by["drive_force_limit"].implausible


def test_simulated_speeds_further_from_the_measured_after_calibration_are_said():
    speeds = {"train": {"before": {"left": 0.30, "right": 0.32}, "after": {"left": 0.20, "right": 0.21}},
              "test": {"before": {"left": 0.31, "right": 0.30}, "after": {"left": 0.40, "right": 0.35}}}
    text = speeds_worse(speeds)  # judged on the held-out part when there is one
    assert "further from the measured ones" in text and "0.31 / 0.3 m/s before, 0.4 / 0.35 m/s after" in text
    assert speeds_worse({"train": speeds["train"]}) == ""
    assert speeds_worse(None) == ""
    rows = not_explained([], speeds)
    assert len(rows) == 1 and rows[0]["acts_like"] == text


def test_saturated_drives_are_named_with_the_measurement_that_shows_them():
    # the Husky's log: measured wheel speeds never above 1.14 m/s, commands to 2.3 m/s
    text = saturation_words((2.3, 2.25), (1.14, 1.12), (1.01, 1.03))
    assert text.startswith("its drives saturate: the measured track speeds never exceed 1.14 / 1.12 m/s")
    assert "commands reach 2.3 / 2.25 m/s" in text and "fitted speed limits 1.01 / 1.03 m/s" in text
    assert "fitted" not in saturation_words((2.3, 2.25), (1.14, 1.12))
    assert saturation_words((1.0, 1.1), (0.95, 1.0)) == ""  # commands the drives reach
    # tracks at 0.8 of every command are not saturated drives, though the commands reach 1.25 times
    assert saturation_words((2.5, 2.5), (2.0, 2.0), scale=(0.8, 0.8)) == ""
    assert "lower commands give 0.8 / 0.8 times" in saturation_words((2.5, 2.5), (1.0, 1.0), scale=(0.8, 0.8))


def test_a_capped_turn_or_mean_speed_is_named_with_the_measurement_that_shows_it():
    # the Warthog's log: the half difference commanded to 4.63 m/s, measured never above 2.55 m/s
    text = cap_words("the turn", 4.63, 2.55)
    assert text.startswith("its speed controller caps the turn: the measured half difference of the track speeds "
                           "never exceeds 2.55 m/s while the commands' reaches 4.63 m/s")
    assert "fitted limit 1.94 m/s" in cap_words("the turn", 4.63, 2.55, limit=1.94)
    assert cap_words("the mean speed", 1.2, 1.1) == ""  # within 1.2 times: reached
    # a mean speed run at 1.7 times the lower commands: the peak command asks for 1.7 x 0.9
    text = cap_words("the mean speed", 0.9, 1.06, scale=1.7)
    assert "the measured mean of the track speeds never exceeds 1.06 m/s" in text and "asks for 1.53 m/s" in text
    assert cap_words("the mean speed", 2.5, 2.0, scale=0.8) == ""  # 0.8 x 2.5 = 2.0: every command reached


def test_the_speed_ratio_of_the_lower_commands_ignores_the_saturated_ones():
    from mjtrack.calibrate.result import speed_ratio

    command = np.linspace(0.0, 2.5, 251)
    measured = np.minimum(0.8 * command, 1.0)  # 0.8 of the command up to a cap at 1 m/s
    assert abs(speed_ratio(command, measured, 2.5) - 0.8) < 1e-12  # rows 0.5 to 1.25 m/s: below the cap
    assert speed_ratio(np.zeros(5), np.zeros(5), 0.0) == 1.0  # never commanded: nothing to say
    assert speed_ratio(np.full(5, 2.5), np.full(5, 1.0), 2.5) == 1.0  # every command at the peak: no lower rows


def test_a_cause_that_alone_makes_things_worse_is_said_so():
    """A first cause whose change alone raises the error (it helps only with the others) is not
    said to remove a negative share of it."""
    from mjtrack.calibrate.causes import Cause, summary

    c = Cause(["mu"], {"mu": (0.5, 0.76)}, [], 0.16, -0.04, "its ground's friction is 0.76, not 0.5")
    text = summary([c], (1.25, 0.65), where="held-out", yaw=None)
    assert "alone it raises the error by 4 %: it helps only with the other changes" in text
    assert "removes -" not in text
    c.gain_alone = 0.3
    assert "alone it removes 30 % of the error" in summary([c], (1.25, 0.65), where="held-out", yaw=None)


def test_each_distinct_parameter_set_of_the_causes_is_simulated_once():
    """With two groups, one group's "without" is the other's "alone": scored once, same numbers."""
    from mjtrack.calibrate.causes import find_causes

    values = {"cg_x": 0.05, "mu": 0.7}
    described = {"cg_x": 0.0, "mu": 0.5}
    asked = []

    def score(variants):  # by hand: each change removes a fixed part of the error
        asked.extend(variants)
        return np.array([0.3 - 0.1 * (v["cg_x"] == 0.05) - 0.05 * (v["mu"] == 0.7) for v in variants])

    causes = find_causes(["cg_x", "mu"], values, described, np.eye(2), {}, score, 0.3, 0.15)
    assert len(asked) == 2 and {tuple(sorted(v.items())) for v in asked} == {(("cg_x", 0.05), ("mu", 0.5)),
                                                                             (("cg_x", 0.0), ("mu", 0.7))}
    by = {c.parameters[0]: c for c in causes}
    assert by["cg_x"].share == pytest.approx(0.1 / 0.15) and by["mu"].share == pytest.approx(0.05 / 0.15)
    assert by["cg_x"].gain_alone == pytest.approx(0.1 / 0.3) and by["mu"].gain_alone == pytest.approx(0.05 / 0.3)


def _yaw_row(part, lo, hi, measured, after, windows):
    return {"what": f"yaw ratio (|turn ratio| {lo:g} to {hi:g})", "part": part, "measured": measured,
            "simulated_before": 0.5, "simulated_after": after, "windows": windows, "turn_class": [lo, hi]}


def test_a_yaw_ratio_off_in_a_turn_class_is_said():
    """Only classes with enough steady turns count, the test part when there is one, and only a gap
    beyond YAW_CLASS_GAP; a class the calibrated robot never turned steadily in (null) says nothing."""
    from mjtrack.calibrate.causes import YAW_CLASS_GAP, YAW_CLASS_MIN, yaw_class_gaps

    rows = [_yaw_row("train", 0.15, 0.5, 0.62, 0.90, 50),  # train: ignored when a test part exists
            _yaw_row("test", 0.15, 0.5, 0.62, 0.62 + 2 * YAW_CLASS_GAP, YAW_CLASS_MIN),
            _yaw_row("test", 0.5, 1.0, 0.574, 0.574 - YAW_CLASS_GAP / 2, 34),  # within the gap
            _yaw_row("test", 0.0, 0.15, 0.44, 0.90, YAW_CLASS_MIN - 1),  # too few turns
            _yaw_row("test", 0.0, 0.15, 0.44, None, 40)]  # no steady turn simulated
    text = yaw_class_gaps(rows)
    assert "|turn ratio| 0.15 to 0.5: measured 0.620, calibrated 0.680 over 10 steady turns" in text
    assert "0.5 to 1" not in text and "0 to 0.15" not in text
    assert text.startswith("the calibrated robot turns unlike the log in a turn class")
    assert yaw_class_gaps(rows[:1]).count("train windows") == 1  # no test part: the training part's
    assert yaw_class_gaps(rows[2:]) == ""


def test_a_traction_bound_resting_on_defaults_says_which():
    """A description that gives no mass (the shipped Warthog's) gets the default weight: the
    force-limit reason names that default, and the friction's when it was neither given nor fitted."""
    from mjtrack.calibrate.causes import traction_defaults
    bare = Robot.from_dict({"traction": "wheels", "track_gauge": 1.08, "wheelbase": 1.1})
    full = Robot.from_dict({"traction": "wheels", "track_gauge": 1.08, "wheelbase": 1.1, "mass": 228.0, "mu": 0.9})
    assert traction_defaults(bare, {}) == (f", with the default mass {bare.mass:g} kg and friction {bare.mu:g} that the "
                                           "description does not give")
    assert traction_defaults(bare, {"mu": 0.5}) == f", with the default mass {bare.mass:g} kg that the description does not give"
    assert "friction" in traction_defaults(bare, {"mu": bare.mu, "mu_ratio": 1.0})  # a candidate left at the default
    assert traction_defaults(full, {}) == "" and traction_defaults(Robot(), {}) == ""  # built in code: nothing assumed
    why = implausibility("drive_force_limit", 700.0, 200.0, None, traction=78.5,
                         traction_note=traction_defaults(bare, {}))
    assert f"(friction times the side's share of the weight, with the default mass {bare.mass:g} kg" in why
