r"""The node model: a node class declares its inlets, outlets and parameters in one place.

This is Pure Data's object model in Python.  A node type is a :class:`Node` subclass that declares

* ``inlets``: the left inlet is *hot* (a message there computes and outputs), the others are *cold*
  (they only store) unless an :class:`Inlet` says ``hot=True``;
* ``outlets``: a node that outputs on several outlets does so **right to left** (:meth:`Node.emit`);
* ``params``: name, type, default, unit, doc, and whether it can change while running (``live``).
  Creation arguments come from this declaration, by name (``k=0.5``) or by position (``metro 100``).

A message reaching inlet ``gyro`` calls ``on_gyro(msg)``; a cold inlet without a handler stores the
message in ``self.cold["name"]``; a cold inlet declared with ``param=`` sets that parameter.  A *method*
message (``recalibrate``, ``k 0.5``) at the left inlet calls ``do_recalibrate()`` or sets a live
parameter.  Dispatch is synchronous and depth first: :meth:`Node.out` delivers to every connected inlet,
in connection order, before it returns.  A data message goes straight to the inlet's handler; a
method message goes through :meth:`Node.receive`, and so does every message to a node type that
overrides ``receive`` (``trigger``, ``pack``: the class's own, bound when the node is made).

A node type whose per-sample work a compiled chain (:mod:`pointat.compiled`, ``pointat run --compiled``)
can do for it says so (``fusable = True``) and owns its state there as everywhere: :meth:`Node.fused_state`
gives the state the chain runs on, as plain values (None while the node is in no steady state to hand
over: an average under way, a capture pending), and :meth:`Node.restore_fused` takes it back, moved on,
when the chain hands the node its work again.  What the chain needs of every node the base gives:
:meth:`Node.targets` to read the wiring, :meth:`Node.detach` and :meth:`Node.reattach` to leave out a link
whose work it does, and :meth:`Node.hold` and :meth:`Node.unhold` to be told before the node handles
anything from outside the chain (a message, a method, a parameter) or shows its health.  The chain reads
no private field of any node: a node's author may change those freely.

A minimal node::

    @register("double")
    class Double(Node):
        "Output twice the input."
        inlets = (Inlet("in", ("float",), "a number"),)
        outlets = (Outlet("out", "float", "twice the number"),)

        def on_in(self, msg):
            self.out(0, 2.0 * as_float(msg))
"""

from __future__ import annotations

import functools
import inspect
import logging
import re
import threading
from collections.abc import Callable, Collection, Mapping, Sequence
from typing import TYPE_CHECKING, Any, ClassVar

from .declarations import (
    PARAM_TYPES,
    REQUIRED,
    ROLES,
    Inlet,
    Outlet,
    Param,
    ParamError,
    Params,
    Reading,
)
from .errors import FeedbackError, did_you_mean, worth_reporting
from .message import KINDS, Message, make

if TYPE_CHECKING:
    from pathlib import Path

    from .errors import Where
    from .scheduling import Scheduler, Timer

__all__ = [
    "PARAM_TYPES",
    "REQUIRED",
    "ROLES",
    "SKIP",
    "Inlet",
    "Node",
    "Outlet",
    "Param",
    "ParamError",
    "Params",
    "Reading",
    "Tap",
]

log = logging.getLogger("pointat.node")

#: Placeholder in :meth:`Node.emit` for an outlet that stays silent.
SKIP: Any = type("Skip", (), {"__repr__": lambda self: "SKIP"})()

#: How deep synchronous dispatch may go before it is called a feedback loop (Pd's stack limit is 1000
#: objects; a Python hop costs several interpreter frames, and real chains are a few dozen deep).
MAX_DEPTH = 250


def _check_arguments(sel: str, fn: Callable[..., Any], args: Sequence[Any]) -> None:
    """Raise a TypeError in the sender's words when ``args`` do not fit method ``fn``'s parameters."""
    sig = inspect.signature(fn)
    try:
        sig.bind(*args)
    except TypeError:
        names = [
            p.name.upper() if p.default is inspect.Parameter.empty else f"[{p.name.upper()}]"
            for p in sig.parameters.values()
        ]
        takes = f"'{sel} {' '.join(names)}'" if names else f"'{sel}' alone, no values"
        raise TypeError(f"method '{sel}' takes {takes}; got {len(args)} value(s) {tuple(args)}") from None


