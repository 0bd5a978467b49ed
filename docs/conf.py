"""Sphinx configuration of the mjtrack documentation (built by docs/build)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))  # the extensions that generate the CLI and results pages
os.environ.setdefault("MPLBACKEND", "Agg")

import mjtrack  # noqa: E402  (after the path: the API pages document this checkout)

project = "mjtrack"
author = "the mjtrack authors"
release = mjtrack.__version__
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "cli_reference",
    "results_pages",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
exclude_patterns = ["_build", "**/_*.md"]
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3
myst_dmath_double_inline = True

autodoc_typehints = "description"
autodoc_member_order = "bysource"
autodoc_default_options = {"members": False}
napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_use_rtype = False

html_theme = "furo"
html_title = f"mjtrack {release}"
html_static_path = ["_static"]
# MathJax bundled (docs/_static/mathjax/README.txt): the maths renders offline, no CDN is contacted
mathjax_path = "mathjax/tex-svg.js"

nitpicky = False
suppress_warnings = []
