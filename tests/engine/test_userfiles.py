"""Files that stall or crash a start (issue 45, point 5): a pipe nobody writes, /dev/zero, a 2 GB sparse
file, a folder, a loop of symbolic links and JSON nested 100,000 deep, given to every reader of a user's
file.  Each must say, with the file's name, what it expected; none may hang or raise a traceback.

The command-line cases run as subprocesses, each with a ceiling on its time far above what it needs (a
hang is the failure; how fast they end is not asserted)."""

from __future__ import annotations

import gzip
import json
import os
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pointat.errors import PointatError
from pointat.userfiles import UserFileError, lines, read_bytes, read_json, read_text

CEILING = 120.0  # seconds: a hang, not a slow machine


@pytest.fixture
def special(tmp_path):
    """name -> (path, what the error says of it)."""
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    sparse = tmp_path / "sparse.json"
    with open(sparse, "wb") as fh:
        fh.truncate(2 * 1024**3)  # 2 GB of nothing on the disk
    folder = tmp_path / "folder.json"
    folder.mkdir()
    loop = tmp_path / "loop.json"
    os.symlink(tmp_path / "loop2.json", loop)
    os.symlink(loop, tmp_path / "loop2.json")
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    return {
        "fifo": (fifo, "a pipe (FIFO), not a regular file"),
        "zero": (Path("/dev/zero"), "a character device, not a regular file"),
        "sparse": (sparse, "2048.0 MB: larger than"),
        "folder": (folder, "a folder, not a regular file"),
        "loop": (loop, "Too many levels of symbolic links"),
        "deep": (deep, "nested too deeply"),
    }


def _soon(fn, *args):
    """``fn(*args)``'s exception, on a thread given :data:`CEILING` seconds (a blocking open must fail
    the test, not hang it)."""
    out: list[BaseException | None] = []

    def call():
        try:
            fn(*args)
            out.append(None)
        except BaseException as exc:  # noqa: BLE001 (handed back to the test)
            out.append(exc)

    th = threading.Thread(target=call, daemon=True)
    th.start()
    th.join(CEILING)
    assert out, f"{getattr(fn, '__name__', fn)}{args}: still reading after {CEILING} s"
    return out[0]


def _readers():
    """Every reader of a user's file, as (name, function of a path, whether it reads JSON)."""
    from pointat.console import about
    from pointat.gesture_files import load_model, read_recording
    from pointat.maths.calibration import Calibration
    from pointat.maths.evaluation import load_broad
    from pointat.maths.skeleton import Skeleton
    from pointat.maths.vbap import read_layout
    from pointat.nodes.recording import read_lines
    from pointat.plotting import read_take
    from pointat.spec import read_patch_bytes

    return [
        ("patch", read_patch_bytes, False),
        ("calibration", Calibration.load, True),
        ("gesture model", lambda p: load_model(p, None), True),
        ("gesture recording", read_recording, False),
        ("take (replay)", lambda p: list(read_lines(p)), False),
        ("take (plot)", read_take, False),
        ("layout", read_layout, True),
        ("skeleton", Skeleton.load, True),
        ("BROAD take", load_broad, False),
        ("presets", _presets, True),
        ("the patch's first comment", _about(about), False),
    ]


def _presets(path):
    from pointat.presets import Presets

    class Rt:
        nodes: dict = {}

    p = Presets(Rt(), path)
    assert not p.writable  # never written over
    raise ValueError("refused")  # (what it said went to the log: checked in test_presets_files_...)


def _about(about):
    def read(path):
        assert about(path) == ""  # a banner without the patch's comment, no more

    return read


@pytest.mark.parametrize("case", ["fifo", "zero", "sparse", "folder", "loop", "deep"])
def test_every_reader_refuses_a_special_file_at_once_with_its_name(special, case):
    path, said = special[case]
    for name, read, is_json in _readers():
        if case == "deep" and not is_json:
            continue
        exc = _soon(read, path)
        if name == "the patch's first comment":
            assert exc is None, exc
            continue
        if name == "presets":
            assert isinstance(exc, ValueError) and str(exc) == "refused", exc
            continue
        assert isinstance(exc, (ValueError, PointatError)), (name, case, repr(exc))
        assert str(path) in str(exc) and said in str(exc), (name, case, str(exc))


def test_the_plain_readers_say_what_they_expected(special, tmp_path):
    fifo, _ = special["fifo"]
    with pytest.raises(UserFileError, match=r"fifo.json: a pipe \(FIFO\), not a regular file: expected a"):
        read_json(fifo, "presets")
    small = tmp_path / "small.json"
    small.write_text('{"a": 1}')
    with pytest.raises(
        UserFileError, match=r"small.json: 8 bytes: larger than a presets file \(JSON\) can be"
    ):
        read_bytes(small, "presets", limit=4)
    bad = tmp_path / "bad.json"
    bad.write_bytes(b'{\n"a": "caf\xe9"}')
    with pytest.raises(UserFileError, match=r"bad.json:2: not UTF-8 text \(byte 0xe9\)"):
        read_text(bad, "presets")
    with pytest.raises(UserFileError, match=r"bad.json:2: not JSON"):
        (tmp_path / "bad.json").write_text('{\n"a": }')
        read_json(bad, "presets")
    bomb = tmp_path / "bomb.csv.gz"  # 8 KB that open to 64 MB: refused once past the limit
    bomb.write_bytes(gzip.compress(b"0" * (64 * 1024 * 1024 + 1)))
    with pytest.raises(UserFileError, match="more than 64.0 MB once decompressed"):
        read_bytes(bomb, "recording", gzip_ok=True)
    long_line = tmp_path / "long.csv"
    long_line.write_bytes(b"t,acc_x\n" + b"0" * (2 * 1024 * 1024))
    with pytest.raises(UserFileError, match=r"long.csv:2: a line longer than 1.0 MB"):
        list(lines(long_line, "take"))


