"""Pure Data files: reading files that Pd itself wrote, writing them back, and the stub abstractions.

The fixtures in tests/data/pd/ were saved by Pd 0.53 (see their README); ``NAME.out`` is what Pd printed
when it ran ``NAME.pd``, so a patch that prints the same here behaves as it does in Pd.
"""

import logging
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from pointat.errors import PatchError
from pointat.expansion import flatten
from pointat.loader import build, check, expand
from pointat.patchfile import format_value, parse_patch, read_patch, write_patch
from pointat.pdfile import STUB_FOLDER, VANILLA, parse_pd, read_pd, write_pd, write_stubs
from pointat.registry import default_registry
from pointat.spec import PatchSpec

DATA = Path(__file__).parent / "data" / "pd"
PATCHES = Path(__file__).parent.parent / "patches"
REG = default_registry.load_builtins()


def to_pd(spec, registry=None):
    """Pd text of a patch, its abstractions flattened first (as pointat convert does)."""
    return write_pd(flatten(spec), registry)


HEAD = "#N canvas 0 50 450 300 12;\n"


def run(spec: PatchSpec, seconds: float = 1.0) -> list[str]:
    """Check, build with a manual clock, run ``seconds`` of logical time; what the print nodes wrote."""
    rt = build(check(spec, REG), realtime=False)
    printed: list[str] = []
    rt.console = printed.append
    try:
        rt.advance(seconds)
    finally:
        rt.shutdown()
    return printed


def pd_printed(name: str) -> list[str]:
    return (DATA / f"{name}.out").read_text().splitlines()


def problems_of(text: str) -> list[tuple[int, str]]:
    with pytest.raises(PatchError) as info:
        parse_pd(text, "x.pd")
    return [(p.where.line, p.message) for p in info.value.problems]


def graph(spec: PatchSpec) -> tuple[dict, dict]:
    """Node name -> (type, repr of the resolved parameters); (node, outlet) -> its targets in fan-out order.

    Pd saves connections grouped by source box, so only the order within one outlet is kept (and matters).
    """
    nodes = {}
    for n in expand(spec).nodes:
        values = REG.get(n.type).resolve_params(n.args, n.params)
        nodes[n.name] = (n.type, repr(values))
    fanout: dict[tuple[str, int], list[tuple[str, int]]] = {}
    for src, outlet, dst, inlet in check(spec, REG).wires:
        fanout.setdefault((src, outlet), []).append((dst, inlet))
    return nodes, fanout


HAND = """
node go   loadbang
node tr   trigger b f b
node m    msg 1 2 , 3 $1 ; bus 0.5 ; other two words
node pk   pack 0 0 s
node rt   route 1 3 a
node sh   print prefix="two words; x, y" time=true
node fu   tqt k=0.123456789012 rho=0.25 mode=paper dip=-61.5
node sp   speedlim 33.333333333333336
node rec  record file=out.csv columns=[qw, qx, "a b"]
node bus  receive bus
node back delay 10.5
go -> tr
tr.2 -> m
tr.1 -> pk.1
tr.0 -> pk
pk -> rt -> sh
rt.1 -> sp -> sh
rt.2 -> fu
fu.quat -> rec
bus -> back -> tr
"""


# --------------------------------------------------------------------------- files written by Pd
def test_vanilla_objects_load_as_pointat_nodes_and_print_what_pd_printed():
    spec = read_pd(DATA / "vanilla.pd")
    types = [n.type for n in spec.nodes]
    assert types[:8] == ["loadbang", "metro", "print", "delay", "msg", "t", "msg", "route"]
    assert {"r", "s", "receive", "unpack", "pack", "change"} <= set(types)
    assert spec.node("metro_1").args == [100]
    assert spec.node("msg_6").args == [1, 2, ",", 3, 4, ";", "bus", 5, 6]
    assert spec.node("msg_13").args == ["$1", "$1"]
    assert spec.node("t_5").where.line == 7 and spec.node("t_5").where.box == 5
    checked = check(spec, REG)
    assert checked.warnings == []
    # loadbang -> metro 100 -> print tick, stopped at 350 ms: ticks at 0, 100, 200, 300 ms, as in Pd
    assert run(spec, 1.0) == pd_printed("vanilla")


