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
import threading
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pointat.checking import check
from pointat.devices.osc_wire import encode_message
from pointat.expansion import read_spec
from pointat.loader import build, parse_overrides
from pointat.monitor.observe import Observer
from pointat.monitor.webserver import READS_METHODS, MonitorServer
from pointat.registry import Registry
from tests.monitor_client import ws_connect, ws_receive, ws_send

#: Hypothesis examples of the request and frame properties (derandomized; the long fuzz run is
#: tests/fuzz_websocket.py): POINTAT_FUZZ_EXAMPLES sets more.
EXAMPLES = int(os.environ.get("POINTAT_FUZZ_EXAMPLES", "40"))

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
    return (int(reply.split(b" ", 2)[1]) if reply else 0), reply


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
    # two Hosts, or two Origins, name no one server
    for extra in ([f"Host: 127.0.0.1:{port}"], ["Host: evil.example"], ["Origin: a", "Origin: b"]):
        status, _ = _request(port, ["GET /monitor/state HTTP/1.1", f"Host: 127.0.0.1:{port}", *extra])
        assert status == 403, extra
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


# -- availability -----------------------------------------------------------------------------------
class _SmallServer(MonitorServer):
    """The same server with a small house and a short patience, so that a test fills and empties it."""

    MAX_CONNECTIONS = 16
    OPEN_TIMEOUT = 1.0


def test_many_slow_connections_neither_starve_the_glove_nor_hold_threads(tmp_path, caplog):
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rt = build(
        check(read_spec(_write(tmp_path, PATCH.format(port=rx.getsockname()[1]))), REG, parse_overrides([]))
    )
    obs = Observer(rt).attach()
    server = _SmallServer(rt, obs, "127.0.0.1", 0, advertise=False)
    server.start()
    th = rt.run_in_thread(60)
    obs.start()
    threads_before = threading.active_count()
    slow: list[socket.socket] = []
    try:
        with caplog.at_level(logging.INFO, logger="pointat.monitor"):
            for _ in range(200):  # a slowloris: requests begun and never ended
                s = socket.create_connection(("127.0.0.1", server.port), timeout=30)
                s.sendall(f"GET /monitor/state HTTP/1.1\r\nHost: 127.0.0.1:{server.port}\r\nX-a: ".encode())
                slow.append(s)
            assert _streaming(rx, 100), "the glove's output starved"
            # at most MAX_CONNECTIONS held (each with the library's reader thread), the rest turned away
            assert threading.active_count() - threads_before <= 3 * _SmallServer.MAX_CONNECTIONS + 4
            assert server.turned_away > 0 and server.most_open == _SmallServer.MAX_CONNECTIONS
            # every slow one is closed by the server (after OPEN_TIMEOUT, or at once when turned away)
            for s in slow:
                try:
                    while s.recv(4096):
                        pass
                except ConnectionResetError:
                    pass
            status, _ = _request(server.port, ["GET /?HOST_INFO HTTP/1.1", f"Host: 127.0.0.1:{server.port}"])
            assert status == 200
        lines = [r.getMessage() for r in caplog.records if "turned away" in r.getMessage()]
        assert 1 <= len(lines) <= 5, lines  # 184 turned away, told in a few lines
        assert _streaming(rx)
    finally:
        for s in slow:
            s.close()
        obs.stop()
        rt.stop()
        th.join(5)
        server.close()
        rx.close()


def test_a_websocket_asking_for_nothing_is_closed_when_idle(served):
    _rt, server, _rx = served
    server.IDLE_TIMEOUT = 0.5  # (read by the session when it waits)
    s = ws_connect(server.port)
    s.settimeout(30)
    opcode, payload = ws_receive(s)
    assert opcode == 8 and b"idle" in payload
    s.close()
    # one that watches the monitor stays
    s = ws_connect(server.port)
    s.settimeout(30)
    ws_send(s, 1, json.dumps({"COMMAND": "MONITOR"}).encode())
    for _ in range(20):
        opcode, _payload = ws_receive(s)
        assert opcode == 1
    s.close()


# -- any bytes --------------------------------------------------------------------------------------
class _Errors(logging.Handler):
    """What the server logs at ERROR or with a traceback (there must be none)."""

    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.records: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        if record.levelno >= logging.ERROR or record.exc_info:
            self.records.append(f"{record.name}: {record.getMessage()}")


