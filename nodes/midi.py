r"""MIDI for pointat, with mido: ``midi_out`` (directions and gestures to a DAW or a synth) and ``midi_in``
(a foot controller).

Cheat sheet::

    node pan  midi_out kind=cc number=10 range=[90, -90] fold=true file=pan.mid   # azimuth -> CC10 pan, to a file
    node pan  midi_out kind=cc number=10 range=[90, -90] fold=true port="IAC Bus 1"   # ... to a named port
    node fine midi_out kind=cc14 number=10 range=[90, -90] fold=true   # 14-bit: CC10 (MSB) + CC42 (LSB)
    node nrpn midi_out kind=nrpn number=300 range=[-180, 180] # NRPN 99/98 (parameter) + 6/38 (value)
    node bend midi_out kind=pitchbend range=[-45, 45]         # 14-bit pitch bend, centre 0 -> 8192
    node hit  midi_out kind=note number=60                    # 1 / non-zero: note on, 0: note off, bang: a hit
    node foot midi_in port="FCB1010"                          # -> (cc number, value), (note, velocity)

The layers, from the bottom:

* plain functions (:func:`scale_to_int`, :func:`cc_messages`, :func:`cc14_messages`,
  :func:`nrpn_messages`, :func:`pitchbend_message`) build port-less ``mido.Message`` objects;
* :class:`MidiSender` holds one output's mapping and state (last value sent, notes held) and turns
  pointat values into lists of messages; it knows nothing of ports or of the engine;
* :class:`MidiFileWriter` writes a standard MIDI file message by message (valid on disk after each one);
* :func:`open_output`, :func:`open_input`, :func:`output_names` and :func:`input_names` are the only
  places that touch a MIDI system (through mido's default backend, python-rtmidi).  Tests replace them
  with functions returning real ``mido.ports.BaseOutput`` / ``BaseInput`` subclasses;
* the nodes ``midi_out`` and ``midi_in`` connect those to the patch.

Channels count 1..16 everywhere in this module, as people count them (mido's ``channel`` is 0..15).
Values are mapped linearly from the input ``range`` ``[in_lo, in_hi]`` onto the integer MIDI range
``0..top`` (127 or 16383) and clipped; ``in_lo > in_hi`` reverses the direction.  The mapping follows
MIDI's bipolar convention: the middle of the input range is the MIDI centre (64, or 8192 for 14-bit)
with a rounding bin centred on it, so a hand held still at the centre never flickers between two
values; the bottom of the range is 0 and the top is ``top`` (see :func:`scale_to_int`).

**Azimuth -> DAW pan.**  DAW pan on CC10 is 0 = hard left, 64 = centre, 127 = hard right, while pointat's
azimuth is positive to the *left*.  ``range=[90, -90]`` maps azimuth +90 deg (left) to 0, 0 deg (front)
to 64 and -90 deg (right) to 127:

.. math:: \mathrm{CC10} = \min\left(127, \left\lfloor 128\,\mathrm{clip}\!\left(\frac{90 - az}{180},
          0, 1\right) + \tfrac12 \right\rfloor\right)

With ``fold=true`` an azimuth behind the listener is first mirrored to the front half, as a stereo pan
hears it (:func:`pointat.maths.scalar.fold_front`: 135 deg, behind left, pans as 45; 180 as the
centre), so a performer turning round pans smoothly back; without it \|az\| > 90 deg clips to the
nearer side and the pan jumps from hard left to hard right where the azimuth crosses 180.  One 7-bit step is
180/128 = 1.41 deg (64 covers -0.70..+0.70 deg); with ``kind=cc14`` one step is 180/16384 = 0.011 deg.

**Files.**  With ``file=`` (or when no MIDI system is present and no port was asked for), messages go to a
format-0 standard MIDI file.  Each message's pointat time stamp (seconds since the patch started: sensor
time when the source knows it) becomes its position, at the tempo ``bpm`` (default 120) and resolution
``ppq`` (ticks per quarter note, default 480): a tick is :math:`60 / (\mathrm{bpm} \cdot \mathrm{ppq})`
s, 1/960 s = 1.04 ms at the defaults.  The file is valid on disk after every message and is closed
(with its end-of-track) when the patch stops, so Ctrl-C loses nothing.
"""

from __future__ import annotations

import contextlib
import logging
import math
import struct
import threading
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, BinaryIO

import mido
import mido.ports

from pointat.errors import PointatError
from pointat.maths.scalar import fold_front
from pointat.message import Message, as_float, method
from pointat.node import Inlet, Node, Outlet, Param
from pointat.nodes.mapping import FOLD
from pointat.registry import register
from pointat.runtime import Timer

__all__ = [
    "MIDI_KINDS",
    "MidiFileWriter",
    "MidiIn",
    "MidiOut",
    "MidiSender",
    "MidiUnavailable",
    "cc14_messages",
    "cc_messages",
    "check_mapping",
    "input_names",
    "nrpn_messages",
    "open_input",
    "open_output",
    "output_names",
    "pitchbend_message",
    "scale_to_int",
    "split14",
]

log = logging.getLogger("pointat.midi")