def test_a_print_box_takes_all_its_words_as_its_prefix_as_pd_does():
    """Pd joins a [print]'s atoms into its prefix ([print my label] prints "my label: bang"), "a=b" words
    and numbers too; two atoms of which the second is 0 or 1 are the prefix and time, as pointat writes
    time=true."""
    text = (
        HEAD + "#X obj 10 10 loadbang;\n#X obj 10 60 print my label=2.5 1000000 here;\n#X connect 0 0 1 0;\n"
    )
    spec = parse_pd(text, "x.pd")
    assert spec.node("print_1").args == ["my label=2.5 1e+06 here"]  # numbers as Pd shows them
    assert run(spec) == ["my label=2.5 1e+06 here: bang"]
    timed = parse_pd(text.replace("my label=2.5 1000000 here", "tick 1"), "x.pd")
    assert REG.get("print").resolve_params(timed.node("print_1").args, {})["time"] is True


@pytest.mark.parametrize(
    ("prefix", "time", "box"),
    [
        ("gyro nulls (hold the glove still):", False, "print gyro nulls (hold the glove still):"),
        ("level 1", False, r"print level\ 1"),  # read as words it would be prefix "level", time=true
        ("two words", True, r"print two\ words 1"),
        ("a=b c", False, r"print a\=b\ c"),
        ("one", False, "print one"),
        ("a b ", False, r"print a\ b\ "),  # the escaped space before ';' stays (it once made '\;')
        ("x\\", False, r"print x\\"),
    ],
)
def test_a_print_prefix_of_words_is_written_as_words_and_reads_back_the_same(prefix, time, box):
    spec = parse_patch(
        f"node lb loadbang\nnode p print prefix={format_value(prefix)} time={str(time).lower()}\nlb -> p",
        "x.pat",
    )
    text = to_pd(spec, REG)
    assert f" {box};" in text
    back = parse_pd(text, "x.pd")
    assert REG.get("print").resolve_params(back.node("p").args, back.node("p").params) == {
        "prefix": prefix,
        "time": time,
        "decimals": 1,
    }


def test_unknown_and_gui_boxes_are_reported_all_at_once_with_their_box():
    spec = read_pd(DATA / "unknown.pd")
    with pytest.raises(PatchError) as info:
        check(spec, REG)
    found = [
        (p.where.line, p.where.box, re.search(r"unknown node type '([^']+)'", p.message)[1])
        for p in info.value.problems
    ]
    assert found == [(3, 1, "osc~"), (4, 2, "bng"), (5, 3, "floatatom"), (7, 5, "tgl"), (12, 6, "graph")]
    assert "unknown.pd:4 (box 2)" in str(info.value)
    # the comment (box 4) and the array (box 6) count: the print is box 7
    assert spec.node("print_7").where.box == 7
    assert [str(w) for w in spec.wires] == [
        "loadbang_0.0 -> bng_2.0",
        "bng_2.0 -> print_7.0",
        "floatatom_3.0 -> print_7.0",
        "tgl_5.0 -> print_7.0",
    ]


def test_comments_count_in_box_indices_and_name_the_next_box():
    spec = read_pd(DATA / "comments.pd")
    assert [(n.name, n.where.box) for n in spec.nodes] == [("loadbang_0", 0), ("greet", 3), ("print_5", 5)]
    assert [str(w) for w in spec.wires] == ["loadbang_0.0 -> greet.0", "greet.0 -> print_5.0"]
    assert run(spec) == pd_printed("comments")


