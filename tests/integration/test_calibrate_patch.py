"""patches/calibrate_glove.pat as its comments tell a user to drive it: `pointat run` in one process,
`pointat send` steps from another, a calibration file that the glove patch then reads."""

import json
import os
import queue
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from pointat.devices.glove_sim import GloveSimulator

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}


def _free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _send(port: int, address: str, *values: str) -> None:
    cmd = [sys.executable, "-m", "pointat.cli", "send", str(port), address, *values]
    subprocess.run(cmd, cwd=ROOT, env=ENV, check=True, timeout=30)


@pytest.fixture
def calibrating(tmp_path):
    """The calibration patch running on the simulated glove; its printed lines arrive on a queue."""
    port, target = _free_udp_port(), tmp_path / "glove.json"
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


def _until(lines: queue.Queue, word: str, timeout: float = 10.0) -> str:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            line = lines.get(timeout=0.1)
        except queue.Empty:
            continue
        if word in line:
            return line
    raise AssertionError(f"no '{word}' printed within {timeout} s")


def test_rest_then_save_from_a_shell_writes_the_gyro_nulls_the_glove_has(calibrating):
    port, target, lines = calibrating
    # the simulated glove rests for its first 2 s: ask until the patch listens, then the 0.3 s of rest
    deadline = time.monotonic() + 20.0
    while time.monotonic() < deadline:
        _send(port, "/pointat/cal/rest")
        try:
            _until(lines, "collecting rest", timeout=0.3)
            break
        except AssertionError:
            continue
    rest = _until(lines, "rest ")
    assert "moved" not in rest, rest
    _send(port, "/pointat/cal/save")
    assert str(target) in _until(lines, "saved")
    nulls = json.loads(target.read_text())["gyro"]["null"]
    truth = np.mean([GloveSimulator().sample(k).frame.channels[:3] for k in range(150)], axis=0)
    assert nulls == pytest.approx(truth, abs=1.5)  # the gyro noise is ~3 counts rms
