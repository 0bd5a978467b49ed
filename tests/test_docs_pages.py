"""The written documentation pages agree with the code they describe.

The Python page's example runs as printed; the robot-file table lists every key of
:class:`mjtrack.Robot` with its default and bound; the drive-log page every column with its
bound; the diagnosis page every effect; and every equation number the code cites is on a
theory page. (The results pages have their own check: tests/test_docs_results.py.)
"""

from __future__ import annotations

import dataclasses
import re

import pytest

import mjtrack
from mjtrack.io.logs import KNOWN, PLAUSIBLE
from mjtrack.io.robot import GROUND_MODELS, PLAUSIBLE_ROBOT, Robot
from support.repo import DOCS, ROOT

ROBOT_KEYS = DOCS / "reference" / "formats" / "_robot_keys.md"


def _table_rows(path) -> list[list[str]]:
    rows = []
    for line in path.read_text().splitlines():
        if line.startswith("|") and not line.startswith("|---"):
            rows.append([c.strip() for c in re.split(r"(?<!\\)\|", line.strip())[1:-1]])
    return rows


def _python_blocks(path) -> list[str]:
    return re.findall(r"```python\n(.*?)```", path.read_text(), flags=re.S)


def test_python_page_example_runs_as_printed(tmp_path, monkeypatch, capsys):
    (code,) = _python_blocks(DOCS / "python.md")
    assert len(code.strip().splitlines()) <= 15
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "docs/python.md", "exec"), {"__name__": "docs_python_page"})
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 3 and out[2].startswith("calibrated cg_x 0.06"), out  # the hidden 0.06 m recovered
    assert mjtrack.read_robot(tmp_path / "calibrated.json").cg_x == pytest.approx(0.06, abs=0.005)


def _number(text: str) -> float:
    return float(text.replace("−", "-"))


def test_robot_file_table_lists_every_key_with_its_default_and_bound():
    rows = {r[0].strip("`"): r for r in _table_rows(ROBOT_KEYS) if r[0].startswith("`")}
    fields = {f.name: f for f in dataclasses.fields(Robot) if f.name not in ("extra", "provided")}
    missing = sorted(set(fields) - set(rows))
    assert not missing, f"robot keys not documented: {missing}"
    for name, f in fields.items():
        key, unit, default, bound, _ = rows[name][:5]
        if name == "track_gauge":
            assert default == "required"
            continue
        value = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        if value is None:
            assert default.startswith("null"), (name, default)
        elif isinstance(value, (int, float)) and not isinstance(value, bool):
            assert _number(default) == pytest.approx(value), (name, default, value)
        elif name == "ground":
            assert '"coulomb"' in default
        else:
            assert default.strip("`\"") == str(value), (name, default, value)
        if name in PLAUSIBLE_ROBOT:
            low, high, _ = PLAUSIBLE_ROBOT[name]
            numbers = [_number(n) for n in re.findall(r"−?\d+(?:\.\d+)?(?:e\d+)?", bound)]
            assert high in numbers, (name, bound)
            assert low in numbers or "above 0" in bound or low == 0, (name, bound)
    grounds = [r for r in _table_rows(ROBOT_KEYS) if r[0].strip("`") in GROUND_MODELS]
    for model, params in GROUND_MODELS.items():
        for param, (default, low, high) in params.items():
            row = next((r for r in grounds if r[0].strip("`") == model and r[1].strip("`") == param), None)
            assert row is not None, (model, param)
            assert _number(row[3]) == default and str(low).rstrip("0").rstrip(".") in row[4], (model, param, row)


def test_drive_log_page_lists_every_column_and_its_bound():
    rows = _table_rows(DOCS / "reference" / "formats" / "drive-log.md")
    documented = {}
    for row in rows:
        for name in re.findall(r"`(\w+)`", row[0]):
            documented[name] = row
    assert set(KNOWN) <= set(documented), sorted(set(KNOWN) - set(documented))
    for name, (limit, _, _) in PLAUSIBLE.items():
        assert _number(documented[name][-1]) == limit, (name, documented[name])
    for name in ("t", "v_left_cmd", "v_right_cmd", "x", "y", "yaw"):
        assert documented[name][1] == "yes"


def test_diagnosis_page_names_every_effect():
    from mjtrack.diagnose.vocabulary import EFFECTS

    text = (DOCS / "reference" / "formats" / "diagnosis-json.md").read_text()
    for name, effect in EFFECTS.items():
        assert f"| `{name}` |" in text, name
        for p in effect.params:
            assert f"`{p}`" in text, (name, p)


CITATION = re.compile(r"(?<![\w.])\(([123])\.(\d{1,2})\)")


def test_every_equation_the_code_cites_is_on_a_theory_page():
    theory = "\n".join(p.read_text() for p in (DOCS / "theory").glob("*.md"))
    on_pages = set()
    for first, last in re.findall(r"\((\d\.\d+)\)(?:[–-]\((\d\.\d+)\))?", theory):
        on_pages.add(first)
        if last:  # a range such as (2.10)–(2.13)
            a, b = first.split("."), last.split(".")
            on_pages |= {f"{a[0]}.{i}" for i in range(int(a[1]), int(b[1]) + 1)}
    cited = {}
    for path in (ROOT / "mjtrack").rglob("*.py"):
        for chapter, number in CITATION.findall(path.read_text()):
            if number != "0":
                cited.setdefault(f"{chapter}.{number}", path.relative_to(ROOT).as_posix())
    missing = {eq: where for eq, where in cited.items() if eq not in on_pages}
    assert not missing, f"equations cited in the code but on no theory page: {missing}"
    assert len(cited) > 40  # the scan found the citations