@pytest.fixture(scope="module")
def house(tmp_path_factory):
    """One running glove patch and its server for a property's examples: (server, rx, errors)."""
    tmp = tmp_path_factory.mktemp("house")
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rt = build(
        check(read_spec(_write(tmp, PATCH.format(port=rx.getsockname()[1]))), REG, parse_overrides([]))
    )
    obs = Observer(rt).attach()
    server = MonitorServer(rt, obs, "127.0.0.1", 0, advertise=False)
    errors = _Errors()
    logging.getLogger().addHandler(errors)
    hook = threading.excepthook
    threading.excepthook = lambda a: errors.records.append(f"thread {a.thread.name}: {a.exc_type.__name__}")
    server.start()
    th = rt.run_in_thread(600)
    obs.start()
    try:
        yield server, rx, errors
    finally:
        threading.excepthook = hook
        logging.getLogger().removeHandler(errors)
        obs.stop()
        rt.stop()
        th.join(5)
        server.close()
        rx.close()


def _exchange(port: int, data: bytes, *, handshake: bool = False) -> bytes:
    """Send ``data`` (after a valid handshake, answered, when asked) and read until the server closes
    or is silent for a quarter of a second (a request begun and not ended waits for its end)."""
    with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
        reply = b""
        if handshake:
            key = base64.b64encode(os.urandom(16)).decode()
            s.sendall(
                f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n".encode()
            )
            while b"\r\n\r\n" not in reply:
                chunk = s.recv(4096)
                assert chunk, "no answer to a valid handshake"
                reply += chunk
            assert reply.startswith(b"HTTP/1.1 101 ")
        try:
            s.sendall(data)
            if handshake:
                s.sendall(bytes([0x88, 0x82, 0, 0, 0, 0, 0x03, 0xE8]))  # the client's close
        except OSError:  # the server closed first
            pass
        s.settimeout(0.25)
        try:
            while chunk := s.recv(65536):
                reply += chunk
        except (TimeoutError, ConnectionResetError):
            pass
    return reply


def _serves_on(server: MonitorServer, rx: socket.socket, errors: _Errors) -> None:
    assert not errors.records, errors.records
    status, _ = _request(server.port, ["GET /?HOST_INFO HTTP/1.1", f"Host: 127.0.0.1:{server.port}"])
    assert status == 200
    assert _streaming(rx, 5)


_REQUEST = (
    b"GET /monitor/state?token=x HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nOrigin: http://127.0.0.1:{port}\r\n"
    b"Upgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
    b"Sec-WebSocket-Version: 13\r\nCookie: a=b\r\n\r\n"
)


@st.composite
def mutated_requests(draw):
    """A request the page sends, a header line doubled, bytes replaced, put in, cut out; or any bytes."""
    if draw(st.booleans()):
        return draw(st.binary(max_size=400))
    lines = _REQUEST.split(b"\r\n")
    if draw(st.booleans()):
        i = draw(st.integers(1, len(lines) - 3))
        lines.insert(draw(st.integers(1, len(lines) - 2)), lines[i])
    data = bytearray(b"\r\n".join(lines))
    for _ in range(draw(st.integers(0, 4))):
        i = draw(st.integers(0, len(data)))
        kind = draw(st.sampled_from(["set", "insert", "cut"]))
        chunk = draw(st.binary(min_size=1, max_size=20))
        if kind == "set":
            data[i : i + len(chunk)] = chunk
        elif kind == "insert":
            data[i:i] = chunk
        else:
            del data[i : i + len(chunk)]
    return bytes(data)


@settings(derandomize=True, database=None, deadline=None, max_examples=EXAMPLES,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])  # fmt: skip
@given(data=mutated_requests())
def test_any_request_bytes_are_answered_or_closed_and_the_server_serves_on(house, data):
    server, rx, errors = house
    reply = _exchange(server.port, data.replace(b"{port}", str(server.port).encode()))
    assert reply == b"" or reply.startswith(b"HTTP/1.1 ")
    _serves_on(server, rx, errors)


