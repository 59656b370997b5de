"""Hot reload (pointat.reload): a patch edited while a simulated glove streams to a real UDP receiver.

The runtime runs on its logical clock; the reload is made between two ``advance`` calls (or two mote
frames), as the scheduler's thread makes it between two samples.  What the receiver got is compared with a run of the
same patch left unedited: every sample index once, and the same directions, bit for bit.
"""

from __future__ import annotations

import gzip
import os
import socket
from pathlib import Path

import numpy as np
import pytest

from pointat.checking import check
from pointat.compiled import build
from pointat.control import control
from pointat.devices.mote_frame import Frame
from pointat.devices.osc_wire import decode_packet, encode_message
from pointat.errors import Where
from pointat.expansion import read_spec
from pointat.loader import ready
from pointat.monitor.observe import Observer
from pointat.monitor.oscquery import address_space, find
from pointat.node import Inlet, Node, Outlet
from pointat.reload import Reloader, plan
from pointat.testing import test_registry, wait_until


class Count(Node):
    """How many messages came so far (a sample index the receiver can check)."""

    type_name = "count"
    inlets = (Inlet("in", ("any",), "anything"),)
    outlets = (Outlet("n", "int", "how many so far"),)

    def setup(self) -> None:
        self.n = 0

    def on_in(self, msg) -> None:
        self.n += 1
        self.out(0, self.n)


def registry():
    reg = test_registry()
    reg.add(Count, "tests.engine.test_reload")
    return reg


