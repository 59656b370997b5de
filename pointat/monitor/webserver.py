"""The monitor and OSCQuery server of a running patch (``pointat run --monitor``).

One TCP port serves, as the OSCQuery proposal asks, HTTP and WebSocket together:

* ``GET /`` and ``GET /PATH``: the address space as JSON (:mod:`pointat.monitor.oscquery`); ``?HOST_INFO``,
  ``?VALUE`` and the other attributes; 404 for an address the patch does not have.
* ``GET /monitor``: the monitor page (``pointat/monitor/``), and ``/monitor/state``: the observer's last
  reading with the history of the plots, as JSON.
* WebSocket on any path: ``{"COMMAND": "LISTEN", "DATA": PATH}`` and ``IGNORE`` (the value is then sent
  as a binary OSC message whenever it changes), binary OSC messages from the client (live control, as
  on the OSC port), and ``{"COMMAND": "MONITOR"}``: the monitor's readings as JSON text, 25 a second.

A UDP port (``HOST_INFO``'s ``OSC_PORT``) takes OSC for live control.  With zeroconf installed the
server is advertised as ``_oscjson._tcp`` (and the OSC port as ``_osc._udp``) on the interfaces it
serves, so ossia score, Chataigne or any OSCQuery browser finds it.

HTTP and WebSocket are the ``websockets`` library's (its threaded server; a plain GET is answered from
its ``process_request``, and the connection then closed): it parses requests and frames, bounds their
sizes, pings idle sockets and closes dead ones.  What is ours: who may come in (:mod:`pointat.monitor.webaccess`:
Host, Origin, peers, token, checked before anything is answered), at most :attr:`MonitorServer.
MAX_CONNECTIONS` connections at once, a request in :attr:`~MonitorServer.OPEN_TIMEOUT` seconds, a
stuck reader dropped after :attr:`~MonitorServer.SEND_TIMEOUT`, and a log that tells clients gone and
packets malformed in a few lines, never a traceback.

Nothing here runs on the scheduler's thread: requests are served by threads of their own, readings come
from the observer's thread, and live control is posted to the scheduler like any other event (never
waiting: a full queue drops the message and counts it).  Loopback only unless asked
(``--monitor-host``, with ``--monitor-allow``).
"""

from __future__ import annotations

import json
import logging
import socket
import struct
import threading
import time
from collections.abc import Sequence
from http import HTTPStatus
from importlib import resources
from typing import Any
from urllib.parse import unquote, urlsplit

from websockets import __version__ as _websockets_version
from websockets.datastructures import Headers
from websockets.exceptions import ConnectionClosed, ConnectionClosedOK
from websockets.http11 import Request, Response
from websockets.sync.server import ServerConnection, serve

from ..control import PREFIX, control
from ..devices.osc_wire import decode_packet, encode_message
from ..scheduling import quiet_thread
from .oscquery import EXTENSIONS, address_space, find, value_of
from .webaccess import Access, LogLimit, is_loopback

__all__ = ["MonitorServer"]

log = logging.getLogger("pointat.monitor")

#: Whether the websockets library reads a request of another method than GET (17 on): HEAD is then
#: answered without a body, the others 405; before (16, what Python 3.10 gets) it closes them unanswered.
READS_METHODS = int(_websockets_version.split(".")[0]) >= 17

_STATIC = {
    "/monitor": ("index.html", "text/html; charset=utf-8"),
    "/monitor/": ("index.html", "text/html; charset=utf-8"),
    "/monitor/monitor.js": ("monitor.js", "text/javascript; charset=utf-8"),
    "/monitor/monitor.css": ("monitor.css", "text/css; charset=utf-8"),
}


