r"""Wire format of the glove's mote: one sample of nine 12-bit ADC channels, binary or text.

The Tyndall 25 mm WIMU (Torre et al., NIME 2008, §3.1) sends its samples wirelessly to a base station on a
serial port; its packet layout is not published.  pointat therefore defines its own two framings of the
same sample, a compact binary frame for radio links and a text line an Arduino can ``Serial.println``.
A :class:`FrameParser` reads either (or both, interleaved) from a byte stream.

Channels
--------
Every sample carries nine raw ADC counts, 0..4095 (the mote's ADC is 12-bit), always in this order
(:data:`CHANNELS`), on the glove's sensor axes (x along the hand, y left, z out of the back of the hand):

=====  =========  =====  =========  =====  =========
index  channel    index  channel    index  channel
=====  =========  =====  =========  =====  =========
0      gyro_x     3      accel_x    6      mag_x
1      gyro_y     4      accel_y    7      mag_y
2      gyro_z     5      accel_z    8      mag_z
=====  =========  =====  =========  =====  =========

How counts become °/s, m/s² and gauss (Torre's Table 1) is :class:`MoteSpec`: ``value = (count - null)
* resolution``.

Binary frame (21 bytes)
-----------------------
Multi-byte integers are big-endian (network order).  Channels are packed two per three bytes, high
nibble first, exactly as a 12-bit ADC delivers them; the odd ninth channel takes two bytes whose top
four bits must be zero.

======  =====  =======================================================================
offset  size   field
======  =====  =======================================================================
0       1      sync ``0xA5``
1       1      sync ``0x5A``
2       1      mote id, u8 (0..255)
3       2      ``n_pack``, u16, +1 per sample, wraps 65535 -> 0
5       3      gyro_x, gyro_y: ``aaaaaaaa aaaabbbb bbbbbbbb``
8       3      gyro_z, accel_x
11      3      accel_y, accel_z
14      3      mag_x, mag_y
17      2      ``0000`` + mag_z (12 bits)
19      2      CRC-16/CCITT-FALSE of bytes 2..18
======  =====  =======================================================================

Why these choices:

* **Packing.** 21 bytes instead of 25 with one u16 per channel: four motes at 100 Hz need 8400 B/s,
  73% of a 115200-baud 8N1 link (11520 B/s), against 87% unpacked.
* **Sync** ``0xA5 0x5A``: alternating bits, and ``0xA5`` is not ASCII, so a binary frame can never be
  mistaken for the start or the middle of a text line (auto-detection stays unambiguous).  The sync
  bytes may also occur inside a payload; the checksum, not the sync, decides what is a frame.
* **CRC-16/CCITT-FALSE** (polynomial 0x1021, initial value 0xFFFF, no reflection, no final XOR; check
  value 0x29B1 for ``b"123456789"``).  Over a 17-byte body it detects every error of 1, 2 or any odd
  number of bits and every burst of up to 16 bits, and lets a random false sync through with probability
  2⁻¹⁶.  The non-zero initial value makes leading zero bytes count.  It is cheap on a microcontroller
  (avr-libc ``_crc_xmodem_update`` started at 0xFFFF) and in Python (:func:`binascii.crc_hqx` with
  ``0xFFFF``).  An XOR or additive checksum would miss swapped and paired errors.

Text line
---------
One sample per line, ASCII, eleven unsigned decimal integers::

    [$]id n_pack c1 c2 c3 c4 c5 c6 c7 c8 c9\n

* Separators: one or more spaces or tabs, or a comma with optional spaces around it (``1,7,2048,...``).
* An optional leading ``$`` marks the start of a line.  :func:`encode_text` writes it and Arduino
  sketches should too: it lets the parser resynchronise in the middle of a damaged line (a ``$`` can
  only start a line), whereas a stray digit glued to an untagged line changes its mote id.
* ``\r\n`` endings (``Serial.println``) are accepted; a line is at most :data:`MAX_LINE` bytes.
* Ranges: id 0..255, n_pack 0..65535, channels 0..4095.  Text lines carry **no checksum**: damage that
  keeps the structure and the ranges goes undetected.  Use the binary frame on noisy links.

Parsing, loss and corruption
----------------------------
:class:`FrameParser` is incremental: feed it bytes as they come, in any chunking, and it returns the
complete frames.  Anything that is not a good frame is skipped byte by byte and counted as garbage (the
bytes of a rejected frame included), so the parser resynchronises after noise, truncated frames and
sync bytes inside payloads.  Candidate frames that fail (bad checksum, channel out of range, malformed
line) are dropped and counted as corrupt.  Per mote id it checks that ``n_pack`` increases by one
(wrap-aware, serial-number arithmetic as in RFC 1982) and reports gaps as :class:`LostPackets` events.
Given the motes' sample rate and the time each read came in, a gap larger than the packets a mote could
have sent since its last frame (:func:`could_be_lost`) is a :class:`CounterJump` instead: a mote that
restarted with its counter past 32767 would otherwise read as some 30,000 packets lost.

Examples
--------
>>> frame = Frame(mote=1, n_pack=7, channels=(2048, 2049, 2047, 2048, 2048, 2558, 2448, 2048, 1606))
>>> wire = encode_frame(frame)
>>> len(wire), wire[:2].hex()
(21, 'a55a')
>>> encode_text(frame)
b'$1 7 2048 2049 2047 2048 2048 2558 2448 2048 1606\n'
>>> parser = FrameParser()
>>> parser.feed(b"noise" + wire[:10])
[]
>>> parser.feed(wire[10:] + encode_text(frame._replace(n_pack=9))) == [frame, frame._replace(n_pack=9, lost=1)]
True
>>> parser.pop_events()
[Garbage(nbytes=5), NewMote(mote=1, n_pack=7), LostPackets(mote=1, expected=8, got=9, count=1)]
>>> parser.stats.motes[1].received, parser.stats.motes[1].lost
(2, 1)
"""

