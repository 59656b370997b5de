"""Reading Pure Data files: records, canvases and boxes into a flat :class:`~pointat.spec.PatchSpec`."""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import PatchError, Problem, Where
from ..patchfile import parse_int, parse_value
from ..spec import NodeDecl, PatchSpec, Wire, read_patch_bytes
from .common import (
    _ATOM_BOXES,
    _INNER_ESCAPE,
    _INT,
    _KEY,
    _NAME_DY,
    _NOT_NAME,
    _NUMBER,
    MAX_SPLICES,
    NAME_TAG,
    _print_args,
    log,
)


# =========================================================================== reading: tokens and records
@dataclass
class _Record:
    """One record: its first line and its messages (split at unescaped commas; the first is the record)."""

    line: int
    messages: list[list[Any]]
    words: list[str] = field(default_factory=list)  # the record's tokens as written (escapes undone)

    @property
    def atoms(self) -> list[Any]:
        return self.messages[0]


class _Escaped(str):
    """A symbol that had an escape in the file: never a number; ``key=value`` only if its first ``=`` was
    not escaped (``keyable``)."""

    keyable = True


def _atom(text: str, escaped: bool, keyable: bool) -> Any:
    """A token -> int, float or str.  Escaped tokens are symbols; a lone escaped ``,``/``;`` is that atom.
    :class:`ValueError` for a whole number too large for a float (:func:`~pointat.patchfile.parse_int`)."""
    if escaped:
        # Pd 0.53 keeps the backslash of an escape inside a symbol and saves it as "\\\,": drop it too
        sym = _Escaped(_INNER_ESCAPE.sub(r"\1", text))
        sym.keyable = keyable
        return sym
    if _NUMBER.match(text):
        return parse_int(text) if _INT.match(text) else float(text)
    return text


def _records(text: str, path: str) -> list[_Record]:
    """Split Pd text into records, with the line on which each starts; :class:`PatchError` lists every
    number too large and a last record not ended."""
    records: list[_Record] = []
    problems: list[Problem] = []
    messages: list[list[Any]] = []
    atoms: list[Any] = []
    words: list[str] = []
    buf: list[str] = []
    escaped = False
    key: bool | None = None  # whether the token's first '=' was unescaped
    line, start, at = 1, 0, 0  # the line now, the record's first line, the token's
    i, n = 0, len(text)

    def flush() -> None:
        nonlocal escaped, key
        if buf:
            word = "".join(buf)
            try:
                atoms.append(_atom(word, escaped, bool(key)))
            except ValueError as exc:
                problems.append(Problem(Where(path, at), str(exc)))
                atoms.append(word)
            if not messages:
                words.append(word)
            buf.clear()
        escaped, key = False, None

    while i < n:
        c = text[i]
        if not (buf or atoms or messages) and not c.isspace():
            start = line
        if not buf:
            at = line
        if c == "\\" and i + 1 < n:
            nxt = text[i + 1]
            buf.append(nxt)
            escaped = True
            if nxt == "=" and key is None:
                key = False
            if nxt == "\n":
                line += 1
            i += 2
            continue
        i += 1
        if c == "\n":
            line += 1
        if c.isspace():
            flush()
        elif c == ";":
            flush()
            messages.append(atoms)
            records.append(_Record(start, messages, words))
            messages, atoms, words = [], [], []
        elif c == ",":
            flush()
            messages.append(atoms)
            atoms = []
        else:
            buf.append(c)
            if c == "=" and key is None:
                key = True
    flush()
    if atoms or messages:
        problems.append(
            Problem(
                Where(path, start), f"record not ended by ';' (starts with {_show(atoms or messages[0])})"
            )
        )
    if problems:
        raise PatchError(problems)
    return records


def _plain(atom: Any) -> Any:
    return str(atom) if isinstance(atom, str) else atom


def _comment_text(words: Sequence[str]) -> str:
    """A comment's words as the text Pd shows: apart, with ``,`` and ``;`` against the word before.

    >>> _comment_text(["send", "mag", ",", "then", "gyro", "1.", "0.50"])
    'send mag, then gyro 1. 0.50'
    """
    text = ""
    for word in words:
        text += word if not text or word in (",", ";") else " " + word
    return text


