"""Atomic file output: write to a temporary file in the same folder, rename at the end.

A command that fails half-way therefore leaves no partial file behind. The file gets the
ordinary permissions of a new file (0666 minus the umask), not the 0600 of ``mkstemp``.

A command's outputs as a set: inside :func:`transaction` (the command line opens one per command)
every file written here, and every folder created for them, is recorded; when the block fails or
is interrupted they are removed again, so that an output folder holds a command's complete set or
nothing new (files marked with :meth:`OutputTransaction.keep`, what a resume needs, stay). The same
transaction enforces the overwrite rule: without ``force`` a file that existed before the command
is not replaced (:class:`~mjtrack.errors.InputError` naming the file and ``--force``); the
commands check their outputs before any work, this is the guard behind those checks.

Temporary files still open are listed in :data:`PENDING` so that an emergency exit
(:mod:`mjtrack.interrupts`) can remove them.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from pathlib import Path
from typing import IO, Iterator

from mjtrack.errors import InputError

PENDING: set[str] = set()  # temporary files and folders being written now


def _umask() -> int:
    mask = os.umask(0o022)  # reading the umask means setting it; restore at once
    os.umask(mask)
    return mask


_UMASK = _umask()


class OutputTransaction:
    """The outputs of one command (module docstring).

    Attributes:
        force: existing files may be replaced.
        written: files created or replaced so far, in order.
        created_dirs: folders created for them, outermost first.
        kept: files that survive a rollback (resume state).
    """

    def __init__(self, *, force: bool = False) -> None:
        self.force = force
        self.written: list[Path] = []
        self.created_dirs: list[Path] = []
        self.kept: set[Path] = set()
        self.allowed: set[Path] = set()

    def allow(self, path: str | os.PathLike) -> None:
        """``path`` may be replaced without ``force`` (a command's own resume state)."""
        self.allowed.add(Path(path).absolute())

    def keep(self, path: str | os.PathLike) -> None:
        """``path`` stays when the transaction is rolled back (it is what a resume needs)."""
        self.kept.add(Path(path).absolute())

    def commit(self) -> None:
        """Everything written so far is final: a later rollback keeps it (a complete set of outputs
        must not be undone by an interrupt that arrives after it is in place)."""
        self.kept.update(self.written)

    def discard(self, path: str | os.PathLike) -> None:
        """``path`` no longer stays on a rollback (its resume state has been used up)."""
        self.kept.discard(Path(path).absolute())

    def check_replace(self, path: Path) -> None:
        p = path.absolute()
        if self.force or p in self.allowed or p in self.written or not os.path.lexists(p):
            return
        raise InputError(f"{path}: exists; pass force=True to replace it")

    def record(self, path: Path) -> None:
        p = path.absolute()
        if p not in self.written:
            self.written.append(p)

    def make_dirs(self, folder: Path) -> None:
        """Create ``folder`` and its missing parents, recording the ones created."""
        folder = folder.absolute()
        missing = []
        for p in (folder, *folder.parents):
            if p.exists():
                break
            missing.append(p)
        folder.mkdir(parents=True, exist_ok=True)
        self.created_dirs.extend(reversed(missing))

    def rollback(self) -> None:
        """Remove what the command wrote (except kept files) and the folders it created, if empty."""
        for p in reversed(self.written):
            if p not in self.kept:
                with contextlib.suppress(OSError):
                    p.unlink()
        for d in reversed(self.created_dirs):
            with contextlib.suppress(OSError):
                d.rmdir()  # only when empty: kept files keep their folder


_CURRENT: list[OutputTransaction] = []


def current() -> OutputTransaction | None:
    """The innermost open transaction, or None."""
    return _CURRENT[-1] if _CURRENT else None


@contextlib.contextmanager
def transaction(*, force: bool = False) -> Iterator[OutputTransaction]:
    """Record the outputs written in the block; roll them back if it raises (module docstring)."""
    tx = OutputTransaction(force=force)
    _CURRENT.append(tx)
    try:
        yield tx
    except BaseException:
        tx.rollback()
        raise
    finally:
        _CURRENT.remove(tx)


def emergency_cleanup() -> None:
    """Remove temporary files being written and roll back every open transaction (for an exit
    that cannot unwind the stack; never raises)."""
    for p in list(PENDING):
        with contextlib.suppress(OSError):
            if os.path.isdir(p):
                shutil.rmtree(p, ignore_errors=True)
            else:
                os.unlink(p)
    for tx in list(_CURRENT):
        tx.rollback()


def make_output_dir(folder: str | os.PathLike) -> Path:
    """Create an output folder (and its parents), recorded by the open transaction if any."""
    folder = Path(folder)
    tx = current()
    if tx is None:
        folder.mkdir(parents=True, exist_ok=True)
    else:
        tx.make_dirs(folder)
    return folder


def _prepare(path: Path) -> OutputTransaction | None:
    tx = current()
    if tx is not None:
        tx.check_replace(path)
    make_output_dir(path.parent)
    return tx


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike, mode: str = "w", **kwargs) -> Iterator[IO]:
    """Open a temporary file beside ``path``; on success it replaces ``path``."""
    path = Path(path)
    tx = _prepare(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    PENDING.add(tmp)
    try:
        os.chmod(tmp, 0o666 & ~_UMASK)
        try:
            fh = os.fdopen(fd, mode, **kwargs)
        except BaseException:
            os.close(fd)
            raise
        with fh:
            yield fh
        if tx is not None:
            tx.record(path)  # before the rename: an interrupt between the two still rolls it back
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise
    finally:
        PENDING.discard(tmp)


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """A temporary path with ``path``'s name in a hidden folder beside it; renamed onto ``path`` on success.

    For writers that need a file name rather than a handle (ffmpeg picks the format from the
    extension). The folder is removed in every case.
    """
    path = Path(path)
    tx = _prepare(path)
    with tempfile.TemporaryDirectory(prefix=f".{path.name}.", dir=path.parent) as folder:
        PENDING.add(folder)
        try:
            tmp = Path(folder) / path.name
            yield tmp
            if tx is not None:
                tx.record(path)
            os.replace(tmp, path)
        finally:
            PENDING.discard(folder)


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` as UTF-8 (whatever the locale), line ends untranslated, atomically."""
    with atomic_open(path, "w", encoding="utf-8", newline="") as fh:
        fh.write(text)


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    with atomic_open(path, "wb") as fh:
        fh.write(data)
