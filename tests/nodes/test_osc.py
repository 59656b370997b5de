"""osc_out and osc_in over real UDP sockets on 127.0.0.1: profiles, bundles, pacing, absent receivers,
sensor formats, live control, time tags and malformed packets.

Packets are read back with a small OSC decoder written here from the OSC 1.0 specification, not with the
library that encodes them; packets sent to osc_in are built with python-osc.
"""

import math
import os
import socket
import struct
import time

import numpy as np
import pytest
from pythonosc.osc_bundle_builder import IMMEDIATELY as PY_IMMEDIATELY
from pythonosc.osc_bundle_builder import OscBundleBuilder
from pythonosc.osc_message_builder import OscMessageBuilder

from pointat.errors import PatchError
from pointat.loader import load
from pointat.message import make, method
from pointat.osc_bridge.profiles import PROFILES
from pointat.testing import free_udp_port, patch

IMMEDIATELY = b"\x00" * 7 + b"\x01"
NTP_UNIX = 2208988800
F32 = 1e-6  # relative tolerance of float32


# --------------------------------------------------------------------------- an independent OSC reader
def _string(data: bytes, i: int) -> tuple[str, int]:
    end = data.index(b"\x00", i)
    return data[i:end].decode("utf-8"), (end + 4) & ~3


def decode(data: bytes, stamp: bytes | None = None) -> list[tuple[bytes | None, str, str, list]]:
    """(time tag, address, type tags, arguments) of every message in a packet, bundles flattened."""
    if data.startswith(b"#bundle\x00"):
        stamp, i, out = data[8:16], 16, []
        while i < len(data):
            (size,) = struct.unpack(">i", data[i : i + 4])
            out += decode(data[i + 4 : i + 4 + size], stamp)
            i += 4 + size
        assert i == len(data), "bundle element sizes do not add up"
        return out
    address, i = _string(data, 0)
    tags, i = _string(data, i)
    assert tags.startswith(","), tags
    args: list = []
    for t in tags[1:]:
        if t == "f":
            args.append(struct.unpack(">f", data[i : i + 4])[0])
            i += 4
        elif t == "i":
            args.append(struct.unpack(">i", data[i : i + 4])[0])
            i += 4
        elif t == "s":
            s, i = _string(data, i)
            args.append(s)
        else:
            raise AssertionError(f"unexpected type tag {t!r} in {tags!r}")
    assert i == len(data), "trailing bytes after the arguments"
    return [(stamp, address, tags[1:], args)]


def ntp_to_unix(stamp: bytes) -> float:
    sec, frac = struct.unpack(">II", stamp)
    return sec - NTP_UNIX + frac / 2**32


class Receiver:
    """A UDP socket on 127.0.0.1 with a free port."""

    def __init__(self, port: int = 0):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", port))
        self.port = self.sock.getsockname()[1]

    def packets(self, n: int | None = None, timeout: float = 1.0, quiet: float = 0.05) -> list[bytes]:
        """``n`` packets (waiting up to ``timeout``), or with ``n=None`` all until ``quiet`` s of silence."""
        out: list[bytes] = []
        deadline = time.monotonic() + timeout
        while n is None or len(out) < n:
            wait = quiet if n is None else deadline - time.monotonic()
            if wait <= 0:
                break
            self.sock.settimeout(wait)
            try:
                out.append(self.sock.recv(65536))
            except TimeoutError:
                break
        return out

    def messages(self, n: int | None = None, timeout: float = 1.0) -> list[tuple]:
        return [m for p in self.packets(n, timeout) for m in decode(p)]

    def close(self) -> None:
        self.sock.close()


@pytest.fixture
def receivers():
    made: list[Receiver] = []

    def make_one(port: int = 0) -> Receiver:
        made.append(Receiver(port))
        return made[-1]

    yield make_one
    for r in made:
        r.close()


def push(node, az, el=None, dist=None, spread=None):
    """Cold inlets first, then the hot azimuth, as a patch would."""
    for inlet, value in ((3, spread), (2, dist), (1, el)):
        if value is not None:
            node.receive(inlet, make(float(value)))
    node.receive(0, make(float(az)))


def out_node(started, port, params=""):
    rt = started(patch(f"node out osc_out port={port} {params}"))
    return rt, rt.nodes["out"]


def values_match(got, want):
    return len(got) == len(want) and all(
        g == w if isinstance(w, (int, str)) else math.isclose(g, w, rel_tol=F32, abs_tol=1e-6)
        for g, w in zip(got, want, strict=True)
    )


# --------------------------------------------------------------------------- osc_out: profiles
C10, S10, C30, S30 = (math.cos(math.radians(10)), math.sin(math.radians(10)), math.cos(math.radians(30)), 0.5)
# one update: azimuth 30 (left), elevation 10, roll distance 45 (half way in), spread 20
EXPECTED = {
    "pointat": [("/pointat/1/aed", "fff", [30.0, 10.0, 0.5])],
    "vbap": [("/vbap/1", "fff", [30.0, 10.0, 20.0])],
    "adm": [("/adm/obj/1/aed", "fff", [30.0, 10.0, 0.5])],
    "iem_stereo": [("/StereoEncoder/azimuth", "f", [30.0]), ("/StereoEncoder/elevation", "f", [10.0])],
    "iem_multi": [("/MultiEncoder/azimuth0", "f", [30.0]), ("/MultiEncoder/elevation0", "f", [10.0])],
    "spat": [("/source/1/aed", "fff", [-30.0, 10.0, 0.5])],
    "icst": [("/icst/ambi/sourceindex/xyz", "ifff", [1, -0.5 * C10 * S30, 0.5 * C10 * C30, 0.5 * S10])],
    "reaper": [("/track/1/pan", "f", [1.0 / 3.0])],
    "generic": [("/pointat/1/direction", "ff", [30.0, 10.0])],
}


def test_every_profile_is_covered():
    assert set(EXPECTED) == set(PROFILES)


@pytest.mark.parametrize("profile", sorted(EXPECTED))
def test_profile_addresses_type_tags_and_values(profile, started, receivers):
    rx = receivers()
    _, out = out_node(started, rx.port, f"profile={profile}")
    push(out, 30.0, el=10.0, dist=45.0, spread=20.0)
    want = EXPECTED[profile]
    got = rx.messages(len(want))
    assert [(a, t) for _, a, t, _ in got] == [(a, t) for a, t, _ in want]
    for (_, _, _, args), (_, _, expected) in zip(got, want, strict=True):
        assert values_match(args, expected), (args, expected)
    assert all(stamp is None for stamp, *_ in got)  # plain messages, not bundles
    assert rx.packets(quiet=0.05) == []  # exactly one update's messages
    assert [t for _, _, t, _ in got] == (PROFILES[profile].type_tags() or ["ff"])


def test_generic_address_fields_constants_and_source(started, receivers):
    rx = receivers()
    _, out = out_node(
        started, rx.port, "profile=generic address=/my/{n}/dir fields=[az, el, n, 2.5, 7, x] source=4"
    )
    push(out, -90.0, el=0.0)
    [(_, address, tags, args)] = rx.messages(1)
    assert (address, tags) == ("/my/4/dir", "ffifif")
    assert values_match(args, [-90.0, 0.0, 4, 2.5, 7, 1.0])  # x: + right


