"""The monitor and OSCQuery server of a running patch (``pointat run --monitor``).

One TCP port serves, as the OSCQuery proposal asks, HTTP and WebSocket together:

* ``GET /`` and ``GET /PATH``: the address space as JSON (:mod:`pointat.oscquery`); ``?HOST_INFO``,
  ``?VALUE`` and the other attributes; 404 for an address the patch does not have.
* ``GET /monitor``: the monitor page (``pointat/monitor/``), and ``/monitor/state``: the observer's last
  reading with the history of the plots, as JSON.
* WebSocket on any path: ``{"COMMAND": "LISTEN", "DATA": PATH}`` and ``IGNORE`` (the value is then sent
  as a binary OSC message whenever it changes), binary OSC messages from the client (live control, as
  on the OSC port), and ``{"COMMAND": "MONITOR"}``: the monitor's readings as JSON text, 25 a second.

A UDP port (``HOST_INFO``'s ``OSC_PORT``) takes OSC for live control.  With zeroconf installed the
server is advertised as ``_oscjson._tcp`` (and the OSC port as ``_osc._udp``), so ossia score,
Chataigne or any OSCQuery browser finds it.

Nothing here runs on the scheduler's thread: requests are served by threads of their own, readings come
from the observer's thread, and live control is posted to the scheduler like any other event (never
waiting: a full queue drops the message and counts it).  Loopback only unless asked
(``--monitor-host``).
"""

from __future__ import annotations

import json
import logging
import socket
import threading
import time
from collections.abc import Sequence
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from typing import Any
from urllib.parse import unquote, urlsplit

from .control import PREFIX, control
from .devices.osc_wire import decode_packet, encode_message
from .oscquery import EXTENSIONS, address_space, find, value_of
from .scheduling import quiet_thread
from .webaccess import Access, LogLimit
from .websocket import BINARY, CLOSE, PING, PONG, TEXT, FrameReader, WebSocketError, accept_key, encode_frame

__all__ = ["MonitorServer"]

log = logging.getLogger("pointat.monitor")

_STATIC = {
    "/monitor": ("index.html", "text/html; charset=utf-8"),
    "/monitor/": ("index.html", "text/html; charset=utf-8"),
    "/monitor/monitor.js": ("monitor.js", "text/javascript; charset=utf-8"),
    "/monitor/monitor.css": ("monitor.css", "text/css; charset=utf-8"),
}


class _Server(ThreadingHTTPServer):
    """Threads for its requests, each marked quiet: they wait on their sockets, and a spinning scheduler
    (``--spin``) must not pause for them (:func:`pointat.scheduling.quiet_thread`)."""

    daemon_threads = True

    monitor: MonitorServer

    def handle_error(self, request: Any, client_address: Any) -> None:
        """A client gone mid-answer (or any other failure of one request): a line, rate-limited, no
        traceback."""
        import sys

        exc = sys.exc_info()[1]
        self.monitor.gone(f"{client_address[0]}:{client_address[1]}", exc)

    def process_request(self, request: Any, client_address: Any) -> None:
        th = threading.Thread(
            target=self.process_request_thread, args=(request, client_address), name="pointat-monitor-client"
        )
        th.daemon = True
        quiet_thread(th).start()


class _Client:
    """One WebSocket client: what it listens to, and a lock so that two threads never interleave frames."""

    def __init__(self, sock: socket.socket):
        self.sock = sock
        self.lock = threading.Lock()
        self.listening: dict[str, Any] = {}  # path -> the value last sent
        self.monitor = False
        self.alive = True

    def send(self, opcode: int, payload: bytes) -> None:
        with self.lock:
            if not self.alive:
                return
            try:
                self.sock.sendall(encode_frame(opcode, payload))
            except OSError:  # gone, or too slow to take a frame within the timeout: dropped
                self.alive = False


