r"""OSC 1.0 on the wire: messages and bundles encoded and decoded, time tags, UDP ports.

The bottom floor of the OSC nodes (:mod:`pointat.osc_bridge`) and of ``pointat send``: bytes in, values
out, nothing of the engine.  Written directly with :mod:`struct` (the same bytes as python-osc, about ten
times faster to encode; python-osc's :class:`~pythonosc.osc_packet.OscPacket` reads the rarer argument
types).  Numbers go out as float32 (``f``) and int32 (``i``): Pd's ``[oscparse]`` rejects 64-bit doubles.

>>> encode_message("/adm/obj/1/aed", [30.0, 0.0, 1.0])[:24]
b'/adm/obj/1/aed\x00\x00,fff\x00\x00\x00\x00'
>>> encode_bundle([b"/a\x00\x00,\x00\x00\x00"], None)[:16]
b'#bundle\x00\x00\x00\x00\x00\x00\x00\x00\x01'
"""

from __future__ import annotations

import functools
import math
import struct
from collections.abc import Sequence
from typing import Any

from pythonosc.osc_packet import OscPacket

__all__ = [
    "F32_MAX",
    "IMMEDIATELY",
    "NTP_UNIX_OFFSET",
    "bundle_time",
    "decode_packet",
    "encode_bundle",
    "encode_message",
    "ntp_time",
    "udp_port",
]

#: Seconds from the NTP epoch (1900) to the Unix epoch (1970).
NTP_UNIX_OFFSET = 2208988800
#: OSC's special time tag "immediately".
IMMEDIATELY = b"\x00\x00\x00\x00\x00\x00\x00\x01"


# --------------------------------------------------------------------------- encoding
def _osc_string(s: str) -> bytes:
    """An OSC string: UTF-8, NUL-terminated, padded to a multiple of 4 bytes."""
    b = s.encode("utf-8")
    return b + b"\x00" * (4 - len(b) % 4)


_padded = functools.lru_cache(maxsize=1024)(_osc_string)  # addresses repeat: pad each once


def encode_message(address: str, args: Sequence[Any]) -> bytes:
    """One OSC message: ints as ``i`` (int32), floats as ``f`` (float32), anything else as ``s``.

    Written directly with :mod:`struct` (the same bytes as python-osc's builder, about ten times
    faster); at 1 kHz per source the encoder is in the hot path.

    >>> encode_message("/a", [1.0, 2, "x"]).hex()
    '2f6100002c666973000000003f8000000000000278000000'
    """
    tags = [","]
    data = []
    for a in args:
        if isinstance(a, float):
            tags.append("f")
            data.append(_F32.pack(_fit(a)))
        elif isinstance(a, int):  # bool included
            tags.append("i")
            data.append(_I32.pack(_fit(int(a))))
        else:
            tags.append("s")
            data.append(_osc_string(str(a)))
    return b"".join([_padded(address), _padded("".join(tags)), *data])


_F32 = struct.Struct(">f")
_I32 = struct.Struct(">i")


#: The largest finite float32 (an OSC ``f``).
F32_MAX = 3.4028234663852886e38


def _fit(value: Any) -> Any:
    """``value`` brought into what OSC's ``f`` and ``i`` hold: a float beyond float32 to ±its largest
    (as a float32 cast saturates in a DSP), an int beyond int32 to its ends.

    >>> _fit(1e39), _fit(-1e39), _fit(2**40), _fit(0.5)
    (3.4028234663852886e+38, -3.4028234663852886e+38, 2147483647, 0.5)
    """
    if isinstance(value, float):
        return max(-F32_MAX, min(F32_MAX, value)) if math.isfinite(value) else value
    if isinstance(value, int) and not isinstance(value, bool):
        return max(-(2**31), min(2**31 - 1, value))
    return value


def ntp_time(unix_seconds: float) -> bytes:
    r"""A Unix time (seconds since 1970) as an OSC/NTP time tag: 32-bit seconds since 1900, 32-bit fraction.

    >>> ntp_time(0.5).hex()
    '83aa7e8080000000'
    """
    seconds = math.floor(unix_seconds)
    fraction = int((unix_seconds - seconds) * 2**32)
    return struct.pack(">II", (seconds + NTP_UNIX_OFFSET) & 0xFFFFFFFF, min(fraction, 2**32 - 1))


