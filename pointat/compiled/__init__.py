r"""Compiled glove chains: a patch's per-sample work compiled into one function, as Max's gen~ or Heavy do.

The glove chain of ``patches/glove_tqt.pat``, ``mote -> offset -> scaling -> tqt -> reference ->
azi_ele, roll_distance -> osc_out``, costs about 30 µs a sample node by node, most of it in the hops
between the nodes and the messages they pass.  When the runtime starts, :func:`install` looks for that
chain behind each outlet of each ``mote``; the chains it finds run as one compiled function
(:func:`pointat.compiled.kernel.chain_frames`) over all the frames of a read, every glove of a base
station in one call, from the nine counts to the OSC datagram.

Nothing about the patch changes for its user.  The nodes stay where they are, with their parameters,
methods, OSCQuery entries and health; whatever reaches a node of a fused chain from outside it (a live
parameter, a method such as ``recalibrate``, the reference's capture bang) first hands the chain back to
the nodes (:meth:`Group.release`: the compiled state written into them), and the message is handled
node by node, as ever.  The chain is taken up again with the next frame when it is in its steady state:
the gyro nulls averaged, no capture pending, ``osc_out`` with no pacing, deadband or bundles.  Nodes
outside the chain that listen to one of its outlets (a ``print``, the monitor) hear every value they
would have heard.  ``tests/integration/test_compiled.py`` holds both ways to the same datagrams, bit for
bit, on recorded takes.

The chain goes through the nodes' door only (:mod:`pointat.node`): each node type of the chain says it
can be fused (``fusable``) and hands its state over and takes it back with its own ``fused_state`` and
``restore_fused``; the wiring is read with ``targets``, the chain's links left out with ``detach`` and
put back with ``reattach``, and ``hold`` has a node hand the chain back before it handles anything from
outside.  The ``mote`` hands its frames over through its ``fuse``.  Nothing here reads a private field of
a node, so that a node's author may change those freely (``tests/engine/test_compiled_chains.py``
checks it).

Where the chain is not there (another filter, a ``tqt_bank``, a profile with more than one message, a
node fed per sample from outside the chain), the patch runs node by node, and ``pointat run -v`` says
why.  ``pointat run --compiled off`` turns it off; ``on`` compiles at start when the cache is cold
(seconds); ``auto``, the default, fuses when the compiled code is cached and otherwise runs node by node
while a process of its own compiles it for the next run (:mod:`pointat.compiled.build`).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from pointat.compiled import kernel as K
from pointat.message import floats, make, vector
from pointat.node import Node

__all__ = ["MODES", "Chains", "Group", "install"]

log = logging.getLogger("pointat.compiled")

#: ``pointat run --compiled``: ``auto`` (fused when cached; compiled meanwhile for the next run),
#: ``on`` (fused, compiling now when it must), ``off`` (node by node).
MODES = ("auto", "on", "off")

# (node outlet -> node inlet) of the chain, by type and port name: what the compiled function replaces
_LINKS = (
    ("offset", "adc", "scaling", "adc"),
    ("scaling", "gyro", "tqt", "gyro"),
    ("scaling", "accel", "tqt", "accel"),
    ("scaling", "mag", "tqt", "mag"),
    ("tqt", "quat", "reference", "quat"),
    ("reference", "quat", "azi_ele", "quat"),
    ("reference", "quat", "roll_distance", "quat"),
    ("azi_ele", "elevation", "osc_out", "elevation"),
    ("roll_distance", "azimuth", "osc_out", "azimuth"),
    ("roll_distance", "distance", "osc_out", "distance"),
)
_ROLES = ("offset", "scaling", "tqt", "reference", "azi_ele", "roll_distance", "osc_out")
# inlets of the chain that nodes outside it may feed: told once (range), a bang (capture), or stored
# for the next update (spread, flags)
_OPEN_INLETS = {("tqt", "range"), ("reference", "capture"), ("osc_out", "spread"), ("osc_out", "flags")}
# the outlets that send every sample (the others, events: nulls' status, scaling's range at the start, the
# flags and the roll mode when they change, go as they go)
_PER_SAMPLE = (
    ("offset", 0),
    ("scaling", 0),
    ("scaling", 1),
    ("scaling", 2),
    ("tqt", 0),
    ("reference", 0),
    ("azi_ele", 0),
    ("azi_ele", 1),
    ("roll_distance", 0),
    ("roll_distance", 1),
)
# of those, the ones osc_out merely stores, which the chain reads: no hand-back
_READ_INLETS = {("osc_out", "spread"), ("osc_out", "flags")}


def _port(specs: Any, name: str) -> int:
    return next(i for i, s in enumerate(specs) if s.name == name)


class Chain:
    """One glove's chain: its nodes, by role, and while it is fused the state it took from them."""

    def __init__(self, mote: Node, outlet: int, nodes: dict[str, Node]) -> None:
        self.mote, self.outlet, self.nodes = mote, outlet, nodes
        self.offset, self.scaling, self.tqt = nodes["offset"], nodes["scaling"], nodes["tqt"]
        self.ref, self.dir, self.roll, self.out = (
            nodes["reference"],
            nodes["azi_ele"],
            nodes["roll_distance"],
            nodes["osc_out"],
        )
        # the links it replaces, as (node, outlet index, target node, inlet index)
        self.links = [(mote, outlet, self.offset, 0)]
        for src, o, dst, i in _LINKS:
            s, d = nodes[src], nodes[dst]
            self.links.append((s, _port(s.out_specs, o), d, _port(d.in_specs, i)))
        self.fused = False
        #: While fused: each node's :meth:`~pointat.node.Node.fused_state`, by role.
        self.states: dict[str, dict[str, Any]] = {}
        #: While fused: roll_distance's mode as the chain last told it.
        self.mode = ""
        # (node, outlet) with listeners outside the chain while it is fused: they hear every value
        self.taps: set[tuple[str, int]] = set()

    def name(self) -> str:
        return f"{self.mote.name}.{self.mote.out_specs[self.outlet].name} -> {self.out.name}"


