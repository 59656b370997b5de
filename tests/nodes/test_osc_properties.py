"""Property-based tests of ``osc_in``: what any sender on the network may put in a datagram.

Datagrams go to the node's own reader (:meth:`OscIn._readable`) through a stand-in socket, so no packet
is lost on the way and every example is checked datagram by datagram.  Properties: nothing raises out
of the node; a malformed packet is counted as such and a well-formed one never is; a sensor message
comes out of its outlets as the rules say (the arguments times the scale, right count, floats), and no
NaN or infinity comes out that the sender did not send; a good sensor message after any garbage still
comes out; live control with any address and any arguments leaves every parameter of every node valid;
the node's memories stay bounded.  The map rules (``parse_rule``) refuse what they cannot read.
"""

from __future__ import annotations

import contextlib
import fnmatch
import math
import struct
from typing import Any

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from pointat.node import ParamError
from pointat.osc_bridge.profiles import SENSOR_OUTLETS, G, parse_rule
from pointat.testing import patch

SETTINGS = settings(
    max_examples=60,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)

# --------------------------------------------------------------------------- an OSC writer for the tests
# Written here from the OSC 1.0 specification (with the 1.1 and common additions), so that it can write
# what python-osc's builder will not: NaN and infinity in any type, every tag, NULs inside strings.


def _pad(b: bytes) -> bytes:
    return b + b"\x00" * (-len(b) % 4)


def osc_string(b: bytes) -> bytes:
    return b + b"\x00" * (4 - len(b) % 4)


def message(address: bytes, args: list[tuple[str, bytes]]) -> bytes:
    return (
        osc_string(address)
        + osc_string(("," + "".join(t for t, _ in args)).encode())
        + b"".join(d for _, d in args)
    )


def bundle(elements: list[bytes], stamp: bytes = b"\x00" * 7 + b"\x01") -> bytes:
    return b"#bundle\x00" + stamp + b"".join(struct.pack(">i", len(e)) + e for e in elements)


# An argument as (tag, its bytes, what it decodes to): NUMBER for the numbers a sensor reads.
def _arg(tag: str, fmt: str | None = None):
    return lambda v: (tag, struct.pack(">" + fmt, v) if fmt else b"", v)


ints = st.integers(-(2**31), 2**31 - 1).map(_arg("i", "i"))
int64s = st.integers(-(2**63), 2**63 - 1).map(_arg("h", "q"))
float32s = st.floats(width=32).map(_arg("f", "f"))
float64s = st.floats().map(_arg("d", "d"))
numbers = st.one_of(float32s, float64s, ints, int64s)
texts = st.text(st.characters(blacklist_characters="\x00", blacklist_categories=("Cs",)), max_size=12)
strings = texts.map(lambda s: ("s", osc_string(s.encode()), s))
blobs = st.binary(max_size=12).map(lambda b: ("b", struct.pack(">i", len(b)) + _pad(b), b))
constants = st.sampled_from([("T", b"", True), ("F", b"", False), ("N", b"", None), ("I", b"", math.inf)])
chars = st.integers(0, 0x10FFFF).map(lambda c: ("c", struct.pack(">i", c), chr(c)))
others = st.sampled_from(
    [("t", b"\x00" * 7 + b"\x01", None), ("m", b"\x00\x90\x3c\x40", None), ("r", b"\xff\x00\x00\xff", None)]
)
any_arg = st.one_of(numbers, strings, blobs, constants, chars, others)
#: Not numbers, among a sensor's arguments (not the colour 'r': python-osc reads it as an int).
sensor_other = st.one_of(strings, blobs, constants, chars, others.filter(lambda a: a[0] != "r"))

#: Tags python-osc (which osc_in hands blobs, arrays, time tags, MIDI and colours to) does not read.
_NOT_PYTHON_OSC = set("cIS")
_PYTHON_OSC_ONLY = set("bmtr[]")


def tags_of(args) -> str:
    return "".join(a[0] for a in args)


