"""The engine knows no node by name (issue 47): what the console, the monitor and OSCQuery show of a node
comes from what the node declares (``role``, ``readings``, ``describe``, ``read``, ``health``), checked
here on the engine's source, on the registry's refusals, and on a node type made in the test."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from pointat.console import banner, describe
from pointat.monitor.observe import Observer
from pointat.monitor.oscquery import address_space, find, value_of
from pointat.node import Inlet, Node, Param, Reading
from pointat.registry import Registry, RegistryError
from pointat.testing import patch, test_registry

ROOT = Path(__file__).resolve().parents[2]
#: The engine's modules that tell people about nodes, the node model itself, and what loads, checks, runs
#: and reloads a patch (Pd's scheduler never asks what an object is).
ENGINE = [
    *(
        ROOT / "pointat" / f"{name}.py"
        for name in ("console", "node", "registry", "checking", "loader", "runtime", "scheduling", "reload")
    ),
    *sorted((ROOT / "pointat" / "monitor").glob("*.py")),
]
#: The built-in types' names, but those that name a part of every node too (``receive``: a method).
TYPE_NAMES = {cls.type_name for cls in Registry().load_builtins()} - set(dir(Node))


def _named_types(source: str) -> list[tuple[int, str]]:
    """Where ``source`` names a node type: a string that is a registered type's name, or a comparison
    with a node's ``type_name``."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value in TYPE_NAMES:
            found.append((node.lineno, node.value))
        if isinstance(node, ast.Compare):
            sides = [node.left, *node.comparators]
            if any(isinstance(s, ast.Attribute) and s.attr == "type_name" for s in sides):
                found.append((node.lineno, "a comparison with type_name"))
    return found


def test_the_check_finds_a_node_known_by_name():
    assert sorted(_named_types('if node.type_name == "osc_out":\n    pass\n')) == [
        (1, "a comparison with type_name"),
        (1, "osc_out"),
    ]
    assert sorted(_named_types('kinds = ("simulate", "mote")\nif t in kinds: pass\n')) == [
        (1, "mote"),
        (1, "simulate"),
    ]


@pytest.mark.parametrize("path", ENGINE, ids=lambda p: p.name)
def test_the_engine_names_no_node_type(path):
    assert len(TYPE_NAMES) > 40 and {"osc_out", "vbap", "simulate"} <= TYPE_NAMES
    assert _named_types(path.read_text(encoding="utf-8")) == []


def test_every_input_and_output_says_what_it_reads_or_where_it_sends():
    roles: dict[str, set[str]] = {"input": set(), "output": set()}
    for cls in Registry().load_builtins():
        if cls.role != "process":
            roles[cls.role].add(cls.type_name)
            assert cls.describe is not Node.describe, cls.type_name
    # the banner lists what it listed by name before the roles were declared
    assert roles == {
        "input": {"simulate", "simulate_body", "mote", "replay", "osc_in", "midi_in"},
        "output": {"osc_out", "osc_send", "osc_body", "record", "bvh_record", "midi_out", "calibrate"},
    }


def _declared(**attrs):
    cls = type("Odd", (Node,), {"__doc__": "A node declared for the test.", **attrs})
    cls.type_name = "odd"
    return cls


def test_a_role_or_a_reading_declared_wrongly_is_refused_naming_the_type():
    with pytest.raises(
        RegistryError, match=r"node type 'odd'.*role 'sink' is none of input, output, process"
    ):
        Registry().add(_declared(role="sink"))
    level = Reading("level", "how loud")
    with pytest.raises(RegistryError, match="reading 'level' is named twice"):
        Registry().add(_declared(readings=(level, level)))
    with pytest.raises(RegistryError, match="reading 'gain' is named twice, or as a parameter"):
        Registry().add(_declared(readings=(Reading("gain"),), params=(Param("gain", "float", 1.0),)))
    with pytest.raises(RegistryError, match=r"reading 'a/b' is no name"):
        Registry().add(_declared(readings=(Reading("a/b"),)))
    with pytest.raises(RegistryError, match=r"reading 'aim' has 2 unit\(s\); .*three for a direction"):
        Registry().add(_declared(readings=(Reading("aim", units=("deg", "deg"), direction=True),)))
    with pytest.raises(RegistryError, match=r"reading 'none' has 0 unit\(s\)"):
        Registry().add(_declared(readings=(Reading("none", units=()),)))


class Meter(Node):
    """Keep the last level that came in."""

    role = "process"
    inlets = (Inlet("in", ("float",), "a level"),)
    readings = (
        Reading("level", "the last level", units=("dB",), minimum=-120.0, maximum=0.0),
        Reading("span", "the lowest and highest", units=("dB", "dB")),
    )

    def setup(self) -> None:
        self.level = -120.0
        self.span = [0.0, -120.0]

    def on_in(self, msg) -> None:
        self.level = msg.value
        self.span = [min(self.span[0], msg.value), max(self.span[1], msg.value)]

    def read(self):
        return {"level": self.level, "span": self.span}