def _find(rt: Any, mote: Node, outlet: int, feeders: dict[int, list[tuple[Node, int, int]]]) -> Chain | str:
    """The chain behind ``mote``'s ``outlet``, or why there is none."""
    nodes: dict[str, Node] = {}

    def follow(src: Node, out_name: str, kind: str, in_name: str) -> Node | str:
        o = _port(src.out_specs, out_name)
        found = [d for d, i in src.targets(o) if d.type_name == kind and d.in_specs[i].name == in_name]
        if len(found) != 1:
            return f"'{src.name}'.{out_name} goes to {len(found)} {kind} nodes, not one"
        return found[0]

    if not mote.targets(outlet):
        return ""  # (wired to nothing)
    first = [d for d, i in mote.targets(outlet) if d.type_name == "offset" and i == 0]
    if len(first) != 1:
        return "not into one offset"
    nodes["offset"] = first[0]
    for src, o, dst, i in _LINKS:
        d = follow(nodes[src], o, dst, i)
        if isinstance(d, str):
            return d
        if dst in nodes and nodes[dst] is not d:
            return f"'{src}'.{o} and another link reach two {dst} nodes"
        nodes[dst] = d
    for role, node in nodes.items():
        if not type(node).fusable:  # (a type registered anew under a built-in's name)
            return f"{role} '{node.name}' ({type(node).__name__}) cannot be fused"
    ref, dir_, roll = nodes["reference"], nodes["azi_ele"], nodes["roll_distance"]
    order = [d for d, _ in ref.targets(0)]
    if order.index(dir_) > order.index(roll):
        return f"'{ref.name}' feeds roll_distance before azi_ele (the elevation would be a sample late)"
    tqt, out = nodes["tqt"], nodes["osc_out"]
    if tqt.p.mode != "robust":
        return f"tqt '{tqt.name}' is in {tqt.p.mode} mode (the compiled chain runs robust mode)"
    if _fields(out) is None:
        return f"osc_out '{out.name}': profile {out.p.profile} is sent node by node"
    if out.p.bundle:
        return f"osc_out '{out.name}' sends bundles"
    chain = Chain(mote, outlet, nodes)
    inside = {(id(s), o, id(d), i) for s, o, d, i in chain.links}
    for role, node in nodes.items():
        for src, o, i in feeders.get(id(node), ()):
            if (id(src), o, id(node), i) in inside or (role, node.in_specs[i].name) in _OPEN_INLETS:
                continue
            return f"'{src.name}' feeds {role} '{node.name}'.{node.in_specs[i].name} from outside the chain"
    return chain


