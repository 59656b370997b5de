"""pointat's ``vbap`` against real Pure Data + pd-vbap, over OSC on loopback.

A pointat patch streams a pointing sweep with ``osc_out profile=vbap`` to the shipped receiver patch
(``examples/pd/vbap_receiver.pd``, or ``vbap_receiver_3d.pd``) running in a headless Pd; the receiver's
``[vbap]`` sends each update's gains back (``/vbap/gains g1 g2 ...``) to a socket here, and they must
equal the gains of pointat's own ``vbap`` node in the same patch, for the same directions: 2-D exactly
(pd-vbap computes in float32: 1e-5), 3-D once pointat's triplets have been sent to Pd
(``ls-directions`` / ``ls-triplets``), spread included.

Pd is started with ``-nogui -noaudio -noprefs`` (never ``-batch``: it does not read sockets), on free
ports written into a copy of the receiver patch, and killed in a ``finally``.
"""

from __future__ import annotations

import glob
import os
import shutil
import socket
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from pythonosc.osc_message import OscMessage
from pythonosc.osc_message_builder import OscMessageBuilder

import pointat.nodes.spatial  # noqa: F401  (registers the vbap node)
from pointat.maths.vbap import make_layout, pd_messages, vbap_gains
from pointat.message import make
from pointat.testing import free_udp_port, patch

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples" / "pd"
PD = shutil.which("pd")
VBAP_DIRS = [
    "/usr/lib/pd/extra/vbap",
    "/usr/local/lib/pd/extra/vbap",
    "/usr/lib/pd-l2ork/extra/vbap",
    os.path.expanduser("~/Documents/Pd/externals/vbap"),
    os.path.expanduser("~/.local/lib/pd/extra/vbap"),
]
VBAP = next((d for d in VBAP_DIRS if glob.glob(os.path.join(d, "vbap.*"))), None)

RING = [0, 45, 90, 135, 180, -135, -90, -45]
DOME_AZ = RING + [45, 135, -135, -45]
DOME_EL = [0] * 8 + [45] * 4
TIMEOUT = 5.0  # seconds for any one reply from Pd


@pytest.fixture(autouse=True)
def _pd_and_vbap(require_tool):
    require_tool(PD is not None, "Pure Data (pd) is not installed")
    require_tool(VBAP is not None, "the pd-vbap external is not installed (Debian: pd-vbap)")


def _osc(address: str, args) -> bytes:
    b = OscMessageBuilder(address)
    for a in args:
        b.add_arg(float(a), "f")  # float32: Pd's oscparse rejects doubles
    return b.build().dgram


def pd_command(patch: Path) -> list[str]:
    """A headless Pd opening ``patch``, with the shipped abstractions on its path."""
    return [PD, "-nogui", "-noaudio", "-noprefs", "-stderr", "-path", str(EXAMPLES), "-open", str(patch)]


class PdReceiver:
    """A headless Pd running a copy of a shipped receiver patch on free ports; replies collected here."""

    def __init__(self, receiver: str, tmp: Path):
        self.rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.rx.bind(("127.0.0.1", 0))
        self.reply_port = self.rx.getsockname()[1]
        self.port = free_udp_port()
        text = (EXAMPLES / receiver).read_text()
        assert "vbap_osc 9000 1 0" in text, f"{receiver} no longer holds [vbap_osc 9000 1 0]"
        self.patch = tmp / receiver
        self.patch.write_text(text.replace("vbap_osc 9000 1 0", f"vbap_osc {self.port} 1 {self.reply_port}"))
        self.log = tmp / "pd.log"
        self.proc: subprocess.Popen | None = None
        self.tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)

    def start(self) -> None:
        with open(self.log, "wb") as log:
            self.proc = subprocess.Popen(
                pd_command(self.patch), stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT
            )
        self.gains()  # the receiver's loadbang sets the layout and bangs [vbap]: Pd is listening

    def send(self, address: str, args) -> None:
        self.tx.sendto(_osc(address, args), ("127.0.0.1", self.port))

    def gains(self) -> np.ndarray:
        """The next /vbap/gains message from Pd."""
        deadline = time.monotonic() + TIMEOUT
        while time.monotonic() < deadline:
            if self.proc is not None and self.proc.poll() is not None:
                pytest.fail(f"Pd exited with {self.proc.returncode}:\n{self.log.read_text()}")
            self.rx.settimeout(0.1)
            try:
                data, _ = self.rx.recvfrom(65536)
            except TimeoutError:
                continue
            msg = OscMessage(data)
            if msg.address == "/vbap/gains":
                return np.array(msg.params, dtype=float)
        pytest.fail(f"no /vbap/gains from Pd within {TIMEOUT} s; Pd said:\n{self.log.read_text()}")

    def problems(self) -> list[str]:
        text = self.log.read_text(errors="replace")
        return [ln for ln in text.splitlines() if "couldn't create" in ln or ln.startswith("error")]

    def close(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=3)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=3)
        self.rx.close()
        self.tx.close()


@pytest.fixture
def pd_receiver(tmp_path):
    made: list[PdReceiver] = []

    def start(receiver: str) -> PdReceiver:
        pd = PdReceiver(receiver, tmp_path)
        made.append(pd)
        pd.start()
        return pd

    try:
        yield start
    finally:
        for pd in made:
            pd.close()


