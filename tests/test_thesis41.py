"""Section 4.1 of the thesis: reconstruction, the three slip cases, the sample classes, the runner."""

import json
import math

import numpy as np
import pytest

from mjtrack.errors import InputError
from mjtrack.models import MICR, MVIR, Nominal, integrate
from mjtrack.thesis import SECTIONS, Section, run_thesis
from mjtrack.thesis import ex41
from mjtrack.thesis.ex41 import UPath, lateral_slip, longitudinal_slip, no_slip, run_case

PATH = UPath()
V, T, W = PATH.speed, PATH.track_gauge, PATH.turn_rate


@pytest.fixture(scope="module")
def ex():
    return ex41.compute()


def test_reconstruction_is_a_u_turn_of_exactly_pi():
    t = PATH.times
    vl, vr = PATH.commands()
    assert t.size == 2701 and t[-1] == pytest.approx(27.0)
    straight = (PATH.midpoints < 10) | (PATH.midpoints > 17)
    assert np.all(vl[straight] == vr[straight]) and np.all(vl[straight] == V)
    hold = PATH.holding()
    assert hold.sum() == 500  # 11-16 s at 100 Hz
    assert np.allclose(vr[hold] - vl[hold], W * T, rtol=0, atol=1e-15)
    q = integrate(Nominal(T), (0, 0, 0), t, vl, vr)
    assert q[-1, 2] == pytest.approx(math.pi, abs=1e-12)  # midpoint sampling is the exact mean of the ramps
    assert q[1000, 0] == pytest.approx(5.0, abs=1e-12) and abs(q[1000, 1]) < 1e-12  # 10 s straight at 0.5 m/s
    # the return leg is parallel and ends level with the start (5 m back along -x)
    assert abs(q[-1, 0]) < 1e-9 and q[-1, 1] > 1.5


@pytest.mark.parametrize("kwargs, match", [
    ({"dt": 0.03}, "not a multiple of dt"),
    ({"ramp": 7.0}, "ramp must be in"),
    ({"duration": 15.0}, "must lie in"),
    ({"speed": 0.0}, "speed must be > 0"),
])
def test_bad_reconstruction_is_refused(kwargs, match):
    with pytest.raises(InputError, match=match):
        UPath(**kwargs)


def test_no_slip_all_models_equal_the_nominal_path(ex):
    r = ex.results["no_slip"]
    for name in ("MPP", "MICR", "MVIR", "MICR_finite", "MVIR_finite"):
        assert np.max(np.abs(r.paths[name] - r.paths["nominal"])) < 1e-12, name
    assert r.regular.sum() == 700 and r.straight.sum() == 2001 and not r.unrepresentable.any()
    # ICRs at the nominal positions during the turn (2.13 of a nominal twist)
    assert np.allclose(r.icr["y_l"], T / 2, atol=1e-12) and np.allclose(r.icr["y_r"], -T / 2, atol=1e-12)
    s = ex41.summarize(PATH, r)
    assert max(s["nominal_dev_m"].values()) < 1e-12


@pytest.mark.parametrize("case", ["no_slip", "longitudinal_slip", "lateral_slip"])
def test_models_agree_in_every_case(ex, case):
    r = ex.results[case]
    s = ex41.summarize(PATH, r)
    assert s["max_dev_m"] < 1e-9 and s["max_dev_yaw_rad"] < 1e-9
    # where finite parameters exist, the models themselves reproduce the MPP twist (2.14)∘(2.13) = id
    assert max(s["max_twist_err_representable"].values()) < 1e-12
    for name in ("MICR", "MVIR"):
        fin = r.twists[name + "_finite"]
        ok = ~r.unrepresentable
        assert np.max(np.abs(fin[ok] - r.twists["MPP"][ok])) < 1e-12
    for params in (r.icr, r.virtual):  # never NaN/inf fed to a model
        assert all(np.all(np.isfinite(v)) for v in params.values())


@pytest.mark.parametrize("case", ["longitudinal_slip", "lateral_slip"])
def test_unrepresentable_samples_are_exactly_equal_commands_with_rotation(ex, case):
    # Derived in ex41's docstring: with finite parameters V_L = V_R forces the nominal twist.
    r = ex.results[case]
    vl, vr = ex.v_left, ex.v_right
    tw = r.twists["MPP"]
    assert np.array_equal(r.unrepresentable, (vl == vr) & (tw[:, 2] != 0))
    assert r.unrepresentable.sum() == 2001  # both straights, 0-10 s and 17-27 s
    fin = r.twists["MICR_finite"][r.unrepresentable]
    assert np.all(fin[:, 2] == 0) and np.allclose(fin[:, 0], V)
    # (2.13) there puts both track ICRs at the same place and the virtual wheel distance at 0
    k = np.flatnonzero(r.unrepresentable)
    assert np.allclose(r.virtual_raw["track"][k], 0.0, atol=1e-15)
    # the models on their own leave the MPP path by metres
    assert ex41.max_dev_m(r, ("MPP", "MICR_finite", "MVIR_finite")) > 1.0


