"""Check a patch: every problem at once, and warnings about what can never act.

:func:`check` never runs anything.  It expands abstractions (:mod:`pointat.expansion`), then passes over
the patch one concern at a time: names, the command line's ``--set``, each node (its type with a
close-name suggestion, every wrong parameter, ranges, files it reads or writes), an abstraction's own
ports, the wires (ends, ports, the kinds they carry), feedback loops with no delay.  A node refused in one
pass keeps its ports for the next, so one run says everything, in line order, each problem naming
``file:line`` and what was expected and found.  Warnings: one outlet feeding two inlets of one node
(whose order only the file knows), a node fed on cold inlets only or not at all, a source wired to
nothing, a patch or a chain that reaches no output, a chain deeper than the runtime's limit, a file a
node reads at start that is not there (an error where the files are read: ``pointat check`` and ``run``,
which share :func:`pointat.loader.ready`).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from . import shipped
from .errors import PatchError, Problem, Where, did_you_mean, shorten
from .expansion import _expand, _set_arguments
from .graphs import reached
from .node import MAX_DEPTH, Inlet, Node, Outlet, ParamError
from .patchfile import format_value
from .registry import Registry, default_registry
from .spec import NodeDecl, PatchSpec, Wire, is_abstraction, path_kind

__all__ = ["Checked", "Resolved", "check"]


@dataclass
class Resolved:
    decl: NodeDecl
    cls: type[Node]
    values: dict[str, Any]
    inlets: tuple[Inlet, ...]
    outlets: tuple[Outlet, ...]
    #: Where the node's files go when the patch names none (:func:`files_folder`).
    folder: Path | None = None


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
    recordings: :meth:`Node.check_files`), as ``pointat check`` and ``pointat run`` do
    (:func:`pointat.loader.ready`), and a missing one (not ``optional``) is an error, for the node cannot
    start without it; without ``read_files`` (``graph``, ``convert``) it is a warning.  The passes below
    each say what they find and leave the rest to the next, so that one run finds every problem.
    """
    run = _Run(registry or default_registry, read_files)
    run.expand(spec, overrides)
    for step in (_names, _overrides, _nodes, _own_ports, _wires):
        step(run)
    result = run.result
    for finder in (_never_triggered, _going_nowhere):
        result.warnings += finder(result)
    if not run.flat.nodes:  # all comments, or a file of another kind: it would run and do nothing
        result.warnings.append(
            Problem(Where(run.flat.path), "the patch has no nodes: it does nothing", "warning")
        )
    edges = _hot_edges(result)
    run.problems += _cycles(result, edges)  # among the nodes and wires that are right: said with the rest
    result.warnings += _too_deep(result, edges)
    if run.problems:
        raise PatchError(_in_line_order(run.problems))
    return result


Ports = tuple[tuple[Inlet, ...], tuple[Outlet, ...]]


