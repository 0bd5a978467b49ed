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


def test_an_output_never_replaces_the_robot_file_it_reads_even_with_force(tmp_path):
    robot = tmp_path / "typo.json"
    robot.write_text('{"track_gauge": 0.4}\n')
    before = robot.read_bytes()
    for extra in ([], ["--force"]):
        res = run_cli(["simulate", "--scenario", "straight", "--duration", "0.1", "--robot", robot,
                       "--out", tmp_path / "typo.csv", *extra])
        assert_usage_error(res, r"typo\.json: is an input of this command", "not even with --force")
    assert robot.read_bytes() == before and not (tmp_path / "typo.csv").exists()


def test_a_robot_file_error_is_reported_before_an_output_clash(tmp_path):
    robot = tmp_path / "typo.json"
    robot.write_text('{"track_gauge": 0.4, "drive_lags": 0.1}\n')
    (tmp_path / "typo.csv").write_text("t\n")  # the output exists too: the robot file speaks first
    res = run_cli(["simulate", "--scenario", "straight", "--robot", robot, "--out", tmp_path / "typo.csv"])
    assert_usage_error(res, r"typo\.json: key 'drive_lags': did you mean 'drive_lag'")


def test_a_log_and_its_robot_file_are_inputs_of_the_folder_commands(tmp_path):
    from mjtrack.commands._common import check_overwrite
    from mjtrack.errors import InputError

    log = tmp_path / "report.html"  # a log named like an output, in the output folder
    log.write_text("x")
    with pytest.raises(InputError, match="is an input of this command"):
        check_overwrite([tmp_path / "report.html"], True, [log])
    link = tmp_path / "link.html"
    link.symlink_to(log)
    with pytest.raises(InputError, match="is an input of this command"):  # through a link too
        check_overwrite([link], True, [log])
    check_overwrite([tmp_path / "other.html"], False, [log])  # another name: allowed


def test_negative_numbers_reach_options_through_public_argparse_only():
    import inspect

    import mjtrack.cli as cli

    source = inspect.getsource(cli)
    assert "_get_values" not in source and "_negative_number_matcher" not in source
    assert cli.join_negative_values(["--v-left", "-1e300", "--settle", "-.5", "-q", "--", "--x", "-1"]) == [
        "--v-left=-1e300", "--settle=-.5", "-q", "--", "--x", "-1"]
    assert cli.join_negative_values(["--v-left=-1", "-2"]) == ["--v-left=-1", "-2"]  # already has its value
    for value in ("-1e300", "-.5", "-inf", "-1E-3"):  # each a value, refused or taken by the option's type
        res = run_cli(["steady", "--v-left", value, "--v-right", "0.3", "--settle", "-1"])
        assert_usage_error(res, r"argument --(v-left|settle): ")
        assert "expected one argument" not in res.err


def test_library_errors_speak_of_parameters_not_options():
    """No error raised outside the commands names a command-line option; the commands translate."""
    import ast
    from pathlib import Path

    root = Path(__file__).resolve().parents[1] / "mjtrack"
    found = []
    for path in root.rglob("*.py"):
        if "commands" in path.parts or path.name == "cli.py" or "testing" in path.parts:
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Raise) and node.exc is not None:
                for const in ast.walk(node.exc):
                    if isinstance(const, ast.Constant) and isinstance(const.value, str) \
                            and re.search(r"(^|[\s(])--[a-z]", const.value):
                        found.append(f"{path.relative_to(root)}:{node.lineno}: {const.value[:60]}")
    assert not found, found


@pytest.mark.parametrize("message, words", [
    ("params: unknown parameter 'x'", "--params: unknown parameter 'x'"),
    ("terrain='incline:2': incline angle", "--terrain incline:2: incline angle"),
    ("a.txt: exists; pass force=True to replace it", "a.txt: exists; pass --force to replace it"),
    ("settle_s 3 s + window_s 2 s", "--settle 3 s + --window 2 s"),
    ("bag: several topics; choose one with odom=TOPIC", "bag: several topics; choose one with --odom TOPIC"),
    ("robot: the terrain is flat; out of params", "robot: the terrain is flat; out of params"),  # words stay words
])
def test_option_words_translates_parameters_only(message, words):
    from mjtrack.commands._common import option_words

    assert option_words(message) == words