def test_escapes_in_a_pd_saved_file():
    spec = read_pd(DATA / "escapes.pd")
    assert spec.node("msg_0").args == [1, ",", 2, ";", "foo", "$1", "bar baz", "+5", -3, 1e10, 0.5, "$1-x"]
    tqt = spec.node("tqt_1")
    assert tqt.args == [] and tqt.params == {"k": 0.123456789012, "mode": "robust", "rho": 0.5}
    assert spec.node("print_2").args == ["two words"]
    # a Pd print whose prefix looks like key=value prints it, as Pd does; time=1 is pointat's parameter
    assert spec.node("print_3").args == ["a=b"] and spec.node("print_3").params == {}
    check(spec, REG)
    timed = parse_pd(HEAD + "#X obj 20 140 print a=b time=1 c;\n", "x.pd")
    assert timed.node("print_0").args == ["a=b c"] and timed.node("print_0").params == {"time": True}


def test_subpatch_inlets_are_ordered_by_x_and_ports_wire_through():
    spec = read_pd(DATA / "subpatch.pd")
    assert [n.name for n in spec.nodes] == ["loadbang_0", "t_1", "msg_2", "msg_3", "inner/pack_2", "print_6"]
    assert spec.node("inner/pack_2").where.box == 2  # its index inside the subpatch
    # box 2 of 'inner' is its left inlet (x=20) although created second; 'through' is inlet -> outlet
    assert [str(w) for w in spec.wires] == [
        "inner/pack_2.0 -> print_6.0",
        "loadbang_0.0 -> t_1.0",
        "t_1.0 -> msg_2.0",
        "t_1.1 -> msg_3.0",
        "msg_2.0 -> inner/pack_2.0",
        "msg_3.0 -> inner/pack_2.1",
    ]
    assert run(spec) == pd_printed("subpatch") == ["sub: 7 5"]


def test_records_spanning_lines_read_as_pd_reads_them():
    wrapped, resaved = read_pd(DATA / "wrapped.pd"), read_pd(DATA / "wrapped.resaved.pd")
    assert [(n.name, n.type, n.args) for n in wrapped.nodes] == [
        (n.name, n.type, n.args) for n in resaved.nodes
    ]
    assert [str(w) for w in wrapped.wires] == [str(w) for w in resaved.wires]
    assert wrapped.node("msg_1").where.line == 4 and wrapped.wires[0].where.line == 17
    assert wrapped.node("msg_1").args[-6:] == [",", "second", "message", ";", "bus", 3]
    assert wrapped.node("graph_2").where.box == 2  # the array: '#A' data over two lines, skipped
    wrapped.nodes = [n for n in wrapped.nodes if n.type != "graph"]
    assert run(wrapped) == pd_printed("wrapped")


def test_fan_out_follows_connect_order_and_one_outlet_into_two_inlets_warns():
    spec = read_pd(DATA / "fanout.pd")
    assert [str(w) for w in spec.wires][1:5] == [
        "msg_1.0 -> print_3.0",
        "msg_1.0 -> print_2.0",
        "msg_1.0 -> pack_4.1",
        "msg_1.0 -> pack_4.0",
    ]
    checked = check(spec, REG)
    [warning] = checked.warnings
    assert "feeds 2 inlets of 'pack_4'" in warning.message and warning.where.line == 12
    assert run(spec) == pd_printed("fanout") == ["first: 5", "second: 5", "packed: 5 5"]


def test_an_exported_patch_saved_by_pd_reads_back_the_same():
    original = read_patch(DATA / "exported.pat")
    resaved = read_pd(DATA / "exported.pd")  # write_pd's output, opened and saved by Pd 0.53
    assert graph(resaved) == graph(original)
    assert resaved.node("fu").params["k"] == 0.123456789012
    assert resaved.node("sp").params == {"interval": 33.333333333333336}
    assert resaved.node("sh").args == ["two words; x, y", 1]


