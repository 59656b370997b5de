"""The registry: built-ins, aliases, duplicates, entry-point plugins and --plugins folders."""

import os
import subprocess
import sys
import textwrap

import pytest

from pointat.node import Inlet, Node, Param
from pointat.registry import Registry, RegistryError, default_registry

PLUGIN = textwrap.dedent('''
    from pointat.message import as_float
    from pointat.node import Inlet, Node, Outlet, Param


    class Gain(Node):
        """Multiply by a gain (a third-party node)."""

        type_name = "gain3p"
        aliases = ("g3",)
        inlets = (Inlet("in", ("float",), "a number"),)
        outlets = (Outlet("out", "float", "the product"),)
        params = (Param("gain", "float", 2.0, "the factor", live=True),)

        def on_in(self, msg):
            self.out(0, self.p.gain * as_float(msg))
''')


def test_builtins_and_aliases():
    reg = default_registry.load_builtins()
    for name in (
        "metro",
        "delay",
        "del",
        "trigger",
        "t",
        "pack",
        "unpack",
        "route",
        "send",
        "s",
        "receive",
        "r",
        "loadbang",
        "print",
        "change",
        "speedlim",
        "msg",
    ):
        assert name in reg, name
    assert reg.get("t") is reg.get("trigger")
    assert reg.suggest("metor") == "metro"


def test_duplicate_names_are_an_error_naming_both():
    reg = Registry()

    class A(Node):
        type_name = "thing"

    class B(Node):
        type_name = "other"
        aliases = ("thing",)

    reg.add(A, "first.py")
    reg.add(A, "first.py")  # the same class again is fine
    with pytest.raises(
        RegistryError, match=r"'thing' is taken twice: by .*A \(first.py\) and by .*B \(second.py\)"
    ):
        reg.add(B, "second.py")


def test_declarations_are_checked():
    reg = Registry()

    class BadParam(Node):
        type_name = "bad1"
        params = (Param("name", "float", 1.0),)

    class Typo(Node):
        type_name = "bad2"
        inlets = (
            Inlet(
                "gyro",
            ),
        )

        def on_gyr(self, msg):
            pass

    with pytest.raises(RegistryError, match="'name' is reserved"):
        reg.add(BadParam)
    with pytest.raises(RegistryError, match="handler on_gyr names no inlet"):
        reg.add(Typo)


def test_plugins_folder(tmp_path):
    (tmp_path / "gain.py").write_text(PLUGIN)
    reg = Registry().load_plugins(tmp_path)
    cls = reg.get("g3")
    assert cls is reg.get("gain3p") and "plugin file" in cls.origin
    with pytest.raises(RegistryError, match="not a folder"):
        Registry().load_plugins(tmp_path / "nope")


def _install_distribution(site, module_name="pointat_gain_plugin"):
    """A real installed distribution: a module and a .dist-info with an entry_points.txt, on a path."""
    (site / f"{module_name}.py").write_text(PLUGIN)
    info = site / "pointat_gain_plugin-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: pointat-gain-plugin\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(f"[pointat.nodes]\ngain = {module_name}\n")


def test_entry_point_plugin_installed_in_the_test(tmp_path, monkeypatch):
    _install_distribution(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    reg = Registry().load_entry_points()
    cls = reg.get("gain3p")
    assert cls is not None and "entry point 'gain' of pointat-gain-plugin" in cls.origin
    # and the command line sees it: listed, documented and usable in a patch
    env = {**os.environ, "PYTHONPATH": str(tmp_path) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    out = subprocess.run(
        [sys.executable, "-m", "pointat.cli", "nodes"], env=env, capture_output=True, text=True, timeout=60
    )
    assert out.returncode == 0 and "gain3p (g3)" in out.stdout
    (tmp_path / "p.pat").write_text("node a g3 gain=3\nnode b print\na -> b\n")
    out = subprocess.run(
        [sys.executable, "-m", "pointat.cli", "check", str(tmp_path / "p.pat")],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 0, out.stderr
