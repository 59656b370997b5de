"""``mapper`` and ``mapper_in``: a patch on a libmapper bus, so that machines map each other's signals.

``mapper`` makes the running patch a libmapper device (``pointat run PATCH --mapper IFACE`` adds one):
its gloves, gestures, postures, strokes and skeleton segments are outgoing signals, its live parameters
incoming ones.  ``mapper_in`` brings one signal of the bus into the patch as messages.  What becomes
which signal, and why, is :mod:`pointat.mapper`'s docstring; this module only wires it to the runtime.
The library is the optional extra ``pointat[mapper]``; without it a node says so as the patch starts.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from pointat import mapper as bus
from pointat.control import PREFIX, control
from pointat.errors import worth_reporting
from pointat.message import Message, make
from pointat.node import Node, Outlet, Param, Tap
from pointat.registry import register

__all__ = ["Mapper", "MapperIn"]

log = logging.getLogger("pointat.mapper")

_INTERFACE = Param(
    "interface",
    "symbol",
    doc="the network interface the bus is joined on (eth0, wlan0; lo: a bus of this machine alone); no default: "
    "a bus has no access control, so the show's network is chosen, never taken",
)


class _Polled(Node):
    """A node that holds a :class:`pointat.mapper.Device` and polls it every :data:`pointat.mapper.POLL`
    seconds on the scheduler's clock."""

    acts_alone = True
    needs_input = False

    def setup(self) -> None:
        self.device: bus.Device | None = None
        self._timer: Any = None
        self._next = 0.0

    def _poll_soon(self) -> None:
        now = self.now
        self._next = max(self._next + bus.POLL, now)  # a deadline: no drift, no burst after a stall
        self._timer = self.call_at(self._next, self._poll)
        self._timer.daemon = True  # keeps no ended patch running

    def _poll(self) -> None:
        if self.device is None:
            return
        self.device.poll()
        self.poll_tick()
        self._poll_soon()

    def poll_tick(self) -> None:
        """After each poll (scheduler thread)."""

    def loadbang(self) -> None:
        self._next = self.now
        self._poll_soon()

    def close(self) -> None:
        self.active = False
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        if self.device is not None:
            device, self.device = self.device, None
            device.close()


