"""Drive logs (docs/reference/formats/drive-log.md): what ``simulate`` writes and ``validate``/``diagnose`` read.

A drive log is a CSV file with one header row and one row per sample. Required columns:
``t`` [s], ``v_left_cmd``, ``v_right_cmd`` [m/s], ``x``, ``y`` [m], ``yaw`` [rad]; optional
known columns: ``v_left``, ``v_right`` [m/s] (measured track speeds), ``vx``, ``vy`` [m/s],
``wz`` [rad/s] (body twist of the geometric centre) and ``window`` (integer segment id);
any other column is kept in :attr:`DriveLog.extra` and written back.

Segments: a segment is a maximal run of consecutive rows with the same ``window`` id (the
whole log when there is no ``window`` column). Time must increase strictly inside a segment;
between segments it may jump (gaps) or even go back. The rows of one window must be
contiguous: an id that reappears after another id is refused, because "segment k" would
otherwise be ambiguous.

Bad input raises :class:`~mjtrack.errors.InputError` with one line that names the file, the
column and the first bad row as a *file line number* (the header is line 1, so the first data
row is line 2; blank lines count, as in an editor)::

    run.csv: line 7, column 't': time not strictly increasing inside window 0 (0.25 after 0.3)

Exactness: floats are written with ``repr`` (the shortest string that parses back to the same
double), so ``read_log`` of a written log returns bit-identical arrays, and the same content
always gives the same bytes.
"""

from __future__ import annotations

import builtins
import csv
import dataclasses
import io
import logging
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, Callable, Iterator, Mapping

import numpy as np

from mjtrack.errors import InputError
from mjtrack.io.atomic import atomic_open
from mjtrack.io.robot import Robot, read_robot

log = logging.getLogger(__name__)

REQUIRED: tuple[str, ...] = ("t", "v_left_cmd", "v_right_cmd", "x", "y", "yaw")
OPTIONAL: tuple[str, ...] = ("v_left", "v_right", "vx", "vy", "wz", "z", "roll", "pitch", "window")
KNOWN: tuple[str, ...] = REQUIRED + OPTIONAL

# Physical plausibility: a value beyond these bounds is a unit mix-up, a corrupt file or a sim
# that blew up, never a ground robot; it is refused like a non-number (docs/reference/formats/drive-log.md).
_SPEED = (100.0, "m/s", "a track or body speed")
PLAUSIBLE: Mapping[str, tuple[float, str, str]] = MappingProxyType({
    "t": (1e10, "s", "a time (an epoch time stamp is 1.7e9 s)"),
    "v_left_cmd": _SPEED, "v_right_cmd": _SPEED, "v_left": _SPEED, "v_right": _SPEED, "vx": _SPEED, "vy": _SPEED,
    "x": (1e6, "m", "a coordinate"), "y": (1e6, "m", "a coordinate"), "z": (1e6, "m", "a coordinate"),
    "yaw": (1e6, "rad", "a heading (even unwrapped)"), "roll": (1e6, "rad", "an angle"),
    "pitch": (1e6, "rad", "an angle"), "wz": (100.0, "rad/s", "a yaw rate"),
})


