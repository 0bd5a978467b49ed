"""A time stated to users (README, a command's --help) agrees with the benchmark result it comes from.

Each statement names its benchmark; the test reads the stated range from the text with its own
pattern and the measured wall time from the benchmark's result file, and fails when the
measurement lies outside the range (a faster or slower program, or a stale sentence).
"""

from __future__ import annotations

import json
import re

import pytest

from support.repo import RESULTS, ROOT

WORDS = {"one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "ten": 10}
_COUNT = r"(one|two|three|four|five|ten|\d+)"
RANGE = re.compile(rf"\b{_COUNT} to {_COUNT} (minutes|seconds) on a? ?2[- ]core")


def demo_help() -> str:
    from mjtrack.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    return sub.choices["demo"].format_help()


def stated_minutes(text: str) -> tuple[float, float]:
    """The stated range in minutes ('one to three minutes', '30 to 60 seconds' on 2 cores)."""
    found = RANGE.findall(" ".join(text.split()))
    assert found, "no stated duration ('N to M minutes|seconds on 2 cores') found"
    assert len(set(found)) == 1, f"differing durations stated: {found}"
    lo, hi, unit = found[0]
    per_minute = 60.0 if unit == "seconds" else 1.0
    return tuple((WORDS[n] if n in WORDS else int(n)) / per_minute for n in (lo, hi))


@pytest.mark.parametrize("text, minutes", [("one to three minutes on a 2-core machine", (1, 3)),
                                           ("30 to 45 seconds on 2 cores", (0.5, 0.75))])
def test_the_stated_range_is_read_in_minutes_or_seconds(text, minutes):
    assert stated_minutes(text) == pytest.approx(minutes)


@pytest.mark.parametrize("where", ["README.md", "demo --help"])
def test_the_stated_demo_time_holds_the_benchmark(where):
    text = (ROOT / "README.md").read_text() if where == "README.md" else demo_help()
    lo, hi = stated_minutes(text)
    measured = json.loads((RESULTS / "bench_demo.json").read_text())["wall_s"] / 60
    assert lo <= measured <= hi, f"{where} says {lo:g} to {hi:g} min; bench_demo.json measured {measured:.2f} min"
