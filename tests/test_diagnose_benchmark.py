"""The fast subset of benchmarks/diagnose_benchmark.py (the short logs: a slope on the large
robot, a near-noise command delay, a clean 30 s log at 50 Hz; and the wheeled robot's DRIVE-layout
logs, clean and command delay + speed scale, whose body transient carries on across the window
starts), run by the default test run; the whole benchmark (41 logs) is
``python benchmarks/diagnose_benchmark.py`` and ``-m slow`` here."""

from __future__ import annotations

import pytest

from support.repo import load_benchmark

bench = load_benchmark("diagnose_benchmark")


def _check(row):
    assert row["right"], row
    assert not row["extra"], row
    for p in row["params"]:
        assert p["covered"], p
        assert abs(p["rel_err"]) < 0.25, p


# cases 33 and 38 cost about 40 and 30 s of CPU: slow here, still in the benchmark's --fast subset
SLOW_CASES = (33, 38)


@pytest.mark.parametrize("case", [pytest.param(c, marks=(pytest.mark.slow,) if c in SLOW_CASES else ())
                                  for c in bench.FAST])
def test_fast_subset(case):
    _check(bench.run_case(bench.cases()[case]))


@pytest.mark.slow
def test_whole_benchmark_meets_the_targets():
    rows = [bench.run_case(c) for c in bench.cases()]
    s = bench.summarise(rows)
    assert s["named_right"] >= 0.95 * s["with_effect"]  # the logs above the detectability floor
    assert s["below_floor_fooled"] == 0 and s["below_floor"] <= 2  # below it: no wrong cause named
    assert s["clean_none"] == s["clean"]
    assert s["covered"] >= 0.9 * s["params"]
    assert s["median_abs_bias"] < 0.05


def test_below_floor_effect_without_speeds_is_warned_not_named():
    """A yaw-rate limit hit in one spin of a 60 s log without track speeds (case 29 on the fresh
    logs of --seed 1000: it acts in 1 of the 10 blocks): no blocked bootstrap can establish it, so
    the cause stays "none", but the pose's gain (54 %) is not kept from the user: a warning names
    the suggested effect and why it is not reported."""
    row = bench.run_case(bench.cases()[29], 1000)
    assert row["below_floor"] and row["floor"]["active"] < row["floor"]["need"], row["floor"]
    assert row["cause"] == "none" and not row["fooled"]
    assert row["warned"], row["warnings"]
    assert any("suggested by the pose" in w for w in row["warnings"]), row["warnings"]
