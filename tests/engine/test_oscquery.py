"""The OSCQuery server of a running patch, in process, over real sockets on 127.0.0.1: the address space
(types, ranges, units, values), attribute queries, live control by OSC (its UDP port, a WebSocket) and
the refusals; and what the observer reads for it (streams, dropouts, flags, pointers, layout)."""

from __future__ import annotations

import json
import socket
import threading
import time
import urllib.error
import urllib.request

import pytest
from pythonosc.udp_client import SimpleUDPClient

from pointat.checking import check
from pointat.devices.osc_wire import decode_packet, encode_message
from pointat.expansion import read_spec
from pointat.loader import build, parse_overrides
from pointat.monitor.observe import Observer
from pointat.monitor.oscquery import address_space, find, value_of
from pointat.monitor.webserver import MonitorServer
from pointat.patchfile import parse_patch
from pointat.presets import Presets
from pointat.registry import Registry
from tests.monitor_client import ws_connect, ws_receive, ws_send

REG = Registry().load_builtins()

PATCH = """\
# A glove and a vbap node.
node glove simulate rate=100 output=direct noise=false
node nulls offset samples=20
node units scaling
node fuse  tqt rate=100
node dir   azi_ele
node pan   vbap layout=[30, -30, 110, -110]
node out   osc_out port={port} rate=50
glove.adc -> nulls -> units
units.mag -> fuse.mag
units.accel -> fuse.accel
units.gyro -> fuse.gyro
fuse.flags -> out.flags
fuse -> dir
dir.elevation -> out.elevation
dir.elevation -> pan.elevation
dir.azimuth -> out.azimuth
dir.azimuth -> pan.azimuth
"""


def _get(url: str):
    with urllib.request.urlopen(url, timeout=5) as r:
        body = r.read()
        return r.status, json.loads(body) if body else None


@pytest.fixture
def served(tmp_path):
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    path = tmp_path / "glove.pat"
    path.write_text(PATCH.format(port=rx.getsockname()[1]))
    rt = build(check(read_spec(str(path)), REG, parse_overrides([])))
    rt.presets = Presets(rt, tmp_path / "glove.presets.json")
    obs = Observer(rt, patch="glove").attach()
    server = MonitorServer(rt, obs, "127.0.0.1", 0, name="pointat test", advertise=False)
    server.start()
    th = rt.run_in_thread(30)
    obs.start()
    try:
        yield rt, obs, server, f"http://127.0.0.1:{server.port}"
    finally:
        obs.stop()
        rt.stop()
        th.join(5)
        server.close()
        rx.close()


def _settle(check, seconds=5.0):
    deadline = time.monotonic() + seconds
    while not check():
        assert time.monotonic() < deadline, "never happened"
        time.sleep(0.02)


def test_the_tree_describes_live_parameters_methods_and_directions(served):
    rt, _obs, server, url = served
    status, tree = _get(url + "/")
    assert status == 200 and tree["FULL_PATH"] == "/"
    k = find(tree, "/pointat/fuse/k")
    assert k["TYPE"] == "f" and k["ACCESS"] == 3 and k["VALUE"] == [rt.nodes["fuse"].p.k]
    rate = find(tree, "/pointat/out/rate")
    assert rate["UNIT"] == ["time.hz"] and rate["VALUE"] == [50.0]
    profile = find(tree, "/pointat/out/profile")
    assert profile is None  # not live: a receiver is chosen in the patch
    spread = find(tree, "/pointat/pan/spread")
    assert spread["TYPE"] == "f" and spread["ACCESS"] == 3
    recal = find(tree, "/pointat/nulls/recalibrate")
    assert recal["TYPE"] == "N" and recal["ACCESS"] == 2
    aed = find(tree, "/pointat/out/aed")
    assert aed["TYPE"] == "fff" and aed["ACCESS"] == 1
    assert find(tree, "/pointat/preset/save")["TYPE"] == "s"
    # what is there is exactly what is served node by node, and what value_of reads
    status, node = _get(url + "/pointat/fuse/k")
    assert node == k
    assert value_of(rt, "/pointat/out/rate") == [50.0]
    assert value_of(rt, "/pointat/nowhere/x") is None and value_of(rt, "/other") is None
    assert address_space(rt)["CONTENTS"]["pointat"]["CONTENTS"].keys() >= {"glove", "fuse", "out", "preset"}

    def walk(node, path):  # every entry says where it is (clients split FULL_PATH)
        assert node["FULL_PATH"] == (path or "/"), (path, node)
        for name, child in node.get("CONTENTS", {}).items():
            walk(child, f"{path}/{name}")
        assert "CONTENTS" in node or "TYPE" in node, path  # a container or a method

    walk(tree, "")


