"""Load a patch: read it (native or Pd), expand abstractions, check it against the registry, build it.

:func:`check` finds every problem at once and never runs anything: unknown node types (with a close-name
suggestion), unknown inlets and outlets, bad or missing parameters, wrong value types, wires whose kinds
cannot meet, feedback loops with no delay, and warnings: one outlet feeding two inlets of one node (whose
order only the file knows), a node fed on cold inlets only (it never outputs), a file a node reads at
start that is not there.  Every problem names ``file:line`` and what was expected and found.
"""

from __future__ import annotations

import dataclasses
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .errors import PatchError, Problem, Where, closest, did_you_mean
from .node import MAX_DEPTH, Inlet, Node, Outlet, ParamError
from .patchfile import format_value, parse_value, read_patch
from .registry import Registry, default_registry
from .runtime import Runtime
from .spec import NodeDecl, PatchSpec, PortDecl, Wire, is_abstraction, is_pd_file

__all__ = ["Checked", "build", "check", "expand", "load", "read_spec"]

_DOLLAR = re.compile(r"\$([A-Za-z_][A-Za-z0-9_]*|0)")


def read_spec(path: str | Path) -> PatchSpec:
    """Read a patch file of either format, by its extension (``.pd`` is Pure Data, the rest native; a
    native file whose text is Pd's is read as Pd)."""
    path = Path(path)
    if is_pd_file(path):
        from .pdfile import read_pd

        return read_pd(path)
    return read_patch(path)


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


def _expand(
    spec: PatchSpec, problems: list[Problem], _stack: tuple[str, ...] = (), _prefix: str = ""
) -> PatchSpec:
    """:func:`expand`, its problems added to ``problems``: the instances that cannot be expanded are left
    out (with their wires), the rest is there to be checked."""
    if not _stack:  # the top patch: an abstraction checked, run or converted on its own has its defaults;
        # any other $name is a mistake at its own line, not one to meet inside an abstraction it is given to
        spec = _with_arguments(spec, {**spec.args, "0": Path(spec.path).stem})
        _stack = (str(Path(spec.path).resolve()),)
    out = PatchSpec(path=spec.path, args=dict(spec.args))
    out.doc = spec.doc
    # (instance, port name) -> [(node, port)] for inlets; -> (node, port) for outlets
    inlet_map: dict[tuple[str, str | int], list[tuple[str, str | int]]] = {}
    outlet_map: dict[tuple[str, str | int], tuple[str, str | int]] = {}
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
    # this patch's own inlets and outlets may lead into an abstraction it holds: through to its nodes
    out.inlets, out.outlets = [], []
    for port in spec.inlets:
        if port.node not in instances:
            out.inlets.append(port)
        elif port.node not in failed:
            inner = inlet_map.get((port.node, port.port))
            if inner is None:
                problems.append(
                    Problem(port.where, f"abstraction instance '{port.node}' has no inlet {port.port!r}")
                )
                continue
            out.inlets += [PortDecl(port.name, n, i, port.where) for n, i in inner]
    for port in spec.outlets:
        if port.node not in instances:
            out.outlets.append(port)
        elif port.node not in failed:
            if (port.node, port.port) not in outlet_map:
                problems.append(
                    Problem(port.where, f"abstraction instance '{port.node}' has no outlet {port.port!r}")
                )
                continue
            n, o = outlet_map[(port.node, port.port)]
            out.outlets.append(PortDecl(port.name, n, o, port.where))
    for w in spec.wires:
        if w.src in failed or w.dst in failed:
            continue
        srcs = [(w.src, w.outlet)]
        dsts = [(w.dst, w.inlet)]
        if w.src in instances:
            if (w.src, w.outlet) not in outlet_map:
                problems.append(
                    Problem(w.where, f"abstraction instance '{w.src}' has no outlet {w.outlet!r}")
                )
                continue
            srcs = [outlet_map[(w.src, w.outlet)]]
        if w.dst in instances:
            if (w.dst, w.inlet) not in inlet_map:
                problems.append(Problem(w.where, f"abstraction instance '{w.dst}' has no inlet {w.inlet!r}"))
                continue
            dsts = inlet_map[(w.dst, w.inlet)]
        for s, o in srcs:
            for d, i in dsts:
                out.wires.append(Wire(s, o, d, i, w.where))
    out.failed = failed  # type: ignore[attr-defined]  # (check: their wires are not "no such node")
    return out


