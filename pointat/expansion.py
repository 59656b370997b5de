"""Read a patch (native or Pd) and expand its abstractions into one flat patch.

:func:`read_spec` reads either format; :func:`expand` replaces every abstraction instance by its nodes
(``instance/node``), its arguments substituted, and rewires to them; :func:`rebase_paths` keeps relative
paths right in a patch written to another folder (``pointat convert``).
"""

from __future__ import annotations

import dataclasses
import os
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from . import patchfile, pdfile
from .errors import PatchError, Problem, Where, closest, shorten
from .patchfile import parse_patch, parse_value
from .registry import Registry
from .shipped import PREFIX, is_shipped
from .spec import (
    NodeDecl,
    PatchSpec,
    PortDecl,
    Wire,
    is_abstraction,
    is_pd_file,
    is_pd_text,
    path_kind,
    read_patch_bytes,
)

__all__ = ["expand", "flatten", "read_spec", "rebase_paths"]

_DOLLAR = re.compile(r"\$([A-Za-z_][A-Za-z0-9_]*|0)")


def read_spec(path: str | Path) -> PatchSpec:
    """Read a patch file of either format: Pure Data's by its extension (``.pd``) or its text (a Pd file
    saved as ``my.pat``, a download), else native.  Either way a regular file of at most
    :data:`~pointat.spec.MAX_PATCH_BYTES`."""
    raw = read_patch_bytes(path)
    if is_pd_file(path) or is_pd_text(raw):
        return pdfile.parse_pd(pdfile.decode(raw), str(path))
    return parse_patch(patchfile.decode(raw, str(path)), str(path))


# --------------------------------------------------------------------------- abstractions
def _names(args: Mapping[str, Any]) -> str:
    """The arguments a patch declares ($0, which every instance has, left out)."""
    return ", ".join(k for k in args if k != "0") or "none"


def _substitute(value: Any, args: Mapping[str, Any], where: Where | None) -> Any:
    if isinstance(value, list):
        return [_substitute(v, args, where) for v in value]
    if not isinstance(value, str) or "$" not in value:
        return value
    whole = _DOLLAR.fullmatch(value)
    if whole:
        key = whole.group(1)
        if key not in args:
            raise PatchError(f"${key} is not an argument (arguments: {_names(args)})", where)
        return args[key]

    def repl(m: re.Match) -> str:
        if m.group(1) not in args:
            raise PatchError(f"${m.group(1)} is not an argument (arguments: {_names(args)})", where)
        return str(args[m.group(1)])

    text = _DOLLAR.sub(repl, value)
    try:  # "$n" in "0.$n" makes a number; in a quoted text that reads as no value ("[glove $id] az") a text
        return parse_value(text)
    except ValueError:
        return text


def expand(spec: PatchSpec, _stack: tuple[str, ...] = (), _prefix: str = "") -> PatchSpec:
    """Replace every abstraction instance by its nodes (named ``instance/node``) and rewire to them.

    Arguments given to the instance override the abstraction's ``args`` defaults; ``$name`` is replaced
    in parameter values, ``$0`` by the instance's full name (``left/fuse`` for an instance ``fuse`` inside
    an instance ``left``: unique in the whole patch, however deep).  :class:`PatchError` lists every
    instance that cannot be expanded.
    """
    problems: list[Problem] = []
    out = _expand(spec, problems, _stack, _prefix)
    if problems:
        raise PatchError(problems)
    return out


#: (instance, port name) -> [(node, port)] for inlets; -> (node, port) for outlets
_InletMap = dict[tuple[str, str | int], list[tuple[str, str | int]]]
_OutletMap = dict[tuple[str, str | int], tuple[str, str | int]]