@register("mapper")
class Mapper(_Polled):
    """Make the running patch a libmapper device: its gloves and gestures are signals other machines
    map, its live parameters signals they set (``pointat run PATCH --mapper IFACE`` adds this node).

    Outgoing, found by what the nodes declare: every pointer's (a node with a ``direction`` reading:
    ``osc_out``) ``NODE/azimuth``,
    ``/elevation``, ``/distance`` (degrees, pointat's convention) and the quaternion upstream of it
    (``NODE/quat``); a ``gesture`` outlet's ``NODE/LABEL`` score, a ``posture`` outlet's ``NODE/LABEL``
    1 or 0, a ``stroke`` outlet's ``NODE/stroke``, a ``segments`` outlet's ``NODE/SEGMENT``
    quaternions.  Incoming: ``NODE/PARAM`` for every live parameter (the range its declaration gives),
    set as live control sets it.  See :mod:`pointat.mapper` for types, units and ranges.

    The device is named ``device`` (default: ``pointat_`` and the patch's file name), and the bus adds an
    ordinal (``pointat_glove_tqt.1``).  It joins the bus on ``interface`` only; the bus has no access
    control: use it on a show's own network.  Webmapper (or any libmapper session tool) sees the device,
    and a map drawn there from a glove's azimuth to another patch's parameter sets it live.
    """

    params = (
        _INTERFACE,
        Param(
            "device", "symbol", "", "the device's name on the bus (default: pointat_ and the patch's name)"
        ),
    )
    example = """
node bus  mapper interface=lo device=anna
"""

    def setup(self) -> None:
        super().setup()
        self.sent = 0  # values set on outgoing signals
        self.taken = 0  # values that came in and were set
        self.refused = 0  # values that came in and did not fit their parameter
        self.joined = ""  # the device's name once the bus agreed it (pointat_glove_tqt.1)
        self._flushing = False
        self._events: dict[str, Any] = {}  # posture node name -> the label it holds
        self._taps: list[tuple[Node, int, Any]] = []  # (node, outlet, the tap on it)

    def device_name(self) -> str:
        """The name asked of the bus (it adds the ordinal): ``device``, else ``pointat_`` and the patch's."""
        if self.p.device:
            return bus.device_name(self.p.device, prefix="")
        stem = Path(self.where.file).stem if self.where is not None and self.where.file else "patch"
        return bus.device_name(stem)

    def start(self) -> None:
        self.device = bus.Device(self.device_name(), self.p.interface)
        self.active = True
        self._attach()
        reloader = getattr(self._runtime(), "reloader", None)
        if reloader is not None:  # (pointat run --watch: the patch's nodes may be made anew)
            reloader.listen(self.reattach)

    def reattach(self, _plan: Any = None) -> None:
        """After a reload (scheduler thread): the taps taken off, the patch's signals found again; this
        node back among the runtime's when the new file does not name it (``--mapper`` added it)."""
        if self.device is None:
            return  # (closed: the reload dropped it)
        rt = self._runtime()
        if rt.nodes.get(self.name) is not self:  # type: ignore[attr-defined]
            rt.nodes = {**rt.nodes, self.name: self}  # type: ignore[attr-defined]
        for node, outlet, t in self._taps:
            node.untap(outlet, t)
        self._taps = []
        self._attach()

    def _tap(self, node: Node, outlet: int, fn: Callable[[Message], None]) -> None:
        self._taps.append((node, outlet, node.tap(outlet, fn)))

    def _attach(self) -> None:
        """Signals for what the patch's nodes declare, and taps on their outlets."""
        assert self.device is not None
        rt = self._runtime()
        nodes = [n for n in rt.nodes.values() if n is not self]  # type: ignore[attr-defined]
        for node in nodes:
            self._pointer(node, nodes)
            self._outlets(node)
            for p in type(node).params:
                spec = bus.param_signal(node.name, p) if p.live else None
                if spec is not None:
                    address = f"{PREFIX}{node.name}/{p.name}"
                    self.device.add(spec, incoming=True, on_value=self._setter(address))

    # outgoing ------------------------------------------------------------------------------------
    def _publish(self, sig: Any, value: Any) -> None:
        device = self.device
        if device is None:
            return
        device.set(sig, value)
        self.sent += 1
        if not self._flushing:
            self._flushing = True
            self._runtime().at_pass_end(self, self._flush)

    def _flush(self) -> None:
        self._flushing = False
        if self.device is not None:
            self.device.flush()

    def _pointer(self, node: Node, nodes: list[Node]) -> None:
        """Taps for a node that points (a :class:`~pointat.node.Reading` marked ``direction``, as
        ``osc_out`` declares): its azimuth, elevation and distance as they reach its inlets of those
        names, and the quaternion nearest upstream of it.  (What reaches it, not what it reads: a
        compiled chain feeds the node's inlets and keeps its state apart until the end.)"""
        if not any(r.direction for r in type(node).readings):
            return
        names = [i.name for i in node.in_specs]
        coords = [c[0] for c in bus.POINTER]
        where = {names.index(c): k for k, c in enumerate(coords) if c in names}
        if not where:
            return
        assert self.device is not None
        sigs = [
            self.device.add(bus.SignalSpec(bus.signal_name(node.name, c), 1, "f", unit, (lo,), (hi,)))
            for c, unit, lo, hi in bus.POINTER
        ]
        feeders: dict[Node, list[Node]] = {}
        for src in nodes:
            for o in range(len(src.out_specs)):
                for dst, inlet in src.targets(o):
                    if isinstance(dst, Tap):
                        continue
                    feeders.setdefault(dst, []).append(src)
                    if dst is node and inlet in where:
                        self._tap(src, o, self._coordinate(sigs, where[inlet]))
        quat = _nearest_quat(node, feeders)
        if quat is not None:
            qsig = self.device.add(replace(bus.QUAT, name=bus.signal_name(node.name, "quat")))
            self._tap(*quat, self._vector(qsig, 4))

    def _coordinate(self, sigs: list[Any], k: int) -> Callable[[Message], None]:
        def take(msg: Message) -> None:
            if msg.kind == "list" and k == 0:  # az el dist [spread] at the azimuth inlet
                values = [float(v) for v in msg.value[:3] if isinstance(v, (int, float))]
                for j, v in enumerate(values):
                    if math.isfinite(v):
                        self._publish(sigs[j], v)
            elif msg.kind in ("float", "int") and math.isfinite(msg.value):
                self._publish(sigs[k], float(msg.value))

        return take

    def _vector(self, sig: Any, n: int) -> Callable[[Message], None]:
        def take(msg: Message) -> None:
            values = _numbers(msg)
            if len(values) == n and bus.finite(values):
                self._publish(sig, values)

        return take

    def _outlets(self, node: Node) -> None:
        """Taps for the event and segment outlets a node declares."""
        assert self.device is not None
        for o, spec in enumerate(node.out_specs):
            if spec.name == "gesture" and spec.kind == "list":
                self._tap(node, o, self._gesture(node.name))
            elif spec.name == "posture" and spec.kind == "symbol":
                self._tap(node, o, self._posture(node.name))
                none = [i for i, s in enumerate(node.out_specs) if s.name == "none"]
                if none:
                    self._tap(node, none[0], self._posture(node.name, leaves=True))
            elif spec.name == "stroke" and spec.kind == "list":
                sig = self.device.add(replace(bus.STROKE, name=bus.signal_name(node.name, "stroke")))
                self._tap(node, o, self._vector(sig, 3))
            elif spec.name == "segments" and spec.kind == "vector":
                self._tap(node, o, self._segments(node))

    def _label_signal(self, node_name: str, label: Any, unit: str) -> Any:
        assert self.device is not None
        spec = bus.SignalSpec(bus.signal_name(node_name, str(label)), 1, "f", unit, (0.0,), (1.0,))
        return self.device.add(spec)

    def _gesture(self, node_name: str) -> Callable[[Message], None]:
        def take(msg: Message) -> None:
            if self.device is None or msg.kind != "list" or len(msg.value) < 2:
                return
            label, score = msg.value[0], msg.value[1]
            if isinstance(score, (int, float)) and math.isfinite(score):
                self._publish(self._label_signal(node_name, label, "score"), float(score))

        return take

    def _posture(self, node_name: str, leaves: bool = False) -> Callable[[Message], None]:
        def take(msg: Message) -> None:
            if self.device is None:
                return
            held = self._events.pop(node_name, None)
            if held is not None and (leaves or msg.value != held):  # (the same again: still 1)
                self._publish(self._label_signal(node_name, held, ""), 0.0)
            if not leaves and msg.kind == "symbol":
                self._events[node_name] = msg.value
                self._publish(self._label_signal(node_name, msg.value, ""), 1.0)

        return take

    def _segments(self, node: Node) -> Callable[[Message], None]:
        body = getattr(node, "body", None)
        names = [s.name for s in getattr(body, "segments", ())]
        sigs: list[Any] = []

        def take(msg: Message) -> None:
            values = _numbers(msg)
            if self.device is None or len(values) % 4 or not bus.finite(values):
                return
            while len(sigs) < len(values) // 4:
                k = len(sigs)
                label = names[k] if k < len(names) else f"segment{k}"
                sigs.append(self.device.add(replace(bus.QUAT, name=bus.signal_name(node.name, label))))
            for k, sig in enumerate(sigs):
                self._publish(sig, values[4 * k : 4 * k + 4])

        return take

    # incoming ------------------------------------------------------------------------------------
    def _setter(self, address: str) -> Callable[[Any], None]:
        def put(value: Any) -> None:
            args = list(value) if isinstance(value, (list, tuple)) else [value]
            why = control(self._runtime(), address, args, self.now)
            if why is None:
                self.taken += 1
                return
            self.refused += 1
            if worth_reporting(self.refused):
                log.warning(
                    "node '%s' (mapper): %s %s refused: %s (%d refused so far)",
                    self.name,
                    address,
                    args,
                    why,
                    self.refused,
                )

        return put

    def poll_tick(self) -> None:
        if not self.joined and self.device is not None and self.device.ready:
            self.joined = self.device.name
            log.info("node '%s' (mapper): on the bus as %s", self.name, self.joined)

    def health(self) -> dict[str, Any]:
        return {
            "device": self.joined or "(joining)",
            "sent": self.sent,
            "taken": self.taken,
            "refused": self.refused,
        }