def _abstraction_path(parent: PatchSpec, decl: NodeDecl) -> Path:
    """The file of an abstraction instance: its type, relative to the patch that holds it."""
    return (Path(parent.path).parent / decl.type).resolve()


def _instantiate(parent: PatchSpec, decl: NodeDecl, stack: tuple[str, ...], outer: str = "") -> PatchSpec:
    base = Path(parent.path).parent
    if "\0" in decl.type:
        raise PatchError(
            f"abstraction name {decl.type!r} holds a NUL character: no file is named so", decl.where
        )
    path = _abstraction_path(parent, decl)
    if path.is_dir():
        raise PatchError(f"abstraction '{decl.type}' is a folder ({path}), not a patch file", decl.where)
    if path.exists() and not path.is_file():  # a device (/dev/zero), a FIFO: no end to read to, or none
        raise PatchError(
            f"abstraction '{decl.type}' is not a regular file ({path}): a patch is a text file", decl.where
        )
    if not path.exists():
        near = [str(f.relative_to(base)) for f in (*base.glob("*.pat"), *base.glob("*/*.pat"))]
        hint = closest(decl.type, near)
        raise PatchError(
            f"abstraction file '{decl.type}' not found (looked in {base})"
            + (f"; did you mean '{hint}'?" if hint else ""),
            decl.where,
        )
    if str(path) in stack:
        loop = [Path(p).name for p in stack[stack.index(str(path)) :]] + [path.name]
        raise PatchError(
            f"abstraction '{decl.type}' includes itself"
            + (f": {' -> '.join(loop)}" if len(loop) > 2 else ""),
            decl.where,
        )
    sub = read_spec(path)
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


# --------------------------------------------------------------------------- checking
@dataclass
class Resolved:
    decl: NodeDecl
    cls: type[Node]
    values: dict[str, Any]
    inlets: tuple[Inlet, ...]
    outlets: tuple[Outlet, ...]


@dataclass
class Checked:
    """A checked patch: resolved nodes, wires as indices, and the warnings."""

    spec: PatchSpec
    nodes: dict[str, Resolved] = field(default_factory=dict)
    wires: list[tuple[str, int, str, int]] = field(default_factory=list)
    warnings: list[Problem] = field(default_factory=list)


def _port_index(ports: Sequence[Inlet | Outlet], port: str | int) -> int | None:
    if isinstance(port, int):
        return port if 0 <= port < len(ports) else None
    for i, p in enumerate(ports):
        if p.name == port:
            return i
    return None


def _port_list(ports: Sequence[Inlet | Outlet]) -> str:
    return ", ".join(f"{p.name} ({i})" for i, p in enumerate(ports)) or "none"


def _kinds_meet(outlet: Outlet, inlet: Inlet) -> bool:
    if outlet.kind == "any" or "any" in inlet.accepts:
        return True
    numeric = {"float", "int"}
    if outlet.kind in numeric and numeric & set(inlet.accepts):
        return True
    return outlet.kind in inlet.accepts


def _origin(decl: NodeDecl, top: str) -> str:
    """Where a node of an expanded patch comes from (``top``: the patch's own file), for a message
    that names two of them."""
    if decl.where is None:
        return "at ?"
    instance, _, inner = decl.name.rpartition("/")
    if instance and decl.where.file != top:  # from an abstraction's file
        return f"at {decl.where} (node '{inner}' of instance '{instance}')"
    return f"at {decl.where}"


