r"""A mutation fuzzer for patch files: every mutant is either checked or refused with a located error.

::

    python -m tests.fuzz --minutes 5                  # as many mutants as fit in 5 minutes
    python -m tests.fuzz --cases 10000 --seed 7       # 10,000 mutants, reproducible
    python -m tests.fuzz --cases 2000 --run           # also run the mutants that pass, 0.5 s each

The seeds are every ``patches/*.pat``, ``patches/lib/*.pat``, ``examples/**/*.pat``, the Pd files of
``examples/`` and ``tests/data/pd/``, and ``.pd`` files written by :func:`pointat.pdfile.write_pd` from a
few of the patches.  A mutant is a seed with one to five mutations: byte flips, lines dropped, doubled,
repeated, swapped or taken from another seed, tokens dropped, doubled, swapped or replaced, odd Unicode
(NUL, line and paragraph separators, right-to-left marks, a byte-order mark, digits of other scripts),
numbers such as ``1e999``, a 400-digit integer or ``nan``, brackets and quotes nested deep or left open,
very long lines, CRLF, truncation, paths such as ``/dev/zero``, a FIFO or a folder, and long chains of
nodes and deep subpatches.

Each mutant is written into a sandbox that mirrors the repository (the stock patches beside it, so that
``lib/tqt_fusion.pat`` and ``../pointat/data/...`` are found as they are from the original) and checked
in a worker process by the code ``pointat check`` runs (:func:`pointat.cli.cmd_check`), with a time limit
per case (a hang) and a memory limit (``RLIMIT_AS``).  The outcome is one of: checked, refused (a
:class:`~pointat.errors.PatchError` or :class:`~pointat.errors.PointatError`: what ``pointat check``
prints as an error), a traceback (any other exception), a hang (the time limit; where it hung is
taken from :mod:`faulthandler`), or a worker that died.  Tracebacks and hangs are grouped into classes
by exception type and the innermost frame in the repository; each class's smallest mutant is cut down
(lines, then words) while it still gives that class, and saved with its traceback.  The exit status is 1
when there was any traceback, hang or death.
"""

from __future__ import annotations

import argparse
import contextlib
import faulthandler
import io
import itertools
import logging
import math
import multiprocessing
import os
import random
import re
import resource
import signal
import sys
import tempfile
import threading
import time
import traceback
import warnings
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from multiprocessing.connection import Connection, wait
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: Seeds, as globs relative to the repository.
SEED_GLOBS = (
    "patches/*.pat",
    "patches/lib/*.pat",
    "examples/**/*.pat",
    "examples/**/*.pd",
    "tests/data/pd/*.pd",
)
#: Patches also written as Pd files (by pointat.pdfile.write_pd) to seed the Pd reader.
PD_FROM = ("patches/pointing_at.pat", "patches/glove_tqt.pat", "patches/replay_tqt.pat", "examples/adm.pat")
#: Folders the sandbox links to rather than copies (data files that patches read).
LINKED = ("pointat/data",)

TIMEOUT = 5.0  # seconds a case may take
MEMORY_MB = 2048  # the worker's address space
MAX_BYTES = 1_000_000  # a mutation that makes a mutant longer is not made: a slow read is not a hang
RECYCLE = 500  # cases a worker checks before a fresh one takes over (leaks stay small)
LOOPBACK = frozenset({"127.0.0.1", "localhost", "::1", "127.0.1.1"})

OUTCOMES = ("ok", "refused", "traceback", "hang", "died")


# =========================================================================== cases and outcomes
@dataclass(frozen=True)
class Case:
    """One mutant: its number, the seed it came from, where it goes in the sandbox, and its bytes."""

    number: int
    seed: str  # the seed's path relative to the repository
    data: bytes
    mutations: tuple[str, ...] = ()

    @property
    def folder(self) -> str:
        return str(Path(self.seed).parent)

    @property
    def suffix(self) -> str:
        return Path(self.seed).suffix


@dataclass
class Outcome:
    """What checking a case gave: ``kind`` is one of :data:`OUTCOMES`; a traceback, hang or death has a
    ``key`` (its class) and a ``detail`` (the traceback)."""

    kind: str
    key: str = ""
    detail: str = ""
    unlocated: str = ""  # refused with an error that names no line: that error's message
    ran: str = ""  # with --run: "ok", "refused" or "skipped" (not safe to run), or "" (not run)
    recycle: bool = False  # the worker should not go on (after a MemoryError)


@dataclass
class CrashClass:
    """Tracebacks (or hangs) of one kind at one place, and the smallest case that gave one."""

    key: str
    kind: str
    count: int
    case: Case
    detail: str
    saved: Path | None = None


@dataclass
class Report:
    """The fuzzer's tally."""

    cases: int = 0
    counts: dict[str, int] = field(default_factory=lambda: dict.fromkeys(OUTCOMES, 0))
    unlocated: dict[str, int] = field(default_factory=dict)  # by message, numbers and quotes left out
    ran: dict[str, int] = field(default_factory=dict)
    classes: dict[str, CrashClass] = field(default_factory=dict)
    seconds: float = 0.0
    save_dir: Path | None = None

    @property
    def failures(self) -> int:
        return self.counts["traceback"] + self.counts["hang"] + self.counts["died"]

    def add(self, case: Case, outcome: Outcome) -> None:
        self.cases += 1
        self.counts[outcome.kind] += 1
        if outcome.unlocated:
            kind = re.sub(r"\S*pointat-fuzz-\S*", "FILE", outcome.unlocated)
            kind = re.sub(r"'[^']*'|\"[^\"]*\"|\d+", "_", kind)[:100]
            self.unlocated[kind] = self.unlocated.get(kind, 0) + 1
        if outcome.ran:
            self.ran[outcome.ran] = self.ran.get(outcome.ran, 0) + 1
        if outcome.kind in ("traceback", "hang", "died"):
            known = self.classes.get(outcome.key)
            if known is None:
                self.classes[outcome.key] = CrashClass(outcome.key, outcome.kind, 1, case, outcome.detail)
            else:
                known.count += 1
                if len(case.data) < len(known.case.data):
                    known.case, known.detail = case, outcome.detail