def test_host_info_and_attributes_as_the_proposal_asks(served):
    _rt, _obs, server, url = served
    _, info = _get(url + "/?HOST_INFO")
    assert info["OSC_PORT"] == server.osc_port and info["OSC_TRANSPORT"] == "UDP"
    assert info["EXTENSIONS"]["LISTEN"] is True and info["EXTENSIONS"]["VALUE"] is True
    _, value = _get(url + "/pointat/out/rate?VALUE")
    assert value == {"VALUE": [50.0]}
    with urllib.request.urlopen(url + "/pointat/out/rate?CRITICAL", timeout=5) as r:
        assert r.status == 204  # an attribute the node does not have
    with pytest.raises(urllib.error.HTTPError) as info:
        urllib.request.urlopen(url + "/pointat/no/such", timeout=5)
    assert info.value.code == 404


def test_a_value_set_by_osc_is_set_in_the_running_patch_and_bad_ones_are_refused(served, caplog):
    rt, _obs, server, url = served
    osc = SimpleUDPClient("127.0.0.1", server.osc_port)
    osc.send_message("/pointat/out/rate", 20.2)
    _settle(lambda: rt.nodes["out"].p.rate == 20.2)  # 20.2 as typed, not float32's 20.200000762939453
    _, value = _get(url + "/pointat/out/rate?VALUE")
    assert value == {"VALUE": [20.2]}
    with caplog.at_level("WARNING", logger="pointat.monitor"):
        osc.send_message("/pointat/out/rate", -5.0)  # below its range
        osc.send_message("/pointat/outt/rate", 5.0)  # no such node
        osc.send_message("/elsewhere", 1.0)  # not live control
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM).sendto(
            b"\x00garbage", ("127.0.0.1", server.osc_port)
        )
        osc.send_message("/pointat/nulls/recalibrate", [])  # a method with no values
        _settle(lambda: server.control_refused >= 4)
    assert rt.nodes["out"].p.rate == 20.2  # nothing bad was taken
    text = caplog.text
    assert "-5" in text and "no node 'outt'" in text and "did you mean 'out'" in text, text
    assert "/elsewhere refused" in text and "malformed" in text, text


def test_over_a_websocket_listen_streams_changes_and_binary_osc_sets_values(served):
    rt, _obs, server, _url = served
    s = ws_connect(server.port)
    try:
        ws_send(s, 1, json.dumps({"COMMAND": "LISTEN", "DATA": "/pointat/out/rate"}).encode())
        opcode, payload = ws_receive(s)
        assert opcode == 2 and decode_packet(payload) == [("/pointat/out/rate", [50.0])]
        # a value set another way reaches the listener as an OSC message
        SimpleUDPClient("127.0.0.1", server.osc_port).send_message("/pointat/out/rate", 25.0)
        opcode, payload = ws_receive(s)
        assert decode_packet(payload) == [("/pointat/out/rate", [25.0])]
        # and a binary OSC frame from the client sets one

        ws_send(s, 2, encode_message("/pointat/out/rate", [30.0]))
        _settle(lambda: rt.nodes["out"].p.rate == 30.0)
        ws_send(s, 9, b"hi")  # ping
        while True:
            opcode, payload = ws_receive(s)
            if opcode == 10:
                assert payload == b"hi"
                break
    finally:
        s.close()


def test_a_client_that_breaks_the_protocol_is_closed_and_the_patch_goes_on(served):
    rt, _obs, server, url = served
    s = ws_connect(server.port)
    s.sendall(b"\x81\x05hello")  # unmasked: a client's frames must be masked
    opcode, payload = ws_receive(s)
    assert opcode == 8 and b"mask" in payload
    s.close()
    _, value = _get(url + "/pointat/out/rate?VALUE")
    assert value == {"VALUE": [50.0]}
    assert rt.running


