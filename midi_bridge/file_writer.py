r"""Standard MIDI files written message by message, valid on disk after each one (``midi_out file=``).

With ``file=`` (or when no MIDI system is present and no port was asked for), messages go to a
format-0 standard MIDI file.  Each message's pointat time stamp (seconds since the patch started: sensor
time when the source knows it) becomes its position, at the tempo ``bpm`` (default 120) and resolution
``ppq`` (ticks per quarter note, default 480): a tick is :math:`60 / (\mathrm{bpm} \cdot \mathrm{ppq})`
s, 1/960 s = 1.04 ms at the defaults.  The file is valid on disk after every message and is closed
(with its end-of-track) when the patch stops, so Ctrl-C loses nothing.
"""

from __future__ import annotations

import contextlib
import math
import struct
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any, BinaryIO

import mido

#: The largest delta time a MIDI file's variable-length quantity holds (4 bytes, 28 bits).
MAX_DELTA = 0x0FFFFFFF


def _write_all(fh: BinaryIO, data: bytes) -> None:
    """All of ``data`` into an unbuffered file, or OSError (a raw write may take only a part)."""
    view = memoryview(data)
    while view:
        n = fh.write(view)
        if not n:
            raise OSError(f"no room for {len(view)} more bytes")
        view = view[n:]


def _varlen(n: int) -> bytes:
    """A MIDI variable-length quantity (7 bits a byte, high bit set on all but the last).

    >>> _varlen(0).hex(), _varlen(127).hex(), _varlen(128).hex(), _varlen(960).hex()
    ('00', '7f', '8100', '8740')
    """
    out = [n & 0x7F]
    n >>= 7
    while n:
        out.append((n & 0x7F) | 0x80)
        n >>= 7
    return bytes(reversed(out))


class MidiFileWriter:
    """Write a format-0 standard MIDI file one message at a time; valid on disk after every message.

    The header and the tempo are written at once; each :meth:`write` appends ``delta, message`` and
    updates the track length, so a file cut off by a crash still reads.  :meth:`close` adds the
    end-of-track; it is idempotent.  Times are seconds (pointat time stamps), converted to ticks at
    ``bpm`` and ``ppq`` from an origin of 0 s; a time earlier than the previous one is written at the
    same tick (delta 0).

    Parameters
    ----------
    path : str or Path
        The file to (over)write.
    bpm : float
        Tempo written into the file, beats per minute.
    ppq : int
        Ticks per quarter note (1..32767).
    """

    _LENGTH_AT = 18  # 'MThd' + length + 6 header bytes + 'MTrk'
    _HEADER_END = 22  # and the track's length: where its events begin

    def __init__(self, path: str | Path, *, bpm: float = 120.0, ppq: int = 480, name: str = "pointat"):
        if not bpm > 0:
            raise ValueError(f"bpm must be positive, got {bpm}")
        if not 1 <= ppq <= 32767:
            raise ValueError(f"ppq must be 1..32767, got {ppq}")
        self.path = Path(path)
        self.bpm, self.ppq = float(bpm), int(ppq)
        #: Ticks per second of pointat time.
        self.ticks_per_second = self.bpm / 60.0 * self.ppq
        self.count = 0
        self._tick = 0
        self._length = 0
        self._lock = threading.Lock()
        # unbuffered: what a write did not put on the disk is known at once, and cut off (see _append)
        self._fh: BinaryIO | None = open(self.path, "wb", buffering=0)  # closed by close()
        _write_all(self._fh, b"MThd" + struct.pack(">LHHH", 6, 0, 1, self.ppq) + b"MTrk" + b"\0\0\0\0")
        tempo = mido.MetaMessage("set_tempo", tempo=mido.bpm2tempo(self.bpm))
        events = [tempo]
        if name:
            events.insert(0, mido.MetaMessage("track_name", name=name))
        for meta in events:
            self._append(b"\0" + bytes(meta.bytes()))

    def ticks(self, seconds: float) -> int:
        """The tick of a time stamp (rounded; negative times are tick 0)."""
        return max(0, round(seconds * self.ticks_per_second))

    def write(self, msg: mido.Message, time: float) -> None:
        """Append ``msg`` at ``time`` seconds."""
        self.write_all([msg], time)

    def write_all(self, messages: Sequence[mido.Message], time: float) -> None:
        """Append ``messages`` at ``time`` seconds, all or none (a 14-bit value's two halves together)."""
        for msg in messages:
            if msg.is_meta or msg.is_realtime:
                raise ValueError(f"cannot write {msg.type} into a MIDI file track")
        if not messages:
            return
        if not math.isfinite(time):
            raise ValueError(f"time {time} is not a number of seconds: {messages[0].type} not written")
        tick = max(self._tick, self.ticks(time))
        if tick - self._tick > MAX_DELTA:  # a damaged time stamp: the file would no longer read
            raise ValueError(
                f"time {time:g} s is {(tick - self._tick) / self.ticks_per_second / 3600:.3g} hours after the "
                f"last message, more than a MIDI file can say in one step: {messages[0].type} not written"
            )
        data = _varlen(tick - self._tick) + b"".join(
            (b"\0" if k else b"") + bytes(m.bytes()) for k, m in enumerate(messages)
        )
        with self._lock:
            self._append(data)
            self._tick = tick
            self.count += len(messages)

    def _append(self, data: bytes) -> None:
        """Add ``data`` to the track and its length to the header, or nothing at all: a write that fails
        (a full disk) is cut off again, so the file stays what it was and reads."""
        fh = self._fh
        if fh is None:
            raise ValueError(f"{self.path} is closed")
        end = self._HEADER_END + self._length
        try:
            fh.seek(end)
            _write_all(fh, data)
            fh.seek(self._LENGTH_AT)
            _write_all(fh, struct.pack(">L", self._length + len(data)))
        except BaseException:  # a full disk, or Ctrl-C in the middle (a runtime in a notebook)
            with contextlib.suppress(OSError):
                fh.truncate(end)
                fh.seek(self._LENGTH_AT)
                _write_all(fh, struct.pack(">L", self._length))
            raise
        self._length += len(data)

    @property
    def closed(self) -> bool:
        return self._fh is None

    def close(self) -> None:
        """Write the end of track and close the file (idempotent)."""
        with self._lock:
            if self._fh is None:
                return
            try:
                self._append(b"\0" + bytes(mido.MetaMessage("end_of_track").bytes()))
            finally:
                self._fh.close()
                self._fh = None

    def __enter__(self) -> MidiFileWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# Writers shared by the midi_out nodes of a process that name the same file: {resolved path: [writer, users]}
_writers: dict[str, list[Any]] = {}
_writers_lock = threading.Lock()


def acquire_writer(path: str, bpm: float, ppq: int) -> MidiFileWriter:
    key = str(Path(path).resolve())
    with _writers_lock:
        entry = _writers.get(key)
        if entry is None:
            entry = _writers[key] = [MidiFileWriter(path, bpm=bpm, ppq=ppq), 0]
        w: MidiFileWriter = entry[0]
        if (w.bpm, w.ppq) != (float(bpm), int(ppq)):
            raise ValueError(
                f"{path} is being written at bpm={w.bpm:g} ppq={w.ppq} by another midi_out; use the same values"
            )
        entry[1] += 1
        return w


def release_writer(writer: MidiFileWriter) -> None:
    key = str(writer.path.resolve())
    with _writers_lock:
        entry = _writers.get(key)
        if entry is None or entry[0] is not writer:
            writer.close()
            return
        entry[1] -= 1
        if entry[1] <= 0:
            del _writers[key]
            writer.close()
