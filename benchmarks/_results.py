"""What the benchmark scripts share: where their result files go, and how a printed report is kept.

The scripts run as programs (``python benchmarks/NAME.py``), so Python finds this module beside
them (``from _results import RESULTS``); the tests load it before a script they import
(``tests/support/repo.py``). It is not a benchmark itself (the leading underscore).
"""

from __future__ import annotations

import contextlib
import io
import os
import sys
from pathlib import Path
from typing import Iterator

RESULTS = Path(__file__).resolve().parent / "results"
"""The stored result files (stable names) the documentation's results pages are generated from."""


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
