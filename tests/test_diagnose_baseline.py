"""The Baseline interface (mjtrack.diagnose.baseline): every baseline -- the Coulomb surrogate,
the kinematic model, the MuJoCo robot -- speaks the one effect vocabulary, simulates many
parameter values in one call with the same result as one at a time, reduces to its nominal
prediction at an effect's no-effect value, and carries its model-form error by one definition.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from mjtrack.diagnose.baseline import Baseline, ModelForm
from mjtrack.diagnose.vocabulary import EFFECTS
from mjtrack.diagnose.mujoco_baseline import MujocoBaseline, _spec
from mjtrack.diagnose.surrogate.baseline import surrogate_problem as make_surrogate_problem
from mjtrack.io.robot import Robot
from mjtrack.testing.mujoco_effects import ROBOT, make_log

NOMINAL = Robot.from_dict({**ROBOT.to_dict(), "drive_force_limit": 600.0 / ROBOT.sprocket_radius})


@pytest.fixture(scope="module")
def mujoco_problem():
    lg, _ = make_log("cg_offset_x", seed=0, duration=8.0)
    model = MujocoBaseline(NOMINAL, lg)
    return model, model.problem(3, n_train=int(np.searchsorted(lg.t, 4.0)))


@pytest.fixture(scope="module", params=["coulomb", "kinematic"])
def surrogate_problem(request):
    lg, _ = make_log("cg_offset_x", seed=0, duration=30.0)
    model, problem, _, _ = make_surrogate_problem(lg, NOMINAL, horizon_s=1.0, n_folds=3,
                                             baseline="kinematic" if request.param == "kinematic" else "surrogate",
                                             max_fit_windows=3000, transient=False, test_log=None)
    assert model.name == request.param
    return model, problem


def test_model_form_is_one_definition():
    mf = ModelForm(0.1, {"icr_spread": 0.03})
    # relative to the size |theta - nominal|, the absolute term in quadrature
    assert mf.se("cg_x", [0.05], [0.01]) == pytest.approx([0.004])
    assert mf.se("icr_spread", [1.4], [1.0]) == pytest.approx([math.hypot(0.04, 0.03)])
    # a slope is a vector: rel x its length on each component
    assert mf.se("slope", [0.06, -0.08], [0.0, 0.0]) == pytest.approx([0.01, 0.01])
    assert mf.se("drive_speed_limit", [0.5], [np.inf]) == pytest.approx([0.0])  # a limit from infinity: no size


def test_baselines_speak_the_one_vocabulary(surrogate_problem, mujoco_problem):
    for bl, problem in (surrogate_problem, mujoco_problem):
        assert isinstance(bl, Baseline)
        assert set(bl.vocabulary) <= set(EFFECTS) and set(bl.untestable) <= set(EFFECTS)
        assert not set(bl.vocabulary) & set(bl.untestable)
        assert all(isinstance(v, str) and v for v in bl.vocabulary.values())
        # the MuJoCo robot tests the shear modulus by default only on the shear ground (it is named otherwise),
        # the ratio of its moduli only when named
        own = [n for n in EFFECTS if n in bl.vocabulary or n in bl.untestable]
        assert bl.default_effects() == [n for n in own if n != "lateral_shear_ratio"
                                        and (n != "shear_modulus" or bl.robot.ground.model == "shear")]
        assert bl.model_form.rel > 0 and bl.model_form.measured_by
        assert bl.describe()
    assert "ground_anisotropy" in mujoco_problem[0].vocabulary
    assert "ground_anisotropy" not in surrogate_problem[0].vocabulary
    if surrogate_problem[0].name == "kinematic":
        assert "friction_scale" in surrogate_problem[0].untestable


def _check_batched_and_nominal(bl, problem, names, windows):
    nominal = bl.errors(problem, windows)
    assert nominal.shape == (1, windows.size, 3)
    for name in names:
        eff = EFFECTS[name]
        no = bl.nominal(eff, problem)
        size = 0.2 * max(abs(float(no[0])), 0.2)
        values = np.array([no, no + size])
        both = bl.errors(problem, windows, eff, values)
        assert both.shape == (2, windows.size, 3)
        # at its no-effect value an effect is the nominal model
        np.testing.assert_allclose(both[0], nominal[0], atol=1e-9, err_msg=name)
        # many values in one call: the same as one at a time
        np.testing.assert_allclose(both[1], bl.errors(problem, windows, eff, values[1:])[0], atol=1e-12, err_msg=name)
        assert np.max(np.abs(both[1] - both[0])) > 1e-6, name  # and the effect does change the prediction


def test_surrogate_errors_batched_and_nominal(surrogate_problem):
    names = ["track_speed_scale", "drive_delay", "cg_x", "mu_ratio"]
    bl, problem = surrogate_problem
    _check_batched_and_nominal(bl, problem, names, np.arange(0, problem.starts.size, 7))


def test_mujoco_errors_batched_and_nominal(mujoco_problem):
    bl, problem = mujoco_problem
    _check_batched_and_nominal(bl, problem, ["cg_x", "track_speed_scale"], np.arange(problem.starts.size))


def test_mujoco_test_split_and_combined_effects(mujoco_problem):
    bl, p = mujoco_problem
    assert p.score_folds == (0,) and set(np.unique(p.fold)) == {0, 1}
    assert np.all(p.fold[p.fit_windows] == 1)  # fitted on the first log only
    assert np.all(p.starts[p.fold == 0] >= np.searchsorted(p.data.t, 4.0))
    # effects already found combine with the candidate: friction scale x asymmetry, clip, slope
    r = bl.robot
    parts = [(EFFECTS["friction_scale"], [0.5]), (EFFECTS["mu_ratio"], [2.0]),
             (EFFECTS["drive_speed_limit"], [0.4]), (EFFECTS["slope"], [math.sin(0.1), 0.0]), (EFFECTS["cg_x"], [0.02])]
    kind, variant, clip = _spec(r, parts)
    assert kind == "base" and clip == 0.4
    assert variant == pytest.approx({"mu_left": r.friction_right * 2.0 * 0.5, "mu_right": r.friction_right * 0.5,
                                     "cg_x": 0.02, "slope_x": math.sin(0.1), "slope_y": 0.0})
    with_base = dataclasses.replace(p, base=((EFFECTS["friction_scale"], np.array([0.5])),))
    w = np.arange(2)
    one = bl.errors(with_base, w, EFFECTS["cg_x"], [[0.03]])[0]
    joint = bl._run(w, [_spec(r, [(EFFECTS["friction_scale"], [0.5]), (EFFECTS["cg_x"], [0.03])])], ["joint"])[0]
    np.testing.assert_allclose(one, joint, atol=1e-12)
