"""Load a patch: read it (native or Pd), expand its abstractions, check it, build it.

The steps are modules of their own: :mod:`pointat.expansion` (:func:`read_spec`, :func:`expand`),
:mod:`pointat.checking` (:func:`check`: every problem at once) and here :func:`build` and :func:`load`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .checking import Checked, Resolved, check
from .errors import PatchError
from .expansion import expand, read_spec, rebase_paths
from .patchfile import parse_value
from .registry import Registry, default_registry
from .runtime import Runtime

__all__ = [
    "Checked",
    "Resolved",
    "build",
    "check",
    "expand",
    "load",
    "parse_overrides",
    "read_spec",
    "rebase_paths",
]


def build(checked: Checked, *, realtime: bool = True) -> Runtime:
    """Instantiate the checked nodes and wires into a :class:`~pointat.runtime.Runtime`."""
    rt = Runtime(realtime=realtime)
    for name, r in checked.nodes.items():
        try:
            node = r.cls(name, r.values)
        except Exception as exc:
            raise PatchError(
                f"node '{name}' ({r.decl.type}): cannot be created: {exc}", r.decl.where
            ) from exc
        node.where = r.decl.where
        rt.add(node)
    for src, o, dst, i in checked.wires:
        rt.connect(src, o, dst, i)
    rt.prune()
    return rt


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