from __future__ import annotations

import binascii
import copy
import logging
import operator
import re
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal, NamedTuple

import numpy as np

__all__ = [
    "ADC_MAX",
    "ADC_NULL",
    "CHANNELS",
    "DEFAULT_RESOLUTION",
    "DEFAULT_SPEC",
    "FRAME_LEN",
    "MAX_LINE",
    "SYNC",
    "CorruptFrame",
    "CounterJump",
    "Frame",
    "FrameEvent",
    "FrameFormat",
    "FrameParser",
    "Garbage",
    "LostPackets",
    "MoteSpec",
    "MoteStats",
    "NewMote",
    "ParserStats",
    "adc_full_scale",
    "could_be_lost",
    "crc16_ccitt_false",
    "encode_frame",
    "encode_text",
]

log = logging.getLogger(__name__)

CHANNELS: tuple[str, ...] = (
    "gyro_x",
    "gyro_y",
    "gyro_z",
    "accel_x",
    "accel_y",
    "accel_z",
    "mag_x",
    "mag_y",
    "mag_z",
)
"""Channel names in frame order."""

ADC_MAX = 4095
"""Largest 12-bit ADC count."""
ADC_NULL = 2048
"""Mid-scale count: the nominal zero of every channel."""

SYNC = b"\xa5\x5a"
"""The two sync bytes that open a binary frame."""
FRAME_LEN = 21
"""Length of a binary frame in bytes."""
MAX_LINE = 128
"""Longest accepted text line in bytes, ``$`` and line ending excluded."""

_N_CHANNELS = 9
_CRC_INIT = 0xFFFF
_MAX_GARBAGE_RUN = 1024  # report a long run of garbage in parts of this size


# --------------------------------------------------------------------------------------------------
# Sample and sensor specification
# --------------------------------------------------------------------------------------------------


class Frame(NamedTuple):
    """One sample of one mote: its id, its packet counter and nine raw ADC counts.

    Parameters
    ----------
    mote : int
        Mote id, 0..255.
    n_pack : int
        Packet counter, 0..65535, incremented by the mote for every sample and wrapping to 0.
    channels : tuple of int
        Nine ADC counts 0..4095 in :data:`CHANNELS` order (gyro x y z, accel x y z, mag x y z).
    lost : int
        Set by :class:`FrameParser`: the packets of this mote that never arrived just before this one
        (its :class:`LostPackets` event's count), else 0.
    jump : bool
        Set by :class:`FrameParser`: the counter jumped to this frame (a :class:`CounterJump`: a restart,
        a duplicate, an outage too long to count), so its time is not the last one's plus a packet.

    Examples
    --------
    >>> f = Frame(3, 65535, tuple(range(9)))
    >>> f.gyro, f.accel, f.mag
    ((0, 1, 2), (3, 4, 5), (6, 7, 8))
    """

    mote: int
    n_pack: int
    channels: tuple[int, ...]
    lost: int = 0
    jump: bool = False

    @property
    def gyro(self) -> tuple[int, ...]:
        """Gyroscope counts (x, y, z)."""
        return tuple(self.channels[0:3])

    @property
    def accel(self) -> tuple[int, ...]:
        """Accelerometer counts (x, y, z)."""
        return tuple(self.channels[3:6])

    @property
    def mag(self) -> tuple[int, ...]:
        """Magnetometer counts (x, y, z)."""
        return tuple(self.channels[6:9])


