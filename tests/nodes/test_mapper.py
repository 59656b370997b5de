"""The ``mapper`` and ``mapper_in`` nodes on a real libmapper bus over loopback (``lo``), against a plain
libmapper device made here with the library's own Python binding.

Each test runs the patch on a manual clock and moves it on by hand while the library's devices talk
over the loopback interface; every wait is bounded (:data:`WAIT` seconds) and no wall time is asserted.
The bus across machines is :mod:`tests.integration.test_mapper_hosts`.
"""

from __future__ import annotations

import itertools
import subprocess
import sys
import time

import pytest

from pointat import mapper as bus
from pointat.errors import PointatError
from pointat.node import Node, Outlet
from pointat.testing import make, patch, test_registry

mpr = pytest.importorskip(
    "libmapper", reason="the mapper extra is not installed (pip install 'pointat[mapper]')"
)

#: The longest any condition is waited for (seconds of wall time; a device is ready in about one).
WAIT = 20.0
_names = itertools.count()


def unique(stem: str) -> str:
    """A device name no other test's device has (tests may share the loopback bus with a running show)."""
    return f"t{time.monotonic_ns() % 10**9}_{next(_names)}_{stem}"


class Client:
    """A plain libmapper device on ``lo``: what another program on the bus would be."""

    def __init__(self, name: str):
        self.graph = mpr.Graph(mpr.Type.DEVICE | mpr.Type.SIGNAL)
        self.graph.set_interface("lo")
        self.dev = mpr.Device(name, self.graph)
        self.got: list[tuple[str, object]] = []

    def incoming(self, name: str, length: int = 1, unit: str | None = None):
        def take(sig, _event, _inst, value, _time):
            self.got.append((sig[mpr.Property.NAME], value))

        return self.dev.add_signal(
            mpr.Signal.Direction.INCOMING,
            name,
            length,
            mpr.Type.FLOAT,
            unit,
            None,
            None,
            None,
            take,
            mpr.Object.Event.REMOTE_UPDATE,
        )

    def outgoing(self, name: str, length: int = 1):
        return self.dev.add_signal(mpr.Signal.Direction.OUTGOING, name, length, mpr.Type.FLOAT)

    def signal(self, device_prefix: str, name: str):
        for sig in bus.every(self.graph.signals()):
            owner = str(sig.device()[mpr.Property.NAME])
            if sig[mpr.Property.NAME] == name and owner.startswith(device_prefix + "."):
                return sig
        return None

    def close(self):
        self.dev.free()
        self.graph.free()


def until(rt, condition, client: Client | None = None, what: str = "") -> None:
    """Move the patch on 5 ms at a time, polling the client, until ``condition()`` (or fail naming it)."""
    deadline = time.monotonic() + WAIT
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail(f"not seen within {WAIT} s: {what}")
        rt.advance(bus.POLL)
        if client is not None:
            client.dev.poll(5)
        else:
            time.sleep(0.005)


@pytest.fixture
def client():
    made = []

    def make_client(stem="client"):
        c = Client(unique(stem))
        made.append(c)
        return c

    yield make_client
    for c in made:
        c.close()


def glove_patch(name: str):
    return patch(
        f"""
node q    msg 1 0 0 0
node ref  reference
node dir  azi_ele
node out  osc_out port=9
node bus  mapper interface=lo device={name}
q -> ref
ref -> dir
dir.elevation -> out.elevation
dir.azimuth -> out.azimuth
"""
    )


def test_a_pointer_is_published_with_its_unit_range_and_quaternion_and_a_map_carries_it(client):
    name = unique("glove")
    rt = glove_patch(name)
    try:
        c = client()
        rt.start()
        sigs: dict = {}
        names = ("out/azimuth", "out/elevation", "out/distance", "out/quat")
        until(rt, lambda: all([_found(sigs, c, name, s) for s in names]), c, "the glove's four signals")
        az = sigs["out/azimuth"]
        assert (az[mpr.Property.UNIT], az[mpr.Property.MIN], az[mpr.Property.MAX]) == ("deg", -180.0, 180.0)
        assert sigs["out/quat"][mpr.Property.LENGTH] == 4
        half = c.incoming("half")
        quat = c.incoming("quat", 4)
        maps = [mpr.Map("%y=%x*0.5", half, az), mpr.Map("%y=%x", quat, sigs["out/quat"])]
        for m in maps:
            m.push()
        until(rt, lambda: all(m.ready for m in maps), c, "the maps made")
        # a quarter turn about z (north-west-up): the hand points 90 deg to the left
        s = 0.5**0.5
        rt.nodes["ref"].receive(0, make((s, 0.0, 0.0, s)))
        until(rt, lambda: {n for n, _ in c.got} >= {"half", "quat"}, c, "the values through the maps")
        values = dict(c.got)
        assert values["half"] == pytest.approx(45.0, abs=1e-3)
        assert values["quat"] == pytest.approx([s, 0.0, 0.0, s], abs=1e-6)
    finally:
        rt.shutdown()


