"""Hot reload, measured (``python -m benchmarks.reload``): how long a save takes to run, and what the
output sees of it.

A simulated glove (``simulate output=direct``) streams through the glove chain (offset, scaling, tqt,
azi_ele) into an ``osc_out`` and, beside it, a sample index (a counter into an ``osc_send``), both to a
UDP receiver on 127.0.0.1 that notes when each datagram came.  The runtime runs in real time in this
process with a :class:`pointat.reload.Reloader` watching the file (``pointat run --watch``, as the CLI
makes it).  The file is saved again and again as an editor saves (written beside, then renamed over),
one version after another: a node added (a ``speedlim`` and a ``print``), ``osc_out`` made anew (a
parameter that is not live), then back.  For each save:

* **save → running**: from the rename to the swap done on the scheduler's thread (the ``reloaded``
  line), which includes the watcher's polling (:attr:`Reloader.POLL`, a save counted once it looks the
  same twice); **read → running**, the reload alone (read, check, the nodes made, the swap); and **the
  swap**, the part on the scheduler's thread, which the next sample waits for.
* **the output across it**: sample indices lost or doubled at the receiver over the whole run, and the
  longest interval between two indices from the save to 100 ms after the swap, beside the longest one
  outside the reloads in the same run (the machine's own hiccups) and the sample period.

Medians over the saves, with their range; 100 Hz and 1 kHz, side by side in one run.
"""

from __future__ import annotations

import argparse
import os
import socket
import statistics
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from pointat.checking import check
from pointat.devices.osc_wire import decode_packet
from pointat.expansion import read_spec
from pointat.loader import ready
from pointat.node import Inlet, Node, Outlet
from pointat.reload import Reloader
from pointat.testing import test_registry


class Count(Node):
    """How many messages came so far: the sample index the receiver checks."""

    type_name = "count"
    inlets = (Inlet("in", ("any",), "anything"),)
    outlets = (Outlet("n", "int", "how many so far"),)

    def setup(self) -> None:
        self.n = 0

    def on_in(self, msg: object) -> None:
        self.n += 1
        self.out(0, self.n)


BASE = """\
node glove  simulate rate={rate} output=direct seed=3
node nulls  offset samples=50
node units  scaling
node fuse   tqt rate={rate}
node dir    azi_ele
node out    osc_out profile=pointat host=127.0.0.1 port={port}
node n      count
node idx    osc_send address=/idx port={port}
glove.adc -> nulls -> units
units.gyro -> fuse.gyro
units.accel -> fuse.accel
units.mag -> fuse.mag
fuse.quat -> dir
dir.elevation -> out.elevation
dir.azimuth -> out.azimuth
glove.adc -> n -> idx
"""
ADDED = "node slow speedlim 1000\nnode show print prefix=az\ndir.azimuth -> slow -> show\n"


def versions(rate: float, port: int) -> list[str]:
    """The file's versions, saved in turn: a node added, osc_out made anew, back to the first."""
    base = BASE.format(rate=rate, port=port)
    added = base + ADDED
    anew = added.replace(f"port={port}\nnode n", f"port={port} bundle=true\nnode n", 1)
    return [added, anew, base]


class Receiver:
    """Takes every datagram on a free port of 127.0.0.1 in a thread: (monotonic time, index)."""

    def __init__(self) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 22)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.2)
        self.port = self.sock.getsockname()[1]
        self.indices: list[tuple[float, int]] = []
        self.directions = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                data = self.sock.recv(65536)
            except TimeoutError:
                continue
            now = time.monotonic()
            for address, args in decode_packet(data):
                if address == "/idx":
                    self.indices.append((now, int(args[0])))
                elif address.endswith("/aed"):
                    self.directions += 1

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2.0)
        self.sock.close()