def _fields(out: Node) -> list[Any] | None:
    """osc_out's one message's fields, when the chain can encode them all."""
    messages = out.messages
    if len(messages) != 1:
        return None
    fields = list(messages[0][1])
    ok = all(f == "n" or not isinstance(f, str) or f in K.FIELD_CODES for f in fields)
    return fields if ok and len(fields) <= _MAX_FIELDS else None


_MAX_FIELDS = 8  # (arguments a message may have in the compiled chain: the templates' slots)


def install(rt: Any, mode: str = "auto") -> Chains | None:
    """Compile the glove chains of a started runtime ``rt``; ``None`` when there are none, when the
    compiled code is not cached yet and ``mode`` is ``auto`` (it is compiled meanwhile), or when ``mode``
    is ``off``."""
    if mode == "off":
        return None
    motes = [n for n in rt.nodes.values() if n.type_name == "mote" and not n.READ_IN_THREAD]
    if not motes:
        return None
    feeders: dict[int, list[tuple[Node, int, int]]] = {}
    for node in rt.nodes.values():
        for o in range(len(node.out_specs)):
            for d, i in node.targets(o):
                feeders.setdefault(id(d), []).append((node, o, i))
    found: dict[Node, list[Chain]] = {}
    taken: set[int] = set()
    for mote in motes:
        for k in range(len(mote.p.ids)):
            chain = _find(rt, mote, k, feeders)
            if chain == "":
                continue
            if isinstance(chain, str):
                log.info("mote '%s' %s: node by node: %s", mote.name, mote.out_specs[k].name, chain)
                continue
            if any(id(n) in taken for n in chain.nodes.values()):
                log.info("%s: node by node: its nodes are another chain's too", chain.name())
                continue
            taken.update(id(n) for n in chain.nodes.values())
            found.setdefault(mote, []).append(chain)
    if not found:
        return None
    from pointat.compiled import build

    if mode == "auto" and not build.ready():
        build.warm_in_background()
        rt.console(
            "compiling the glove chain for the next runs (a few seconds, in the background); "
            "this run goes node by node"
        )
        return None
    return Chains([Group(rt, mote, chains) for mote, chains in found.items()])


class Chains:
    """The compiled chains of a runtime, in groups: one per ``mote``."""

    def __init__(self, groups: list[Group]) -> None:
        self.groups = groups
        for g in groups:
            g.mote.fuse(g)

    @property
    def chains(self) -> list[Chain]:
        return [c for g in self.groups for c in g.chains]

    def describe(self) -> str:
        """For the console: which chains run compiled."""
        names = ", ".join(c.name() for c in self.chains)
        return f"compiled glove chains ({len(self.chains)}): {names}"

    def close(self) -> None:
        """Hand every chain back to its nodes (their state, counters and health as if never fused)."""
        for g in self.groups:
            g.release_all()
            g.mote.fuse(None)


