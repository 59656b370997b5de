"""Writing Pure Data files: boxes laid out in columns, and the stub abstractions."""

from __future__ import annotations

import inspect
import math
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from itertools import accumulate
from pathlib import Path
from typing import Any

from ..errors import PatchError, PointatError
from ..names import inside
from ..node import REQUIRED, Inlet, Node, Outlet
from ..patchfile import format_value
from ..registry import Registry, default_registry
from ..spec import NodeDecl, PatchSpec, Wire, is_abstraction
from .common import (
    _CHAR,
    _COLUMN,
    _FONT,
    _KEY,
    _LINE,
    _MARGIN,
    _NAME_DY,
    _NUMBER,
    _ROW,
    _TOP,
    _UNSAFE,
    NAME_TAG,
    STUB_FOLDER,
    VANILLA,
    log,
)


# =========================================================================== writing
def _escape(text: str) -> str:
    r"""A symbol's text as Pd writes it: ``\`` ``,`` ``;`` ``$`` and white space escaped."""
    return re.sub(r"([\\,;$\s])", r"\\\1", text)


def _atom_text(value: Any) -> str:
    """One Pd atom: numbers as numbers (full precision), ``,``/``;`` as separators, other text escaped."""
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value)
    text = str(value)
    if text in (",", ";"):
        return "\\" + text
    out = _escape(text)
    if _NUMBER.match(text):  # keep a symbol "12" a symbol
        return "\\" + out
    if _KEY.match(text):  # and "a=b" a positional atom, not a named parameter
        return out.replace("=", "\\=", 1)
    return out


def _plain_words(text: str) -> bool:
    """Whether ``text`` is two or more words one space apart that Pd keeps as written: none reads as a
    number (:data:`_NUMBER`) or as ``key=value`` (:data:`_KEY`), none holds a separator, a ``$``, a brace
    or a backslash."""
    words = text.split(" ")
    return len(words) > 1 and all(
        w and not (_NUMBER.match(w) or _KEY.match(w) or _UNSAFE.search(w)) for w in words
    )


def _value_text(value: Any) -> str:
    """A parameter value as :func:`~pointat.patchfile.parse_value` reads it; lists without commas."""
    if isinstance(value, (list, tuple)):
        return "[" + " ".join(_value_text(v) for v in value) + "]"
    return format_value(value)


def _same(a: Any, b: Any) -> bool:
    """Equal values, NaN equal to NaN (a NaN default is not worth writing)."""
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    try:
        return bool(a == b)
    except (TypeError, ValueError):  # numpy arrays and the like
        return False


def _default_of(cls: type[Node], name: str) -> Any:
    p = cls.param(name)
    if p is None or p.default is REQUIRED:
        return REQUIRED
    try:
        return p.coerce(p.default)
    except ValueError:
        return p.default


def _positional(cls: type[Node], values: dict[str, Any], node: str) -> list[str]:
    """Creation atoms for one of Pd's own types: parameters in order, up to the last one that matters."""
    params = cls.params
    last = -1
    for k, p in enumerate(params):
        first_number = k == 0 and p.type in ("float", "int")  # "metro 100", never a bare "metro"
        if p.variadic or first_number or not _same(values[p.name], _default_of(cls, p.name)):
            last = k
    atoms: list[str] = []
    for p in params[: last + 1]:
        v = values[p.name]
        items = list(v) if isinstance(v, (list, tuple)) else [v]
        for item in items:
            _warn_precision(node, cls.type_name, item)
            if isinstance(item, float) and p.type == "float" and item.is_integer() and abs(item) < 1e15:
                atoms.append(str(int(item)))
            else:
                atoms.append(_atom_text(item))
    return atoms


def _warn_precision(node: str, type_name: str, value: Any) -> None:
    """Pd writes number atoms with 6 significant digits, whole numbers too, and has no infinity or NaN:
    say so when that would change ``value``."""
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        return
    if not math.isfinite(value):
        log.warning(
            "node '%s' (%s): Pd has no number %r: it reads back as the word '%s'",
            node,
            type_name,
            value,
            value,
        )
    elif float(f"{value:.6g}") != value:
        log.warning(
            "node '%s' (%s): Pd keeps 6 significant digits of %r: it becomes %.6g if Pd saves the file",
            node,
            type_name,
            value,
            value,
        )


