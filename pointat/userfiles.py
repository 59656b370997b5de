"""Reading a user's files: the one door every node and command reads a file a person named through.

A user file (a patch, its presets, a calibration, a gesture model, a recording, a take) may be anything
a path can name: a pipe that no one writes (an open that waits for ever), ``/dev/zero`` (a read that never
ends), a 2 GB sparse file (a MemoryError), a folder, a loop of symbolic links, JSON nested a hundred
thousand deep.  So every read goes through :func:`open_user_file`, which

* opens without blocking (``O_NONBLOCK``: a pipe's open returns at once) and refuses anything but a
  regular file, by the opened file's own ``fstat`` (no gap between the look and the read);
* refuses a file larger than its kind's limit (:data:`LIMITS`) before reading it, and never reads more
  than the limit (a file that grows meanwhile), decompressed ``.gz`` data included;

and :func:`read_json` turns every way JSON can fail (nesting too deep among them) into the same error.
Each refusal is a :class:`UserFileError` (a ``ValueError``) that names the file, what was expected
and what was found::

    /tmp/x.presets.json: a pipe (FIFO), not a regular file: expected a presets file (JSON)
"""

from __future__ import annotations

import gzip
import io
import json
import os
import stat
import zlib
from collections.abc import Iterator
from typing import Any, BinaryIO

from .errors import PointatError

__all__ = [
    "LIMITS",
    "UserFileError",
    "lines",
    "open_user_file",
    "read_bytes",
    "read_json",
    "read_text",
]

_MB = 1024 * 1024

#: The largest file of each kind read (bytes, decompressed for ``.gz``), and what the kind is.
LIMITS: dict[str, int] = {
    "patch": 4 * _MB,  # a thousand-node patch is ~50 KB
    "presets": 4 * _MB,  # the most presets a patch keeps (pointat.presets.MOST_BYTES) is 1 MB
    "calibration": 1 * _MB,  # ~1 KB
    "layout": 4 * _MB,  # a loudspeaker layout
    "skeleton": 4 * _MB,
    "gesture model": 256 * _MB,  # ten thousand long examples
    "recording": 64 * _MB,  # one gesture's CSV
    "take": 1024 * _MB,  # hours of a glove at 1 kHz
}
WHAT: dict[str, str] = {
    "patch": "a patch (text)",
    "presets": "a presets file (JSON)",
    "calibration": "a calibration file (JSON)",
    "layout": "a loudspeaker layout (JSON or Pd text)",
    "skeleton": "a skeleton (JSON)",
    "gesture model": "a gesture model (JSON)",
    "recording": "a gesture recording (CSV)",
    "take": "a take (CSV or NDJSON)",
}

#: The longest line :func:`lines` hands out: a row of a take is ~200 bytes.
LONGEST_LINE = 1 * _MB


class UserFileError(PointatError, ValueError):
    """A user's file that cannot be read as what it should be; the message names it."""

    def __init__(self, path: str | os.PathLike[str], message: str):
        self.path = os.fspath(path) if not isinstance(path, bytes) else repr(path)
        self.problem = message
        super().__init__(f"{self.path}: {message}")


def _what_is(mode: int) -> str:
    for test, name in (
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISFIFO, "a pipe (FIFO)"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    ):
        if test(mode):
            return name
    return "not a file"


def _size(n: int) -> str:
    return f"{n / _MB:.1f} MB" if n >= _MB else f"{n} bytes"


