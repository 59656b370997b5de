"""A running patch found, listed and driven by an OSCQuery client that pointat did not write.

``tests/oscquery_client/client.mjs`` uses the npm package ``oscquery`` (jangxx/node-oscquery): its
``OSCQueryDiscovery`` browses mDNS (bonjour-service, on the loopback interface) for ``_oscjson._tcp``,
queries the HTTP server and parses the tree; the client then sets a value by a hand-encoded OSC float
message to HOST_INFO's OSC_PORT and reads it back through the library.  Here ``pointat run glove_tqt
--monitor 0`` (the simulated glove) runs as a subprocess, the client runs against it, and the patch's
own server is asked afterwards whether it really took the value.

Needs: Node.js and ``npm ci --prefix tests/oscquery_client`` (skipped with the reason otherwise, failed
where POINTAT_REQUIRE_TOOLS=1).
"""

import json
import queue
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.request
from pathlib import Path

import pytest

from pointat.nodes.tqt import TQT

ROOT = Path(__file__).resolve().parents[2]
CLIENT = ROOT / "tests" / "oscquery_client"
K_HEADING = "/pointat/tqt/fuse/k_heading"


@pytest.fixture
def node(require_tool):
    """The ``node`` program, with the client's packages installed."""
    path = shutil.which("node")
    require_tool(path is not None, "Node.js is not installed (Debian: apt-get install nodejs npm)")
    require_tool(
        (CLIENT / "node_modules" / "oscquery").is_dir(),
        "tests/oscquery_client/node_modules is missing (npm ci --prefix tests/oscquery_client)",
    )
    return path


@pytest.fixture
def patch_running(node):
    """``pointat run glove_tqt --monitor 0``: yields (monitor port, the socket its OSC output goes to)."""
    out = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    out.bind(("127.0.0.1", 0))  # a free port, held for the patch's output
    out.settimeout(5)
    proc = subprocess.Popen(
        [sys.executable, "-m", "pointat.cli", "run", "glove_tqt", "--monitor", "0"]
        + ["--set", f"out.port={out.getsockname()[1]}", "--set", "ctl.port=0", "--for", "20"],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        errors="replace",
    )
    lines: queue.Queue = queue.Queue()
    threading.Thread(target=lambda: [lines.put(x) for x in proc.stdout], daemon=True).start()
    seen = []
    try:
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            try:
                line = lines.get(timeout=0.1)
            except queue.Empty:
                assert proc.poll() is None, "pointat run stopped:\n" + "".join(seen)
                continue
            seen.append(line)
            if line.startswith("  monitor  http://127.0.0.1:"):
                port = int(line.split("http://127.0.0.1:")[1].split("/")[0])
                break
        else:
            pytest.fail("no monitor line in pointat run's banner within 10 s:\n" + "".join(seen))
        yield port, out
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)  # Ctrl-C: a clean stop (zeroconf says goodbye)
            try:
                proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        out.close()


def test_node_oscquery_finds_lists_and_sets(node, patch_running):
    port, out = patch_running
    assert out.recv(65536).startswith(b"/"), "the patch sends no OSC"

    run = subprocess.run(
        [node, "client.mjs", "--port", str(port), "--path", K_HEADING, "--set", "0.2", "--timeout", "5"],
        cwd=CLIENT,
        capture_output=True,
        text=True,
        timeout=20,  # (the client gives up by itself after 15 s)
    )
    report = f"node client.mjs exited {run.returncode}\nstdout: {run.stdout}\nstderr: {run.stderr}"
    assert run.returncode == 0, report
    got = json.loads(run.stdout)

    # mDNS works on loopback here (and on CI, the same kind of machine): lo has no MULTICAST flag, yet
    # Linux delivers 224.0.0.251 on it to sockets that join the group there, which both pointat's
    # python-zeroconf (interfaces=["127.0.0.1"]) and the client's bonjour-service do.  So the service
    # must have been discovered, not reached by the client's direct fallback.
    assert got["discovered_by"] == "mdns", report
    assert got["service"] == {"address": "127.0.0.1", "port": port}
    assert got["host_info"]["oscPort"] > 0 and got["host_info"]["oscTransport"] == "UDP"

    assert got["n_methods"] >= 30, report
    assert got["methods"]["/pointat/out/aed"] == {"type": "fff", "access": "read-only"}
    before, after = got["before"], got["after"]
    assert before["type_names"] == ["FLOAT"] and before["access"] == "read-write", report
    default = next(p.default for p in TQT.params if p.name == "k_heading")
    assert before["value"] == [pytest.approx(default)], report
    assert after["value"] == [pytest.approx(0.2)], report

    # ... and the patch itself took it, as its own server says.
    with urllib.request.urlopen(f"http://127.0.0.1:{port}{K_HEADING}?VALUE", timeout=5) as r:
        assert json.load(r) == {"VALUE": [pytest.approx(0.2)]}
