"""Command line interface: ``mjtrack COMMAND ...``.

The CLI is a thin layer. Each command lives in ``mjtrack/commands/<name>.py`` and
defines ``HELP`` (one line), ``add_arguments(parser)`` and ``run(args) -> int``;
the library does the work. Exit status: 0 success, 2 bad input or usage,
1 internal failure.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys

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


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
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
        p.set_defaults(_run=module.run)
    return parser


def one_line(text: object) -> str:
    """``text`` with control characters escaped (a file name or cell with a newline or a carriage
    return must not break the one-line error message)."""
    return "".join(c if c.isprintable() else ascii(c)[1:-1] for c in str(text))


def main(argv: list[str] | None = None) -> int:
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
    try:
        return int(args._run(args) or 0)
    except InputError as exc:
        print(f"mjtrack {args.command}: error: {one_line(exc)}", file=sys.stderr)
        return 2
    except MjtrackError as exc:
        print(f"mjtrack {args.command}: failed: {one_line(exc)}", file=sys.stderr)
        return 1
    except OSError as exc:  # disk full, permission denied, ...: one line, not a traceback
        print(f"mjtrack {args.command}: failed: {one_line(exc)}", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
