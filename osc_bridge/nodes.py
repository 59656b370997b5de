r"""``osc_out`` and ``osc_send``: pointat's doors out to spatial-sound systems, DAWs and whatever listens.

Both speak OSC 1.0 over UDP (the wire format: :mod:`pointat.devices.osc_wire`).  ``osc_out`` encodes every
number as float32 (``f``) and every index as int32 (``i``): Pd's ``[oscparse]`` rejects 64-bit doubles.
Its sockets are non-blocking (:mod:`pointat.osc_bridge.sender`), so a full buffer or an absent receiver
costs a counted, dropped datagram and never a stalled scheduler.  The door in is ``osc_in``
(:mod:`pointat.osc_bridge.listener`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from pointat.devices.osc_wire import F32_MAX, encode_message
from pointat.message import Message, as_float
from pointat.node import Inlet, Param, Reading
from pointat.registry import register
from pointat.runtime import Timer

from .encoder import UpdateEncoder
from .profiles import FIELDS, PROFILES, Source, check_fields
from .sender import Destination, UdpSender, destinations

__all__ = ["OscOut", "OscSend"]

#: The lowest ``osc_out rate`` but 0: one update every 100 s.
MIN_RATE = 0.01


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
    fusable = True
    role = "output"
    readings = (
        Reading(
            "aed",
            "the direction last sent: azimuth (+ left), elevation (+ up), distance (0 far .. 90 near)",
            units=("deg", "deg", ""),
            direction=True,
        ),
    )

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
            Destination(h, p)
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

    def describe(self) -> str:
        return f"OSC to {', '.join(d.label for d in self.dests)}, profile {self.p.profile}"

    def read(self) -> dict[str, Any]:
        return {"aed": self.state[:3]}

    def health(self) -> dict[str, Any]:
        return {
            "to": [d.label for d in self.dests],
            "updates": self.updates,  # directions sent
            "sent": self.sent,  # datagrams, the heartbeats among them
            "heard": self.heard,  # directions in: the monitor's waiting, ok and dropout
            "flag": self.flag,
            "refused": self.refused,
            "failed": self.failed,
        }

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

    # the compiled chain (pointat.compiled) -------------------------------------
    def fused_state(self) -> dict[str, Any]:
        """For :mod:`pointat.compiled`: the direction last taken (azimuth, elevation, distance), the
        spread, and the first message of an update for the current source number, encoded with every
        value 0 (``datagram``), its arguments from byte ``arguments_at`` on, 4 bytes each."""
        (head, _, _) = self._encoder.parts[0]
        (data, *_) = self._encoder.encode(Source(self.p.source or self.profile.first, 0.0))
        return {
            "direction": tuple(self.state[:3]),
            "spread": self.state[3],
            "datagram": data,
            "arguments_at": len(head),
        }

    def restore_fused(self, state: Mapping[str, Any]) -> None:
        """The direction the chain sent last (the spread is the inlet's: the chain reads it as it goes)."""
        self.state[:3] = state["direction"]
        self._last = tuple(self.state)

    def send_updates(self, datagrams: list[bytes]) -> None:
        """Send the datagrams of updates a compiled chain encoded, now, to every destination, each counted
        as an update heard and sent (what :meth:`on_azimuth` and :meth:`_release` count)."""
        k = len(datagrams)
        self.heard += k
        self.updates += k
        sent = 0
        for dgram in datagrams:
            for d in self.dests:
                if d.connected and not d.outage:
                    try:
                        d.sock.send(dgram)
                    except OSError as exc:
                        self._send_one(d, dgram, exc)
                    else:
                        sent += 1
                else:
                    self._send_one(d, dgram)
        self.sent += sent

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
        self.dests = [Destination(h, p) for h, p in destinations(self.p.host, self.p.port, self.p.to)]
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

    def describe(self) -> str:
        return f"OSC {self.p.address} to {', '.join(d.label for d in self.dests)}"

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