@dataclass(frozen=True, eq=False)
class DriveLog:
    """A drive log held as read-only 1-D numpy arrays of one common length ``n``.

    Attributes:
        t: time, (n,) [s], strictly increasing inside each segment.
        v_left_cmd, v_right_cmd: commanded track surface speeds, (n,) [m/s].
        x, y, yaw: world pose of the geometric centre, (n,) [m, m, rad] (yaw may be wrapped).
        v_left, v_right: measured track speeds, (n,) [m/s], or ``None``.
        vx, vy, wz: body-frame twist of the geometric centre, (n,) [m/s, m/s, rad/s], or ``None``.
        z, roll, pitch: height of the geometric centre and the chassis' roll and pitch (Z-Y-X
            Euler angles after yaw), (n,) [m, rad, rad], or ``None``; written on terrain. On any
            terrain x, y are horizontal and yaw is the heading of the body x axis projected on
            the horizontal plane.
        window: integer segment ids, (n,) int64, or ``None`` (the whole log is one segment).
        extra: other columns by name, in file order: int64, float64 or str arrays of shape (n,)
            (a read-only mapping).
        source: the file it was read from, for messages; not part of equality.

    Required columns must be finite; optional ones may hold NaN (a missing measurement).
    Construction validates everything and raises :class:`InputError` (rows counted from 0).
    Equality compares every column exactly (NaN equals NaN), not ``source``.
    """

    t: np.ndarray
    v_left_cmd: np.ndarray
    v_right_cmd: np.ndarray
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    v_left: np.ndarray | None = None
    v_right: np.ndarray | None = None
    vx: np.ndarray | None = None
    vy: np.ndarray | None = None
    wz: np.ndarray | None = None
    z: np.ndarray | None = None
    roll: np.ndarray | None = None
    pitch: np.ndarray | None = None
    window: np.ndarray | None = None
    extra: Mapping[str, np.ndarray] = field(default_factory=dict)
    source: str | None = None

    def __post_init__(self) -> None:
        src = self.source or "drive log"
        if self.source is not None:
            object.__setattr__(self, "source", str(self.source))
        n = None
        for name in KNOWN:
            value = getattr(self, name)
            if value is None:
                if name in REQUIRED:
                    raise InputError(f"{src}: missing required column '{name}'")
                continue
            arr = _as_column(value, name, src, integer=(name == "window"))
            if n is None:
                n = arr.shape[0]
            if arr.shape[0] != n:
                raise InputError(f"{src}: column '{name}' has {arr.shape[0]} rows, 't' has {n}")
            object.__setattr__(self, name, arr)
        if n == 0:
            raise InputError(f"{src}: no data rows")
        extra = {}
        for name, value in dict(self.extra).items():
            if name in KNOWN or not isinstance(name, str) or not name:
                raise InputError(f"{src}: bad extra column name {name!r}")
            arr = _as_extra(value, name, src)
            if arr.shape != (n,):
                raise InputError(f"{src}: column '{name}' has shape {arr.shape}, expected ({n},)")
            extra[name] = arr
        object.__setattr__(self, "extra", MappingProxyType(extra))
        problem = _first_problem(self.to_columns())
        if problem is not None:
            name, row, what = problem
            raise InputError(f"{src}: row {row}, column '{name}': {what}")

    # -- construction -------------------------------------------------------------------
    @classmethod
    def from_columns(cls, columns: Mapping[str, Any], *, source: str | os.PathLike | None = None) -> "DriveLog":
        """Build from ``{column name: 1-D array}``; names outside :data:`KNOWN` go to ``extra``."""
        known = {k: v for k, v in columns.items() if k in KNOWN}
        extra = {k: v for k, v in columns.items() if k not in KNOWN}
        src = str(source) if source is not None else None
        for name in REQUIRED:
            if name not in known:
                raise InputError(f"{src or 'drive log'}: missing required column '{name}'")
        return cls(**known, extra=extra, source=src)

    def replace(self, **changes: Any) -> "DriveLog":
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    # -- views ----------------------------------------------------------------------------
    def to_columns(self) -> dict[str, np.ndarray]:
        """All columns in file order: required, optional present (in :data:`OPTIONAL` order), extras."""
        cols = {name: getattr(self, name) for name in KNOWN if getattr(self, name) is not None}
        cols.update(self.extra)
        return cols

    @property
    def n_samples(self) -> int:
        return int(self.t.shape[0])

    def __len__(self) -> int:
        return self.n_samples

    @property
    def duration(self) -> float:
        """``t[-1] - t[0]`` [s] (gaps between segments included)."""
        return float(self.t[-1] - self.t[0])

    @property
    def has_track_speeds(self) -> bool:
        """Both measured track speeds are present."""
        return self.v_left is not None and self.v_right is not None

    @property
    def has_twist(self) -> bool:
        """The body twist (vx, vy, wz) is present."""
        return self.vx is not None and self.vy is not None and self.wz is not None

    def segment_slices(self) -> list[builtins.slice]:
        """Index ranges of the segments, in file order."""
        if self.window is None:
            return [builtins.slice(0, self.n_samples)]
        cuts = np.flatnonzero(self.window[1:] != self.window[:-1]) + 1
        bounds = [0, *cuts.tolist(), self.n_samples]
        return [builtins.slice(a, b) for a, b in zip(bounds[:-1], bounds[1:])]

    def segments(self) -> list["DriveLog"]:
        """One :class:`DriveLog` per segment (window id), in file order."""
        return [self[s] for s in self.segment_slices()]

    def slice(self, start: int | None = None, stop: int | None = None) -> "DriveLog":
        """Rows ``start:stop`` (Python slice semantics, step 1) as a new log."""
        return self[builtins.slice(start, stop)]

    def __getitem__(self, index: builtins.slice | np.ndarray) -> "DriveLog":
        """Rows selected by a slice, an index array or a boolean mask, as a new log."""
        changes = {name: getattr(self, name)[index] for name in KNOWN if getattr(self, name) is not None}
        return dataclasses.replace(self, **changes, extra={k: v[index] for k, v in self.extra.items()})

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, DriveLog):
            return NotImplemented
        a, b = self.to_columns(), other.to_columns()
        return list(a) == list(b) and all(_same(a[k], b[k]) for k in a)

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return (
            f"DriveLog(n_samples={self.n_samples}, columns={list(self.to_columns())}, "
            f"segments={len(self.segment_slices())}, source={self.source!r})"
        )