class _LibraryLog(logging.Filter):
    """What the websockets library logs, as our lines: warnings and errors only, one line each (no
    traceback), rate-limited.  Its debug and info lines (a line per frame with ``-v``) are not wanted."""

    def __init__(self) -> None:
        super().__init__()
        self.limit = LogLimit(lambda msg, *args: None)

    def filter(self, record: logging.LogRecord) -> bool:
        if record.levelno < logging.WARNING:
            return False
        exc = record.exc_info[1] if record.exc_info else None
        text = record.getMessage()
        if text == "opening handshake failed":  # a request the library does not take (before 17: any
            return False  # method but GET, bytes not ASCII): already told, rate-limited, as a client gone
        if text == "keepalive ping failed":  # a client that stopped answering: closed, as any gone one
            record.levelno, record.levelname = logging.INFO, "INFO"
            text, exc = "a client stopped answering pings; its connection closed", None
        elif text == "unexpected internal error":
            # a client's bytes or end of stream before the handshake's answer: the library fails its own
            # assertion (or reads past the end), closes that connection and serves on (found by
            # tests/fuzz_websocket.py): a client's doing, told as a warning
            record.levelno, record.levelname = logging.WARNING, "WARNING"
            text = "a client's stream ended or went on before the answer; its connection closed"
        record.msg = f"monitor (websockets): {text}" + (f" ({exc!r})"[:200] if exc else "")
        record.args = None
        record.exc_info = record.exc_text = None
        before = self.limit.held
        self.limit(record.msg)
        return self.limit.held == before


_library_log = logging.getLogger("pointat.monitor.websockets")
_library_log.setLevel(logging.WARNING)
_library_log.addFilter(_LibraryLog())


class _Client:
    """One WebSocket client: what it listens to, and what waits to be sent to it.

    A thread of its own sends: whoever has something for the client (the observer's thread above all)
    leaves the latest message of its kind (the monitor's reading, each path's value) and never waits on
    a reader that does not keep up; such a reader misses readings, and one that stops reading is dropped
    (:attr:`MonitorServer.SEND_TIMEOUT`, or the pings).
    """

    def __init__(self, connection: ServerConnection):
        self.connection = connection
        self.listening: dict[str, Any] = {}  # path -> the value last sent
        self.monitor = False
        self.alive = True
        self._outbox: dict[str, tuple[bytes, bool]] = {}  # kind -> the latest message, text or not
        self._ready = threading.Condition()
        self.sender = threading.Thread(target=self._send_all, name="pointat-monitor-send", daemon=True)
        quiet_thread(self.sender).start()

    def send(self, kind: str, message: bytes, text: bool = False) -> None:
        """Leave ``message`` for the client (any thread, never waiting); it replaces one of the same
        ``kind`` not sent yet."""
        with self._ready:
            if self.alive:
                self._outbox[kind] = (message, text)
                self._ready.notify()

    def stop(self) -> None:
        with self._ready:
            self.alive = False
            self._outbox.clear()
            self._ready.notify()

    def _send_all(self) -> None:
        while True:
            with self._ready:
                while self.alive and not self._outbox:
                    self._ready.wait()
                if not self.alive:
                    return
                messages = list(self._outbox.values())
                self._outbox.clear()
            for message, text in messages:
                try:
                    self.connection.send(message, text=text)
                except (ConnectionClosed, OSError):  # gone, or stuck SEND_TIMEOUT: the session ends too
                    self.stop()
                    return


