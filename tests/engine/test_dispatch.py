"""Message order: right to left, depth first, fan-out in wire order; hot and cold inlets; the depth guard."""

import logging
import math
import re

import numpy as np
import pytest

from pointat.errors import PatchError
from pointat.message import as_float, bang, make, method, vector
from pointat.node import Inlet, Node, Outlet, Param
from pointat.testing import patch


def test_trigger_fires_right_to_left_converting_each_outlet():
    rt = patch("""
node t trigger b f l
node a collect
t.0 -> a
t.1 -> a
t.2 -> a
""")
    rt.nodes["t"].receive(0, make(3))
    assert [(m.kind, m.value) for m in rt.nodes["a"].messages] == [
        ("list", (3,)),
        ("float", 3.0),
        ("bang", None),
    ]


def test_trigger_that_cannot_convert_for_one_outlet_fires_none():
    rt = patch("""
node t trigger l s a
node a collect
t.0 -> a
t.1 -> a
t.2 -> a
""")
    t = rt.nodes["t"]
    with pytest.raises(TypeError, match="expected a symbol"):
        t.receive(0, make([1.0, 2.0, 3.0]))
    assert rt.nodes["a"].messages == []  # not the float alone, half a trigger
    t.receive(0, make("x"))
    assert [(m.kind, m.value) for m in rt.nodes["a"].messages] == [
        ("symbol", "x"),
        ("symbol", "x"),
        ("list", ("x",)),
    ]


def test_depth_first_and_fan_out_order():
    rt = patch("""
node t trigger a a
node u trigger a a
node log collect
node x msg left $1
node y msg right-first $1
node z msg fan2 $1
t.1 -> u
u.1 -> y -> log
u.0 -> x -> log
t.0 -> z -> log
""")
    rt.nodes["t"].receive(0, make(5))
    got = [m.kind + " " + str(m.value[0]) for m in rt.nodes["log"].messages]
    # t fires right (into u, whose whole subtree runs first: right then left), then left
    assert got == ["right-first 5", "left 5", "fan2 5"]


def test_fan_out_follows_wire_order():
    rt = patch("""
node src trigger a
node one msg one
node two msg two
node log collect
src -> two -> log
src -> one -> log
""")
    rt.nodes["src"].receive(0, bang())
    assert [m.kind for m in rt.nodes["log"].messages] == ["two", "one"]


def test_cold_inlets_store_hot_inlet_outputs():
    rt = patch("""
node p pack 0 0 0
node out collect
p -> out
""")
    p = rt.nodes["p"]
    p.receive(2, make(3.0))
    p.receive(1, make(2.0))
    assert rt.nodes["out"].messages == []
    p.receive(0, make(1.0))
    assert rt.nodes["out"].values == [(1.0, 2.0, 3.0)]
    p.receive(0, bang())
    assert rt.nodes["out"].values[-1] == (1.0, 2.0, 3.0)


def test_a_vector_wired_into_pack_is_refused_when_the_patch_is_checked():
    # `pointat help pack` lists what its inlets take: a quaternion must be unpacked first
    with pytest.raises(
        PatchError, match=r"outlet 'truth' sends vector, inlet 'in1' of 'p' accepts bang\|float"
    ):
        patch("node g simulate\nnode p pack 0 0\ng.truth -> p.1\n")


def test_cold_param_inlet_sets_parameter():
    rt = patch("node m metro 100\nnode out collect\nm -> out\n")
    m = rt.nodes["m"]
    m.receive(1, make(250))
    assert m.p.interval == 250.0
    with pytest.raises(ValueError, match="interval"):
        m.receive(1, make("fast"))


def test_unpack_vector_right_to_left():
    rt = patch("""
node u unpack f f f f
node log collect
u.3 -> log
u.0 -> log
""")
    rt.nodes["u"].receive(0, vector([0.5, 0.1, 0.2, 0.3]))
    assert rt.nodes["log"].values == [0.3, 0.5]


def test_route_by_selector_and_first_element():
    rt = patch("""
node r route recalibrate 3 k
node a collect
node b collect
node c collect
node rest collect
r.0 -> a
r.1 -> b
r.2 -> c
r.3 -> rest
""")
    r = rt.nodes["r"]
    r.receive(0, method("recalibrate"))
    r.receive(0, make([3, 4, 5]))
    r.receive(0, method("k", 0.5))
    r.receive(0, make("other"))
    assert rt.nodes["a"].messages[0].kind == "bang"
    assert rt.nodes["b"].values == [(4, 5)]
    assert rt.nodes["c"].values == [0.5]
    assert rt.nodes["rest"].values == ["other"]