def well_formed(args) -> bool:
    """Whether osc_in reads a message of these arguments: always, but a char, an Infinitum or an 'S'
    next to a type only python-osc reads (python-osc would skip them and read the rest shifted)."""
    tags = set(tags_of(args))
    return not (tags & _PYTHON_OSC_ONLY and tags & _NOT_PYTHON_OSC)


addresses = st.one_of(
    st.sampled_from(["/sensors", "/quaternion", "/imu/left/acc", "/imu//acc", "/q", "/cue", "/a/b/c"]),
    texts.map(lambda s: "/" + s),
)

# --------------------------------------------------------------------------- the patch and its model

RULES = [  # (pattern, outlet, indices, scale): ngimu's, then the map's
    ("/sensors", "gyro", (0, 1, 2), math.pi / 180.0),
    ("/sensors", "accel", (3, 4, 5), G),
    ("/sensors", "mag", (6, 7, 8), 0.01),
    ("/quaternion", "quat", (0, 1, 2, 3), 1.0),
    ("/imu/*/acc", "accel", (0, 1, 2), 2.0),
    ("/q", "quat", (0, 1, 2, 3), 1.0),
]
SENSOR_TEXT = """
node imu osc_in port=0 device=ngimu map=["/imu/*/acc=accel*2", "/q=quat"]
node got_gyro collect
node got_accel collect
node got_mag collect
node got_quat collect
node got_any collect
imu.gyro -> got_gyro
imu.accel -> got_accel
imu.mag -> got_mag
imu.quat -> got_quat
imu.any -> got_any
"""
#: Nodes with live parameters of every kind, for live control.
CONTROLLED = """
node metro metro 100
node out osc_out profile=adm port=9
node mp map
node thr threshold
node sm smooth
node fuse tqt
node gi gyro_integrator
node sl speedlim
node dl delay
"""


class FakeSocket:
    """What ``_readable`` reads: the datagrams given, then "nothing more" (a non-blocking socket's)."""

    def __init__(self, datagrams: list[bytes], sender=("127.0.0.1", 50000)):
        self.datagrams = list(datagrams)
        self.sender = sender

    def recvfrom(self, size: int):
        if not self.datagrams:
            raise BlockingIOError
        return self.datagrams.pop(0)[:size], self.sender

    def getsockname(self):
        return ("127.0.0.1", 9001)


@contextlib.contextmanager
def running(text: str):
    rt = patch(text)
    rt.start()
    try:
        yield rt
    finally:
        rt.shutdown()


def deliver(imu, data: bytes) -> None:
    """One datagram through the node's reader, as the scheduler calls it when the socket is readable."""
    real, imu._sock = imu._sock, FakeSocket([data])
    try:
        imu._readable()  # an exception here fails the test: nothing may raise out of the node
    finally:
        imu._sock = real


def sensor_outputs(rt) -> dict[str, list[tuple]]:
    return {
        name: [m.value for m in rt.nodes[f"got_{name}"].messages if m.kind == "vector"]
        for name in SENSOR_OUTLETS
    }


def expected(address: str, args) -> tuple[dict[str, list[tuple]], int]:
    """What the rules make of one message: per outlet the values, and how many rules could not read it
    (numbers only, as many as the rule takes; a finite number the scale overflows is refused too)."""
    out: dict[str, list[tuple]] = {name: [] for name in SENSOR_OUTLETS}
    unreadable = 0
    for pattern, outlet, idx, scale in RULES:
        if not fnmatch.fnmatchcase(address, pattern):
            continue
        if len(args) <= max(idx) or any(args[i][0] not in "ifdhI" for i in idx):
            unreadable += 1
            continue
        values = tuple(args[i][2] * scale for i in idx)
        if any(not math.isfinite(v) and math.isfinite(args[i][2]) for v, i in zip(values, idx, strict=True)):
            unreadable += 1  # a reading of 1e308 g is no reading: refused, not sent on as infinity
            continue
        out[outlet].append(values)
    return out, unreadable


def same(a: tuple, b: tuple) -> bool:
    return len(a) == len(b) and all(
        x == y or (math.isnan(x) and math.isnan(y)) for x, y in zip(a, b, strict=True)
    )


