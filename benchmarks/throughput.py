"""Throughput on one core, the cost of each node, the pure filters against their peers, and start-up.

Every figure is a median over chunks, runs or rounds, with the range (min–max) beside it: the machine is
shared, and the fastest of many tries shows what it can do when nothing else runs, not what it does.

* **Patches, scheduler saturated.**  In process: (a) ``benchmarks/patches/throughput_CHAIN.pat``: the
  simulated glove (``simulate output=direct``) into the chain, one thread, manual clock advanced as fast
  as it goes; the glove's own cost is measured alone and subtracted for the "chain only" figure.  (b) The
  same chain fed pre-made ADC vectors by calling its first node's ``receive`` (no input I/O, no parsing,
  no scheduler).  (c) The shipped replay patches (``patches/replay_pointing_at.pat``,
  ``patches/replay_tqt.pat``) with ``replay speed=0`` of a BROAD recording on the real-time runtime: the
  source thread, the bounded queue and the scheduler thread.  Whole process: (d) the same replay patches
  run by ``pointat run`` in a process of their own, their OSC counted at a UDP socket in this one, from
  the first datagram to the last (kernel time stamps).
* **Per node.**  Every message each node of the chain received during (b) is recorded, then replayed into
  a fresh instance of that node alone (its outlets into a sink that does nothing): microseconds per input
  sample, which add up to about the chain's cost.  A ``cProfile`` of (b) names the hot functions.
* **Pure filters.**  One ``update`` per sample of a BROAD trial, inputs prepared beforehand in each
  library's own format: pointat's ``TQTFilter`` (robust, paper), ``ComplementaryFilter`` (and its ``fuse``
  alone: what the ``complementary`` node runs a sample, the filter's own code), ``TQTBank`` over
  15 sensors (per sensor-sample), against ``ahrs`` Madgwick and Mahony, ``imufusion`` and ``vqf`` called
  once per sample, and VQF's and BasicVQF's ``updateBatch`` (one call for the whole trial) beside the bank,
  batch against batch.
* **Start-up.**  ``pointat run glove_tqt --for 0`` and ``pointat check glove_tqt``, whole process, wall
  time from this process, after a first run that is not counted (files in the page cache).
"""

from __future__ import annotations

import contextlib
import cProfile
import functools
import gc
import gzip
import logging
import math
import pstats
import select
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pointat.devices.glove_sim import GloveSimulator
from pointat.loader import load
from pointat.maths.evaluation import BROAD_RATE
from pointat.maths.fusion import ComplementaryFilter
from pointat.maths.scalar import accmag_quat as accmag_quat_floats
from pointat.maths.scalar import axis_angle_quat
from pointat.maths.tqt import TQTBank, TQTFilter
from pointat.message import Message, floats, vector
from pointat.node import Inlet, Node
from pointat.nodes.body import SkeletonNode
from pointat.nodes.tqt import TQT as TQTNode
from pointat.nodes.tqt import TQTBankNode
from pointat.runtime import Runtime

from .latency import (
    _drain,
    free_udp_port,
    pointat_command,
    receiver_socket,
    shown,
    stop_process,
    udp_hole,
)

log = logging.getLogger("benchmarks.throughput")

#: The 15-segment body the body row measures.
BODY15 = "pointat:data/body15.json"
BODY_ROW = "body: tqt_bank 15 + skeleton 15 segments"
#: How each filter of the table is called (:attr:`FilterCost.calls`): like is set against like.
PER_CALL = "one sensor-sample a call"
BANK_CALLS = "15 sensors a call (a batch across sensors)"
BATCH = "the whole trial a call (a batch across time)"
IN_PATCH = "in a patch: 3 messages a sensor-sample"

REPO = Path(__file__).resolve().parents[1]
PATCHES = Path(__file__).resolve().parent / "patches"
CHAINS = {"torre": "Pointing-at (torre_fusion)", "tqt": "tqt (tqt_fusion)"}


class _Null(Node):
    """A sink that does nothing: the outlets of a node measured alone go here."""

    type_name = "null"
    inlets = (Inlet("in", ("any",), "anything"),)

    def on_in(self, msg: Message) -> None:
        pass


@contextlib.contextmanager
def udp_sink(seconds: float = 900.0) -> Iterator[int]:
    """A UDP sink on 127.0.0.1 in its own process (no receiver thread competing for this one's GIL).

    Yields its port; the process is stopped on the way out (and stops by itself after ``seconds``).
    """
    port = free_udp_port()
    cmd = [sys.executable, "-m", "benchmarks.relay", "--in-port", str(port), "--out-port", "0"]
    proc = subprocess.Popen(
        [*cmd, "--for", f"{seconds:.0f}"],
        cwd=REPO,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        start_new_session=True,
    )
    try:
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline and not _bound(port):
            time.sleep(0.05)
        yield port
    finally:
        stop_process(proc)


