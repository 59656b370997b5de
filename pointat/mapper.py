r"""A running patch on a libmapper bus: what it offers as signals, and the library's device behind it.

`libmapper <https://libmapper.org>`_ is the signal-mapping network of the live-electronics world (the one
webmapper draws, with Max, Pd, SuperCollider, Python and C bindings): devices find each other on the LAN
and anyone maps any outgoing signal to any incoming one, with a range or an expression.  pointat writes no
bus of its own; this module says how a patch's messages become signals, and keeps the library's calls in
one place (the nodes are :mod:`pointat.osc_bridge.mapper`'s ``mapper`` and ``mapper_in``).  The library is
the optional extra ``pointat[mapper]``: :func:`load` imports it only when a patch asks for the bus.

**The device.**  One libmapper device a patch, named after it (``pointat run glove_tqt --mapper eth0``
is ``pointat_glove_tqt.1`` on the bus; libmapper adds the ordinal; ``--mapper-name anna`` names it
``anna.1``).  It joins the bus on the one interface it is told (:class:`Device`); the library's own UDP
ports listen on every address of the machine once it is there, and the bus has no access control: it
belongs on a show's own network.

**Outgoing signals** (float32; one signal per glove rather than instances of one, so that webmapper
lists each glove by its node's name, and a map from glove A's azimuth is drawn from ``A/azimuth``):

============================  =======  =========  ==============  ========================================
signal                        length   unit       range           from
============================  =======  =========  ==============  ========================================
``NODE/azimuth``              1        deg        -180 .. 180     every pointer (a node with a reading
``NODE/elevation``            1        deg        -90 .. 90       marked ``direction``: ``osc_out``), as
``NODE/distance``             1        deg        0 .. 90         they reach its inlets of those names,
                                                                  in pointat's convention (+ left, + up,
                                                                  0 far .. 90 near), before any
                                                                  receiver's profile
``NODE/quat``                 4        (none)     -1 .. 1         the nearest ``quat`` outlet upstream of
                                                                  that pointer (w x y z, sensor -> NWU)
``NODE/LABEL``                1        score      0 .. 1          a ``gesture`` outlet's LABEL SCORE, one
                                                                  signal a label, made as it is first seen
``NODE/LABEL``                1        (none)     0 .. 1          a ``posture`` outlet: 1 as the hand
                                                                  takes it, 0 as it leaves (``none``)
``NODE/stroke``               3        deg,deg,g  see below       a ``stroke`` outlet: azimuth -180..180,
                                                                  elevation -90..90, strength 0..16 g
``NODE/SEGMENT``              4        (none)     -1 .. 1         a ``segments`` outlet, one signal a
                                                                  segment, named as the node's body names
                                                                  it (``segment0``... otherwise)
============================  =======  =========  ==============  ========================================

Found by declaration (a node's readings, its outlets' names), never by node type: a third party's node with a
``gesture`` outlet is published as the built-in one is.  A value is set as the message passes and the
bus is told when the scheduler's pass ends (:meth:`pointat.runtime.Runtime.at_pass_end`), so a glove's
three coordinates leave together.

**Incoming signals**: every live parameter of every node (:class:`pointat.node.Param` ``live=True``, as
OSCQuery lists them), ``NODE/PARAM``: a float, int or bool (int 0/1) of length 1, or a vector of its
size, with the declared unit and bounds as its range.  A value that arrives is set on the scheduler's
thread exactly as ``/pointat/NODE/PARAM value`` over OSC would set it (:func:`pointat.control.control`):
validated, refused and logged when it does not fit, told on the console.  Symbols and lists have no
libmapper type and are left out.

**Polling.**  libmapper does its work when polled; the ``mapper`` node polls it without waiting
(``poll(0)``, a few microseconds) every :data:`POLL` seconds of the scheduler's clock, so an incoming
value waits at most that long and the scheduler is never held.

Names: a label or a node's name becomes part of an OSC path on the bus; :func:`signal_name` keeps
letters, digits and ``_ - . /`` and turns anything else into ``_``.
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from types import ModuleType
from typing import Any

from .errors import PointatError

__all__ = [
    "EXTRA",
    "POLL",
    "POINTER",
    "Device",
    "SignalSpec",
    "device_name",
    "every",
    "load",
    "param_signal",
    "signal_name",
]

log = logging.getLogger("pointat.mapper")

#: The optional extra that brings libmapper.
EXTRA = "pointat[mapper]"
#: Seconds between two polls of the library by the scheduler (an incoming value's longest wait).
POLL = 0.005
#: How long a device may take to become ready on the bus (name and ordinal agreed with its peers).
READY = 10.0


def load() -> ModuleType:
    """The libmapper module, or a :class:`~pointat.errors.PointatError` that names the extra to install."""
    try:
        import libmapper
    except ImportError as exc:  # (an OSError too, when the wheel's shared library cannot load)
        raise PointatError(
            f"the libmapper bus needs the optional extra: pip install '{EXTRA}' ({exc})"
        ) from None
    except OSError as exc:
        raise PointatError(f"libmapper is installed but its library does not load: {exc}") from None
    return libmapper


@dataclass(frozen=True)
class SignalSpec:
    """One signal: its name on the device, vector length, type (``f`` float32, ``i`` int32), unit and
    range (one number a component, or None where unbounded)."""

    name: str
    length: int = 1
    type: str = "f"
    unit: str = ""
    minimum: tuple[float, ...] | None = None
    maximum: tuple[float, ...] | None = None


_UNSAFE = re.compile(r"[^A-Za-z0-9_.\-/]")


def signal_name(*parts: str) -> str:
    """Parts joined by ``/`` as a signal's name: characters that OSC paths or webmapper would take
    otherwise become ``_``, and no part is empty.

    >>> signal_name("left/out", "azimuth")
    'left/out/azimuth'
    >>> signal_name("moves", "big circle #2")
    'moves/big_circle__2'
    >>> signal_name("moves", "")
    'moves/_'
    """
    return "/".join(_UNSAFE.sub("_", p.strip("/")) or "_" for p in parts)


def device_name(text: str, prefix: str = "pointat_") -> str:
    """A device name from a patch's name (or a person's): libmapper's take no ``/``, spaces or dots
    (its ordinal follows a dot).

    >>> device_name("glove_tqt")
    'pointat_glove_tqt'
    >>> device_name("my show.v2", prefix="")
    'my_show_v2'
    """
    return prefix + (re.sub(r"[^A-Za-z0-9_\-]", "_", text) or "patch")


def _three(low: float, high: float, n: int) -> tuple[tuple[float, ...], tuple[float, ...]]:
    return (low,) * n, (high,) * n


#: A pointer's coordinates: (name, unit, minimum, maximum), in pointat's convention.
POINTER = (
    ("azimuth", "deg", -180.0, 180.0),
    ("elevation", "deg", -90.0, 90.0),
    ("distance", "deg", 0.0, 90.0),
)
QUAT = SignalSpec("quat", 4, "f", "", *_three(-1.0, 1.0, 4))
STROKE = SignalSpec("stroke", 3, "f", "deg,deg,g", (-180.0, -90.0, 0.0), (180.0, 90.0, 16.0))


def param_signal(node_name: str, p: Any) -> SignalSpec | None:
    """The incoming signal of a live parameter ``p`` (:class:`pointat.node.Param`), or None when its
    type has no libmapper form (a symbol, a list, a path, a vector of no fixed size).

    >>> from pointat.node import Param
    >>> param_signal("tqt/fuse", Param("k", "float", 0.5, unit="", live=True, minimum=0.0, maximum=1.0))
    SignalSpec(name='tqt/fuse/k', length=1, type='f', unit='', minimum=(0.0,), maximum=(1.0,))
    >>> param_signal("out", Param("change", "bool", False, live=True)).type
    'i'
    >>> param_signal("out", Param("profile", "symbol", "pointat", live=True)) is None
    True
    """
    name = signal_name(node_name, p.name)
    if p.type == "bool":
        return SignalSpec(name, 1, "i", "", (0.0,), (1.0,))
    if p.type in ("float", "int"):
        n, kind = 1, "f" if p.type == "float" else "i"
    elif p.type == "vector" and p.size:
        n, kind = int(p.size), "f"
    else:
        return None
    low = p.minimum if p.minimum is not None else p.above
    return SignalSpec(
        name,
        n,
        kind,
        p.unit,
        None if low is None else (float(low),) * n,
        None if p.maximum is None else (float(p.maximum),) * n,
    )


class Device:
    """One libmapper device on one interface: signals added, values set and sent, the bus polled.

    Every call is the scheduler thread's (libmapper is not thread-safe); none of them waits.
    """

    def __init__(self, name: str, interface: str, subscribe: bool = False):
        mpr = self.mpr = load()
        flags = mpr.Type.DEVICE | mpr.Type.SIGNAL if subscribe else mpr.Type.UNKNOWN
        self.graph = mpr.Graph(flags)
        self.graph.set_interface(interface)
        if self.graph.interface != interface:  # libmapper falls back to another one without a word
            found = self.graph.interface
            self.graph.free()
            raise PointatError(
                f"no network interface '{interface}' for the libmapper bus (libmapper would have taken "
                f"'{found}'); name one of this machine's: ip -brief address"
            )
        self.dev = mpr.Device(name, self.graph)
        self.signals: dict[str, Any] = {}
        self._callbacks: list[Callable[..., None]] = []  # kept alive while libmapper holds them
        self._pending: set[int] = set()  # the signals given a value since the last flush (their ids)
        self._closing = False

    @property
    def ready(self) -> bool:
        """Whether the bus has agreed the device's name (before that no map can reach it)."""
        return self.dev is not None and bool(self.dev.ready)

    @property
    def name(self) -> str:
        """The device's name on the bus, ordinal included (``pointat_glove_tqt.1``) once ready."""
        return str(self.dev[self.mpr.Property.NAME]) if self.dev is not None else ""

    def add(
        self,
        spec: SignalSpec,
        incoming: bool = False,
        on_value: Callable[[Any], None] | None = None,
    ) -> Any:
        """Add ``spec`` as an outgoing signal, or an incoming one whose values go to ``on_value(value)``."""
        mpr = self.mpr
        if spec.name in self.signals:
            return self.signals[spec.name]
        one = spec.length == 1

        def bounds(b: tuple[float, ...] | None) -> Any:
            if b is None:
                return None
            values = [int(x) if spec.type == "i" else float(x) for x in b]
            return values[0] if one else values

        callback = None
        if on_value is not None:

            def callback(_sig: Any, _event: Any, _instance: int, value: Any, _time: Any) -> None:
                try:  # (an exception would end in ctypes, printed and lost)
                    if value is not None and not self._closing:
                        on_value(value)
                except Exception:
                    log.exception("libmapper signal '%s': a value could not be taken", spec.name)

            self._callbacks.append(callback)
        sig = self.dev.add_signal(
            mpr.Signal.Direction.INCOMING if incoming else mpr.Signal.Direction.OUTGOING,
            spec.name,
            spec.length,
            mpr.Type.INT32 if spec.type == "i" else mpr.Type.FLOAT,
            spec.unit or None,
            bounds(spec.minimum),
            bounds(spec.maximum),
            None,
            callback,
            mpr.Object.Event.REMOTE_UPDATE,
        )
        self.signals[spec.name] = sig
        return sig

    def set(self, sig: Any, value: float | Sequence[float]) -> None:
        """Give outgoing ``sig`` a value; it leaves at the next :meth:`flush` (or poll).  A signal given a
        second value before then sends the first at once: libmapper keeps only a signal's latest value
        until it sends, and two datagrams read in one pass are two values, both wanted."""
        key = sig._obj
        if key in self._pending:
            self.flush()
        sig.set_value(float(value) if isinstance(value, (int, float)) else [float(v) for v in value])
        self._pending.add(key)

    def flush(self) -> None:
        """Send what was set since the last flush to every map."""
        if self._pending and self.dev is not None:
            self._pending.clear()
            self.dev.update_maps()

    def poll(self) -> None:
        """Take what the bus sent (values, maps made or released) without waiting."""
        if self.dev is not None:
            self.dev.poll(0)

    def find(self, device: str, signal: str) -> Any | None:
        """A remote signal this device's graph knows (it must be made with ``subscribe``): ``device`` as
        the bus names it, with or without its ordinal (``pointat_glove.1`` or ``pointat_glove``)."""
        prop = self.mpr.Property.NAME
        for sig in every(self.graph.signals()):
            if sig[prop] != signal:
                continue
            owner = str(sig.device()[prop])
            if owner == device or owner.rpartition(".")[0] == device:
                return sig
        return None

    #: Polls at most, when the device closes, to take what is still on its way (dropped).
    DRAIN = 100

    def close(self) -> None:
        """Leave the bus (idempotent).  What is still on its way is taken first and dropped: freeing a
        device with values waiting crashed libmapper 2.6.1's binding (a signal's callback called as its
        signal was freed; found by the benchmark's soak, benchmarks/mapper.py)."""
        if self.dev is not None:
            self._closing = True
            for _ in range(self.DRAIN):
                if self.dev.poll(0) <= 0:
                    break
            self.dev.free()
            self.dev = None
        if self.graph is not None:
            self.graph.free()
            self.graph = None


def every(found: Any) -> list[Any]:
    """A libmapper query's result (``graph.signals()``, ``sig.maps()``...) read to its end at once: a
    result left half read and collected after its graph is freed crashes the interpreter (libmapper
    2.6.1's ``List.__del__``)."""
    return list(found)


def finite(values: Sequence[float]) -> bool:
    """Whether every value is a finite number (what may be set on a signal).

    >>> finite([1.0, 2.0]), finite([1.0, math.nan])
    (True, False)
    """
    return all(math.isfinite(v) for v in values)