def test_longitudinal_slip_closed_form_yaw(ex):
    # left slip 10 s: wz = 0.1 V/T; turn with both slipping: 0.9*pi; right slip 10 s: -0.1 V/T
    r = ex.results["longitudinal_slip"]
    assert r.paths["MPP"][1000, 2] == pytest.approx(10 * 0.1 * V / T, abs=1e-12)
    assert r.paths["MPP"][1700, 2] == pytest.approx(10 * 0.1 * V / T + 0.9 * math.pi, abs=1e-12)
    assert r.paths["MPP"][-1, 2] == pytest.approx(0.9 * math.pi, abs=1e-12)
    # equal slip during the turn keeps the radius and slows the robot: vx = 0.9 V
    assert np.allclose(r.twists["MPP"][PATH.holding(), 0], 0.9 * V)


def test_lateral_slip_pushes_out_and_the_virtual_centre_jumps(ex):
    r = ex.results["lateral_slip"]
    tw = r.twists["MPP"]
    hold = PATH.holding()
    # wz = (V_R - 0.9 V_L)/T = 0.1 V/T + 0.95 w(t) at every sample (V_L,R = V -+ w T/2), w integrating to pi
    assert r.paths["MPP"][-1, 2] == pytest.approx(27 * 0.1 * V / T + 0.95 * math.pi, abs=1e-12)
    assert np.all(tw[hold, 2] > 0) and np.all(tw[hold, 1] < 0)  # left turn, centre slides right = outwards
    x_o = r.virtual_raw["x_o"]
    assert np.allclose(x_o, tw[:, 0] * np.tan(r.case.alpha) / tw[:, 2], rtol=1e-12, atol=0)  # (2.16) with (2.9)
    steps = ex41.virtual_centre_steps(PATH, r)
    assert [s["t_s"] for s in steps] == pytest.approx([11.0, 16.0])
    assert steps[0]["after"]["x_o"] > 0.2 > 0.01 > steps[0]["before"]["x_o"] > 0
    assert all(s["jump_m"] > 0.19 for s in steps)


def test_constant_rate_turn_has_unrepresentable_equal_slip_straights():
    # The 6 s constant-rate alternative: case (b) then drives straight with both tracks slipping
    # (10-10.5 s and 16.5-17 s): wz = 0 but vx = 0.9 V, which no finite ICRs give.
    path = UPath(turn_start=10.5, ramp=0.0)
    r = run_case(path, longitudinal_slip(path))
    straight_both = (r.twists["MPP"][:, 2] == 0)
    assert straight_both.sum() == 100 and np.all(r.unrepresentable[straight_both])
    s = ex41.summarize(path, r)
    assert s["max_dev_m"] < 1e-9 and s["max_dev_finite_m"] > 0.01


def test_summary_is_strict_json(ex):
    doc = ex41.summary(ex)
    text = json.dumps(doc, allow_nan=False)
    back = json.loads(text)
    assert set(back) >= {"reconstruction", "no_slip", "longitudinal_slip", "lateral_slip", "models_agree"}
    assert back["models_agree"] is True and back["models_agree_finite"] is False
    assert "pi/6" in back["reconstruction"]["description"]


def test_case_builders_follow_the_thesis_schedule():
    b = longitudinal_slip(PATH)
    tm = PATH.midpoints
    assert np.all(b.s_left[tm < 10] == 0.1) and np.all(b.s_right[tm < 10] == 0)
    assert np.all(b.s_left[(tm > 10) & (tm < 17)] == 0.1) and np.all(b.s_right[(tm > 10) & (tm < 17)] == 0.1)
    assert np.all(b.s_left[tm > 17] == 0) and np.all(b.s_right[tm > 17] == 0.1)
    c = lateral_slip(PATH)
    assert np.all(c.alpha[PATH.holding()] == pytest.approx(math.pi / 12))
    assert np.all(c.alpha[~PATH.holding()] == pytest.approx(0.02 * math.pi / 12))
    a = no_slip(PATH)
    assert not (a.s_left.any() or a.s_right.any() or a.alpha.any())


def test_models_with_the_fed_parameters_are_the_library_models(ex):
    # the finite paths are plain library integrations: nothing special-cased in the models
    r = ex.results["lateral_slip"]
    t, vl, vr = PATH.times, ex.v_left, ex.v_right
    assert np.array_equal(integrate(MICR(**r.icr), (0, 0, 0), t, vl, vr), r.paths["MICR_finite"])
    assert np.array_equal(integrate(MVIR(**r.virtual), (0, 0, 0), t, vl, vr), r.paths["MVIR_finite"])


def test_runner_registry_plugs_in_a_section(tmp_path, monkeypatch):
    # a later section (4.2) is one registry entry; fake one that computes nothing
    def plot(result, out):
        (out / "fake.png").write_bytes(b"\x89PNG")
        return {"9.1": {"file": "fake.png", "caption": "fake"}}

    fake = Section("9.9", "fake", lambda: 42, lambda r: {"value": r}, plot)
    monkeypatch.setitem(SECTIONS, "9.9", fake)
    doc = run_thesis(tmp_path, quiet=True, sections=["9.9"])
    on_disk = json.loads((tmp_path / "thesis.json").read_text())
    assert on_disk == doc and doc["sections"] == ["9.9"] and doc["9.9"]["value"] == 42
    assert doc["figures"] == ["fake.png"] and "4.1" not in doc
    with pytest.raises(InputError, match="unknown thesis section"):
        run_thesis(tmp_path, sections=["7.7"])
