"""The fit's shortcuts (mjtrack.calibrate.rounds, mjtrack.calibrate.fit) give the answer of the
long way, on residuals written out here with a known truth (no simulation).

The residuals are r(p) = f(p) - f(p_true) - noise with f mildly nonlinear (a quadratic term per
row), the noise shared within a window; the reference answers are computed here with numpy's own
least squares and finite differences, independently of the code under test.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from mjtrack.calibrate import rounds
from mjtrack.calibrate.fit import SCREEN_KEEP, SCREEN_WINDOWS, _multistart, fit
from mjtrack.calibrate.params import specs_for
from mjtrack.io.robot import Robot

ROWS = 12
M = 40
NAMES = ["mu", "cg_x", "cg_y"]
DESCRIBED = {"mu": 0.8, "cg_x": 0.0, "cg_y": 0.0}
TRUTH = {"mu": 0.8, "cg_x": 0.04, "cg_y": 0.0}  # the log says cg_x must change, nothing else


class Analytic:
    """What :func:`fit` and the rounds ask of an objective, for the residuals of the module docstring."""

    rows_per_window = ROWS

    def __init__(self, names, seed=0, fixed=None, windows=None):
        rng = np.random.default_rng(seed)
        self.names, self.specs = list(names), specs_for(Robot())
        self.fixed = dict(DESCRIBED if fixed is None else fixed)
        self.res = np.array([self.specs[n].resolution for n in NAMES])
        self.a = rng.normal(0, 0.01, (M * ROWS, 3))  # [m per resolution]
        self.b = rng.normal(0, 1.0, (M * ROWS, 3))
        self.noise = rng.normal(0, 3e-4, M * ROWS) + np.repeat(rng.normal(0, 3e-4, M), ROWS)
        self.rows = np.arange(M * ROWS) if windows is None else windows
        self.windows = np.arange(len(self.rows) // ROWS)
        self.evaluations, self.seconds = 0, 0.0

    @property
    def scales(self):
        return np.array([self.specs[n].scale for n in self.names])

    def params_of(self, z):
        return {n: float(v) for n, v in zip(self.names, np.asarray(z, float) * self.scales)}

    def f(self, p):
        u = (np.array([p[n] for n in NAMES]) - np.array([DESCRIBED[n] for n in NAMES])) / self.res
        return self.a @ u + 0.002 * (self.b @ u) ** 2

    def residuals(self, Z):
        Z = np.asarray(Z, float)
        cols = Z[:, None] if Z.ndim == 1 else Z
        self.evaluations += cols.shape[1]
        out = np.stack([(self.f({**self.fixed, **self.params_of(c)}) - self.f(TRUTH) - self.noise)[self.rows]
                        for c in cols.T], -1) / np.sqrt(len(self.windows))
        return out[:, 0] if Z.ndim == 1 else out

    def cost(self, Z):
        return np.sum(self.residuals(Z if np.ndim(Z) == 2 else np.asarray(Z)[:, None]) ** 2, axis=0)

    def on(self, index):
        rows = (np.asarray(index)[:, None] * ROWS + np.arange(ROWS)).ravel()
        return Analytic(self.names, fixed=self.fixed, windows=rows)


class Fitter(rounds.Fitter):
    def objective(self, fws, names):
        return Analytic(names, fixed={**DESCRIBED})


def _fitter():
    meter = SimpleNamespace(stage=lambda *a, **k: None, tail=0, windows=lambda n: None)
    return Fitter(sim=SimpleNamespace(robot=Robot(), dt=0.005), train=None, names=list(NAMES),
                  described=dict(DESCRIBED), config=None, max_iter=8, nthread=1, warmup_s=0.0, meter=meter)


@pytest.fixture(autouse=True)
def _no_model_form(monkeypatch):
    monkeypatch.setattr(rounds, "model_form_sources", lambda *a, **k: ([], {}))


def _numpy_jacobian(obj, z, h):
    """Central differences of step h (n,) at z, by hand."""
    return np.stack([(obj.residuals(z + e) - obj.residuals(z - e)) / (2 * e[i]) for i, e in enumerate(np.diag(h))], -1)


def test_a_decision_within_the_optimisers_tolerance_keeps_the_jacobian_and_gives_the_refits_answer():
    """After the first fit, the decision (cg_x changed, mu and cg_y back to their description)
    lies within the tolerance: no refit, one pass for the residuals there; the value and the
    interval are those of a fit of cg_x alone with a fresh central-difference Jacobian at its end
    (both computed here) to within the optimiser's tolerance (STEP_TOL of the half-width)."""
    fx = _fitter()
    obj = Analytic(NAMES)
    first = fit(obj, dict(DESCRIBED), multistart=False)
    cur = rounds.Linearisation(dict(first.values), first.resid, first.jac, list(NAMES))
    before = obj.evaluations
    sel, cur, theta, sources, size, fits = rounds.decision_rounds(fx, obj, np.arange(M), cur, rounds.MAX_ROUNDS, None)
    assert sel.free == ["cg_x"] and fits == []
    assert obj.evaluations - before == 1  # the residuals at the decided point, nothing else
    assert cur.taken_at == first.values and cur.point != first.values
    verdicts, values, *_ = rounds.settle_verdicts(fx, obj, sel, cur, theta, sources, size, rounds.MAX_ROUNDS)
    lo, hi = verdicts["cg_x"].interval
    # the long way, by hand: cg_x alone fitted to convergence (Gauss-Newton with numpy), its
    # interval half-width from a fresh central difference there (same sandwich code as the rounds)
    one = Analytic(["cg_x"])
    z = np.array([values["cg_x"] / one.scales[0]])
    for _ in range(20):
        J = _numpy_jacobian(one, z, np.array([1e-3]))
        z = z - np.linalg.lstsq(J, one.residuals(z), rcond=None)[0]
    J = _numpy_jacobian(one, z, np.array([one.specs["cg_x"].resolution / one.scales[0]]))
    lin = fx.linearised(one, z, J, one.residuals(z), [], names=["cg_x"])
    half = float(lin.uncertainty([0]).half[0])
    assert abs(values["cg_x"] - z[0] * one.scales[0]) <= rounds.STEP_TOL * half
    assert (hi - lo) / 2 == pytest.approx(half, rel=0.1)
    assert lo <= TRUTH["cg_x"] <= hi


