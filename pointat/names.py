"""Names that become files: a gesture's label, a preset's name.  A name is one word of a folder, never a path.

A label is the folder ``pointat gestures export`` writes an example into (``DIR/<label>/1.csv``), and it
comes from outside: live OSC (``/pointat/NODE/record LABEL``), a patch, a model file someone sent.  So
every door checks it here, with one rule: :func:`check_name` accepts a name only if it stays one entry of
the folder it is put in, on Linux, macOS and Windows alike:

* 1 to :data:`MOST_CHARACTERS` characters, at most :data:`MOST_BYTES` bytes as UTF-8 (a file name's
  room is 255 bytes, and ``1.csv`` goes after it);
* no ``/`` or ``\\``, none of Windows' ``< > : " | ? *``, no control or format character (NUL, a
  newline, a right-to-left override), no unpaired surrogate;
* not ``.`` or ``..``, not starting with ``.`` (a hidden file, and ``read_folder`` skips those), not
  ending with a dot or a space (Windows drops them), not a Windows device (``CON``, ``nul.txt``, ``COM1``);
* a label is a word (no space at all: ``record circle 3`` is a label and a count); a preset's name may
  hold single spaces inside (``/pointat/preset/save "slow stage"``).

:func:`inside` is the second line of defence where a file is written: the path, resolved (symbolic links
followed), must lie in the folder.

>>> check_name("label", "circle")
'circle'
>>> check_name("label", "../../escaped")
Traceback (most recent call last):
...
pointat.names.BadName: label: expected a name, not a path: no '/' (got '../../escaped')
"""

from __future__ import annotations

import os
import re
import unicodedata
from pathlib import Path
from typing import Any

from .errors import PointatError

__all__ = ["MOST_BYTES", "MOST_CHARACTERS", "BadName", "check_name", "inside"]

MOST_CHARACTERS = 100
MOST_BYTES = 200

#: What each kind of name may hold besides the rule above: whether spaces are allowed inside.
KINDS = {"label": False, "preset": True}

_FORBIDDEN = '/\\<>:"|?*'
_WINDOWS_DEVICE = re.compile(r"(con|prn|aux|nul|com[0-9¹²³]|lpt[0-9¹²³]|conin\$|conout\$)", re.IGNORECASE)


class BadName(PointatError, ValueError):
    """A name that would not stay one entry of its folder (a path, a device, a control character)."""


def check_name(kind: str, value: Any) -> str:
    """``value`` when it is a good ``kind`` name (``label``, ``preset``); :class:`BadName` saying why not.

    >>> check_name("preset", "slow stage")
    'slow stage'
    >>> check_name("label", "CON")
    Traceback (most recent call last):
    ...
    pointat.names.BadName: label: expected a file's name, not a device's: 'CON' is one on Windows
    """
    spaces = KINDS.get(kind, False)

    def bad(why: str) -> BadName:
        shown = (
            repr(value[:40] + ("..." if len(value) > 40 else "")) if isinstance(value, str) else repr(value)
        )
        return BadName(f"{kind}: {why} (got {shown})")

    if not isinstance(value, str):
        raise BadName(f"{kind}: expected text, got {type(value).__name__} {str(value)[:40]!r}")
    if not value:
        raise bad("expected a name, got nothing")
    if len(value) > MOST_CHARACTERS:
        raise bad(f"expected at most {MOST_CHARACTERS} characters, got {len(value)}")
    for c in value:
        if c in _FORBIDDEN:
            what = "a name, not a path" if c in "/\\" else "a name a file can have on any system"
            raise bad(f"expected {what}: no {c!r}")
        category = unicodedata.category(c)
        if category[0] == "C" and category != "Cn" or category in ("Zl", "Zp"):  # control, format...
            raise bad(f"expected printable characters: no {unicodedata.name(c, f'U+{ord(c):04X}')}")
        if c.isspace() and (not spaces or c != " "):
            raise bad("expected one word: no spaces" if not spaces else "expected no tabs or other spaces")
    if spaces and ("  " in value or value != value.strip()):
        raise bad("expected single spaces between words, none at the ends")
    if len(value.encode("utf-8")) > MOST_BYTES:
        raise bad(f"expected at most {MOST_BYTES} bytes as UTF-8")
    if value in (".", ".."):
        raise bad("expected a name, not a folder ('.' is this one, '..' the one above)")
    if value.startswith("."):
        raise bad("expected a name, not a hidden or relative one: no '.' first")
    if value.endswith((".", " ")):
        raise bad("expected a name a file can have on any system: no '.' or space last")
    if _WINDOWS_DEVICE.fullmatch(value.split(".")[0].rstrip(" ")):
        raise BadName(f"{kind}: expected a file's name, not a device's: {value!r} is one on Windows")
    return value


def inside(folder: str | os.PathLike[str], path: str | os.PathLike[str]) -> Path:
    """``path`` resolved (symbolic links followed, ``..`` taken), when it lies in ``folder`` resolved;
    :class:`BadName` otherwise: a file about to be written never lands outside the folder it was meant for.
    """
    root = Path(folder).resolve()
    where = Path(path).resolve()
    if where != root and root not in where.parents:
        raise BadName(f"{path}: resolves to {where}, outside {root}: not written")
    return where
