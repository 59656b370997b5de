"""Which chains the runtime compiles (pointat.compiled.install), and why the others run node by node."""

from __future__ import annotations

import ast
import logging
from pathlib import Path

import pytest

from pointat.shipped import find_patch
from pointat.testing import patch

CHAIN = """
node base  mote ids=[1, 2] rate=100
node nulls offset samples=10
node units scaling
node tqt   tqt rate=100 mode={mode}
node ref   reference
node dir   azi_ele
node roll  roll_distance
node out   osc_out host=127.0.0.1 port=9 {out}
base.m1 -> nulls -> units
units.mag -> tqt.mag
units.accel -> tqt.accel
units.gyro -> tqt.gyro
tqt.quat -> ref
ref -> {first}
ref -> {second}
dir.elevation -> out.elevation
roll.distance -> out.distance
roll.azimuth -> out.azimuth
{extra}
"""


def _why(caplog, **kw) -> tuple[object, str]:
    values = {"mode": "robust", "out": "", "first": "dir", "second": "roll", "extra": ""} | kw
    rt = patch(CHAIN.format(**values))
    rt.compiled = "on"
    with caplog.at_level(logging.INFO, logger="pointat.compiled"):
        rt._fuse()
    text = " ".join(r.getMessage() for r in caplog.records if r.name == "pointat.compiled")
    return rt.compiled_chains, text


def test_the_glove_chain_is_compiled_and_says_so(caplog):
    fusion, _ = _why(caplog)
    assert fusion is not None and [c.name() for c in fusion.chains] == ["base.m1 -> out"]
    assert fusion.describe() == "compiled glove chains (1): base.m1 -> out"


@pytest.mark.parametrize(
    ("change", "why"),
    [
        ({"mode": "paper"}, "paper mode"),
        ({"out": "profile=iem_stereo"}, "profile iem_stereo is sent node by node"),
        ({"out": "profile=generic fields=[x, y, z]"}, "profile generic is sent node by node"),
        ({"out": "bundle=true"}, "sends bundles"),
        ({"first": "roll", "second": "dir"}, "feeds roll_distance before azi_ele"),
        ({"extra": "node more msg 3\nmore -> out.elevation"}, "'more' feeds osc_out 'out'.elevation"),
        (
            {"extra": "node other azi_ele\nref -> other\nother.elevation -> out.elevation"},
            "goes to 2 azi_ele nodes",
        ),
    ],
)
def test_a_chain_that_is_not_the_glove_chain_runs_node_by_node_and_the_log_says_why(caplog, change, why):
    fusion, text = _why(caplog, **change)
    assert fusion is None
    assert why in text, text
    assert "m2" not in text  # (an outlet wired to nothing is no chain to talk about)


def test_the_shipped_patches_compile_where_they_have_the_chain():
    """glove_tqt (through its abstraction) has it; the Pointing-at chain and the bank do not."""
    from pointat.checking import check
    from pointat.expansion import read_spec
    from pointat.loader import build
    from pointat.registry import default_registry

    def chains(name: str) -> int:
        rt = build(check(read_spec(find_patch(name)), default_registry.load_builtins()), realtime=False)
        rt.compiled = "on"
        rt._fuse()
        return len(rt.compiled_chains.chains) if rt.compiled_chains else 0

    assert chains("glove_tqt") == 1
    assert chains("pointing_at") == 0
    assert chains("gloves_bank") == 0


# -- the door: pointat.compiled reads the nodes through their public methods only -----------------------
def _private(name: str) -> bool:
    """``_name`` (not ``__name__``, a protocol's, unless it is ``__dict__``: every field of an object)."""
    dunder = name.startswith("__") and name.endswith("__")
    return name.startswith("_") and (not dunder or name == "__dict__")


def _private_uses(source: str) -> list[str]:
    """Where ``source`` imports a private name of another module, reads or sets a private attribute of
    anything but ``self``, or names one to getattr and its kin."""
    found = []
    for node in ast.walk(ast.parse(source)):
        where = f"line {getattr(node, 'lineno', '?')}"
        if isinstance(node, ast.ImportFrom):
            found += [
                f"{where}: from {node.module} import {a.name}" for a in node.names if a.name.startswith("_")
            ]
            if any(_private(part) for part in (node.module or "").split(".")):
                found.append(f"{where}: from {node.module}")
        elif isinstance(node, ast.Import):
            found += [
                f"{where}: import {a.name}"
                for a in node.names
                if any(_private(part) for part in a.name.split("."))
            ]
        elif isinstance(node, ast.Attribute) and _private(node.attr):
            if not (isinstance(node.value, ast.Name) and node.value.id == "self"):
                found.append(f"{where}: {ast.unparse(node)}")
        elif (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id in ("getattr", "setattr", "delattr", "hasattr")
            and len(node.args) > 1
            and isinstance(node.args[1], ast.Constant)
            and _private(str(node.args[1].value))
        ):
            found.append(f"{where}: {ast.unparse(node)}")
    return found


def test_the_check_for_private_names_finds_them():
    bad = (
        "from pointat.osc_bridge.profiles import _dist\n"
        "import pointat._secret\n"
        "def f(node, self):\n"
        "    node._targets[0] = []\n"
        "    x = node.filter._s\n"
        "    setattr(node, '_az', 1.0)\n"
        "    node.__dict__.pop('health')\n"
        "    return self._mine, node.__name__\n"
    )
    assert len(_private_uses(bad)) == 6, _private_uses(bad)


def test_the_compiled_chain_uses_no_private_name_of_another_module():
    """A node's private fields are its own: pointat.compiled goes through the node's door (fused_state,
    restore_fused, targets, detach, hold...) and imports nothing private (issue 47)."""
    import pointat.compiled

    folder = Path(pointat.compiled.__file__).parent
    files = sorted(folder.glob("*.py"))
    assert {f.name for f in files} >= {"__init__.py", "build.py", "kernel.py"}
    found = {f.name: _private_uses(f.read_text()) for f in files}
    assert not any(found.values()), found


def test_every_fusable_type_takes_back_the_state_it_gives():
    """The door loses nothing: fused_state, restore_fused with it, fused_state again give the same
    values, on a chain that has run; and the fusable types are the chain's (a new one needs the kernel)."""
    from pointat.devices.mote_frame import Frame
    from pointat.registry import default_registry

    chain_types = {"offset", "scaling", "tqt", "reference", "azi_ele", "roll_distance", "osc_out"}
    assert {cls.type_name for cls in default_registry.load_builtins() if cls.fusable} == chain_types
    values = {"mode": "robust", "out": "", "first": "dir", "second": "roll", "extra": ""}
    rt = patch(CHAIN.format(**values))
    rt.start()
    nodes = {n.type_name: n for n in rt.nodes.values() if n.type_name in chain_types}
    assert nodes["offset"].fused_state() is None  # (the gyro nulls still to be averaged)
    mote = rt.nodes["base"]
    for k in range(60):
        counts = (2048 + k % 3, 2047, 2049, 2048, 2048, 2900, 2300, 2048, 1700)
        mote._frame(Frame(1, k, counts), 0.0, 100.0 + k / 100.0)  # noqa: SLF001 - a frame as the reader gives it
    for kind, node in nodes.items():
        state = node.fused_state()
        assert state is not None, kind
        node.restore_fused(state)
        assert node.fused_state() == state, kind
    assert nodes["tqt"].fused_state()["filter"][0][4] == 1.0  # (the filter started: S_INIT)
    rt.shutdown()
