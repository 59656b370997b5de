"""``record`` any stream to a file, ``replay`` a recording (ours, or a BROAD data-set trial) into a patch.

Files
-----
CSV (``.csv``, also gzipped ``.csv.gz`` for replay): optional ``#`` comment lines, a header line of
column names, then one row per message, the first column ``t`` (seconds).  ``record`` writes
``t,<columns>``: for the evaluation patches ``columns=[qw, qx, qy, qz]`` gives ``t,qw,qx,qy,qz``.

NDJSON (``.ndjson`` or ``.jsonl``, also gzipped for replay): one JSON object per message, ``{"t": 1.5,
"kind": "vector", "value": [1, 0, 0, 0]}``; any kind of message round-trips.

Both are line-buffered: every message is on disk when the next arrives, so Ctrl-C loses nothing.

``replay`` recognises columns by name: ``gyr_x``/``gyro_x``..., ``acc_x``/``accel_x``..., ``mag_x``...
go to the ``gyro``, ``accel`` and ``mag`` outlets; a BROAD trial's optical ground truth ``gt_qw``... (ENU)
goes to ``truth`` converted to pointat's NWU frame (``qw``... columns go there as they are); every row
also goes to ``row`` as one vector of all columns but ``t``.
"""

from __future__ import annotations

import gzip
import json
import logging
import math
import os
import threading
import time
import warnings
import zlib
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from pointat.maths.quaternion import enu_to_nwu
from pointat.message import Message, floats, vector
from pointat.node import Inlet, Node, Outlet, Param
from pointat.nodes.sensors import FULL_SCALE_PARAMS, RANGE_OUTLET, full_scale
from pointat.registry import register
from pointat.userfiles import UserFileError
from pointat.userfiles import lines as user_lines

log = logging.getLogger(__name__)

_GROUPS = {
    "gyro": (("gyr_x", "gyr_y", "gyr_z"), ("gyro_x", "gyro_y", "gyro_z")),
    "accel": (("acc_x", "acc_y", "acc_z"), ("accel_x", "accel_y", "accel_z")),
    "mag": (("mag_x", "mag_y", "mag_z"),),
    "truth": (("gt_qw", "gt_qx", "gt_qy", "gt_qz"), ("qw", "qx", "qy", "qz")),
}


FORMAT = Param(
    "format", "symbol", "auto", "auto (by extension), csv or ndjson", choices=("auto", "csv", "ndjson")
)


def _format(path: str, fmt: str) -> str:
    if fmt != "auto":
        return fmt
    name = path.lower().removesuffix(".gz")
    return "ndjson" if name.endswith((".ndjson", ".jsonl")) else "csv"


class Unreadable(ValueError):
    """A recording that cannot be read to its end: not UTF-8, or its compressed data damaged or cut
    short.  The message names the file and the line where reading stopped."""


def read_lines(path: str | Path) -> Iterator[tuple[int, str]]:
    """The lines of a recording with their numbers, from 1 as an editor counts them (``.gz`` through
    gzip).  A file that cannot be read to its end raises :class:`Unreadable`, naming it and the line."""
    path = Path(path)
    n = 0
    try:
        # a regular file (a device or a pipe would be read for ever, or waited on for ever) of 1 GB at
        # most, a line of 1 MB at most; decoded line by line, so a bad byte is placed exactly
        for n, raw in user_lines(path, "take"):
            yield n, raw.decode("utf-8")
    except UserFileError as exc:
        raise Unreadable(str(exc)) from None
    except UnicodeDecodeError as exc:
        raise Unreadable(
            f"{path}:{n}: not UTF-8 text (byte {exc.object[exc.start]:#04x} at column {exc.start + 1})"
        ) from None
    except EOFError:
        raise Unreadable(f"{path}:{n + 1}: the compressed data ends here: the file was cut short") from None
    except (gzip.BadGzipFile, zlib.error) as exc:
        if n == 0 and isinstance(exc, gzip.BadGzipFile):
            raise Unreadable(f"{path}: not a gzip file, though its name ends in .gz ({exc})") from None
        raise Unreadable(f"{path}:{n + 1}: the compressed data is damaged here ({exc})") from None


