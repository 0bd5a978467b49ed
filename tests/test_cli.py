"""CLI smoke tests: ``mjtrack --help`` and ``mjtrack thesis --out DIR`` with content checks."""

import json
import re

import numpy as np
import pytest
from matplotlib.image import imread

from mjtrack.cli import COMMANDS
from support.cli import assert_usage_error, run_cli

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def test_help_lists_every_command():
    res = run_cli(["--help"])
    assert res.rc == 0
    for name in COMMANDS:
        assert f"\n    {name} " in res.out or f"\n    {name}\n" in res.out, name


@pytest.mark.parametrize("name", list(COMMANDS))
def test_every_command_has_help(name):
    res = run_cli([name, "--help"])
    assert res.rc == 0 and f"usage: mjtrack {name}" in res.out


def _option_help(name: str, option: str) -> str:
    """The help text of one option of ``mjtrack NAME``, lines joined (argparse wraps them)."""
    text = run_cli([name, "--help"]).out
    block = text.split(f"\n  {option} ", 1)[1]
    return " ".join(re.split(r"\n(?! {3})", block, maxsplit=1)[0].split())  # to the next unindented line


@pytest.mark.parametrize("name", ["simulate", "validate", "render"])
def test_scenario_help_names_every_scenario(name):
    from mjtrack.sim.scenarios import SCENARIOS

    text = _option_help(name, "--scenario")
    for scenario in SCENARIOS.values():  # every name with its description, in the help itself
        assert f"{scenario.name}: {scenario.description}" in text, scenario.name


@pytest.mark.parametrize("name, default", [("steady", "flat ground"), ("sweep", "flat ground"),
                                           ("simulate", "the scenario's terrain, else flat")])
def test_terrain_help_says_its_real_default(name, default):
    text = _option_help(name, "--terrain")
    assert text.endswith(f"(default: {default})"), text[-80:]


def test_no_command_is_a_usage_error():
    assert run_cli([]).rc == 2


@pytest.fixture(scope="module")
def thesis_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("thesis") / "new" / "dir"  # not there yet: created
    res = run_cli(["thesis", "--out", str(out)])
    return res, out


def test_thesis_writes_json_with_agreeing_models(thesis_run):
    res, out = thesis_run
    assert res.rc == 0, res.err
    doc = json.loads((out / "thesis.json").read_text())
    sec = doc["4.1"]
    for case in ("no_slip", "longitudinal_slip", "lateral_slip"):
        assert sec[case]["max_dev_m"] < 1e-9, case
        assert set(sec[case]["final_pose"]) == {"nominal", "MPP", "MICR", "MVIR"}
        assert f"4.1 {case}: max_dev_m = " in res.out
    assert max(sec["no_slip"]["nominal_dev_m"].values()) < 1e-9
    assert sec["longitudinal_slip"]["nominal_dev_m"]["MPP"] > 1.0  # slip does move the robot off the U
    assert sec["reconstruction"]["dt"] == 0.01 and "half-turn" in sec["reconstruction"]["description"]
    assert sec["lateral_slip"]["virtual_centre_steps"][0]["t_s"] == pytest.approx(11.0)


def test_thesis_writes_readable_figures(thesis_run):
    _, out = thesis_run
    doc = json.loads((out / "thesis.json").read_text())
    figs = doc["4.1"]["figures"]
    assert sorted(figs) == ["4.1", "4.2", "4.3", "4.4", "4.5", "4.6", "4.7"]
    figs42 = doc["4.2"]["figures"]
    assert sorted(figs42) == ["4.10", "4.11", "4.12", "4.13", "4.14", "4.8", "4.9"]
    assert doc["figures"] == [figs[k]["file"] for k in sorted(figs)] + [
        figs42[k]["file"] for k in sorted(figs42, key=lambda n: int(n.split(".")[1]))
    ]
    for number, fig in figs.items():
        path = out / fig["file"]
        assert path.read_bytes()[:8] == PNG_MAGIC, number
        img = imread(path)
        assert img.ndim == 3 and img.shape[0] > 400 and img.shape[1] > 700, (number, img.shape)
        assert float(np.std(img[..., :3])) > 0.05, number  # not blank
        assert "Reconstruction:" in fig["caption"] and "pi/6" in fig["caption"]
    assert sorted(p.name for p in out.iterdir()) == sorted([*doc["figures"], "thesis.json"])  # no temp files left


@pytest.mark.slow  # a second whole thesis run; --quiet is checked on the other commands
def test_thesis_quiet_prints_nothing(tmp_path):
    res = run_cli(["thesis", "--out", str(tmp_path), "--quiet"])
    assert res.rc == 0 and res.out == "" and res.err == ""
    assert (tmp_path / "thesis.json").exists()


def test_thesis_bad_out_is_refused(tmp_path):
    assert_usage_error(run_cli(["thesis"]), "--out")
    afile = tmp_path / "afile"
    afile.write_text("x")
    assert_usage_error(run_cli(["thesis", "--out", str(afile)]), "must be a folder")
    assert afile.read_text() == "x"