def encode_bundle(datagrams: Sequence[bytes], when: float | None) -> bytes:
    """An OSC bundle of encoded messages, time-tagged ``when`` (Unix seconds) or "immediately" (``None``)."""
    parts = [b"#bundle\x00", IMMEDIATELY if when is None else ntp_time(when)]
    for d in datagrams:
        parts += [struct.pack(">i", len(d)), d]
    return b"".join(parts)


# --------------------------------------------------------------------------- decoding
#: Fixed-size argument types: struct code and size in bytes (OSC 1.0 and the common 1.1 additions).
_FIXED = {"i": "i", "f": "f", "d": "d", "h": "q"}
#: Argument types that carry no bytes (``I``: OSC 1.0's Infinitum, as liblo reads it).
_EMPTY = {"T": True, "F": False, "N": None, "I": math.inf}
#: Other types python-osc reads (blob, MIDI, time tag, colour, arrays); any other is an error.  (Not the
#: char ``c`` nor ``I``: python-osc 1.10 skips them with a warning, and the arguments after them shift.)
_RARE = frozenset("bmtr[]")
#: Types read here that python-osc skips (the arguments after them shift): a message with one of them and
#: one of :data:`_RARE` is refused rather than misread.
_SKIPPED = frozenset("cIS")


@functools.lru_cache(maxsize=256)
def _arg_plan(tags: str) -> tuple[tuple[str, Any], ...] | None:
    """How to read the arguments of type tags ``tags`` (without the comma): runs of fixed-size numbers as
    one :class:`struct.Struct`, strings, chars, constants; ``None`` for types left to python-osc.

    >>> _arg_plan("bfQ")  # after a blob too
    Traceback (most recent call last):
    ...
    ValueError: unknown OSC type tag 'Q'
    """
    plan: list[tuple[str, Any]] = []
    run = ""
    rare = False
    for t in tags:
        if t in _FIXED:
            run += _FIXED[t]
            continue
        if run:
            plan.append(("fixed", struct.Struct(">" + run)))
            run = ""
        if t in ("s", "S"):
            plan.append(("string", None))
        elif t == "c":
            plan.append(("char", _I32))
        elif t in _EMPTY:
            plan.append(("const", _EMPTY[t]))
        elif t in _RARE:
            rare = True  # python-osc reads the message; every tag is still checked here
        else:
            raise ValueError(f"unknown OSC type tag {t!r}")
    if run:
        plan.append(("fixed", struct.Struct(">" + run)))
    if rare and (skipped := _SKIPPED.intersection(tags)):
        raise ValueError(
            f"type tag {min(skipped)!r} beside a blob, array, time tag, MIDI or colour argument is not read"
            " (python-osc, which reads those, would skip it and read the arguments after it shifted)"
        )
    return None if rare else tuple(plan)


def _read_string(data: bytes, i: int, end: int) -> tuple[str, int]:
    """An OSC string at ``data[i:]``: its text and the index after its padding."""
    nul = data.find(b"\x00", i, end)
    if nul < 0:
        raise ValueError(f"unterminated string at byte {i}")
    return data[i:nul].decode("utf-8"), (nul + 4) & ~3