#: What ``midi_out`` can send.
MIDI_KINDS = ("cc", "cc14", "nrpn", "pitchbend", "note")
#: The largest MIDI value of each kind (the input range maps onto 0..top).
TOP = {"cc": 127, "cc14": 16383, "nrpn": 16383, "pitchbend": 16383, "note": 127}
#: The largest ``number`` of each kind (a 14-bit CC's LSB goes on number + 32, so 0..31).
NUMBER_MAX = {"cc": 127, "cc14": 31, "nrpn": 16383, "pitchbend": 0, "note": 127}
#: Controllers that select or rewrite a synth's settings rather than follow a value (a cc14's number is
#: its MSB's: 0 and 6 stream bank select and data entry with their LSBs 32 and 38).
SPECIAL_CC = {
    0: "bank select",
    32: "bank select (LSB)",
    6: "data entry (it rewrites the selected RPN, e.g. the pitch-bend range)",
    38: "data entry (LSB)",
    98: "the NRPN select (LSB)",
    99: "the NRPN select",
    100: "the RPN select (LSB)",
    101: "the RPN select",
}

#: What to do when python-rtmidi is missing, and when the MIDI system is.
FIX_RTMIDI = "install python-rtmidi (pip install 'pointat[midi]' or pip install python-rtmidi)"
FIX_SYSTEM = (
    "make a MIDI system available (Linux: ALSA with its sequencer, so that /dev/snd/seq exists: "
    "modprobe snd-seq, or pass --device /dev/snd to a container; macOS: CoreMIDI; Windows: a loopback "
    "driver such as loopMIDI)"
)


class MidiUnavailable(PointatError):
    """A MIDI port was asked for and cannot be opened; the message names the node and the fix."""


# --------------------------------------------------------------------------- pure mapping
def scale_to_int(x: float, lo: float, hi: float, top: int) -> int:
    r"""Map ``x`` linearly from ``[lo, hi]`` onto the integers ``0..top``, clipped, centre exact.

    .. math:: f = \mathrm{clip}\!\left(\frac{x - lo}{hi - lo}, 0, 1\right), \qquad
              v = \min\left(\mathrm{top}, \left\lfloor (\mathrm{top} + 1) f + \tfrac12 \right\rfloor\right)

    MIDI's bipolar convention: ``top + 1`` steps (128 or 16384) of equal width, so the middle of the
    input range maps to the MIDI centre ``(top + 1) / 2`` (64 or 8192) and sits in the middle of its
    rounding bin; ``lo`` maps to 0 and ``hi`` to ``top``.  ``lo > hi`` reverses the direction.  Raises
    ``ValueError`` for NaN, infinity or ``lo == hi``.

    >>> scale_to_int(0.0, 90.0, -90.0, 127)  # azimuth 0 (front) -> pan centre
    64
    >>> scale_to_int(0.6, 90.0, -90.0, 127), scale_to_int(-0.6, 90.0, -90.0, 127)  # still the centre
    (64, 64)
    >>> scale_to_int(90.0, 90.0, -90.0, 127), scale_to_int(-135.0, 90.0, -90.0, 127)
    (0, 127)
    >>> scale_to_int(0.5, 0.0, 1.0, 16383), scale_to_int(1.0, 0.0, 1.0, 16383)  # 14-bit centre and top
    (8192, 16383)
    """
    if not math.isfinite(x):
        raise ValueError(f"cannot send {x} over MIDI")
    if hi == lo:
        raise ValueError(f"empty input range [{lo}, {hi}]")
    frac = min(1.0, max(0.0, (x - lo) / (hi - lo)))
    return min(top, math.floor(frac * (top + 1) + 0.5))


def split14(value: int) -> tuple[int, int]:
    """A 14-bit value ``0..16383`` -> ``(msb, lsb)``, 7 bits each.

    >>> split14(8192), split14(16383), split14(300)
    ((64, 0), (127, 127), (2, 44))
    """
    if not 0 <= value <= 16383:
        raise ValueError(f"14-bit value out of range 0..16383: {value}")
    return value >> 7, value & 0x7F


def _ch(channel: int) -> int:
    if not 1 <= channel <= 16:
        raise ValueError(f"MIDI channel must be 1..16, got {channel}")
    return channel - 1


def cc_messages(channel: int, number: int, value: int) -> list[mido.Message]:
    """One 7-bit control change; ``channel`` 1..16.

    >>> [m.hex() for m in cc_messages(1, 10, 64)]
    ['B0 0A 40']
    """
    return [mido.Message("control_change", channel=_ch(channel), control=number, value=value)]


def cc14_messages(channel: int, number: int, value: int) -> list[mido.Message]:
    """A 14-bit control change: the MSB on controller ``number`` (0..31), then the LSB on ``number + 32``.

    >>> [m.hex() for m in cc14_messages(1, 10, 8192)]
    ['B0 0A 40', 'B0 2A 00']
    """
    if not 0 <= number <= 31:
        raise ValueError(f"a 14-bit controller number must be 0..31 (LSB on number + 32), got {number}")
    msb, lsb = split14(value)
    c = _ch(channel)
    return [
        mido.Message("control_change", channel=c, control=number, value=msb),
        mido.Message("control_change", channel=c, control=number + 32, value=lsb),
    ]


