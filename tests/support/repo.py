"""Where the repository's tests, benchmark scripts and their result files are (for the tests).

The benchmark scripts find their result folder through ``benchmarks/_results.py`` and the
results pages' generator through its own location; ``tests/test_docs_results.py`` checks that
they name the same folder as :data:`RESULTS` here.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[2]  # tests/support/repo.py
"""The repository's root folder."""
TESTS = ROOT / "tests"
"""The test suite and its stored data (``tests/data``)."""
BENCHMARKS = ROOT / "benchmarks"
"""The benchmark scripts: each one writes its result files under :data:`RESULTS`."""
RESULTS = BENCHMARKS / "results"
"""The stored result files (stable names) the documentation's results pages are generated from."""
DOCS = ROOT / "docs"
"""The documentation sources; ``docs/_ext`` holds the generators of its CLI and results pages."""


def load_benchmark(name: str) -> ModuleType:
    """Import the benchmark script ``BENCHMARKS/name.py`` as a module.

    The scripts are meant to be run as programs (``python benchmarks/NAME.py``), where Python
    puts their own folder on the import path; tests that reuse a script's cases import it
    through this function instead, which loads it by file name and leaves ``sys.path`` alone.
    The scripts' shared helper ``benchmarks/_results.py`` is loaded first (as ``_results``, by
    :func:`load_file`), so that a script's ``from _results import ...`` finds it.

    Args:
        name: the script's file name without ``.py``, e.g. ``"fidelity"``.

    Returns:
        The imported module (also registered in ``sys.modules`` under ``name``, so that
        multiprocessing workers and pickled objects find it).

    Raises:
        FileNotFoundError: no such script in :data:`BENCHMARKS`.
    """
    return load_file(BENCHMARKS / f"{name}.py", name)


def load_file(path: Path, name: str) -> ModuleType:
    """Import the Python file ``path`` as the module ``name`` (see :func:`load_benchmark`)."""
    if name in sys.modules:
        return sys.modules[name]
    if path.parent == BENCHMARKS and name != "_results":  # the scripts' shared helper, found beside them when run
        load_file(BENCHMARKS / "_results.py", "_results")
    if not path.is_file():
        raise FileNotFoundError(f"no such script {path}")
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    return module