class MonitorServer:
    """Serve a runtime's monitor and OSCQuery; :meth:`start` before the runtime runs, :meth:`close` after.

    ``allow``: the other machines that may connect (needed when ``host`` is not loopback); ``token``:
    the secret a browser there carries (made up when not given).
    """

    #: Connections served at once (HTTP and WebSocket); more are answered 503 and closed at once.
    MAX_CONNECTIONS = 32
    #: Seconds a client has to send its request (a slow or silent one is closed after).
    OPEN_TIMEOUT = 5.0
    #: Seconds a client may take to accept what is sent to it before it is dropped.
    SEND_TIMEOUT = 2.0
    #: Seconds between pings of an open WebSocket, and for its answer: a dead peer is closed.
    PING = 10.0
    #: Seconds a WebSocket may stay open asking for nothing (no MONITOR, no LISTEN) and sending nothing.
    IDLE_TIMEOUT = 60.0
    #: The largest message a client may send (an OSC packet or a command is a few hundred bytes).
    MAX_MESSAGE = 1 << 16

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
        self.refused = 0
        self.turned_away = 0  # connections over MAX_CONNECTIONS
        self.most_open = 0  # the most connections served at once
        self._refusals_told: set[str] = set()
        self._refusal_log = LogLimit(log.warning)
        self._gone_log = LogLimit(log.info)
        self._malformed_log = LogLimit(log.warning)
        self._full_log = LogLimit(log.warning)
        self._open: dict[socket.socket, str] = {}  # connections being served, and their peers

        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        sock = socket.create_server((host, port), family=family)
        self.port = sock.getsockname()[1]
        try:
            self.access = Access(host, self.port, allow=allow, token=token)
            self.osc = socket.socket(family, socket.SOCK_DGRAM)
        except (ValueError, OSError):
            sock.close()
            raise
        try:
            self.osc.bind((host, self.port))  # the same number when it is free: one port to remember
        except OSError:
            self.osc.bind((host, 0))
        self.osc_port = self.osc.getsockname()[1]
        # (a blocked recvfrom is not woken by close() on Linux: the reader looks at _closed between waits)
        self.osc.settimeout(0.2)

        server = self

        class Connection(_Connection):
            monitor = server

        self.ws = serve(
            self._session,
            sock=sock,
            process_request=self._http,
            compression=None,
            server_header="pointat",
            open_timeout=self.OPEN_TIMEOUT,
            ping_interval=self.PING,
            ping_timeout=self.PING,
            close_timeout=1.0,
            max_size=self.MAX_MESSAGE,
            max_queue=16,
            logger=_library_log,
            create_connection=Connection,
        )
        self._handle = self.ws.handler
        self.ws.handler = self._connection
        self._threads: list[threading.Thread] = []
        self._zeroconf: Any = None
        self._closed = False
        observer.listen(self._push)
        observer.detailed = True

    @property
    def url(self) -> str:
        """The monitor page's address, with its token when served beyond this machine."""
        return self.access.url("/monitor")

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

    # -- the log -----------------------------------------------------------------------------------
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

    # -- running -----------------------------------------------------------------------------------
    def start(self) -> None:
        for target, what in ((self.ws.serve_forever, "http"), (self._read_osc, "osc")):
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
        with self._lock:
            waiting = list(self._open)
        for sock in waiting:  # a client still sending its request: no need to wait OPEN_TIMEOUT for it
            try:
                sock.shutdown(socket.SHUT_RD)
            except OSError:
                pass
        self.ws.shutdown()
        try:
            self.osc.close()
        except OSError:
            pass
        self._refusal_log.flush("requests refused (403)")
        self._gone_log.flush("clients gone or failed")
        self._malformed_log.flush("malformed packets or commands dropped")
        self._full_log.flush("connections turned away (503)")
        for th in self._threads:  # the server's own threads end with it (zeroconf's registration aside)
            if th.name != "pointat-zeroconf":
                th.join(1.0)

    def _connection(self, sock: socket.socket, addr: Any) -> None:
        """A connection's thread, before the library's handler: the cap, and a send timeout."""
        quiet_thread(threading.current_thread())
        with self._lock:
            full = len(self._open) >= self.MAX_CONNECTIONS
            if not full:
                self._open[sock] = str(addr[0])
                self.most_open = max(self.most_open, len(self._open))
        if full:
            self.turned_away += 1
            self._full_log(
                "monitor: %d connections open: %s turned away (503)", self.MAX_CONNECTIONS, addr[0]
            )
            try:
                sock.setblocking(False)
                sock.send(
                    b"HTTP/1.1 503 Service Unavailable\r\nContent-Length: 0\r\nConnection: close\r\n\r\n"
                )
                sock.shutdown(socket.SHUT_RDWR)  # the library's handler then ends at once
            except OSError:
                pass
            sock.setblocking(True)
        else:
            _send_timeout(sock, self.SEND_TIMEOUT)
        try:
            self._handle(sock, addr)
        finally:
            with self._lock:
                self._open.pop(sock, None)

    def peer(self, connection: ServerConnection) -> str:
        """The address a connection came from (as accepted: its socket may be closed by now)."""
        return self._open.get(connection.socket, "?")

    # -- HTTP --------------------------------------------------------------------------------------
    def _http(self, connection: ServerConnection, request: Request) -> Response | None:
        """Every request first: refused (403) unless Host, Origin, peer and token are right; then a
        WebSocket is let through (None), anything else answered."""
        headers = request.headers
        peer = self.peer(connection)
        why = self.access.refusal(
            peer,
            _header(headers, "Host"),
            _header(headers, "Origin"),
            request.path,
            _header(headers, "Cookie", "; "),
        )
        if why is not None:
            self.refuse(why)
            return _response(HTTPStatus.FORBIDDEN, b"forbidden\n", "text/plain; charset=utf-8")
        method = getattr(request, "method", "GET")  # (the library reads other methods since 16)
        if method not in ("GET", "HEAD"):
            response = _response(HTTPStatus.METHOD_NOT_ALLOWED, b"GET only\n", "text/plain; charset=utf-8")
            response.headers["Allow"] = "GET, HEAD"
            return response
        if "websocket" in (_header(headers, "Upgrade") or "").lower():
            return None
        if not request.path.isascii():  # (before 17 the library passes bytes that are not ASCII on)
            return _response(HTTPStatus.BAD_REQUEST, b"bad request\n", "text/plain; charset=utf-8")
        try:
            response = self._answer(request.path)
            if method == "HEAD":
                response.body = b""  # (its Content-Length stays the GET's)
            return response
        except Exception as exc:  # a bug here must not close the server: told, and a 500
            log.error("monitor: GET %s failed: %s: %s", request.path[:100], type(exc).__name__, exc)
            return _response(HTTPStatus.INTERNAL_SERVER_ERROR, b"error\n", "text/plain; charset=utf-8")

    def _answer(self, target: str) -> Response:
        url = urlsplit(target)
        path = unquote(url.path) or "/"
        if path in _STATIC:
            name, ctype = _STATIC[path]
            body = resources.files("pointat.monitor").joinpath(name).read_bytes()
            return _response(200, body, ctype, cookie=self.access.set_cookie(url.query))
        if path == "/monitor/state":
            return _json({**self.observer.snapshot(), "url": self.url})
        if path == "/favicon.ico":
            return _response(204, b"", "text/plain")
        if path == "/" and url.query == "HOST_INFO":
            return _json(self.host_info())
        node = find(self.tree(), path)
        if node is None:
            return _response(404, f"no OSC address {path[:200]}\n".encode(), "text/plain; charset=utf-8")
        if url.query:
            attr = url.query.split("&")[0].upper()
            if attr == "HOST_INFO":
                return _json(self.host_info())
            if attr not in node:
                return _response(204, b"", "text/plain")
            return _json({attr: node[attr]})
        return _json(node)

    # -- WebSocket ---------------------------------------------------------------------------------
    def _session(self, connection: ServerConnection) -> None:
        """A WebSocket's thread, for as long as it is open: its commands and its OSC."""
        client = _Client(connection)
        with self._lock:
            self.clients.append(client)
        try:
            while client.alive:
                try:
                    message = connection.recv(timeout=self.IDLE_TIMEOUT)
                except TimeoutError:
                    if not client.monitor and not client.listening:
                        connection.close(1000, "idle")
                        break
                    continue
                if isinstance(message, str):
                    self._command(client, message)
                else:
                    self.apply(message)
        except ConnectionClosedOK:
            pass
        except ConnectionClosed as exc:
            sent = exc.sent
            if sent is not None and sent.code in (1002, 1007, 1009):  # the client broke the protocol
                self._malformed_log("monitor: a WebSocket client closed: %s", sent.reason or sent.code)
            else:
                self.gone(self.peer(connection), exc)
        finally:
            client.stop()

    def _command(self, client: _Client, payload: str) -> None:
        try:
            cmd = json.loads(payload)
            verb, data = cmd.get("COMMAND"), cmd.get("DATA")
        except (ValueError, AttributeError, RecursionError):
            self._malformed_log("monitor: a WebSocket command that is not JSON {COMMAND, DATA} ignored")
            return
        if verb == "LISTEN" and isinstance(data, str):
            value = value_of(self.rt, data)
            if value is not None:
                client.listening[data] = value
                client.send(data, encode_message(data, value))
        elif verb == "IGNORE" and isinstance(data, str):
            client.listening.pop(data, None)
        elif verb == "MONITOR":
            client.monitor = True
            snap = self.observer.snapshot()
            client.send("monitor", json.dumps({**snap, "url": self.url}).encode(), text=True)
        else:
            self._malformed_log(
                "monitor: WebSocket command %r ignored (LISTEN, IGNORE, MONITOR)", str(verb)[:40]
            )

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
                c.send("monitor", text, text=True)
            for path, last in list(c.listening.items()):
                value = value_of(self.rt, path)
                if value is not None and value != last:
                    c.listening[path] = value
                    c.send(path, encode_message(path, value))

    # -- OSC ---------------------------------------------------------------------------------------
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


