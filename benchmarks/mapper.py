"""What the libmapper bus costs (``python -m benchmarks.mapper``; ``--minutes 10`` for the long soak).

Whole ``pointat run`` processes on this machine's loopback bus (``--mapper lo``), a plain libmapper
client in this process (the library's Python binding):

* **Map creation to first value**: a patch publishes a glove's azimuth at 100 Hz; the client asks for a
  map from it to a signal of its own and times the first value to arrive, the map released between
  rounds.
* **Added latency against direct OSC**, side by side on the same samples: the benchmark sends a value
  over OSC into a patch (``osc_in`` -> ``route`` -> ``osc_out``), which sends it on twice, as OSC to a
  UDP socket here and on the bus through the ``mapper`` node to the client's signal.  Each value's
  time from the send to each arrival; the added latency is the bus's arrival minus OSC's, sample by
  sample (both leave when the scheduler's pass ends).
* **From the bus to a live parameter**: the client sets a signal of its own mapped to a patch's live
  parameter (a ``metro``'s ``interval``, eight in turn, each at most once a second); each value's time
  until the patch's console tells it set, read from its standard output (the bus, the ``mapper``
  node's poll every 5 ms of the scheduler's clock, live control, then the console's writer thread and
  the pipe: a little more than the parameter's own wait).
* **16 devices on one bus**: sixteen such patches, each fed 100 values a second, every one of their
  azimuths mapped to the client for ``--minutes`` (default 1; the issue's figure is 10): values lost
  (sent into the patch, never out of the bus), where they were lost (each UDP socket's own count of
  datagrams dropped for a full receive buffer, ``/proc/net/udp``, the client's sockets and the
  patches'), and each process's resident memory from the first minute on, growth per minute.  The
  client takes 1,600 values a second on one socket; ``--rcvbuf`` gives it a bigger receive buffer.

Medians with their range over rounds; the machine is shared (2 cores), so the figures compare the two
paths within one run, not runs with each other.
"""

from __future__ import annotations

import argparse
import os
import re
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from pointat.devices.osc_wire import decode_packet, encode_message

POINTAT = Path(sys.executable).with_name("pointat")

