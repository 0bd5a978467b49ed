"""The turn stage (mjtrack.calibrate.turns): the steady turns set what the end poses leave free.

The log is made by MuJoCo with a known robot (written here, not taken from the code under test);
the stage must find the contact length and motion resistance that robot turns with, with intervals
that cover them, and must neither run when the robot already turns as the log does nor replace a
fit whose end poses speak more strongly against it than the turns against the fit.
"""

from __future__ import annotations

import numpy as np
import pytest

from mjtrack.calibrate.params import specs_for
from mjtrack.calibrate.turns import match_turns, turn_candidates
from mjtrack.io.robot import Robot
from mjtrack.sim import drive_log
from mjtrack.windows import make_windows

TRUE = {"track_length": 0.34, "rolling_resistance": 0.06}  # the log's robot; the description says otherwise
GAUGE, MASS, MU = 0.4, 20.0, 0.8


def _turns(duration: float, seed: int):
    """Steady turns of both signs, gentle and sharp (turn ratio 0.3, 0.6, 1.0), each held 4 s, on
    the 0.05 s grid."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, 4.0)
    v = rng.uniform(0.3, 0.8, len(t))
    turn = rng.choice([-1.0, -0.6, -0.3, 0.3, 0.6, 1.0], len(t), p=[0.1, 0.15, 0.25, 0.25, 0.15, 0.1])
    return t, v * (1 - turn), v * (1 + turn)


@pytest.fixture(scope="module")
def case():
    from mjtrack.sim.windows import WindowSim, simulate_windows

    truth = Robot(track_gauge=GAUGE, mass=MASS, mu=MU, **TRUE)
    log = drive_log(truth, _turns(120.0, 5), duration=120.0, log_rate=20.0)
    described = Robot(track_gauge=GAUGE, track_length=0.5, mass=MASS, mu=MU)
    ws = make_windows(log, 2.0)
    sim = WindowSim(described, resisted=True)

    def score(values):
        res = simulate_windows(sim, log, ws, [values], warmup_s=0.5)
        return float(res.rms()[0]), int(res.diverged[0].sum()), res

    return log, described, ws, sim, score


def _run(case, fitted, *, score=None, refit=None):
    log, described, ws, sim, own = case
    _, diverged, res = own(fitted)
    return match_turns(sim, log, ws, described, fitted, ["track_length", "rolling_resistance"],
                       specs_for(described), fitted_errors=res.pos_err()[0], fitted_diverged=diverged,
                       fitted_poses=res.poses[0], fitted_speeds=res.speeds[0], nthread=2, warmup_s=0.5,
                       score=score or (lambda p: (own(p)[2].pos_err()[0], 0)), refit=refit)


def test_the_steady_turns_find_the_robots_contact_and_resistance(case):
    fitted = {"track_length": 0.5, "rolling_resistance": 0.0}  # a fit that left both at the description
    tm = _run(case, fitted)
    assert tm is not None and tm.accepted and tm.refused_by is None, tm and tm.why
    for n, truth in TRUE.items():
        lo, hi = tm.intervals[n]
        assert lo <= truth <= hi, (n, truth, tm.values[n], tm.intervals[n])
    assert all(abs(m - s) <= 0.03 for lab, m, s in zip(tm.labels, tm.measured, tm.matched) if lab.startswith("yaw"))
    assert tm.train_rms[1] < tm.train_rms[0]  # the truth fits the end poses better than the wrong length
    assert "track_length" in tm.sentence() and "replace the fit's" in tm.sentence()


def test_a_robot_that_already_turns_as_the_log_does_is_left_alone(case):
    assert _run(case, dict(TRUE)) is None


@pytest.mark.slow
def test_turning_as_the_log_does_at_worse_end_poses_does_not_replace_the_fit(case):
    fitted = {"track_length": 0.5, "rolling_resistance": 0.0}
    n = len(case[2])  # as if the turn-matched robot missed every end pose by a kilometre
    tm = _run(case, fitted, score=lambda v: (np.full(n, 1e3), 0))
    assert tm is not None and not tm.accepted and tm.refused_by == "end_poses"
    assert "show the fit's robot better" in tm.why
    assert "the fit's values stand" in tm.sentence()


def test_a_turn_match_the_end_poses_show_slightly_worse_is_kept_when_the_turns_speak_louder(case):
    """The end poses show the turn-matched robot worse by a little on every window (its squared
    error 0.001 to 0.003 m^2 above the fit's), while the fit's robot, with the described contact
    length, turns far from the log: the turns speak more strongly against the fit's robot, so the
    turn-matched one is kept, and its record says the two kinds of evidence ask for different robots."""
    fitted = {"track_length": 0.5, "rolling_resistance": 0.0}
    own, n = case[4], len(case[2])
    fit_err = own(fitted)[2].pos_err()[0]
    extra = np.random.default_rng(3).uniform(0.001, 0.003, n)
    tm = _run(case, fitted, score=lambda p: (np.sqrt(fit_err ** 2 + extra), 0))
    assert tm is not None and tm.accepted and tm.refused_by is None, tm.why
    assert tm.mse_gap_interval[0] > 0  # the end poses alone would refuse it
    ev = tm.evidence
    assert ev["end_poses_z"] > 2 and ev["chi2_turn_matched"] < ev["chi2_fit"]
    assert ev["chi2_turn_matched"] == pytest.approx(ev["turns_wald_turn_matched"] + ev["end_poses_z"] ** 2)
    assert ev["chi2_fit"] == ev["turns_wald_fit"]
    assert "ask for different robots" in tm.why and "replace the fit's" in tm.sentence()


def test_the_turns_wald_statistic_and_the_evidence_against_each_robot():
    """The Wald statistic against the truth written out (independent classes: the sum of squared
    z), classes that share windows through the pseudo-inverse, and the end poses counted against
    the robot they show worse only."""
    from mjtrack.calibrate.turns import _gap_z, evidence, turn_wald

    gap, sd = np.array([0.04, -0.02]), np.array([0.01, 0.02])
    assert turn_wald(gap, np.diag(sd ** 2)) == pytest.approx((0.04 / 0.01) ** 2 + (0.02 / 0.02) ** 2)
    same = np.full((2, 2), 1e-4)  # two classes of the same windows: one piece of evidence, not two
    assert turn_wald(np.array([0.03, 0.03]), same) == pytest.approx(0.03 ** 2 / 1e-4)
    assert np.isnan(turn_wald(gap, np.full((2, 2), np.nan))) and np.isnan(turn_wald(np.array([]), np.zeros((0, 0))))
    assert evidence(20.0, 1.0, 3.0) == (20.0, 10.0)  # the end poses show the turn-matched robot worse
    assert evidence(20.0, 1.0, -2.0) == (24.0, 1.0)  # ... or the fit's robot
    assert _gap_z(np.full(5, 0.01)) == np.inf and _gap_z(np.zeros(5)) == 0.0
    draws = np.random.default_rng(1).normal(0.5, 0.25, 4000)
    assert _gap_z(draws) == pytest.approx(2.0, rel=0.05)


@pytest.mark.slow
def test_the_robot_judged_is_the_one_whose_other_values_were_refitted_with_the_turns_held(case):
    """A pose fit that left friction wrong (0.5; the log's robot has 0.8) with the contact length
    and resistance at the description: the turn candidates are fitted, the refit (here one that
    finds the log's friction, standing in for the pose fit with the turn values held) moves the
    friction, and the turn candidates are fitted once more from there. The robot judged and kept is
    the refitted one, its intervals cover the truth, and every robot scored held what it was given."""
    fitted = {"track_length": 0.5, "rolling_resistance": 0.0, "mu": 0.5}
    held, scored = [], []
    own = case[4]

    def refit(values):
        held.append(dict(values))
        return {"mu": MU}, []

    def score(p):
        scored.append(dict(p))
        return own(p)[2].pos_err()[0], 0

    tm = _run(case, fitted, score=score, refit=refit)
    assert tm.accepted and tm.refit is not None and tm.refit["kept"], tm.why
    assert held == [tm.refit["plain"]["values"]]  # the refit was handed the first turn fit's values
    assert tm.refit["base"] == {"mu": MU} and tm.params == {"mu": MU, **tm.values}
    assert [p["mu"] for p in scored] == [0.5, MU]  # the first turn-matched robot, the refitted one
    for n, truth in TRUE.items():
        lo, hi = tm.intervals[n]
        assert lo <= truth <= hi, (n, truth, tm.values[n], tm.intervals[n])
    assert tm.train_rms[1] <= tm.refit["plain"]["train_rms_m"]  # the refit's friction is the log's
    assert "fitted again to the end poses" in tm.sentence() and "with the refitted values" in tm.sentence()


@pytest.mark.parametrize("why", ["end_poses", "bound"])
def test_a_refused_refit_leaves_the_first_turn_match_judged(case, why):
    """When the robot with the others refitted is refused -- made to miss every end pose, or its
    refit ended a value on a bound (then the turns are not fitted again) -- and the first
    turn-matched robot is not, the first one is judged and the record says so."""
    fitted = {"track_length": 0.5, "rolling_resistance": 0.0}
    own, n = case[4], len(case[2])

    def score(p):
        return (np.full(n, 1e3), 0) if "mu" in p else (own(p)[2].pos_err()[0], 0)

    # the refit finds the log's friction: its robot turns as the log does and is refused for the reason made here
    tm = _run(case, fitted, score=score, refit=lambda values: ({"mu": MU}, ["mu"] if why == "bound" else []))
    assert tm.accepted and tm.refused_by is None
    assert tm.refit is not None and not tm.refit["kept"] and tm.refit["refused_by"] == why
    assert "mu" not in tm.params and tm.values == tm.refit["plain"]["values"]
    assert (tm.refit["values"] is None) == (why == "bound")
    assert "that robot was refused" in tm.sentence()
    assert ("the refit put mu on a bound" in tm.sentence()) == (why == "bound")


def test_objective_holds_what_it_is_told_to_hold(case):
    """An objective of friction alone with the contact length held gives the residuals of the
    objective of both at the same values."""
    from mjtrack.calibrate.fit import objective

    log, described, ws, sim, _ = case
    sub = ws.subset(np.arange(6))
    both = objective(sim, log, sub, ["mu", "track_length"], warmup_s=0.5)
    one = objective(sim, log, sub, ["mu"], warmup_s=0.5, held={"track_length": 0.34})
    r_both = both.residuals(np.array([0.7, 0.34]) / both.scales)
    r_one = one.residuals(np.array([0.7]) / one.scales)
    np.testing.assert_array_equal(r_one, r_both)
    free = objective(sim, log, sub, ["mu"], warmup_s=0.5)  # the described length, 0.5 m
    assert not np.allclose(free.residuals(np.array([0.7]) / free.scales), r_one)


def test_turn_candidates_are_those_named_and_the_shear_grounds_ratio_with_its_modulus():
    wheels = Robot(traction="wheels", track_gauge=0.55, wheelbase=0.5)
    assert turn_candidates(["mu", "wheelbase", "rolling_resistance", "shear_modulus"], wheels) == [
        "wheelbase", "rolling_resistance", "shear_modulus", "lateral_shear_ratio"]
    tracks = Robot(track_gauge=0.4, track_length=0.5)
    assert turn_candidates(["mu", "track_length", "rolling_resistance", "cg_x"], tracks) == [
        "track_length", "rolling_resistance"]
    assert turn_candidates(["mu", "cg_x"], tracks) == []
    aniso = Robot(track_gauge=0.4, track_length=0.5, ground={"model": "anisotropic", "lateral_ratio": 0.5})
    assert turn_candidates(["track_length", "shear_modulus"], aniso) == ["track_length"]


def test_the_end_poses_gap_draws_a_held_commands_windows_together():
    """The squared-error gap's interval: windows of one label are drawn as one (doubling every
    window under its own label gives the single windows' interval), and a robot worse on every
    window is shown worse."""
    from mjtrack.calibrate.turns import _mse_gap_interval

    rng = np.random.default_rng(0)
    a, b = rng.uniform(0.1, 0.3, 40), rng.uniform(0.1, 0.3, 40)
    one = _mse_gap_interval(a, b, np.arange(40))
    two = _mse_gap_interval(np.repeat(a, 2), np.repeat(b, 2), np.repeat(np.arange(40), 2))
    assert one == pytest.approx(two)
    lo, hi = _mse_gap_interval(a + 0.1, a, np.arange(40))
    assert lo > 0 and lo <= hi
