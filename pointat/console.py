"""What ``pointat run`` tells a performer: a banner (what the patch is, where its data comes from and goes
to), a status line per glove while it runs, and a summary at the end.  Words only, from a built runtime;
the console's writer (:mod:`pointat.terminal`) puts them on the screen."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from . import __version__
from .userfiles import open_user_file

__all__ = ["about", "banner", "describe", "files"]


def about(path: str | os.PathLike[str]) -> str:
    """What a patch is: the first sentence of its opening comment.

    >>> import tempfile
    >>> with tempfile.NamedTemporaryFile("w", suffix=".pat", delete=False) as f:
    ...     _ = f.write("# The Pointing-at glove, with\\n# its filter. More.\\nnode a metro\\n")
    >>> about(f.name)
    'The Pointing-at glove, with its filter.'
    """
    try:
        with open_user_file(path, "patch") as fh:  # never a wait on a pipe
            head = fh.read(4096).decode("utf-8", errors="replace")
    except (OSError, ValueError):
        return ""
    words: list[str] = []
    for line in head.splitlines():
        text = line.strip()
        if not text.startswith("#") or text.startswith(("#N ", "#X ")):  # code, or a Pd file
            break
        text = text.lstrip("#").strip()
        if not text:
            if words:
                break
            continue
        words.append(text)
    paragraph = " ".join(words)
    end = paragraph.find(". ")
    sentence = paragraph if end < 0 else paragraph[: end + 1]
    return sentence if len(sentence) <= 200 else sentence[:199] + "…"


def describe(node: Any) -> str:
    """One node as a performer would name it: its type and name, and what it reads or where it sends
    (what the node's own :meth:`~pointat.node.Node.describe` says)."""
    label = f"{node.type_name} '{node.name}'"
    what = node.describe()
    return f"{label}: {what}" if what else label


def files(rt: Any, copied: Sequence[tuple[Path, Path]] = ()) -> list[str]:
    """Where each file the patch writes goes, as whole paths (a shipped patch's go to the current folder
    or ``--out``); ``copied``: the shipped files the run copied there first, to be the user's own."""
    lines = [
        f"  copied   {os.path.abspath(copy)}  (the shipped {src.name}: yours to change and save)"
        for src, copy in copied
    ]
    for node in rt.nodes.values():
        for p in type(node).params:
            value = getattr(node.p, p.name, None)
            if p.type == "path" and p.writes and value:
                lines.append(
                    f"  file     {os.path.abspath(value)}  ({node.type_name} '{node.name}': {p.doc})"
                )
    return lines


def banner(
    rt: Any, patch: str, *, monitor: Any = None, presets: Any = None, copied: Sequence[tuple[Path, Path]] = ()
) -> list[str]:
    """The lines ``pointat run`` starts with."""
    name = Path(patch).stem
    what = about(patch)
    lines = [f"pointat {__version__} · {name}" + (f": {what}" if what else "")]
    for label, role in (("in ", "input"), ("out", "output")):
        for node in rt.nodes.values():
            if node.role == role:
                lines.append(f"  {label}  {describe(node)}")
    if monitor is not None:
        lines.append(
            f"  monitor  {monitor.url}  (OSCQuery on the same port; OSC control on {monitor.osc_port}/udp)"
        )
    lines += files(rt, copied)
    if presets is not None:
        lines.append(f"  presets  {presets.path}  (/pointat/preset/save NAME, /pointat/preset/recall NAME)")
    lines.append("  Ctrl-C stops.")
    return lines
