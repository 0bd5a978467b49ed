"""The documentation's results pages print only numbers read from their result files.

The pages are generated (docs/_ext/results_pages.py, run by docs/build) together with a
provenance file naming, for every number, its result file and JSON pointer. This test reads
each page as Markdown, finds every number in its tables, resolves the pointer in the result
file with its own code, and fails when a printed number differs from the file by more than
the rounding of its printed digits, when a table number has no provenance, or when the text
outside the tables carries a number of its own.
"""

from __future__ import annotations

import json
import math
import re
import shutil
import statistics
from pathlib import Path

import pytest

from support.repo import BENCHMARKS, DOCS, RESULTS, ROOT, TESTS, load_file

pages = load_file(DOCS / "_ext" / "results_pages.py", "results_pages")

NUMBER = re.compile(r"^[-+]?(\d+(\.\d*)?|\.\d+)([eE][-+]?\d+)?$")
TYPED = re.compile(r"\d+\.\d+|\d{2,}")  # a decimal or a number of two digits or more


def resolve(data, pointer: str):
    """RFC 6901: "~1" in a token is "/" and "~0" is "~" (a battery case is named "default/cg_x")."""
    for part in pointer.strip("/").split("/"):
        part = part.replace("~1", "/").replace("~0", "~")
        data = data[int(part)] if isinstance(data, list) else data[part]
    return data


def file_value(root: Path, prov: dict):
    data = json.loads((root / prov["file"]).read_text())
    value = resolve(data, prov["pointer"])
    if prov["reduce"]:
        items = [v[prov["field"]] for v in value] if prov["field"] else list(value)
        value = {"mean": statistics.fmean, "max": max, "min": min, "median": statistics.median,
                 "count": lambda xs: len([x for x in xs if x is True]), "length": len}[prov["reduce"]](items)
    return value if isinstance(value, (bool, type(None))) else value * prov["scale"]


def rounding(text: str) -> float:
    """Half a unit of the last printed digit of ``text``."""
    mantissa, _, exponent = text.lower().partition("e")
    decimals = len(mantissa.partition(".")[2])
    return 0.5 * 10.0 ** (-decimals + (int(exponent) if exponent else 0))


