"""The doctests of the node packages kept at the top of the repository (``nodes/``, ``osc_bridge/``,
``midi_bridge/``).

pytest's ``--doctest-modules`` collects ``pointat/`` itself; these install inside the package
(``pointat.nodes``, ``pointat.osc_bridge``, ``pointat.midi_bridge``) and must be imported under those names, once, as the
registry imports them: collected from their folders they would be imported a second time under
another name and register every node type twice.
"""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import pointat.midi_bridge
import pointat.nodes
import pointat.osc_bridge

MODULES = [
    f"{package.__name__}.{info.name}"
    for package in (pointat.nodes, pointat.osc_bridge, pointat.midi_bridge)
    for info in pkgutil.iter_modules(package.__path__)
]


def test_every_node_module_is_found():
    assert {"pointat.nodes.tqt", "pointat.midi_bridge.mapping", "pointat.osc_bridge.profiles"} <= set(MODULES)


@pytest.mark.parametrize("name", MODULES)
def test_doctests(name):
    module = importlib.import_module(name)
    flags = doctest.NORMALIZE_WHITESPACE | doctest.ELLIPSIS
    result = doctest.testmod(module, optionflags=flags, report=False)
    assert result.failed == 0, (
        f"{result.failed} of {result.attempted} doctests of {name} failed (run it with -s)"
    )