@st.composite
def frames(draw):
    """Client frames with every header field drawn (FIN, reserved bits, opcode, mask bit, length and its
    form, payload), now and then a real command; or any bytes."""
    if draw(st.integers(0, 4)) == 0:
        return draw(st.binary(max_size=300))
    out = b""
    for _ in range(draw(st.integers(1, 5))):
        opcode = draw(st.sampled_from([0, 1, 2, 3, 8, 9, 10, 11, 15]))
        payload = draw(
            st.one_of(
                st.binary(max_size=200),
                st.sampled_from(
                    [
                        b'{"COMMAND": "MONITOR"}',
                        b'{"COMMAND": "LISTEN", "DATA": "/pointat/out/rate"}',
                        encode_message("/pointat/out/rate", [100.0]),
                        b"[" * 5000,
                    ]
                ),  # fmt: skip
            )
        )
        fin, rsv, masked = draw(st.booleans()), draw(st.integers(0, 7)), draw(st.integers(0, 9)) > 0
        n = draw(st.one_of(st.just(len(payload)), st.sampled_from([0, 125, 126, 127, 65535, 65536, 2**63])))
        b0 = (0x80 if fin else 0) | rsv << 4 | opcode
        m = 0x80 if masked else 0
        if n < 126 and draw(st.booleans()):
            head = bytes([b0, m | n])
        elif n < 1 << 16:
            head = bytes([b0, m | 126]) + n.to_bytes(2, "big")
        else:
            head = bytes([b0, m | 127]) + n.to_bytes(8, "big")
        key = draw(st.binary(min_size=4, max_size=4)) if masked else b""
        body = bytes(b ^ key[i % 4] for i, b in enumerate(payload)) if masked else payload
        out += head + key + body
    return out


@settings(derandomize=True, database=None, deadline=None, max_examples=EXAMPLES,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])  # fmt: skip
@given(data=frames())
def test_any_frames_on_an_open_socket_close_it_or_are_taken_and_the_server_serves_on(house, data):
    server, rx, errors = house
    _exchange(server.port, data, handshake=True)
    _serves_on(server, rx, errors)
    assert server.rt.nodes["out"].p.rate == 100.0  # (the only value a frame sets is the one it has)


def test_a_stage_tablet_needs_the_allow_list_and_the_token(tmp_path):
    """Served on this machine's network address (as with --monitor-host 0.0.0.0) to a tablet in
    --monitor-allow: the page wants the printed URL's token and keeps it as a cookie for its socket;
    an OSCQuery tool there (no Origin) reads the tree without it."""
    from pointat.monitor.webaccess import _lan_address

    lan = _lan_address()
    if lan is None:
        pytest.skip("no network address on this machine")
    rt = build(check(read_spec(_write(tmp_path, PATCH.format(port=9))), REG, parse_overrides([])))
    obs = Observer(rt).attach()
    server = MonitorServer(rt, obs, lan, 0, advertise=False, allow=[f"{lan}/32"])
    server.start()
    port, token = server.port, server.access.token
    host = f"Host: {lan}:{port}"
    try:
        assert server.url == f"http://{lan}:{port}/monitor?token={token}"

        def get(target: str, *extra: str) -> tuple[int, bytes]:
            with socket.create_connection((lan, port), timeout=5) as s:  # from lan: not loopback
                s.sendall(("\r\n".join([f"GET {target} HTTP/1.1", host, *extra, "", ""])).encode())
                reply = b""
                while chunk := s.recv(65536):
                    reply += chunk
            return int(reply.split(b" ", 2)[1]), reply

        assert get("/monitor")[0] == 403
        assert get("/monitor?token=wrong")[0] == 403
        status, reply = get(f"/monitor?token={token}")
        assert status == 200 and f"Set-Cookie: pointat_token_{port}={token};".encode() in reply
        origin = f"Origin: http://{lan}:{port}"
        upgrade = ["Upgrade: websocket", "Connection: Upgrade", "Sec-WebSocket-Version: 13"]
        upgrade.append("Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==")
        with socket.create_connection((lan, port), timeout=5) as s:
            lines = ["GET / HTTP/1.1", host, origin, f"Cookie: pointat_token_{port}={token}", *upgrade]
            s.sendall(("\r\n".join([*lines, "", ""])).encode())
            assert s.recv(4096).startswith(b"HTTP/1.1 101 ")
        assert get("/", origin, *upgrade)[0] == 403  # the socket without the cookie
        assert get("/?HOST_INFO")[0] == 200  # an OSCQuery tool
        with socket.create_connection((lan, port), timeout=5) as s:
            s.sendall(f"GET /?HOST_INFO HTTP/1.1\r\nHost: evil.example:{port}\r\n\r\n".encode())
            assert s.recv(64).startswith(b"HTTP/1.1 403 ")
    finally:
        server.close()


