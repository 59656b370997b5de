"""The runtime: one scheduler thread runs the graph; sources hand it events through a bounded queue.

* **Logical time.**  ``clock.now()`` is seconds since the patch started.  With ``realtime=True`` it
  follows ``time.monotonic()`` and timers are *deadlines*: a metro that ticks every 10 ms schedules tick
  ``n`` at ``start + n * 0.01``, so it never drifts.  With ``realtime=False`` time stands still until a
  test calls :meth:`Runtime.advance`, which runs every timer due on the way, in order.
* **Sources with a file descriptor** (a serial port, a UDP socket) are read on the scheduler thread
  itself, as Pd does: :meth:`Runtime.add_reader` registers the descriptor and a callback, and the
  scheduler sleeps in one ``select`` (epoll) over every descriptor and the next timer's deadline.  A
  datagram or a frame goes from the kernel into the graph with no thread hand-off in between.
* **Other sources** (file replay, MIDI input) do their blocking work in their own threads
  (:meth:`Node.spawn <pointat.node.Node.spawn>`) and hand results to the scheduler with
  :meth:`Node.post <pointat.node.Node.post>`, which wakes the ``select``.  The queue is bounded: a fast
  file replay waits for the graph instead of filling memory.
* **Ending.**  :meth:`Runtime.run` returns when :meth:`stop` is called (Ctrl-C, SIGTERM), when its
  ``duration`` (``--for``) is up, or by itself when nothing can happen any more: no active source, no
  pending timer, nothing queued.  Every node's ``close()`` runs and every thread is joined.
* **Falling behind.**  A timer that costs more than its period (a machine too slow for the patch) falls
  behind in logical time, as Pd's clocks do, and the timers due after it wait with it; but each pass over
  the timers ends at the first timer scheduled during it, so the descriptors and the queue are still
  served between passes, ``duration`` is wall-clock time, and the log says that the machine cannot keep
  up (a timer more than :attr:`Runtime.LATE` late; at most every :attr:`Runtime.LATE_EVERY` seconds).
* **Passes.**  The scheduler handles what is ready in passes: the timers that are due, or the readers
  that woke it and the queue.  A pass runs queued events for :attr:`Runtime.QUEUE_BUDGET` at most (one
  at least), so a source that floods the queue (``replay speed=0``) cannot hold the timers and the
  descriptors (OSC control) for seconds; the rest wait, in order, for the next passes.
  :meth:`Runtime.at_pass_end` runs a callback when the current pass is done,
  before the scheduler sleeps again; ``osc_out`` sends that way, so the datagrams of every sensor read in
  one wake-up leave together.
* **Spinning.**  With ``spin`` seconds (``pointat run --spin MS``) the scheduler polls its descriptors
  instead of sleeping for that long after each input: the next sample finds it awake, with its caches
  warm, and the system's wake-up no longer adds to its latency; a CPU is busy while input flows.  With
  other Python threads in the process it waits :attr:`Waiter.SPIN_GRAIN <pointat.waiting.Waiter.SPIN_GRAIN>`
  in select between polls, so that they still get the interpreter (threads marked with
  :func:`quiet_thread`, such as the console's writer, do not count).
* **Live control.**  :meth:`set_param` and :meth:`send` may be called from any thread (the OSC bridge
  uses them); they are carried out on the scheduler thread.
"""

from __future__ import annotations

import heapq
import itertools
import logging
import math
import queue
import re
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Mapping
from typing import Any

from .errors import FeedbackError, PatchError, Problem, Repeats, worth_reporting
from .graphs import reached
from .message import Message, make, method
from .node import Node
from .scheduling import (
    CPU_DMA_LATENCY,
    ManualClock,
    RealClock,
    Timer,
    _Reader,
    keep_cpus_awake,
    quiet_thread,
    realtime_priority,
)
from .waiting import Waiter

__all__ = [
    "CPU_DMA_LATENCY",
    "ManualClock",
    "RealClock",
    "Runtime",
    "StartError",
    "Timer",
    "keep_cpus_awake",
    "quiet_thread",
    "realtime_priority",
]

log = logging.getLogger("pointat.runtime")


class StartError(PatchError):
    """Some nodes could not start; a problem for each, with its place in the patch and why."""