def tables(markdown: str) -> list[list[list[str]]]:
    """The Markdown tables of a page: rows of cell texts (header and rule dropped)."""
    found, current = [], None
    for line in markdown.splitlines():
        if line.startswith("|"):
            cells = [c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", line.strip())[1:-1]]
            if current is None:
                current = []
                found.append(current)
            current.append(cells)
        else:
            current = None
    return [[row for row in t[2:]] for t in found]


def problems(page: str, markdown: str, provenance: list[dict], root: Path) -> list[str]:
    out = []
    by_cell = {(p["table"], p["row"], p["column"]): p for p in provenance}
    for t, rows in enumerate(tables(markdown)):
        for r, row in enumerate(rows):
            for c, text in enumerate(row):
                prov = by_cell.pop((t, r, c), None)
                where = f"{page}: table {t} row {r} column {c} ({text!r})"
                if prov is None:
                    if TYPED.search(text):
                        out.append(f"{where}: a number without a result file")
                    continue
                value = file_value(root, prov)
                if prov["kind"] == "bool":
                    if text != ("yes" if value else "no"):
                        out.append(f"{where}: {prov['file']}{prov['pointer']} is {value}")
                elif prov["kind"] == "null":
                    if value is not None or text != "n/a":
                        out.append(f"{where}: {prov['file']}{prov['pointer']} is {value}")
                elif not NUMBER.match(text):
                    out.append(f"{where}: not a number")
                elif not math.isclose(float(text), value, rel_tol=0, abs_tol=rounding(text) * (1 + 1e-9)):
                    out.append(f"{where}: the file {prov['file']}{prov['pointer']} holds {value!r}")
    out += [f"{page}: provenance for a cell not on the page: {key}" for key in by_cell]
    prose = "\n".join(line for line in markdown.splitlines() if not line.startswith("|"))
    prose = re.sub(r"`[^`]*`", "", prose)  # commands and file names in code spans
    for match in TYPED.finditer(prose):
        out.append(f"{page}: a number in the text: ...{prose[max(0, match.start() - 30):match.end() + 10]!r}")
    return out


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    out = tmp_path_factory.mktemp("results")
    pages.write_pages(out)
    return out, json.loads((out / "_provenance.json").read_text())


def test_results_root_is_the_one_constant():
    """The results pages, the benchmark scripts and the tests name the same result folder."""
    assert pages.RESULTS == RESULTS
    assert load_file(BENCHMARKS / "_results.py", "_results").RESULTS == RESULTS


def test_every_number_on_every_results_page_is_its_result_file_value(generated):
    out, provenance = generated
    assert set(provenance) == {p.stem for p in out.glob("*.md")} - {"index"}
    found = []
    for page, prov in provenance.items():
        assert prov, f"{page}: no number traced to a result file"
        found += problems(page, (out / f"{page}.md").read_text(), prov, ROOT)
    assert not found, "\n".join(found)


def test_a_changed_number_or_result_file_is_caught(generated, tmp_path):
    """The check above can fail: a hand-edited page number, a typed number in the text, and a
    result file that no longer holds the printed value are each reported."""
    out, provenance = generated
    page = "fidelity"
    text = (out / f"{page}.md").read_text()
    prov = provenance[page]
    first = next(p for p in prov if p["kind"] == "number" and "." in p["text"])
    edited = text.replace(f"| {first['text']} |", f"| {float(first['text']) * 1.5:.3g} |", 1)
    assert edited != text
    assert any("holds" in p for p in problems(page, edited, prov, ROOT))
    typed = text.replace("# Fidelity against Coulomb theory", "# Fidelity against Coulomb theory\n\nWithin 0.05 of it.")
    assert any("a number in the text" in p for p in problems(page, typed, prov, ROOT))
    # the same page against a result file whose value has moved
    copy_root = tmp_path / "repo"
    target = copy_root / first["file"]
    target.parent.mkdir(parents=True)
    shutil.copyfile(ROOT / first["file"], target)
    data = json.loads(target.read_text())
    keys = first["pointer"].strip("/").split("/")
    holder = resolve(data, "/".join(keys[:-1])) if len(keys) > 1 else data
    last = int(keys[-1]) if isinstance(holder, list) else keys[-1]
    holder[last] = holder[last] * 2 + 1
    target.write_text(json.dumps(data))
    for p in prov:
        if p["file"] != first["file"]:
            other = copy_root / p["file"]
            if not other.exists():
                other.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(ROOT / p["file"], other)
    assert any("holds" in p for p in problems(page, text, prov, copy_root))


# -- the result files and the pages that cite them --------------------------------------------
JOIN = re.compile(r"""["']\s*/\s*["']""")  # RESULTS / "a" / "b.json" reads as "a/b.json"
CITED_SCRIPT = re.compile(r"benchmarks/([\w-]+\.py)")
CITED_RESULT = re.compile(r"benchmarks/results/([\w./+-]*[\w/])")
HISTORY = {"changelog.md"}  # names what past releases shipped, scripts since retired included


def _readers(generated_pages: Path | None = None) -> dict[str, str]:
    """The text of every docs page, README and test, and of the results pages as generated into
    ``generated_pages``; path joins of Python written as one path."""
    paths = [ROOT / "README.md", *DOCS.rglob("*.md"), *TESTS.rglob("*.py")]
    skip = (DOCS / "_build", DOCS / "results")  # build output and results pages generated earlier
    out = {p.relative_to(ROOT).as_posix(): JOIN.sub("/", p.read_text()) for p in paths
           if not any(p.is_relative_to(s) for s in skip)}
    if generated_pages is not None:
        out |= {f"results/{p.name}": p.read_text() for p in generated_pages.glob("*.md")}
    return out


def _pages() -> dict[str, str]:
    """The written documentation: README and the docs pages (not the generated ones, not history)."""
    return {k: v for k, v in _readers().items() if k.endswith(".md") and Path(k).name not in HISTORY}


def test_every_result_file_is_read_by_a_docs_page_or_a_test(generated):
    """A stored result earns its place by a page (a results page as generated) or a test reading
    it: its path under benchmarks/results named in their text."""
    text = "\n".join(_readers(generated[0]).values())
    orphans = [rel for rel in sorted(p.relative_to(RESULTS).as_posix() for p in RESULTS.rglob("*") if p.is_file())
               if not re.search(rf"(?<![\w-]){re.escape(rel)}(?![\w.-])", text)]
    assert not orphans, f"result files read by no docs page and no test: {orphans}"


def test_every_script_and_result_file_a_page_cites_exists():
    missing = []
    for page, text in _pages().items():
        missing += [f"{page}: benchmarks/{m}" for m in CITED_SCRIPT.findall(text)
                    if not (BENCHMARKS / m).is_file() and not m[:-3].isupper()]  # NAME.py: a placeholder
        missing += [f"{page}: benchmarks/results/{m}" for m in CITED_RESULT.findall(text)
                    if not (RESULTS / m).exists()]
    assert not missing, f"cited but not in the repository: {missing}"


def test_the_benchmarks_are_at_most_twenty_scripts():
    scripts = sorted(p.name for p in BENCHMARKS.glob("*.py") if not p.name.startswith("_"))
    assert len(scripts) <= 20, scripts


def test_the_citation_checks_can_fail(tmp_path):
    """An orphan result file and a cited script that is gone are each caught by the rules above."""
    text = "see `python benchmarks/no_such_study.py`, result benchmarks/results/no_such.json"
    assert CITED_SCRIPT.findall(text) == ["no_such_study.py"] and CITED_RESULT.findall(text) == ["no_such.json"]
    assert JOIN.sub("/", 'RESULTS / "fidelity" / "fidelity.json"') == 'RESULTS / "fidelity/fidelity.json"'
    assert re.search(r"(?<![\w-])fidelity/fidelity\.json(?![\w.-])", "\n".join(_readers().values()))
    assert "no_such.json" not in JOIN.sub("/", (ROOT / "README.md").read_text())


def test_the_surrogates_model_form_constants_are_their_measured_values():
    """Two constants of the diagnosis surrogate are measured by benchmark scripts; the code holds the
    values their stored results print."""
    from mjtrack.diagnose.surrogate.baseline import MODEL_ABS

    spread = re.search(r"icr_spread gaps .* RMS (\d\.\d+)", (RESULTS / "generator_spread.txt").read_text())
    assert spread and MODEL_ABS["icr_spread"] == float(spread.group(1))
    steps = json.loads((RESULTS / "diagnose_transient_steps.json").read_text())
    assert MODEL_ABS["friction_scale"] == pytest.approx(steps["model_abs_friction_scale"]["all"], abs=5e-4)  # 3 digits