def _empty(sock: socket.socket) -> None:
    with contextlib.suppress(BlockingIOError):
        while sock.recv(2048):
            pass


#: Sends back to back in :func:`wake_cost`'s burst (a base station's delivery for 16 motes).
WAKE_BURST = 16


def wake_cost(
    sink_port: int, hole: socket.socket, n: int = 2000, gap: float = 50e-6, burst: int = WAKE_BURST
) -> tuple[float, float, float]:
    """Microseconds one ``send`` of a 40-byte datagram takes: ``gap`` seconds after the previous one, to the
    sink process (asleep between datagrams, as a receiver is) and to the hole (nobody to wake); and each
    send of ``burst`` back to back to the sink (what ``osc_out`` does with the gloves of one delivery).
    The median of 3 rounds of ``n`` sends each."""
    result = []
    for port, size in ((sink_port, 1), (hole.getsockname()[1], 1), (sink_port, burst)):
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sock.connect(("127.0.0.1", port))
        each = []
        for _ in range(3):
            total = 0.0
            rounds = max(1, n // size)
            for _ in range(rounds):
                t0 = time.perf_counter()
                while time.perf_counter() - t0 < gap * size:
                    pass
                t = time.perf_counter()
                for _ in range(size):
                    sock.send(b"x" * 40)
                total += time.perf_counter() - t
            each.append(1e6 * total / (rounds * size))
        sock.close()
        _empty(hole)
        result.append(statistics.median(each))
    return result[0], result[1], result[2]


def _bound(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return True
    return False


# --------------------------------------------------------------------------------------- results
class _Spread:
    """The median and the range of the ``us`` of each chunk, run or round."""

    us: list[float]

    @property
    def median_us(self) -> float:
        return statistics.median(self.us) if self.us else math.nan

    @property
    def min_us(self) -> float:
        return min(self.us, default=math.nan)

    @property
    def max_us(self) -> float:
        return max(self.us, default=math.nan)


@dataclass
class PatchRate(_Spread):
    """Samples per second through one patch, and what it was measured with.

    ``us`` holds the µs per sample of every chunk (or run, or round) measured, in order; the figures are
    their median, with their range beside it.
    """

    chain: str
    how: str
    samples: int  # per chunk or run
    us: list[float]
    source_us: float = 0.0  # per-sample cost of the source, subtracted for "chain only"
    #: measured from outside: ``pointat run`` in a process of its own, its datagrams counted here
    whole_process: bool = False
    #: (datagrams received, datagrams the patch sent) over every run, where counted
    received: tuple[int, int] | None = None

    @classmethod
    def pooled(cls, rates: list[PatchRate]) -> PatchRate:
        """One rate from several measurements of the same thing: all their chunks together."""
        first = rates[0]
        counted = [r.received for r in rates if r.received is not None]
        received = (sum(a for a, _ in counted), sum(b for _, b in counted)) if counted else None
        us = [u for r in rates for u in r.us]
        return cls(first.chain, first.how, first.samples, us, first.source_us, first.whole_process, received)

    @property
    def per_second(self) -> float:
        """Samples per second at the median chunk."""
        return 1e6 / self.median_us if self.median_us > 0 else math.nan

    @property
    def chain_per_second(self) -> float:
        us = self.median_us - self.source_us
        return 1e6 / us if us > 0 else math.nan


@dataclass
class NodeCost:
    chain: str
    node: str
    type_name: str
    messages: int
    us_per_sample: float


@dataclass
class FilterCost(_Spread):
    """µs per update (per sensor-sample, per frame: see ``note``) of each round, in order."""

    name: str
    library: str
    us: list[float]
    note: str = ""
    #: how the filter is called: :data:`PER_CALL`, :data:`BANK_CALLS`, :data:`BATCH` or :data:`IN_PATCH`
    calls: str = PER_CALL


@dataclass
class Startup:
    """Wall time of a whole command, start to exit, each run (s), after a first run not counted."""

    label: str
    command: str
    seconds: list[float] = field(default_factory=list)
    error: str = ""


@dataclass
class ThroughputResults:
    patches: list[PatchRate] = field(default_factory=list)
    nodes: list[NodeCost] = field(default_factory=list)
    chain_totals: dict[str, float] = field(default_factory=dict)
    filters: list[FilterCost] = field(default_factory=list)
    hotspots: dict[str, list[tuple[str, int, float, float]]] = field(default_factory=dict)
    #: (us per send to a sleeping receiver, to a socket nobody waits on, in a burst of 16 to the receiver)
    wake: tuple[float, float, float] | None = None
    #: chain -> (samples, {generation: (collections, mean pause us, longest pause us)})
    gc_pauses: dict[str, tuple[int, dict[int, tuple[int, float, float]]]] = field(default_factory=dict)
    #: the commands of the whole-process measurements, (d) and start-up, as a person would type them
    commands: list[str] = field(default_factory=list)
    startup: list[Startup] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)


# --------------------------------------------------------------------------------------- patches
def _adc_messages(n: int, rate: float = 1000.0) -> list[Message]:
    sim = GloveSimulator(rate_hz=rate, seed=5)
    cycle = [np.array(s.frame.channels, dtype=float) for s in sim.samples(min(n, 2000))]
    return [vector(cycle[k % len(cycle)], k / rate) for k in range(n)]


def _load_chain(chain: str, port: int) -> Runtime:
    rt = load(PATCHES / f"throughput_{chain}.pat", overrides=[f"g/out.port={port}"], realtime=False)
    rt.console = lambda line: None
    return rt


CHUNKS = 5  # patch rates in process: each run is timed in this many equal chunks
PUSH_ROUNDS = 3  # (b), (b'), (c) and (d): measured this many times, in turn over the chains
WHOLE_RUNS = 2  # (d): runs of the whole process in each of those rounds


def _advance_chunks(rt: Runtime, seconds: float) -> list[float]:
    """Advance a manual clock by ``seconds`` in :data:`CHUNKS` chunks; the µs per sample (1 kHz) of each."""
    samples = seconds / CHUNKS * 1000
    walls = []
    for _ in range(CHUNKS):
        t0 = time.perf_counter()
        rt.advance(seconds / CHUNKS)
        walls.append(1e6 * (time.perf_counter() - t0) / samples)
    return walls


def simulate_rate(chain: str, seconds: float, port: int) -> PatchRate:
    """(a) The patch with its simulated glove, manual clock, as fast as it goes."""
    rt = _load_chain(chain, port)
    rt.start()
    rt.advance(0.2)  # the offset node's gyro averaging and first-call costs out of the way
    us = _advance_chunks(rt, seconds)
    rt.shutdown()
    return PatchRate(chain, "simulated glove, manual clock", round(seconds / CHUNKS * 1000), us)


def simulator_cost(seconds: float) -> float:
    """Microseconds per sample of ``simulate rate=1000 output=direct`` alone (the median chunk)."""
    from pointat.testing import patch

    rt = patch("node glove simulate rate=1000 output=direct\n")
    rt.start()
    rt.advance(0.1)
    us = _advance_chunks(rt, seconds)
    rt.shutdown()
    return statistics.median(us)


PUSHED = "ADC vectors pushed into the chain's first node"
#: (b'): as (b), the OSC going to a socket no process sleeps on.
PUSHED_NO_WAKE = "ADC vectors pushed, OSC to a socket nobody waits on"
#: (c) and (d)
REPLAYED = "replay speed=0 (real-time runtime, BROAD trial)"
WHOLE = "pointat run, replay speed=0, UDP out counted by a receiver"


def _spy(node: Node) -> list[tuple[int, Message]]:
    """Record every data message ``node`` gets from now on, (inlet, message), in the list returned.

    Data reaches a node by ``receive`` from outside and by its per-inlet delivery from an upstream
    ``out`` (:meth:`pointat.node.Node.out`): both doors are watched.
    """
    log: list[tuple[int, Message]] = []

    def tap(index: int, fn: Callable[[Message], None]) -> Callable[[Message], None]:
        def spy(msg: Message) -> None:
            log.append((index, msg))
            fn(msg)

        return spy

    if node._deliver is node._handlers:  # receive ends in the same handlers that out calls
        node._handlers[:] = [tap(i, fn) for i, fn in enumerate(node._handlers)]
    else:  # the type has its own receive, and out calls it
        receive = node.receive

        def spy_receive(index: int, msg: Message) -> None:
            log.append((index, msg))
            receive(index, msg)

        node.receive = spy_receive  # type: ignore[method-assign]
        node._deliver[:] = [functools.partial(spy_receive, i) for i in range(len(node._deliver))]
    return log


def push_rate(chain: str, messages: list[Message], port: int, record: bool = False, how: str = PUSHED):
    """(b) ADC vectors straight into the chain's first node; optionally record every node's inputs."""
    rt = _load_chain(chain, port)
    rt.start()
    first = rt.nodes["g/nulls"]
    for msg in messages[:200]:  # warm up, and finish the offset node's averaging
        first.receive(0, msg)
    recorded: dict[str, list[tuple[int, Message]]] = {}
    if record:
        for name, node in rt.nodes.items():
            if name.startswith("g/"):
                recorded[name] = _spy(node)
    body = messages[200:]
    size = len(body) // CHUNKS
    us = []
    for c in range(CHUNKS):
        chunk = body[c * size : (c + 1) * size]
        t0 = time.perf_counter()
        for msg in chunk:
            first.receive(0, msg)
        us.append(1e6 * (time.perf_counter() - t0) / size)
    nodes = dict(rt.nodes)
    rt.shutdown()
    return PatchRate(chain, how, size, us), recorded, nodes


def node_costs(
    chain: str, recorded: dict[str, list[tuple[int, Message]]], nodes: dict[str, Node], n: int, port: int
) -> list[NodeCost]:
    """Replay each node's recorded inputs into a fresh instance of it alone."""
    out = []
    for name, inputs in recorded.items():
        proto = nodes[name]
        values = dict(vars(proto.p))
        if proto.type_name == "osc_out":
            values["port"] = port
        walls = []
        for _ in range(3):  # a fresh instance each time (same state path); the median run counts
            inst = type(proto)(name, values)
            rt = Runtime(realtime=False)
            rt.add(inst)
            sink = rt.add(_Null("sink"))
            for o in range(len(inst.out_specs)):
                rt.connect(inst, o, sink, 0)
            rt.start()
            receive = inst.receive
            t0 = time.perf_counter()
            for index, msg in inputs:
                receive(index, msg)
            walls.append(time.perf_counter() - t0)
            rt.shutdown()
        us = 1e6 * statistics.median(walls) / n
        out.append(NodeCost(chain, name.removeprefix("g/"), proto.type_name, len(inputs), us))
    return out


def profile_chain(
    chain: str, messages: list[Message], port: int, top: int = 12
) -> list[tuple[str, int, float, float]]:
    """cProfile of (b): ``(function, calls, tottime us/sample, cumtime us/sample)``, by tottime."""
    rt = _load_chain(chain, port)
    rt.start()
    first = rt.nodes["g/nulls"]
    for msg in messages[:200]:
        first.receive(0, msg)
    body = messages[200:]
    prof = cProfile.Profile()
    prof.enable()
    for msg in body:
        first.receive(0, msg)
    prof.disable()
    rt.shutdown()
    stats = pstats.Stats(prof)
    rows = []
    for (filename, line, func), (_cc, nc, tt, ct, _callers) in stats.stats.items():  # type: ignore[attr-defined]
        where = Path(filename)
        try:
            where = where.resolve().relative_to(REPO)
        except ValueError:
            where = Path(where.name)
        label = f"{func} ({where}:{line})" if line else func
        rows.append((label, nc, 1e6 * tt / len(body), 1e6 * ct / len(body)))
    rows.sort(key=lambda r: -r[2])
    return rows[:top]


def gc_pauses(
    chain: str, messages: list[Message], port: int
) -> tuple[int, dict[int, tuple[int, float, float]]]:
    """Python's cyclic garbage collections while ADC vectors go through the chain: count and pauses."""
    pauses: list[tuple[int, float]] = []
    started: list[int] = []

    def watch(phase: str, info: dict) -> None:
        if phase == "start":
            started.append(time.perf_counter_ns())
        elif started:
            pauses.append((info["generation"], (time.perf_counter_ns() - started.pop()) / 1000.0))

    gc.callbacks.append(watch)
    try:
        push_rate(chain, messages, port)
    finally:
        gc.callbacks.remove(watch)
    by: dict[int, list[float]] = {}
    for gen, us in pauses:
        by.setdefault(gen, []).append(us)
    return len(messages), {g: (len(v), float(np.mean(v)), float(np.max(v))) for g, v in sorted(by.items())}


def _broad_head(path: Path, rows: int, workdir: Path) -> tuple[Path, int]:
    """The first ``rows`` samples of a BROAD trial as a smaller .csv.gz (replay loads whole files), and
    how many it holds (fewer when the trial is shorter)."""
    out = workdir / f"head_{rows}.csv.gz"
    with gzip.open(path, "rt", encoding="utf-8") as src, gzip.open(out, "wt", encoding="utf-8") as dst:
        header_seen = 0
        for line in src:
            dst.write(line)
            if line.startswith("#"):
                continue
            header_seen += 1
            if header_seen > rows:
                break
    return out, min(rows, header_seen - 1)


def _replay_patch(chain: str) -> Path:
    return REPO / "patches" / ("replay_pointing_at.pat" if chain == "torre" else "replay_tqt.pat")


def replay_rate(chain: str, head: Path, port: int) -> PatchRate:
    """(c) ``patches/replay_*.pat`` with ``speed=0``: real-time runtime, source thread and queue."""
    rt = load(_replay_patch(chain), overrides=[f"source.file={head}", "source.speed=0", f"out.port={port}"])
    rt.console = lambda line: None
    src = rt.nodes["source"]
    marks: dict[str, float] = {}
    orig_emit, orig_done = src._emit, src._done  # type: ignore[attr-defined]

    def emit(i: int, j: int) -> None:
        if i == 0:
            marks["first"] = time.perf_counter()
        orig_emit(i, j)

    def done() -> None:
        marks["done"] = time.perf_counter()
        orig_done()

    src._emit, src._done = emit, done  # type: ignore[attr-defined]
    rt.run(120.0)
    wall = marks.get("done", math.nan) - marks.get("first", math.nan)
    n = int(src.emitted)
    return PatchRate(chain, REPLAYED, n, [1e6 * wall / n if n else math.nan])


def whole_process_command(chain: str, head: Path, port: int) -> list[str]:
    """(d) ``pointat run`` of the shipped replay patch at ``speed=0``, its OSC to ``port``."""
    overrides = [f"source.file={head}", "source.speed=0", f"out.port={port}"]
    cmd = pointat_command(_replay_patch(chain), overrides, 120.0)
    return cmd[:4] + ["--status", "0"] + cmd[4:]


def whole_process_rate(chain: str, head: Path, rows: int) -> tuple[PatchRate, str]:
    """(d) The replay patch in a ``pointat run`` process of its own, as a user runs it: start-up, the
    recording read, the source thread, the scheduler, ``osc_out``.  Its directions are counted at a UDP
    socket in this process; the rate is from the kernel's receive time stamps of the first and the last
    (start-up and exit are not in it: the start-up has a table of its own).  Returns the rate and the
    command as shown."""
    sock = receiver_socket()
    cmd = whole_process_command(chain, head, sock.getsockname()[1])
    stamps: list[int] = []
    got: list[tuple[int, bytes]] = []
    try:
        proc = subprocess.Popen(
            cmd, cwd=REPO, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, start_new_session=True
        )
        try:
            deadline = time.monotonic() + 120.0
            while proc.poll() is None and time.monotonic() < deadline:
                select.select([sock], [], [], 0.05)
                _drain(sock, got)
                stamps += [t for t, data in got if data.startswith(b"/pointat/1/aed")]  # not the status
                got.clear()
        finally:
            stop_process(proc)
        _drain(sock, got)
        stamps += [t for t, data in got if data.startswith(b"/pointat/1/aed")]
    finally:
        sock.close()
    if len(stamps) < 2:
        raise RuntimeError(f"{len(stamps)} directions came out of {rows}")
    us = (stamps[-1] - stamps[0]) / 1000.0 / (len(stamps) - 1)
    cmd_shown = shown(cmd).replace(str(head), f"FIRST_{rows}_ROWS_OF_TRIAL.csv.gz")
    return PatchRate(chain, WHOLE, rows, [us], whole_process=True, received=(len(stamps), rows)), cmd_shown


def startup_times(runs: int, port: int) -> list[Startup]:
    """Wall time of ``pointat run glove_tqt --for 0`` and ``pointat check glove_tqt`` (whole process, from
    this one: fork, interpreter, imports, patch, nodes started and stopped), beside ``python -c pass`` (the
    interpreter alone).  One run of each first, not counted; then ``runs`` rounds, the commands in turn."""
    run = pointat_command(Path("glove_tqt"), [f"out.port={port}", "ctl.port=0"], 0.0)
    commands = [
        ("pointat run glove_tqt --for 0", [*run[:4], "--status", "0", *run[4:]]),
        ("pointat check glove_tqt", [sys.executable, "-m", "pointat.cli", "check", "glove_tqt"]),
        ("python -c pass (the interpreter alone)", [sys.executable, "-c", "pass"]),
    ]
    out = [Startup(label, shown(cmd).replace(sys.executable, "python")) for label, cmd in commands]
    for k in range(runs + 1):
        for (_, cmd), res in zip(commands, out, strict=True):
            if res.error:
                continue
            t0 = time.perf_counter()
            done = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=60)
            wall = time.perf_counter() - t0
            if done.returncode:
                res.error = f"exit {done.returncode}: {(done.stderr or done.stdout).strip()[-200:]}"
            elif k:  # the first run warms the page cache and is not counted
                res.seconds.append(wall)
    return out


