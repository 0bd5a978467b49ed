"""What a user types or does cannot crash mjtrack, hang it, exhaust the machine or leave half a
result: option bounds, JSON limits, robot keys, overwrites, output transactions, chunked
rollouts, work estimates and interrupts (SIGINT / SIGTERM on real processes)."""

from __future__ import annotations

import json
import logging
import os
import re
import signal
import time
from pathlib import Path

import numpy as np
import pytest

from support.cli import Forker, run_cli
from mjtrack.errors import InputError


def one_error_line(res, *patterns: str) -> str:
    """Exit 2 and exactly one line on stderr matching every pattern; no traceback."""
    assert res.rc == 2, (res.rc, res.err)
    lines = res.err.strip().splitlines()
    assert len(lines) == 1, res.err
    for p in patterns:
        assert re.search(p, lines[0]), (p, lines[0])
    return lines[0]


@pytest.fixture(scope="module")
def forker():
    with Forker() as fk:
        yield fk


# -- option bounds: one table, every command, before any work ----------------------------
@pytest.mark.parametrize("argv, pattern", [
    (["steady", "--v-left", "1e300", "--v-right", "0.5"], r"--v-left: 1e300 is out of range: .* \[-100, 100\] m/s"),
    (["steady", "--v-left", "-1e300", "--v-right", "0.5"], r"--v-left: -1e300 is out of range"),
    (["steady", "--v-left", "1000", "--v-right", "0.5"], r"--v-left: 1000 is out of range"),
    (["steady", "--v-left", "0.5", "--v-right", "0.5", "--settle", "1e12"], r"--settle: 1e12 is out of range"),
    (["track", "--laps", "1000000000000", "--out", "T"], r"--laps: 1000000000000 is out of range"),
    (["track", "--scenario", "circle", "--speed", "1e300", "--out", "T"], r"--speed: 1e300 is out of range"),
    (["render", "log.csv", "--width", "1000000", "--out", "r.mp4"], r"--width: 1000000 is out of range: .*\[16, 7680\] px"),
    (["render", "log.csv", "--width", "641", "--out", "r.mp4"], r"--width: 641 is out of range: an even"),
    (["diagnose", "log.csv", "--folds", "1000000000", "--out", "D"], r"--folds: 1000000000 is out of range"),
    (["sweep", "--grid", "g.json", "--out", "W", "--workers", "100000"], r"--workers: 100000 is out of range"),
    (["simulate", "--scenario", "straight", "--seed", "-1", "--out", "s.csv"], r"--seed: -1 is out of range"),
    (["simulate", "--scenario", "straight", "--mass", "1e12", "--out", "s.csv"], r"--mass: 1e12 is out of range"),
    (["simulate", "--scenario", "straight", "--duration", "nan", "--out", "s.csv"], r"--duration: must be finite"),
    (["calibrate", "log.csv", "--threads", "0", "--out", "C"], r"--threads: 0 is out of range"),
])
def test_out_of_range_options_are_one_line_usage_errors(tmp_path, argv, pattern):
    res = _in(tmp_path, argv)
    one_error_line(res, pattern, r"^mjtrack \S+: error: argument ")
    assert list(tmp_path.iterdir()) == []


def _in(folder: Path, argv: list[str]):
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        return run_cli(argv)
    finally:
        os.chdir(cwd)


def test_every_numeric_option_is_bounded():
    """Every option that takes a number goes through the bounds table (no bare float/int)."""
    import argparse

    from mjtrack.cli import build_parser
    from mjtrack.commands._common import OPTION_BOUNDS

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    unbounded = [f"{name} {action.option_strings} ({action.type})"
                 for name, p in sub.choices.items() for action in p._actions
                 if action.type is not None and action.type not in (str, Path)
                 and getattr(action.type, "__name__", "") not in (*OPTION_BOUNDS, "_horizon")]
    assert unbounded == []
    assert sum(1 for p in sub.choices.values() for a in p._actions
               if getattr(a.type, "__name__", "") in OPTION_BOUNDS) > 50  # they are there