def test_a_decision_beyond_the_tolerance_is_refitted():
    """A first fit that stopped short (mu a resolution off, its Jacobian taken there) is refitted."""
    fx = _fitter()
    obj = Analytic(NAMES)
    first = fit(obj, dict(DESCRIBED), multistart=False)
    off = {**first.values, "mu": first.values["mu"] + obj.specs["mu"].resolution}
    from mjtrack.calibrate.fit import central_jacobian

    resid, jac = central_jacobian(obj, fx.scaled(off))
    cur = rounds.Linearisation(off, resid, jac, list(NAMES))
    sel, cur, *_, fits = rounds.decision_rounds(fx, obj, np.arange(M), cur, rounds.MAX_ROUNDS, None)
    assert sel.free == ["cg_x"] and len(fits) >= 1
    # the Jacobian the verdicts use was taken at (or within the tolerance of) the final point
    assert all(abs(cur.point[n] - cur.taken_at[n]) <= rounds.REUSE_TOL * obj.specs[n].resolution for n in NAMES)
    assert abs(cur.taken_at["mu"] - off["mu"]) > obj.specs["mu"].resolution / 2  # not the stale one


def test_the_multistart_screen_keeps_the_start_that_wins_on_every_window():
    """The starts screened on a few windows, the best few costed on all: the start chosen is the
    one the full costing of every start chooses, and only SCREEN_KEEP starts are costed on all."""
    obj = Analytic(NAMES)
    z0 = np.array([DESCRIBED[n] for n in NAMES]) / obj.scales
    cands = [z0 + d for d in np.random.default_rng(3).normal(0, 1.0, (8, 3))]
    import mjtrack.calibrate.fit as fit_mod

    orig = fit_mod.start_points
    try:
        fit_mod.start_points = lambda names, specs, z: cands
        assert M >= 3 * SCREEN_WINDOWS
        best, tried = _multistart(obj, z0)
    finally:
        fit_mod.start_points = orig
    full = [float(np.sum(obj.residuals(c) ** 2)) for c in np.stack(cands, -1).T]
    assert np.allclose(best, cands[int(np.argmin(full))])
    assert sum(np.isfinite(c) for _, c in tried) == SCREEN_KEEP


@pytest.mark.parametrize("n_rounds", [0, rounds.MAX_ROUNDS])
def test_rounds_that_run_out_say_what_the_log_points_at_and_how_to_go_further(n_rounds):
    """From a point where only mu was fitted, the log points at cg_x: with no rounds left the fit
    cannot move it, so cg_x keeps its description and its verdict says where the log points and
    that more rounds would reach it; with the default rounds the fit reaches the truth."""
    from mjtrack.calibrate.fit import central_jacobian

    fx = _fitter()
    obj = Analytic(NAMES)
    resid, jac = central_jacobian(obj, fx.scaled(DESCRIBED))
    cur = rounds.Linearisation(dict(DESCRIBED), resid, jac, ["mu"])
    sel, cur, theta, sources, size, fits = rounds.decision_rounds(fx, obj, np.arange(M), cur, n_rounds, None)
    verdicts, values, *_ = rounds.settle_verdicts(fx, obj, sel, cur, theta, sources, size, n_rounds)
    if n_rounds == 0:
        assert fits == [] and values["cg_x"] == DESCRIBED["cg_x"]
        assert f"did not settle within 0 rounds ({rounds.ROUNDS_HINT})" in verdicts["cg_x"].reason
        assert verdicts["cg_x"].points_at == pytest.approx(TRUTH["cg_x"], abs=0.01)
    else:
        lo, hi = verdicts["cg_x"].interval
        assert verdicts["cg_x"].changed and lo <= TRUTH["cg_x"] <= hi