# -- validation -------------------------------------------------------------------------
def _as_column(value: Any, name: str, src: str, *, integer: bool) -> np.ndarray:
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{src}: column '{name}' is not numeric") from None
    if arr.ndim != 1:
        raise InputError(f"{src}: column '{name}' must be 1-D, got shape {arr.shape}")
    if integer:
        bad = ~np.isfinite(arr) | (arr != np.round(arr))
        if bad.any():
            row = int(np.argmax(bad))
            raise InputError(
                f"{src}: row {row}, column '{name}': window id must be an integer, got {float(arr[row])!r}"
            )
        arr = arr.astype(np.int64)
    arr.setflags(write=False)
    return arr


def _as_extra(value: Any, name: str, src: str) -> np.ndarray:
    arr = np.array(value)
    if arr.dtype.kind in "biu":  # booleans are written and read back as 0/1
        arr = arr.astype(np.int64)
    elif arr.dtype.kind == "f":
        arr = arr.astype(np.float64)
    elif arr.dtype.kind not in "UO":
        raise InputError(f"{src}: column '{name}' has unsupported dtype {arr.dtype}")
    arr.setflags(write=False)
    return arr


def _first_problem(cols: Mapping[str, np.ndarray]) -> tuple[str, int, str] | None:
    """First bad cell as ``(column, row index from 0, what is wrong)``, or ``None``.

    Checks, in order: non-finite values in required columns (file column order), values
    beyond :data:`PLAUSIBLE` bounds (NaN allowed in optional columns: missing), windows
    that are not contiguous, time not strictly increasing inside a segment.
    """
    for name in cols:
        if name in REQUIRED:
            bad = ~np.isfinite(cols[name])
            if bad.any():
                row = int(np.argmax(bad))
                return name, row, f"{float(cols[name][row])!r} in a required column (must be finite)"
    for name in cols:
        if name in PLAUSIBLE and cols[name].dtype.kind in "fi":
            limit, unit, what = PLAUSIBLE[name]
            a = cols[name].astype(np.float64)
            bad = ~np.isnan(a) & ~(np.abs(a) <= limit)
            if bad.any():
                row = int(np.argmax(bad))
                return name, row, (f"{float(a[row])!r} {unit} is beyond physical plausibility for {what} "
                                   f"(|value| <= {limit:g} {unit})")
    window = cols.get("window")
    same = np.ones(len(cols["t"]) - 1, bool) if window is None else window[1:] == window[:-1]
    if window is not None:
        starts = np.concatenate(([0], np.flatnonzero(~same) + 1))
        ids = window[starts]
        _, first = np.unique(ids, return_index=True)
        if len(first) != len(ids):
            k = min(set(range(len(ids))) - set(first.tolist()))
            row = int(starts[k])
            what = f"window id {int(ids[k])} appears again after other windows (rows of a window must be contiguous)"
            return "window", row, what
    t = cols["t"]
    bad = same & (np.diff(t) <= 0)
    if bad.any():
        row = int(np.argmax(bad)) + 1
        inside = "" if window is None else f" inside window {int(window[row])}"
        return "t", row, f"time not strictly increasing{inside} ({float(t[row])!r} after {float(t[row - 1])!r})"
    return None


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    if a.shape != b.shape:
        return False
    if a.dtype.kind == "f" and b.dtype.kind == "f":
        return bool(np.array_equal(a, b, equal_nan=True))
    return bool(np.array_equal(a, b))