class _Connection(ServerConnection):
    """The library's connection, its threads marked quiet (they sleep on the socket: a spinning
    scheduler need not pause for them), and a request that fails (a client gone mid-answer, too slow)
    told as one line."""

    monitor: MonitorServer

    def __init__(self, *args: Any, **kwargs: Any):
        super().__init__(*args, **kwargs)
        quiet_thread(self.recv_events_thread)

    def start_keepalive(self) -> None:
        super().start_keepalive()
        keepalive = getattr(self, "keepalive_thread", None)
        if keepalive is not None:
            quiet_thread(keepalive)

    def handshake(self, *args: Any, **kwargs: Any) -> None:
        try:
            super().handshake(*args, **kwargs)
        except Exception as exc:
            self.monitor.gone(self.monitor.peer(self), exc)
            raise


def _header(headers: Headers, name: str, sep: str = ", ") -> str | None:
    """A header's value, several joined (two Hosts or two Origins then name no server: refused)."""
    values = headers.get_all(name)
    return sep.join(values) if values else None


def _send_timeout(sock: socket.socket, seconds: float) -> None:
    """Make a blocking send on ``sock`` give up after ``seconds`` without progress (SO_SNDTIMEO): a client
    that stops reading cannot hold a thread, nor the observer's pushes, for longer."""
    whole = int(seconds)
    try:
        sock.setsockopt(
            socket.SOL_SOCKET, socket.SO_SNDTIMEO, struct.pack("ll", whole, int((seconds - whole) * 1e6))
        )
    except (OSError, struct.error):  # not on this system: the keepalive pings close it, later
        pass


