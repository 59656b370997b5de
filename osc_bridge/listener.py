"""``osc_in``: pointat's door in for OSC sensors (phones, NGIMU, ZIG SIM) and live control of a running patch.

OSC 1.0 over UDP (the wire format: :mod:`pointat.devices.osc_wire`).  ``osc_in`` parses packets itself,
so a bundle's time tag is read past and never waited for; a sender outside the allow-list is not heard.
"""

from __future__ import annotations

import errno
import ipaddress
import logging
import socket
import time
from collections.abc import Mapping, Sequence
from typing import Any

from pointat.control import control
from pointat.devices.osc_wire import bundle_time, decode_packet
from pointat.errors import Repeats, worth_reporting
from pointat.message import floats, method
from pointat.node import Node, Outlet, Param
from pointat.nodes.sensors import FULL_SCALE_PARAMS, RANGE_OUTLET, full_scale
from pointat.registry import register

from .profiles import SENSORS, Rule, parse_rule
from .sender import is_loopback
from .tagclock import TagClock

__all__ = ["OscIn"]

log = logging.getLogger("pointat.osc")


# --------------------------------------------------------------------------- osc_in
def _allowed_networks(allow: Sequence[Any]) -> list[ipaddress.IPv4Network | ipaddress.IPv6Network]:
    nets = []
    for item in allow:
        try:
            nets.append(ipaddress.ip_network(str(item), strict=False))
        except ValueError:
            raise ValueError(
                f"allow: {item!r} is not an IP address or network (such as 192.168.1.20)"
            ) from None
    return nets