def nrpn_messages(channel: int, number: int, value: int) -> list[mido.Message]:
    """An NRPN: parameter number on CC99 (MSB) and CC98 (LSB), then the value on CC6 (MSB) and CC38 (LSB).

    >>> [m.hex() for m in nrpn_messages(2, 300, 16383)]
    ['B1 63 02', 'B1 62 2C', 'B1 06 7F', 'B1 26 7F']
    """
    if not 0 <= number <= 16383:
        raise ValueError(f"NRPN number must be 0..16383, got {number}")
    pm, pl = split14(number)
    vm, vl = split14(value)
    c = _ch(channel)
    return [
        mido.Message("control_change", channel=c, control=99, value=pm),
        mido.Message("control_change", channel=c, control=98, value=pl),
        mido.Message("control_change", channel=c, control=6, value=vm),
        mido.Message("control_change", channel=c, control=38, value=vl),
    ]


def pitchbend_message(channel: int, value: int) -> mido.Message:
    """Pitch bend from a 14-bit value 0..16383 (8192 = centre, no bend); mido's ``pitch`` is value - 8192.

    >>> pitchbend_message(1, 8192).hex(), pitchbend_message(1, 0).hex(), pitchbend_message(1, 16383).hex()
    ('E0 00 40', 'E0 00 00', 'E0 7F 7F')
    """
    split14(value)
    return mido.Message("pitchwheel", channel=_ch(channel), pitch=value - 8192)


def check_mapping(
    kind: str, channel: int, number: int, in_range: Sequence[float], velocity: int = 100
) -> None:
    """Raise ``ValueError`` saying what is wrong with an output's mapping, or return None."""
    if kind not in MIDI_KINDS:
        raise ValueError(f"kind must be one of {', '.join(MIDI_KINDS)}; got {kind!r}")
    if not 1 <= channel <= 16:
        raise ValueError(f"channel must be 1..16 (as people count MIDI channels), got {channel}")
    if kind != "pitchbend" and not 0 <= number <= NUMBER_MAX[kind]:
        raise ValueError(f"number for kind={kind} must be 0..{NUMBER_MAX[kind]}, got {number}")
    if kind == "cc" and number >= 120:
        raise ValueError(
            f"number {number} is a channel-mode message, not a controller (120 all sound off, 121 reset all "
            f"controllers, 122 local control, 123 all notes off, 124-127 omni and mono/poly): a stream of "
            f"values there silences or resets the synth; choose 0..119"
        )
    if kind in ("cc", "cc14") and number in SPECIAL_CC:
        log.warning(
            "midi: kind=%s number=%d streams %s: most synths take it as a command, not a value to follow",
            kind,
            number,
            SPECIAL_CC[number],
        )
    if len(in_range) != 2 or not all(math.isfinite(v) for v in in_range) or in_range[0] == in_range[1]:
        raise ValueError(f"range must be two different numbers [in_lo, in_hi], got {list(in_range)}")
    if not 1 <= velocity <= 127:
        raise ValueError(f"velocity must be 1..127, got {velocity}")