def decoded(arg) -> Any:
    """What a well-formed argument decodes to (float32 as the float it holds)."""
    tag, data, value = arg
    if tag == "f":
        return struct.unpack(">f", data)[0]
    return value


# --------------------------------------------------------------------------- datagrams


@st.composite
def sensor_message(draw) -> tuple[bytes, str, list]:
    """A message a sensor rule matches, its arguments mostly numbers (NaN, infinity, huge ones too)."""
    address = draw(st.sampled_from(["/sensors", "/quaternion", "/imu/left/acc", "/imu//acc", "/q"]))
    n = draw(st.integers(0, 11))
    args = draw(st.lists(st.one_of(numbers, numbers, numbers, sensor_other), min_size=n, max_size=n))
    args = [(t, d, decoded((t, d, v))) for t, d, v in args]
    return message(address.encode(), [(t, d) for t, d, _ in args]), address, args


@st.composite
def any_message(draw) -> tuple[bytes, bool | None]:
    """A message with any address and arguments; whether osc_in reads it (None: a string holds a NUL,
    which ends it early, and what follows is read misaligned, or refused)."""
    args = draw(st.lists(any_arg, max_size=8))
    address = draw(addresses)
    if draw(st.integers(0, 4)) == 0:  # a NUL inside a string, or inside the address
        text = draw(texts) + "\x00" + draw(texts)
        if draw(st.booleans()):
            address = "/" + text
        else:
            args.insert(draw(st.integers(0, len(args))), ("s", osc_string(text.encode()), text))
        return message(address.encode(), [(t, d) for t, d, _ in args]), None
    return message(address.encode(), [(t, d) for t, d, _ in args]), well_formed(args)


@st.composite
def any_bundle(draw, depth: int = 0) -> tuple[bytes, bool]:
    elements = draw(
        st.lists(
            any_message() if depth >= 3 else st.one_of(any_message(), any_bundle(depth + 1)),
            max_size=4,
        )
    )
    stamp = draw(st.one_of(st.just(b"\x00" * 7 + b"\x01"), st.binary(min_size=8, max_size=8)))
    oks = [ok for _, ok in elements]
    return bundle([e for e, _ in elements], stamp), None if None in oks else all(oks)


@st.composite
def damaged(draw) -> bytes:
    """A good packet cut short, with bytes changed, or with junk glued on."""
    data = bytearray(draw(st.one_of(any_message(), any_bundle()))[0])
    for _ in range(draw(st.integers(1, 3))):
        how = draw(st.sampled_from(["cut", "flip", "insert"]))
        if how == "cut" and data:
            del data[draw(st.integers(0, len(data) - 1)) :]
        elif how == "flip" and data:
            data[draw(st.integers(0, len(data) - 1))] = draw(st.integers(0, 255))
        else:
            at = draw(st.integers(0, len(data)))
            data[at:at] = draw(st.binary(min_size=1, max_size=8))
    return bytes(data)


def surely_malformed(data: bytes) -> bool:
    """Malformed whatever else it holds: OSC packets are a positive multiple of 4 bytes and start with
    an address ('/') or '#bundle'."""
    return (
        len(data) == 0 or len(data) % 4 != 0 or not (data.startswith(b"/") or data.startswith(b"#bundle\x00"))
    )


datagrams = st.one_of(
    st.binary(max_size=64).map(lambda d: (d, None)),
    any_message(),
    any_bundle(),
    damaged().map(lambda d: (d, None)),
)

GOOD = message(
    b"/sensors", [("f", struct.pack(">f", v)) for v in (1.0, 2.0, 3.0, 0.0, 0.0, 1.0, 20.0, 0.0, -40.0)]
)
GOOD_OUT = {
    "gyro": tuple(v * (math.pi / 180.0) for v in (1.0, 2.0, 3.0)),
    "accel": (0.0, 0.0, G),
    "mag": (0.2, 0.0, -0.4),
}


QUAT = [("f", struct.pack(">f", v)) for v in (1.0, 2.0, 3.0, 0.0)]  # the 0.0 reads as an empty blob's size