def check(
    spec: PatchSpec,
    registry: Registry | None = None,
    overrides: Sequence[tuple[str, str, Any]] = (),
    *,
    read_files: bool = False,
) -> Checked:
    """Expand and check ``spec``; raise :class:`PatchError` with every error, or return the result.

    ``overrides`` are ``(node, param, value)`` triples (``--set node.param=value``).  ``read_files``
    also reads the files that nodes read when they start (calibrations, loudspeaker layouts,
    recordings: :meth:`Node.check_files`), as ``pointat check`` does; a missing one is a warning either
    way (a calibration may be taken before the patch runs).
    """
    registry = registry or default_registry
    problems: list[Problem] = []
    instances = {d.name for d in spec.nodes if is_abstraction(d.type)}
    # an instance's arguments given on the command line: a node inside it that refuses a value says so
    argued: dict[str, list[str]] = {}
    for node, arg, value in overrides:
        if node in instances:
            argued.setdefault(node, []).append(f"--set {node}.{arg}={format_value(value)}")

    def hint(name: str) -> str:
        """What the command line gave that may be to blame for a refusal at the file's line."""
        own = [f"--set {name}.{k}={format_value(v)}" for k, v in over.get(name, {}).items()]
        given = argued.get(name.split("/", 1)[0], []) if "/" in name else []
        return "".join(
            f" ({what}: {', '.join(items)})"
            for what, items in (("given on the command line", own), ("its instance's arguments given", given))
            if items
        )

    spec, overrides = _set_arguments(spec, overrides, problems)
    flat = _expand(spec, problems)  # what cannot be expanded is said, the rest still checked
    result = Checked(flat)
    # nodes refused (a parameter, a range), with the ports their declaration gives, so that their wires
    # are checked in the same run
    refused_ports: dict[str, tuple[tuple[Inlet, ...], tuple[Outlet, ...]]] = {}

    def set_aside(cls: type[Node], decl: NodeDecl, values: Mapping[str, Any] | None) -> None:
        try:
            refused_ports[decl.name] = cls.layout(
                values if values is not None else {p.name: p.default for p in cls.params}
            )
        except Exception:  # (a layout that needs the refused value): the class's own ports
            refused_ports[decl.name] = (cls.inlets, cls.outlets)

    names: dict[str, NodeDecl] = {}
    for decl in flat.nodes:
        first = names.get(decl.name)
        if first is None:
            names[decl.name] = decl
            continue
        # (a hand-written 'a/b' meets node 'b' of an abstraction instance 'a': say which is which)
        problems.append(
            Problem(
                decl.where,
                f"node '{decl.name}' is defined twice: {_origin(first, flat.path)} and {_origin(decl, flat.path)}; rename one",
            )
        )
    over: dict[str, dict[str, Any]] = {}
    for node, param, value in overrides:
        if node not in names:
            problems.append(
                Problem(
                    None,
                    f"--set {node}.{param}: no node named '{node}'" + _inside(node, param, names, registry),
                )
            )
        else:
            over.setdefault(node, {})[param] = value
    for decl in names.values():
        cls = registry.get(decl.type)
        label = f"node '{decl.name}'"
        if cls is None:
            problems.append(
                Problem(
                    decl.where,
                    f"{label}: unknown node type "
                    # (a NUL or a control character that an editor left in the box: shown, not hidden)
                    + (f"'{decl.type}'" if decl.type.isprintable() else repr(decl.type))
                    + did_you_mean(decl.type, registry.names()),
                )
            )
            continue
        try:
            values = cls.resolve_params(decl.args, decl.params)
        except (ParamError, ValueError) as exc:
            problems.append(Problem(decl.where, f"{label} ({decl.type}): {exc}{hint(decl.name)}"))
            partial = getattr(exc, "partial", None)
            if partial is not None:  # the ranges of the values that did fit, said now too
                try:
                    cls.validate(partial)
                except (ParamError, ValueError) as more:
                    if str(more) not in str(exc):
                        problems.append(
                            Problem(decl.where, f"{label} ({decl.type}): {more}{hint(decl.name)}")
                        )
                except Exception:  # (a check that needs the refused value)
                    pass
            set_aside(cls, decl, partial)
            continue
        refused = False
        for key, value in over.get(decl.name, {}).items():  # the command line's, not the file's, to blame
            p = cls.param(key)
            try:
                if p is None:
                    raise ParamError(cls.unknown_param(key))
                values[key] = p.coerce(value)
            except (ParamError, ValueError) as exc:
                problems.append(Problem(None, f"--set {decl.name}.{key}: {label} ({decl.type}): {exc}"))
                refused = True
        if refused:
            set_aside(cls, decl, values)
            continue
        try:
            _anchor_paths(cls, values, decl, over.get(decl.name, {}))
            for p in cls.params:
                if p.writes and values.get(p.name):
                    _writable(p.name, values[p.name])
            cls.validate(values)
            ins, outs = cls.layout(values)
        except (ParamError, ValueError) as exc:
            problems.append(Problem(decl.where, f"{label} ({decl.type}): {exc}{hint(decl.name)}"))
            set_aside(cls, decl, values)
            continue
        result.nodes[decl.name] = Resolved(decl, cls, values, ins, outs)
        files = [p.name for p in cls.params if p.reads and values.get(p.name)]
        missing = [name for name in files if not Path(values[name]).exists()]
        for name in missing:
            result.warnings.append(
                Problem(
                    decl.where,
                    f"{label} ({decl.type}): parameter '{name}': no file {values[name]!r} "
                    "(it cannot start without it)",
                    "warning",
                )
            )
        if read_files and files and not missing:
            try:
                cls.check_files(values)
            except Exception as exc:  # what building or starting the node would say
                problems.append(Problem(decl.where, f"{label} ({decl.type}): {exc}{hint(decl.name)}"))
    # an abstraction checked on its own: where its inlets and outlets lead must exist
    for head, ports, side in (("inlet", flat.inlets, "inlets"), ("outlet", flat.outlets, "outlets")):
        arrow = "->" if head == "inlet" else "<-"
        for port in ports:
            what = f"{head} {port.name} {arrow} {port.node}.{port.port}"
            if port.node not in names:
                problems.append(Problem(port.where, f"{what}: no node named '{port.node}'"))
            elif port.node in result.nodes:
                r = result.nodes[port.node]
                if _port_index(getattr(r, side), port.port) is None:
                    problems.append(
                        Problem(
                            port.where,
                            f"{what}: node '{port.node}' ({r.decl.type}) has no {head} {port.port!r}; "
                            f"{side} are {_port_list(getattr(r, side))}",
                        )
                    )
    fan: dict[tuple[str, int, str], list[Wire]] = {}
    for w in flat.wires:
        ok = True
        for end in (w.src, w.dst):
            if end not in names:
                problems.append(
                    Problem(w.where, f"wire {w}: no node named '{end}'" + did_you_mean(end, names))
                )
                ok = False
        if not ok:
            continue

        def ports(name: str) -> tuple[tuple[Inlet, ...], tuple[Outlet, ...]] | None:
            r = result.nodes.get(name)
            return (r.inlets, r.outlets) if r is not None else refused_ports.get(name)

        src_ports, dst_ports = ports(w.src), ports(w.dst)
        o = i = None
        if src_ports is not None:
            o = _port_index(src_ports[1], w.outlet)
            if o is None:
                problems.append(
                    Problem(
                        w.where,
                        f"wire {w}: node '{w.src}' ({names[w.src].type}) has no outlet {w.outlet!r}; "
                        f"outlets are {_port_list(src_ports[1])}",
                    )
                )
        if dst_ports is not None:
            i = _port_index(dst_ports[0], w.inlet)
            if i is None:
                problems.append(
                    Problem(
                        w.where,
                        f"wire {w}: node '{w.dst}' ({names[w.dst].type}) has no inlet {w.inlet!r}; "
                        f"inlets are {_port_list(dst_ports[0])}",
                    )
                )
        if o is None or i is None or w.src not in result.nodes or w.dst not in result.nodes:
            continue
        s, d = result.nodes[w.src], result.nodes[w.dst]
        if not _kinds_meet(s.outlets[o], d.inlets[i]):
            problems.append(
                Problem(
                    w.where,
                    f"wire {w}: outlet '{s.outlets[o].name}' sends {s.outlets[o].kind}, inlet "
                    f"'{d.inlets[i].name}' of '{w.dst}' accepts {'|'.join(d.inlets[i].accepts)}",
                )
            )
            continue
        result.wires.append((w.src, o, w.dst, i))
        fan.setdefault((w.src, o, w.dst), []).append(w)
    for (src, o, dst), ws in fan.items():
        if len(ws) > 1:
            result.warnings.append(
                Problem(
                    ws[-1].where,
                    f"outlet {o} of '{src}' feeds {len(ws)} inlets of '{dst}': they receive "
                    f"in wire order ({', '.join(str(w.inlet) for w in ws)}); use a trigger to make it explicit",
                    "warning",
                )
            )
    result.warnings += _never_triggered(result)
    result.warnings += _going_nowhere(result)
    if not flat.nodes:  # all comments, or a file of another kind: it would run and do nothing
        result.warnings.append(
            Problem(Where(flat.path), "the patch has no nodes: it does nothing", "warning")
        )
    problems += _cycles(result)  # among the nodes and wires that are right: said with the rest
    result.warnings += _too_deep(result)
    if problems:
        raise PatchError(_in_line_order(problems))
    return result