class Lamp(Node):
    """Point a lamp where the hand points: an output with a direction reading."""

    role = "output"
    inlets = (Inlet("azimuth", ("float",), "degrees"),)
    params = (Param("dropout", "float", 0.5, "seconds"),)
    readings = (Reading("aim", "where it points", units=("deg", "deg", ""), direction=True),)

    def setup(self) -> None:
        self.aim = (0.0, 0.0, 0.0)
        self.heard = 0

    def describe(self) -> str:
        return "a lamp on the ceiling"

    def on_azimuth(self, msg) -> None:
        self.aim = (msg.value, 0.0, 0.0)
        self.heard += 1

    def read(self):
        return {"aim": self.aim}

    def health(self):
        return {"heard": self.heard, "flag": "ok"}


def test_what_a_node_declares_is_what_the_console_the_observer_and_oscquery_show():
    reg = test_registry()
    for name, cls in (("meter", Meter), ("lamp", Lamp)):
        cls.type_name = name
        reg.add(cls)
    rt = patch("node v msg -6\nnode m meter\nnode l lamp\nv -> m\nv -> l\n", registry=reg)
    try:
        obs = Observer(rt).attach()
        assert [p.node.name for p in obs.pointers] == ["l"]
        assert obs.read()["pointers"][0]["state"] == "waiting"
        assert describe(rt.nodes["l"]) == "lamp 'l': a lamp on the ceiling"
        assert "  out  lamp 'l': a lamp on the ceiling" in banner(rt, "x.pat")
        assert not any("meter" in line for line in banner(rt, "x.pat"))  # a process: not in the banner
        rt.send("v", "bang")
        rt.advance(0.0)
        (lamp,) = obs.read()["pointers"]
        assert (lamp["name"], lamp["azimuth"], lamp["state"], lamp["about"]) == (
            "l",
            -6.0,
            "ok",
            "a lamp on the ceiling",
        )
        assert obs.status_lines() == ["l: az  -6.0°  el  0.0°  dist 0", "m: level: -6 dB, span: -6 dB -6 dB"]
        tree = address_space(rt)
        level = find(tree, "/pointat/m/level")
        assert level == {
            "FULL_PATH": "/pointat/m/level",
            "TYPE": "f",
            "ACCESS": 1,
            "DESCRIPTION": "the last level",
            "VALUE": [-6.0],
            "UNIT": ["dB"],
            "RANGE": [{"MIN": -120.0, "MAX": 0.0}],
        }
        assert find(tree, "/pointat/m/span")["VALUE"] == [-6.0, -6.0]
        assert find(tree, "/pointat/l/aim")["UNIT"] == ["angle.degree", "angle.degree", ""]
        assert value_of(rt, "/pointat/m/span") == [-6.0, -6.0]
        assert value_of(rt, "/pointat/l/aim") == [-6.0, 0.0, 0.0]
        assert value_of(rt, "/pointat/m/nothing") is None
    finally:
        rt.shutdown()


def test_a_node_a_compiled_chain_holds_is_synced_before_its_readings_are_read():
    rt = patch("node o osc_out port=9\n")
    o = rt.nodes["o"]
    calls: list[str] = []
    o.hold(lambda: calls.append("release"), lambda: calls.append("sync"))
    try:
        assert o.read() == {"aed": [0.0, 0.0, 0.0]} and calls == ["sync"]  # (OSCQuery reads no health)
        o.unhold()
        o.read()
        assert calls == ["sync"]
    finally:
        rt.shutdown()


class Broken(Node):
    """A node whose read() raises: the observer and OSCQuery go on without its values."""

    role = "output"
    inlets = (Inlet("in", ("float",), "anything"),)
    readings = (Reading("aim", "where it points", units=("deg", "deg", ""), direction=True),)

    def read(self):
        raise RuntimeError("not now")


def test_a_reading_that_fails_leaves_the_observer_and_oscquery_going(caplog):
    reg = test_registry()
    Broken.type_name = "broken"
    reg.add(Broken)
    rt = patch("node b broken\n", registry=reg)
    try:
        with caplog.at_level("DEBUG", logger="pointat"):
            (pointer,) = Observer(rt).attach().read()["pointers"]
            assert (pointer["azimuth"], pointer["state"]) == (0.0, "waiting")
            assert find(address_space(rt), "/pointat/b/aim")["VALUE"] == [None, None, None]
            assert value_of(rt, "/pointat/b/aim") == [None, None, None]
        assert sum("node 'b' (broken): read() failed" in r.getMessage() for r in caplog.records) == 3
    finally:
        rt.shutdown()