def test_readers_that_never_read_hold_up_neither_the_glove_nor_the_other_pages(served):
    _rt, server, rx = served
    stuck = []
    for _ in range(3):
        s = socket.socket()
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        s.connect(("127.0.0.1", server.port))
        key = base64.b64encode(os.urandom(16)).decode()
        s.sendall(
            f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{server.port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
            f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n".encode()
        )
        ws_send(s, 1, json.dumps({"COMMAND": "MONITOR"}).encode())
        ws_send(s, 1, json.dumps({"COMMAND": "LISTEN", "DATA": "/pointat/out/aed"}).encode())
        stuck.append(s)  # and never read
    try:
        page = ws_connect(server.port)
        page.settimeout(30)
        ws_send(page, 1, json.dumps({"COMMAND": "MONITOR"}).encode())
        readings = 0
        while readings < 100:  # 4 s of readings at 25 a second, each one whole JSON
            opcode, payload = ws_receive(page)
            if opcode == 1:
                json.loads(payload)
                readings += 1
        page.close()
        assert _streaming(rx, 100)
    finally:
        for s in stuck:
            s.close()


def test_head_is_answered_without_a_body_and_other_methods_are_refused(served):
    _rt, server, _rx = served
    port = server.port
    status, reply = _request(port, ["HEAD /?HOST_INFO HTTP/1.1", f"Host: 127.0.0.1:{port}"])
    head, _, body = reply.partition(b"\r\n\r\n")
    if READS_METHODS:
        assert status == 200 and body == b"" and b"Content-Length: " in head
    else:  # (websockets before 17, Python 3.10's: a method but GET, HEAD too, is closed unanswered)
        assert status == 0 and reply == b""
    for method in ("POST", "PUT", "DELETE", "OPTIONS"):
        status, reply = _request(port, [f"{method} /pointat/out/rate HTTP/1.1", f"Host: 127.0.0.1:{port}"])
        if READS_METHODS:
            assert status == 405 and b"Allow: GET, HEAD" in reply, (method, reply[:200])
        else:  # (websockets before 17, Python 3.10's: a method but GET is closed unanswered)
            assert status == 0 and reply == b"", (method, reply[:200])
    status, _ = _request(port, ["POST / HTTP/1.1", "Host: evil.example"])
    assert status == (403 if READS_METHODS else 0)  # who asks is looked at first


def test_the_reproduction_of_issue_45_against_pointat_run_glove_tqt(tmp_path):
    """As the issue reproduced it: ``pointat run glove_tqt --monitor``, another site's page sends
    ``/pointat/base/close`` over the socket, and a rebinding asks for ``/monitor/state``.  Both are
    refused and the glove goes on at 100 directions a second."""
    import subprocess
    import sys

    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    cmd = [sys.executable, "-m", "pointat.cli", "run", "glove_tqt", "--monitor", "0", "--for", "60"]
    cmd += ["--set", f"out.port={rx.getsockname()[1]}", "--set", "ctl.port=0", "--compiled", "off"]
    proc = subprocess.Popen(cmd, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        port = None
        for line in proc.stdout:
            if "  monitor  http://127.0.0.1:" in line:
                port = int(line.split("http://127.0.0.1:")[1].split("/")[0])
                break
        assert port is not None, "no monitor line in the banner"
        assert _streaming(rx, 50)
        status, s = _handshake(port, "http://evil.example")
        assert status == 403
        try:
            ws_send(s, 2, encode_message("/pointat/base/close", []))
        except OSError:
            pass
        s.close()
        status, reply = _request(port, ["GET /monitor/state HTTP/1.1", "Host: evil.example"])
        assert status == 403 and b"pointers" not in reply
        assert _streaming(rx, 300), "the glove was silenced"  # 3 s more of directions
    finally:
        proc.terminate()
        out, _ = proc.communicate(timeout=20)
        rx.close()
    assert "Traceback" not in out, out[-3000:]
    assert "refused (403)" in out


@pytest.mark.parametrize(
    ("allow", "said"),
    [(None, "needs an allow-list"), ("192.168.1.300", "'192.168.1.300' is not an IP address or network")],
)
def test_pointat_run_refuses_a_monitor_beyond_loopback_without_a_good_allow_list(tmp_path, allow, said):
    import subprocess
    import sys

    cmd = [sys.executable, "-m", "pointat.cli", "run", "glove_tqt", "--monitor", "0", "--for", "5"]
    cmd += ["--monitor-host", "0.0.0.0", "--set", "out.port=9", "--set", "ctl.port=0", "--compiled", "off"]
    if allow is not None:
        cmd += ["--monitor-allow", allow]
    run = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert run.returncode != 0 and said in run.stderr, run.stderr[-2000:]
    assert "Traceback" not in run.stderr
