"""pointat: a dataflow toolkit for pointing with a hand-worn IMU, after the Pointing-at glove.

Cheat sheet::

    import pointat

    rt = pointat.load("patches/glove_tqt.pat", overrides=["fuse.k=0.5"])   # read, check, build
    rt.run(10.0)                                    # run 10 s (Ctrl-C, rt.stop() or the end stop it)

    # a node type of your own (register it; list it with `pointat nodes`)
    @pointat.register("double")
    class Double(pointat.Node):
        "Output twice the input."
        inlets = (pointat.Inlet("in", ("float",), "a number"),)
        outlets = (pointat.Outlet("out", "float", "twice the number"),)
        params = (pointat.Param("gain", "float", 2.0, "the factor", live=True),)

        def on_in(self, msg):
            self.out(0, self.p.gain * pointat.as_float(msg))

    pointat.make(0.5, time=1.0)                     # a float message; vector(...), bang(), method("set")
    pointat.as_floats(pointat.vector([1, 2, 3]), 3)  # a vector is a tuple of floats: (1.0, 2.0, 3.0)

Modules: :mod:`pointat.message` (messages), :mod:`pointat.node` (the node model), :mod:`pointat.registry`,
:mod:`pointat.runtime` (scheduler, clocks), :mod:`pointat.patchfile` (the .pat format),
:mod:`pointat.pdfile` (Pure Data files), :mod:`pointat.loader` (check and build), :mod:`pointat.cli`,
:mod:`pointat.testing` (patches in tests), :mod:`pointat.monitor` (the console's status lines, the
monitor page and OSCQuery).  The pure math is in :mod:`pointat.maths` and the devices in
:mod:`pointat.devices`; neither imports the engine, and importing them does not load it either: the
names below are loaded on first use.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys
from pathlib import Path
from typing import Any

__version__ = "0.1.0"

_EXPORTS = {
    "Message": "message",
    "as_float": "message",
    "as_floats": "message",
    "as_vector": "message",
    "bang": "message",
    "floats": "message",
    "make": "message",
    "method": "message",
    "vector": "message",
    "Inlet": "node",
    "Node": "node",
    "Outlet": "node",
    "Param": "node",
    "Reading": "node",
    "register": "registry",
    "Registry": "registry",
    "Runtime": "runtime",
    "StartError": "runtime",
    "check": "loader",
    "load": "loader",
    "PatchError": "errors",
    "PointatError": "errors",
}

__all__ = ["__version__", *sorted(_EXPORTS)]


#: Subpackages kept at the top of the repository (as the project is laid out) that install inside this
#: package (pyproject's package-dir): in a checkout they are found there.
_CHECKOUT_FOLDERS = ("nodes", "osc_bridge", "midi_bridge")


class _CheckoutFolders(importlib.abc.MetaPathFinder):
    """``pointat.nodes``, ``pointat.osc_bridge`` and ``pointat.midi_bridge`` from a source checkout's
    ``nodes/``, ``osc_bridge/`` and ``midi_bridge/``, where no installed copy is inside the package (a
    wheel has them inside; an editable install maps them itself).  Only those names: nothing else of
    the checkout becomes part of the package."""

    def __init__(self, root: Path) -> None:
        self.root = root

    def find_spec(
        self, fullname: str, path: Any = None, target: Any = None
    ) -> importlib.machinery.ModuleSpec | None:
        prefix, _, name = fullname.partition(".")
        if prefix != __name__ or name not in _CHECKOUT_FOLDERS:
            return None
        folder = self.root / name
        return importlib.util.spec_from_file_location(
            fullname, folder / "__init__.py", submodule_search_locations=[str(folder)]
        )


def _checkout() -> None:
    here = Path(__file__).resolve().parent
    root = here.parent
    if (here / "nodes").is_dir() or not (root / "pyproject.toml").is_file():
        return  # installed: the subpackages are inside
    if all((root / name / "__init__.py").is_file() for name in _CHECKOUT_FOLDERS):
        if not any(isinstance(f, _CheckoutFolders) for f in sys.meta_path):
            sys.meta_path.insert(0, _CheckoutFolders(root))


_checkout()


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'pointat' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"pointat.{module}"), name)
    globals()[name] = value
    return value
