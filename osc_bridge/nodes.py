r"""``osc_out`` and ``osc_in``: pointat's doors to spatial-sound systems, DAWs and OSC sensors.

Both speak OSC 1.0 over UDP (the wire format: :mod:`pointat.devices.osc_wire`).  ``osc_out`` encodes every
number as float32 (``f``) and every index as int32 (``i``): Pd's ``[oscparse]`` rejects 64-bit doubles.
Its sockets are non-blocking, so a full buffer or an absent receiver costs a counted, dropped datagram and
never a stalled scheduler.  ``osc_in`` parses packets itself, so a bundle's time tag is read past and never
waited for.
"""

from __future__ import annotations

import errno
import ipaddress
import logging
import math
import socket
import struct
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from pointat.control import control
from pointat.devices.osc_wire import (
    F32_MAX,
    _fit,
    _padded,
    bundle_time,
    decode_packet,
    encode_bundle,
    encode_message,
    udp_port,
)
from pointat.errors import Repeats, worth_reporting
from pointat.message import Message, as_float, floats, method
from pointat.node import FULL_SCALE_PARAMS, RANGE_OUTLET, Inlet, Node, Outlet, Param, full_scale
from pointat.registry import register
from pointat.runtime import Timer

from .profiles import FIELDS, PROFILES, SENSORS, Profile, Rule, Source, check_fields, parse_rule

__all__ = ["OscIn", "OscOut", "OscSend", "UpdateEncoder", "destinations"]

log = logging.getLogger("pointat.osc")

#: The lowest ``osc_out rate`` but 0: one update every 100 s.
MIN_RATE = 0.01


# --------------------------------------------------------------------------- encoding an update
class UpdateEncoder:
    """The OSC messages of one update, their addresses and type tags encoded once (:meth:`Profile.compile`):
    per update only the numbers are packed.  The same bytes as :func:`encode_message` of
    :meth:`Profile.render`.

    >>> from pointat.devices.osc_wire import encode_message
    >>> enc = UpdateEncoder(PROFILES["adm"], 3)
    >>> enc.encode(Source(3, az=30.0)) == [encode_message("/adm/obj/3/aed", [30.0, 0.0, 1.0])]
    True
    """

    def __init__(self, profile: Profile, n: int, messages: Sequence[tuple[str, Sequence[Any]]] | None = None):
        self.parts = tuple(
            (_padded(address) + _padded("," + tags), getters, struct.Struct(">" + tags).pack)
            for address, tags, getters in profile.compile(n, messages)
        )

    def encode(self, source: Source) -> list[bytes]:
        try:
            return [head + pack(*[g(source) for g in getters]) for head, getters, pack in self.parts]
        except (struct.error, OverflowError):  # a number beyond float32 / int32: the nearest that fits
            return [head + pack(*[_fit(g(source)) for g in getters]) for head, getters, pack in self.parts]


class TagClock:
    """One sender's bundle time tags (its own clock) mapped onto our ``time.monotonic()``.

    A tag plus the least *lag* seen (arrival - tag: the clocks' offset and the quickest delivery) is
    when the sample was taken, as near as we can tell, and never later than it arrived: samples that
    Wi-Fi delivers in a burst keep the spacing the sender gave them.  The least lag may creep up by
    :attr:`CREEP` (a sender's clock slower than ours by up to 100 ppm), and starts over when every lag
    for :attr:`JUMP` seconds has been more than :attr:`JUMP` above it (the sender's clock was set back).

    >>> c = TagClock()
    >>> [round(c.stamp(tag, arrival), 3) for tag, arrival in [(10.00, 5.003), (10.01, 5.030), (10.02, 5.030)]]
    [5.003, 5.013, 5.023]
    """

    CREEP = 1e-4
    JUMP = 1.0

    def __init__(self) -> None:
        self.lag: float | None = None
        self._at = 0.0
        self._over: tuple[float, float] | None = None  # since when, and the least lag since, lags above

    def stamp(self, tag: float, arrival: float) -> float:
        """When a packet time-tagged ``tag`` (seconds) that arrived at ``arrival`` (monotonic) was sent."""
        lag = arrival - tag
        if self.lag is None or lag <= self.lag:
            self.lag, self._over = lag, None
        else:
            self.lag = min(lag, self.lag + self.CREEP * max(0.0, arrival - self._at))
            if lag - self.lag <= self.JUMP:
                self._over = None
            elif self._over is None:
                self._over = (arrival, lag)
            elif arrival - self._over[0] < self.JUMP:
                self._over = (self._over[0], min(self._over[1], lag))
            else:  # late by more than a second for a second: the sender's clock was set back
                self.lag, self._over = min(self._over[1], lag), None
        self._at = arrival
        return tag + self.lag