# -- reading ----------------------------------------------------------------------------
def read_log(path: str | os.PathLike) -> DriveLog:
    """Read a drive log CSV; bad input raises :class:`InputError` naming file, column and line.

    Cell parsing follows Python's ``float``. In optional known columns an empty cell means
    NaN (a missing measurement); in required columns it is an error. Extra columns become
    int64 if every cell is an integer, else float64 if every cell is a number, else str.
    """
    path = Path(path)
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            reader = csv.reader(fh)
            rows: list[list[str]] = []
            lines: list[int] = []
            header = None
            for row in reader:
                if not row or (len(row) == 1 and not row[0].strip()):
                    continue  # blank line
                if header is None:
                    header, header_line = [c.strip() for c in row], reader.line_num
                else:
                    rows.append(row)
                    lines.append(reader.line_num)
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        why = getattr(exc, "strerror", None) or str(exc)
        raise InputError(f"{path}: cannot read drive log ({why})") from None

    if header is None:
        raise InputError(f"{path}: line 1: empty file, expected a header with columns {', '.join(REQUIRED)}")
    for j, name in enumerate(header):
        if not name:
            raise InputError(f"{path}: line {header_line}, column {j + 1}: empty column name")
        if name in header[:j]:
            raise InputError(f"{path}: line {header_line}, column '{name}': duplicate column name")
    missing = [name for name in REQUIRED if name not in header]
    if missing:
        raise InputError(
            f"{path}: line {header_line}, column '{missing[0]}': missing required column"
            + (f" (also missing: {', '.join(missing[1:])})" if missing[1:] else "")
        )
    if not rows:
        raise InputError(f"{path}: line {header_line + 1}: no data rows after the header")
    width = len(header)
    for row, line in zip(rows, lines):
        if len(row) != width:
            raise InputError(f"{path}: line {line}: {len(row)} fields, the header has {width}")

    cells = list(zip(*rows))
    columns: dict[str, np.ndarray] = {}
    for j, name in enumerate(header):
        where = lambda i, name=name: f"{path}: line {lines[i]}, column '{name}'"  # noqa: E731
        if name in REQUIRED:
            columns[name] = _parse_float(cells[j], where, empty_is_nan=False)
        elif name in OPTIONAL:
            columns[name] = _parse_float(cells[j], where, empty_is_nan=True)
            if name == "window":
                columns[name] = _window_ids(columns[name], where)
        else:
            columns[name] = _parse_extra(cells[j])
    problem = _first_problem({k: columns[k] for k in header if k in KNOWN or k in PLAUSIBLE})
    if problem is not None:
        name, row, what = problem
        raise InputError(f"{path}: line {lines[row]}, column '{name}': {what}")
    log.debug("read %s: %d rows, columns %s", path, len(rows), header)
    return DriveLog.from_columns(columns, source=path)


