"""Which chains the runtime compiles (pointat.fusion.install), and why the others run node by node."""

from __future__ import annotations

import logging

import pytest

from pointat.fusion import compiled
from pointat.shipped import find_patch
from pointat.testing import patch

pytestmark = pytest.mark.skipif(not compiled.available(), reason="numba is not installed")

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
    with caplog.at_level(logging.INFO, logger="pointat.fusion"):
        rt._fuse()
    text = " ".join(r.getMessage() for r in caplog.records if r.name == "pointat.fusion")
    return rt.fusion, text


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
        return len(rt.fusion.chains) if rt.fusion else 0

    assert chains("glove_tqt") == 1
    assert chains("pointing_at") == 0
    assert chains("gloves_bank") == 0
