"""Names that become files (gesture labels, preset names): one word of a folder, never a path, at every
door: the validator itself, live OSC, a model file someone sent, and the export that writes folders."""

from __future__ import annotations

import json
import os
from pathlib import Path, PurePosixPath, PureWindowsPath

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pointat.gesture_files import export_model, load_model
from pointat.names import BadName, check_name, inside

HOSTILE = [
    "../../escaped",
    "/abs/dir",
    "a/b",
    "a\\b",
    "..",
    ".",
    ".hidden",
    "",
    "a\0b",
    "a\nb",
    "tab\there",
    "x" * 101,
    "é" * 101,
    "CON",
    "nul.txt",
    "Com1",
    "lpt9.csv",
    "a:b",
    "what?",
    "trailing.",
    "\u202eevil",
    "\ud800",
]


@pytest.mark.parametrize("value", HOSTILE)
def test_a_path_a_device_or_a_control_character_is_no_name(value):
    for kind in ("label", "preset"):
        with pytest.raises(BadName, match=f"^{kind}: "):
            check_name(kind, value)


def test_words_are_names_and_presets_may_have_spaces_inside():
    for good in ("circle", "palm_up", "nod-2", "Kreis", "円", "a.b", "null"):
        assert check_name("label", good) == good
    assert check_name("preset", "slow stage") == "slow stage"
    for bad in ("slow stage", " x"):
        with pytest.raises(BadName, match="no spaces"):
            check_name("label", bad)
    for bad in (" x", "x ", "a  b"):
        with pytest.raises(BadName):
            check_name("preset", bad)
    with pytest.raises(BadName, match="expected text, got int"):
        check_name("label", 3)


@settings(max_examples=2000, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(value=st.text(st.characters(), max_size=120) | st.sampled_from(HOSTILE))
def test_no_accepted_name_leaves_its_folder(tmp_path, value):
    """Whatever is accepted stays one entry of the folder, on POSIX and Windows paths alike."""
    try:
        name = check_name("label", value)
    except BadName:
        return
    assert PurePosixPath(name).name == name and PurePosixPath(name).parts == (name,)
    assert PureWindowsPath(name).name == name and not PureWindowsPath(name).drive
    child = tmp_path / name / "1.csv"
    assert inside(tmp_path, child).parent.parent == tmp_path.resolve()
    assert len(name.encode("utf-8")) + len("/1.csv") < 255


def _model(labels):
    return {
        "format": "pointat-gestures",
        "version": 1,
        "kind": "gesture",
        "channels": ["gyr"],
        "size": 0,
        "examples": [{"label": lab, "t": [0.0, 0.01], "frames": [[0, 0, 0], [1, 1, 1]]} for lab in labels],
    }


def test_a_model_file_with_a_path_for_a_label_is_refused_at_its_example(tmp_path):
    path = tmp_path / "sent.json"
    path.write_text(json.dumps(_model(["circle", "../../escaped"])))
    with pytest.raises(ValueError, match=r"sent.json: examples\[1\]: label: expected a name, not a path"):
        load_model(path, "gesture")
    out = tmp_path / "deep" / "out"
    with pytest.raises(ValueError, match="not a path"):
        export_model(path, out)
    assert not (tmp_path / "escaped").exists() and not out.exists()


def test_export_never_writes_outside_its_folder_even_through_a_link(tmp_path):
    path = tmp_path / "m.json"
    path.write_text(json.dumps(_model(["circle", "circle"])))
    out, elsewhere = tmp_path / "out", tmp_path / "elsewhere"
    out.mkdir()
    elsewhere.mkdir()
    os.symlink(elsewhere, out / "circle")  # a label's folder that leads out of DIR
    with pytest.raises(ValueError, match="outside"):
        export_model(path, out)
    assert list(elsewhere.iterdir()) == []
    assert [p.name for p in export_model(path, tmp_path / "fine")] == ["1.csv", "2.csv"]


def test_inside_follows_links_and_dots():
    root = Path("/tmp")
    assert inside(root, "/tmp/a/../b") == Path("/tmp/b").resolve()
    with pytest.raises(BadName, match="outside"):
        inside(root, "/tmp/../etc/passwd")


@pytest.mark.parametrize("label", ["../../escaped", "/abs/dir", "..", "a\0b", "CON"])
def test_live_osc_record_refuses_a_path_for_a_label(label):
    from pointat.control import control
    from pointat.testing import patch

    rt = patch("node moves gesture channels=[gyr] file=\nnode st collect\nmoves.status -> st\n")
    try:
        rt.start()
        why = control(rt, "/pointat/moves/record", [label], rt.clock.now())
        assert why is not None and "label: expected" in why, why
        assert rt.nodes["moves"].recording is None and not rt.nodes["st"].messages
    finally:
        rt.shutdown()


@pytest.mark.parametrize("name", ["../../escaped", "/abs/dir", "", "a\nb"])
def test_live_osc_preset_save_refuses_a_path_for_a_name(tmp_path, name):
    from pointat.control import control
    from pointat.presets import Presets
    from pointat.testing import patch

    rt = patch("node lim speedlim 100\n")
    rt.presets = Presets(rt, tmp_path / "p.presets.json")
    try:
        rt.start()
        why = control(rt, "/pointat/preset/save", [name], rt.clock.now())
        assert why is not None and "preset: expected" in why, why
        assert rt.presets.names() == []
    finally:
        rt.shutdown()


def test_a_plugins_type_name_never_writes_a_pd_stub_outside_its_folder(tmp_path):
    from pointat.node import Node
    from pointat.pdfile.writing import write_stubs
    from pointat.registry import Registry

    class Evil(Node):
        type_name = "../../evil"

    registry = Registry()
    registry.add(Evil, "a plugin")
    with pytest.raises(BadName, match="outside"):
        write_stubs(tmp_path / "a" / "stubs", registry=registry)
    assert not (tmp_path / "evil.pd").exists()


def test_export_refuses_labels_that_would_share_a_folder_where_case_is_ignored(tmp_path):
    path = tmp_path / "m.json"
    path.write_text(json.dumps(_model(["circle", "Circle"])))
    with pytest.raises(ValueError, match="labels 'circle' and 'Circle' would share a folder"):
        export_model(path, tmp_path / "out")
    assert not (tmp_path / "out").exists()
