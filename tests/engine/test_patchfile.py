"""The native patch format and the checker: one test per error class, asserting message and line."""

import pytest

from pointat.errors import PatchError
from pointat.loader import check, expand, read_spec
from pointat.patchfile import format_value, parse_patch, parse_value, write_patch
from pointat.testing import test_registry

REG = test_registry()


def errors_of(text, name="p.pat"):
    with pytest.raises(PatchError) as info:
        check(parse_patch(text, name), REG)
    return [(p.where.line if p.where else None, p.message) for p in info.value.problems]


def test_parse_nodes_params_wires_and_chain():
    spec = parse_patch(
        """# A header comment
# becomes the doc.
node m   metro 100           # positional
node p   print prefix="a b"  \\
             time=true
node lst pack values=[1, 2.5, x]
m -> p
m.0 -> lst.1 -> p.0
""",
        "x.pat",
    )
    assert spec.doc == "A header comment\nbecomes the doc."
    assert [(n.name, n.type, n.args, n.params) for n in spec.nodes] == [
        ("m", "metro", [100], {}),
        ("p", "print", [], {"prefix": "a b", "time": True}),
        ("lst", "pack", [], {"values": [1, 2.5, "x"]}),
    ]
    assert [str(w) for w in spec.wires] == ["m.0 -> p.0", "m.0 -> lst.1", "lst.0 -> p.0"]
    assert spec.wires[2].where.line == 8


def test_numbers_keep_full_precision_and_values_round_trip():
    for v in (0.1 + 0.2, 1e-17, -3, 123456789.123456789, "two words", "sweep", ["a", 1, [2.5]], True, "12"):
        assert parse_value(format_value(v)) == v
    # texts with what splits a statement in them come back whole, in a node line too
    for v in ("a;b", "a,b", "x->y", "x<-y", "a[1]", "x\\", 'say "hi"', "a#b", "é;"):
        assert parse_value(format_value(v)) == v, v
        assert parse_patch(f"node p print {format_value(v)} true\n").node("p").args == [v, True], v


def test_a_value_ending_in_a_backslash_is_quoted_so_that_it_does_not_continue_the_line():
    spec = parse_patch('node lb loadbang\nnode q print "x\\\\"\nlb -> q\n', "x.pat")
    assert spec.node("q").args == ["x\\"]
    text = write_patch(spec)
    assert 'print "x\\\\"' in text
    assert parse_patch(text).node("q").args == ["x\\"] and len(parse_patch(text).wires) == 1


def test_write_then_parse_gives_the_same_spec():
    text = 'node a metro 33.333333333333336\nnode b print prefix="x: "\na -> b.0\n'
    spec = parse_patch(text)
    again = parse_patch(write_patch(spec))
    assert [(n.name, n.type, n.args, n.params) for n in again.nodes] == [
        (n.name, n.type, n.args, n.params) for n in spec.nodes
    ]
    assert [str(w) for w in again.wires] == [str(w) for w in spec.wires]


def test_syntax_errors_name_the_line():
    problems = errors_of('node a metro 100\nnode\nnode b print prefix="open\nwibble wobble\na -> \n')
    assert [line for line, _ in problems] == [2, 3, 4, 5]
    assert "expected 'node NAME TYPE" in problems[0][1]
    assert "unclosed quote" in problems[1][1]
    assert "unknown statement 'wibble'" in problems[2][1]


def test_duplicate_node_name():
    [(line, msg)] = errors_of("node a metro\nnode a print\n")
    assert line == 2 and "node 'a' is defined twice (first at line 1)" in msg


def test_unknown_node_type_suggests_a_close_name():
    [(line, msg)] = errors_of("node a metro\nnode b prnt\n")
    assert line == 2 and "unknown node type 'prnt' (did you mean 'print'?)" in msg


def test_unknown_parameter():
    [(line, msg)] = errors_of("node a metro intervall=3\n")
    assert (
        line == 1 and "unknown parameter 'intervall' (did you mean 'interval'?); parameters: interval" in msg
    )