# --------------------------------------------------------------------------- helpers
_LOOPBACK_NAMES = ("localhost",)


def _is_loopback(host: str) -> bool:
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
class _Destination:
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
    said once.  A subclass sets ``dests`` (:class:`_Destination`), ``_outbox`` (``[]``), ``_timer``
    (``None``) and the counters ``sent``, ``failed``, ``refused`` in its ``setup``."""

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

    def _connect(self, d: _Destination) -> bool:
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

    def _retry(self, pending: list[_Destination]) -> None:
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

    def _send_one(self, d: _Destination, dgram: bytes, first: OSError | None = None) -> None:
        """Send one datagram, refusals and failures counted; ``first``: what a first send the caller tried
        itself raised (the compiled chains send the usual case themselves, :mod:`pointat.fusion`)."""
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


# --------------------------------------------------------------------------- osc_out
@register("osc_out")
class OscOut(UdpSender):
    """Send a source's direction over OSC (UDP) in the convention of the chosen receiver ``profile``.

    Profiles (``osc_bridge.profiles``): ``pointat`` (/pointat/N/aed: az el and distance 0..1, 1 far, 0
    near, as ADM-OSC's), ``vbap`` (Pd/Max: /vbap/N az el spread), ``adm`` (ADM-OSC /adm/obj/N/aed,
    port 4001, objects from 1), ``iem_stereo`` and
    ``iem_multi`` (IEM encoders; MultiEncoder inputs from 0), ``spat`` (SPAT Revolution, + right,
    metres), ``icst`` (AmbiEncoder xyz), ``reaper`` (track pan 0..1), ``generic`` (``address`` and
    ``fields``).  Switching receivers is one parameter; ``port=0`` takes the profile's usual port.

    The azimuth inlet is hot (a bang resends the current direction); elevation, distance and spread are
    stored.  Numbers go out as float32, indices as int32.  One update is one message per address, or one
    bundle (``bundle=true``) time-tagged "immediately", or now + ``delay`` ms for receivers that
    schedule.  ``rate`` caps updates per second (the latest held one follows, so the receiver always
    ends where the hand stopped); ``change=true`` or a ``deadband`` skips updates that moved no more
    than ``deadband`` degrees.  ``to`` adds destinations.  Datagrams leave when the scheduler has run
    everything that arrived together: right after a glove's sample, in one burst for all the gloves of
    a base station's delivery (a receiver they share is woken once); an ``osc_out`` holds one update
    back at most.  Sending never blocks and never stops the
    patch: an absent receiver (ECONNREFUSED) is counted (``refused``) and logged at the 1st, 10th,
    100th... datagram of each outage, and when it listens again; datagrams the system would not take
    are counted in ``failed``.

    The receiver is also told how the glove is: ``/pointat/N/status STATE RATE`` every ``status`` seconds
    and at once when the state changes: ``waiting`` (no direction yet), ``ok``, ``dropout`` (no direction
    in for ``dropout`` seconds: what ``rate`` or a deadband hold back is no dropout), or the filter's flag from the ``flags`` inlet (wire ``tqt.flags`` there):
    ``mag_disturbed``, ``acc_saturated``, ``gyro_saturated``, ``shaking``.  RATE is the updates sent per
    second since the last status.  On for the pointat, vbap and generic profiles; ``status=1`` turns it
    on for the others, ``status=0`` off.
    """

    needs_input = True

    inlets = (
        Inlet("azimuth", ("float", "int", "list", "bang"), "degrees, + left (or a list: az el dist spread)"),
        Inlet("elevation", ("float", "int"), "degrees, + up"),
        Inlet("distance", ("float", "int"), "0 far .. 90 near (the roll gesture)"),
        Inlet("spread", ("float", "int"), "source spread 0..100 (vbap)"),
        Inlet("flags", ("symbol",), "the filter's flags (tqt's flags outlet): told in the status"),
    )
    params = (
        Param("profile", "symbol", "pointat", "the receiver", choices=tuple(PROFILES)),
        Param("host", "symbol", "127.0.0.1", "receiver address (name or IP)"),
        Param("port", "int", 0, "receiver UDP port (0: the profile's usual port)"),
        Param("to", "list", (), "more destinations: host:port, or a port on the same host"),
        Param(
            "source",
            "int",
            0,
            "source / object / track / input number (0: the profile's first)",
            live=True,
            maximum=2**31 - 1,  # an OSC int32
        ),
        Param("address", "symbol", "/pointat/{n}/direction", "generic profile: the address ({n}: source)"),
        Param(
            "fields", "list", ("az", "el"), f"generic profile: the arguments: {' '.join(FIELDS)} or numbers"
        ),
        Param(
            "radius",
            "float",
            1.0,
            "distance at dist01 = 1, for receivers in metres (spat)",
            unit="m",
            live=True,
        ),
        Param("bundle", "bool", False, "send each update as one bundle"),
        Param("delay", "float", 0.0, "bundle time tag = now + delay (0: immediately)", unit="ms", live=True),
        Param(
            "rate", "float", 0.0, "at most this many updates per second (0: every one)", unit="Hz", live=True
        ),
        Param("change", "bool", False, "send only updates that moved more than the deadband", live=True),
        Param("deadband", "float", 0.0, "with change (or > 0): skip smaller moves", unit="deg", live=True),
        Param(
            "status",
            "float",
            -1.0,
            "seconds between heartbeats /pointat/N/status STATE RATE (states at once when they change); "
            "-1: the profile's usual (1 s for pointat, vbap and generic, none for the products), 0: none",
            unit="s",
            minimum=-1.0,
            live=True,
        ),
        Param(
            "dropout",
            "float",
            0.5,
            "no direction in for this long is a dropout, told in the status (a few of the sensor's periods "
            "at least; the longest gap seen in normal running, on a loaded machine, was 0.13 s)",
            unit="s",
            minimum=0.05,
            live=True,
        ),
    )
    example = """