def _expand(
    spec: PatchSpec, problems: list[Problem], _stack: tuple[str, ...] = (), _prefix: str = ""
) -> PatchSpec:
    """:func:`expand`, its problems added to ``problems``: the instances that cannot be expanded are left
    out (with their wires), the rest is there to be checked."""
    if not _stack:  # the top patch: an abstraction checked, run or converted on its own has its defaults;
        # any other $name is a mistake at its own line, not one to meet inside an abstraction it is given to
        spec = _with_arguments(spec, {**spec.args, "0": Path(spec.path).stem})
        _stack = (os.path.realpath(spec.path),)  # (Path.resolve raises on a loop of links before 3.13)
    out = PatchSpec(path=spec.path, args=dict(spec.args))
    out.doc = spec.doc
    inlet_map: _InletMap = {}
    outlet_map: _OutletMap = {}
    failed: set[str] = set()
    for decl in spec.nodes:
        if not is_abstraction(decl.type):
            out.nodes.append(decl)
            continue
        try:
            sub = _instantiate(spec, decl, _stack, _prefix)
        except PatchError as exc:
            problems += exc.problems
            failed.add(decl.name)  # its wires would only repeat that it has no such inlet or outlet
            continue
        out.nodes += sub.nodes
        out.wires += sub.wires
        # an inlet's number counts names, not declarations: 'inlet a -> x' twice (a fan-out) is one inlet
        names = list(dict.fromkeys(port.name for port in sub.inlets))
        for port in sub.inlets:
            for key in (port.name, names.index(port.name)):
                inlet_map.setdefault((decl.name, key), []).append((port.node, port.port))
        names = list(dict.fromkeys(port.name for port in sub.outlets))
        for port in sub.outlets:
            for key in (port.name, names.index(port.name)):
                outlet_map[(decl.name, key)] = (port.node, port.port)
    instances = {d.name for d in spec.nodes if is_abstraction(d.type)}
    through = _Through(instances, failed, inlet_map, outlet_map, problems)
    out.inlets, out.outlets = through.ports(spec)
    out.wires += through.wires(spec)
    out.failed = failed  # type: ignore[attr-defined]  # (check: their wires are not "no such node")
    return out


@dataclasses.dataclass
class _Through:
    """A patch's abstraction instances once expanded: what their inlets and outlets lead to (and which
    failed), to lead the patch's own ports and wires through them; problems are added to ``problems``."""

    instances: set[str]
    failed: set[str]
    inlet_map: _InletMap
    outlet_map: _OutletMap
    problems: list[Problem]

    def ports(self, spec: PatchSpec) -> tuple[list[PortDecl], list[PortDecl]]:
        """This patch's own inlets and outlets: those that lead into an abstraction it holds, through to its
        nodes."""
        inlets, outlets = [], []
        for port in spec.inlets:
            if port.node not in self.instances:
                inlets.append(port)
            elif port.node not in self.failed:
                inner = self._into(port.node, port.port, port.where)
                inlets += [PortDecl(port.name, n, i, port.where) for n, i in inner or ()]
        for port in spec.outlets:
            if port.node not in self.instances:
                outlets.append(port)
            elif port.node not in self.failed:
                source = self._out_of(port.node, port.port, port.where)
                if source is not None:
                    outlets.append(PortDecl(port.name, *source, port.where))
        return inlets, outlets

    def wires(self, spec: PatchSpec) -> list[Wire]:
        """This patch's wires, those to or from an abstraction it holds led to and from its nodes (none of
        an instance that failed: its problem is said once)."""
        wires = []
        for w in spec.wires:
            if w.src in self.failed or w.dst in self.failed:
                continue
            srcs: list[tuple[str, str | int]] = [(w.src, w.outlet)]
            dsts: list[tuple[str, str | int]] | None = [(w.dst, w.inlet)]
            if w.src in self.instances:
                source = self._out_of(w.src, w.outlet, w.where)
                if source is None:
                    continue
                srcs = [source]
            if w.dst in self.instances:
                dsts = self._into(w.dst, w.inlet, w.where)
                if dsts is None:
                    continue
            wires += [Wire(s, o, d, i, w.where) for s, o in srcs for d, i in dsts]
        return wires

    def _into(self, node: str, port: str | int, where: Where | None) -> list[tuple[str, str | int]] | None:
        """Where instance ``node``'s inlet ``port`` leads; ``None``, the problem said, when it has none."""
        inner = self.inlet_map.get((node, port))
        if inner is None:
            self.problems.append(Problem(where, f"abstraction instance '{node}' has no inlet {port!r}"))
        return inner

    def _out_of(self, node: str, port: str | int, where: Where | None) -> tuple[str, str | int] | None:
        """What instance ``node``'s outlet ``port`` comes from; ``None``, the problem said, when it has
        none."""
        source = self.outlet_map.get((node, port))
        if source is None:
            self.problems.append(Problem(where, f"abstraction instance '{node}' has no outlet {port!r}"))
        return source