@pytest.mark.parametrize(
    ("az", "spat_az", "pan"),
    [
        (30.0, -30.0, 1 / 3),  # left: SPAT negative, pan towards 0
        (-30.0, 30.0, 2 / 3),
        (0.0, 0.0, 0.5),
        (90.0, -90.0, 0.0),  # hard left
        (-90.0, 90.0, 1.0),  # hard right
        (150.0, -150.0, 1 / 3),  # behind left pans as its mirror image in front
        (180.0, 180.0, 0.5),
        (190.0, 170.0, 0.5 + 10 / 180),  # wrapped to -170 first
    ],
)
def test_azimuth_conventions_spat_and_reaper(az, spat_az, pan, started, receivers):
    rx_spat, rx_reaper = receivers(), receivers()
    _, spat = out_node(started, rx_spat.port, "profile=spat")
    push(spat, az)
    [(_, _, _, (got_az, _, _))] = rx_spat.messages(1)
    assert math.isclose(got_az, spat_az, abs_tol=1e-5)
    rt = started(patch(f"node out2 osc_out port={rx_reaper.port} profile=reaper"))
    push(rt.nodes["out2"], az)
    [(_, _, _, (got_pan,))] = rx_reaper.messages(1)
    assert math.isclose(got_pan, pan, abs_tol=1e-6)


@pytest.mark.parametrize(
    ("dist", "dist01"), [(0.0, 1.0), (45.0, 0.5), (90.0, 0.0), (120.0, 0.0), (-5.0, 1.0)]
)
def test_adm_distance_is_normalised_far_one_near_zero(dist, dist01, started, receivers):
    rx = receivers()
    _, out = out_node(started, rx.port, "profile=adm")
    push(out, 0.0, el=0.0, dist=dist)
    [(_, _, _, (_, _, got))] = rx.messages(1)
    assert math.isclose(got, dist01, abs_tol=1e-7)


def test_spat_distance_in_metres_and_source_numbers(started, receivers):
    rx = receivers()
    rt, out = out_node(started, rx.port, "profile=spat radius=3 source=5")
    push(out, 0.0, dist=45.0)
    [(_, address, _, (_, _, metres))] = rx.messages(1)
    assert address == "/source/5/aed" and math.isclose(metres, 1.5, rel_tol=F32)
    out.set_param("source", 2)  # live
    push(out, 0.0)
    assert rx.messages(1)[0][1] == "/source/2/aed"


def test_iem_multi_counts_inputs_from_zero_and_adm_objects_from_one(started, receivers):
    rx = receivers()
    rt = started(
        patch(
            f"node a osc_out port={rx.port} profile=iem_multi\n"
            f"node b osc_out port={rx.port} profile=iem_multi source=3\n"
            f"node c osc_out port={rx.port} profile=adm\n"
        )
    )
    for name in ("a", "b", "c"):
        push(rt.nodes[name], 10.0)
    got = [a for _, a, _, _ in rx.messages(5)]
    assert got == [
        "/MultiEncoder/azimuth0",
        "/MultiEncoder/elevation0",
        "/MultiEncoder/azimuth3",
        "/MultiEncoder/elevation3",
        "/adm/obj/1/aed",
    ]


def test_list_input_and_bang_resend(started, receivers):
    rx = receivers()
    _, out = out_node(started, rx.port, "profile=adm")
    out.receive(0, make([20.0, -5.0, 90.0]))
    out.receive(0, make(None))  # bang: send the current direction again
    got = [args for *_, args in rx.messages(2)]
    assert values_match(got[0], [20.0, -5.0, 0.0]) and got[1] == got[0]


# --------------------------------------------------------------------------- osc_out: bundles
def test_bundle_time_tag_immediately(started, receivers):
    rx = receivers()
    _, out = out_node(started, rx.port, "profile=iem_stereo bundle=true")
    push(out, 45.0, el=-10.0)
    [packet] = rx.packets(1)
    assert packet.startswith(b"#bundle\x00")
    got = decode(packet)
    assert [(s, a, t) for s, a, t, _ in got] == [
        (IMMEDIATELY, "/StereoEncoder/azimuth", "f"),
        (IMMEDIATELY, "/StereoEncoder/elevation", "f"),
    ]
    assert values_match([got[0][3][0], got[1][3][0]], [45.0, -10.0])
    assert rx.packets(quiet=0.05) == []  # one packet per update


def test_bundle_time_tag_now_plus_delay(started, receivers):
    rx = receivers()
    _, out = out_node(started, rx.port, "profile=adm bundle=true delay=250")
    before = time.time()
    push(out, 10.0)
    after = time.time()
    [(stamp, address, tags, _)] = rx.messages(1)
    assert (address, tags) == ("/adm/obj/1/aed", "fff")
    assert before + 0.25 - 1e-3 <= ntp_to_unix(stamp) <= after + 0.25 + 1e-3


def test_delay_without_bundle_is_a_load_error():
    with pytest.raises(PatchError, match="bundle=true"):
        patch("node out osc_out delay=20")


@pytest.mark.parametrize("profile", ["iem_stereo", "iem_multi"])
def test_delay_for_a_receiver_that_ignores_time_tags_is_a_load_error(profile):
    with pytest.raises(
        PatchError, match=f"delay does nothing for profile {profile}.*ignores bundle time tags"
    ):
        patch(f"node out osc_out profile={profile} bundle=true delay=20")
    patch(f"node out osc_out profile={profile} bundle=true")  # a bundle alone is fine: sent at once


# --------------------------------------------------------------------------- osc_out: pacing
def azimuths(rx):
    return [round(args[0], 4) for *_, args in rx.messages(None)]


def test_rate_limit_sends_the_latest_held_update_when_the_interval_ends(started, receivers):
    rx = receivers()
    rt, out = out_node(started, rx.port, "profile=adm rate=10")
    for az in (1.0, 2.0, 3.0):  # t = 0
        push(out, az)
    assert azimuths(rx) == [1.0]
    rt.advance(0.05)
    assert azimuths(rx) == []
    rt.advance(0.05)  # t = 0.1: the held one (the latest) goes
    assert azimuths(rx) == [3.0]
    push(out, 4.0)  # t = 0.1: held until 0.2
    rt.advance(0.09)
    assert azimuths(rx) == []
    rt.advance(0.01)
    assert azimuths(rx) == [4.0]
    rt.advance(0.5)
    push(out, 5.0)  # long after the last one: at once
    assert azimuths(rx) == [5.0]
    assert out.updates == 4


def test_deadband_skips_small_moves_the_short_way_round(started, receivers):
    rx = receivers()
    _, out = out_node(started, rx.port, "profile=adm deadband=2")
    for az, el in [(0, 0), (1, 0), (1.5, 0), (2.5, 0), (3, 0), (3, 3), (179, 3), (-179.5, 3), (-175, 3)]:
        push(out, az, el=el)
    # 1, 1.5: within 2 of 0; 3: within 2 of 2.5; (3, el 3): elevation moved 3; 179 -> -179.5 is 1.5 deg
    assert azimuths(rx) == [0.0, 2.5, 3.0, 179.0, -175.0]


def test_send_on_change_drops_exact_repeats(started, receivers):
    rx = receivers()
    _, out = out_node(started, rx.port, "profile=adm change=true")
    for az in (5.0, 5.0, 5.0, 6.0, 6.0, 5.0):
        push(out, az)
    assert azimuths(rx) == [5.0, 6.0, 5.0]


def test_a_held_update_is_dropped_when_the_hand_comes_back(started, receivers):
    rx = receivers()
    rt, out = out_node(started, rx.port, "profile=adm rate=10 deadband=1")
    push(out, 0.0)
    push(out, 5.0)  # held
    push(out, 0.5)  # back within the deadband of what the receiver has
    rt.advance(0.2)
    assert azimuths(rx) == [0.0]


def test_multiple_destinations_each_get_every_update(started, receivers):
    a, b, c = receivers(), receivers(), receivers()
    _, out = out_node(started, a.port, f'profile=adm to=[{b.port}, "127.0.0.1:{c.port}"]')
    push(out, 12.0)
    push(out, 13.0)
    for rx in (a, b, c):
        assert azimuths(rx) == [12.0, 13.0]
    assert out.sent == 6 and out.failed == 0


