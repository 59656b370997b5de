r"""End-to-end latency and jitter: a sample goes in, its OSC datagram comes out on 127.0.0.1.

Every measurement runs the system under test in its own process and drives it from this one, in a single
thread that paces the input on a deadline schedule and reads the output socket in between:

* **pointat, mote path** -- ``pointat run benchmarks/patches/mote_CHAIN_N.pat``: real 21-byte mote frames
  (:func:`pointat.devices.mote_frame.encode_frame`) written into a pseudo-terminal whose slave is the
  ``mote`` node's ``device``; the patch's ``osc_out`` sends one datagram per update to our UDP socket.
  All N motes of one tick go out in one write, as a base station delivers them.
* **pointat, UDP path** -- ``pointat run benchmarks/patches/oscin_CHAIN.pat``: the same sensor sample as
  one OSC datagram into ``osc_in``, through the fusion half of the chain, out of ``osc_out``.  CHAIN
  ``relay`` has no fusion (``osc_in`` -> ``osc_out``): what the engine itself adds to the floors below;
  ``mote_relay_1.pat`` is the same for the mote path (``mote`` -> ``osc_out``).
* **transport floors** -- a bare python-osc relay (:mod:`benchmarks.relay`: parse, re-encode, forward) and
  Pure Data relaying OSC (``benchmarks/patches/relay.pd``: ``[netreceive -u -b]`` -> ``[oscparse]`` ->
  ``[oscformat]`` -> ``[netsend -u -b]``), run as ``pd -nogui -noaudio -noprefs`` with and without
  ``-sleepgrain 0.1``.  UDP in, UDP out, no pseudo-terminal.  The mote path's floor is the same relay
  reading the mote frames from the pseudo-terminal (``benchmarks.relay --pty``).  Both Python relays are
  measured asleep in ``select`` between inputs, and again polling for two sample periods after each input
  (``--poll``), as ``pointat run --spin`` polls: pointat's ``--spin`` rows are set against the polling
  relays, its other rows against the sleeping ones.

Latency = the kernel's receive time stamp of the output datagram (``SO_TIMESTAMPNS``, ``CLOCK_REALTIME``)
minus ``time.time_ns()`` taken just before the input was written, so the harness's own wake-up delay on
the receiving side is not counted.  Each input names its sample: the floors carry the tick number as an
int argument; for pointat the tick number modulo 1000 rides in the data (a tag in the gyro x count, or a
``/tag`` message in the same bundle) and comes back in ``osc_out``'s spread field; an output is matched to
the latest input with its tag sent before it arrived.  Only inputs sent in the measurement window count;
before it, the run waits for the first output (process start-up, the ``offset`` node's 150 samples of
gyro averaging) and warms up for a while.  Inputs that never come out within the drain time count as
lost; a pseudo-terminal that would not take a tick's bytes (the patch fell behind and its buffers are
full) counts it as refused.

**Rounds.**  The machine is shared, and its load drifts over minutes.  So that a floor and the pointat run
it is compared with see the same machine, :func:`run_all` measures in rounds: every configuration in turn
for a part of its time, then again, and pools each configuration's samples (:func:`pool`).  Each round's
p50 and p99 are kept, so that a ratio can be given round by round as well as pooled.
"""

from __future__ import annotations

import bisect
import contextlib
import logging
import math
import os
import select
import shutil
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
import tty
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from pointat.devices.glove_sim import GloveSimulator
from pointat.devices.mote_frame import Frame, encode_frame
from pointat.node import Inlet, Node
from pointat.runtime import Runtime, keep_cpus_awake

log = logging.getLogger("benchmarks.latency")

REPO = Path(__file__).resolve().parents[1]
PATCHES = Path(__file__).resolve().parent / "patches"

_SO_TIMESTAMPNS = getattr(socket, "SO_TIMESTAMPNS", 35)  # Linux value; Python does not export it
_TAG_PERIOD = 1000  # pointat paths: the tag is the tick number modulo this
_TAG_BASE = 1548  # gyro x count of tag 0 (2048 - 500: +-50 deg/s about the null)


# ------------------------------------------------------------------------------------------ results
@dataclass
class LatencyResult:
    """One latency run: what was measured, how, and the per-sample latencies in microseconds."""

    label: str
    family: str  # "pointat-mote", "pointat-udp", "floor"
    chain: str  # "torre", "tqt", "relay" (pointat, no filter), "python-osc" ("python-osc+20us": busy), "pty", "pd", "pd-sg0.1"
    rate: float
    motes: int
    command: str
    latencies_us: np.ndarray = field(default_factory=lambda: np.zeros(0))
    expected: int = 0
    refused: int = 0
    duplicates: int = 0
    cpu_fraction: float | None = None
    rss_peak_kb: int | None = None
    error: str = ""
    #: run at real-time priority (pointat ``--rt``; a floor under ``chrt -f``), as Pd runs by default as root
    realtime: bool = False
    #: pointat ``--spin MS``: the scheduler polls for this many ms after each input instead of sleeping
    #: (a floor with ``--poll MS``: the relay does the same, the floor of the ``--spin`` rows)
    spin: float = 0.0
    #: pointat ``--compiled on``: the glove chains run as one compiled function (:mod:`pointat.compiled`)
    compiled: bool = False
    #: (p50, p99) of each round (:func:`pool`) in the order they ran; ``None`` for a round that failed
    rounds: list[tuple[float, float] | None] = field(default_factory=list)

    @property
    def received(self) -> int:
        return int(self.latencies_us.size)

    def pct(self, q: float) -> float:
        return float(np.percentile(self.latencies_us, q)) if self.received else float("nan")

    @property
    def p50(self) -> float:
        return self.pct(50)

    @property
    def p99(self) -> float:
        return self.pct(99)

    @property
    def max(self) -> float:
        return float(self.latencies_us.max()) if self.received else float("nan")

    @property
    def jitter(self) -> float:
        return self.p99 - self.p50

    @property
    def lost(self) -> int:
        return max(0, self.expected - self.received)


# ------------------------------------------------------------------------------------------ OSC bits
def _pad(b: bytes) -> bytes:
    return b + b"\0" * (4 - len(b) % 4)


def osc_message(address: str, tags: str, *args: float | int) -> bytes:
    """Encode one OSC message (types ``i`` and ``f`` only), fast enough for a 16 kHz sender.

    >>> osc_message("/a", "if", 1, 0.5).hex(" ")
    '2f 61 00 00 2c 69 66 00 00 00 00 01 3f 00 00 00'
    """
    return _pad(address.encode()) + _pad(("," + tags).encode()) + struct.pack(">" + tags, *args)


def osc_bundle(*messages: bytes) -> bytes:
    """An OSC bundle, time tag "immediately"."""
    parts = [b"#bundle\0", b"\0\0\0\0\0\0\0\x01"]
    for m in messages:
        parts += [struct.pack(">i", len(m)), m]
    return b"".join(parts)