# --------------------------------------------------------------------------- the reader on its own
def test_tokens_numbers_symbols_and_trailing_width_messages():
    spec = parse_pd(
        HEAD + "#X msg 1 2 +5 -3 .5 5. 1e+10 inf 0x10 \\5 \\$1 $2 a\\ b\\\\\\,c, f 20;\n"
        "#X obj 1 2 print x, f 12;\n#X f 30;\n#X coords 0 1 2 3;\n#X obj 1 2;\n#X obj 1 2 declare -path x;\n"
        "#X obj 1 2 t b b;\n#X scalar tmpl 10 20 \\; 1 2 \\;;\n#X obj 1 2 cyclone/coll;\n#C restore;\n"
        "#X obj 1 2 print y;\n#X connect 0 0 1 0;\n#X connect 4 1 0 0;\n#X connect 6 0 7 0;\n"
    )
    assert spec.node("msg_0").args == ["+5", -3, 0.5, 5.0, 1e10, "inf", "0x10", "5", "$1", "$2", "a b,c"]
    assert spec.node("print_1").args == ["x"]
    assert [n.name for n in spec.nodes] == [
        "msg_0",
        "print_1",
        "t_4",
        "scalar_5",
        "cyclone_coll_6",
        "print_7",
    ]
    assert [str(w) for w in spec.wires] == [
        "msg_0.0 -> print_1.0",
        "t_4.1 -> msg_0.0",
        "cyclone_coll_6.0 -> print_7.0",
    ]


def test_names_are_sanitised_and_unique():
    spec = parse_pd(
        HEAD + "#X text 0 0 @name dup;\n#X obj 0 0 osc~;\n#X text 0 0 @name dup;\n#X obj 0 0 +;\n"
        "#X obj 0 0 dup;\n#X text 0 0 @name 9-lives;\n#X msg 0 0;\n"
        "#N canvas 0 0 450 300 my-sub 0;\n#X obj 0 0 metro 5;\n#X restore 0 0 pd my-sub;\n"
        "#N canvas 0 0 450 300 my-sub 0;\n#X obj 0 0 metro 5;\n#X restore 0 0 pd my-sub;\n"
    )
    assert [n.name for n in spec.nodes] == [
        "dup",
        "dup_2",
        "dup_4",
        "_9_lives",
        "my_sub/metro_0",
        "my_sub_2/metro_0",
    ]


def _retyped(pd_text: str, box: int) -> str:
    """``pd_text`` as Pd saves it after box ``box`` of the top canvas was retyped in its editor: the box
    record moves to the end of the canvas's boxes, and the connections are renumbered."""
    lines = pd_text.splitlines()
    boxes = [i for i, ln in enumerate(lines) if re.match(r"#X (obj|msg|text|floatatom|symbolatom) ", ln)]
    order = [b for k, b in enumerate(boxes) if k != box] + [boxes[box]]
    new_index = {boxes.index(b): k for k, b in enumerate(order)}

    def renumber(m: re.Match) -> str:
        a, o, b, i = map(int, m.groups())
        return f"#X connect {new_index[a]} {o} {new_index[b]} {i};"

    rest = [
        re.sub(r"#X connect (\d+) (\d+) (\d+) (\d+);", renumber, ln)
        for ln in lines
        if ln.startswith("#X connect")
    ]
    head = [ln for ln in lines[: boxes[0]] if not ln.startswith("#X connect")]
    return "\n".join(head + [lines[b] for b in order] + rest) + "\n"


def test_names_survive_a_box_retyped_or_moved_in_pds_editor():
    spec = parse_patch(
        "node m1 metro 100\nnode m2 metro 200\nnode p1 print one\nnode p2 print two\nm1 -> p1\nm2 -> p2\n",
        "e.pat",
    )
    text = to_pd(spec, REG)
    retyped = _retyped(text, 2)  # [metro 100]: the box after the declare and its @name comment
    assert retyped != text and graph(parse_pd(retyped, "e.pd")) == graph(spec)
    # moved by hand: the box leaves its @name comment behind, and is still the next box after it
    moved = re.sub(
        r"#X obj (\d+) (\d+) metro 200", lambda m: f"#X obj {int(m[1]) + 37} {int(m[2]) + 90} metro 200", text
    )
    assert moved != text and graph(parse_pd(moved, "e.pd")) == graph(spec)
    assert graph(parse_pd(_retyped(moved, 4), "e.pd")) == graph(spec)  # and then retyped