@dataclass
class _Run:
    """What the passes of one :func:`check` share."""

    registry: Registry
    read_files: bool
    problems: list[Problem] = field(default_factory=list)
    flat: PatchSpec = field(default_factory=lambda: PatchSpec(path="<patch>"))
    result: Checked = field(default_factory=lambda: Checked(PatchSpec(path="<patch>")))
    overrides: list[tuple[str, str, Any]] = field(default_factory=list)
    names: dict[str, NodeDecl] = field(default_factory=dict)
    over: dict[str, dict[str, Any]] = field(default_factory=dict)  # node -> --set values
    argued: dict[str, list[str]] = field(default_factory=dict)  # instance -> its --set arguments
    refused: dict[str, Ports] = field(default_factory=dict)  # refused nodes' ports, for their wires
    out: Path = field(default_factory=Path)  # where a shipped patch's files go (PatchSpec.out)
    instances: dict[str, NodeDecl] = field(default_factory=dict)  # the patch's own abstraction instances

    def expand(self, spec: PatchSpec, overrides: Sequence[tuple[str, str, Any]]) -> None:
        """Instances' arguments from the command line, then the abstractions expanded (what cannot be
        is said, the rest is still checked)."""
        instances = {d.name for d in spec.nodes if is_abstraction(d.type)}
        for node, arg, value in overrides:
            if node in instances:
                self.argued.setdefault(node, []).append(f"--set {node}.{arg}={format_value(value)}")
        spec, self.overrides = _set_arguments(spec, overrides, self.problems)
        self.instances = {d.name: d for d in spec.nodes if is_abstraction(d.type)}
        self.flat = _expand(spec, self.problems)
        self.out = Path(spec.out or ".").absolute()
        self.result = Checked(self.flat)

    def refuse(self, decl: NodeDecl, message: str, at: Where | None | str = "decl") -> None:
        where = decl.where if at == "decl" else at
        self.problems.append(self._at_instance(decl, where, message))  # type: ignore[arg-type]

    def _at_instance(self, decl: NodeDecl, where: Where | None, message: str) -> Problem:
        """A node of an abstraction refused: said at the line of the user's patch that made the instance
        (whose arguments are the likely cause, and the file the user can change), naming both places."""
        top = self.instances.get(decl.name.split("/", 1)[0]) if "/" in decl.name else None
        if top is None or top.where is None or where is None or where.file == top.where.file:
            return Problem(where, message)
        inner = os.path.relpath(where.file, Path(top.where.file).parent)
        return Problem(top.where, f"{message} (in abstraction {inner}:{where.line}, created at {top.where})")

    def hint(self, name: str) -> str:
        """What the command line gave that may be to blame for a refusal at the file's line."""
        own = [f"--set {name}.{k}={format_value(v)}" for k, v in self.over.get(name, {}).items()]
        given = self.argued.get(name.split("/", 1)[0], []) if "/" in name else []
        return "".join(
            f" ({what}: {', '.join(items)})"
            for what, items in (("given on the command line", own), ("its instance's arguments given", given))
            if items
        )

    def set_aside(self, cls: type[Node], decl: NodeDecl, values: Mapping[str, Any] | None) -> None:
        """A refused node: the ports its declaration gives, so that its wires are checked all the same."""
        try:
            self.refused[decl.name] = cls.layout(
                values if values is not None else {p.name: p.default for p in cls.params}
            )
        except Exception:  # (a layout that needs the refused value): the class's own ports
            self.refused[decl.name] = (cls.inlets, cls.outlets)

    def ports(self, name: str) -> Ports | None:
        r = self.result.nodes.get(name)
        return (r.inlets, r.outlets) if r is not None else self.refused.get(name)


def _names(run: _Run) -> None:
    """Every node name once (a hand-written 'a/b' meeting node 'b' of an instance 'a' says which is which)."""
    for decl in run.flat.nodes:
        first = run.names.get(decl.name)
        if first is None:
            run.names[decl.name] = decl
            continue
        run.refuse(
            decl,
            f"node '{decl.name}' is defined twice: {_origin(first, run.flat.path)} and "
            f"{_origin(decl, run.flat.path)}; rename one",
        )


def _overrides(run: _Run) -> None:
    """``--set NODE.PARAM=value``: NODE must be there."""
    for node, param, value in run.overrides:
        if node in run.names:
            run.over.setdefault(node, {})[param] = value
        else:
            run.problems.append(
                Problem(
                    None,
                    f"--set {node}.{param}: no node named '{node}'"
                    + _inside(node, param, run.names, run.registry),
                )
            )


def _nodes(run: _Run) -> None:
    """Each node: its type, its parameters (every one that is wrong), the command line's, its ranges and
    files; a node refused keeps its ports for the wires."""
    for decl in run.names.values():
        cls = run.registry.get(decl.type)
        if cls is None:
            run.refuse(
                decl,
                f"node '{decl.name}': unknown node type "
                # (a NUL or a control character that an editor left in the box: shown, not hidden)
                + (f"'{decl.type}'" if decl.type.isprintable() else repr(decl.type))
                + did_you_mean(decl.type, run.registry.names()),
            )
            continue
        values = _parameters(run, decl, cls)
        if values is not None:
            _node_files(run, decl, cls, values)


def _parameters(run: _Run, decl: NodeDecl, cls: type[Node]) -> dict[str, Any] | None:
    """The node's values, resolved and validated; None (problems said, ports set aside) when refused."""
    label = f"node '{decl.name}' ({decl.type})"
    try:
        values = cls.resolve_params(decl.args, decl.params)
    except (ParamError, ValueError) as exc:
        run.refuse(decl, f"{label}: {exc}{run.hint(decl.name)}")
        partial = getattr(exc, "partial", None)
        if partial is not None:  # the ranges of the values that did fit, said now too
            try:
                cls.validate(partial)
            except (ParamError, ValueError) as more:
                if str(more) not in str(exc):
                    run.refuse(decl, f"{label}: {more}{run.hint(decl.name)}")
            except Exception:  # (a check that needs the refused value)
                pass
        run.set_aside(cls, decl, partial)
        return None
    refused = False
    for key, value in run.over.get(decl.name, {}).items():  # the command line's, not the file's, to blame
        p = cls.param(key)
        try:
            if p is None:
                raise ParamError(cls.unknown_param(key))
            values[key] = p.coerce(value)
        except (ParamError, ValueError) as exc:
            run.problems.append(
                Problem(None, f"--set {decl.name}.{key}: node '{decl.name}' ({decl.type}): {exc}")
            )
            refused = True
    if refused:
        run.set_aside(cls, decl, values)
        return None
    try:
        _anchor_paths(cls, values, decl, run.over.get(decl.name, {}), run.out)
        for p in cls.params:
            if p.writes and values.get(p.name):
                _writable(p.name, values[p.name])
        cls.validate(values)
        ins, outs = cls.layout(values)
    except (ParamError, ValueError) as exc:
        run.refuse(decl, f"{label}: {exc}{run.hint(decl.name)}")
        run.set_aside(cls, decl, values)
        return None
    run.result.nodes[decl.name] = Resolved(decl, cls, values, ins, outs, files_folder(decl.where, run.out))
    return values