class Group:
    """The fused chains behind one ``mote``: their state in arrays, the frames of a read waiting for
    :meth:`flush`."""

    def __init__(self, rt: Any, mote: Node, chains: list[Chain]) -> None:
        from pointat.compiled import build
        from pointat.maths.tqt import step

        self.rt, self.mote, self.chains = rt, mote, chains
        self.fn, self.scan_fn = build.chain_frames(), build.scan_plain()
        self.by_outlet: dict[int, int] = {c.outlet: g for g, c in enumerate(chains)}
        n = len(chains)
        # a datagram's room: the longest address (a source number of up to 10 digits), tags, arguments
        longest = max(len(c.out.messages[0][0]) + len(c.out.messages[0][1]) for c in chains)
        self.width = 8 * (longest // 8) + 96
        self.P = np.zeros((n, K.G_SIZE))
        self.S = np.zeros((n, K.C_SIZE))
        self.TS = np.zeros((n, step.STATE_SIZE))
        self.TP = np.zeros((n, step.PARAM_SIZE + 2))  # (paper mode's two after them)
        self.tmpl = np.zeros((n, self.width), np.uint8)
        self.tlen = np.zeros(n, np.int64)
        self.slot = np.full((n, _MAX_FIELDS), -1, np.int64)
        self.code = np.zeros((n, _MAX_FIELDS), np.int64)
        self._grow(max(16, 2 * n))
        self.n = 0  # frames waiting
        # plain frames straight from the reader's buffer (scan): mote id -> chain, or -1 (the node's way)
        self.plain_of = np.full(256, -1, np.int64)
        self._per_mote = np.zeros(256, np.int64)
        self._bulk: dict[int, list[Callable[[int], None]]] = {}
        self.plain_taken = 0  # frames the scan took straight from the reader's buffer
        self.stale = True  # plain_of to be worked out again (a chain taken up or handed back, a silence)
        self._flushing = False
        self._later: list[int] = []  # chains handed back while a flush was telling its listeners
        self.fused_frames = 0

    def _grow(self, cap: int) -> None:
        old = getattr(self, "cap", 0)
        keep = self.n if old else 0
        arrays = {
            "idx": np.zeros(cap, np.int64),
            "counts": np.zeros((cap, 9)),
            "times": np.zeros(cap),
            "spread": np.zeros(cap),
            "R": np.zeros((cap, K.O_SIZE)),
            "ev": np.zeros(cap, np.int64),
            "flags": np.zeros(cap, np.int64),
            "buf": np.zeros((cap, self.width), np.uint8),
        }
        for name, a in arrays.items():
            if keep:
                a[:keep] = getattr(self, name)[:keep]
            setattr(self, name, a)
        self.cap = cap

    # -- frames ----------------------------------------------------------------------------------------
    def take(self, outlet: int, counts: tuple[int, ...], t: float) -> bool:
        """A frame of the mote's ``outlet``: queued for :meth:`flush` when its chain is fused (False: the
        caller sends it node by node).  Nodes outside the chain listening to the outlet hear it now."""
        g = self.by_outlet.get(outlet)
        if g is None:
            return False
        chain = self.chains[g]
        if not chain.fused and not self.adopt(g):
            return False
        if self.mote.connected(outlet):
            self.mote.out(outlet, vector(counts, t))
        n = self.n
        if n == self.cap:
            self._grow(2 * self.cap)
        self.idx[n] = g
        self.counts[n] = counts
        self.times[n] = t
        self.spread[n] = chain.out.state[3]
        self.n = n + 1
        return True

    def scan(
        self,
        buf: bytearray,
        pos: int,
        end: int,
        last: np.ndarray,
        held: np.ndarray,
        clock: np.ndarray,
        rate: float,
    ) -> tuple[int, int, dict[int, int]] | None:
        """Take the run of plain frames at ``buf[pos:end]`` (:func:`pointat.compiled.kernel.scan_plain`):
        the parser's hook, :attr:`pointat.devices.mote_frame.FrameParser.plain`."""
        if self.stale:
            self._refresh()
        if not self._any:
            return None
        need = self.n + (end - pos) // 21 + 1
        if need > self.cap:
            self._grow(max(need, 2 * self.cap))
        per = self._per_mote
        view = np.frombuffer(buf, np.uint8)
        try:
            k, stop = self.scan_fn(
                view,
                pos,
                end,
                last,
                held,
                self.plain_of,
                clock,
                rate,
                self.idx,
                self.counts,
                self.times,
                per,
                self.n,
            )
        finally:
            del view  # (the parser's buffer may not be resized while a view of it lives)
        self.plain_taken += k
        if not k:
            return None
        n0 = self.n
        self.n = n0 + k
        spread = np.array([c.out.state[3] for c in self.chains])  # as osc_out holds them now
        self.spread[n0 : n0 + k] = spread[self.idx[n0 : n0 + k]]
        motes = np.flatnonzero(per)
        taken = dict(zip(motes.tolist(), per[motes].tolist(), strict=True))
        per[motes] = 0
        for mote, count in taken.items():
            for bulk in self._bulk[mote]:  # listeners that count (the observer's streams)
                bulk(count)
        return k, int(stop), taken

    def silences_changed(self) -> None:
        """A mote fell silent or spoke again (the ``mote`` says so): its frames go the node's way while
        it is silent, so which the scan may take is worked out again."""
        self.stale = True

    def _refresh(self) -> None:
        """Which motes' frames the scan may take: a fused chain's, not silent, heard by nothing outside
        the chain but counters."""
        self.stale = False
        self.plain_of[:] = -1
        self._bulk = {}
        mote = self.mote
        for g, c in enumerate(self.chains):
            m = int(mote.p.ids[c.outlet])
            if not c.fused or mote.silent(m):
                continue
            counters = [getattr(node, "bulk", None) for node, _ in mote.targets(c.outlet)]
            if all(counters):
                self.plain_of[m] = g
                self._bulk[m] = counters  # type: ignore[assignment]
        self._any = bool((self.plain_of >= 0).any())

    def flush(self) -> None:
        """Run the waiting frames through the compiled chain, tell the listeners, send the datagrams."""
        n = self.n
        if not n or self._flushing:
            return
        self._flushing = True
        try:
            self.fn(
                self.idx[:n], self.counts[:n], self.times[:n], self.spread[:n], self.P, self.S, self.TS,
                self.TP, self.R[:n], self.ev[:n], self.flags[:n], self.buf[:n], self.tmpl, self.tlen,
                self.slot, self.code,
            )  # fmt: skip
            self.fused_frames += n
            self._after(n)
        finally:
            self._flushing = False
            self.n = 0
        later, self._later = self._later, []
        for g in later:
            self.release(g)

    def _after(self, n: int) -> None:
        """Per frame: the listeners and events (:meth:`_tell`) where there are any; then each chain's
        datagrams, sent at once by its ``osc_out`` (as its node sends what a pass encoded, at the pass's
        end)."""
        width = self.width
        data = self.buf[:n].tobytes()
        tlen = self.tlen.tolist()
        chains = self.chains
        times = self.times[:n].tolist()
        sends: list[list[bytes]] = [[] for _ in chains]
        for f, (g, e) in enumerate(zip(self.idx[:n].tolist(), self.ev[:n].tolist(), strict=True)):
            c = chains[g]
            if e != K.EV_OUT or c.taps:
                self._tell(f, g, e, c, times[f])
                if not e & K.EV_OUT or e & K.EV_BAD:
                    continue
            sends[g].append(data[f * width : f * width + tlen[g]])
        for g, datagrams in enumerate(sends):
            if datagrams:
                chains[g].out.send_updates(datagrams)

    def _tell(self, f: int, g: int, e: int, c: Chain, t: float) -> None:
        """A frame's events and the values for the listeners outside the chain, in the nodes' order."""
        r = self.R[f].tolist()
        taps = c.taps

        def tap(node: Node, outlet: int, value: Any) -> None:
            if (node.name, outlet) in taps:
                node.out(outlet, value, t)

        if taps:
            tap(c.offset, 0, floats(tuple(r[K.O_ADC : K.O_ADC + 9]), t))
            sc = c.scaling
            tap(sc, 2, floats(tuple(r[K.O_MAG : K.O_MAG + 3]), t))
            tap(sc, 1, floats(tuple(r[K.O_ACCEL : K.O_ACCEL + 3]), t))
            tap(sc, 0, floats(tuple(r[K.O_GYRO : K.O_GYRO + 3]), t))
        tqt = c.tqt
        if e & K.EV_FLAGS:
            tqt.time = t
            tqt.tell_flags(
                int(self.flags[f]) & K.NOT_REST
            )  # (this frame's: the state holds the batch's last)
        if not e & K.EV_OUT and not e & K.EV_BAD:
            return
        if taps:
            tap(tqt, 0, floats(tuple(r[K.O_QUAT : K.O_QUAT + 4]), t))
        if e & K.EV_BAD:
            exc = ValueError("not a finite number; the last good values stay")
            c.out.fail(0, make(r[K.O_ROLL_AZ], t), exc)
            return
        if taps:
            tap(c.ref, 0, floats(tuple(r[K.O_REL : K.O_REL + 4]), t))
            tap(c.dir, 1, r[K.O_DIR_EL])
            tap(c.dir, 0, r[K.O_DIR_AZ])
        if e & K.EV_MODE:  # (changed at this frame)
            c.mode = "azimuth" if c.mode == "distance" else "distance"
            c.roll.time = t
            c.roll.tell_mode(c.mode)
        if taps:
            tap(c.roll, 1, r[K.O_ROLL_DIST])
            tap(c.roll, 0, r[K.O_ROLL_AZ])

    # -- handing over ----------------------------------------------------------------------------------
    def adopt(self, g: int) -> bool:
        """Take chain ``g`` from its nodes when they are in their steady state; False when they are not."""
        c = self.chains[g]
        out = c.out
        if out.p.rate > 0 or out.p.change or out.p.deadband > 0:
            return False
        states = {}
        for role in _ROLES:  # (offset first: the one that is not steady for a while, at the start)
            state = c.nodes[role].fused_state()
            if state is None:
                return False
            states[role] = state
        if not self._template(g, c, states["osc_out"]):
            return False
        P, S = self.P[g], self.S[g]
        P[K.G_NULLS : K.G_NULLS + 9] = states["offset"]["nulls"]
        sc = states["scaling"]
        P[K.G_FACTOR : K.G_FACTOR + 9] = sc["factor"]
        for at, has, m in (
            (K.G_SOFT, K.G_HAS_SOFT, sc["soft_iron"]),
            (K.G_ACCM, K.G_HAS_ACCM, sc["acc_misalignment"]),
            (K.G_GYROM, K.G_HAS_GYROM, sc["gyro_misalignment"]),
        ):
            P[has] = 0.0 if m is None else 1.0
            if m is not None:
                P[at : at + 9] = m
        tqt = states["tqt"]
        P[K.G_NOMINAL] = 1.0 / c.tqt.p.rate
        P[K.G_MAX_GAP] = c.tqt.MAX_GAP
        P[K.G_REF : K.G_REF + 4] = states["reference"]["offset"]
        P[K.G_AXIS : K.G_AXIS + 3] = c.dir.p.axis
        P[K.G_DIR_POLE] = c.dir.p.pole
        rd = states["roll_distance"]
        P[K.G_ENTER], P[K.G_LEAVE], P[K.G_GAIN] = rd["enter"], rd["leave"], rd["gain"]
        P[K.G_MAX_EL], P[K.G_ROLL_POLE] = rd["max_elevation"], c.roll.p.pole
        P[K.G_RADIUS] = out.p.radius
        s, p, flags = tqt["filter"]
        self.TS[g] = s
        self.TP[g] = p
        S[K.C_LAST_T] = _nan(tqt["last_t"])
        S[K.C_BITS] = tqt["bits"]
        S[K.C_FLAGS] = flags
        S[K.C_DIR_AZ] = _nan(states["azi_ele"]["azimuth"])
        S[K.C_ROLL_AZ] = _nan(rd["azimuth"])
        S[K.C_ROLL : K.C_ROLL + len(rd["roll"])] = rd["roll"]
        S[K.C_OUT : K.C_OUT + 3] = states["osc_out"]["direction"]
        S[K.C_OUT + 3] = states["osc_out"]["spread"]
        c.states, c.mode = states, rd["mode"]
        self._hold(g, c)
        c.fused = True
        self.stale = True
        return True

    def _template(self, g: int, c: Chain, state: dict[str, Any]) -> bool:
        """osc_out's message for its current source number (its own encoder's bytes, the fields the
        kernel writes left as they come), the fields' places in it."""
        fields = _fields(c.out)
        data = state["datagram"]
        if fields is None or len(data) > self.width:
            return False
        self.tmpl[g, : len(data)] = np.frombuffer(data, np.uint8)
        self.tlen[g] = len(data)
        self.slot[g] = -1
        k = 0
        for j, f in enumerate(fields):
            if isinstance(f, str) and f != "n":
                self.slot[g, k] = state["arguments_at"] + 4 * j
                self.code[g, k] = K.FIELD_CODES[f]
                k += 1
        return True

    def _hold(self, g: int, c: Chain) -> None:
        """Take the chain's links out of its nodes and have them hand it back before they handle
        anything from outside it."""
        for s, o, d, i in c.links:
            s.detach(o, d, i)
        c.taps = {(c.nodes[r].name, o) for r, o in _PER_SAMPLE if c.nodes[r].connected(o)}
        for role, node in c.nodes.items():
            node.hold(
                lambda: self.release(g),
                lambda: self.sync(g),  # (the monitor's thread reads health too: no flush from there)
                open_inlets=[name for r, name in _READ_INLETS if r == role],
            )

    def sync(self, g: int) -> None:
        """Write chain ``g``'s compiled state into its nodes (it stays fused)."""
        c = self.chains[g]
        if not c.fused:
            return
        S = self.S[g]
        st = c.states
        st["tqt"].update(
            filter=(self.TS[g].tolist(), self.TP[g].tolist(), int(S[K.C_FLAGS])),
            last_t=_none(float(S[K.C_LAST_T])),
            bits=int(S[K.C_BITS]),
        )
        st["azi_ele"]["azimuth"] = _none(float(S[K.C_DIR_AZ]))
        rd = st["roll_distance"]
        rd["azimuth"] = _none(float(S[K.C_ROLL_AZ]))
        rd["roll"] = S[K.C_ROLL : K.C_ROLL + len(rd["roll"])].tolist()
        st["osc_out"]["direction"] = tuple(S[K.C_OUT : K.C_OUT + 3].tolist())
        for role, node in c.nodes.items():
            node.restore_fused(st[role])

    def release(self, g: int) -> None:
        """Hand chain ``g`` back to its nodes: the frames waiting go first, then its state."""
        c = self.chains[g]
        if not c.fused:
            return
        if self._flushing:  # a listener sent something into the chain: after this flush
            self._later.append(g)
            return
        self.flush()
        self.sync(g)
        for node in c.nodes.values():
            node.unhold()
            node.reattach()  # (listeners connected meanwhile, the monitor's, stay)
        self.mote.reattach(c.outlet)  # (the mote's other outlets are other chains')
        c.states = {}
        c.taps = set()
        c.fused = False
        self.stale = True

    def release_all(self) -> None:
        for g in range(len(self.chains)):
            self.release(g)


def _nan(x: float | None) -> float:
    return math.nan if x is None else x


def _none(x: float) -> float | None:
    return None if x != x else x