def _in_line_order(problems: list[Problem]) -> list[Problem]:
    """Problems in the order of the lines they are at: the command line's first, then each file's (in the
    order the files first come up) by line."""
    files: dict[str, int] = {}
    for p in problems:
        if p.where is not None:
            files.setdefault(p.where.file, len(files))

    def key(p: Problem) -> tuple[int, int, int]:
        return (0, 0, 0) if p.where is None else (1, files[p.where.file], p.where.line or 0)

    return sorted(problems, key=key)


def _inside(node: str, param: str, names: Mapping[str, NodeDecl], registry: Registry) -> str:
    """The rest of a "no node named" message: the nodes named ``node/...`` that have ``param``, when
    ``node`` is a subpatch of a ``.pd`` file or an abstraction instance that ``convert`` flattened; else
    the nodes there are."""
    inner = [n for n, d in names.items() if n.startswith(node + "/")]
    if not inner:
        return f" (nodes: {', '.join(names)})"
    having = [n for n in inner if (cls := registry.get(names[n].type)) is not None and cls.param(param)]
    return f" but nodes inside it, a subpatch or a converted abstraction ({', '.join(inner)}); set " + (
        " or ".join(f"{n}.{param}" for n in having)
        if having
        else f"one of them (none has a parameter '{param}')"
    )


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
        known = read_spec(path).args if path.is_file() else None  # a missing one is reported by expand
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


