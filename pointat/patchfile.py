r"""pointat's native patch format (``.pat``): text that people write by hand and read in a diff.

::

    # comments run from a '#' that starts a word to the end of the line (a#b is a word)
    node glove  simulate rate=100           # node NAME TYPE [positional...] [param=value...]
    node fuse   tqt k=0.5 rho=0.5 mode=robust
    node dir    azi_ele
    node show   print prefix="az el"        # quote text with spaces
    node spk    vbap layout=[0, 45, 90, 135, 180, -135, -90, -45]
    glove.gyro -> fuse.gyro                 # SRC[.OUTLET] -> DST[.INLET]; names or 0-based indices
    glove.accel -> fuse.accel
    fuse -> dir.1 -> show                   # a chain: a middle port is an inlet; it leaves by outlet 0

An *abstraction* is a patch file used as a node type (``node left glove.pat id=1``).  It declares its
arguments and its ports::

    args   id=1 port=9000                  # arguments with defaults, used as $id, $port
    inlet  reset -> cal.reset              # inlet NAME -> node.inlet (repeat a name to fan out)
    outlet azimuth <- dir.azimuth          # outlet NAME <- node.outlet
    node   dev mote id=$id                 # $0: this instance's full name, unique

Values: integers, floats (kept at full precision), ``true``/``false``, bare words, ``"quoted text"``
(in which ``\"`` is a quote and ``\\`` a backslash; any other backslash is itself, as in a Windows path
``"C:\Takes\one.csv"``), and lists in brackets ``[1, 2, 3]``.  A line ending in ``\`` continues on the
next one.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path
from typing import Any

from .errors import PatchError, Problem, Where
from .spec import NodeDecl, PatchSpec, PortDecl, Wire, read_patch_bytes

__all__ = ["format_value", "parse_int", "parse_patch", "parse_value", "read_patch", "write_patch"]

_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
#: Node names may have path parts: ``left/fuse`` (a node inside an abstraction or a Pd subpatch).
_NODE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*\Z")
#: How deep lists may nest in a value (``[[[1]]]`` is 3).
MAX_NESTING = 100
#: The most digits an integer may have: a float holds none longer (nodes compute with floats), and
#: ``int()`` refuses more than 4300 (Python's guard against slow conversions).
MAX_DIGITS = 309
_INT = re.compile(r"[+-]?\d+\Z")
_FLOAT = re.compile(r"[+-]?(\d+\.\d*|\.\d+|\d+)([eE][+-]?\d+)?\Z")
_KEY = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)=(.*)\Z", re.S)
#: A text written without quotes: nothing in it that :func:`tokenize` splits at (``,`` ``;`` ``->`` ``<-``,
#: brackets, quotes, space) and no ``\`` at its end (at the end of a line, that continues the line).
_BARE = re.compile(r"(?!.*(?:->|<-))[A-Za-z_$/.][^\s\[\]\"#=,;]*(?<!\\)\Z")


def read_patch(path: str | Path) -> PatchSpec:
    """Read a native patch file; :class:`PatchError` lists every syntax problem with its line.  (A file
    whose text is Pd's, whatever its name: :func:`pointat.expansion.read_spec` reads either.)"""
    return parse_patch(decode(read_patch_bytes(path), str(path)), str(path))


def decode(raw: bytes, path: str) -> str:
    """A native patch's text: UTF-8, a byte-order mark (Windows editors) dropped; a located error else."""
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise PatchError(
            f"not UTF-8 text: byte 0x{raw[exc.start]:02x} cannot be read; save the patch as UTF-8",
            Where(path, line),
        ) from None


def _logical_lines(text: str) -> list[tuple[int, str]]:
    """(first line number, text) for each statement; joins ``\\`` continuations.  A comment line does
    not continue: its ``\\`` at the end is text (a diagram's branch), not a join with the next line."""
    out: list[tuple[int, str]] = []
    buf, start = "", 0
    for i, raw in enumerate(text.splitlines(), 1):
        line = raw.rstrip()
        if not buf:
            start = i
        if line.endswith("\\") and (buf or not line.lstrip().startswith("#")):
            buf += line[:-1] + " "
            continue
        out.append((start, buf + line))
        buf = ""
    if buf:
        out.append((start, buf))
    return out


def tokenize(line: str) -> list[str]:
    """Split a statement into tokens: quotes and brackets stay whole, ``->``/``<-`` and the separators
    ``,`` ``;`` stand alone, a ``#`` that begins a word ends it (``a#b`` is one word).

    >>> tokenize('node m msg set 1, bang;bus "a, b" [1, 2]')
    ['node', 'm', 'msg', 'set', '1', ',', 'bang', ';', 'bus', '"a, b"', '[1, 2]']
    """
    tokens: list[str] = []
    cur: list[str] = []  # the word so far, in pieces (adding to a str char by char is quadratic)
    i, n = 0, len(line)
    depth = 0
    while i < n:
        c = line[i]
        if c == '"':
            j = i + 1
            while j < n and line[j] != '"':
                j += 2 if line[j] == "\\" else 1
            if j >= n:
                raise ValueError("unclosed quote")
            cur.append(line[i : j + 1])
            i = j + 1
            continue
        if c == "[":
            depth += 1
        elif c == "]":
            depth -= 1
            if depth < 0:
                raise ValueError("']' without '['")
        if depth == 0:
            if c == "#" and not cur:
                break
            if c.isspace():
                if cur:
                    tokens.append("".join(cur))
                    cur = []
                i += 1
                continue
            if line.startswith("->", i) or line.startswith("<-", i):
                if cur:
                    tokens.append("".join(cur))
                    cur = []
                tokens.append(line[i : i + 2])
                i += 2
                continue
            if c in ",;":  # a message box's separators stand alone, written apart or not (as in Pd)
                if cur:
                    tokens.append("".join(cur))
                    cur = []
                tokens.append(c)
                i += 1
                continue
        cur.append(c)
        i += 1
    if depth:
        raise ValueError("unclosed '['")
    if cur:
        tokens.append("".join(cur))
    return tokens


def parse_value(token: str) -> Any:
    r"""A value token -> int, float, bool, str or list.

    >>> parse_value("0.1000000000000000055511151231257827")
    0.1
    >>> parse_value("[1, 2.5, a]")
    [1, 2.5, 'a']
    >>> parse_value('"two words"')
    'two words'
    >>> print(parse_value(r'"C:\My Takes\new.csv"'), parse_value(r'"say \"hi\" \\"'))  # only \" and \\ escape
    C:\My Takes\new.csv say "hi" \
    """
    if token.startswith('"') and token.endswith('"') and len(token) >= 2:
        return re.sub(r'\\([\\"])', r"\1", token[1:-1])
    if token.startswith("["):
        if not token.endswith("]"):
            raise ValueError(f"bad list {token!r}")
        inner = token[1:-1]
        items: list[Any] = []
        cur: list[str] = []  # the item so far, in pieces (adding to a str char by char is quadratic)
        depth, inq = 0, False
        for c in inner:
            if c == '"':
                inq = not inq
            if not inq and c == "[":
                depth += 1
                if depth >= MAX_NESTING:  # each level is a call deeper: Python's stack would end first
                    raise ValueError(f"lists nested more than {MAX_NESTING} deep")
            elif not inq and c == "]":
                depth -= 1
            if not inq and depth == 0 and (c == "," or c.isspace()):
                if cur:
                    items.append(parse_value("".join(cur)))
                    cur = []
                continue
            cur.append(c)
        if cur:
            items.append(parse_value("".join(cur)))
        return items
    if _INT.match(token):
        return parse_int(token)
    if _FLOAT.match(token):
        return float(token)
    if token in ("true", "false"):
        return token == "true"
    if token in ("inf", "-inf", "nan"):
        return float(token)
    return token


def parse_int(token: str) -> int:
    """A whole number's text -> int; :class:`ValueError` when it is too large for a float to hold.

    >>> parse_int("-42"), parse_int("9" * 308) > 0
    (-42, True)
    >>> parse_int("9" * 400)
    Traceback (most recent call last):
    ValueError: number too large: 999999999999...999999999999 (400 digits); at most 1.8e+308
    """
    digits = len(token.lstrip("+-").lstrip("0"))
    if digits <= MAX_DIGITS:
        number = int(token)
        if abs(number) <= sys.float_info.max:
            return number
    shown = token if len(token) <= 30 else f"{token[:12]}...{token[-12:]} ({digits} digits)"
    raise ValueError(f"number too large: {shown}; at most {sys.float_info.max:.2g}")


def _endpoint(token: str, default: int) -> tuple[str, str | int]:
    name, dot, port = token.partition(".")
    if not _NODE.match(name):
        raise ValueError(f"bad node name {name!r} in {token!r}")
    if not dot:
        return name, default
    if port.isascii() and port.isdigit():  # (not '²', which is a digit to isdigit() but not to int())
        return name, int(port)
    if not _NAME.match(port):
        raise ValueError(f"bad port {port!r} in {token!r}")
    return name, port


def parse_patch(text: str, path: str = "<patch>") -> PatchSpec:
    """Parse native patch text; every problem is collected and raised together as a :class:`PatchError`."""
    spec = PatchSpec(path=path)
    problems: list[Problem] = []
    doc_lines: list[str] = []
    in_header = True
    for lineno, line in _logical_lines(text):
        where = Where(path, lineno)
        stripped = line.strip()
        if in_header and stripped.startswith("#"):
            body = stripped[1:]  # the '#' and one space: a diagram's indentation is part of the text
            doc_lines.append(body[1:] if body.startswith(" ") else body)
            continue
        if stripped:
            in_header = False
        try:
            tokens = tokenize(line)
        except ValueError as exc:
            problems.append(Problem(where, f"syntax error: {exc}"))
            continue
        if not tokens:
            continue
        try:
            _statement(spec, tokens, where)
        except ValueError as exc:
            problems.append(Problem(where, str(exc)))
    spec.doc = "\n".join(doc_lines).strip()
    if problems:
        raise PatchError(problems)
    return spec


def _statement(spec: PatchSpec, tokens: list[str], where: Where) -> None:
    head = tokens[0]
    if head == "node":
        if len(tokens) < 3:
            raise ValueError("expected 'node NAME TYPE [args...] [param=value...]'")
        name, typ = tokens[1], tokens[2]
        if not _NODE.match(name):
            raise ValueError(
                f"bad node name {name!r}: use letters, digits and '_', not starting with a digit "
                "('/' only between two such parts, as in left/fuse)"
            )
        if spec.node(name) is not None:
            raise ValueError(f"node '{name}' is defined twice (first at line {spec.node(name).where.line})")
        decl = NodeDecl(name, typ, where=where)
        for tok in tokens[3:]:
            m = _KEY.match(tok)
            if m:
                if m.group(1) in decl.params:
                    raise ValueError(f"node '{name}': parameter '{m.group(1)}' given twice")
                decl.params[m.group(1)] = parse_value(m.group(2))
            elif decl.params:
                raise ValueError(f"node '{name}': positional argument {tok!r} after named ones")
            else:
                decl.args.append(parse_value(tok))
        spec.nodes.append(decl)
    elif head == "args":
        for tok in tokens[1:]:
            m = _KEY.match(tok)
            if not m:
                raise ValueError(f"expected 'args name=default ...', got {tok!r}")
            if m.group(1) in spec.args:
                raise ValueError(f"argument '{m.group(1)}' given twice")
            spec.args[m.group(1)] = parse_value(m.group(2))
        spec.args_where = where
    elif head in ("inlet", "outlet"):
        arrow = "->" if head == "inlet" else "<-"
        if len(tokens) != 4 or tokens[2] != arrow or not _NAME.match(tokens[1]):
            raise ValueError(f"expected '{head} NAME {arrow} node.{head}'")
        node, port = _endpoint(tokens[3], 0)
        (spec.inlets if head == "inlet" else spec.outlets).append(PortDecl(tokens[1], node, port, where))
    elif "->" in tokens:
        if (
            tokens[0] == "->"
            or tokens[-1] == "->"
            or any((a == "->") == (b == "->") for a, b in zip(tokens, tokens[1:], strict=False))
        ):
            raise ValueError("expected 'src[.outlet] -> dst[.inlet] [-> ...]'")
        ends = tokens[::2]
        for k, (a, b) in enumerate(zip(ends, ends[1:], strict=False)):
            src, outlet = _endpoint(a, 0)
            if k > 0:  # in a chain, a middle port names the inlet; the next wire leaves by outlet 0
                outlet = 0
            dst, inlet = _endpoint(b, 0)
            spec.wires.append(Wire(src, outlet, dst, inlet, where))
    else:
        raise ValueError(f"unknown statement {head!r}: expected node, args, inlet, outlet or a wire 'a -> b'")


def format_value(value: Any) -> str:
    """The text for a value, such that :func:`parse_value` gives it back exactly.

    >>> format_value(0.1), format_value([1, "a b"]), format_value("sweep")
    ('0.1', '[1, "a b"]', 'sweep')
    """
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(format_value(v) for v in value) + "]"
    s = str(value)
    if _BARE.match(s) and not isinstance(parse_value(s), (int, float, bool)):
        return s
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _port(port: str | int) -> str:
    return str(port)


def write_patch(spec: PatchSpec) -> str:
    """Native text for a patch: header comment, args, ports, nodes (aligned), then wires."""
    lines = [("#" if ln.startswith("#") else "# ") + ln for ln in spec.doc.splitlines()] if spec.doc else []
    lines = [ln.rstrip() for ln in lines]
    if lines:
        lines.append("")
    if spec.args:
        lines.append("args " + " ".join(f"{k}={format_value(v)}" for k, v in spec.args.items()))
    for p in spec.inlets:
        lines.append(f"inlet {p.name} -> {p.node}.{_port(p.port)}")
    for p in spec.outlets:
        lines.append(f"outlet {p.name} <- {p.node}.{_port(p.port)}")
    if spec.args or spec.inlets or spec.outlets:
        lines.append("")
    width = max((len(n.name) for n in spec.nodes), default=0)
    for n in spec.nodes:
        parts = [f"node {n.name:<{width}} {n.type}"]
        parts += [format_value(a) for a in n.args]
        parts += [f"{k}={format_value(v)}" for k, v in n.params.items()]
        lines.append(" ".join(parts))
    if spec.wires:
        lines.append("")
    for w in spec.wires:
        lines.append(f"{w.src}.{_port(w.outlet)} -> {w.dst}.{_port(w.inlet)}")
    return "\n".join(lines) + "\n"
