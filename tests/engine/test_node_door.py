"""The node's door for a compiled chain (pointat.node): targets, detach and reattach, hold and unhold."""

from __future__ import annotations

from pointat.message import make
from pointat.testing import patch


def _chain():
    return patch("""
node a  trigger f
node b  collect
node c  collect
a -> b
a -> c
""")


def test_a_detached_link_is_silent_until_reattached_in_its_old_place():
    rt = _chain()
    a, b, c = rt.nodes["a"], rt.nodes["b"], rt.nodes["c"]
    assert a.targets(0) == [(b, 0), (c, 0)] and a.connected(0)
    a.detach(0, b, 0)
    a.receive(0, make(1.0))
    assert [m.value for m in b.messages] == [] and [m.value for m in c.messages] == [1.0]
    late = rt.nodes["c"]  # a listener connected meanwhile (as the monitor's taps are)
    a.targets(0).append((late, 0))  # (a copy: the wiring does not change by it)
    assert a.targets(0) == [(c, 0)]
    a.reattach()
    a.reattach()  # (idempotent)
    assert a.targets(0) == [(b, 0), (c, 0)]
    a.receive(0, make(2.0))
    assert [m.value for m in b.messages] == [2.0] and [m.value for m in c.messages] == [1.0, 2.0]


def test_reattach_of_one_outlet_leaves_the_others_detached():
    rt = patch("node t trigger f f\nnode x collect\nnode y collect\nt.0 -> x\nt.1 -> y\n")
    t, x, y = rt.nodes["t"], rt.nodes["x"], rt.nodes["y"]
    t.detach(0, x, 0)
    t.detach(1, y, 0)
    t.reattach(1)
    assert t.targets(0) == [] and t.targets(1) == [(y, 0)]
    t.reattach()
    assert t.targets(0) == [(x, 0)]


def test_a_held_node_calls_release_before_what_reaches_it_and_sync_before_its_health():
    rt = patch("node o osc_out port=9\n")
    o = rt.nodes["o"]
    calls: list[str] = []
    # what the node holds as each is called: release and sync come before the node does anything
    o.hold(
        lambda: calls.append(f"release {o.state[1]} {o.p.radius}"),
        lambda: calls.append("sync"),
        open_inlets=("spread",),
    )
    o.receive(3, make(50.0))  # spread: open, stored as ever
    assert calls == [] and o.state[3] == 50.0
    o.receive(1, make(10.0))  # elevation: released first (by receive and the handler: more than once)
    assert set(calls) == {"release 0.0 1.0"} and o.state[1] == 10.0
    calls.clear()
    o.set_params(radius=2.0)
    assert set(calls) == {"release 10.0 1.0"} and o.p.radius == 2.0
    calls.clear()
    assert {"refused": 0, "failed": 0}.items() <= o.health().items()
    assert calls == ["sync"]
    o.unhold()
    o.unhold()  # (idempotent)
    calls.clear()
    o.receive(1, make(20.0))
    o.set_params(radius=3.0)
    o.health()
    assert calls == [] and o.state[1] == 20.0


def test_a_held_handler_keeps_its_marks():
    """Live control refuses a path to a handler marked ``names_path`` (the mote's control inlet): the
    mark must survive hold."""
    rt = patch("node m mote\n")
    m = rt.nodes["m"]
    m.hold(lambda: None, lambda: None)
    assert getattr(m._handlers[0], "names_path", False)  # noqa: SLF001 - what pointat.control reads
    m.unhold()