def test_the_observer_reads_streams_flags_pointers_and_the_vbap_layout(served):
    rt, obs, server, url = served
    _settle(lambda: obs.snapshot()["pointers"] and obs.snapshot()["pointers"][0]["updates"] > 20)
    _settle(lambda: obs.snapshot()["streams"][0]["rate"] > 80)
    snap = obs.snapshot()
    (stream,) = snap["streams"]
    assert stream["name"] == "glove.adc" and stream["state"] == "ok" and stream["nominal"] == 100.0
    assert (
        snap["layout"]["azimuths"] == [30.0, -30.0, 110.0, -110.0] and snap["layout"]["from"] == "vbap 'pan'"
    )
    (pointer,) = snap["pointers"]
    assert pointer["name"] == "out" and len(pointer["gains"]) == 4
    assert "fuse" in snap["flags"] and snap["flags"]["fuse"]["flag"] in ("ok", "uninitialised")
    assert {"resting", "bias_dps", "bias_learned_s", "dip_deg"} <= set(snap["flags"]["fuse"])
    lines = obs.status_lines()
    assert lines[0].startswith("out: az ") and any(line.startswith("glove.adc: ok, ") for line in lines)
    # the glove goes silent: a dropout, told within DROPOUT and a reading
    rt.send("glove", "dropout", 1.0)
    _settle(lambda: obs.snapshot()["streams"][0]["state"] == "dropout", 2.0)
    assert any("NO DATA" in line for line in obs.status_lines())
    _settle(lambda: obs.snapshot()["streams"][0]["state"] == "ok", 3.0)
    assert obs.snapshot()["streams"][0]["dropouts"] == 1
    summary = obs.summary()
    assert any(line.startswith("glove.adc: ") and "1 dropouts" in line for line in summary), summary
    # the page's own state, the same reading with its history
    _, state = _get(url + "/monitor/state")
    assert state["history"]["out"] and state["url"].endswith("/monitor")


def test_presets_over_oscquery(served, tmp_path):
    rt, _obs, server, url = served
    osc = SimpleUDPClient("127.0.0.1", server.osc_port)
    osc.send_message("/pointat/out/rate", 40.0)
    _settle(lambda: rt.nodes["out"].p.rate == 40.0)
    osc.send_message("/pointat/preset/save", "a")
    _settle(lambda: (tmp_path / "glove.presets.json").exists())
    osc.send_message("/pointat/out/rate", 10.0)
    _settle(lambda: rt.nodes["out"].p.rate == 10.0)
    osc.send_message("/pointat/preset/recall", "a")
    _settle(lambda: rt.nodes["out"].p.rate == 40.0)
    _, tree = _get(url + "/")
    assert find(tree, "/pointat/preset/recall")["RANGE"] == [{"VALS": ["a"]}]


def test_a_patch_without_osc_out_or_vbap_has_a_ring_of_eight_and_no_pointer():
    spec = parse_patch("node m metro 100\nnode p print\nnode on loadbang\non -> m -> p", "x.pat")
    rt = build(check(spec, REG))
    obs = Observer(rt).attach()
    snap = obs.read()
    assert snap["pointers"] == [] and snap["streams"] == [] and len(snap["layout"]["azimuths"]) == 8


def test_the_observer_and_the_server_leave_a_spinning_scheduler_polling_without_pauses():
    """``--spin`` polls without pauses when no other thread wants the interpreter: the observer's thread
    and the server's (requests, OSC, zeroconf) sleep on their sockets and timers, marked quiet."""
    rt = build(check(parse_patch("node ctl osc_in port=0\nnode p print\nctl.any -> p", "x.pat"), REG))
    assert rt._waiter.spin_grain() == 0.0
    obs = Observer(rt).attach()
    server = MonitorServer(rt, obs, "127.0.0.1", 0, advertise=True)
    server.start()
    obs.start()
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{server.port}/?HOST_INFO", timeout=5):
            pass
        deadline = time.monotonic() + 5
        while server._zeroconf is None and time.monotonic() < deadline:  # advertised (or given up)
            time.sleep(0.01)
        assert rt._waiter.spin_grain() == 0.0, [t.name for t in threading.enumerate()]
    finally:
        obs.stop()
        server.close()


def test_a_dome_given_on_the_command_line_is_the_monitors_layout():
    from pointat.cli.run import _layout

    dome = _layout("0:0,90:0,180:0,-90:0,45:45,-135:45,0:90")
    assert dome.dim == 3 and dome.n == 7
    rt = build(
        check(parse_patch("node m metro 100\nnode p print\nnode on loadbang\non -> m -> p", "x.pat"), REG)
    )
    layout = Observer(rt, layout=dome).attach().read()["layout"]
    assert layout["dim"] == 3 and layout["elevations"][-1] == 90.0 and layout["from"] == "--layout"
    with pytest.raises(Exception, match="--layout"):
        _layout("front,back")
