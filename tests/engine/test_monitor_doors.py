"""The monitor's doors tried as an attacker would (issue 45), against a running patch on 127.0.0.1 whose
simulated glove streams to a receiver of the test's: another site's page in the performer's browser
(a foreign ``Origin`` on the WebSocket), a DNS rebinding (a foreign ``Host``), clients that go away
mid-answer, slow and idle connections, malformed packets.  Each must fail to do harm while the glove
keeps streaming, and tell the log in a few lines, never a traceback."""

from __future__ import annotations

import base64
import json
import logging
import os
import socket
import struct
import time

import pytest

from pointat.checking import check
from pointat.devices.osc_wire import encode_message
from pointat.expansion import read_spec
from pointat.loader import build, parse_overrides
from pointat.observe import Observer
from pointat.registry import Registry
from pointat.testing import ws_connect, ws_receive, ws_send
from pointat.webserver import MonitorServer

REG = Registry().load_builtins()

PATCH = """\
node glove simulate rate=100 output=direct noise=false
node units scaling
node fuse  tqt rate=100
node dir   azi_ele
node out   osc_out port={port} rate=100
glove.adc -> units
units.mag -> fuse.mag
units.accel -> fuse.accel
units.gyro -> fuse.gyro
fuse -> dir
dir.elevation -> out.elevation
dir.azimuth -> out.azimuth
"""


@pytest.fixture
def served(tmp_path):
    """A running glove patch with its monitor: (runtime, server, the glove's receiver)."""
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(5)
    path = tmp_path / "glove.pat"
    path.write_text(PATCH.format(port=rx.getsockname()[1]))
    rt = build(check(read_spec(str(path)), REG, parse_overrides([])))
    obs = Observer(rt, patch="glove").attach()
    server = MonitorServer(rt, obs, "127.0.0.1", 0, name="pointat doors", advertise=False)
    server.start()
    th = rt.run_in_thread(60)
    obs.start()
    try:
        yield rt, server, rx
    finally:
        obs.stop()
        rt.stop()
        th.join(5)
        server.close()
        rx.close()


def _streaming(rx: socket.socket, n: int = 20) -> bool:
    """Whether the glove's directions still arrive: ``n`` datagrams in a row (5 s each at most)."""
    rx.settimeout(5)
    for _ in range(n):
        if not rx.recv(65536).startswith(b"/"):
            return False
    return True


def _request(port: int, lines: list[str], body: bytes = b"") -> tuple[int, bytes]:
    """A raw HTTP/1.1 request; (status, the whole answer)."""
    with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
        s.sendall(("\r\n".join([*lines, "Connection: close", "", ""])).encode() + body)
        reply = b""
        while True:
            try:
                chunk = s.recv(65536)
            except (ConnectionResetError, TimeoutError):
                break
            if not chunk:
                break
            reply += chunk
    return int(reply.split(b" ", 2)[1]), reply


def _handshake(port: int, origin: str | None, host: str | None = None) -> tuple[int, socket.socket]:
    s = socket.create_connection(("127.0.0.1", port), timeout=5)
    key = base64.b64encode(os.urandom(16)).decode()
    lines = ["GET / HTTP/1.1", f"Host: {host or f'127.0.0.1:{port}'}", "Upgrade: websocket"]
    lines += ["Connection: Upgrade", f"Sec-WebSocket-Key: {key}", "Sec-WebSocket-Version: 13"]
    if origin is not None:
        lines.append(f"Origin: {origin}")
    s.sendall(("\r\n".join([*lines, "", ""])).encode())
    head = b""
    while b"\r\n\r\n" not in head:
        chunk = s.recv(1)
        if not chunk:
            break
        head += chunk
    return int(head.split(b" ", 2)[1]), s


def test_another_sites_page_cannot_open_the_socket_nor_drive_the_show(served, caplog):
    rt, server, rx = served
    port = server.port
    with caplog.at_level(logging.WARNING, logger="pointat.monitor"):
        for _ in range(5):  # a page trying again and again
            status, s = _handshake(port, "http://evil.example")
            assert status == 403
            # whatever it sends next (the glove's dropout, a parameter) reaches nothing
            try:
                ws_send(s, 2, encode_message("/pointat/glove/dropout", [30.0]))
                ws_send(s, 2, encode_message("/pointat/out/rate", [1.0]))
            except OSError:
                pass
            s.close()
        status, s = _handshake(port, "null")  # a sandboxed frame or a file:// page
        s.close()
        assert status == 403
    assert rt.nodes["out"].p.rate == 100.0
    assert _streaming(rx), "the glove stopped streaming"
    told = [r for r in caplog.records if "refused (403)" in r.getMessage()]
    assert len(told) == 2, [r.getMessage() for r in told]  # once for evil.example, once for null
    assert "http://evil.example" in told[0].getMessage()
    # the page's own origin opens it, and live control works through it
    status, s = _handshake(port, f"http://127.0.0.1:{port}")
    assert status == 101
    ws_send(s, 2, encode_message("/pointat/out/rate", [50.0]))
    ws_send(s, 1, json.dumps({"COMMAND": "LISTEN", "DATA": "/pointat/out/rate"}).encode())
    deadline = time.monotonic() + 5
    while rt.nodes["out"].p.rate != 50.0 and time.monotonic() < deadline:
        time.sleep(0.02)
    assert rt.nodes["out"].p.rate == 50.0
    opcode, _payload = ws_receive(s)
    assert opcode == 2
    s.close()