def _csv_header(lines: Iterable[tuple[int, str]]) -> list[str]:
    """The column names of a CSV recording: its first line that is neither blank nor a ``#`` comment
    (read from ``lines`` up to it); none when there is no such line."""
    for _, line in lines:
        if line.strip() and not line.startswith("#"):
            return [c.strip() for c in line.strip().split(",")]
    return []


def read_csv_table(path: str | Path) -> tuple[list[str], np.ndarray]:
    """Column names and rows of a CSV recording (``#`` comments, one header line; ``.gz`` allowed)."""
    path = Path(path)
    lines = read_lines(path)
    header = _csv_header(lines)
    if not header or header[0] != "t":
        raise ValueError(f"{path}: expected a header line starting with 't', got {','.join(header)!r}")
    try:
        # lines of blanks (and a comment) are skipped, as _first_bad_row skips them: loadtxt reads them as
        # a row of one empty cell, and refused a file whose last line held a space
        data = (line for _, line in lines if line.split("#", 1)[0].strip())
        rows = np.loadtxt(data, delimiter=",", ndmin=2, comments="#")
    except Unreadable:
        raise
    except ValueError:
        rows = None
    if rows is None or (rows.size and rows.shape[1] != len(header)):
        raise ValueError(_first_bad_row(path, len(header)))
    return header, rows.reshape(-1, len(header))


def _first_bad_row(path: Path, width: int) -> str:
    """Where and why a CSV recording does not read as numbers: ``FILE:LINE: ...`` (the line in the file,
    as an editor counts it)."""
    header_seen = False
    for n, line in read_lines(path):
        text = line.split("#", 1)[0].strip()
        if not text:
            continue
        if not header_seen:
            header_seen = True
            continue
        cells = [c.strip() for c in text.split(",")]
        if len(cells) != width:
            return f"{path}:{n}: {len(cells)} values, the header names {width} columns"
        for col, cell in enumerate(cells, 1):
            if not _number(cell):
                return f"{path}:{n}: column {col}: {cell!r} is not a number"
    return f"{path}: not a table of numbers"


def _number(cell: str) -> bool:
    """Whether a CSV cell is a number as :func:`read_csv_table` reads it: numpy's ``loadtxt`` decides
    (Python's ``float`` also takes ``1_000`` and other scripts' digits, and not a leading ``\x1c``)."""
    try:
        if float(cell) is not None and cell.isascii() and "_" not in cell:
            return True  # the common case, fast
    except ValueError:
        pass
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # loadtxt warns of a cell of blanks ("no data")
        try:
            return np.loadtxt([cell], delimiter=",", ndmin=1, comments=None).size == 1
        except ValueError:
            return False


