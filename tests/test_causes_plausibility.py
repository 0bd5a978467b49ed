"""Plausibility in calibrate's causes: a value on its bound or an effective geometry far from the
described one is reported as something no candidate describes, never named as a cause.

The calibration result is constructed (the Husky's commanded fit of the shared log: mu on its upper
bound, the wheelbase doubled), the scores given by hand."""

from __future__ import annotations

import numpy as np

from mjtrack.calibrate.causes import find_causes, implausibility, summary

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