# --------------------------------------------------------------------------- properties


@SETTINGS
@given(st.lists(datagrams, min_size=1, max_size=12), st.booleans())
def test_any_datagrams_never_raise_out_are_counted_when_malformed_and_a_good_one_still_comes_through(
    items, timetags
):
    text = SENSOR_TEXT.replace("device=ngimu", "device=ngimu timetags=true") if timetags else SENSOR_TEXT
    with running(text) as rt:
        imu = rt.nodes["imu"]
        for data, readable in items:
            before = (imu.received, imu.malformed, imu.unreadable)
            deliver(imu, data)
            packet_malformed = (imu.malformed - before[1]) - (imu.unreadable - before[2])
            assert packet_malformed in (0, 1)
            if surely_malformed(data):
                assert packet_malformed == 1 and imu.received == before[0], data
            if readable is True:
                assert packet_malformed == 0, data
            if readable is False:  # a char, an Infinitum or an 'S' beside a blob: refused, not misread
                assert packet_malformed == 1, data
        deliver(imu, GOOD)
        got = sensor_outputs(rt)
        for name, values in GOOD_OUT.items():
            assert got[name] and same(got[name][-1], values), name
        # what came out of a sensor outlet is floats, as many as the outlet carries
        for name, outs in got.items():
            assert all(len(v) == SENSOR_OUTLETS[name] and all(type(x) is float for x in v) for v in outs)
        times = [m.time for n in SENSOR_OUTLETS for m in rt.nodes[f"got_{n}"].messages]
        assert all(math.isfinite(t) for t in times)  # whatever time tag a bundle had
        assert len(imu._routes) <= imu.ROUTES_KEPT


@SETTINGS
@given(st.lists(sensor_message(), min_size=1, max_size=10))
@example(  # a finite reading that the scale makes infinite (1e308 g) went out as infinity
    [(message(b"/imu/x/acc", [("d", struct.pack(">d", 1e308))] * 3), "/imu/x/acc", [("d", b"", 1e308)] * 3)]
)
@example(  # a char among the numbers next to a blob: python-osc skipped it and read the rest shifted
    [
        (
            message(b"/q", [("c", struct.pack(">i", 65)), *QUAT, ("b", struct.pack(">i", 0))]),
            "/q",
            [("c", b"", "A"), *[(t, d, struct.unpack(">f", d)[0]) for t, d in QUAT], ("b", b"", b"")],
        )
    ]
)
def test_sensor_messages_come_out_as_the_rules_say_and_no_nan_or_infinity_that_was_not_sent(items):
    with running(SENSOR_TEXT) as rt:
        imu = rt.nodes["imu"]
        for data, address, args in items:
            before = sensor_outputs(rt)
            unreadable = imu.unreadable
            malformed = imu.malformed
            deliver(imu, data)
            after = sensor_outputs(rt)
            if not well_formed(args):
                assert imu.malformed == malformed + 1 and after == before  # refused whole
                continue
            want, refused = expected(address, args)
            assert imu.unreadable - unreadable == refused
            for name in SENSOR_OUTLETS:
                new = after[name][len(before[name]) :]
                assert len(new) == len(want[name]) and all(map(same, new, want[name])), (
                    name,
                    new,
                    want[name],
                )


# --------------------------------------------------------------------------- live control

control_values = st.one_of(
    numbers,
    st.sampled_from(
        ["nan", "inf", "-inf", "1e400", "-1", "0", "1", "true", "off", "", "linear", "exact"]
    ).map(lambda s: ("s", osc_string(s.encode()), s)),
    strings,
    blobs,
    constants,
)


@st.composite
def control_message(draw, names: list[str], selectors: list[str], live: list[str]) -> bytes:
    if draw(st.booleans()):  # a live parameter of a node of the patch: /pointat/NODE/PARAM value
        address = "/pointat/" + draw(st.sampled_from(live))
        args = draw(st.lists(control_values, min_size=1, max_size=2))
    else:
        node = draw(st.one_of(st.sampled_from(names), texts))
        parts = draw(st.lists(st.one_of(st.sampled_from(selectors), texts), max_size=2))
        address = "/pointat/" + "/".join([node, *parts])
        args = draw(st.lists(control_values, max_size=3))
    return message(address.encode(), [(t, d) for t, d, _ in args]), well_formed(args)