@register("record")
class Record(Node):
    """Write every message with its time stamp to a CSV or NDJSON file, line by line (nothing lost on Ctrl-C).

    CSV rows are ``t`` then the message's numbers (a vector or list spread over columns); the header is
    ``t`` and ``columns`` (default ``v0, v1...``, or ``value`` for a single number).  ``append`` writes
    under the header already there (other ``columns`` are refused: replay could not read the take).  A
    file deleted while it is written is written anew from there, and the log says so.
    """

    needs_input = True
    role = "output"

    inlets = (Inlet("in", ("any",), "the stream to record"),)
    params = (
        Param("file", "path", doc="the file to write (.csv, .ndjson)", writes=True),
        FORMAT,
        Param("columns", "list", (), "CSV column names after t"),
        Param("append", "bool", False, "append instead of replacing the file"),
    )
    example = """
node sink record file=out.csv columns=[qw, qx, qy, qz]
"""

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        if str(values["file"]).lower().endswith(".gz"):
            raise ValueError(
                f"file {values['file']!r}: record writes plain text, line by line, so that nothing is lost"
                " if the patch stops: name it without .gz (and compress it afterwards)"
            )

    def describe(self) -> str:
        return f"records into {self.p.file}"

    def setup(self) -> None:
        self._fh: TextIO | None = None
        self._width: int | None = None
        self._checked = 0.0
        self.count = 0
        self._fmt = _format(self.p.file, self.p.format)

    #: Seconds between checks that the file being written is still there (deleted, rows go nowhere).
    CHECK_EVERY = 1.0

    def start(self) -> None:
        header = self._header_there() if self.p.append and self._fmt == "csv" else None
        if header is not None and self.p.columns and header != ["t", *map(str, self.p.columns)]:
            raise ValueError(
                f"{self.p.file} has the columns {','.join(header)}, not t,{','.join(map(str, self.p.columns))}:"
                f" appended to, it would be a take that replay cannot read; record to another file"
            )
        self._open("a" if self.p.append else "w")
        if header is not None:  # appending under the header that is there
            self._width = len(header) - 1
        elif self.p.columns and self._fmt == "csv":
            self._width = len(self.p.columns)
            self._write_header()
        self._checked = time.monotonic()

    def _open(self, mode: str) -> None:
        try:
            self._fh = open(self.p.file, mode, buffering=1, encoding="utf-8")
        except OSError as exc:
            raise OSError(f"cannot write {self.p.file}: {exc.strerror}") from exc

    def _header_there(self) -> list[str] | None:
        """The header of the CSV file to append to; None when there is none yet."""
        path = Path(self.p.file)
        if not os.path.lexists(path):  # (the user-file reader says a missing file as an error of its own)
            return None
        return _csv_header(read_lines(path)) or None

    def _still_there(self) -> None:
        """Once a second: a file deleted while it is written takes every row into the void; start it anew."""
        now = time.monotonic()
        if now - self._checked < self.CHECK_EVERY or self._fh is None:
            return
        self._checked = now
        try:
            gone = os.fstat(self._fh.fileno()).st_nlink == 0
        except OSError:
            return
        if gone:
            log.warning(
                "record '%s': %s was deleted while being written: writing it anew from here (%d rows before are lost)",
                self.name,
                self.p.file,
                self.count,
            )
            self._fh.close()
            self._open("w")
            if self._width is not None and self._fmt == "csv":
                self._write_header()

    def _write_header(self) -> None:
        """``t`` and the columns: ``columns``, else ``v0, v1...`` (``value`` for one) for ``_width`` numbers."""
        assert self._fh is not None and self._width is not None
        names = self.p.columns or (["value"] if self._width == 1 else [f"v{i}" for i in range(self._width)])
        self._fh.write(",".join(["t", *map(str, names)]) + "\n")

    def health(self) -> dict[str, Any]:
        return {"recording": str(self.p.file), "rows": self.count}

    def on_in(self, msg: Message) -> None:
        if self._fh is None:
            raise RuntimeError(f"record: {self.p.file} is not open")
        if self._fmt == "ndjson":
            value = list(msg.value) if msg.kind == "vector" else msg.value
            if msg.is_method:
                value = list(value)
            self._fh.write(json.dumps({"t": msg.time, "kind": msg.kind, "value": value}) + "\n")
        else:
            values = self._numbers(msg)
            if not values:  # a bang: it must not make a header of no columns that refuses every row after
                raise ValueError(
                    "a CSV row holds numbers and a bang has none: not recorded (.ndjson keeps bangs)"
                )
            if self._width is None:
                self._width = len(values)
                self._write_header()
            if len(values) != self._width:
                raise ValueError(f"expected {self._width} values per row (the header's), got {len(values)}")
            self._fh.write(",".join([repr(float(msg.time)), *(repr(float(v)) for v in values)]) + "\n")
        self.count += 1
        self._still_there()

    @staticmethod
    def _numbers(msg: Message) -> list[Any]:
        if msg.kind == "vector":
            return np.ravel(msg.value).tolist()
        if msg.kind in ("float", "int"):
            return [msg.value]
        if msg.kind == "list" and all(isinstance(v, (int, float)) for v in msg.value):
            return list(msg.value)
        if msg.kind == "bang":
            return []
        raise TypeError(f"CSV takes numbers; got {msg.describe()[:40]!r} (use an .ndjson file)")

    def close(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None


def _recorded(kind: Any, value: Any, t: float) -> Message:
    """One NDJSON line's message, its value checked against its kind (a "float" that holds a string
    would fail far downstream, in the middle of a show)."""
    if not isinstance(kind, str) or not kind:
        raise ValueError(f"kind must be a name, got {kind!r}")
    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    if kind == "vector" and isinstance(value, list):  # (a string's characters are no numbers: "123")
        return vector(value, t)
    if kind == "float" and number:
        return Message(kind, float(value), t)
    if kind == "int" and isinstance(value, int) and not isinstance(value, bool):
        return Message(kind, value, t)
    if kind == "symbol" and isinstance(value, str):
        return Message(kind, value, t)
    if kind == "bang":
        return Message(kind, None, t)
    if kind not in ("float", "int", "symbol") and isinstance(value, list):  # a list, or a method message
        return Message(kind, tuple(value), t)
    raise ValueError(f"a {kind} message cannot hold {value!r}")


@register("replay")
class Replay(Node):
    """Play a recording back: in real time (``speed=1``), faster or slower, or as fast as possible (``speed=0``).

    Reads ``record``'s CSV and NDJSON and the BROAD data set's CSV (``*.csv.gz``), so real recordings
    drive patches.  Messages carry the file's time stamps; a row with no time, one further than
    ``FAR`` (10⁶ s) from the recording's, or one more than ``SPIKE`` (1 s) ahead of the rows on both
    sides (damaged rows) goes out at once, with the time of the good row before it, and the log names its
    file and row.  At ``speed=0`` the rows reach the scheduler 64 at a time (``BATCH``), each row's messages
    as at any speed: the scheduler's timers and other inputs (OSC control) wait for the batches of one
    pass at most, about 5 ms of them (the runtime's ``QUEUE_BUDGET``), never for the whole queue.  At the
    end it bangs ``done`` and, unless ``loop``, its part in the patch is over: a patch whose sources
    have all ended stops by itself.

    The recorded sensor's full scale (``acc_range`` in g, ``gyro_range`` in °/s, from its data sheet)
    goes out of ``range`` as the patch starts, for ``tqt``'s ``range``: a recording of strikes that
    saturated the accelerometer is then fused as the live glove would be.
    """

    sample_outlets = "gyro"
    role = "input"

    outlets = (
        Outlet("gyro", "vector", "angular rate, rad/s (gyr_*/gyro_* columns)"),
        Outlet("accel", "vector", "specific force, m/s² (acc_*/accel_* columns)"),
        Outlet("mag", "vector", "magnetic field (mag_* columns)"),
        Outlet(
            "truth",
            "vector",
            "a quaternion: gt_q* (BROAD's ground truth, ENU) turned to sensor -> NWU; q* as they are, in"
            " whatever frame the file has (evaluate_*.pat write ENU)",
        ),
        Outlet("row", "any", "every row but t, as one vector (NDJSON: the message as recorded)"),
        Outlet("done", "bang", "at the end of the file"),
        RANGE_OUTLET,
    )
    params = (
        Param("file", "path", doc="the recording (.csv, .ndjson, either gzipped: .csv.gz...)", reads=True),
        Param("speed", "float", 1.0, "1 real time, 2 twice as fast, 0 as fast as possible", minimum=0.0),
        Param("loop", "bool", False, "start again at the end"),
        FORMAT,
        *FULL_SCALE_PARAMS,
    )
    example = """
node source replay file=trial.csv.gz speed=0
node fuse   tqt
source.gyro -> fuse.gyro
source.accel -> fuse.accel
source.mag -> fuse.mag
"""

    #: Rows handed to the scheduler at once at ``speed=0``: one hand-over between the threads (a queue
    #: item, a wake-up) and one conversion from the file's arrays for this many rows, not for each one.
    BATCH = 64
    #: Seconds from the recording's middle (its median time) beyond which a row's time is none to wait
    #: for (a damaged row, a time in other units): the row goes out at once, as a row with no time does.
    FAR = 1e6
    #: Seconds a row's time may be ahead of the next row's, which is not behind the row before it, before
    #: the row counts as damaged (it goes out at once instead of being waited for).
    SPIKE = 1.0

    def describe(self) -> str:
        pace = "as fast as it can" if self.p.speed == 0 else f"at {self.p.speed:g}x"
        return f"plays {self.p.file} {pace}"

    def setup(self) -> None:
        self.emitted = 0

    @classmethod
    def check_files(cls, values: Mapping[str, Any]) -> None:
        cls("check", values)._read()  # the recording is read as the patch starts, not as the node is built

    def start(self) -> None:
        self._read()
        self.active = True
        self.spawn(self._pump, "replay")

    def loadbang(self) -> None:
        full_scale(self)

    def _read(self) -> None:
        path = self.p.file
        if _format(path, self.p.format) == "ndjson":
            self._load_ndjson(path)
        else:
            self._load_csv(path)
        self._check_times(path)

    def _check_times(self, path: str) -> None:
        """Say where the time column is not a time line; keep the rows that have no time, or one too far
        from the recording's to wait for, out of ``_waits``: they go out at once."""
        t = np.asarray(self._times, dtype=float)
        finite = np.isfinite(t)
        if not finite.all():
            k = int(np.argmin(finite))
            log.warning(
                "replay '%s': %s: data row %d has no time (%s); it goes out at once",
                self.name,
                path,
                k + 1,
                t[k],
            )
        middle = float(np.median(t[finite])) if finite.any() else 0.0
        with np.errstate(over="ignore", invalid="ignore"):
            far = finite & ~(np.abs(t - middle) <= self.FAR)
        if far.any():
            k = int(np.argmax(far))
            log.warning(
                "replay '%s': %s: data row %d has time %g, more than %g s from the recording's (about %g; %d such "
                "rows): a damaged row, or a time in other units? It goes out at once",
                self.name,
                path,
                k + 1,
                t[k],
                self.FAR,
                middle,
                int(far.sum()),
            )
        # a row whose time is well ahead of the rows on both sides (505.0 between 4.99 and 5.01) is damaged:
        # waited for, it would hold the replay silent for minutes, and the rows after it come in a burst
        spike = np.zeros(len(t), dtype=bool)
        with np.errstate(invalid="ignore"):
            spike[1:-1] = (t[1:-1] - t[2:] > self.SPIKE) & (t[2:] >= t[:-2])
        spike &= finite & ~far
        if spike.any():
            k = int(np.argmax(spike))
            log.warning(
                "replay '%s': %s: data row %d has time %g, ahead of the rows on both sides (%g, %g; %d such "
                "rows): a damaged row; it goes out at once",
                self.name,
                path,
                k + 1,
                t[k],
                t[k - 1],
                t[k + 1],
                int(spike.sum()),
            )
        timed = np.flatnonzero(finite & ~far & ~spike)
        self._waits = np.full(len(t), math.nan)
        self._waits[timed] = t[timed]
        if len(timed) < len(t):  # what goes out at once carries the time of the good row before it
            last = np.where(np.isfinite(self._waits), np.arange(len(t)), -1)
            np.maximum.accumulate(last, out=last)
            first = t[timed[0]] if len(timed) else 0.0
            stamps = np.where(last >= 0, t[np.maximum(last, 0)], first)
            if self._messages is not None:
                for k in np.flatnonzero(np.isnan(self._waits)):
                    self._messages[k] = self._messages[k]._replace(time=float(stamps[k]))
            self._times = stamps
        back = np.flatnonzero(np.diff(t[timed]) < 0)
        if len(back):
            k, before = int(timed[back[0] + 1]), int(timed[back[0]])
            log.warning(
                "replay '%s': %s: time goes back at data row %d (%g after %g; %d such rows), so the rows after it "
                "go out in a burst: two takes in one file (record append=true)? Replay them as two files",
                self.name,
                path,
                k + 1,
                t[k],
                t[before],
                len(back),
            )

    def _load_csv(self, path: str) -> None:
        header, rows = read_csv_table(path)
        self._times = rows[:, 0]
        self._rows = rows[:, 1:]
        col = {name: i for i, name in enumerate(header)}
        self._groups: dict[int, np.ndarray] = {}
        for outlet, alternatives in enumerate(_GROUPS.values()):
            for names in alternatives:
                if all(n in col for n in names):
                    data = rows[:, [col[n] for n in names]]
                    if names[0] == "gt_qw":  # the BROAD data set: ENU ground truth
                        ok = np.all(np.isfinite(data), axis=1)
                        data = data.copy()
                        data[ok] = enu_to_nwu(data[ok])
                    self._groups[outlet] = data
                    break
        self._messages: list[Message] | None = None
        silent = [
            name
            for outlet, name in enumerate(_GROUPS)
            if outlet not in self._groups and self._targets[outlet]
        ]
        if silent:
            log.warning(
                "replay '%s': %s has no columns for %s (its columns: %s); those outlets stay silent",
                self.name,
                path,
                ", ".join(f"{n} ({' or '.join(' '.join(a) for a in _GROUPS[n])})" for n in silent),
                " ".join(header),
            )

    def _load_ndjson(self, path: str) -> None:
        messages = []
        for lineno, line in read_lines(path):
            if not line.strip():
                continue
            try:
                d = json.loads(line)
                kind, value, t = d["kind"], d["value"], float(d["t"])
                messages.append(_recorded(kind, value, t))
            # (OverflowError: a number past a float's range, 1e400 written as an integer; RecursionError: [[[...)
            except (ValueError, KeyError, TypeError, OverflowError, RecursionError) as exc:
                raise ValueError(f"{path}:{lineno}: not a recorded message: {exc}") from exc
        self._messages = messages
        self._times = np.array([m.time for m in messages])

    def _pump(self) -> None:
        """Reader thread: hand rows to the scheduler on time (or as fast as it takes them)."""
        n = len(self._times)
        waits = self._waits  # the times to wait for: NaN where a row goes out at once
        timed = np.flatnonzero(np.isfinite(waits))
        t_first = float(waits[timed[0]]) if len(timed) else 0.0
        stopping = self._runtime().stopping
        while True:
            t_start = time.monotonic()
            i = 0
            while i < n:
                if self.p.speed > 0:
                    due = t_start + (waits[i] - t_first) / self.p.speed
                    delay = min(due - time.monotonic(), threading.TIMEOUT_MAX)  # (NaN: not waited for)
                    if delay > 0 and stopping.wait(delay):
                        return
                    j = i + 1
                else:  # as fast as it goes: rows in batches
                    j = min(i + self.BATCH, n)
                if not self.post(self._emit, i, j):
                    return
                i = j
            if not self.p.loop or stopping.is_set() or n == 0:
                break
        self.post(self._done)

    def _emit(self, i: int, j: int) -> None:
        """Send rows ``i`` to ``j - 1``, each as one row's messages, right to left."""
        if self._messages is not None:
            for msg in self._messages[i:j]:
                self.emitted += 1
                self.out(4, msg)
            return
        times = self._times[i:j].tolist()  # Python floats, a row a tuple: no numpy call per row
        rows = [tuple(r) for r in self._rows[i:j].tolist()]
        groups = [
            (outlet, [tuple(r) for r in data[i:j].tolist()])
            for outlet in (3, 2, 1, 0)  # right to left: the gyro (a filter's hot inlet) last
            if (data := self._groups.get(outlet)) is not None
        ]
        for k, t in enumerate(times):
            self.emitted += 1
            self.out(4, floats(rows[k], t))
            for outlet, values in groups:
                v = values[k]
                if outlet != 3 or not math.isnan(v[0]):  # (no ground truth on this row: silent)
                    self.out(outlet, floats(v, t))

    def _done(self) -> None:
        self.time = float(self._times[-1]) if len(self._times) else 0.0
        self.active = False
        self.ended = True
        self.out(5, None)