def open_user_file(path: str | os.PathLike[str], kind: str, *, limit: int | None = None) -> BinaryIO:
    """``path`` opened to read in binary, when it is a regular file of at most ``limit`` bytes (the
    kind's, :data:`LIMITS`); :class:`UserFileError` otherwise, at once: never a wait, never a long read.

    >>> open_user_file("/", "patch")
    Traceback (most recent call last):
    ...
    pointat.userfiles.UserFileError: /: a folder, not a regular file: expected a patch (text)
    """
    what = WHAT.get(kind, kind)
    limit = LIMITS[kind] if limit is None else limit
    flags = (
        os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_BINARY", 0)
    )
    try:
        fd = os.open(path, flags)
    except IsADirectoryError:  # (Windows)
        raise UserFileError(path, f"a folder, not a regular file: expected {what}") from None
    except OSError as exc:  # missing, no permission, a loop of links, a name too long
        raise UserFileError(path, f"cannot read {kind}: {exc.strerror or exc}") from None
    except ValueError:
        raise UserFileError(path, f"a NUL character in the name: expected {what}") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise UserFileError(path, f"{_what_is(info.st_mode)}, not a regular file: expected {what}")
        if info.st_size > limit:
            raise UserFileError(
                path, f"{_size(info.st_size)}: larger than {what} can be ({_size(limit)} at most)"
            )
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)  # a regular file: reads are whole again
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def read_bytes(
    path: str | os.PathLike[str], kind: str, *, limit: int | None = None, gzip_ok: bool = False
) -> bytes:
    """The bytes of a user file (:func:`open_user_file`), decompressed when ``gzip_ok`` and its name ends
    in ``.gz``; at most ``limit`` bytes, either way."""
    what = WHAT.get(kind, kind)
    limit = LIMITS[kind] if limit is None else limit
    with open_user_file(path, kind, limit=limit) as fh:
        try:
            raw = fh.read(limit + 1)
        except OSError as exc:
            raise UserFileError(path, f"cannot read {kind}: {exc.strerror or exc}") from None
    if len(raw) > limit:  # (it grew while read)
        raise UserFileError(path, f"larger than {what} can be ({_size(limit)} at most)")
    if gzip_ok and os.fspath(path).endswith(".gz"):
        try:
            with gzip.GzipFile(fileobj=io.BytesIO(raw)) as gz:
                raw = gz.read(limit + 1)
        except (OSError, EOFError, zlib.error) as exc:  # (gzip.BadGzipFile is an OSError)
            raise UserFileError(
                path, f"not whole gzip data ({exc or 'cut short'}): expected {what}"
            ) from None
        if len(raw) > limit:
            raise UserFileError(
                path, f"more than {_size(limit)} once decompressed: larger than {what} can be"
            )
    return raw


def read_text(
    path: str | os.PathLike[str],
    kind: str,
    *,
    limit: int | None = None,
    gzip_ok: bool = False,
    encoding: str = "utf-8-sig",
) -> str:
    """The text of a user file (:func:`read_bytes`), UTF-8 (a byte-order mark from a Windows editor is
    fine); a byte that is not names the line."""
    raw = read_bytes(path, kind, limit=limit, gzip_ok=gzip_ok)
    try:
        return raw.decode(encoding)
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise UserFileError(
            f"{os.fspath(path)}:{line}",
            f"not UTF-8 text (byte {raw[exc.start]:#04x}): expected {WHAT.get(kind, kind)}",
        ) from None


def read_json(path: str | os.PathLike[str], kind: str, *, limit: int | None = None) -> Any:
    """A user file's JSON (:func:`read_text`); bad JSON names the line, and nesting deeper than Python's
    recursion allows (``[[[[...``) is refused, not a RecursionError."""
    what = WHAT.get(kind, kind)
    text = read_text(path, kind, limit=limit)
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise UserFileError(
            f"{os.fspath(path)}:{exc.lineno}", f"not JSON ({exc.msg}): expected {what}"
        ) from None
    except RecursionError:
        raise UserFileError(path, f"JSON nested too deeply: expected {what}") from None
    except ValueError as exc:  # an integer of more than 4300 digits (sys.get_int_max_str_digits)
        raise UserFileError(path, f"not {what}: {exc}") from None


def lines(
    path: str | os.PathLike[str], kind: str, *, limit: int | None = None
) -> Iterator[tuple[int, bytes]]:
    """The lines of a user file (bytes, with their numbers from 1), ``.gz`` decompressed as it goes;
    a line longer than :data:`LONGEST_LINE`, or more than ``limit`` bytes in all, is refused where it
    is met.  Damaged compressed data is the caller's to name (``gzip.BadGzipFile``, ``EOFError``...)."""
    what = WHAT.get(kind, kind)
    limit = LIMITS[kind] if limit is None else limit
    with open_user_file(path, kind, limit=limit) as raw:
        fh: Any = gzip.GzipFile(fileobj=raw) if os.fspath(path).endswith(".gz") else raw
        try:
            total, n = 0, 0
            while True:
                line = fh.readline(LONGEST_LINE + 1)
                if not line:
                    return
                n += 1
                total += len(line)
                if len(line) > LONGEST_LINE:
                    raise UserFileError(
                        f"{os.fspath(path)}:{n}", f"a line longer than {_size(LONGEST_LINE)}: expected {what}"
                    )
                if total > limit:
                    raise UserFileError(
                        path, f"more than {_size(limit)} once decompressed: larger than {what}"
                    )
                yield n, line
        finally:
            if fh is not raw:
                fh.close()