def _show(atoms: Sequence[Any]) -> str:
    text = " ".join(str(a) for a in atoms[:6])
    return repr(text + (" ..." if len(atoms) > 6 else ""))


# =========================================================================== reading: canvases and boxes
@dataclass
class _Box:
    """A box of a canvas: a node, a subpatch, an ``[inlet]``/``[outlet]``, or nothing (comment, declare)."""

    uid: int
    index: int
    line: int
    role: str  # "node", "sub", "port" (a control [inlet]/[outlet]) or "none"
    x: float = 0.0
    type: str = ""
    y: float = 0.0
    comment: bool = False  # a '#X text' record (never named by an @name)
    args: list[Any] = field(default_factory=list)
    params: dict[str, Any] = field(default_factory=dict)
    port: str = ""  # "in" or "out" for [inlet] [outlet] [inlet~] [outlet~]
    label: str = ""  # its @name
    sub_name: str = ""  # a subpatch's name ('pd NAME'), when it has no @name
    sub: _Canvas | None = None
    name: str = ""  # the final, unique node name
    dead: bool = False  # inside an array's graph: no node


@dataclass
class _Canvas:
    line: int
    boxes: list[_Box] = field(default_factory=list)
    #: its @name comments: (name, line, x, y, how many boxes came before it)
    labels: list[tuple[str, int, float, float, int]] = field(default_factory=list)
    dead: bool = False  # an array's graph: its content makes no nodes and no wires

    def kill(self) -> None:
        """Mark this canvas and every box in it, subpatches and theirs too, as no node (an array's graph)."""
        todo = [self]  # (not by recursion: subpatches may nest deeper than Python's stack)
        while todo:
            canvas = todo.pop()
            canvas.dead = True
            for b in canvas.boxes:
                b.dead = True
                if b.sub is not None:
                    todo.append(b.sub)

    def ports(self, kind: str) -> list[_Box]:
        """The canvas' inlets or outlets, ordered by x position (then box order), as Pd orders them."""
        return sorted((b for b in self.boxes if b.port == kind), key=lambda b: (b.x, b.index))


@dataclass
class _Connect:
    line: int
    canvas: _Canvas
    src: int
    outlet: int
    dst: int
    inlet: int


