"""A running patch's OSC address space as OSCQuery describes it (Vidvox's OSCQuery proposal).

Every node's live parameters (``/pointat/NODE/PARAM``, with TYPE, VALUE, RANGE, UNIT, DESCRIPTION and
ACCESS read-write) and methods (``/pointat/NODE/METHOD``, write-only); each node's readings
(:attr:`pointat.node.Node.readings`: an ``osc_out``'s direction as it was last sent,
``/pointat/NODE/aed``, read-only, with its units and range); the presets (``/pointat/preset/save`` and
``recall``); ``/pointat/patch/reload`` when the patch runs from a file.  The addresses are the ones
``osc_in`` takes for live control, so a value set through OSCQuery is set exactly as ``pointat send``
would set it (:func:`pointat.control.control`).

Plain functions of a runtime and an observer; the server (:mod:`pointat.monitor.webserver`) serves them.
"""

from __future__ import annotations

import inspect
import logging
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..control import PREFIX
from ..node import Reading

__all__ = ["EXTENSIONS", "address_space", "find", "value_of"]

log = logging.getLogger("pointat.monitor.oscquery")

#: What the server implements of the proposal's optional parts (HOST_INFO's EXTENSIONS).
EXTENSIONS = {
    "ACCESS": True,
    "VALUE": True,
    "RANGE": True,
    "DESCRIPTION": True,
    "UNIT": True,
    "TAGS": False,
    "CLIPMODE": False,
    "CRITICAL": False,
    "EXTENDED_TYPE": False,
    "HTML": False,
    "LISTEN": True,
    "PATH_CHANGED": False,
    "PATH_ADDED": False,
    "PATH_REMOVED": False,
    "PATH_RENAMED": False,
}

#: pointat's units as OSCQuery's UNIT names (libossia's), where one fits; others are given as they are.
UNITS = {
    "deg": "angle.degree",
    "rad": "angle.radian",
    "s": "time.second",
    "ms": "time.millisecond",
    "Hz": "time.hz",
    "m": "distance.m",
    "cm": "distance.cm",
}

_TYPES = {"float": "f", "int": "i", "bool": "T", "symbol": "s"}
_ACCESS_READ, _ACCESS_WRITE, _ACCESS_RW = 1, 2, 3


def _param_leaf(path: str, node: Any, p: Any) -> dict[str, Any] | None:
    if p.type in _TYPES:
        tag = _TYPES[p.type]
    elif p.type == "vector" and p.size:
        tag = "f" * p.size
    else:
        return None  # a list or a path: not something a fader sets
    leaf: dict[str, Any] = {
        "FULL_PATH": path,
        "TYPE": tag,
        "ACCESS": _ACCESS_RW,
        "DESCRIPTION": p.doc,
        "VALUE": _value(getattr(node.p, p.name), tag),
    }
    if p.unit:
        leaf["UNIT"] = [UNITS.get(p.unit, p.unit)] * len(tag)
    if p.choices:
        leaf["RANGE"] = [{"VALS": list(p.choices)}]
    elif p.minimum is not None or p.maximum is not None or p.above is not None:
        low = p.minimum if p.minimum is not None else p.above
        rng = {k: v for k, v in (("MIN", low), ("MAX", p.maximum)) if v is not None}
        leaf["RANGE"] = [rng] * len(tag)
    return leaf


def _value(value: Any, tag: str) -> list[Any]:
    if isinstance(value, np.ndarray):
        value = value.tolist()
    values = list(value) if isinstance(value, (list, tuple)) else [value]
    out = []
    for v in values:
        if isinstance(v, float) and not math.isfinite(v):
            out.append(None)
        elif isinstance(v, np.generic):
            out.append(v.item())
        else:
            out.append(v)
    return out if len(out) == len(tag) else out[: len(tag)]


def _reading_leaf(path: str, r: Reading, value: Any) -> dict[str, Any]:
    """A node's reading (:class:`~pointat.node.Reading`): read-only numbers, with units and range."""
    tag = "f" * r.size
    leaf: dict[str, Any] = {
        "FULL_PATH": path,
        "TYPE": tag,
        "ACCESS": _ACCESS_READ,
        "DESCRIPTION": r.doc,
        "VALUE": _numbers(value, r.size),
        "UNIT": [UNITS.get(u, u) for u in r.units],
    }
    if r.minimum is not None or r.maximum is not None:
        rng = {k: v for k, v in (("MIN", r.minimum), ("MAX", r.maximum)) if v is not None}
        leaf["RANGE"] = [rng] * r.size
    return leaf


def _read(node: Any) -> Mapping[str, Any]:
    """What a node's :meth:`~pointat.node.Node.read` says now (nothing when it fails: a reading from
    another thread can meet the node changing)."""
    try:
        return node.read()
    except Exception:
        log.debug("node '%s' (%s): read() failed", node.name, node.type_name, exc_info=True)
        return {}


def _numbers(value: Any, size: int) -> list[Any]:
    """A reading's value as OSCQuery's VALUE: ``size`` numbers, None for one not finite or missing."""
    given = [] if value is None else _value(value, "f" * size)
    numbers = [float(v) if isinstance(v, (int, float)) and math.isfinite(v) else None for v in given]
    return numbers + [None] * (size - len(numbers))


