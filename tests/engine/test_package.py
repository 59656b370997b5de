"""The package surface: the cheat-sheet names, and math that stands apart from the engine."""

import subprocess
import sys

import pointat


def test_exported_names_resolve():
    for name in pointat.__all__:
        assert getattr(pointat, name) is not None


def test_math_and_devices_do_not_load_the_engine():
    code = (
        "import sys, pointat.maths.tqt, pointat.maths.vbap, pointat.maths.smoothing, pointat.devices.glove_sim;"
        "print(sorted(m for m in sys.modules if m in ('pointat.node', 'pointat.runtime', 'pointat.loader',"
        " 'pointat.registry', 'nodes', 'osc_bridge')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"