def _nearest_quat(node: Node, feeders: dict[Node, list[Node]]) -> tuple[Node, int] | None:
    """The wired ``quat`` outlet (a vector) nearest upstream of ``node``, by wires walked back, or None."""
    seen = {node}
    level = [node]
    while level:
        nxt = []
        for n in level:
            for src in feeders.get(n, ()):
                if src in seen:
                    continue
                seen.add(src)
                nxt.append(src)
                for o, spec in enumerate(src.out_specs):
                    if spec.name == "quat" and spec.kind == "vector":
                        return src, o
        level = nxt
    return None


def _numbers(msg: Message) -> list[float]:
    value = msg.value
    if msg.kind in ("float", "int"):
        return [float(value)]
    try:
        return [float(v) for v in value]
    except (TypeError, ValueError):
        return []


@register("mapper_in")
class MapperIn(_Polled):
    """Bring one signal of a libmapper bus into the patch: each value it takes leaves by ``out``.

    The node is a small device of its own (``device``, default ``pointat_in``) with one incoming signal,
    named as the node is.  Draw a map to it in webmapper, or name the ``source``
    (``DEVICE/SIGNAL``, the device with or without its ordinal: ``pointat_glove_tqt/out/azimuth``) and
    the node maps it itself as soon as that device is on the bus, again if it comes back after going.
    ``length`` numbers a value (1: a float, more: a vector).  It joins the bus on ``interface`` only.
    """

    outlets = (Outlet("out", "any", "each value the signal takes: a float, or a vector of length numbers"),)
    params = (
        _INTERFACE,
        Param("source", "symbol", "", "DEVICE/SIGNAL to map from ('': wait for a map drawn elsewhere)"),
        Param("length", "int", 1, "numbers a value", minimum=1, maximum=256),
        Param("device", "symbol", "in", "this node's device name on the bus, after pointat_"),
    )
    example = """
node az   mapper_in interface=lo source=pointat_glove_tqt/out/azimuth
node show print prefix=azimuth
az -> show
"""

    #: Seconds between two looks for the source, while it is not mapped.
    LOOK = 0.25

    def setup(self) -> None:
        super().setup()
        self.received = 0
        self.mapped = False
        self._look_at = -math.inf
        self._map: Any = None
        source = str(self.p.source)
        device, _, signal = source.partition("/")
        self._source = (device, signal) if source else None

    @classmethod
    def validate(cls, values: Any) -> None:
        source = str(values["source"])
        if source and ("/" not in source.strip("/") or source.startswith("/")):
            raise ValueError(f"source {source!r}: expected DEVICE/SIGNAL (pointat_glove_tqt/out/azimuth)")

    def start(self) -> None:
        self.device = bus.Device(
            bus.device_name(self.p.device), self.p.interface, subscribe=self._source is not None
        )
        self.active = True
        spec = bus.SignalSpec(bus.signal_name(self.name), int(self.p.length))
        self._signal = self.device.add(spec, incoming=True, on_value=self._take)

    def _take(self, value: Any) -> None:
        self.received += 1
        t = self.now
        if isinstance(value, (list, tuple)):
            self.out(0, make(tuple(float(v) for v in value), t))
        else:
            self.out(0, make(float(value), t))

    def poll_tick(self) -> None:
        if self._source is None or self.device is None or not self.device.ready:
            return  # (a map asked of a device the bus has not named yet is never made)
        now = self.now
        if now - self._look_at < self.LOOK:
            return
        self._look_at = now
        self.mapped = any(m.ready for m in bus.every(self._signal.maps()))
        if self.mapped:
            return
        src = self.device.find(*self._source)
        if src is not None:
            mpr = self.device.mpr
            self._map = mpr.Map("%y=%x", self._signal, src)
            self._map.push()
            log.info("node '%s' (mapper_in): mapping %s", self.name, self.p.source)

    def health(self) -> dict[str, Any]:
        return {"source": self.p.source, "mapped": self.mapped, "received": self.received}