def _needs_input(cls: type[Node]) -> bool:
    return cls.pure if cls.needs_input is None else cls.needs_input


def _never_triggered(result: Checked) -> list[Problem]:
    """Nodes that act on their inputs (:attr:`Node.needs_input`: filters, conversions, sinks) fed on
    cold inlets only: they store what comes and never act (the wire to the hot inlet is missing, or went
    to a cold one by mistake); and those nothing is wired to at all."""
    fed: dict[str, set[int]] = {}
    for _src, _o, dst, i in result.wires:
        fed.setdefault(dst, set()).add(i)
    for port in result.spec.inlets:  # an abstraction checked on its own: its inlets feed from outside
        r = result.nodes.get(port.node)
        i = None if r is None else _port_index(r.inlets, port.port)
        if i is not None:
            fed.setdefault(port.node, set()).add(i)
    found = []
    live = _live_control(result)
    for name, r in result.nodes.items():
        if not _needs_input(r.cls) or not r.inlets:
            continue
        if name not in fed and not r.cls.type_name == "send":  # (a send may be fed by a msg's "; bus")
            if live and {"any", "bang"} & set(r.inlets[0].accepts):
                continue  # a button for live control (/pointat/press/bang): that is what it is there for
            found.append(
                Problem(
                    r.decl.where,
                    f"node '{name}' ({r.decl.type}): nothing is wired to it, so it never acts"
                    + (" (unless live control sends to it)" if live else ""),
                    "warning",
                )
            )
            continue
        hot = {i for i, inlet in enumerate(r.inlets) if inlet.is_hot(i)}
        if name in fed and hot and not fed[name] & hot:
            inlets = " or ".join(f"'{r.inlets[i].name}'" for i in sorted(hot))
            found.append(
                Problem(
                    r.decl.where,
                    f"node '{name}' ({r.decl.type}) is fed on cold inlets only: nothing reaches its hot "
                    f"inlet {inlets}, so it never acts"
                    + (" (unless live control sends to it)" if live else ""),
                    "warning",
                )
            )
    return found