PATCH = """\
node glove  simulate rate=100 output=direct seed=3
node nulls  offset samples=20
node units  scaling
node fuse   tqt rate=100
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


class Receiver:
    """A UDP socket on a free port of 127.0.0.1: what came, as (address, arguments)."""

    def __init__(self):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 22)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.setblocking(False)
        self.port = self.sock.getsockname()[1]
        self.got: list[tuple[str, list]] = []

    def read(self) -> None:
        while True:
            try:
                data = self.sock.recv(65536)
            except BlockingIOError:
                return
            self.got += decode_packet(data)

    def indices(self) -> list[int]:
        return [args[0] for address, args in self.got if address == "/idx"]

    def directions(self) -> list[tuple[float, ...]]:
        return [tuple(args) for address, args in self.got if address.endswith("/aed")]


def start(path: Path):
    reg = registry()
    checked, rt = ready(read_spec(path), reg, realtime=False)
    reloader = Reloader(rt, checked, lambda: check(read_spec(path), reg, read_files=True), path=path)
    rt.reloader = reloader
    return rt, reloader


def run(path: Path, rx: Receiver, edits: dict[int, str], steps: int = 300):
    """Advance 10 ms at a time; before step k, write edits[k] into the patch file and reload."""
    rt, reloader = start(path)
    results = {}
    try:
        for k in range(steps):
            if k in edits:
                path.write_text(edits[k])
                results[k] = (reloader.reload(), list(reloader.problems))
            rt.advance(0.01)
            rx.read()
    finally:
        rt.shutdown()
    rx.read()
    return rt, reloader, results


@pytest.fixture
def receivers():
    made = []

    def make():
        made.append(Receiver())
        return made[-1]

    yield make
    for r in made:
        r.sock.close()


def test_an_edited_patch_loses_no_sample_and_its_direction_does_not_jump(tmp_path, receivers):
    plain_rx, edited_rx = receivers(), receivers()
    plain = tmp_path / "plain.pat"
    plain.write_text(PATCH.format(port=plain_rx.port))
    run(plain, plain_rx, {})

    edited = tmp_path / "edited.pat"
    text = PATCH.format(port=edited_rx.port)
    edited.write_text(text)
    with_print = text + "node slow speedlim 200\nnode show print prefix=az\ndir.azimuth -> slow -> show\n"
    bundled = with_print.replace(f"port={edited_rx.port}\n", f"port={edited_rx.port} bundle=true\n", 1)
    broken = bundled + "node oops nosuchtype\n"
    rt, reloader, results = run(edited, edited_rx, {100: with_print, 150: bundled, 200: broken, 250: bundled})
    assert {k: ok for k, (ok, _) in results.items()} == {100: True, 150: True, 200: False, 250: True}

    n = len(plain_rx.indices())
    assert n == 300
    assert edited_rx.indices() == list(range(1, n + 1))  # none lost, none twice
    # the same directions, bit for bit: the filter kept its state through the swaps (the new osc_out
    # sends the same floats in a bundle)
    assert edited_rx.directions() == plain_rx.directions()
    assert len(edited_rx.directions()) > 250
    # the broken edit: refused, said with its file and line, the patch ran on
    assert reloader.refused == 1
    problems = results[200][1]
    assert [p.where for p in problems] == [Where(str(edited), broken.count("\n"))]
    assert "unknown node type 'nosuchtype'" in problems[0].message
    assert "oops" not in rt.nodes and "show" in rt.nodes


def test_unchanged_nodes_keep_their_objects_live_changes_retune_others_are_made_anew(tmp_path, receivers):
    rx = receivers()
    path = tmp_path / "p.pat"
    text = PATCH.format(port=rx.port)
    path.write_text(text)
    rt, reloader = start(path)
    try:
        rt.advance(0.5)
        before = dict(rt.nodes)
        fuse = before["fuse"]
        assert fuse.p.k_heading != 0.5
        edited = text.replace("node fuse   tqt rate=100", "node fuse   tqt rate=100 k_heading=0.5")
        edited = edited.replace("node nulls  offset samples=20", "node nulls  offset samples=30")
        edited = edited.replace("glove.adc -> n -> idx\n", "").replace("node n      count\n", "")
        edited = edited.replace(f"node idx    osc_send address=/idx port={rx.port}\n", "")
        path.write_text(edited)
        steps = plan(reloader.checked, check(read_spec(path), registry(), read_files=True))
        assert steps.keep == ["glove", "units", "dir", "out"]
        assert steps.retune == {"fuse": {"k_heading": 0.5}}
        assert steps.make == ["nulls"] and sorted(steps.drop) == ["idx", "n", "nulls"]
        assert reloader.reload()
        for name in ("glove", "units", "dir", "out", "fuse"):
            assert rt.nodes[name] is before[name]
        assert rt.nodes["fuse"].p.k_heading == 0.5
        assert rt.nodes["nulls"] is not before["nulls"] and rt.nodes["nulls"].p.samples == 30
        assert set(rt.nodes) == {"glove", "nulls", "units", "fuse", "dir", "out"}
        # the removed nodes are closed and hear nothing more; the kept source goes on
        counted = before["n"].n
        rx.read()
        rx.got.clear()
        rt.advance(0.5)  # (the new nulls average their 30 samples first)
        rx.read()
        assert before["n"].n == counted
        assert rx.directions() and not rx.indices()
        assert not any(t.node is before["idx"] and not t.cancelled for t in rt._timers)
    finally:
        rt.shutdown()


def test_a_new_node_that_cannot_start_is_said_and_left_out(tmp_path, receivers, caplog):
    rx = receivers()
    taken = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    taken.bind(("127.0.0.1", 0))
    path = tmp_path / "p.pat"
    text = PATCH.format(port=rx.port)
    path.write_text(text)
    rt, reloader = start(path)
    try:
        rt.advance(0.1)
        edited = text + f"node ctl osc_in port={taken.getsockname()[1]}\n"
        path.write_text(edited)
        assert reloader.reload()
        assert "ctl" not in rt.nodes
        line = f"{path}:{edited.count(chr(10))}: error: node 'ctl' (osc_in): cannot start"
        assert any(line in r.getMessage() for r in caplog.records)
        rx.read()
        got = len(rx.indices())
        rt.advance(0.1)
        rx.read()
        assert rx.indices()[got:] == list(range(got + 1, got + 11))
    finally:
        rt.shutdown()
        taken.close()


def test_reload_over_osc_asks_the_reloader_and_oscquery_lists_it(tmp_path, receivers):
    rx = receivers()
    path = tmp_path / "p.pat"
    path.write_text(PATCH.format(port=rx.port))
    rt, reloader = start(path)
    try:
        assert find(address_space(rt), "/pointat/patch/reload")["ACCESS"] == 2
        assert (
            control(rt, "/pointat/patch/reload", [1], 0.0) == "expected /pointat/patch/reload (no arguments)"
        )
        assert not reloader._wanted.is_set()
        assert control(rt, "/pointat/patch/reload", [], 0.0) is None
        assert reloader._wanted.is_set()
        rt.reloader = None
        assert "from a file" in control(rt, "/pointat/patch/reload", [], 0.0)
    finally:
        rt.shutdown()


def test_watch_reloads_a_file_saved_by_rename_on_a_running_patch(tmp_path, receivers):
    """Real time: the reloader's thread sees the save (an editor's write-then-rename) and the scheduler's
    thread swaps; then /pointat/patch/reload over UDP to the patch's osc_in reloads again; the receiver
    still gets every index once."""
    rx = receivers()
    path = tmp_path / "p.pat"
    text = PATCH.format(port=rx.port) + "node ctl osc_in port=0\n"
    path.write_text(text)
    reg = registry()
    checked, rt = ready(read_spec(path), reg)
    reloader = Reloader(rt, checked, lambda: check(read_spec(path), reg, read_files=True), watch=True)
    rt.reloader = reloader
    told: list[str] = []
    rt.console = told.append
    scheduler = rt.run_in_thread()
    reloader.start()
    try:
        assert wait_until(lambda: (rx.read(), len(rx.indices()) > 20)[1], timeout=20)
        saved = tmp_path / ".p.pat.swp"
        saved.write_text(text + "node show print prefix=x\ndir.azimuth -> show\n")
        os.replace(saved, path)
        assert wait_until(lambda: reloader.reloads == 1, timeout=20), reloader.problems
        got = len(rx.indices())
        assert wait_until(lambda: (rx.read(), len(rx.indices()) > got + 20)[1], timeout=20)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.sendto(encode_message("/pointat/patch/reload", []), rt.nodes["ctl"].address)
        assert wait_until(lambda: reloader.reloads == 2, timeout=20), reloader.problems
        got = len(rx.indices())
        assert wait_until(lambda: (rx.read(), len(rx.indices()) > got + 20)[1], timeout=20)
    finally:
        reloader.stop()
        rt.stop()
        scheduler.join(10)
    rx.read()
    assert any(line.startswith("reloaded p.pat: 9 nodes kept, 1 new (show)") for line in told)
    assert any(line.startswith("reloaded p.pat: 10 nodes kept") for line in told)  # (nothing changed)
    indices = rx.indices()
    assert indices == list(range(1, len(indices) + 1))


def test_a_save_that_lands_during_a_reload_is_reloaded_too(tmp_path):
    """An editor saving twice in quick succession: the second save lands while the first is read and
    swapped in.  The watcher compares the files with how they looked before the reload, so the second
    save is a change still to see and is reloaded too (it compared them with how they looked after, took
    the second save for the one loaded, and the patch ran the first until the next save)."""
    path = tmp_path / "p.pat"
    text = "node lb loadbang\nnode m metro 50\nnode c collect\nlb -> m\nm -> c\n"
    path.write_text(text)
    reg = registry()
    checked, rt = ready(read_spec(path), reg)
    reads: list[int] = []

    def read():
        got = check(read_spec(path), reg, read_files=True)
        reads.append(1)
        if len(reads) == 1:  # (the second save, while the first is being reloaded)
            path.write_text(text + "node second collect\nm -> second\n")
        return got

    reloader = Reloader(rt, checked, read, watch=True)
    rt.reloader = reloader
    rt.console = lambda line: None
    scheduler = rt.run_in_thread()
    reloader.start()
    try:
        path.write_text(text + "node first collect\nm -> first\n")
        assert wait_until(lambda: reloader.reloads == 2, timeout=20), (reloader.reloads, reloader.problems)
        assert "second" in rt.nodes and "first" not in rt.nodes
    finally:
        reloader.stop()
        rt.stop()
        scheduler.join(10)


COMPILED = """\
node base   mote ids=[1] rate=100
node nulls  offset samples=50
node units  scaling
node fuse   tqt rate=100 mode=robust
node ref    reference mode=heading
node dir    azi_ele
node roll   roll_distance
node out    osc_out host=127.0.0.1 port={port} source=1
base.m1 -> nulls -> units
units.mag -> fuse.mag
units.accel -> fuse.accel
units.range -> fuse.range
units.gyro -> fuse.gyro
fuse.quat -> ref
ref -> dir
ref -> roll
dir.elevation -> out.elevation
roll.distance -> out.distance
roll.azimuth -> out.azimuth
"""


def _glove_take(n: int) -> list[tuple[int, ...]]:
    data = Path(__file__).resolve().parents[2] / "pointat" / "data" / "glove_take.csv.gz"
    with gzip.open(data, "rt") as fh:
        counts = np.loadtxt(fh, delimiter=",", comments="#", skiprows=3)[:, 1:]
    return [tuple(int(c) for c in counts[k % len(counts)]) for k in range(n)]


def _compiled_run(path: Path, rx: Receiver, mode: str, edits: dict[int, str], counts: list) -> tuple:
    rt, reloader = start(path)
    rt.compiled = mode
    rt.start()
    fused_before = fused_after = 0
    try:
        for k, c in enumerate(counts):
            if k in edits:
                fused_before = (
                    sum(g.fused_frames for g in rt.compiled_chains.groups) if rt.compiled_chains else 0
                )
                path.write_text(edits[k])
                assert reloader.reload(), reloader.problems
            mote = rt.nodes["base"]
            mote._frame(Frame(1, k & 0xFFFF, c), 0.0, 1000.0 + k / 100.0)
            if mote._fused is not None:
                mote._fused.flush()
            rx.read()
        fused_after = sum(g.fused_frames for g in rt.compiled_chains.groups) if rt.compiled_chains else 0
    finally:
        rt.shutdown()
    rx.read()
    return rx.directions(), fused_before, fused_after


def test_a_compiled_chain_is_handed_back_and_fused_again_across_a_reload(tmp_path, receivers):
    build.chain_frames()  # (compiled once: seconds when the cache is cold)
    counts = _glove_take(900)
    plain_rx, fused_rx = receivers(), receivers()
    plain = tmp_path / "plain.pat"
    plain.write_text(COMPILED.format(port=plain_rx.port))
    want, _, none = _compiled_run(plain, plain_rx, "off", {}, counts)
    assert none == 0 and len(want) > 800

    path = tmp_path / "fused.pat"
    text = COMPILED.format(port=fused_rx.port)
    path.write_text(text)
    edited = text.replace("source=1\n", "source=1 status=0\n") + "node note msg hello\n"
    have, before, after = _compiled_run(path, fused_rx, "on", {400: edited}, counts)
    assert before > 300  # fused before the reload ...
    assert after > 450  # ... and again after it (new Chains: counted from the reload on)
    assert have == want  # every direction, bit for bit, as node by node without a reload


def test_the_observer_keeps_its_streams_and_taps_what_is_new(tmp_path, receivers):
    rx = receivers()
    path = tmp_path / "p.pat"
    text = PATCH.format(port=rx.port)
    path.write_text(text)
    rt, reloader = start(path)
    observer = Observer(rt, patch="p").attach()
    reloader.listen(observer.reattach)
    try:
        rt.advance(0.495)
        (stream,) = observer.streams
        assert stream.count == 50 and "fuse" not in observer.flags
        edited = text.replace(f"port={rx.port}\nnode n", f"port={rx.port} bundle=true\nnode n", 1)
        path.write_text(edited + "node fl print\nfuse.flags -> fl\n")  # osc_out anew, flags wired now
        assert reloader.reload()
        assert observer.streams == [stream]
        assert [p.node for p in observer.pointers] == [rt.nodes["out"]]
        assert "fuse" in observer.flags
        rt.advance(0.5)
        assert stream.count == 100  # the same tap, once: every sample counted, none twice
        assert observer.pointers[0].node.state[0] != 0.0
    finally:
        rt.shutdown()
