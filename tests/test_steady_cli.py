"""mjtrack steady: a readable table by default, JSON with --json, a window that has not settled
said so, and the robot file's simulator settings used."""

import json

import pytest

from mjtrack.io.robot import Robot, write_robot
from support.cli import run_cli

SHORT = ["--settle", "0.2", "--window", "0.2"]


def test_default_is_a_table_and_json_is_the_same_numbers():
    table = run_cli(["steady", "--v-left", "0.3", "--v-right", "0.6", *SHORT])
    js = run_cli(["steady", "--v-left", "0.3", "--v-right", "0.6", *SHORT, "--json"])
    assert table.rc == js.rc == 0, table.err + js.err
    values = json.loads(js.out)
    with pytest.raises(json.JSONDecodeError):
        json.loads(table.out)
    rows = {line.split("  ")[0]: line for line in table.out.splitlines()}
    assert f"{values['y_l']:.6g}" in rows["y_l, left-track ICR"]
    assert f"{values['wz']:.6g}" in rows["wz (std)"]


def test_a_window_that_has_not_settled_says_so():
    """A 1 s drive lag under a 0.2 s settle: the tracks are still speeding up in the window."""
    slow = ["--robot", None, "--v-left", "0.3", "--v-right", "0.6", "--settle", "0.2", "--window", "0.4"]
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "lag.json"
        write_robot(Robot(drive_lag=1.0), path)
        slow[1] = path
        res = run_cli(["steady", *slow, "--json"])
        assert res.rc == 0, res.err
        assert json.loads(res.out)["unsettled"].startswith("not settled: ")
        assert "warning: not settled" in res.err and "lengthen --settle" in res.err
        table = run_cli(["steady", *slow])
        assert "unsettled: not settled" in table.out
    settled = run_cli(["steady", "--v-left", "0.3", "--v-right", "0.6", "--settle", "1", "--window", "0.4", "--json"])
    assert json.loads(settled.out)["unsettled"] is None and settled.err == ""


def test_the_robot_files_simulator_timestep_is_used(tmp_path):
    def y_l(simulator):
        path = tmp_path / "r.json"
        path.write_text(json.dumps({"track_gauge": 0.4, **({"simulator": simulator} if simulator else {})}))
        res = run_cli(["steady", "--robot", path, "--v-left", "0.3", "--v-right", "0.6", *SHORT, "--json"])
        assert res.rc == 0, res.err
        return json.loads(res.out)["y_l"]

    plain, coarse, again = y_l(None), y_l({"track_model": "rollers", "timestep": 0.004}), y_l({"timestep": 0.004})
    assert coarse != plain and coarse == again  # the recorded step changes the result, deterministically


def test_validate_scenarios_use_and_sweep_refuses_the_recorded_step(tmp_path):
    from mjtrack.cli import build_parser
    from mjtrack.commands.validate import source_from_args
    from support.cli import assert_usage_error

    plain, fitted = tmp_path / "plain.json", tmp_path / "fitted.json"
    plain.write_text(json.dumps({"track_gauge": 0.4}))
    fitted.write_text(json.dumps({"track_gauge": 0.4, "simulator": {"track_model": "rollers", "timestep": 0.004}}))
    logs = []
    for robot in (plain, fitted):
        args = build_parser().parse_args(["validate", "--scenario", "circle", "--duration", "0.4", "--robot", str(robot),
                                          "--out", str(tmp_path / "v")])
        logs.append(source_from_args(args)[0])
    assert logs[0].x[-1] != logs[1].x[-1]  # the recorded step is the one simulated
    (tmp_path / "grid.json").write_text(json.dumps({"v_left_cmd": [0.3], "v_right_cmd": [0.6]}))
    res = run_cli(["sweep", "--grid", tmp_path / "grid.json", "--robot", fitted, "--out", tmp_path / "s"])
    assert_usage_error(res, r"simulator settings timestep are not used by sweep")
    assert not (tmp_path / "s").exists()


def test_simulate_notes_that_a_measured_drive_input_is_not_used(tmp_path):
    """A simulated run has no logged track speeds: the key is named as unused, the log still written."""
    robot = tmp_path / "cal.json"
    robot.write_text(json.dumps({"track_gauge": 0.4, "simulator": {"drive_input": "measured"}}))
    res = run_cli(["simulate", "--scenario", "straight", "--duration", "0.2", "--robot", robot,
                   "--out", tmp_path / "run.csv"])
    assert res.rc == 0, res.err
    assert "simulator.drive_input 'measured'" in res.err and (tmp_path / "run.csv").exists()
    plain = tmp_path / "plain.json"
    plain.write_text(json.dumps({"track_gauge": 0.4}))
    res = run_cli(["simulate", "--scenario", "straight", "--duration", "0.2", "--robot", plain,
                   "--out", tmp_path / "run2.csv"])
    assert res.rc == 0 and "drive_input" not in res.err


def test_the_table_speaks_of_wheels_on_a_wheeled_robot():
    from mjtrack.commands.steady import _ROWS, steady_table

    values = {key: 0.1 for key, _, _ in _ROWS}
    wheels, tracks = steady_table(values, "wheels"), steady_table(values)
    assert "track" not in wheels and "roller" not in wheels
    assert "left wheel speed" in wheels and "wheels in contact" in wheels and "left-wheels ICR" in wheels
    assert "left track speed" in tracks and "rollers in contact" in tracks

