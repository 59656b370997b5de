"""``osc_out`` and ``osc_in``: pointat's doors to spatial-sound systems, DAWs and OSC sensors."""

from __future__ import annotations

import logging
import math
import socket
import time
from typing import Any

from pythonosc.osc_bundle_builder import IMMEDIATELY, OscBundleBuilder
from pythonosc.osc_message_builder import OscMessageBuilder
from pythonosc.osc_packet import OscPacket, ParseError

from pointat.message import Message, as_float, make, method, vector
from pointat.node import Inlet, Node, Outlet, Param
from pointat.registry import register

from .profiles import FIELDS, PROFILES, Source

log = logging.getLogger("pointat.osc")


def _osc_message(address: str, args: list[Any]) -> bytes:
    b = OscMessageBuilder(address)
    for a in args:
        if isinstance(a, bool):
            b.add_arg(a)
        elif isinstance(a, int):
            b.add_arg(a, "i")
        elif isinstance(a, float):
            b.add_arg(a, "f")  # float32: Pd's oscparse rejects doubles
        else:
            b.add_arg(str(a), "s")
    return b.build().dgram


def _destinations(host: str, port: int, extra: tuple) -> list[tuple[str, int]]:
    out = [(host, port)]
    for item in extra:
        h, _, p = str(item).rpartition(":")
        if not h or not p.isdigit():
            raise ValueError(f"destination {item!r}: expected host:port")
        out.append((h, int(p)))
    return out