class Node:
    """Base class of every node type.  See the module docstring for the model.

    Subclasses declare ``inlets``, ``outlets``, ``params`` and optionally ``example`` (a patch snippet
    shown by ``pointat help``), and override the hooks they need: :meth:`setup`, :meth:`start`,
    :meth:`loadbang`, :meth:`param_changed`, :meth:`close`.

    What people see of a node is declared too, and the engine knows no node type by name: ``role``
    (``input``, ``output`` or ``process``: the console's banner lists inputs and outputs, with what
    :meth:`describe` says of each), ``readings`` (values of its state, each a :class:`Reading` with its
    units and range, given by :meth:`read`: the monitor shows them and OSCQuery serves them read-only;
    one marked ``direction`` is a pointer on the monitor and a direction on the console's status line),
    and :meth:`health` (plain words and numbers: a mote's lost packets, a calibration's step)::

        role = "output"
        readings = (Reading("aed", "the direction last sent", units=("deg", "deg", ""), direction=True),)

        def read(self):
            return {"aed": self.last}
    """

    type_name: ClassVar[str] = ""
    aliases: ClassVar[tuple[str, ...]] = ()
    inlets: ClassVar[tuple[Inlet, ...]] = ()
    outlets: ClassVar[tuple[Outlet, ...]] = ()
    params: ClassVar[tuple[Param, ...]] = ()
    example: ClassVar[str] = ""
    #: True for nodes whose output never happens inside the call that fed them (delay, metro):
    #: a loop through such a node is not a synchronous feedback loop.
    defers: ClassVar[bool] = False
    #: True for nodes whose only effect is their output (conversions, filters, control logic): when no
    #: path from such a node reaches a node with effects (an output, a file, a print), the runtime does
    #: not feed it at all (:meth:`pointat.runtime.Runtime.prune`).
    pure: ClassVar[bool] = False
    #: True for nodes that do nothing until a message reaches their hot inlet: ``pointat check`` warns
    #: when nothing in the patch wires to it.  ``None`` (the default): as :attr:`pure` says; sinks
    #: (``osc_out``, ``record``, ``print``) say True, sources with an optional inlet (``mote``) False.
    needs_input: ClassVar[bool | None] = None
    #: True for nodes that do their work with nothing wired to their outlets (``osc_in``'s live control).
    acts_alone: ClassVar[bool] = False
    #: Parameter values the type's Pd stub (:func:`pointat.pdfile.write_stubs`) is drawn for, where the
    #: ports depend on parameters and the defaults would give too few.
    stub_values: ClassVar[dict[str, Any]] = {}
    #: Where the class came from (module, entry point or plugin file), for error messages.
    origin: ClassVar[str] = ""
    #: A source's outlets that carry one sensor sample per message (a regular expression over outlet
    #: names, ``m[0-9]+`` for a mote's): the console, the monitor and OSCQuery count them for the rate,
    #: and tell a dropout when they fall silent (:mod:`pointat.monitor.observe`).
    sample_outlets: ClassVar[str] = ""
    #: Where the node is declared (patch file and line), when it was built from a patch: the runtime's
    #: errors name the place.
    where: Where | None = None
    #: Where a file the node names itself goes, as its patch's own relative files do: beside the patch
    #: file, or ``pointat run --out`` (the working directory by default) for a shipped patch; None (the
    #: working directory) for a patch read from no file (:func:`pointat.checking.files_folder`).
    folder: Path | None = None

    # ----------------------------------------------------------------- what people see of it
    #: Whether the node is an end of a named bus (its ``bus`` parameter), as Pd's ``[send]`` and
    #: ``[receive]`` are: ``"sends"`` (what reaches it goes to every node of the bus that ``"hears"``),
    #: ``"hears"``, or None.  The runtime orders and the checker follows the links a bus makes from this.
    bus_end: ClassVar[str | None] = None
    #: What the node is to a performer: ``input`` (where the patch's data comes from: a glove, a file, a
    #: port), ``output`` (where it goes: a receiver, a file, a port) or ``process`` (the work between).
    #: The console's banner lists the inputs and outputs, each with what :meth:`describe` says.
    role: ClassVar[str] = "process"
    #: The values the node lets people read while it runs (:class:`Reading`), given by :meth:`read`: the
    #: monitor shows them, OSCQuery serves them; a ``direction`` one is drawn as a pointer.
    readings: ClassVar[tuple[Reading, ...]] = ()

    def describe(self) -> str:
        """What the node reads or where it sends, as a performer names it (``OSC to 127.0.0.1:9000``):
        the console's banner line after the node's type and name.  Default: nothing."""
        return ""

    def read(self) -> Mapping[str, Any]:
        """The value of each of :attr:`readings` now, by name (a number, or a sequence of ``size``).
        Called from the observer's thread (:mod:`pointat.monitor.observe`), so it only reads attributes.

        A node with a ``direction`` reading says through :meth:`health` whether it is fresh: ``heard``
        (the directions that came in so far: none yet is *waiting*, no new one for the node's ``dropout``
        seconds a *dropout*), ``flag`` (the filter's state, as it was told) and ``updates`` (sent).
        Default: nothing."""
        return {}

    #: True for node types whose per-sample work a compiled chain (:mod:`pointat.compiled`) can do: they
    #: implement :meth:`fused_state` and :meth:`restore_fused`.
    fusable: ClassVar[bool] = False

    # ----------------------------------------------------------------- declaration
    @classmethod
    def layout(cls, values: Mapping[str, Any]) -> tuple[tuple[Inlet, ...], tuple[Outlet, ...]]:
        """Inlets and outlets for these parameter values; override when they depend on parameters."""
        return tuple(cls.inlets), tuple(cls.outlets)

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        """Raise ``ValueError`` when these parameter values cannot work together (an empty range...).

        Runs when a patch is checked, so the error carries the patch line, and before every live change,
        so a bad change is refused and the old values stay.  Override it; the default accepts anything.
        """

    @classmethod
    def check_files(cls, values: Mapping[str, Any]) -> None:
        """Read the files the node reads (its ``reads`` parameters, all of them there) as it will when the
        patch starts, and raise what it would raise: ``pointat check`` calls this, so that a calibration
        file spoiled by a hand edit is found before the show, not at it.

        The default builds the node, for a node reads its files as it is built (:meth:`setup`); a node
        that reads them in :meth:`start` overrides it.
        """
        cls("check", values).close()

    @classmethod
    def param(cls, name: str) -> Param | None:
        for p in cls.params:
            if p.name == name:
                return p
        return None

    @classmethod
    def unknown_param(cls, key: str) -> str:
        """What to say of a parameter ``key`` the node does not have: the closest one, and all of them."""
        names = [q.name for q in cls.params]
        return (
            f"unknown parameter '{key}'{did_you_mean(key, names)}; parameters: {', '.join(names) or 'none'}"
        )

    @classmethod
    def resolve_params(cls, positional: Sequence[Any] = (), named: Mapping[str, Any] | None = None) -> dict:
        """Creation arguments -> a complete, typed parameter dict.

        Positional arguments fill the parameters in declaration order (a variadic parameter takes the
        rest); named ones override.  Raises :class:`ParamError` naming the parameter, expected and got.
        """
        named = dict(named or {})
        values: dict[str, Any] = {}
        problems: list[str] = []  # every one, not the first: a patch is mended in one go
        pos = list(positional)
        for p in cls.params:
            if not pos:
                break
            if p.variadic:
                values[p.name] = tuple(pos)
                pos = []
            else:
                values[p.name] = pos.pop(0)
        if pos:
            problems.append(
                f"too many creation arguments: {len(positional)} given, "
                f"{len([p for p in cls.params if not p.variadic])} expected ({', '.join(map(repr, pos))} left over)"
            )
        for key, value in named.items():
            p = cls.param(key)
            if p is None:
                problems.append(cls.unknown_param(key))
            elif key in values:
                problems.append(f"parameter '{key}' given twice (by position and by name)")
            else:
                values[key] = value
        out = {}
        for p in cls.params:
            if p.name in values:
                try:
                    out[p.name] = p.coerce(values[p.name])
                    continue
                except (ParamError, ValueError) as exc:
                    problems.append(str(exc))
            elif p.default is REQUIRED:
                problems.append(f"parameter '{p.name}' is required ({p.doc or p.type})")
            out[p.name] = p.default
        if problems:
            raise ParamError("; ".join(problems), out)
        return out

    # ----------------------------------------------------------------- instance
    def __init__(self, name: str = "", values: Mapping[str, Any] | None = None):
        self.name = name or self.type_name
        cls = type(self)
        if values is None or any(p.name not in values for p in cls.params):
            values = cls.resolve_params(named=values)
        self.p = Params(values)
        self.in_specs, self.out_specs = cls.layout(values)
        self._targets: list[list[tuple[Node, int]]] = [[] for _ in self.out_specs]
        self.cold: dict[str, Message] = {}
        self.time = 0.0
        self.rt: Scheduler | None = None  # the runtime, once the node is in one
        self.active = False
        #: Set by a source whose material is over (a take played to its end, a duration run out), as
        #: against one closed by a message: the patch's end (:meth:`Runtime._finished`).
        self.ended = False
        self.errors = 0
        self._handlers = [self._make_handler(i, inlet) for i, inlet in enumerate(self.in_specs)]
        #: What :meth:`out` calls with a data message, per inlet: the handler itself, or the class's own
        #: ``receive`` where it overrides the base's.
        self._deliver: list[Callable[[Message], None]] = (
            self._handlers
            if cls.receive is Node.receive
            else [functools.partial(self.receive, i) for i in range(len(self.in_specs))]
        )
        self._detached: dict[int, list[tuple[Node, int]]] = {}  # outlet -> its targets before detach
        self._held: tuple[list[Callable[[Message], None]], list[Callable[[Message], None]]] | None = None
        self.setup()

    def __repr__(self) -> str:
        return f"<{self.type_name} '{self.name}'>"

    def _make_handler(self, index: int, inlet: Inlet) -> Callable[[Message], None]:
        handler = getattr(self, "on_" + inlet.name, None)
        if handler is not None:
            return handler
        if inlet.param is not None:
            pname = inlet.param

            def set_from_inlet(msg: Message) -> None:
                self.set_param(pname, msg.value if msg.kind != "list" else list(msg.value))

            return set_from_inlet

        def store(msg: Message) -> None:
            self.cold[inlet.name] = msg

        return store

    # hooks ------------------------------------------------------------------
    def setup(self) -> None:
        """Build the node's state from ``self.p`` (no I/O here)."""

    def prepare(self) -> None:
        """Heavy one-time work before the patch's clock starts (a model read and trained, compiled code
        loaded), so that it holds no timer up.  No output here.  Called once, before :meth:`start`."""

    def start(self) -> None:
        """Open ports, start threads or timers. Called once when the patch starts running."""

    def loadbang(self) -> None:
        """Called once after every node has started."""

    def param_changed(self, name: str) -> None:
        """A parameter was set while running; rebuild what depends on it."""

    def health(self) -> Mapping[str, Any]:
        """What a person would want to know of this node while it runs (a filter's rest, a mote's lost
        packets, a calibration's step), as names and plain values; read from the observer's thread
        (:mod:`pointat.monitor.observe`), so it must only read attributes, never change them.  Default: nothing."""
        return {}

    def close(self) -> None:
        """Release ports, files and threads. Must be idempotent."""

    # the compiled chain's door (pointat.compiled) ---------------------------------
    def fused_state(self) -> dict[str, Any] | None:
        """The state a compiled chain runs this node's work on, as plain values (numbers, tuples), or None
        while the node is in no steady state to hand over.  Implemented by :attr:`fusable` types; the
        chain reads parameters from ``self.p`` as anyone may."""
        raise NotImplementedError(f"{self.type_name} nodes cannot be fused")

    def restore_fused(self, state: Mapping[str, Any]) -> None:
        """Take back the state a compiled chain ran on: what :meth:`fused_state` gave, its values moved on
        by the samples the chain handled meanwhile."""
        raise NotImplementedError(f"{self.type_name} nodes cannot be fused")

    def targets(self, outlet: int) -> list[tuple[Node, int]]:
        """Where ``outlet`` sends, in connection order: ``(node, inlet index)`` pairs (a copy)."""
        return list(self._targets[outlet])

    def connected(self, outlet: int) -> bool:
        """Whether ``outlet`` sends anywhere (what :meth:`targets` says, with no copy made)."""
        return bool(self._targets[outlet])

    def tap(
        self, outlet: int, fn: Callable[[Message], None], bulk: Callable[[int], None] | None = None
    ) -> Tap:
        """Also call ``fn(msg)`` for every message ``outlet`` sends, after its wired targets: a listener
        that is no node of the patch (the monitor's observer, the libmapper bus).  A sender with no
        messages to give (a compiled chain) calls ``bulk(n)`` for n of them, where there is one.  Returns
        the tap, for :meth:`untap`; a reload keeps it on a node that stays."""
        listener = Tap(fn, bulk)
        self._targets[outlet].append((listener, 0))
        return listener

    def untap(self, outlet: int, listener: Tap) -> None:
        """Stop calling what :meth:`tap` gave (idempotent)."""
        self._targets[outlet] = [t for t in self._targets[outlet] if t[0] is not listener]

    def unwire(self, keep: Callable[[Node], bool] | None = None) -> None:
        """Send nowhere any more but to the targets ``keep`` says yes to (by their node): a reload rewires
        a patch and keeps, on a node that stays, the listeners that are not the patch's (the observer's)."""
        self._targets = [[t for t in targets if keep is not None and keep(t[0])] for targets in self._targets]

    def detach(self, outlet: int, target: Node, inlet: int) -> None:
        """Stop sending from ``outlet`` to ``target``'s inlet ``inlet`` until :meth:`reattach` (a compiled
        chain does that link's work meanwhile).  Connections made meanwhile stay, after the old ones."""
        self._detached.setdefault(outlet, self._targets[outlet])
        self._targets[outlet] = [(n, i) for n, i in self._targets[outlet] if not (n is target and i == inlet)]

    def reattach(self, outlet: int | None = None) -> None:
        """Send again over the links :meth:`detach` left out, at ``outlet`` or at every outlet, in their
        old order (idempotent)."""
        for o in list(self._detached) if outlet is None else [outlet]:
            old = self._detached.pop(o, None)
            if old is not None:
                old += [t for t in self._targets[o] if t not in old]
                self._targets[o] = old

    def hold(
        self, release: Callable[[], None], sync: Callable[[], None], *, open_inlets: Collection[str] = ()
    ) -> None:
        """Until :meth:`unhold`, call ``release()`` before this node handles anything that reaches it (a
        message at any inlet but those named in ``open_inlets``, a method, a parameter set), and
        ``sync()`` before its :meth:`health` or :meth:`read` is read: a compiled chain doing this node's work hands it
        back first, or writes its state into the node (:mod:`pointat.compiled`).  ``release`` may be
        called more than once for one message (by :meth:`receive`, then by the inlet's handler)."""
        if self._held is not None:
            raise RuntimeError(f"node '{self.name}' is held already")

        def first(before: Callable[[], None], fn: Callable[..., Any]) -> Callable[..., Any]:
            @functools.wraps(fn)  # (its marks too: names_path)
            def wrapper(*args: Any, **kwargs: Any) -> Any:
                before()
                return fn(*args, **kwargs)

            return wrapper

        handlers = list(self._handlers)
        deliver = handlers if self._deliver is self._handlers else list(self._deliver)
        held = [i for i, spec in enumerate(self.in_specs) if spec.name not in open_inlets]
        for i in held:
            handlers[i] = first(release, self._handlers[i])
            if deliver is not handlers:
                deliver[i] = first(release, self._deliver[i])
        self._held = (self._handlers, self._deliver)
        self._handlers, self._deliver = handlers, deliver
        receive = self.receive

        @functools.wraps(receive)
        def receive_held(index: int, msg: Message) -> None:
            if index in held:  # (a method or a parameter comes to the left inlet: held unless open)
                release()
            receive(index, msg)

        # the instance's own, in front of the class's methods until unhold
        self.receive = receive_held  # type: ignore[method-assign]
        self.set_params = first(release, self.set_params)  # type: ignore[method-assign]
        self.health = first(sync, self.health)  # type: ignore[method-assign]
        self.read = first(sync, self.read)  # type: ignore[method-assign]

    def unhold(self) -> None:
        """End :meth:`hold` (idempotent)."""
        if self._held is None:
            return
        self._handlers, self._deliver = self._held
        self._held = None
        for method in (Node.receive, Node.set_params, Node.health, Node.read):
            self.__dict__.pop(method.__name__, None)

    # receiving --------------------------------------------------------------
    def receive(self, index: int, msg: Message) -> None:
        """Deliver ``msg`` to inlet ``index`` (synchronously)."""
        self.time = msg.time
        if msg.kind in KINDS or not self._method(index, msg):
            self._handlers[index](msg)

    def _method(self, index: int, msg: Message) -> bool:
        """Handle a method message; False passes it on to an inlet that accepts ``any`` message."""
        sel = msg.kind
        p = type(self).param(sel)
        fn = getattr(self, "do_" + sel, None)
        if (p is not None or fn is not None) and index != 0:
            raise TypeError(f"method '{sel}' must be sent to the left inlet")
        if p is not None:
            args = msg.value
            if not args:
                raise TypeError(f"'{sel}' needs a value ({p.describe_type()}), e.g. '{sel} {p.default}'")
            self.set_param(sel, args[0] if len(args) == 1 else list(args))
            return True
        if fn is not None:
            try:
                fn(*msg.value)
            except TypeError:
                _check_arguments(sel, fn, msg.value)  # the sender's mistake, said as the sender sees it
                raise
            return True
        if index < len(self.in_specs) and "any" in self.in_specs[index].accepts:
            return False
        methods = sorted(n[3:] for n in dir(self) if n.startswith("do_"))
        live = sorted(q.name for q in type(self).params if q.live)
        known = ", ".join(methods + live) or "none"
        raise TypeError(f"no method '{sel}' (methods and live parameters: {known})")

    def set_param(self, name: str, value: Any) -> None:
        """Set a parameter, validated against its declaration; only ``live`` ones while running."""
        self.set_params(**{name: value})

    def set_params(self, **values: Any) -> None:
        """Set several parameters at once, validated as a whole (:meth:`validate`): all or none change."""
        cls = type(self)
        running = self.rt is not None and self.rt.running
        new = {}
        for name, value in values.items():
            p = cls.param(name)
            if p is None:
                raise ParamError(f"node '{self.name}' ({self.type_name}) has no parameter '{name}'")
            if running and not p.live:
                raise ParamError(f"parameter '{name}' of node '{self.name}' cannot change while running")
            new[name] = p.coerce(value)
        cls.validate({**vars(self.p), **new})
        old = {name: getattr(self.p, name) for name in new}
        for name, value in new.items():
            setattr(self.p, name, value)
        try:
            for name in new:
                self.param_changed(name)
        except Exception:  # the node refused the new values as it rebuilt: it keeps the ones that worked
            for name, value in old.items():
                setattr(self.p, name, value)
            for name in old:
                self.param_changed(name)
            raise

    def fail(self, index: int, msg: Message, exc: BaseException) -> None:
        """A message could not be handled: log it with the node's name and drop it (rate-limited)."""
        self.errors += 1
        if worth_reporting(self.errors):
            inlet = self.in_specs[index].name if index < len(self.in_specs) else index
            log.error(
                "node '%s' (%s), inlet '%s': dropped %s: %s%s",
                self.name,
                self.type_name,
                inlet,
                msg.describe()[:80],
                exc,
                f" ({self.errors} errors so far)" if self.errors > 3 else "",
            )

    # sending ----------------------------------------------------------------
    def out(self, outlet: int, value: Any, time: float | None = None) -> None:
        """Send ``value`` from ``outlet`` to every connected inlet, depth first, in connection order."""
        targets = self._targets[outlet]
        if not targets:
            return
        msg = value if type(value) is Message else make(value, self.time if time is None else time)
        data = msg.kind in KINDS
        t = msg.time
        rt = self.rt
        if rt is not None:
            depth = rt.depth + 1
            if depth > MAX_DEPTH:
                rt.depth = 0
                raise self._loop(outlet, f"more than {MAX_DEPTH} nested messages", deep=True)
            rt.depth = depth
        for node, inlet in targets:
            try:
                if data:  # the per-sample case: what receive would do, one call less
                    node.time = t
                    node._deliver[inlet](msg)
                else:
                    node.receive(inlet, msg)
            except FeedbackError:  # the depth was reset where it was raised
                raise
            except RecursionError as exc:
                if rt is not None:
                    rt.depth = 0
                raise self._loop(outlet, f"recursion too deep at node '{node.name}'") from exc
            except Exception as exc:  # a bad message never stops the patch
                node.fail(inlet, msg, exc)
        if rt is not None:
            rt.depth -= 1

    def _loop(self, outlet: int, what: str, deep: bool = False) -> FeedbackError:
        """The error of a feedback loop found at ``outlet``.  (Built here, not in :meth:`out`: with the
        message formatted inside it, a hop through ``out`` measured 0.57 instead of 0.38 µs, CPython 3.11.)"""
        if deep:  # a loop, or a chain longer than MAX_DEPTH (which check warns of)
            return FeedbackError(
                f"{what}, last from node '{self.name}' outlet {outlet}: a feedback loop (put a delay in it), "
                f"or a chain of more than {MAX_DEPTH} nodes one after the other (put a delay 0 in it)"
            )
        return FeedbackError(
            f"feedback loop: {what}, last from node '{self.name}' outlet {outlet}; put a delay in the loop"
        )

    def emit(self, *values: Any) -> None:
        """Output one value per outlet, right to left (Pd order); :data:`SKIP` leaves an outlet silent."""
        for i in range(len(values) - 1, -1, -1):
            if values[i] is not SKIP:
                self.out(i, values[i])

    # scheduler access -------------------------------------------------------
    @property
    def now(self) -> float:
        """The scheduler's logical time in seconds."""
        return self.rt.clock.now() if self.rt is not None else 0.0

    def call_later(self, delay: float, fn: Callable[..., Any], *args: Any) -> Timer:
        """Run ``fn(*args)`` on the scheduler thread ``delay`` seconds from now (logical time)."""
        return self._runtime().call_at(self._runtime().clock.now() + delay, self, fn, *args)

    def call_at(self, when: float, fn: Callable[..., Any], *args: Any) -> Timer:
        """Run ``fn(*args)`` on the scheduler thread at logical time ``when`` (a deadline: no drift)."""
        return self._runtime().call_at(when, self, fn, *args)

    def post(self, fn: Callable[..., Any], *args: Any, block: bool = True) -> bool:
        """From any thread: queue ``fn(*args)`` to run on the scheduler thread. False if it was dropped.

        For a source that has a file descriptor, :meth:`add_reader` is quicker: no thread at all.

        ``block`` waits while the queue is full (a file replay); without it a full queue drops the event
        and counts it (a live network source must never stall its reader).
        """
        return self._runtime().post(self, fn, *args, block=block)

    def add_reader(self, fileobj: Any, fn: Callable[[], Any]) -> None:
        """Call ``fn()`` on the scheduler thread whenever ``fileobj`` (a socket, a serial port's file
        descriptor) has data: the scheduler reads it itself, with no thread hand-off.  ``fn`` must read what
        is there.  :meth:`remove_reader` stops it (in :meth:`close`)."""
        self._runtime().add_reader(fileobj, fn, self)

    def remove_reader(self, fileobj: Any) -> None:
        """Stop watching ``fileobj`` (idempotent)."""
        if self.rt is not None:
            self.rt.remove_reader(fileobj)

    def spawn(self, target: Callable[[], Any], what: str = "") -> threading.Thread:
        """Start a thread for blocking I/O; the runtime joins it at shutdown."""
        return self._runtime().spawn(self, target, what)

    def _runtime(self) -> Scheduler:
        if self.rt is None:
            raise RuntimeError(f"node '{self.name}' is not part of a running patch")
        return self.rt

    # documentation ----------------------------------------------------------
    @classmethod
    def help_text(cls) -> str:
        """The help page of the node type, generated from its declaration."""
        doc = plain_text(inspect.cleandoc(cls.__doc__ or ""))
        lines = [f"{cls.type_name}" + (f" (aliases: {', '.join(cls.aliases)})" if cls.aliases else ""), ""]
        if doc:
            lines += [doc, ""]
        try:
            ins, outs = cls.layout({p.name: p.default for p in cls.params})
        except Exception:
            ins, outs = cls.inlets, cls.outlets
        # (each column as wide as its longest entry, so that the descriptions line up)
        port = max([10, *(len(x.name) for x in (*ins, *outs))])
        lines.append("inlets:")
        for i, inlet in enumerate(ins):
            hot = inlet.is_hot(i)
            lines.append(
                f"  {i} {inlet.name:<{port}} {'hot ' if hot else 'cold'} {'|'.join(inlet.accepts):<14} {inlet.doc}"
            )
        if not ins:
            lines.append("  (none)")
        lines.append("outlets:")
        for i, outlet in enumerate(outs):
            lines.append(f"  {i} {outlet.name:<{port}} {outlet.kind:<19} {outlet.doc}")
        if not outs:
            lines.append("  (none)")
        if cls.readings:
            lines.append("readings (what the monitor and OSCQuery show of it while it runs):")
            reading = max([12, *(len(r.name) for r in cls.readings)])
            for r in cls.readings:
                lines.append(f"  {r.name:<{reading}} [{', '.join(u or '-' for u in r.units)}] {r.doc}")
        lines.append("parameters (by name, or by position in this order):")
        name = max([12, *(len(p.name) for p in cls.params)])
        # (a type longer than 22 characters, a long list of choices, overflows its column)
        kind = max([10, *(len(t) for p in cls.params if len(t := p.describe_type()) <= 22)])
        for p in cls.params:
            default = "required" if p.default is REQUIRED else f"default {p.default!r}"
            flags = ", live" if p.live else ""
            unit = f" [{p.unit}]" if p.unit else ""
            lines.append(f"  {p.name:<{name}} {p.describe_type():<{kind}} {default}{unit}{flags}")
            if p.doc:
                lines.append(f"      {p.doc}")
        if not cls.params:
            lines.append("  (none)")
        methods = sorted(n[3:] for n in dir(cls) if n.startswith("do_"))
        if methods:
            lines.append("methods (messages to the left inlet): " + ", ".join(methods))
        if cls.example:
            lines += ["example:", *("  " + ln for ln in cls.example.strip().splitlines())]
        return "\n".join(lines)