def _named(cls: type[Node], values: dict[str, Any], decl: NodeDecl) -> list[str]:
    """``key=value`` atoms for every parameter of a pointat-only type that the patch gives (by name or by
    position, even at its default value: ``port=9001`` stays in sight) or that differs from its default."""
    given = set(decl.params) | {p.name for p in cls.params[: len(decl.args)]}
    return [
        f"{p.name}={_escape(_value_text(values[p.name]))}"
        for p in cls.params
        if p.name in given or not _same(values[p.name], _default_of(cls, p.name))
    ]


@dataclass
class _Out:
    """A node on its way out: its decl, the text of its box, its ports, and its place."""

    decl: NodeDecl
    kind: str  # "obj" or "msg"
    atoms: list[str]
    inlets: Sequence[Inlet] | None
    outlets: Sequence[Outlet] | None
    column: int = 0
    row: int = 0


def _port(ports: Sequence[Inlet] | Sequence[Outlet] | None, port: str | int, what: str, w: Wire) -> int:
    if isinstance(port, int):
        return port
    for i, p in enumerate(ports or ()):
        if p.name == port:
            return i
    raise PatchError(f"wire {w}: no {what} named {port!r}", w.where)


def _box(decl: NodeDecl, registry: Registry) -> _Out:
    cls = registry.get(decl.type)
    if cls is None:  # not a pointat type: write what the patch says
        atoms = [_atom_text(a) for a in decl.args]
        atoms += [f"{k}={_escape(_value_text(v))}" for k, v in decl.params.items()]
        return _Out(decl, "obj", [_escape(decl.type), *atoms], None, None)
    try:
        values = cls.resolve_params(decl.args, decl.params)
        ins, outs = cls.layout(values)
    except ValueError as exc:
        raise PatchError(f"node '{decl.name}' ({decl.type}): {exc}", decl.where) from exc
    if cls.type_name == "msg":
        for a in values["content"]:
            _warn_precision(decl.name, "msg", a)
        return _Out(decl, "msg", [_atom_text(a) for a in values["content"]], ins, outs)
    if (
        cls.type_name == "print"
        and not values["time"]
        and values["decimals"] == 1
        and _plain_words(values["prefix"])
    ):
        # as Pd reads it: [print gyro nulls] prints "gyro nulls: ...", and its box shows no escapes
        return _Out(decl, "obj", [decl.type, *values["prefix"].split(" ")], ins, outs)
    if cls.type_name in VANILLA:
        return _Out(decl, "obj", [decl.type, *_positional(cls, values, decl.name)], ins, outs)
    default_ins, default_outs = _default_layout(cls)
    if len(ins) > len(default_ins) or len(outs) > len(default_outs):
        log.warning(
            "node '%s' (%s) has %d inlets and %d outlets, its Pd stub (default parameters) %d and %d: "
            "Pd will not connect the extra ones",
            decl.name,
            decl.type,
            len(ins),
            len(outs),
            len(default_ins),
            len(default_outs),
        )
    return _Out(decl, "obj", [decl.type, *_named(cls, values, decl)], ins, outs)


def _columns(n: int, edges: list[tuple[int, int]]) -> list[int]:
    """Topological depth of each node (longest path from a source), loops broken at their back edges."""
    succ: list[list[int]] = [[] for _ in range(n)]
    for a, b in edges:
        if b not in succ[a]:
            succ[a].append(b)
    state = [0] * n  # 0 new, 1 on the DFS stack, 2 done
    back: set[tuple[int, int]] = set()
    for root in range(n):
        if state[root]:
            continue
        state[root] = 1
        stack = [(root, iter(succ[root]))]
        while stack:
            v, it = stack[-1]
            for w in it:
                if state[w] == 0:
                    state[w] = 1
                    stack.append((w, iter(succ[w])))
                    break
                if state[w] == 1:
                    back.add((v, w))
            else:
                state[v] = 2
                stack.pop()
    dag = [[w for w in succ[v] if (v, w) not in back] for v in range(n)]
    indeg = [0] * n
    for v in range(n):
        for w in dag[v]:
            indeg[w] += 1
    depth = [0] * n
    ready = [v for v in range(n) if indeg[v] == 0]
    while ready:
        v = ready.pop(0)
        for w in dag[v]:
            depth[w] = max(depth[w], depth[v] + 1)
            indeg[w] -= 1
            if indeg[w] == 0:
                ready.append(w)
    return depth