def test_work_estimates_refuse_before_spending(tmp_path):
    # a closed loop too short to control, and one too long to simulate
    one_error_line(_in(tmp_path, ["track", "--speed", "100", "--out", "T"]), r"less than 10 control periods")
    one_error_line(_in(tmp_path, ["track", "--speed", "0.001", "--laps", "1000", "--out", "T"]),
                   r"time steps of .*; at most 2e\+06")
    # a steady state of more steps than one rollout takes
    one_error_line(_in(tmp_path, ["steady", "--v-left", "0.5", "--v-right", "0.6", "--settle", "80000"]),
                   r"--settle 80000 s \+ --window 2 s at the .* time steps; at most 2e\+06")
    # a rollout longer than the step budget
    one_error_line(_in(tmp_path, ["simulate", "--scenario", "straight", "--duration", "50000", "--out", "s.csv"]),
                   r"time steps; one rollout takes at most")
    assert list(tmp_path.iterdir()) == []


def test_rollout_memory_is_estimated(monkeypatch):
    from mjtrack.io.robot import Robot
    from mjtrack.sim import rollout
    from mjtrack.sim.builder import build_model
    from mjtrack.sim.config import SimConfig

    model = build_model(Robot(), SimConfig())
    per_step = 8 * (2 * model.nu + model.nsensordata + __import__("mujoco").mj_stateSize(model, rollout.STATE_SPEC))
    assert rollout.rollout_bytes(model, 3, 100) == 3 * 100 * per_step
    monkeypatch.setattr("mjtrack.resources.available_memory", lambda: 1e6)  # a machine with 1 MB free
    with pytest.raises(InputError, match=r"needs about .* of memory; at most 0.0008 GB here"):
        rollout.check_rollout(model, 1, 10_000)


def test_diagnose_folds_are_bounded_by_the_log(tmp_path):
    _in(tmp_path, ["simulate", "--scenario", "straight", "--duration", "1", "--log-rate", "10", "--out", "log.csv",
                   "--track-length", "0.5"])
    one_error_line(_in(tmp_path, ["diagnose", "log.csv", "--folds", "900", "--out", "D"]),
                   r"900 folds: the log's 11 samples make at most 5")
    assert not (tmp_path / "D").exists()


def test_negative_numbers_are_values_and_usage_errors_are_one_line(tmp_path):
    res = _in(tmp_path, ["steady", "--v-left", "-0.2", "--v-right", "0.2", "--settle", "0", "--window", "0.02"])
    assert res.rc == 0, res.err
    one_error_line(_in(tmp_path, ["steady", "--v-left", "0.1"]), r"required: --v-right")
    one_error_line(_in(tmp_path, ["simulate", "--scenario", "nope", "--out", "x.csv"]), r"invalid choice: 'nope'")
    # argparse drops a "--" value and hands the option an empty list: refused, not a traceback
    one_error_line(_in(tmp_path, ["steady", "--v-left", "0.1", "--v-right", "0.2", "--settle=--"]),
                   r"--settle: expected one value, got '--'")


@pytest.mark.parametrize("path", ["", ".", "logs/"])
def test_a_log_path_that_names_no_file_is_refused(path):
    from mjtrack.io.logs import robot_path_for

    with pytest.raises(InputError, match="not a file name"):
        robot_path_for(path)


# -- JSON readers ---------------------------------------------------------------------------
def test_deep_and_large_json_files_are_refused_in_one_line(tmp_path):
    (tmp_path / "deep.json").write_text("[" * 100_000)
    (tmp_path / "deep2.json").write_text(json.dumps({"track_gauge": 0.4, "x": [[[[[[[[1]]]]]]]]}))
    (tmp_path / "big.json").write_text(json.dumps({"track_gauge": 0.4, "note": "x" * (1 << 20)}))
    steady = ["steady", "--v-left", "0.5", "--v-right", "0.6", "--robot"]
    one_error_line(_in(tmp_path, [*steady, "deep.json"]), r"deep.json: nested more than 1000 deep")
    one_error_line(_in(tmp_path, [*steady, "deep2.json"]), r"deep2.json: nested 9 deep; a robot description is nested "
                                                           r"at most 6 deep")
    one_error_line(_in(tmp_path, [*steady, "big.json"]), r"big.json: larger than 1,048,576 bytes")
    one_error_line(_in(tmp_path, ["simulate", "--scenario", "straight", "--terrain", "deep.json", "--out", "s.csv"]),
                   r"--terrain deep.json: deep.json: nested more than 1000 deep")
    one_error_line(_in(tmp_path, ["simulate", "--scenario", "straight", "--terrain", "patches:deep2.json",
                                  "--out", "s.csv"]), r"nested 9 deep; a terrain file is nested at most 3 deep")
    one_error_line(_in(tmp_path, ["sweep", "--grid", "deep.json", "--out", "W"]), r"deep.json: nested more than 1000")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.json", "deep.json", "deep2.json"]