# ----------------------------------------------------------------------------- paths
_ROLE = re.compile(r":[\w.+-]+(?::[\w.+-]+)*:`([^`]*)`")
_LITERAL = re.compile(r"``(.+?)``", re.S)
_LINK = re.compile(r"`([^`<]+?)\s*(?:<[^`>]*>)?`__?")
_TICKS = re.compile(r"`([^`]+)`")
_DIRECTIVE = re.compile(r"^(\s*)\.\. [\w:-]+::[ \t]*", re.M)


class Tap(Node):
    """A listener on an outlet (:meth:`Node.tap`): no node of the patch (not in the runtime's nodes), only
    a call per message."""

    inlets = (Inlet("in", ("any",), "any message"),)

    def __init__(self, fn: Callable[[Message], None], bulk: Callable[[int], None] | None = None):
        super().__init__("(tap)")
        self._fn = fn
        #: ``bulk(n)``: n messages at once, for a sender that has no messages to give (the compiled
        #: chains, :mod:`pointat.compiled`); None when each message matters.
        self.bulk = bulk

    def on_in(self, msg: Message) -> None:
        self._fn(msg)


def _role_text(match: re.Match[str]) -> str:
    """``:func:`~a.b.c``` -> ``c``, ``:class:`x <a.b>``` -> ``x``, ``:math:`e^x``` -> ``e^x``."""
    text = match.group(1)
    if text.endswith(">") and "<" in text:
        text = text[: text.rindex("<")].strip()
    return text[1:].rsplit(".", 1)[-1] if text.startswith("~") else text