# --------------------------------------------------------------------------------------- filters
def _rounds(fn: Callable[[], None], n: int, rounds: int) -> list[float]:
    """µs per item (``n`` of them a call of ``fn``) of each of ``rounds`` calls."""
    times = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        fn()
        times.append(1e6 * (time.perf_counter() - t0) / n)
    return times


def _feed(
    rt: Runtime, feeds: list[tuple[Callable[[int, Message], None], int]], msgs: list[list[tuple]]
) -> None:
    """Run a patch of tqt or tqt_bank nodes over ``msgs`` (per sample, per sensor: mag, accel, gyro):
    each sensor's three messages to its node's inlets, the hot gyro last, as ``scaling`` sends them."""
    rt.start()
    for sample in msgs:
        for (receive, gyro), (mm, am, gm) in zip(feeds, sample, strict=True):
            receive(gyro + 2, mm)
            receive(gyro + 1, am)
            receive(gyro, gm)
    rt.shutdown()


def _increment(rate: list[float], dt: float) -> tuple[float, float, float, float] | None:
    """The body-frame rotation of one gyro sample, as :meth:`ComplementaryFilter.update` makes it."""
    wx, wy, wz = rate
    r = math.sqrt(wx * wx + wy * wy + wz * wz)
    return axis_angle_quat(wx / r, wy / r, wz / r, r * dt) if r > 0.0 else None


