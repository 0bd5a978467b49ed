"""The one JSON reader behind every JSON input (robot descriptions, terrain specs and patches,
sweep grids): bounded in size and nesting, every failure a one-line InputError; and the one JSON
writer of results (:func:`write_json`, :func:`json_value`).

A file larger than its kind needs is refused before it is read (and at most that much is ever
read, so a device or a growing file cannot exhaust memory); nesting deeper than the kind needs is
refused after parsing (Python's parser itself gives up near a depth of 1000, caught here too).
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from mjtrack.errors import InputError
from mjtrack.io.atomic import atomic_write_text

MAX_PARSER_DEPTH = 1000  # about where Python's json parser raises RecursionError


def nesting_depth(value: Any) -> int:
    """Depth of nested lists and objects in a parsed JSON value (a scalar 0, ``[]`` 1, ``[[1]]`` 2)."""
    depth, stack = 0, [(value, 1)]
    while stack:
        item, level = stack.pop()
        if isinstance(item, dict):
            depth = max(depth, level)
            stack.extend((v, level + 1) for v in item.values())
        elif isinstance(item, list):
            depth = max(depth, level)
            stack.extend((v, level + 1) for v in item)
    return depth


def read_json(path: str | os.PathLike, *, what: str, max_bytes: int, max_depth: int, where: str | None = None) -> Any:
    """Parse the JSON file ``path``.

    Args:
        what: what the file is, for messages ("robot description").
        max_bytes: largest accepted file [bytes].
        max_depth: deepest accepted nesting of lists and objects (:func:`nesting_depth`).
        where: the start of every message (default: the path).
    Raises:
        InputError: one line: cannot read, too large, not UTF-8, not JSON, nested too deeply.
    """
    path = Path(path)
    where = str(path) if where is None else where
    try:
        with open(path, "rb") as fh:
            raw = fh.read(max_bytes + 1)
    except OSError as exc:
        raise InputError(f"{where}: cannot read {what} ({exc.strerror or exc})") from None
    if len(raw) > max_bytes:
        raise InputError(f"{where}: larger than {max_bytes:,} bytes; a {what} is at most that large")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"{where}: not valid JSON (not UTF-8 text at byte {exc.start})") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{where}: not valid JSON (line {exc.lineno}: {exc.msg})") from None
    except RecursionError:
        raise InputError(f"{where}: nested more than {MAX_PARSER_DEPTH} deep; a {what} is nested at most "
                         f"{max_depth} deep") from None
    depth = nesting_depth(data)
    if depth > max_depth:
        raise InputError(f"{where}: nested {depth} deep; a {what} is nested at most {max_depth} deep")
    return data


def json_value(value: Any) -> Any:
    """A copy of ``value`` that strict JSON can hold: numpy floats, integers and booleans as
    Python's, arrays and tuples as lists, mapping keys as strings, NaN and infinities as null
    (JSON has no such numbers; null says "no value")."""
    if isinstance(value, dict):
        return {str(k): json_value(v) for k, v in value.items()}
    if isinstance(value, np.ndarray):
        return json_value(value.tolist())
    if isinstance(value, (list, tuple)):
        return [json_value(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


def write_json(path: str | os.PathLike, value: Any, *, sort_keys: bool = False) -> None:
    """Write ``value`` (through :func:`json_value`) as indented JSON with a final newline,
    atomically (a reader never sees half a file)."""
    text = json.dumps(json_value(value), indent=2, sort_keys=sort_keys, allow_nan=False)
    atomic_write_text(path, text + "\n")

