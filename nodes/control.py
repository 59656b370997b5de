"""Core control nodes, after Pd's vanilla objects of the same names.

metro, delay, trigger (t), pack, unpack, route, send (s), receive (r), loadbang, print, change, speedlim,
and msg (a Pd message box).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pointat.message import Message, as_float, bang, make, method
from pointat.node import Inlet, Node, Outlet, Param
from pointat.registry import register
from pointat.runtime import Timer


def _is_on(msg: Message) -> bool:
    if msg.kind == "bang":
        return True
    if msg.kind == "symbol" or msg.is_method:
        raise TypeError(f"expected bang, a number or stop, got {msg.describe()!r}")
    return as_float(msg) != 0.0


@register("metro")
class Metro(Node):
    """Output a bang every ``interval`` milliseconds while switched on.

    A bang or a non-zero number starts it (the first bang comes at once), 0 or ``stop`` stops it.  Ticks
    are deadlines on the scheduler clock (tick n at start + n x interval), so a metro never drifts.
    """

    pure = True

    inlets = (
        Inlet("on", ("bang", "float", "int"), "bang or non-zero: start; 0 or 'stop': stop"),
        Inlet("interval", ("float", "int"), "set the interval (ms)", param="interval"),
    )
    outlets = (Outlet("out", "bang", "a bang per tick"),)
    params = (
        Param(
            "interval",
            "float",
            100.0,
            "time between bangs (0 or less: 1, as Pd's metro)",
            unit="ms",
            live=True,
        ),
    )
    example = """
node tick metro 50
node show print
tick -> show
"""
    defers = True

    def setup(self) -> None:
        self._timer: Timer | None = None
        self._t0 = 0.0
        self._n = 0

    def on_on(self, msg: Message) -> None:
        if _is_on(msg):
            self._cancel()
            self._t0, self._n = self.now, 0
            self.time = self._t0
            self._tick()
        else:
            self.do_stop()

    def do_stop(self) -> None:
        self._cancel()

    def _cancel(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None

    def _period(self) -> float:
        return (self.p.interval if self.p.interval > 0 else 1.0) / 1000.0  # Pd's metro takes 1 ms

    def _tick(self) -> None:
        self._last_tick = self.time
        self._n += 1
        self._timer = self.call_at(self._t0 + self._n * self._period(), self._tick)
        self.out(0, None)

    def param_changed(self, name: str) -> None:
        if self._timer is not None:  # the new interval counts from the last tick
            self._timer.cancel()
            self._t0, self._n = self._last_tick, 1
            self._timer = self.call_at(self._t0 + self._period(), self._tick)

    def close(self) -> None:
        self._cancel()


@register("delay", "del")
class Delay(Node):
    """Output a bang ``time`` milliseconds after a bang; a new bang restarts the wait, ``stop`` cancels it."""

    pure = True

    inlets = (
        Inlet("in", ("bang", "float", "int"), "bang: start; a number: set the time and start"),
        Inlet("time", ("float", "int"), "set the time (ms)", param="time"),
    )
    outlets = (Outlet("out", "bang", "the delayed bang"),)
    params = (Param("time", "float", 0.0, "the delay", unit="ms", live=True),)
    defers = True

    def setup(self) -> None:
        self._timer: Timer | None = None

    def on_in(self, msg: Message) -> None:
        if msg.kind != "bang":
            self.set_param("time", as_float(msg))
        self.do_stop()
        self._timer = self.call_later(max(0.0, self.p.time) / 1000.0, self._fire)

    def _fire(self) -> None:
        self._timer = None
        self.out(0, None)

    def do_stop(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None

    def close(self) -> None:
        self.do_stop()


_TRIGGER_TYPES = {"b": "bang", "f": "float", "s": "symbol", "l": "list", "a": "any", "v": "vector"}


_LONG_TYPES = {"bang": "b", "float": "f", "symbol": "s", "list": "l", "anything": "a", "vector": "v"}


def _short_type(t: object) -> str:
    """Pd accepts ``t bang float`` as well as ``t b f``."""
    return _LONG_TYPES.get(str(t), str(t))


def _convert(kind: str, msg: Message) -> Message:
    """Convert a message for a trigger / unpack outlet of type ``kind`` (b f s l a v)."""
    if kind == "a":
        return msg
    if kind == "b":
        return bang(msg.time)
    if kind == "f":
        if msg.kind == "vector":
            return make(float(np.ravel(msg.value)[0]), msg.time)
        return make(as_float(msg), msg.time)
    if kind == "s":
        if msg.kind == "symbol":
            return msg
        if msg.kind == "list" and msg.value and isinstance(msg.value[0], str):
            return make(msg.value[0], msg.time)
        raise TypeError(f"expected a symbol, got {msg.describe()!r}")
    if kind == "l":
        if msg.kind == "list":
            return msg
        if msg.kind == "vector":
            return make(tuple(np.ravel(msg.value).tolist()), msg.time)
        if msg.kind == "bang":
            return make((), msg.time)
        if msg.is_method:
            return make((msg.kind, *msg.value), msg.time)
        return make((msg.value,), msg.time)
    if kind == "v":
        if msg.kind == "vector":
            return msg
        if msg.kind == "list":
            return make(np.array(msg.value, dtype=float), msg.time)
        raise TypeError(f"expected a vector or a list, got {msg.describe()!r}")
    raise ValueError(kind)


@register("trigger", "t")
class Trigger(Node):
    """Send the input out of every outlet, right to left, converted per outlet (b f s l a v).

    ``trigger b f`` sends the number out of the right outlet first, then a bang out of the left one.  Types: b bang, f float, s symbol, l list, a anything (as is), v vector.
    """

    pure = True

    inlets = (Inlet("in", ("any",), "any message"),)
    params = (Param("types", "list", ("a", "a"), "one type per outlet: b f s l a v", variadic=True),)
    example = """
