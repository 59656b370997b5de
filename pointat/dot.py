"""Graphviz ``dot`` text for a checked patch (``pointat graph``)."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

from .checking import Checked
from .errors import PointatError
from .patchfile import format_value

__all__ = ["to_dot", "write_svg"]


def _escape(s: str) -> str:
    return s.replace("\\", "\\\\").replace('"', '\\"')


def _quote(s: str) -> str:
    return '"' + _escape(s) + '"'


def to_dot(checked: Checked, title: str = "patch") -> str:
    """The graph as dot text: one box per node (name, type and parameters), one edge per wire."""
    lines = [
        f"digraph {_quote(title)} {{",
        "  rankdir=LR;",
        '  node [shape=box, fontname="Helvetica", fontsize=10];',  # box: {} | <> in a label are text
        '  edge [fontname="Helvetica", fontsize=8];',
    ]
    for name, r in checked.nodes.items():
        decl = r.decl
        given = [format_value(a) for a in decl.args] + [
            f"{k}={format_value(v)}" for k, v in decl.params.items()
        ]
        box = f"[{r.cls.type_name}{' ' if given else ''}{' '.join(given)}]"
        lines.append(f'  {_quote(name)} [label="{_escape(name)}\\n{_escape(box)}"];')  # two lines
    for src, o, dst, i in checked.wires:
        s, d = checked.nodes[src], checked.nodes[dst]
        label = f"{s.outlets[o].name} → {d.inlets[i].name}"
        lines.append(f"  {_quote(src)} -> {_quote(dst)} [label={_quote(label)}];")
    lines.append("}")
    return "\n".join(lines) + "\n"


def write_svg(dot_text: str, path: str | Path) -> bool:
    """Render with Graphviz's ``dot`` when it is installed; False when it is not."""
    exe = shutil.which("dot")
    if exe is None:
        return False
    try:
        subprocess.run(
            [exe, "-Tsvg", "-o", str(path)],
            input=dot_text.encode(),
            capture_output=True,
            check=True,
            timeout=60,
        )
    except subprocess.CalledProcessError as exc:
        said = exc.stderr.decode(errors="replace").strip()
        raise PointatError(
            f"Graphviz's dot could not draw {path}: {said or f'exit status {exc.returncode}'}"
        ) from None
    except subprocess.TimeoutExpired:
        raise PointatError(f"Graphviz's dot took over a minute to draw {path}; gave up") from None
    return True
