"""The package surface: the cheat-sheet names, and math that stands apart from the engine."""

import subprocess
import sys

import pytest

import pointat


def test_exported_names_resolve():
    for name in pointat.__all__:
        assert getattr(pointat, name) is not None


def test_math_and_devices_do_not_load_the_engine():
    code = (
        "import sys, pointat.maths.tqt, pointat.maths.vbap, pointat.maths.smoothing, pointat.devices.glove_sim;"
        "print(sorted(m for m in sys.modules if m in ('pointat.node', 'pointat.runtime', 'pointat.loader',"
        " 'pointat.registry', 'pointat.nodes', 'pointat.osc_bridge', 'pointat.midi_bridge')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


@pytest.mark.slow  # (a wheel built: seconds)
def test_the_wheel_is_one_package_and_carries_the_patches_and_examples(tmp_path):
    """pip install . puts exactly one top-level package, pointat, into site-packages, with the node
    packages, the shipped patches, the examples and the sample data inside it."""
    import zipfile
    from pathlib import Path

    from tests.test_wheel import _sources

    root = Path(__file__).resolve().parents[2]
    source = _sources(tmp_path / "source")  # built from a copy: setuptools writes build/ beside the sources
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--no-deps",
            "-q",
            "-w",
            str(tmp_path),
            str(source),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.returncode == 0, out.stderr
    [wheel] = tmp_path.glob("pointat-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert {n.split("/")[0] for n in names} == {
        "pointat",
        f"{wheel.name.split('-')[0]}-{wheel.name.split('-')[1]}.dist-info",
    }
    for path in (
        "pointat/nodes/orientation.py",
        "pointat/midi_bridge/nodes.py",
        "pointat/osc_bridge/nodes.py",
        "pointat/devices/osc_wire.py",
        "pointat/maths/tqt/step.py",
        "pointat/patches/glove_tqt.pat",
        "pointat/patches/lib/tqt_fusion.pat",
        "pointat/examples/adm.pat",
        "pointat/examples/pd/vbap_receiver.pd",
        "pointat/data/glove_take.csv.gz",
    ):
        assert path in names, path
    code = {f"pointat/{p.relative_to(root / 'pointat').as_posix()}" for p in (root / "pointat").rglob("*.py")}
    code |= {
        f"pointat/{p.relative_to(root).as_posix()}"
        for d in ("nodes", "osc_bridge", "midi_bridge")
        for p in (root / d).glob("*.py")
    }
    assert code <= set(names), sorted(code - set(names))  # every module (a package missing from pyproject)
    shipped = {p.relative_to(root).as_posix() for p in (root / "patches").rglob("*.pat")}
    assert {f"pointat/{p}" for p in shipped} <= set(names)
    entry_points = (
        zipfile.ZipFile(wheel).read(next(n for n in names if n.endswith("entry_points.txt"))).decode()
    )
    assert "[pointat.nodes]" in entry_points and "tqt = pointat.nodes.tqt" in entry_points