DEFAULT_RESOLUTION: dict[str, float] = {"gyro": 0.1, "accel": 0.0192, "mag": 0.001}
"""Default resolution per sensor, in Torre's Table 1 units per ADC count.

========== ============ ================ ================================================
sensor     unit         per count        full scale about the null of 2048
========== ============ ================ ================================================
gyro       °/s          0.1              ±204.8 °/s
accel      m/s²         0.0192           ±39.3 m/s² (±4.0 g)
mag        gauss        0.001            ±2.048 gauss (the Earth's field is ~0.25..0.65)
========== ============ ================ ================================================

These are plausible values, not the Tyndall mote's calibration (unpublished): the gyro figure matches
an ADXRS150 (12.5 mV/°/s) read by a 12-bit ADC with a 5 V reference (1.22 mV/count -> 0.098 °/s).
Torre et al. find the real nulls by averaging the first thousand samples at rest and take the
resolutions from the data sheets or by experiment.
"""


@dataclass(frozen=True)
class MoteSpec:
    r"""How raw ADC counts map to physical units, per channel: ``value = (count - null) * resolution``.

    This is Torre et al.'s Table 1 as data, shared by the glove simulator and the ``scaling`` node.
    Units are the table's: gyro °/s, accelerometer m/s² (specific force), magnetometer gauss.

    Parameters
    ----------
    null : tuple of 9 float
        Count that reads zero, per channel (:data:`CHANNELS` order).  Default 2048 (mid-scale).
    resolution : tuple of 9 float
        Physical units per count, per channel.  Default :data:`DEFAULT_RESOLUTION`.

    Examples
    --------
    >>> spec = MoteSpec()
    >>> spec.to_units([2058, 2048, 2048, 2048, 2048, 2559, 2448, 2048, 1606])[:3]
    (1.0, 0.0, 0.0)
    >>> spec.to_counts([1.0, 0, 0, 0, 0, 9.81, 0.4, 0, -0.442])
    (2058, 2048, 2048, 2048, 2048, 2559, 2448, 2048, 1606)
    >>> spec.to_counts([500.0, -500.0, 0, 0, 0, 0, 0, 0, 0])[:2]
    (4095, 0)
    """

    null: tuple[float, ...] = (float(ADC_NULL),) * _N_CHANNELS
    resolution: tuple[float, ...] = (
        (DEFAULT_RESOLUTION["gyro"],) * 3
        + (DEFAULT_RESOLUTION["accel"],) * 3
        + (DEFAULT_RESOLUTION["mag"],) * 3
    )

    def __post_init__(self) -> None:
        if len(self.null) != _N_CHANNELS or len(self.resolution) != _N_CHANNELS:
            raise ValueError(
                f"MoteSpec needs {_N_CHANNELS} nulls and resolutions, got {len(self.null)} and "
                f"{len(self.resolution)}"
            )
        if any(r == 0 for r in self.resolution):
            raise ValueError(f"MoteSpec resolution must be non-zero, got {self.resolution}")
        object.__setattr__(self, "null", tuple(float(v) for v in self.null))
        object.__setattr__(self, "resolution", tuple(float(v) for v in self.resolution))

    @property
    def full_scale(self) -> tuple[tuple[float, float], ...]:
        """Per channel, the physical values of counts 0 and 4095."""
        return tuple(
            ((0 - n) * r, (ADC_MAX - n) * r) for n, r in zip(self.null, self.resolution, strict=True)
        )

    def to_units(self, counts: Sequence[float]) -> tuple[float, ...]:
        """Convert nine counts to physical units (°/s, m/s², gauss)."""
        if len(counts) != _N_CHANNELS:
            raise ValueError(f"expected {_N_CHANNELS} counts, got {len(counts)}")
        return tuple((c - n) * r for c, n, r in zip(counts, self.null, self.resolution, strict=True))

    def to_counts(self, values: Sequence[float]) -> tuple[int, ...]:
        """Convert nine physical values to ADC counts: round to nearest, clip to 0..4095."""
        if len(values) != _N_CHANNELS:
            raise ValueError(f"expected {_N_CHANNELS} values, got {len(values)}")
        return tuple(
            min(ADC_MAX, max(0, int(round(n + v / r))))
            for v, n, r in zip(values, self.null, self.resolution, strict=True)
        )


