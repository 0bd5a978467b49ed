"""What a log determines (mjtrack.calibrate.identify), on linear problems whose truth is known.

The residuals are written here as r = J theta - y with y = J theta_true + noise, the noise shared
within a window (correlated components) and independent across windows; the least-squares optimum
is solved with numpy, independently of the code under test.
"""

from __future__ import annotations

import numpy as np

from mjtrack.calibrate.identify import Linearised, ModelFormSource, select
from mjtrack.calibrate.params import ParamSpec

ROWS = 12  # residual components per window


def _spec(name: str, resolution: float = 0.1) -> ParamSpec:
    return ParamSpec(name, -10.0, 10.0, 1.0, resolution, "-", "mass", name)


def _problem(J_window: np.ndarray, truth: np.ndarray, seed: int, *, noise: float = 0.01,
             shared: float = 0.01) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(J (R, n), theta_hat (n,), resid (R,)) for M windows of ROWS rows each."""
    rng = np.random.default_rng(seed)
    M = J_window.shape[0] // ROWS
    e = rng.normal(0, noise, J_window.shape[0]) + np.repeat(rng.normal(0, shared, M), ROWS)
    y = J_window @ truth + e
    theta = np.linalg.lstsq(J_window, y, rcond=None)[0]
    return J_window, theta, J_window @ theta - y


def _lin(names, J, theta, resid, specs=None, model_form=()):
    specs = specs or {n: _spec(n) for n in names}
    return Linearised(names=list(names), theta=theta, jac=J, resid=resid, rows_per_window=ROWS, specs=specs,
                      model_form=list(model_form))


def test_sandwich_intervals_cover_the_truth_at_their_level():
    """95 % intervals of a well-determined 3-parameter fit cover the truth in 93-97 % of 400 logs,
    with noise shared within windows (intervals that treat every residual as independent
    undercover here: checked below)."""
    rng = np.random.default_rng(0)
    M = 60
    # as in a window fit, a parameter moves the components of one window alike (growing along it)
    J = np.repeat(rng.normal(size=(M, 3)), ROWS, axis=0) * np.tile(np.linspace(0.25, 1.0, ROWS), M)[:, None]
    J += 0.1 * rng.normal(size=J.shape)
    truth = np.array([0.3, -0.2, 0.1])
    hits, naive = [], []
    for seed in range(400):
        J_, theta, resid = _problem(J, truth, seed, noise=0.01, shared=0.03)
        u = _lin(["a", "b", "c"], J_, theta, resid).uncertainty([0, 1, 2])
        hits.append(np.abs(theta - truth) <= u.half)
        s2 = resid @ resid / (resid.size - 3)
        naive.append(np.abs(theta - truth) <= 1.96 * np.sqrt(s2 * np.diag(np.linalg.inv(J_.T @ J_))))
    cover = np.mean(hits)
    assert 0.93 <= cover <= 0.975, cover
    assert np.mean(naive) < 0.6  # independent-residual intervals: far too narrow here


def test_a_parameter_the_log_does_not_move_is_undetermined_and_kept():
    rng = np.random.default_rng(1)
    M = 40
    J = rng.normal(size=(M * ROWS, 3))
    J[:, 2] *= 1e-4  # the residuals barely depend on c
    J_, theta, resid = _problem(J, np.array([0.5, 0.0, 0.0]), 2)
    sel = select(_lin(["a", "b", "c"], J_, theta, resid), {"a": 0.0, "b": 0.0, "c": 0.0})
    assert sel.free == ["a"]
    assert not sel.verdicts["c"].determined and "not determined" in sel.verdicts["c"].reason
    assert sel.verdicts["b"].determined and not sel.verdicts["b"].changed  # consistent with 0: kept
    assert abs(sel.values["a"] - 0.5) < 0.02


def test_two_parameters_that_trade_leave_one_to_carry_their_combination():
    rng = np.random.default_rng(3)
    M = 40
    base = rng.normal(size=(M * ROWS, 3))
    J = np.column_stack([base[:, 0], base[:, 0] + 3e-3 * base[:, 2], base[:, 1]])  # a and b act almost alike
    J_, theta, resid = _problem(J, np.array([0.4, 0.0, 0.2]), 4)
    sel = select(_lin(["a", "b", "x"], J_, theta, resid), {"a": 0.0, "b": 0.0, "x": 0.0})
    dropped = [n for n in ("a", "b") if n not in sel.free]
    carrier = [n for n in ("a", "b") if n in sel.free]
    assert len(dropped) == 1 and len(carrier) == 1 and "x" in sel.free
    assert "trades with" in sel.verdicts[dropped[0]].reason
    assert sel.ties == {carrier[0]: dropped}
    assert abs(sel.values[carrier[0]] - 0.4) < 0.02  # the combination a + b


def test_a_model_form_shift_widens_the_interval_by_its_size():
    rng = np.random.default_rng(5)
    M = 40
    J = rng.normal(size=(M * ROWS, 2))
    J_, theta, resid = _problem(J, np.array([0.1, 0.2]), 6, noise=1e-4, shared=0.0)
    dr = J_[:, 0] * 0.05  # a better simulator would move the first parameter by 0.05
    plain = _lin(["a", "b"], J_, theta, resid).uncertainty([0, 1])
    with_mf = _lin(["a", "b"], J_, theta, resid, model_form=[ModelFormSource("finer", J_.T @ dr)]).uncertainty([0, 1])
    assert np.allclose(with_mf.shift, [0.05, 0.0], atol=1e-9)
    assert np.allclose(with_mf.half - plain.half, [0.05, 0.0], atol=1e-9)


def test_the_gauss_newton_step_respects_a_bound_the_gradient_pushes_against():
    rng = np.random.default_rng(7)
    M = 30
    J = rng.normal(size=(M * ROWS, 2))
    specs = {"a": ParamSpec("a", 0.0, 10.0, 1.0, 0.1, "-", "drive", "a"), "b": _spec("b")}
    y = J @ np.array([-0.3, 0.2])  # the optimum of a lies below its bound 0
    theta = np.array([0.0, 0.0])
    lin = _lin(["a", "b"], J, theta, J @ theta - y, specs=specs)
    d = lin.step()
    assert d[0] == 0.0
    b_only = np.linalg.lstsq(J[:, [1]], y, rcond=None)[0][0]  # b's optimum with a held at its bound
    assert abs(d[1] - b_only) < 1e-9


def test_summary_names_no_cause_when_the_changes_do_not_lower_the_error():
    from mjtrack.calibrate.causes import Cause, summary

    c = Cause(parameters=["cg_y"], changed={"cg_y": (0.0, 0.046)}, tied=[], share=0.0, gain_alone=-0.04,
              sentence="its centre of mass is 0.046 m left of the centre line")
    worse = summary([c], (0.46, 0.474), where="held-out", yaw=None)
    assert worse.startswith("No candidate explains the error") and "erred mostly because" not in worse
    assert "cg_y" in worse and "0.46 m to 0.474 m" in worse
    better = summary([Cause(["cg_y"], {"cg_y": (0.0, 0.05)}, [], 1.0, 0.99, "its centre of mass is 0.05 m left")],
                     (0.04, 0.001), where="held-out", yaw=None)
    assert better.startswith("The described MuJoCo robot erred mostly because its centre of mass")


def test_summary_says_what_the_log_does_not_determine():
    from mjtrack.calibrate.causes import summary

    text = summary([], (0.327, 0.327), where="held-out", yaw=(0.45, 0.53), undetermined=["mu", "wheelbase"])
    assert text.startswith("Nothing the log determines needs to change. It does not determine mu, wheelbase")
    assert "measured 0.45, described robot 0.53" in text
    clean = summary([], (0.004, 0.004), where="held-out", yaw=None, undetermined=[])
    assert clean.startswith("Nothing needs to change")


def test_what_the_log_points_at_but_the_fit_did_not_reach_is_said():
    """A candidate the fit's rounds did not reach keeps its described value: calibration.json gives
    the value the log points at, and the summary says the log does not confirm the description."""
    from mjtrack.calibrate.causes import Cause, summary
    from mjtrack.calibrate.identify import Verdict

    v = Verdict("mu_ratio", True, False, 1.0, 1.0, None, "the log points at 1.3 (linearised), ...", points_at=1.3)
    assert v.to_json()["points_at"] == 1.3
    assert "points_at" not in Verdict("mu", True, False, 0.5, 0.5, (0.4, 0.6), "kept").to_json()
    c = Cause(["wheelbase"], {"wheelbase": (0.512, 0.6)}, [], 0.9, 0.3, "its wheelbase acts as 0.6 m")
    one = summary([c], (0.3, 0.2), where="held-out", yaw=None, unsettled={"mu_ratio": "1.3"})
    assert one.endswith("The log also points at mu_ratio 1.3, which the fit did not reach within its rounds (more "
                        "rounds, --rounds, let it go further): it keeps its described value, which the log does not "
                        "confirm.")
    two = summary([c], (0.3, 0.2), where="held-out", yaw=None, unsettled={"mu_ratio": "1.3", "cg_y": "-0.047 m"})
    assert "points at mu_ratio 1.3, cg_y -0.047 m, which" in two and "they keep their described values" in two
    assert summary([c], (0.3, 0.2), where="held-out", yaw=None) == summary([c], (0.3, 0.2), where="held-out",
                                                                          yaw=None, unsettled={})
    back = summary([c], (0.3, 0.2), where="held-out", yaw=None, sent_back=["mu", "drive_force_limit"])
    assert back.endswith("The fit's rounds ran out before its decisions settled: the last decision would send mu, "
                         "drive_force_limit back to their described values (more rounds, --rounds, let it go "
                         "further); the values given are the last fit's.")


def test_an_unreached_value_that_cannot_be_the_robots_is_not_said_to_be_pointed_at():
    """A force limit the log moves towards but the fit did not reach, above what a side's friction
    transmits, is said with the reason it cannot be the robot's, not as what the log points at."""
    from mjtrack.calibrate.causes import Cause, implausibility, summary, traction_limit
    from mjtrack.io.robot import Robot

    robot = Robot(mass=50.0, mu=0.5, track_gauge=0.55, traction="wheels", wheelbase=0.512)
    traction = traction_limit(robot, {})
    assert abs(traction - 0.5 * 50.0 * 9.81 / 2) < 0.1  # mu x half the weight, written out here
    why = implausibility("drive_force_limit", 2290.0, 909.0, (25.0, 2500.0, 25.0), traction=traction)
    assert why is not None and "above what the ground can transmit under a side, 123 N" in why
    assert implausibility("drive_force_limit", 100.0, 909.0, (25.0, 2500.0, 25.0), traction=traction) is None
    c = Cause(["wheelbase"], {"wheelbase": (0.512, 0.6)}, [], 0.9, 0.3, "its wheelbase acts as 0.6 m")
    text = summary([c], (0.3, 0.2), where="held-out", yaw=None,
                   unsettled_implausible={"drive_force_limit": ("2.29e+03 N", why)})
    assert "points at" not in text
    assert text.endswith("The log also moves drive_force_limit towards 2.29e+03 N, which the fit did not reach within "
                         f"its rounds and which cannot be the robot's ({why}): not a cause; it keeps its described "
                         "value.")


