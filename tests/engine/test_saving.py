"""Saves off the scheduler's thread (issue 45, point 4): a flood of preset saves is a few whole writes
(the latest state wins), bounded, and a save a kill cut short leaves nothing behind at the next start."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading

import pytest

from pointat import presets as presets_module
from pointat.presets import Presets
from pointat.saving import Saver, clean_stray, write_atomic
from pointat.testing import patch


def test_write_atomic_leaves_the_file_whole_and_nothing_beside_it(tmp_path):
    target = tmp_path / "x.json"
    write_atomic(target, "old\n")
    write_atomic(target, b"new\n")
    assert target.read_text() == "new\n" and os.listdir(tmp_path) == ["x.json"]
    with pytest.raises(FileNotFoundError):
        write_atomic(tmp_path / "no" / "x.json", "x")
    assert os.listdir(tmp_path) == ["x.json"]


def test_a_stray_temporary_file_of_a_process_gone_is_removed_and_a_live_ones_kept(tmp_path):
    target = tmp_path / "show.presets.json"
    gone = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True
    )
    dead = int(gone.stdout)
    strays = [tmp_path / f".show.presets.json.{dead}-3.tmp", tmp_path / f".show.presets.json.{dead}.tmp"]
    mine = tmp_path / f".show.presets.json.{os.getpid()}-1.tmp"  # (a save under way: never touched)
    other = tmp_path / ".other.json.1.tmp"
    for p in (*strays, mine, other):
        p.write_text("{half")
    assert sorted(clean_stray(target)) == sorted(strays)
    assert mine.exists() and other.exists()


def test_the_saver_keeps_the_latest_state_and_writes_far_fewer_times(tmp_path):
    target = tmp_path / "x.json"
    saver = Saver("test", interval=0.25)
    for n in range(2000):
        saver.submit(target, lambda n=n: json.dumps({"n": n}))
    saver.close()
    assert json.loads(target.read_text()) == {"n": 1999}
    assert 1 <= saver.written < 2000 and saver.failed == 0
    assert sorted(os.listdir(tmp_path)) == ["x.json"]


def test_a_write_that_fails_is_logged_and_the_saver_goes_on(tmp_path, caplog):
    saver = Saver("test", interval=0.0)
    saver.submit(tmp_path / "gone" / "x.json", lambda: "x")
    saver.submit(tmp_path / "y.json", lambda: "y")
    assert saver.flush(timeout=60)
    saver.close()
    assert saver.failed == 1 and (tmp_path / "y.json").read_text() == "y"
    assert "test: " in caplog.text and "x.json not saved" in caplog.text


def _runtime(tmp_path):
    rt = patch("node lim speedlim 100\nnode tick metro 50\n")
    said: list[str] = []
    rt.console = said.append
    rt.start()
    return rt, said


def test_a_preset_save_flood_is_a_few_writes_off_the_scheduler_thread(tmp_path):
    rt, said = _runtime(tmp_path)
    path = tmp_path / "show.presets.json"
    presets = Presets(rt, path)
    writers: set[str] = set()
    real = presets_module.Saver._write

    def spy(self, *args):
        writers.add(threading.current_thread().name)
        return real(self, *args)

    presets.saver._write = spy.__get__(presets.saver)
    for n in range(1000):  # a flood, as from /pointat/preset/save at 100/s
        rt.set_param("lim", "interval", float(n))
        rt.drain()
        presets.save(f"p{n % 50}")
    presets.close()
    assert writers == {"pointat-save-presets"}, writers  # never this (the scheduler's) thread
    assert presets.saver.written < 1000
    data = json.loads(path.read_text())
    assert len(data["presets"]) == 50 and data["presets"]["p49"]["lim"]["interval"] == 999.0
    assert [p.name for p in tmp_path.iterdir()] == ["show.presets.json"]
    rt.shutdown()


def test_presets_are_bounded_and_a_save_beyond_is_refused(tmp_path, monkeypatch):
    rt, _ = _runtime(tmp_path)
    presets = Presets(rt, tmp_path / "show.presets.json")
    monkeypatch.setattr(presets_module, "MOST_PRESETS", 3)
    for name in ("a", "b", "c"):
        presets.save(name)
    with pytest.raises(ValueError, match="preset 'd' not saved: 3 presets already, the most a patch keeps"):
        presets.save("d")
    presets.save("c")  # saving over one is fine
    presets.delete("a")
    presets.save("d")
    monkeypatch.setattr(presets_module, "MOST_PRESETS", 10)
    monkeypatch.setattr(presets_module, "MOST_BYTES", 300)
    with pytest.raises(ValueError, match="preset 'e' not saved: the presets would take .* MB, more than"):
        presets.save("e")
    presets.close()
    assert sorted(json.loads((tmp_path / "show.presets.json").read_text())["presets"]) == ["b", "c", "d"]
    rt.shutdown()


def test_a_presets_file_with_a_path_for_a_name_is_refused_and_never_written_over(tmp_path, caplog):
    rt, _ = _runtime(tmp_path)
    path = tmp_path / "show.presets.json"
    text = json.dumps({"pointat_presets": 1, "presets": {"../../x": {"lim": {"interval": 1.0}}}})
    path.write_text(text)
    presets = Presets(rt, path)
    assert not presets.writable and "presets: preset: expected a name, not a path" in caplog.text
    presets.save("fine")
    presets.close()
    assert path.read_text() == text
    rt.shutdown()


def test_a_stray_save_is_cleaned_when_the_presets_are_read_at_the_start(tmp_path):
    rt, _ = _runtime(tmp_path)
    path = tmp_path / "show.presets.json"
    stray = tmp_path / ".show.presets.json.999999999-1.tmp"  # (no such process)
    stray.write_text('{"pointat_presets": 1, "pres')
    Presets(rt, path).close()
    assert not stray.exists()
    rt.shutdown()


def test_calibrate_cleans_a_stray_save_at_start(tmp_path):
    from pointat.maths.calibration import Calibration

    path = tmp_path / "calibration.json"
    Calibration(gyro_null=[2001.0, 2002.0, 2003.0]).save(path)
    stray = tmp_path / ".calibration.json.999999999-4.tmp"  # a save a kill cut short
    stray.write_text('{"format": "pointat-cal')
    rt = patch(f"node cal calibrate file={path}\n")
    rt.start()
    rt.shutdown()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["calibration.json"]
