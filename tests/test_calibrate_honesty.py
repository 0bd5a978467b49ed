"""Calibration on logs the MuJoCo robot itself made: the truth is known exactly.

Generator: :mod:`mjtrack.testing.battery` (``mjtrack.sim.drive_log`` of the truth: one rollout from
rest, the robot built with the changed description); the calibration sees the log and the
description without the change. Fast cases use 20 s logs and a few candidate parameters; the
slow battery runs every change of the default geometry with every default candidate.
"""

from __future__ import annotations

import pytest

from mjtrack.calibrate.run import calibrate
from mjtrack.testing.battery import case, described_robot, make_log
from support.repo import load_benchmark

NAMES = ["mu", "cg_x", "drive_lag", "drive_delay"]


def _calibrate(change: str, duration: float = 20.0, names=NAMES):
    c = case("default", change)
    train, test = make_log(c, duration=duration, seed=11), make_log(c, duration=duration, seed=12)
    return c, calibrate(train, described_robot(c), test=test, names=list(names) if names else None)


def test_a_centre_of_mass_offset_is_named_and_its_interval_covers_it():
    c, cal = _calibrate("cg_x")
    assert cal.changed == ["cg_x"], {n: v.reason for n, v in cal.verdicts.items()}
    lo, hi = cal.verdicts["cg_x"].interval
    assert lo <= c.truth["cg_x"] <= hi and cal.verdicts["cg_x"].determined
    for n in ("mu", "drive_lag", "drive_delay"):  # kept at the truth, which is the description here
        assert cal.values[n] == pytest.approx(c.truth[n])
    assert cal.causes[0].parameters[0] == "cg_x" and cal.causes[0].share > 0.9
    assert "centre of mass" in cal.sentence and "ahead" in cal.sentence
    assert cal.test_after.rms < 0.1 * cal.test_before.rms


def test_a_clean_log_changes_nothing_and_says_so():
    c, cal = _calibrate("clean")
    assert cal.changed == [] and cal.causes == []
    assert cal.test_after.rms == cal.test_before.rms  # the described robot, unchanged
    # "Nothing needs to change", or, where the short log leaves a candidate undetermined,
    # "Nothing the log determines needs to change" (and which ones it does not determine)
    assert cal.sentence.startswith(("Nothing needs to change", "Nothing the log determines needs to change"))
    js = cal.to_json()
    assert js["causes"] == [] and set(js["determined"]) == set(NAMES)
    assert all(v["reason"] for v in js["determined"].values())


@pytest.mark.slow
@pytest.mark.parametrize("change", ["clean", "cg_x", "cg_y", "drive_lag", "drive_delay", "lag_delay",
                                    "friction_asymmetry", "track_length", "track_speed_scale", "slope"])
def test_battery_default_geometry(change):
    """Every default candidate on 60 s logs: every determined parameter's interval covers its truth,
    the true cause leads (the clean log has none)."""
    bench = load_benchmark("calibration_battery")
    r = bench.run_case(case("default", change), duration=60.0, diagnose=False)
    missed = [(x["parameter"], x["truth"], x["interval"]) for x in r["rows"] if x["determined"] and x["covered"] is False]
    assert not missed, missed
    assert r["cause_ok"], (r["expected_cause"], [c["parameters"] for c in r["causes"]])
    assert r["test"][1] <= r["test"][0] * 1.0001