def parse_osc(data: bytes) -> tuple[str, list[float | int | str]]:
    """Decode one OSC message with ``i``, ``f`` and ``s`` arguments.

    >>> parse_osc(osc_message("/bench/3", "iff", 3, 1.5, -2.0))
    ('/bench/3', [3, 1.5, -2.0])
    """
    end = data.index(b"\0")
    address = data[:end].decode()
    pos = (end + 4) & ~3
    tend = data.index(b"\0", pos)
    tags = data[pos + 1 : tend].decode()
    pos = (tend + 4) & ~3
    args: list[float | int | str] = []
    for t in tags:
        if t == "i":
            args.append(struct.unpack_from(">i", data, pos)[0])
            pos += 4
        elif t == "f":
            args.append(struct.unpack_from(">f", data, pos)[0])
            pos += 4
        elif t == "s":
            e = data.index(b"\0", pos)
            args.append(data[pos:e].decode())
            pos = (e + 4) & ~3
        else:
            raise ValueError(f"OSC type {t!r} not handled")
    return address, args


# ------------------------------------------------------------------------------------------ helpers
def free_udp_port() -> int:
    """A UDP port on 127.0.0.1 that was free a moment ago."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def receiver_socket() -> socket.socket:
    """A non-blocking UDP socket on 127.0.0.1 with kernel receive time stamps and a large buffer."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8 << 20)
    sock.setsockopt(socket.SOL_SOCKET, _SO_TIMESTAMPNS, 1)
    sock.bind(("127.0.0.1", 0))
    sock.setblocking(False)
    return sock


@contextlib.contextmanager
def udp_hole() -> Iterator[socket.socket]:
    """A UDP socket in this process that nobody waits on: sending to it wakes no receiver.

    Yields the socket; the caller drops what arrives, between runs.
    """
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 24)
        sock.bind(("127.0.0.1", 0))
        sock.setblocking(False)
        yield sock
    finally:
        sock.close()


_ANC = socket.CMSG_SPACE(16)


def _drain(sock: socket.socket, into: list[tuple[int, bytes]]) -> None:
    while True:
        try:
            data, anc, _flags, _addr = sock.recvmsg(4096, _ANC)
        except (BlockingIOError, InterruptedError):
            return
        ts = 0
        for level, kind, payload in anc:
            if level == socket.SOL_SOCKET and kind == _SO_TIMESTAMPNS and len(payload) >= 16:
                sec, nsec = struct.unpack("qq", payload[:16])
                ts = sec * 1_000_000_000 + nsec
        into.append((ts or time.time_ns(), data))