@register("osc_in")
class OscIn(Node):
    """Receive OSC: IMU data from phones and OSC sensors, and live control of the running patch.

    Listens on 127.0.0.1 by default.  Another ``host`` (0.0.0.0: every interface) only when asked, and
    then only the senders in ``allow`` (addresses or networks) are heard; without an allow-list that is
    a load error.

    Sensors (``device``): ``ngimu`` (``/sensors``: gyro deg/s, accel g, mag uT; ``/quaternion`` w x y z),
    ``zigsim`` (``/.../quaternion`` x y z w, ``/.../gyro`` rad/s, ``/.../gravity`` g), and ``map`` for
    anything else (``map=["/imu/acc=accel*9.80665", "/imu/gyro=gyro"]``: address, outlet, optional scale;
    ``*`` in an address matches anything).  Outputs are SI: gyro rad/s, accel m/s² (+g up at rest), mag
    gauss; one message's outlets fire right to left (mag, accel, then gyro), as ``scaling`` does.  A
    message a sensor rule matches but cannot read (too few arguments, a string) is counted in
    ``malformed`` and, when no rule read it, leaves by ``any`` like any other message.

    Live control (``control=true``): ``/pointat/NODE/PARAM value`` sets a live parameter,
    ``/pointat/NODE/METHOD args`` sends a method (``/pointat/nulls/recalibrate``, ``/pointat/ref/set``),
    ``/pointat/NODE value...`` sends the values (a bang when none) to the node's left inlet; NODE may be
    inside an abstraction (``/pointat/left/ref/set``).  Every other message (pointat's own
    ``/pointat/1/aed`` too) leaves by ``any`` as a method message named by its address, for ``route``.

    Bundle time tags are never waited for (a device clock ahead of ours must not stall anything).  Every
    message is stamped with the time its packet arrived; with ``timetags=true`` a bundle's messages are
    stamped with its time tag instead, mapped onto pointat's clock for each sender (the tag plus the
    least delay seen from that sender, so never later than the arrival).  A filter then steps by the
    sender's own sample spacing when Wi-Fi delivers a few packets at once; plain messages and bundles
    tagged "immediately" keep their arrival time.
    Malformed packets are counted (``malformed``) and dropped; the patch keeps running.

    A sensor's full scale (its data sheet's ±g and ±°/s: ``acc_range``, ``gyro_range``) goes out of
    ``range`` as the patch starts; wired to ``tqt``'s ``range``, a reading stuck at the limit during a
    strike is known to be saturated rather than taken for the hand's motion.
    """

    sample_outlets = "gyro|quat"

    acts_alone = True  # live control
    role = "input"

    outlets = (
        Outlet("gyro", "vector", "angular rate, rad/s"),
        Outlet("accel", "vector", "specific force, m/s² (+g up at rest)"),
        Outlet("mag", "vector", "magnetic field, gauss"),
        Outlet("quat", "vector", "orientation quaternion (w, x, y, z), as the device defines it"),
        Outlet("any", "any", "every other message: selector = address, then the arguments"),
        RANGE_OUTLET,
    )
    params = (
        Param("port", "int", 9001, "UDP port to listen on (0: any free port)"),
        Param("host", "symbol", "127.0.0.1", "address to listen on (0.0.0.0: every interface, needs allow)"),
        Param("allow", "list", (), "senders heard (IP addresses or networks); required off loopback"),
        Param("device", "symbol", "none", "sensor format", choices=tuple(SENSORS)),
        Param("map", "list", (), "more sensor messages: /address=outlet or /address=outlet*scale"),
        Param("control", "bool", True, "accept /pointat/NODE/... control messages"),
        Param(
            "timetags",
            "bool",
            False,
            "stamp a bundle's messages with its time tag (the sender's clock, mapped onto ours) instead of "
            "their arrival: samples that Wi-Fi delivers in bursts keep their spacing",
        ),
        *FULL_SCALE_PARAMS,
    )
    example = """
node phone osc_in port=9001 device=zigsim host=0.0.0.0 allow=["192.168.1.0/24"]
node dir   azi_ele
phone.quat -> dir
"""

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        """Check host, allow-list and map (so that ``pointat check`` finds mistakes)."""
        host = str(values["host"])
        if not is_loopback(host):
            try:
                ipaddress.IPv4Address(host)
            except ValueError:
                raise ValueError(f"host {host!r}: expected an IPv4 address such as 0.0.0.0") from None
            if not values["allow"]:
                raise ValueError(
                    f"listening on {host} (not loopback) needs an allow-list of senders: "
                    'allow=["192.168.1.20"] (addresses or networks)'
                )
        _allowed_networks(values["allow"])
        if not 0 <= values["port"] <= 65535:
            raise ValueError(f"port {values['port']} is outside 0..65535")
        for item in values["map"]:
            parse_rule(item)

    def describe(self) -> str:
        p = self.p
        what = "live control" if p.device == "none" and not p.map else f"{p.device}"
        control = ": /pointat/NODE/PARAM value" if p.control else ""
        return f"OSC on {p.host}:{p.port or 'a free port'} ({what}{control})"

    def setup(self) -> None:
        self.rules: tuple[Rule, ...] = SENSORS[self.p.device] + tuple(parse_rule(m) for m in self.p.map)
        self._outlet = {name: i for i, name in enumerate(o.name for o in self.outlets)}
        self._allow = _allowed_networks(self.p.allow)
        self._routes: dict[str, tuple[tuple[int, Rule], ...]] = {}
        self._sock: socket.socket | None = None
        self.received = 0
        self.malformed = 0
        self.unreadable = 0  # sensor messages a rule matched but could not read (also in malformed)
        self.refused = 0
        self._refused_from: set[str] = set()  # the senders outside allow named in the log
        self._clocks: dict[tuple[str, int], TagClock] = {}  # timetags: each sender's clock
        self.refused_control = 0
        self._refusals = Repeats(self.REFUSED_ADDRESSES, quiet=self.REFUSED_QUIET)  # control, by address

    def start(self) -> None:
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        host = "127.0.0.1" if self.p.host == "localhost" else self.p.host
        try:
            sock.bind((host, self.p.port))
        except OSError as exc:
            sock.close()
            hint = ": another program listens there (a second pointat? Pd?); stop it or set port=..."
            raise OSError(
                f"cannot listen on UDP {host}:{self.p.port}: {exc.strerror}"
                + (hint if exc.errno == errno.EADDRINUSE else "")
            ) from exc
        sock.setblocking(False)
        self._sock = sock
        self.active = True
        self.add_reader(sock, self._readable)  # read on the scheduler thread: no hand-off

    def loadbang(self) -> None:
        full_scale(self)

    @property
    def address(self) -> tuple[str, int]:
        """Where it listens (the real port when ``port=0``)."""
        sock = self._sock
        return sock.getsockname() if sock is not None else (self.p.host, self.p.port)

    def _heard(self, sender: str) -> bool:
        if not self._allow:
            return True
        ip = ipaddress.ip_address(sender)
        return any(ip in net for net in self._allow)

    #: Datagrams read per wake-up at most, and seconds spent on them at most (a flood of 64 kB ones takes
    #: ~2 ms each to decode), so that a flood cannot starve timers and other sources.
    BURST = 64
    BUDGET = 0.005
    #: Senders outside ``allow`` named in the log (each once); after that many, refusals are only counted.
    REFUSED_NAMED = 16
    #: Addresses whose refused control is counted (and told) each on its own; more share one count.
    REFUSED_ADDRESSES = 32
    #: A refusal that comes this many seconds after the last one at its address is told whatever the
    #: count: a person trying a command again, not a flood.
    REFUSED_QUIET = 3.0

    def _readable(self) -> None:
        """Scheduler thread, the socket has data: read what is there (up to :attr:`BURST` datagrams, or
        :attr:`BUDGET` seconds)."""
        sock = self._sock
        deadline = time.perf_counter() + self.BUDGET
        for _ in range(self.BURST):
            if sock is None:
                return
            try:
                data, sender = sock.recvfrom(65536)
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:  # e.g. an ICMP error reported on the socket: drop it, go on
                log.debug("osc_in '%s': %s", self.name, exc)
                continue
            t = time.monotonic()
            if time.perf_counter() >= deadline:  # the rest on the next wake-up, after timers and sources
                sock = None
            if self.p.timetags:
                tag = bundle_time(data)
                if tag is not None:
                    t = self._tag_clock(sender).stamp(tag, t)
            if not self._heard(sender[0]):
                self.refused += 1
                if sender[0] not in self._refused_from and len(self._refused_from) < self.REFUSED_NAMED:
                    self._refused_from.add(sender[0])  # each sender once: a phone on a new address too
                    log.warning("osc_in '%s': ignoring %s (not in allow)", self.name, sender[0])
                continue
            try:
                messages = decode_packet(data)
            except Exception as exc:  # python-osc raises several kinds on garbage: count, drop, go on
                self.malformed += 1
                if worth_reporting(self.malformed):
                    log.warning(
                        "osc_in '%s': malformed packet from %s dropped (%s); %d so far",
                        self.name,
                        sender[0],
                        exc,
                        self.malformed,
                    )
                continue
            try:
                self._handle(messages, t)
            except Exception as exc:  # one bad packet never stops the listening (nor counts against it)
                self.malformed += 1
                if worth_reporting(self.malformed):
                    log.warning("osc_in '%s': packet from %s dropped: %s", self.name, sender[0], exc)

    #: Senders whose clocks are followed at most (``timetags``); more start the memory over.
    CLOCKS_KEPT = 64

    def _tag_clock(self, sender: tuple[str, int]) -> TagClock:
        """The clock of a sender (address and port: a device that restarts gets a new one)."""
        clock = self._clocks.get(sender)
        if clock is None:
            if len(self._clocks) >= self.CLOCKS_KEPT:
                self._clocks.clear()
            clock = self._clocks[sender] = TagClock()
        return clock

    def _handle(self, messages: list[tuple[str, list[Any]]], t: float) -> None:
        """Scheduler thread: route one packet's messages."""
        self.time = self._runtime().clock.from_monotonic(t)
        for address, args in messages:
            self.received += 1
            if self.p.control and address.startswith("/pointat/") and self._control(address, args):
                continue
            routes = self._routes.get(address)
            if routes is None:
                routes = self._route(address)
            outputs = []
            for outlet, rule in routes:
                try:
                    outputs.append((outlet, rule.extract(args)))
                except ValueError as exc:
                    self.malformed += 1
                    self.unreadable += 1  # its own count: bad packets before it must not silence it
                    if worth_reporting(self.unreadable):
                        log.warning(
                            "osc_in '%s': %s dropped (%s); %d so far",
                            self.name,
                            address,
                            exc,
                            self.unreadable,
                        )
            if not outputs:  # no rule, or none could read it (a wildcard map meets /imu/battery)
                self.out(4, method(address, *args))
            for outlet, values in outputs:
                self.out(outlet, floats(tuple(values), self.time))

    #: Addresses whose matching rules are remembered: a sensor sends the same few.  When a controller
    #: or a flood of junk brings more, the memory starts over, so it stays small and the addresses that
    #: keep coming are soon remembered again.
    ROUTES_KEPT = 256

    def _route(self, address: str) -> tuple[tuple[int, Rule], ...]:
        """The rules ``address`` matches, as (outlet, rule), right outlet first (Pd order)."""
        found = [(self._outlet[r.outlet], r) for r in self.rules if r.matches(address)]
        routes = tuple(sorted(found, key=lambda o: -o[0]))
        if len(self._routes) >= self.ROUTES_KEPT:
            self._routes.clear()
        self._routes[address] = routes
        return routes

    def _control(self, address: str, args: list[Any]) -> bool:
        """``/pointat/NODE/SELECTOR args``, ``/pointat/NODE args`` or ``/pointat/preset/...``
        (:func:`pointat.control.control`); False when it names no node.

        Node names never start with a digit, so pointat's own direction messages (``/pointat/1/aed``)
        are not control: they go on by ``any``.
        """
        rest = address[len("/pointat/") :]
        if not rest or rest[0].isdigit():
            return False
        why = control(self._runtime(), address, args, self.time)
        if why is not None:
            self._refuse(address, why)
        return True

    def _refuse(self, address: str, why: str) -> None:
        """A live-control message that did nothing: counted, and logged the first times at its address,
        then every 10th, 100th...: a flood of them keeps the console readable, and a typo is still told.
        One that follows :attr:`REFUSED_QUIET` seconds without any at its address is always told (the
        fourth ``turn_end`` of a calibration, refused, must not pass in silence)."""
        self.refused_control += 1
        # counted per address: a stray fader must not silence a typo; made-up addresses share one count
        n, tell = self._refusals.add(address, "")
        if tell:
            log.warning(
                "osc_in '%s' (port %d): %s refused: %s%s",
                self.name,
                self.address[1],
                address[:80],
                why[:200],
                f" ({n} refused at this address so far)" if n > 3 else "",
            )

    def close(self) -> None:
        self.active = False
        sock, self._sock = self._sock, None
        if sock is not None:
            self.remove_reader(sock)
            sock.close()