def _control_patch() -> tuple[str, list[str], list[str], list[str]]:
    text = "node imu osc_in port=0\n" + CONTROLLED
    rt = patch(text)
    names = [n for n in rt.nodes if n != "imu"]
    selectors = sorted({p.name for n in names for p in type(rt.nodes[n]).params})
    selectors += sorted({a[3:] for n in names for a in dir(rt.nodes[n]) if a.startswith("do_")})
    live = [f"{n}/{p.name}" for n in names for p in type(rt.nodes[n]).params if p.live]
    rt.shutdown()
    return text, names, selectors, live


CONTROL_TEXT, CONTROL_NODES, CONTROL_SELECTORS, CONTROL_LIVE = _control_patch()


def check_params(rt, fixed: dict[str, dict[str, Any]]) -> None:
    """Every parameter of every node is what its declaration allows, and the ones that are not live are
    what they were."""
    for name, node in rt.nodes.items():
        cls = type(node)
        values = vars(node.p)
        for p in cls.params:
            v = values[p.name]
            try:
                again = p.coerce(v)
            except ParamError as exc:
                pytest.fail(f"node '{name}': parameter '{p.name}' = {v!r} is invalid: {exc}")
            assert again == v or (isinstance(v, float) and math.isnan(v) and math.isnan(again)), (
                name,
                p.name,
                v,
            )
        cls.validate(values)
        assert {k: values[k] for k in fixed[name]} == fixed[name], name


@SETTINGS
@given(st.lists(control_message(CONTROL_NODES, CONTROL_SELECTORS, CONTROL_LIVE), min_size=1, max_size=15))
def test_live_control_with_any_address_and_arguments_never_raises_out_nor_sets_an_invalid_value(msgs):
    with running(CONTROL_TEXT) as rt:
        imu = rt.nodes["imu"]
        fixed = {
            name: {p.name: getattr(node.p, p.name) for p in type(node).params if not p.live}
            for name, node in rt.nodes.items()
        }
        for data, readable in msgs:
            received, malformed = imu.received, imu.malformed
            deliver(imu, data)
            # read, then done with or refused (an Infinitum beside a blob is refused as malformed)
            assert (imu.received - received, imu.malformed - malformed) == ((1, 0) if readable else (0, 1))
            check_params(rt, fixed)
        assert len(imu._refusals.counts) <= imu.REFUSED_ADDRESSES + 1


# --------------------------------------------------------------------------- map rules


@SETTINGS
@given(
    st.one_of(
        st.text(max_size=30),
        st.tuples(
            st.sampled_from(["/imu/acc", "*/gyro", "/a=b", "", "imu"]),
            st.sampled_from([*SENSOR_OUTLETS, "", "acc", "gyro*"]),
            st.one_of(
                st.just(""),
                st.sampled_from(["nan", "inf", "-inf", "1e400", "1e-400", "0", "2", " 3 ", "1_0", "x", "*2"]),
                st.floats().map(repr),
            ),
        ).map(lambda t: f"{t[0]}={t[1]}" + (f"*{t[2]}" if t[2] else "")),
    )
)
@example("/imu/acc=accel*inf")
@example("/imu/acc=accel*nan")
@example("/imu/acc=accel*1e400")
def test_a_map_rule_is_read_whole_or_refused_naming_the_entry(text):
    try:
        rule = parse_rule(text)
    except ValueError as exc:
        assert str(exc).startswith(f"map entry {text!r}: ")
        return
    assert rule.pattern.startswith(("/", "*")) and rule.outlet in SENSOR_OUTLETS
    assert math.isfinite(rule.scale), f"{text!r} gave a scale of {rule.scale}"
    assert text == f"{rule.pattern}={rule.outlet}" or text.startswith(f"{rule.pattern}={rule.outlet}*")