def test_what_one_pass_encodes_leaves_together_at_its_end(started, receivers):
    """Two sources updated in one scheduler pass (as a base station's frames for two gloves are): neither
    datagram leaves before both chains ran; then both have, and each went to its own receiver."""
    rx_a, rx_b = receivers(), receivers()
    rt = started(patch(f"node a osc_out port={rx_a.port}\nnode b osc_out port={rx_b.port} source=2"))
    a, b = rt.nodes["a"], rt.nodes["b"]
    seen = []

    def both_gloves():
        push(a, 10.0)
        seen.append((a.sent, rx_a.packets(quiet=0.05)))  # encoded, not sent yet
        push(b, 20.0)
        seen.append((b.sent, rx_b.packets(quiet=0.05)))

    rt.call_at(0.01, None, both_gloves)
    rt.advance(0.02)
    assert seen == [(0, []), (0, [])]
    assert a.sent == b.sent == 1
    assert azimuths(rx_a) == [10.0] and azimuths(rx_b) == [20.0]
    assert rx_b.messages(None) == [] and rx_a.messages(None) == []
    push(a, 11.0)  # outside a pass (fed by hand): at once
    assert a.sent == 2 and azimuths(rx_a) == [11.0]


def test_a_backlog_worked_off_in_one_pass_goes_out_as_it_comes_in_order(started, receivers):
    """Five updates of one source in one pass (a stalled port's frames read at once): one update waits at
    most, so the datagrams do not pile up until the pass ends; all of them arrive, in order."""
    rx = receivers()
    rt = started(patch(f"node out osc_out port={rx.port}"))
    out = rt.nodes["out"]
    sent = []

    def backlog():
        for az in (1.0, 2.0, 3.0, 4.0, 5.0):
            push(out, az)
            sent.append(out.sent)

    rt.call_at(0.01, None, backlog)
    rt.advance(0.02)
    assert sent == [0, 2, 2, 4, 4]
    assert out.sent == 5 and azimuths(rx) == [1.0, 2.0, 3.0, 4.0, 5.0]


def test_bad_destinations_are_load_errors():
    with pytest.raises(PatchError, match="host:port"):
        patch('node out osc_out to=["nohostport"]')
    with pytest.raises(PatchError, match="outside 1..65535"):
        patch("node out osc_out to=[70000]")
    with pytest.raises(PatchError, match="unknown field"):
        patch("node out osc_out profile=generic address=/a fields=[azimuth]")


@pytest.mark.parametrize("address", ["/a/{source}", "/a/{n}/{0}", "/a/{n"])
def test_a_generic_address_may_name_only_n_and_says_so_at_load(address):
    with pytest.raises(PatchError, match=r"\{n\} \(the source number\) is the only field"):
        patch(f'node out osc_out profile=generic address="{address}"')
    assert patch('node out osc_out profile=generic address="/a/{{x}}/{n:02d}"')  # braces written twice


def test_a_bad_value_is_dropped_and_the_next_one_goes(started, receivers):
    rx = receivers()
    rt = started(patch(f"node num t f\nnode out osc_out port={rx.port} profile=adm\nnum -> out"))
    rt.nodes["num"].receive(0, make(math.nan))
    rt.nodes["num"].receive(0, make(7.0))
    assert azimuths(rx) == [7.0]
    assert rt.nodes["out"].errors == 1


def test_one_bad_control_message_spoils_none_of_the_updates_after_it(started, receivers):
    # /pointat/out 0 0 0 nan once: its NaN spread was kept, and every later update was refused for good
    rx = receivers()
    rt = started(patch(f"node out osc_out port={rx.port} profile=adm"))
    out = rt.nodes["out"]
    push(out, 5.0, el=10.0)
    with pytest.raises(ValueError, match="not a finite number in .*; the last good values stay"):
        out.receive(0, make((0.0, 0.0, 0.0, math.nan)))
    with pytest.raises(ValueError, match="elevation nan refused"):
        out.receive(1, make(math.nan))  # a cold inlet too
    with pytest.raises(ValueError, match="distance inf refused"):
        out.receive(2, make(math.inf))
    push(out, 7.0)
    got = [args for *_, args in rx.messages(None)]
    assert [round(a[0], 4) for a in got] == [5.0, 7.0] and got[-1][1] == pytest.approx(10.0)


# --------------------------------------------------------------------------- osc_out: absent receiver
def _taken(port: int) -> bool:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        s.bind(("127.0.0.1", port))
    except OSError:
        return True
    finally:
        s.close()
    return False


def test_absent_receiver_is_counted_and_the_patch_keeps_going(started, receivers):
    for _ in range(3):
        # a free port is free only when asked: if anything on the machine (the sender's own socket
        # included) takes it meanwhile, nobody refuses, and the case is tried again on another
        port = free_udp_port()
        rt = started(
            patch(
                f"""
node lb   loadbang
node tick metro 5
node az   msg 30
node out  osc_out profile=adm port={port}
node seen collect
lb -> tick -> az
az -> out
az -> seen
"""
            )
        )
        out = rt.nodes["out"]
        assert all(not d.sock.getblocking() for d in out.dests)  # sending can never block the scheduler
        rt.advance(1.0)
        assert len(rt.nodes["seen"].messages) == 201  # every tick went through the whole patch
        assert out.updates == 201 and out.errors == 0
        for _ in range(100):  # the refusal is an ICMP answer, not the send's own result: pace on for it
            if out.refused:
                break
            time.sleep(0.01)
            rt.advance(0.01)
        if out.refused or not _taken(port):
            break
        rt.shutdown()
    assert out.refused >= 1, f"port {port} is free, and no send to it was refused"  # ... and it was counted
    assert out.errors == 0 and out.updates == len(rt.nodes["seen"].messages)
    rx = receivers(port)  # the receiver turns up: the next updates reach it
    rt.advance(0.05)
    assert azimuths(rx) == [30.0] * 10


def test_a_receiver_host_that_refuses_once_a_second_is_not_taken_for_back(started, caplog):
    # another host rate-limits its "port unreachable" to about one a second: at 100 Hz, 100 sends pass
    # between two refusals, and that is not a receiver that came back
    class Refusing:
        def __init__(self):
            self.n = 0

        def send(self, dgram):
            self.n += 1
            if self.n % 101 == 0:
                raise ConnectionRefusedError

        def close(self):
            pass

    rt, out = out_node(started, 9)
    [d] = out.dests
    d.sock.close()
    d.sock = Refusing()
    for _ in range(1000):
        push(out, 10.0)
    lines = [r.getMessage() for r in caplog.records if r.name == "pointat.osc"]
    assert not any("listening again" in x for x in lines)
    assert sum("nobody listening" in x for x in lines) == 1  # one outage, told once (9 refusals)


def test_the_log_says_when_a_receiver_is_back_and_of_each_outage(started, receivers, caplog, monkeypatch):
    from pointat.osc_bridge.sender import Destination

    monkeypatch.setattr(Destination, "BACK_QUIET", 0.0)  # loopback refuses at once: no need to wait
    port = free_udp_port()
    rt, out = out_node(started, port)
    lines = lambda: [r.getMessage() for r in caplog.records if r.name == "pointat.osc"]  # noqa: E731
    for _ in range(50):
        push(out, 10.0)
    assert sum("nobody listening" in x for x in lines()) == 2  # the 1st refusal, the 10th: not 50
    rx = receivers(port)
    for _ in range(20):
        push(out, 20.0)
    assert any(f"127.0.0.1:{port} is listening again" in x for x in lines())
    assert azimuths(rx)[-5:] == [20.0] * 5
    rx.close()  # a second outage is told from its start again
    caplog.clear()
    for _ in range(5):
        push(out, 30.0)
    assert any("nobody listening" in x and "(1 datagram refused)" in x for x in lines())


# --------------------------------------------------------------------------- osc_in
def osc(address, *args, types=None):
    b = OscMessageBuilder(address)
    for i, a in enumerate(args):
        b.add_arg(
            a, types[i] if types else ("i" if isinstance(a, int) else "f" if isinstance(a, float) else "s")
        )
    return b.build()


