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


def fuzz(n: int):
    """Bounded, derandomized and seeded: the same examples on every run."""
    def wrap(test):
        return hypothesis.seed(20261123)(settings(max_examples=n, deadline=None, derandomize=True, database=None,
                                                  print_blob=False, suppress_health_check=list(HealthCheck))(test))
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


def test_help_texts_are_self_contained():
    from mjtrack.cli import COMMANDS

    for name in COMMANDS:
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            assert main([name, "--help"]) == 0
        assert "CONTRACTS" not in out.getvalue() and "§" not in out.getvalue(), name


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
