"""A default is not information: a kept parameter's interval allows for a parameter held at a
default the description does not give (mjtrack.calibrate.identify, "Defaults are not information").

The residuals are linear in the parameters, written out here with a known truth (no simulation):
r(p) = A (u - u_true) - noise, u the parameters in units of their resolution, the noise
i.i.d. cg_x must change (its truth lies many half-widths from the description); mu's
truth lies one resolution from the default 0.8, inside what this log leaves open, so the fit sends
mu back to 0.8 and cg_x follows it. The estimates are correlated (0.85), so cg_x held at mu = 0.8
is biased: an interval conditional on the default often misses the truth, one that allows for mu
covers it. Coverage counted over seeds here, against the truth.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from mjtrack.calibrate import rounds
from mjtrack.calibrate.params import specs_for
from mjtrack.io.robot import Robot

ROWS = 6
M = 60
NAMES = ["mu", "cg_x"]
DESCRIBED = {"mu": 0.8, "cg_x": 0.0}
SPECS = specs_for(Robot())
RES = np.array([SPECS[n].resolution for n in NAMES])
U_TRUE = np.array([1.0, 4.0])  # mu one resolution above its default; cg_x four resolutions off
SD = np.array([0.83, 1.0])  # the estimates' standard deviations, resolution units
CORR = 0.85  # below identify.TIE: mu is undetermined on its own, not traded with cg_x
COV = np.outer(SD, SD) * np.array([[1.0, CORR], [CORR, 1.0]])
NOISE = 0.01
TRUTH = {n: DESCRIBED[n] + u * r for n, u, r in zip(NAMES, U_TRUE, RES)}


class Linear:
    """What the fit and its rounds ask of an objective, for the residuals of the module docstring."""

    rows_per_window = ROWS

    def __init__(self, names, seed, windows=None):
        rng = np.random.default_rng(seed)
        self.names, self.specs = list(names), SPECS
        # columns built for a chosen covariance of the estimates (resolution units): A^T A = s^2 C^-1
        # for the noise s, whatever the random orthonormal directions Q
        q, _ = np.linalg.qr(rng.normal(0.0, 1.0, (M * ROWS, 2)))
        self.A = q @ np.linalg.cholesky(NOISE ** 2 * np.linalg.inv(COV)).T
        self.noise = rng.normal(0.0, NOISE, M * ROWS)
        self.rows = np.arange(M * ROWS) if windows is None else windows
        self.windows = np.arange(len(self.rows) // ROWS)
        self.seed, self.evaluations, self.seconds = seed, 0, 0.0

    @property
    def scales(self):
        return np.array([self.specs[n].scale for n in self.names])

    def params_of(self, z):
        return {n: float(v) for n, v in zip(self.names, np.asarray(z, float) * self.scales)}

    def residuals(self, Z):
        Z = np.asarray(Z, float)
        cols = Z[:, None] if Z.ndim == 1 else Z
        self.evaluations += cols.shape[1]
        out = []
        for c in cols.T:
            p = {**DESCRIBED, **self.params_of(c)}
            u = np.array([(p[n] - DESCRIBED[n]) / r for n, r in zip(NAMES, RES)])
            out.append((self.A @ (u - U_TRUE) - self.noise)[self.rows])
        out = np.stack(out, -1) / np.sqrt(len(self.windows))
        return out[:, 0] if Z.ndim == 1 else out

    def cost(self, Z):
        return np.sum(self.residuals(Z if np.ndim(Z) == 2 else np.asarray(Z)[:, None]) ** 2, axis=0)

    def on(self, index):
        rows = (np.asarray(index)[:, None] * ROWS + np.arange(ROWS)).ravel()
        return Linear(self.names, self.seed, windows=rows)


class Fitter(rounds.Fitter):
    seed: int = 0

    def objective(self, fws, names):
        return Linear(names, self.seed)


@pytest.fixture(autouse=True)
def _no_model_form(monkeypatch):
    monkeypatch.setattr(rounds, "model_form_sources", lambda *a, **k: ([], {}))


def _attempt(seed: int, undescribed: tuple[str, ...]):
    meter = SimpleNamespace(stage=lambda *a, **k: None, tail=0, windows=lambda n: None)
    fx = Fitter(sim=SimpleNamespace(robot=Robot(), dt=0.005), train=None, names=list(NAMES),
                described=dict(DESCRIBED), config=None, max_iter=8, nthread=1, warmup_s=0.0, meter=meter,
                undescribed=undescribed)
    fx.seed = seed
    return rounds.fit_attempt(fx, np.arange(M), dict(DESCRIBED))


SEEDS = range(40)


def test_an_interval_allowing_for_a_default_covers_the_truth_one_conditional_on_it_does_not():
    """Over the seeds where the log leaves mu open (the fit sends it back to its default), the
    interval of cg_x allowing for mu covers the truth about as often as a 95 % interval should; the
    interval conditional on mu = 0.8 covers it about half the time."""
    held, allowing = [], []
    for seed in SEEDS:
        plain, wide = _attempt(seed, ()), _attempt(seed, ("mu",))
        mu = plain.verdicts["mu"]
        if mu.determined or mu.tied_with:  # the log determined mu on this seed: not the setting
            continue
        assert mu.value == DESCRIBED["mu"] and wide.verdicts["mu"].value == DESCRIBED["mu"]
        for att, out in ((plain, held), (wide, allowing)):
            cg = att.verdicts["cg_x"]
            assert cg.changed
            lo, hi = cg.interval
            out.append((lo <= TRUTH["cg_x"] <= hi, hi - lo, cg))
        assert wide.verdicts["cg_x"].value == plain.verdicts["cg_x"].value  # the value is the fit's, unchanged
    assert len(held) >= 20, len(held)  # the setting arises on most seeds (27 of 40 when written)
    cover_held = np.mean([c for c, _, _ in held])
    cover_allowing = np.mean([c for c, _, _ in allowing])
    # measured when written: 0.93 allowing for mu, 0.48 held. A 95 % interval covers 85 % or more of
    # 27 with probability 0.99 under the binomial; selecting the seeds where mu looks undetermined
    # biases both a little (it prefers estimates of mu near the default)
    assert cover_allowing >= 0.85, cover_allowing
    assert cover_held <= 0.65, cover_held
    for (_, w_held, _), (_, w_allow, v) in zip(held, allowing):
        assert w_allow > w_held and v.allows_for == ["mu"]
        assert "allows for mu, which the description does not give" in v.reason
        assert v.to_json()["allows_for"] == ["mu"]


def test_a_described_parameter_is_the_users_statement_and_changes_nothing():
    """The same fit with mu given by the description: the interval is the conditional one, byte for
    byte, and says nothing of allowing for mu."""
    att = _attempt(3, ())
    v = att.verdicts["cg_x"]
    assert v.allows_for == [] and "allows_for" not in v.to_json() and "allows for" not in v.reason
    again = _attempt(3, ())
    assert again.verdicts["cg_x"].interval == v.interval


def test_the_undescribed_candidates_are_the_robot_keys_the_file_leaves_out():
    from mjtrack.calibrate.run import undescribed

    names = ["mu", "mu_ratio", "cg_x", "track_length", "drive_lag", "slope_x"]
    robot = Robot.from_dict({"track_gauge": 0.5, "mu": 0.7, "track_length": 0.6})
    # mu and the length are given; mu_ratio and a slope are not robot keys (the ratio follows the
    # sides' friction, a slope is the log's ground)
    assert undescribed(robot, names) == ("cg_x", "drive_lag")
    assert undescribed(Robot(), names) == ()  # built in full, in code: every value is stated


@pytest.mark.parametrize("names, words", [([], "no parameter named"), (["bogus"], "unknown parameter 'bogus'"),
                                          (["cg_x", "cg_x"], "named twice")])
def test_a_list_of_candidates_is_checked_as_params_is(names, words):
    """The Python API's list of candidates goes through the checks of --params: an empty list or
    an unknown name is refused in words before anything is simulated, not a crash deep in the fit."""
    from mjtrack.calibrate.run import calibrate
    from mjtrack.errors import InputError
    from mjtrack.io.logs import DriveLog

    t = np.arange(0.0, 6.0, 0.05)
    z = np.zeros_like(t)
    log = DriveLog(t=t, x=0.3 * t, y=z, yaw=z, v_left_cmd=z + 0.3, v_right_cmd=z + 0.3)
    with pytest.raises(InputError, match=words):
        calibrate(log, Robot.from_dict({"track_gauge": 0.4}), names=names, quiet=True)