def bundle(stamp, *messages):
    b = OscBundleBuilder(stamp)
    for m in messages:
        b.add_content(m)
    return b.build().dgram


def sender():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    return s


def wait_for(rt, predicate, timeout=2.0):
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            return False
        rt.drain(timeout=0.02)
    return True


def in_patch(started, params, wires=""):
    rt = started(patch(f"node imu osc_in port=0 {params}\n{wires}"))
    return rt, rt.nodes["imu"], rt.nodes["imu"].address


def test_a_port_already_taken_says_which_and_what_to_do():
    from pointat.runtime import StartError

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as taken:
        taken.bind(("127.0.0.1", 0))
        port = taken.getsockname()[1]
        rt = patch(f"node ctl osc_in port={port}")
        with pytest.raises(StartError) as info:
            rt.start()
    msg = str(info.value)
    assert f"node 'ctl' (osc_in): cannot start: cannot listen on UDP 127.0.0.1:{port}" in msg
    assert "another program listens there (a second pointat? Pd?)" in msg


def test_ngimu_sensors_and_quaternion_in_si_units_right_to_left(started):
    rt, imu, addr = in_patch(
        started,
        "device=ngimu",
        "node s collect\nnode q collect\nimu.gyro -> s\nimu.accel -> s\nimu.mag -> s\nimu.quat -> q",
    )
    sensors = osc("/sensors", 90.0, -45.0, 0.0, 0.0, 0.0, 1.0, 20.0, 0.0, -40.0, 1013.25)
    quat = osc("/quaternion", 0.5, 0.5, -0.5, 0.5)
    with sender() as tx:
        tx.sendto(bundle(100.0, sensors, quat), addr)  # NGIMU stamps bundles with its own clock
        assert wait_for(rt, lambda: len(rt.nodes["s"].messages) == 3 and rt.nodes["q"].messages)
    mag, accel, gyro = (list(m.value) for m in rt.nodes["s"].messages)  # right to left
    assert values_match(gyro, [math.pi / 2, -math.pi / 4, 0.0])
    assert values_match(accel, [0.0, 0.0, 9.80665])  # +1 g up at rest -> m/s²
    assert values_match(mag, [0.2, 0.0, -0.4])  # uT -> gauss
    assert list(rt.nodes["q"].values[0]) == [0.5, 0.5, -0.5, 0.5]  # w first, as sent


def test_zigsim_reorders_the_quaternion_and_feeds_accel_from_gravity(started):
    rt, imu, addr = in_patch(
        started,
        "device=zigsim",
        "node q collect\nnode a collect\nnode g collect\nnode other collect\n"
        "imu.quat -> q\nimu.accel -> a\nimu.gyro -> g\nimu.any -> other",
    )
    uuid = "/ZIGSIM/3F2504E0-4F89"
    with sender() as tx:
        tx.sendto(
            bundle(
                PY_IMMEDIATELY,
                osc(f"{uuid}/quaternion", 0.1, 0.2, 0.3, 0.9),
                osc(f"{uuid}/gravity", 0.0, 0.0, -1.0),
                osc(f"{uuid}/gyro", 0.5, 0.0, -0.25),
                osc(f"{uuid}/accel", 0.3, 0.0, 0.0),
            ),
            addr,
        )
        assert wait_for(rt, lambda: rt.nodes["other"].messages)
    assert values_match(list(rt.nodes["q"].values[0]), [0.9, 0.1, 0.2, 0.3])  # x y z w -> w x y z
    assert values_match(list(rt.nodes["a"].values[0]), [0.0, 0.0, 9.80665])  # gravity down -> +g up
    assert values_match(list(rt.nodes["g"].values[0]), [0.5, 0.0, -0.25])  # rad/s already
    [user_accel] = rt.nodes["other"].messages  # user acceleration is not specific force: passed on
    assert user_accel.kind == f"{uuid}/accel"


def test_generic_map_scales_and_wrong_argument_counts_are_dropped(started):
    rt, imu, addr = in_patch(
        started,
        'map=["/imu/acc=accel*2", "/imu/*/q=quat"]',
        "node a collect\nnode q collect\nimu.accel -> a\nimu.quat -> q",
    )
    with sender() as tx:
        tx.sendto(osc("/imu/acc", 1.0, 2.0).dgram, addr)  # one short: counted, dropped
        tx.sendto(osc("/imu/acc", 1.0, 2, 3.0).dgram, addr)
        tx.sendto(osc("/imu/left/q", 1.0, 0.0, 0.0, 0.0).dgram, addr)
        assert wait_for(rt, lambda: rt.nodes["a"].messages and rt.nodes["q"].messages)
    assert list(rt.nodes["a"].values[0]) == [2.0, 4.0, 6.0]
    assert list(rt.nodes["q"].values[0]) == [1.0, 0.0, 0.0, 0.0]
    assert imu.malformed == 1


def test_sensor_arguments_must_be_numbers_and_true_is_not_one(started):
    rt, imu, addr = in_patch(started, 'map=["/g=gyro"]', "node g collect\nimu.gyro -> g")
    with sender() as tx:
        tx.sendto(osc("/g", 1.0, "x", 3.0).dgram, addr)
        tx.sendto(osc("/g", 1.0, True, 3.0, types="fTf").dgram, addr)
        tx.sendto(osc("/g", 1, 2, 3).dgram, addr)  # ints are numbers
        assert wait_for(rt, lambda: rt.nodes["g"].messages)
    assert rt.nodes["g"].values == [(1.0, 2.0, 3.0)]
    assert all(type(v) is float for v in rt.nodes["g"].values[0])
    assert imu.malformed == 2


def test_routes_are_remembered_for_a_few_addresses_and_a_flood_still_routes(started):
    rt, imu, addr = in_patch(
        started,
        'map=["/imu/*/g=gyro"]',
        "node g collect\nnode other collect\nimu.gyro -> g\nimu.any -> other",
    )
    with sender() as tx:
        for _ in range(2):  # the second time from memory: the same outlets
            tx.sendto(osc("/imu/0/g", -1.0, 0.0, 0.0).dgram, addr)
            tx.sendto(osc("/cue", 1).dgram, addr)
        assert wait_for(rt, lambda: len(rt.nodes["g"].messages) == 2 and len(rt.nodes["other"].messages) == 2)
        assert set(imu._routes) == {"/imu/0/g", "/cue"}
        n = imu.ROUTES_KEPT + 50  # more distinct addresses than are remembered
        for k in range(n):
            tx.sendto(osc(f"/imu/{k}/g", float(k), 0.0, 0.0).dgram, addr)
            if k % 50 == 49:  # do not overrun the socket's buffer
                assert wait_for(rt, lambda k=k: len(rt.nodes["g"].messages) == k + 3)
        tx.sendto(osc("/cue", 2).dgram, addr)
        assert wait_for(
            rt, lambda: len(rt.nodes["g"].messages) == n + 2 and len(rt.nodes["other"].messages) == 3
        )
    assert [v[0] for v in rt.nodes["g"].values] == [-1.0, -1.0, *map(float, range(n))]
    assert [m.value for m in rt.nodes["other"].messages] == [(1,), (1,), (2,)]
    assert len(imu._routes) <= imu.ROUTES_KEPT  # it started over instead of growing


def test_a_matched_message_no_rule_can_read_leaves_by_any(started):
    rt, imu, addr = in_patch(
        started, 'map=["/imu/*=gyro"]', "node g collect\nnode other collect\nimu.gyro -> g\nimu.any -> other"
    )
    with sender() as tx:
        tx.sendto(osc("/imu/battery", 0.8).dgram, addr)  # the wildcard matches; one number is no gyro
        tx.sendto(osc("/imu/name", "left").dgram, addr)
        tx.sendto(osc("/imu/gyro", 0.1, 0.2, 0.3).dgram, addr)
        assert wait_for(rt, lambda: rt.nodes["g"].messages and len(rt.nodes["other"].messages) == 2)
    assert [m.kind for m in rt.nodes["other"].messages] == ["/imu/battery", "/imu/name"]
    [gyro] = rt.nodes["g"].values
    assert values_match(list(gyro), [0.1, 0.2, 0.3])
    assert imu.malformed == 2