class MidiSender:
    """One MIDI output's mapping and state, with no port: pointat values in, ``mido.Message`` lists out.

    Parameters
    ----------
    kind : str
        ``cc`` (7-bit), ``cc14`` (MSB on ``number``, LSB on ``number + 32``), ``nrpn`` (99/98 + 6/38),
        ``pitchbend`` (14-bit) or ``note``.
    channel : int
        MIDI channel, 1..16.
    number : int
        Controller, NRPN parameter or note number (ignored for ``pitchbend``).
    in_range : (float, float)
        The input values that map to the bottom and the top of the MIDI range (clipped beyond).
    change : bool
        Send only when the MIDI value changes (a held note is not struck again).
    velocity : int
        Note-on velocity, 1..127.

    >>> s = MidiSender("cc", channel=1, number=10, in_range=(90.0, -90.0))
    >>> [m.hex() for m in s.value(0.0)], s.value(0.5), [m.hex() for m in s.value(-90.0)]
    (['B0 0A 40'], [], ['B0 0A 7F'])
    >>> n = MidiSender("note", number=60)
    >>> [m.hex() for m in n.value(1)], n.value(1), [m.hex() for m in n.value(0)]
    (['90 3C 64'], [], ['80 3C 00'])
    """

    def __init__(
        self,
        kind: str = "cc",
        channel: int = 1,
        number: int = 10,
        in_range: Sequence[float] = (0.0, 1.0),
        *,
        change: bool = True,
        velocity: int = 100,
    ):
        check_mapping(kind, channel, number, in_range, velocity)
        self.kind = kind
        self.channel = channel
        self.number = number
        self.in_range = (float(in_range[0]), float(in_range[1]))
        self.change = change
        self.velocity = velocity
        #: The last MIDI value sent (0..127 or 0..16383), None before the first.
        self.last: int | None = None
        #: Notes held (sent on, not yet off), in the order they were struck.
        self.held: list[int] = []

    def configure(self, **changes: Any) -> list[mido.Message]:
        """Change the mapping (validated first); returns the note-offs owed when the target moved."""
        new = {k: getattr(self, k) for k in ("kind", "channel", "number", "in_range", "velocity")}
        unknown = set(changes) - set(new) - {"change"}
        if unknown:
            raise TypeError(f"unknown setting(s): {', '.join(sorted(unknown))}")
        new.update({k: v for k, v in changes.items() if k != "change"})
        check_mapping(new["kind"], new["channel"], new["number"], new["in_range"], new["velocity"])
        owed: list[mido.Message] = []
        if any(new[k] != getattr(self, k) for k in ("kind", "channel", "number")):
            owed = self.release()
            self.last = None
        self.kind, self.channel, self.number = new["kind"], new["channel"], new["number"]
        self.in_range = (float(new["in_range"][0]), float(new["in_range"][1]))
        self.velocity = new["velocity"]
        self.change = changes.get("change", self.change)
        return owed

    def scaled(self, x: float) -> int:
        """``x`` mapped onto this kind's MIDI range."""
        return scale_to_int(x, self.in_range[0], self.in_range[1], TOP[self.kind])

    def encode(self, v: int) -> list[mido.Message]:
        """The messages that carry the MIDI value ``v`` (control kinds)."""
        if self.kind == "cc":
            return cc_messages(self.channel, self.number, v)
        if self.kind == "cc14":
            return cc14_messages(self.channel, self.number, v)
        if self.kind == "nrpn":
            return nrpn_messages(self.channel, self.number, v)
        if self.kind == "pitchbend":
            return [pitchbend_message(self.channel, v)]
        raise ValueError("kind=note has no value to encode; use gate(), hit() or note()")

    def value(self, x: float) -> list[mido.Message]:
        """The messages for the input value ``x``; none when ``change`` and the MIDI value is the same.

        For ``kind=note`` the value is a gate: non-zero strikes the note, zero releases it.
        """
        if self.kind == "note":
            return self.gate(x)
        v = self.scaled(x)
        if self.change and v == self.last:
            return []
        self.last = v
        return self.encode(v)

    def resend(self) -> list[mido.Message]:
        """The last value again, whatever ``change`` says (to bring a receiver up to date)."""
        return [] if self.last is None or self.kind == "note" else self.encode(self.last)

    def gate(self, x: float) -> list[mido.Message]:
        """Non-zero: note on (with ``velocity``); zero: note off.  NaN is an error."""
        if math.isnan(x):
            raise ValueError("cannot gate a note with NaN")
        return self.note(self.number, self.velocity if x != 0 else 0)

    def hit(self) -> list[mido.Message]:
        """Strike the note now (a bang); releasing it is the caller's timer (:meth:`note_off`)."""
        out = self.note_off(self.number) if self.number in self.held else []
        return out + self.note(self.number, self.velocity, retrigger=True)

    def note(self, number: int, velocity: int, *, retrigger: bool = False) -> list[mido.Message]:
        """Note ``number`` on with ``velocity`` (1..127), or off with 0; repeats obey ``change``."""
        if not 0 <= number <= 127:
            raise ValueError(f"note number must be 0..127, got {number}")
        if not 0 <= velocity <= 127:
            raise ValueError(f"velocity must be 0..127, got {velocity}")
        if velocity == 0:
            if self.change and number not in self.held:
                return []
            return self.note_off(number)
        out: list[mido.Message] = []
        if number in self.held:
            if self.change and not retrigger:
                return []
            out = self.note_off(number)
        self.held.append(number)
        self.last = velocity
        return [*out, mido.Message("note_on", channel=self.channel - 1, note=number, velocity=velocity)]

    def note_off(self, number: int) -> list[mido.Message]:
        """Release note ``number`` (a note-off message, velocity 0)."""
        if number in self.held:
            self.held.remove(number)
        self.last = 0
        return [mido.Message("note_off", channel=self.channel - 1, note=number, velocity=0)]

    def unsent(self, messages: list[mido.Message]) -> None:
        """Take back what making ``messages`` did to the state: they were not delivered (a full disk), so
        the next value goes out even when it is the same, a note struck is not held, and a note whose
        note-off failed still is (the end of the take releases it)."""
        self.last = None
        for m in reversed(messages):
            if m.type == "note_on" and m.velocity > 0:
                if m.note in self.held:
                    self.held.remove(m.note)
            elif m.type in ("note_on", "note_off") and m.note not in self.held:
                self.held.append(m.note)

    def release(self) -> list[mido.Message]:
        """Note-offs for every note held (at the end, or before the channel or number changes)."""
        out: list[mido.Message] = []
        for n in list(self.held):
            out += self.note_off(n)
        return out


# --------------------------------------------------------------------------- standard MIDI files
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


def _acquire_writer(path: str, bpm: float, ppq: int) -> MidiFileWriter:
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


def _release_writer(writer: MidiFileWriter) -> None:
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


# --------------------------------------------------------------------------- the MIDI system (replaceable)
def open_output(name: str | None, *, virtual: bool = False) -> mido.ports.BaseOutput:
    """Open a MIDI output port with mido's backend (python-rtmidi); tests replace this function."""
    return mido.open_output(name, virtual=virtual)


def open_input(
    name: str | None, *, virtual: bool = False, callback: Callable[[mido.Message], None] | None = None
) -> mido.ports.BaseInput:
    """Open a MIDI input port whose messages go to ``callback`` (on the backend's thread); replaceable."""
    return mido.open_input(name, virtual=virtual, callback=callback)


def output_names() -> list[str]:
    """The MIDI output ports of the system; raises ``ImportError`` or ``OSError`` without a MIDI system."""
    return list(mido.get_output_names())