@register("osc_out")
class OscOut(Node):
    """Send a source's direction over OSC (UDP) in the convention of the chosen receiver ``profile``.

    Profiles: pointat, vbap (Pd/Max), adm (ADM-OSC), iem_stereo, iem_multi, spat, icst, reaper, generic
    (see ``osc_bridge.profiles``).  The azimuth inlet is hot; elevation, distance and spread are stored.
    Arguments are float32.  ``bundle=true`` sends each update as one bundle, time-tagged now + ``delay``
    ms for receivers that schedule.  ``rate`` limits updates per second and ``deadband`` drops updates that
    moved less than that many degrees.  Sending never blocks and never fails the patch: an absent
    receiver is counted and logged once.
    """

    inlets = (
        Inlet("azimuth", ("float", "int", "list"), "degrees, + left (or a list: azimuth elevation distance)"),
        Inlet("elevation", ("float", "int"), "degrees, + up"),
        Inlet("distance", ("float", "int"), "0 far .. 90 near (the roll gesture)"),
        Inlet("spread", ("float", "int"), "source spread 0..100 (vbap)"),
    )
    params = (
        Param("profile", "symbol", "pointat", "the receiver", choices=tuple(PROFILES)),
        Param("host", "symbol", "127.0.0.1", "receiver address"),
        Param("port", "int", 0, "receiver UDP port (0: the profile's default)"),
        Param("to", "list", (), "more destinations, host:port each"),
        Param("source", "int", 0, "source / object number (0: the profile's first)", live=True),
        Param("address", "symbol", "/pointat/azimuth", "generic profile: the address"),
        Param("fields", "list", ("az", "el"), f"generic profile: the arguments, from: {' '.join(FIELDS)}"),
        Param("bundle", "bool", False, "send each update as one bundle"),
        Param("delay", "float", 0.0, "bundle time tag = now + delay", unit="ms", live=True),
        Param("rate", "float", 0.0, "at most this many updates per second (0: all)", unit="Hz", live=True),
        Param("deadband", "float", 0.0, "skip updates that moved less than this", unit="deg", live=True),
    )
    example = """
node dir azi_ele
node out osc_out profile=adm port=4001 source=1
dir.elevation -> out.elevation
dir.azimuth -> out.azimuth
"""

    def setup(self) -> None:
        self.profile = PROFILES[self.p.profile]
        for f in self.p.fields:
            if f not in FIELDS:
                raise ValueError(f"unknown field '{f}' (fields: {' '.join(FIELDS)})")
        self.targets = _destinations(self.p.host, self.p.port or self.profile.port, self.p.to)
        self._sock: socket.socket | None = None
        self._el = self._dist = self._spread = 0.0
        self._last: tuple[float, float, float] | None = None
        self._last_sent = -math.inf
        self.sent = 0
        self.failed = 0

    def start(self) -> None:
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._sock.setblocking(False)

    def on_elevation(self, msg: Message) -> None:
        self._el = as_float(msg)

    def on_distance(self, msg: Message) -> None:
        self._dist = as_float(msg)

    def on_spread(self, msg: Message) -> None:
        self._spread = as_float(msg)

    def on_azimuth(self, msg: Message) -> None:
        if msg.kind == "list":
            values = [float(v) for v in msg.value]
            az = values[0]
            if len(values) > 1:
                self._el = values[1]
            if len(values) > 2:
                self._dist = values[2]
        else:
            az = as_float(msg)
        if not all(math.isfinite(v) for v in (az, self._el, self._dist)):
            raise ValueError("not sent: NaN or infinite value")
        now = time.monotonic()
        if self.p.rate > 0 and now - self._last_sent < 1.0 / self.p.rate:
            return
        state = (az, self._el, self._dist)
        if self._last is not None and self.p.deadband > 0:
            moved = max(
                abs((az - self._last[0] + 180.0) % 360.0 - 180.0),
                abs(self._el - self._last[1]),
                abs(self._dist - self._last[2]),
            )
            if moved < self.p.deadband:
                return
        self._last, self._last_sent = state, now
        n = self.p.source or self.profile.first
        src = Source(n, az, self._el, self._dist, self._spread)
        self.send(self.profile.render(src, self.p.address, tuple(self.p.fields)))

    def send(self, messages: list[tuple[str, list]]) -> None:
        """Send (address, args) pairs, as messages or one bundle, to every destination."""
        if self.p.bundle:
            stamp = IMMEDIATELY if self.p.delay <= 0 else time.time() + self.p.delay / 1000.0
            b = OscBundleBuilder(stamp)
            for address, args in messages:
                b.add_content(_osc_build(address, args))
            datagrams = [b.build().dgram]
        else:
            datagrams = [_osc_message(address, args) for address, args in messages]
        if self._sock is None:
            raise RuntimeError("osc_out is not running")
        for target in self.targets:
            for dgram in datagrams:
                try:
                    self._sock.sendto(dgram, target)
                    self.sent += 1
                except OSError as exc:  # refused (no receiver yet), buffer full: never stop the patch
                    self.failed += 1
                    if self.failed == 1 or self.failed % 1000 == 0:
                        log.warning(
                            "osc_out '%s': cannot send to %s:%d (%s); %d not sent so far",
                            self.name,
                            target[0],
                            target[1],
                            exc.strerror or exc,
                            self.failed,
                        )

    def close(self) -> None:
        if self._sock is not None:
            self._sock.close()
            self._sock = None


def _osc_build(address: str, args: list[Any]):
    from pythonosc.osc_message import OscMessage

    return OscMessage(_osc_message(address, args))


_LOOPBACK = ("127.0.0.1", "::1", "localhost")
G = 9.80665


