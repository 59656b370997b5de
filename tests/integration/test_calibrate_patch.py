"""patches/calibrate_glove.pat as its comments tell a user to drive it: `pointat run` in one process,
`pointat send` steps from another, a calibration file that the glove patch then reads."""

import json
import os
import queue
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from pointat.devices.glove_sim import GloveSimulator
from pointat.testing import free_udp_port

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}


def _send(port: int, address: str, *values: str) -> None:
    cmd = [sys.executable, "-m", "pointat.cli", "send", str(port), address, *values]
    subprocess.run(cmd, cwd=ROOT, env=ENV, check=True, timeout=30)


@pytest.fixture
def calibrating(tmp_path):
    """The calibration patch running on the simulated glove; its printed lines arrive on a queue."""
    port, target = free_udp_port(), tmp_path / "glove.json"
    args = ["--set", f"ctl.port={port}", "--set", f"cal.file={target}", "--set", "cal.samples=30"]
    proc = subprocess.Popen(
        [sys.executable, "-m", "pointat.cli", "run", "patches/calibrate_glove.pat", "--for", "30", *args],
        cwd=ROOT,
        env=ENV,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    lines: queue.Queue[str] = queue.Queue()
    threading.Thread(target=lambda: [lines.put(x.strip()) for x in proc.stdout], daemon=True).start()
    try:
        yield port, target, lines
    finally:
        proc.terminate()
        proc.communicate(timeout=30)


def _until(lines: queue.Queue, *words: str, timeout: float = 10.0) -> str:
    """The first printed line with one of ``words`` in it."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            line = lines.get(timeout=0.05)
        except queue.Empty:
            continue
        if any(w in line for w in words):
            return line
    raise AssertionError(f"none of {words} printed within {timeout} s")


def test_rest_then_save_from_a_shell_writes_the_gyro_nulls_the_glove_has(calibrating):
    from pythonosc.udp_client import SimpleUDPClient

    port, target, lines = calibrating
    # the simulated glove rests for its first 2 s only: ask every 50 ms until the patch listens
    client = SimpleUDPClient("127.0.0.1", port)
    deadline = time.monotonic() + 20.0
    while time.monotonic() < deadline:
        client.send_message("/pointat/cal/rest", [])
        try:
            _until(lines, "collecting rest", timeout=0.05)
            break
        except AssertionError:
            continue
    rest = _until(lines, "rest ", "moved")
    assert "moved" not in rest, rest
    _send(port, "/pointat/cal/save")  # as the patch's header says, from another terminal
    assert str(target) in _until(lines, "saved")
    nulls = json.loads(target.read_text())["gyro"]["null"]
    sim = GloveSimulator()
    still = sim.sensor.spec.to_counts(sim.sensor.values(sim.sample(0).q, [0.0, 0.0, 0.0]).tolist())[:3]
    assert nulls == pytest.approx(still, abs=2.5)  # 30 samples of ~3 counts rms noise: 0.6 rms off
