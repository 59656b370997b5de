"""``pointat check`` says ok exactly when ``pointat run`` starts: both go through one validation
(:func:`pointat.loader.ready`: the patch checked with its files read, every node built and prepared), and
run opens its devices and ports only after it.

A property over patches generated from nodes that read and write files (good, spoilt, missing, a folder)
and over the fuzzer's mutants of every shipped patch (``tests/fuzz.py``): check exits 0 iff ``run --for 0``
does, and where both refuse they say the same errors.  Every port is moved off the show's
(:func:`pointat.testing.beside`); a patch that would open a device (a serial port, MIDI), write outside
the sandbox or into a FIFO, or send off this machine is checked but not run (the line between check and
run: opening things is run's alone).
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import os
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pointat import cli
from pointat.errors import PointatError
from pointat.maths.calibration import Calibration
from pointat.testing import beside

ROOT = Path(__file__).resolve().parents[2]


def _fuzz_module():
    """``tests/fuzz.py`` (loaded once, as tests/engine/test_fuzz_patches.py loads it)."""
    name = "pointat_tests_fuzz"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, ROOT / "tests" / "fuzz.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


fuzz = _fuzz_module()

#: Files the generated patches name, in the sandbox's gen/ folder (made by the fixture): the good one
#: first and twice, so that about half the patches check.
CALIBRATIONS = ("cal.json", "cal.json", "spoilt.json", "missing.json", "afolder", "")
TAKES = ("pointat:data/glove_take.csv.gz", "pointat:data/glove_take.csv.gz", "spoilt.csv", "missing.csv")
SKELETONS = ("pointat:data/arm.json", "pointat:data/arm.json", "spoilt.json", "missing.json")
LAYOUTS = ("layout.txt", "layout.txt", "spoilt.json", "missing.txt", "")
EXAMPLES = ("missing.json", "missing.json", "spoilt.json", "afolder")  # (missing: the node starts empty)
WRITTEN = ("out.csv", "out.csv", "nofolder/out.csv", "afolder")

NODES = st.one_of(
    st.sampled_from(
        (
            "loadbang",
            "metro 5",
            "msg 1",
            "print p",
            "delay 1",
            "tqt",
            "osc_in",
            "osc_out",
            "simulate duration=0.05",
            "azi_ele",
            "metro -1",
            "nosuch",
        )
    ),
    st.sampled_from(CALIBRATIONS).map(lambda f: f"offset calibration={f}".rstrip("=")),
    st.sampled_from(CALIBRATIONS).map(lambda f: f"scaling calibration={f}".rstrip("=")),
    st.sampled_from(TAKES).map(lambda f: f"replay file={f}"),
    st.sampled_from(SKELETONS).map(lambda f: f"skeleton file={f}"),
    st.sampled_from(LAYOUTS).map(lambda f: f"vbap file={f}".rstrip("=")),
    st.sampled_from(EXAMPLES).map(lambda f: f"gesture channels=[acc] file={f}"),
    st.sampled_from(WRITTEN).map(lambda f: f"record file={f}"),
)
#: Nodes that are right, their files too: what is wrong in a patch of these is in its wires.
GOOD = st.sampled_from(
    (
        "metro 5",
        "print p",
        "tqt",
        "osc_in",
        "osc_out",
        "simulate duration=0.05",
        "offset calibration=cal.json",
        "replay file=pointat:data/glove_take.csv.gz",
        "skeleton file=pointat:data/arm.json",
        "vbap file=layout.txt",
        "gesture channels=[acc] file=missing.json",
        "record file=out.csv",
    )
)


@st.composite
def generated(draw, kinds=NODES) -> tuple[str, str, list[str]]:
    """A patch of a few nodes and wires (some wrong), and ``--set``s (some of files, some of nothing)."""
    nodes = draw(st.lists(kinds, min_size=1, max_size=4))
    lines = [f"node n{k} {text}" for k, text in enumerate(nodes)]
    ends = st.integers(0, len(nodes) - 1)
    for a, o, b, i in draw(st.lists(st.tuples(ends, st.integers(0, 2), ends, st.integers(0, 2)), max_size=4)):
        lines.append(f"n{a}.{o} -> n{b}.{i}")
    sets = draw(
        st.lists(
            st.tuples(ends, st.sampled_from(("calibration", "file"))).flatmap(
                lambda np: st.sampled_from(CALIBRATIONS + TAKES).map(lambda f: f"n{np[0]}.{np[1]}={f}")
            ),
            max_size=1,
        )
    )
    return "gen/patch.pat", "\n".join(lines) + "\n", sets


@pytest.fixture(scope="module")
def sandbox(tmp_path_factory):
    """The fuzzer's sandbox (the repository's patches, data linked, FIFOs), and gen/ with the files the
    generated patches name."""
    seeds = fuzz.seeds()
    root = fuzz.make_sandbox(tmp_path_factory.mktemp("check-is-run"), seeds)
    gen = root / "gen"
    (gen / "afolder").mkdir(parents=True)
    Calibration().save(gen / "cal.json")
    (gen / "spoilt.json").write_text('{"gyro": [1, 2,\n')
    (gen / "spoilt.csv").write_text("t,gyr_x\n0.0,abc\n")
    (gen / "layout.txt").write_text("ls-directions 2 30 -30;\n")
    return root, seeds


@contextlib.contextmanager
def _in(folder: Path):
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        yield
    finally:
        os.chdir(cwd)


def _main(*args: str) -> tuple[int, str]:
    """``pointat ARGS`` in this process: exit status and what it wrote to standard error."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main(list(args))
    return code, err.getvalue()


