"""Saving a running patch's files (presets, gesture examples) off the scheduler's thread, whole or not at all.

A save asked for from live control must not hold the patch up: a save flood at 100 a second, each
rewriting a growing file on the scheduler's thread, once put it 70 s behind its timers.  So a
:class:`Saver` takes the content to write as a function (called on its own thread), keeps only the
latest one per file (a save asked for while another waits replaces it: the latest state wins), writes a
file at most once per ``interval`` seconds, and writes it with :func:`write_atomic` (a temporary file
beside it, ``fsync``, renamed over it, the folder synced): a crash or a kill leaves the old file or the
new, never half of one.  A temporary file a kill left behind is removed at the next start
(:func:`clean_stray`).
"""

from __future__ import annotations

import contextlib
import glob
import itertools
import logging
import math
import os
import threading
import time
from collections.abc import Callable
from pathlib import Path

__all__ = ["Saver", "clean_stray", "temporary_path", "write_atomic"]

log = logging.getLogger("pointat.saving")

_serial = itertools.count(1)


def temporary_path(path: Path) -> Path:
    """Where ``path`` is written before it is renamed: hidden, beside it, this process's (``.NAME.PID-N.tmp``)."""
    return path.with_name(f".{path.name}.{os.getpid()}-{next(_serial)}.tmp")


def write_atomic(path: str | os.PathLike[str], data: bytes | str) -> None:
    """Write ``data`` (text as UTF-8) to ``path`` whole or not at all: a temporary file beside it, synced
    to the disk, renamed over it, and the folder synced (the rename itself survives a power cut)."""
    path = Path(path)
    raw = data.encode("utf-8") if isinstance(data, str) else data
    tmp = temporary_path(path)
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666)
        with os.fdopen(fd, "wb") as fh:
            fh.write(raw)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    sync_folder(path.parent)


def sync_folder(folder: str | os.PathLike[str]) -> None:
    """Sync a folder, so that a rename in it survives a power cut (POSIX; elsewhere nothing)."""
    if hasattr(os, "O_DIRECTORY"):
        with contextlib.suppress(OSError):
            dfd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
            try:
                os.fsync(dfd)
            finally:
                os.close(dfd)


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):  # someone else's process, or a system that cannot tell: leave it
        return True
    return True


def clean_stray(path: str | os.PathLike[str]) -> list[Path]:
    """Remove the temporary files of ``path`` that a process killed mid-save left behind
    (``.NAME.PID-N.tmp`` whose process is gone); the ones removed.  A file of a process still running
    (two patches sharing a file) is left to it."""
    path = Path(path)
    removed = []
    for name in glob.glob(glob.escape(str(path.parent / f".{path.name}.")) + "*.tmp"):
        stray = Path(name)
        pid_text = stray.name[len(path.name) + 2 : -len(".tmp")].split("-")[0]
        if not pid_text.isdigit() or _alive(int(pid_text)):
            continue
        with contextlib.suppress(OSError):
            stray.unlink()
            removed.append(stray)
    if removed:
        log.info("%s: removed %d half-written file(s) a stopped process left beside it", path, len(removed))
    return removed


class Saver:
    """One writer thread for the files its owner saves; ``submit`` returns at once.

    ``make`` is called on the writer's thread and returns the bytes or text to write: it must read only
    what the caller handed it (a copy), never the live state.  ``close`` writes what waits and stops.

    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> saver = Saver("test", interval=0.0)
    >>> for n in range(100):
    ...     saver.submit(folder / "x.json", lambda n=n: f"{n}\\n")
    >>> saver.close()
    >>> (folder / "x.json").read_text(), saver.written <= 100, sorted(p.name for p in folder.iterdir())
    ('99\\n', True, ['x.json'])
    """

    def __init__(self, owner: str, *, interval: float = 0.25):
        self.owner = owner
        self.interval = interval
        #: Files written, and saves that failed (each logged).
        self.written = 0
        self.failed = 0
        self._pending: dict[Path, Callable[[], bytes | str]] = {}
        self._last: dict[Path, float] = {}
        self._busy = False
        self._closed = False
        self._cond = threading.Condition()
        self._thread: threading.Thread | None = None

    def submit(self, path: str | os.PathLike[str], make: Callable[[], bytes | str]) -> None:
        """Write ``make()`` to ``path`` soon (replacing a write of it still waiting); after :meth:`close`,
        at once on this thread."""
        path = Path(path)
        with self._cond:
            if not self._closed:
                self._pending[path] = make
                if self._thread is None:
                    self._thread = threading.Thread(target=self._run, name=f"pointat-save-{self.owner}")
                    self._thread.daemon = True  # close() writes what waits; a kill leaves the old file
                    self._thread.start()
                self._cond.notify_all()
                return
        self._write(path, make)

    def flush(self, timeout: float | None = None) -> bool:
        """Wait until every save asked for is written (or failed); False when ``timeout`` passed first."""
        deadline = None if timeout is None else time.monotonic() + timeout
        with self._cond:
            while self._pending or self._busy:
                left = None if deadline is None else deadline - time.monotonic()
                if left is not None and left <= 0:
                    return False
                self._cond.notify_all()
                self._cond.wait(left if left is not None else 1.0)
        return True

    def close(self, timeout: float = 30.0) -> None:
        """Write what waits (no interval kept), then stop the thread.  Idempotent."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()
            thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout)
            if thread.is_alive():
                log.error("%s: a save still being written after %.0f s", self.owner, timeout)

    def _run(self) -> None:
        while True:
            with self._cond:
                self._busy = False
                self._cond.notify_all()
                while not self._pending and not self._closed:
                    self._cond.wait()
                if not self._pending:  # closed, nothing waits
                    return
                now = time.monotonic()
                due = {p: self._last.get(p, -math.inf) + self.interval for p in self._pending}
                path = min(due, key=due.__getitem__)
                if due[path] > now and not self._closed:
                    self._cond.wait(due[path] - now)
                    continue
                make = self._pending.pop(path)
                self._last[path] = now
                self._busy = True
            self._write(path, make)

    def _write(self, path: Path, make: Callable[[], bytes | str]) -> None:
        try:
            write_atomic(path, make())
            self.written += 1
        except Exception as exc:  # a full disk, a folder gone: said, and the patch goes on
            self.failed += 1
            log.error("%s: %s not saved: %s", self.owner, path, getattr(exc, "strerror", None) or exc)
