"""What the OSC senders share (``osc_out``, ``osc_send``, ``osc_body``): destinations, and a non-blocking
UDP socket for each, refusals and losses counted and said once."""

from __future__ import annotations

import errno
import ipaddress
import logging
import socket
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from pointat.devices.osc_wire import encode_bundle, udp_port
from pointat.errors import worth_reporting
from pointat.node import Node
from pointat.runtime import Timer

log = logging.getLogger("pointat.osc")

_LOOPBACK_NAMES = ("localhost",)


def is_loopback(host: str) -> bool:
    if host in _LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def _is_ip(host: str) -> bool:
    """True for an IPv4 address literal (and localhost): no name lookup needed."""
    if host in _LOOPBACK_NAMES:
        return True
    try:
        ipaddress.IPv4Address(host)
    except ValueError:
        return False
    return True


def destinations(host: str, port: int, extra: Sequence[Any]) -> list[tuple[str, int]]:
    """The (host, port) pairs to send to: ``host:port`` first, then each ``to`` item (``host:port`` or a
    bare port on ``host``).

    >>> destinations("127.0.0.1", 4001, ["10.0.0.2:9000", 9001])
    [('127.0.0.1', 4001), ('10.0.0.2', 9000), ('127.0.0.1', 9001)]
    """
    if not host:
        raise ValueError("host is empty")
    out = [(host, udp_port(port))]
    for item in extra:
        if isinstance(item, int) and not isinstance(item, bool):
            out.append((host, udp_port(item, f"to {item!r}: port")))
            continue
        h, colon, p = str(item).rpartition(":")
        if not colon or not h:
            raise ValueError(f"to {item!r}: expected host:port or a port number")
        out.append((h, udp_port(p, f"to {item!r}: port")))
    return out


@dataclass
class Destination:
    """One receiver: its socket (connected once the address resolves) and its counters."""

    host: str
    port: int
    sock: socket.socket | None = None
    connected: bool = False
    refused: int = 0
    failed: int = 0
    warned: bool = False
    outage: int = 0  # datagrams refused since the receiver last answered
    clean: int = 0  # sends in a row without a refusal, during an outage
    last_refused: float = 0.0  # monotonic time of the last refusal

    #: A receiver is back after this many sends in a row without a refusal, the last refusal this many
    #: seconds ago: loopback reports a refusal on the send after each datagram nobody took, another host
    #: (its ICMP rate limit) about once a second.
    BACK_AFTER = 10
    BACK_QUIET = 3.0

    @property
    def label(self) -> str:
        return f"{self.host}:{self.port}"