def proc_cpu_seconds(pid: int) -> float | None:
    """User + system CPU seconds of a process, all its threads (Linux ``/proc``)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def proc_memory_kb(pid: int) -> dict[str, int]:
    """``VmRSS`` and ``VmHWM`` (peak resident set) of a process in kB (Linux ``/proc``)."""
    out: dict[str, int] = {}
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            key, _, value = line.partition(":")
            if key in ("VmRSS", "VmHWM"):
                out[key] = int(value.split()[0])
    except OSError:
        pass
    return out


@contextlib.contextmanager
def child_process(cmd: list[str], log_path: Path) -> Iterator[subprocess.Popen]:
    """Start ``cmd`` in its own process group; always stop it (SIGTERM, then SIGKILL) on the way out."""
    with open(log_path, "wb") as logf:
        proc = subprocess.Popen(
            cmd,
            cwd=REPO,
            stdin=subprocess.DEVNULL,
            stdout=logf,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
        try:
            yield proc
        finally:
            stop_process(proc)


def _last_words(log: Path, limit: int = 300) -> str:
    """The end of what a failed child printed (its log lives in a folder removed after the run)."""
    try:
        lines = [ln.strip() for ln in log.read_text(errors="replace").splitlines() if ln.strip()]
    except OSError:
        return ""
    return f"; it printed: {' | '.join(lines[-3:])[-limit:]}" if lines else "; it printed nothing"


def stop_process(proc: subprocess.Popen) -> None:
    """Terminate a child (and its process group) and reap it; kill it if it does not go within 3 s."""
    if proc.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(timeout=3.0)
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(timeout=3.0)


def pointat_command(
    patch: Path,
    overrides: list[str],
    seconds: float,
    realtime: bool = False,
    spin: float = 0.0,
    compiled: bool | None = None,
) -> list[str]:
    """``pointat run [--compiled on|off] [--rt] [--spin MS] PATCH --set ... --for SECONDS`` through this
    interpreter; ``compiled`` for a patch with glove chains: a row says which way they run (``auto``
    would fuse them whenever the compiled code is cached)."""
    cmd = [sys.executable, "-m", "pointat.cli", "run"]
    cmd += [] if compiled is None else ["--compiled", "on" if compiled else "off"]
    cmd += ["--rt"] if realtime else []
    cmd += [*(["--spin", f"{spin:g}"] if spin else []), str(patch)]
    for o in overrides:
        cmd += ["--set", o]
    return cmd + ["--for", f"{seconds:.0f}"]


def spin_for(rate: float) -> float:
    """The ``--spin`` the benchmark gives pointat at ``rate`` Hz: two sample periods, in ms (2 at 1 kHz),
    so that the scheduler is polling when the next sample comes."""
    return 2000.0 / rate


def _mode(realtime: bool, spin: float) -> tuple[str, str]:
    """A run's options as they show in its label (", --rt") and in its log's name ("_rt")."""
    if realtime:
        return ", --rt", "_rt"
    if spin:
        return f", --spin {spin:g}", "_spin"
    return "", ""


#: Real-time priority for the floors, as pointat's ``--rt`` asks for it (SCHED_FIFO 10).
CHRT = ["chrt", "-f", "10"]


def realtime_refused() -> str:
    """Why real-time priority cannot be had here ("" when it can): the --rt rows need it."""
    if not hasattr(os, "sched_setscheduler") or shutil.which("chrt") is None:
        return "no real-time scheduling (sched_setscheduler, chrt) on this system"
    if os.geteuid() != 0:
        return "real-time priority needs root (or an rtprio limit) here"
    return ""


def shown(cmd: list[str]) -> str:
    """A command as a person would type it (repo-relative paths, ``pointat`` for the CLI)."""
    parts = list(cmd)
    if parts[:3] == [sys.executable, "-m", "pointat.cli"]:
        parts = ["pointat", *parts[3:]]
    elif parts[:2] == [sys.executable, "-m"]:
        parts = ["python", "-m", *parts[2:]]
    out = []
    for p in parts:
        with contextlib.suppress(ValueError):
            p = str(Path(p).relative_to(REPO)) if p.startswith(str(REPO)) else p
        out.append(p if " " not in p else f'"{p}"')
    return " ".join(out)


# ------------------------------------------------------------------------------------------ patches
def mote_patch_text(chain: str, motes: int) -> str:
    """The text of ``benchmarks/patches/mote_CHAIN_N.pat``: one base station, N tagged gloves.

    ``chain`` is ``torre`` or ``tqt`` (a glove's whole chain a glove, ``glove_CHAIN.pat``) or
    ``tqt_bank`` (each glove's ``offset`` and ``scaling``, then one ``tqt_bank`` for all of them, then
    each glove's ``glove_bank.pat``: the tqt chain with the filter shared).

    >>> print(mote_patch_text("tqt", 1).splitlines()[-1])
    base.m1 -> g1.adc
    """
    what = {
        "torre": "the Pointing-at chain (glove_torre.pat)",
        "tqt": "the tqt chain (glove_tqt.pat)",
        "tqt_bank": "the tqt chain with one tqt_bank for all the gloves (glove_bank.pat after it)",
        "tqt_plain": "the tqt chain (glove_tqt.pat), untagged: what a glove-sample costs, nothing added",
    }[chain]
    plain = chain == "tqt_plain"
    ids = ", ".join(str(i) for i in range(1, motes + 1))
    lines = [
        f"# {'Cost' if plain else 'Latency'} benchmark: {motes} mote{'s' if motes > 1 else ''} on one base station"
        " (a pseudo-terminal that the",
        f"# benchmark writes real mote frames into), each through {what}.",
        "# Written by benchmarks.latency.mote_patch_text(); the benchmark sets base.device, base.rate and",
        "# every gN/out.port." + ("  No sample tag: the outputs are counted, not matched." if plain else ""),
    ]
    if not plain:
        lines += [
            "#",
            f"# Sample tag: the benchmark puts {_TAG_BASE} + (k mod {_TAG_PERIOD}) into the gyro x count of frame k;",
            "# tapN/tagN map it to 0..99.9 in osc_out's spread field, so each OSC message names its frame.",
        ]
    lines += ["", f"node base mote ids=[{ids}] rate=1000"]
    if chain == "tqt_bank":
        lines.append(f"node bank tqt_bank sensors={motes} rate=1000 mode=robust")
    for i in range(1, motes + 1):
        if not plain:
            lines += [f"node tap{i} unpack f", f"node tag{i} map {_TAG_BASE} {_TAG_BASE + _TAG_PERIOD} 0 100"]
        if chain == "tqt_bank":
            lines += [
                f"node nulls{i} offset samples=150 still=0",  # the tag rides in gyro x
                f"node units{i} scaling",
                f"node g{i}   glove_bank.pat id={i} port=9000",
            ]
        else:
            lines.append(f"node g{i}   glove_{chain.removesuffix('_plain')}.pat id={i} port=9000 rate=1000")
    lines.append("")
    for i in range(1, motes + 1):
        if not plain:
            lines.append(f"base.m{i} -> tap{i} -> tag{i} -> g{i}.spread")
        if chain == "tqt_bank":
            lines.append(f"base.m{i} -> nulls{i} -> units{i}")
            lines += [f"units{i}.{s} -> bank.{s}{i}" for s in ("mag", "accel", "gyro")]
            lines.append(f"bank.quat{i} -> g{i}.quat")
        else:
            lines.append(f"base.m{i} -> g{i}.adc")
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------------------------ inputs
class MoteSource:
    """Real mote frames into a pseudo-terminal; tick ``k`` is one frame per mote with tag ``k mod 1000``."""

    def __init__(self, rate: float, motes: int) -> None:
        sim = GloveSimulator(rate_hz=rate, seed=3)
        self._channels = [list(s.frame.channels) for s in sim.samples(_TAG_PERIOD)]
        self.ids = list(range(1, motes + 1))
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        os.set_blocking(self.master, False)
        self.device = os.ttyname(self.slave)
        self._pending = b""
        self.refused = 0

    def tick(self, k: int) -> int | None:
        """Write tick ``k``; return ``time.time_ns()`` just before the write, or None if refused."""
        ch = self._channels[k % _TAG_PERIOD]
        ch[0] = _TAG_BASE + k % _TAG_PERIOD
        n_pack = k & 0xFFFF
        data = b"".join(encode_frame(Frame(i, n_pack, tuple(ch))) for i in self.ids)
        if self._pending:  # the rest of a partial write first: frames must stay whole
            try:
                n = os.write(self.master, self._pending)
            except BlockingIOError:
                n = 0
            self._pending = self._pending[n:]
            if self._pending:
                self.refused += 1
                return None
        t = time.time_ns()
        try:
            n = os.write(self.master, data)
        except BlockingIOError:
            self.refused += 1
            return None
        self._pending = data[n:]
        return t

    def close(self) -> None:
        for fd in (self.master, self.slave):
            with contextlib.suppress(OSError):
                os.close(fd)


class UdpSource:
    """One OSC datagram per tick to 127.0.0.1:``port``: NGIMU ``/sensors`` from a BROAD recording.

    ``style="bundle"`` (pointat): ``[/tag k mod 1000, /sensors g a m]``; ``style="arg"`` (relays):
    ``/sensors g a m k``, the tick number as a tenth (int) argument.
    """

    def __init__(self, port: int, style: str, sample: dict[str, np.ndarray]) -> None:
        n = min(_TAG_PERIOD, len(sample["gyr"]))
        start = len(sample["gyr"]) // 3  # the middle of a trial: the hand is moving
        g = np.degrees(sample["gyr"][start : start + n])
        a = sample["acc"][start : start + n] / 9.80665
        m = sample["mag"][start : start + n]
        self._rows = [tuple(float(v) for v in (*g[i], *a[i], *m[i])) for i in range(n)]
        self._sensors = [osc_message("/sensors", "fffffffff", *r) for r in self._rows]
        self.style = style
        self.addr = ("127.0.0.1", port)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.refused = 0

    def tick(self, k: int) -> int | None:
        i = k % len(self._rows)
        if self.style == "bundle":
            data = osc_bundle(osc_message("/tag", "i", k % _TAG_PERIOD), self._sensors[i])
        else:
            data = osc_message("/sensors", "fffffffffi", *self._rows[i], k)
        t = time.time_ns()
        try:
            self.sock.sendto(data, self.addr)
        except OSError:
            self.refused += 1
            return None
        return t

    def close(self) -> None:
        self.sock.close()


# ------------------------------------------------------------------------------------------ driving
@dataclass
class Phases:
    """How long each phase of a run lasts, seconds."""

    measure: float
    warmup: float = 0.5
    start_timeout: float = 20.0
    drain: float = 2.0

    @property
    def lifetime(self) -> float:
        """How long a process under test may run (its ``--for``): every phase and 5 s of margin."""
        return self.start_timeout + self.warmup + self.measure + self.drain + 5


@dataclass
class Drive:
    """What :func:`drive` saw: send times (-1: refused), the measurement window, the outputs, the CPU use."""

    sends: list[int]
    k_start: int
    k_end: int
    rx: list[tuple[int, bytes]]
    cpu_fraction: float | None


def drive(
    tick: Callable[[int], int | None],
    rate: float,
    sock: socket.socket,
    phases: Phases,
    proc: subprocess.Popen,
) -> Drive:
    """Pace ``tick(k)`` at ``rate`` Hz and collect the output datagrams with their kernel time stamps.

    The CPU use of ``proc`` (all threads, fraction of one core) is measured over the measurement window.
    """
    period = 1.0 / rate
    sends: list[int] = []
    rx: list[tuple[int, bytes]] = []
    t0 = time.monotonic()
    next_t = t0
    state = "start"
    k_start = k_end = 0
    until = quiet = t0 + phases.start_timeout
    cpu0 = cpu1 = None
    w0 = w1 = 0.0
    while True:
        now = time.monotonic()
        if state == "start":
            if rx:
                state, until = "warm", now + phases.warmup
            elif now >= until or proc.poll() is not None:
                status = "exited" if proc.poll() is not None else "running"
                raise RuntimeError(f"no output within {phases.start_timeout:.0f} s (process {status})")
        if state == "warm" and now >= until:
            state, until, k_start = "measure", now + phases.measure, len(sends)
            cpu0, w0 = proc_cpu_seconds(proc.pid), now
        if state == "measure" and now >= until:
            state, k_end = "drain", len(sends)
            cpu1, w1 = proc_cpu_seconds(proc.pid), now
            until = now + phases.drain
            quiet = now
        if state == "drain":
            n = len(rx)
            r, _, _ = select.select([sock], [], [], max(0.0, min(until, quiet + 0.3) - now))
            if r:
                _drain(sock, rx)
            if len(rx) > n:
                quiet = time.monotonic()
            elif time.monotonic() >= min(until, quiet + 0.3):
                break
            continue
        if now >= next_t:
            t = tick(len(sends))
            sends.append(-1 if t is None else t)
            next_t += period
            if now - next_t > 0.05:  # the harness itself was held up: do not send a burst to catch up
                next_t = now + period
            continue
        r, _, _ = select.select([sock], [], [], next_t - now)
        if r:
            _drain(sock, rx)
    cpu = (cpu1 - cpu0) / (w1 - w0) if cpu0 is not None and cpu1 is not None and w1 > w0 else None
    return Drive(sends, k_start, k_end, rx, cpu)


def match(
    sends: list[int],
    k_start: int,
    k_end: int,
    rx: list[tuple[int, bytes]],
    key: Callable[[bytes], tuple[int, int]],
    period: int | None,
) -> tuple[dict[int, list[float]], int]:
    """Latencies (us) per source of the ticks in ``[k_start, k_end)``, and the number of duplicate matches.

    ``key(datagram)`` gives ``(source, tag)``.  With ``period=None`` the tag is the tick number.  Else it is
    the tick number modulo ``period``: a source's datagram belongs to the tick after the one its previous
    datagram belonged to (skipping refused ticks) when the tag agrees -- pointat loses nothing inside, so
    outputs come in input order -- and otherwise (the first output, after a loss) to the latest tick with
    that tag sent before it arrived.
    """
    times = np.array(sends, dtype=np.int64)
    mono = np.maximum.accumulate(np.where(times < 0, 0, times))  # refused ticks: not sent
    sent = np.flatnonzero(times >= 0)
    seen: dict[int, set[int]] = {}
    prev: dict[int, int] = {}
    out: dict[int, list[float]] = {}
    dups = 0
    for ts, data in rx:
        try:
            src, tag = key(data)
        except (ValueError, IndexError, struct.error):
            continue
        if period is None:
            j = tag
            if not 0 <= j < len(times) or times[j] < 0 or times[j] > ts:
                continue
        else:
            j = -1
            if src in prev:
                i = int(np.searchsorted(sent, prev[src], side="right"))
                if i < sent.size and sent[i] % period == tag and times[sent[i]] <= ts:
                    j = int(sent[i])
            if j < 0:
                last = bisect.bisect_right(mono, ts) - 1
                j = last - ((last - tag) % period)
                while j >= 0 and times[j] < 0:
                    j -= period
                if j < 0:
                    continue
        if j in seen.setdefault(src, set()):
            dups += 1
            continue
        seen[src].add(j)
        prev[src] = j
        if k_start <= j < k_end:
            out.setdefault(src, []).append((ts - times[j]) / 1000.0)
    return out, dups


def _pointat_key(data: bytes) -> tuple[int, int]:
    _address, args = parse_osc(data)
    return int(args[0]), int(round(float(args[1]) * 10.0)) % _TAG_PERIOD


def _floor_key(data: bytes) -> tuple[int, int]:
    _address, args = parse_osc(data)
    return 0, int(round(float(args[-1])))


# ------------------------------------------------------------------------------------------ runs
def _finish(
    res: LatencyResult,
    proc: subprocess.Popen,
    d: Drive,
    key: Callable[[bytes], tuple[int, int]],
    period: int | None,
    n_sources: int,
) -> None:
    per_src, res.duplicates = match(d.sends, d.k_start, d.k_end, d.rx, key, period)
    res.latencies_us = np.array([v for lst in per_src.values() for v in lst], dtype=float)
    res.cpu_fraction = d.cpu_fraction
    window = d.sends[d.k_start : d.k_end]
    sent = sum(1 for t in window if t >= 0)
    res.refused = len(window) - sent
    res.expected = sent * n_sources
    mem = proc_memory_kb(proc.pid)
    res.rss_peak_kb = mem.get("VmHWM")


def _measure(
    res: LatencyResult,
    cmd: list[str],
    log: Path,
    src: Any,
    sock: socket.socket,
    rate: float,
    phases: Phases,
    key: Callable[[bytes], tuple[int, int]],
    period: int | None,
    n_sources: int,
) -> LatencyResult:
    """Run ``cmd`` as a child, drive ``src`` at ``rate`` into it, fill ``res``; always close src and sock.

    A ``realtime`` row where real-time priority cannot be had is reported as failed, with the reason.
    """
    if res.realtime and realtime_refused():
        res.error = realtime_refused()
        src.close()
        sock.close()
        return res
    try:
        with child_process(cmd, log) as proc:
            _finish(res, proc, drive(src.tick, rate, sock, phases, proc), key, period, n_sources)
    except RuntimeError as exc:
        res.error = str(exc) + _last_words(log)
    finally:
        src.close()
        sock.close()
    return res


def run_pointat_mote(
    chain: str,
    rate: float,
    motes: int,
    phases: Phases,
    sample: dict[str, np.ndarray],
    workdir: Path,
    realtime: bool = False,
    spin: float = 0.0,
    compiled: bool = False,
) -> LatencyResult:
    """pointat's mote path: frames into a pty -> ``mote`` -> chain(s) -> ``osc_out`` -> our socket;
    ``compiled``: the chains fused (``pointat run --compiled on``)."""
    sock, src, overrides = _mote_rig(rate, motes)
    cmd = pointat_command(
        PATCHES / f"mote_{chain}_{motes}.pat", overrides, phases.lifetime, realtime, spin, compiled
    )
    shown_mode, log_mode = _mode(realtime, spin)
    if compiled:
        shown_mode, log_mode = f", compiled{shown_mode}", f"_compiled{log_mode}"
    label = f"pointat {chain} (mote, pty{shown_mode})"
    res = LatencyResult(
        label,
        "pointat-mote",
        chain,
        rate,
        motes,
        _shown_mote(cmd, motes),
        realtime=realtime,
        spin=spin,
        compiled=compiled,
    )
    log = workdir / f"mote_{chain}_{motes}_{rate:g}{log_mode}.log"
    return _measure(res, cmd, log, src, sock, rate, phases, _pointat_key, _TAG_PERIOD, motes)


@dataclass
class CostResult:
    """What a glove-sample costs the whole ``pointat run`` process: N untagged gloves at a rate, CPU time
    over the outputs counted at our socket, in rounds."""

    label: str
    motes: int
    rate: float
    compiled: bool
    command: str
    us: list[float] = field(default_factory=list)  # per round: CPU µs per glove-sample
    delivered: list[float] = field(default_factory=list)  # per round: outputs / inputs
    error: str = ""

    @property
    def median_us(self) -> float:
        return float(np.median(self.us)) if self.us else math.nan


def run_cost(motes: int, rate: float, seconds: float, workdir: Path, compiled: bool) -> tuple[float, float]:
    """One round of :class:`CostResult`: (CPU µs per glove-sample, outputs / inputs) over ``seconds``
    after a warm-up; the frames written on a deadline schedule, the outputs drained as they come."""
    sock, src, overrides = _mote_rig(rate, motes)
    cmd = pointat_command(
        PATCHES / f"mote_tqt_plain_{motes}.pat", overrides, seconds + 30.0, compiled=compiled
    )
    log_path = workdir / f"cost_{motes}_{'compiled' if compiled else 'nodes'}.log"
    got = 0

    def drain() -> int:
        n = 0
        while True:
            try:
                sock.recv(512)
                n += 1
            except BlockingIOError:
                return n

    try:
        with child_process(cmd, log_path) as proc:
            deadline = time.monotonic() + 20.0
            k = 0
            while time.monotonic() < deadline and not got:  # started: the first outputs are back
                src.tick(k)
                k += 1
                time.sleep(1.0 / rate)
                got = drain()
                if proc.poll() is not None:
                    raise RuntimeError(f"pointat exited: {_last_words(log_path)}")
            t0 = time.monotonic()
            for j in range(int(rate)):  # a second of warm-up
                src.tick(k)
                k += 1
                _sleep_until(t0 + (j + 1) / rate)
                drain()
            cpu0, t0, got, sent = proc_cpu_seconds(proc.pid), time.monotonic(), 0, 0
            for j in range(int(seconds * rate)):
                if src.tick(k) is not None:
                    sent += 1
                k += 1
                _sleep_until(t0 + (j + 1) / rate)
                got += drain()
            time.sleep(0.2)
            got += drain()
            cpu1 = proc_cpu_seconds(proc.pid)
    finally:
        sock.close()
        src.close()
    if cpu0 is None or cpu1 is None or not got:
        raise RuntimeError("no CPU time or nothing out")
    # per output: a process that falls behind (frames refused by the full pty) is not flattered
    return (cpu1 - cpu0) * 1e6 / got, got / (sent * motes)


def costs(
    rate: float, seconds: float, rounds: int, progress: Callable[[str], None], workdir: Path | None = None
) -> list[CostResult]:
    """:func:`run_cost` for 16 and 64 untagged gloves, compiled and node by node, in alternating rounds."""
    workdir = workdir or Path(tempfile.mkdtemp(prefix="pointat-cost-"))
    plan = [(motes, compiled) for motes in (16, 64) for compiled in (True, False)]
    out = {
        key: CostResult(
            f"pointat tqt mote x{key[0]}" + (", compiled" if key[1] else ""),
            key[0],
            rate,
            key[1],
            shown(pointat_command(PATCHES / f"mote_tqt_plain_{key[0]}.pat", [], seconds, compiled=key[1])),
        )
        for key in plan
    }
    for k in range(rounds):
        for key in plan:
            progress(f"cost {rate:g} Hz, round {k + 1}/{rounds}: {out[key].label}")
            try:
                us, delivered = run_cost(key[0], rate, seconds, workdir, key[1])
            except (RuntimeError, OSError) as exc:
                out[key].error = str(exc)
                continue
            out[key].us.append(us)
            out[key].delivered.append(delivered)
            progress(f"  {us:.1f} us a glove-sample, {delivered:.3f} of the inputs out")
    return list(out.values())


def _sleep_until(when: float) -> None:
    left = when - time.monotonic()
    if left > 0:
        time.sleep(left)


def _mote_rig(rate: float, motes: int) -> tuple[socket.socket, MoteSource, list[str]]:
    """Our receiving socket, the pty the frames go into, and the ``--set``s that connect a mote patch
    to them."""
    sock = receiver_socket()
    src = MoteSource(rate, motes)
    port = sock.getsockname()[1]
    overrides = [f"base.device={src.device}", f"base.rate={rate:g}"]
    return sock, src, overrides + [f"g{i}/out.port={port}" for i in range(1, motes + 1)]


def _shown_mote(cmd: list[str], motes: int) -> str:
    text = shown(cmd)
    if motes > 2:  # g1/out.port ... g16/out.port: abbreviate
        text, _, tail = text.rpartition(" --for ")
        parts = text.split(" --set ")
        keep = [p for p in parts if "/out.port=" not in p]
        port = next(p for p in parts if "/out.port=" in p).split("=")[1]
        text = " --set ".join([*keep, f"gN/out.port={port}"]) + f" --for {tail}  # N = 1..{motes}"
    return (
        text.replace(text.split("base.device=")[1].split()[0], "/dev/pts/N")
        if "base.device=" in text
        else text
    )


def run_pointat_udp(
    chain: str,
    rate: float,
    phases: Phases,
    sample: dict[str, np.ndarray],
    workdir: Path,
    realtime: bool = False,
    spin: float = 0.0,
) -> LatencyResult:
    """pointat's UDP path: one OSC bundle per sample -> ``osc_in`` -> fusion -> ``osc_out`` -> our socket."""
    patch = PATCHES / f"oscin_{chain}.pat"
    sock = receiver_socket()
    in_port = free_udp_port()
    src = UdpSource(in_port, "bundle", sample)
    overrides = [f"src.port={in_port}", f"out.port={sock.getsockname()[1]}"]
    cmd = pointat_command(patch, overrides, phases.lifetime, realtime, spin)
    shown_mode, log_mode = _mode(realtime, spin)
    label = f"pointat {chain} (osc_in, UDP{shown_mode})"
    res = LatencyResult(label, "pointat-udp", chain, rate, 1, shown(cmd), realtime=realtime, spin=spin)
    log = workdir / f"oscin_{chain}_{rate:g}{log_mode}.log"
    return _measure(res, cmd, log, src, sock, rate, phases, _pointat_key, _TAG_PERIOD, 1)


def pd_version() -> str | None:
    """``Pd-0.53.1`` or None when Pure Data is not installed."""
    pd = shutil.which("pd")
    if pd is None:
        return None
    try:
        done = subprocess.run([pd, "-version"], capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.TimeoutExpired):
        return None
    words = (done.stdout + done.stderr).split()
    return words[0] if words else "pd"


def run_floor(
    kind: str,
    rate: float,
    phases: Phases,
    sample: dict[str, np.ndarray],
    workdir: Path,
    realtime: bool = False,
    busy_us: float = 0.0,
    poll: float = 0.0,
) -> LatencyResult:
    """A transport floor: ``python-osc`` relay, ``pd`` (default flags) or ``pd-sg0.1`` (-sleepgrain 0.1).

    ``realtime`` runs the python-osc relay under ``chrt -f 10`` (Pd takes real-time priority itself) with
    the CPUs kept out of deep idle states while it is measured, as ``pointat run --rt`` keeps them.
    ``busy_us`` makes the python-osc relay spin that long on each message before it sends (its chain is
    then ``python-osc+Nus``): what a chain of that cost adds to the floor.  ``poll`` (ms) makes the
    python-osc relay poll its socket for that long after each input instead of sleeping in ``select``, as
    ``pointat run --spin`` does: the floor the ``--spin`` rows are set against (its ``spin`` is ``poll``).
    """
    sock = receiver_socket()
    in_port = free_udp_port()
    out_port = sock.getsockname()[1]
    src = UdpSource(in_port, "arg", sample)
    total = phases.lifetime
    if kind == "python-osc":
        cmd = [
            sys.executable,
            "-m",
            "benchmarks.relay",
            "--in-port",
            str(in_port),
            "--out-port",
            str(out_port),
        ]
        cmd += ["--for", f"{total:.0f}"]
        label = "python-osc relay"
        if busy_us:
            cmd += ["--busy-us", f"{busy_us:g}"]
            label += f", +{busy_us:g} µs of work a message"
        if poll:
            cmd += ["--poll", f"{poll:g}"]
            label += f", polling (--poll {poll:g})"
        if realtime:
            cmd = [*CHRT, *cmd]
            label += " (chrt -f 10)"
    else:
        text = (PATCHES / "relay.pd").read_text()
        text = text.replace("IN_PORT", str(in_port)).replace("OUT_PORT", str(out_port))
        text = text.replace("MAX_MS", str(int(total * 1000)))
        pd_patch = workdir / f"relay_{in_port}.pd"
        pd_patch.write_text(text)
        cmd = ["pd", "-nogui", "-noaudio", "-noprefs"]
        if kind == "pd-sg0.1":
            cmd += ["-sleepgrain", "0.1"]
        cmd += ["-open", str(pd_patch)]
        label = "Pd relay" + (" -sleepgrain 0.1" if kind == "pd-sg0.1" else " (default flags)")
    shown_cmd = shown(cmd).replace(str(workdir / f"relay_{in_port}.pd"), "benchmarks/patches/relay.pd")
    chain = f"{kind}+{busy_us:g}us" if busy_us else kind
    res = LatencyResult(label, "floor", chain, rate, 1, shown_cmd, realtime=realtime, spin=poll)
    if kind != "python-osc" and shutil.which("pd") is None:
        src.close()
        sock.close()
        res.error = "Pure Data (pd) is not installed"
        return res
    # as pointat run --rt does for itself; where it cannot be had, neither run has it
    awake, _why = keep_cpus_awake() if realtime else (None, None)
    try:
        log = workdir / f"{kind}_{rate:g}{'_poll' if poll else ''}.log"
        return _measure(res, cmd, log, src, sock, rate, phases, _floor_key, None, 1)
    finally:
        if awake is not None:
            os.close(awake)


def run_floor_pty(
    rate: float, phases: Phases, sample: dict[str, np.ndarray], workdir: Path, poll: float = 0.0
) -> LatencyResult:
    """The mote path's floor: the same frames into a pty, a bare Python process (pointat's frame parser,
    python-osc's client) sending one datagram per frame to our socket; polling for ``poll`` ms after each
    input, as ``--spin`` does, when ``poll`` is given."""
    sock = receiver_socket()
    src = MoteSource(rate, 1)
    cmd = [sys.executable, "-m", "benchmarks.relay", "--pty", src.device]
    cmd += ["--out-port", str(sock.getsockname()[1]), "--for", f"{phases.lifetime:.0f}"]
    label = "python pty relay"
    if poll:
        cmd += ["--poll", f"{poll:g}"]
        label += f", polling (--poll {poll:g})"
    shown_cmd = shown(cmd).replace(src.device, "/dev/pts/N")
    res = LatencyResult(label, "floor", "pty", rate, 1, shown_cmd, spin=poll)
    log = workdir / f"pty_{rate:g}{'_poll' if poll else ''}.log"
    return _measure(res, cmd, log, src, sock, rate, phases, _pointat_key, _TAG_PERIOD, 1)


class _Idle(Node):
    """A node that only keeps a runtime alive (``active``) while :func:`handoff` posts to it."""

    type_name = "idle"

    def start(self) -> None:
        self.active = True


def handoff(rate: float, seconds: float) -> np.ndarray:
    """The engine's hand-off alone: a thread calls ``Runtime.post`` at ``rate`` Hz; microseconds until
    the scheduler thread runs the call (the step a source in a thread of its own -- ``replay``,
    ``midi_in`` -- takes; ``mote`` and ``osc_in`` are read on the scheduler thread and skip it).
    """
    rt = Runtime(realtime=True)
    node = rt.add(_Idle("idle"))
    delays: list[float] = []

    def handle(t_ns: int) -> None:
        delays.append((time.perf_counter_ns() - t_ns) / 1000.0)

    def feed() -> None:
        period = 1.0 / rate
        next_t = time.perf_counter() + 0.2
        end = next_t + seconds
        while next_t < end and not rt.stopping.is_set():
            wait = next_t - time.perf_counter()
            if wait > 0:
                time.sleep(wait)
            rt.post(node, handle, time.perf_counter_ns())
            next_t += period
        rt.stop()

    th = threading.Thread(target=feed, name="bench-handoff", daemon=True)
    th.start()
    rt.run(seconds + 5.0)
    th.join(2.0)
    return np.array(delays[10:], dtype=float)


class _Lateness(Node):
    """Records how late each message arrives: the scheduler's clock now minus the message's time (a
    ``metro`` tick carries the time it was due)."""

    type_name = "lateness"
    inlets = (Inlet("in", ("bang",), "a timer's output"),)

    def setup(self) -> None:
        self.late_us: list[float] = []

    def on_in(self, msg: Any) -> None:
        self.late_us.append((self.rt.clock.now() - msg.time) * 1e6)  # type: ignore[union-attr]


def _metro_lateness(rate: float, seconds: float) -> np.ndarray:
    """A ``metro`` at ``rate`` Hz on the real-time runtime, ``seconds`` long: µs each tick ran after it
    was due (the first ticks left out)."""
    from pointat.nodes.control import Loadbang, Metro

    rt = Runtime(realtime=True)
    start = rt.add(Loadbang("lb"))
    metro = rt.add(Metro("m", {"interval": 1000.0 / rate}))
    probe = rt.add(_Lateness("probe"))
    rt.connect(start, 0, metro, 0)
    rt.connect(metro, 0, probe, 0)
    rt.run(seconds)
    return np.array(probe.late_us[10:], dtype=float)


def _sleep_lateness(rate: float, seconds: float) -> np.ndarray:
    """The floor: a bare Python loop that sleeps (``time.sleep``) until each deadline of a ``rate`` Hz
    schedule; µs it woke after it (the first ticks left out)."""
    period = 1.0 / rate
    start = time.monotonic()
    late = []
    for k in range(1, int(seconds * rate)):
        due = start + k * period
        wait = due - time.monotonic()
        if wait > 0.0:
            time.sleep(wait)
        late.append((time.monotonic() - due) * 1e6)
    return np.array(late[10:], dtype=float)


def timers(rate: float, seconds: float, rounds: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """How late the runtime's timers run: a ``metro`` at ``rate`` Hz against a bare Python loop sleeping
    until the same deadlines, ``rounds`` times in turn (``seconds`` each in all).  Returns (metro,
    sleep) lateness in µs."""
    metro, floor = [], []
    for _ in range(rounds):
        floor.append(_sleep_lateness(rate, seconds / rounds))
        metro.append(_metro_lateness(rate, seconds / rounds))
    return np.concatenate(metro), np.concatenate(floor)


@dataclass
class CallCount:
    """How much Python one sample runs on the osc_in path, from the datagram's arrival to the one sent."""

    path: str  # "python-osc" (the relay), "relay" (pointat's, no filter), "torre", "tqt"
    calls: float  # Python function calls per sample (C functions not counted)
    distinct: int  # different Python functions among them
    #: machine instructions per sample, counted by callgrind (:func:`instructions_per_sample`); None
    #: where valgrind is not installed or the count failed
    instructions: float | None = None


#: The osc_in paths whose work per sample is counted, the python-osc relay first (the others' reference).
OSC_PATHS = ("python-osc", "relay", "torre", "tqt")


@contextlib.contextmanager
def osc_path(path: str, sample: dict[str, np.ndarray], out_port: int) -> Iterator[tuple[UdpSource, Callable]]:
    """One osc_in path in this process: yields its input (a :class:`UdpSource`) and ``step()``, which
    reads one datagram and runs it through (select, receive, parse, the chain, encode, send to
    ``out_port``).  ``path`` is one of :data:`OSC_PATHS`; "python-osc" is the floor's own code
    (:func:`benchmarks.relay.osc_relay`), the others pointat's ``oscin_PATH.pat``."""
    from pointat.loader import load

    from .relay import osc_relay

    in_port = free_udp_port()
    if path == "python-osc":
        server = osc_relay(in_port, out_port)
        src, step, done = UdpSource(in_port, "arg", sample), server.handle_request, server.server_close
    else:
        rt = load(PATCHES / f"oscin_{path}.pat", overrides=[f"src.port={in_port}", f"out.port={out_port}"])
        rt.console = lambda line: None
        rt.start()
        src, step, done = UdpSource(in_port, "bundle", sample), partial(rt.drain, 1.0), rt.shutdown
    try:
        yield src, step
    finally:
        done()
        src.close()


def python_calls(sample: dict[str, np.ndarray], samples: int = 50, warmup: int = 200) -> list[CallCount]:
    """Count, with :func:`sys.setprofile`, the Python function calls a sample makes through the
    python-osc relay and through pointat's ``oscin_*.pat`` patches (:func:`osc_path`), in this process.
    """
    counts = []
    with udp_hole() as hole:
        for path in OSC_PATHS:
            seen: dict[Any, int] = {}

            def profile(frame: Any, event: str, arg: Any, seen: dict[Any, int] = seen) -> None:
                if event == "call":
                    seen[frame.f_code] = seen.get(frame.f_code, 0) + 1

            with osc_path(path, sample, hole.getsockname()[1]) as (src, step):
                for k in range(warmup + samples):
                    src.tick(k)
                    time.sleep(0.0005)  # arrived: the step below reads it without waiting
                    if k >= warmup:
                        sys.setprofile(profile)
                    try:
                        step()
                    finally:
                        sys.setprofile(None)
                    if k % 50 == 0:
                        _drain(hole, [])
            counts.append(CallCount(path, sum(seen.values()) / samples, len(seen)))
    return counts


def run_osc_path(path: str, trial: str | Path, samples: int) -> None:
    """``samples`` samples through one osc_in path (or, for ``path="none"``, only sent: the driver's own
    work), as fast as they are read; what :func:`instructions_per_sample` counts.

    The samples run inside :func:`sys.call_tracing` (with no tracer set, a plain call), a C function
    that nothing else calls: callgrind counts only inside it (``--toggle-collect``), so the process's
    start-up, which varies from run to run, is not counted at all.
    """
    from pointat.maths.evaluation import load_broad

    sample = load_broad(trial)
    with udp_hole() as hole:
        if path == "none":
            src = UdpSource(free_udp_port(), "bundle", sample)
            with contextlib.closing(src):
                sys.call_tracing(_send_and_step, (src, None, hole, samples))
            return
        with osc_path(path, sample, hole.getsockname()[1]) as (src, step):
            sys.call_tracing(_send_and_step, (src, step, hole, samples))


def _send_and_step(src: UdpSource, step: Callable | None, hole: socket.socket, samples: int) -> None:
    """Send ``samples`` samples, each read and run through by ``step()``; with no ``step``, only sent."""
    for k in range(samples):
        src.tick(k)
        time.sleep(0.0005)
        if step is not None:
            step()
            if k % 50 == 0:
                _drain(hole, [])


def _callgrind_total(path: str, trial: str | Path, samples: int) -> int:
    """Instructions callgrind counts for a whole ``python -m benchmarks.work PATH TRIAL SAMPLES``."""
    cmd = ["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null", "--collect-atstart=no"]
    cmd += ["--toggle-collect=sys_call_tracing", sys.executable]
    cmd += ["-m", "benchmarks.work", path, str(trial), str(samples)]
    env = {**os.environ, "PYTHONHASHSEED": "0"}
    done = subprocess.run(cmd, cwd=REPO, env=env, capture_output=True, text=True, timeout=900)
    for line in done.stderr.splitlines():
        if "Collected :" in line:
            return int(line.split("Collected :")[1].split()[0])
    raise RuntimeError(
        f"callgrind printed no total for {path} (exit {done.returncode}): {done.stderr[-300:]}"
    )


def instructions_per_sample(
    trial: str | Path, paths: tuple[str, ...] = OSC_PATHS, samples: int = 1000, warmup: int = 300
) -> dict[str, float] | None:
    """Machine instructions per sample on each osc_in path, counted by ``valgrind --tool=callgrind``:
    unlike a time, the same on a busy machine as on an idle one.

    Each path runs twice, ``warmup`` samples and ``warmup + samples``; the difference over ``samples``
    is the steady cost of one sample, start-up and the filters' first samples left out.  The driver's
    own part (building and sending the datagram, the pacing sleep) is counted the same way with no
    receiver (path "none") and taken out.  User-space instructions only: the system calls' kernel work
    is not in it.  None when valgrind is not installed.
    """
    if shutil.which("valgrind") is None:
        return None
    jobs = [(p, n) for p in ("none", *paths) for n in (warmup, warmup + samples)]
    with ThreadPoolExecutor(max_workers=max(1, min(2, os.cpu_count() or 1))) as pool:
        counts = pool.map(lambda job: _callgrind_total(job[0], trial, job[1]), jobs)
        totals = dict(zip(jobs, counts, strict=True))
    per = {p: (totals[(p, warmup + samples)] - totals[(p, warmup)]) / samples for p in ("none", *paths)}
    return {p: per[p] - per["none"] for p in paths}


def pool(runs: list[LatencyResult]) -> LatencyResult:
    """One configuration's rounds as one result: the samples together, the counts summed, each round's
    p50 and p99 kept (``None`` for a round that failed or matched nothing: it adds nothing else).  When
    every round failed, the result is failed, with every round's error."""
    for r in runs:
        if not r.error and not r.received:
            r.error = "no output matched an input"
    good = [r for r in runs if not r.error]
    failed = [f"round {i + 1}: {r.error}" for i, r in enumerate(runs) if r.error]
    if not good:
        return replace(runs[0], error="; ".join(failed) if len(runs) > 1 else runs[0].error)
    if failed:
        log.warning("%s: %s", runs[0].label, "; ".join(failed))
    cpu = [r.cpu_fraction for r in good if r.cpu_fraction is not None]
    rss = [r.rss_peak_kb for r in good if r.rss_peak_kb is not None]
    return replace(
        good[0],
        latencies_us=np.concatenate([r.latencies_us for r in good]),
        expected=sum(r.expected for r in good),
        refused=sum(r.refused for r in good),
        duplicates=sum(r.duplicates for r in good),
        cpu_fraction=float(np.mean(cpu)) if cpu else None,
        rss_peak_kb=max(rss) if rss else None,
        rounds=[None if r.error else (r.p50, r.p99) for r in runs],
    )


#: Busy work (µs a message) the python-osc relay is also measured with at 1 kHz (:func:`run_all`).
BUSY_US = (20, 40)


def run_all(
    rates: tuple[float, ...],
    phases_for: Callable[[float], Phases],
    sample: dict[str, np.ndarray],
    progress: Callable[[str], None],
    rounds: int = 3,
) -> list[LatencyResult]:
    """Every latency configuration, floors next to the pointat runs they are compared with, in ``rounds``
    rounds that share each configuration's measuring time (``phases_for(rate).measure`` in all)."""
    results: list[LatencyResult] = []
    with tempfile.TemporaryDirectory(prefix="pointat-bench-") as tmp:
        workdir = Path(tmp)
        for rate in rates:
            whole = phases_for(rate)
            ph = replace(whole, measure=whole.measure / rounds)
            plan: list[tuple[str, Callable[[], LatencyResult]]] = [
                ("python-osc relay", partial(run_floor, "python-osc", rate, ph, sample, workdir)),
                # what the 1.2 x goal asks: the same relay with a chain's worth of plain busy work
                *(
                    (
                        f"python-osc relay +{us} us",
                        partial(run_floor, "python-osc", rate, ph, sample, workdir, busy_us=us),
                    )
                    for us in (BUSY_US if rate >= 500 else ())
                ),
                ("pointat relay osc_in", partial(run_pointat_udp, "relay", rate, ph, sample, workdir)),
                ("pointat torre osc_in", partial(run_pointat_udp, "torre", rate, ph, sample, workdir)),
                ("pointat tqt osc_in", partial(run_pointat_udp, "tqt", rate, ph, sample, workdir)),
                ("Pd relay", partial(run_floor, "pd", rate, ph, sample, workdir)),
                ("Pd relay -sleepgrain 0.1", partial(run_floor, "pd-sg0.1", rate, ph, sample, workdir)),
            ]
            plan.append(("python pty relay", partial(run_floor_pty, rate, ph, sample, workdir)))
            plan.append(
                ("pointat relay mote x1", partial(run_pointat_mote, "relay", rate, 1, ph, sample, workdir))
            )
            # at real-time priority, as Pd runs by default when it may (pointat --rt, the relay under chrt)
            plan.append(
                (
                    "python-osc relay, real-time",
                    partial(run_floor, "python-osc", rate, ph, sample, workdir, True),
                )
            )
            # pointat --rt beside it; then polling instead of sleeping (--spin), at normal priority, against
            # the same relays polling the same way (polling against polling)
            for option, how in (("--rt", {"realtime": True}), ("--spin", {"spin": spin_for(rate)})):
                if option == "--spin":
                    poll = spin_for(rate)
                    plan.append(
                        (
                            "python-osc relay, polling",
                            partial(run_floor, "python-osc", rate, ph, sample, workdir, poll=poll),
                        )
                    )
                    plan.append(
                        ("python pty relay, polling", partial(run_floor_pty, rate, ph, sample, workdir, poll))
                    )
                for chain in ("torre", "tqt"):
                    plan.append(
                        (
                            f"pointat {chain} osc_in {option}",
                            partial(run_pointat_udp, chain, rate, ph, sample, workdir, **how),
                        )
                    )
                    plan.append(
                        (
                            f"pointat {chain} mote x1 {option}",
                            partial(run_pointat_mote, chain, rate, 1, ph, sample, workdir, **how),
                        )
                    )
            for motes in (1, 16):
                for chain in ("torre", "tqt"):
                    plan.append(
                        (
                            f"pointat {chain} mote x{motes}",
                            partial(run_pointat_mote, chain, rate, motes, ph, sample, workdir),
                        )
                    )
            # the same 16 gloves with one tqt_bank for all of them (a body suit's way)
            plan.append(
                (
                    "pointat tqt_bank mote x16",
                    partial(run_pointat_mote, "tqt_bank", rate, 16, ph, sample, workdir),
                )
            )
            # many performers, at 1 kHz: the tqt chains compiled (pointat.compiled), 1, 16 and 64 gloves on
            # one base station, one glove polling, and 64 node by node (more than one core's work)
            if rate >= 1000:
                for motes in (1, 16, 64):
                    plan.append(
                        (
                            f"pointat tqt mote x{motes} compiled",
                            partial(run_pointat_mote, "tqt", rate, motes, ph, sample, workdir, compiled=True),
                        )
                    )
                polling = partial(
                    run_pointat_mote, "tqt", rate, 1, ph, sample, workdir, spin=spin_for(rate), compiled=True
                )
                plan.append(("pointat tqt mote x1 compiled --spin", polling))
                plan.append(
                    ("pointat tqt mote x64", partial(run_pointat_mote, "tqt", rate, 64, ph, sample, workdir))
                )
            runs: dict[str, list[LatencyResult]] = {name: [] for name, _ in plan}
            for k in range(rounds):
                for name, fn in plan:
                    progress(f"latency {rate:g} Hz, round {k + 1}/{rounds}: {name}")
                    r = fn()
                    if r.error:
                        progress(f"  FAILED: {r.error}")
                    else:
                        progress(
                            f"  p50 {r.p50:.0f} us, p99 {r.p99:.0f} us, max {r.max:.0f} us, "
                            f"{r.received}/{r.expected} received"
                        )
                    runs[name].append(r)
            results += [pool(rs) for rs in runs.values()]
    return results