DEFAULT_SPEC = MoteSpec()


def adc_full_scale(
    sensor: Literal["gyro", "accel", "mag"], spec: MoteSpec = DEFAULT_SPEC
) -> tuple[float, float, float]:
    """The glove's own full scale: the symmetric range (±, physical units) each axis of ``sensor`` spans
    through the 12-bit ADC, the smaller of ``null * resolution`` and ``(4095 - null) * resolution``.

    Beyond it a reading clips at count 0 or 4095 (one side reaches a count further).  Units as
    :class:`MoteSpec`: °/s, m/s², gauss.

    Examples
    --------
    >>> [round(v, 4) for v in adc_full_scale("accel")], round(adc_full_scale("accel")[0] / 9.80665, 3)
    ([39.3024, 39.3024, 39.3024], 4.008)
    >>> [round(v, 1) for v in adc_full_scale("gyro")]
    [204.7, 204.7, 204.7]
    """
    groups = {"gyro": 0, "accel": 3, "mag": 6}
    if sensor not in groups:
        raise ValueError(f"sensor must be 'gyro', 'accel' or 'mag', got {sensor!r}")
    i = groups[sensor]
    return tuple(min(abs(lo), abs(hi)) for lo, hi in spec.full_scale[i : i + 3])  # type: ignore[return-value]


"""The default :class:`MoteSpec`: null 2048 and :data:`DEFAULT_RESOLUTION` on every channel."""


# --------------------------------------------------------------------------------------------------
# Encoding
# --------------------------------------------------------------------------------------------------


def crc16_ccitt_false(data: bytes | bytearray | memoryview) -> int:
    """CRC-16/CCITT-FALSE: polynomial 0x1021, init 0xFFFF, not reflected, no final XOR.

    Examples
    --------
    >>> hex(crc16_ccitt_false(b"123456789"))
    '0x29b1'
    """
    return binascii.crc_hqx(data, _CRC_INIT)


def _as_int(value: object, what: str, hi: int) -> int:
    try:
        v = operator.index(value)  # ints and numpy integers; not floats
    except TypeError:
        raise ValueError(f"{what} must be an integer 0..{hi}, got {value!r}") from None
    if not 0 <= v <= hi:
        raise ValueError(f"{what} must be an integer 0..{hi}, got {value!r}")
    return v


def _check_frame(frame: Frame) -> tuple[int, int, tuple[int, ...]]:
    mote, n_pack, channels = frame[:3]
    if len(channels) != _N_CHANNELS:
        raise ValueError(f"expected {_N_CHANNELS} channels, got {len(channels)}")
    return (
        _as_int(mote, "mote id", 255),
        _as_int(n_pack, "n_pack", 0xFFFF),
        tuple(_as_int(c, f"channel {name}", ADC_MAX) for name, c in zip(CHANNELS, channels, strict=True)),
    )


def encode_frame(frame: Frame) -> bytes:
    """Encode a frame as the 21-byte binary frame described in the module docstring.

    Raises
    ------
    ValueError
        If the id, counter or a channel is out of range or not an integer (numpy integers are fine).

    Examples
    --------
    >>> encode_frame(Frame(1, 258, (0x123, 0x456, 0, 0, 0, 0, 0, 0, 0xABC))).hex(" ")
    'a5 5a 01 01 02 12 34 56 00 00 00 00 00 00 00 00 00 0a bc 54 05'
    """
    mote, n_pack, ch = _check_frame(frame)
    body = bytearray((mote, n_pack >> 8, n_pack & 0xFF))
    for a, b in zip(ch[0:8:2], ch[1:8:2], strict=True):
        body += bytes((a >> 4, ((a & 0xF) << 4) | (b >> 8), b & 0xFF))
    body += bytes((ch[8] >> 8, ch[8] & 0xFF))
    crc = crc16_ccitt_false(body)
    return SYNC + bytes(body) + bytes((crc >> 8, crc & 0xFF))