def test_grid_values_must_be_lists(tmp_path):
    from mjtrack.sweep import grid_from_dict

    with pytest.raises(InputError, match=r"key 'speed': expected a list of values, got 0.5 \(write \[0.5\] for one"):
        grid_from_dict({"speed": 0.5, "turn_radius": [1.0]}, source="g.json")
    with pytest.raises(InputError, match=r"key 'mu': expected a list of values, got \{"):
        grid_from_dict({"speed": [0.5], "turn_radius": [1.0], "mu": {"a": 1}}, source="g.json")


def test_terrain_sizes_are_refused_before_the_data_is_read(tmp_path):
    import imageio.v3 as iio

    iio.imwrite(tmp_path / "h.png", np.zeros((1001, 1000), dtype=np.uint8))
    np.save(tmp_path / "h.npy", np.zeros((2000, 600), dtype=np.float32))
    (tmp_path / "many.json").write_text(json.dumps({"patches": [{"x": i, "y": 0, "size_x": 0.5, "size_y": 0.5,
                                                                 "mu": 0.5} for i in range(300)]}))
    for spec, what in [("hfield:h.png:10:10:0.1", r"1001 x 1000 = 1e\+06 samples would take about 0.06 GB"),
                       ("hfield:h.npy:10:10:0.1", r"2000 x 600 = 1.2e\+06 samples"),
                       ("patches:many.json", r"300 steps and patches; at most 256")]:
        one_error_line(_in(tmp_path, ["simulate", "--scenario", "straight", "--terrain", spec, "--out", "s.csv"]), what)


# -- robot keys -------------------------------------------------------------------------------
@pytest.mark.parametrize("key, known", [("drive_lags", "drive_lag"), ("Mass", "mass"), ("track_gauge_m", "track_gauge"),
                                        ("mu_lef", "mu_left"), ("wheel_radiuss", "wheel_radius")])
def test_a_misspelt_robot_key_is_refused(tmp_path, key, known):
    from mjtrack.io.robot import read_robot

    (tmp_path / "r.json").write_text(json.dumps({"track_gauge": 0.4, key: 0.3}))
    with pytest.raises(InputError, match=rf"r.json: key '{key}': did you mean '{known}'\?"):
        read_robot(tmp_path / "r.json")


def test_metadata_keys_are_kept_and_listed_once(tmp_path, caplog):
    from mjtrack.io import robot as robot_io

    doc = {"track_gauge": 0.4, "robot": "husky", "note": "poses from ICP", "sample_rate_hz": 20.0,
           "wheel_count": 4, "terrain": "boreal trail", "traction": "wheels", "wheel_radius": 0.16, "wheelbase": 0.5,
           "wheels_per_side": 2}
    (tmp_path / "r.json").write_text(json.dumps(doc))
    with caplog.at_level(logging.WARNING, logger="mjtrack.io.robot"):
        r = robot_io.read_robot(tmp_path / "r.json")
        robot_io.read_robot(tmp_path / "r.json")  # the same file again (another stage): no second line
    lines = [rec.getMessage() for rec in caplog.records]
    assert lines == [f"{tmp_path / 'r.json'}: key(s) robot, note, sample_rate_hz, wheel_count not used by mjtrack; "
                     "kept in the description"]
    assert {k: r.to_dict()[k] for k in doc if k != "wheel_radius"} == {k: v for k, v in doc.items()
                                                                        if k != "wheel_radius"}  # round trip
    assert r.sprocket_radius == 0.16  # wheel_radius is its alias


def test_a_data_set_description_is_accepted_with_one_warning(caplog, monkeypatch):
    from mjtrack.io import robot as robot_io

    monkeypatch.setattr(robot_io, "_warned", set())  # as in a fresh process
    path = Path(__file__).with_name("data") / "marmotte_excerpt.json"
    with caplog.at_level(logging.WARNING, logger="mjtrack.io.robot"):
        robot = robot_io.read_robot(path)
    assert robot.track_gauge == 0.592723 and robot.traction == "tracks"
    assert [r.getMessage().split(": ", 1)[1] for r in caplog.records] == [
        "key(s) robot, sample_rate_hz, note not used by mjtrack; kept in the description"]


