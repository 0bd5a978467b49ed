"""mjtrack sweep: grids, dask clusters, same numbers as `mjtrack steady`, resume after a kill."""

from __future__ import annotations

import contextlib
import csv
import json
import math
import os
import signal
import subprocess
import sys
import time

import pytest

from mjtrack.cli import main
from mjtrack.errors import InputError
from mjtrack.io.robot import Robot
from mjtrack.sweep import grid_from_dict, track_commands

SHORT = ["--settle", "0.3", "--window", "0.2"]  # short runs: the tests check plumbing, not physics
GRID = {"speed": [0.4, -0.6], "turn_radius": [0.5, None, -2.0], "mu": [0.5, 0.9]}  # 12 cases


# -- grids (no simulation) --------------------------------------------------------------
def test_grid_product_order_and_track_commands():
    g = grid_from_dict({"speed": [1.0, 2.0], "turn_radius": [0.5, None], "mass": [10, 30]}, base=Robot(track_gauge=0.4))
    assert len(g.cases) == 8
    assert [dict(c.values)["mass"] for c in g.cases[:2]] == [10.0, 30.0]  # last key fastest
    c = g.cases[0]  # v = 1, R = 0.5: w = 2, V_L,R = 1 -/+ 2 * 0.2
    assert (c.v_left_cmd, c.v_right_cmd) == pytest.approx((0.6, 1.4), abs=1e-15)
    assert c.robot.mass == 10.0 and c.robot.track_gauge == 0.4
    assert track_commands(1.0, None, 0.4) == (1.0, 1.0)
    # the no-slip turn radius of the commands, closed form: R = (T/2) (V_R + V_L) / (V_R - V_L)
    assert 0.2 * (1.4 + 0.6) / (1.4 - 0.6) == pytest.approx(0.5)


@pytest.mark.parametrize("grid, match", [
    ({}, "non-empty JSON object"),
    ([1, 2], "non-empty JSON object"),
    ({"speed": [1], "turn_radius": [1], "warp": [1]}, "unknown key 'warp'"),
    ({"speed": [1]}, "both 'speed' and 'turn_radius'"),
    ({"speed": [1], "turn_radius": [1], "v_left_cmd": [1]}, "not a mix"),
    ({"v_left_cmd": [1], "v_right_cmd": []}, "empty list"),
    ({"v_left_cmd": [1e300], "v_right_cmd": [1]}, "beyond a plausible track speed"),
    ({"speed": [1], "turn_radius": [0]}, "0 < |R|"),
    ({"speed": [1], "turn_radius": [0.001]}, "beyond a plausible track speed"),
    ({"speed": [1], "turn_radius": [1], "mu": ["high"]}, "entry 0: expected a finite number"),
    ({"speed": [1], "turn_radius": [1], "cg_x": [0.0, 5.0]}, "case 1 .*cg_x"),
    ({"v_left_cmd": [k / 10 for k in range(400)], "v_right_cmd": [k / 10 for k in range(400)], "mu": [0.1, 0.2]}, "at most"),
])
def test_bad_grids_are_refused(grid, match):
    with pytest.raises(InputError, match=match):
        grid_from_dict(grid, source="g.json")


