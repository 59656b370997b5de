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
* **16 devices on one bus**: sixteen such patches, each fed 100 values a second, every one of their
  azimuths mapped to the client for ``--minutes`` (default 1; the issue's figure is 10): values lost
  (sent into the patch, never out of the bus) and each process's resident memory from the first minute
  on, growth per minute.

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

    def __init__(self) -> None:
        import libmapper as mpr

        self.mpr = mpr
        self.graph = mpr.Graph(mpr.Type.DEVICE | mpr.Type.SIGNAL)
        self.graph.set_interface("lo")
        self.dev = mpr.Device("bench", self.graph)
        self.got: dict[str, list[tuple[float, float]]] = {}
        self.lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def incoming(self, name: str) -> object:
        mpr = self.mpr
        box = self.got.setdefault(name, [])

        def take(_sig, _event, _inst, value, _time):
            box.append((time.perf_counter(), value))

        return self.dev.add_signal(
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
            return self.dev.ready and bool(box)

        self.poll_until(there, seconds, f"{device}/{signal} on the bus")
        return box[0]

    def poll_until(self, condition: Callable[[], bool], seconds: float, what: str) -> None:
        deadline = time.monotonic() + seconds
        while not condition():
            if time.monotonic() > deadline:
                raise RuntimeError(f"not within {seconds:g} s: {what}")
            with self.lock:
                self.dev.poll(5)

    def start(self) -> None:
        def run() -> None:
            while not self._stop.is_set():
                with self.lock:
                    self.dev.poll(1)

        self._thread = threading.Thread(target=run, daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
        self.dev.free()
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


def _messages(data: bytes) -> list[tuple[str, list]]:
    out: list[tuple[str, list]] = []
    for item in decode_packet(data):
        out.append((item[0], list(item[1])))
    return out


def soak(folder: Path, devices: int, seconds: float, progress: Callable[[str], None]) -> dict[str, object]:
    """``devices`` patches on one bus for ``seconds``, each fed 100 values a second, all mapped here."""
    sink = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.bind(("127.0.0.1", 0))  # (never read: what osc_out sends there is dropped by the system)
    patches = [
        Patch(folder, f"bench_soak{i:02d}", sink.getsockname()[1], seconds + 600) for i in range(devices)
    ]
    client = Client()
    result: dict[str, object] = {}
    try:
        sigs = [client.incoming(p.name) for p in patches]
        srcs: list = [None] * devices

        def found() -> bool:
            for i, p in enumerate(patches):
                if srcs[i] is None:
                    srcs[i] = client.find(p.name, "out/azimuth")
            return client.dev.ready and all(s is not None for s in srcs)

        client.poll_until(found, 120, f"{devices} patches on the bus")
        maps = [_map(client, s, d) for s, d in zip(srcs, sigs, strict=True)]
        client.poll_until(lambda: all(m.ready for m in maps), 60, "the maps")
        client.start()
        drops_before = udp_receive_drops()
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
            if first_rss is None and time.monotonic() - began >= min(60.0, seconds / 3):
                first_rss = rss
                first_at = time.monotonic() - began
            progress(
                f"  soak {time.monotonic() - began:.0f} s: rss median {statistics.median(rss) / 1024:.1f} MB"
            )
        feeder.stop()
        time.sleep(2.0)  # (the last values on their way)
        drops_after = udp_receive_drops()
        last_at, last_rss = samples[-1]
        alive = [p.proc.poll() is None for p in patches]
        with client.lock:
            got = [len(client.got[p.name]) for p in patches]
        lost = [sent - n for sent, n in zip(feeder.count, got, strict=True)]
        minutes = max(1e-9, (last_at - first_at) / 60.0) if first_rss is not None else float("nan")
        growth = [(b - a) / minutes for a, b in zip(first_rss or last_rss, last_rss, strict=True)]
        result = {
            "devices": devices,
            "seconds": seconds,
            "sent": sum(feeder.count),
            "lost": lost,
            "alive": sum(alive),
            "rss_mb": [r / 1024 for r in last_rss],
            "growth_kb_min": growth,
            "window_s": (first_at, last_at) if first_rss is not None else None,
            "udp_drops": None if drops_before is None or drops_after is None else drops_after - drops_before,
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


def report(minutes: float, quick: bool, progress: Callable[[str], None] = print) -> str:
    began = time.monotonic()
    folder = Path(tempfile.mkdtemp(prefix="pointat-mapper-bench-"))
    rounds = 5 if quick else 10
    progress("map creation to first value")
    first = map_to_first_value(folder, rounds, progress)
    progress("latency, bus against OSC")
    lat = latency(folder, 10.0 if quick else 30.0, progress)
    progress(f"16 devices on one bus, {minutes:g} min")
    s = soak(folder, 16, minutes * 60.0, progress)
    lines = [
        "# The libmapper bus: map to first value, added latency, 16 devices",
        "",
        "(`python -m benchmarks.mapper"
        + (f" --minutes {minutes:g}" if minutes != 1 else "")
        + "` writes this file.)",
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
    lost = s["lost"]
    growth = s["growth_kb_min"]
    window = s["window_s"]
    lines += [
        "",
        f"{s['devices']} devices on one bus for {s['seconds'] / 60:g} min"
        + (" (the issue asks for 10: run `--minutes 10`)" if s["seconds"] < 600 else "")
        + f", each fed 100 values a second, every azimuth mapped to one client: {s['sent']} values sent, "
        f"**{sum(lost)} lost** (per device, most {max(lost)}"
        + (
            f"; {s['unpublished']} of them never reached the bus: the patch did not publish them"
            if "unpublished" in s
            else ""
        )
        + (
            f"; meanwhile the system dropped {s['udp_drops']} UDP datagrams for a full receive buffer"
            if s.get("udp_drops") is not None
            else ""
        )
        + f"); {s['alive']} of {s['devices']} processes "
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
    ap.add_argument("--out", type=Path, default=Path(__file__).with_name("MAPPER.md"))
    args = ap.parse_args(argv)
    text = report(args.minutes, args.quick, lambda s: print(s, file=sys.stderr, flush=True))
    args.out.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
