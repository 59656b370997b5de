"""What the monitor and OSCQuery cost a running patch (``python -m benchmarks.monitor``).

Two measurements, each side by side in one run, rounds alternating so that the machine's other work
falls on both alike:

* **In process, batch**: the vendored BROAD trial replayed as fast as it goes (``replay speed=0``)
  through ``lib/tqt_fusion.pat`` into an ``osc_out``, without and with the monitor (the observer's taps
  and thread, the server, one WebSocket client taking the monitor's readings and one LISTEN).  Cost per
  sample, microseconds.
* **Whole process, real time**: ``pointat run glove_tqt --for S`` (the simulated glove at 100 Hz through
  a pseudo-terminal) without ``--monitor``, with it and a WebSocket client reading its 25 readings a
  second, and with it shown by a real browser (headless Chromium through its driver).  The process's CPU
  time per second, and the spacing of the directions at a UDP receiver: the p50 and p99 of how far each
  datagram's interval strays from 10 ms (a scheduler held up by the page would show there).

Medians over rounds, with their range.
"""

from __future__ import annotations

import argparse
import json
import resource
import shutil
import socket
import statistics
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]


def _ws_client(port: int, commands: Sequence[dict]) -> tuple[socket.socket, threading.Thread, list[int]]:
    """A plain WebSocket client that sends ``commands`` and reads every frame until closed."""
    from tests.monitor_client import ws_connect, ws_send

    s = ws_connect(port)
    for cmd in commands:
        ws_send(s, 1, json.dumps(cmd).encode())
    got = [0, 0]  # reads, bytes

    def read() -> None:
        try:
            while True:
                data = s.recv(65536)
                if not data:
                    return
                got[0] += 1
                got[1] += len(data)
        except OSError:
            return

    th = threading.Thread(target=read, daemon=True)
    th.start()
    return s, th, got


# -- in process --------------------------------------------------------------------------------------
def batch_cost(monitored: bool) -> float:
    """Microseconds per sample of the replayed trial through tqt into osc_out, with or without the monitor."""
    from pointat.checking import check
    from pointat.expansion import read_spec
    from pointat.loader import build, parse_overrides
    from pointat.maths.evaluation import BROAD_SAMPLE
    from pointat.monitor.observe import Observer
    from pointat.monitor.webserver import MonitorServer
    from pointat.registry import Registry

    # a socket nobody reads (no thread in this process to wake for each datagram: a reader here would
    # take the interpreter from the scheduler thousands of times a second, and more so beside the
    # monitor's threads); once its buffer is full, the sends fail and are counted, alike in both runs
    sink = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.bind(("127.0.0.1", 0))
    patches = REPO / "patches"
    text = (
        f"node src replay file={BROAD_SAMPLE} speed=0\n"
        "node tqt lib/tqt_fusion.pat rate=285.7142857142857 mode=robust\n"
        f"node out osc_out port={sink.getsockname()[1]} status=0\n"
        "src.mag -> tqt.mag\nsrc.accel -> tqt.accel\nsrc.gyro -> tqt.gyro\n"
        "tqt.elevation -> out.elevation\ntqt.azimuth -> out.azimuth\ntqt.flags -> out.flags\n"
    )
    path = patches / ".bench_monitor.pat"  # beside lib/: the abstraction is found
    path.write_text(text)
    try:
        rt = build(check(read_spec(str(path)), Registry().load_builtins(), parse_overrides([])))
    finally:
        path.unlink()
    server = client = None
    obs = None
    if monitored:
        obs = Observer(rt, patch="bench").attach()
        server = MonitorServer(rt, obs, "127.0.0.1", 0, advertise=False)
        server.start()
        obs.start()
        client = _ws_client(
            server.port, [{"COMMAND": "MONITOR"}, {"COMMAND": "LISTEN", "DATA": "/pointat/out/aed"}]
        )
    rows = 0
    t0 = time.perf_counter()
    rt.run()
    took = time.perf_counter() - t0
    rows = rt.nodes["out"].updates
    if monitored:
        obs.stop()
        server.close()
        client[0].close()
    sink.close()
    return took / max(rows, 1) * 1e6


# -- whole process -----------------------------------------------------------------------------------
def _browser(url: str) -> Callable[[], None] | None:
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service

        from tests.monitor_client import CHROMIUM_FLAGS
    except ImportError:
        return None
    if not (shutil.which("chromium") and shutil.which("chromedriver")):
        return None
    o = webdriver.ChromeOptions()
    o.binary_location = shutil.which("chromium")
    for flag in CHROMIUM_FLAGS:
        o.add_argument(flag)
    d = webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=o)
    d.get(url)
    return d.quit


