"""The patch readers never crash: mutated patch files, and any text at all, are checked or refused with
errors that name the file and the line, never a traceback or a hang.

A fast, seeded run of the mutation fuzzer (``tests/fuzz.py``; its long run is
``python -m tests.fuzz --minutes 10``), and property tests of the tokenizer and the two parsers.
"""

import importlib.util
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pointat.errors import PatchError
from pointat.node import Param, ParamError
from pointat.patchfile import parse_patch, parse_value, tokenize
from pointat.pdfile import parse_pd


def _fuzz_module():
    """``tests/fuzz.py``, whether or not ``tests`` is importable as a package from here."""
    path = Path(__file__).resolve().parents[1] / "fuzz.py"
    spec = importlib.util.spec_from_file_location("pointat_tests_fuzz", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # (its dataclasses, and the cases sent to its workers, look it up)
    spec.loader.exec_module(module)
    return module


fuzz = _fuzz_module()


# =========================================================================== mutants through `pointat check`
@pytest.mark.parametrize("cases", [300, pytest.param(3000, marks=pytest.mark.slow)])
def test_mutated_patches_are_checked_or_refused_never_a_traceback_or_a_hang(cases):
    # a hang is a case with no answer in two minutes: one that takes seconds on a loaded machine is slow,
    # not hung (the fuzzer's own 5 s is for its long runs, on a machine left to it)
    report = fuzz.fuzz(cases_max=cases, seed=2024, jobs=2, timeout=120.0, reduce_seconds=0)
    assert report.cases == cases
    assert min(report.counts["ok"], report.counts["refused"]) > cases // 10  # the mutants reach both ends
    crashes = [
        f"{c.count} x {c.key}: case {c.case.number} from {c.case.seed} ({', '.join(c.case.mutations)}); "
        f"first lines: {c.case.data[:300]!r}\n{c.detail[-1500:]}"
        for c in report.classes.values()
    ]
    assert not crashes, "\n\n".join(crashes)


# =========================================================================== properties
_SETTINGS = settings(max_examples=300, deadline=None, derandomize=True, database=None)

PATCH_WORDS = (
    "node",
    "args",
    "inlet",
    "outlet",
    "->",
    "<-",
    "a",
    "b",
    "a.0",
    "b.1",
    "a.out",
    "left/fuse",
    "metro",
    "print",
    "msg",
    "lib/x.pat",
    "k=1",
    "k=[1, 2]",
    "k=[[a]]",
    'k="a b"',
    "k=",
    "=",
    "true",
    "-0.5",
)
#: Words of native patches, and the fuzzer's odd ones (numbers, Unicode, brackets, quotes, paths).
patch_word = st.one_of(
    st.sampled_from(PATCH_WORDS),
    st.sampled_from(fuzz.NUMBERS + fuzz.ODD + fuzz.STRUCTURE),
    st.text(max_size=6),
)
patch_line = st.lists(patch_word, max_size=8).flatmap(
    lambda words: st.sampled_from((" ", "", "  ", "\t", " \\\n ")).map(lambda sep: sep.join(words))
)
patch_text = st.lists(patch_line, max_size=12).flatmap(
    lambda lines: st.sampled_from(("\n", "\r\n", "\r", "\u2028")).map(lambda nl: nl.join(lines))
)

pd_atom = st.one_of(
    st.sampled_from(
        (
            "0",
            "1",
            "2",
            "-1",
            "10",
            "0.5",
            "inlet",
            "outlet",
            "inlet~",
            "metro",
            "print",
            "change",
            "loadbang",
            "pd",
            "graph",
            "sub",
            "@name",
            "a=b",
            "a\\=b",
            "\\,",
            "\\;",
            "\\$1",
            "\\",
            ",",
            "f",
        )
    ),
    st.sampled_from(fuzz.NUMBERS + fuzz.ODD),
    st.integers(-2, 12).map(str),
    st.text(max_size=5),
)
pd_record = st.one_of(
    st.sampled_from([s for s in fuzz.STRUCTURE if s.startswith("#")]),
    st.builds(
        lambda head, atoms: " ".join([head, *atoms]) + ";",
        st.sampled_from(
            (
                "#N canvas",
                "#X obj",
                "#X obj 0 0",
                "#X msg 0 0",
                "#X text 0 0",
                "#X connect",
                "#X restore 0 0",
                "#X restore 0 0 pd",
                "#X floatatom",
                "#X scalar",
                "#A",
                "#X",
            )
        ),
        st.lists(pd_atom, max_size=6),
    ),
)
pd_text = st.lists(pd_record, max_size=15).map(
    lambda records: "#N canvas 0 50 450 300 10;\n" + "\n".join(records)
)


def _assert_located(exc: PatchError, path: str, lines: int) -> None:
    """Every problem names ``path`` and a line of it (1..``lines``), and says so first: ``path:line: ``."""
    assert exc.problems
    for p in exc.problems:
        assert p.where is not None and p.where.file == path, p
        assert 1 <= p.where.line <= max(lines, 1), p
        assert str(p).startswith(f"{path}:{p.where.line}"), p


@_SETTINGS
@given(st.one_of(st.text(), patch_line))
def test_tokenize_gives_words_or_refuses_with_a_value_error(line):
    try:
        tokens = tokenize(line)
    except ValueError:  # unclosed quote, unbalanced brackets: parse_patch makes it a located syntax error
        return
    assert all(isinstance(t, str) and t for t in tokens)


@_SETTINGS
@given(st.one_of(st.text(), patch_word, patch_line))
def test_parse_value_gives_a_value_or_refuses_with_a_value_error(text):
    tokens = [text]
    try:
        tokens += tokenize(text)
    except ValueError:
        pass
    for token in tokens:
        try:
            value = parse_value(token)
        except ValueError:  # a bad list, lists nested too deep, a number too large
            continue
        assert isinstance(value, (int, float, bool, str, list))


@_SETTINGS
@given(st.one_of(st.text(), patch_word, patch_line))
def test_a_list_or_vector_given_as_one_text_is_its_atoms_or_refused_with_a_param_error(text):
    # (``--set node.ids="1 2"``, an OSC string to a list parameter: read as Pd reads a message)
    for param in (Param("ids", "list", ()), Param("at", "vector", (0.0, 0.0), size=2)):
        try:
            value = param.coerce(text)
        except ParamError:
            continue
        assert isinstance(value, tuple) and value
        if param.type == "list" and len(text.split()) < 2:
            assert value == (text,)  # one word stays one


@_SETTINGS
@given(st.one_of(st.text(), patch_text))
def test_parse_patch_gives_a_patch_or_errors_at_their_lines(text):
    try:
        parse_patch(text, "fuzzed.pat")
    except PatchError as exc:
        _assert_located(exc, "fuzzed.pat", len(text.splitlines()))


@_SETTINGS
@given(st.one_of(st.text(), pd_text, patch_text))
def test_parse_pd_gives_a_patch_or_errors_at_their_lines(text):
    try:
        parse_pd(text, "fuzzed.pd")
    except PatchError as exc:
        _assert_located(exc, "fuzzed.pd", text.count("\n") + 1)


def test_numbers_too_large_for_a_float_are_errors_at_their_line():
    """A 400-digit integer is no float (nodes compute with floats), nor 5,000 digits an int (Python's
    limit): both are refused where they are written, in either format."""
    for digits in ("9" * 400, "1" + "0" * 5000):
        try:
            parse_patch(f"node a metro\nnode b metro {digits}\n", "big.pat")
        except PatchError as exc:
            [problem] = exc.problems
            assert problem.where.line == 2 and "number too large" in problem.message
        else:
            raise AssertionError("a number too large was read")
        try:
            parse_pd(f"#N canvas 0 50 450 300 10;\n#X obj 10 10 metro\n{digits};\n", "big.pd")
        except PatchError as exc:
            [problem] = exc.problems
            assert problem.where.line == 3 and "number too large" in problem.message
        else:
            raise AssertionError("a number too large was read")
    assert parse_value("-" + "9" * 300) == -int("9" * 300)  # large, but a float holds it


def test_subpatches_nested_and_chained_deeper_than_the_stack_are_read():
    """Pd files of 3,000 nested subpatches, or a wire through 2,000 subpatches one after the other, are
    read without recursion (each level once)."""
    n = 3000
    nested = (
        "#N canvas 0 50 450 300 10;\n#X obj 0 0 loadbang;\n"
        + "#N canvas 0 0 450 300 s 0;\n#X obj 0 0 inlet;\n" * n
        + "#X obj 0 0 print;\n#X connect 0 0 1 0;\n"
        + "#X restore 0 0 pd s;\n#X connect 0 0 1 0;\n" * n
    )
    spec = parse_pd(nested, "nested.pd")
    assert [str(w) for w in spec.wires] == [f"loadbang_0.0 -> {'s/' * n}print_1.0"]
    n = 2000
    through = "#N canvas 0 0 450 300 s 0;\n#X obj 0 0 inlet;\n#X obj 0 0 outlet;\n#X connect 0 0 1 0;\n"
    chained = (
        "#N canvas 0 50 450 300 10;\n#X obj 0 0 loadbang;\n"
        + (through + "#X restore 0 0 pd s;\n") * n
        + "#X obj 0 0 print;\n"
        + "".join(f"#X connect {k} 0 {k + 1} 0;\n" for k in range(n + 1))
    )
    spec = parse_pd(chained, "chained.pd")
    assert [str(w) for w in spec.wires] == ["loadbang_0.0 -> print_2001.0"]


def test_a_long_run_of_digits_is_read_in_linear_time():
    """A 100,000-digit word that is no number (``111...1x``) is a symbol at once, not after a search
    through every way to split its digits."""
    spec = parse_pd("#N canvas 0 50 450 300 10;\n#X obj 0 0 print " + "1" * 100_000 + "x;\n", "long.pd")
    assert spec.nodes[0].args == ["1" * 100_000 + "x"]


def test_fan_outs_through_subpatches_that_multiply_past_a_bound_are_an_error_not_a_billion_wires():
    """Each subpatch's inlet feeds two outlets, both wired to the next one's inlet: 2**n wires from the
    loadbang to the print.  Up to a bound they are all made (as Pd would send them all); past it, one error
    at the connect that goes past it, at once."""

    def diamonds(n: int) -> str:
        level = (
            "#N canvas 0 0 450 300 s 0;\n#X obj 0 0 inlet;\n#X obj 0 50 outlet;\n#X obj 50 50 outlet;\n"
            "#X connect 0 0 1 0;\n#X connect 0 0 2 0;\n#X restore 0 0 pd s;\n"
        )
        wires = "".join(
            f"#X connect {k} 0 {k + 1} 0;\n#X connect {k} 1 {k + 1} 0;\n" for k in range(1, n + 1)
        )
        return (
            "#N canvas 0 50 450 300 10;\n#X obj 0 0 loadbang;\n"
            + level * n
            + "#X obj 0 0 print;\n#X connect 0 0 1 0;\n"
            + wires
        )

    assert len(parse_pd(diamonds(10), "d.pd").wires) == 2**10
    try:
        parse_pd(diamonds(60), "d.pd")
    except PatchError as exc:
        [problem] = exc.problems
        assert problem.where.line > 1 and "branch into more than 100,000" in problem.message
    else:
        raise AssertionError("2**60 wires were made")