def encode_text(frame: Frame, *, tag: bool = True, sep: str = " ", newline: str = "\n") -> bytes:
    """Encode a frame as one text line ``[$]id n_pack c1 .. c9``.

    Parameters
    ----------
    frame : Frame
        The sample.
    tag : bool
        Start the line with ``$`` (recommended: it lets a reader resynchronise inside damaged lines).
    sep : str
        Separator: ``" "``, ``"\\t"``, ``","`` or ``", "``.
    newline : str
        ``"\\n"`` or ``"\\r\\n"``.

    Examples
    --------
    >>> encode_text(Frame(2, 5, (1,) * 9), tag=False, sep=",", newline="\\r\\n")
    b'2,5,1,1,1,1,1,1,1,1,1\\r\\n'
    """
    mote, n_pack, ch = _check_frame(frame)
    if sep not in (" ", "\t", ",", ", "):
        raise ValueError(f"sep must be ' ', '\\t', ',' or ', ', got {sep!r}")
    if newline not in ("\n", "\r\n"):
        raise ValueError(f"newline must be '\\n' or '\\r\\n', got {newline!r}")
    text = sep.join(str(int(v)) for v in (mote, n_pack, *ch))
    return (("$" if tag else "") + text + newline).encode("ascii")


# --------------------------------------------------------------------------------------------------
# Events and statistics
# --------------------------------------------------------------------------------------------------


class NewMote(NamedTuple):
    """A mote id was seen for the first time (with this counter value)."""

    mote: int
    n_pack: int


class LostPackets(NamedTuple):
    """The counter of ``mote`` jumped from ``expected`` to ``got``: ``count`` samples never arrived."""

    mote: int
    expected: int
    got: int
    count: int


class CounterJump(NamedTuple):
    """The counter of ``mote`` went backwards or jumped by more than ``max_gap``, or by more than the
    mote could have sent in the time since its last frame (:func:`could_be_lost`).

    A mote reset, a duplicate, or an outage too long to count; the count resumes from ``got``.
    """

    mote: int
    expected: int
    got: int


class CorruptFrame(NamedTuple):
    """A candidate frame was dropped.

    ``mote`` is the id the damaged frame claims if that id was already known, else ``None``;
    ``kind`` is ``"binary"`` or ``"text"``; ``reason`` says what was wrong.
    """

    mote: int | None
    kind: str
    reason: str


class Garbage(NamedTuple):
    """``nbytes`` bytes were skipped.

    Reported when the run of garbage ends at a good frame, every 1024 bytes of a long run, and by
    :meth:`FrameParser.flush`; garbage at the very end of the input waits for one of these.
    """

    nbytes: int


FrameEvent = NewMote | LostPackets | CounterJump | CorruptFrame | Garbage
"""Any event a :class:`FrameParser` reports."""


@dataclass
class MoteStats:
    """Counters for one mote id."""

    received: int = 0
    lost: int = 0
    corrupt: int = 0
    jumps: int = 0
    last_n_pack: int | None = None


@dataclass
class ParserStats:
    """Counters of a :class:`FrameParser`.

    Invariant: ``bytes_in == frame_bytes + garbage_bytes + pending`` where ``pending`` is the parser's
    count of buffered bytes.  ``corrupt`` counts every dropped candidate frame; ``motes[i].corrupt``
    only those whose (unverified) id was already known.
    """

    bytes_in: int = 0
    frame_bytes: int = 0
    garbage_bytes: int = 0
    frames: int = 0
    binary_frames: int = 0
    text_frames: int = 0
    corrupt: int = 0
    lost: int = 0
    motes: dict[int, MoteStats] = field(default_factory=dict)

    def copy(self) -> ParserStats:
        """A deep copy, safe to read while the parser goes on."""
        return copy.deepcopy(self)


# --------------------------------------------------------------------------------------------------
# Parser
# --------------------------------------------------------------------------------------------------

#: How far a mote's clock may run from its stated rate (5%): it may have sent that many more packets.
RATE_SLACK = 0.05
#: Seconds a frame may wait between being sent and being read (a stalled reader, an adapter's buffer):
#: the packets of a mote read together were sent that much further apart.
LATE_SLACK = 1.0


def could_be_lost(missing: int, elapsed: float, rate: float) -> bool:
    r"""Whether ``missing`` packets can have been lost between two frames of a mote that samples at
    ``rate`` Hz, read ``elapsed`` seconds apart by the host: at most

    .. math:: n_{max} = \left((1 + s)\,\Delta t + L\right) f

    of them (:data:`RATE_SLACK` :math:`s`, :data:`LATE_SLACK` :math:`L` seconds), and :math:`n_{max}`
    below the counter's 65536, beyond which the counter may have gone round and its gap says nothing.
    A larger gap is a restart or a jump of the counter, not loss.

    >>> could_be_lost(3, 0.04, 100.0), could_be_lost(1999, 20.0, 100.0)
    (True, True)
    >>> could_be_lost(25535, 2.0, 100.0), could_be_lost(5, 700.0, 100.0)  # restarted; gone round?
    (False, False)
    """
    most = ((1.0 + RATE_SLACK) * max(elapsed, 0.0) + LATE_SLACK) * rate
    return 0 <= missing <= most < 0x10000


