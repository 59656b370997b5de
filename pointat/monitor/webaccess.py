"""Who may use the monitor's port: the peers, the ``Host`` and ``Origin`` a request names, and the token a
stage tablet carries; and a log that tells a flood in a few lines.

A request is refused (403) when

* its peer is neither this machine (loopback) nor in the allow-list (``--monitor-allow``, addresses or
  networks as ``osc_in``'s ``allow``);
* its ``Host`` is not a name or address this server answers to (``127.0.0.1``, ``localhost``, ``[::1]``
  on loopback; the bound address, the machine's names and its interfaces' addresses when bound wider),
  on the port served: a page of another site that a DNS rebinding points at 127.0.0.1 names its own host;
* it carries an ``Origin`` (a browser does, on every WebSocket and cross-site request) that is not the
  page's own (``http://`` one of those names and the port): another site's page open in the same
  browser cannot open the socket that drives the show (cross-site WebSocket hijacking);
* it comes from another machine, asks for the monitor page or carries an ``Origin`` (a browser), and
  has no token: ``?token=`` in the printed URL, kept by the page as a cookie for its own requests.  An
  OSCQuery tool on an allowed machine (no ``Origin``) reads the tree without one, as it sends OSC to the
  allowed UDP port without one.

>>> a = Access("127.0.0.1", 9002)
>>> a.refusal("127.0.0.1", "127.0.0.1:9002", None, "") is None
True
>>> a.refusal("127.0.0.1", "evil.example:9002", None, "")
"Host 'evil.example:9002' is not this server (127.0.0.1, [::1], localhost on port 9002)"
>>> a.refusal("127.0.0.1", "localhost:9002", "http://evil.example", "")
"Origin 'http://evil.example' is not the monitor page's own"
"""

from __future__ import annotations

import hmac
import ipaddress
import logging
import secrets
import socket
import time
from collections.abc import Callable, Iterable, Sequence
from http.cookies import CookieError, SimpleCookie
from typing import Any
from urllib.parse import parse_qs, urlsplit

__all__ = ["Access", "LogLimit", "allowed_networks", "is_loopback"]

#: The names of this machine on loopback, as a ``Host`` header gives them.
LOOPBACK_NAMES = ("127.0.0.1", "localhost", "::1")