def input_names() -> list[str]:
    """The MIDI input ports of the system; raises ``ImportError`` or ``OSError`` without a MIDI system."""
    return list(mido.get_input_names())


def _match_port(name: str, names: Sequence[str]) -> str | None:
    """The port called ``name``, else the only one whose name contains it (case-insensitive)."""
    if name in names:
        return name
    low = name.lower()
    found = [n for n in names if low in n.lower()]
    return found[0] if len(found) == 1 else None


def _open_port(
    node: Node, direction: str, name: str, virtual: bool, opener: Callable[[str | None], Any]
) -> Any:
    """Open a port by name (or the system's first when ``name`` is empty) or create a virtual one.

    Every failure becomes :class:`MidiUnavailable` naming the node, the port and the fix.
    """
    lister = output_names if direction == "output" else input_names
    label = f"{node.type_name} '{node.name}'"
    what = (
        f"virtual MIDI {direction} port {name!r}"
        if virtual
        else (f"MIDI {direction} port {name!r}" if name else f"the first MIDI {direction} port")
    )
    fallback = (
        f"write a MIDI file instead with file={_safe_stem(node.name)}.mid" if direction == "output" else ""
    )
    try:
        if virtual or not name:
            return opener(name or None)
        try:
            names = lister()
        except OSError:
            names = []  # the opener below reports it
        return opener(_match_port(name, names) or name)
    except ImportError as exc:
        raise MidiUnavailable(
            f"{label}: cannot open {what}: python-rtmidi, the backend mido uses, is not installed ({exc}). "
            f"To fix: {FIX_RTMIDI} and {FIX_SYSTEM}" + (f"; or {fallback}" if fallback else "")
        ) from exc
    except OSError as exc:
        try:
            names = lister()
        except (ImportError, OSError):
            raise MidiUnavailable(
                f"{label}: cannot open {what}: no MIDI system ({type(exc).__name__}: {exc}). "
                f"To fix: {FIX_SYSTEM}" + (f"; or {fallback}" if fallback else "")
            ) from exc
        ports = ", ".join(repr(n) for n in names) or "none"
        raise MidiUnavailable(
            f"{label}: cannot open {what}: {exc}. {direction.capitalize()} ports: {ports}. "
            f"To fix: name one of them (or a unique part of its name), or create one with virtual=true"
            + (f"; or {fallback}" if fallback else "")
        ) from exc


def _first_port(direction: str) -> tuple[str | None, str]:
    """The port a node with no ``port`` opens, for a person: (the system's first, "") or (None, why none)."""
    lister = output_names if direction == "output" else input_names
    try:
        names = lister()
    except ImportError:
        return None, "python-rtmidi is not installed: pip install 'pointat[midi]'"
    except OSError as exc:
        return None, f"no MIDI system ({exc})"
    return (names[0], "") if names else (None, f"the MIDI system has no {direction} port")


def _safe_stem(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in name) or "midi_out"


# --------------------------------------------------------------------------- nodes
#: How often a port opened by name is looked for while the patch runs, in seconds: a controller
#: unplugged mid-show is reported, and opened again when it is plugged back in.
WATCH_PERIOD = 1.0


class _PortWatch:
    """For a MIDI node with a port opened by name: notice it vanish (a cable pulled mid-show, where the
    backend itself goes quiet without a word) and open it again when it comes back.

    A thread of its own lists the system's ports every :data:`WATCH_PERIOD` s (listing opens a MIDI
    client, too slow for the scheduler thread) and hands the list to the scheduler, where the node
    compares it with the port it has open.  A port back under another client number (ALSA numbers a
    replugged device anew) is found again by the name the patch gives, as at start.
    """

    def _watch(self: Any, direction: str) -> None:
        self._direction = direction
        self._missing = False
        if self.p.virtual or not self.p.port:
            return  # ours (virtual) cannot vanish; "the first port" names nothing to look for again
        lister = output_names if direction == "output" else input_names
        rt = self.rt

        def look() -> None:
            while not rt.stopping.wait(WATCH_PERIOD):
                try:
                    names = lister()
                except (ImportError, OSError):
                    continue  # the MIDI system itself hiccuped: look again next time
                rt.post(self, self._ports_seen, names, block=False)

        self.spawn(look, "watch")

    def _ports_seen(self: Any, names: list[str]) -> None:
        """Scheduler thread: the ports the system has now."""
        if not self._missing:
            if self._port_name() in names:
                return
            self._missing = True
            self._lost()
            log.warning(
                "%s '%s': MIDI %s port %r is gone (unplugged?); waiting for it to come back",
                self.type_name,
                self.name,
                self._direction,
                self._port_name(),
            )
            return
        found = _match_port(self.p.port, names)
        if found is None:
            return
        try:
            self._reopen(found)
        except MidiUnavailable as exc:  # still appearing: try again next time
            log.debug("%s", exc)
            return
        self._missing = False
        log.warning("%s '%s': MIDI %s port %r is back", self.type_name, self.name, self._direction, found)

    @staticmethod
    def _close_gone(port: Any) -> None:
        """Close a port that vanished; the backend may refuse to close what is already gone."""
        try:
            port.close()
        except Exception:
            pass