def whole_process(mode: str, seconds: float) -> dict[str, float]:
    """One ``pointat run glove_tqt`` of ``seconds``; mode ``plain``, ``client`` or ``browser``."""
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(0.2)
    cmd = [sys.executable, "-m", "pointat.cli", "run", "glove_tqt", "--for", f"{seconds:g}", "--status", "0"]
    cmd += ["--set", f"out.port={rx.getsockname()[1]}", "--set", "ctl.port=0", "--set", "out.status=0"]
    if mode != "plain":
        cmd += ["--monitor", "0"]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, cwd="/tmp")
    port = None
    while mode != "plain" and port is None:
        line = proc.stdout.readline()
        if not line:
            break
        if "  monitor  http://" in line:
            port = int(line.split("127.0.0.1:")[1].split("/")[0])
    stop = None
    client = None
    if port is not None:
        if mode == "client":
            client = _ws_client(port, [{"COMMAND": "MONITOR"}])
        elif mode == "browser":
            stop = _browser(f"http://127.0.0.1:{port}/monitor")
    arrivals = []
    while proc.poll() is None:
        try:
            data = rx.recv(1024)
        except TimeoutError:
            continue
        if data.startswith(b"/pointat/1/aed"):
            arrivals.append(time.perf_counter())
    proc.communicate()
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if stop is not None:
        stop()
    if client is not None:
        client[0].close()
    rx.close()
    a = np.diff(np.array(arrivals[len(arrivals) // 10 :]))  # past the gyro nulls and the start
    stray = np.abs(a - 0.01) * 1e3
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {
        "cpu": cpu / seconds,
        "p50": float(np.percentile(stray, 50)) if len(stray) else float("nan"),
        "p99": float(np.percentile(stray, 99)) if len(stray) else float("nan"),
        "n": len(arrivals),
        "frames": client[2][0] if client else 0,
        "browser": stop is not None,
    }


def _med(values: Sequence[float], fmt: str = "{:.2f}") -> str:
    v = [x for x in values if x == x]
    if not v:
        return "–"
    return f"{fmt.format(statistics.median(v))} ({fmt.format(min(v))}–{fmt.format(max(v))})"


def report(quick: bool = False, progress: Callable[[str], None] = print) -> str:
    rounds = 3 if quick else 5
    t0 = time.perf_counter()
    batch: dict[bool, list[float]] = {False: [], True: []}
    for r in range(rounds):
        for monitored in (False, True) if r % 2 == 0 else (True, False):
            progress(f"monitor: batch, round {r + 1}/{rounds}, monitor {'on' if monitored else 'off'}")
            batch[monitored].append(batch_cost(monitored))
    ratios = [b / a for a, b in zip(batch[False], batch[True], strict=True)]
    seconds = 8.0 if quick else 20.0
    modes = ("plain", "client", "browser")
    live: dict[str, list[dict[str, float]]] = {m: [] for m in modes}
    for r in range(2 if quick else 3):
        order = modes if r % 2 == 0 else tuple(reversed(modes))
        for mode in order:
            progress(f"monitor: pointat run glove_tqt for {seconds:g} s, round {r + 1}, {mode}")
            live[mode].append(whole_process(mode, seconds))
    browser_ran = all(x["browser"] for x in live["browser"])
    lines = [
        "# The monitor's cost: beside the same patch without it",
        "",
        __doc__.split("\n\n", 1)[1].strip(),
        "",
        f"In process, batch ({rounds} rounds, alternating): the BROAD trial through tqt into osc_out.",
        "",
        "| | µs per sample, median (range) |",
        "|---|---|",
        f"| without the monitor | {_med(batch[False])} |",
        f"| with the monitor, a WebSocket client and a LISTEN | {_med(batch[True])} |",
        f"| ratio, round by round | {_med(ratios)} |",
        "",
        f"Whole process, real time: `pointat run glove_tqt --for {seconds:g}`, {len(live['plain'])} rounds "
        "(order reversed every other round).  CPU: the process's user + system seconds per second.  "
        "Spacing: |interval − 10 ms| between consecutive directions at the receiver.",
        "",
        "| | CPU (s/s) | spacing p50 (ms) | spacing p99 (ms) | directions received |",
        "|---|---|---|---|---|",
    ]
    names = {
        "plain": "without `--monitor`",
        "client": "`--monitor`, a WebSocket client reading the monitor",
        "browser": "`--monitor`, the page open in headless Chromium"
        + ("" if browser_ran else " (Chromium or its driver missing: not measured)"),
    }
    for mode in modes:
        rows = live[mode]
        lines.append(
            f"| {names[mode]} | {_med([x['cpu'] for x in rows], '{:.3f}')} | {_med([x['p50'] for x in rows])} | "
            f"{_med([x['p99'] for x in rows])} | {_med([x['n'] for x in rows], '{:.0f}')} |"
        )
    lines += ["", f"Measured in {time.perf_counter() - t0:.0f} s."]
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.monitor", description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer and shorter rounds")
    ap.add_argument("--out", type=Path, default=Path(__file__).with_name("MONITOR.md"))
    args = ap.parse_args(argv)
    text = report(args.quick, lambda s: print(s, file=sys.stderr, flush=True))
    args.out.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