# -- overwrites and transactions --------------------------------------------------------------
def test_existing_outputs_are_refused_without_force(tmp_path):
    sim = ["simulate", "--scenario", "straight", "--duration", "0.2", "--out", "s.csv", "-q"]
    assert _in(tmp_path, sim).rc == 0
    before = (tmp_path / "s.csv").read_bytes()
    one_error_line(_in(tmp_path, sim), r"s.csv: exists; pass --force to replace it")
    (tmp_path / "s.csv").write_text("mine\n")
    assert _in(tmp_path, [*sim, "--force"]).rc == 0 and (tmp_path / "s.csv").read_bytes() == before
    (tmp_path / "t.tum").write_text("keep\n")
    one_error_line(_in(tmp_path, ["export", "s.csv", "--format", "tum", "--out", "t.tum"]), r"t.tum: exists; pass --force")
    assert (tmp_path / "t.tum").read_text() == "keep\n"
    assert _in(tmp_path, ["export", "s.csv", "--format", "tum", "--out", "t.tum", "--force"]).rc == 0


def test_force_is_in_every_writing_command_help():
    from mjtrack.cli import COMMANDS

    for name in COMMANDS:
        res = run_cli([name, "--help"])
        assert ("--force" in res.out) == (name != "steady"), name


def test_a_failed_command_leaves_nothing(tmp_path):
    from mjtrack.io import atomic

    out = tmp_path / "new" / "deeper"
    (tmp_path / "old.txt").write_text("old")
    with pytest.raises(RuntimeError), atomic.transaction() as tx:
        atomic.atomic_write_text(out / "a.txt", "a")
        atomic.atomic_write_text(out / "keep.txt", "k")
        tx.keep(out / "keep.txt")
        atomic.atomic_write_text(out / "b.txt", "b")
        raise RuntimeError("half-way")
    assert sorted(p.name for p in out.iterdir()) == ["keep.txt"]
    with pytest.raises(RuntimeError), atomic.transaction():
        atomic.atomic_write_text(tmp_path / "x" / "a.txt", "a")
        raise RuntimeError
    assert sorted(p.name for p in tmp_path.iterdir()) == ["new", "old.txt"]  # the created folder went too
    with atomic.transaction(), pytest.raises(InputError, match="old.txt: exists; pass force=True"):
        atomic.atomic_write_text(tmp_path / "old.txt", "new")
    assert (tmp_path / "old.txt").read_text() == "old"


# -- chunked rollouts ---------------------------------------------------------------------------
def test_chunked_rollouts_give_the_bytes_of_one_call(monkeypatch):
    """A log simulated in chunks of 137 steps equals the one-call log byte for byte, and each
    chunk's last state carries the sensors evaluated at that state (checked independently by
    mj_forward on the returned states)."""
    import mujoco

    from mjtrack.io.logs import log_to_csv_text
    from mjtrack.io.robot import Robot
    from mjtrack.sim import rollout
    from mjtrack.sim.builder import build_model, control_matrix
    from mjtrack.sim.config import SimConfig
    from mjtrack.sim.scenarios import scenario_commands

    robot = Robot(cg_x=0.05)
    table, duration = scenario_commands("random_steps", robot, duration=3.0, seed=7)
    chunked_log = log_to_csv_text(rollout.drive_log(robot, table, duration=duration))
    original = rollout.aligned_rollout

    def one_call(*args, **kwargs):
        kwargs["chunk_steps"] = 10**9
        return original(*args, **kwargs)

    monkeypatch.setattr(rollout, "aligned_rollout", one_call)
    assert log_to_csv_text(rollout.drive_log(robot, table, duration=duration)) == chunked_log
    monkeypatch.undo()

    model = build_model(robot, SimConfig())
    s0 = rollout.settled_state(model)
    commands = np.repeat(np.random.default_rng(3).uniform(-1, 1, (6, 2)), 70, axis=0)  # 420 steps
    control = (commands @ control_matrix(model).T)[None]
    data = mujoco.MjData(model)
    st1, sd1 = rollout.aligned_rollout(model, data, s0[None], control, chunk_steps=137)
    st2, sd2 = rollout.aligned_rollout(model, mujoco.MjData(model), s0[None], control, chunk_steps=10**9)
    assert st1.tobytes() == st2.tobytes() and sd1.tobytes() == sd2.tobytes()
    check = mujoco.MjData(model)
    for k in (0, 135, 136, 137, 273, 274, 419):  # around the chunk ends (136 = the first chunk's last state)
        mujoco.mj_setState(model, check, st1[0, k], rollout.STATE_SPEC)
        mujoco.mj_forward(model, check)
        pos = slice(int(model.sensor("body_pos").adr[0]), int(model.sensor("body_pos").adr[0]) + 3)
        assert np.array_equal(check.sensordata[pos], sd1[0, k, pos]), k