def _live_control(result: Checked) -> bool:
    """Whether messages from outside may reach any node (an ``osc_in`` that takes live control)."""
    return any(r.cls.acts_alone and r.values.get("control", True) for r in result.nodes.values())


def _going_nowhere(result: Checked) -> list[Problem]:
    """What computes for nothing: a patch with no output at all; sources whose outlets are wired to
    nothing; the patch's own chains (not an abstraction's spare outlets) that reach no output."""
    if not result.nodes:
        return []
    found = []
    sinks = [n for n, r in result.nodes.items() if not r.cls.pure and r.inlets]
    if not sinks and not any(r.cls.acts_alone for r in result.nodes.values()) and not result.spec.outlets:
        found.append(
            Problem(
                Where(result.spec.path),
                "the patch has no output (osc_out, midi_out, print, record...): it computes and sends nothing",
                "warning",
            )
        )
        return found
    feeds = {src for src, _o, _d, _i in result.wires}
    for name, r in result.nodes.items():
        if r.outlets and not r.inlets and not r.cls.acts_alone and name not in feeds:
            if not any(p.node == name for p in result.spec.outlets):
                found.append(
                    Problem(
                        r.decl.where,
                        f"node '{name}' ({r.decl.type}): its outlets are wired to nothing",
                        "warning",
                    )
                )
    # pure nodes of the patch's own file fed but reaching no node with effects (the runtime skips them)
    useful = {n for n, r in result.nodes.items() if not r.cls.pure}
    useful |= {p.node for p in result.spec.outlets}
    feeders: dict[str, list[str]] = {}
    for src, _o, dst, _i in result.wires:
        feeders.setdefault(dst, []).append(src)
    for name, r in result.nodes.items():  # send -> receive: a receive's bus is fed by its sends
        if r.cls.type_name == "receive":
            feeders.setdefault(name, []).extend(
                n
                for n, s in result.nodes.items()
                if s.cls.type_name == "send" and s.values.get("bus") == r.values.get("bus")
            )
    stack = list(useful)
    while stack:
        for src in feeders.get(stack.pop(), ()):
            if src not in useful:
                useful.add(src)
                stack.append(src)
    own = result.spec.path
    idle = [
        n
        for n, r in result.nodes.items()
        if n not in useful
        and r.decl.where is not None
        and r.decl.where.file == own
        and n in feeds | set(feeders)
    ]
    if idle:
        found.append(
            Problem(
                result.nodes[idle[0]].decl.where,
                f"{', '.join(repr(n) for n in idle)}: what they compute reaches no output (osc_out, print, "
                "record...), so they are not run",
                "warning",
            )
        )
    return found


def _writable(name: str, value: str) -> None:
    """Refuse a file a node will write but could not: a folder, or a file in a folder that is not there
    (found at the desk, not when the show starts)."""
    path = Path(value)
    if path.is_dir():
        raise ValueError(f"parameter '{name}': {value!r} is a folder: name a file in it")
    folder = path.parent
    if not folder.is_dir():
        what = "is a file, not a folder" if folder.exists() else "does not exist"
        raise ValueError(f"parameter '{name}': cannot write {value!r}: the folder {str(folder)!r} {what}")


def _anchor_paths(
    cls: type[Node], values: dict[str, Any], decl: NodeDecl, overridden: Mapping[str, Any]
) -> None:
    """Relative ``path`` parameters written in a patch are relative to that patch file (as in Pd);
    those given on the command line (``--set``) stay relative to the working directory."""
    if decl.where is None or decl.where.file.startswith("<"):
        return
    base = Path(decl.where.file).parent
    for p in cls.params:
        v = values.get(p.name)
        if p.type == "path" and v and p.name not in overridden and not Path(v).is_absolute():
            values[p.name] = str(base / v)