def test_a_wake_up_reads_datagrams_for_a_bounded_time_and_leaves_the_rest_for_the_next(started, monkeypatch):
    # a flood of 64 kB datagrams took ~2 ms each to decode: 64 of them held the timers for 120 ms
    import select

    rt, imu, addr = in_patch(started, "", "node c collect\nimu.any -> c")
    with sender() as tx:
        for k in range(10):
            tx.sendto(osc("/cue", k).dgram, addr)
    assert select.select([imu._sock], [], [], 2.0)[0]
    monkeypatch.setattr(type(imu), "BUDGET", 0.0)  # every datagram is over the budget
    imu._readable()
    assert imu.received == 1  # the one it began, then back to the scheduler
    monkeypatch.undo()
    imu._readable()
    assert imu.received == 10 and [v for (v,) in rt.nodes["c"].values] == list(range(10))


def test_other_messages_leave_by_any_for_route(started):
    rt, imu, addr = in_patch(started, "", "node r route /cue\nnode c collect\nimu.any -> r\nr.0 -> c")
    with sender() as tx:
        tx.sendto(osc("/cue", 3, 2.5, "go").dgram, addr)
        assert wait_for(rt, lambda: rt.nodes["c"].messages)
    assert rt.nodes["c"].values == [(3, 2.5, "go")]


def test_pointat_to_pointat_directions_are_not_taken_for_control(started):
    rt, imu, addr = in_patch(started, "", "node c collect\nimu.any -> c")
    glove = started(patch(f"node out osc_out profile=pointat port={addr[1]}"))  # another pointat
    push(glove.nodes["out"], 15.0)
    assert wait_for(rt, lambda: rt.nodes["c"].messages)
    [msg] = rt.nodes["c"].messages  # /pointat/1/...: node names never start with a digit
    assert msg.kind == "/pointat/1/aed" and values_match(list(msg.value), [15.0, 0.0, 1.0])


def test_a_flood_of_bad_control_is_counted_and_logged_sparingly_and_good_control_still_works(started, caplog):
    rt, imu, addr = in_patch(started, "", "node m metro 100")
    with sender() as tx:
        for k in range(300):
            tx.sendto(osc("/pointat/nosuch/k", 1.0).dgram, addr)  # no such node
            tx.sendto(osc("/pointat/m/nosuch", "x" * 5000).dgram, addr)  # no such method, a huge string
            if k % 10 == 9:  # let it read them: 5 kB datagrams would overflow the socket's buffer
                assert wait_for(rt, lambda k=k: imu.refused_control == 2 * (k + 1))
        tx.sendto(osc("/pointat/m/interval", 5.0).dgram, addr)
        assert wait_for(rt, lambda: rt.nodes["m"].p.interval == 5.0)
        # then the performer's typo, and values for a node that has no inlets: each is told at once
        tx.sendto(osc("/pointat/m/intervl", 5.0).dgram, addr)
        tx.sendto(osc("/pointat/imu", 1.0).dgram, addr)
        assert wait_for(rt, lambda: imu.refused_control == 602)
    lines = [r.getMessage() for r in caplog.records if "refused" in r.getMessage()]
    assert len(lines) == 12  # at each address the 1st, 2nd, 3rd, 10th, 100th: not 600
    assert f"osc_in 'imu' (port {addr[1]}): /pointat/nosuch/k refused: no node 'nosuch'" in lines[0]
    assert "/pointat/nosuch/k refused: no node 'nosuch'" in lines[-4]
    assert lines[-4].endswith("(100 refused at this address so far)")
    assert "/pointat/m/intervl refused: node 'm': no method 'intervl'" in lines[-2]
    assert lines[-1].endswith(
        "/pointat/imu refused: node 'imu' has no inlets to take values; send /pointat/imu/PARAM value or "
        "/pointat/imu/METHOD"
    )
    assert max(len(x) for x in lines) < 400  # the 5000-character string is not echoed whole


def test_a_refused_command_tried_again_after_a_pause_is_told_every_time(started, caplog, monkeypatch):
    # the 4th refused turn_end of a calibration passed in silence (only the 10th, 100th... were told)
    rt, imu, addr = in_patch(started, "", "node m metro 100")
    monkeypatch.setattr(imu._refusals, "quiet", 0.2)  # REFUSED_QUIET: a person's pause, shortened
    with sender() as tx:
        for k in range(5):
            tx.sendto(osc("/pointat/m/intervl", 5.0).dgram, addr)
            assert wait_for(rt, lambda k=k: imu.refused_control == k + 1)
            time.sleep(0.3)
    lines = [r.getMessage() for r in caplog.records if "intervl refused" in r.getMessage()]
    assert len(lines) == 5 and lines[-1].endswith("(5 refused at this address so far)")


def test_a_flood_of_made_up_control_addresses_is_told_of_sparingly_too(started, caplog):
    rt, imu, addr = in_patch(started, "", "node m metro 100")
    with sender() as tx:
        for k in range(300):
            tx.sendto(osc(f"/pointat/nosuch{k}/k", 1.0).dgram, addr)
            if k % 10 == 9:  # let it read them: the socket's buffer holds a few hundred
                assert wait_for(rt, lambda k=k: imu.refused_control == k + 1)
    lines = [r.getMessage() for r in caplog.records if "refused" in r.getMessage()]
    # the first 32 addresses each once, then the rest as one count: its 1st, 2nd, 3rd, 10th, 100th
    assert len(lines) == imu.REFUSED_ADDRESSES + 5 and lines[-1].endswith(
        "(100 refused at this address so far)"
    )


def test_control_reaches_a_node_inside_an_abstraction(tmp_path, started):
    (tmp_path / "hand.pat").write_text("node m metro 100\n")
    (tmp_path / "show.pat").write_text("node left hand.pat\nnode ctl osc_in port=0\n")
    rt = started(load(tmp_path / "show.pat", realtime=False))
    with sender() as tx:
        tx.sendto(osc("/pointat/left/m/interval", 5.0).dgram, rt.nodes["ctl"].address)
        assert wait_for(rt, lambda: rt.nodes["left/m"].p.interval == 5.0)


def test_a_bundle_stamped_an_hour_ahead_is_delivered_at_once(started):
    rt, imu, addr = in_patch(started, "", "node c collect\nimu.any -> c")
    with sender() as tx:
        tx.sendto(bundle(time.time() + 3600.0, osc("/later", 1.0)), addr)
        assert wait_for(rt, lambda: rt.nodes["c"].messages, timeout=60.0)  # (not in an hour)
    assert rt.nodes["c"].messages[0].kind == "/later"