node t trigger b f
"""

    @classmethod
    def layout(cls, values):
        types = tuple(_short_type(t) for t in values.get("types", ("a", "a"))) or ("a",)
        for t in types:
            if t not in _TRIGGER_TYPES:
                raise ValueError(f"trigger type '{t}' is not one of {' '.join(_TRIGGER_TYPES)}")
        outs = tuple(
            Outlet(f"out{i}", _TRIGGER_TYPES[t], f"the input as {_TRIGGER_TYPES[t]}")
            for i, t in enumerate(types)
        )
        return cls.inlets, outs

    def setup(self) -> None:
        self._types = [_short_type(t) for t in self.p.types] or ["a"]

    def receive(self, index: int, msg: Message) -> None:
        self.time = msg.time
        values = [_convert(t, msg) for t in self._types]  # all first: one it cannot convert fires none
        for i in range(len(values) - 1, -1, -1):
            self.out(i, values[i])


@register("pack")
class Pack(Node):
    """Combine several values into a list.  The left inlet outputs; the others only store.

    Creation arguments are the initial values (and so the number of inlets); ``s`` makes a symbol slot.
    A bang at the left inlet outputs the list as it is.
    """

    pure = True

    params = (
        Param(
            "values", "list", (0.0, 0.0), "initial values, one per inlet ('s' for a symbol)", variadic=True
        ),
    )
    outlets = (Outlet("out", "list", "the packed list"),)

    @classmethod
    def layout(cls, values):
        vals = values.get("values", (0.0, 0.0)) or (0.0,)
        ins = tuple(
            Inlet(
                f"in{i}",
                ("bang", "float", "symbol", "list"),
                "hot: set and output" if i == 0 else "cold: set",
                hot=i == 0,
            )
            for i in range(len(vals))
        )
        return ins, cls.outlets

    def setup(self) -> None:
        # as in Pd: 's' is a symbol slot, 'f' a float slot starting at 0
        self._slots: list[Any] = [{"s": "", "f": 0.0}.get(v, v) for v in (self.p.values or (0.0,))]

    def receive(self, index: int, msg: Message) -> None:
        self.time = msg.time
        if msg.kind == "bang" and index == 0:
            self.out(0, tuple(self._slots))
            return
        if msg.kind == "list":
            for j, v in enumerate(msg.value[: len(self._slots) - index]):
                self._slots[index + j] = v
        elif msg.kind == "vector":
            raise TypeError("pack takes numbers and symbols; unpack the vector first")
        elif msg.is_method:
            raise TypeError(f"pack has no method '{msg.kind}'")
        else:
            self._slots[index] = msg.value
        if index == 0:
            self.out(0, tuple(self._slots))


@register("unpack")
class Unpack(Node):
    """Split a list (or a vector: a quaternion, a 3-vector) into its elements, right to left."""

    pure = True

    inlets = (Inlet("in", ("list", "vector"), "a list or a vector"),)
    params = (
        Param("types", "list", ("f", "f"), "one per outlet: f (number) s (symbol) a (as is)", variadic=True),
    )

    @classmethod
    def layout(cls, values):
        n = len(values.get("types", ("f", "f"))) or 1
        return cls.inlets, tuple(Outlet(f"out{i}", "any", f"element {i}") for i in range(n))

    def on_in(self, msg: Message) -> None:
        if msg.kind == "vector" or msg.kind == "list":  # a vector is a flat tuple of floats
            items = list(msg.value)
        elif msg.is_method:
            items = [msg.kind, *msg.value]
        else:
            items = [msg.value]
        n = min(len(items), len(self.out_specs))
        for i in range(n - 1, -1, -1):
            self.out(i, items[i])


@register("route")
class Route(Node):
    """Route by the first element: ``route a b`` sends ``a 1 2`` out of outlet 0 as ``1 2``.

    Matches the selector of a method message (``recalibrate``) or the first element of a list (a symbol
    or a number).  What matches nothing leaves by the rightmost outlet, unchanged.
    """

    pure = True

    inlets = (Inlet("in", ("any",), "the message to route"),)
    params = (Param("selectors", "list", (), "what each outlet matches", variadic=True),)
    example = """
