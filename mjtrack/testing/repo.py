"""Where the repository's tests, benchmark scripts and their result files are.

Meaningful in a source checkout (an editable install): the benchmark scripts and the stored
result files are not part of the installed package. Every path the tests, the benchmark scripts
and the documentation build use for them is derived from the constants here, so moving a folder
changes one line.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import os
import sys
from pathlib import Path
from types import ModuleType
from typing import Iterator

ROOT = Path(__file__).resolve().parents[2]
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


def benchmark_command(script: str | Path, argv: list[str] | None = None) -> str:
    """The command line that reruns a benchmark script, as its result files record it.

    Args:
        script: the script's path (``__file__``) or file name.
        argv: its arguments (default: this process's, ``sys.argv[1:]``).

    Returns:
        ``"python benchmarks/NAME.py ARGS"``.
    """
    args = sys.argv[1:] if argv is None else argv
    return " ".join(["python", f"benchmarks/{Path(script).name}", *args])


@contextlib.contextmanager
def printed_result(path: Path | None, *, command: str) -> Iterator[None]:
    """Write what the block prints to the result file ``path`` as well as to the terminal.

    For the benchmark scripts whose result is a printed report: the file starts with the command
    that reran it and the machine's load average, and is written (atomically) only when the
    block ends without an exception, so that an interrupted run leaves the stored result alone.
    The scripts pass their stable result file for the run without arguments, whose report the
    documentation quotes, and ``None`` (print only) for a variant run.

    Args:
        path: the result file, under :data:`RESULTS`, a stable name; ``None``: print only.
        command: the command line (:func:`benchmark_command`).
    """
    from mjtrack.io.atomic import atomic_write_text

    if path is None:
        yield
        return
    buffer = io.StringIO()
    tee = _Tee(sys.stdout, buffer)
    load = os.getloadavg()
    with contextlib.redirect_stdout(tee):
        yield
    header = f"# {command}\n# load average before {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}, after " + \
        " ".join(f"{x:.2f}" for x in os.getloadavg()) + f" ({os.cpu_count()} CPUs)\n"
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, header + buffer.getvalue())


class _Tee(io.TextIOBase):
    """A text stream that writes to several streams."""

    def __init__(self, *streams) -> None:
        self.streams = streams

    def write(self, text: str) -> int:
        for s in self.streams:
            s.write(text)
        return len(text)

    def flush(self) -> None:
        for s in self.streams:
            s.flush()


def default_run_result(name: str) -> Path | None:
    """The stable result file ``RESULTS/name`` for a benchmark script run without arguments, else
    ``None`` (see :func:`printed_result`)."""
    return RESULTS / name if len(sys.argv) <= 1 else None