def test_a_live_parameter_is_an_incoming_signal_set_as_live_control_sets_it_and_refuses_what_does_not_fit(
    client,
):
    name = unique("recv")
    rt = patch(f"node p print decimals=1\nnode bus mapper interface=lo device={name}\n")
    try:
        c = client()
        rt.start()
        box: dict = {}
        until(rt, lambda: _found(box, c, name, "p/decimals"), c, "the parameter's signal")
        decimals = box["p/decimals"]
        assert (decimals[mpr.Property.TYPE], decimals[mpr.Property.MIN], decimals[mpr.Property.MAX]) == (
            mpr.Type.INT32,
            0,
            12,
        )
        fader = c.outgoing("fader")
        m = mpr.Map("%y=%x*0.5", decimals, fader)
        m.push()
        until(rt, lambda: m.ready, c, "the map made")
        fader.set_value(10.0)
        c.dev.update_maps()
        until(rt, lambda: rt.nodes["p"].p.decimals == 5, c, "the parameter set through the map")
        fader.set_value(40.0)  # 20: beyond the parameter's 0..12
        c.dev.update_maps()
        until(rt, lambda: rt.nodes["bus"].refused == 1, c, "the value refused")
        assert rt.nodes["p"].p.decimals == 5
        assert rt.nodes["bus"].health()["taken"] == 1
    finally:
        rt.shutdown()


def _found(box: dict, c: Client, device: str, name: str) -> bool:
    if box.get(name) is None:
        box[name] = c.signal(device, name)
    return box[name] is not None


def test_mapper_in_maps_the_named_source_itself_and_sends_its_values(client):
    c = client("source")
    level = c.outgoing("level")
    deadline = time.monotonic() + WAIT
    while not c.dev.ready and time.monotonic() < deadline:
        c.dev.poll(10)
    assert c.dev.ready, f"the client not on the bus within {WAIT} s"
    source = f"{c.dev[mpr.Property.NAME]}/level"
    rt = patch(
        f"node in mapper_in interface=lo source={source} device={unique('in')}\nnode got collect\nin -> got\n"
    )
    try:
        rt.start()
        until(rt, lambda: rt.nodes["in"].mapped, c, "the map made by mapper_in")
        until(rt, lambda: any(m.ready for m in bus.every(level.maps())), c, "the map known at the source")
        level.set_value(0.75)
        c.dev.update_maps()
        until(rt, lambda: rt.nodes["got"].values, c, "the value in the patch")
        assert rt.nodes["got"].values == [pytest.approx(0.75)]
    finally:
        rt.shutdown()


def test_an_interface_that_is_not_there_is_said_not_taken_for_another(started):
    rt = patch("node bus mapper interface=nosuch0")
    with pytest.raises(PointatError, match="no network interface 'nosuch0'"):
        started(rt)


class _Segment:
    def __init__(self, name: str):
        self.name = name


class Events(Node):
    """A third party's node: events and segments declared by their outlets' names, as the built-ins'."""

    type_name = "events"
    outlets = (
        Outlet("gesture", "list", "LABEL SCORE"),
        Outlet("posture", "symbol", "LABEL"),
        Outlet("none", "bang", "no posture"),
        Outlet("stroke", "list", "AZIMUTH ELEVATION STRENGTH"),
        Outlet("segments", "vector", "4M numbers"),
    )

    def setup(self) -> None:
        self.body = type("Body", (), {"segments": [_Segment("upper arm"), _Segment("hand")]})()


def test_events_and_segments_are_signals_found_by_their_outlets_names_labels_made_as_they_come(client):
    registry = test_registry()
    registry.add(Events, "tests")
    name = unique("events")
    rt = patch(f"node ev events\nnode bus mapper interface=lo device={name}\n", registry=registry)
    try:
        c = client()
        rt.start()
        ev = rt.nodes["ev"]
        ev.out(0, ("big circle", 0.8))  # a label's signal is made as the label first comes
        ev.out(1, "open")
        ev.out(4, (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0))
        wanted = {
            "ev/big_circle": 1,
            "ev/open": 1,
            "ev/stroke": 3,
            "ev/upper_arm": 4,
            "ev/hand": 4,
        }
        sigs: dict = {}
        until(rt, lambda: all([_found(sigs, c, name, s) for s in wanted]), c, "the event signals")
        assert {s: sigs[s][mpr.Property.LENGTH] for s in wanted} == wanted
        assert sigs["ev/big_circle"][mpr.Property.UNIT] == "score"
        maps = [mpr.Map(sigs[s], c.incoming(s.replace("/", "_"), n)) for s, n in wanted.items()]
        for m in maps:
            m.push()
        until(rt, lambda: all(m.ready for m in maps), c, "the maps made")
        ev.out(0, ("big circle", 0.5))
        ev.out(1, "open")
        ev.out(3, (30.0, -10.0, 2.5))
        ev.out(4, (0.0, 1.0, 0.0, 0.0, 0.5, 0.5, 0.5, 0.5))
        until(rt, lambda: len({n for n, _ in c.got}) == 5, c, "a value from each")
        values = dict(c.got)
        ev.out(2, None)  # the hand leaves every posture: the one it held goes to 0
        until(rt, lambda: ("ev_open", 0.0) in c.got, c, "the posture left")
        assert values["ev_big_circle"] == pytest.approx(0.5)
        assert values["ev_stroke"] == pytest.approx([30.0, -10.0, 2.5])
        assert values["ev_upper_arm"] == pytest.approx([0.0, 1.0, 0.0, 0.0])
        assert values["ev_hand"] == pytest.approx([0.5, 0.5, 0.5, 0.5])
        assert [v for n, v in c.got if n == "ev_open"] == [1.0, 0.0]
    finally:
        rt.shutdown()


