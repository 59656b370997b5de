"""What reading and writing Pd files share: the vanilla objects, names and tokens."""

from __future__ import annotations

import logging
import re
from typing import Any

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


def _print_args(args: list[Any]) -> list[Any]:
    """A ``[print]`` box's creation atoms as pointat's ``print`` takes them.

    Pd's ``print`` joins all its atoms into its prefix, one space apart (``[print gyro nulls]`` prints
    ``gyro nulls: ...``), numbers as Pd shows them.  Two atoms of which the second is 0 or 1 are the
    prefix and ``time``, the form pointat writes for ``time=true``; three, the second 0 or 1 and the third
    a whole number, are the prefix, ``time`` and ``decimals``.
    """
    timed = len(args) in (2, 3) and type(args[1]) is int and args[1] in (0, 1)
    if len(args) < 2 or (timed and (len(args) == 2 or type(args[2]) is int)):
        return args
    return [" ".join(f"{a:g}" if isinstance(a, (int, float)) else str(a) for a in args)]