def _node_files(run: _Run, decl: NodeDecl, cls: type[Node], values: dict[str, Any]) -> None:
    """The files a node reads as it starts: a missing one is a warning; with ``read_files``, read."""
    label = f"node '{decl.name}' ({decl.type})"
    files = [p.name for p in cls.params if p.reads and values.get(p.name)]
    kinds = {name: path_kind(values[name]) for name in files}
    optional = {p.name for p in cls.params if p.optional}
    missing = [name for name in files if kinds[name] == "missing" and name not in optional]
    for name in files:
        if kinds[name] not in ("file", "missing"):  # a folder, a device or a pipe (which would hang)...
            what = "not a regular file" if kinds[name] in ("folder", "other") else kinds[name]
            run.refuse(decl, f"{label}: parameter '{name}': {shorten(str(values[name]))}: {what}")
            return
    for name in missing:  # an error where the files are read (pointat check and run): it would not start
        message = f"{label}: parameter '{name}': no file {values[name]!r} (it cannot start without it)"
        if run.read_files:
            run.refuse(decl, message + run.hint(decl.name))
        else:
            run.result.warnings.append(Problem(decl.where, message, "warning"))
    if run.read_files and files and not missing:
        try:
            cls.check_files(values)
        except Exception as exc:  # what building or starting the node would say
            run.refuse(decl, f"{label}: {exc}{run.hint(decl.name)}")


def _own_ports(run: _Run) -> None:
    """An abstraction checked on its own: where its inlets and outlets lead must exist."""
    for head, ports, side in (("inlet", run.flat.inlets, 0), ("outlet", run.flat.outlets, 1)):
        arrow = "->" if head == "inlet" else "<-"
        for port in ports:
            what = f"{head} {port.name} {arrow} {port.node}.{port.port}"
            if port.node not in run.names:
                run.problems.append(Problem(port.where, f"{what}: no node named '{port.node}'"))
                continue
            theirs = run.ports(port.node)
            if theirs is not None and _port_index(theirs[side], port.port) is None:
                run.problems.append(
                    Problem(
                        port.where,
                        f"{what}: node '{port.node}' ({run.names[port.node].type}) has no {head} "
                        f"{port.port!r}; {head}s are {_port_list(theirs[side])}",
                    )
                )


def _wires(run: _Run) -> None:
    """Each wire: its ends, their ports (also of refused nodes), the kinds they send and take; then
    one outlet into several inlets of one node (a warning: the file's order decides)."""
    fan: dict[tuple[str, int, str], list[Wire]] = {}
    for w in run.flat.wires:
        missing = [end for end in (w.src, w.dst) if end not in run.names]
        for end in missing:
            run.problems.append(
                Problem(w.where, f"wire {w}: no node named '{end}'" + did_you_mean(end, run.names))
            )
        if missing:
            continue
        o = _wire_end(run, w, w.src, 1, w.outlet)
        i = _wire_end(run, w, w.dst, 0, w.inlet)
        if o is None or i is None or w.src not in run.result.nodes or w.dst not in run.result.nodes:
            continue
        s, d = run.result.nodes[w.src], run.result.nodes[w.dst]
        if not _kinds_meet(s.outlets[o], d.inlets[i]):
            run.problems.append(
                Problem(
                    w.where,
                    f"wire {w}: outlet '{s.outlets[o].name}' sends {s.outlets[o].kind}, inlet "
                    f"'{d.inlets[i].name}' of '{w.dst}' accepts {'|'.join(d.inlets[i].accepts)}",
                )
            )
            continue
        run.result.wires.append((w.src, o, w.dst, i))
        fan.setdefault((w.src, o, w.dst), []).append(w)
    for (src, o, dst), ws in fan.items():
        if len(ws) > 1:
            run.result.warnings.append(
                Problem(
                    ws[-1].where,
                    f"outlet {o} of '{src}' feeds {len(ws)} inlets of '{dst}': they receive "
                    f"in wire order ({', '.join(str(w.inlet) for w in ws)}); use a trigger to make it explicit",
                    "warning",
                )
            )