def test_send_receive_by_name_and_msg_semicolon():
    rt = patch("""
node s send bus=speed
node r1 receive speed
node r2 receive speed
node m msg 1 , 2 ; speed 7
node a collect
node b collect
r1 -> a
r2 -> b
m -> a
""")
    rt.start()
    rt.nodes["s"].receive(0, make(0.25))
    assert rt.nodes["a"].values == [0.25] and rt.nodes["b"].values == [0.25]
    rt.nodes["m"].receive(0, bang())
    assert rt.nodes["a"].values == [0.25, 1, 2, 7]
    rt.shutdown()


def test_msg_separators_written_against_a_word_split_as_in_pd():
    rt = patch(
        "node m msg turn_end -220 2, save;bus go\nnode a collect\nnode r receive bus\nm -> a\nr -> a\n"
    )
    rt.start()
    rt.nodes["m"].receive(0, bang())
    assert [(m.kind, m.value) for m in rt.nodes["a"].messages] == [
        ("turn_end", (-220, 2)),
        ("save", ()),
        ("go", ()),
    ]
    rt.shutdown()
    quoted = patch('node m msg "a, b"\nnode a collect\nm -> a\n')  # quoted, a comma is just text
    quoted.nodes["m"].receive(0, bang())
    assert [m.kind for m in quoted.nodes["a"].messages] == ["a, b"]


def test_change_drops_repeats_including_vectors():
    rt = patch("node c change\nnode out collect\nc -> out\n")
    c = rt.nodes["c"]
    for v in (1.0, 1.0, 2.0, 2.0, 1.0):
        c.receive(0, make(v))
    c.receive(0, vector([1, 2, 3]))
    c.receive(0, vector([1, 2, 3]))
    assert rt.nodes["out"].values[:3] == [1.0, 2.0, 1.0]
    assert len(rt.nodes["out"].values) == 4


def test_depth_guard_turns_runtime_feedback_into_an_error(caplog):
    # A loop the checker cannot see (through send/receive with a bus set while running) still hits the guard.
    rt = patch("""
node s send
node r receive loop
node t trigger a
r -> t -> s
""")
    rt.start()
    s = rt.nodes["s"]
    s.set_param("bus", "loop")
    with caplog.at_level(logging.ERROR):
        rt.post(s, s.receive, 0, make(1.0))
        rt.drain()
    assert any("feedback loop" in r.getMessage() for r in caplog.records)
    assert rt.depth == 0
    # the patch survives: the next message is handled normally
    s.set_param("bus", "elsewhere")
    rt.post(s, s.receive, 0, make(2.0))
    assert rt.drain() == 1
    rt.shutdown()


class Doubler(Node):
    type_name = "doubler_test"
    inlets = (Inlet("in", ("float", "int")), Inlet("gain", ("float",), param="gain"))
    outlets = (Outlet("out", "float"),)
    params = (Param("gain", "float", 2.0, live=True),)

    def on_in(self, msg):
        self.out(0, self.p.gain * as_float(msg))

    def do_reset(self):
        self.p.gain = 2.0


def test_bad_message_is_logged_with_node_name_and_dropped(caplog):
    from pointat.runtime import Runtime
    from pointat.testing import Collect

    rt = Runtime(realtime=False)
    src = rt.add(Doubler("src"))
    dst = rt.add(Doubler("twice"))
    out = rt.add(Collect("out"))
    rt.connect(src, 0, dst, 0)
    rt.connect(dst, 0, out, 0)
    rt.start()
    with caplog.at_level(logging.ERROR):
        src.out(0, make("oops"))
    assert "node 'twice' (doubler_test), inlet 'in'" in caplog.text
    src.receive(0, make(1.5))
    assert out.values == [6.0]
    # live parameters and methods by message
    src.receive(0, method("gain", 10.0))
    src.receive(0, make(1.0))
    assert out.values[-1] == 20.0
    src.receive(0, method("reset"))
    assert src.p.gain == 2.0
    with pytest.raises(TypeError, match="no method 'explode'"):
        src.receive(0, method("explode"))


def test_vectors_are_read_only_and_carry_time():
    source = np.array([1.0, 2.0, 3.0])
    m = vector(source, time=4.5)
    with pytest.raises(TypeError):
        m.value[0] = 9
    source[0] = 9.0  # the message is a copy: changing the array afterwards changes nothing
    assert m.value == (1.0, 2.0, 3.0) and all(type(v) is float for v in m.value)
    assert m.time == 4.5 and m.describe() == "vector 1 2 3"