def is_loopback(host: str) -> bool:
    """Whether ``host`` (an address or ``localhost``) is this machine only."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def _wildcard(host: str) -> bool:
    return host in ("", "0.0.0.0", "::")


def allowed_networks(allow: Iterable[str]) -> list[ipaddress.IPv4Network | ipaddress.IPv6Network]:
    """The networks of an allow-list (``192.168.1.20``, ``192.168.1.0/24``); ValueError naming a bad one."""
    nets = []
    for item in allow:
        try:
            nets.append(ipaddress.ip_network(str(item).strip(), strict=False))
        except ValueError:
            raise ValueError(
                f"--monitor-allow: {item!r} is not an IP address or network (such as 192.168.1.20)"
            ) from None
    return nets


def _machine_names(host: str) -> set[str]:
    """The names and addresses a browser on the stage's network may use for this machine bound at
    ``host`` (every interface's address when bound to all)."""
    names = {host} if not _wildcard(host) else set()
    try:
        machine = socket.gethostname()
        names |= {machine, f"{machine}.local", socket.getfqdn()}
    except OSError:  # no name: the addresses still serve
        pass
    if _wildcard(host):
        try:
            import ifaddr  # zeroconf's own dependency

            for adapter in ifaddr.get_adapters():
                for ip in adapter.ips:
                    names.add(ip.ip if isinstance(ip.ip, str) else ip.ip[0])
        except Exception as exc:  # no list of interfaces: the machine's names still serve
            logging.getLogger("pointat.monitor").info("monitor: the interfaces' addresses unknown: %s", exc)
    return {n.lower().split("%")[0] for n in names if n}


class Access:
    """The rules of one server bound at ``host``:``port`` (see the module's head).

    ``allow``: the peers heard besides this machine (required when ``host`` is not loopback); ``token``:
    the secret a browser from another machine must carry (made up when the server is bound wider and
    none is given; None on loopback).
    """

    #: The cookie a page from another machine keeps its token in (one per port).
    COOKIE = "pointat_token_{port}"

    def __init__(
        self,
        host: str,
        port: int,
        *,
        allow: Sequence[str] = (),
        token: str | None = None,
    ):
        self.host = host
        self.port = port
        self.loopback = is_loopback(host)
        self.networks = allowed_networks(allow)
        if not self.loopback and not self.networks:
            raise ValueError(
                f"--monitor-host {host}: serving beyond this machine needs an allow-list of the machines "
                "that may connect: --monitor-allow 192.168.1.20 (addresses or networks, comma-separated)"
            )
        self.token = None if self.loopback else (token or secrets.token_urlsafe(12))
        names = set(LOOPBACK_NAMES)
        if not self.loopback:
            names = (names if _wildcard(host) else set()) | _machine_names(host)
        self.names = frozenset(names)
        self.cookie = self.COOKIE.format(port=port)

    def _named(self) -> str:
        shown = sorted(f"[{n}]" if ":" in n else n for n in self.names)
        return ", ".join(shown[:8]) + (", ..." if len(shown) > 8 else "") + f" on port {self.port}"

    def _ours(self, netloc: str) -> bool:
        """Whether ``host[:port]`` names this server."""
        try:
            parts = urlsplit("//" + netloc)
            port = parts.port
            name = parts.hostname
        except ValueError:
            return False
        if name is None or (port if port is not None else 80) != self.port:
            return False
        return name.lower() in self.names

    def peer_allowed(self, peer: str) -> bool:
        """Whether a connection from ``peer`` (an IP address) may be served at all."""
        try:
            ip = ipaddress.ip_address(peer.split("%")[0])
        except ValueError:
            return False
        if ip.is_loopback:
            return True
        if isinstance(ip, ipaddress.IPv6Address) and ip.ipv4_mapped is not None:
            ip = ip.ipv4_mapped
            if ip.is_loopback:
                return True
        return any(ip in net for net in self.networks)

    def token_in(self, query: str, cookie_header: str | None) -> bool:
        """Whether the request's ``?token=`` or its cookie carries the token."""
        if self.token is None:
            return True
        given = parse_qs(query).get("token", [])
        if cookie_header:
            try:
                morsel = SimpleCookie(cookie_header).get(self.cookie)
            except CookieError:
                morsel = None
            if morsel is not None:
                given.append(morsel.value)
        return any(hmac.compare_digest(g.encode(), self.token.encode()) for g in given)

    def refusal(
        self,
        peer: str,
        host_header: str | None,
        origin: str | None,
        path: str,
        cookie_header: str | None = None,
    ) -> str | None:
        """Why a request must be refused (403), or None to serve it.  ``path`` is the request target."""
        if not self.peer_allowed(peer):
            return f"peer {peer} is not in --monitor-allow"
        if host_header is None or not self._ours(host_header.strip()):
            return f"Host {host_header!r} is not this server ({self._named()})"
        if origin is not None and not self._ours_origin(origin):
            return f"Origin {origin[:100]!r} is not the monitor page's own"
        if self.token is not None and not is_loopback(peer.split("%")[0]):
            url = urlsplit(path)
            if (origin is not None or url.path.startswith("/monitor")) and not self.token_in(
                url.query, cookie_header
            ):
                return "no token: open the URL pointat run printed (with its ?token=)"
        return None

    def _ours_origin(self, origin: str) -> bool:
        try:
            parts = urlsplit(origin.strip())
        except ValueError:
            return False
        if parts.scheme != "http" or parts.path not in ("", "/") or parts.query or parts.username:
            return False
        return self._ours(parts.netloc)

    def set_cookie(self, query: str) -> str | None:
        """A ``Set-Cookie`` value for a page fetched with the right ``?token=`` (else None)."""
        if self.token is None or not parse_qs(query).get("token"):
            return None
        if not self.token_in(query, None):
            return None
        return f"{self.cookie}={self.token}; Path=/; HttpOnly; SameSite=Strict"

    def url(self, path: str = "/monitor") -> str:
        """The address to open (with the token when one is needed)."""
        host = self.host
        if _wildcard(host):
            host = _lan_address() or "127.0.0.1"
        if ":" in host:
            host = f"[{host}]"
        query = f"?token={self.token}" if self.token else ""
        return f"http://{host}:{self.port}{path}{query}"


def _lan_address() -> str | None:
    """This machine's address on the default route's network (no packet is sent), or None."""
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        s.connect(("192.0.2.1", 9))  # TEST-NET-1: connect() only picks the interface
        address = s.getsockname()[0]
    except OSError:
        return None
    finally:
        s.close()
    return None if address.startswith(("0.", "127.")) else address


class LogLimit:
    """A log of one kind of event that stays a few lines however often the event comes: at most
    ``burst`` lines in each ``period`` seconds; the ones held back are counted and the count is told with
    the next line that is let through.

    >>> lines = []
    >>> limit = LogLimit(lambda msg, *a: lines.append(msg % a), burst=2, period=10.0, clock=lambda: 0.0)
    >>> for i in range(5):
    ...     limit("client %d left", i)
    >>> lines
    ['client 0 left', 'client 1 left']
    >>> limit.held
    3
    >>> limit.flush("clients left")
    >>> lines[-1]
    '3 more clients left, not logged one by one'
    """

    def __init__(
        self,
        emit: Callable[..., Any],
        *,
        burst: int = 5,
        period: float = 10.0,
        clock: Callable[[], float] = time.monotonic,
    ):
        self.emit = emit
        self.burst = burst
        self.period = period
        self.clock = clock
        self._start = -float("inf")
        self._told = 0
        self.held = 0  # lines held back since the last one told
        self.count = 0  # events in all

    def __call__(self, msg: str, *args: Any) -> None:
        self.count += 1
        now = self.clock()
        if now - self._start >= self.period:
            self._start, self._told = now, 0
        if self._told >= self.burst:
            self.held += 1
            return
        self._told += 1
        if self.held:
            msg += f" (and {self.held} more like it before, not logged one by one)"
            self.held = 0
        self.emit(msg, *args)

    def flush(self, what: str) -> None:
        """Tell how many were held back since the last line (at the end: none goes untold)."""
        if self.held:
            self.emit("%d more %s, not logged one by one", self.held, what)
            self.held = 0