def test_bad_parameter_value_says_expected_and_got():
    [(line, msg)] = errors_of("\nnode a metro interval=fast\n")
    assert line == 2 and "parameter 'interval' expects a number; got 'fast'" in msg


def test_missing_required_parameter():
    [(line, msg)] = errors_of("node r receive\n")
    assert line == 1 and "parameter 'bus' is required" in msg


def test_too_many_positional_arguments():
    [(line, msg)] = errors_of("node m metro 100 200\n")
    assert "too many creation arguments" in msg


def test_unknown_node_in_wire():
    [(line, msg)] = errors_of("node a metro\nnode b print\na -> bb\n")
    assert line == 3 and "no node named 'bb' (did you mean 'b'?)" in msg


def test_unknown_outlet_and_inlet_list_the_ports():
    problems = errors_of("node a metro\nnode b print\na.tick -> b\na -> b.3\n")
    assert problems[0] == (
        3,
        "wire a.tick -> b.0: node 'a' (metro) has no outlet 'tick'; outlets are out (0)",
    )
    assert problems[1] == (4, "wire a.0 -> b.3: node 'b' (print) has no inlet 3; inlets are in (0)")


def test_wire_kinds_that_cannot_meet():
    [(line, msg)] = errors_of("node a metro\nnode b metro\na -> b.interval\n")
    assert line == 3 and "outlet 'out' sends bang, inlet 'interval' of 'b' accepts float|int" in msg


def test_feedback_loop_without_delay_is_an_error_but_a_delay_breaks_it():
    [(line, msg)] = errors_of("node a trigger a\nnode b trigger a\na -> b\nb -> a\n")
    assert line == 1 and "feedback loop with no delay: a -> b -> a" in msg
    # through a delay, or into a cold inlet, it is fine
    check(parse_patch("node a trigger b\nnode d delay 10\na -> d\nd -> a\n"), REG)
    check(parse_patch("node a pack 0 0\nnode t trigger a\na -> t\nt -> a.1\n"), REG)
    # send/receive by name closes loops too
    [(line, msg)] = errors_of("node s send x\nnode r receive x\nnode t trigger a\nr -> t -> s\n")
    assert "feedback loop" in msg


def test_fan_out_into_one_node_is_a_warning():
    checked = check(parse_patch("node t trigger f\nnode p pack 0 0\nt -> p.1\nt -> p.0\n", "w.pat"), REG)
    [w] = [w for w in checked.warnings if "wire order" in w.message]  # (and that it does nothing)
    assert w.severity == "warning" and w.where.line == 4 and "in wire order" in w.message


def test_a_node_fed_on_cold_inlets_only_is_a_warning():
    # the gyro wire forgotten (or sent to a cold inlet by mistake): the filter would store and stay silent
    text = (
        "node lb loadbang\nnode src msg 1 2 3\nnode u unpack 0 0 0\nnode f tqt\nnode p print\n"
        "lb -> src\nsrc -> u\nu.0 -> f.accel\nu.1 -> f.mag\nf -> p\n"
    )
    [w] = check(parse_patch(text, "c.pat"), REG).warnings
    assert w.severity == "warning" and w.where.line == 4
    assert "node 'f' (tqt) is fed on cold inlets only" in w.message and "hot inlet 'gyro'" in w.message
    assert "live control" not in w.message  # nothing from outside could reach it either
    # wired to the hot inlet: nothing to say
    assert not check(parse_patch(text + "u.2 -> f.gyro\n", "c.pat"), REG).warnings
    # an abstraction checked on its own: its inlet feeds the hot inlet from outside
    assert not check(parse_patch("inlet gyro -> f.gyro\n" + text, "c.pat"), REG).warnings


