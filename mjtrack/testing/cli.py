"""Helpers for CLI-level tests: run ``mjtrack ARGS`` and look at exit status, stdout, stderr.

    from mjtrack.testing.cli import run_cli, assert_usage_error

    res = run_cli(["diagnose", str(log_path), "--out", str(tmp_path / "d")])
    assert res.rc == 0, res.err

``run_cli`` calls :func:`mjtrack.cli.main` in-process (fast, no console-script install
needed); ``in_subprocess=True`` runs ``python -m mjtrack.cli`` instead, for the real thing
(exit status through the OS, nothing shared with the test process).
"""

from __future__ import annotations

import contextlib
import io
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class CliResult:
    rc: int
    out: str
    err: str


def run_cli(argv: list[str], *, in_subprocess: bool = False, cwd: str | Path | None = None,
            timeout: float = 600) -> CliResult:
    """Run ``mjtrack *argv`` and capture exit status, stdout and stderr."""
    argv = [str(a) for a in argv]
    if in_subprocess:
        proc = subprocess.run([sys.executable, "-m", "mjtrack.cli", *argv], capture_output=True,
                              text=True, cwd=cwd, timeout=timeout)
        return CliResult(proc.returncode, proc.stdout, proc.stderr)
    from mjtrack.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            rc = main(argv)
        except SystemExit as exc:  # a command that exits by itself
            rc = exc.code if isinstance(exc.code, int) else 1
    return CliResult(int(rc), out.getvalue(), err.getvalue())


def assert_usage_error(res: CliResult, *patterns: str) -> str:
    """Exit status 2, stderr ends with one error line matching every regex in ``patterns``.

    argparse usage errors print the usage first; input errors print a single line. Returns
    that last line.
    """
    assert res.rc == 2, f"expected exit status 2, got {res.rc}; stderr: {res.err!r}"
    lines = res.err.strip().splitlines()
    assert lines, "nothing on stderr"
    last = lines[-1]
    assert "error" in last, last
    for pattern in patterns:
        assert re.search(pattern, last), f"{pattern!r} not in {last!r}"
    assert "Traceback" not in res.err, res.err
    return last