class Runtime:
    """Runs a graph of connected nodes.  Build one with :func:`pointat.loader.build` or by hand."""

    def __init__(
        self,
        nodes: Iterable[Node] = (),
        *,
        realtime: bool = True,
        queue_size: int = 4096,
        spin: float = 0.0,
    ):
        self.nodes: dict[str, Node] = {}
        self.clock: RealClock | ManualClock = RealClock() if realtime else ManualClock()
        self.realtime = realtime
        self.running = False
        self._sources: list[Node] = []  # active after the start, not for live control only (_finished)
        self._over_told = False
        self.depth = 0
        self.bus: dict[str, list[Node]] = {}
        self.dropped = 0
        self._failures = Repeats(self.FAILURE_KINDS)  # failed events (_failed)
        self.stopping = threading.Event()
        self._timers: list[Timer] = []
        self._seq = itertools.count()
        self._queue: queue.Queue = queue.Queue(maxsize=queue_size)
        self._threads: list[threading.Thread] = []
        self._closed = False
        self._prepared = False
        self._scheduler: threading.Thread | None = None
        # Descriptors read on the scheduler thread, and a socket pair that wakes its select for posts
        # (made when first needed, closed at shutdown); slept in, or spun on (:mod:`pointat.waiting`).
        self._waiter = Waiter()
        self._passing = False  # a pass (timers due, or readers and queue) is being handled
        self._at_end: list[tuple[Node | None, Callable[[], Any]]] = []
        self._late_warned = -math.inf  # when the log last said that timers run late (time.monotonic)
        self.spin = spin
        #: ``pointat run --compiled``: whether the glove chains run compiled (:mod:`pointat.compiled`);
        #: off unless asked, so that a runtime built by hand never starts a compile.
        self.compiled = "off"
        #: The compiled chains, once started (:class:`pointat.compiled.Chains`), or None.
        self.compiled_chains: Any = None
        #: The patch's presets (:class:`pointat.presets.Presets`), when it runs from a file.
        self.presets: Any = None
        #: What reloads the patch from its file (:class:`pointat.reload.Reloader`), when it runs from one.
        self.reloader: Any = None
        #: Where ``print`` nodes write; the CLI points it at the terminal, tests at a list.
        self.console: Callable[[str], None] = logging.getLogger("pointat.console").info
        for node in nodes:
            self.add(node)

    @property
    def spin(self) -> float:
        """Seconds after each input during which the scheduler polls for the next one instead of sleeping
        (``pointat run --spin``); 0 (the default): it sleeps as soon as there is nothing to do.  A runtime
        on a manual clock (``realtime=False``) never sleeps, and never spins."""
        return self._waiter.spin_for

    @spin.setter
    def spin(self, seconds: float) -> None:
        if not (isinstance(seconds, (int, float)) and math.isfinite(seconds) and seconds >= 0.0):
            raise ValueError(f"spin must be a finite number of seconds >= 0, got {seconds!r}")
        self._waiter.spin_for = float(seconds)

    # building ----------------------------------------------------------------------
    def add(self, node: Node) -> Node:
        if node.name in self.nodes:
            raise ValueError(f"a node named '{node.name}' exists already")
        node.rt = self
        self.nodes[node.name] = node
        return node

    def connect(self, src: Node | str, outlet: int, dst: Node | str, inlet: int) -> None:
        """Wire ``src`` outlet -> ``dst`` inlet (appended: fan-out follows connection order)."""
        s = self.nodes[src] if isinstance(src, str) else src
        d = self.nodes[dst] if isinstance(dst, str) else dst
        if not 0 <= outlet < len(s.out_specs):
            raise ValueError(f"node '{s.name}' has no outlet {outlet}")
        if not 0 <= inlet < len(d.in_specs):
            raise ValueError(f"node '{d.name}' has no inlet {inlet}")
        s._targets[outlet].append((d, inlet))

    def prune(self) -> list[str]:
        """Stop feeding pure nodes whose outputs reach no node with effects; returns their names.

        A conversion left unconnected in an abstraction (``quat2axis`` in the Pointing-at chain when only
        azimuth and elevation are used) then costs nothing.  They stay in :attr:`nodes`, so live control
        still finds them.
        """
        useful = {n for n in self.nodes.values() if not type(n).pure}
        feeders: dict[Node, list[Node]] = {}
        for node in self.nodes.values():
            for targets in node._targets:
                for dst, _inlet in targets:
                    feeders.setdefault(dst, []).append(node)
        useful = reached(useful, lambda n: feeders.get(n, ()))
        for node in self.nodes.values():
            node._targets = [[(d, i) for d, i in targets if d in useful] for targets in node._targets]
        idle = [n.name for n in self.nodes.values() if n not in useful]
        if idle:
            log.info("not fed, their outputs reach no output: %s", ", ".join(idle))
        return idle

    # scheduling --------------------------------------------------------------------
    def call_at(self, when: float, node: Node | None, fn: Callable, *args: Any) -> Timer:
        """Schedule ``fn(*args)`` at logical time ``when`` (scheduler thread only).

        ``when`` must be a finite number: NaN would break the order of the timers, and every timer of
        the patch with it; the caller gets a ``ValueError`` and the schedule stays as it was.
        """
        if not math.isfinite(when):
            who = f"node '{node.name}': " if node is not None else ""
            raise ValueError(f"{who}cannot schedule at time {when!r}: expected a finite time")
        t = Timer(when, next(self._seq), node, fn, args)
        heapq.heappush(self._timers, t)
        return t

    def at_pass_end(self, node: Node | None, fn: Callable[[], Any]) -> None:
        """Run ``fn()`` on the scheduler thread when the pass being handled is done: after the readers
        that woke the scheduler and the queue, or after the timers that are due, before it sleeps again.
        Outside a pass (a node fed by hand, a loadbang) it runs at once.  Call it on the scheduler thread.

        ``osc_out`` sends this way.  A base station's frames arrive together, one per sensor: their
        datagrams then leave in one burst after all the chains ran, instead of one between every two
        chains.  A burst wakes the receiver once; on a virtual machine a ``send`` that wakes a sleeping
        receiver costs tens of microseconds, the ones right after it a few.
        """
        if self._passing:
            self._at_end.append((node, fn))
        else:
            fn()

    def post(self, node: Node | None, fn: Callable, *args: Any, block: bool = True) -> bool:
        """Queue ``fn(*args)`` for the scheduler thread; safe from any thread.

        With ``block`` the caller waits while the queue is full (back-pressure) until the runtime stops;
        without it a full queue drops the event and counts it.  Returns whether it was queued.
        """
        item = (node, fn, args)
        if block and threading.current_thread() is self._scheduler:
            block = False  # the scheduler waiting for its own queue to drain would wait forever
        if not block:
            try:
                self._queue.put_nowait(item)
            except queue.Full:
                self.dropped += 1
                if worth_reporting(self.dropped):  # a live source's event lost: never silently
                    who = f" from node '{node.name}'" if node is not None else ""
                    log.warning(
                        "the scheduler's queue is full (%d events): an event%s was dropped (%d so far); "
                        "the scheduler cannot keep up with the patch's sources",
                        self._queue.maxsize,
                        who,
                        self.dropped,
                    )
                return False
            self._waiter.wake()
            return True
        while not self.stopping.is_set():
            try:
                self._queue.put(item, timeout=0.1)
            except queue.Full:
                continue
            self._waiter.wake()
            return True
        return False

    def add_reader(self, fileobj: Any, callback: Callable[[], Any], node: Node | None = None) -> None:
        """Call ``callback()`` on the scheduler thread whenever ``fileobj`` (a socket, a file descriptor,
        anything with ``fileno()``) has data to read.  Call it from the scheduler thread (``start``,
        a timer, a handler).  A failure in the callback is logged with ``node``'s name and the patch goes
        on; the callback must read what is there (the descriptor stays readable until it does).
        """
        self._waiter.descriptors().register(fileobj, _Reader(fileobj, node, callback))

    def remove_reader(self, fileobj: Any) -> None:
        """Stop watching ``fileobj`` (idempotent: a descriptor that is not watched is ignored)."""
        reader = self._waiter.unregister(fileobj)
        if reader is not None:
            reader.watched = False

    def spawn(self, node: Node, target: Callable[[], Any], what: str = "") -> threading.Thread:
        """Start a daemon thread for ``node``'s blocking I/O; exceptions are logged with the node's name."""

        def guarded() -> None:
            try:
                target()
            except Exception:
                log.exception("node '%s' (%s): thread %s failed", node.name, node.type_name, what or "")

        th = threading.Thread(target=guarded, name=f"pointat-{node.name}-{what}".rstrip("-"), daemon=True)
        self._threads.append(th)
        th.start()
        return th

    # live control ------------------------------------------------------------------
    def set_param(self, node_name: str, param: str, value: Any) -> None:
        """Set a live parameter by name, from any thread (validated on the scheduler thread)."""
        self.send(node_name, param, value)

    @staticmethod
    def message(selector: str | Any, *args: Any) -> Message:
        """The message :meth:`send` delivers: ``bang``, a value, a ``list``, or a method with its args."""
        if selector == "bang":
            return make(None)
        if selector in ("float", "int", "symbol"):
            if not args:
                raise ValueError(f"'{selector}' without a value")
            return make(args[0])
        if selector == "list":
            return make(tuple(args))
        if isinstance(selector, str):
            return method(selector, *args)
        return make(selector)

    def send(self, node_name: str, selector: str | Any, *args: Any, inlet: int = 0) -> None:
        """Send a message to a node by name, from any thread: a method (``recalibrate``, ``k 0.5``) or a value."""
        node = self.nodes.get(node_name)
        if node is None:
            log.error("no node named '%s' (nodes: %s)", node_name, ", ".join(self.nodes))
            return
        msg = self.message(selector, *args)

        def deliver() -> None:
            node.receive(inlet, msg._replace(time=self.clock.now()))

        self.post(node, deliver, block=False)

    # running -----------------------------------------------------------------------
    def start(self) -> None:
        """Start every node (ports, threads, timers), then fire the loadbangs.

        A node that cannot start (a port that will not open, a file that cannot be read) stops the
        patch before it runs: :class:`StartError` names every such node, and everything already
        opened is closed again.  Later failures (a device that vanishes) are the nodes' to survive.
        """
        if self.running:
            return
        if self.compiled != "off":  # (before the clock starts: loading the compiled code takes a while)
            self._fuse()
        self.prepare()  # (done already when pointat run checked the patch: pointat.loader.ready)
        failures = []
        self.clock.reset()
        self.running = True
        for node in self._downstream_first():
            try:
                node.start()
            except Exception as exc:  # a port that cannot open, a file that cannot be read...
                failures.append(
                    Problem(node.where, f"node '{node.name}' ({node.type_name}): cannot start: {exc}")
                )
        if failures:
            self.shutdown()
            raise StartError(failures)
        for node in list(self.nodes.values()):
            self._guard(node, node.loadbang)
        # the sources whose end is the patch's end (see _finished)
        self._sources = [n for n in self.nodes.values() if n.active and not self._listens_only(n)]
        self._over_told = False

    def prepare(self) -> None:
        """Every node's heavy one-time work (:meth:`Node.prepare`), once: what :meth:`start` does before
        the clock starts, and the last thing ``pointat check`` does (:func:`pointat.loader.ready`), for it
        opens nothing.  A node that fails stops the patch as at the start: :class:`StartError` names every
        such node, and the runtime is shut down."""
        if self._prepared:
            return
        self._prepared = True
        failures = []
        for node in self.nodes.values():
            try:
                node.prepare()
            except Exception as exc:
                failures.append(
                    Problem(node.where, f"node '{node.name}' ({node.type_name}): cannot start: {exc}")
                )
        if failures:
            self.shutdown()
            raise StartError(failures)

    def swap(
        self,
        nodes: Mapping[str, Node],
        wires: Iterable[tuple[str, int, str, int]],
        retune: Mapping[str, Mapping[str, Any]] | None = None,
    ) -> list[Node]:
        """Put the patch ``nodes`` (by name, wired by ``wires``) in place of the one running: a reload
        (:mod:`pointat.reload`), on the scheduler's thread between two passes (:meth:`between_passes`).

        A node object in both patches stays as it is, its state, ports, timers and the listeners on its
        outlets that are not the patch's (the observer's taps) with it; ``retune`` gives some of them new
        live values, as live control would.  The old patch's other nodes are closed and their timers
        cancelled; the new patch's new nodes start, each after those it sends to (one that cannot start is
        logged with its file:line, closed and left out: the rest plays), then get their loadbang.  Compiled
        glove chains are handed back to their nodes first and compiled again after.  Returns the new nodes
        that started.
        """
        fused = self.compiled_chains is not None
        if fused:  # the compiled chains' state written back into their nodes
            self._guard(None, self.compiled_chains.close)
            self.compiled_chains = None
        old = self.nodes
        in_patch = {id(n) for n in old.values()}
        staying = [n for name, n in old.items() if nodes.get(name) is n]
        taps = {n.name: [n.targets(o) for o in range(len(n.out_specs))] for n in staying}
        self._close_nodes([n for name, n in old.items() if nodes.get(name) is not n])
        for name, values in (retune or {}).items():
            node = nodes[name]
            if not self._guard(node, lambda node=node, values=values: node.set_params(**values)):
                log.error("node '%s': the new values were refused; it keeps its old ones", name)
        new = [n for n in nodes.values() if id(n) not in in_patch]
        for node in nodes.values():
            node.unwire()
            node.rt = self
        self.nodes = dict(nodes)  # (one assignment: the observer's and the monitor's threads read it)
        for wire in wires:
            self.connect(*wire)
        self.prune()
        for name, per_outlet in taps.items():
            for o, targets in enumerate(per_outlet):
                for dst, inlet in targets:
                    if id(dst) not in in_patch:
                        self.connect(self.nodes[name], o, dst, inlet)
        started = self._start_new([n for n in self._downstream_first() if n in new])
        for node in started:
            self._guard(node, node.loadbang)
        kept = [n for n in self._sources if self.nodes.get(n.name) is n]
        self._sources = kept + [n for n in started if n.active and not self._listens_only(n)]
        self._over_told = False
        if fused and self.compiled != "off":
            self._fuse()
        return started

    def _close_nodes(self, nodes: list[Node]) -> None:
        """Close nodes leaving the patch: nothing they still send reaches anyone, their timers dropped."""
        ids = {id(n) for n in nodes}
        for node in nodes:
            node.unwire()
            self._guard(node, node.close)
        for t in self._timers:
            if t.node is not None and id(t.node) in ids:
                t.cancel()

    def _start_new(self, nodes: list[Node]) -> list[Node]:
        """Start nodes new to a running patch; one that cannot start is said (file:line, why), closed and
        left out."""
        started = []
        for node in nodes:
            try:
                node.start()
                started.append(node)
            except Exception as exc:
                log.error(
                    "%s: error: node '%s' (%s): cannot start: %s; the patch runs without it",
                    node.where,
                    node.name,
                    node.type_name,
                    exc,
                )
                self._close_nodes([node])
                self.nodes = {k: n for k, n in self.nodes.items() if n is not node}
                for other in self.nodes.values():
                    other.unwire(keep=lambda dst, node=node: dst is not node)
        return started

    @property
    def scheduler_thread(self) -> threading.Thread | None:
        """The thread that runs the patch (:meth:`run`) once it runs; None before, and with a manual clock."""
        return self._scheduler

    def between_passes(self, fn: Callable[[], Any], wait: float) -> bool:
        """Run ``fn`` on the scheduler's thread when the pass it is in is done, and wait for it, at most
        ``wait`` seconds; at once when there is no scheduler thread (a manual clock) or this is it.  False
        when the runtime stopped first or the wait ran out."""
        scheduler = self._scheduler
        if scheduler is None or scheduler is threading.current_thread() or not scheduler.is_alive():
            if self.stopping.is_set():
                return False
            self.at_pass_end(None, fn)
            return True
        done = threading.Event()

        def at_end() -> None:
            try:
                fn()
            finally:
                done.set()

        if not self.post(None, lambda: self.at_pass_end(None, at_end)):
            return False
        deadline = time.monotonic() + wait
        while not done.wait(0.05):
            if self.stopping.is_set() or time.monotonic() > deadline:
                return False
        return True

    def _fuse(self) -> None:
        """Run the glove chains compiled where the patch has them (:mod:`pointat.compiled`); the patch runs
        node by node whatever goes wrong there."""
        from pointat import compiled

        try:
            self.compiled_chains = compiled.install(self, self.compiled)
            if self.compiled_chains is not None:
                self.console(self.compiled_chains.describe())
        except Exception:  # never a reason not to play
            log.exception("the compiled glove chain failed to start; running node by node")
            self.compiled_chains = None

    def _downstream_first(self) -> list[Node]:
        """Every node, each after the nodes it sends to (a loop's in declaration order): a sink is ready
        (a file open, a socket bound) before a source that speaks as it starts (a ``mote``'s ``opened``)
        says anything.  Iterative: a chain of thousands of nodes is no recursion."""
        receivers: dict[str, list[Node]] = {}
        for node in self.nodes.values():
            if type(node).bus_end == "hears":
                receivers.setdefault(node.p.bus, []).append(node)

        def after(node: Node) -> Iterator[Node]:
            for targets in node._targets:
                yield from (t for t, _ in targets)
            if type(node).bus_end == "sends":
                yield from receivers.get(node.p.bus, ())

        order: list[Node] = []
        seen: set[int] = set()
        for root in self.nodes.values():
            if id(root) in seen:
                continue
            seen.add(id(root))
            stack = [(root, after(root))]
            while stack:
                node, todo = stack[-1]
                for nxt in todo:
                    if id(nxt) not in seen:
                        seen.add(id(nxt))
                        stack.append((nxt, after(nxt)))
                        break
                else:
                    stack.pop()
                    order.append(node)
        return order

    def run(self, duration: float | None = None) -> None:
        """Run on this thread until stopped, ``duration`` seconds pass, or nothing is left to happen.

        ``duration`` is the clock's time: wall-clock time for a real-time runtime, so a patch that falls
        behind its timers (a machine too slow for them) still stops when it is up.
        """
        if duration is not None and not (math.isfinite(duration) and duration >= 0.0):
            raise ValueError(f"duration must be a finite number of seconds >= 0, got {duration}")
        self._scheduler = threading.current_thread()
        self.start()
        deadline = None if duration is None else self.clock.now() + duration
        try:
            while not self.stopping.is_set():
                timeout = self._run_due()
                if self.stopping.is_set() or self._finished():
                    break
                if deadline is not None:
                    left = deadline - self.clock.now()
                    if left <= 0.0:
                        break
                    timeout = min(timeout, left)
                self._poll(timeout)
        finally:
            self.shutdown()

    def run_in_thread(self, duration: float | None = None) -> threading.Thread:
        """:meth:`run` on a new thread (tests, embedding); :meth:`stop` ends it."""
        th = threading.Thread(target=self.run, args=(duration,), name="pointat-scheduler", daemon=True)
        th.start()
        return th

    def stop(self) -> None:
        """Ask the scheduler to stop; safe from any thread and from signal handlers."""
        self.stopping.set()
        try:
            self._queue.put_nowait(None)
        except queue.Full:
            pass
        self._waiter.wake()

    def shutdown(self) -> None:
        """Close every node (in reverse order) and join the threads. Idempotent."""
        if self._closed:
            return
        self._closed = True
        self.stopping.set()
        self.running = False
        if self.compiled_chains is not None:  # the nodes' state, counters and health as if never fused
            self._guard(None, self.compiled_chains.close)
        for node in reversed(list(self.nodes.values())):
            self._guard(node, node.close)
        if self.presets is not None:  # a save still waiting is written
            self._guard(None, self.presets.close)
        self._waiter.close()
        deadline = time.monotonic() + 3.0
        for th in self._threads:
            th.join(timeout=max(0.0, deadline - time.monotonic()))
            if th.is_alive():
                log.warning("thread %s did not stop within 3 s", th.name)

    # manual stepping (tests) -------------------------------------------------------
    def advance(self, seconds: float) -> None:
        """Move a manual clock forward, running every timer due on the way in time order, then the queue."""
        if not isinstance(self.clock, ManualClock):
            raise RuntimeError("advance() needs a runtime built with realtime=False")
        if not self.running:
            self.start()
        target = self.clock.t + seconds
        self.drain()
        while self._timers and self._timers[0].when <= target:
            self.clock.t = max(self.clock.t, self._timers[0].when)
            self._run_due()
            self.drain()
        self.clock.t = target
        self.drain()

    def drain(self, timeout: float = 0.0) -> int:
        """Read ready descriptors and run queued events, waiting up to ``timeout`` seconds for the first
        one.  Returns how many ran."""
        return self._poll(timeout)

    # internals ---------------------------------------------------------------------
    # The scheduler thread looks at the queue's length without its lock (``queue.Queue.queue``, a
    # deque: its length is read atomically).  A post that lands just after the look wakes the select.
    # (Without the GIL, a free-threaded Python, the look has no memory barrier: a wake-up might be
    # missed, and the post would then wait for the next wake-up, IDLE at the latest.)
    def _finished(self) -> bool:
        """Nothing queued, no timer, and no node active; a node that only listens for live control (an
        ``osc_in`` whose outlets are wired to nothing) does not keep a patch running whose own sources
        are all done, one of them at the end of its material (a ``replay`` at the end of its take, a
        ``simulate`` whose duration ran out): the take is over."""
        if self._queue.queue or not all(t.cancelled or t.daemon for t in self._timers):
            return False
        active = [n for n in self.nodes.values() if n.active]
        if not active:
            return True
        if any(n.active for n in self._sources) or not any(n.ended for n in self._sources):
            return False  # (a source closed by a message may be opened again by live control)
        if not self._over_told:
            self._over_told = True
            self.console(
                "the patch's sources have ended ("
                + ", ".join(f"{n.type_name} '{n.name}'" for n in self._sources)
                + "); live control ("
                + ", ".join(f"{n.type_name} '{n.name}'" for n in active)
                + ") ends with them"
            )
        return True

    @staticmethod
    def _listens_only(node: Node) -> bool:
        """A node active for live control only: it acts alone, and nothing is wired to its outlets."""
        return type(node).acts_alone and not any(node._targets)

    #: Longest sleep in select (seconds), so that a stop is noticed even if its wake-up were lost.
    IDLE = 0.25
    #: Seconds of queued events that one pass runs at most (real time only; one event at least).  A full
    #: queue of a fast replay's hand-overs (4096 of 64 rows) took 5 s through the tqt chain in one pass.
    QUEUE_BUDGET = 0.005
    #: A timer run this many seconds after its time says the machine cannot keep up: a warning, at most
    #: once every :attr:`LATE_EVERY` seconds.
    LATE = 0.1
    LATE_EVERY = 10.0
    #: Timers one pass of a manual clock runs at most, for one logical time (see :meth:`_run_due`).
    MANUAL_PASS = 100_000

    def _run_due(self) -> float:
        """Run the timers that are due; return the seconds until the next one (at most :attr:`IDLE`; 0
        once the runtime is stopping).

        In time order, a pass runs the timers that were due when it began; one scheduled during it
        (real time only) waits for the next pass, after the descriptors and the queue are served.  So a
        periodic timer that costs more than its period (or a ``metro`` set to a microsecond) falls
        behind, but keeps neither the other timers nor the serial ports and sockets from running.  On a
        manual clock a pass runs what its timers schedule for the same time too, as a Pd tick runs the
        clocks set during it; past :attr:`MANUAL_PASS` of them it raises :class:`FeedbackError` (a
        ``delay 0`` that triggers itself would run forever, in Pd too), leaving the rest scheduled.
        """
        timers = self._timers
        clock = self.clock
        now = start = clock.now()
        newer = next(self._seq) if self.realtime else math.inf  # scheduled from here on: larger numbers
        if timers and timers[0].when <= start:
            self._passing = True
            later: list[Timer] = []  # scheduled during this pass, and due already: the next pass's
            ran = 0
            try:
                while timers and timers[0].when <= start:
                    t = heapq.heappop(timers)
                    if t.cancelled:
                        continue
                    if t.seq >= newer:  # a timer that fell behind must not keep the others from running
                        later.append(t)
                        continue
                    if start - t.when > self.LATE and self.realtime:
                        self._late(t, start - t.when)
                    ran += 1
                    if ran > self.MANUAL_PASS and not self.realtime:
                        heapq.heappush(timers, t)
                        who = f" (node '{t.node.name}')" if t.node is not None else ""
                        raise FeedbackError(
                            f"more than {self.MANUAL_PASS} timers at {start:g} s: a timer that schedules"
                            f" itself for the same time{who}, such as a delay 0 that triggers itself,"
                            " would run forever"
                        )
                    if t.node is not None:
                        t.node.time = t.when
                        self._guard(t.node, t.fn, *t.args)
                    else:
                        t.fn(*t.args)
                    if self.stopping.is_set():
                        return 0.0
                    now = None  # time went on while it ran
            finally:
                for t in later:
                    heapq.heappush(timers, t)
                self._end_pass()
        if not timers:
            return self.IDLE
        return min(self.IDLE, max(0.0, timers[0].when - (clock.now() if now is None else now)))

    def _late(self, timer: Timer, late: float) -> None:
        now = time.monotonic()
        if now - self._late_warned < self.LATE_EVERY:
            return
        self._late_warned = now
        who = f" (node '{timer.node.name}')" if timer.node is not None else ""
        log.warning(
            "the scheduler is %.0f ms behind its timers%s: this machine cannot keep up with the patch, and its "
            "timing and latency suffer (a lighter patch, a lower rate, or pointat run --rt)",
            late * 1000.0,
            who,
        )

    def _poll(self, timeout: float) -> int:
        """Sleep in select until a watched descriptor is readable, an event is posted or ``timeout``
        passes; then run the ready readers and every queued event.  Returns how many ran."""
        if self._closed:
            return 0
        waiting = self._queue.queue
        ready = self._waiter.wait(timeout, waiting, self.realtime)
        self._passing = True
        try:
            n = self._serve(ready, waiting)
            if n:
                self._waiter.served()
            return n
        finally:
            self._end_pass()

    def _serve(self, ready: list, waiting: Any) -> int:
        """One pass: the readers in ``ready``, then what is in the queue now, for :attr:`QUEUE_BUDGET`
        seconds at most (real time only): the rest is left in the queue for the next passes."""
        n = 0
        for reader in ready:
            if reader is None:  # the wake-up socket
                self._waiter.woken()
                continue
            if not reader.watched:  # removed by a reader before it in this wake-up
                continue
            if self._guard(reader.node, reader.callback):
                reader.failures = 0
            else:
                reader.failures += 1
                if reader.failures >= _Reader.GIVE_UP:  # it fails without reading: do not spin on it
                    who = f"node '{reader.node.name}'" if reader.node is not None else "a reader"
                    log.error(
                        "%s failed %d times in a row: its input is no longer read", who, reader.failures
                    )
                    self.remove_reader(reader.fileobj)
            n += 1
        if waiting:  # what is queued now, not what keeps coming: timers get their turn between polls
            until = time.monotonic() + self.QUEUE_BUDGET if self.realtime else math.inf
            try:
                for _ in range(len(waiting)):
                    self._run_item(self._queue.get_nowait())
                    n += 1
                    if time.monotonic() >= until:
                        break
            except queue.Empty:
                pass
        return n

    def _end_pass(self) -> None:
        """Run what :meth:`at_pass_end` collected during the pass (and what those calls add), in order.

        The list is taken before it runs, so a pass started inside one of the calls (a ``drain``) runs
        only what was collected since; if a call is interrupted (KeyboardInterrupt), the ones after it
        stay first in line for the end of the next pass.
        """
        try:
            while self._at_end:
                pending, self._at_end = self._at_end, []
                for i, (node, fn) in enumerate(pending):
                    try:
                        self._guard(node, fn)
                    except BaseException:
                        self._at_end[:0] = pending[i + 1 :]
                        raise
        finally:
            self._passing = False

    def _run_item(self, item: tuple | None) -> None:
        if item is None:
            return
        node, fn, args = item
        self._guard(node, fn, *args)

    def _guard(self, node: Node | None, fn: Callable, *args: Any) -> bool:
        """Run one event; a failure is logged with the node's name and the patch goes on.  True if it ran."""
        self.depth = 0
        try:
            fn(*args)
            return True
        except FeedbackError as exc:
            n, tell = self._failed(node, exc)
            if tell:
                log.error("%s%s", exc, f" ({n} so far)" if n > 3 else "")
        except Exception as exc:
            n, tell = self._failed(node, exc)
            if tell:  # a timer that fails at every tick must not flood the console
                who = f"node '{node.name}' ({node.type_name})" if node is not None else "runtime"
                log.error(
                    "%s: %s: %s%s",
                    who,
                    type(exc).__name__,
                    exc,
                    f" ({n} so far)" if n > 3 else "",
                    exc_info=log.isEnabledFor(logging.DEBUG),
                )
        finally:
            self.depth = 0
        return False

    #: Failed events are counted by node, error type and message with its numbers blanked (``moved 3.2
    #: deg`` and ``moved 4.1 deg`` are one): a new failure is told at once, a repeated one at its 1st,
    #: 2nd, 3rd, 10th, 100th...  Past this many different messages, by node and type alone.
    FAILURE_KINDS = 256
    _NUMBERS = re.compile(r"[-+]?[0-9][0-9.eE+-]*")

    def _failed(self, node: Node | None, exc: BaseException) -> tuple[int, bool]:
        """How many times events of ``node`` failed so, this one included, and whether to log this one."""
        who, kind = None if node is None else node.name, type(exc).__name__
        return self._failures.add((who, kind, self._NUMBERS.sub("#", str(exc))[:120]), (who, kind, ""))
