"""The command-line reference page, generated from the argument parsers.

Run by the documentation build (a Sphinx extension that writes ``reference/cli.md`` when the
build starts) or alone: ``python docs/_ext/cli_reference.py [OUT.md]``. Everything on the page
comes from :func:`mjtrack.cli.build_parser`: the commands, their descriptions, usage lines,
arguments, defaults and choices. Help texts are plain text, so every punctuation character is
escaped and they show as written.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

from mjtrack.cli import build_parser

HERE = Path(__file__).resolve().parent
DEFAULT_OUT = HERE.parent / "reference" / "cli.md"

INTRO = """\
# Command line

Generated from the argument parsers of the installed `mjtrack` when the documentation is built:
every command, argument, default and choice below is what `mjtrack COMMAND --help` prints.
Exit status: 0 on success, 2 on bad input or usage (one line on stderr naming what is wrong,
and nothing written), 1 on an internal failure.
"""

_PUNCT = re.compile(r"([\\`*_{}\[\]<>()#+\-.!|$~&:;'\"=@%^,/?])")


def plain(text: str) -> str:
    """Markdown that shows ``text`` as written (every ASCII punctuation character escaped)."""
    return _PUNCT.sub(r"\\\1", text)


def _paragraphs(text: str) -> list[str]:
    blocks = re.split(r"\n\s*\n", text.strip())
    return [plain(" ".join(line.strip() for line in b.splitlines())) for b in blocks if b.strip()]


def _argument(action: argparse.Action) -> list[str]:
    if action.option_strings:
        names = ", ".join(f"`{o}`" for o in action.option_strings)
        if action.nargs != 0:
            names += f" `{action.metavar or action.dest.upper()}`"
    else:
        names = f"`{action.metavar or action.dest}`"
    facts = []
    if action.required or not action.option_strings:
        facts.append("required")
    if action.choices is not None:
        facts.append("one of " + ", ".join(f"`{c}`" for c in action.choices))
    if action.option_strings and action.nargs != 0 and action.default not in (None, argparse.SUPPRESS):
        facts.append(f"default `{action.default}`")
    help_text = "" if action.help in (None, argparse.SUPPRESS) else plain(" ".join(action.help.split()))
    tail = f" ({'; '.join(facts)})" if facts else ""
    return [names, f": {help_text}{tail}", ""]


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def _helps(parser: argparse.ArgumentParser) -> dict[str, str]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return {a.dest: a.help or "" for a in action._choices_actions}
    return {}


def render(parser: argparse.ArgumentParser | None = None) -> str:
    """The whole page as MyST Markdown."""
    parser = parser or build_parser()
    lines = [INTRO, "```text", parser.format_usage().strip(), "```", ""]
    helps = _helps(parser)
    subs = _subparsers(parser)
    lines += ["| command | does |", "|---|---|"]
    lines += [f"| [`{name}`](#mjtrack-{name}) | {plain(helps.get(name, ''))} |" for name in subs]
    lines.append("")
    for name, sub in subs.items():
        lines += [f"({'mjtrack-' + name})=", f"## `mjtrack {name}`", ""]
        lines += [p + "\n" for p in _paragraphs(sub.description or helps.get(name, ""))]
        lines += ["```text", sub.format_usage().strip(), "```", ""]
        for action in sub._actions:
            if isinstance(action, argparse._HelpAction):
                continue
            lines += _argument(action)
    return "\n".join(lines)


def write_page(out: Path = DEFAULT_OUT) -> Path:
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(render())
    return out


def _on_builder_inited(app) -> None:
    write_page(Path(app.srcdir) / "reference" / "cli.md")


def setup(app):
    app.connect("builder-inited", _on_builder_inited)
    return {"version": "1", "parallel_read_safe": True}


if __name__ == "__main__":
    print(write_page(Path(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT_OUT))
