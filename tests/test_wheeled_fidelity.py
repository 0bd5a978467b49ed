"""The wheeled MuJoCo robot against the point-contact Coulomb reference (benchmarks/wheeled_fidelity.py):
every steady turn of the grid within 0.05 T/2 of the reference's ICRs, halving the step moves them by
less than 0.02 T/2, every side in ground contact, a steady window. The reference is independent
physics (mjtrack.models.coulomb: rigid planar body on Coulomb point contacts with Wong's loads; its
wheeled closed forms are checked in tests/test_wheels.py)."""

from __future__ import annotations

import functools

import pytest

from support.repo import BENCHMARKS, load_file


@functools.lru_cache(maxsize=2)
def _grid(quick: bool):
    bench = load_file(BENCHMARKS / "wheeled_fidelity.py", "wheeled_fidelity")
    return bench, bench.run(quick)


def _check(quick: bool, n_cases: int) -> None:
    bench, rows = _grid(quick)
    assert len(rows) == n_cases
    for r in rows:
        case = {k: r[k] for k in bench.CASE_KEYS}
        assert r["err"] <= bench.TOL_ERR, case  # NaN (no reference steady state) fails too
        assert r["dt_err"] < bench.TOL_DT, case
        assert r["contact_min"] >= bench.TOL_CONTACT and r["steady"], case


def test_quick_wheeled_grid_matches_the_point_contact_reference():
    """40 turns: Husky-, Warthog-, Jackal-like and a six-wheeler, pivot and R 1-10 m at 0.2 and
    2 m/s, cg +-0.1 B (the full grid's worst cases: benchmarks/results/wheeled_fidelity.json)."""
    _check(True, 40)


@pytest.mark.slow
def test_full_wheeled_grid_matches_the_point_contact_reference():
    """The full grid (8 robots, 2 and 3 wheels a side, 12-280 kg, pivot and R 0.5-10 m at 0.2, 0.7
    and 2 m/s, both directions, forward and reverse, cg_x -0.1/0/+0.1 B; about 10 min on one core)."""
    bench, _ = _grid(False)
    _check(False, sum(1 for _ in bench.cases(False)))