def test_a_library_error_reaches_the_command_line_in_options(tmp_path):
    res = run_cli(["simulate", "--scenario", "straight", "--terrain", "incline:9", "--out", tmp_path / "x.csv"])
    assert_usage_error(res, r"error: --terrain incline:9: incline angle must be in")



# "(2.13)", "eq. 2.21", "eqs. 3.1-3.4", "(3.2.2.1)", "Section 4.2", "fig. 4.1", "figures 4.8-4.14", "thesis 4.2":
# a citation of a source's equation, section or figure
CITED = re.compile(r"(?<![\w.])(?:\(\d\.\d{1,2}(?:\.\d{1,2})*(?:-\d\.\d{1,2})?\)|(?:eqs?\.|section|thesis|figs?\.|"
                   r"figures?|table) \(?\d\.\d{1,2}(?:\.\d{1,2})*(?:-\d\.\d{1,2})?\)?)", re.IGNORECASE)


def test_every_equation_number_in_help_and_reports_names_its_source():
    """'(2.13)' alone says nothing to a reader: each number names its source as docs/references.md does."""
    from pathlib import Path

    from mjtrack.validate.report import DEFINITIONS

    references = (Path(__file__).resolve().parents[1] / "docs" / "references.md").read_text()
    labels = re.findall(r"^\*\*(\[[^\]]+\])\*\*", references, re.MULTILINE)
    texts = {name: " ".join(run_cli([name, "--help"]).out.split()) for name in COMMANDS}
    texts["validate report"] = " ".join(f"{k}: {v}" for k, v in DEFINITIONS.items())
    cited = []
    for where, text in texts.items():
        for match in CITED.finditer(text):
            after = text[match.end():match.end() + 30]
            cited.append(where)
            assert any(f"of {label}" in after for label in labels), (where, text[match.start():match.end() + 30])
    assert {"validate", "track", "thesis", "validate report"} <= set(cited)  # the scan saw the citations


def test_one_word_for_simulated_and_for_logged_motion(tmp_path):
    """validate names a log it simulates "simulated log" and a log file "logged motion" (never
    "measured", which a simulated file is not); demo and the sweep map say simulated too."""
    import inspect

    import mjtrack.demo
    import mjtrack.sweep.figure
    from mjtrack.cli import build_parser
    from mjtrack.commands import demo, validate
    from mjtrack.io.logs import write_log

    parser = build_parser()
    args = parser.parse_args(["validate", "--scenario", "straight", "--duration", "0.2", "--out", str(tmp_path)])
    drive, _, words, title = validate.source_from_args(args)
    assert title == validate.SIMULATED == "simulated log" and words.startswith("simulated log of the scenario")
    write_log(drive, tmp_path / "run.csv")
    args = parser.parse_args(["validate", str(tmp_path / "run.csv"), "--track-gauge", "0.4", "--out", str(tmp_path)])
    assert validate.source_from_args(args)[3] == validate.LOGGED == "logged motion"
    for module in (mjtrack.demo, demo, validate, mjtrack.sweep.figure):
        text = inspect.getsource(module)
        assert "MuJoCo rollout" not in text and "Measured ICRs" not in text and "measured log" not in text, module


def test_help_texts_point_only_to_what_exists():
    """A help text that sends the reader to README's grid, a file or a results page that is not
    there (any more) is refused: files named must exist, results pages must be generated."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    pages = set(re.findall(r"Page\(\s*\"[\w-]+\", \"([^\"]+)\"", (root / "docs" / "_ext" / "results_pages.py").read_text()))
    for name in COMMANDS:
        text = " ".join(run_cli([name, "--help"]).out.split())
        assert "README's" not in text and "see README" not in text, name  # README has no numbered sections
        for path in re.findall(r"\b((?:benchmarks|docs|assets|tests)/[\w./-]+\w)", text):
            assert (root / path).exists(), (name, path)
        for page in re.findall(r"results page \"([^\"]+)\"", text):
            assert page in pages, (name, page)
