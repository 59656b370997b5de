"""osc_out against independent receivers, and the example patches end to end.

* ``oscdump`` (liblo, Debian ``liblo-tools``) prints every message it receives as
  ``<NTP time tag hex> <address> <type tags> <arguments>`` (floats ``%f``): each profile's addresses,
  type tags and values must come out exactly as promised.
* The PyPI ``adm-osc`` package (the ADM-OSC working group's own client/server) receives our ADM-OSC
  messages and decodes object, azimuth, elevation and distance.
* Every ``examples/*.pat`` written for a receiver passes ``pointat check`` and runs for 1 s with
  ``pointat run`` (both through subprocesses); with oscdump present they run into it, and each one's
  messages must arrive.

Needs: apt-get install liblo-tools; pip install adm-osc (skipped with the reason otherwise, failed where
POINTAT_REQUIRE_TOOLS=1).
"""

import importlib.util
import math
import os
import queue
import shutil
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from pointat.message import make
from pointat.osc_bridge.profiles import PROFILES
from pointat.testing import beside, free_udp_port, patch

ROOT = Path(__file__).resolve().parents[2]
NTP_UNIX = 2208988800
OSCDUMP_MISSING = "oscdump not found (Debian/Ubuntu: apt-get install liblo-tools)"
ADM_OSC_MISSING = "the adm-osc package is not installed (pip install adm-osc)"


