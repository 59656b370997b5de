r"""MIDI mapping with no port and no engine: pointat values in, port-less ``mido.Message`` lists out.

* plain functions (:func:`scale_to_int`, :func:`cc_messages`, :func:`cc14_messages`,
  :func:`nrpn_messages`, :func:`pitchbend_message`) build the messages;
* :class:`MidiSender` holds one output's mapping and state (last value sent, notes held) and turns
  pointat values into lists of messages; it knows nothing of ports or of the engine.

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
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from typing import Any

import mido

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
