"""pointat.jit: a module compiled with the modules it calls, each function seeing its own module's names,
the machine code in the user's cache folder and nowhere else."""

from __future__ import annotations

import importlib
import os
import sys
import textwrap

from pointat import jit


def _modules(tmp_path, monkeypatch):
    (tmp_path / "jit_case_a.py").write_text(
        textwrap.dedent(
            """
            def twice(x):
                return 2.0 * x

            def run(x):
                return twice(x)
            """
        )
    )
    (tmp_path / "jit_case_b.py").write_text(
        textwrap.dedent(
            """
            from jit_case_a import run as run_a

            def twice(x):  # the same name as jit_case_a's, another function
                return 3.0 * x

            def run(x):
                return twice(x) + run_a(x)
            """
        )
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    modules = []
    for name in ("jit_case_a", "jit_case_b"):  # this test's files, gone from sys.modules after it
        monkeypatch.delitem(sys.modules, name, raising=False)
        modules.append(importlib.import_module(name))
        monkeypatch.setitem(sys.modules, name, modules[-1])
    return modules


def test_each_module_calls_its_own_functions_compiled(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    a, b = _modules(tmp_path, monkeypatch)
    compiled = jit.compile_module(b, calls=[a])
    # b's twice (3x) and a's (2x), each where its own module calls it: 3 + 2, not 3 + 3 or 2 + 2
    assert compiled.run(1.0) == 5.0 == b.run(1.0)
    assert compiled.run.signatures  # (numba's: it ran compiled, not the Python function)
    assert jit.compile_module(b, calls=[a]) is compiled  # once a process
    assert b.twice is not compiled.twice and b.twice(1.0) == 3.0  # the module keeps its Python functions
    where = jit.cache_dir(b, calls=[a])
    assert where.parent == tmp_path / "cache" / "pointat"
    assert any(p.suffix == ".nbi" for p in where.rglob("*"))  # the cache's index, there
    assert not [p for p in tmp_path.rglob("*.nb*") if where not in p.parents]  # and nowhere else


def test_the_cache_folder_changes_with_any_source_compiled_together(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    a, b = _modules(tmp_path, monkeypatch)
    before = jit.cache_dir(b, calls=[a])
    assert jit.cache_dir(b) != before  # (another set of modules)
    with open(a.__file__, "a") as fh:  # a change to the module called, not to the one asked for
        fh.write("\n# another version\n")
    importlib.invalidate_caches()
    import linecache

    linecache.checkcache(a.__file__)
    assert jit.cache_dir(b, calls=[a]) != before


def test_folders_of_versions_unused_for_a_month_are_removed_as_another_opens(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    root = jit.cache_root()
    now = 2_000_000_000.0
    old, recent, stamped = (root / f"numba-{n}" for n in ("old", "recent", "stamped"))
    for folder in (old, recent, stamped):
        folder.mkdir(parents=True)
        (folder / "f.nbi").write_text("x")
    os.utime(old, (now - 40 * 86400, now - 40 * 86400))
    os.utime(recent, (now - 2 * 86400, now - 2 * 86400))
    os.utime(stamped, (now - 40 * 86400, now - 40 * 86400))  # an old folder, opened yesterday:
    (stamped / "used").touch()
    os.utime(stamped / "used", (now - 86400, now - 86400))
    other = root / "not-numba"
    other.mkdir()
    os.utime(other, (now - 400 * 86400, now - 400 * 86400))
    assert jit.prune(root, keep=recent, now=now) == [old]
    assert sorted(p.name for p in root.iterdir()) == ["not-numba", "numba-recent", "numba-stamped"]
    os.utime(recent, (now - 40 * 86400, now - 40 * 86400))
    assert jit.prune(root, keep=recent, now=now) == []  # (the folder being opened is kept)


def test_opening_a_folder_marks_it_used(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    a, b = _modules(tmp_path, monkeypatch)
    stale = jit.cache_root() / "numba-0123456789abcdef"
    stale.mkdir(parents=True)
    os.utime(stale, (1.0, 1.0))  # (1970: no run has opened it since)
    jit.compile_module(b, calls=[a])
    assert (jit.cache_dir(b, calls=[a]) / "used").exists()
    assert not stale.exists()


def test_a_link_among_the_folders_is_left_and_not_said_removed(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    root = jit.cache_root()
    target = tmp_path / "elsewhere"
    target.mkdir()
    (target / "keep.txt").write_text("x")
    root.mkdir(parents=True)
    link = root / "numba-link"
    link.symlink_to(target, target_is_directory=True)
    os.utime(link, (1.0, 1.0), follow_symlinks=False)
    os.utime(target, (1.0, 1.0))
    assert jit.prune(root, keep=root / "numba-current", now=2_000_000_000.0) == []
    assert (target / "keep.txt").exists()
