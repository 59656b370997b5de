"""The patch model that every patch format reads into and writes from: nodes, wires and their places.

A :class:`PatchSpec` is pure data: it knows nothing of node classes.  The loader
(:mod:`pointat.loader`) expands abstractions, checks it against the registry and builds a runtime.
"""

from __future__ import annotations

import os
import stat
from dataclasses import dataclass, field
from pathlib import PurePath
from typing import Any

from .errors import PatchError, Where
from .userfiles import LIMITS, UserFileError, read_bytes

__all__ = [
    "MAX_PATCH_BYTES",
    "NodeDecl",
    "PatchSpec",
    "PortDecl",
    "Wire",
    "is_abstraction",
    "is_pd_file",
    "is_pd_text",
    "path_kind",
    "read_patch_bytes",
]

#: What a patch file's name ends with (in any case): native, Pure Data.
PATCH_SUFFIXES = (".pat", ".pd")


def is_abstraction(type_name: str) -> bool:
    """Whether a node's type names a patch file (an abstraction) rather than a node class: it ends in
    ``.pat`` or ``.pd``, or has a folder in it."""
    return type_name.lower().endswith(PATCH_SUFFIXES) or "/" in type_name


#: The largest patch file read (bytes): a thousand-node patch is ~50 KB; a file beyond this is no patch.
MAX_PATCH_BYTES = LIMITS["patch"]


def read_patch_bytes(path: str | PurePath) -> bytes:
    """A patch file's bytes: a regular file (not a device, a pipe or a folder) of at most
    :data:`MAX_PATCH_BYTES`, read as every user file is (:mod:`pointat.userfiles`); :class:`PatchError`
    at the file otherwise."""
    try:
        return read_bytes(path, "patch", limit=MAX_PATCH_BYTES)
    except UserFileError as exc:
        raise PatchError(exc.problem, Where(str(path))) from None


def path_kind(path: str | PurePath) -> str:
    """What is at ``path``: ``file``, ``folder``, ``other`` (a device, a pipe, a socket), ``missing``, or
    why no file can be there (``name too long``...): never an exception, for a name a user typed.

    >>> path_kind("/"), path_kind("/no/such/file"), path_kind("x" * 300), path_kind("a" + chr(0))
    ('folder', 'missing', 'File name too long', 'a NUL character in the name')
    """
    try:
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return "missing"
    except OSError as exc:
        return exc.strerror or str(exc)
    except ValueError:
        return "a NUL character in the name"
    return "file" if stat.S_ISREG(mode) else "folder" if stat.S_ISDIR(mode) else "other"


def is_pd_text(raw: bytes) -> bool:
    """Whether a file's bytes are a Pure Data patch (``#N canvas`` first), whatever its name."""
    return raw.lstrip().startswith(b"#N canvas")


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
    #: Where the relative files of a shipped patch go (``pointat run --out``; empty: the current folder
    #: as it is checked): a shipped patch is read-only (:func:`pointat.shipped.place`).
    out: str = ""

    def node(self, name: str) -> NodeDecl | None:
        for n in self.nodes:
            if n.name == name:
                return n
        return None
