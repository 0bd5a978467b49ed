"""Robot descriptions (mjtrack.io.robot) and the shared CLI options (mjtrack.commands._common)."""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import types
from pathlib import Path

import pytest

from mjtrack.commands._common import (
    add_output_options,
    add_robot_options,
    check_out_dir,
    check_out_file,
    robot_from_args,
)
from mjtrack.errors import InputError
from mjtrack.io.robot import Robot, read_robot, write_robot
from support.cli import assert_usage_error, run_cli

DATA = Path(__file__).parent / "data"


# -- Robot validation ------------------------------------------------------------------------
@pytest.mark.parametrize(
    "fields, pattern",
    [
        (dict(track_gauge=-0.4), r"'track_gauge' must be a positive number, got -0\.4"),
        (dict(track_gauge=0.0), r"'track_gauge' must be a positive number"),
        (dict(mass=float("nan")), r"'mass' must be a positive number, got nan"),
        (dict(mu=True), r"'mu' must be a positive number, got True"),
        (dict(cg_z="0.1"), r"'cg_z' must be a finite number, got '0\.1'"),
        (dict(mu_left=-1.0), r"'mu_left' must be a positive number or null"),
        (dict(cg_y=0.2), r"'cg_y' = 0\.2 puts the centre of mass outside the tracks \(\|cg_y\| must be < track_gauge/2 = 0\.2\)"),
        (dict(cg_x=-0.3), r"'cg_x' = -0\.3 puts the centre of mass outside the tracks"),
        (dict(cg_z=-0.5), r"'cg_z' = -0\.5 m puts the centre of mass at or below the ground"),
        (dict(cg_z=0.0), r"'cg_z' = 0 m puts the centre of mass at or below the ground"),
        # 2 x max(T 0.4, L 0.5) = 1 m
        (dict(cg_z=50.0), r"'cg_z' = 50 m is beyond physical plausibility: .* at most 2 x max\(track_gauge, "
                          r"track_length\) = 1 m above the ground"),
        (dict(cg_z=1.3, traction="wheels", wheelbase=0.6), r"'cg_z' = 1\.3 m .* max\(track_gauge, wheelbase\) = 1\.2 m"),
    ],
)
def test_robot_refuses_bad_values(fields, pattern):
    with pytest.raises(InputError, match=r"^robot: " + pattern):
        Robot(**fields)


@pytest.mark.parametrize(
    "data, pattern",
    [
        ({"mass": 10}, r"^r\.json: missing required key 'track_gauge'$"),
        ({"track_gauge": "0.5"}, r"^r\.json: key 'track_gauge' must be a number, got '0\.5'$"),
        ({"track_gauge": 0.5, "cg_y": 0.3}, r"^r\.json: 'cg_y' = 0\.3 puts the centre of mass outside"),
        ([0.5], r"^r\.json: expected a JSON object, got list$"),
    ],
)
def test_from_dict_refuses_bad_descriptions(data, pattern):
    with pytest.raises(InputError, match=pattern):
        Robot.from_dict(data, source="r.json")


def test_bad_json_file(tmp_path):
    path = tmp_path / "robot.json"
    path.write_text('{\n  "track_gauge": 0.5,\n}\n')
    with pytest.raises(InputError, match=r"robot\.json: not valid JSON \(line 3: "):
        read_robot(path)


def test_nan_in_json_file(tmp_path):
    path = tmp_path / "robot.json"
    path.write_text('{"track_gauge": NaN}')
    with pytest.raises(InputError, match=r"robot\.json: key 'track_gauge' must be a number, got nan"):
        read_robot(path)


def test_missing_robot_file(tmp_path):
    with pytest.raises(InputError, match=r"none\.json: cannot read robot description \(No such file or directory\)"):
        read_robot(tmp_path / "none.json")


def test_json_round_trip_keeps_extra_keys(tmp_path):
    robot = Robot.from_dict({"track_gauge": 0.6, "cg_x": 0.05, "mu_right": 0.4, "name": "r2", "notes": [1, 2]})
    path = tmp_path / "r.json"
    write_robot(robot, path)
    back = read_robot(path)
    assert back == robot and back.to_dict() == robot.to_dict()
    assert back.extra == {"name": "r2", "notes": [1, 2]}
    assert back.friction_right == 0.4 and back.friction_left == robot.mu
    first = path.read_bytes()
    write_robot(back, path)
    assert path.read_bytes() == first  # deterministic


def test_marmotte_description():
    robot = read_robot(DATA / "marmotte_excerpt.json")
    assert robot.track_gauge == 0.592723 and robot.sprocket_radius == 0.116702
    assert set(robot.extra) == {"robot", "terrain", "sample_rate_hz", "note"}
    assert robot.traction == "tracks"


