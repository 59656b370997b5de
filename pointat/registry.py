"""The registry of node types by name.

Node types arrive from three places, all through :func:`register`:

1. entry points of the group ``pointat.nodes``: pointat's own (its built-in modules,
   :mod:`pointat.nodes` and :mod:`pointat.osc_bridge`, declared in its ``pyproject.toml``) and those of
   third-party distributions, through the same door (each entry point names a module to import, or a
   :class:`~pointat.node.Node` subclass); one that cannot be loaded is an error naming it;
2. ``--plugins DIR``: every ``*.py`` file in a folder.

A name (or alias) registered twice by two different classes is an error that names both origins.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import importlib.util
import inspect
import logging
import re
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

from .errors import PointatError, closest
from .node import PARAM_TYPES, ROLES, Node

__all__ = [
    "ENTRY_POINT_GROUP",
    "Registry",
    "RegistryError",
    "default_registry",
    "register",
]

log = logging.getLogger("pointat.registry")

ENTRY_POINT_GROUP = "pointat.nodes"
#: The distribution whose entry points are the built-in node types.
DISTRIBUTION = "pointat"


class RegistryError(PointatError):
    """A node type is declared wrongly, or a name is taken twice."""


def _check_declaration(cls: type[Node]) -> None:
    where = f"node type '{cls.type_name}' ({cls.__module__}.{cls.__qualname__})"
    names = [p.name for p in cls.params]
    if len(set(names)) != len(names):
        raise RegistryError(f"{where}: duplicate parameter names {names}")
    for p in cls.params:
        if p.type not in PARAM_TYPES:
            raise RegistryError(f"{where}: parameter '{p.name}' has unknown type '{p.type}'")
        if p.name == "name":
            raise RegistryError(f"{where}: 'name' is reserved for the node's name in a patch")
        if hasattr(cls, "do_" + p.name):
            raise RegistryError(f"{where}: parameter '{p.name}' clashes with method do_{p.name}")
    if cls.role not in ROLES:
        raise RegistryError(f"{where}: role '{cls.role}' is none of {', '.join(ROLES)}")
    readings = [r.name for r in cls.readings]
    for r in cls.readings:
        if not re.fullmatch(r"[A-Za-z_]\w*", r.name):
            raise RegistryError(
                f"{where}: reading {r.name!r} is no name (letters, digits, _): an OSC address"
            )
        if readings.count(r.name) > 1 or cls.param(r.name) is not None or hasattr(cls, "do_" + r.name):
            raise RegistryError(
                f"{where}: reading '{r.name}' is named twice, or as a parameter or a method (its OSCQuery "
                f"address /pointat/NODE/{r.name} would be two things)"
            )
        if not r.units or (r.direction and r.size != 3):
            raise RegistryError(
                f"{where}: reading '{r.name}' has {r.size} unit(s); expected one per number"
                + (", three for a direction (azimuth, elevation, distance)" if r.direction else "")
            )
    inlet_names = {i.name for i in cls.inlets}
    for attr in dir(cls):
        if (
            attr.startswith("on_")
            and attr[3:] not in inlet_names
            and cls.layout.__func__ is Node.layout.__func__
        ):
            raise RegistryError(f"{where}: handler {attr} names no inlet (inlets: {sorted(inlet_names)})")


class Registry:
    """Node types by name (and alias)."""

    def __init__(self) -> None:
        self._types: dict[str, type[Node]] = {}
        self._loaded_builtins = False

    def add(self, cls: type[Node], origin: str = "") -> type[Node]:
        """Register ``cls`` under its ``type_name`` and aliases; a clash with another class is an error."""
        if not (inspect.isclass(cls) and issubclass(cls, Node)) or not cls.type_name:
            raise RegistryError(f"{cls!r} is not a Node subclass with a type_name")
        _check_declaration(cls)
        if origin and not cls.origin:
            cls.origin = origin
        for name in (cls.type_name, *cls.aliases):
            old = self._types.get(name)
            if old is not None and old is not cls:
                raise RegistryError(
                    f"node type name '{name}' is taken twice: by {old.__module__}.{old.__qualname__}"
                    f" ({old.origin or 'unknown origin'}) and by {cls.__module__}.{cls.__qualname__}"
                    f" ({origin or cls.origin or 'unknown origin'})"
                )
            self._types[name] = cls
        return cls

    def copy(self) -> Registry:
        """A registry with the same types, to extend without touching this one (tests, tools)."""
        new = Registry()
        new._types = dict(self._types)
        new._loaded_builtins = self._loaded_builtins
        return new

    def get(self, name: str) -> type[Node] | None:
        return self._types.get(name)

    def __contains__(self, name: object) -> bool:
        return name in self._types

    def __iter__(self) -> Iterator[type[Node]]:
        """Each class once, sorted by type name."""
        seen = {id(c): c for c in self._types.values()}
        return iter(sorted(seen.values(), key=lambda c: c.type_name))

    def names(self) -> list[str]:
        return sorted(self._types)

    def suggest(self, name: str) -> str | None:
        """The closest registered name, for "did you mean" hints."""
        return closest(name, self._types)

    # loading ------------------------------------------------------------------------
    def load_builtins(self) -> Registry:
        """Load pointat's own node types: the ``pointat.nodes`` entry points of its distribution."""
        if not self._loaded_builtins:
            self._loaded_builtins = True
            own = [ep for ep in _entry_points() if ep.dist is not None and ep.dist.name == DISTRIBUTION]
            if not own:
                raise RegistryError(
                    "pointat's built-in node types come through its entry points, and none were found: "
                    "install it (pip install -e . in a checkout)"
                )
            for ep in own:
                self._load(ep, f"built-in ({ep.value})")
        return self

    def load_entry_points(self) -> Registry:
        """Load third-party node types from the ``pointat.nodes`` entry-point group."""
        for ep in _entry_points():
            if ep.dist is None or ep.dist.name != DISTRIBUTION:
                self._load(
                    ep, f"entry point '{ep.name}' of {ep.dist.name if ep.dist else 'an unknown distribution'}"
                )
        return self

    def _load(self, ep: importlib.metadata.EntryPoint, origin: str) -> None:
        try:
            obj = ep.load()
        except Exception as exc:  # a module missing or broken: said, never skipped
            raise RegistryError(f"cannot load {origin} ({ep.value}): {exc}") from exc
        self._adopt(obj, origin)

    def load_plugins(self, folder: str | Path) -> Registry:
        """Import every ``*.py`` in ``folder``; their node classes are registered."""
        folder = Path(folder)
        if not folder.is_dir():
            raise RegistryError(f"--plugins {folder}: not a folder")
        for path in sorted(folder.glob("*.py")):
            modname = f"pointat_plugin_{path.stem}"
            spec = importlib.util.spec_from_file_location(modname, path)
            if spec is None or spec.loader is None:
                raise RegistryError(f"{path}: cannot be imported")
            module = importlib.util.module_from_spec(spec)
            sys.modules[modname] = module
            try:
                spec.loader.exec_module(module)
            except RegistryError:
                raise
            except Exception as exc:
                raise RegistryError(f"{path}: import failed: {exc}") from exc
            self._adopt(module, f"plugin file {path}")
        return self

    def _adopt(self, obj: object, origin: str) -> None:
        """Register a class, or every registered class defined in a module."""
        if inspect.isclass(obj):
            self.add(obj, origin)
            return
        for value in vars(obj).values():
            if (
                inspect.isclass(value)
                and issubclass(value, Node)
                and value.type_name
                and value.__module__ == getattr(obj, "__name__", None)
            ):
                self.add(value, origin)


def _entry_points() -> list[importlib.metadata.EntryPoint]:
    """The ``pointat.nodes`` entry points, each once (an editable install beside a built one lists a
    distribution twice)."""
    seen: dict[tuple[str, str], importlib.metadata.EntryPoint] = {}
    for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
        seen.setdefault((ep.name, ep.value), ep)
    return list(seen.values())


default_registry = Registry()


def register(name: str, *aliases: str) -> Callable[[type[Node]], type[Node]]:
    """Class decorator: give a node class its type name (and aliases) and add it to the default registry."""

    def decorate(cls: type[Node]) -> type[Node]:
        cls.type_name = name
        cls.aliases = tuple(aliases)
        return default_registry.add(cls, cls.origin or cls.__module__)

    return decorate