def test_a_large_change_with_a_wide_interval_is_determined_and_changed():
    """A parameter whose interval is wider than its resolution but far from the description (the
    log says it must change, and by about how much) stays fitted, with its interval; one whose
    equally wide interval reaches the description is not determined."""
    rng = np.random.default_rng(5)
    M = 40
    J = rng.normal(size=(M * ROWS, 2)) * np.array([0.05, 0.05])  # weakly determined: sd ~ 0.05 each
    J_, theta, resid = _problem(J, np.array([2.0, 0.03]), 6, noise=0.01, shared=0.01)
    lin = _lin(["far", "near"], J_, theta, resid, specs={"far": _spec("far", 0.01), "near": _spec("near", 0.01)})
    half = lin.uncertainty([0, 1]).half
    assert np.all(half > 0.01)  # both wider than the resolution
    sel = select(lin, {"far": 0.0, "near": 0.0})
    assert sel.free == ["far"]
    assert abs(sel.values["far"] - 2.0) < 3 * half[0]
    assert not sel.verdicts["near"].determined and "not determined" in sel.verdicts["near"].reason


def test_summary_says_when_the_other_changes_compensate_a_cause():
    """A share above 100 % means the calibrated robot without that change is worse than the
    described one (the other changes compensate for it): said in words, not as '1433 %'."""
    from mjtrack.calibrate.causes import Cause, summary

    delay = Cause(["drive_delay"], {"drive_delay": (0.0, 0.45)}, [], 14.3, 0.46, "its drives act 0.45 s late")
    cg = Cause(["cg_x"], {"cg_x": (0.016, 0.03)}, [], 0.33, 0.02, "its centre of mass is 0.03 m ahead")
    text = summary([delay, cg], (0.246, 0.086), where="held-out", yaw=None)
    assert "without it the other changes are worse than the description" in text
    assert "1430 %" not in text and "(33 % of the improvement)" in text