PATCH = """\
# a value in over OSC (/az V), out as a pointer's azimuth: over OSC and on the bus
node in    osc_in port={port} control=false
node r     route /az
node out   osc_out profile=pointat port={out}
in.any -> r
r.out0 -> out.azimuth
"""


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Client:
    """A plain libmapper device on ``lo`` with one incoming signal per source mapped to it; a thread
    polls it and stamps each value as it comes (``time.perf_counter``)."""

    def __init__(self, devices: int = 1, rcvbuf: int = 0) -> None:
        import libmapper as mpr

        self.mpr = mpr
        before = socket_inodes(os.getpid())
        self.graph = mpr.Graph(mpr.Type.DEVICE | mpr.Type.SIGNAL)
        self.graph.set_interface("lo")
        self.devs = [mpr.Device("bench", self.graph) for _ in range(devices)]
        self.dev = self.devs[0]
        #: The receive buffer of libmapper's sockets here (``rcvbuf`` bytes asked; 0: the system's default).
        self.rcvbuf = _enlarge(socket_inodes(os.getpid()) - before, rcvbuf)
        self.got: dict[str, list[tuple[float, float]]] = {}
        self.lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    @property
    def ready(self) -> bool:
        return all(d.ready for d in self.devs)

    def incoming(self, name: str, k: int = 0) -> object:
        """A signal of the ``k``-th device (modulo their number) whose values are kept in ``got[name]``."""
        mpr = self.mpr
        box = self.got.setdefault(name, [])

        def take(_sig, _event, _inst, value, _time):
            box.append((time.perf_counter(), value))

        return self.devs[k % len(self.devs)].add_signal(
            mpr.Signal.Direction.INCOMING,
            name,
            1,
            mpr.Type.FLOAT,
            None,
            None,
            None,
            None,
            take,
            mpr.Object.Event.REMOTE_UPDATE,
        )

    def outgoing(self, name: str) -> object:
        """A signal of the first device that this process sets (no range: a map passes it unchanged)."""
        mpr = self.mpr
        return self.dev.add_signal(mpr.Signal.Direction.OUTGOING, name, 1, mpr.Type.FLOAT)

    def find(self, device: str, signal: str) -> object | None:
        prop = self.mpr.Property.NAME
        for sig in list(self.graph.signals()):
            if sig[prop] == signal and str(sig.device()[prop]).rpartition(".")[0] == device:
                return sig
        return None

    def source(self, device: str, signal: str, seconds: float = 60.0) -> object:
        """A signal of another device on the bus, once this device is ready and the graph knows it."""
        box: list = []

        def there() -> bool:
            if not box:
                box.extend(filter(None, [self.find(device, signal)]))
            return self.ready and bool(box)

        self.poll_until(there, seconds, f"{device}/{signal} on the bus")
        return box[0]

    def poll_until(self, condition: Callable[[], bool], seconds: float, what: str) -> None:
        deadline = time.monotonic() + seconds
        while not condition():
            if time.monotonic() > deadline:
                raise RuntimeError(f"not within {seconds:g} s: {what}")
            with self.lock:
                for d in self.devs:
                    d.poll(5 if len(self.devs) == 1 else 0)
            if len(self.devs) > 1:
                time.sleep(0.001)

    def start(self) -> None:
        def run() -> None:
            one = len(self.devs) == 1
            while not self._stop.is_set():
                with self.lock:
                    for d in self.devs:
                        d.poll(1 if one else 0)
                if not one:
                    time.sleep(0.0005)

        self._thread = threading.Thread(target=run, daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
        # What is still on its way (a busy client's backlog) is taken before the devices go: freeing a
        # device with values waiting crashed libmapper 2.6.1's binding (a signal's callback called as
        # its signal was freed).
        quiet, seen = 0, -1
        while quiet < 3:
            for d in self.devs:
                d.poll(20)
            now = sum(len(b) for b in self.got.values())
            quiet, seen = (quiet + 1, seen) if now == seen else (0, now)
        for d in self.devs:
            d.free()
        self.graph.free()


class Patch:
    """``pointat run`` of :data:`PATCH` on the loopback bus, as device NAME."""

    def __init__(self, folder: Path, name: str, out_port: int, seconds: float):
        self.port = _free_port()
        path = folder / f"{name}.pat"
        path.write_text(PATCH.format(port=self.port, out=out_port))
        self.log = folder / f"{name}.log"
        with self.log.open("w") as out:
            self.proc = subprocess.Popen(
                [str(POINTAT), "run", str(path), "--mapper", "lo", "--mapper-name", name, "--status", "0"]
                + ["--for", str(seconds)],
                stdout=out,
                stderr=subprocess.STDOUT,
                cwd=folder,
            )
        self.name = name

    def published(self) -> int | None:
        """The values the patch set on the bus, as its summary says at the end (after :meth:`stop`)."""
        found = re.findall(r"mapper: .*\bsent: (\d+)", self.log.read_text())
        return int(found[-1]) if found else None

    def rss_kb(self) -> int:
        for line in Path(f"/proc/{self.proc.pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
        return 0

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


def _value(k: int) -> float:
    """The k-th value sent: distinct within 4800 in a row (48 s at 100 Hz), within the azimuth's range,
    exact in float32 (so that it is found again as it arrives)."""
    return (k % 4800) * 0.0625 - 150.0


def _map(client: Client, src: object, dst: object) -> object:
    m = client.mpr.Map(src, dst)
    m.push()
    return m


def map_to_first_value(folder: Path, rounds: int, progress: Callable[[str], None]) -> list[float]:
    """Seconds from asking for a map to its first value, each round a new map."""
    sink = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.bind(("127.0.0.1", 0))
    patch = Patch(folder, "bench_first", sink.getsockname()[1], 3600)
    client = Client()
    times = []
    try:
        sig = client.incoming("first")
        src = client.source("bench_first", "out/azimuth")
        feeder = _Feeder([patch.port], 100.0)
        feeder.start()
        try:
            box = client.got["first"]
            for r in range(rounds):
                box.clear()
                asked = time.perf_counter()
                m = _map(client, src, sig)
                client.poll_until(lambda: bool(box), 30, "the first value")
                times.append(box[0][0] - asked)
                m.release()
                client.poll_until(lambda: not list(sig.maps()), 30, "the map released")
                for _ in range(20):  # (values already in flight when the map went)
                    client.dev.poll(5)
                progress(f"  map to first value, round {r + 1}: {times[-1] * 1000:.1f} ms")
        finally:
            feeder.stop()
    finally:
        patch.stop()
        client.stop()
        sink.close()
    return times


class _Feeder:
    """Sends ``/az V`` to each port at ``rate`` Hz from a thread; remembers when each value left."""

    def __init__(self, ports: Sequence[int], rate: float, keep: bool = True):
        self.keep = keep
        self.ports = list(ports)
        self.period = 1.0 / rate
        self.sent: list[dict[float, float]] = [{} for _ in self.ports]  # value -> perf_counter
        self.count = [0] * len(self.ports)
        self._stop = threading.Event()
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._thread = threading.Thread(target=self._run, daemon=True)
        self.counting = False

    def start(self) -> None:
        self._thread.start()

    def _run(self) -> None:
        k = 0
        next_at = time.perf_counter()
        while not self._stop.is_set():
            v = _value(k)
            data = encode_message("/az", [v])
            for i, port in enumerate(self.ports):
                if self.counting:
                    if self.keep:
                        self.sent[i][v] = time.perf_counter()
                    self.count[i] += 1
                self._sock.sendto(data, ("127.0.0.1", port))
            k += 1
            next_at += self.period
            pause = next_at - time.perf_counter()
            if pause > 0:
                time.sleep(pause)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        self._sock.close()


def latency(folder: Path, seconds: float, progress: Callable[[str], None]) -> dict[str, np.ndarray]:
    """Per sample, ms from the send into the patch to arrival: by OSC, by the bus, and their difference."""
    osc = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    osc.bind(("127.0.0.1", 0))
    osc.settimeout(0.2)
    patch = Patch(folder, "bench_lat", osc.getsockname()[1], 3600)
    client = Client()
    arrived_osc: dict[float, float] = {}
    stop = threading.Event()

    def read_osc() -> None:
        while not stop.is_set():
            try:
                data = osc.recv(4096)
            except (TimeoutError, OSError):
                continue
            t = time.perf_counter()
            for _addr, args in _messages(data):
                if args and isinstance(args[0], float):
                    arrived_osc.setdefault(float(np.float32(args[0])), t)

    try:
        sig = client.incoming("lat")
        m = _map(client, client.source("bench_lat", "out/azimuth"), sig)
        client.poll_until(lambda: m.ready, 30, "the map")
        client.start()
        reader = threading.Thread(target=read_osc, daemon=True)
        reader.start()
        feeder = _Feeder([patch.port], 100.0)
        feeder.start()
        time.sleep(2.0)  # warm: the first values, the caches
        feeder.counting = True
        time.sleep(seconds)
        feeder.counting = False
        time.sleep(1.0)
        feeder.stop()
        stop.set()
        reader.join(timeout=5)
    finally:
        client.stop()
        patch.stop()
        osc.close()
    sent = feeder.sent[0]
    bus = {float(np.float32(v)): t for t, v in client.got["lat"]}
    both = [(sent[v], arrived_osc[v], bus[v]) for v in sent if v in arrived_osc and v in bus]
    a = np.array(both, dtype=float)
    progress(f"  latency: {len(both)} of {len(sent)} values by both paths")
    return {
        "osc": (a[:, 1] - a[:, 0]) * 1000,
        "bus": (a[:, 2] - a[:, 0]) * 1000,
        "added": (a[:, 2] - a[:, 1]) * 1000,
        "sent": np.array([len(sent)]),
        "lost_osc": np.array([sum(1 for v in sent if v not in arrived_osc)]),
        "lost_bus": np.array([sum(1 for v in sent if v not in bus)]),
    }


PARAM_PATCH = """\
# live parameters only (metros never started): the bus sets them, the console tells each one
""" + "".join(f"node m{k} metro 100\n" for k in range(8))


def bus_to_parameter(folder: Path, seconds: float, progress: Callable[[str], None]) -> np.ndarray:
    """Per value, ms from the client setting a signal mapped to a patch's live parameter (a ``metro``'s
    ``interval``) to the patch's console telling it was set (``live control: /pointat/mK/interval V``,
    read from its standard output here): the bus, the ``mapper`` node's poll, live control, and the
    console's writer thread and pipe.  Eight parameters in turn, each set at most once a second (the
    console tells an address's first value at once, then one line a second)."""
    path = folder / "bench_param.pat"
    path.write_text(PARAM_PATCH)
    proc = subprocess.Popen(
        [str(POINTAT), "run", str(path), "--mapper", "lo", "--mapper-name", "bench_param", "--status", "0"]
        + ["--for", "3600"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        cwd=folder,
        text=True,
        bufsize=1,
    )
    told: dict[str, list[tuple[float, float]]] = {}
    said = re.compile(r"live control: /pointat/(m\d)/interval (\S+)")

    def read() -> None:
        assert proc.stdout is not None
        for line in proc.stdout:
            t = time.perf_counter()
            found = said.search(line)
            if found:
                told.setdefault(found[1], []).append((t, float(found[2])))

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    client = Client()
    times: list[float] = []
    try:
        names = [f"m{k}" for k in range(8)]
        outs = {n: client.outgoing(f"set/{n}") for n in names}
        maps = [_map(client, outs[n], client.source("bench_param", f"{n}/interval")) for n in names]
        client.poll_until(lambda: all(m.ready for m in maps), 30, "the maps")
        client.start()
        began = time.monotonic()
        k = 0
        while time.monotonic() - began < seconds + 2.0:
            name = names[k % len(names)]
            value = 100.0 + (k % 1000) * 0.5  # (exact in float32, never the value before)
            box = told.setdefault(name, [])
            seen = len(box)
            with client.lock:
                outs[name].set_value(value)
                asked = time.perf_counter()
                client.dev.update_maps()
            deadline = time.monotonic() + 2.0
            while len(box) == seen and time.monotonic() < deadline:
                time.sleep(0.0002)
            if len(box) > seen and box[seen][1] == value and time.monotonic() - began > 2.0:
                times.append((box[seen][0] - asked) * 1000)  # (the first 2 s warm up)
            k += 1
            time.sleep(max(0.0, 1.2 / len(names) - (time.perf_counter() - asked)))
        progress(f"  bus to parameter: {len(times)} values told of {k}")
    finally:
        client.stop()
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        reader.join(timeout=5)
    return np.array(times, dtype=float)


def _messages(data: bytes) -> list[tuple[str, list]]:
    out: list[tuple[str, list]] = []
    for item in decode_packet(data):
        out.append((item[0], list(item[1])))
    return out


def soak(
    folder: Path,
    devices: int,
    seconds: float,
    progress: Callable[[str], None],
    clients: int = 1,
    rcvbuf: int = 0,
) -> dict[str, object]:
    """``devices`` patches on one bus for ``seconds``, each fed 100 values a second, all mapped here (to
    one libmapper device, or to ``clients`` of them in turn).  Where a value is lost is counted socket by
    socket (:func:`udp_drops`): this process's (the client's libmapper sockets), the patches'."""
    sink = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.bind(("127.0.0.1", 0))  # (never read: what osc_out sends there is dropped, and not counted below)
    patches = [
        Patch(folder, f"bench_soak{i:02d}", sink.getsockname()[1], seconds + 600) for i in range(devices)
    ]
    client = Client(clients, rcvbuf)
    result: dict[str, object] = {}
    try:
        sigs = [client.incoming(p.name, i) for i, p in enumerate(patches)]
        srcs: list = [None] * devices

        def found() -> bool:
            for i, p in enumerate(patches):
                if srcs[i] is None:
                    srcs[i] = client.find(p.name, "out/azimuth")
            return client.ready and all(s is not None for s in srcs)

        client.poll_until(found, 120, f"{devices} patches on the bus")
        maps = [_map(client, s, d) for s, d in zip(srcs, sigs, strict=True)]
        client.poll_until(lambda: all(m.ready for m in maps), 60, "the maps")
        client.start()
        mine = socket_inodes(os.getpid()) - {os.fstat(sink.fileno()).st_ino}
        theirs = set().union(*(socket_inodes(p.proc.pid) for p in patches))
        drops_before = udp_drops()
        system_before = udp_receive_drops()
        load = [os.getloadavg()[0]]
        feeder = _Feeder([p.port for p in patches], 100.0, keep=False)
        feeder.counting = True  # (every value: each one sent after the maps were made must arrive)
        feeder.start()
        began = time.monotonic()
        first_rss: list[int] | None = None
        samples = []
        while time.monotonic() - began < seconds:
            time.sleep(min(10.0, seconds / 6))
            rss = [p.rss_kb() for p in patches]
            samples.append((time.monotonic() - began, rss))
            load.append(os.getloadavg()[0])
            if first_rss is None and time.monotonic() - began >= min(60.0, seconds / 3):
                first_rss = rss
                first_at = time.monotonic() - began
            progress(
                f"  soak {time.monotonic() - began:.0f} s: rss median {statistics.median(rss) / 1024:.1f} MB, "
                f"load {load[-1]:.1f}"
            )
        feeder.stop()
        time.sleep(2.0)  # (the last values on their way)
        drops_after = udp_drops()
        system_after = udp_receive_drops()
        last_at, last_rss = samples[-1]
        alive = [p.proc.poll() is None for p in patches]
        with client.lock:
            got = [len(client.got[p.name]) for p in patches]
        lost = [sent - n for sent, n in zip(feeder.count, got, strict=True)]
        minutes = max(1e-9, (last_at - first_at) / 60.0) if first_rss is not None else float("nan")
        growth = [(b - a) / minutes for a, b in zip(first_rss or last_rss, last_rss, strict=True)]

        def dropped(inodes: set[int]) -> int:
            return sum(drops_after.get(i, 0) - drops_before.get(i, 0) for i in inodes)

        result = {
            "devices": devices,
            "clients": clients,
            "seconds": seconds,
            "sent": sum(feeder.count),
            "lost": lost,
            "alive": sum(alive),
            "rss_mb": [r / 1024 for r in last_rss],
            "growth_kb_min": growth,
            "window_s": (first_at, last_at) if first_rss is not None else None,
            "client_drops": dropped(mine),
            "patch_drops": dropped(theirs),
            "udp_drops": None
            if system_before is None or system_after is None
            else system_after - system_before,
            "rcvbuf": client.rcvbuf,
            "load": (min(load), max(load)),
        }
    finally:
        client.stop()
        for p in patches:
            p.stop()
        sink.close()
    published = [p.published() for p in patches]
    if result and all(n is not None for n in published):
        result["unpublished"] = sum(sent - n for sent, n in zip(feeder.count, published, strict=True))
    return result


def _enlarge(inodes: set[int], size: int) -> int:
    """Ask ``size`` bytes of receive buffer (``SO_RCVBUF``, which the system caps at ``net.core.rmem_max``)
    for this process's UDP sockets of these inodes; the smallest buffer they have after it."""
    got = []
    for fd in Path("/proc/self/fd").iterdir():
        try:
            target = os.readlink(fd)
        except OSError:
            continue
        if not target.startswith("socket:[") or int(target[8:-1]) not in inodes:
            continue
        with socket.socket(fileno=os.dup(int(fd.name))) as s:
            if s.type != socket.SOCK_DGRAM:
                continue
            if size:
                s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, size)
            got.append(s.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF))
    return min(got, default=0)


def socket_inodes(pid: int) -> set[int]:
    """The inodes of the sockets process ``pid`` holds open."""
    found = set()
    fds = Path(f"/proc/{pid}/fd")
    for fd in fds.iterdir():
        try:
            target = os.readlink(fd)
        except OSError:
            continue
        if target.startswith("socket:["):
            found.add(int(target[8:-1]))
    return found


def udp_drops() -> dict[int, int]:
    """Every UDP socket's count of datagrams dropped on arrival (a full receive buffer, mostly), by the
    socket's inode: ``/proc/net/udp``'s last column, so a loss is found at the socket that had it."""
    out: dict[int, int] = {}
    for name in ("udp", "udp6"):
        try:
            lines = Path(f"/proc/net/{name}").read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            f = line.split()
            out[int(f[9])] = int(f[-1])
    return out


def _sysctl(name: str) -> int | None:
    try:
        return int(Path("/proc/sys", *name.split(".")).read_text())
    except (OSError, ValueError):
        return None


def udp_receive_drops() -> int | None:
    """The system's count of UDP datagrams dropped for a full receive buffer (every process's), or None
    where ``/proc/net/snmp`` does not say."""
    try:
        lines = [
            ln.split() for ln in Path("/proc/net/snmp").read_text().splitlines() if ln.startswith("Udp:")
        ]
        return int(lines[1][lines[0].index("RcvbufErrors")])
    except (OSError, ValueError, IndexError):
        return None


def _range(values: Sequence[float], fmt: str = "{:.2f}") -> str:
    v = list(values)
    return f"{fmt.format(statistics.median(v))} ({fmt.format(min(v))}–{fmt.format(max(v))})"


def report(minutes: float, quick: bool, rcvbuf: int, progress: Callable[[str], None] = print) -> str:
    began = time.monotonic()
    folder = Path(tempfile.mkdtemp(prefix="pointat-mapper-bench-"))
    rounds = 5 if quick else 10
    progress("map creation to first value")
    first = map_to_first_value(folder, rounds, progress)
    progress("latency, bus against OSC")
    lat = latency(folder, 10.0 if quick else 30.0, progress)
    progress("bus to a live parameter")
    param = bus_to_parameter(folder, 10.0 if quick else 30.0, progress)
    progress(f"16 devices on one bus, {minutes:g} min")
    s = soak(folder, 16, minutes * 60.0, progress, rcvbuf=rcvbuf)
    args = (f" --minutes {minutes:g}" if minutes != 1 else "") + (f" --rcvbuf {rcvbuf}" if rcvbuf else "")
    lines = [
        "# The libmapper bus: map to first value, added latency, 16 devices",
        "",
        f"(`python -m benchmarks.mapper{args}` writes this file.)",
        "",
        __doc__.split("\n\n", 1)[1].strip(),
        "",
        f"Map creation to first value ({rounds} rounds, a new map each): "
        f"**{_range([t * 1000 for t in first], '{:.1f}')} ms**, median (range).",
        "",
        f"Latency from the value sent into the patch to its arrival here, the same "
        f"{len(lat['osc'])} samples by both paths (100 Hz; {int(lat['lost_osc'][0])} of "
        f"{int(lat['sent'][0])} lost by OSC, {int(lat['lost_bus'][0])} by the bus):",
        "",
        "| path | p50 (ms) | p99 (ms) |",
        "|---|---|---|",
    ]
    for key, label in (
        ("osc", "OSC (`osc_out` to a UDP socket)"),
        ("bus", "libmapper (`mapper` to a signal)"),
        ("added", "**added by the bus**, sample by sample"),
    ):
        a = lat[key]
        lines.append(f"| {label} | {np.percentile(a, 50):.3f} | {np.percentile(a, 99):.3f} |")
    lines += [
        "",
        f"From the bus to a live parameter ({len(param)} values, a plain client's signal mapped to a "
        f"`metro`'s `interval`, each timed to the patch's console telling it set): "
        f"**p50 {np.percentile(param, 50):.2f} ms, p99 {np.percentile(param, 99):.2f} ms** "
        f"(range {param.min():.2f}–{param.max():.2f}).",
    ]
    lost = s["lost"]
    growth = s["growth_kb_min"]
    window = s["window_s"]
    lines += [
        "",
        f"{s['devices']} devices on one bus for {s['seconds'] / 60:g} min"
        + (" (the issue asks for 10: run `--minutes 10`)" if s["seconds"] < 600 else "")
        + f", each fed 100 values a second, every azimuth mapped to one client (its receive buffer "
        f"{s['rcvbuf'] // 1024} KB, as the kernel reports it; the load average {s['load'][0]:.1f}–"
        f"{s['load'][1]:.1f}): {s['sent']} values sent, "
        f"**{sum(lost)} lost** (per device, most {max(lost)}"
        + (
            f"; {s['unpublished']} of them never reached the bus: the patch did not publish them"
            if "unpublished" in s
            else ""
        )
        + f"; dropped for a full receive buffer, by the sockets' own counters: {s['client_drops']} at the "
        f"client's, {s['patch_drops']} at the patches'" + f"); {s['alive']} of {s['devices']} processes "
        f"alive at the end.  Resident memory per process at the end {_range(s['rss_mb'], '{:.1f}')} MB; "
        + (
            f"growth from {window[0]:.0f} s to {window[1]:.0f} s **{_range(growth, '{:+.1f}')} KB/min**."
            if window is not None
            else "too short a run for a growth figure."
        ),
        "",
        f"Measured in {time.monotonic() - began:.0f} s on {os.cpu_count()} CPUs, libmapper "
        f"{_libmapper_version()}.",
        "",
    ]
    return "\n".join(lines)


def _libmapper_version() -> str:
    import libmapper

    return str(getattr(libmapper, "__version__", "?"))


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.mapper", description=__doc__.split("\n\n")[0])
    ap.add_argument("--minutes", type=float, default=1.0, help="the 16-device soak's length (default 1)")
    ap.add_argument("--quick", action="store_true", help="fewer rounds and a shorter latency run")
    ap.add_argument(
        "--rcvbuf",
        type=int,
        default=0,
        metavar="BYTES",
        help="the soak's client asks this receive buffer of its sockets (SO_RCVBUF; 0: the system's default)",
    )
    ap.add_argument("--out", type=Path, default=Path(__file__).with_name("MAPPER.md"))
    args = ap.parse_args(argv)
    text = report(args.minutes, args.quick, args.rcvbuf, lambda s: print(s, file=sys.stderr, flush=True))
    args.out.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
