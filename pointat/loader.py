"""Load a patch: read it (native or Pd), expand its abstractions, check it, build it.

The steps are modules of their own: :mod:`pointat.expansion` (:func:`read_spec`, :func:`expand`),
:mod:`pointat.checking` (:func:`check`: every problem at once) and here :func:`build` and :func:`load`.

:func:`ready` is the one validation ``pointat check`` and ``pointat run`` share: check with the files
read, build, prepare.  Where check stops is where run starts opening things: a device, a port, a socket,
a file to write (:meth:`Node.start`), and the compiled glove chains (which never stop a start).  So a
patch check passes is one run starts, but for a device that is not there or a port another program holds.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .checking import Checked, Resolved, check
from .errors import PatchError, Problem
from .expansion import expand, read_spec, rebase_paths
from .patchfile import parse_value
from .registry import Registry, default_registry
from .runtime import Runtime
from .spec import PatchSpec

__all__ = [
    "Checked",
    "Resolved",
    "build",
    "check",
    "expand",
    "load",
    "parse_overrides",
    "read_spec",
    "ready",
    "rebase_paths",
]


def build(checked: Checked, *, realtime: bool = True) -> Runtime:
    """Instantiate the checked nodes and wires into a :class:`~pointat.runtime.Runtime`; a node that
    cannot be created (a file it reads as it is built) is a :class:`PatchError` naming every such node,
    and the nodes made are closed again."""
    rt = Runtime(realtime=realtime)
    problems = []
    for name, r in checked.nodes.items():
        try:
            node = r.cls(name, r.values)
        except Exception as exc:
            problems.append(Problem(r.decl.where, f"node '{name}' ({r.decl.type}): cannot be created: {exc}"))
            continue
        node.where, node.folder = r.decl.where, r.folder
        rt.add(node)
    if problems:
        rt.shutdown()
        raise PatchError(problems)
    for src, o, dst, i in checked.wires:
        rt.connect(src, o, dst, i)
    rt.prune()
    return rt


def ready(
    spec: PatchSpec,
    registry: Registry | None = None,
    overrides: Sequence[tuple[str, str, Any]] = (),
    *,
    realtime: bool = True,
) -> tuple[Checked, Runtime]:
    """Everything ``pointat run`` does before the patch's clock starts, short of opening anything: the one
    validation ``pointat check`` and ``pointat run`` share, so that a patch check passes is one run starts.

    The patch is checked with its files read (:func:`check` with ``read_files``: a file a node reads that
    is missing or spoilt is an error), every node is built (a node reads its files as it is made), wired
    and pruned, and prepared (:meth:`Runtime.prepare`: the learning nodes' examples read and trained, their
    compiled code loaded).  Left to :meth:`Runtime.start`, and so to ``run`` alone: what opens a device, a
    port or a socket, or a file to write (:meth:`Node.start`), and the compiled glove chains, which never
    stop a start.  Raises :class:`PatchError` with every problem; the caller starts the runtime, or shuts
    it down.
    """
    checked = check(spec, registry, overrides, read_files=True)
    rt = build(checked, realtime=realtime)
    rt.prepare()
    return checked, rt


def parse_overrides(items: Sequence[str]) -> list[tuple[str, str, Any]]:
    """``["node.param=value", ...]`` -> triples; raises :class:`PatchError` for a malformed item."""
    out = []
    for item in items:
        target, eq, value = item.partition("=")
        node, dot, param = target.rpartition(".")
        if not eq or not dot or not node or not param:
            raise PatchError(f"--set {item!r}: expected node.param=value")
        try:
            out.append((node, param, parse_value(value)))
        except ValueError as exc:
            raise PatchError(f"--set {item!r}: {exc}") from None
    return out


def load(
    path: str | Path,
    *,
    registry: Registry | None = None,
    overrides: Sequence[str] = (),
    realtime: bool = True,
) -> Runtime:
    """Read, check and build a patch file in one call."""
    registry = registry or default_registry.load_builtins()
    checked = check(read_spec(path), registry, parse_overrides(overrides))
    return build(checked, realtime=realtime)