def test_malformed_records_name_their_line_all_at_once():
    problems = problems_of(
        HEAD + "#X obj a b metro;\n#X connect 0 0 1;\n#X obj 0 0 print;\n#X connect 0 0 7 0;\n"
        "#X text 0 0 @name a b;\nwibble;\n#X restore 0 0 pd x;\n#X text 0 0 @name lost;\n"
    )
    assert [line for line, _ in problems] == [2, 3, 6, 7, 8, 9, 5]
    assert "numeric position" in problems[0][1] and "4 whole numbers" in problems[1][1]
    assert "expected '@name NODENAME'" in problems[2][1] and "#N, #X, #A" in problems[3][1]
    assert "without a subpatch" in problems[4][1] and "followed by no box" in problems[5][1]
    assert "box 7 does not exist" in problems[6][1]
    assert "not ended by ';'" in problems_of(HEAD + "#X obj 0 0 metro\n 100\n")[0][1]
    assert problems_of(HEAD + "#N canvas 0 0 1 1 s 0;\n#X obj 0 0 t;\n") == [
        (2, "subpatch never closed by '#X restore'")
    ]
    with pytest.raises(PatchError, match="no '#N canvas'"):
        parse_pd("", "empty.pd")


def test_wires_to_missing_subpatch_ports_and_comments_are_errors():
    problems = problems_of(
        HEAD + "#N canvas 0 0 1 1 s 0;\n#X obj 0 0 inlet;\n#X restore 0 0 pd s;\n#X obj 0 0 t;\n"
        "#X text 0 0 hello;\n#X connect 1 0 0 1;\n#X connect 1 0 2 0;\n#X connect 0 0 1 0;\n"
    )
    assert [line for line, _ in problems] == [7, 8, 9]
    assert "has no inlet 1" in problems[0][1] and "comment" in problems[1][1]
    assert "has no outlet 0" in problems[2][1]


# --------------------------------------------------------------------------- writing
@pytest.mark.parametrize("name", [p.name for p in sorted(PATCHES.glob("*.pat"))] + ["hand", "exported"])
def test_round_trip_native_to_pd_to_native_keeps_the_graph(name, tmp_path):
    if name == "hand":
        spec = parse_patch(HAND, str(tmp_path / "hand.pat"))
    elif name == "exported":
        spec = read_patch(DATA / "exported.pat")
    else:
        spec = read_patch(PATCHES / name)
    text = to_pd(spec, REG)
    back = parse_pd(text, str(tmp_path / "back.pd"))
    assert graph(back) == graph(spec)
    assert check(back, REG).wires == check(spec, REG).wires  # written in the same order
    assert [n.name for n in back.nodes] == [n.name for n in expand(spec).nodes]
    for ours, theirs in zip(expand(spec).nodes, back.nodes, strict=True):  # even at its default: port=9001
        cls = REG.get(ours.type)
        if cls is not None and cls.type_name not in VANILLA:
            given = {*ours.params, *(p.name for p in cls.params[: len(ours.args)])}
            assert given <= set(theirs.params), ours.name
    assert back.doc == as_pd_shows(written_header(spec))
    assert parse_patch(write_patch(back)).doc == back.doc  # and on to a native patch's header


def written_header(spec: PatchSpec) -> str:
    """The header ``write_pd`` writes: the patch's, and a line naming the abstraction instances it flattened."""
    flattened = [f"{n.name} ({n.type})" for n in spec.nodes if n.type.endswith(".pat")]
    note = f"Abstractions flattened, each into nodes named INSTANCE/NODE: {', '.join(flattened)}."
    return "\n".join([spec.doc, note] if flattened else [spec.doc])