class MonitorServer:
    """Serve a runtime's monitor and OSCQuery; :meth:`start` before the runtime runs, :meth:`close` after."""

    #: Seconds a WebSocket client may take to accept a frame before it is dropped.
    SEND_TIMEOUT = 1.0

    def __init__(
        self,
        rt: Any,
        observer: Any,
        host: str = "127.0.0.1",
        port: int = 0,
        *,
        name: str = "pointat",
        advertise: bool = True,
        allow: Sequence[str] = (),
        token: str | None = None,
    ):
        self.rt = rt
        self.observer = observer
        self.host = host
        self.name = name
        self.advertise = advertise
        self.clients: list[_Client] = []
        self._lock = threading.Lock()
        self.control_refused = 0
        self.control_dropped = 0
        server = self

        class Handler(_Handler):
            monitor = server

        self.http = _Server((host, port), Handler)
        self.http.monitor = self
        self.port = self.http.server_address[1]
        try:
            self.access = Access(host, self.port, allow=allow, token=token)
        except ValueError:
            self.http.server_close()
            raise
        self.refused = 0
        self._refusals_told: set[str] = set()
        self._refusal_log = LogLimit(log.warning)
        self._gone_log = LogLimit(log.info)
        self._malformed_log = LogLimit(log.warning)
        self.osc = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self.osc.bind((host, self.port))  # the same number when it is free: one port to remember
        except OSError:
            self.osc.bind((host, 0))
        self.osc_port = self.osc.getsockname()[1]
        # (a blocked recvfrom is not woken by close() on Linux: the reader looks at _closed between waits)
        self.osc.settimeout(0.2)
        self._threads: list[threading.Thread] = []
        self._zeroconf: Any = None
        self._closed = False
        observer.listen(self._push)
        observer.detailed = True

    @property
    def url(self) -> str:
        """The monitor page's address, with its token when served beyond this machine."""
        return self.access.url("/monitor")

    #: Refusals named in the log one by one (each reason once); past that, they share a rate-limited line.
    REFUSALS_NAMED = 32

    def refuse(self, reason: str) -> None:
        """A request refused (403): told once per reason, then only counted."""
        self.refused += 1
        with self._lock:
            if reason in self._refusals_told:
                return
            if len(self._refusals_told) < self.REFUSALS_NAMED:
                self._refusals_told.add(reason)
                log.warning("monitor: a request refused (403): %s", reason)
                return
        self._refusal_log("monitor: a request refused (403): %s", reason)

    def gone(self, peer: str, exc: BaseException | None) -> None:
        """A client that went away mid-request, or a request that failed: one line, rate-limited."""
        self._gone_log("monitor: client %s: %s", peer, _why(exc))

    def host_info(self) -> dict[str, Any]:
        return {
            "NAME": self.name,
            "EXTENSIONS": EXTENSIONS,
            "OSC_IP": self.host,
            "OSC_PORT": self.osc_port,
            "OSC_TRANSPORT": "UDP",
            "WS_IP": self.host,
            "WS_PORT": self.port,
        }

    def tree(self) -> dict[str, Any]:
        return address_space(self.rt, f"pointat: {self.name}")

    # -- running -----------------------------------------------------------------------------------
    def start(self) -> None:
        for target, what in ((self.http.serve_forever, "http"), (self._read_osc, "osc")):
            th = quiet_thread(threading.Thread(target=target, name=f"pointat-monitor-{what}", daemon=True))
            th.start()
            self._threads.append(th)
        if self.advertise:  # (zeroconf probes the network for a second or two: not in anyone's way)
            th = quiet_thread(threading.Thread(target=self._advertise, name="pointat-zeroconf", daemon=True))
            th.start()
            self._threads.append(th)

    def _advertise(self) -> None:
        self._zeroconf = _advertise(self.name, self.host, self.port, self.osc_port)
        if self._closed and self._zeroconf is not None:
            self._zeroconf.close()

    def close(self) -> None:
        self._closed = True
        if self._zeroconf is not None:
            try:
                self._zeroconf.unregister_all_services()
                self._zeroconf.close()
            except Exception:  # the network went away: nothing to tell
                pass
        self.http.shutdown()
        self.http.server_close()
        try:
            self.osc.close()
        except OSError:
            pass
        for c in list(self.clients):
            c.alive = False
            try:
                c.sock.close()
            except OSError:
                pass
        for th in self._threads:  # the server's own threads end with it (zeroconf's registration aside)
            if th.name != "pointat-zeroconf":
                th.join(1.0)

    def _read_osc(self) -> None:
        while not self._closed:
            try:
                data, peer = self.osc.recvfrom(65536)
            except TimeoutError:
                continue
            except OSError:
                return  # closed
            if not self.access.peer_allowed(peer[0]):
                self.refuse(f"OSC from {peer[0]}, not in --monitor-allow")
                continue
            self.apply(data)

    def apply(self, data: bytes) -> None:
        """Carry out an OSC packet of live control (from the OSC port or a WebSocket), on the scheduler."""
        try:
            messages = decode_packet(data)
        except ValueError as exc:
            self.control_refused += 1
            self._malformed_log("OSCQuery: a malformed OSC packet dropped: %s", exc)
            return
        for address, args in messages:
            args = [a for a in args if a is not None]  # a method sent as N (nil): no values
            if not address.startswith(PREFIX):
                self.control_refused += 1
                log.warning(
                    "OSCQuery: %s refused: live control addresses start with %s", address[:80], PREFIX
                )
                continue

            def deliver(address: str = address, args: list[Any] = args) -> None:
                why = control(self.rt, address, args, self.rt.clock.now())
                if why is not None:
                    self.control_refused += 1
                    log.warning("OSCQuery: %s refused: %s", address[:80], why[:200])

            if not self.rt.post(None, deliver, block=False):
                self.control_dropped += 1

    def _push(self, snap: dict[str, Any]) -> None:
        """Observer's thread: the monitor's reading to monitor clients, changed values to listeners."""
        with self._lock:
            clients = [c for c in self.clients if c.alive]
            self.clients = clients
        if not clients:
            return
        text = None
        for c in clients:
            if c.monitor:
                if text is None:
                    text = json.dumps({k: v for k, v in snap.items() if not k.endswith("history")}).encode()
                c.send(TEXT, text)
            for path, last in list(c.listening.items()):
                value = value_of(self.rt, path)
                if value is not None and value != last:
                    c.listening[path] = value
                    c.send(BINARY, encode_message(path, value))

    def add_client(self, client: _Client) -> None:
        with self._lock:
            self.clients.append(client)


