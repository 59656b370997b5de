"""The WebSocket protocol (RFC 6455), server side, in plain functions: the handshake's accept key, frames
out, and a reader of the frames a client sends.  Outside bytes: every frame the reader cannot take raises
:class:`WebSocketError` saying why, and the connection is closed; nothing else is assumed of the peer.

>>> accept_key("dGhlIHNhbXBsZSBub25jZQ==")   # RFC 6455 section 1.3's example
's3pPLMBiTxaQ9kYGzzhZRbK+xOo='
>>> r = FrameReader()
>>> r.feed(bytes([0x81, 0x82, 1, 2, 3, 4]) + bytes(a ^ b for a, b in zip(b"hi", b"\\x01\\x02")))
[(1, b'hi')]
>>> encode_frame(TEXT, b"ok")
b'\\x81\\x02ok'
"""

from __future__ import annotations

import base64
import hashlib
import struct

__all__ = [
    "BINARY",
    "CLOSE",
    "PING",
    "PONG",
    "TEXT",
    "FrameReader",
    "WebSocketError",
    "accept_key",
    "encode_frame",
]

_GUID = b"258EAFA5-E914-47DA-95CA-C5AB0DC85B11"

CONTINUATION, TEXT, BINARY, CLOSE, PING, PONG = 0x0, 0x1, 0x2, 0x8, 0x9, 0xA
_DATA = (TEXT, BINARY)
_CONTROL = (CLOSE, PING, PONG)


class WebSocketError(ValueError):
    """A frame a server must refuse (the connection is then closed)."""


def accept_key(key: str) -> str:
    """``Sec-WebSocket-Accept`` for a client's ``Sec-WebSocket-Key`` (16 random bytes in base64)."""
    try:
        raw = base64.b64decode(key.strip().encode("ascii"), validate=True)
    except (ValueError, UnicodeEncodeError) as exc:
        raise WebSocketError(f"Sec-WebSocket-Key is not base64: {key[:40]!r}") from exc
    if len(raw) != 16:
        raise WebSocketError(f"Sec-WebSocket-Key must be 16 bytes in base64, got {len(raw)}")
    return base64.b64encode(hashlib.sha1(key.strip().encode("ascii") + _GUID).digest()).decode("ascii")


def encode_frame(opcode: int, payload: bytes) -> bytes:
    """One unmasked, final frame (a server's frames are never masked)."""
    n = len(payload)
    if n < 126:
        head = struct.pack("!BB", 0x80 | opcode, n)
    elif n < 1 << 16:
        head = struct.pack("!BBH", 0x80 | opcode, 126, n)
    else:
        head = struct.pack("!BBQ", 0x80 | opcode, 127, n)
    return head + payload


class FrameReader:
    """Frames of a client, fed as bytes arrive: :meth:`feed` returns the complete messages (opcode,
    payload), fragments joined, control frames as they come.

    A client's frames must be masked; a message longer than ``limit`` bytes or in more than
    :attr:`FRAGMENTS` fragments, a control frame that is
    fragmented or longer than 125 bytes, reserved bits or opcodes, a continuation without a start, or
    text that is not UTF-8 raise :class:`WebSocketError`.
    """

    #: Fragments one message may come in (a browser sends one; a flood of empty ones is refused).
    FRAGMENTS = 1024

    def __init__(self, limit: int = 1 << 16):
        self.limit = limit
        self._buf = bytearray()
        self._parts: list[bytes] = []
        self._size = 0  # bytes in _parts
        self._opcode: int | None = None  # of the fragmented message being joined

    def feed(self, data: bytes) -> list[tuple[int, bytes]]:
        self._buf += data
        out: list[tuple[int, bytes]] = []
        while True:
            frame = self._frame()
            if frame is None:
                return out
            fin, opcode, payload = frame
            if opcode in _CONTROL:
                if not fin or len(payload) > 125:
                    raise WebSocketError("a control frame must be final and at most 125 bytes")
                out.append((opcode, payload))
                continue
            if opcode == CONTINUATION:
                if self._opcode is None:
                    raise WebSocketError("a continuation frame with no message to continue")
            elif self._opcode is not None:
                raise WebSocketError("a new message began before the fragmented one ended")
            else:
                self._opcode = opcode
            self._parts.append(payload)
            self._size += len(payload)
            if self._size > self.limit:
                raise WebSocketError(f"a message longer than {self.limit} bytes")
            if len(self._parts) > self.FRAGMENTS:
                raise WebSocketError(f"a message in more than {self.FRAGMENTS} fragments")
            if fin:
                message, kind = b"".join(self._parts), self._opcode
                self._parts, self._opcode, self._size = [], None, 0
                if kind == TEXT:
                    try:
                        message.decode("utf-8")
                    except UnicodeDecodeError as exc:
                        raise WebSocketError("a text message that is not UTF-8") from exc
                out.append((kind, message))

    def _frame(self) -> tuple[bool, int, bytes] | None:
        buf = self._buf
        if len(buf) < 2:
            return None
        b0, b1 = buf[0], buf[1]
        if b0 & 0x70:
            raise WebSocketError("reserved bits set (no extension was agreed)")
        opcode = b0 & 0x0F
        if opcode not in (CONTINUATION, *_DATA, *_CONTROL):
            raise WebSocketError(f"unknown opcode {opcode}")
        if not b1 & 0x80:
            raise WebSocketError("a client's frame must be masked")
        n = b1 & 0x7F
        i = 2
        if n == 126:
            if len(buf) < 4:
                return None
            (n,) = struct.unpack_from("!H", buf, 2)
            i = 4
        elif n == 127:
            if len(buf) < 10:
                return None
            (n,) = struct.unpack_from("!Q", buf, 2)
            i = 10
        if n > self.limit:
            raise WebSocketError(f"a frame longer than {self.limit} bytes")
        if len(buf) < i + 4 + n:
            return None
        mask = bytes(buf[i : i + 4])
        body = bytes(buf[i + 4 : i + 4 + n])
        del buf[: i + 4 + n]
        if n:
            key = (mask * (n // 4 + 1))[:n]
            body = (int.from_bytes(body, "big") ^ int.from_bytes(key, "big")).to_bytes(n, "big")
        return bool(b0 & 0x80), opcode, body
