"""pointat as a new user meets it: the wheel built, installed in a fresh virtual environment, and run
from an empty folder (the README's quick start, ``pointat patches``, every shipped patch by name).

Nothing may be written inside the installed package (its site-packages is listed before and after:
files added, changed or removed), and no command may print a traceback.  The checkout is never on the
path: the installed program runs from a folder of its own, as it would on a performer's machine.
Marked ``slow`` and ``wheel`` (.ci/run runs it: ``python -m pytest -m slow``; alone, ``-m wheel``).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from pointat import shipped
from pointat.testing import beside

ROOT = Path(__file__).resolve().parent.parent

pytestmark = [pytest.mark.slow, pytest.mark.wheel]

#: How long each shipped patch runs (seconds): long enough to start, read, compute and write.
SECONDS = 3
#: Patches run at once (two cores; each mostly waits for its clock).
AT_ONCE = 3


def _sources(target: Path) -> Path:
    """The repository's files as git knows them (tracked, and new ones not ignored), copied into
    ``target``: what a clean checkout holds, without the takes, presets or caches lying about."""
    listed = subprocess.run(
        ["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
        cwd=ROOT,
        capture_output=True,
        timeout=60,
    )
    if listed.returncode != 0:  # (not a git checkout: an unpacked source archive)
        shutil.copytree(ROOT, target, ignore=shutil.ignore_patterns(".venv", ".git", "__pycache__"))
        return target
    for name in filter(None, listed.stdout.decode().split("\0")):
        src = ROOT / name
        if src.is_file():
            (target / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, target / name)
    return target


def _listing(site: Path) -> dict[str, tuple[int, int]]:
    return {
        str(p.relative_to(site)): (p.stat().st_size, p.stat().st_mtime_ns)
        for p in sorted(site.rglob("*"))
        if p.is_file()
    }


def _changed(before: dict, after: dict) -> list[str]:
    return sorted(
        [f"added {p}" for p in after.keys() - before.keys()]
        + [f"removed {p}" for p in before.keys() - after.keys()]
        + [f"changed {p}" for p in before.keys() & after.keys() if before[p] != after[p]]
    )


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """(the venv's bin folder, its site-packages, an environment without the checkout on the path)."""
    tmp = tmp_path_factory.mktemp("wheel")
    source = _sources(tmp / "source")
    built = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp / "dist"), str(source)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert built.returncode == 0, built.stderr
    [wheel] = (tmp / "dist").glob("pointat-*.whl")
    venv = tmp / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=120)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    env["XDG_CACHE_HOME"] = str(tmp / "cache")  # (the compiled chain's cache: this user's, fresh)
    env["PIP_DISABLE_PIP_VERSION_CHECK"] = "1"
    pip = subprocess.run(
        [str(venv / "bin" / "python"), "-m", "pip", "install", "-q", str(wheel)],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
    )
    assert pip.returncode == 0, pip.stderr
    site = subprocess.run(
        [
            str(venv / "bin" / "python"),
            "-c",
            "import pointat, pathlib; print(pathlib.Path(pointat.__file__).parents[1])",
        ],
        capture_output=True,
        text=True,
        env=env,
        cwd=tmp,
        timeout=60,
    )
    assert site.returncode == 0, site.stderr
    site_packages = Path(site.stdout.strip())
    assert site_packages.is_relative_to(venv), site_packages  # the wheel's pointat, not the checkout's
    return venv / "bin", site_packages, env


def _run(bin_dir: Path, args: list[str], env: dict, cwd: Path, timeout: float = 120) -> subprocess.Popen:
    return subprocess.Popen(
        [str(bin_dir / "pointat"), *args],
        cwd=cwd,
        env=env,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _finish(name: str, proc: subprocess.Popen, timeout: float = 120) -> tuple[str, str, str]:
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        return name, out, err + f"\n(timed out after {timeout} s)"
    trouble = "" if proc.returncode == 0 else f"\n(exit status {proc.returncode})"
    return name, out, err + trouble


def test_the_installed_wheel_runs_every_shipped_patch_from_an_empty_folder(installed, tmp_path):
    bin_dir, site, env = installed
    before = _listing(site)
    here = tmp_path / "empty"
    here.mkdir()
    results = []

    # the README's quick start, shortened
    quick = ["run", "glove_tqt", "--for", str(SECONDS), "--monitor", *beside(shipped.find_patch("glove_tqt"))]
    results.append(_finish("quick start", _run(bin_dir, quick, env, here)))

    listing = _finish("patches", _run(bin_dir, ["patches"], env, here))
    results.append(listing)
    names = [line.split()[0] for line in listing[1].splitlines() if line.strip()]
    assert names == shipped.patch_names(), listing

    running: list[tuple[str, subprocess.Popen]] = []
    for name in names:
        args = ["run", name, "--for", str(SECONDS), *beside(shipped.find_patch(name))]
        running.append((name, _run(bin_dir, args, env, here)))
        if len(running) == AT_ONCE:
            results.append(_finish(*running.pop(0)))
    results += [_finish(*r) for r in running]

    failed = [
        f"--- pointat {name}\n{out[-2000:]}\n{err[-4000:]}"
        for name, out, err in results
        if "Traceback" in out + err or "(exit status" in err or "(timed out" in err
    ]
    assert not failed, "\n".join(failed)
    written = _changed(before, _listing(site))
    assert not written, "written inside the installed package:\n" + "\n".join(written)
    assert "monitor  http://127.0.0.1:" in results[0][1], results[0][1]
    for name in ("take.csv", "body.bvh", "midi_pan.mid", "evaluate_tqt.csv", "gestures.json"):
        assert (here / name).is_file(), f"{name}: not written here (what the shipped patches write)"
