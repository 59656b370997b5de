"""The patches pointat ships, as a user finds them: by name from any folder, installed or in a checkout."""

import shutil
from pathlib import Path

from pointat import shipped
from pointat.cli import main

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