def test_cause_phrases_speak_of_wheels_on_a_wheeled_robot():
    from mjtrack.calibrate.causes import phrase

    for name, value in (("rolling_resistance", 0.15), ("track_speed_scale", 0.93)):
        tracked, wheeled = phrase(name, value, 0.0, wheels=False), phrase(name, value, 0.0, wheels=True)
        assert "tracks" in tracked and "wheels" not in tracked
        assert "wheels" in wheeled and "tracks" not in wheeled
    # against measured track speeds a speed scale is a rolling radius, not a command's scale
    assert "commanded" not in phrase("track_speed_scale", 0.94, 1.0, wheels=True, measured=True)
    assert "effective radius" in phrase("track_speed_scale", 0.94, 1.0, wheels=True, measured=True)


def test_a_value_at_the_edge_of_the_range_searched_says_so():
    from mjtrack.calibrate.identify import final_verdicts

    rng = np.random.default_rng(3)
    M = 40
    J = rng.normal(size=(M * ROWS, 2))
    specs = {"a": ParamSpec("a", 0.0, 1.0, 1.0, 0.5, "-", "mass", "a"), "b": _spec("b", resolution=0.5)}
    y = J @ np.array([1.3, 0.4]) + rng.normal(0, 0.01, M * ROWS)  # a's optimum lies beyond its bound 1
    theta = np.array([1.0, np.linalg.lstsq(J[:, [1]], y - J[:, 0], rcond=None)[0][0]])
    verdicts, _, _ = final_verdicts(_lin(["a", "b"], J, theta, J @ theta - y, specs=specs), {"a": 0.0, "b": 0.0}, {})
    assert "edge of the range searched" in verdicts["a"].reason and verdicts["a"].interval[1] == 1.0
    assert "edge" not in verdicts["b"].reason


def test_cause_sentences_show_a_small_change_and_say_a_slope_once():
    from mjtrack.calibrate.causes import phrase, sentence_of

    # a change below three digits is printed with enough digits to be seen
    text = phrase("track_length", 0.79964, 0.8)
    assert "0.7996 m long, not 0.8 m" in text
    values = {"slope_x": 0.038, "slope_y": 0.032, "track_length": 0.79964}
    described = {"slope_x": 0.0, "slope_y": 0.0, "track_length": 0.8}
    both = sentence_of(["slope_x", "slope_y"], values, described, [])
    assert both.count("inclined") == 1
    # a cause holding one slope component speaks of that component only
    one = sentence_of(["track_length", "slope_y"], values, described, [])
    assert "inclined" not in one and "log's y axis" in one and "0.032" in one