class _Handler(BaseHTTPRequestHandler):
    monitor: MonitorServer
    server_version = "pointat"
    protocol_version = "HTTP/1.1"

    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 (the base class's name)
        log.debug("%s %s", self.address_string(), format % args)

    def _send(
        self, status: int, body: bytes, ctype: str = "application/json", cookie: str | None = None
    ) -> None:
        self.send_response(status)
        if cookie is not None:
            self.send_header("Set-Cookie", cookie)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        if self.command != "HEAD":
            self.wfile.write(body)

    def _json(self, value: Any, status: int = 200) -> None:
        self._send(status, json.dumps(value).encode())

    def do_HEAD(self) -> None:  # noqa: N802 (http.server's name)
        self.do_GET()

    def _refused(self) -> bool:
        """Refuse (403) a request from a peer, Host or Origin not served (:mod:`pointat.webaccess`)."""
        m = self.monitor
        why = m.access.refusal(
            self.client_address[0],
            self.headers.get("Host"),
            self.headers.get("Origin"),
            self.path,
            self.headers.get("Cookie"),
        )
        if why is None:
            return False
        m.refuse(why)
        self.close_connection = True
        self._send(HTTPStatus.FORBIDDEN, b"forbidden\n", "text/plain; charset=utf-8")
        return True

    def do_GET(self) -> None:  # noqa: N802
        if self._refused():
            return
        if self.headers.get("Upgrade", "").lower() == "websocket":
            return self._websocket()
        url = urlsplit(self.path)
        path = unquote(url.path) or "/"
        m = self.monitor
        if path in _STATIC:
            name, ctype = _STATIC[path]
            body = resources.files("pointat.monitor").joinpath(name).read_bytes()
            return self._send(200, body, ctype, cookie=m.access.set_cookie(url.query))
        if path == "/monitor/state":
            return self._json({**m.observer.snapshot(), "url": m.url})
        if path == "/favicon.ico":
            return self._send(204, b"", "text/plain")
        if path == "/" and url.query == "HOST_INFO":
            return self._json(m.host_info())
        node = find(m.tree(), path)
        if node is None:
            return self._send(404, f"no OSC address {path}\n".encode(), "text/plain; charset=utf-8")
        if url.query:
            attr = url.query.split("&")[0].upper()
            if attr == "HOST_INFO":
                return self._json(m.host_info())
            if attr not in node:
                return self._send(204, b"", "text/plain")
            return self._json({attr: node[attr]})
        return self._json(node)

    # -- WebSocket ---------------------------------------------------------------------------------
    def _websocket(self) -> None:
        try:
            key = accept_key(self.headers.get("Sec-WebSocket-Key", ""))
        except WebSocketError as exc:
            return self._send(HTTPStatus.BAD_REQUEST, f"{exc}\n".encode(), "text/plain; charset=utf-8")
        self.send_response(HTTPStatus.SWITCHING_PROTOCOLS)
        self.send_header("Upgrade", "websocket")
        self.send_header("Connection", "Upgrade")
        self.send_header("Sec-WebSocket-Accept", key)
        self.end_headers()
        self.wfile.flush()
        sock = self.connection
        sock.settimeout(MonitorServer.SEND_TIMEOUT)
        client = _Client(sock)
        self.monitor.add_client(client)
        reader = FrameReader()
        try:
            while client.alive:
                try:
                    data = sock.recv(65536)
                except TimeoutError:
                    continue
                if not data:
                    break
                for opcode, payload in reader.feed(data):
                    if opcode == CLOSE:
                        client.send(CLOSE, payload[:2])
                        client.alive = False
                        break
                    if opcode == PING:
                        client.send(PONG, payload)
                    elif opcode == TEXT:
                        self._command(client, payload)
                    elif opcode == BINARY:
                        self.monitor.apply(payload)
        except WebSocketError as exc:
            self.monitor._malformed_log("monitor: a WebSocket client closed: %s", exc)
            client.send(CLOSE, (1002).to_bytes(2, "big") + str(exc)[:100].encode())
        except OSError:
            pass
        finally:
            client.alive = False
            self.close_connection = True

    def _command(self, client: _Client, payload: bytes) -> None:
        try:
            cmd = json.loads(payload)
            verb, data = cmd.get("COMMAND"), cmd.get("DATA")
        except (ValueError, AttributeError):
            log.warning("monitor: a WebSocket command that is not JSON {COMMAND, DATA} ignored")
            return
        if verb == "LISTEN" and isinstance(data, str):
            value = value_of(self.monitor.rt, data)
            if value is not None:
                client.listening[data] = value
                client.send(BINARY, encode_message(data, value))
        elif verb == "IGNORE" and isinstance(data, str):
            client.listening.pop(data, None)
        elif verb == "MONITOR":
            client.monitor = True
            snap = self.monitor.observer.snapshot()
            client.send(TEXT, json.dumps({**snap, "url": self.monitor.url}).encode())
        else:
            log.warning("monitor: WebSocket command %r ignored (LISTEN, IGNORE, MONITOR)", str(verb)[:40])


def _advertise(name: str, host: str, port: int, osc_port: int) -> Any:
    """Register ``_oscjson._tcp`` and ``_osc._udp`` with zeroconf; None (and a log line) without it."""
    try:
        from zeroconf import ServiceInfo, Zeroconf
    except ImportError:
        log.info("zeroconf is not installed: the OSCQuery server is not advertised (pip install zeroconf)")
        return None
    address = "127.0.0.1" if host in ("", "0.0.0.0") else host
    try:
        addresses = [socket.inet_aton(socket.gethostbyname(address))]
        before = set(threading.enumerate())
        zc = Zeroconf(interfaces=["127.0.0.1"] if address.startswith("127.") else None)
        for th in set(threading.enumerate()) - before:  # its event loop, asleep on its sockets
            quiet_thread(th)
        label = f"{name} {time.strftime('%H%M%S')}"[:63]
        for kind, p in (("_oscjson._tcp.local.", port), ("_osc._udp.local.", osc_port)):
            zc.register_service(
                ServiceInfo(
                    kind, f"{label}.{kind}", addresses=addresses, port=p, server=f"pointat-{p}.local."
                ),
                allow_name_change=True,
            )
        return zc
    except Exception as exc:  # no multicast on this network: the server works, unadvertised
        log.warning("the OSCQuery server is not advertised (zeroconf: %s)", exc)
        return None


def _why(exc: BaseException | None) -> str:
    """A failure told in a few words (no traceback): a client gone is the usual one."""
    if isinstance(exc, (BrokenPipeError, ConnectionResetError, ConnectionAbortedError)):
        return "went away mid-answer"
    if isinstance(exc, TimeoutError):
        return "timed out"
    return f"{type(exc).__name__}: {str(exc)[:120]}" if exc is not None else "failed"
