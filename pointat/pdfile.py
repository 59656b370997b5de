r"""Pure Data files (``.pd``): read a Pd patch into a :class:`~pointat.spec.PatchSpec`, write one, write stubs.

**Reading** (:func:`read_pd`).  A Pd file is a list of records, each ending at an unescaped ``;`` (a record
may span lines).  ``\,`` ``\;`` ``\$1`` and ``\ `` are escapes; an unescaped ``,`` inside a record starts
a trailing message such as Pd's box width ``, f 40``, which is ignored.  A token is a number only when it
has no escape and reads as one (``-3``, ``0.5``, ``1e+10``); ``+5``, ``inf`` and ``0x10`` are symbols.

* ``#X obj x y CLASS args...`` is a node of type CLASS.  Atoms ``key=value`` (whose ``=`` is not escaped) are
  pointat's named parameters, the value read by :func:`~pointat.patchfile.parse_value`; the other atoms
  are positional.  A ``[print]`` box's atoms are its prefix, joined as Pd joins them (``[print my label]``
  prints ``my label: ...``; ``a=b`` is a word of it), but for ``time=...`` and ``prefix=...``, and for two
  atoms of which the second is 0 or 1: the prefix and ``time``, the form pointat writes.
* ``#X msg x y content...`` is a node of type ``msg``; an escaped ``,`` / ``;`` stays a ``","`` / ``";"``
  atom, ``\$1`` becomes ``"$1"``.
* ``#X floatatom``, ``symbolatom``, ``listbox``, ``#X scalar`` and GUI objects (``bng``, ``tgl``, ``hsl``...)
  become nodes of that type, so that :func:`pointat.loader.check` reports every one of them (all at once)
  as an unknown node type, with ``file:line (box N)``.
* ``#X text`` comments and ``[declare]`` boxes make no node, but every box counts in the 0-based indices of
  ``#X connect src outlet dst inlet``.  ``#X coords``, ``#X declare``, ``#X f``, ``#X array``, ``#A`` (and
  other data records such as cyclone's ``#C``) are not boxes and are skipped.  Wires keep the order of the connect records: it is Pd's fan-out
  order.
* A subpatch, ``#N canvas ...;`` ... ``#X restore x y pd NAME;``, is one box of its parent.  It is
  flattened: its boxes become nodes named ``NAME/...``; its ``[inlet]`` and ``[outlet]`` objects, ordered
  by x position as in Pd, wire straight through (a wire into inlet k of the subpatch box reaches whatever
  the k-th ``[inlet]`` feeds, in that order).  An array (``#X restore x y graph;``) is one box of type
  ``graph``, which pointat does not know.  ``[inlet]``/``[outlet]`` objects of the top canvas (a Pd
  abstraction file) lead nowhere.

**Comments.**  The comments of the top canvas (all but the ``@name`` ones), read top to bottom, become the
patch's header comment (:attr:`~pointat.spec.PatchSpec.doc`), which a native patch writes as its leading
``#`` lines; comments inside subpatches are left out.

**Node names.**  A comment ``@name NODENAME`` names the next box of its canvas (pointat writes one just
above each box).  A box without one is named ``TYPE_INDEX`` (``metro_1``, ``osc_3`` for ``osc~``); a
subpatch is named by its ``pd NAME``.  Names are reduced to letters, digits and ``_`` (``/`` separates
subpatch levels) and made unique with a ``_2``, ``_3``... suffix.

**Writing** (:func:`write_pd`).  Box 0 is ``[declare -path pointat-stubs]`` (Pd then finds the stub
abstractions written by :func:`write_stubs` next to the patch).  The patch's header comment is drawn above
the nodes, a comment a line (blank lines dropped; written after the nodes' boxes, so that it moves no box
index).  Each node is a ``@name`` comment and,
20 px below it, the node's box.  Columns follow the topological depth of the wires (sources on the
left), at least 160 px apart and wider for long boxes; within a column, rows 50 px apart are ordered by
the mean row of each node's inputs.  Pd's own types (metro, delay, trigger, pack, unpack, route, send,
receive, loadbang, print, msg, change) get positional atoms only, as Pd expects (a ``print`` prefix of
plain words as one atom a word: Pd's ``print`` joins them again, and reading a ``.pd`` file does the
same with a ``[print]`` box's atoms); pointat's other types get
``key=value`` atoms for every parameter that the patch gives or that differs from its default.  Such a value is one symbol atom,
so a float keeps its full precision (Pd writes number atoms with 6 significant digits: a positional float
that would lose digits is logged as a warning).  Symbols that would read as a number or as ``key=value``
are escaped (``\12``, ``a\=b``); Pd keeps that while the patch is open but drops it when it saves.

**Stubs** (:func:`write_stubs`).  One ``TYPE.pd`` abstraction per pointat-only node type, with its inlets
and outlets (for the default parameters, or the type's ``stub_values``) and its doc line, so Pd's editor draws and connects the boxes.

>>> spec = parse_pd("#N canvas 0 50 450 300 12;\n#X obj 10 10 metro 100;\n#X text 10 40 @name out;\n"
...                 "#X obj 10 60 print tick;\n#X connect 0 0 2 0;\n", "t.pd")
>>> [(n.name, n.type, n.args) for n in spec.nodes], [str(w) for w in spec.wires]
([('metro_0', 'metro', [100]), ('out', 'print', ['tick'])], ['metro_0.0 -> out.0'])
"""

