"""Ctrl-C (SIGINT) and SIGTERM: end a command quickly, with one line, and no half result.

:func:`handling` installs, for the duration of a command, handlers that raise
:class:`Interrupted` in the main thread; the command unwinds through its ``with`` blocks (temp
files removed, a dask cluster closed, written outputs rolled back by
:class:`mjtrack.io.atomic.OutputTransaction`) and the command line prints one line and exits
128 + the signal number (130 for SIGINT, 143 for SIGTERM).

Python runs a signal handler only between two bytecodes of the main thread, so a long call into
C code (one ``mujoco.rollout`` of a whole log) would hold the interrupt until it returns. The
long rollouts therefore run in chunks (:mod:`mjtrack.sim.rollout`), and a watchdog thread woken by
the signal itself (``signal.set_wakeup_fd``) ends the process after :data:`GRACE_S` if the main
thread has still not finished: it runs the registered emergency clean-ups (temporary files,
outputs of the interrupted command), prints the line and calls ``os._exit``. The watchdog can
run because MuJoCo releases the GIL while it steps.

:func:`deferred` marks a short section that must not be cut (moving a finished set of files into
place): a signal received inside is acted on when it ends.

No mjtrack import: every layer may use this module.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time
from typing import Callable, Iterator

GRACE_S = 1.0  # [s] after a signal, the main thread's time to unwind before the watchdog ends the process
DEFERRED_MAX_S = 10.0  # [s] longest wait for a deferred section before the watchdog acts anyway
SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(KeyboardInterrupt):
    """Raised in the main thread on SIGINT or SIGTERM (a KeyboardInterrupt, so that code which
    already treats Ctrl-C specially keeps doing so)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum

    @property
    def exit_status(self) -> int:
        """128 + the signal number, as a shell reports a command killed by it."""
        return 128 + self.signum


class _State:
    def __init__(self) -> None:
        self.received: int | None = None  # first signal received
        self.deferred = 0  # depth of deferred() sections
        self.pending: int | None = None  # a signal received inside a deferred section
        self.raised = False
        self.cleanups: list[Callable[[], None]] = []
        self.message: Callable[[int], str] = lambda signum: f"interrupted by {signal.Signals(signum).name}"
        self.active = False
        self.redelivered = 0  # interrupts swallowed where Python ignores exceptions


_state = _State()


def received() -> int | None:
    """The signal number received in the current or last :func:`handling` block (None if none)."""
    return _state.received


def add_emergency_cleanup(func: Callable[[], None]) -> None:
    """Run ``func`` (no arguments, must not raise) if the watchdog has to end the process."""
    _state.cleanups.append(func)


def _unraisable(info) -> None:
    """``sys.unraisablehook`` while handling: an Interrupted raised where Python ignores exceptions
    (a weakref callback inside an import, a ``__del__``) would print "Exception ignored" and be
    lost; it is dropped without a word, and the watchdog, which saw the signal, ends the process
    after its grace period (a second signal is raised again)."""
    if isinstance(getattr(info, "exc_value", None), Interrupted) and _state.active:
        _state.raised = False
        _state.redelivered += 1
        return
    sys.__unraisablehook__(info)


def _handler(signum: int, frame) -> None:
    if _state.received is None:
        _state.received = signum
    if _state.deferred:
        _state.pending = _state.pending or signum
        return
    if not _state.raised:  # once: a second Ctrl-C must not cut the clean-up of the first short
        _state.raised = True
        raise Interrupted(signum)


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """A section that a signal does not cut: the signal takes effect when the section ends."""
    _state.deferred += 1
    try:
        yield
    finally:
        _state.deferred -= 1
    if not _state.deferred and _state.pending is not None and _state.active and not _state.raised:
        signum, _state.pending = _state.pending, None
        _state.raised = True
        raise Interrupted(signum)


def _write_line(line: str, err_fd: int | None, stream) -> None:
    """``line`` on the standard error the command started with (a dup of its fd: a block that sends
    fd 2 elsewhere, :func:`silent_children`, must not swallow it), else on ``stream``."""
    try:
        if err_fd is not None:
            os.write(err_fd, (line + "\n").encode("utf-8", "replace"))
        else:
            stream.write(line + "\n")
            stream.flush()
    except Exception:
        pass