def one_rate(rate: float, saves: int, every: float, progress: Callable[[str], None]) -> dict:
    """Save the patch ``saves`` times, ``every`` seconds apart, while it runs at ``rate`` Hz."""
    rx = Receiver()
    reg = test_registry().copy()
    reg.add(Count, "benchmarks.reload")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "glove.pat"
        path.write_text(BASE.format(rate=rate, port=rx.port))
        checked, rt = ready(read_spec(path), reg)
        reloader = Reloader(rt, checked, lambda: check(read_spec(path), reg, read_files=True), watch=True)
        rt.reloader = reloader
        swapped: list[float] = []
        rt.console = lambda line: swapped.append(time.monotonic()) if line.startswith("reloaded") else None
        scheduler = rt.run_in_thread()
        reloader.start()
        texts = versions(rate, rx.port)
        saved: list[float] = []
        seconds: list[float] = []
        swaps: list[float] = []
        try:
            time.sleep(1.5)  # (the nulls averaged, the stream steady)
            for k in range(saves):
                progress(f"reload: {rate:g} Hz, save {k + 1}/{saves}")
                side = path.with_name(".glove.pat.new")
                side.write_text(texts[k % len(texts)])
                before = reloader.reloads
                saved.append(time.monotonic())
                os.replace(side, path)
                deadline = time.monotonic() + 10.0
                while reloader.reloads == before and time.monotonic() < deadline:
                    time.sleep(0.005)
                seconds.append(reloader.seconds)
                swaps.append(reloader.swap_seconds)
                time.sleep(every)
        finally:
            reloader.stop()
            rt.stop()
            scheduler.join(10.0)
            time.sleep(0.2)
            rx.close()
    got = [i for _, i in rx.indices]
    lost = (got[-1] - len(set(got))) if got else 0
    doubled = len(got) - len(set(got))
    times = [t for t, _ in rx.indices]
    windows = [(s, w + 0.1) for s, w in zip(saved, swapped, strict=False)]
    inside, outside = [], []
    for a, b in zip(times, times[1:], strict=False):
        (inside if any(lo <= b and a <= hi for lo, hi in windows) else outside).append(b - a)
    return {
        "rate": rate,
        "saves": saves,
        "reloads": len(swapped),
        "save_to_running": [w - s for s, w in zip(saved, swapped, strict=False)],
        "read_to_running": seconds,
        "swap": swaps,
        "samples": len(got),
        "lost": lost,
        "doubled": doubled,
        "in_order": got == sorted(got),
        "gap_reload": max(inside) if inside else float("nan"),
        "gap_else": max(outside) if outside else float("nan"),
        "directions": rx.directions,
    }


def _ms(values: Sequence[float]) -> str:
    if not values:
        return "-"
    ms = [1000.0 * v for v in values]
    return f"{statistics.median(ms):.1f} ({min(ms):.1f}–{max(ms):.1f})"


def report(quick: bool = False, progress: Callable[[str], None] = print) -> str:
    saves = 6 if quick else 15
    results = [one_rate(rate, saves, 0.5, progress) for rate in (100.0, 1000.0)]
    lines = [
        "# Hot reload: a save, and what the output sees of it",
        "",
        "(`python -m benchmarks.reload` writes this file; `python -m benchmarks` puts the same table in "
        "REPORT.md, section 7.)",
        "",
        __doc__.split("\n\n", 1)[1].strip(),
        "",
        f"{saves} saves a rate, {0.5:g} s apart; times in ms, median (range) over the saves.",
        "",
        "| rate | save → running | read → running | the swap (scheduler's thread) | samples at the receiver | "
        "lost | twice | longest interval across a reload | longest elsewhere | sample period |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in results:
        lines.append(
            f"| {r['rate']:g} Hz | {_ms(r['save_to_running'])} | {_ms(r['read_to_running'])} | "
            f"{_ms(r['swap'])} | {r['samples']} | {r['lost']} | {r['doubled']} | {1000 * r['gap_reload']:.1f} | "
            f"{1000 * r['gap_else']:.1f} | {1000 / r['rate']:g} |"
        )
    lines += [
        "",
        "Every save ran ("
        + ", ".join(f"{r['reloads']}/{r['saves']} at {r['rate']:g} Hz" for r in results)
        + "); the indices came in order: "
        + ", ".join(f"{'yes' if r['in_order'] else 'no'} at {r['rate']:g} Hz" for r in results)
        + ".",
        "",
    ]
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.reload", description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer saves")
    ap.add_argument("--out", type=Path, default=Path(__file__).with_name("RELOAD.md"))
    args = ap.parse_args(argv)
    text = report(args.quick, lambda s: print(s, file=sys.stderr, flush=True))
    args.out.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