from __future__ import annotations

import inspect
import logging
import math
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from itertools import accumulate
from pathlib import Path
from typing import Any

from .errors import PatchError, PointatError, Problem, Where
from .node import REQUIRED, Inlet, Node, Outlet
from .patchfile import format_value, parse_int, parse_value
from .registry import Registry, default_registry
from .spec import NodeDecl, PatchSpec, Wire, is_abstraction, read_patch_bytes

__all__ = ["STUB_FOLDER", "VANILLA", "parse_pd", "read_pd", "write_pd", "write_stubs"]

log = logging.getLogger("pointat.pdfile")

#: Node types that Pd itself knows: written with positional creation arguments only, and given no stub.
VANILLA = frozenset(
    "metro delay del trigger t pack unpack route send s receive r loadbang print msg change".split()
)
#: The folder (next to an exported patch) that its ``[declare -path]`` names.
STUB_FOLDER = "pointat-stubs"
NAME_TAG = "@name"

#: How many connections splicing out subpatch inlets and outlets may follow, in all: a fan-out in one
#: subpatch multiplies the fan-outs after it, and a file of a few kilobytes could make a billion wires.
MAX_SPLICES = 100_000

_INT = re.compile(r"-?\d+\Z")
# (not "\d+\.?\d*": without its '.', a long run of digits splits between its two \d in as many ways
# as it is long, and a non-match tries them all)
_NUMBER = re.compile(r"-?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?\Z")
_KEY = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)=(.*)\Z", re.S)
_INNER_ESCAPE = re.compile(r"\\([,;$\s\\])")
_NOT_NAME = re.compile(r"[^A-Za-z0-9_]+")
_UNSAFE = re.compile(r"[\s\\,;${}]")  # what a word of Pd's text must not hold to be written as it is
_ATOM_BOXES = ("floatatom", "symbolatom", "listbox")

# layout of written patches (px, font size 10)
_FONT = 10
_CHAR = 7
_MARGIN = 20
_TOP = 40
_COLUMN = 160
_ROW = 50
_NAME_DY = 20
_LINE = 18  # a header comment's line


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
                    self.arguments(box, atoms[5:], rec.line, keys=("prefix", "time"))
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


def _print_args(args: list[Any]) -> list[Any]:
    """A ``[print]`` box's creation atoms as pointat's ``print`` takes them.

    Pd's ``print`` joins all its atoms into its prefix, one space apart (``[print gyro nulls]`` prints
    ``gyro nulls: ...``), numbers as Pd shows them.  Two atoms of which the second is 0 or 1 are the
    prefix and ``time``, the form pointat writes for ``time=true``.
    """
    if len(args) < 2 or (len(args) == 2 and type(args[1]) is int and args[1] in (0, 1)):
        return args
    return [" ".join(f"{a:g}" if isinstance(a, (int, float)) else str(a) for a in args)]


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
    if cls.type_name == "print" and not values["time"] and _plain_words(values["prefix"]):
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
            path.write_text(_stub(name, cls), encoding="utf-8")
            paths.append(path)
    except OSError as exc:  # a file where the folder should be, no permission, a full disk
        raise PointatError(
            f"cannot write the stubs to {folder}: {exc.strerror or exc}"
            + (f" ({exc.filename})" if exc.filename and str(exc.filename) != str(folder) else "")
        ) from None
    return paths
