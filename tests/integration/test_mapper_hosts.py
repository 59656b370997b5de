"""Three hosts on one libmapper bus, tested as hosts (issue 48, point 2).

Network namespaces stand for the machines: a bridge in a namespace of its own and a veth pair from it to
each host's namespace (10.248.0.0/24), nothing in the machine's own namespace, so nothing leaves them.
Host A runs the shipped glove patch (the simulated glove) with ``--mapper``, host B a receiving patch
with a live parameter, host C a plain libmapper client (``mapper_client.py``: the library's own Python
binding, no pointat) that maps glove A's azimuth to B's parameter with the expression ``y=x*0.5``, and
the same azimuth to a signal of its own.  Every value B sets must be half of one that C saw.

Root, ``ip netns`` and the mapper extra are needed (CI has them all: there a missing one fails);
otherwise the test skips and says why.  The namespaces
are removed whatever happens.  Waits are bounded; no wall time is asserted.
"""

from __future__ import annotations

import contextlib
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

HERE = Path(__file__).resolve().parent
POINTAT = Path(sys.executable).with_name("pointat")
#: The longest the whole exchange is waited for (seconds): three processes start, the bus names them,
#: the maps are made and a few seconds of values pass.
WAIT = 120.0
HOSTS = ("a", "b", "c")


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, timeout=30)


def _netns_usable() -> str | None:
    """Why namespaces (and the bus) cannot be made here, or None."""
    if importlib.util.find_spec("libmapper") is None:
        return "the mapper extra is not installed (pip install 'pointat[mapper]')"
    if os.geteuid() != 0:
        return "network namespaces need root"
    if shutil.which("ip") is None:
        return "the ip command (iproute2) is not installed"
    probe = f"ptprobe{os.getpid()}"
    made = subprocess.run(["ip", "netns", "add", probe], capture_output=True, text=True, timeout=30)
    if made.returncode != 0:
        return f"ip netns add does not work here: {made.stderr.strip()}"
    subprocess.run(["ip", "netns", "del", probe], capture_output=True, timeout=30)
    return None


@contextlib.contextmanager
def bridged_hosts() -> Iterator[dict[str, tuple[str, str]]]:
    """Namespaces ``{host: (namespace, interface)}`` joined by a bridge in a namespace of its own."""
    stem = f"pt{os.getpid()}"
    bridge = stem + "br"
    made: list[str] = []
    try:
        _ip("netns", "add", bridge)
        made.append(bridge)
        _ip("-n", bridge, "link", "add", "br0", "type", "bridge")
        hosts = {}
        for k, host in enumerate(HOSTS):
            ns, iface = stem + host, f"e{host}"
            _ip("netns", "add", ns)
            made.append(ns)
            _ip("-n", ns, "link", "set", "lo", "up")
            _ip("-n", bridge, "link", "add", f"v{host}", "type", "veth", "peer", "name", iface)
            _ip("-n", bridge, "link", "set", iface, "netns", ns)
            _ip("-n", bridge, "link", "set", f"v{host}", "master", "br0")
            _ip("-n", bridge, "link", "set", f"v{host}", "up")
            _ip("-n", ns, "addr", "add", f"10.248.0.{k + 2}/24", "dev", iface)
            _ip("-n", ns, "link", "set", iface, "up")
            hosts[host] = (ns, iface)
        _ip("-n", bridge, "link", "set", "br0", "up")
        yield hosts
    finally:
        for ns in reversed(made):
            subprocess.run(["ip", "netns", "del", ns], capture_output=True, timeout=30)


class Host:
    """A process in a namespace whose output lines are gathered as they come."""

    def __init__(self, ns: str, argv: list[str], cwd: Path):
        self.lines: list[str] = []
        self.proc = subprocess.Popen(
            ["ip", "netns", "exec", ns, *argv],
            cwd=cwd,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=15)
        self._reader.join(timeout=5)


RECEIVER = """\
# host B: a mapping whose top is set from the bus
node m     map
node show  print prefix=mapped
m -> show
"""


def test_a_map_from_glove_a_to_patch_b_made_by_a_plain_client_carries_the_expression(tmp_path, require_tool):
    why = _netns_usable()
    require_tool(why is None, str(why))
    (tmp_path / "receiver.pat").write_text(RECEIVER)
    run = [str(POINTAT), "run", "--status", "0", "--for", str(WAIT)]
    with bridged_hosts() as hosts:
        started: list[Host] = []
        try:
            a = Host(
                hosts["a"][0],
                [*run, "glove_tqt", "--mapper", hosts["a"][1], "--mapper-name", "gloveA"],
                tmp_path,
            )
            started.append(a)
            b = Host(
                hosts["b"][0],
                [*run, "receiver.pat", "--mapper", hosts["b"][1], "--mapper-name", "receiver"],
                tmp_path,
            )
            started.append(b)
            client = [sys.executable, str(HERE / "mapper_client.py"), hosts["c"][1]]
            c = Host(hosts["c"][0], [*client, "gloveA/out/azimuth", "receiver/m/out_hi", "y=x*0.5"], tmp_path)
            started.append(c)
            told = re.compile(r"live control: /pointat/m/out_hi (\S+)")
            deadline = time.monotonic() + WAIT
            while sum(1 for line in b.lines if told.search(line)) < 4:
                gone = [h for h in started if h.proc.poll() is not None]
                if gone or time.monotonic() > deadline:
                    pytest.fail(
                        "B was not set through the map"
                        + (f" (a host ended: {[h.proc.args for h in gone]})" if gone else f" within {WAIT} s")
                        + "\nA: "
                        + "\n".join(a.lines[-15:])
                        + "\nB: "
                        + "\n".join(b.lines[-15:])
                        + "\nC: "
                        + "\n".join(c.lines[-5:])
                    )
                time.sleep(0.2)
        finally:
            for h in started:
                h.stop()
    events = [json.loads(line) for line in c.lines if line.startswith("{")]
    assert {"asked": "y=x*0.5"} in events, c.lines[:5]
    seen = [e["x"] for e in events if "x" in e]
    set_in_b = [float(m.group(1)) for line in b.lines if (m := told.search(line))]
    assert len(seen) > 10 and len(set(set_in_b)) > 1, (seen[:5], set_in_b)
    for value in set_in_b:  # each one half an azimuth the client saw (7 digits as the console tells it)
        nearest = min(seen, key=lambda x: abs(0.5 * x - value))
        assert 0.5 * nearest == pytest.approx(value, abs=1e-4), (value, nearest)
    assert all(-180.0 <= x <= 180.0 for x in seen)