class OscDump:
    """A running ``oscdump -L PORT``; its stdout lines are parsed into (time, address, tags, args)."""

    def __init__(self) -> None:
        for _ in range(3):  # a free port can be taken between our probe and oscdump's bind: retry
            self.port = free_udp_port()
            self.proc = subprocess.Popen(
                ["oscdump", "-L", str(self.port)],
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
            )
            self.lines: queue.Queue = queue.Queue()
            threading.Thread(target=self._read, daemon=True).start()
            if self._ready():
                return
            self.close()
        raise RuntimeError("oscdump did not start")

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.put(line.rstrip("\n"))

    def _ready(self) -> bool:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            for _ in range(100):
                if self.proc.poll() is not None:
                    return False
                s.sendto(b"/ready\x00\x00,\x00\x00\x00", ("127.0.0.1", self.port))
                try:
                    if self.lines.get(timeout=0.05).split()[1] == "/ready":
                        self.drain(0.05)
                        return True
                except queue.Empty:
                    continue
        return False

    def read(self, n: int, timeout: float = 2.0) -> list[tuple[float, str, str, list]]:
        out = []
        deadline = time.monotonic() + timeout
        while len(out) < n and (left := deadline - time.monotonic()) > 0:
            try:
                out.append(self.parse(self.lines.get(timeout=left)))
            except queue.Empty:
                break
        return out

    def drain(self, quiet: float = 0.1) -> list[tuple[float, str, str, list]]:
        out = []
        while True:
            try:
                out.append(self.parse(self.lines.get(timeout=quiet)))
            except queue.Empty:
                return out

    @staticmethod
    def parse(line: str) -> tuple[float, str, str, list]:
        stamp, address, *rest = line.split(" ")
        tags, args = (rest[0], rest[1:]) if rest else ("", [])
        sec, frac = (int(x, 16) for x in stamp.split("."))
        values = [
            int(a) if t == "i" else float(a) if t in "fd" else a for t, a in zip(tags, args, strict=True)
        ]
        return sec - NTP_UNIX + frac / 2**32, address, tags, values

    def close(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(timeout=3)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()


@pytest.fixture(scope="module")
def dump():
    """One oscdump for the module; ``None`` when it is not installed (tests then call require_tool)."""
    if shutil.which("oscdump") is None:
        yield None
        return
    d = OscDump()
    yield d
    d.close()


@pytest.fixture
def oscdump(dump, require_tool):
    require_tool(dump is not None, OSCDUMP_MISSING)
    dump.drain(0.02)
    return dump


def push(node, az, el=0.0, dist=0.0, spread=0.0):
    for inlet, value in ((3, spread), (2, dist), (1, el)):
        node.receive(inlet, make(float(value)))
    node.receive(0, make(float(az)))


# --------------------------------------------------------------------------- oscdump, profile by profile
C10, S10, C30 = math.cos(math.radians(10)), math.sin(math.radians(10)), math.cos(math.radians(30))
# azimuth 30 (left), elevation 10, roll distance 45, spread 20 -> what each receiver must see
PROMISED = {
    "pointat": [("/pointat/1/aed", "fff", [30.0, 10.0, 0.5])],
    "vbap": [("/vbap/1", "fff", [30.0, 10.0, 20.0])],
    "adm": [("/adm/obj/1/aed", "fff", [30.0, 10.0, 0.5])],
    "iem_stereo": [("/StereoEncoder/azimuth", "f", [30.0]), ("/StereoEncoder/elevation", "f", [10.0])],
    "iem_multi": [("/MultiEncoder/azimuth0", "f", [30.0]), ("/MultiEncoder/elevation0", "f", [10.0])],
    "spat": [("/source/1/aed", "fff", [-30.0, 10.0, 1.5])],  # + right; radius=3 m below
    "icst": [("/icst/ambi/sourceindex/xyz", "ifff", [1, -0.25 * C10, 0.5 * C10 * C30, 0.5 * S10])],
    "reaper": [("/track/1/pan", "f", [1.0 / 3.0])],
    "generic": [("/pointat/1/direction", "ff", [30.0, 10.0])],
}


def test_every_profile_is_promised():
    assert set(PROMISED) == set(PROFILES)


@pytest.mark.parametrize("profile", sorted(PROMISED))
def test_oscdump_sees_each_profiles_addresses_type_tags_and_values(profile, oscdump, started):
    rt = started(patch(f"node out osc_out profile={profile} port={oscdump.port} radius=3"))
    push(rt.nodes["out"], 30.0, el=10.0, dist=45.0, spread=20.0)
    want = PROMISED[profile]
    got = oscdump.read(len(want))
    assert [(a, t) for _, a, t, _ in got] == [(a, t) for a, t, _ in want]
    for (*_, values), (*_, expected) in zip(got, want, strict=True):
        assert len(values) == len(expected)
        for v, e in zip(values, expected, strict=True):
            assert v == e if isinstance(e, int) else abs(v - e) <= 1e-6 + 1e-6 * abs(e), (values, expected)
    assert oscdump.drain(0.05) == []


def test_oscdump_sees_bundles_now_and_later(oscdump, started):
    rt = started(
        patch(
            f"node now osc_out profile=iem_stereo bundle=true port={oscdump.port}\n"
            f"node later osc_out profile=adm bundle=true delay=150 port={oscdump.port}\n"
        )
    )
    t0 = time.time()
    push(rt.nodes["now"], -20.0, el=5.0)
    push(rt.nodes["later"], 45.0)
    got = oscdump.read(3, timeout=3.0)
    assert [(a, t) for _, a, t, _ in got] == [
        ("/StereoEncoder/azimuth", "f"),
        ("/StereoEncoder/elevation", "f"),
        ("/adm/obj/1/aed", "fff"),  # liblo holds a future bundle until its time tag: it comes last
    ]
    assert got[0][0] == got[1][0]  # one bundle: one time tag for both
    assert abs(got[0][0] - t0) < 0.1  # "immediately": liblo stamps it with the time it arrived
    assert t0 + 0.15 - 0.01 <= got[2][0] <= time.time() + 0.01  # now + delay, as we stamped it
    assert [v for *_, v in got] == [[-20.0], [5.0], [45.0, 0.0, 1.0]]


# --------------------------------------------------------------------------- the adm-osc package
def test_adm_osc_package_decodes_our_objects_and_directions(require_tool, started):
    require_tool(importlib.util.find_spec("adm_osc") is not None, ADM_OSC_MISSING)
    import adm_osc

    class Probe(adm_osc.OscClientServer):
        def __init__(self) -> None:
            self.got: queue.Queue = queue.Queue()
            super().__init__(address="127.0.0.1", out_port=free_udp_port(), in_port=0)

        def on_received_message(self, target, objects, parameter, *args):
            self.got.put((target, objects, parameter.attribute, tuple(args)))

    probe = Probe()
    try:
        port = probe.server.server_address[1]
        rt = started(
            patch(
                f"node one osc_out profile=adm port={port}\n"
                f"node three osc_out profile=adm port={port} source=3 bundle=true\n"
            )
        )
        cases = [
            ("one", (30.0, 10.0, 45.0), (1, 30.0, 10.0, 0.5)),  # + left stays + left
            ("one", (-170.0, -20.0, 0.0), (1, -170.0, -20.0, 1.0)),  # far: on the loudspeakers
            ("one", (190.0, 0.0, 90.0), (1, -170.0, 0.0, 0.0)),  # wrapped; near: the centre
            ("three", (-90.0, 90.0, 30.0), (3, -90.0, 90.0, 2 / 3)),  # right, straight up; a bundle
            ("three", (180.0, -90.0, 120.0), (3, 180.0, -90.0, 0.0)),  # the range ends are legal
        ]
        for node, (az, el, dist), (obj, *aed) in cases:
            push(rt.nodes[node], az, el=el, dist=dist)
            target, objects, attribute, args = probe.got.get(timeout=2.0)
            assert (target, objects, attribute) == ("obj", obj, "aed")
            assert all(math.isclose(a, b, rel_tol=1e-6, abs_tol=1e-6) for a, b in zip(args, aed, strict=True))
    finally:
        probe.server.shutdown()
        probe.server.server_close()


# --------------------------------------------------------------------------- the example patches
EXAMPLES = {  # file -> the message its receiver must see
    "adm.pat": ("/adm/obj/1/aed", "fff"),
    "iem.pat": ("/StereoEncoder/azimuth", "f"),
    "spat.pat": ("/source/1/aed", "fff"),
    "reaper.pat": ("/track/1/pan", "f"),
    "icst.pat": ("/icst/ambi/sourceindex/xyz", "ifff"),
    "generic_osc.pat": ("/glove/1/direction", "fff"),
}


def _pointat(*args: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    return subprocess.Popen(
        [sys.executable, "-m", "pointat.cli", *args],
        cwd=ROOT,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


@pytest.fixture(scope="module")
def example_runs(dump):
    """Check and run every example at once (they are independent): {file: (check, run, dump lines)}."""
    files = {name: str(ROOT / "examples" / name) for name in EXAMPLES}
    checks = {name: _pointat("check", path) for name, path in files.items()}
    redirect = ["--set", f"out.port={dump.port}"] if dump is not None else []
    if dump is not None:
        dump.drain(0.02)
    runs = {
        name: _pointat("run", path, "--for", "1", *beside(path), *redirect) for name, path in files.items()
    }
    done = {}
    for name in files:
        check = checks[name].communicate(timeout=60)
        run = runs[name].communicate(timeout=60)
        done[name] = ((checks[name].returncode, *check), (runs[name].returncode, *run))
    lines = dump.drain(0.2) if dump is not None else []
    return done, lines


@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_example_checks_and_runs(name, example_runs):
    done, _ = example_runs
    (check_rc, check_out, check_err), (run_rc, _run_out, run_err) = done[name]
    assert check_rc == 0 and check_out.startswith(f"{ROOT / 'examples' / name}: ok"), check_err
    assert run_rc == 0, run_err
    assert "ERROR" not in run_err and "Traceback" not in run_err, run_err


@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_example_reaches_its_receiver(name, example_runs, require_tool, dump):
    require_tool(dump is not None, OSCDUMP_MISSING)
    _, lines = example_runs
    address, tags = EXAMPLES[name]
    mine = [(a, t) for _, a, t, _ in lines if a == address]
    assert mine, f"{name}: no {address} among {sorted({a for _, a, _, _ in lines})}"
    assert all(t == tags for _, t in mine)
