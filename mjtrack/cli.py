"""Command line interface: ``mjtrack COMMAND ...``.

The CLI is a thin layer. Each command lives in ``mjtrack/commands/<name>.py`` and
defines ``HELP`` (one line), ``add_arguments(parser)`` and ``run(args) -> int``;
the library does the work. Exit status: 0 success, 2 bad input or usage (one line),
1 internal failure, 130 / 143 interrupted by SIGINT (Ctrl-C) / SIGTERM (one line; the outputs
the command had written are removed again, except what a resume needs:
:mod:`mjtrack.interrupts`, :func:`mjtrack.io.atomic.transaction`).
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import re
import signal
import sys

from mjtrack import interrupts
from mjtrack.errors import InputError, MjtrackError

# Command name -> module under mjtrack.commands. Order is the order of ``--help``.
COMMANDS: dict[str, str] = {
    "demo": "demo",
    "simulate": "simulate",
    "steady": "steady",
    "validate": "validate",
    "render": "render",
    "diagnose": "diagnose",
    "calibrate": "calibrate",
    "track": "track",
    "thesis": "thesis",
    "sweep": "sweep",
    "import-bag": "import_bag",
    "export": "export",
}


# a value that starts with "-" is a negative number, not an option: -1e300, -.5, -inf (argparse's own
# rule knows only -1 and -1.5, so "--v-left -1e300" was a usage error about a missing argument)
_NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$|^-(inf|infinity|nan)$", re.IGNORECASE)


def join_negative_values(words: list[str]) -> list[str]:
    """``words`` with each negative number that follows a long option joined to it
    (``--v-left -1e300`` -> ``--v-left=-1e300``), the form argparse reads as the option's value
    whatever the number looks like. A flag so joined is refused by argparse as before (a flag takes
    no value); after ``--`` nothing is changed."""
    out: list[str] = []
    for word in words:
        if (out and _NEGATIVE_NUMBER.match(word) and out[-1].startswith("--") and "=" not in out[-1]
                and out[-1] != "--" and "--" not in out[:-1]):
            out[-1] = f"{out[-1]}={word}"
        else:
            out.append(word)
    return out


class OneLineParser(argparse.ArgumentParser):
    """argparse with usage errors on one line (the usage itself is in ``--help``) and negative
    numbers of any form as option values (:func:`join_negative_values`)."""

    def parse_known_args(self, args=None, namespace=None):
        words = sys.argv[1:] if args is None else [str(a) for a in args]
        namespace, extras = super().parse_known_args(join_negative_values(words), namespace)
        # argparse drops the value "--" (``--settle=--``) and stores an empty list past the option's
        # type check; no option of mjtrack takes a list, so an empty list is that dropped value
        for dest, value in vars(namespace).items():
            if isinstance(value, list) and not value:
                self.error(f"argument --{dest.replace('_', '-')}: expected one value, got '--'")
        return namespace, extras

    def error(self, message: str):  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {one_line(message)} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="mjtrack",
        description=(
            "Tracked-robot testbed: MuJoCo skid-steer physics, kinematic slip models "
            "(nominal, MPP, MICR, MVIR), their estimators, validation and diagnosis."
        ),
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="log debug messages")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, module_name in COMMANDS.items():
        module = importlib.import_module(f"mjtrack.commands.{module_name}")
        p = sub.add_parser(name, help=module.HELP, description=module.__doc__)
        module.add_arguments(p)
        p.set_defaults(_run=module.run, _on_interrupt=getattr(module, "ON_INTERRUPT", ""))
    return parser


def one_line(text: object) -> str:
    """``text`` with control characters escaped (a file name or cell with a newline or a carriage
    return must not break the one-line error message)."""
    return "".join(c if c.isprintable() else ascii(c)[1:-1] for c in str(text))


def main(argv: list[str] | None = None) -> int:
    program = argv is None  # run as the mjtrack program (not called from Python code)
    words = sys.argv[1:] if argv is None else [str(a) for a in argv]
    # the handlers go in first: building the parser imports every command (seconds on a busy machine)
    state = {"command": next((w for w in words if w in COMMANDS), None), "hint": ""}

    def interrupted(signum: int) -> str:
        who = f"mjtrack {state['command']}" if state["command"] else "mjtrack"
        hint = f"; {state['hint']}" if state["hint"] else ""
        return f"{who}: interrupted by {signal.Signals(signum).name}{hint}"

    try:
        # run as a program, the signals are ignored once the block ends: the result is decided and
        # printed inside it, a late signal must not turn it into a death without a word
        with interrupts.handling(message=interrupted, then_ignore=program):
            return _run(argv, state, program, interrupted)
    except interrupts.Interrupted as exc:  # while the handlers were being installed
        return _end_interrupted(interrupted(exc.signum), exc.exit_status, program=program)


def _run(argv: list[str] | None, state: dict, program: bool, interrupted) -> int:
    """Parse and run one command inside the interrupt handling of :func:`main`; every outcome is
    printed here (one line on stderr unless it succeeds)."""
    try:
        from mjtrack.io import atomic

        interrupts.add_emergency_cleanup(atomic.emergency_cleanup)
        parser = build_parser()
        try:
            args = parser.parse_args(argv)
        except SystemExit as exc:  # argparse exits 2 on usage errors, 0 on --help
            return int(exc.code or 0)
        logging.basicConfig(
            level=logging.DEBUG if args.verbose else logging.WARNING,
            format="%(levelname)s %(name)s: %(message)s",
        )
        if not getattr(args, "command", None):
            parser.print_help()
            return 2
        state["command"], state["hint"] = args.command, args._on_interrupt
        with atomic.transaction(force=bool(getattr(args, "force", False))):
            return int(args._run(args) or 0)
    except interrupts.Interrupted as exc:
        return _end_interrupted(interrupted(exc.signum), exc.exit_status, program=program)
    except Exception as exc:
        signum = interrupts.received()
        if signum is not None:  # a failure the interrupt caused (a pipe to a killed child, a cancelled task)
            return _end_interrupted(interrupted(signum), 128 + signum, program=program)
        if isinstance(exc, InputError):
            from mjtrack.commands._common import option_words  # the library names parameters

            print(f"mjtrack {state['command']}: error: {one_line(option_words(str(exc)))}", file=sys.stderr)
            return 2
        if isinstance(exc, (MjtrackError, OSError)):  # OSError: disk full, permission denied, ...
            print(f"mjtrack {state['command']}: failed: {one_line(exc)}", file=sys.stderr)
            return 1
        if isinstance(exc, MemoryError):  # the work estimates should have refused it before
            print(f"mjtrack {state['command']}: failed: out of memory", file=sys.stderr)
            return 1
        raise


def _end_interrupted(line: str, status: int, *, program: bool) -> int:
    """Print the interrupt's one line. Run as a program (``argv`` None), end the process at once:
    the outputs are already rolled back, and the exit handlers of half-started libraries (a dask
    cluster cut short while it started) would only add tracebacks after the line."""
    print(line, file=sys.stderr)
    if program:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        os._exit(status)
    return status


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