def test_without_the_extra_the_bus_says_which_to_install_and_a_patch_without_it_never_imports_it(monkeypatch):
    monkeypatch.setitem(sys.modules, "libmapper", None)  # (import libmapper raises ImportError)
    with pytest.raises(PointatError, match=r"pip install 'pointat\[mapper\]'"):
        bus.load()
    rt = patch("node bus mapper interface=lo")
    with pytest.raises(PointatError, match=r"node 'bus' \(mapper\): cannot start: .*pointat\[mapper\]"):
        rt.start()
    found = subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys, pointat.cli, pointat.registry as r; r.default_registry.load_builtins(); "
            "print('libmapper' in sys.modules)",
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert found.stdout.strip() == "False", found.stderr


def test_two_values_of_a_signal_before_a_flush_both_leave(client):
    """libmapper keeps a signal's latest value until it sends: two datagrams read in one pass would lose
    the first without the device's flush in between."""
    device = bus.Device(unique("twice"), "lo")
    try:
        c = client()
        sig = device.add(bus.SignalSpec("x"))
        got = c.incoming("x")
        deadline = time.monotonic() + WAIT
        src = None
        while src is None or not (device.ready and c.dev.ready):
            assert time.monotonic() < deadline, "the device not on the bus"
            device.poll()
            c.dev.poll(5)
            src = src or c.signal(device.name.rpartition(".")[0], "x")
        m = mpr.Map(src, got)
        m.push()
        while not m.ready:
            assert time.monotonic() < deadline, "the map not made"
            device.poll()
            c.dev.poll(5)
        device.set(sig, 1.0)
        device.set(sig, 2.0)
        device.flush()
        while len(c.got) < 2 and time.monotonic() < deadline:
            device.poll()
            c.dev.poll(5)
        assert [v for _n, v in c.got] == [1.0, 2.0]
    finally:
        device.close()


def test_pointat_run_mapper_joins_the_bus_and_a_missing_interface_is_an_error_said_plainly(tmp_path, capsys):
    from pointat.cli import main

    pat = tmp_path / "two.pat"
    pat.write_text("node lb loadbang\nnode m msg 1\nnode p print\nlb -> m -> p\n")
    name = unique("cli")
    assert (
        main(["run", str(pat), "--mapper", "lo", "--mapper-name", name, "--for", "1.5", "--status", "0"]) == 0
    )
    assert "mapper:" in capsys.readouterr().out  # (its health in the summary)
    assert main(["run", str(pat), "--mapper", "nosuch0", "--for", "1"]) != 0
    assert "no network interface 'nosuch0'" in capsys.readouterr().err


def test_after_a_reload_the_bus_has_the_new_nodes_signals_and_each_outlet_one_tap(tmp_path, client):
    from pointat.checking import check
    from pointat.expansion import read_spec
    from pointat.loader import ready
    from pointat.node import Tap
    from pointat.reload import Reloader

    path = tmp_path / "p.pat"
    text = "node t trigger f\nnode out osc_out port=9\nt -> out.azimuth\n"
    path.write_text(text)
    reg = test_registry()
    checked, rt = ready(read_spec(path), reg, realtime=False)
    rt.reloader = Reloader(rt, checked, lambda: check(read_spec(path), reg, read_files=True), path=path)
    name = unique("reload")
    bus_node = rt.add(reg.get("mapper")("mapper", {"interface": "lo", "device": name}))
    try:
        c = client()
        rt.start()
        path.write_text(
            text.replace("node out", "node aim").replace("-> out", "-> aim") + "node p print decimals=1\n"
        )
        assert rt.reloader.reload(), rt.reloader.problems
        assert rt.nodes["mapper"] is bus_node
        sigs: dict = {}
        until(rt, lambda: all([_found(sigs, c, name, s) for s in ("aim/azimuth", "p/decimals")]), c, "new")
        taps = [d for d, _ in rt.nodes["t"].targets(0) if isinstance(d, Tap)]
        assert len(taps) == 1
        got = c.incoming("aim")
        m = mpr.Map(sigs["aim/azimuth"], got)
        m.push()
        until(rt, lambda: m.ready, c, "the map")
        rt.nodes["t"].receive(0, make(12.5))
        until(rt, lambda: c.got, c, "the value through the new node")
        assert c.got == [("aim", 12.5)]
    finally:
        rt.shutdown()
