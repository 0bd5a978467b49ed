"""Where the repository's tests, benchmark scripts and their result files are.

Meaningful in a source checkout (an editable install): the benchmark scripts and the stored
result files are not part of the installed package. Every path the tests, the benchmark scripts
and the documentation build use for them is derived from the constants here, so moving a folder
changes one line.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[2]
"""The repository's root folder."""
TESTS = ROOT / "tests"
"""The test suite and its stored data (``tests/data``)."""
BENCHMARKS = ROOT / "experiments"
"""The benchmark scripts: each one writes its result files under :data:`RESULTS`."""
RESULTS = BENCHMARKS / "results"
"""The stored result files the documentation's results pages are generated from."""
MEASUREMENTS = ROOT / "benchmarks"
"""Measurement scripts of the wheeled robot; their result files are in ``MEASUREMENTS / "results"``."""
DOCS = ROOT / "docs"
"""The documentation sources; ``docs/_ext`` holds the generators of its CLI and results pages."""


def load_benchmark(name: str) -> ModuleType:
    """Import the benchmark script ``BENCHMARKS/name.py`` as a module.

    The scripts are meant to be run as programs (``python experiments/NAME.py``), where Python
    puts their own folder on the import path; tests that reuse a script's cases import it
    through this function instead, which loads it by file name and leaves ``sys.path`` alone.

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