def _wire_end(run: _Run, w: Wire, name: str, side: int, port: str | int) -> int | None:
    """The index of a wire's port at node ``name`` (side 0: inlets, 1: outlets), or None (said, when
    the node's ports are known)."""
    ports = run.ports(name)
    if ports is None:
        return None
    index = _port_index(ports[side], port)
    if index is None:
        head = ("inlet", "outlet")[side]
        run.problems.append(
            Problem(
                w.where,
                f"wire {w}: node '{name}' ({run.names[name].type}) has no {head} {port!r}; "
                f"{head}s are {_port_list(ports[side])}",
            )
        )
    return index


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
        if name not in fed and r.cls.bus_end != "sends":  # (a send may be fed by a msg's "; bus")
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
    for send, receives in _bus_links(result).items():  # a receive is fed by the sends of its bus
        for name in receives:
            feeders.setdefault(name, []).append(send)
    useful = reached(useful, lambda n: feeders.get(n, ()))
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
    kind = path_kind(path)
    if kind == "folder":
        raise ValueError(f"parameter '{name}': {value!r} is a folder: name a file in it")
    if kind not in ("file", "missing", "other"):  # (other: /dev/null, a FIFO a reader waits on: writable)
        raise ValueError(f"parameter '{name}': {shorten(value)}: {kind}")
    folder = path.parent
    kind = path_kind(folder)
    if kind != "folder":
        what = {"missing": "does not exist", "file": "is a file, not a folder"}.get(
            kind, f"cannot be: {kind}"
        )
        raise ValueError(f"parameter '{name}': cannot write {value!r}: the folder {str(folder)!r} {what}")


def files_folder(where: Where | None, out: Path) -> Path | None:
    """The folder a node's relative files written in its patch go to (:func:`_anchor_paths`), for a file
    the node names itself (``midi_out``'s ``NODE.mid`` when there is no MIDI port): beside the patch file,
    as in Pd, or ``out`` for a shipped patch, which is read-only; None for a patch read from no file."""
    if where is None or where.file.startswith("<"):
        return None
    return out if shipped.is_shipped(where.file) else Path(where.file).parent


def _anchor_paths(
    cls: type[Node], values: dict[str, Any], decl: NodeDecl, overridden: Mapping[str, Any], out: Path
) -> None:
    """Relative ``path`` parameters written in a patch are relative to that patch file (as in Pd),
    except in a shipped patch, which is read-only: what it writes goes to ``out``, what it reads is the
    user's copy there first (:func:`pointat.shipped.place`); those given on the command line (``--set``)
    stay relative to the working directory; ``pointat:...`` names a file the package ships."""
    for p in cls.params:  # pointat:data/... is the package's, from anywhere (pointat.shipped)
        v = values.get(p.name)
        if p.type == "path" and isinstance(v, str) and v.startswith(shipped.PREFIX):
            values[p.name] = shipped.resolve(v)
    if decl.where is None or decl.where.file.startswith("<"):
        return
    base = Path(decl.where.file).parent
    read_only = shipped.is_shipped(decl.where.file)
    for p in cls.params:
        v = values.get(p.name)
        if p.type == "path" and v and p.name not in overridden and not Path(v).is_absolute():
            if read_only:
                values[p.name] = shipped.place(v, base, out, reads=p.reads, writes=p.writes)
            else:
                values[p.name] = str(base / v)


def _too_deep(result: Checked, edges: dict[str, list[str]]) -> list[Problem]:
    """A chain through hot inlets longer than the runtime's :data:`~pointat.node.MAX_DEPTH` (no loop in
    it; loops are :func:`_cycles`'): messages stop there, as Pd's "stack overflow" stops them."""
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
    for send, receives in _bus_links(result).items():
        edges[send] += receives
    return edges


def _bus_links(result: Checked) -> dict[str, list[str]]:
    """Each node that sends on a bus (``send``) -> the nodes that hear it (``receive``)."""
    buses: dict[str, list[str]] = {}
    for name, r in result.nodes.items():
        if r.cls.bus_end == "hears":
            buses.setdefault(str(r.values.get("bus")), []).append(name)
    return {
        name: buses.get(str(r.values.get("bus")), [])
        for name, r in result.nodes.items()
        if r.cls.bus_end == "sends"
    }


def _cycles(result: Checked, edges: dict[str, list[str]]) -> list[Problem]:
    """Feedback loops through hot inlets with no deferring node (delay, metro) on them (``edges``:
    :func:`_hot_edges`)."""
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