def _response(status: int, body: bytes, ctype: str, cookie: str | None = None) -> Response:
    headers = Headers()
    headers["Content-Type"] = ctype
    headers["Content-Length"] = str(len(body))
    headers["Cache-Control"] = "no-store"
    headers["Connection"] = "close"
    if cookie is not None:
        headers["Set-Cookie"] = cookie
    return Response(int(status), HTTPStatus(int(status)).phrase, headers, body)


def _json(value: Any, status: int = 200) -> Response:
    return _response(status, json.dumps(value).encode(), "application/json")


def _why(exc: BaseException | None) -> str:
    """A failure told in a few words (no traceback): a client gone is the usual one."""
    while isinstance(exc, ConnectionClosed) and exc.__cause__ is not None:
        exc = exc.__cause__
    if isinstance(exc, (BrokenPipeError, ConnectionResetError, ConnectionAbortedError)):
        return "went away mid-answer"
    if isinstance(exc, (TimeoutError, BlockingIOError)):
        return "timed out"
    if isinstance(exc, ConnectionClosed):
        return "went away"
    return f"{type(exc).__name__}: {str(exc)[:120]}" if exc is not None else "failed"


def _advertise(name: str, host: str, port: int, osc_port: int) -> Any:
    """Register ``_oscjson._tcp`` and ``_osc._udp`` with zeroconf on the interfaces served; None (and a
    log line) without it.

    Served on loopback, zeroconf answers on loopback only: its sockets are held to the loopback device
    (``SO_BINDTODEVICE``), so nothing on the network reaches its port 5353; served on one address, they
    are held to that address's interface; where they cannot be, the server is not advertised.  Served
    on every interface, it answers on all.
    """
    try:
        from zeroconf import InterfaceChoice, ServiceInfo, Zeroconf
    except ImportError:
        log.info("zeroconf is not installed: the OSCQuery server is not advertised (pip install zeroconf)")
        return None
    loopback = is_loopback(host)
    try:
        if loopback:
            addresses = [socket.inet_aton("127.0.0.1")]
            interfaces: Any = ["127.0.0.1"]
        elif host in ("", "0.0.0.0"):
            addresses = [socket.inet_aton(a) for a in _interface_addresses()]
            interfaces = InterfaceChoice.All
        else:
            addresses = [socket.inet_aton(socket.gethostbyname(host))]
            interfaces = [host]
        before = set(threading.enumerate())
        zc = Zeroconf(interfaces=interfaces)
        for th in set(threading.enumerate()) - before:  # its event loop, asleep on its sockets
            quiet_thread(th)
        wildcard = host in ("", "0.0.0.0")
        device = _loopback_device() if loopback else None if wildcard else _device_of(host)
        if not wildcard and not _hold_to(zc, device):
            zc.close()
            log.info("the OSCQuery server is not advertised: zeroconf cannot be held to %s here", host)
            return None
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


