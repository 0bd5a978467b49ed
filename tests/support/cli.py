"""Helpers for CLI-level tests: run ``mjtrack ARGS`` and look at exit status, stdout, stderr.

    from support.cli import run_cli, assert_usage_error

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


@dataclass(frozen=True)
class ForkResult:
    """What :meth:`Forker.run` saw: exit status (negative: killed by that signal), output, timings."""

    rc: int
    out: str
    err: str
    seconds: float
    signalled_at: float | None  # [s] after the start, when the first signal was sent (None: none)
    after_signal_s: float | None  # [s] from the first signal to the end
    killed: bool  # still running after the grace period: killed with SIGKILL (a hang)


class Forker:
    """Runs ``mjtrack ARGS`` as real processes forked from a warm one (``cli_zygote.py`` beside this module), under a
    memory cap and a time limit, optionally interrupted by a signal (see that module).

        with Forker() as fk:
            res = fk.run(["simulate", ...], cwd=tmp_path, signal=(signal.SIGINT, 0.5))
    """

    def __init__(self) -> None:
        self.proc = subprocess.Popen([sys.executable, str(Path(__file__).with_name("cli_zygote.py"))],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        ready = self.proc.stdout.readline()
        if ready.strip() != "ready":
            raise RuntimeError(f"cli_zygote did not start: {ready!r}")

    def run(self, argv: list, *, cwd: str | Path, memory: int = 4_000_000_000, limit_s: float = 60.0,
            signal: tuple[int, float] | None = None, grace_s: float = 5.0) -> ForkResult:
        import json

        req = {"argv": [str(a) for a in argv], "cwd": str(cwd), "memory": memory, "limit_s": limit_s,
               "signal": None if signal is None else [int(signal[0]), float(signal[1])], "grace_s": grace_s}
        self.proc.stdin.write(json.dumps(req) + "\n")
        self.proc.stdin.flush()
        res = json.loads(self.proc.stdout.readline())
        return ForkResult(res["rc"], res["stdout"], res["stderr"], res["seconds"], res["signalled_at"],
                          res["after_signal_s"], res["killed"])

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.stdin.close()
            self.proc.wait(timeout=30)

    def __enter__(self) -> "Forker":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