def _pointat_sender(layout_param: str, port: int):
    """The pointat side: one direction list -> the vbap node and osc_out profile=vbap (to Pd)."""
    rt = patch(f"""
node src  unpack f f f
node spk  vbap layout={layout_param}
node out  osc_out profile=vbap port={port}
node got  collect
src.2 -> spk.spread
src.2 -> out.spread
src.1 -> spk.elevation
src.1 -> out.elevation
src.0 -> spk.azimuth
src.0 -> out.azimuth
spk.gains -> got
""")
    rt.start()
    return rt


def _sweep(rt, pd: PdReceiver, directions) -> tuple[np.ndarray, np.ndarray]:
    ours, theirs = [], []
    for az, el, spread in directions:
        rt.nodes["src"].receive(0, make((float(az), float(el), float(spread))))
        theirs.append(pd.gains())
        ours.append(np.asarray(rt.nodes["got"].values[-1]))
    return np.array(ours), np.array(theirs)


def test_2d_ring_gains_equal_pd_vbap(pd_receiver):
    pd = pd_receiver("vbap_receiver.pd")
    rt = _pointat_sender("[" + ", ".join(map(str, RING)) + "]", pd.port)
    rng = np.random.default_rng(7)
    directions = [(az, 0.0, 0.0) for az in np.arange(-180.0, 180.1, 7.5)]
    directions += [(az, 10.0, 0.0) for az in (-170.5, -12.25, 33.0)]  # elevation is ignored in 2-D
    directions += [
        (np.round(az * 64) / 64, 0.0, s)  # float32-exact angles
        for az, s in zip(
            rng.uniform(-180, 180, 36), [1, 5, 15, 30, 45, 60, 70, 80, 95, 100] * 4, strict=False
        )
    ]
    try:
        ours, theirs = _sweep(rt, pd, directions)
    finally:
        rt.shutdown()
    assert ours.shape == theirs.shape == (len(directions), 8)
    np.testing.assert_allclose(ours, theirs, atol=1e-5, rtol=0)
    assert np.ptp(ours[:, 0]) > 0.99  # the sweep really moved the source round the ring
    assert pd.problems() == []


def test_3d_dome_gains_equal_pd_vbap_with_pointat_triplets(pd_receiver):
    pd = pd_receiver("vbap_receiver_3d.pd")
    layout = make_layout(DOME_AZ, DOME_EL)
    for selector, args in pd_messages(layout):  # pointat's triplets replace the patch's (the same ones)
        pd.send(f"/vbap/{selector}", args)
    pd.gains()  # after ls-triplets the receiver bangs [vbap]: the layout is in place
    pairs = "[" + ", ".join(f"[{a}, {e}]" for a, e in zip(DOME_AZ, DOME_EL, strict=True)) + "]"
    rt = _pointat_sender(pairs, pd.port)
    directions = [
        (az, el, 0.0) for el in (0.0, 7.5, 22.5, 30.0, 45.0, 67.5, 89.5) for az in range(-180, 180, 15)
    ]
    directions += [
        (az, el, s)
        for s, el in ((10, 20.0), (25, 40.0), (50, 60.0), (85, 12.5))
        for az in range(-170, 180, 40)
    ]
    try:
        ours, theirs = _sweep(rt, pd, directions)
    finally:
        rt.shutdown()
    assert ours.shape == theirs.shape == (len(directions), 12)
    np.testing.assert_allclose(ours, theirs, atol=1e-5, rtol=0)
    assert pd.problems() == []


def test_receiver_3d_patch_holds_pointats_triplets():
    """The dome receiver's built-in layout is pointat's triangulation, not pd-vbap's own."""
    layout = make_layout(DOME_AZ, DOME_EL)
    text = (EXAMPLES / "vbap_receiver_3d.pd").read_text()
    for selector, args in pd_messages(layout):
        assert f"{selector} {' '.join(str(a) for a in args)}" in text


def test_vbap_osc_inlet_takes_a_source_numbered_as_a_float_as_the_readme_says(tmp_path):
    """``[1 az el spread(`` into the left inlet of ``[vbap_osc 0 1 REPLY]`` (examples/pd/README.md): a source
    number that is a float, as a message box has it, and not only the symbol ``[oscparse]`` gives."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as rx:
        rx.bind(("127.0.0.1", 0))
        rx.settimeout(0.2)
        patch_file = tmp_path / "inlet.pd"
        patch_file.write_text(
            "#N canvas 0 50 450 300 10;\n#X obj 20 20 loadbang;\n"
            r"#X msg 20 50 define_loudspeakers 2 -45 45 \, 2 -30 0 0 \, 1 30 0 0 \, 1 -10 0 0;"
            f"\n#X obj 20 80 vbap_osc 0 1 {rx.getsockname()[1]};\n#X connect 0 0 1 0;\n#X connect 1 0 2 0;\n"
        )
        proc = subprocess.Popen(
            pd_command(patch_file), stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT
        )
        got: list[list[float]] = []
        try:
            deadline = time.monotonic() + TIMEOUT
            while len(got) < 3 and time.monotonic() < deadline:
                try:
                    got.append(OscMessage(rx.recvfrom(65536)[0]).params)
                except TimeoutError:
                    continue
        finally:
            proc.terminate()
            said = proc.communicate(timeout=5)[0].decode(errors="replace")
    assert "error" not in said, said
    layout = make_layout([-45, 45])
    # the layout's own output, then source 1 at 30 and at -10; source 2 is not this receiver's
    assert len(got) == 3, (got, said)
    np.testing.assert_allclose(got[1], vbap_gains(layout, 30.0), atol=1e-5)
    np.testing.assert_allclose(got[2], vbap_gains(layout, -10.0), atol=1e-5)