def _loopback_device() -> str | None:
    for _index, name in socket.if_nameindex():
        if name in ("lo", "lo0"):
            return name
    return None


def _device_of(address: str) -> str | None:
    """The network interface that has ``address``, or None."""
    try:
        import ifaddr

        for adapter in ifaddr.get_adapters():
            if any(ip.ip == address for ip in adapter.ips):
                return str(adapter.name)
    except Exception:  # no list of interfaces: not held, so not advertised
        pass
    return None


def _hold_to(zc: Any, device: str | None) -> bool:
    """Hold every socket of ``zc`` to ``device`` (its port 5353 is bound to every address); False where
    that cannot be done (no such device, not Linux, or zeroconf's sockets not where they were)."""
    option = getattr(socket, "SO_BINDTODEVICE", None)
    engine = getattr(zc, "engine", None)
    transports = [*getattr(engine, "readers", ()), *getattr(engine, "senders", ())]
    socks = {getattr(t, "sock", None) for t in transports}
    if device is None or option is None or not socks or None in socks:
        return False
    try:
        for s in socks:
            s.setsockopt(socket.SOL_SOCKET, option, device.encode())
    except OSError:
        return False
    return True


def _interface_addresses() -> list[str]:
    """This machine's IPv4 addresses off loopback (for the advertisement of a server on every one)."""
    try:
        import ifaddr

        found = [
            ip.ip
            for adapter in ifaddr.get_adapters()
            for ip in adapter.ips
            if isinstance(ip.ip, str) and not ip.ip.startswith("127.")
        ]
    except Exception:  # no list of interfaces: the machine's name
        found = []
    return found or [socket.gethostbyname(socket.gethostname())]
