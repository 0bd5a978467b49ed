"""A small progress display for long work (rollouts, filter runs, sweeps).

On a terminal it redraws one line on stderr::

    rollouts [##########----------]  12/24  50%  0:07 elapsed, ~0:07 left

It writes nothing when ``quiet`` is true or when the stream is not a TTY (pipes, files, CI,
tests), so library code can use it unconditionally. Redraws are throttled (``min_interval``)
and the final state is always drawn, followed by a newline, when the work ends, even on an
exception (so that an error message starts on a fresh line). No dependency.

Two ways to use it::

    for item in progress(items, label="rollouts", quiet=args.quiet):
        ...

    with Progress(total=n, label="EKF") as bar:
        for k in range(n):
            ...
            bar.update()
"""

from __future__ import annotations

import shutil
import sys
import time
from typing import Callable, Iterable, Iterator, TextIO, TypeVar

T = TypeVar("T")

_BAR = 20  # characters of the bar


def _is_tty(stream: TextIO) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # no isatty, or a closed stream
        return False


def clock_text(seconds: float) -> str:
    seconds = int(round(seconds))
    h, rest = divmod(seconds, 3600)
    m, s = divmod(rest, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


class Progress:
    """Counts done items and shows them on a TTY.

    Args:
        total: number of items expected, or ``None`` if unknown (no bar, no percentage).
        label: what is counted, shown first.
        quiet: never draw.
        stream: where to draw; ``sys.stderr`` at construction time by default.
        clock: seconds, monotonic (injectable for tests).
        min_interval: least time between two redraws [s].
    """

    def __init__(
        self,
        total: int | None = None,
        *,
        label: str = "",
        quiet: bool = False,
        stream: TextIO | None = None,
        clock: Callable[[], float] = time.monotonic,
        min_interval: float = 0.1,
    ) -> None:
        self.total = total
        self.label = label
        self.stream = sys.stderr if stream is None else stream
        self.enabled = not quiet and _is_tty(self.stream)
        self.count = 0
        self.note = ""
        self._clock = clock
        self._start = clock()
        self._last_draw = -float("inf")
        self._width = 0
        self._drawn = -1  # count at the last draw
        self._closed = False
        self.min_interval = min_interval

    @property
    def elapsed(self) -> float:
        """Seconds since the display was created."""
        return self._clock() - self._start

    def update(self, n: int = 1, *, note: str | None = None) -> None:
        """``n`` more items done; ``note`` replaces the short text shown after the counts."""
        self.count += n
        if note is not None:
            self.note = note
        if self.enabled and self._clock() - self._last_draw >= self.min_interval:
            self._draw()

    def redraw(self) -> None:
        """Draw the line now, unthrottled (a new stage in the label is news; a count is not)."""
        if self.enabled and not self._closed:
            self._draw()

    def say(self, text: str) -> None:
        """A line of its own (a stage's start, an expected duration) above the bar, which is then
        drawn again below it; on a TTY only, never when quiet, like the bar."""
        if not self.enabled or self._closed:
            return
        self.stream.write("\r" + " " * self._width + "\r" + text + "\n")
        self._width = 0
        self._draw()

    def text(self) -> str:
        """The line as it would be drawn now (without the carriage return)."""
        parts = [self.label] if self.label else []
        elapsed = self.elapsed
        if self.total:
            frac = min(max(self.count / self.total, 0.0), 1.0)
            filled = int(frac * _BAR)
            parts.append("[" + "#" * filled + "-" * (_BAR - filled) + "]")
            width = len(str(self.total))
            parts.append(f"{self.count:>{width}}/{self.total}")
            parts.append(f"{100 * frac:3.0f}%")
            timing = f"{clock_text(elapsed)} elapsed"
            if 0 < self.count < self.total:
                timing += f", ~{clock_text(elapsed * (self.total - self.count) / self.count)} left"
            parts.append(timing)
        else:
            parts.append(str(self.count))
            parts.append(f"{clock_text(elapsed)} elapsed")
        if self.note:
            parts.append(self.note)
        return "  ".join(parts)

    def _draw(self) -> None:
        columns = shutil.get_terminal_size((80, 24)).columns
        line = self.text()[: max(columns - 1, 10)]
        self.stream.write("\r" + line + " " * max(self._width - len(line), 0))
        self.stream.flush()
        self._width = len(line)
        self._drawn = self.count
        self._last_draw = self._clock()

    def close(self) -> None:
        """Draw the final state and end the line (once; later calls do nothing)."""
        if self._closed:
            return
        self._closed = True
        if self.enabled:
            if self.count != self._drawn:  # the last state may have been throttled away
                self._draw()
            self.stream.write("\n")
            self.stream.flush()

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def progress(
    items: Iterable[T],
    *,
    label: str = "",
    total: int | None = None,
    quiet: bool = False,
    stream: TextIO | None = None,
    clock: Callable[[], float] = time.monotonic,
    min_interval: float = 0.1,
) -> Iterator[T]:
    """Yield ``items`` unchanged while showing progress (``total`` defaults to ``len(items)``)."""
    if total is None:
        try:
            total = len(items)  # type: ignore[arg-type]
        except TypeError:
            total = None
    with Progress(total, label=label, quiet=quiet, stream=stream, clock=clock, min_interval=min_interval) as bar:
        for item in items:
            yield item
            bar.update()