class _PortSink:
    def __init__(self, port: mido.ports.BaseOutput):
        self.port = port
        self.lost = False  # the port vanished (see _PortWatch)

    def send(self, messages: list[mido.Message], time: float) -> None:
        for m in messages:
            self.port.send(m)

    def close(self) -> None:
        self.port.close()

    def __str__(self) -> str:
        return f"MIDI port {getattr(self.port, 'name', '')!r}"


class _FileSink:
    def __init__(self, path: str, bpm: float, ppq: int):
        self.writer = _acquire_writer(path, bpm, ppq)

    def send(self, messages: list[mido.Message], time: float) -> None:
        self.writer.write_all(messages, time)

    def close(self) -> None:
        _release_writer(self.writer)

    def __str__(self) -> str:
        return f"MIDI file {str(self.writer.path)!r}"


def _check_out_params(values: dict[str, Any]) -> None:
    check_mapping(
        values.get("kind", "cc"),
        values.get("channel", 1),
        values.get("number", 10),
        values.get("range", (0.0, 1.0)),
        values.get("velocity", 100),
    )
    if values.get("file") and (values.get("port") or values.get("virtual")):
        raise ValueError("give file= (a MIDI file) or port=/virtual= (a MIDI port), not both")
    if values.get("length", 100.0) < 0:
        raise ValueError(f"length must be >= 0 ms, got {values.get('length')}")
    if not values.get("bpm", 120.0) > 0:
        raise ValueError(f"bpm must be positive, got {values.get('bpm')}")
    if not 1 <= values.get("ppq", 480) <= 32767:
        raise ValueError(f"ppq must be 1..32767, got {values.get('ppq')}")


_MAPPING_PARAMS = {
    "kind": "kind",
    "channel": "channel",
    "number": "number",
    "range": "in_range",
    "velocity": "velocity",
    "change": "change",
}