def as_pd_shows(doc: str) -> str:
    """A header comment as Pd shows it: a comment a line, blank lines gone, words one space apart, a space
    after ``,`` and ``;``, braces (which Pd cannot have) as parentheses, no backslash (Pd drops them)."""
    lines = (
        re.sub(r"\s*([,;])", r"\1 ", ln).replace("{", "(").replace("}", ")").replace("\\", "")
        for ln in doc.splitlines()
    )
    return "\n".join(" ".join(ln.split()) for ln in lines if ln.strip())


def test_header_lines_are_drawn_above_the_boxes_a_semicolon_taking_a_line_more():
    spec = parse_patch("# one; two\n# three\nnode a loadbang\n", "h.pat")
    text = to_pd(spec, REG)
    boxes = [line.split(" ", 4) for line in text.splitlines() if line.startswith(("#X text", "#X obj"))]
    ys = {words[4]: int(words[3]) for words in boxes}
    assert ys["one \\; two, f 20;"] + 36 == ys["three, f 20;"]  # Pd shows 'one;' and 'two' on two lines
    assert ys["three, f 20;"] < ys["@name a;"] < ys["loadbang;"]
    assert parse_pd(text, "h.pd").doc == "one; two\nthree"


def test_top_level_comments_become_the_header_top_to_bottom_and_others_do_not():
    spec = parse_pd(
        HEAD
        + "#X text 10 90 then the gyro 1. 0.50 \\, last\\; done;\n"
        + "#X text 10 10 Send mag and accel first, f 60;\n"
        + "#X text 200 10 (right of it);\n"
        + "#X text 10 40 @name out;\n"
        + "#X obj 10 60 print tick;\n"
        + "#N canvas 0 50 450 300 sub 0;\n#X text 10 10 inside a subpatch;\n#X restore 10 120 pd sub;\n",
        "c.pd",
    )
    assert spec.doc == "Send mag and accel first\n(right of it)\nthen the gyro 1. 0.50, last; done"
    assert [n.name for n in spec.nodes] == ["out"]


def test_writing_uses_positional_atoms_for_pd_types_and_named_ones_for_pointat_types(caplog):
    with caplog.at_level(logging.WARNING, logger="pointat.pdfile"):
        text = to_pd(parse_patch(HAND + "node slow metro 33.333333333333336\n", "h.pat"), REG)
    boxes = dict(re.findall(r"#X text \d+ \d+ @name (\S+);\n#X \w+ \d+ \d+ ([^\n]*);", text))
    assert boxes["tr"] == "trigger b f b" and boxes["pk"] == "pack 0 0 s" and boxes["rt"] == "route 1 3 a"
    assert boxes["m"] == r"1 2 \, 3 \$1 \; bus 0.5 \; other two words"
    assert boxes["sh"] == r"print two\ words\;\ x\,\ y 1"
    assert boxes["back"] == "delay 10.5" and boxes["go"] == "loadbang" and boxes["bus"] == "receive bus"
    assert boxes["fu"] == "tqt mode=paper k=0.123456789012 rho=0.25 dip=-61.5"  # the defaults left out
    assert boxes["sp"] == "speedlim interval=33.333333333333336"
    assert boxes["rec"] == r'record file=out.csv columns=[qw\ qx\ "a\ b"]'
    assert [r.message for r in caplog.records] == [
        "node 'slow' (metro): Pd keeps 6 significant digits of 33.333333333333336: it becomes 33.3333 if Pd "
        "saves the file"
    ]
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="pointat.pdfile"):  # whole numbers lose digits too
        to_pd(parse_patch("node d delay 1234567\nnode m msg 16777217 100000 inf\n", "n.pat"), REG)
    assert [r.message for r in caplog.records] == [
        "node 'd' (delay): Pd keeps 6 significant digits of 1234567.0: it becomes 1.23457e+06 if Pd saves the file",
        "node 'm' (msg): Pd keeps 6 significant digits of 16777217: it becomes 1.67772e+07 if Pd saves the file",
        "node 'm' (msg): Pd has no number inf: it reads back as the word 'inf'",
    ]
    assert text.startswith("#N canvas 0 50 ")
    assert text.splitlines()[1:3] == [
        f"#X declare -path {STUB_FOLDER};",
        f"#X obj 20 10 declare -path {STUB_FOLDER};",
    ]