def _abstraction_path(parent: PatchSpec, decl: NodeDecl) -> Path:
    """The file of an abstraction instance: its type, relative to the patch that holds it."""
    return Path(os.path.realpath(Path(parent.path).parent / decl.type))  # a loop of links: read's error


def _instantiate(parent: PatchSpec, decl: NodeDecl, stack: tuple[str, ...], outer: str = "") -> PatchSpec:
    base = Path(parent.path).parent
    if "\0" in decl.type:
        raise PatchError(
            f"abstraction name {decl.type!r} holds a NUL character: no file is named so", decl.where
        )
    path = _abstraction_path(parent, decl)
    kind = path_kind(path)
    if kind == "folder":
        raise PatchError(f"abstraction '{decl.type}' is a folder ({path}), not a patch file", decl.where)
    if kind == "other":  # a device (/dev/zero), a FIFO: no end to read to, or none
        raise PatchError(
            f"abstraction '{decl.type}' is not a regular file ({path}): a patch is a text file", decl.where
        )
    if kind == "missing":
        near = [str(f.relative_to(base)) for f in (*base.glob("*.pat"), *base.glob("*/*.pat"))]
        hint = closest(decl.type, near)
        raise PatchError(
            f"abstraction file '{decl.type}' not found (looked in {base})"
            + (f"; did you mean '{hint}'?" if hint else ""),
            decl.where,
        )
    if kind != "file":  # a name too long, no permission...
        raise PatchError(f"abstraction '{shorten(decl.type)}': {kind}", decl.where)
    if str(path) in stack:
        loop = [Path(p).name for p in stack[stack.index(str(path)) :]] + [path.name]
        raise PatchError(
            f"abstraction '{decl.type}' includes itself"
            + (f": {' -> '.join(loop)}" if len(loop) > 2 else ""),
            decl.where,
        )
    try:
        sub = read_spec(path)
    except PatchError as exc:  # a file that cannot be read (unlike one with errors at its lines) is
        # the instance's problem, at the instance's line
        if any(p.where is not None and p.where.line for p in exc.problems):
            raise
        raise PatchError(
            f"abstraction '{shorten(decl.type)}': " + "; ".join(p.message for p in exc.problems), decl.where
        ) from None
    if decl.args:
        raise PatchError(
            f"abstraction '{decl.type}' takes named arguments ({', '.join(sub.args) or 'none'}), "
            f"not positional ones",
            decl.where,
        )
    unknown = [k for k in decl.params if k not in sub.args]
    if unknown:
        raise PatchError(
            f"abstraction '{decl.type}' has no argument {unknown[0]!r} (arguments: {', '.join(sub.args) or 'none'})",
            decl.where,
        )
    prefix = decl.name + "/"
    renamed = _with_arguments(sub, {**sub.args, **decl.params, "0": outer + decl.name})
    flat = expand(renamed, (*stack, str(path)), outer + prefix)
    for n in flat.nodes:
        n.name = prefix + n.name
    for w in flat.wires:
        w.src, w.dst = prefix + w.src, prefix + w.dst
    for p in (*flat.inlets, *flat.outlets):
        p.node = prefix + p.node
    return flat