def _decode_message(data: bytes, i: int, end: int, out: list[tuple[str, list[Any]]]) -> None:
    address, j = _read_string(data, i, end)
    if not address.startswith("/"):
        raise ValueError(f"address {address[:20]!r} does not start with '/'")
    if j >= end:  # no type tag string: an old-style message without arguments
        out.append((address, []))
        return
    tags, j = _read_string(data, j, end)
    if not tags.startswith(","):
        raise ValueError(f"type tags {tags[:20]!r} do not start with ','")
    plan = _arg_plan(tags[1:])
    if plan is None:  # blobs, arrays, time tags, MIDI...: python-osc knows them all
        try:
            out += [(m.message.address, list(m.message.params)) for m in OscPacket(data[i:end]).messages]
        except Exception as exc:  # python-osc's ParseError and whatever its readers raise on garbage
            raise ValueError(f"{address}: {exc}") from None
        return
    args: list[Any] = []
    for kind, how in plan:
        if kind == "fixed":
            if j + how.size > end:
                raise ValueError(f"{address}: arguments end past the packet ({end} bytes)")
            args += how.unpack_from(data, j)
            j += how.size
        elif kind == "string":
            text, j = _read_string(data, j, end)
            args.append(text)
        elif kind == "char":
            if j + 4 > end:
                raise ValueError(f"{address}: arguments end past the packet ({end} bytes)")
            code = how.unpack_from(data, j)[0]
            if not 0 <= code <= 0x10FFFF:
                raise ValueError(f"{address}: char argument {code} is not a character")
            args.append(chr(code))
            j += 4
        else:
            args.append(how)
    if j > end:
        raise ValueError(f"{address}: arguments end past the packet ({end} bytes)")
    out.append((address, args))


def decode_packet(data: bytes) -> list[tuple[str, list[Any]]]:
    r"""Every message of an OSC packet as ``(address, arguments)``, a bundle's in order (nested too).

    Time tags are read past, never waited for.  Numbers (``i f d h``), strings and ``T F N`` are decoded
    here, a few times faster than python-osc; other types go to python-osc.  Raises ``ValueError`` for a
    malformed packet.

    >>> decode_packet(encode_bundle([encode_message("/a", [1.5, 2]), encode_message("/b", ["x"])], None))
    [('/a', [1.5, 2]), ('/b', ['x'])]
    >>> decode_packet(b"#bundle\x00" + IMMEDIATELY + struct.pack(">i", 64) + b"/a\x00\x00")
    Traceback (most recent call last):
    ...
    ValueError: bundle element of 64 bytes at byte 16 does not fit in 24
    """
    out: list[tuple[str, list[Any]]] = []
    _decode(data, 0, len(data), out, 0)
    return out


def _decode(data: bytes, i: int, end: int, out: list[tuple[str, list[Any]]], depth: int) -> None:
    if end - i < 4 or (end - i) % 4:
        raise ValueError(f"packet of {end - i} bytes is not a positive multiple of 4")
    if data.startswith(b"#bundle\x00", i):
        if end - i < 16:
            raise ValueError(f"bundle of {end - i} bytes has no time tag")
        if depth > 8:
            raise ValueError("bundles nested more than 8 deep")
        j = i + 16
        while j < end:
            if j + 4 > end:
                raise ValueError(f"bundle element size cut at byte {j}")
            size = _I32.unpack_from(data, j)[0]
            if size <= 0 or size % 4 or j + 4 + size > end:
                raise ValueError(f"bundle element of {size} bytes at byte {j} does not fit in {end}")
            _decode(data, j + 4, j + 4 + size, out, depth + 1)
            j += 4 + size
        return
    _decode_message(data, i, end, out)


def bundle_time(data: bytes) -> float | None:
    r"""A bundle's time tag in NTP seconds (since 1900), or None: not a bundle, or "immediately".

    >>> bundle_time(encode_bundle([], 0.5)) - NTP_UNIX_OFFSET
    0.5
    >>> bundle_time(encode_bundle([], None)), bundle_time(b"/a\x00\x00,\x00\x00\x00")
    (None, None)
    """
    if len(data) < 16 or not data.startswith(b"#bundle\x00") or data[8:16] == IMMEDIATELY:
        return None
    seconds, fraction = _NTP.unpack_from(data, 8)
    return seconds + fraction / 2**32


_NTP = struct.Struct(">II")


def udp_port(value: Any, what: str = "port") -> int:
    """A UDP port number 1..65535; ``ValueError`` starting with ``what`` otherwise."""
    try:
        port = int(value)
    except (TypeError, ValueError):
        raise ValueError(f"{what} {value!r} is not a number") from None
    if not 1 <= port <= 65535:
        raise ValueError(f"{what} {port} is outside 1..65535")
    return port