def _watchdog(read_fd: int, done: threading.Event, stream, err_fd: int | None) -> None:
    while True:
        try:
            data = os.read(read_fd, 64)
        except OSError:
            return
        if done.is_set() or not data:
            return
        signums = [b for b in data if b in {int(s) for s in SIGNALS}]
        if not signums:
            continue
        signum = _state.received or signums[0]
        if done.wait(GRACE_S):
            return
        start = time.monotonic()
        while _state.deferred and time.monotonic() - start < DEFERRED_MAX_S:
            if done.wait(0.05):
                return
        if done.is_set():
            return
        for func in list(_state.cleanups):
            try:
                func()
            except Exception:  # best effort: the process ends now whatever happens
                pass
        _write_line(_state.message(signum), err_fd, stream)
        os._exit(128 + signum)


@contextlib.contextmanager
def handling(message: Callable[[int], str] | None = None, *, stream=None, then_ignore: bool = False) -> Iterator[None]:
    """Install the SIGINT/SIGTERM handlers and the watchdog for the ``with`` block.

    Args:
        message: the one line the watchdog prints if it has to end the process (given the
            signal number); the caller prints its own line when the block unwinds normally.
        stream: where the watchdog writes (default ``sys.stderr`` at entry).
        then_ignore: after the block, ignore SIGINT and SIGTERM instead of restoring the previous
            handlers (a program about to exit with a result it has already reported).

    Outside the main thread (where Python cannot set handlers) it does nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.getsignal(s) for s in SIGNALS}
    saved = (_state.deferred, _state.pending, _state.raised, list(_state.cleanups), _state.message, _state.active)
    _state.received, _state.deferred, _state.pending, _state.raised = None, 0, None, False
    _state.cleanups = []
    if message is not None:
        _state.message = message
    _state.active = True
    previous_hook = sys.unraisablehook
    sys.unraisablehook = _unraisable
    _state.redelivered = 0
    for s in SIGNALS:  # first: a signal from now on is ours, even while the watchdog starts
        signal.signal(s, _handler)
    read_fd, write_fd = os.pipe()
    os.set_blocking(write_fd, False)
    done = threading.Event()
    old_fd = signal.set_wakeup_fd(write_fd, warn_on_full_buffer=False)
    stream = stream or sys.stderr
    try:
        err_fd = os.dup(stream.fileno())
    except (AttributeError, OSError, ValueError):  # a stream without a file (a test's StringIO)
        err_fd = None
    watchdog = threading.Thread(target=_watchdog, args=(read_fd, done, stream, err_fd), daemon=True,
                                name="mjtrack-interrupt-watchdog")
    try:
        watchdog.start()
    except BaseException:  # interrupted while starting: undo, and let the interrupt through
        signal.set_wakeup_fd(old_fd)
        for fd in (write_fd, read_fd, err_fd):
            if fd is not None:
                os.close(fd)
        for s, h in previous.items():
            signal.signal(s, h)
        sys.unraisablehook = previous_hook
        _state.deferred, _state.pending, _state.raised, _state.cleanups, _state.message, _state.active = saved
        raise
    try:
        yield
    finally:
        done.set()
        for s, h in previous.items():
            signal.signal(s, signal.SIG_IGN if then_ignore else h)
        sys.unraisablehook = previous_hook
        signal.set_wakeup_fd(old_fd)
        with contextlib.suppress(OSError):
            os.write(write_fd, b"\0")  # wake the watchdog so that it sees `done`
        watchdog.join(timeout=1.0)
        for fd in (write_fd, read_fd, err_fd):
            if fd is not None:
                os.close(fd)
        # `received` stays: the caller reads it after the block to tell an interrupt's aftermath
        _state.deferred, _state.pending, _state.raised, _state.cleanups, _state.message, _state.active = saved


@contextlib.contextmanager
def silent_children() -> Iterator[None]:
    """Child processes started in the block write their stderr to /dev/null.

    A Ctrl-C in a terminal reaches the whole process group; the workers of a dask cluster would
    each print a KeyboardInterrupt traceback. Neither a blocked mask nor a handler survives the
    ``exec`` of multiprocessing's spawn, and an ignored SIGINT would also be ignored here during
    the block, so instead the children's standard error goes nowhere: this process reports their
    failures (they come back as task errors) and prints the one line. This process's own standard
    error is silent during the block too (nothing is written there while a cluster starts)."""
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError, AttributeError):  # no real fd 2 (an embedding host): nothing to do
        yield
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(devnull)