@register("osc_in")
class OscIn(Node):
    """Receive OSC: IMU data from phones and OSC sensors, and live control of the patch.

    Listens on ``host`` (127.0.0.1 by default; another address only when asked, then only senders in
    ``allow`` are heard).  Sensor formats (``device``): ``ngimu`` (``/sensors`` gyro deg/s, accel g,
    mag uT; ``/quaternion`` w x y z), ``zigsim`` (``/ID/quaternion`` x y z w, ``/ID/gyro``,
    ``/ID/accel`` in g), or ``none``.  Whatever the format, ``/pointat/NODE/PARAM value`` sets a live
    parameter and ``/pointat/NODE/METHOD args`` sends a method (recalibrate, set...) to that node.  Every
    other message leaves by ``any`` as a method message named by its address, for ``route``.  Bundle time
    tags are read, never waited for (a device clock ahead of ours must not stall anything).  Malformed
    packets are counted and dropped.
    """

    outlets = (
        Outlet("gyro", "vector", "angular rate, rad/s"),
        Outlet("accel", "vector", "specific force, m/s²"),
        Outlet("mag", "vector", "magnetic field, as sent (uT for NGIMU)"),
        Outlet("quat", "vector", "orientation quaternion (w, x, y, z), as the device sends it"),
        Outlet("any", "any", "every other message: selector = address, then the arguments"),
    )
    params = (
        Param("port", "int", 9001, "UDP port to listen on"),
        Param("host", "symbol", "127.0.0.1", "address to listen on (0.0.0.0: every interface)"),
        Param("allow", "list", (), "senders heard when host is not loopback (IP addresses)"),
        Param("device", "symbol", "none", "sensor format", choices=("none", "ngimu", "zigsim")),
        Param("control", "bool", True, "accept /pointat/NODE/PARAM control messages"),
    )

    def setup(self) -> None:
        self.malformed = 0
        self.refused = 0
        self.received = 0
        self._sock: socket.socket | None = None
        if self.p.host not in _LOOPBACK and not self.p.allow:
            raise ValueError(f"listening on {self.p.host} needs allow=[...] senders (an allow-list)")

    def start(self) -> None:
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._sock.bind((self.p.host, self.p.port))
        self._sock.settimeout(0.1)
        self.active = True
        self.spawn(self._listen, "listen")

    @property
    def address(self) -> tuple[str, int]:
        """Where it listens (the real port when ``port=0``)."""
        return self._sock.getsockname() if self._sock is not None else (self.p.host, self.p.port)

    def _listen(self) -> None:
        stopping = self._runtime().stopping
        allow = {str(a) for a in self.p.allow}
        while not stopping.is_set() and self._sock is not None:
            try:
                data, sender = self._sock.recvfrom(65536)
            except TimeoutError:
                continue
            except OSError:
                return
            if self.p.host not in _LOOPBACK and sender[0] not in allow:
                self.refused += 1
                continue
            try:
                packet = OscPacket(data)
            except (ParseError, ValueError, IndexError, TypeError) as exc:
                self.malformed += 1
                if self.malformed <= 3:
                    log.warning(
                        "osc_in '%s': malformed packet from %s dropped (%s)", self.name, sender[0], exc
                    )
                continue
            for timed in packet.messages:
                self.post(self._handle, timed.message.address, list(timed.message.params), block=False)

    def _handle(self, address: str, args: list[Any]) -> None:
        self.received += 1
        self.time = self.now
        if self.p.control and address.startswith("/pointat/"):
            parts = address.split("/")
            if len(parts) == 4:
                self._runtime().send(parts[2], parts[3], *args)
                return
        if self.p.device == "ngimu" and address == "/sensors" and len(args) >= 9:
            g = [float(v) for v in args[:9]]
            self.out(2, vector(g[6:9]))
            self.out(1, vector([a * G for a in g[3:6]]))
            self.out(0, vector([math.radians(w) for w in g[0:3]]))
            return
        if self.p.device == "ngimu" and address == "/quaternion" and len(args) == 4:
            self.out(3, vector([float(v) for v in args]))
            return
        if self.p.device == "zigsim":
            leaf = address.rsplit("/", 1)[-1]
            if leaf == "quaternion" and len(args) == 4:
                x, y, z, w = (float(v) for v in args)
                self.out(3, vector([w, x, y, z]))
                return
            if leaf in ("gyro", "accel") and len(args) == 3:
                v = [float(a) for a in args]
                self.out(0, vector(v)) if leaf == "gyro" else self.out(1, vector([a * G for a in v]))
                return
        self.out(4, method(address, *args) if address not in ("bang",) else make(None))

    def close(self) -> None:
        self.active = False
        if self._sock is not None:
            self._sock.close()
            self._sock = None