node dir  azi_ele
node out  osc_out profile=adm rate=50
dir.elevation -> out.elevation
dir.azimuth -> out.azimuth
"""

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        """Check the parameters that types alone do not (so that ``pointat check`` finds mistakes)."""
        profile = PROFILES[values["profile"]]
        if profile.name == "generic":
            address = str(values["address"])
            if not address.startswith("/"):
                raise ValueError(f"address {address!r} must start with '/'")
            try:
                address.format(n=0)
            except (KeyError, IndexError, ValueError) as exc:  # {source}, {0}, a lone '{'
                raise ValueError(
                    f"address {address!r}: {{n}} (the source number) is the only field it may name, "
                    f"and a literal brace is written twice ({{{{ }}}}); {type(exc).__name__}: {exc}"
                ) from None
            if not values["fields"]:
                raise ValueError("fields is empty: name at least one argument")
            check_fields(values["fields"])
        destinations(values["host"], values["port"] or profile.port, values["to"])
        if values["source"] < 0:
            raise ValueError(f"source {values['source']} is negative")
        for name in ("delay", "rate", "deadband", "radius"):
            if not math.isfinite(values[name]) or values[name] < 0:
                raise ValueError(f"{name} must be a finite number >= 0, got {values[name]}")
        if values["radius"] > F32_MAX:
            raise ValueError(
                f"radius {values['radius']:g} is beyond an OSC float (float32, at most {F32_MAX:.4g})"
            )
        if 0 < values["rate"] < MIN_RATE:
            raise ValueError(f"rate must be 0 (every update) or at least {MIN_RATE} Hz, got {values['rate']}")
        if values["delay"] > 0 and not values["bundle"]:
            raise ValueError("delay only applies to bundles: add bundle=true")
        if values["delay"] > 0 and not profile.time_tags:
            raise ValueError(
                f"delay does nothing for profile {profile.name}: the receiver ignores bundle time tags"
            )

    def setup(self) -> None:
        self.profile = PROFILES[self.p.profile]
        self.messages = self.profile.messages or ((self.p.address, check_fields(self.p.fields)),)
        self._compile()
        self.dests = [
            _Destination(h, p)
            for h, p in destinations(self.p.host, self.p.port or self.profile.port, self.p.to)
        ]
        self.state = [0.0, 0.0, 0.0, 0.0]  # azimuth, elevation, distance, spread
        self._last: tuple[float, ...] | None = None
        self._last_time = -math.inf
        self._held: tuple[float, ...] | None = None
        self._timer: Timer | None = None
        self._outbox: list[bytes] = []  # encoded this pass, sent at its end
        self.updates = 0
        self.sent = 0
        self.failed = 0
        self.refused = 0
        self.heard = 0  # directions in (a count: no clock read per sample)
        self._heard_seen = (0, -math.inf)  # (heard, the look that saw it change)
        self.flag = "ok"  # the filter's flags, as its outlet last said
        self.status_state = ""  # the state last told
        self.statuses = 0
        self._beat: tuple[float, int] = (0.0, 0)  # (time, updates) at the last heartbeat
        self._status_timer: Timer | None = None

    # status --------------------------------------------------------------------
    #: Seconds between two looks at the state (a dropout is told within this of ``dropout``).
    STATUS_LOOK = 0.1

    def status_every(self) -> float:
        """Seconds between heartbeats (0: none)."""
        every = self.p.status
        return (1.0 if self.profile.status else 0.0) if every < 0 else every

    def loadbang(self) -> None:
        # "waiting" is told only if it lasts a heartbeat: a glove that starts at once says "ok" first
        self.status_state = "waiting"
        if self.status_every() > 0:
            self._beat = (self.now, 0)
            self._status_timer = self.call_later(self.STATUS_LOOK, self._look)
            self._status_timer.daemon = True

    def _look(self) -> None:
        """Every :attr:`STATUS_LOOK` s: tell a changed state at once, and the state every ``status`` s."""
        every = self.status_every()
        self._status_timer = None
        if every <= 0:
            return
        now = self.now
        if self.heard != self._heard_seen[0]:
            self._heard_seen = (self.heard, now)
        if not self.heard:
            state = "waiting"
        elif now - self._heard_seen[1] > self.p.dropout:
            state = "dropout"
        else:
            state = self.flag if self.flag != "ok" else "ok"
        if state != self.status_state or now - self._beat[0] >= every - 1e-9:
            then, count = self._beat
            rate = (self.updates - count) / (now - then) if now > then else 0.0
            self._beat = (now, self.updates)
            self.status_state = state
            self.statuses += 1
            n = self.p.source or self.profile.first
            self.send([encode_message(f"/pointat/{n}/status", [state, float(round(rate, 1))])])
        self._status_timer = self.call_later(self.STATUS_LOOK, self._look)
        self._status_timer.daemon = True  # a heartbeat keeps no ended patch running

    def on_flags(self, msg: Message) -> None:
        self.flag = str(msg.value)

    def param_changed(self, name: str) -> None:
        if name == "source":
            self._compile()
        elif (
            name == "status"
            and self._status_timer is None
            and self.status_every() > 0
            and self.rt is not None
        ):
            self._beat = (self.now, self.updates)
            self._look()

    def health(self) -> dict[str, Any]:
        return {"refused": self.refused, "failed": self.failed}

    def on_elevation(self, msg: Message) -> None:
        v = msg.value if msg.kind == "float" else as_float(msg)  # (per sample: a call less)
        if v - v != 0.0:  # NaN or infinity; the last good value stays
            _refuse("elevation", v)
        self.state[1] = v

    def on_distance(self, msg: Message) -> None:
        v = msg.value if msg.kind == "float" else as_float(msg)
        if v - v != 0.0:
            _refuse("distance", v)
        self.state[2] = v

    def on_spread(self, msg: Message) -> None:
        v = as_float(msg)
        if v - v != 0.0:
            _refuse("spread", v)
        self.state[3] = v

    def on_azimuth(self, msg: Message) -> None:
        self.heard += 1  # (a dropout is judged on what comes in: pacing and deadband hold updates)
        kind = msg.kind
        state = self.state
        if kind == "float":  # the per-sample case (a float message holds a float; the others are checked)
            az = msg.value
            if az - az != 0.0:
                _refuse("azimuth", az)
            state[0] = az
            update = (az, state[1], state[2], state[3])
        else:
            if kind == "bang":  # send the current state again, whatever the pacing says
                update = tuple(state)
            elif kind == "list":
                values = [float(v) for v in msg.value[:4]]
                if not values:
                    raise ValueError("empty list")
                update = (*values, *state[len(values) :])
            else:
                update = (as_float(msg), state[1], state[2], state[3])
            if not math.isfinite(sum(update)):  # NaN or infinity anywhere makes the sum so
                raise ValueError(f"not sent: not a finite number in {update}; the last good values stay")
            state[:] = update  # taken only when all of it is good: one bad message spoils none after it
        if kind == "bang":
            self._release(update)
        else:
            self.offer(update)

    # update policy -------------------------------------------------------------
    def offer(self, update: tuple[float, ...]) -> None:
        """Apply send-on-change, deadband and rate limit to one update, then send it (or hold it)."""
        p = self.p
        if (p.change or p.deadband > 0) and self._last is not None:
            if _moved(self._last, update) <= p.deadband:
                self._held = None  # the hand came back: nothing newer to deliver
                return
        if p.rate > 0:
            due = self._last_time + 1.0 / p.rate
            if self.now < due:
                self._held = update
                if self._timer is None:
                    self._timer = self.call_at(due, self._flush)
                return
        self._release(update)

    def _flush(self) -> None:
        self._timer = None
        if self._held is not None:
            self._release(self._held)

    def _release(self, update: tuple[float, ...]) -> None:
        self._held = None
        self._last = update
        if self.p.rate > 0:  # the time only paces (a rate set later finds an old one: the next goes at once)
            self._last_time = self.now
        self.updates += 1
        az, el, dist, spread = update
        src = Source(self.p.source or self.profile.first, az, el, dist, spread, self.p.radius)
        self.send(self._encoder.encode(src))

    def _compile(self) -> None:
        """The encoder of one update for the current source number (addresses and tags encoded once)."""
        self._encoder = UpdateEncoder(self.profile, self.p.source or self.profile.first, self.messages)

    # sending -------------------------------------------------------------------


@register("osc_send")
class OscSend(UdpSender):
    """Send any message as OSC: a gesture's label, a stroke, a cue, to whatever listens.

    What reaches the inlet goes to ``address`` with its values as the arguments: ``circle 0.93`` (a
    ``gesture`` node's) leaves as ``/pointat/gesture "circle" 0.93``; a number as one argument, a bang
    with none.  A message whose selector is an address (``/cue/go 3``, from a ``msg`` box) goes to that
    address instead; one whose selector is a word (``next``) goes to ``address/next``.  Numbers go as
    float32 (whole numbers as int32), symbols as strings: what Pd's ``[oscparse]``, Max's ``udpreceive``
    and every DAW read.  ``to`` adds destinations; sending never blocks, and an absent receiver is counted
    and said once, as ``osc_out`` does.
    """

    inlets = (
        Inlet("in", ("any",), "values to send (a list, a number, a symbol, a bang), or /address values"),
    )
    params = (
        Param("address", "symbol", "/pointat/gesture", "where the values go: an OSC address"),
        Param("host", "symbol", "127.0.0.1", "receiver address (name or IP)"),
        Param("port", "int", 9000, "receiver UDP port", minimum=1, maximum=65535),
        Param("to", "list", (), "more destinations: host:port, or a port on the same host"),
        Param("bundle", "bool", False, "send each message as a bundle"),
    )
    example = """
node go   msg circle 1
node tell osc_send address=/pointat/gesture port=9000
go -> tell
"""

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        address = str(values["address"])
        if not address.startswith("/") or any(c in address for c in " #*,?[]{}"):
            raise ValueError(f"address {address!r}: expected an OSC address such as /pointat/gesture")

    def setup(self) -> None:
        self.dests = [_Destination(h, p) for h, p in destinations(self.p.host, self.p.port, self.p.to)]
        self._outbox: list[bytes] = []
        self.sent = self.failed = self.refused = 0

    def receive(self, index: int, msg: Message) -> None:
        self.time = msg.time
        kind, value = msg.kind, msg.value
        address = self.p.address
        if kind == "bang":
            args: list[Any] = []
        elif kind in ("list", "vector"):
            args = list(value)
        elif kind in ("float", "int", "symbol"):
            args = [value]
        else:  # a method message: its selector names the address, or a word under it
            address = kind if kind.startswith("/") else f"{address.rstrip('/')}/{kind}"
            args = list(value or ())
        self.send([encode_message(address, [_osc_arg(a) for a in args])])

    def health(self) -> dict[str, Any]:
        return {"sent": self.sent, "refused": self.refused, "failed": self.failed}


def _osc_arg(a: Any) -> Any:
    """A value as an OSC argument: a whole float stays a float (float32), numpy numbers become Python's."""
    if isinstance(a, (bool, np.bool_)):
        return int(a)
    if isinstance(a, np.integer):
        return int(a)
    if isinstance(a, np.floating):
        return float(a)
    return a


def _refuse(what: str, value: float) -> None:
    raise ValueError(f"{what} {value} refused: not a finite number; the last good value stays")


def _moved(a: Sequence[float], b: Sequence[float]) -> float:
    """The largest change between two updates, degrees (azimuth the short way round)."""
    daz = abs((b[0] - a[0] + 180.0) % 360.0 - 180.0)
    return max(daz, *(abs(y - x) for x, y in zip(a[1:], b[1:], strict=True)))


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
        if not _is_loopback(host):
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