# -- robot options -----------------------------------------------------------------------------
def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="t")
    add_robot_options(p)
    add_output_options(p)
    return p


def test_no_options_gives_default_or_base():
    assert robot_from_args(parser().parse_args([])) == Robot()
    base = Robot(track_gauge=0.7)
    assert robot_from_args(parser().parse_args([]), base) is base


def test_options_override_each_field():
    args = parser().parse_args(["--cg-x", "0.05", "--cg-y", "-0.02", "--mu", "0.5", "--mass", "30",
                                "--track-gauge", "0.6", "--track-length", "0.7"])
    assert robot_from_args(args) == Robot(cg_x=0.05, cg_y=-0.02, mu=0.5, mass=30.0,
                                          track_gauge=0.6, track_length=0.7)


def test_robot_file_then_options(tmp_path):
    path = tmp_path / "r.json"
    write_robot(Robot(track_gauge=0.6, mass=50.0, extra={"name": "x"}), path)
    robot = robot_from_args(parser().parse_args(["--robot", str(path), "--mu", "0.3"]), Robot(mass=1.0))
    assert robot == Robot(track_gauge=0.6, mass=50.0, mu=0.3)  # the file wins over base
    assert robot.extra == {"name": "x"}


def test_override_checked_with_the_rest(tmp_path):
    """--track-gauge 0.3 with a file's cg_y = 0.18 puts the CG outside: the message says why."""
    path = tmp_path / "r.json"
    write_robot(Robot(track_gauge=0.6, cg_y=0.18), path)
    args = parser().parse_args(["--robot", str(path), "--track-gauge", "0.3"])
    with pytest.raises(InputError, match=r"'cg_y' = 0\.18 puts .* \(options: --track-gauge 0\.3 on top of .*r\.json\)$"):
        robot_from_args(args)


def test_invalid_option_value_is_refused_at_parsing(capsys):
    """A robot option beyond the robot reader's plausibility table is a usage error naming the
    option, the value and the range (before any robot is built)."""
    with pytest.raises(SystemExit) as info:
        parser().parse_args(["--mu", "-1"])
    assert info.value.code == 2
    assert "argument --mu: -1 is out of range: a robot's mu in (0, 10]" in capsys.readouterr().err


@pytest.mark.parametrize("value", ["abc", "nan", "inf"])
def test_non_numeric_option_is_a_usage_error(value, capsys):
    with pytest.raises(SystemExit) as info:
        parser().parse_args(["--mass", value])
    assert info.value.code == 2
    assert "--mass" in capsys.readouterr().err


def test_quiet_option():
    assert parser().parse_args(["-q"]).quiet and not parser().parse_args([]).quiet


# -- --out checks ------------------------------------------------------------------------------
def test_check_out_dir(tmp_path):
    assert check_out_dir(tmp_path / "a" / "b") == tmp_path / "a" / "b"
    assert not (tmp_path / "a").exists()  # checks only, creates nothing
    (tmp_path / "f").write_text("")
    with pytest.raises(InputError, match=r"f: --out must be a folder, this is an existing file"):
        check_out_dir(tmp_path / "f")
    with pytest.raises(InputError, match=r"f/sub: cannot create output folder: .*f is not a folder"):
        check_out_dir(tmp_path / "f" / "sub")


def test_check_out_file(tmp_path):
    assert check_out_file(tmp_path / "new" / "x.csv", suffixes=[".csv"]) == tmp_path / "new" / "x.csv"
    with pytest.raises(InputError, match=r"x\.txt: --out must end in \.mp4"):
        check_out_file(tmp_path / "x.txt", suffixes=[".mp4"])
    with pytest.raises(InputError, match=r"--out is an existing folder"):
        check_out_file(tmp_path)
    (tmp_path / "in.csv").write_text("t\n")
    with pytest.raises(InputError, match=r"--out would overwrite the input"):
        check_out_file(tmp_path / "." / "in.csv", inputs=[tmp_path / "in.csv"])
    (tmp_path / "file").write_text("")
    with pytest.raises(InputError, match=r"cannot create output file: .*file is not a folder"):
        check_out_file(tmp_path / "file" / "x.csv")