class UdpSender(Node):
    """What ``osc_out`` and ``osc_body`` share: one non-blocking UDP socket for each destination, names
    resolved off the scheduler thread, datagrams sent when the pass ends, refusals and losses counted and
    said once.  A subclass sets ``dests`` (:class:`Destination`), ``_outbox`` (``[]``), ``_timer``
    (``None``) and the counters ``sent``, ``failed``, ``refused`` in its ``setup``."""

    role = "output"
    _timer: Timer | None = None

    def start(self) -> None:
        unresolved = []
        for d in self.dests:
            d.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            d.sock.setblocking(False)
            d.sock.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)
            if not _is_ip(d.host) or not self._connect(d):
                unresolved.append(d)
        if unresolved:  # name lookups can block for seconds: never on the scheduler thread
            self.spawn(lambda: self._retry(unresolved), "resolve")

    def _connect(self, d: Destination) -> bool:
        """Resolve and connect (the system then reports ECONNREFUSED when nobody listens on loopback)."""
        try:
            info = socket.getaddrinfo(d.host, d.port, socket.AF_INET, socket.SOCK_DGRAM)
            if d.sock is None:
                return False
            d.sock.connect(info[0][4])
        except OSError as exc:
            if not d.warned:
                d.warned = True
                log.warning(
                    "%s '%s': cannot reach %s (%s); retrying every 2 s",
                    self.type_name,
                    self.name,
                    d.label,
                    exc,
                )
            return False
        d.connected = True
        if d.warned:
            log.warning("%s '%s': %s reachable now", self.type_name, self.name, d.label)
        return True

    def _retry(self, pending: list[Destination]) -> None:
        stopping = self._runtime().stopping
        while True:
            pending = [d for d in pending if d.sock is not None and not self._connect(d)]
            if not pending or stopping.wait(2.0):
                return

    # inlets ------------------------------------------------------------------
    def send(self, datagrams: list[bytes]) -> None:
        """Send encoded OSC messages, as they are or as one bundle, to every destination.

        They leave when the scheduler's pass is done (:meth:`Runtime.at_pass_end
        <pointat.runtime.Runtime.at_pass_end>`): right after this sample's chain when one sensor woke
        the scheduler, together with the other sensors' when a base station delivered several frames at
        once (a receiver they share is woken once, not once per sensor).  One update waits at most: a
        second one in the same pass (a backlog being worked off) sends both at once, so a long pass
        never piles datagrams up into one burst that would overflow the receiver's buffer.
        """
        if self.p.bundle:
            delay = getattr(self.p, "delay", 0.0)  # (osc_body has none)
            when = time.time() + delay / 1000.0 if delay > 0 else None
            datagrams = [encode_bundle(datagrams, when)]
        rt = self.rt
        if self._outbox or rt is None:
            self._outbox += datagrams
            self._send_queued()
        else:
            self._outbox = list(datagrams)
            rt.at_pass_end(self, self._send_queued)

    def _send_queued(self) -> None:
        datagrams, self._outbox = self._outbox, []
        for d in self.dests:
            for dgram in datagrams:
                self._send_one(d, dgram)

    def _send_one(self, d: Destination, dgram: bytes, first: OSError | None = None) -> None:
        """Send one datagram, refusals and failures counted; ``first``: what a first send the caller tried
        itself raised (the compiled chains send the usual case themselves, :mod:`pointat.compiled`)."""
        if d.sock is None:
            raise RuntimeError(f"{self.type_name} is not running")
        if not d.connected:  # not resolved (yet): never look a name up on the scheduler thread
            self.failed += 1
            d.failed += 1
            return
        refused = False
        for _attempt in range(2):
            try:
                if first is not None:
                    exc, first = first, None
                    raise exc
                d.sock.send(dgram)
                self.sent += 1
                if d.outage and not refused:
                    d.clean += 1
                    if d.clean >= d.BACK_AFTER and time.monotonic() - d.last_refused >= d.BACK_QUIET:
                        log.warning(
                            "%s '%s': %s is listening again (%d datagram%s refused meanwhile)",
                            self.type_name,
                            self.name,
                            d.label,
                            d.outage,
                            "s" if d.outage > 1 else "",
                        )
                        d.outage = d.clean = 0
                return
            except ConnectionRefusedError:
                # an earlier datagram found nobody listening; the error is now cleared: try this one again
                refused = True
                self.refused += 1
                d.refused += 1
                d.outage += 1
                d.clean, d.last_refused = 0, time.monotonic()
                if worth_reporting(d.outage, first=1):
                    log.warning(
                        "%s '%s': nobody listening at %s (%d datagram%s refused); sending on",
                        self.type_name,
                        self.name,
                        d.label,
                        d.outage,
                        "s" if d.outage > 1 else "",
                    )
            except OSError as exc:  # buffer full (EAGAIN), no route: drop, count, go on
                self.failed += 1
                d.failed += 1
                if worth_reporting(d.failed, first=1):
                    log.warning(
                        "%s '%s': cannot send to %s (%s); %d datagrams dropped so far",
                        self.type_name,
                        self.name,
                        d.label,
                        errno.errorcode.get(exc.errno or 0, "") or exc,
                        d.failed,
                    )
                return
        self.failed += 1
        d.failed += 1

    def close(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        if self._outbox and all(d.sock is not None for d in self.dests):
            self._send_queued()  # a pass cut short: what was encoded still goes
        for d in self.dests:
            if d.sock is not None:
                d.sock.close()
                d.sock = None
                d.connected = False