node ctl route recalibrate reference
"""

    @classmethod
    def layout(cls, values):
        sels = values.get("selectors", ())
        outs = tuple(Outlet(f"out{i}", "any", f"the rest of '{s}' messages") for i, s in enumerate(sels))
        return cls.inlets, (*outs, Outlet("reject", "any", "everything else"))

    def setup(self) -> None:
        self._index = {}
        for i, s in enumerate(self.p.selectors):
            self._index.setdefault(s if isinstance(s, str) else float(s), i)

    def on_in(self, msg: Message) -> None:
        if msg.is_method:
            head, rest = msg.kind, msg.value
        elif msg.kind == "list" and msg.value:
            head, rest = msg.value[0], msg.value[1:]
        elif msg.kind in ("float", "int", "symbol"):
            head, rest = msg.value, ()
        else:
            head, rest = msg.kind, ()
        key = head if isinstance(head, str) else float(head)
        i = self._index.get(key)
        if i is None:
            self.out(len(self.out_specs) - 1, msg)
        elif not rest:
            self.out(i, bang(msg.time))
        elif len(rest) == 1:
            self.out(i, make(rest[0], msg.time))
        elif isinstance(rest[0], str):
            self.out(i, method(rest[0], *rest[1:], time=msg.time))
        else:
            self.out(i, make(tuple(rest), msg.time))


@register("send", "s")
class Send(Node):
    """Send every message to all ``receive`` nodes of the same bus name, anywhere in the patch."""

    needs_input = True
    bus_end = "sends"
    inlets = (
        Inlet("in", ("any",), "the message to send"),
        Inlet("bus", ("symbol",), "set the bus name", param="bus"),
    )
    params = (Param("bus", "symbol", "", "the bus name", live=True),)

    def on_in(self, msg: Message) -> None:
        if not self.p.bus:
            raise ValueError("no bus name: give one as an argument or to the right inlet")
        for node in self._runtime().bus.get(self.p.bus, ()):
            node.out(0, msg)


@register("receive", "r")
class Receive(Node):
    """Output every message sent to its bus name by ``send`` nodes (or by ``msg`` boxes with ``; bus``)."""

    bus_end = "hears"
    outlets = (Outlet("out", "any", "what was sent"),)
    params = (Param("bus", "symbol", doc="the bus name"),)

    def start(self) -> None:
        self._runtime().bus.setdefault(self.p.bus, []).append(self)

    def close(self) -> None:
        if self.rt is not None and self in self.rt.bus.get(self.p.bus, []):
            self.rt.bus[self.p.bus].remove(self)


@register("loadbang")
class Loadbang(Node):
    """Output a bang once, when the patch has started."""

    outlets = (Outlet("out", "bang", "one bang at start"),)

    def loadbang(self) -> None:
        self.time = self.now
        self.out(0, None)


@register("print")
class Print(Node):
    """Print every message to the console, behind a prefix, as a person reads it: numbers rounded to
    ``decimals`` places (a direction to 0.1 deg by default), no type words (``list``, ``symbol``)."""

    needs_input = True
    inlets = (Inlet("in", ("any",), "any message"),)
    params = (
        Param("prefix", "symbol", "print", "text before each message"),
        Param("time", "bool", False, "also show the message's time stamp"),
        Param(
            "decimals", "int", 1, "places after the point of every number", minimum=0, maximum=12, live=True
        ),
    )

    def on_in(self, msg: Message) -> None:
        stamp = f" @{msg.time:.3f}" if self.p.time else ""
        self._runtime().console(f"{self.p.prefix}{stamp}: {msg.human(self.p.decimals)}")


@register("change")
class Change(Node):
    """Let a value through only when it differs from the previous one (drop repeats).

    ``set x`` sets the remembered value without output.
    """

    pure = True

    inlets = (Inlet("in", ("float", "int", "symbol", "list", "vector"), "a value"),)
    outlets = (Outlet("out", "any", "the value, when it changed"),)

    def setup(self) -> None:
        self._last: Any = None

    def on_in(self, msg: Message) -> None:
        if msg.kind == "bang":
            if self._last is not None:
                self.out(0, make(self._last, msg.time))
            return
        v = msg.value
        same = (
            self._last is not None
            and type(self._last) is type(v)
            and (np.array_equal(self._last, v) if isinstance(v, np.ndarray) else self._last == v)
        )
        if not same:
            self._last = v
            self.out(0, msg)

    def do_set(self, value: Any) -> None:
        self._last = value


@register("speedlim")
class Speedlim(Node):
    """Let at most one message through every ``interval`` ms; the latest held one follows when it ends."""

    pure = True

    inlets = (
        Inlet("in", ("any",), "any message"),
        Inlet("interval", ("float", "int"), "set the interval (ms)", param="interval"),
    )
    outlets = (Outlet("out", "any", "the rate-limited messages"),)
    params = (Param("interval", "float", 100.0, "minimum time between outputs", unit="ms", live=True),)

    def setup(self) -> None:
        self._held: Message | None = None
        self._timer: Timer | None = None

    def on_in(self, msg: Message) -> None:
        if self._timer is None:
            self._pass(msg)
        else:
            self._held = msg

    def _pass(self, msg: Message) -> None:
        self._timer = self.call_later(self.p.interval / 1000.0, self._release)
        self.out(0, msg)

    def _release(self) -> None:
        self._timer = None
        if self._held is not None:
            msg, self._held = self._held, None
            self._pass(msg)

    def close(self) -> None:
        if self._timer is not None:
            self._timer.cancel()


@register("msg")
class Msg(Node):
    """A message box: on any input, output its content, with ``$1``... replaced by the input's elements.

    ``,`` separates messages sent one after the other; ``; bus message`` sends to a ``receive`` bus.
    """

    needs_input = True

    inlets = (Inlet("in", ("any",), "bang or the values for $1, $2..."),)
    outlets = (Outlet("out", "any", "the message"),)
    params = (Param("content", "list", (), "the message text", variadic=True),)

    def on_in(self, msg: Message) -> None:
        if msg.kind == "list":
            args = list(msg.value)
        elif msg.kind in ("float", "int", "symbol"):
            args = [msg.value]
        elif msg.is_method:
            args = [msg.kind, *msg.value]
        else:
            args = []
        to_bus = False  # after a ';' the first atom of each message names a receive bus
        for part, sep in _split(self.p.content):
            atoms = [_dollar(a, args) for a in part]
            if atoms and not to_bus:
                self.out(0, _atoms_to_message(atoms, msg.time))
            elif len(atoms) > 1:
                for node in list(self._runtime().bus.get(str(atoms[0]), ())):
                    node.out(0, _atoms_to_message(atoms[1:], msg.time))
            to_bus = to_bus or sep == ";"


def _split(content: tuple) -> list[tuple[list, str]]:
    """The messages of a message box and the separator after each (``,`` ``;`` or none at the end).

    >>> _split(("a", 1, ",", "b", 2, ";", "bus", "go"))
    [(['a', 1], ','), (['b', 2], ';'), (['bus', 'go'], '')]
    """
    parts, cur = [], []
    for tok in content:
        if tok in (",", ";"):
            parts.append((cur, tok))
            cur = []
        else:
            cur.append(tok)
    parts.append((cur, ""))
    return parts


def _dollar(atom: Any, args: list) -> Any:
    if isinstance(atom, str) and atom.startswith("$") and atom[1:].isdigit():
        i = int(atom[1:])
        if not 1 <= i <= len(args):
            raise ValueError(f"${i}: the input has {len(args)} element(s)")
        return args[i - 1]
    return atom


def _atoms_to_message(atoms: list, time: float) -> Message:
    head = atoms[0]
    if isinstance(head, str):
        if head == "bang" and len(atoms) == 1:
            return bang(time)
        if head in ("list", "float", "symbol"):
            return make(tuple(atoms[1:]) if head == "list" else atoms[1], time)
        return method(head, *atoms[1:], time=time)
    if len(atoms) == 1:
        return make(head, time)
    return make(tuple(atoms), time)