@pytest.mark.skipif(sys.platform == "win32" or os.geteuid() == 0, reason="root writes anywhere")
def test_check_out_refuses_read_only_folder(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        with pytest.raises(InputError, match=r"not writable"):
            check_out_file(ro / "x.csv")
        with pytest.raises(InputError, match=r"not writable"):
            check_out_dir(ro / "d")
    finally:
        ro.chmod(0o700)


# -- end to end through mjtrack.cli.main, with a throwaway command ----------------------------
@pytest.fixture
def robot_command(monkeypatch):
    """Register ``mjtrack robot-echo [robot options] --out FILE``: prints the robot as JSON."""
    module = types.ModuleType("mjtrack.commands._robot_echo")
    module.__doc__ = "Print the robot the options describe."
    module.HELP = "print the robot"

    def add_arguments(p):
        add_robot_options(p)
        add_output_options(p)
        p.add_argument("--out", type=Path)

    def run(args):
        if args.out is not None:
            check_out_file(args.out, suffixes=[".json"])
        print(json.dumps(robot_from_args(args).to_dict(), sort_keys=True))
        return 0

    module.add_arguments, module.run = add_arguments, run
    monkeypatch.setitem(sys.modules, module.__name__, module)
    import mjtrack.cli

    # only this command: the real ones may import heavy modules (or not exist yet)
    monkeypatch.setattr(mjtrack.cli, "COMMANDS", {"robot-echo": "_robot_echo"})
    return "robot-echo"


def test_cli_robot_options_end_to_end(robot_command):
    res = run_cli([robot_command, "--robot", DATA / "marmotte_excerpt.json", "--cg-x", "0.04"])
    assert res.rc == 0, res.err
    out = json.loads(res.out)
    assert out["track_gauge"] == 0.592723 and out["cg_x"] == 0.04 and out["robot"] == "marmotte"


def test_cli_bad_robot_is_exit_2_one_line(robot_command, tmp_path):
    assert_usage_error(run_cli([robot_command, "--cg-y", "0.5"]), r"^mjtrack robot-echo: error: robot: 'cg_y' = 0\.5 puts")
    assert_usage_error(run_cli([robot_command, "--robot", tmp_path / "no.json"]), r"no\.json: cannot read robot description")
    assert_usage_error(run_cli([robot_command, "--mu", "x"]), r"argument --mu: not a number: 'x'")
    assert_usage_error(run_cli([robot_command, "--out", tmp_path / "o.txt"]), r"--out must end in \.json")


def test_provided_keys_are_recorded():
    from mjtrack.io.robot import Robot

    r = Robot.from_dict({"track_gauge": 0.6, "note": "x"})
    assert r.provided == frozenset({"track_gauge"})
    assert r.replace(mass=30.0).provided == frozenset({"track_gauge", "mass"})
    assert Robot().provided is None
    assert "provided" not in r.to_dict()


def test_cg_height_bound_is_the_stated_multiple_of_the_footprint():
    """At the bound the robot tips under a lateral acceleration of g T / (2 cg_z) <= g / 4."""
    from mjtrack.io.robot import MAX_CG_HEIGHT_RATIO

    robot = Robot(track_gauge=0.6, track_length=0.3)
    assert robot.max_cg_z == pytest.approx(MAX_CG_HEIGHT_RATIO * 0.6)
    assert Robot(track_gauge=0.6, track_length=0.3, cg_z=robot.max_cg_z).cg_z == robot.max_cg_z  # inclusive
    assert robot.track_gauge / (2 * robot.max_cg_z) <= 0.25


@pytest.mark.parametrize("option, bound", [("--cg-x", "|cg_x| < track_length/2 (wheelbase/2 on wheels)"),
                                           ("--cg-y", "|cg_y| < track_gauge/2")])
def test_centre_of_mass_help_states_the_bound_the_robot_checks(option, bound):
    res = run_cli(["simulate", "--help"])
    block = " ".join(res.out.split(f"\n  {option} ", 1)[1].split("\n  --", 1)[0].split())
    assert block.endswith(bound) and "100" not in block, block
    name, limit = bound.split(" (")[0].split(" < ")  # the robot's own check words it the same way
    with pytest.raises(InputError, match=re.escape(f"{name} must be < {limit}")):
        Robot(cg_x=0.5) if option == "--cg-x" else Robot(cg_y=0.3)


@pytest.mark.parametrize("key, meant", [("weight", "mass"), ("length", "track_length"), ("mass_kg", "mass"),
                                        ("gauge_mm", "track_gauge"), ("cg_height", "cg_z"),
                                        ("Axle-Distance", "wheelbase"), ("actuator_lag", "drive_lag")])
def test_a_key_naming_a_known_quantity_is_refused_with_the_key_it_means(key, meant):
    with pytest.raises(InputError, match=rf"^r\.json: key '{key}' looks like the robot's {meant}: "
                                         rf"did you mean '{meant}'"):
        Robot.from_dict({"track_gauge": 0.4, key: 60}, source="r.json")


def test_metadata_keys_of_the_data_sets_are_still_kept():
    robot = Robot.from_dict({"track_gauge": 0.4, "robot": "husky", "note": "x", "sample_rate_hz": 20},
                            source="r.json")
    assert robot.extra == {"robot": "husky", "note": "x", "sample_rate_hz": 20}