def test_timetags_stamp_a_burst_with_the_senders_spacing(started):
    wires = "node g collect\nimu.gyro -> g"
    rts = [  # on the real clock: arrival times are what the tags are weighed against
        started(patch(f'node imu osc_in port=0 map=["/g=gyro"] {tags}\n{wires}', realtime=True))
        for tags in ("timetags=true", "")
    ]
    got = [rt.nodes["g"].messages for rt in rts]
    t0 = time.time()
    with sender() as tx:
        for k in range(14):  # 100 Hz by the sender's clock: ten in time, then four held back, sent at once
            time.sleep(max(0.0, t0 + (0.01 * k if k < 10 else 0.15) - time.time()))
            for rt in rts:
                tx.sendto(bundle(t0 + 0.01 * k, osc("/g", float(k), 0.0, 0.0)), rt.nodes["imu"].address)
                if k < 10:  # read as it comes (a running scheduler does)
                    assert wait_for(rt, lambda n=k + 1, rt=rt: len(rt.nodes["g"].messages) == n)
        for rt in rts:
            tx.sendto(osc("/g", 99.0, 0.0, 0.0).dgram, rt.nodes["imu"].address)  # plain: its arrival
            assert wait_for(rt, lambda rt=rt: len(rt.nodes["g"].messages) == 15)
    tagged, by_arrival = ([m.time for m in messages] for messages in got)
    assert np.diff(tagged[10:14]) == pytest.approx([0.01] * 3, abs=2e-5)  # the burst keeps its spacing
    assert tagged[13] <= tagged[14]  # stamped no later than it arrived
    assert np.diff(by_arrival[10:14]).max() < 0.005  # without timetags, squeezed together


@pytest.mark.parametrize("ppm", [80, -80])
def test_tag_clock_follows_a_drifting_sender_and_one_set_back(ppm):
    from pointat.osc_bridge.tagclock import TagClock

    rng = np.random.default_rng(3)
    clock = TagClock()
    errors = []
    for k in range(60_000):  # 10 minutes at 100 Hz, the sender's clock off by ppm, deliveries 1-30 ms late
        taken = 100.0 + 0.01 * k
        tag = 5000.0 + (taken - 100.0) * (1 - ppm * 1e-6)
        errors.append(clock.stamp(tag, taken + rng.uniform(0.001, 0.030)) - taken)
    assert 0.001 <= min(errors[100:]) and max(errors[100:]) < 0.002  # the quickest delivery, + < 1 ms
    taken += 1.0
    stamps = [clock.stamp(tag - 3600.0 + 0.01 * i, taken + 0.01 * i + 0.002) for i in range(150)]
    assert stamps[0] < taken - 3000  # a second of tags an hour behind: taken at their word...
    assert stamps[-1] == pytest.approx(taken + 1.49, abs=0.003)  # ...then followed again


def test_malformed_packets_are_counted_and_survived(started):
    rt, imu, addr = in_patch(started, "", "node c collect\nimu.any -> c")
    garbage = [
        b"garbage",
        b"",
        b"#bundle\x00\x00\x00",  # truncated time tag
        b"/x\x00\x00,s\x00\x00\xff\xfe\x00\x00",  # not UTF-8
        b"/x\x00\x00fff\x00",  # type tags without the comma
        b"#bundle\x00"
        + IMMEDIATELY
        + struct.pack(">i", 64)
        + b"/a\x00\x00",  # element longer than the packet
    ]
    with sender() as tx:
        for g in garbage:
            tx.sendto(g, addr)
        tx.sendto(osc("/still/here", 1).dgram, addr)
        assert wait_for(rt, lambda: rt.nodes["c"].messages)
    assert imu.malformed == len(garbage)
    assert [m.kind for m in rt.nodes["c"].messages] == ["/still/here"]


def test_listening_off_loopback_needs_an_allow_list():
    with pytest.raises(PatchError, match="allow-list"):
        patch("node imu osc_in host=0.0.0.0")
    with pytest.raises(PatchError, match="not an IP address"):
        patch('node imu osc_in host=0.0.0.0 allow=["phone"]')
    with pytest.raises(PatchError, match="IPv4 address"):
        patch('node imu osc_in host=example.org allow=["10.0.0.2"]')
    rt = patch('node imu osc_in host=0.0.0.0 allow=["192.168.1.0/24", "10.0.0.2"]')  # built, not started
    assert rt.nodes["imu"].p.host == "0.0.0.0"


def test_allow_list_filters_senders(started):
    rt, imu, addr = in_patch(started, 'allow=["10.1.2.3"]', "node c collect\nimu.any -> c")
    rt2, imu2, addr2 = in_patch(started, 'allow=["127.0.0.0/8"]', "node c collect\nimu.any -> c")
    with sender() as tx:
        tx.sendto(osc("/a", 1).dgram, addr)
        tx.sendto(osc("/b", 1).dgram, addr2)
        assert wait_for(rt2, lambda: rt2.nodes["c"].messages)
        assert wait_for(rt, lambda: imu.refused == 1)
    rt.drain(timeout=0.05)
    assert rt.nodes["c"].messages == []
    assert rt2.nodes["c"].messages[0].kind == "/b"


def test_each_refused_sender_is_named_once(started, caplog):
    rt, imu, addr = in_patch(started, 'allow=["10.1.2.3"]', "")
    for host in ("127.0.0.1", "127.0.0.2", "127.0.0.1"):  # a second device (a phone on a new address)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as tx:
            tx.bind((host, 0))
            tx.sendto(osc("/a", 1).dgram, addr)
            assert wait_for(rt, lambda n=imu.refused + 1: imu.refused == n)
    named = [r.getMessage() for r in caplog.records if "not in allow" in r.getMessage()]
    assert named == [f"osc_in 'imu': ignoring {h} (not in allow)" for h in ("127.0.0.1", "127.0.0.2")]


def test_an_unreadable_sensor_message_is_logged_even_after_bad_packets(started, caplog):
    rt, imu, addr = in_patch(started, 'map=["/g=gyro"]', "node g collect\nimu.gyro -> g")
    with sender() as tx:
        for _ in range(3):
            tx.sendto(b"abc\n", addr)  # three bad packets: the packet count has had its first three
        tx.sendto(osc("/g", 1.0, 2.0).dgram, addr)  # one short
        tx.sendto(osc("/g", 1.0, 2.0, 3.0).dgram, addr)
        assert wait_for(rt, lambda: rt.nodes["g"].messages)
    assert imu.malformed == 4 and imu.unreadable == 1
    assert any("/g dropped" in r.getMessage() and "1 so far" in r.getMessage() for r in caplog.records)


def test_live_control_of_a_running_patch():
    rt = patch(
        """
node ctl    osc_in port=0
node lb     loadbang
node m      metro 100
node ticks  collect
node nulls  offset samples=2
node status collect
lb -> m -> ticks
nulls.status -> status
""",
        realtime=True,
    )
    th = rt.run_in_thread()
    ticks, status, metro = rt.nodes["ticks"].messages, rt.nodes["status"].messages, rt.nodes["m"]

    def until(predicate, timeout=30.0):  # (a ceiling for a loaded machine: what is waited for comes)
        deadline = time.monotonic() + timeout
        while not predicate():
            assert time.monotonic() < deadline, "timed out"
            time.sleep(0.005)

    try:
        until(lambda: rt.nodes["ctl"].address[1] != 0)
        addr = rt.nodes["ctl"].address
        with sender() as tx:
            tx.sendto(osc("/pointat/m/interval", 5.0).dgram, addr)  # a live parameter
            until(lambda: metro.p.interval == 5.0)
            n = len(ticks)
            until(lambda: len(ticks) - n >= 15)
            # 100 ms -> 5 ms, in the patch's time (a loaded machine runs the ticks late, never apart)
            last = [m.time for m in ticks[-10:]]  # (one copy: the scheduler's thread appends meanwhile)
            assert [round(b - a, 6) for a, b in zip(last[:-1], last[1:], strict=True)] == [0.005] * 9

            for _ in range(3):
                rt.send("nulls", "list", *[2048.0] * 9)
            until(lambda: len(status) == 2)
            assert [s.value[0] for s in status] == ["calibrating", "ready"]
            tx.sendto(osc("/pointat/nulls/recalibrate").dgram, addr)  # a method

            def feed():  # samples keep coming, as from a glove; the next status follows recalibrate
                rt.send("nulls", "list", *[2048.0] * 9)
                return len(status) >= 3

            until(feed)
            assert status[2].value[0] == "calibrating"

            # mistakes are logged, never fatal
            tx.sendto(osc("/pointat/nosuch/interval", 1.0).dgram, addr)
            tx.sendto(osc("/pointat/nulls/samples", 5).dgram, addr)  # not live
            tx.sendto(b"junk", addr)
            n = len(ticks)
            until(lambda: len(ticks) > n + 5)

            tx.sendto(osc("/pointat/m/stop").dgram, addr)
            until(lambda: metro._timer is None)  # the stop taken, however late
            n = len(ticks)
            time.sleep(0.05)
            assert len(ticks) == n  # stopped
            tx.sendto(osc("/pointat/m").dgram, addr)  # a bang to the left inlet: starts again
            until(lambda: len(ticks) > n)
        assert rt.nodes["ctl"].malformed == 1
    finally:
        rt.stop()
        th.join(timeout=5.0)
    assert not th.is_alive()