def test_check_warns_about_what_can_never_act():
    def warnings(text):
        return [
            (w.where.line if w.where else None, w.message)
            for w in check(parse_patch(text, "w.pat"), REG).warnings
        ]

    # a filter and a sink nothing is wired to
    [(line, msg)] = warnings("node f tqt\nnode p print\nf -> p\n")
    assert line == 1 and "node 'f' (tqt): nothing is wired to it, so it never acts" in msg
    # an osc_out fed on its cold inlets only (the azimuth, its hot inlet, forgotten)
    text = "node g simulate\nnode q quat2euler\nnode o osc_out port=9\ng.truth -> q\nq.1 -> o.elevation\n"
    [(line, msg)] = warnings(text)
    assert line == 3 and "node 'o' (osc_out) is fed on cold inlets only" in msg and "'azimuth'" in msg
    # a sink with no source; a source wired to nothing
    assert [m for _, m in warnings("node o osc_out port=9\nnode g simulate\n")] == [
        "node 'o' (osc_out): nothing is wired to it, so it never acts",
        "node 'g' (simulate): its outlets are wired to nothing",
    ]
    # a patch that sends nothing anywhere
    [(line, msg)] = warnings("node g simulate\nnode n offset\nnode u scaling\ng -> n -> u\n")
    assert "the patch has no output" in msg
    # a chain of the patch that reaches no output, beside one that does
    msgs = warnings(
        "node g simulate\nnode n offset\nnode u scaling\nnode p print\ng -> n -> u\ng.truth -> p\n"
    )
    assert msgs == [
        (2, "'n', 'u': what they compute reaches no output (osc_out, print, record...), so they are not run")
    ]
    # a button for live control is what it is there for; a filter is not
    text = "node ctl osc_in port=0\nnode press msg bang\nnode f tqt\nnode p print\npress -> p\nf -> p\n"
    [(line, msg)] = warnings(text)
    assert line == 3 and msg.endswith("never acts (unless live control sends to it)")


def test_check_says_every_problem_in_one_run(tmp_path):
    """Syntax-free but wrong in every other way: parameter types, ranges, wires, a loop and a missing
    abstraction, all in one run, in the order of the lines."""
    (tmp_path / "show.pat").write_text(
        "node glove simulate rate=abc\nnode fuse tqt dip=120\nnode out osc_out port=9999 radius=-1\n"
        "node b msg 1\nnode c t b b\nglove.adc -> fuse.gyro\nfuse.nope -> out\nghost -> out\n"
        "node x missing.pat\nb -> c\nc -> b\nglove.adc -> fuse.wrong\n"
    )
    with pytest.raises(PatchError) as info:
        check(read_spec(tmp_path / "show.pat"), REG)
    said = [(p.where.line, p.message) for p in info.value.problems]
    lines = [line for line, _ in said]
    assert lines == sorted(lines)
    text = "\n".join(m for _, m in said)
    for part in (
        "parameter 'rate' expects a number; got 'abc'",
        "dip must be -90..90",
        "radius must be a finite number >= 0",
        "feedback loop with no delay: b -> c -> b",
        "node 'fuse' (tqt) has no outlet 'nope'",
        "no node named 'ghost'",
        "'missing.pat' not found",
        "node 'fuse' (tqt) has no inlet 'wrong'",  # a wire into a node that is itself refused
    ):
        assert part in text, part
    # two wrong parameters of one node: both
    with pytest.raises(PatchError) as info:
        check(parse_patch("node g simulate rate=abc seed=-1 nosuch=1\n", "p.pat"), REG)
    [problem] = info.value.problems
    assert "rate" in problem.message and "seed" in problem.message and "nosuch" in problem.message


def test_a_file_a_node_reads_at_start_that_is_not_there_is_a_warning(tmp_path):
    (tmp_path / "take1.csv").write_text("t,gx\n")
    (tmp_path / "show.pat").write_text("node a replay file=take1.csv\nnode b replay file=take2.csv\n")
    warnings = check(read_spec(tmp_path / "show.pat"), REG).warnings
    [w] = [w for w in warnings if "no file" in w.message]  # relative to the patch: take1 is found
    assert w.severity == "warning" and w.where.line == 2
    assert "node 'b' (replay): parameter 'file': no file" in w.message and "take2.csv" in w.message
    # a file a node writes may well not be there yet
    text = "node g simulate\nnode r record file=out.csv\ng.truth -> r\n"
    assert not check(parse_patch(text, str(tmp_path / "r.pat")), REG).warnings