def _method_leaf(path: str, fn: Any) -> dict[str, Any]:
    params = [
        p
        for p in inspect.signature(fn).parameters.values()
        if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)
    ]
    tag = "".join(_TYPES.get(_annotation(p), "s") for p in params) or "N"
    doc = inspect.getdoc(fn) or ""
    return {"FULL_PATH": path, "TYPE": tag, "ACCESS": _ACCESS_WRITE, "DESCRIPTION": doc.split("\n\n")[0]}


def _annotation(p: inspect.Parameter) -> str:
    a = p.annotation
    name = a if isinstance(a, str) else getattr(a, "__name__", "")
    return {"float": "float", "int": "int", "bool": "bool", "str": "symbol"}.get(
        name.split("|")[0].strip(), "symbol"
    )


def _container(path: str, description: str = "") -> dict[str, Any]:
    node: dict[str, Any] = {"FULL_PATH": path, "CONTENTS": {}}
    if description:
        node["DESCRIPTION"] = description
    return node


def _place(root: dict[str, Any], path: str, leaf: dict[str, Any]) -> None:
    parts = [p for p in path.split("/") if p]
    here = root
    for i, part in enumerate(parts[:-1]):
        contents = here.setdefault("CONTENTS", {})
        here = contents.setdefault(part, _container("/" + "/".join(parts[: i + 1])))
    contents = here.setdefault("CONTENTS", {})
    old = contents.get(parts[-1], {})
    new = {**old, **leaf}
    if "CONTENTS" in old and "CONTENTS" in leaf:  # what was placed inside it first stays
        new["CONTENTS"] = {**leaf["CONTENTS"], **old["CONTENTS"]}
    contents[parts[-1]] = new


def address_space(rt: Any, description: str = "") -> dict[str, Any]:
    """The whole tree, as the root's JSON (``GET /``)."""
    root = _container("/", description or "pointat: a running patch's live parameters and methods")
    for name, node in rt.nodes.items():
        base = PREFIX + name
        doc = (type(node).__doc__ or "").strip().splitlines()
        # a container: each has its FULL_PATH (clients split it) and its CONTENTS, empty or not
        _place(
            root,
            base,
            {"FULL_PATH": base, "CONTENTS": {}, "DESCRIPTION": f"{node.type_name}: {doc[0] if doc else ''}"},
        )
        for p in type(node).params:
            if p.live:
                leaf = _param_leaf(f"{base}/{p.name}", node, p)
                if leaf is not None:
                    _place(root, leaf["FULL_PATH"], leaf)
        for attr in dir(type(node)):
            if attr.startswith("do_") and callable(getattr(node, attr, None)):
                fn = getattr(node, attr)
                _place(root, f"{base}/{attr[3:]}", _method_leaf(f"{base}/{attr[3:]}", fn))
        if type(node).readings:
            values = _read(node)
            for r in type(node).readings:
                _place(root, f"{base}/{r.name}", _reading_leaf(f"{base}/{r.name}", r, values.get(r.name)))
    presets = getattr(rt, "presets", None)
    if presets is not None and "preset" not in rt.nodes:
        names = presets.names()
        for verb, doc in (
            ("save", "save every live parameter as the named preset"),
            ("recall", "set the live parameters of the named preset"),
            ("delete", "forget the named preset"),
        ):
            leaf = {
                "FULL_PATH": f"{PREFIX}preset/{verb}",
                "TYPE": "s",
                "ACCESS": _ACCESS_WRITE,
                "DESCRIPTION": doc,
            }
            if verb != "save" and names:
                leaf["RANGE"] = [{"VALS": names}]
            _place(root, leaf["FULL_PATH"], leaf)
    if getattr(rt, "reloader", None) is not None and "patch" not in rt.nodes:
        path = f"{PREFIX}patch/reload"
        _place(
            root,
            path,
            {
                "FULL_PATH": path,
                "TYPE": "N",
                "ACCESS": _ACCESS_WRITE,
                "DESCRIPTION": "read the patch's file again and run it, keeping the state of the nodes "
                "that did not change",
            },
        )
    return root


def find(tree: dict[str, Any], path: str) -> dict[str, Any] | None:
    """The node at ``path`` in ``tree`` (``/`` is the root), or None."""
    here = tree
    for part in (p for p in path.split("/") if p):
        here = here.get("CONTENTS", {}).get(part)
        if here is None:
            return None
    return here


def value_of(rt: Any, path: str) -> list[Any] | None:
    """A readable address's value now (a live parameter, a node's reading), or None."""
    if not path.startswith(PREFIX):
        return None
    name, _, leaf = path[len(PREFIX) :].rpartition("/")
    node = rt.nodes.get(name)
    if node is None:
        return None
    for r in type(node).readings:
        if r.name == leaf:
            return _numbers(_read(node).get(leaf), r.size)
    p = type(node).param(leaf)
    if p is None or not p.live:
        return None
    tag = _TYPES.get(p.type, "f" * (p.size or 0))
    return _value(getattr(node.p, leaf), tag) if tag else None