def rebase_paths(spec: PatchSpec, registry: Registry, target_dir: str | Path) -> None:
    """Rewrite relative ``path`` parameters (given by name) and abstraction files so they still point at
    the same files from a patch saved in ``target_dir`` (``pointat convert`` to another folder).  Each is
    relative to the file it was written in: an expanded abstraction's nodes to the abstraction's folder."""

    def moved(value: str, decl: NodeDecl) -> str:
        if Path(value).is_absolute():
            return value
        written = (
            decl.where.file if decl.where is not None and not decl.where.file.startswith("<") else spec.path
        )
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
                decl.params[name] = moved(value, decl)


def _too_deep(result: Checked) -> list[Problem]:
    """A chain through hot inlets longer than the runtime's :data:`~pointat.node.MAX_DEPTH` (no loop in
    it; loops are :func:`_cycles`'): messages stop there, as Pd's "stack overflow" stops them."""
    edges = _hot_edges(result)
    into = {n: 0 for n in edges}
    for v in edges:
        for w in edges[v]:
            into[w] += 1
    depth = {n: 1 for n in edges}
    ready = [n for n, k in into.items() if k == 0]
    while ready:  # Kahn's order; what a loop holds never gets ready (and is _cycles' to say)
        v = ready.pop()
        for w in edges[v]:
            depth[w] = max(depth[w], depth[v] + 1)
            into[w] -= 1
            if into[w] == 0:
                ready.append(w)
    deepest = max(depth, key=depth.__getitem__, default=None)
    if deepest is None or depth[deepest] - 1 <= MAX_DEPTH:  # (hops between the nodes)
        return []
    return [
        Problem(
            result.nodes[deepest].decl.where,
            f"a chain of {depth[deepest]} nodes one after the other ends at '{deepest}': messages stop after "
            f"{MAX_DEPTH} (put a delay in it)",
            "warning",
        )
    ]


def _hot_edges(result: Checked) -> dict[str, list[str]]:
    """Node -> the nodes it sends to synchronously (a hot inlet, no deferring node between)."""
    edges: dict[str, list[str]] = {n: [] for n in result.nodes}
    for src, _o, dst, i in result.wires:
        s, d = result.nodes[src], result.nodes[dst]
        if d.inlets[i].is_hot(i) and not s.cls.defers:
            edges[src].append(dst)
    # send -> receive by bus name
    buses: dict[str, list[str]] = {}
    for name, r in result.nodes.items():
        if r.cls.type_name == "receive":
            buses.setdefault(str(r.values.get("bus")), []).append(name)
    for name, r in result.nodes.items():
        if r.cls.type_name == "send":
            edges[name] += buses.get(str(r.values.get("bus")), [])
    return edges


def _cycles(result: Checked) -> list[Problem]:
    """Feedback loops through hot inlets with no deferring node (delay, metro) on them."""
    edges = _hot_edges(result)
    # Tarjan's strongly connected components, iterative: a chain of thousands of nodes is no recursion
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    sccs: list[list[str]] = []

    def enter(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)

    for root in edges:
        if root in index:
            continue
        enter(root)
        work = [(root, iter(edges[root]))]
        while work:
            v, todo = work[-1]
            for w in todo:
                if w not in index:
                    enter(w)
                    work.append((w, iter(edges[w])))
                    break
                if w in on:
                    low[v] = min(low[v], index[w])
            else:  # every edge of v done
                work.pop()
                if work:
                    u = work[-1][0]
                    low[u] = min(low[u], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    sccs.append(comp)
    position = {name: k for k, name in enumerate(result.nodes)}
    problems = []
    for comp in sccs:
        if len(comp) > 1 or comp[0] in edges[comp[0]]:
            order = sorted(comp, key=position.__getitem__)
            where = result.nodes[order[0]].decl.where
            problems.append(
                Problem(
                    where,
                    f"feedback loop with no delay: {' -> '.join([*order, order[0]])}; "
                    f"messages would go round forever (put a delay or a cold inlet in the loop)",
                )
            )
    return problems


# --------------------------------------------------------------------------- building
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
