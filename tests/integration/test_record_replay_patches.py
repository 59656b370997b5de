"""patches/record_glove.pat then patches/replay_glove.pat, as a performer uses them: a take recorded live
(simulated glove, real pty, real UDP) plays back through the same chain into the same datagrams."""

import os
import socket
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from pointat.testing import beside

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}


class Listener:
    """Every datagram that reaches a UDP port on 127.0.0.1, read on a thread as it comes."""

    def __init__(self) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 22)  # a burst at speed=0
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.2)
        self.port = self.sock.getsockname()[1]
        self.datagrams: list[bytes] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self) -> None:
        while not self._stop.is_set():
            try:
                self.datagrams.append(self.sock.recv(4096))
            except TimeoutError:
                continue

    def close(self) -> list[bytes]:
        self._stop.set()
        self._thread.join(timeout=5)
        self.sock.setblocking(False)
        while True:  # what came in after the thread's last read
            try:
                self.datagrams.append(self.sock.recv(4096))
            except BlockingIOError:
                break
        self.sock.close()
        # the directions; the heartbeats (/pointat/N/status) follow the clock, not the take
        self.statuses = [d for d in self.datagrams if d.split(b"\0", 1)[0].endswith(b"/status")]
        return [d for d in self.datagrams if not d.split(b"\0", 1)[0].endswith(b"/status")]


def _run(patch: str, *sets: str, seconds: float | None = None) -> subprocess.CompletedProcess:
    args = beside(ROOT / patch) + [a for s in sets for a in ("--set", s)]  # (the test's own last: they win)
    args += [] if seconds is None else ["--for", str(seconds)]
    return subprocess.run(
        [sys.executable, "-m", "pointat.cli", "run", patch, *args],
        cwd=ROOT,
        env=ENV,
        capture_output=True,
        text=True,
        timeout=60,
    )


@pytest.mark.slow  # (two patches run in real time, 3 s and the replay)
def test_a_take_replays_into_the_datagrams_it_gave_live(tmp_path):
    take = tmp_path / "take.csv"
    live = Listener()
    try:
        rec = _run(
            "patches/record_glove.pat", f"take.file={take}", f"out.port={live.port}", "ctl.port=0", seconds=3
        )
    finally:
        sent_live = live.close()
    assert rec.returncode == 0, rec.stderr
    rows = take.read_text().splitlines()
    assert rows[0] == "t,adc_gx,adc_gy,adc_gz,adc_ax,adc_ay,adc_az,adc_mx,adc_my,adc_mz"
    assert len(rows) > 200  # ~3 s at 100 Hz, less the start-up
    assert len(sent_live) == len(rows) - 1 - 150  # every frame after the 150 of the gyro nulls

    again = Listener()
    try:
        rep = _run(  # live control keeps the patch running after the take: --for
            "patches/replay_glove.pat",
            f"source.file={take}",
            "source.speed=0",
            f"out.port={again.port}",
            "ctl.port=0",
            seconds=4,
        )
    finally:
        sent_again = again.close()
    assert rep.returncode == 0, rep.stderr
    assert sent_again == sent_live  # the same directions, bit for bit, in the same order