# =========================================================================== seeds and sandbox
def seeds(root: Path = ROOT) -> dict[str, bytes]:
    """Seed files by their path relative to ``root``: the stock patches, and Pd files written from a few."""
    out: dict[str, bytes] = {}
    for pattern in SEED_GLOBS:
        for path in sorted(root.glob(pattern)):
            out[path.relative_to(root).as_posix()] = path.read_bytes()
    from pointat.expansion import flatten
    from pointat.loader import check, read_spec, rebase_paths
    from pointat.pdfile import write_pd
    from pointat.registry import default_registry

    registry = default_registry.load_builtins().load_entry_points()
    log = logging.getLogger("pointat")
    level = log.level
    log.setLevel(logging.ERROR)  # write_pd's warnings of the digits Pd would lose
    try:
        for rel in PD_FROM:
            source = root / rel
            if not source.exists():
                continue
            spec = read_spec(source)
            check(spec, registry)
            spec = flatten(spec)
            rebase_paths(spec, registry, source.parent)  # beside the original: the same relative paths
            out[str(Path(rel).with_suffix(".pd"))] = write_pd(spec, registry).encode()
    finally:
        log.setLevel(level)
    return out


def make_sandbox(folder: Path, seed_files: dict[str, bytes], root: Path = ROOT) -> Path:
    """Lay out ``folder`` as the repository as far as patches see it: every seed at its place, the data
    folders linked, and a FIFO (``fifo.pat``, ``fifo.pd``) beside each, which a mutant may name."""
    for rel, data in seed_files.items():
        path = folder / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
    for rel in LINKED:
        if (root / rel).exists():
            (folder / rel).parent.mkdir(parents=True, exist_ok=True)
            (folder / rel).symlink_to(root / rel, target_is_directory=True)
    for sub in {Path(rel).parent for rel in seed_files}:
        for name in ("fifo.pat", "fifo.pd"):
            if not (folder / sub / name).exists():
                os.mkfifo(folder / sub / name)
    return folder


# =========================================================================== mutations
NUMBERS = (
    "1e999",
    "-1e999",
    "1e-999",
    "9" * 400,
    "-" + "9" * 400,
    "1" + "0" * 5000,
    "0." + "0" * 400 + "1",
    "1" * 20000,
    "nan",
    "-nan",
    "inf",
    "-inf",
    "NaN",
    "Infinity",
    "-0",
    "-0.0",
    "0x10",
    "1_000",
    "9223372036854775808",
    "-9223372036854775809",
    "2147483648",
    "4294967296",
    "1e308",
    "1.8e308",
    "4.9e-324",
    "1.",
    ".5",
    "+5",
    "1e+10",
    "00",
    "1e",
    "--1",
    "65536",
    "-1",
    "0",
    "\u0663",  # ARABIC-INDIC DIGIT THREE: a \d
    "\uff11\uff12",  # FULLWIDTH 1 2
    "\u00b2",  # SUPERSCRIPT TWO: isdigit() but not int()
    "\u00bd",
    "\U0001d7d9",  # MATHEMATICAL DOUBLE-STRUCK DIGIT ONE
)
ODD = (
    "\x00",
    "\x01",
    "\x07",
    "\x0b",
    "\x0c",
    "\x1c",
    "\x1e",
    "\x7f",
    "\x85",
    "\xa0",
    "\r",
    "\t",
    "\u2028",
    "\u2029",
    "\u200b",
    "\u200d",
    "\u200e",
    "\u200f",
    "\u202e",
    "\u2066",
    "\u2069",
    "\ufeff",
    "\ufffd",
    "\uffff",
    "\U0010ffff",
    "\U0001f600",
    "\u0301",
    "\u3000",
    "\ue000",
    "\u0130",  # I WITH DOT: lowercases to two characters
    "\u00df",
    "\ufb01",
    "\u01c5",
    "\u0663",
    "\uff10",
    "\u00b2",
    "\u2074",
)
STRUCTURE = (
    "[",
    "]",
    "[]",
    "[[",
    "]]",
    '"',
    '""',
    '"\\"',
    '\\"',
    "\\",
    "\\\\",
    "->",
    "<-",
    "-> ->",
    "<- <-",
    ".",
    "..",
    ".0",
    ".x",
    ".99999999999999999999",
    "#",
    "a#b",
    "$",
    "$0",
    "$id",
    "$rate",
    "$$",
    "$1",
    "\\$1",
    "${}",
    "=",
    "a=",
    "=b",
    "a==b",
    "k=[",
    "k=]",
    "k=[1,,2]",
    'k="',
    ",",
    ";",
    ", ;",
    "\\;",
    "\\,",
    "\\ ",
    "node",
    "args",
    "inlet",
    "outlet",
    "node a",
    "node a msg",
    "args a=",
    "inlet x -> ",
    "outlet x <- a.",
    "a -> a",
    "a.0 -> a.0",
    "#N",
    "#X",
    "#A",
    "#C",
    "#N canvas 0 50 450 300 12;",
    "#N canvas;",
    "#X restore 0 0 pd sub;",
    "#X restore 0 0 graph;",
    "#X restore;",
    "#X connect 0 0 0 0;",
    "#X connect 0 0 99999999999999999999 0;",
    "#X connect -1 0 0 0;",
    "#X obj 0 0 inlet;",
    "#X obj 0 0 outlet;",
    "#X obj 0 0;",
    "#X obj x y metro;",
    "#X obj 1e999 nan metro;",
    "#X text 0 0 @name;",
    "#X text 0 0 @name a b;",
    "#X text 0 0 @name \\$0;",
    "#X text nan 0 hello;",
    "#X msg 0 0 \\, \\; \\$1;",
    "#X floatatom 0 0 5 0 0 0 - - -;",
    "#X scalar;",
    "#X coords 0 -1 1 1 200 140 1;",
    "#X array a 100 float 2;",
    "#A 0 1 2 3;",
    "#X f 40;",
    "#X declare -path x;",
    "#X pop;",
    "#X wibble;",
    "@name",
)
PATHS = (
    "/dev/zero",
    "/dev/null",
    "/dev/urandom",
    "/dev/stdin",
    "/proc/self/mem",
    "/proc/self/fd/0",
    "fifo.pat",
    "fifo.pd",
    "../fifo.pat",
    "lib/fifo.pat",
    "lib",
    "lib/",
    ".",
    "..",
    "/",
    "",
    "lib/\x00.pat",
    "a\x00b.pat",
    "x" * 5000 + ".pat",
    "/" + "a/" * 3000 + "x.pat",
    "~/x.pat",
    "C:\\x.pat",
    "nul.pd",
    "lib/tqt_fusion.pat",
    "lib/torre_fusion.pat",
    "../patches/lib/tqt_fusion.pat",
    "lib/tqt_fusion.PD",
    "lib/tqt_fusion.pd",
    "pointing_at.pat",
    "fuzz.pat",
    "lib/x.pat",
)
INTERESTING = NUMBERS + ODD + STRUCTURE + PATHS


