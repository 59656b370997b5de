"""The patches pointat ships, as a user finds them: by name from any folder, installed or in a checkout."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from pointat import shipped
from pointat.checking import check
from pointat.cli import main
from pointat.expansion import read_spec
from pointat.maths.calibration import Calibration
from pointat.presets import presets_path
from pointat.registry import default_registry
from pointat.testing import beside

ROOT = Path(__file__).resolve().parent.parent


def test_the_names_do_not_depend_on_where_the_package_lies(tmp_path):
    """An installed package lies under .venv/lib/python3.X/site-packages: a 'lib' in its own path must
    not hide every patch (only the abstractions' lib/ below the patches folder is left out)."""
    installed = tmp_path / ".venv" / "lib" / "python3.11" / "site-packages" / "pointat" / "patches"
    shutil.copytree(ROOT / "patches", installed)
    names = shipped.names_in(installed)
    assert names == shipped.names_in(ROOT / "patches")
    assert "glove_tqt" in names and "gestures" in names
    assert not [n for n in names if n.startswith("lib")]


def test_pointat_patches_lists_them_all(capsys):
    assert main(["patches"]) == 0
    listed = [line.split()[0] for line in capsys.readouterr().out.splitlines()]
    assert listed == shipped.patch_names()
    assert {"glove_tqt", "record_glove", "midi_pan", "pd/glove_to_pd_vbap"} <= set(listed)


def test_copy_makes_the_folder_it_is_given(tmp_path, capsys):
    target = tmp_path / "show" / "patches"
    assert main(["patches", "--copy", "gestures", "--to", str(target)]) == 0
    written = capsys.readouterr().out.split()
    assert sorted(written) == sorted(
        str(target / n) for n in ("gestures.pat", "gestures.json", "lib/tqt_fusion.pat")
    )
    assert (target / "gestures.json").read_bytes() == (ROOT / "patches" / "gestures.json").read_bytes()
    assert main(["patches", "--copy", "gestures", "--to", str(target)]) == 2  # never over a file
    assert "already there: nothing copied" in capsys.readouterr().err
    (tmp_path / "afile").write_text("")
    assert main(["patches", "--copy", "gestures", "--to", str(tmp_path / "afile")]) == 2
    assert "not a folder" in capsys.readouterr().err


def _listing() -> dict[str, int]:
    """Every file of the shipped folders (patches, examples, their lib/ and pd/) and its size."""
    return {
        str(p): p.stat().st_size
        for top in shipped.PATCH_FOLDERS
        for p in shipped.folder(top).rglob("*")
        if p.is_file() and "__pycache__" not in p.parts
    }


def _run(cwd: Path, *args: str) -> subprocess.CompletedProcess:
    name = args[0]
    cmd = [sys.executable, "-m", "pointat.cli", "run", *args, *beside(shipped.find_patch(name))]
    out = subprocess.run(cmd, capture_output=True, text=True, cwd=cwd, timeout=120)
    assert out.returncode == 0 and "Traceback" not in out.stderr, out.stderr
    return out


def test_a_shipped_patch_writes_into_the_current_folder_or_out_and_never_beside_itself(tmp_path):
    """record_glove run by name from an empty folder: its take lands there, the banner says so, and
    nothing is written beside the patch (inside the package, when installed)."""
    before = _listing()
    here = tmp_path / "here"
    here.mkdir()
    out = _run(here, "record_glove", "--for", "1")
    assert f"  file     {here / 'take.csv'}  (record 'take': " in out.stdout
    assert f"  presets  {here / 'record_glove.presets.json'}" in out.stdout
    assert (here / "take.csv").read_text().startswith("t,adc_gx,")
    elsewhere = tmp_path / "takes"
    elsewhere.mkdir()
    out = _run(here, "record_glove", "--for", "1", "--out", str(elsewhere), "--set", "take.file=mine.csv")
    assert (here / "mine.csv").exists()  # (a --set path is the command line's: relative to here)
    out = _run(here, "body_suit", "--for", "1", "--out", str(elsewhere))
    assert f"  file     {elsewhere / 'body.bvh'}  (bvh_record 'take': " in out.stdout
    assert (elsewhere / "body.bvh").read_text().startswith("HIERARCHY")
    assert _listing() == before
    gone = subprocess.run(
        [sys.executable, "-m", "pointat.cli", "run", "record_glove", "--out", str(tmp_path / "no")],
        capture_output=True,
        text=True,
        cwd=here,
        timeout=60,
    )
    assert gone.returncode == 2 and f"--out {tmp_path / 'no'}: no such folder" in gone.stderr


def test_the_calibration_saved_by_the_shipped_patch_is_the_one_the_next_step_names(tmp_path, monkeypatch):
    """calibrate_glove saves calibration.json into the current folder, and the next step,
    ``pointat run glove_tqt --set nulls.calibration=calibration.json``, finds it there."""
    monkeypatch.chdir(tmp_path)
    spec = read_spec(shipped.find_patch("calibrate_glove"))
    cal = check(spec, default_registry.load_builtins()).nodes["cal"]
    assert cal.values["file"] == str(tmp_path / "calibration.json")
    Calibration().save("calibration.json")  # (what /pointat/cal/save writes)
    sets = ["--set", "nulls.calibration=calibration.json", "--set", "units.calibration=calibration.json"]
    assert main(["check", "glove_tqt", *sets]) == 0


@pytest.mark.slow  # (two runs of the patch; tests/test_wheel.py sees the copy made from an empty folder too)
def test_the_gesture_examples_are_copied_once_to_be_the_users_own(tmp_path):
    """gestures reads and saves gestures.json: the first run copies the shipped one into the current
    folder (said in the banner) and loads it from there; the next run finds the user's copy."""
    before = _listing()
    out = _run(tmp_path, "gestures", "--for", "1")
    mine = tmp_path / "gestures.json"
    assert f"  copied   {mine}  (the shipped gestures.json" in out.stdout
    assert f"moves: loaded {mine} 9" in out.stdout
    assert mine.read_bytes() == (shipped.folder("patches") / "gestures.json").read_bytes()
    mine.write_text(mine.read_text().replace('"circle"', '"round"'))  # taught more, say
    out = _run(tmp_path, "gestures", "--for", "1")
    assert "copied" not in out.stdout and '"round"' in mine.read_text()
    assert _listing() == before


def test_a_file_a_shipped_patch_reads_is_the_users_copy_first(tmp_path):
    base, out = tmp_path / "shipped", tmp_path / "here"
    base.mkdir()
    out.mkdir()
    (base / "layout.json").write_text("{}")
    assert shipped.place("layout.json", base, out, reads=True, writes=False) == str(base / "layout.json")
    (out / "layout.json").write_text("{}")
    assert shipped.place("layout.json", base, out, reads=True, writes=False) == str(out / "layout.json")
    assert shipped.place("other.json", base, out, reads=True, writes=False) == str(out / "other.json")
    assert shipped.place("layout.json", base, out, reads=True, writes=True) == str(out / "layout.json")
    (out / "layout.json").unlink()
    assert shipped.place("layout.json", base, out, reads=False, writes=True) == str(out / "layout.json")
    assert presets_path(shipped.find_patch("glove_tqt"), out) == out / "glove_tqt.presets.json"


def test_a_patch_name_gets_a_did_you_mean(tmp_path, capsys):
    assert main(["check", "glove_tq"]) == 2
    err = capsys.readouterr().err
    assert "error: no patch file or shipped patch 'glove_tq' (did you mean 'glove_tqt'?)" in err
    assert main(["run", "glove_to_pd_vbap"]) == 2
    assert "(did you mean 'pd/glove_to_pd_vbap'?)" in capsys.readouterr().err
    assert main(["check", str(tmp_path / "nope.pat")]) == 2
    assert "cannot read patch" in capsys.readouterr().err


def test_the_shipped_take_is_plotted_into_the_current_folder(tmp_path, monkeypatch, capsys):
    pytest.importorskip("matplotlib")
    monkeypatch.chdir(tmp_path)
    before = _listing()
    data = {p.name for p in shipped.folder("data").iterdir()}
    assert main(["plot", "pointat:data/glove_take.csv.gz"]) == 0
    assert capsys.readouterr().out.split() == ["glove_take.png", "glove_take.html"]
    assert (tmp_path / "glove_take.png").stat().st_size > 1000
    assert _listing() == before and {p.name for p in shipped.folder("data").iterdir()} == data
