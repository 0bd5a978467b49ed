"""The fit's start from what the log suggests (mjtrack.calibrate.start): the contact length at which
the Coulomb reference turns as the log's steady turns do, whatever the description says."""

from __future__ import annotations

import numpy as np
import pytest

from mjtrack.calibrate.measures import measured_speeds
from mjtrack.calibrate.params import specs_for
from mjtrack.calibrate.start import suggested_start
from mjtrack.io.robot import Robot
from mjtrack.sim import drive_log
from mjtrack.windows import make_windows
from mjtrack.windows.define import measured_window_poses

TRUE_LENGTH = 0.34  # [m] the log's robot; the descriptions below say otherwise


def _turns(duration: float, seed: int):
    """Steady turns of both signs and sharpness, each held 4 s (two windows: the first settles, the
    second is steady), on the 0.05 s grid."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, 4.0)
    v = rng.uniform(0.2, 0.8, len(t))
    turn = rng.choice([-1.0, -0.6, -0.3, 0.3, 0.6, 1.0], len(t))
    return t, v * (1 - turn), v * (1 + turn)


@pytest.fixture(scope="module")
def log():
    truth = Robot(track_gauge=0.4, track_length=TRUE_LENGTH, mass=20.0, mu=0.8)
    return drive_log(truth, _turns(48.0, 3), duration=48.0, log_rate=20.0)


@pytest.mark.parametrize("described", [0.5, 0.9])
def test_the_log_suggests_its_own_contact_length_whatever_the_description_says(log, described):
    robot = Robot(track_gauge=0.4, track_length=described, mass=35.0, mu=0.6)
    ws = make_windows(log, 2.0)
    s = suggested_start(log, ws, robot, ["mu", "track_length"], specs_for(robot), measured_window_poses(log, ws),
                        measured_speeds(log, ws))["track_length"]
    # the MuJoCo robot agrees with the Coulomb reference's ICRs to a few % of T/2 (benchmarks/fidelity.py);
    # through the yaw ratio's slope in L that is a few cm of length: 0.04 m is that, not a fitted tolerance
    assert s.value == pytest.approx(TRUE_LENGTH, abs=0.04), s.why
    assert s.turns >= 8 and "steady turns" in s.why


def test_a_log_without_steady_turns_keeps_the_described_start():
    robot = Robot(track_gauge=0.4, track_length=0.5)
    t = np.arange(0.0, 12.0, 2.0)
    straight = drive_log(robot, (t, np.full(len(t), 0.5), np.full(len(t), 0.5)), duration=12.0, log_rate=20.0)
    ws = make_windows(straight, 2.0)
    s = suggested_start(straight, ws, robot, ["track_length"], specs_for(robot),
                        measured_window_poses(straight, ws), measured_speeds(straight, ws))["track_length"]
    assert s.value is None and "described value is the start" in s.why


def test_nothing_is_suggested_for_a_fit_that_does_not_move_the_length(log):
    robot = Robot(track_gauge=0.4, track_length=0.5)
    ws = make_windows(log, 2.0)
    assert suggested_start(log, ws, robot, ["mu"], specs_for(robot), measured_window_poses(log, ws),
                           measured_speeds(log, ws)) == {}


def test_calibrate_starts_a_length_the_description_leaves_out_where_the_log_puts_it(log):
    from mjtrack.calibrate.run import _prepare

    shipped = Robot.from_dict({"track_gauge": 0.4}, source="shipped")  # the length is a default (0.5 m)
    pb = _prepare(log, shipped, None, ["mu", "track_length"], horizon_s=2.0, n_rollers=None,
                  keep_contradicting=False, src="log", test_src=None)
    assert pb.start["track_length"] == pytest.approx(TRUE_LENGTH, abs=0.04)
    assert pb.described["track_length"] == 0.5  # what the description means stays what it was
    assert "start value from the log" in pb.assumed["track_length"]
    given = Robot.from_dict({"track_gauge": 0.4, "track_length": 0.5}, source="given")
    pb = _prepare(log, given, None, ["mu", "track_length"], horizon_s=2.0, n_rollers=None,
                  keep_contradicting=False, src="log", test_src=None)
    assert pb.start["track_length"] == 0.5  # a length the user gave is where the fit starts