def test_our_encoder_writes_what_python_osc_writes():
    from pythonosc.osc_message_builder import OscMessageBuilder

    from pointat.devices.osc_wire import encode_message

    for address, args in [
        ("/a", []),
        ("/adm/obj/12/aed", [1.5, -30.25, 0.0]),
        ("/x", [3, "héllo", 2.5e-8, True]),
    ]:
        b = OscMessageBuilder(address)
        for a in args:
            b.add_arg(
                int(a) if isinstance(a, bool) else a,
                "f" if isinstance(a, float) else "i" if isinstance(a, int) else "s",
            )
        assert encode_message(address, args) == b.build().dgram


@pytest.mark.parametrize("profile", sorted(PROFILES))
def test_the_compiled_update_encoder_writes_what_render_and_encode_message_write(profile):
    from pointat.devices.osc_wire import encode_message
    from pointat.osc_bridge.encoder import UpdateEncoder
    from pointat.osc_bridge.profiles import Source

    prof = PROFILES[profile]
    messages = prof.messages or (("/g/{n}/x", ("n", "az", "el", "dist01", "spread", 7, 0.25, "pan")),)
    for n in (0, 1, 12):
        enc = UpdateEncoder(prof, n, messages)
        for src in (
            Source(n, 30.0),
            Source(n, -170.5, 12.25, 45.0, 50.0, 2.5),
            Source(n, 190.0, -95.0, 99.0),
        ):
            expected = [encode_message(a, args) for a, args in prof.render(src, messages)]
            assert enc.encode(src) == expected


def _packets():
    """Valid packets built by python-osc: every argument type it writes, bundles nested two deep."""
    specs = [
        ("/a", []),
        ("/sensors", [0.5, -1.25, 3.0, 1e-8, 2.0, 9.80665, 0.2, 0.0, -0.4]),
        ("/mixed", [1, 2.5, "héllo", True, False, None, "", "abc"]),
        ("/wide", [(2**40, "h"), (1.0 / 3.0, "d"), (b"\x00\x01\x02", "b"), 7]),
        ("/x/y/zz", ["a" * 3, "b" * 4, -(2**31)]),
    ]
    messages = []
    for address, args in specs:
        b = OscMessageBuilder(address)
        for a in args:
            if isinstance(a, tuple):
                b.add_arg(a[0], a[1])
            else:
                b.add_arg(a)
        messages.append(b.build())
    inner = OscBundleBuilder(PY_IMMEDIATELY)
    inner.add_content(messages[0])
    inner.add_content(messages[2])
    outer = OscBundleBuilder(PY_IMMEDIATELY)
    outer.add_content(messages[1])
    outer.add_content(inner.build())
    outer.add_content(messages[3])
    return [m.dgram for m in messages] + [outer.build().dgram]


def _python_osc(data):
    from pythonosc.osc_packet import OscPacket

    return [(m.message.address, list(m.message.params)) for m in OscPacket(data).messages]


def _python_osc_reads_all(data):
    """Whether python-osc reads every argument of ``data``: it skips the char ``c`` and Infinitum ``I``
    (with a warning), and the arguments after them shift."""
    from pointat.devices.osc_wire import _read_string

    def tags(message):
        _address, j = _read_string(message, 0, len(message))
        return _read_string(message, j, len(message))[0] if j < len(message) else ""

    return not any(t in tags(m) for m in _messages(data) for t in "cI")


def _messages(data):
    """The message datagrams of a well-formed packet, a bundle's in order."""
    if not data.startswith(b"#bundle\x00"):
        return [data]
    out, j = [], 16
    while j < len(data):
        size = struct.unpack_from(">i", data, j)[0]
        out += _messages(data[j + 4 : j + 4 + size])
        j += 4 + size
    return out


def test_decode_packet_reads_what_python_osc_reads():
    from pointat.devices.osc_wire import decode_packet

    for data in _packets():
        assert decode_packet(data) == _python_osc(data)


def test_decode_packet_says_malformed_with_a_value_error_and_never_reads_garbage_as_data():
    import random

    from pointat.devices.osc_wire import decode_packet

    rng = random.Random(7)
    packets = _packets()
    rejected = 0
    for _ in range(3000):
        data = bytearray(rng.choice(packets))
        for _ in range(rng.randint(1, 3)):
            if rng.random() < 0.5 and len(data) > 4:
                del data[rng.randrange(1, len(data)) :]  # cut short
            elif data:
                data[rng.randrange(len(data))] = rng.randrange(256)  # a flipped byte
        data = bytes(data)
        try:
            got = decode_packet(data)
        except ValueError:
            rejected += 1
            continue
        if _python_osc_reads_all(data):
            assert got == _python_osc(data)  # what is accepted, python-osc reads the same way
    assert rejected > 500  # the damage is mostly caught


def _char_then_floats():
    """``/imu/acc ,cfff 'A' 1 2 3`` (python-osc's builder writes no chars)."""
    return b"/imu/acc\x00\x00\x00\x00,cfff\x00\x00\x00" + struct.pack(">ifff", ord("A"), 1.0, 2.0, 3.0)


def test_decode_packet_reads_chars_and_infinitum_in_place_and_checks_every_tag():
    from pointat.devices.osc_wire import decode_packet

    data = _char_then_floats()  # python-osc 1.10 skips the char: [9e-44, 1.0, 2.0]
    assert decode_packet(data) == [("/imu/acc", ["A", 1.0, 2.0, 3.0])]
    infinitum = b"/a\x00\x00,Iff\x00\x00\x00\x00" + struct.pack(">ff", 1.0, 2.0)
    assert decode_packet(infinitum) == [("/a", [math.inf, 1.0, 2.0])]
    blob_then_unknown = b"/a\x00\x00,bQ\x00" + struct.pack(">i", 4) + b"abcd"
    with pytest.raises(ValueError, match="unknown OSC type tag 'Q'"):
        decode_packet(blob_then_unknown)
    with pytest.raises(ValueError, match="not a character"):
        decode_packet(b"/a\x00\x00,c\x00\x00" + struct.pack(">i", -5))
    assert _python_osc_reads_all(infinitum) is False and _python_osc_reads_all(blob_then_unknown[:12]) is True


def test_a_char_among_sensor_numbers_is_refused_not_read_shifted(started):
    rt, imu, addr = in_patch(started, 'map=["/imu/acc=accel"]', "node a collect\nimu.accel -> a")
    with sender() as tx:
        tx.sendto(_char_then_floats(), addr)
        tx.sendto(osc("/imu/acc", 4.0, 5.0, 6.0).dgram, addr)
        assert wait_for(rt, lambda: rt.nodes["a"].messages)
    assert rt.nodes["a"].values == [(4.0, 5.0, 6.0)]
    assert imu.malformed == 1


def test_the_field_clamps_are_min_max_including_nan():
    from pointat.osc_bridge.profiles import FIELDS, Source

    for v in (-1e9, -200.0, -90.0, -0.5, 0.0, 45.0, 90.0, 99.0, 100.0, 1e9, math.nan):
        s = Source(1, 0.0, v, v, v)
        expected = (min(max(v, -90.0), 90.0), min(max(v, 0.0), 90.0), min(max(v, 0.0), 100.0))
        got = (FIELDS["el"].fn(s), FIELDS["dist"].fn(s), FIELDS["spread"].fn(s))
        assert str(got) == str(expected)  # (as text: nan == nan)


