"""Memory: peak resident set of a running patch, and whether it grows.

``benchmarks/patches/soak.pat`` -- the simulated glove at 1 kHz writing real mote frames into a
pseudo-terminal, the ``mote`` node, both chains (Pointing-at and tqt) and their ``osc_out`` -- runs as
``pointat run`` for 30 s (``--quick``) or 10 min, its datagrams drained by a sink process.  The resident set
(``VmRSS``) is sampled from ``/proc`` every second; the growth is the least-squares slope after the first
fifth of the run (start-up, imports, first allocations), in KB per minute, and the peak is ``VmHWM``.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .latency import PATCHES, REPO, pointat_command, proc_cpu_seconds, proc_memory_kb, shown, stop_process


@dataclass
class MemoryResult:
    seconds: float
    command: str
    times: list[float] = field(default_factory=list)  # s since start
    rss_kb: list[int] = field(default_factory=list)
    peak_kb: int | None = None
    slope_kb_per_min: float = float("nan")
    slope_stderr: float = float("nan")
    cpu_fraction: float | None = None
    datagrams: int | None = None
    lifetime: float = float("nan")  # s from starting the patch to stopping it
    error: str = ""

    @property
    def fit_start(self) -> float:
        return self.seconds / 5.0


class Soak:
    """Start the soak in the background (:meth:`start`), do other work, then :meth:`finish` it."""

    def __init__(self, seconds: float) -> None:
        self.seconds = seconds
        self._tmp = tempfile.TemporaryDirectory(prefix="pointat-soak-")
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._proc: subprocess.Popen | None = None
        self._sink: subprocess.Popen | None = None
        self.result: MemoryResult | None = None

    def start(self) -> None:
        from .latency import free_udp_port

        port = free_udp_port()
        self._sink = subprocess.Popen(
            [sys.executable, "-m", "benchmarks.relay", "--in-port", str(port), "--out-port", "0"]
            + ["--for", f"{self.seconds + 60:.0f}"],
            cwd=REPO,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            text=True,
            start_new_session=True,
        )
        cmd = pointat_command(
            PATCHES / "soak.pat", [f"a/out.port={port}", f"b/out.port={port}"], self.seconds + 30
        )
        self.result = MemoryResult(self.seconds, shown(cmd))
        log_path = Path(self._tmp.name) / "soak.log"
        self._log = open(log_path, "wb")  # noqa: SIM115 - closed in finish()
        self._proc = subprocess.Popen(
            cmd,
            cwd=REPO,
            stdin=subprocess.DEVNULL,
            stdout=self._log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
        self._t0 = time.monotonic()
        self._thread = threading.Thread(target=self._sample, name="bench-soak", daemon=True)
        self._thread.start()

    def _sample(self) -> None:
        assert self._proc is not None and self.result is not None
        t0 = self._t0
        cpu0 = None
        while not self._stop.is_set():
            t = time.monotonic() - t0
            if t >= self.seconds or self._proc.poll() is not None:
                break
            mem = proc_memory_kb(self._proc.pid)
            if "VmRSS" in mem:
                self.result.times.append(t)
                self.result.rss_kb.append(mem["VmRSS"])
                self.result.peak_kb = mem.get("VmHWM", self.result.peak_kb)
            if cpu0 is None and t >= self.result.fit_start:
                cpu0 = (proc_cpu_seconds(self._proc.pid), t)
            self._stop.wait(1.0)
        if cpu0 is not None and cpu0[0] is not None:
            cpu1 = proc_cpu_seconds(self._proc.pid)
            t = time.monotonic() - t0
            if cpu1 is not None and t > cpu0[1]:
                self.result.cpu_fraction = (cpu1 - cpu0[0]) / (t - cpu0[1])
        if self._proc.poll() is None:
            stop_process(self._proc)  # the window is over: the patch's output count ends here too
        self.result.lifetime = time.monotonic() - t0

    def finish(self) -> MemoryResult:
        """Wait for the soak's end, stop the processes, fit the slope."""
        assert self._thread is not None and self._proc is not None and self.result is not None
        res = self.result
        try:
            self._thread.join(self.seconds + 30)
            if self._proc.poll() is not None and len(res.times) < 3:
                res.error = "the patch stopped early: " + Path(self._tmp.name, "soak.log").read_text()[-800:]
        finally:
            self._stop.set()
            stop_process(self._proc)
            self._log.close()
            if self._sink is not None:
                stop_process(self._sink)
                out = self._sink.stdout.read() if self._sink.stdout else ""
                for line in out.splitlines():
                    if line.startswith("received "):
                        res.datagrams = int(line.split()[1])
            self._tmp.cleanup()
        t = np.array(res.times)
        y = np.array(res.rss_kb, dtype=float)
        keep = t >= res.fit_start
        if keep.sum() >= 3:
            tm = t[keep] / 60.0
            A = np.vstack([tm, np.ones_like(tm)]).T
            coef, resid, *_ = np.linalg.lstsq(A, y[keep], rcond=None)
            res.slope_kb_per_min = float(coef[0])
            n = keep.sum()
            if n > 2:
                s2 = float(np.sum((y[keep] - A @ coef) ** 2)) / (n - 2)
                res.slope_stderr = float(np.sqrt(s2 / np.sum((tm - tm.mean()) ** 2)))
        return res