def test_a_node_with_more_ports_than_its_stub_is_a_warning(caplog):
    with caplog.at_level(logging.WARNING, logger="pointat.pdfile"):
        to_pd(parse_patch("node base mote ids=[1, 2]\nnode show print\nbase.m2 -> show\n", "m.pat"), REG)
    [record] = caplog.records
    assert (
        "node 'base' (mote) has 1 inlets and 3 outlets, its Pd stub (default parameters) 1 and 2"
        in record.message
    )


def test_symbols_that_read_as_numbers_or_key_value_stay_symbols():
    spec = parse_patch(
        'node a print prefix="x=1"\nnode b route "5" 5 "k=v"\nnode c msg "7" "a=b"\nnode d record file="my file.csv"\n',
        "s.pat",
    )
    text = to_pd(spec, REG)
    assert r"print x\=1;" in text and r"route \5 5 k\=v;" in text and r" \7 a\=b;" in text
    back = parse_pd(text, "s.pd")
    assert [(n.args, n.params) for n in back.nodes] == [
        (["x=1"], {}),
        (["5", 5, "k=v"], {}),
        (["7", "a=b"], {}),
        ([], {"file": "my file.csv"}),
    ]


def test_layout_columns_follow_depth_and_rows_stack():
    spec = parse_patch(
        "node a loadbang\nnode b metro 10\nnode c print\nnode d print\nnode e delay 5\n"
        "a -> b -> c\nb -> d\nb -> e -> b\n",
        "l.pat",
    )
    text = to_pd(spec, REG)
    place = {name: (int(x), int(y)) for x, y, name in re.findall(r"#X text (\d+) (\d+) @name (\w+);", text)}
    box = {
        name: tuple(map(int, xy))
        for xy, name in zip(re.findall(r"#X obj (\d+) (\d+) (?!declare)", text), "abcde", strict=True)
    }
    assert place["a"][0] < place["b"][0] < place["c"][0]  # columns by depth; the loop through e is cut
    assert place["c"][0] == place["d"][0] == place["e"][0]
    assert sorted(place[k][1] for k in "cde") == [40, 90, 140]  # rows 50 px apart in a column
    assert all(box[k] == (place[k][0], place[k][1] + 20) for k in "abcde")  # the name just above its box
    assert place["b"][0] - place["a"][0] >= 160
    assert [ln for ln in text.splitlines() if ln.startswith("#X connect")] == [
        "#X connect 2 0 4 0;",
        "#X connect 4 0 6 0;",
        "#X connect 4 0 8 0;",
        "#X connect 4 0 10 0;",
        "#X connect 10 0 4 0;",
    ]


def test_abstraction_instances_are_expanded_before_writing(tmp_path):
    (tmp_path / "blink.pat").write_text(
        "args every=50\ninlet go -> m.0\nnode m metro $every\nnode p print\nm -> p\n"
    )
    main = tmp_path / "main.pat"
    main.write_text("node go loadbang\nnode one blink.pat every=25\ngo -> one.go\n")
    back = parse_pd(to_pd(read_patch(main), REG), str(tmp_path / "main.pd"))
    assert [(n.name, n.args) for n in back.nodes] == [("go", []), ("one/m", [25]), ("one/p", [])]
    assert [str(w) for w in back.wires] == ["one/m.0 -> one/p.0", "go.0 -> one/m.0"]
    assert back.doc == "Abstractions flattened, each into nodes named INSTANCE/NODE: one (blink.pat)."