def test_all_errors_are_reported_at_once():
    problems = errors_of("node a metr\nnode b prnt\nnode c metro x=1\n")
    assert [line for line, _ in problems] == [1, 2, 3]


def test_overrides(tmp_path):
    spec = parse_patch("node m metro 100\n")
    checked = check(spec, REG, [("m", "interval", 20)])
    assert checked.nodes["m"].values["interval"] == 20.0
    with pytest.raises(PatchError, match="--set mm.interval: no node named 'mm'"):
        check(spec, REG, [("mm", "interval", 20)])
    with pytest.raises(PatchError) as info:  # a bad value is the command line's, not the file's line 1
        check(spec, REG, [("m", "interval", "fast"), ("m", "intervl", 5)])
    assert [(p.where, p.message) for p in info.value.problems] == [
        (None, "--set m.interval: node 'm' (metro): parameter 'interval' expects a number; got 'fast'"),
        (
            None,
            "--set m.intervl: node 'm' (metro): unknown parameter 'intervl' (did you mean 'interval'?); parameters: interval",
        ),
    ]


def test_a_value_that_does_not_read_is_a_located_error_and_a_substituted_text_stays_text(tmp_path):
    from pointat.loader import parse_overrides

    with pytest.raises(PatchError, match=r"--set 'n.samples=\[1,': bad list"):  # not a traceback
        parse_overrides(["n.samples=[1,"])
    (tmp_path / "a.pat").write_text('args id=1\ninlet in -> p.0\nnode p print prefix="[glove $id] az el"\n')
    (tmp_path / "main.pat").write_text("node g a.pat id=3\n")
    checked = check(read_spec(tmp_path / "main.pat"), REG)  # "[glove 3] az el" read as a list failed
    assert checked.nodes["g/p"].values["prefix"] == "[glove 3] az el"


def test_an_override_of_a_flattened_instance_names_the_nodes_inside_that_take_it():
    # a .pd subpatch, or an abstraction instance that convert flattened: 'v' is no node, 'v/m' and 'v/d' are
    spec = parse_patch("node v/m metro 100\nnode v/d delay 5\nnode p print\nv/m -> v/d -> p\n")
    with pytest.raises(PatchError) as info:
        check(spec, REG, [("v", "interval", 20), ("v", "speed", 2), ("v", "time", 9)])
    assert [p.message for p in info.value.problems] == [
        "--set v.interval: no node named 'v' but nodes inside it, a subpatch or a converted abstraction "
        "(v/m, v/d); set v/m.interval",
        "--set v.speed: no node named 'v' but nodes inside it, a subpatch or a converted abstraction "
        "(v/m, v/d); set one of them (none has a parameter 'speed')",
        "--set v.time: no node named 'v' but nodes inside it, a subpatch or a converted abstraction "
        "(v/m, v/d); set v/d.time",
    ]