class _Reader:
    """Turns the records of one Pd file into a flat :class:`PatchSpec`."""

    def __init__(self, path: str):
        self.path = path
        self.problems: list[Problem] = []
        self.stack: list[_Canvas] = []
        self.root: _Canvas | None = None
        self.boxes: list[_Box] = []  # every box, in file order
        self.connects: list[_Connect] = []
        self.comments: list[tuple[float, float, str]] = []  # the top canvas' comments: y, x, text
        self.splices = MAX_SPLICES  # connections through [inlet]/[outlet] objects still to follow

    # ------------------------------------------------------------------ records
    def problem(self, line: int, message: str, box: int | None = None) -> None:
        self.problems.append(Problem(Where(self.path, line, box), message))

    def read(self, records: list[_Record]) -> PatchSpec:
        for rec in records:
            atoms = rec.atoms
            if not atoms:
                continue
            head = atoms[0]
            try:
                if head == "#N":
                    self.n_record(rec)
                elif head == "#X":
                    self.x_record(rec)
                elif not (isinstance(head, str) and re.fullmatch(r"#[A-Za-z]", head)):
                    raise ValueError(f"expected a record starting with #N, #X, #A..., got {_show(atoms)}")
            except ValueError as exc:
                self.problem(rec.line, str(exc))
        if self.root is None:
            # (at line 1, where a Pd file's first record, its canvas, is)
            raise PatchError(f"not a Pd file: no '#N canvas' record in {self.path}", Where(self.path, 1))
        while len(self.stack) > 1:
            inner = self.stack.pop()
            self.problem(inner.line, "subpatch never closed by '#X restore'")
        self.close(self.root)
        return self.finish()

    def n_record(self, rec: _Record) -> None:
        if len(rec.atoms) > 1 and rec.atoms[1] == "canvas":
            canvas = _Canvas(rec.line)
            if self.root is None:
                self.root = canvas
            self.stack.append(canvas)

    def x_record(self, rec: _Record) -> None:
        atoms = rec.atoms
        kind = atoms[1] if len(atoms) > 1 else ""
        if not self.stack:
            raise ValueError(f"'#X {kind}' before any '#N canvas'")
        canvas = self.stack[-1]
        if kind == "connect":
            nums = atoms[2:]
            if len(nums) != 4 or not all(isinstance(a, int) and a >= 0 for a in nums):
                raise ValueError(
                    f"expected '#X connect SRC OUTLET DST INLET' (4 whole numbers), got {_show(atoms)}"
                )
            self.connects.append(_Connect(rec.line, canvas, *nums))
        elif kind == "text":
            self.add(canvas, rec, "none")
            words = atoms[4:]
            if words and words[0] == NAME_TAG:
                if len(words) != 2:
                    raise ValueError(f"expected '{NAME_TAG} NODENAME', got {_show(words)}")
                box = canvas.boxes[-1]
                canvas.labels.append((str(words[1]), rec.line, box.x, box.y, len(canvas.boxes)))
            elif words and canvas is self.root:
                self.comments.append((float(atoms[3]), float(atoms[2]), _comment_text(rec.words[4:])))
        elif kind == "obj":
            cls = atoms[4] if len(atoms) > 4 else None
            if cls is None or cls == "declare":
                self.add(canvas, rec, "none")
            elif cls in ("inlet", "outlet"):
                self.add(canvas, rec, "port").port = "in" if cls == "inlet" else "out"
            else:
                box = self.add(canvas, rec, "node", str(cls))
                if cls == "print":  # "a=b" is a word of Pd's print prefix, but "time=1" sets pointat's
                    self.arguments(box, atoms[5:], rec.line, keys=("prefix", "time", "decimals"))
                    box.args = _print_args(box.args)
                else:
                    self.arguments(box, atoms[5:], rec.line)
                if cls in ("inlet~", "outlet~"):
                    box.port = "in" if cls == "inlet~" else "out"
        elif kind == "msg":
            self.add(canvas, rec, "node", "msg").args = [_plain(a) for a in atoms[4:]]
        elif kind in _ATOM_BOXES:
            self.add(canvas, rec, "node", kind)
        elif kind == "scalar":  # '#X scalar TEMPLATE x y ...': no x y up front
            self.add(canvas, _Record(rec.line, [["#X", "scalar", 0, 0]]), "node", "scalar")
        elif kind == "restore":
            self.restore(rec)
        elif kind not in ("coords", "declare", "f", "array", "pop"):
            log.warning("%s:%d: skipped an unknown record '#X %s'", self.path, rec.line, kind)

    def add(self, canvas: _Canvas, rec: _Record, role: str, type_: str = "") -> _Box:
        """A new box at the end of ``canvas`` (its ``@name``, if any, is given when the canvas closes)."""
        atoms = rec.atoms
        if len(atoms) < 4 or not all(isinstance(a, (int, float)) for a in atoms[2:4]):
            raise ValueError(f"expected '#X {atoms[1]} X Y ...' with a numeric position, got {_show(atoms)}")
        box = _Box(
            len(self.boxes), len(canvas.boxes), rec.line, role, float(atoms[2]), type_, float(atoms[3])
        )
        box.comment = atoms[1] == "text"
        canvas.boxes.append(box)
        self.boxes.append(box)
        return box

    def arguments(self, box: _Box, atoms: list[Any], line: int, keys: Sequence[str] | None = None) -> None:
        """The box's creation atoms: ``key=value`` ones as parameters (only ``keys``, when given), the
        others as positional arguments."""
        for a in atoms:
            m = _KEY.match(a) if isinstance(a, str) and getattr(a, "keyable", True) else None
            if m is not None and keys is not None and m.group(1) not in keys:
                m = None
            if m is None:
                box.args.append(_plain(a))
                continue
            key, text = m.groups()
            if key in box.params:
                self.problem(line, f"box {box.index} ({box.type}): parameter '{key}' given twice", box.index)
                continue
            try:
                box.params[key] = parse_value(text)
            except ValueError as exc:
                self.problem(line, f"box {box.index} ({box.type}): parameter '{key}': {exc}", box.index)

    def restore(self, rec: _Record) -> None:
        if len(self.stack) < 2:
            raise ValueError("'#X restore' without a subpatch to close")
        inner = self.stack.pop()
        self.close(inner)
        rest = rec.atoms[4:]
        if rest[:1] == ["graph"]:
            self.add(self.stack[-1], rec, "node", "graph")
            inner.kill()
            return
        box = self.add(self.stack[-1], rec, "sub", "pd")
        box.sub = inner
        if len(rest) > 1:
            box.sub_name = "_".join(str(a) for a in rest[1:])

    def close(self, canvas: _Canvas) -> None:
        """Give each ``@name`` comment's name to its box: the one right below it, where ``write_pd`` puts
        them; else (the box was moved in Pd's editor) the next box in the file after the comment that has
        no name yet.  Pd moves a box it retypes to the end of its canvas, so the file order alone is not
        enough, and a box moved by hand leaves its comment behind, so the position alone is not either."""
        boxes = [b for b in canvas.boxes if not b.comment]
        left = []
        for label in canvas.labels:
            _name, _line, x, y, _after = label
            below = [b for b in boxes if not b.label and abs(b.x - x) < 0.5 and abs(b.y - y - _NAME_DY) < 0.5]
            if below:
                below[0].label = label[0]
            else:
                left.append(label)
        for name, line, _x, _y, after in left:
            nxt = next((b for b in canvas.boxes[after:] if not b.comment and not b.label), None)
            if nxt is None:
                self.problem(line, f"'{NAME_TAG} {name}' is followed by no box without a name")
            else:
                nxt.label = name
        canvas.labels.clear()

    # ------------------------------------------------------------------ naming and wiring
    def name(self, root: _Canvas, used: set[str]) -> None:
        """Name the boxes of ``root`` and of its subpatches, a canvas's named boxes first, then each
        subpatch's (in box order, depth first: not by recursion, subpatches may nest deep)."""
        todo = [(root, "")]
        while todo:
            canvas, prefix = todo.pop()
            named = [b for b in canvas.boxes if b.role in ("node", "sub")]
            for b in named:
                if b.label or b.sub_name:
                    b.name = _unique(prefix + _sanitize_name(b.label or b.sub_name), used)
            for b in named:
                if not (b.label or b.sub_name):
                    b.name = _unique(f"{prefix}{_sanitize(b.type)}_{b.index}", used)
            todo += [(b.sub, b.name + "/") for b in reversed(named) if b.sub is not None]

    def endpoint(self, con: _Connect, out: bool) -> tuple[_Box, int] | None:
        """The box and port a connect record's source (``out``) or destination refers to.

        A subpatch's port is replaced by its ``[inlet]``/``[outlet]`` object (port 0)."""
        idx, port = (con.src, con.outlet) if out else (con.dst, con.inlet)
        boxes = con.canvas.boxes
        what = "source" if out else "destination"
        if idx >= len(boxes):
            self.problem(
                con.line,
                f"connect {what} box {idx} does not exist (the canvas has {len(boxes)} box{'es' * (len(boxes) != 1)})",
            )
            return None
        box = boxes[idx]
        if box.role == "sub":
            assert box.sub is not None
            ports = box.sub.ports("out" if out else "in")
            if port >= len(ports):
                self.problem(
                    con.line,
                    f"subpatch '{box.name}' (box {idx}) has no {'outlet' if out else 'inlet'} {port} "
                    f"({len(ports)} {'outlets' if out else 'inlets'})",
                )
                return None
            return ports[port], 0
        if box.role == "none" or (box.role == "port" and box.port == ("out" if out else "in")):
            kind = "a comment or declare box" if box.role == "none" else f"an [{box.port}let] object"
            self.problem(con.line, f"connect {what} box {idx} is {kind}: nothing to connect there")
            return None
        return box, port

    def finish(self) -> PatchSpec:
        assert self.root is not None
        used: set[str] = set()
        self.name(self.root, used)
        spec = PatchSpec(path=self.path, doc="\n".join(text for _y, _x, text in sorted(self.comments)))
        for b in self.boxes:
            if b.role == "node" and not b.dead:
                spec.nodes.append(
                    NodeDecl(b.name, b.type, b.args, b.params, Where(self.path, b.line, b.index))
                )
        # resolve every connect, then splice out [inlet]/[outlet] objects, keeping the order
        ends: list[tuple[_Connect, tuple[_Box, int], tuple[_Box, int]]] = []
        through: dict[int, list[tuple[_Box, int]]] = {}
        for con in self.connects:
            if con.canvas.dead:
                continue
            src, dst = self.endpoint(con, True), self.endpoint(con, False)
            if src is None or dst is None:
                continue
            if src[0].role == "port":
                through.setdefault(src[0].uid, []).append(dst)
            else:
                ends.append((con, src, dst))
        for con, (sbox, outlet), dst in ends:
            for dbox, inlet in self.expand(dst, through, con.line):
                spec.wires.append(Wire(sbox.name, outlet, dbox.name, inlet, Where(self.path, con.line)))
        if self.problems:
            raise PatchError(self.problems)
        return spec

    def expand(
        self, end: tuple[_Box, int], through: dict[int, list[tuple[_Box, int]]], line: int
    ) -> list[tuple[_Box, int]]:
        """The node inlets that a wire into ``end`` reaches: ``end`` itself, or, for an ``[inlet]`` or
        ``[outlet]`` object, what it leads to, depth first in connect order (as Pd sends).  Not by
        recursion: a chain of subpatches may be longer than Python's stack is deep.  Nothing once
        :data:`MAX_SPLICES` connections have been followed (the first to go past it says so)."""
        out: list[tuple[_Box, int]] = []
        passing: set[int] = set()  # the ports on the way to the end now followed
        todo: list[tuple[_Box, int] | int] = [end]  # ends to follow, and ports to leave (their uid)
        while todo:
            item = todo.pop()
            if isinstance(item, int):
                passing.discard(item)
                continue
            box = item[0]
            if box.role != "port":
                out.append(item)
            elif box.uid in passing:
                self.problem(line, "a loop made only of subpatch inlets and outlets")
            else:
                nxt = through.get(box.uid, [])
                self.splices -= len(nxt)
                if self.splices < 0:
                    if self.splices + len(nxt) >= 0:
                        self.problem(
                            line,
                            f"the wires through subpatch inlets and outlets branch into more than "
                            f"{MAX_SPLICES:,} (each fan-out in a subpatch multiplies those after it)",
                        )
                    return []
                passing.add(box.uid)
                todo.append(box.uid)
                todo += reversed(nxt)
        return out


def _sanitize(text: str) -> str:
    """Letters, digits and ``_`` only, not starting with a digit (``osc~`` -> ``osc``)."""
    s = _NOT_NAME.sub("_", text).strip("_") or "box"
    return "_" + s if s[0].isdigit() else s


def _sanitize_name(text: str) -> str:
    return "/".join(_sanitize(part) for part in str(text).split("/"))


def _unique(name: str, used: set[str]) -> str:
    out, k = name, 2
    while out in used:
        out, k = f"{name}_{k}", k + 1
    used.add(out)
    return out


def parse_pd(text: str, path: str = "<pd>") -> PatchSpec:
    """Parse Pd file text; every syntax problem is raised together as one :class:`PatchError`."""
    return _Reader(path).read(_records(text, path))


def read_pd(path: str | Path) -> PatchSpec:
    """Read a Pure Data file into a flat :class:`PatchSpec` (subpatches flattened, names kept)."""
    return parse_pd(decode(read_patch_bytes(path)), str(path))


def decode(raw: bytes) -> str:
    """A Pd file's text: UTF-8 with or without a byte-order mark, else Latin-1 (old Pd files often are)."""
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        return raw.decode("latin-1")
