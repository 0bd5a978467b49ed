"""Effect families in physically different implementations, from two generators that share no code
with the diagnosis (:mod:`mjtrack.testing.implementations`): a lag on the track speed, a lag on the
drive force and a pure delay are each named by their family -- by the right effect, or reported as
a lag/delay tie with both estimates -- and never as the wrong effect alone, with no spurious effect
beside them. The default run diagnoses one log per implementation with the surrogate baseline; the
other generator's logs, the lag beside a centre-of-mass offset and the lag on a light robot are
``-m slow``; the whole table (both baselines) is ``python benchmarks/diagnose_implementations.py``.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from mjtrack.diagnose import diagnose
from mjtrack.testing.implementations import BY_NAME, GENERATORS, make_case_log, score

FAST = {("lag_speed", "B"), ("lag_force", "A"), ("dead_time", "B")}
DRIVE = ("lag_speed", "lag_force", "dead_time")


def _marks(name, generator):
    return () if (name, generator) in FAST else (pytest.mark.slow,)


def _diagnosed(name, generator):
    case = BY_NAME[name]
    log, robot = make_case_log(case, generator, seed=1)
    d = diagnose(log, robot, baseline="surrogate")
    return case, d, score(d, case)


def _check_right_or_tie(case, d, s):
    assert s["verdict"] in ("right", "tie"), (s, d.summary())
    assert not s["extra"] and not s["confused"], s
    for f in d.findings:  # a tie carries both estimates, each with its interval
        assert np.all(np.isfinite(f.estimate)), f.effect.name
        assert np.all(f.interval[:, 0] <= f.estimate) and np.all(f.estimate <= f.interval[:, 1]), f.effect.name
        for n in f.tied_with:
            assert n in {g.effect.name for g in d.findings}, (f.effect.name, n)


@pytest.mark.parametrize("name,generator", [pytest.param(n, g, marks=_marks(n, g)) for n in DRIVE for g in GENERATORS])
def test_drive_response_is_named_or_tied_never_wrong(name, generator):
    _check_right_or_tie(*_diagnosed(name, generator))


@pytest.mark.slow
@pytest.mark.parametrize("generator", GENERATORS)
@pytest.mark.parametrize("name", ["lag_cg", "lag_light"])
def test_lag_beside_another_cause_or_on_a_light_robot(name, generator):
    """The lag is not read as a delay without a tie, and nothing but the true causes is named."""
    _check_right_or_tie(*_diagnosed(name, generator))


def _fake(*findings):
    """A diagnosis as :func:`score` reads it, from (effect name, tied with) per finding: a finding
    tied with an earlier one is reported beside it, the others are chosen."""
    out = [SimpleNamespace(effect=SimpleNamespace(name=n), tied_with=list(t)) for n, t in findings]
    chosen = [f for i, f in enumerate(out) if not any(g.effect.name in f.tied_with for g in out[:i])]
    return SimpleNamespace(findings=out, chosen=chosen)


@pytest.mark.parametrize("findings,verdict", [
    ([("drive_lag", ())], "right"),
    ([("drive_delay", ("drive_lag",)), ("drive_lag", ("drive_delay",))], "tie"),
    ([("drive_delay", ())], "wrong"),  # a lag named a delay without a tie
    ([("drive_lag", ()), ("friction_scale", ())], "spurious"),
    ([("drive_delay", ()), ("friction_scale", ())], "wrong"),
    ([("cg_x", ())], "wrong"),
    ([], "missed"),
])
def test_scoring_of_a_lag(findings, verdict):
    """The truth side's verdicts on a speed lag (the scoring must be able to fail)."""
    assert score(_fake(*findings), BY_NAME["lag_speed"])["verdict"] == verdict