def test_overrides_reach_an_abstraction_instances_arguments(tmp_path):
    (tmp_path / "voice.pat").write_text("args rate=100\ninlet go -> m.0\nnode m metro $rate\n")
    (tmp_path / "main.pat").write_text("node left voice.pat rate=50\nnode right voice.pat\n")
    spec = read_spec(tmp_path / "main.pat")
    # --set left.rate=20: the instance's argument, as if written on its line; inner nodes by their path
    checked = check(spec, REG, [("left", "rate", 20), ("right/m", "interval", 30)])
    assert checked.nodes["left/m"].values["interval"] == 20.0
    assert checked.nodes["right/m"].values["interval"] == 30.0
    with pytest.raises(
        PatchError,
        match=r"--set left.rte: abstraction instance 'left' \(voice.pat\) has no "
        r"argument 'rte' \(arguments: rate; its nodes are set as left/NODE.PARAM\)",
    ):
        check(spec, REG, [("left", "rte", 20)])
    with pytest.raises(PatchError) as info:  # refused inside the abstraction: at the user's line, and why
        check(spec, REG, [("left", "rate", "fast")])
    [problem] = info.value.problems
    assert problem.where.file.endswith("main.pat") and problem.where.line == 1
    assert problem.message.endswith(
        "got 'fast' (its instance's arguments given: --set left.rate=fast) "
        f"(in abstraction voice.pat:3, created at {tmp_path / 'main.pat'}:1)"
    )
    (tmp_path / "lib").mkdir()  # an argument written on the instance's line, the abstraction elsewhere
    (tmp_path / "lib" / "voice.pat").write_text("args rate=100\ninlet go -> m.0\nnode m metro $rate\n")
    (tmp_path / "mine.pat").write_text("# mine\nnode left lib/voice.pat rate=fast\n")
    with pytest.raises(PatchError) as info:
        check(read_spec(tmp_path / "mine.pat"), REG)
    [problem] = info.value.problems
    assert str(problem).startswith(f"{tmp_path / 'mine.pat'}:2: error: node 'left/m' (metro): ")
    assert str(problem).endswith(f"(in abstraction lib/voice.pat:3, created at {tmp_path / 'mine.pat'}:2)")


def test_abstraction_instantiated_twice_with_arguments(tmp_path):
    (tmp_path / "voice.pat").write_text(
        "# one voice\nargs rate=100 bus=x\ninlet go -> m.0\noutlet tick <- m.0\n"
        "node m metro $rate\nnode s send bus=$0-$bus\nm -> s\n"
    )
    (tmp_path / "main.pat").write_text(
        "node lb loadbang\nnode left voice.pat rate=50\nnode right voice.pat bus=y\nnode p print\n"
        "lb -> left.go\nlb -> right\nleft.tick -> p\nright.0 -> p\n"
    )
    spec = expand(read_spec(tmp_path / "main.pat"))
    names = [n.name for n in spec.nodes]
    assert names == ["lb", "left/m", "left/s", "right/m", "right/s", "p"]
    params = {n.name: (n.args, n.params) for n in spec.nodes}
    assert params["left/m"] == ([50], {}) and params["right/m"] == ([100], {})
    assert params["left/s"][1] == {"bus": "left-x"} and params["right/s"][1] == {"bus": "right-y"}
    assert sorted(str(w) for w in spec.wires) == sorted(
        [
            "left/m.0 -> left/s.0",
            "right/m.0 -> right/s.0",
            "lb.0 -> left/m.0",
            "lb.0 -> right/m.0",
            "left/m.0 -> p.0",
            "right/m.0 -> p.0",
        ]
    )
    check(read_spec(tmp_path / "main.pat"), REG)


def test_nested_abstractions_ports_dollar_zero_and_fanned_out_inlets(tmp_path):
    (tmp_path / "inner.pat").write_text(
        "inlet in -> s\noutlet out <- r\nnode s send bus=$0-b\nnode r receive bus=$0-b\n"
    )
    # outer's ports lead into an instance of inner; its inlet 'go' fans out, so 'stop' is inlet 1
    (tmp_path / "outer.pat").write_text(
        "inlet go -> x\ninlet go -> m\ninlet stop -> q\noutlet out <- x.out\n"
        "node x inner.pat\nnode m metro 100\nnode q print\n"
    )
    (tmp_path / "main.pat").write_text(
        "node lb loadbang\nnode a outer.pat\nnode b outer.pat\nnode p print\n"
        "lb -> a -> p\nlb -> b.1\nb.out -> p\n"
    )
    spec = expand(read_spec(tmp_path / "main.pat"))
    params = {n.name: n.params for n in spec.nodes}
    assert params["a/x/s"] == {"bus": "a/x-b"} and params["b/x/r"] == {"bus": "b/x-b"}  # one bus each
    assert sorted(str(w) for w in spec.wires) == sorted(
        ["lb.0 -> a/x/s.0", "lb.0 -> a/m.0", "a/x/r.0 -> p.0", "lb.0 -> b/q.0", "b/x/r.0 -> p.0"]
    )
    check(read_spec(tmp_path / "main.pat"), REG)
    (tmp_path / "bad.pat").write_text("inlet in -> x.nosuch\noutlet out <- x.7\nnode x inner.pat\n")
    (tmp_path / "main2.pat").write_text("node c bad.pat\n")
    with pytest.raises(PatchError) as info:
        check(read_spec(tmp_path / "main2.pat"), REG)
    assert [(p.where.file, p.where.line, p.message) for p in info.value.problems] == [
        (str(tmp_path / "bad.pat"), 1, "abstraction instance 'x' has no inlet 'nosuch'"),
        (str(tmp_path / "bad.pat"), 2, "abstraction instance 'x' has no outlet 7"),
    ]