FrameFormat = Literal["auto", "binary", "text"]

_SYNC0, _SYNC1 = SYNC
_DOLLAR = ord("$")
_LF = ord("\n")
_CR = ord("\r")
_CANDIDATE = {
    "auto": re.compile(rb"[\xa5$0-9]"),
    "binary": re.compile(rb"\xa5"),
    "text": re.compile(rb"[$0-9]"),
}
# printable ASCII without '$', plus tab and CR: the bytes a line body may hold
_LINE_BODY = re.compile(rb"[\t\r\x20-\x23\x25-\x7e]*")
_TEXT_SEP = re.compile(r"\s*,\s*|\s+")
_TEXT_FIELD = re.compile(r"[0-9]{1,5}")


class FrameParser:
    """Incremental parser of mote frames, binary and text, with loss and corruption accounting.

    Parameters
    ----------
    format : {"auto", "binary", "text"}
        Which framings to look for.  ``"auto"`` decides per frame, so a stream may mix both.
    max_gap : int
        Largest forward jump of ``n_pack`` counted as lost packets; a larger jump or a backwards step is
        reported as :class:`CounterJump`.  Default 32767, half the counter range (RFC 1982).
    rate : float, optional
        The motes' sample rate, Hz.  With it, and the time of each read given to :meth:`feed`, a jump
        larger than the packets a mote could have sent since its last frame was read is a
        :class:`CounterJump` too (:func:`could_be_lost`): a restart, not loss.
    max_events : int
        Events kept until :meth:`pop_events`; the oldest are dropped beyond this.

    Notes
    -----
    Not thread-safe: feed it from one thread (:class:`~pointat.devices.serial_reader.SerialMoteReader`
    does).  Frames from all motes come out in stream order; use ``frame.mote`` to separate them.
    """

    def __init__(
        self,
        format: FrameFormat = "auto",
        *,
        max_gap: int = 0x7FFF,
        rate: float | None = None,
        max_events: int = 10_000,
    ):
        if format not in _CANDIDATE:
            raise ValueError(f"format must be 'auto', 'binary' or 'text', got {format!r}")
        if not 0 <= max_gap <= 0xFFFE:
            raise ValueError(f"max_gap must be 0..65534, got {max_gap}")
        if rate is not None and not rate > 0:
            raise ValueError(f"rate must be > 0 Hz, got {rate}")
        self.format: FrameFormat = format
        self.max_gap = max_gap
        self.rate = rate
        self._now: float | None = None  # the time of the read being parsed
        self._seen: dict[int, float] = {}  # per mote: the time of the read of its last frame
        self._candidate = _CANDIDATE[format]
        self._buf = bytearray()
        self._events: deque[FrameEvent] = deque(maxlen=max_events)
        self._garbage_run = 0
        self._stats = ParserStats()
        #: Each mote's last packet counter, -1 for one not seen (what :meth:`_accept` keeps in its
        #: :class:`MoteStats`, as an array for :attr:`plain`).
        self.last = np.full(256, -1, np.int64)
        #: A consumer's taker of plain frames, or None: ``plain(buf, pos, end, last, held, now)`` takes the
        #: run of plain binary frames at ``buf[pos:end]`` itself (compiled:
        #: :func:`pointat.compiled.kernel.scan_plain`) and returns ``(frames, position after them, {mote:
        #: frames})``, or None for none.  The parser counts them as it counts its own (:meth:`_took`); they
        #: are not in :meth:`feed`'s list.  ``held[m]`` is 1 for a mote with a frame in that list already:
        #: its later frames go there too, so that the consumer, which handles the list's frames first,
        #: sees every mote's frames in their order.
        self.plain: Any = None
        self.held = np.zeros(256, np.uint8)

    # -- public -----------------------------------------------------------------------------------

    @property
    def stats(self) -> ParserStats:
        """The live counters (use ``stats.copy()`` for a snapshot)."""
        return self._stats

    @property
    def pending(self) -> int:
        """Bytes buffered while waiting for the rest of a frame."""
        return len(self._buf)

    def feed(self, data: bytes | bytearray | memoryview, now: float | None = None) -> list[Frame]:
        """Add bytes and return the frames they complete, in stream order; ``now`` is when they were
        read (seconds, any clock that only goes forward), for telling loss from a restart (``rate``)."""
        self._now = now
        self._stats.bytes_in += len(data)
        buf = self._buf
        buf += data
        frames: list[Frame] = []
        pos, n = 0, len(buf)
        plain = self.plain if self.format != "text" else None
        while pos < n:
            if plain is not None and buf[pos] == _SYNC0 and n - pos >= FRAME_LEN:
                took = plain(buf, pos, n, self.last, self.held, now)
                if took is not None:
                    pos = self._took(pos, *took)
                    if pos >= n:
                        break
            m = self._candidate.search(buf, pos)
            start = n if m is None else m.start()
            if start > pos:
                self._skip(start - pos)
                pos = start
                if pos >= n:
                    break
            if buf[pos] == _SYNC0:
                used = self._try_binary(buf, pos, frames)
            else:
                used = self._try_text(buf, pos, frames)
            if used == 0:  # incomplete: wait for more bytes
                break
            if used < 0:  # not a frame: skip that many bytes
                used = -used
                self._skip(used)
            pos += used
        del buf[:pos]
        if frames and plain is not None:
            self.held[:] = 0
        return frames

    def flush(self) -> None:
        """Drop the buffered bytes (a truncated frame) and count them as garbage.

        Call it when the stream is broken off, e.g. when the serial device was reopened.
        """
        if self._buf:
            self._skip(len(self._buf))
            self._buf.clear()
        self._report_garbage()

    def pop_events(self) -> list[FrameEvent]:
        """Return the events since the last call, oldest first, and forget them."""
        events = list(self._events)
        self._events.clear()
        return events

    def reset(self) -> None:
        """Forget buffered bytes, events, counters and every mote's counter history."""
        self._buf.clear()
        self._events.clear()
        self._garbage_run = 0
        self._stats = ParserStats()
        self._seen.clear()
        self.last[:] = -1

    # -- internals --------------------------------------------------------------------------------

    def _took(self, pos: int, count: int, end: int, motes: dict[int, int]) -> int:
        """Count ``count`` plain frames that :attr:`plain` took from ``pos`` to ``end``, as
        :meth:`_accept` counts each (their counters are in :attr:`last` already); returns ``end``."""
        st = self._stats
        self._report_garbage()
        st.frames += count
        st.frame_bytes += end - pos
        st.binary_frames += count
        last = self.last
        for mote, k in motes.items():
            ms = st.motes[mote]
            ms.received += k
            ms.last_n_pack = int(last[mote])
            if self._now is not None:
                self._seen[mote] = self._now
        return end

    def _skip(self, nbytes: int) -> None:
        self._stats.garbage_bytes += nbytes
        self._garbage_run += nbytes
        if self._garbage_run >= _MAX_GARBAGE_RUN:
            self._report_garbage()

    def _report_garbage(self) -> None:
        if self._garbage_run:
            self._events.append(Garbage(self._garbage_run))
            self._garbage_run = 0

    def _corrupt(self, mote: int | None, kind: str, reason: str) -> None:
        self._stats.corrupt += 1
        known = mote if mote is not None and mote in self._stats.motes else None
        if known is not None:
            self._stats.motes[known].corrupt += 1
        self._events.append(CorruptFrame(known, kind, reason))
        log.debug("dropped %s frame (mote %s): %s", kind, mote, reason)

    # The _try_* methods return the number of bytes of the frame they accepted, 0 if the candidate is
    # incomplete, or minus the number of bytes to skip as garbage.  A rejected binary candidate skips
    # one byte only: a real frame may start inside it.

    def _try_binary(self, buf: bytearray, pos: int, frames: list[Frame]) -> int:
        avail = len(buf) - pos
        if avail < 2:
            return 0
        if buf[pos + 1] != _SYNC1:
            return -1
        if avail < FRAME_LEN:
            return 0
        body = buf[pos + 2 : pos + 19]
        crc = (buf[pos + 19] << 8) | buf[pos + 20]
        if crc16_ccitt_false(body) != crc:
            self._corrupt(body[0], "binary", "bad checksum")
            return -1
        if body[15] & 0xF0:
            self._corrupt(body[0], "binary", "non-zero padding bits")
            return -1
        ch: list[int] = []
        for i in range(3, 15, 3):
            b0, b1, b2 = body[i], body[i + 1], body[i + 2]
            ch.append((b0 << 4) | (b1 >> 4))
            ch.append(((b1 & 0xF) << 8) | b2)
        ch.append(((body[15] & 0xF) << 8) | body[16])
        self._accept(Frame(body[0], (body[1] << 8) | body[2], tuple(ch)), "binary", FRAME_LEN, frames)
        return FRAME_LEN

    def _try_text(self, buf: bytearray, pos: int, frames: list[Frame]) -> int:
        n = len(buf)
        i = pos + 1 if buf[pos] == _DOLLAR else pos
        limit = i + MAX_LINE + 1  # MAX_LINE bytes, and the CR of a CRLF ending
        end = _LINE_BODY.match(buf, i, min(n, limit)).end()
        if end < n and buf[end] == _LF and (end < limit or buf[end - 1] == _CR):
            # a malformed line is dropped whole, up to its newline (no line or frame can hide inside)
            nbytes = end + 1 - pos
            return nbytes if self._parse_line(bytes(buf[i:end]), nbytes, frames) else -nbytes
        # too long when a byte past MAX_LINE is no line ending, whatever the chunking: a line of exactly
        # MAX_LINE bytes whose CR or LF has not come yet is waited for
        if end == limit and (end < n or buf[end - 1] != _CR):
            self._corrupt(None, "text", f"line longer than {MAX_LINE} bytes")
            return -(end - pos)
        if end < n:  # a byte no line may hold (binary data, a control character, a '$'): not a line
            return -(end - pos)
        return 0

    def _parse_line(self, line: bytes, nbytes: int, frames: list[Frame]) -> bool:
        # the line body holds printable ASCII only (see _LINE_BODY), so decoding cannot fail
        fields = _TEXT_SEP.split(line.decode("ascii").strip())
        mote = int(fields[0]) if _TEXT_FIELD.fullmatch(fields[0]) else None
        if len(fields) != 2 + _N_CHANNELS:
            self._corrupt(mote, "text", f"expected {2 + _N_CHANNELS} fields, got {len(fields)}")
            return False
        bad = [f for f in fields if not _TEXT_FIELD.fullmatch(f)]
        if bad:
            self._corrupt(mote, "text", f"not an unsigned integer: {bad[0]!r}")
            return False
        values = [int(f) for f in fields]
        if values[0] > 255:
            self._corrupt(None, "text", f"mote id {values[0]} > 255")
            return False
        if values[1] > 0xFFFF:
            self._corrupt(mote, "text", f"n_pack {values[1]} > 65535")
            return False
        over = [(name, v) for name, v in zip(CHANNELS, values[2:], strict=True) if v > ADC_MAX]
        if over:
            self._corrupt(mote, "text", f"channel {over[0][0]} = {over[0][1]} > {ADC_MAX}")
            return False
        self._accept(Frame(values[0], values[1], tuple(values[2:])), "text", nbytes, frames)
        return True

    def _in_time(self, mote: int, gap: int) -> bool:
        """Whether the mote can have sent ``gap`` packets since its last frame was read (when the rate and
        the read times are known): more is a restart, not loss."""
        seen = self._seen.get(mote)
        if self.rate is None or self._now is None or seen is None:
            return True
        return could_be_lost(gap, self._now - seen, self.rate)

    def _accept(self, frame: Frame, kind: str, nbytes: int, frames: list[Frame]) -> None:
        st = self._stats
        self._report_garbage()
        st.frames += 1
        st.frame_bytes += nbytes
        if kind == "binary":
            st.binary_frames += 1
        else:
            st.text_frames += 1
        ms = st.motes.get(frame.mote)
        if ms is None:
            ms = st.motes[frame.mote] = MoteStats()
            self._events.append(NewMote(frame.mote, frame.n_pack))
        elif ms.last_n_pack is not None:
            expected = (ms.last_n_pack + 1) & 0xFFFF
            gap = (frame.n_pack - expected) & 0xFFFF
            if 0 < gap <= self.max_gap and self._in_time(frame.mote, gap):
                ms.lost += gap
                st.lost += gap
                self._events.append(LostPackets(frame.mote, expected, frame.n_pack, gap))
                frame = frame._replace(lost=gap)
            elif gap:  # backwards, a duplicate, or more than could be lost: a restart
                ms.jumps += 1
                self._events.append(CounterJump(frame.mote, expected, frame.n_pack))
                frame = frame._replace(jump=True)
        ms.received += 1
        ms.last_n_pack = self.last[frame.mote] = frame.n_pack
        if self._now is not None:
            self._seen[frame.mote] = self._now
        self.held[frame.mote] = 1
        frames.append(frame)
