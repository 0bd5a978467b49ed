"""Run the thesis reproductions: a registry of sections, figures and ``DIR/thesis.json``.

Each chapter-4 experiment is a :class:`Section` in :data:`SECTIONS`: a pure ``compute()``
returning a result object, ``summarize(result)`` giving the JSON-ready numbers, and
``plot(result, out_dir)`` writing PNG figures and returning ``{figure number: {"file",
"caption"}}``. :func:`run_thesis` runs them in registry order and writes ``thesis.json``
atomically, one top-level key per section::

    {"thesis": ..., "sections": ["4.1"], "figures": [...], "4.1": {..., "figures": {...}}}

Adding a section is one entry in :data:`SECTIONS`.
"""

from __future__ import annotations

import json
import logging
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable

from mjtrack.errors import InputError
from mjtrack.io.atomic import atomic_write_text, make_output_dir
from mjtrack.progress import Progress
from mjtrack.thesis import ex41, ex42, figures

log = logging.getLogger(__name__)

JSON_NAME = "thesis.json"
SOURCE = "tracked-robot-models-thesis (Polish, shared/seeds/tracked-robot-models-thesis.pl.txt), chapter 4"


@dataclass(frozen=True)
class Section:
    """One thesis experiment: key ("4.1"), title, and its three steps (see module docstring)."""

    key: str
    title: str
    compute: Callable[[], Any]
    summarize: Callable[[Any], dict]
    plot: Callable[[Any, Path], dict]


SECTIONS: dict[str, Section] = {
    "4.1": Section(
        "4.1",
        "Behaviour of the tracked-robot models: MPP, MICR and MVIR drive the same U-shaped path",
        ex41.compute,
        ex41.summary,
        figures.plot_ex41,
    ),
    "4.2": Section(
        "4.2",
        "EKF estimation of the kinematic models' parameters: slip, ICR and virtual-robot filters",
        ex42.compute,
        ex42.summary,
        ex42.plot,
    ),
}


def run_thesis(out_dir, *, quiet: bool = False, sections: Iterable[str] | None = None) -> dict:
    """Run the registered sections (all by default), write their PNGs and ``out_dir/thesis.json``.

    Args:
        out_dir: output folder (created if missing).
        quiet: no progress display (it is shown only when stderr is a terminal anyway).
        sections: keys of :data:`SECTIONS` to run, in this order.
    Returns:
        The document written to ``thesis.json``.
    """
    keys = list(SECTIONS) if sections is None else list(sections)
    unknown = [k for k in keys if k not in SECTIONS]
    if unknown:
        raise InputError(f"unknown thesis section(s) {', '.join(unknown)}; known: {', '.join(SECTIONS)}")
    out = Path(out_dir)
    make_output_dir(out)
    doc: dict = {"thesis": SOURCE, "command": "mjtrack thesis", "sections": keys, "figures": []}
    with Progress(2 * len(keys), label="thesis", quiet=quiet) as bar:
        for key in keys:
            section = SECTIONS[key]
            start = time.perf_counter()
            result = section.compute()
            entry = {"title": section.title, **section.summarize(result)}
            bar.update(note=f"{key} computed")
            entry["figures"] = section.plot(result, out)
            doc["figures"].extend(f["file"] for f in entry["figures"].values())
            entry["seconds"] = round(time.perf_counter() - start, 3)
            doc[key] = entry
            bar.update(note=f"{key} plotted")
            log.info("thesis %s: %d figures in %.2f s", key, len(entry["figures"]), entry["seconds"])
    atomic_write_text(out / JSON_NAME, json.dumps(doc, indent=2, allow_nan=False) + "\n")
    return doc