def test_osc_in_says_the_sensors_full_scale_and_tqt_flags_a_reading_at_the_rail(started):
    rt, imu, addr = in_patch(
        started,
        "device=ngimu acc_range=16 gyro_range=2000",
        "node fuse tqt\nnode r collect\nnode flags collect\nimu.range -> r\nimu.range -> fuse.range\n"
        "imu.gyro -> fuse.gyro\nimu.accel -> fuse.accel\nimu.mag -> fuse.mag\nfuse.flags -> flags",
    )
    [(acc, gyro)] = rt.nodes["r"].values
    assert acc == pytest.approx(16 * 9.80665) and gyro == pytest.approx(math.radians(2000.0))
    rest = osc("/sensors", 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 20.0, 0.0, -40.0, 1013.25)
    strike = osc("/sensors", 0.0, 0.0, 0.0, 16.0, 0.0, 1.0, 20.0, 0.0, -40.0, 1013.25)  # x at +16 g
    with sender() as tx:
        for _ in range(5):
            tx.sendto(rest.dgram, addr)
        tx.sendto(strike.dgram, addr)
        assert wait_for(rt, lambda: any("acc_saturated" in str(v) for v in rt.nodes["flags"].values))


def test_numbers_beyond_float32_neither_silence_osc_out_nor_pass_as_settings(started, receivers):
    rx = receivers()
    rt, out = out_node(started, rx.port, "profile=generic fields=[az, dist_m] radius=3e38")
    push(out, 30.0, el=0.0, dist=0.0)
    [(_, _, _, (az, dist_m))] = rx.messages(1)
    assert dist_m == pytest.approx(3e38, rel=1e-6)  # the largest radius an OSC float holds goes out
    with pytest.raises(ValueError, match=r"radius 1e\+39 is beyond an OSC float"):
        out.receive(0, method("radius", 1e39))  # as a live OSC double would set it
    assert out.p.radius == 3e38
    push(out, 40.0, el=0.0, dist=0.0)
    [(_, _, _, (az, dist_m))] = rx.messages(1)  # not silenced
    assert az == pytest.approx(40.0)
    with pytest.raises(PatchError, match=r"<test>:1: .*radius 1e\+39 is beyond an OSC float"):
        patch(f"node out osc_out port={rx.port} radius=1e39")
    with pytest.raises(PatchError, match=r"field 5000000000: an OSC int is 32 bits"):
        patch(f"node out osc_out port={rx.port} profile=generic fields=[az, 5000000000]")
    with pytest.raises(PatchError, match=r"field 1e\+39: beyond an OSC float"):
        patch(f"node out osc_out port={rx.port} profile=generic fields=[az, 1e39]")


def test_live_control_names_no_file_or_device(tmp_path, started, caplog):
    """The rule: a message from outside names no path.  ``/pointat/cal/save`` saves where the patch
    says; ``/pointat/cal/save ~/.bashrc`` (any local process can send it) is refused and writes nothing;
    so are ``load PATH`` and a device path sent to a ``mote``."""
    cal = tmp_path / "cal.json"
    victim = tmp_path / "bashrc"
    victim.write_text("export PS1=x\n")
    master, slave = os.openpty()
    try:
        rt, imu, addr = in_patch(
            started,
            "",
            f"node cal calibrate file={cal}\nnode base mote device={os.ttyname(slave)}\nnode s collect\n"
            "node m1 collect\nbase.m1 -> m1\ncal -> s",
        )
        with sender() as tx:
            for address, args in (
                ("/pointat/cal/save", [str(victim)]),
                ("/pointat/cal/load", [str(victim)]),
                ("/pointat/base/open", ["/etc/passwd"]),
                ("/pointat/base", ["/etc/passwd"]),
            ):
                tx.sendto(osc(address, *args).dgram, addr)
            assert wait_for(rt, lambda: imu.refused_control == 4)
            tx.sendto(osc("/pointat/cal/save").dgram, addr)
            assert wait_for(rt, lambda: cal.exists())
        assert victim.read_text() == "export PS1=x\n"
        assert rt.nodes["base"].p.device == os.ttyname(slave)
        assert "live control names no files or devices" in caplog.text
    finally:
        os.close(master)
        os.close(slave)


# --------------------------------------------------------------------------- osc_out: status to the receiver
def _statuses(rx):
    return [(args[0], round(args[1], 1)) for _, addr, _, args in rx.messages() if addr.endswith("/status")]


def test_the_receiver_hears_waiting_ok_a_dropout_and_the_filters_flags(started, receivers):
    rx = receivers()
    rt, out = out_node(started, rx.port, "source=3")
    rt.advance(1.05)  # no direction yet, for a heartbeat: "waiting"
    assert _statuses(rx) == [("waiting", 0.0)]
    for k in range(100):  # 100 Hz for a second
        rt.advance(0.01)
        push(out, k * 0.1, 1.0)
    got = [m for m in rx.messages() if m[1].endswith("/status")]
    assert [m[1] for m in got] == ["/pointat/3/status"]  # the source's own number
    assert got[0][3][0] == "ok"  # told at the next look (0.1 s) after the first direction
    rt.advance(0.1)  # a heartbeat a second after the last status (the "ok"): the updates since then
    ((state, rate),) = _statuses(rx)
    assert state == "ok" and 94 <= rate <= 101, rate
    out.receive(4, make("mag_disturbed"))
    rt.advance(0.1)
    assert _statuses(rx)[0][0] == "mag_disturbed"  # at once, not at the next heartbeat
    out.receive(4, make("ok"))
    rt.advance(0.1)
    assert _statuses(rx)[0][0] == "ok"
    rt.advance(0.25)  # 0.45 s without a direction: not yet a dropout
    assert [s for s, _ in _statuses(rx)] == []
    rt.advance(0.2)  # past 0.5 s, and the look after it
    assert [s for s, _ in _statuses(rx)] == ["dropout"]
    push(out, 5.0)
    rt.advance(0.1)
    assert [s for s, _ in _statuses(rx)] == ["ok"]


def test_status_follows_the_profile_and_can_be_set_or_turned_off(started, receivers):
    rx = receivers()
    rt, out = out_node(started, rx.port, "profile=adm")  # a product: no foreign addresses unless asked
    rt.advance(3.0)
    assert _statuses(rx) == []
    out.set_param("status", 0.5)  # live: from now on, every 0.5 s
    rt.advance(1.05)
    assert [s for s, _ in _statuses(rx)] == ["waiting", "waiting"]
    rx2 = receivers()
    rt2, out2 = out_node(started, rx2.port, "status=0")
    rt2.advance(2.0)
    push(out2, 1.0)
    rt2.advance(2.0)
    assert [m[1] for m in rx2.messages()] == ["/pointat/1/aed"]


def test_a_heartbeat_keeps_no_ended_patch_running():
    from pointat.testing import patch as make_patch

    rt = make_patch("node m msg 1\nnode on loadbang\nnode out osc_out port=9\non -> m -> out")
    rt.start()
    rt.advance(2.0)
    assert rt._timers and all(t.daemon or t.cancelled for t in rt._timers)
    assert rt._finished()
    rt.shutdown()


def test_a_hand_held_still_with_send_on_change_is_no_dropout(started, receivers):
    rx = receivers()
    rt, out = out_node(started, rx.port, "change=true deadband=0.5")
    for _ in range(200):  # two seconds of the same direction: one update sent, the rest held back
        rt.advance(0.01)
        push(out, 10.0, 2.0)
    assert out.updates == 1
    assert "dropout" not in [s for s, _ in _statuses(rx)]
