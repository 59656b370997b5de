"""The patch model that every patch format reads into and writes from: nodes, wires and their places.

A :class:`PatchSpec` is pure data: it knows nothing of node classes.  The loader
(:mod:`pointat.loader`) expands abstractions, checks it against the registry and builds a runtime.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import PurePath
from typing import Any

from .errors import Where

__all__ = ["NodeDecl", "PatchSpec", "PortDecl", "Wire", "is_abstraction", "is_pd_file"]

#: What a patch file's name ends with (in any case): native, Pure Data.
PATCH_SUFFIXES = (".pat", ".pd")


def is_abstraction(type_name: str) -> bool:
    """Whether a node's type names a patch file (an abstraction) rather than a node class: it ends in
    ``.pat`` or ``.pd``, or has a folder in it."""
    return type_name.lower().endswith(PATCH_SUFFIXES) or "/" in type_name


def is_pd_file(path: str | PurePath) -> bool:
    """Whether a patch file is Pure Data's, by its name: ``.pd``, in any case (``OK.PD`` from a
    system that ignores case)."""
    return PurePath(path).suffix.lower() == ".pd"


@dataclass
class NodeDecl:
    """``node NAME TYPE args... key=value...``: a node, or an abstraction instance when TYPE is a file."""

    name: str
    type: str
    args: list[Any] = field(default_factory=list)
    params: dict[str, Any] = field(default_factory=dict)
    where: Where | None = None


@dataclass
class Wire:
    """``src.outlet -> dst.inlet``; ports are names or 0-based indices."""

    src: str
    outlet: str | int
    dst: str
    inlet: str | int
    where: Where | None = None

    def __str__(self) -> str:
        return f"{self.src}.{self.outlet} -> {self.dst}.{self.inlet}"


@dataclass
class PortDecl:
    """An abstraction's inlet (``inlet NAME -> node.inlet``) or outlet (``outlet NAME <- node.outlet``)."""

    name: str
    node: str
    port: str | int
    where: Where | None = None


@dataclass
class PatchSpec:
    """A whole patch file."""

    path: str
    nodes: list[NodeDecl] = field(default_factory=list)
    wires: list[Wire] = field(default_factory=list)
    args: dict[str, Any] = field(default_factory=dict)
    inlets: list[PortDecl] = field(default_factory=list)
    outlets: list[PortDecl] = field(default_factory=list)
    doc: str = ""
    args_where: Where | None = None

    def node(self, name: str) -> NodeDecl | None:
        for n in self.nodes:
            if n.name == name:
                return n
        return None