# --------------------------------------------------------------------------- stubs
def test_stubs_have_the_declared_inlets_and_outlets_left_to_right(tmp_path):
    paths = write_stubs(tmp_path / STUB_FOLDER, REG)
    names = {p.stem for p in paths}
    assert names == {c.type_name for c in REG if c.type_name not in VANILLA}
    assert "speedlim" in names and not names & VANILLA
    for path in paths:
        cls = REG.get(path.stem)
        values = {**{p.name: p.default for p in cls.params}, **cls.stub_values}  # tqt_bank: 16 sensors
        try:
            ins, outs = cls.layout(values)
        except Exception:
            ins, outs = cls.inlets, cls.outlets
        text = path.read_text()
        inlets = [int(x) for x in re.findall(r"#X obj (\d+) \d+ inlet;", text)]
        outlets = [int(x) for x in re.findall(r"#X obj (\d+) \d+ outlet;", text)]
        assert (len(inlets), len(outlets)) == (len(ins), len(outs)), path.name
        assert inlets == sorted(inlets) and outlets == sorted(outlets)
        doc = (cls.__doc__ or "").strip().splitlines()
        if doc:
            assert f"{path.stem} (pointat stub)" in text
    [one] = write_stubs(tmp_path / "some", REG, ["tqt"])
    assert one.name == "tqt.pd" and len(re.findall(r" inlet;", one.read_text())) == len(REG.get("tqt").inlets)
    with pytest.raises(PatchError, match="wibble"):
        write_stubs(tmp_path / "none", REG, ["wibble"])


# --------------------------------------------------------------------------- with a real Pd, when present
def test_pd_opens_exported_patches_with_their_stubs_and_saves_the_same_graph(tmp_path, require_tool):
    require_tool(shutil.which("pd") is not None, "Pure Data (pd) is not installed")
    specs = {p.stem: read_patch(p) for p in sorted(PATCHES.glob("*.pat"))}
    specs["hand"] = parse_patch(HAND, str(tmp_path / "hand.pat"))
    write_stubs(tmp_path / STUB_FOLDER, REG)
    args, sends = [], []
    for name, spec in specs.items():
        (tmp_path / f"{name}.pd").write_text(to_pd(spec, REG))
        args += ["-open", str(tmp_path / f"{name}.pd")]
        sends.append(f"pd-{name}.pd menusave")
    done = subprocess.run(
        ["pd", "-nogui", "-noaudio", "-noprefs", "-stderr", *args, "-send", "; ".join([*sends, "pd quit"])],
        capture_output=True,
        text=True,
        timeout=30,
        check=False,
    )
    assert "couldn't create" not in done.stderr and "connection failed" not in done.stderr, done.stderr
    assert done.stderr.count("saved to:") == len(specs), done.stderr
    for name, spec in specs.items():
        saved = read_pd(tmp_path / f"{name}.pd")
        assert graph(saved) == graph(spec), name
        assert saved.doc == as_pd_shows(written_header(spec)), (
            name
        )  # Pd keeps the header comments as they were


def test_pd_prints_an_exported_print_box_with_the_prefix_pointat_prints(tmp_path, require_tool):
    require_tool(shutil.which("pd") is not None, "Pure Data (pd) is not installed")
    spec = parse_patch('node lb loadbang\nnode p print "gyro nulls (hold still)"\nlb -> p', "x.pat")
    (tmp_path / "x.pd").write_text(to_pd(spec, REG))
    done = subprocess.run(
        [
            "pd",
            "-nogui",
            "-noaudio",
            "-noprefs",
            "-stderr",
            "-open",
            str(tmp_path / "x.pd"),
            "-send",
            "pd quit",
        ],
        capture_output=True,
        text=True,
        timeout=30,
        check=False,
    )
    assert run(spec) == ["gyro nulls (hold still): bang"]
    assert "gyro nulls (hold still): bang" in done.stderr.splitlines(), done.stderr