def _cli(*args, cwd=None):
    out = subprocess.run(
        [sys.executable, "-m", "pointat.cli", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=CEILING,
        cwd=cwd,
    )
    assert "Traceback" not in out.stderr, out.stderr
    return out


def test_the_commands_refuse_special_files_and_never_hang(special, tmp_path):
    fifo, _ = special["fifo"]
    sparse, _ = special["sparse"]
    folder, _ = special["folder"]
    # the patch itself: a folder; an abstraction that is a loop of links
    out = _cli("check", folder)
    assert out.returncode == 2 and f"{folder}: error: a folder, not a regular file" in out.stderr, out.stderr
    os.symlink(tmp_path / "b.pat", tmp_path / "a.pat")
    os.symlink(tmp_path / "a.pat", tmp_path / "b.pat")
    (tmp_path / "main.pat").write_text("node x a.pat\n")
    out = _cli("check", tmp_path / "main.pat")
    assert out.returncode == 2 and "main.pat:1: error: abstraction 'a.pat': Too many levels" in out.stderr
    # plot on a 2 GB take; export and evaluate reading a pipe
    out = _cli("plot", sparse, "-o", tmp_path / "plot")
    assert out.returncode != 0 and f"{sparse}: 2048.0 MB: larger than a take" in out.stderr, out.stderr
    out = _cli("gestures", "export", fifo, tmp_path / "out")
    assert out.returncode != 0 and f"{fifo}: a pipe (FIFO), not a regular file" in out.stderr, out.stderr
    (tmp_path / "train" / "circle").mkdir(parents=True)
    os.mkfifo(tmp_path / "train" / "circle" / "1.csv")
    out = _cli("gestures", "evaluate", "--train", tmp_path / "train", "--test", tmp_path / "train")
    assert out.returncode != 0 and "1.csv: a pipe (FIFO), not a regular file" in out.stderr, out.stderr


def test_calibrate_with_a_pipe_for_its_file_is_refused_by_check_and_run(special, tmp_path):
    fifo, _ = special["fifo"]
    patch = tmp_path / "cal.pat"
    patch.write_text(f"node cal calibrate file={fifo}\nnode p print\ncal -> p\n")
    for command in ("check", "run"):
        out = _cli(command, patch, *(("--for", "5") if command == "run" else ()))
        assert out.returncode == 2 and "cal.pat:1: error: " in out.stderr, out.stderr
        assert "parameter 'file'" in out.stderr and "not a regular file" in out.stderr, out.stderr


def test_a_presets_file_that_is_a_pipe_is_said_and_the_patch_runs(tmp_path):
    patch = tmp_path / "show.pat"
    patch.write_text("node tick metro 100\nnode on loadbang\non -> tick\n")
    os.mkfifo(tmp_path / "show.presets.json")
    out = _cli("run", patch, "--for", "1", "--status", "0")
    assert out.returncode == 0, out.stderr
    assert "show.presets.json: a pipe (FIFO), not a regular file" in out.stderr, out.stderr
    assert "presets saved now are kept in memory only" in out.stderr


def test_a_model_file_with_a_bad_label_loses_nothing_already_loaded(tmp_path):
    from pointat.message import method
    from pointat.testing import patch

    good, bad = tmp_path / "good.json", tmp_path / "bad.json"
    doc = {
        "format": "pointat-gestures",
        "version": 1,
        "kind": "posture",
        "channels": ["q"],
        "size": 0,
        "examples": [
            {"label": lab, "t": [0.0], "frames": [[1.0, 0.0, 0.0, 0.0]]} for lab in ("level", "level", "up")
        ],
    }
    good.write_text(json.dumps(doc))
    doc["examples"][2]["label"] = "../../escaped"
    bad.write_text(json.dumps(doc))
    rt = patch(f"node hand posture file={good} samples=1\n")
    try:
        rt.start()
        hand = rt.nodes["hand"]
        assert len(hand.examples) == 3
        with pytest.raises(ValueError, match=r"bad.json: examples\[2\]: label: expected a name, not a path"):
            hand.receive(0, method("load", str(bad)))
        assert sorted(e.label for e in hand.examples) == ["level", "level", "up"]
    finally:
        rt.shutdown()


_JSON = st.recursive(
    st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=20,
)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    raw=st.binary(max_size=300)
    | _JSON.map(lambda d: json.dumps({"pointat_presets": 1, "presets": d}).encode())
    | _JSON.map(lambda d: json.dumps(d).encode())
)
def test_a_presets_file_of_any_bytes_loads_or_is_refused_and_kept(tmp_path, raw):
    from pointat.presets import Presets

    class Rt:
        nodes: dict = {}

    path = tmp_path / "any.presets.json"
    path.write_bytes(raw)
    presets = Presets(Rt(), path)  # never raises
    presets.close()
    assert presets.writable or path.read_bytes() == raw
    assert all(isinstance(v, dict) for v in presets.presets.values())