@register("midi_out")
class MidiOut(_PortWatch, Node):
    r"""Send values as MIDI: 7-bit or 14-bit CC, NRPN, pitch bend, or notes for gestures.

    A number at the inlet is mapped linearly from ``range`` ``[in_lo, in_hi]`` onto the MIDI range of
    ``kind`` (clipped): ``cc`` 0..127 on controller ``number``; ``cc14`` 0..16383 with the MSB on
    ``number`` (0..31) and the LSB on ``number + 32``; ``nrpn`` 0..16383 as CC99/98 (parameter ``number``)
    then CC6/38 (value); ``pitchbend`` 0..16383 (centre 8192).  With ``change`` (the default) a value that
    maps to the MIDI value already sent is not sent again.  A bang resends the last value.

    ``kind=note`` is for gestures: a non-zero number (1 from a threshold) sends note ``number`` on with
    ``velocity``, 0 sends it off; a bang strikes it and releases it ``length`` ms later; a list
    ``note velocity`` plays that note (velocity 0: off); ``off`` releases every note held.  Notes still
    held when the patch stops are released.

    Azimuth -> DAW pan (CC10: 0 left, 64 centre, 127 right; pointat's azimuth is + left): ``number=10
    range=[90, -90] fold=true``: +90 deg -> 0, 0 deg -> 64, -90 deg -> 127; ``fold`` mirrors an azimuth
    behind the listener to the front (135 -> 45, 180 -> 64), so turning round pans smoothly back (without
    it, beyond +-90 deg is clipped and the pan jumps from side to side where the azimuth crosses 180).

    Where it goes: ``file=out.mid`` writes a standard MIDI file (format 0; times from the messages'
    time stamps at ``bpm`` and ``ppq``: 1 tick = 60 / (bpm x ppq) s, 1.04 ms at the defaults; valid on
    disk after every message, closed when the patch stops).  ``port=NAME`` opens that MIDI output port
    (its exact name, or a unique part of it); ``virtual=true`` creates a port named ``port`` (default
    ``pointat``) for a DAW to connect to.  Ports need python-rtmidi (``pip install 'pointat[midi]'``) and
    a MIDI system: without them a port is an error at start that says so.  With neither ``port`` nor
    ``file`` the system's first output port is used when there is one, else ``NODE_NAME.mid`` in the
    working directory (with a warning).  Several midi_out nodes may write the same file.  A port named
    by ``port`` is looked for every second while the patch runs: unplugged mid-show, it is reported once
    and what would go to it is dropped (counted in ``dropped``); plugged back in, it is opened again and
    the last value is sent again, so the receiver catches up.
    """

    needs_input = True

    inlets = (
        Inlet(
            "in",
            ("float", "int", "bang", "list"),
            "a value in range (note: 1/0 gate); bang: resend (note: strike); list: note velocity",
        ),
    )
    outlets = ()
    params = (
        Param("kind", "symbol", "cc", "what to send", choices=MIDI_KINDS),
        Param("channel", "int", 1, "MIDI channel, 1..16", live=True),
        Param(
            "number",
            "int",
            10,
            "controller (cc 0..119: 120..127 are channel mode messages; cc14 0..31), NRPN (0..16383) or note number",
            live=True,
        ),
        Param(
            "range",
            "vector",
            (0.0, 1.0),
            "input values [in_lo, in_hi] mapped to the MIDI range's bottom and top",
            live=True,
            size=2,
        ),
        FOLD,
        Param("change", "bool", True, "send only when the MIDI value changes", live=True),
        Param("velocity", "int", 100, "note-on velocity, 1..127 (kind=note)", live=True),
        Param("length", "float", 100.0, "how long a banged note sounds (kind=note)", unit="ms", live=True),
        Param("port", "symbol", "", "MIDI output port name (needs python-rtmidi and a MIDI system)"),
        Param("virtual", "bool", False, "create a virtual port named port (default 'pointat')"),
        Param("file", "path", "", "write a standard MIDI file here instead of a port", writes=True),
        Param("bpm", "float", 120.0, "tempo of the MIDI file", unit="beats/min"),
        Param("ppq", "int", 480, "MIDI file resolution, ticks per quarter note"),
    )
    example = """
node dir  azi_ele
node pan  midi_out kind=cc number=10 range=[90, -90] fold=true file=pan.mid
dir.azimuth -> pan
"""

    @classmethod
    def validate(cls, values):
        _check_out_params(dict(values))

    def setup(self) -> None:
        self.sender = MidiSender(
            self.p.kind,
            self.p.channel,
            self.p.number,
            self.p.range,
            change=self.p.change,
            velocity=self.p.velocity,
        )
        self._sink: _PortSink | _FileSink | None = None
        self._timer: Timer | None = None
        self.sent = 0
        self.dropped = 0  # while the port was unplugged

    def start(self) -> None:
        self._sink = self._open_sink()
        log.info("midi_out '%s': sending to %s", self.name, self._sink)
        if isinstance(self._sink, _PortSink):
            self._watch("output")

    def _port_name(self) -> str:
        return getattr(self._sink.port, "name", "") if isinstance(self._sink, _PortSink) else ""

    def describe_port(self) -> str:
        """Where the messages go, named for the console's banner: a file, a port by name (with no
        ``port``, the system's first output as it lists now), or the file written when there is none."""
        if self._sink is not None:
            return str(self._sink)
        if self.p.file:
            return f"MIDI file {self.p.file}"
        if self.p.virtual:
            return f"a virtual MIDI port {self.p.port or 'pointat'!r} for other programs to connect to"
        if self.p.port:
            return f"MIDI port {self.p.port!r}"
        first, why = _first_port("output")
        if first is None:
            return f"MIDI file {Path(_safe_stem(self.name) + '.mid').resolve()} (no MIDI port: {why})"
        return f"MIDI port {first!r} (the system's first)"

    def _lost(self) -> None:
        """The port vanished: close it; what is sent meanwhile is dropped and counted."""
        sink = self._sink
        if isinstance(sink, _PortSink):
            sink.lost = True
            self._close_gone(sink)

    def _reopen(self, name: str) -> None:
        self._sink = _PortSink(_open_port(self, "output", name, False, lambda n: open_output(n)))
        self._send(self.sender.resend(), self.time)  # bring the receiver up to date

    def _open_sink(self) -> _PortSink | _FileSink:
        if self.p.file:
            try:
                return _FileSink(self.p.file, self.p.bpm, self.p.ppq)
            except OSError as exc:  # the folder went away since the patch was checked, a full disk
                raise OSError(f"cannot write {self.p.file}: {exc.strerror or exc}") from exc
        if self.p.port or self.p.virtual:
            name = self.p.port or "pointat"
            port = _open_port(
                self, "output", name, self.p.virtual, lambda n: open_output(n, virtual=self.p.virtual)
            )
            return _PortSink(port)
        try:
            names = output_names()
        except (ImportError, OSError) as exc:
            reason = f"no MIDI system ({type(exc).__name__}: {exc})"
        else:
            if names:
                return _PortSink(_open_port(self, "output", names[0], False, lambda n: open_output(n)))
            reason = "the MIDI system has no output port"
        path = _safe_stem(self.name) + ".mid"
        log.warning(
            "midi_out '%s': %s; writing %s instead (give port= or file= to choose)",
            self.name,
            reason,
            Path(path).resolve(),
        )
        return _FileSink(path, self.p.bpm, self.p.ppq)

    def on_in(self, msg: Message) -> None:
        if msg.kind == "bang":
            if self.p.kind == "note":
                self._strike()
                return
            messages = self.sender.resend()
        elif msg.kind == "list" and self.p.kind == "note" and len(msg.value) >= 2:
            note, velocity = (float(v) for v in msg.value[:2])
            if not (note.is_integer() and velocity.is_integer()):
                raise ValueError(f"a note list is 'note velocity' in whole numbers, got {msg.describe()}")
            messages = self.sender.note(int(note), int(velocity))
        else:
            x = as_float(msg)
            messages = self.sender.value(fold_front(x) if self.p.fold else x)
        self._send(messages, msg.time)

    def _strike(self) -> None:
        self._cancel()
        self._send(self.sender.hit(), self.time)
        self._timer = self.call_later(self.p.length / 1000.0, self._release_hit, self.sender.number)

    def _release_hit(self, number: int) -> None:
        self._timer = None
        if number in self.sender.held:
            self._send(self.sender.note_off(number), self.time)

    def do_off(self) -> None:
        """Release every note held."""
        self._cancel()
        self._send(self.sender.release(), self.time)

    def _cancel(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None

    def _send(self, messages: list[mido.Message], time: float) -> None:
        if not messages:
            return
        if self._sink is None:
            raise RuntimeError(f"midi_out '{self.name}' has no open output (see the error at start)")
        if getattr(self._sink, "lost", False):  # unplugged: said once when it went
            self.dropped += len(messages)
            return
        try:
            self._sink.send(messages, time)  # a 14-bit value's two halves together, or neither
        except BaseException:
            self.sender.unsent(messages)  # owed still: a fader that stays put is written when room comes
            raise
        self.sent += len(messages)

    def param_changed(self, name: str) -> None:
        key = _MAPPING_PARAMS.get(name)
        if key is not None:  # already validated as a whole by validate()
            owed = self.sender.configure(**{key: getattr(self.p, name)})
            if self._sink is not None:
                self._send(owed, self.time)

    def close(self) -> None:
        self._cancel()
        sink, self._sink = self._sink, None
        if sink is None:
            return
        if getattr(sink, "lost", False):  # closed when it vanished
            return
        try:
            sink.send(self.sender.release(), self.time)
        finally:
            sink.close()


@register("midi_in")
class MidiIn(_PortWatch, Node):
    """Receive MIDI from a named port: a foot controller's switches and pedals as control messages.

    Control changes leave by ``cc`` as a list ``number value`` (route them by number with ``route``);
    notes by ``note`` as ``note velocity`` (a note-off is velocity 0); pitch bend by ``bend`` (-8192..8191);
    anything else (program_change, aftertouch...) by ``other`` as a method message named after its type
    with its data (``program_change 5``).  ``channel`` 1..16 keeps one channel (0: all).  Needs
    python-rtmidi and a MIDI system: without them the node reports at start what to install.

    A port named by ``port`` is looked for every second while the patch runs: unplugged mid-show, it is
    reported once, and when it is plugged back in it is opened again (the patch keeps running).
    """

    outlets = (
        Outlet("cc", "list", "controller number, value 0..127"),
        Outlet("note", "list", "note number, velocity 0..127 (0: note off)"),
        Outlet("bend", "int", "pitch bend -8192..8191 (0: centre)"),
        Outlet("other", "any", "other messages: type, then data (program_change 5)"),
    )
    params = (
        Param("port", "symbol", "", "MIDI input port name, or a unique part of it ('': the first)"),
        Param("virtual", "bool", False, "create a virtual input port named port (default 'pointat')"),
        Param("channel", "int", 0, "only this channel, 1..16 (0: every channel)"),
    )
    example = """
node foot  midi_in port="FCB1010"
node pedal route 64
node press route 127
node ref   reference
foot.cc -> pedal
pedal.0 -> press
press.0 -> ref.capture
"""

    @classmethod
    def validate(cls, values):
        ch = values.get("channel", 0)
        if not 0 <= ch <= 16:
            raise ValueError(f"channel must be 1..16, or 0 for every channel; got {ch}")

    def setup(self) -> None:
        self._port: mido.ports.BaseInput | None = None
        self.received = 0

    def describe_port(self) -> str:
        """The port it listens on, named for the console's banner (with no ``port``, the system's first
        input as it lists now)."""
        if self._port is not None:
            return f"MIDI port {getattr(self._port, 'name', '')!r}"
        if self.p.virtual:
            return f"a virtual MIDI port {self.p.port or 'pointat'!r} for other programs to connect to"
        if self.p.port:
            return f"MIDI port {self.p.port!r}"
        first, why = _first_port("input")
        return f"MIDI port {first!r} (the system's first)" if first else f"no MIDI port: {why}"

    def start(self) -> None:
        name = self.p.port or ("pointat" if self.p.virtual else "")
        self._port = _open_port(
            self,
            "input",
            name,
            self.p.virtual,
            lambda n: open_input(n, virtual=self.p.virtual, callback=self._on_midi),
        )
        self.active = True
        log.info("midi_in '%s': listening on %r", self.name, getattr(self._port, "name", name))
        self._watch("input")

    def _port_name(self) -> str:
        return getattr(self._port, "name", "") or ""

    def _lost(self) -> None:
        self.active = False
        self._close_gone(self._port)

    def _reopen(self, name: str) -> None:
        self._port = _open_port(self, "input", name, False, lambda n: open_input(n, callback=self._on_midi))
        self.active = True

    def _on_midi(self, msg: mido.Message) -> None:
        """Backend thread: hand the message to the scheduler (dropped and counted when it is full)."""
        rt = self.rt
        if rt is not None and not rt.stopping.is_set():
            rt.post(self, self._handle, msg, block=False)  # never block the backend's thread

    def _handle(self, msg: mido.Message) -> None:
        self.time = self.now
        channel = getattr(msg, "channel", None)
        if self.p.channel and channel is not None and channel != self.p.channel - 1:
            return
        self.received += 1
        t = msg.type
        if t == "control_change":
            self.out(0, (msg.control, msg.value))
        elif t == "note_on":
            self.out(1, (msg.note, msg.velocity))
        elif t == "note_off":
            self.out(1, (msg.note, 0))
        elif t == "pitchwheel":
            self.out(2, msg.pitch)
        else:
            data = [v for k, v in msg.dict().items() if k not in ("type", "time", "channel")]
            flat = [x for v in data for x in (v if isinstance(v, (tuple, list)) else (v,))]
            self.out(3, method(t, *flat))

    def close(self) -> None:
        self.active = False
        port, self._port = self._port, None
        if port is not None:
            port.close()
