"""What the monitor's tests and benchmark talk to it with: a plain WebSocket client (a few frames, written
here so that a test sees the bytes the server sends) and the flags headless Chromium is started with.

Test-only code, kept out of the wheel: the tests import it as ``tests.monitor_client``, the benchmarks
(run from the repository) too.
"""

from __future__ import annotations

import base64
import os
import socket
import struct

__all__ = ["CHROMIUM_FLAGS", "ws_connect", "ws_receive", "ws_send"]

#: Headless Chromium as the monitor's tests and benchmark start it: no sandbox (root), no GPU, and none of
#: the background connections this machine's closed network refuses.
CHROMIUM_FLAGS = (
    "--headless=new",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-dev-shm-usage",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--window-size=1400,1200",
)


def ws_connect(port: int, host: str = "127.0.0.1") -> socket.socket:
    """A WebSocket client's connection to a server on ``port`` (the handshake done)."""
    s = socket.create_connection((host, port), timeout=5)
    key = base64.b64encode(os.urandom(16)).decode()
    s.sendall(
        (
            f"GET / HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
            f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n"
        ).encode()
    )
    head = b""
    while b"\r\n\r\n" not in head:
        head += s.recv(1)
    if not head.startswith(b"HTTP/1.1 101"):
        raise ConnectionError(f"no WebSocket: {head[:80]!r}")
    return s


def ws_send(s: socket.socket, opcode: int, payload: bytes) -> None:
    """One final frame, masked as a client's must be (opcode 1 text, 2 binary, 9 ping)."""
    mask = os.urandom(4)
    n = len(payload)
    head = (
        struct.pack("!BB", 0x80 | opcode, 0x80 | n)
        if n < 126
        else struct.pack("!BBH", 0x80 | opcode, 0xFE, n)
    )
    s.sendall(head + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(payload)))


def ws_receive(s: socket.socket) -> tuple[int, bytes]:
    """The next frame from the server: (opcode, payload)."""

    def exactly(n: int) -> bytes:
        data = b""
        while len(data) < n:
            chunk = s.recv(n - len(data))
            if not chunk:
                raise ConnectionError("the server closed the connection")
            data += chunk
        return data

    b0, b1 = exactly(2)
    n = b1 & 0x7F
    if n == 126:
        (n,) = struct.unpack("!H", exactly(2))
    elif n == 127:
        (n,) = struct.unpack("!Q", exactly(8))
    return b0 & 0x0F, exactly(n)