def _bus_edges(outs: list[_Out], registry: Registry) -> list[tuple[int, int]]:
    """send -> receive pairs of one bus name: not wires, but they place a receive after its send."""
    kinds = [getattr(registry.get(o.decl.type), "type_name", "") for o in outs]
    buses: dict[str, list[int]] = {}
    for k, o in enumerate(outs):
        if kinds[k] == "receive":
            buses.setdefault(" ".join(o.atoms[1:]), []).append(k)
    return [
        (k, r) for k, o in enumerate(outs) if kinds[k] == "send" for r in buses.get(" ".join(o.atoms[1:]), [])
    ]


def _place(outs: list[_Out], edges: list[tuple[int, int]]) -> None:
    """Column = topological depth; rows in a column ordered by the mean row of the inputs (then spec order)."""
    depth = _columns(len(outs), edges)
    preds: dict[int, list[int]] = {}
    for a, b in edges:
        if depth[a] < depth[b]:
            preds.setdefault(b, []).append(a)

    def key(k: int) -> tuple[float, int]:
        rows = [outs[p].row for p in preds.get(k, [])]
        return (sum(rows) / len(rows) if rows else -1.0, k)

    for col in range(max(depth, default=-1) + 1):
        members = sorted((k for k in range(len(outs)) if depth[k] == col), key=key)
        for row, k in enumerate(members):
            outs[k].column, outs[k].row = col, row


def write_pd(spec: PatchSpec, registry: Registry | None = None) -> str:
    """Pd file text for a flat patch (abstraction instances expanded first:
    :func:`pointat.expansion.flatten`, whose header note says which); see the module docstring.

    Every node is preceded by an ``@name`` comment so that :func:`read_pd` gives back the same names.
    """
    instances = [n for n in spec.nodes if is_abstraction(n.type)]
    if instances:
        raise PatchError(
            f"abstraction instance '{instances[0].name}' ({instances[0].type}): a Pd file holds the nodes "
            "(pointat.expansion.flatten first, as pointat convert does)",
            instances[0].where,
        )
    registry = registry or default_registry.load_builtins()
    outs = [_box(decl, registry) for decl in spec.nodes]
    index = {o.decl.name: k for k, o in enumerate(outs)}
    wires: list[tuple[int, int, int, int]] = []
    for w in spec.wires:
        if w.src not in index or w.dst not in index:
            missing = w.src if w.src not in index else w.dst
            raise PatchError(f"wire {w}: no node named '{missing}'", w.where)
        s, d = outs[index[w.src]], outs[index[w.dst]]
        wires.append(
            (
                index[w.src],
                _port(s.outlets, w.outlet, "outlet", w),
                index[w.dst],
                _port(d.inlets, w.inlet, "inlet", w),
            )
        )
    _place(outs, [(a, c) for a, _o, c, _i in wires] + _bus_edges(outs, registry))
    xs = [_MARGIN]
    for col in range(max((o.column for o in outs), default=0) + 1):
        texts = [o.atoms for o in outs if o.column == col]
        chars = max((len(" ".join(t)) for t in texts), default=0)
        chars = max(chars, *(len(NAME_TAG) + 1 + len(o.decl.name) for o in outs if o.column == col), 0)
        xs.append(xs[-1] + max(_COLUMN, chars * _CHAR + 40))
    width = min(max(450, xs[-1] + _MARGIN), 1600)
    header = [ln for ln in spec.doc.splitlines() if ln.strip()]
    # Pd shows a ';' inside a comment as the end of a line: a comment takes a line more for each
    *header_y, below = accumulate((_LINE * (1 + ln.rstrip(" ;").count(";")) for ln in header), initial=_TOP)
    top = below + _LINE if header else _TOP
    rows = max((o.row for o in outs), default=0) + 1
    height = min(max(300, top + rows * _ROW + _MARGIN), 1000)
    lines = [
        f"#N canvas 0 50 {width} {height} {_FONT};",
        f"#X declare -path {STUB_FOLDER};",
        f"#X obj {_MARGIN} 10 declare -path {STUB_FOLDER};",
    ]
    for o in outs:
        x, y = xs[o.column], top + o.row * _ROW
        lines.append(f"#X text {x} {y} {NAME_TAG} {_escape(o.decl.name)};")
        lines.append(" ".join([f"#X {o.kind} {x} {y + _NAME_DY}", *o.atoms]) + ";")
    for y, line in zip(header_y, header, strict=True):
        lines.append(f"#X text {_MARGIN} {y} {_comment(line)}, f {max(len(line), 20)};")
    for a, o, b, i in wires:
        lines.append(f"#X connect {2 + 2 * a} {o} {2 + 2 * b} {i};")
    return "\n".join(lines) + "\n"