def test_an_abstraction_checked_on_its_own_takes_its_defaults_and_its_ports_are_checked(tmp_path):
    (tmp_path / "voice.pat").write_text(
        "args rate=100\ninlet go -> m\nnode m metro $rate\nnode s send bus=$0-x\n"
    )
    checked = check(read_spec(tmp_path / "voice.pat"), REG)
    assert checked.nodes["m"].values["interval"] == 100.0 and checked.nodes["s"].values["bus"] == "voice-x"
    (tmp_path / "bad.pat").write_text(
        "args n=1\ninlet in -> pp\ninlet in2 -> m.nosuch\noutlet out <- m.7\nnode m metro $n $nope\n"
    )
    with pytest.raises(PatchError) as info:
        check(read_spec(tmp_path / "bad.pat"), REG)
    assert [(p.where.line, p.message) for p in info.value.problems] == [
        (5, "$nope is not an argument (arguments: n)")
    ]
    (tmp_path / "bad.pat").write_text(
        "args n=1\ninlet in -> pp\ninlet in2 -> m.nosuch\noutlet out <- m.7\nnode m metro $n\n"
    )
    with pytest.raises(PatchError) as info:
        check(read_spec(tmp_path / "bad.pat"), REG)
    assert [(p.where.line, p.message) for p in info.value.problems] == [
        (2, "inlet in -> pp.0: no node named 'pp'"),
        (3, "inlet in2 -> m.nosuch: node 'm' (metro) has no inlet 'nosuch'; inlets are on (0), interval (1)"),
        (4, "outlet out <- m.7: node 'm' (metro) has no outlet 7; outlets are out (0)"),
    ]


def test_abstraction_errors(tmp_path):
    (tmp_path / "a.pat").write_text("args x=1\nnode m metro $y\n")
    (tmp_path / "loop.pat").write_text("node again loop.pat\n")
    (tmp_path / "main.pat").write_text(
        "node one a.pat z=2\nnode two missing.pat\nnode three loop.pat\nnode four a.pat\n"
    )
    with pytest.raises(PatchError) as info:
        check(read_spec(tmp_path / "main.pat"), REG)
    msgs = [(p.where.line, p.message) for p in info.value.problems]
    assert msgs[0][0] == 1 and "has no argument 'z' (arguments: x)" in msgs[0][1]
    assert msgs[1][0] == 2 and "'missing.pat' not found" in msgs[1][1]
    assert "includes itself" in msgs[2][1]
    assert msgs[3][0] == 2 and "$y is not an argument" in msgs[3][1]  # the line inside a.pat


def test_a_misspelt_abstraction_is_one_error_with_the_file_it_may_have_meant(tmp_path):
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "voice.pat").write_text("inlet go -> m.0\noutlet tick <- m.0\nnode m metro 100\n")
    (tmp_path / "main.pat").write_text(
        "node lb loadbang\nnode v lib/voise.pat\nnode p print\nlb -> v.go\nv.tick -> p\n"
    )
    with pytest.raises(PatchError) as info:
        check(read_spec(tmp_path / "main.pat"), REG)
    [problem] = info.value.problems  # not one more for each of its wires
    assert problem.where.line == 2 and "did you mean 'lib/voice.pat'?" in problem.message


