"""Every command that simulates takes a wheeled robot file (a small Husky-like robot)."""

from __future__ import annotations

import csv
import json
import math

import pytest

from support.cli import assert_usage_error, run_cli

WHEELED = {"traction": "wheels", "track_gauge": 0.555, "sprocket_radius": 0.165, "wheelbase": 0.512,
           "wheels_per_side": 2, "mass": 50.0, "cg_x": 0.02, "cg_z": 0.2, "track_width": 0.11}


@pytest.fixture(scope="module")
def robot_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("wheels") / "husky.json"
    path.write_text(json.dumps(WHEELED))
    return path


def simulated(robot_file, folder, seconds: float):
    """A random-steps log of the robot file: ``mjtrack simulate`` into ``folder/log.csv``."""
    out = folder / "log.csv"
    res = run_cli(["simulate", "--scenario", "random_steps", "--robot", robot_file, "--duration", seconds, "--out", out,
                   "-q"])
    assert res.rc == 0, res.err
    return out


@pytest.fixture(scope="module")
def wheeled_log(robot_file, tmp_path_factory):
    return simulated(robot_file, tmp_path_factory.mktemp("sim"), 4)


def test_simulate_writes_the_wheeled_description(wheeled_log):
    doc = json.loads(wheeled_log.with_suffix(".json").read_text())
    assert doc["traction"] == "wheels" and doc["wheelbase"] == 0.512 and doc["wheel_radius"] == 0.165
    with open(wheeled_log) as f:
        rows = list(csv.DictReader(f))
    assert float(rows[-1]["t"]) == pytest.approx(4.0) and max(abs(float(r["v_left"])) for r in rows) > 0.1


def test_steady_on_wheels_agrees_with_the_point_contact_reference(robot_file):
    from mjtrack.io.robot import read_robot
    from mjtrack.models.coulomb import steady_state

    res = run_cli(["steady", "--v-left", "0.3", "--v-right", "0.8", "--robot", robot_file, "--json"])
    assert res.rc == 0, res.err
    doc = json.loads(res.out)
    ref = steady_state(read_robot(robot_file), doc["v_left"], doc["v_right"])
    # the fidelity bound (benchmarks/wheeled_fidelity.py): 0.05 T/2 on every ICR
    for key, value in zip(("y_l", "y_r", "x_c"), ref.icr):
        assert abs(doc[key] - value) < 0.05 * 0.555 / 2, key


def test_sweep_over_wheelbase_and_wheel_count(robot_file, tmp_path):
    grid = tmp_path / "grid.json"
    grid.write_text(json.dumps({"speed": [0.5], "turn_radius": [1.0], "wheelbase": [0.4, 0.6], "wheels_per_side": [2, 3]}))
    res = run_cli(["sweep", "--grid", grid, "--robot", robot_file, "--out", tmp_path / "s", "--workers", "1", "-q"])
    assert res.rc == 0, res.err
    with open(tmp_path / "s" / "sweep.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 4
    wz = {(float(r["wheelbase"]), int(float(r["wheels_per_side"]))): float(r["wz"]) for r in rows}
    # a longer wheelbase resists turning more; a middle axle at x = 0 adds no turning resistance
    assert wz[(0.6, 2)] < wz[(0.4, 2)] and wz[(0.6, 2)] < wz[(0.6, 3)]


def test_validate_and_render_a_wheeled_log(wheeled_log, tmp_path):
    res = run_cli(["validate", wheeled_log, "--out", tmp_path / "v", "-q"])
    assert res.rc == 0, res.err
    assert json.loads((tmp_path / "v" / "metrics.json").read_text())
    res = run_cli(["render", wheeled_log, "--out", tmp_path / "h.mp4", "--width", "160", "--height", "120", "-q"])
    if res.rc == 1 and "OpenGL" in res.err:
        pytest.skip(f"no offscreen OpenGL: {res.err.strip()}")
    assert res.rc == 0, res.err
    assert (tmp_path / "h.mp4").stat().st_size > 1000


def test_track_drives_the_wheeled_robot(robot_file, tmp_path):
    res = run_cli(["track", "--scenario", "circle", "--laps", "0.2", "--robot", robot_file, "--out", tmp_path / "t",
                   "-q"])
    assert res.rc == 0, res.err
    doc = json.loads((tmp_path / "t" / "tracking.json").read_text())
    assert doc["robot"]["traction"] == "wheels" and math.isfinite(doc["rms_cross_track_m"])
    assert doc["max_cross_track_m"] < 0.2


@pytest.mark.slow  # the whole demo (about 40 s of CPU); validate and render of a wheeled log stay in the default run
def test_demo_takes_a_wheeled_robot(tmp_path):
    from mjtrack.demo import run_demo
    from mjtrack.io.robot import Robot

    res = run_demo(tmp_path / "d", duration=4.0, video=False, quiet=True, robot=Robot.from_dict(WHEELED))
    assert json.loads(res.log.with_suffix(".json").read_text())["traction"] == "wheels"
    assert "on wheels" in json.loads(res.metrics.read_text())["setup"]["source"]


@pytest.mark.slow
def test_cli_demo_with_a_wheeled_robot_file(robot_file, tmp_path):
    res = run_cli(["demo", "--robot", robot_file, "--out", tmp_path / "d", "--no-video", "-q"])
    assert res.rc == 0, res.err
    assert json.loads((tmp_path / "d" / "rollout.json").read_text())["traction"] == "wheels"


@pytest.mark.parametrize("argv, match", [
    (["steady", "--v-left", "0.3", "--v-right", "0.8", "--track-model", "surfacevel"], "has wheels, not the 'surfacevel'"),
    (["steady", "--v-left", "0.3", "--v-right", "0.8", "--cg-x", "0.3"], "outside the wheels"),
    (["steady", "--v-left", "0.3", "--v-right", "0.8", "--wheelbase", "-1"], "--wheelbase: -1 is out of range"),
])
def test_bad_wheeled_input_exits_2_in_one_line(robot_file, argv, match):
    assert_usage_error(run_cli([*argv, "--robot", robot_file]), match)


@pytest.fixture(scope="module")
def long_log(robot_file, tmp_path_factory):
    return simulated(robot_file, tmp_path_factory.mktemp("sim30"), 30)


@pytest.mark.slow
def test_calibrate_recovers_a_wheeled_robot_s_friction_and_wheelbase(long_log, tmp_path):
    wrong = tmp_path / "wrong.json"
    wrong.write_text(json.dumps({**WHEELED, "mu": 0.6, "wheelbase": 0.42}))
    res = run_cli(["calibrate", long_log, "--robot", wrong, "--params", "mu,wheelbase", "--out", tmp_path / "c", "-q"])
    assert res.rc == 0, res.err
    doc = json.loads((tmp_path / "c" / "calibration.json").read_text())
    # the log's own robot: mu 0.8, wheelbase 0.512; the fit starts from 0.6 and 0.42
    assert doc["parameters"]["mu"] == pytest.approx(0.8, abs=0.02)
    assert doc["parameters"]["wheelbase"] == pytest.approx(0.512, abs=0.01)
    assert doc["train"]["after"] < 0.1 * doc["train"]["before"]


@pytest.mark.slow
def test_diagnose_the_mujoco_wheeled_robot_on_its_own_log(long_log, tmp_path):
    res = run_cli(["diagnose", long_log, "--baseline", "mujoco", "--out", tmp_path / "d", "-q"])
    assert res.rc == 0, res.err
    doc = json.loads((tmp_path / "d" / "diagnosis.json").read_text())
    assert doc["cause"] == "none" and "wheeled robot" in doc["baseline"]["model"]