@dataclass
class Mutator:
    """Mutations of a mutant's bytes, drawn from ``rng``; ``lines`` and ``words`` are those of every seed
    (to take one from another seed)."""

    rng: random.Random
    lines: list[str]
    words: list[str]

    # ------------------------------------------------------------------ bytes
    def flip(self, data: bytes) -> bytes:
        """Flip one to four bits."""
        if not data:
            return data
        b = bytearray(data)
        for _ in range(self.rng.randint(1, 4)):
            k = self.rng.randrange(len(b))
            b[k] ^= 1 << self.rng.randrange(8)
        return bytes(b)

    def byte(self, data: bytes) -> bytes:
        """Insert, replace or drop a byte (a separator, a quote, an invalid UTF-8 byte...)."""
        k = self.rng.randrange(len(data) + 1)
        new = bytes([self.rng.choice(b'\x00\n\r\t "\\[]#;,=.$-><\x80\xc3\xff\xfe\xef\xbb\xbf')])
        how = self.rng.randrange(3)
        if how == 0:
            return data[:k] + new + data[k:]
        if how == 1:
            return data[:k] + new + data[k + 1 :]
        return data[:k] + data[k + 1 :]

    def truncate(self, data: bytes) -> bytes:
        """Cut the file anywhere (in a UTF-8 sequence too)."""
        return data[: self.rng.randrange(len(data) + 1)]

    # ------------------------------------------------------------------ lines
    def _lines(self, text: str) -> list[str]:
        return text.split("\n")

    def drop_line(self, text: str) -> str:
        lines = self._lines(text)
        del lines[self.rng.randrange(len(lines))]
        return "\n".join(lines)

    def double_line(self, text: str) -> str:
        lines = self._lines(text)
        k = self.rng.randrange(len(lines))
        times = self.rng.choice((1, 1, 1, 2, 10, 300, 2000))
        lines[k:k] = [lines[k]] * times
        return "\n".join(lines)

    def swap_lines(self, text: str) -> str:
        lines = self._lines(text)
        a, b = self.rng.randrange(len(lines)), self.rng.randrange(len(lines))
        lines[a], lines[b] = lines[b], lines[a]
        return "\n".join(lines)

    def foreign_line(self, text: str) -> str:
        """A line of another seed (a Pd record into a native patch, an inlet line into a top patch...)."""
        lines = self._lines(text)
        lines.insert(self.rng.randrange(len(lines) + 1), self.rng.choice(self.lines))
        return "\n".join(lines)

    # ------------------------------------------------------------------ words
    def _split(self, text: str) -> list[str]:
        """Words and the white space between them, so that joining gives ``text`` back."""
        return re.split(r"(\s+)", text)

    def _word_index(self, parts: list[str]) -> int | None:
        idx = [k for k, p in enumerate(parts) if p and not p.isspace()]
        return self.rng.choice(idx) if idx else None

    def drop_word(self, text: str) -> str:
        parts = self._split(text)
        k = self._word_index(parts)
        if k is not None:
            parts[k] = ""
        return "".join(parts)

    def double_word(self, text: str) -> str:
        parts = self._split(text)
        k = self._word_index(parts)
        if k is not None:
            parts[k] = parts[k] + self.rng.choice((" ", "")) + parts[k]
        return "".join(parts)

    def swap_words(self, text: str) -> str:
        parts = self._split(text)
        a, b = self._word_index(parts), self._word_index(parts)
        if a is not None and b is not None:
            parts[a], parts[b] = parts[b], parts[a]
        return "".join(parts)

    def replace_word(self, text: str) -> str:
        """A word becomes an interesting one, or a word of another seed."""
        parts = self._split(text)
        k = self._word_index(parts)
        if k is None:
            return text
        new = self.rng.choice(INTERESTING) if self.rng.random() < 0.7 else self.rng.choice(self.words)
        word = parts[k]
        if "=" in word and self.rng.random() < 0.6:  # keep the key: param=NEW
            new = word.split("=", 1)[0] + "=" + new
        elif "." in word and self.rng.random() < 0.3:  # keep the node: node.NEW
            new = word.split(".", 1)[0] + "." + new
        parts[k] = new
        return "".join(parts)

    def number(self, text: str) -> str:
        """A number becomes a huge, tiny, odd or unreadable one."""
        spans = [m.span() for m in re.finditer(r"-?\d+(\.\d*)?([eE][-+]?\d+)?", text)]
        if not spans:
            return self.insert(text)
        a, b = self.rng.choice(spans)
        return text[:a] + self.rng.choice(NUMBERS) + text[b:]

    def path(self, text: str) -> str:
        """A file name (an abstraction, a data file) becomes a device, a FIFO, a folder, a long name."""
        spans = [
            m.span(1) for m in re.finditer(r"(?:^|[\s=])([^\s=]*(?:\.pat|\.pd|\.csv|\.json|\.gz)\b)", text)
        ]
        new = self.rng.choice(PATHS)
        if not spans:
            return self.insert(text, new)
        a, b = self.rng.choice(spans)
        return text[:a] + new + text[b:]

    def insert(self, text: str, new: str | None = None) -> str:
        """Something interesting anywhere."""
        k = self.rng.randrange(len(text) + 1)
        return text[:k] + (new if new is not None else self.rng.choice(INTERESTING)) + text[k:]

    def odd(self, text: str) -> str:
        """An odd code point anywhere, or in place of a character."""
        k = self.rng.randrange(len(text) + 1)
        c = self.rng.choice(ODD) if self.rng.random() < 0.8 else chr(self.rng.choice(_CODE_POINTS))
        return text[:k] + c + text[k + self.rng.randrange(2) :]

    def nest(self, text: str) -> str:
        """Brackets or quotes nested deep, balanced or not."""
        depth = self.rng.choice((2, 50, 99, 100, 101, 1000, 100_000))
        shape = self.rng.randrange(6)
        if shape == 0:
            new = "[" * depth + "1" + "]" * depth
        elif shape == 1:
            new = "[" * depth
        elif shape == 2:
            new = "]" * depth
        elif shape == 3:
            new = '"' * depth
        elif shape == 4:
            new = "[" + '"\\"' * depth + "]"
        else:
            new = "".join(self.rng.choice('[]"\\, ') for _ in range(min(depth, 5000)))
        return self.replace_word(text) if not text else self.insert(text, new)

    def long_line(self, text: str) -> str:
        """A line or word a hundred thousand characters long."""
        n = self.rng.choice((10_000, 100_000))
        new = self.rng.choice(
            (
                "a" * n,
                "1" * n + "x",
                "1" * n + ".",
                "-" + "1" * n + "e",
                "[" + ", ".join("1" for _ in range(n // 3)) + "]",
                "x=" + "1" * n,
                "a." * (n // 2),
                "a/" * (n // 2),
                "\\" * n,
                " " * n,
                "# " * n,
                "\\\n" * (n // 10),
            )
        )
        return self.insert(text, new)

    # ------------------------------------------------------------------ whole files
    def crlf(self, text: str) -> str:
        return text.replace("\n", self.rng.choice(("\r\n", "\r", "\n\r", "\r\r\n", "\u2028", "\x85")))

    def bom(self, text: str) -> str:
        return self.rng.choice(("\ufeff", "\ufeff\ufeff", "\ufffe")) + text

    def chain(self, text: str) -> str:
        """A chain of many nodes (or, in a Pd file, many boxes) or subpatches nested deep."""
        n = self.rng.choice((30, 1100, 3000))
        if not text.lstrip().startswith("#N"):
            nodes = "".join(f"node c{k} change\n" for k in range(n))
            return text + "\n" + nodes + " -> ".join(f"c{k}" for k in range(n)) + "\n"
        shape = self.rng.randrange(3)
        if shape == 0:  # a chain of boxes in a subpatch of its own
            boxes = "".join("#X obj 0 0 change;\n" for _ in range(n))
            wires = "".join(f"#X connect {k} 0 {k + 1} 0;\n" for k in range(n - 1))
            return text + f"\n#N canvas 0 0 450 300 chain 0;\n{boxes}{wires}#X restore 0 0 pd chain;\n"
        if shape == 1:  # subpatches nested n deep, a message passing through each one's inlet
            opening = "#N canvas 0 0 450 300 ports 0;\n#X obj 0 0 loadbang;\n" + (
                "#N canvas 0 0 450 300 s 0;\n#X obj 0 0 inlet;\n" * n
            )
            inner = "#X obj 0 0 change;\n#X connect 0 0 1 0;\n"  # (after the innermost one's inlet)
            closing = "#X restore 0 0 pd s;\n#X connect 0 0 1 0;\n" * n
            return text + "\n" + opening + inner + closing + "#X restore 0 0 pd ports;\n"
        # arrays' graphs nested n deep
        return text + "\n" + "#N canvas 0 0 450 300 (subpatch) 0;\n" * n + "#X restore 0 0 graph;\n" * n

    # ------------------------------------------------------------------ all of them
    def mutate(self, data: bytes) -> tuple[bytes, tuple[str, ...]]:
        """One to five mutations of ``data``, and their names."""
        names = []
        for _ in range(min(1 + int(self.rng.expovariate(0.9)), 5)):
            name, fn, weight = self.rng.choices(_MUTATIONS, weights=[w for _, _, w in _MUTATIONS])[0]
            del weight
            if name in _BYTES:
                new = fn(self, data)
            else:
                new = fn(self, data.decode("utf-8", "surrogateescape")).encode("utf-8", "surrogateescape")
            if len(new) <= max(MAX_BYTES, len(data)):
                data = new
                names.append(name)
        return data, tuple(names)


_CODE_POINTS = [c for c in range(0x110000) if not 0xD800 <= c <= 0xDFFF][::97]  # surrogates left out
_BYTES = {"flip", "byte", "truncate"}
_MUTATIONS: list[tuple[str, Callable, float]] = [
    ("flip", Mutator.flip, 3),
    ("byte", Mutator.byte, 3),
    ("truncate", Mutator.truncate, 1),
    ("drop_line", Mutator.drop_line, 3),
    ("double_line", Mutator.double_line, 3),
    ("swap_lines", Mutator.swap_lines, 2),
    ("foreign_line", Mutator.foreign_line, 3),
    ("drop_word", Mutator.drop_word, 3),
    ("double_word", Mutator.double_word, 2),
    ("swap_words", Mutator.swap_words, 3),
    ("replace_word", Mutator.replace_word, 6),
    ("number", Mutator.number, 4),
    ("path", Mutator.path, 2),
    ("insert", Mutator.insert, 4),
    ("odd", Mutator.odd, 3),
    ("nest", Mutator.nest, 2),
    ("long_line", Mutator.long_line, 1),
    ("crlf", Mutator.crlf, 1),
    ("bom", Mutator.bom, 1),
    ("chain", Mutator.chain, 0.5),
]


def cases(seed_files: dict[str, bytes], seed: int, start: int = 0) -> Iterator[Case]:
    """Mutants without end; case ``n`` depends on ``seed`` and ``n`` only (not on what ran before)."""
    names = sorted(seed_files)
    texts = [seed_files[n].decode("utf-8", "surrogateescape") for n in names]
    lines = sorted({ln for t in texts for ln in t.split("\n") if ln.strip()})
    words = sorted({w for t in texts for w in t.split()})
    n = start
    while True:
        rng = random.Random(f"{seed}/{n}")
        rel = rng.choice(names)
        data, how = Mutator(rng, lines, words).mutate(seed_files[rel])
        yield Case(n, rel, data, how)
        n += 1


# =========================================================================== the worker
def _repo_frame(frames: Iterable[tuple[str, int, str]]) -> str:
    """``file:line (function)`` of the innermost frame in the repository (outside ``tests/``), else of
    the innermost frame."""
    frames = list(frames)
    for filename, lineno, name in reversed(frames):
        path = Path(filename)
        if path.is_relative_to(ROOT) and not path.is_relative_to(ROOT / "tests"):
            return f"{path.relative_to(ROOT)}:{lineno} ({name})"
    if frames:
        filename, lineno, name = frames[-1]
        return f"{Path(filename).name}:{lineno} ({name})"
    return "?"


def _crash(exc: BaseException, what: str = "") -> Outcome:
    frames = [(f.filename, f.lineno or 0, f.name) for f in traceback.extract_tb(exc.__traceback__)]
    lines = traceback.format_exception(exc)
    if len(lines) > 40:
        lines = lines[:12] + [f"  ... {len(lines) - 32} lines ...\n"] + lines[-20:]
    detail = "".join(lines)
    if len(detail) > 8000:
        detail = detail[:4000] + "\n...\n" + detail[-4000:]
    return Outcome(
        "traceback",
        f"{what}{type(exc).__name__} at {_repo_frame(frames)}",
        detail,
        recycle=isinstance(exc, (MemoryError, RecursionError)),
    )


class _Checker:
    """Runs the cases in a worker: writes each into the sandbox and checks it as ``pointat check`` does."""

    def __init__(self, sandbox: Path, tag: str, run_for: float | None):
        from pointat import cli

        self.cli = cli
        self.registry = cli._registry([])
        self.parser = cli._parser()
        self.sandbox = sandbox
        self.tag = tag
        self.run_for = run_for
        self.thread_errors: list[BaseException] = []

    def path(self, case: Case) -> Path:
        return self.sandbox / case.folder / f"fuzz_{self.tag}{case.suffix}"

    def __call__(self, case: Case) -> Outcome:
        from pointat.errors import PatchError, PointatError

        path = self.path(case)
        path.write_bytes(case.data)
        args = self.parser.parse_args(["check", str(path)])  # (every option at its default)
        sink = io.StringIO()
        try:
            with contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink):
                self.cli.cmd_check(args, self.registry)
        except PatchError as exc:
            unlocated = [
                p.message
                for p in exc.problems
                if p.severity == "error" and (p.where is None or p.where.line < 1)
            ]
            return Outcome("refused", unlocated=unlocated[0] if unlocated else "")
        except PointatError as exc:
            return Outcome("refused", unlocated=str(exc) or type(exc).__name__)
        except BaseException as exc:  # noqa: BLE001 - what the fuzzer is looking for
            return _crash(exc)
        outcome = Outcome("ok")
        if self.run_for is not None:
            outcome = self.run(path)
        return outcome

    # ------------------------------------------------------------------ --run
    def safe(self, path: Path, overrides: list[str] | tuple[str, ...] = ()) -> bool:
        """Whether the checked patch at ``path`` (with ``--set overrides``) may run here: it opens no
        device (a serial port, MIDI), writes nothing outside the sandbox nor into a FIFO (which would wait
        for a reader), and sends to and listens on the loopback interface only."""
        from pointat.loader import check, parse_overrides, read_spec

        checked = check(read_spec(path), self.registry, parse_overrides(overrides))
        box = os.path.realpath(self.sandbox)
        for r in checked.nodes.values():
            if r.cls.type_name in ("midi_in", "midi_out") or r.values.get("device") not in (None, "", "none"):
                return False
            for p in r.cls.params:
                value = r.values.get(p.name)
                if p.type == "path" and value and (not p.reads or p.writes):
                    real = os.path.realpath(Path(r.decl.where.file).parent / str(value))
                    if os.path.commonpath([real, box]) != box and real != "/dev/null":
                        return False
                    if p.writes and os.path.exists(real) and not os.path.isfile(real):
                        return False
                if p.name == "host" and str(value) not in LOOPBACK:
                    return False
                if p.name in ("to", "allow") and value:
                    for item in value:
                        host = str(item).rpartition(":")[0]
                        if host and host not in LOOPBACK:
                            return False
        return True

    def run(self, path: Path) -> Outcome:
        try:
            if not self.safe(path):
                return Outcome("ok", ran="skipped")
        except Exception as exc:  # noqa: BLE001 - it checked a moment ago: anything now is a bug
            return _crash(exc, "run: ")
        self.thread_errors.clear()
        cwd = os.getcwd()
        try:
            os.chdir(path.parent)
            code = self.cli.main(["run", str(path), "--for", str(self.run_for)])
        except BaseException as exc:  # noqa: BLE001
            return _crash(exc, "run: ")
        finally:
            os.chdir(cwd)
        if self.thread_errors:
            return _crash(self.thread_errors[0], "run thread: ")
        return Outcome("ok", ran="ok" if code == 0 else "refused")


def _worker(conn: Connection, sandbox: Path, tag: str, memory_mb: int, run_for: float | None) -> None:
    """A worker: checks the cases its connection sends, one at a time, and answers each with an
    :class:`Outcome`; ``None`` ends it.  SIGUSR1 writes every thread's stack to ``faulthandler-TAG``."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's: it stops and reports
    null = os.open(os.devnull, os.O_RDWR)
    for fd in (0, 1, 2):
        os.dup2(null, fd)
    dump = open(sandbox / f"faulthandler-{tag}", "w")  # noqa: SIM115 - open while the worker lives
    faulthandler.register(signal.SIGUSR1, file=dump, all_threads=True)
    logging.disable(logging.CRITICAL)
    warnings.simplefilter("ignore")
    checker = _Checker(sandbox, tag, run_for)
    threading.excepthook = lambda a: checker.thread_errors.append(a.exc_value)  # type: ignore[arg-type]
    limit = memory_mb * 1024 * 1024
    _soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    resource.setrlimit(
        resource.RLIMIT_AS, (limit if hard == resource.RLIM_INFINITY else min(limit, hard), hard)
    )
    while True:
        case = conn.recv()
        if case is None:
            return
        outcome = checker(case)
        conn.send(outcome)
        if outcome.recycle:
            return


def _hang_key(dump: str) -> tuple[str, str]:
    """A hang's class (the innermost repository frame of the main thread) and the stack, from
    :mod:`faulthandler`'s dump."""
    blocks = re.split(r"\n(?=(?:Current thread|Thread) 0x)", dump.strip())
    main = next((b for b in blocks if b.startswith("Current thread")), blocks[-1] if blocks else "")
    frames = [(f, int(n), fn) for f, n, fn in re.findall(r'File "([^"]+)", line (\d+) in (\S+)', main)]
    return f"hang at {_repo_frame(reversed(frames))}", main


class Workers:
    """Worker processes (forked, so that they start with pointat already imported), each with a time
    limit per case."""

    def __init__(
        self,
        sandbox: Path,
        jobs: int,
        timeout: float = TIMEOUT,
        memory_mb: int = MEMORY_MB,
        run_for: float | None = None,
    ):
        self.sandbox, self.timeout, self.memory_mb, self.run_for = sandbox, timeout, memory_mb, run_for
        self.ctx = multiprocessing.get_context("fork")
        self.procs: list = [None] * jobs
        self.conns: list[Connection | None] = [None] * jobs
        self.done = [0] * jobs
        for k in range(jobs):
            self._start(k)

    def _start(self, k: int) -> None:
        here, there = self.ctx.Pipe()
        proc = self.ctx.Process(
            target=_worker,
            args=(there, self.sandbox, str(k), self.memory_mb, self.run_for),
            daemon=True,
            name=f"fuzz-{k}",
        )
        proc.start()
        there.close()
        self.procs[k], self.conns[k], self.done[k] = proc, here, 0

    def _stop(self, k: int, kill: bool) -> None:
        proc, conn = self.procs[k], self.conns[k]
        if proc is None or conn is None:
            return
        if kill:
            proc.kill()
        else:
            with contextlib.suppress(OSError):
                conn.send(None)
        proc.join(5)
        if proc.is_alive():
            proc.kill()
            proc.join()
        conn.close()
        self.procs[k] = self.conns[k] = None

    def close(self) -> None:
        for k in range(len(self.procs)):
            self._stop(k, kill=False)

    def _dump(self, k: int) -> str:
        path = self.sandbox / f"faulthandler-{k}"
        try:
            return path.read_text(errors="replace")
        except OSError:
            return ""
        finally:
            with contextlib.suppress(OSError):
                path.unlink()

    def map(self, todo: Iterable[Case]) -> Iterator[tuple[Case, Outcome]]:
        """Check every case of ``todo``, in parallel; yields them as they end (not in order)."""
        busy: dict[int, tuple[Case, float]] = {}
        try:
            yield from self._map(iter(todo), busy)
        finally:  # left before the end (Ctrl-C, or a caller that took what it wanted): no answer waits
            for k in busy:
                self._stop(k, kill=True)

    def _map(
        self, todo: Iterator[Case], busy: dict[int, tuple[Case, float]]
    ) -> Iterator[tuple[Case, Outcome]]:
        exhausted = False
        timeout = self.timeout + (self.run_for or 0.0) * 2
        while True:
            for k in range(len(self.procs)):
                if k in busy or exhausted:
                    continue
                case = next(todo, None)
                if case is None:
                    exhausted = True
                    break
                if self.procs[k] is None or self.done[k] >= RECYCLE:
                    self._stop(k, kill=False)
                    self._start(k)
                conn = self.conns[k]
                assert conn is not None
                try:
                    conn.send(case)
                except OSError:  # it ended after its last case (a MemoryError): a fresh one
                    self._stop(k, kill=True)
                    self._start(k)
                    conn = self.conns[k]
                    assert conn is not None
                    conn.send(case)
                busy[k] = (case, time.monotonic() + timeout)
            if not busy:
                return
            first = min(deadline for _case, deadline in busy.values())
            ready = wait([self.conns[k] for k in busy], max(0.0, first - time.monotonic()))
            for k in list(busy):
                conn = self.conns[k]
                case, deadline = busy[k]
                if conn in ready:
                    try:
                        outcome = conn.recv()
                    except (EOFError, OSError):
                        proc = self.procs[k]
                        proc.join(1)
                        code = proc.exitcode
                        how = f"signal {-code}" if code is not None and code < 0 else f"exit {code}"
                        outcome = Outcome("died", f"worker died ({how})", self._dump(k))
                        self._stop(k, kill=True)
                    else:
                        self.done[k] += 1
                        if outcome.recycle:
                            self._stop(k, kill=True)
                    del busy[k]
                    yield case, outcome
                elif time.monotonic() >= deadline:
                    proc = self.procs[k]
                    with contextlib.suppress(OSError):
                        os.kill(proc.pid, signal.SIGUSR1)
                    time.sleep(0.3)
                    self._stop(k, kill=True)
                    key, stack = _hang_key(self._dump(k))
                    del busy[k]
                    yield case, Outcome("hang", key, f"no answer in {timeout:g} s; main thread:\n{stack}")

    def one(self, case: Case) -> Outcome:
        return next(self.map([case]))[1]


# =========================================================================== reducing and saving
def reduce(workers: Workers, case: Case, key: str, budget: float = 60.0) -> Case:
    """A smaller case that still gives the class ``key``: lines dropped (halves, quarters... then one by
    one), then words.  Gives up after ``budget`` seconds."""
    end = time.monotonic() + budget

    def same(data: bytes) -> bool:
        return time.monotonic() < end and workers.one(Case(case.number, case.seed, data)).key == key

    def shrink(parts: list[bytes], glue: bytes) -> list[bytes]:
        chunk = max(len(parts) // 2, 1)
        while chunk >= 1 and time.monotonic() < end:
            start, cut = 0, False
            while start < len(parts) and time.monotonic() < end:
                trial = parts[:start] + parts[start + chunk :]
                if trial and same(glue.join(trial)):
                    parts, cut = trial, True
                else:
                    start += chunk
            if not cut:
                chunk //= 2
        return parts

    lines = shrink(case.data.split(b"\n"), b"\n")
    out: list[bytes] = []
    for k, line in enumerate(lines):
        words = line.split(b" ")
        start = 0
        while len(words) > 1 and start < len(words) and time.monotonic() < end:
            trial = words[:start] + words[start + 1 :]
            if same(b"\n".join([*out, b" ".join(trial), *lines[k + 1 :]])):
                words = trial
            else:
                start += 1
        out.append(b" ".join(words))
    return Case(case.number, case.seed, b"\n".join(out), case.mutations)


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "_", text).strip("_")[:80]


def save(report: Report, folder: Path) -> None:
    """Each class's case as a patch file, and a ``.txt`` beside it with its traceback."""
    folder.mkdir(parents=True, exist_ok=True)
    for n, cls in enumerate(sorted(report.classes.values(), key=lambda c: -c.count), 1):
        stem = f"{n:02d}_{_slug(cls.key)}"
        path = folder / (stem + cls.case.suffix)
        path.write_bytes(cls.case.data)
        (folder / (stem + ".txt")).write_text(
            f"{cls.key}\n{cls.count} case(s); this one: case {cls.case.number}, from {cls.case.seed} "
            f"({', '.join(cls.case.mutations) or 'reduced'})\n"
            f"to reproduce, copy it into {cls.case.folder}/ of the repository (the patches it names are "
            f"found from there) and run: pointat check {cls.case.folder}/{path.name}\n\n{cls.detail}\n",
            encoding="utf-8",
        )
        cls.saved = path


# =========================================================================== the whole run
def fuzz(
    *,
    cases_max: int | None = None,
    minutes: float | None = None,
    seed: int = 0,
    jobs: int | None = None,
    timeout: float = TIMEOUT,
    memory_mb: int = MEMORY_MB,
    run_for: float | None = None,
    save_dir: Path | None = None,
    reduce_seconds: float = 60.0,
    progress: Callable[[Report], None] | None = None,
) -> Report:
    """Check mutants until ``cases_max`` of them or ``minutes`` have gone; reduce and save each crash
    class's smallest case in ``save_dir`` (when given)."""
    seed_files = seeds()
    report = Report(save_dir=save_dir)
    end = math.inf if minutes is None else time.monotonic() + minutes * 60
    started = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="pointat-fuzz-") as tmp:
        sandbox = make_sandbox(Path(tmp), seed_files)
        workers = Workers(sandbox, jobs or os.cpu_count() or 1, timeout, memory_mb, run_for)
        todo = itertools.takewhile(lambda _case: time.monotonic() < end, cases(seed_files, seed))
        todo = itertools.islice(todo, cases_max)  # (None: no end)
        try:
            last = time.monotonic()
            with contextlib.suppress(KeyboardInterrupt):  # Ctrl-C: the report so far
                for case, outcome in workers.map(todo):
                    report.add(case, outcome)
                    if progress is not None and time.monotonic() - last > 10:
                        last = time.monotonic()
                        report.seconds = last - started
                        progress(report)
            report.seconds = time.monotonic() - started
            for cls in report.classes.values() if reduce_seconds > 0 else ():
                budget = reduce_seconds if cls.kind == "traceback" else min(reduce_seconds, 6 * timeout)
                with contextlib.suppress(KeyboardInterrupt):
                    cls.case = reduce(workers, cls.case, cls.key, budget)
                    cls.detail = workers.one(cls.case).detail or cls.detail
        finally:
            workers.close()
    if save_dir is not None and report.classes:
        save(report, save_dir)
    return report


def summary(report: Report) -> str:
    """The tally as a table, and each crash class with its reproducer."""
    c = report.counts
    rate = report.cases / report.seconds if report.seconds else 0.0
    rows = [
        ("cases", report.cases),
        ("clean ok", c["ok"]),
        ("clean refusals", c["refused"]),
        ("  (an error without a line)", sum(report.unlocated.values())),
        ("tracebacks", c["traceback"]),
        ("hangs", c["hang"]),
        ("workers died", c["died"]),
    ]
    rows += [(f"--run: {k}", v) for k, v in sorted(report.ran.items())]
    lines = [f"{name:<30} {value:>8}" for name, value in rows]
    lines.append(f"{'cases/s':<30} {rate:>8.1f}")
    if report.unlocated:
        lines.append("")
        lines.append("refusals whose error names no line (count, message with quotes and numbers as _):")
        for kind, n in sorted(report.unlocated.items(), key=lambda kv: -kv[1])[:8]:
            lines.append(f"{n:>6}  {kind}")
    if report.classes:
        lines.append("")
        lines.append(f"{len(report.classes)} crash classes (count, class, reproducer):")
        for cls in sorted(report.classes.values(), key=lambda k: -k.count):
            lines.append(f"{cls.count:>6}  {cls.key}")
            if cls.saved is not None:
                lines.append(f"        {cls.saved}")
    if report.save_dir is not None and report.classes:
        lines.append(f"reproducers: {report.save_dir}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tests.fuzz", description=__doc__.split("\n\n")[0])
    ap.add_argument("--minutes", type=float, help="stop after this long (default: 1, or none with --cases)")
    ap.add_argument("--cases", type=int, help="stop after this many mutants")
    ap.add_argument("--seed", type=int, default=0, help="the mutants' seed: the same seed, the same mutants")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="worker processes")
    ap.add_argument("--timeout", type=float, default=TIMEOUT, help="seconds a case may take (a hang)")
    ap.add_argument("--memory", type=int, default=MEMORY_MB, help="a worker's address space, in MB")
    ap.add_argument("--save", type=Path, help="folder for the reproducers (default: a new temporary one)")
    ap.add_argument("--no-reduce", action="store_true", help="save each class's smallest case as it came")
    ap.add_argument(
        "--run",
        nargs="?",
        const=0.5,
        type=float,
        metavar="SECONDS",
        help="also run each mutant that passes (default 0.5 s) when it writes nothing outside the "
        "sandbox and talks to 127.0.0.1 only",
    )
    args = ap.parse_args(argv)
    minutes = args.minutes if args.minutes is not None or args.cases is not None else 1.0
    save_dir = args.save or Path(tempfile.mkdtemp(prefix="pointat-fuzz-crashes-"))
    print(
        f"fuzzing: seed {args.seed}, {args.jobs} workers, {args.timeout:g} s and {args.memory} MB a case"
        + (f", {args.cases} cases" if args.cases else "")
        + (f", {minutes:g} min" if minutes else ""),
        flush=True,
    )

    def progress(r: Report) -> None:
        print(
            f"  {r.cases} cases, {r.counts['traceback']} tracebacks, {r.counts['hang']} hangs, "
            f"{len(r.classes)} classes, {r.cases / r.seconds:.0f}/s",
            flush=True,
        )

    report = fuzz(
        cases_max=args.cases,
        minutes=minutes,
        seed=args.seed,
        jobs=args.jobs,
        timeout=args.timeout,
        memory_mb=args.memory,
        run_for=args.run,
        save_dir=save_dir,
        reduce_seconds=0.0 if args.no_reduce else 60.0,
        progress=progress,
    )
    print(summary(report))
    return 1 if report.failures else 0


if __name__ == "__main__":
    sys.exit(main())
