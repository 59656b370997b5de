"""The built-in node types' doors: every module of ``nodes/``, ``osc_bridge/`` and ``midi_bridge/`` that
defines node types has its line in pyproject's ``pointat.nodes`` entry points (the registry loads nothing
else, so a module without one is silently missing from ``pointat nodes``), and every line names a module
that exists and defines some."""

from __future__ import annotations

import importlib
import importlib.metadata
import importlib.util
import inspect
from pathlib import Path
from types import ModuleType

import pytest

from pointat.node import Node

ROOT = Path(__file__).resolve().parents[2]
#: The node packages kept at the top of the repository, by the name they install under.
FOLDERS = {"pointat.nodes": "nodes", "pointat.osc_bridge": "osc_bridge", "pointat.midi_bridge": "midi_bridge"}


def declared() -> dict[str, str]:
    """pyproject's ``[project.entry-points."pointat.nodes"]`` as the installed pointat has them (what the
    registry reads; pip install writes them from pyproject): entry-point name -> module.  (Read from the
    metadata rather than pyproject.toml: tomllib is 3.11's, and pointat runs on 3.10.)"""
    entry_points = importlib.metadata.distribution("pointat").entry_points
    return {ep.name: ep.value for ep in entry_points if ep.group == "pointat.nodes"}


def node_types(module: ModuleType) -> list[str]:
    """The node types a module defines (not those it imports), as the registry adopts them."""
    return sorted(
        value.type_name
        for value in vars(module).values()
        if inspect.isclass(value)
        and issubclass(value, Node)
        and value.type_name
        and value.__module__ == module.__name__
    )


def modules() -> list[str]:
    """Every module of the node packages, by its installed name (the packages' ``__init__`` too)."""
    names = []
    for package, folder in FOLDERS.items():
        for path in sorted((ROOT / folder).glob("*.py")):
            names.append(package if path.stem == "__init__" else f"{package}.{path.stem}")
    return names


def test_the_modules_are_found():
    found = modules()
    assert {"pointat.nodes.tqt", "pointat.osc_bridge.listener", "pointat.midi_bridge.nodes"} <= set(found)


@pytest.mark.parametrize("name", modules())
def test_a_module_that_defines_node_types_has_an_entry_point(name):
    types = node_types(importlib.import_module(name))
    if types:
        assert name in declared().values(), (
            f"{name} defines {', '.join(types)} but has no line in pyproject's "
            '[project.entry-points."pointat.nodes"]: the registry never loads it'
        )


@pytest.mark.parametrize("entry", sorted(declared().items()), ids=lambda e: e[0])
def test_every_entry_point_names_a_module_that_defines_node_types(entry):
    ep_name, value = entry
    module_name = value.partition(":")[0]
    assert importlib.util.find_spec(module_name) is not None, (
        f"entry point {ep_name} = {value}: no such module"
    )
    assert node_types(importlib.import_module(module_name)), (
        f"entry point {ep_name} = {value}: the module defines no node type"
    )


def test_the_entry_points_cover_every_built_in_node_type():
    """Seen from the other side: the node types the registry loads are those the modules define."""
    from pointat.registry import default_registry

    defined = {t for name in modules() for t in node_types(importlib.import_module(name))}
    loaded = {cls.type_name for cls in default_registry.load_builtins()}
    assert defined <= loaded, sorted(defined - loaded)