def test_a_tie_with_a_parameter_the_last_fit_kept_free_is_not_claimed():
    """When the rounds run out, the last fit (every candidate free here) stands; a tie the last
    decision drew with a parameter that fit kept free (mu) is not said: mu has its own value and
    verdict, so cg_x cannot "hold only with mu at the described value"."""
    import dataclasses

    fx = _fitter()
    obj = Analytic(NAMES)
    first = fit(obj, dict(DESCRIBED), multistart=False)
    cur = rounds.Linearisation(dict(first.values), first.resid, first.jac, list(NAMES))
    sel, cur, theta, sources, size, _ = rounds.decision_rounds(fx, obj, np.arange(M), cur, 0, None)
    sel = dataclasses.replace(sel, ties={"cg_x": ["mu"]})  # what the decision said, not what was fitted
    verdicts, values, *_, ties = rounds.settle_verdicts(fx, obj, sel, cur, theta, sources, size, 0)
    assert ties == {} and "carries its combination" not in verdicts["cg_x"].reason
    assert values["mu"] == cur.point["mu"] and verdicts["mu"].value == cur.point["mu"]


def test_a_fitted_value_the_last_decision_would_send_back_is_said_unsettled():
    """Rounds run out while the last decision sends mu and cg_y back (only cg_x free) but the last
    fit still has them free: their values are the last fit's, and their verdicts say so."""
    fx = _fitter()
    obj = Analytic(NAMES)
    first = fit(obj, dict(DESCRIBED), multistart=False)  # every candidate free, mu a little off 0.8 by noise
    cur = rounds.Linearisation(dict(first.values), first.resid, first.jac, list(NAMES))
    sel, cur, theta, sources, size, fits = rounds.decision_rounds(fx, obj, np.arange(M), cur, 0, None)
    assert sel.free == ["cg_x"] and fits == []
    verdicts, *_ = rounds.settle_verdicts(fx, obj, sel, cur, theta, sources, size, 0)
    assert verdicts["mu"].unsettled and verdicts["mu"].to_json()["unsettled"] is True
    assert "last decision would send it back to its described value, but its 0 rounds ran out" in verdicts["mu"].reason
    assert not verdicts["cg_x"].unsettled and "unsettled" not in verdicts["cg_x"].to_json()


def test_a_window_that_blows_up_near_the_point_holds_no_slope():
    """A window whose simulation blows up a step away from the point (every component
    DIVERGED_RESIDUAL there) gets a zero row in the Jacobian; the other windows' rows are those of
    the analytic objective. Left in, its row is the jump across the stable range's edge: here
    over thirty times the largest real entry."""
    from mjtrack.calibrate.fit import DIVERGED_RESIDUAL, central_jacobian

    fx = _fitter()
    plain = Analytic(NAMES)
    _, jac = central_jacobian(plain, fx.scaled(DESCRIBED))

    class OneBlowsUp(Analytic):
        def residuals(self, Z):
            out = super().residuals(Z)
            Z = np.asarray(Z, float)
            if Z.ndim == 2:  # window 3 leaves the stable range above the described cg_x
                up = np.flatnonzero(Z[1] > fx.scaled(DESCRIBED)[1] + 1e-12)
                out[3 * ROWS:4 * ROWS, up] = DIVERGED_RESIDUAL / np.sqrt(len(self.windows))
            return out

    resid, jac2 = central_jacobian(OneBlowsUp(NAMES), fx.scaled(DESCRIBED))
    assert np.all(jac2[3 * ROWS:4 * ROWS] == 0.0)
    keep = np.ones(M * ROWS, bool)
    keep[3 * ROWS:4 * ROWS] = False
    np.testing.assert_allclose(jac2[keep], jac[keep])
    # what the row would have been: the jump, against the largest real entry
    jump = DIVERGED_RESIDUAL / np.sqrt(M) / (2 * fx.specs["cg_x"].resolution / fx.specs["cg_x"].scale)
    assert jump > 30 * np.abs(jac[keep]).max()
