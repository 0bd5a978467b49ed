"""The documentation shows its maths without a network: MathJax is bundled, no page loads it from a CDN."""

import re
from pathlib import Path

DOCS = Path(__file__).resolve().parents[1] / "docs"


def _conf() -> dict:
    namespace: dict = {"__file__": str(DOCS / "conf.py")}
    exec(compile((DOCS / "conf.py").read_text(), str(DOCS / "conf.py"), "exec"), namespace)
    return namespace


def test_mathjax_is_bundled_with_its_licence():
    conf = _conf()
    path = conf["mathjax_path"]
    assert "://" not in path and not path.startswith("//"), path  # a local file, not a URL
    static = [DOCS / p for p in conf["html_static_path"]]
    found = [d / path for d in static if (d / path).is_file()]
    assert found, f"{path} is in none of {conf['html_static_path']}"
    script = found[0]
    assert script.stat().st_size > 1_000_000  # the whole single-file build, not a loader stub
    assert "Apache License" in (script.parent / "LICENSE").read_text()


def test_no_page_or_setting_loads_maths_from_a_cdn():
    cdn = re.compile(r"(cdn\.jsdelivr|cdnjs|unpkg\.com|polyfill\.io|mathjax\.org)", re.IGNORECASE)
    sources = [DOCS / "conf.py", *DOCS.glob("_ext/*.py"), *DOCS.rglob("*.md")]
    hits = [p for p in sources if "_build" not in p.parts and cdn.search(p.read_text())]
    assert not hits, hits
    built = DOCS / "_build" / "html"
    if built.is_dir():  # after docs/build: the pages themselves
        pages = [p for p in built.rglob("*.html") if cdn.search(p.read_text(errors="replace"))]
        assert not pages, pages[:5]