def _parse_float(cells: tuple[str, ...], where: Callable[[int], str], *, empty_is_nan: bool) -> np.ndarray:
    try:
        return np.fromiter(map(float, cells), np.float64, len(cells))
    except ValueError:
        pass
    out = np.empty(len(cells))
    for i, cell in enumerate(cells):
        if not cell.strip():
            if not empty_is_nan:
                raise InputError(f"{where(i)}: empty value in a required column")
            out[i] = math.nan
            continue
        try:
            out[i] = float(cell)
        except ValueError:
            raise InputError(f"{where(i)}: not a number: {cell!r}") from None
    return out


def _window_ids(values: np.ndarray, where: Callable[[int], str]) -> np.ndarray:
    bad = ~np.isfinite(values) | (values != np.round(values))
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(f"{where(i)}: window id must be an integer, got {float(values[i])!r}")
    return values.astype(np.int64)


def _parse_extra(cells: tuple[str, ...]) -> np.ndarray:
    for kind in (int, float):
        try:
            return np.fromiter(map(kind, cells), np.int64 if kind is int else np.float64, len(cells))
        except (ValueError, OverflowError):
            pass
    return np.array(cells, dtype=str)


# -- writing ----------------------------------------------------------------------------
def write_log(log_: DriveLog, path: str | os.PathLike) -> None:
    """Write ``log_`` to ``path`` atomically (temp file renamed at the end).

    Column order: :data:`REQUIRED`, present :data:`OPTIONAL` columns, extras in their order.
    Floats are written with ``repr`` (exact round trip), integers as integers, ``\\n`` line ends.
    """
    with atomic_open(path, "w", newline="", encoding="utf-8") as fh:
        _write_csv(fh, log_)


def _write_csv(fh: Any, log_: DriveLog) -> None:
    cols = log_.to_columns()
    writer = csv.writer(fh, lineterminator="\n")
    writer.writerow(list(cols))
    writer.writerows(zip(*(_format(a) for a in cols.values())))


def _format(arr: np.ndarray) -> Iterator[str]:
    if arr.dtype.kind == "f":
        return map(float.__repr__, arr.tolist())
    return map(str, arr.tolist())


def log_to_csv_text(log_: DriveLog) -> str:
    """The exact text :func:`write_log` writes (for tests and in-memory use)."""
    buf = io.StringIO(newline="")
    _write_csv(buf, log_)
    return buf.getvalue()


# -- log + robot -------------------------------------------------------------------------
def robot_path_for(log_path: str | os.PathLike) -> Path:
    """``LOG.json`` beside ``LOG.csv``: the robot description that goes with a log.

    Raises:
        InputError: ``log_path`` names no file (empty, ``.``, a path ending in ``/``).
    """
    path = Path(log_path)
    if not path.name or str(log_path).endswith(os.sep):
        raise InputError(f"{str(log_path)!r}: not a file name")
    return path.with_suffix(".json")


def read_log_with_robot(
    path: str | os.PathLike, robot_path: str | os.PathLike | None = None
) -> tuple[DriveLog, Robot]:
    """Read a log and its robot: ``robot_path`` if given, else ``LOG.json`` beside the log.

    Raises :class:`InputError` when neither exists (the robot's ``track_gauge`` is required).
    """
    drive_log = read_log(path)
    if robot_path is None:
        robot_path = robot_path_for(path)
        if not robot_path.exists():
            raise InputError(
                f"{path}: no robot description: {robot_path} does not exist and no robot_path FILE "
                "was given (a robot JSON with at least 'track_gauge' is required)"
            )
    return drive_log, read_robot(robot_path)