def test_unreadable_file_is_a_patch_error(tmp_path):
    with pytest.raises(PatchError, match="cannot read patch"):
        read_spec(tmp_path / "nope.pat")


def test_a_comment_line_ending_in_a_backslash_does_not_swallow_the_next_line():
    spec = parse_patch(
        "# a diagram:\n#   gyro --\\\n#        \\-> fuse\nnode a metro 100  \\\n    interval=50\n",
        "c.pat",
    )
    assert spec.doc.splitlines() == ["a diagram:", "  gyro --\\", "       \\-> fuse"]  # its indentation kept
    header = "# a diagram:\n#   gyro --\\\n#        \\-> fuse\n## a title\n"
    assert write_patch(parse_patch(header + "node a metro 100\n", "c.pat")).startswith(header)
    assert [(n.name, n.type, n.args, n.params) for n in spec.nodes] == [
        ("a", "metro", [100], {"interval": 50})
    ]


def the_problem(path):
    """The one problem that checking the patch at ``path`` finds."""
    with pytest.raises(PatchError) as info:
        check(read_spec(path), REG)
    [problem] = info.value.problems
    return problem


def test_an_abstraction_loop_names_each_file_and_folder_or_pd_abstractions_are_told_apart(tmp_path):
    (tmp_path / "a.pat").write_text("node x b.pat\n")
    (tmp_path / "b.pat").write_text("node y a.pat\n")
    problem = the_problem(tmp_path / "a.pat")
    assert problem.where.file.endswith("b.pat") and problem.where.line == 1
    assert problem.message == "abstraction 'a.pat' includes itself: a.pat -> b.pat -> a.pat"
    (tmp_path / "lib").mkdir()
    (tmp_path / "dir.pat").mkdir()
    (tmp_path / "ok.pd").write_text(
        "#N canvas 0 0 450 300 12;\n#X obj 10 10 loadbang;\n#X obj 10 40 print;\n"
    )
    (tmp_path / "main.pat").write_text("node f lib/\nnode g dir.pat\nnode h ok.pd\n")
    with pytest.raises(PatchError) as info:
        check(read_spec(tmp_path / "main.pat"), REG)
    assert [(p.where.line, p.message.split(" (")[0]) for p in info.value.problems] == [
        (1, "abstraction 'lib/' is a folder"),  # the line that uses it, not a bare "Is a directory"
        (2, "abstraction 'dir.pat' is a folder"),
    ]  # and ok.pd, with no folder in its name, is an abstraction as ok.pat would be
    ok = check(parse_patch("node h ok.pd\n", str(tmp_path / "m.pat")), REG)
    assert [n.name for n in ok.spec.nodes] == ["h/loadbang_0", "h/print_1"]


def test_a_dollar_name_in_a_patch_without_arguments_is_an_error_at_its_own_line(tmp_path):
    (tmp_path / "good.pat").write_text("args n=1\nnode b metro $n\n")
    (tmp_path / "top.pat").write_text("node lb loadbang\nnode i good.pat n=$z\n")
    problem = the_problem(tmp_path / "top.pat")
    assert problem.where.file.endswith("top.pat") and problem.where.line == 2  # not inside good.pat
    assert problem.message == "$z is not an argument (arguments: none)"


def test_a_hand_written_name_meeting_an_abstractions_node_names_both_and_blames_neither_wrongly(tmp_path):
    (tmp_path / "sub.pat").write_text("args x=1\nnode b metro $x\noutlet o <- b\n")
    (tmp_path / "top.pat").write_text("node a sub.pat\nnode a/b print\na -> a/b\n")
    problem = the_problem(tmp_path / "top.pat")  # no second error about a print node's outlet
    sub, top = tmp_path / "sub.pat", tmp_path / "top.pat"
    assert problem.message == (
        f"node 'a/b' is defined twice: at {sub}:2 (node 'b' of instance 'a') and at {top}:2; rename one"
    )