def plain_text(doc: str) -> str:
    """A docstring's reStructuredText as plain text for a terminal (``pointat help``): roles, literals,
    links and directives to their words, ``Example::`` to ``Example:``.

    >>> plain_text("Gain ``k`` (:math:`e^{-kt}`), see :func:`~pointat.maths.tqt.step` and `Pd`_.")
    'Gain k (e^{-kt}), see step and Pd.'
    >>> print(plain_text("A patch::\\n\\n    node a metro\\n\\n.. math:: q = q_0\\n::\\n"))
    A patch:
    <BLANKLINE>
        node a metro
    <BLANKLINE>
    q = q_0
    <BLANKLINE>
    """
    text = _ROLE.sub(_role_text, doc)
    text = _LITERAL.sub(r"\1", text)
    text = _LINK.sub(r"\1", text)
    text = _TICKS.sub(r"\1", text)
    text = _DIRECTIVE.sub(r"\1", text)
    lines = []
    for line in text.splitlines():
        if line.strip() == "::":
            line = ""
        elif line.endswith("::"):
            line = line[:-1]
        lines.append(line)
    return "\n".join(lines) + ("\n" if text.endswith("\n") else "")


def names_path(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Mark a method (``do_save``) or an inlet's handler that takes a file or device path.

    The rule for live control from outside the patch (``osc_in``'s ``/pointat/...``): it names no path.
    Such a method is called without one (``/pointat/cal/save`` saves to the file the patch chose), and
    a path sent to it is refused; only the patch itself (a ``msg`` box, a wire) gives paths.
    """
    fn.names_path = True  # type: ignore[attr-defined]
    return fn