def test_bad_grid_file_writes_nothing(tmp_path, capsys):
    (tmp_path / "g.json").write_text('{"speed": [1], "turn_radius": [1], "mu": [true]}')
    assert main(["sweep", "--grid", str(tmp_path / "g.json"), "--out", str(tmp_path / "o"), "--workers", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "g.json" in err and "'mu'" in err
    assert not (tmp_path / "o").exists()


# -- runs on dask clusters --------------------------------------------------------------
@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as c:
        yield c


@pytest.fixture(scope="module")
def swept(tmp_path_factory, cluster):
    """The 12-case grid on the test's 2-worker cluster (--scheduler) and on a new 1-worker one."""
    d = tmp_path_factory.mktemp("sweep")
    (d / "g.json").write_text(json.dumps(GRID))
    rc_a = main(["sweep", "--grid", str(d / "g.json"), "--out", str(d / "a"), "--scheduler",
                 cluster.scheduler_address, "-q", *SHORT])
    rc_b = main(["sweep", "--grid", str(d / "g.json"), "--out", str(d / "b"), "--workers", "1", "-q", *SHORT])
    assert (rc_a, rc_b) == (0, 0)
    return d


def _rows(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_sweep_outputs_do_not_depend_on_the_cluster(swept):
    a, b = (swept / "a" / "sweep.csv").read_bytes(), (swept / "b" / "sweep.csv").read_bytes()
    assert a == b
    rows = _rows(swept / "a" / "sweep.csv")
    assert len(rows) == 12 and [int(r["case"]) for r in rows] == list(range(12))
    assert list(rows[0])[:6] == ["case", "speed", "turn_radius", "mu", "v_left_cmd", "v_right_cmd"]
    for col in ("v_left", "v_right", "vx", "vy", "wz", "y_l", "y_r", "x_c"):
        assert col in rows[0]
    straight = [r for r in rows if r["turn_radius"] == ""]
    assert len(straight) == 4 and all(r["y_l"] == "" and r["x_c"] == "" for r in straight)  # undefined ICRs
    turning = [r for r in rows if r["turn_radius"] != ""]
    assert all(math.isfinite(float(r["y_l"])) for r in turning)
    js = json.loads((swept / "a" / "sweep.json").read_text())
    assert js["grid"] == {k: v for k, v in GRID.items()} and len(js["cases"]) == 12
    assert js["cases"][2]["y_l"] is None  # case 2 is straight: null, not NaN
    png = (swept / "a" / "icr_map.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 20_000


def test_sweep_numbers_are_those_of_steady(swept, capsys):
    """Case 6 = (speed -0.6, R 0.5, mu 0.5), run in a batch on a worker, against `mjtrack steady`."""
    row = _rows(swept / "a" / "sweep.csv")[6]
    assert (row["speed"], row["turn_radius"], row["mu"]) == ("-0.6", "0.5", "0.5")
    capsys.readouterr()
    assert main(["steady", "--v-left", row["v_left_cmd"], "--v-right", row["v_right_cmd"], "--mu", "0.5",
                 *SHORT, "--json"]) == 0
    steady = json.loads(capsys.readouterr().out)
    for k in ("v_left_cmd", "v_right_cmd", "v_left", "v_right", "vx", "vy", "wz", "y_l", "y_r", "x_c"):
        assert float(row[k]) == steady[k], k  # bit-identical: same model, same state, same steps


def test_sweep_resumes_from_a_cut_file(swept, cluster, capsys, terminal):
    """A sweep killed after 5 rows, the 6th half written: the rerun runs only the 7 missing cases."""
    full = (swept / "a" / "sweep.csv").read_text()
    lines = full.splitlines(keepends=True)
    out = swept / "resumed"
    out.mkdir()
    (out / "sweep.partial.json").write_text((swept / "a" / "sweep.json").read_text())  # a killed run left both
    # completion order is arbitrary: keep rows 7, 2, 9, 0, 11 and half of row 4
    (out / "sweep.partial.csv").write_text(lines[0] + "".join(lines[1 + k] for k in (7, 2, 9, 0, 11)) + lines[5][:30])
    capsys.readouterr()

    tty = terminal()
    with contextlib.redirect_stderr(tty):  # a terminal: the progress bar is drawn
        assert main(["sweep", "--grid", str(swept / "g.json"), "--out", str(out), "--scheduler",
                     cluster.scheduler_address, *SHORT]) == 0
    assert "sweep  [####################]  7/7  100%" in tty.getvalue()
    said = capsys.readouterr().out
    assert "12 cases (7 run on 2 workers" in said and "5 kept from an earlier run" in said
    assert (out / "sweep.csv").read_text() == full
    assert sorted(p.name for p in out.iterdir()) == ["icr_map.png", "sweep.csv", "sweep.json"]  # resume state gone


def test_resume_refuses_a_file_of_another_grid(swept, cluster, capsys):
    out = swept / "other"
    out.mkdir()
    (out / "sweep.partial.json").write_text((swept / "a" / "sweep.json").read_text())
    text = (swept / "a" / "sweep.csv").read_text().replace("\n0,0.4,0.5,0.5,", "\n0,0.4,0.5,0.7,", 1)
    (out / "sweep.partial.csv").write_text(text)
    assert main(["sweep", "--grid", str(swept / "g.json"), "--out", str(out), "--workers", "1", *SHORT]) == 2
    assert "case 0 was run with other grid values" in capsys.readouterr().err


def test_resume_refuses_other_settings(swept, capsys):
    """The same grid with another averaging window must not be mixed into the earlier rows."""
    out = swept / "settings"
    out.mkdir()
    for name in ("sweep.csv", "sweep.json"):
        (out / name.replace(".", ".partial.")).write_text((swept / "a" / name).read_text())
    before = (out / "sweep.partial.csv").read_bytes()
    assert main(["sweep", "--grid", str(swept / "g.json"), "--out", str(out), "--workers", "1",
                 "--settle", "0.3", "--window", "0.4"]) == 2
    assert "other settings (--window)" in capsys.readouterr().err
    assert (out / "sweep.partial.csv").read_bytes() == before


def test_a_finished_sweep_is_replaced_only_with_force(swept, cluster, capsys):
    """The overwrite rule: a folder holding a finished sweep is refused; --force replaces it, and
    discards a partial sweep of other settings instead of refusing it (a clean restart)."""
    out = swept / "done"
    out.mkdir()
    for name in ("sweep.csv", "sweep.json", "icr_map.png"):
        (out / name).write_bytes((swept / "a" / name).read_bytes())
    args = ["sweep", "--grid", str(swept / "g.json"), "--out", str(out), "--scheduler", cluster.scheduler_address, "-q",
            *SHORT]
    assert main(args) == 2
    assert f"{out / 'sweep.csv'}: exists; pass --force to replace it" in capsys.readouterr().err
    (out / "sweep.partial.json").write_text((swept / "a" / "sweep.json").read_text().replace('"window_s": 0.2',
                                                                                              '"window_s": 0.9'))
    (out / "sweep.partial.csv").write_text((swept / "a" / "sweep.csv").read_text())
    assert main([*args, "--force"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["icr_map.png", "sweep.csv", "sweep.json"]
    assert (out / "sweep.csv").read_bytes() == (swept / "a" / "sweep.csv").read_bytes()
    assert "12 cases (12 run" in capsys.readouterr().out  # nothing kept from the other settings


def test_resume_refuses_a_sweep_from_other_simulator_settings(swept, capsys):
    """A roller-chain sweep started under other settings (older sweep files kept only lag_budget, and ran
    without the belt and the principal axes) must not be mixed with rows of the current model."""
    out = swept / "old_rule"
    out.mkdir()
    doc = json.loads((swept / "a" / "sweep.json").read_text())
    config = doc.pop("sim_config")
    assert config["lag_budget"] == 0.01 and config["belt_timeconst"] == 0.01 and config["principal_axes"] is True
    doc["lag_budget"] = 0.01  # what an older sweep file recorded
    (out / "sweep.partial.json").write_text(json.dumps(doc))
    (out / "sweep.partial.csv").write_text((swept / "a" / "sweep.csv").read_text())
    before = (out / "sweep.partial.csv").read_bytes()
    assert main(["sweep", "--grid", str(swept / "g.json"), "--out", str(out), "--workers", "1", *SHORT]) == 2
    assert "other settings (sim_config)" in capsys.readouterr().err
    assert (out / "sweep.partial.csv").read_bytes() == before


def test_sweep_on_terrain_is_steady_on_terrain(tmp_path, cluster, capsys):
    (tmp_path / "g.json").write_text(json.dumps({"v_left_cmd": [0.3], "v_right_cmd": [0.5, 0.6]}))
    terrain = ["--terrain", "incline:0.1:1.0"]
    assert main(["sweep", "--grid", str(tmp_path / "g.json"), "--out", str(tmp_path / "o"), "--scheduler",
                 cluster.scheduler_address, "-q", *terrain, *SHORT]) == 0
    row = _rows(tmp_path / "o" / "sweep.csv")[1]
    assert json.loads((tmp_path / "o" / "sweep.json").read_text())["terrain"]["spec"] == "incline:0.1:1.0"
    capsys.readouterr()
    assert main(["steady", "--v-left", "0.3", "--v-right", "0.6", *terrain, *SHORT, "--json"]) == 0
    steady = json.loads(capsys.readouterr().out)
    for k in ("vx", "vy", "wz", "y_l", "y_r", "x_c"):
        assert float(row[k]) == steady[k], k
    flat = _rows(tmp_path / "o" / "sweep.csv")  # and the slope did change the motion
    assert main(["steady", "--v-left", "0.3", "--v-right", "0.6", *SHORT, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["vy"] != float(flat[1]["vy"])


def test_unreachable_scheduler_is_an_input_error(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("mjtrack.sweep.run.CONNECT_TIMEOUT_S", 2.0)  # nothing listens on port 9: no need to wait 10 s
    (tmp_path / "g.json").write_text(json.dumps({"v_left_cmd": [0.5], "v_right_cmd": [1.0]}))
    rc = main(["sweep", "--grid", str(tmp_path / "g.json"), "--out", str(tmp_path / "o"),
               "--scheduler", "tcp://127.0.0.1:9", *SHORT])
    assert rc == 2 and "cannot reach a dask scheduler" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()  # refused before anything, the resume state included, is written


@pytest.mark.slow
def test_sweep_killed_mid_run_resumes(tmp_path):
    """SIGKILL a real `python -m mjtrack sweep` after its first rows; the rerun completes the file and
    gives the bytes of an uninterrupted run."""
    grid = {"v_left_cmd": [0.2, 0.5, 0.8, 1.0], "v_right_cmd": [0.3, 0.9, 1.2]}
    (tmp_path / "g.json").write_text(json.dumps(grid))
    cmd = [sys.executable, "-m", "mjtrack", "sweep", "--grid", str(tmp_path / "g.json"), "--workers", "1", "-q",
           "--settle", "1", "--window", "1"]
    proc = subprocess.Popen([*cmd, "--out", str(tmp_path / "k")], start_new_session=True)
    csv_path = tmp_path / "k" / "sweep.partial.csv"
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and (not csv_path.exists() or csv_path.read_text().count("\n") < 3):
        time.sleep(0.2)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    n_before = csv_path.read_text().count("\n") - 1
    assert 2 <= n_before < 12
    assert subprocess.run([*cmd, "--out", str(tmp_path / "k")], capture_output=True).returncode == 0
    assert subprocess.run([*cmd, "--out", str(tmp_path / "full")], capture_output=True).returncode == 0
    assert (tmp_path / "k" / "sweep.csv").read_bytes() == (tmp_path / "full" / "sweep.csv").read_bytes()


def test_auto_chunk_size_gives_every_thread_two_tasks_and_caps_the_chunk():
    from mjtrack.sweep.run import MAX_CHUNK, auto_chunk_size

    assert auto_chunk_size(24, 2) == 6 and auto_chunk_size(24, 1) == 12
    assert auto_chunk_size(3, 8) == 1 and auto_chunk_size(1000, 2) == MAX_CHUNK
    for n, slots in [(1, 1), (7, 3), (50, 4), (1000, 16)]:  # every case in a chunk, no chunk above the cap
        size = auto_chunk_size(n, slots)
        assert 1 <= size <= MAX_CHUNK and size * 2 * slots >= n or size == MAX_CHUNK


def test_chunks_deal_the_cases_out_in_turn():
    """Every case in exactly one chunk, none above the size, and each chunk spans the grid (the
    fast, costly cases are not all in the last chunks)."""
    from mjtrack.sweep.run import _chunks

    for n, size in [(0, 3), (1, 4), (10, 4), (24, 6), (1000, 16)]:
        chunks = list(_chunks(list(range(n)), size))
        assert sorted(i for c in chunks for i in c) == list(range(n))
        assert all(1 <= len(c) <= size for c in chunks) and len(chunks) == -(-n // size)
    assert list(_chunks(list(range(10)), 4)) == [[0, 3, 6, 9], [1, 4, 7], [2, 5, 8]]


@pytest.mark.parametrize("radii", [[0.5, 1.0, 2.0, 3.0], [-2.0, -0.5, 0.5, 2.0]])
def test_icr_map_ticks_read_plain_numbers_and_the_title_says_simulated(radii):
    """Made-up rows (no simulation): the figure's words only."""
    import matplotlib.pyplot as plt

    from mjtrack.sweep.figure import icr_map_figure

    grid = grid_from_dict({"speed": [0.5], "turn_radius": radii}, base=Robot(track_gauge=0.4))
    records = [{"case": i, "y_l": 0.25, "y_r": -0.25, "x_c": 0.01} for i in range(len(radii))]
    fig = icr_map_figure(records, grid)
    try:
        fig.canvas.draw()
        labels = [t.get_text() for ax in fig.axes for axis in (ax.xaxis,)
                  for t in axis.get_majorticklabels() + axis.get_minorticklabels() if t.get_text()]
        assert labels and not [t for t in labels if "$" in t or "10^" in t or "times" in t], labels
        assert 1.0 in {float(t.replace("\u2212", "-")) for t in labels}  # every label a plain number
        assert fig._suptitle.get_text().startswith("Simulated ICRs of 4 steady states")
    finally:
        plt.close(fig)


@pytest.mark.parametrize("traction, side", [("tracks", "track"), ("wheels", "wheels")])
def test_icr_map_names_what_carries_a_side_and_shows_no_speeds_never_commanded(traction, side):
    """A wheeled robot's side ICRs are its wheels' (not a track's); one commanded speed has no colour
    bar spanning speeds nobody commanded, the title says the speed instead."""
    import matplotlib.pyplot as plt

    from mjtrack.sweep.figure import icr_map_figure

    base = Robot(track_gauge=0.5, traction=traction, **({"wheelbase": 0.5, "mass": 50.0} if traction == "wheels"
                                                       else {}))
    grid = grid_from_dict({"speed": [0.5], "turn_radius": [1.0, 2.0]}, base=base)
    records = [{"case": i, "y_l": 0.3, "y_r": -0.3, "x_c": 0.01} for i in range(2)]
    fig = icr_map_figure(records, grid)
    try:
        ylabels = [ax.get_ylabel() for ax in fig.axes if ax.get_ylabel()]
        assert ylabels[:2] == [f"left-{side} ICR y_l [m]", f"right-{side} ICR y_r [m]"]
        assert not any(ax.get_label() == "<colorbar>" for ax in fig.axes)
        assert "commanded speed 0.5 m/s" in fig._suptitle.get_text()
    finally:
        plt.close(fig)