def test_lists_nested_too_deep_long_words_and_arguments_given_twice_are_located():
    deep = "node m msg " + "[" * 1000 + "]" * 1000 + "\n"
    assert errors_of(deep) == [(1, "lists nested more than 100 deep")]
    word = "w" * 300_000  # read in linear time (it once took quadratic: a 5 MB line did not end)
    assert parse_patch(f"node p print prefix={word}\n").node("p").params["prefix"] == word
    assert errors_of("args n=1 n=2\nnode m metro $n\n") == [(1, "argument 'n' given twice")]
    assert errors_of("args n=1\nargs n=2\nnode m metro $n\n") == [(2, "argument 'n' given twice")]


def test_a_chain_of_thousands_of_nodes_is_checked_without_recursion_and_its_depth_is_told():
    n = 3000
    text = "node n0 loadbang\n" + "".join(f"node n{i} t b\n" for i in range(1, n)) + "node p print\n"
    text += "".join(f"n{i - 1} -> n{i}\n" for i in range(1, n)) + f"n{n - 1} -> p\n"
    checked = check(parse_patch(text, "deep.pat"), REG)
    [w] = checked.warnings
    assert f"a chain of {n + 1} nodes one after the other ends at 'p': messages stop after 250" in w.message
    # a loop as long: found (iteratively), named from its first node
    loop = text + "n2999 -> n1\n"
    with pytest.raises(PatchError, match=r"deep.pat:2: .*feedback loop with no delay: n1 -> n2 -> n3"):
        check(parse_patch(loop, "deep.pat"), REG)
    short = "node a loadbang\nnode b t b\nnode p print\na -> b -> p\n"
    assert not check(parse_patch(short, "s.pat"), REG).warnings


def test_names_and_files_no_patch_can_be_are_located_errors_never_a_hang(tmp_path):
    """Names longer than the system takes, devices, pipes and huge files, where a patch names an
    abstraction, a file a node reads or one it writes, or as the patch itself."""
    import os
    import subprocess
    import sys

    long = "x" * 300
    fifo = tmp_path / "take.csv"
    os.mkfifo(fifo)
    cases = {
        f"node a {long}.pat\n": "abstraction 'xxx",
        f"node r replay file={long}.csv\n": "parameter 'file': ",
        f"node t record file={long}.csv\n": "parameter 'file': ",
        f"node r replay file={fifo}\n": "take.csv: not a regular file",
        "node r replay file=/dev/zero\n": "/dev/zero: not a regular file",
        "node a /dev/zero\n": "abstraction '/dev/zero' is not a regular file",
        "node a a\x00b.pat\n": "holds a NUL character: no file is named so",
    }
    for text, said in cases.items():
        with pytest.raises(PatchError) as info:
            check(parse_patch(text, str(tmp_path / "p.pat")), REG, read_files=True)
        [problem] = info.value.problems
        assert problem.where.line == 1 and said in problem.message, (text[:40], problem)
    if os.path.exists("/proc/self/mem"):  # a file that is there and cannot be read: at the instance
        with pytest.raises(PatchError) as info:
            check(parse_patch("node a /proc/self/mem\n", str(tmp_path / "p.pat")), REG)
        [problem] = info.value.problems
        assert (
            problem.where.line == 1 and "abstraction '/proc/self/mem': cannot read patch" in problem.message
        )
    # the patch itself: a pipe nobody writes to, a device without end, a file far larger than a patch
    pipe = tmp_path / "pipe.pat"
    os.mkfifo(pipe)
    big = tmp_path / "big.pat"
    big.write_text("# " + "x" * (5 * 2**20) + "\n")
    for path, said in (
        (pipe, "not a regular file"),
        ("/dev/zero", "not a regular file"),
        (big, "larger than a patch"),
    ):
        out = subprocess.run(
            [sys.executable, "-m", "pointat.cli", "check", str(path)],
            capture_output=True,
            text=True,
            timeout=20,
        )
        assert out.returncode == 2 and f"{path}: error: " in out.stderr and said in out.stderr, out.stderr