def test_vectors_are_flat_floats_whatever_they_are_made_of():
    assert vector([[1, 2], [3, 4]]).value == (1.0, 2.0, 3.0, 4.0)  # a matrix travels row major
    assert vector(np.eye(3)).value == (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    assert vector((np.float32(0.5), 2)).value == (0.5, 2.0)
    with pytest.raises(ValueError):
        vector(["a", "b"])


@pytest.mark.parametrize("value", [float("nan"), float("inf"), "-inf"])
def test_a_setting_that_is_not_a_finite_number_is_refused_and_the_timers_go_on(value):
    from pointat.node import ParamError

    rt = patch("node m metro 10\nnode s speedlim 50\nnode n collect\nm -> s -> n\n")
    rt.start()
    rt.nodes["m"].receive(0, make(1))
    rt.advance(0.1)
    with pytest.raises(ParamError, match="parameter 'interval' expects a finite number"):
        rt.nodes["s"].set_param("interval", value)  # as /pointat/s/interval nan from live control
    assert rt.nodes["s"].p.interval == 50.0
    before = len(rt.nodes["n"].messages)
    rt.advance(1.0)
    assert len(rt.nodes["n"].messages) >= before + 15  # every 50 ms, still: the schedule is whole
    rt.shutdown()


def test_the_scheduler_refuses_a_time_that_is_not_finite():
    rt = patch("node n collect\n")
    with pytest.raises(ValueError, match="cannot schedule at time nan"):
        rt.call_at(float("nan"), None, lambda: None)
    assert rt._timers == []


class Fussy(Node):
    """A test node that rebuilds from its parameter and refuses some values only then."""

    type_name = "fussy_test"
    inlets = (Inlet("in"),)
    params = (Param("k", "float", 1.0, live=True),)

    def setup(self):
        self.built = self.p.k

    def param_changed(self, name):
        if self.p.k > 10:
            raise ValueError("k too large for this filter")
        self.built = self.p.k


def test_a_value_the_node_refuses_while_rebuilding_leaves_the_old_one_in_place():
    node = Fussy("f", {})
    node.set_param("k", 5.0)
    with pytest.raises(ValueError, match="too large"):
        node.set_param("k", 50.0)
    assert node.p.k == 5.0 and node.built == 5.0  # all or none: the value that worked stays


def test_nan_stays_a_setting_where_it_is_the_default_and_tqt_refuses_what_means_nothing():
    from pointat.errors import PatchError

    assert math.isnan(patch("node f tqt dip=nan\n").nodes["f"].p.dip)  # "learn the dip", as by default
    for bad, why in (
        ("dip=inf", "expects a finite number"),
        ("k=-5", "'k' expects a number >= 0"),
        ("rate=0", "rate"),
    ):
        with pytest.raises(PatchError, match=why):
            patch(f"node f tqt {bad}\n")
    rt = patch("node f tqt\n")
    with pytest.raises(ValueError, match="'k_heading' expects a number >= 0; got -1.0"):
        rt.nodes["f"].set_param("k_heading", -1.0)  # live, from /pointat/f/k_heading -1
    assert rt.nodes["f"].p.k_heading == 0.015


def test_a_parameter_sent_without_a_value_says_it_needs_one():
    rt = patch("node f tqt\n")
    with pytest.raises(TypeError, match=r"'k_heading' needs a value \(float >= 0\), e.g. 'k_heading 0.015'"):
        rt.nodes["f"].receive(0, method("k_heading"))
    with pytest.raises(TypeError, match=r"expected a number, got 'symbol abc'$"):
        as_float(make("abc"))


def test_tqt_k_0_live_is_the_modes_own_gain_and_a_rate_of_0_is_refused_everywhere():
    from pointat.errors import PatchError
    from pointat.maths.tqt import TQTFilter

    rt = patch("node f tqt mode=robust k=2\n")
    rt.nodes["f"].set_param("k", 0.0)  # as at load: 0 means the mode's default
    assert rt.nodes["f"].filter.k == TQTFilter.default_k("robust")
    for node in ("gyro_integrator", "complementary", "tqt", "mote", "simulate"):
        with pytest.raises(PatchError, match="parameter 'rate' expects a number > 0; got 0"):
            patch(f"node n {node} rate=0\n")


class Stamp(Node):
    """Records what it receives and the node's time while handling it; a method ``poke`` too."""

    type_name = "stamp_test"
    inlets = (Inlet("in", ("any",)), Inlet("cold", ("float",)))
    outlets = (Outlet("out", "any"),)

    def setup(self):
        self.seen = []

    def on_in(self, msg):
        self.seen.append((msg.kind, msg.value, msg.time, self.time))
        self.out(0, msg)

    def do_poke(self, *args):
        self.seen.append(("poke", args, None, self.time))


class Overrides(Stamp):
    """A type that takes every message in its own ``receive`` and hands data on to the base's."""

    type_name = "overrides_test"

    def receive(self, index, msg):
        self.seen.append(("receive", index, msg.kind))
        super().receive(index, msg)


def _wired(*nodes):
    from pointat.runtime import Runtime

    rt = Runtime(realtime=False)
    for node in nodes:
        rt.add(node)
    for a, b in zip(nodes, nodes[1:], strict=False):
        rt.connect(a, 0, b, 0)
    rt.start()
    return rt


def test_out_delivers_data_with_its_time_and_methods_by_receive():
    src, dst = Stamp("src"), Stamp("dst")
    _wired(src, dst)
    src.out(0, make(2.5, time=7.0))
    src.out(0, method("poke", 1, time=8.0))
    src.out(0, make("hi", time=9.0))
    assert dst.seen == [
        ("float", 2.5, 7.0, 7.0),  # the node's time is the message's while it handles it
        ("poke", (1,), None, 8.0),
        ("symbol", "hi", 9.0, 9.0),
    ]


def test_a_type_that_overrides_receive_gets_every_message_there_and_can_call_the_base():
    src, mid, dst = Stamp("src"), Overrides("mid"), Stamp("dst")
    _wired(src, mid, dst)
    src.out(0, make(1.0, time=2.0))
    src.out(0, method("poke"))
    assert mid.seen == [
        ("receive", 0, "float"),
        ("float", 1.0, 2.0, 2.0),
        ("receive", 0, "poke"),
        ("poke", (), None, 0.0),
    ]
    assert [m[:3] for m in dst.seen] == [("float", 1.0, 2.0)]  # on through the base's receive and out


def test_a_loop_without_a_runtime_is_a_feedback_error_too():
    from pointat.errors import FeedbackError

    a, b = Stamp("a"), Stamp("b")
    a._targets[0].append((b, 0))
    b._targets[0].append((a, 0))
    with pytest.raises(FeedbackError, match="feedback loop: recursion too deep at node"):
        a.receive(0, make(1.0))


@pytest.mark.parametrize(
    "line, why",
    [
        ("node n complementary crossover=0", "'crossover' expects a number > 0; got 0"),
        ("node n accmag_matrix gravity=-9.8", "'gravity' expects a number > 0; got -9.8"),
        ("node n accmag_matrix accel_tolerance=-0.1", "'accel_tolerance' expects a number >= 0; got -0.1"),
        ("node n accmag_matrix mag_tolerance=-0.1", "'mag_tolerance' expects a number >= 0; got -0.1"),
        ("node n accmag_matrix dip_tolerance=-1", "'dip_tolerance' expects a number >= 0; got -1"),
        ("node n calibrate gravity=0", "'gravity' expects a number > 0; got 0"),
        ("node n azi_ele pole=90", "pole must be >= 0 and < 90 deg, got 90.0"),
        ("node n azi_ele pole=-1", "'pole' expects a number >= 0; got -1"),
        ("node n osc_out source=3000000000", "'source' expects a whole number <= 2147483647; got 3000000000"),
        ("node n osc_out rate=0.001", "rate must be 0 (every update) or at least 0.01 Hz, got 0.001"),
    ],
)
def test_values_that_would_silence_a_chain_are_refused_when_the_patch_is_checked(line, why):
    # each was taken, and then every sample failed (a division by zero, an int32 overflow...)
    from pointat.errors import PatchError

    with pytest.raises(PatchError, match=re.escape(why)):
        patch(line + "\n")


def test_a_crossover_of_0_sent_live_is_refused_and_the_fusion_goes_on():
    rt = patch("node f complementary\nnode out collect\nf -> out\n")  # /pointat/f/crossover 0 from a fader
    with pytest.raises(ValueError, match="'crossover' expects a number > 0; got 0"):
        rt.nodes["f"].set_param("crossover", 0.0)
    assert rt.nodes["f"].p.crossover == 0.2


def test_a_method_sent_with_the_wrong_values_says_what_it_takes():
    # /pointat/base/open with no path said "Mote.do_open() missing 1 required positional argument: 'path'"
    rt = patch("node base mote ids=[1]\nnode n offset\nnode c calibrate\n")
    for node, msg, said in (
        ("base", method("open"), "method 'open' takes 'open PATH'; got 0 value(s) ()"),
        ("n", method("recalibrate", 1), "method 'recalibrate' takes 'recalibrate' alone, no values; got 1"),
        ("c", method("turn_end", 1, 2, 3), "method 'turn_end' takes 'turn_end [ANGLE_DEG] [AXIS]'; got 3"),
    ):
        with pytest.raises(TypeError, match=re.escape(said)):
            rt.nodes[node].receive(0, msg)


def test_a_type_error_inside_a_method_is_not_blamed_on_its_values():
    class Broken(Node):
        type_name = "broken_test"

        def do_go(self, x):
            return len(x)  # a number has no len: the method's own bug, told as it is

    node = Broken("b", Broken.resolve_params())
    with pytest.raises(TypeError, match="has no len"):
        node._method(0, method("go", 3))