def _with_arguments(sub: PatchSpec, args: Mapping[str, Any]) -> PatchSpec:
    """``sub`` with ``$name`` (and ``$0``) replaced by ``args`` in its nodes' values; every unknown one is
    an error at its line."""
    renamed = PatchSpec(path=sub.path, doc=sub.doc)
    problems: list[Problem] = []
    for n in sub.nodes:
        try:
            renamed.nodes.append(
                NodeDecl(
                    n.name,
                    n.type,
                    [_substitute(a, args, n.where) for a in n.args],
                    {k: _substitute(v, args, n.where) for k, v in n.params.items()},
                    n.where,
                )
            )
        except PatchError as exc:
            problems += exc.problems
    if problems:
        raise PatchError(problems)
    renamed.wires = list(sub.wires)
    renamed.inlets, renamed.outlets = sub.inlets, sub.outlets
    return renamed


def _set_arguments(
    spec: PatchSpec, overrides: Sequence[tuple[str, str, Any]], problems: list[Problem]
) -> tuple[PatchSpec, list[tuple[str, str, Any]]]:
    """``--set INSTANCE.ARG=value`` on an abstraction instance of ``spec`` gives the instance that
    argument (``--set tqt.mode=paper``); the other overrides are returned for the nodes."""
    instances = {d.name: d for d in spec.nodes if is_abstraction(d.type)}
    rest = [o for o in overrides if o[0] not in instances]
    if len(rest) == len(overrides):
        return spec, rest
    given: dict[str, dict[str, Any]] = {}
    for node, arg, value in overrides:
        if node not in instances:
            continue
        decl = instances[node]
        path = _abstraction_path(spec, decl)
        try:  # a missing or unreadable one is reported by expand
            known = read_spec(path).args if path_kind(path) == "file" else None
        except PatchError:
            known = None
        if known is not None and arg not in known:
            problems.append(
                Problem(
                    None,
                    f"--set {node}.{arg}: abstraction instance '{node}' ({decl.type}) has no argument "
                    f"'{arg}' (arguments: {', '.join(known) or 'none'}; its nodes are set as {node}/NODE.PARAM)",
                )
            )
        else:
            given.setdefault(node, {})[arg] = value
    nodes = [
        NodeDecl(d.name, d.type, d.args, {**d.params, **given[d.name]}, d.where) if d.name in given else d
        for d in spec.nodes
    ]
    return dataclasses.replace(spec, nodes=nodes), rest


def rebase_paths(spec: PatchSpec, registry: Registry, target_dir: str | Path) -> None:
    """Rewrite relative ``path`` parameters (given by name) and abstraction files so they still point at
    the same files from a patch saved in ``target_dir`` (``pointat convert`` to another folder).  Each is
    relative to the file it was written in: an expanded abstraction's nodes to the abstraction's folder.
    A file a shipped patch writes stays as it is written: the converted copy is the user's and writes
    beside itself, never into the shipped folder (the installed package)."""

    def moved(value: str, decl: NodeDecl, writes: bool = False) -> str:
        if Path(value).is_absolute() or value.startswith(PREFIX):  # (the package's file, from anywhere)
            return value
        written = (
            decl.where.file if decl.where is not None and not decl.where.file.startswith("<") else spec.path
        )
        if writes and is_shipped(written):
            return value
        return Path(os.path.relpath(Path(written).parent / value, target_dir)).as_posix()

    for decl in spec.nodes:
        if is_abstraction(decl.type):
            decl.type = moved(decl.type, decl)
            continue
        cls = registry.get(decl.type)
        if cls is None:
            continue
        for name, value in decl.params.items():
            p = cls.param(name)
            if p is not None and p.type == "path" and isinstance(value, str) and value:
                decl.params[name] = moved(value, decl, p.writes)


def flatten(spec: PatchSpec) -> PatchSpec:
    """``spec`` with its abstraction instances expanded into their nodes (named ``INSTANCE/NODE``), as a
    Pd file holds them, and a line of its header naming the instances; ``spec`` itself when it has none."""
    instances = [f"{n.name} ({n.type})" for n in spec.nodes if is_abstraction(n.type)]
    if not instances:
        return spec
    flat = expand(spec)
    note = f"Abstractions flattened, each into nodes named INSTANCE/NODE: {', '.join(instances)}."
    flat.doc = "\n".join([spec.doc, note]).strip("\n")
    return flat
