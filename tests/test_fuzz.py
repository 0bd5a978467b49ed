"""Hostile input, property-based: random and malformed CSV logs, command tables, robot JSON and
grid JSON thrown at the readers and at the CLI (in-process ``mjtrack.cli.main``).

Properties: a reader returns a value or raises InputError with a one-line message; a command
exits 0 or 2 (never 1, never a traceback), prints one line on stderr when it exits 2, and
leaves no output and no temporary file behind when it refuses. Hypothesis runs derandomized
(the same examples every run) with bounded example counts, so the test is deterministic and
stays within its time budget.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import tempfile
from pathlib import Path

import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from mjtrack.cli import main  # noqa: E402
from mjtrack.errors import InputError  # noqa: E402
from mjtrack.io.logs import read_log  # noqa: E402
from mjtrack.io.robot import read_robot  # noqa: E402
from mjtrack.sweep import read_grid  # noqa: E402


def fuzz(n: int, *, shrink: bool = True):
    """Bounded, derandomized and seeded: the same examples on every run. ``shrink`` False: a failing
    example is reported as drawn (shrinking costs minutes where each example is a process run)."""
    phases = list(hypothesis.Phase) if shrink else [hypothesis.Phase.explicit, hypothesis.Phase.generate]

    def wrap(test):
        return hypothesis.seed(20261123)(settings(max_examples=n, deadline=None, derandomize=True, database=None,
                                                  print_blob=False, suppress_health_check=list(HealthCheck),
                                                  phases=phases)(test))
    return wrap


HOSTILE = ["", " ", "nan", "NaN", "inf", "-inf", "1e300", "-1e300", "1e309", "1e-320", "abc", "0x10", "1_0",
           "\u0661", '"', "'", "\x00", "1,2", "\n", "\ufeff1", "-0", "+5", "1e6", "1e10", "101", "-101", "1e7"]
NAMES = ["t", "v_left_cmd", "v_right_cmd", "x", "y", "yaw", "v_left", "v_right", "vx", "vy", "wz", "window",
         "z", "roll", "pitch", "extra", "", "t "]
REQUIRED = ["t", "v_left_cmd", "v_right_cmd", "x", "y", "yaw"]

cell = st.one_of(
    st.floats(min_value=-50, max_value=50).map(repr),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(min_value=-10**30, max_value=10**30).map(str),
    st.sampled_from(HOSTILE),
    st.text(max_size=4),
)


@st.composite
def csv_text(draw) -> str:
    """A CSV: mostly a well-formed log with hostile cells here and there, sometimes garbage."""
    kind = draw(st.integers(0, 9))
    if kind == 0:
        return draw(st.text(max_size=200))
    header = draw(st.lists(st.sampled_from(NAMES), max_size=10)) if kind == 1 else \
        REQUIRED + draw(st.lists(st.sampled_from(NAMES[6:15]), max_size=4, unique=True))
    n = draw(st.integers(0, 8))
    t0 = draw(st.floats(-5, 5))
    rows = []
    for i in range(n):
        row = [repr(t0 + 0.1 * i)] + [repr(draw(st.floats(-3, 3))) for _ in header[1:]]
        if draw(st.integers(0, 3)) == 0:  # one hostile cell
            j = draw(st.integers(0, len(header)))
            if j < len(row):
                row[j] = draw(cell)
            else:
                row.append(draw(cell))  # a ragged row
        rows.append(row)
    sep = draw(st.sampled_from([",", ",", ";"]))
    return "\n".join(sep.join(r) for r in [header, *rows]) + draw(st.sampled_from(["", "\n", "\r\n", "\n\n"]))


json_scalar = st.one_of(st.none(), st.booleans(), st.integers(-10**40, 10**40),
                        st.floats(allow_nan=False, allow_infinity=False), st.text(max_size=5),
                        st.sampled_from([1e300, -1e300, 1e-300, 0, -1, 0.5, 1.0, 2.0]))
json_value = st.recursive(json_scalar, lambda inner: st.lists(inner, max_size=3) |
                          st.dictionaries(st.text(max_size=4), inner, max_size=3), max_leaves=6)

ROBOT_KEYS = ["track_gauge", "track_length", "track_width", "sprocket_radius", "mass", "cg_x", "cg_y", "cg_z", "mu",
              "mu_left", "mu_right", "name"]
plausible_robot_value = st.one_of(st.floats(0.05, 2.0), st.sampled_from([0.0, -0.1, 1e300, 1e-300, 150.0, 1e8]),
                                  json_scalar)
robot_json = st.one_of(
    st.dictionaries(st.sampled_from(ROBOT_KEYS), plausible_robot_value, max_size=8).map(json.dumps),
    st.fixed_dictionaries({"track_gauge": st.floats(0.2, 1.0)},
                          optional={k: st.floats(0.01, 1.0) for k in ROBOT_KEYS[1:9]}).map(json.dumps),
    json_value.map(json.dumps),
    st.text(max_size=60),
)

GRID_KEYS = ["speed", "turn_radius", "v_left_cmd", "v_right_cmd", "mu", "cg_x", "mass", "track_gauge", "warp"]
grid_json = st.one_of(
    st.dictionaries(st.sampled_from(GRID_KEYS),
                    st.one_of(st.lists(st.one_of(st.floats(-3, 3), json_scalar), max_size=4), json_scalar),
                    max_size=5).map(json.dumps),
    json_value.map(json.dumps),
    st.text(max_size=60),
)


@contextlib.contextmanager
def workdir():
    with tempfile.TemporaryDirectory(prefix="mjtrack-fuzz-") as d:
        yield Path(d)


def run(argv: list[str]) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        rc = main([str(a) for a in argv])
    return rc, err.getvalue()


def check_refusal(rc: int, err: str, d: Path, inputs: set[str]) -> None:
    assert rc in (0, 2), err
    assert "Traceback" not in err
    if rc == 2:
        assert len(err.strip().splitlines()) == 1, err
        assert sorted(p.name for p in d.iterdir()) == sorted(inputs), "a refused command wrote something"
    assert not [p for p in d.rglob("*.tmp")], "temporary file left behind"


def reader_is_total(reader, path: Path) -> None:
    try:
        reader(path)
    except InputError as exc:
        assert "\n" not in str(exc) and str(path) in str(exc)


@fuzz(120)
@given(text=csv_text(), raw=st.booleans())
def test_logs_readers_and_cli(text, raw):
    with workdir() as d:
        log = d / "log.csv"
        if raw:  # the same text with invalid UTF-8 bytes in it
            log.write_bytes(text.encode("utf-8", "surrogatepass") + b"\xff\xfe")
        else:
            log.write_text(text, encoding="utf-8", newline="")
        reader_is_total(read_log, log)
        try:
            read_log(log)
            ok = True
        except InputError:
            ok = False
        rc, err = run(["export", log, "--format", "tum", "--out", d / "out.tum"])
        check_refusal(rc, err, d, {"log.csv"})
        assert (rc == 0) == ok
        if not ok:  # the heavy commands must refuse the same file at once
            for cmd in (["diagnose", log, "--robot", _robot(d), "--out", d / "diag"],
                        ["validate", log, "--robot", _robot(d), "--out", d / "val"]):
                rc, err = run(cmd)
                check_refusal(rc, err, d, {"log.csv", "robot.json"})
                assert rc == 2


def _robot(d: Path) -> Path:
    p = d / "robot.json"
    p.write_text('{"track_gauge": 0.4}')
    return p


@fuzz(60)
@given(text=csv_text())
def test_command_tables_for_simulate(text):
    """simulate --commands: bad tables refused; good ones (<= 0.5 s, a few hundred steps) simulated."""
    with workdir() as d:
        cmds = d / "cmds.csv"
        cmds.write_text(text.replace("v_left_cmd", "v_left_cmd").replace("x,", "x2,"), encoding="utf-8")
        rc, err = run(["simulate", "--commands", cmds, "--duration", "0.05", "--out", d / "sim.csv", "-q"])
        check_refusal(rc, err, d, {"cmds.csv"})
        if rc == 0:
            assert (d / "sim.csv").exists() and (d / "sim.json").exists()


@fuzz(80)
@given(text=robot_json)
def test_robot_descriptions(text):
    with workdir() as d:
        path = d / "robot.json"
        path.write_text(text, encoding="utf-8")
        reader_is_total(read_robot, path)
        rc, err = run(["steady", "--robot", path, "--v-left", "0.2", "--v-right", "0.3", "--settle", "0",
                       "--window", "0.01"])
        if rc == 1:
            # Known limit of the MuJoCo robot, not of input checking: with the centre of mass off
            # centre in both axes some plausible robots diverge while settling (e.g. T = L = 1 m,
            # cg (0.15, 0.15) m). That is an internal failure, one line, exit 1, nothing written.
            assert err.startswith("mjtrack steady: failed: simulation diverged") and err.count("\n") == 1, err
            rc = 0
        check_refusal(rc, err, d, {"robot.json"})


@fuzz(120)
@given(text=grid_json)
def test_grids(text, monkeypatch_module):
    with workdir() as d:
        path = d / "grid.json"
        path.write_text(text, encoding="utf-8")
        reader_is_total(read_grid, path)
        rc, err = run(["sweep", "--grid", path, "--out", d / "sweep", "--workers", "1"])
        check_refusal(rc, err, d, {"grid.json"})


@pytest.fixture(scope="module")
def monkeypatch_module():
    """Valid grids stop before the cluster: the fuzz is about parsing, the sweep is tested in test_sweep."""
    import mjtrack.sweep
    from mjtrack.sweep import SweepSummary

    mp = pytest.MonkeyPatch()
    mp.setattr(mjtrack.sweep, "run_sweep", lambda grid, out, **kw: SweepSummary(len(grid.cases), 0, 0, 0.0, 0.0, 0))
    yield
    mp.undo()


# -- the cases the issue names, as plain tests -------------------------------------------
def _log_text(**override) -> str:
    cols = {"t": ["0", "0.1", "0.2"], "v_left_cmd": ["1", "1", "1"], "v_right_cmd": ["1", "1", "1"],
            "x": ["0", "0.1", "0.2"], "y": ["0", "0", "0"], "yaw": ["0", "0", "0"]}
    for k, (row, value) in override.items():
        cols[k][row] = value
    return "\n".join(",".join(r) for r in [list(cols), *zip(*cols.values())]) + "\n"


@pytest.mark.parametrize("column, value, what", [
    ("v_left_cmd", "1e300", "m/s is beyond physical plausibility"),
    ("x", "2e6", "m is beyond physical plausibility"),
    ("t", "1e300", "s is beyond physical plausibility"),
    ("yaw", "-1e300", "rad is beyond physical plausibility"),
])
def test_implausible_values_are_refused_by_diagnose(tmp_path, column, value, what):
    (tmp_path / "log.csv").write_text(_log_text(**{column: (2, value)}))
    (tmp_path / "log.json").write_text('{"track_gauge": 0.4}')
    rc, err = run(["diagnose", tmp_path / "log.csv", "--out", tmp_path / "d"])
    assert rc == 2 and f"log.csv: line 4, column '{column}'" in err and what in err
    assert not (tmp_path / "d").exists()


@pytest.mark.parametrize("robot, match", [
    ('{"track_gauge": 1e300}', "'track_gauge' = 1e+300 m is beyond physical plausibility"),
    ('{"track_gauge": 0.4, "mass": 1e12}', "'mass' = 1e+12 kg is beyond"),
    ('{"track_gauge": 0.4, "mu": 50}', "'mu' = 50 - is beyond"),
    ('{"track_gauge": -1}', "must be a positive number"),
])
def test_implausible_robots_are_refused(tmp_path, robot, match):
    (tmp_path / "r.json").write_text(robot)
    with pytest.raises(InputError, match=re.escape(match)):
        read_robot(tmp_path / "r.json")


def test_unwritable_out_is_refused_before_the_work(tmp_path):
    """--out below a file, or with a name too long for the file system: exit 2 at once."""
    (tmp_path / "log.csv").write_text(_log_text())
    (tmp_path / "log.json").write_text('{"track_gauge": 0.4}')
    (tmp_path / "afile").write_text("")
    for out in (tmp_path / "afile" / "d", tmp_path / ("n" * 300)):
        for cmd in (["diagnose", tmp_path / "log.csv", "--out", out],
                    ["validate", tmp_path / "log.csv", "--out", out],
                    ["export", tmp_path / "log.csv", "--format", "tum", "--out", out],
                    ["simulate", "--scenario", "straight", "--out", Path(str(out) + ".csv")]):
            rc, err = run(cmd)
            assert rc == 2 and "cannot create" in err, (cmd, err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile", "log.csv", "log.json"]


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_read_only_out_folder_is_refused(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        (tmp_path / "log.csv").write_text(_log_text())
        rc, err = run(["export", tmp_path / "log.csv", "--format", "tum", "--out", ro / "x.tum"])
        assert rc == 2 and "not writable" in err
    finally:
        ro.chmod(0o755)


# What a help text must not lean on: a notes file outside the repository (an upper-case NAME.md),
# a section sign, an internal class or field name, or a bare equation number that names no source.
_NOT_IN_HELP = (re.compile(r"\b[A-Z]{4,}\.md\b"), re.compile("§"), re.compile(r"\bSimConfig\b"),
                re.compile(r"\b(lag_budget|slip_budget|belt_timeconst)\b"), re.compile(r"one-step lag"))
_BARE_EQUATION = re.compile(r"(?<![\w.])\(\d\.\d{1,2}\)")


def test_help_texts_are_self_contained():
    from mjtrack.cli import COMMANDS

    for name in COMMANDS:
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            assert main([name, "--help"]) == 0
        text = " ".join(out.getvalue().split())  # argparse wraps lines: join them
        for pattern in _NOT_IN_HELP:
            assert not pattern.search(text), (name, pattern.pattern)
        for m in _BARE_EQUATION.finditer(text):  # an equation number comes with its source
            near = text[max(0, m.start() - 80):m.end() + 80]
            assert "thesis" in near or re.search(r"\[[A-Z][A-Za-z-]+\]", near), (name, m.group())


# -- terrain specs (mjtrack/sim/terrain.py, --terrain) ------------------------------------
terrain_num = st.one_of(st.floats(-0.3, 0.3).map(repr), st.sampled_from(["0", "0.1", "-1", "1e300", "nan", "inf",
                                                                          "", "x", "1e-300", "3.2", "100"]))
patch = st.fixed_dictionaries({k: st.one_of(st.floats(-2, 2), json_scalar) for k in ("x", "y", "size_x", "size_y",
                                                                                      "mu")})
terrain_json = st.one_of(
    st.fixed_dictionaries({}, optional={
        "incline": st.one_of(st.fixed_dictionaries({"angle": st.one_of(st.floats(-0.3, 0.3), json_scalar)},
                                                   optional={"direction": st.one_of(st.floats(-4, 4), json_scalar)}),
                             json_value),
        "steps": st.one_of(st.lists(st.fixed_dictionaries({"height": st.one_of(st.floats(0, 0.1), json_scalar),
                                                           "x": st.one_of(st.floats(-2, 2), json_scalar)}),
                                    max_size=2), json_value),
        "patches": st.one_of(st.lists(patch, max_size=2), json_value),
        "hfield": st.one_of(st.fixed_dictionaries({"file": st.just("h.npy"), "size_x": st.floats(0.5, 4),
                                                   "size_y": st.floats(0.5, 4), "height": st.floats(0, 0.1)}),
                            json_value),
        "bogus": json_value}).map(json.dumps),
    json_value.map(json.dumps),
    st.binary(max_size=30).map(lambda b: b.decode("latin-1")),
)


@st.composite
def terrain_case(draw):
    """(spec with {d} for the folder, files to write: name -> bytes)."""
    kind = draw(st.sampled_from(["flat", "incline", "step", "hfield", "patches", "json", "junk"]))
    n = draw(st.integers(0, 5))
    nums = [draw(terrain_num) for _ in range(n)]
    files: dict[str, bytes] = {}
    heights = draw(st.sampled_from(["ok", "nan", "1d", "text", "big"]))
    import numpy as np

    buf = io.BytesIO()
    arr = {"ok": np.arange(16.0).reshape(4, 4) / 50, "nan": np.full((3, 3), np.nan), "1d": np.zeros(5),
           "big": np.full((2, 2), 1e300), "text": None}[heights]
    if arr is not None:
        np.save(buf, arr)
    files["h.npy"] = buf.getvalue() if arr is not None else b"not numpy"
    if kind == "flat":
        return "flat", files
    if kind in ("incline", "step"):
        return ":".join([kind, *nums]), files
    if kind == "hfield":
        return ":".join(["hfield", "{d}/h.npy", *nums]), files
    files["t.json"] = draw(terrain_json).encode("utf-8", "surrogatepass") + draw(st.sampled_from([b"", b"\xff"]))
    if kind == "patches":
        return "patches:{d}/t.json", files
    if kind == "json":
        return "{d}/t.json", files
    return draw(st.text(max_size=20)), files


@fuzz(100)
@given(case=terrain_case())
def test_terrain_specs(case):
    from mjtrack.sim.terrain import parse_terrain

    spec_t, files = case
    with workdir() as d:
        for name, data in files.items():
            (d / name).write_bytes(data)
        spec = spec_t.replace("{d}", str(d))
        try:
            parse_terrain(spec)
        except InputError as exc:
            assert "\n" not in str(exc)
        rc, err = run(["simulate", "--scenario", "straight", "--duration", "0.05", "--terrain", spec,
                       "--out", d / "sim.csv", "-q"])
        if rc == 1:  # the same known limit as for robots: a plausible terrain the MuJoCo robot diverges on
            assert err.startswith("mjtrack simulate: failed: simulation diverged") and err.count("\n") == 1, err
            rc = 0
        check_refusal(rc, err, d, set(files))


# -- command lines: every option of every command, random and extreme values, interrupts --------
# Each generated command line runs as a real process forked from a warm one (support.cli.Forker)
# under a 4 GB address-space cap. A run still going after LIMIT_S gets SIGINT, as a user would
# stop it; some runs get SIGINT or SIGTERM at a random moment. Properties: no hang (the process
# ends within GRACE_S of a signal), no traceback, no death by a signal or by memory, exit 0, 1, 2
# (one line) or 130 / 143 (one line), and the output is complete (exit 0) or absent (anything
# else; a sweep interrupted or failed in its work keeps only its resume state), with no temporary
# file left.
import shutil  # noqa: E402
import signal as _signal  # noqa: E402

LIMIT_S = 1.5  # [s] a run still going then is interrupted (valid long work is fine: it must stop)
GRACE_S = 4.0  # [s] from a signal to the end of the process, at most (measured under 0.5 s; slack for load)
EXTREME = ["1e300", "-1e300", "1e-300", "-1e-300", "nan", "inf", "-inf", "0", "-0", "-1", "1e308", "99999999999999999999",
           "abc", "", "0x10", "1_0", " 1", "1e", "--", "\u0661"]
PATHS = ["log.csv", "log.json", "cmds.csv", "robot.json", "grid.json", "patches.json", "terrain.json", "h.npy",
         "missing.csv", "", ".", "sub/", "/dev/null", "deep.json"]
TERRAINS = ["flat", "incline:0.1", "incline:0.1:1.5", "step:0.03:0.5", "hfield:h.npy:2:2:0.05", "patches:patches.json",
            "terrain.json", "incline:1e300", "incline:nan", "step:-1:0", "hfield:h.npy:1e9:1e9:0.1", "hfield:missing.npy:1:1:1",
            "patches:deep.json", "bogus:1", "deep.json", ""]
OUT = {"simulate": "o.csv", "import-bag": "o.csv", "export": "o.tum", "render": "o.mp4"}  # others: folder "O"
EXPECTED = {  # files a successful run leaves (besides what the inputs were)
    "simulate": ["o.csv", "o.json"], "import-bag": ["o.csv", "o.json"], "export": ["o.tum"], "render": ["o.mp4"],
    "demo": ["O/report.html", "O/metrics.json", "O/rollout.csv", "O/rollout.json"],
    "validate": ["O/report.html", "O/metrics.json"], "diagnose": ["O/diagnosis.json", "O/report.html"],
    "calibrate": ["O/robot.json", "O/calibration.json", "O/report.html"], "track": ["O/tracking.json", "O/tracking.png"],
    "thesis": ["O/thesis.json"], "sweep": ["O/sweep.csv", "O/sweep.json", "O/icr_map.png"], "steady": [],
}
RESUME_STATE = {"sweep": {"O", "O/sweep.partial.csv", "O/sweep.partial.json"}}


def _parsers() -> dict:
    import argparse

    from mjtrack.cli import build_parser

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices


def _values(action) -> st.SearchStrategy:
    """Values for one option: from its bounds (edges, just outside, typical), its choices, files."""
    from mjtrack.commands._common import OPTION_BOUNDS

    kind = getattr(action.type, "__name__", "")
    if action.choices:
        return st.sampled_from([*map(str, action.choices), "bogus"])
    if action.dest == "terrain":
        return st.sampled_from(TERRAINS)
    if kind in OPTION_BOUNDS or kind == "_horizon":
        b = OPTION_BOUNDS.get(kind) or OPTION_BOUNDS["horizon"]
        lo, hi = b.low, b.high
        edges = [lo, hi, hi + 1, lo - 1, (lo + hi) / 2, lo + (hi - lo) * 1e-3]
        typical = [0.05, 0.1, 0.3, 1, 2, 3, 5, 16, 32, 640, 480]
        numbers = st.one_of(st.sampled_from(edges + typical),
                            st.floats(lo, min(hi, lo + 10), allow_nan=False, allow_infinity=False))
        text = numbers.map(lambda v: str(int(v)) if b.integer and float(v).is_integer() else repr(v))
        return st.one_of(text, text, st.sampled_from(EXTREME + (["auto"] if kind == "_horizon" else [])))
    return st.one_of(st.sampled_from(PATHS), st.text(max_size=6))


@st.composite
def command_line(draw, commands=None) -> tuple[str, list[str], tuple[int, float] | None]:
    """(command, argv, interrupt): the required arguments mostly sensible, 0-4 other options with
    random or extreme values, sometimes a signal after a random delay."""
    parsers = _parsers()
    name = draw(st.sampled_from(sorted(commands or parsers)))
    p = parsers[name]
    argv = [name]
    for action in p._actions:  # positionals
        if not action.option_strings and action.dest not in ("help",) and action.nargs != 0:
            if action.nargs == "?" and draw(st.booleans()):
                continue
            argv.append(draw(st.sampled_from(["log.csv"] * 6 + ["cmds.csv", "missing.csv", "robot.json", ""])))
    if name == "simulate":
        argv += draw(st.sampled_from([["--scenario", "straight"], ["--scenario", "random_steps"],
                                      ["--commands", "cmds.csv"], []]))
    if name in ("validate", "render") and "log.csv" not in argv and draw(st.booleans()):
        argv += ["--scenario", "circle"]
    if name == "export":
        argv += ["--format", "tum"]
    if name == "sweep":
        argv += ["--grid", draw(st.sampled_from(["grid.json"] * 4 + ["deep.json", "robot.json", "missing.json"]))]
    if name != "steady" and draw(st.integers(0, 9)):
        argv += ["--out", OUT.get(name, "O")]
    if name == "steady":
        argv += ["--v-left", "0.3", "--v-right", "0.5"]
    optional = [a for a in p._actions if a.option_strings and a.dest not in ("help", "out", "grid", "format")]
    for action in draw(st.lists(st.sampled_from(optional), max_size=4, unique_by=lambda a: a.dest)):
        flag = draw(st.sampled_from(action.option_strings))
        if action.nargs == 0:
            argv.append(flag)
        else:
            value = draw(_values(action))
            argv += [f"{flag}={value}"] if value.startswith("-") else [flag, value]
    if name in ("validate", "render", "calibrate", "diagnose", "demo", "thesis", "track"):
        argv.append("-q")
    interrupt = draw(st.one_of(st.none(), st.none(), st.tuples(st.sampled_from([_signal.SIGINT, _signal.SIGTERM]),
                                                                  st.floats(0.1, LIMIT_S))))
    return name, argv, interrupt


@pytest.fixture(scope="module")
def forker():
    from support.cli import Forker

    with Forker() as fk:
        yield fk


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """The files command lines name: a short simulated log of a robot with a contact length, a
    command table, a robot, a 2-case grid, terrain files, a nested JSON."""
    import numpy as np

    d = tmp_path_factory.mktemp("fuzz-inputs")
    rc, err = run(["simulate", "--scenario", "random_steps", "--duration", "6", "--track-length", "0.5",
                   "--out", d / "log.csv", "-q"])
    assert rc == 0, err
    (d / "cmds.csv").write_text("t,v_left_cmd,v_right_cmd\n0,0.2,0.4\n0.5,-0.3,0.3\n")
    (d / "robot.json").write_text(json.dumps({"track_gauge": 0.4, "track_length": 0.5, "note": "fuzz"}))
    (d / "grid.json").write_text(json.dumps({"v_left_cmd": [0.3], "v_right_cmd": [0.4, 0.5]}))
    (d / "patches.json").write_text(json.dumps({"patches": [{"x": 1, "y": 0, "size_x": 1, "size_y": 1, "mu": 0.4}]}))
    (d / "terrain.json").write_text(json.dumps({"incline": {"angle": 0.05}, "steps": [{"height": 0.02, "x": 1.0}]}))
    np.save(d / "h.npy", np.random.default_rng(0).uniform(size=(20, 20)))
    (d / "deep.json").write_text("[" * 50_000)
    return d


def _listing(d: Path) -> set[str]:
    return {str(p.relative_to(d)) for p in d.rglob("*")}


def check_command_line(forker, inputs: Path, case, *, limit_s: float = LIMIT_S) -> tuple[str, int]:
    name, argv, interrupt = case
    with workdir() as d:
        for p in inputs.iterdir():
            shutil.copy(p, d / p.name)
        before = _listing(d)
        res = forker.run(argv, cwd=d, signal=interrupt, limit_s=limit_s, grace_s=GRACE_S)
        what = f"{argv} interrupt={interrupt}: rc {res.rc}, {res.seconds:.2f} s, stderr {res.err[-1500:]!r}"
        assert not res.killed, "hang: " + what
        assert res.rc in (0, 1, 2, 130, 143), what  # negative: died of a signal (a crash, the memory cap)
        assert "Traceback" not in res.err and "MemoryError" not in res.err, what
        lines = [ln for ln in res.err.splitlines() if ln.strip() and not ln.startswith("WARNING ")]
        if res.rc != 0:
            assert len(lines) == 1 and lines[0].startswith("mjtrack"), what
            kind = {1: ": failed: ", 2: ": error: "}.get(res.rc, ": interrupted by SIG")
            assert kind in lines[0], what
        if res.signalled_at is not None and res.rc in (130, 143):
            assert res.after_signal_s < GRACE_S, what
        new = _listing(d) - before
        assert not [n for n in new if n.endswith(".tmp") or "/." in "/" + n], "temporary file left: " + what
        if res.rc == 0:
            assert set(EXPECTED[name]) <= new, f"incomplete output {sorted(new)}: " + what
        elif res.rc in (1, 130, 143):  # interrupted or failed in the work: at most what a resume needs
            assert new <= RESUME_STATE.get(name, set()), f"partial output {sorted(new)}: " + what
        else:
            assert not new, f"output left by a refused run {sorted(new)}: " + what
        return name, res.rc


@fuzz(10, shrink=False)
@given(case=command_line(commands=["simulate", "steady", "export", "track", "diagnose", "render"]))
def test_command_lines_fast(forker, inputs, case):
    """The default run's sample: a few command lines of the quick commands (< 60 s)."""
    check_command_line(forker, inputs, case, limit_s=1.5)


FUZZ_COUNTS: dict[tuple[str, int], int] = {}


@pytest.mark.slow
@fuzz(int(os.environ.get("MJTRACK_FUZZ_LINES", "2000")), shrink=False)
@given(case=command_line())
def test_command_lines(forker, inputs, case):
    """2000 command lines over every command and option (MJTRACK_FUZZ_LINES sets another count)."""
    key = check_command_line(forker, inputs, case)
    FUZZ_COUNTS[key] = FUZZ_COUNTS.get(key, 0) + 1
    if sum(FUZZ_COUNTS.values()) % 100 == 0:
        print(f"\n{sum(FUZZ_COUNTS.values())} command lines: {dict(sorted(FUZZ_COUNTS.items()))}", flush=True)