def test_a_dns_rebinding_reads_nothing(served):
    """``curl -H 'Host: evil.example' http://127.0.0.1:PORT/monitor/state`` and the like."""
    _rt, server, rx = served
    port = server.port
    for target in ("/monitor/state", "/monitor", "/", "/?HOST_INFO", "/pointat/out/rate?VALUE"):
        for host in ("evil.example", f"evil.example:{port}", "127.0.0.1.evil.example", None):
            lines = [f"GET {target} HTTP/1.1"] + ([f"Host: {host}"] if host is not None else [])
            status, reply = _request(port, lines)
            assert status == 403, (target, host, reply[:200])
            assert b"VALUE" not in reply and b"pointers" not in reply
        status, reply = _request(port, [f"GET {target} HTTP/1.1", f"Host: localhost:{port}"])
        assert status == 200, (target, reply[:200])
    status, _ = _handshake(port, None, host="evil.example")
    assert status == 403
    assert _streaming(rx)


def test_a_client_gone_mid_answer_is_a_line_not_a_traceback(served, caplog, capfd):
    _rt, server, rx = served
    port = server.port
    with caplog.at_level(logging.INFO, logger="pointat.monitor"):
        for _ in range(60):
            s = socket.create_connection(("127.0.0.1", port), timeout=5)
            s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))  # RST on close
            s.sendall(f"GET /monitor/state HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode())
            s.close()
        assert _streaming(rx)
    out, err = capfd.readouterr()
    assert "Traceback" not in out + err and "BrokenPipe" not in out + err, err[-2000:]
    gone = [r for r in caplog.records if r.getMessage().startswith("monitor: client ")]
    assert len(gone) <= 5, [r.getMessage() for r in gone]  # rate-limited (none if every answer fitted)
    status, _ = _request(port, ["GET /?HOST_INFO HTTP/1.1", f"Host: 127.0.0.1:{port}"])
    assert status == 200


def test_malformed_packets_are_told_in_a_few_lines(served, caplog):
    _rt, server, rx = served
    udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    with caplog.at_level(logging.WARNING, logger="pointat.monitor"):
        for i in range(200):
            udp.sendto(b"\x00garbage%d" % i, ("127.0.0.1", server.osc_port))
        for _ in range(30):
            s = ws_connect(server.port)
            s.sendall(b"\x81\x05hello")  # unmasked: refused
            s.close()
        deadline = time.monotonic() + 5
        while server.control_refused < 200 and time.monotonic() < deadline:
            time.sleep(0.02)
        assert server.control_refused == 200
    udp.close()
    lines = [
        r.getMessage() for r in caplog.records if "malformed" in r.getMessage() or "closed" in r.getMessage()
    ]
    assert 1 <= len(lines) <= 10, lines
    assert _streaming(rx)


def test_served_on_loopback_zeroconf_hears_loopback_only(tmp_path):
    """zeroconf's sockets (its port 5353 bound to every address) are held to the loopback device, so
    nothing on the network reaches them while the monitor is this machine's only."""
    pytest.importorskip("zeroconf")
    if not hasattr(socket, "SO_BINDTODEVICE"):
        pytest.skip("SO_BINDTODEVICE is Linux's")
    rt = build(check(read_spec(_write(tmp_path, PATCH.format(port=9))), REG, parse_overrides([])))
    obs = Observer(rt).attach()
    server = MonitorServer(rt, obs, "127.0.0.1", 0, advertise=True)
    server.start()
    try:
        deadline = time.monotonic() + 10
        while server._zeroconf is None and time.monotonic() < deadline:
            time.sleep(0.02)
        zc = server._zeroconf
        assert zc is not None, "not advertised"
        socks = {t.sock for t in [*zc.engine.readers, *zc.engine.senders]}
        assert socks
        for s in socks:
            device = s.getsockopt(socket.SOL_SOCKET, socket.SO_BINDTODEVICE, 16).rstrip(b"\0")
            assert device in (b"lo", b"lo0"), (s.getsockname(), device)
    finally:
        server.close()


def _write(tmp_path, text: str) -> str:
    path = tmp_path / "glove.pat"
    path.write_text(text)
    return str(path)