# =========================================================================== stubs
def _default_layout(cls: type[Node]) -> tuple[tuple[Inlet, ...], tuple[Outlet, ...]]:
    """Inlets and outlets for the default parameters, or those the type names for its stub
    (:attr:`~pointat.node.Node.stub_values`); the declared ones when that needs a value."""
    try:
        return cls.layout({**{p.name: p.default for p in cls.params}, **cls.stub_values})
    except Exception:  # a required parameter or a layout that validates: fall back to the declaration
        return tuple(cls.inlets), tuple(cls.outlets)


def _comment(text: str) -> str:
    r"""Words of a comment: ``,`` and ``;`` as separate escaped atoms, ``$`` escaped, and a word that
    reads as a number escaped too, so that Pd keeps it as it is written (``1.`` stays ``1.``).  Pd has no
    braces in a comment and drops a backslash when it saves one: braces become parentheses, backslashes go.

    >>> _comment("1. send mag, then $1 \\-> {x}")
    '\\1. send mag \\, then \\$1 -> (x)'
    """
    atoms: list[str] = []
    for word in text.replace("{", "(").replace("}", ")").replace("\\", "").split():
        for part in re.split(r"([,;])", word):
            if part in (",", ";"):
                atoms.append("\\" + part)
            elif part:
                part = part.replace("$", "\\$")
                atoms.append("\\" + part if _NUMBER.match(part) else part)
    return " ".join(atoms)


def _stub(name: str, cls: type[Node]) -> str:
    ins, outs = _default_layout(cls)
    names = [p.name for p in (*ins, *outs)]
    step = max(70, max((len(n) for n in names), default=0) * _CHAR + 20)
    doc = inspect.cleandoc(cls.__doc__ or "").splitlines()
    first = doc[0] if doc else ""
    width = max(450, _MARGIN * 2 + step * max(len(ins), len(outs), 1))
    lines = [f"#N canvas 0 50 {width} 220 {_FONT};"]
    boxes: list[str] = []
    for k, inlet in enumerate(ins):
        boxes.append(f"#X obj {_MARGIN + k * step} 10 inlet;")
        boxes.append(f"#X text {_MARGIN + k * step} 35 {_comment(inlet.name)};")
    boxes.append(f"#X text {_MARGIN} 80 {_comment(f'{name} (pointat stub): {first}')};")
    for k, outlet in enumerate(outs):
        boxes.append(f"#X text {_MARGIN + k * step} 145 {_comment(outlet.name)};")
        boxes.append(f"#X obj {_MARGIN + k * step} 170 outlet;")
    return "\n".join(lines + boxes) + "\n"


def write_stubs(
    folder: str | Path, registry: Registry | None = None, types: Iterable[str] | None = None
) -> list[Path]:
    """Write ``TYPE.pd`` stub abstractions into ``folder``: one per pointat-only type (and alias), or ``types``.

    A stub holds ``[inlet]`` and ``[outlet]`` objects left to right in the node's port order (for its
    default parameters) and a comment with the first line of its doc, so that Pd's editor draws and
    connects the box.  Returns the paths written.
    """
    registry = registry or default_registry.load_builtins()
    folder = Path(folder)
    if types is None:
        names = [n for cls in registry if cls.type_name not in VANILLA for n in (cls.type_name, *cls.aliases)]
    else:
        names = list(types)
        unknown = [n for n in names if registry.get(n) is None]
        if unknown:
            raise PatchError(f"no stub for unknown node type(s): {', '.join(unknown)}")
    paths = []
    try:
        folder.mkdir(parents=True, exist_ok=True)
        for name in names:
            cls = registry.get(name)
            assert cls is not None
            path = folder / f"{name}.pd"
            inside(folder, path)  # a plugin's type name is no way out of the folder
            path.write_text(_stub(name, cls), encoding="utf-8")
            paths.append(path)
    except OSError as exc:  # a file where the folder should be, no permission, a full disk
        raise PointatError(
            f"cannot write the stubs to {folder}: {exc.strerror or exc}"
            + (f" ({exc.filename})" if exc.filename and str(exc.filename) != str(folder) else "")
        ) from None
    return paths
