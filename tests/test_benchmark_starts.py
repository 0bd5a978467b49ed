"""benchmarks/real_robots.py --starts: two calibrations of one log agree in their parameters and in
their turning (the rule of the start comparison, on records written here)."""

from __future__ import annotations

from support.repo import load_benchmark


def _start(params: dict, yaw: list[tuple[float, float, float, int]]) -> dict:
    """A start record: values determined with a +-0.1 interval, and (lo, hi, calibrated, windows) yaw classes."""
    return {"parameters": params, "intervals": {n: [v - 0.1, v + 0.1] for n, v in params.items()},
            "determined": {n: {"determined": True} for n in params}, "mass": 50.0,
            "yaw_by_class": [{"class": [lo, hi], "measured": 0.45, "calibrated": c, "windows": n}
                             for lo, hi, c, n in yaw]}


def test_two_starts_that_turn_apart_do_not_agree_though_their_parameters_do():
    rr = load_benchmark("real_robots")
    a = _start({"mu": 0.80}, [(0.15, 0.5, 0.48, 28), (0.5, 1.0, 0.42, 37), (0.0, 0.15, 0.30, 6)])
    b = _start({"mu": 0.85}, [(0.15, 0.5, 0.43, 28), (0.5, 1.0, 0.43, 37), (0.0, 0.15, 0.50, 6)])
    got = rr.agreement(a, b)
    assert got["parameters_agree"] and got["turning_agrees"] is False and got["agree"] is False
    assert list(got["turning"]) == ["0.15 to 0.5", "0.5 to 1"]  # a class of 6 steady windows is not judged
    assert got["turning"]["0.15 to 0.5"]["within_gap"] is False and got["turning"]["0.5 to 1"]["within_gap"]
    b["yaw_by_class"][0]["calibrated"] = 0.46
    assert rr.agreement(a, b)["agree"] is True


def test_a_record_without_turning_is_judged_on_its_parameters():
    rr = load_benchmark("real_robots")
    a, b = _start({"mu": 0.8}, []), _start({"mu": 1.2}, [])
    del a["yaw_by_class"]
    got = rr.agreement(a, b)
    assert got["turning"] is None and got["turning_agrees"] is None and got["agree"] is False  # mu 0.8 vs 1.2