# -- interrupts on real processes ---------------------------------------------------------------
@pytest.mark.parametrize("sig, status", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_an_interrupted_long_rollout_stops_at_once(tmp_path, forker, sig, status):
    """simulate --duration 3000 (a 600 000-step rollout): the signal is acted on within about a
    second (the chunk in progress), one line, nothing written."""
    res = forker.run(["simulate", "--scenario", "random_steps", "--duration", "3000", "--out", "s.csv"],
                     cwd=tmp_path, signal=(sig, 2.0))
    assert res.rc == status and not res.killed, res
    assert res.err.strip() == f"mjtrack simulate: interrupted by {signal.Signals(sig).name}"
    # measured 0.05-0.3 s alone, 1.70 s at load 6 on 2 cores beside a second test worker (the chunk in
    # progress gets half a core); the whole rollout would take minutes, so 3 s still catches a missed signal
    assert res.after_signal_s < 3.0, res.after_signal_s
    assert list(tmp_path.iterdir()) == []


def test_an_interrupted_command_rolls_back_what_it_wrote(tmp_path, forker):
    """track writes tracking.json, then renders tracking.png: an interrupt in between leaves
    neither (the folder it created goes too)."""
    results = []
    for delay in (0.5, 1.5, 3.0):
        res = forker.run(["track", "--scenario", "circle", "--laps", "1", "--out", f"T{delay}"], cwd=tmp_path,
                         signal=(signal.SIGINT, delay))
        results.append(res.rc)
        assert res.rc in (0, 130) and not res.killed, res
        assert res.rc == 0 or res.err.strip() == "mjtrack track: interrupted by SIGINT", res.err
        if res.rc == 130:
            assert not (tmp_path / f"T{delay}").exists()
        else:
            assert sorted(p.name for p in (tmp_path / f"T{delay}").iterdir()) == ["tracking.json", "tracking.png"]
    assert 130 in results
    assert not [p for p in tmp_path.rglob("*") if p.name.startswith(".")]


@pytest.mark.slow
def test_an_interrupted_sweep_resumes_to_the_same_bytes(tmp_path):
    """Ctrl-C (SIGINT to the process group, as a terminal sends it) during a sweep on a local cluster:
    one line, exit 130, no dask noise; the folder holds only the resume state; the rerun completes
    it to the bytes of an uninterrupted run."""
    import subprocess
    import sys

    (tmp_path / "g.json").write_text(json.dumps({"v_left_cmd": [0.2, 0.5, 0.8, 1.0], "v_right_cmd": [0.3, 0.9, 1.2]}))
    cmd = [sys.executable, "-m", "mjtrack", "sweep", "--grid", "g.json", "--workers", "2", "-q", "--settle", "1",
           "--window", "1"]
    proc = subprocess.Popen([*cmd, "--out", "k"], cwd=tmp_path, start_new_session=True, stderr=subprocess.PIPE,
                            text=True)
    partial = tmp_path / "k" / "sweep.partial.csv"
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and (not partial.exists() or partial.read_text().count("\n") < 3):
        time.sleep(0.1)
    t0 = time.monotonic()
    os.killpg(proc.pid, signal.SIGINT)
    err = proc.communicate(timeout=60)[1]
    assert time.monotonic() - t0 < 3.0
    assert proc.returncode == 130 and err.strip().splitlines() == [
        "mjtrack sweep: interrupted by SIGINT; the finished cases are kept: run the same command again to resume"], err
    assert sorted(p.name for p in (tmp_path / "k").iterdir()) == ["sweep.partial.csv", "sweep.partial.json"]
    rerun = subprocess.run([*cmd, "--out", "k"], cwd=tmp_path, capture_output=True, text=True)
    assert rerun.returncode == 0 and "kept from an earlier run" in rerun.stdout, rerun.stderr
    assert sorted(p.name for p in (tmp_path / "k").iterdir()) == ["icr_map.png", "sweep.csv", "sweep.json"]
    full = subprocess.run([*cmd, "--out", "full"], cwd=tmp_path, capture_output=True, text=True)
    assert full.returncode == 0
    assert (tmp_path / "k" / "sweep.csv").read_bytes() == (tmp_path / "full" / "sweep.csv").read_bytes()