def _errors(text: str) -> list[str]:
    return [line for line in text.splitlines() if "error" in line]


def _check_and_run(root: Path, rel: str, data: str | bytes, sets: list[str]) -> None:
    path = root / rel
    path.write_bytes(data if isinstance(data, bytes) else data.encode())
    try:
        ports = beside(path)
    except PointatError:  # (a patch that cannot be read: check and run refuse it alike)
        ports = []
    given = ports + [a for s in sets for a in ("--set", s)]
    with _in(path.parent):
        checked, said = _main("check", str(path), *given)
        if checked == 0 and not fuzz._Checker(root, "prop", 0.0).safe(path, _values(given)):
            return  # it would open a device, write outside the sandbox or send off this machine
        ran, told = _main("run", str(path), "--for", "0", *given)
    assert (checked == 0) == (ran == 0), (
        f"check exited {checked}, run --for 0 exited {ran}\ncheck said:\n{said}\nrun said:\n{told}"
    )
    if checked:
        assert _errors(told) == _errors(said)


def _values(given: list[str]) -> list[str]:
    return [a for a in given if a != "--set"]


def _property(examples: int):
    """The property with ``examples`` examples (derandomized: the same ones every run, no deadline: a
    loaded machine is no failure)."""

    @settings(
        max_examples=examples,
        deadline=None,
        derandomize=True,
        database=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )
    @given(case=st.one_of(generated(), generated(GOOD), st.integers(0, 10**6)))
    def prop(case, sandbox):
        root, seeds = sandbox
        if isinstance(case, int):  # the fuzzer's mutant number `case` of a shipped patch
            mutant = next(fuzz.cases(seeds, seed=44, start=case))
            rel, data, sets = str(Path(mutant.folder) / f"prop{mutant.suffix}"), mutant.data, []
        else:
            rel, data, sets = case
        _check_and_run(root, rel, data, sets)

    return prop


test_check_says_ok_exactly_when_run_starts = _property(40)
test_check_says_ok_exactly_when_run_starts_long = pytest.mark.slow(_property(400))


#: Through the real program: the issue's case and its neighbours ({--set: whether both say ok}).
CLI_CASES = {
    "nulls.calibration=missing.json": False,  # issue 44: check said ok, and run refused
    "nulls.calibration=spoilt.json": False,
    "nulls.calibration=cal.json": True,
}


@pytest.fixture(scope="module")
def cli_runs(tmp_path_factory):
    """``pointat check glove_tqt`` and ``pointat run glove_tqt --for 0`` with each case's ``--set``, from
    a folder holding the files, all at once (each is mostly a Python start-up): {case: (check, run)}."""
    folder = tmp_path_factory.mktemp("cli")
    Calibration().save(folder / "cal.json")
    (folder / "spoilt.json").write_text('{"gyro": [1, 2,\n')
    ports = beside(ROOT / "patches" / "glove_tqt.pat")

    def start(*args: str) -> subprocess.Popen:
        return subprocess.Popen(
            [sys.executable, "-m", "pointat.cli", *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            cwd=folder,
        )

    procs = {
        case: (
            start("check", "glove_tqt", *ports, "--set", case),
            start("run", "glove_tqt", "--for", "0", *ports, "--set", case),
        )
        for case in CLI_CASES
    }
    done = {}
    for case, pair in procs.items():
        outs = [p.communicate(timeout=300) for p in pair]  # (first: then the exit status is there)
        done[case] = tuple(
            subprocess.CompletedProcess(p.args, p.returncode, *o) for p, o in zip(pair, outs, strict=True)
        )
    return done


@pytest.mark.parametrize("case", sorted(CLI_CASES))
def test_the_command_line_check_and_run_agree(case, cli_runs):
    ok = CLI_CASES[case]
    checked, ran = cli_runs[case]
    assert (checked.returncode == 0) == ok, checked.stderr
    assert (ran.returncode == 0) == ok, ran.stderr
    assert "Traceback" not in checked.stderr + ran.stderr
    if not ok:
        assert _errors(ran.stderr) == _errors(checked.stderr)
        assert "glove_tqt.pat:18: error: node 'nulls' (offset)" in checked.stderr