def filter_costs(sample: dict[str, np.ndarray], n: int, rounds: int) -> tuple[list[FilterCost], list[str]]:
    """Per-update cost of pointat's pure filters and of the peers, same samples, same rounds."""
    g, a, m = (np.ascontiguousarray(sample[k][:n]) for k in ("gyr", "acc", "mag"))
    n = len(g)
    dt = 1.0 / BROAD_RATE
    gl, al, ml = g.tolist(), a.tolist(), m.tolist()
    out: list[FilterCost] = []
    errors: list[str] = []

    def tqt(mode: str, backend: str) -> Callable[[], None]:
        def run() -> None:
            f = TQTFilter(mode=mode, backend=backend)  # type: ignore[arg-type]
            upd = f.update
            for i in range(n):
                upd(gl[i], al[i], ml[i], dt)

        return run

    TQTFilter()  # compiles the robust step (or loads it from numba's cache) outside the timing
    for mode, backend, note in (
        ("robust", "auto", "Python floats in; the step compiled (numba), one call a sample"),
        ("robust", "python", "Python floats in; the step in Python"),
        ("paper", "python", "Python floats in"),
    ):
        name = f"TQTFilter {mode}" + (
            ", the step in Python" if backend == "python" and mode == "robust" else ""
        )
        out.append(FilterCost(name, "pointat", _rounds(tqt(mode, backend), n, rounds), note))

    def compl() -> None:
        f = ComplementaryFilter(0.05)
        for i in range(n):
            f.update(g[i], a[i], m[i], dt)

    us = _rounds(compl, n, max(1, rounds - 1))
    out.append(FilterCost("ComplementaryFilter", "pointat", us, "numpy rows in"))

    # what the complementary node runs a sample: fuse, on the gyro's increment and the acc/mag orientation
    # (the chain's gyro_integrator and accmag_matrix give them; here made beforehand from the same samples)
    increments = [_increment(gl[i], dt) for i in range(n)]
    accmags = [accmag_quat_floats(al[i], ml[i]) for i in range(n)]

    def fuse() -> None:
        step = ComplementaryFilter(0.05).fuse
        for i in range(n):
            step(increments[i], accmags[i], dt)

    us = _rounds(fuse, n, max(1, rounds - 1))
    out.append(
        FilterCost(
            "ComplementaryFilter.fuse",
            "pointat",
            us,
            "the complementary node's step: gyro increment and acc/mag orientation in, Python floats",
        )
    )

    k15 = 15
    nb = min(n, 4000)
    G = np.repeat(g[:nb, None, :], k15, 1)
    A = np.repeat(a[:nb, None, :], k15, 1)
    M = np.repeat(m[:nb, None, :], k15, 1)

    for backend in ("numba", "python"):
        TQTBank(k15, backend=backend).update(G[0], A[0], M[0], dt)  # compiles (numba) outside the timing

        def bank(backend: str = backend) -> None:
            b = TQTBank(k15, backend=backend)
            for i in range(nb):
                b.update(G[i], A[i], M[i], dt)

        note = "per sensor-sample; " + (
            "compiled loop (numba)" if backend == "numba" else "a Python loop over the sensors"
        )
        us = _rounds(bank, nb * k15, rounds)
        out.append(FilterCost(f"TQTBank robust, 15 sensors, {backend}", "pointat", us, note, BANK_CALLS))
    G15, A15, M15 = G.tolist(), A.tolist(), M.tolist()

    def fifteen() -> None:
        fs = [TQTFilter() for _ in range(k15)]
        for i in range(nb):
            gi, ai, mi = G15[i], A15[i], M15[i]
            for j in range(k15):
                fs[j].update(gi[j], ai[j], mi[j], dt)

    us = _rounds(fifteen, nb * k15, rounds)
    out.append(FilterCost("15 x TQTFilter robust", "pointat", us, "per sensor-sample"))

    # the same in a patch, as a user wires it: one tqt_bank node, or a tqt node a sensor; three messages
    # in a sensor-sample (mag, accel, then the hot gyro), its quaternion out to a sink
    msgs = [
        [tuple(floats(tuple(X[i][j]), i * dt) for X in (M15, A15, G15)) for j in range(k15)]
        for i in range(nb)
    ]
    for label, note in (
        ("tqt_bank node, 15 sensors", "per sensor-sample, in a patch: 3 messages in, the quaternion out"),
        ("15 tqt nodes", "per sensor-sample, in a patch: 3 messages in, the quaternion out"),
    ):

        def nodes(bank: bool = label.startswith("tqt_bank")) -> None:
            rt = Runtime(realtime=False)
            sink = rt.add(_Null("sink"))
            if bank:
                node = rt.add(TQTBankNode("bank", {**TQTBankNode.resolve_params(named={"sensors": k15})}))
                for j in range(k15):
                    rt.connect(node, 2 + j, sink, 0)  # quatJ
                feeds = [(node.receive, 1 + 3 * j) for j in range(k15)]  # (inlet 0: range)
            else:
                feeds = []
                for j in range(k15):
                    node = rt.add(TQTNode(f"f{j}", TQTNode.resolve_params()))
                    rt.connect(node, 0, sink, 0)
                    feeds.append((node.receive, 0))
            _feed(rt, feeds, msgs)

        out.append(FilterCost(label, "pointat", _rounds(nodes, nb * k15, rounds), note, IN_PATCH))

    # a whole body (issue 33): 15 sensors through one tqt_bank into a 15-segment skeleton (offsets from
    # the calibration pose, forward kinematics), per frame of all 15, beside one glove's tqt node per sample
    def body(with_skeleton: bool = True) -> None:
        rt = Runtime(realtime=False)
        sink = rt.add(_Null("sink"))
        bank = rt.add(TQTBankNode("bank", {**TQTBankNode.resolve_params(named={"sensors": k15})}))
        if with_skeleton:
            skel = rt.add(
                SkeletonNode("body", SkeletonNode.resolve_params(named={"file": BODY15, "auto": 0.05}))
            )
            rt.connect(bank, 0, skel, 0)  # quats
            for o in range(3):
                rt.connect(skel, o, sink, 0)
        else:
            rt.connect(bank, 0, sink, 0)
        _feed(rt, [(bank.receive, 1 + 3 * j) for j in range(k15)], msgs)

    per_frame = "per frame of 15 sensors, in a patch"
    us = _rounds(body, nb, rounds)
    out.append(FilterCost(BODY_ROW, "pointat", us, per_frame, IN_PATCH))
    us = _rounds(lambda: body(False), nb, rounds)
    out.append(FilterCost("body: tqt_bank 15 alone", "pointat", us, per_frame, IN_PATCH))

    try:
        import ahrs

        q0 = np.array([1.0, 0.0, 0.0, 0.0])

        def madgwick() -> None:
            f = ahrs.filters.Madgwick(frequency=BROAD_RATE, gain=0.041)
            q = q0
            for i in range(n):
                q = f.updateMARG(q, g[i], a[i], m[i])

        def mahony() -> None:
            f = ahrs.filters.Mahony(frequency=BROAD_RATE, k_P=0.74, k_I=0.0012)
            q = q0
            for i in range(n):
                q = f.updateMARG(q, g[i], a[i], m[i])

        for name, fn in (("Madgwick", madgwick), ("Mahony", mahony)):
            us = _rounds(fn, n, max(1, rounds - 1))
            out.append(FilterCost(name, f"ahrs {ahrs.__version__}", us, "numpy rows in"))
    except ImportError as exc:
        errors.append(f"ahrs not installed ({exc}): pip install ahrs")

    try:
        us = _rounds(imufusion_loop(g, a, m, n), n, rounds)
        library = f"imufusion {package_version('imufusion')}"
        out.append(FilterCost("Ahrs (update + get_quaternion)", library, us, "C, numpy rows in"))
    except ImportError as exc:
        errors.append(f"imufusion not installed ({exc}): pip install imufusion")

    try:
        import vqf

        library = f"vqf {package_version('vqf')}"
        # the full filter and the basic one (no bias estimation, no magnetic disturbance rejection), each
        # called once a sample as a live patch would, and once for the whole trial (updateBatch: the loop
        # in C++, the same trade as TQTBank's one call for 15 sensors)
        for name, cls in (("VQF", vqf.VQF), ("BasicVQF", vqf.BasicVQF)):

            def loop(cls: type = cls) -> None:
                f = cls(dt)
                upd, get = f.update, f.getQuat9D
                for i in range(n):
                    upd(g[i], a[i], m[i])
                    get()

            def batch(cls: type = cls) -> None:
                cls(dt).updateBatch(g, a, m)

            us = _rounds(loop, n, rounds)
            out.append(FilterCost(f"{name} (update + getQuat9D)", library, us, "C++, numpy rows in"))
            us = _rounds(batch, n, rounds)
            note = "C++ loop over the whole trial; per sample"
            out.append(FilterCost(f"{name} updateBatch", library, us, note, BATCH))
    except ImportError as exc:
        errors.append(f"vqf not installed ({exc}): pip install vqf")
    return out, errors


def package_version(dist: str) -> str:
    """An installed distribution's version, ``?`` when it is not installed."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(dist)
    except PackageNotFoundError:
        return "?"


def imufusion_loop(g: np.ndarray, a: np.ndarray, m: np.ndarray, n: int) -> Callable[[], None]:
    """imufusion's Ahrs over the first ``n`` samples of a trial (gyro rad/s, accelerometer m/s², as BROAD
    gives them), one update and one read a sample, as a live patch would call it.  (ImportError without
    imufusion.)"""
    import imufusion

    gd = np.ascontiguousarray(np.degrees(g))
    ag = np.ascontiguousarray(a / 9.80665)

    def fusion() -> None:
        s = imufusion.AhrsSettings()
        s.sample_rate = BROAD_RATE
        f = imufusion.Ahrs()
        f.set_settings(s)
        upd, get = f.update, f.get_quaternion
        for i in range(n):
            upd(gd[i], ag[i], m[i])
            get()

    return fusion


# --------------------------------------------------------------------------------------- all
def run_all(
    sample: dict[str, np.ndarray],
    trial: Path,
    quick: bool,
    progress: Callable[[str], None],
) -> ThroughputResults:
    res = ThroughputResults()
    sim_seconds = 2.0 if quick else 10.0
    n_push = 4000 if quick else 20000
    replay_rows = 5000 if quick else 20000
    n_filter = 5000 if quick else 20000
    rounds = 3 if quick else 5
    startup_runs = 5 if quick else 10
    messages = _adc_messages(n_push + 200)
    simulated: dict[str, PatchRate] = {}
    measured: dict[tuple[str, str], list[PatchRate]] = {}
    with (
        udp_sink() as port,
        udp_hole() as hole,
        tempfile.TemporaryDirectory(prefix="pointat-bench-") as tmp,
    ):
        head, rows = _broad_head(trial, replay_rows, Path(tmp))
        shown_for: set[str] = set()

        def push_round(r: int) -> None:
            """(b), (b'), (c) and (d) once for each chain.  The section runs PUSH_ROUNDS of these, spread
            over it, so that a slow spell of the shared machine does not decide the figures alone; the
            report gives the median of all the chunks (or runs) and their range."""
            for chain in CHAINS:
                progress(
                    f"throughput: {chain} chain, pushed, replayed, whole process, round {r + 1}/{PUSH_ROUNDS}"
                )
                measured.setdefault((chain, PUSHED), []).append(push_rate(chain, messages, port)[0])
                rate = push_rate(chain, messages, hole.getsockname()[1], how=PUSHED_NO_WAKE)[0]
                measured.setdefault((chain, PUSHED_NO_WAKE), []).append(rate)
                _empty(hole)
                try:
                    measured.setdefault((chain, REPLAYED), []).append(replay_rate(chain, head, port))
                    for _ in range(WHOLE_RUNS):
                        rate, command = whole_process_rate(chain, head, rows)
                        measured.setdefault((chain, WHOLE), []).append(rate)
                        if r == 0 and chain not in shown_for:  # once a chain (the ports differ)
                            shown_for.add(chain)
                            res.commands.append(command)
                except Exception as exc:  # report, do not stop the other benchmarks
                    res.errors.append(f"replay {chain}, round {r + 1}: {type(exc).__name__}: {exc}")

        progress("throughput: the system's cost of waking a receiver")
        res.wake = wake_cost(port, hole)
        progress("throughput: simulated glove alone")
        sim_us = simulator_cost(sim_seconds / 2)
        push_round(0)
        for chain in CHAINS:
            progress(f"throughput: {chain} chain")
            r = simulate_rate(chain, sim_seconds, port)
            r.source_us = sim_us
            simulated[chain] = r
            _, recorded, nodes = push_rate(chain, messages, port, record=True)
            res.nodes += node_costs(chain, recorded, nodes, n_push, port)
            res.hotspots[chain] = profile_chain(chain, messages, port)
            res.gc_pauses[chain] = gc_pauses(chain, _adc_messages(20200), port)
        push_round(1)
        progress("throughput: pure filters and peers")
        res.filters, errs = filter_costs(sample, n_filter, rounds)
        res.errors += errs
        for r in range(2, PUSH_ROUNDS):
            push_round(r)
        progress("throughput: start-up, whole process")
        res.startup = startup_times(startup_runs, hole.getsockname()[1])
        res.commands += [st.command for st in res.startup]
        _empty(hole)
    for chain in CHAINS:  # the table's order: (a), (b), (b'), (c), (d)
        res.patches.append(simulated[chain])
        for how in (PUSHED, PUSHED_NO_WAKE, REPLAYED, WHOLE):
            if measured.get((chain, how)):
                res.patches.append(PatchRate.pooled(measured[(chain, how)]))
        res.chain_totals[chain] = PatchRate.pooled(measured[(chain, PUSHED)]).median_us
    return res
