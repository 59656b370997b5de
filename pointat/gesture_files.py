"""Gesture files: folders of labelled recordings (CSV), and the model files the gesture nodes keep.

A folder of recordings holds one folder per label, and one CSV file per example in it::

    DIR/circle/1.csv   DIR/circle/2.csv   DIR/flick/take-3.csv ...

Each CSV has a header and a row per sample: ``t`` (seconds, increasing) and any of the channel groups
``acc_x,acc_y,acc_z`` (m/s², +g up at rest), ``gyr_x,gyr_y,gyr_z`` (rad/s), ``mag_x,mag_y,mag_z``
and ``qw,qx,qy,qz`` (the orientation, sensor -> earth); other columns are ignored, as are blank lines and
lines starting with ``#``.  ``.csv.gz`` is read too.

A model file is JSON: ``{"format": "pointat-gestures", "version": 1, "kind": ..., "channels": [...],
"size": N, "examples": [{"label": ..., "t": [...], "frames": [[...], ...]}, ...]}``: the examples
themselves, from which the node trains again as it loads (training takes well under a second), so a
file stays readable whatever the training becomes.

Every error names the file, and the line or the example, and says what was expected and what was found.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import unicodedata
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from pointat.maths.gestures import CHANNELS, Example, channel_slices
from pointat.names import BadName, check_name, inside
from pointat.saving import write_atomic
from pointat.userfiles import read_json, read_text

__all__ = [
    "COLUMNS",
    "KINDS",
    "export_model",
    "FORMAT",
    "Recording",
    "dump_model",
    "load_model",
    "model_text",
    "read_folder",
    "read_recording",
    "write_recording",
]

#: The CSV columns of each channel group.
COLUMNS: dict[str, tuple[str, ...]] = {
    "acc": ("acc_x", "acc_y", "acc_z"),
    "gyr": ("gyr_x", "gyr_y", "gyr_z"),
    "mag": ("mag_x", "mag_y", "mag_z"),
    "q": ("qw", "qx", "qy", "qz"),
}

FORMAT = "pointat-gestures"
VERSION = 1

#: Limits that keep a hostile or broken file from taking the machine: an example this long is no
#: gesture (a minute at 1 kHz), and no model holds more examples than a performer records.
MOST_SAMPLES = 60_000
MOST_EXAMPLES = 10_000


class Recording:
    """One labelled recording: its label, path, times (s) and channel groups (name -> (T, k) array)."""

    def __init__(self, label: str, path: str, t: np.ndarray, groups: dict[str, np.ndarray]):
        self.label, self.path, self.t, self.groups = label, path, t, groups

    def example(self, channels: Sequence[str]) -> Example:
        """The recording as an :class:`~pointat.maths.gestures.Example` of these channels."""
        missing = [c for c in channels if c not in self.groups]
        if missing:
            cols = ", ".join(col for c in missing for col in COLUMNS.get(c, (c,)))
            raise ValueError(f"{self.path}: no column(s) {cols} (channels {' '.join(channels)})")
        return Example(self.label, self.t, np.column_stack([self.groups[c] for c in channels]))


def read_recording(path: str | os.PathLike[str], label: str = "") -> Recording:
    """Read one CSV recording; ``ValueError`` naming the file and line for anything amiss."""
    path = Path(path)
    text = read_text(path, "recording", gzip_ok=True)  # a regular file of 64 MB at most, never a wait
    reader = csv.reader(io.StringIO(text, newline=""))
    rows = []
    try:
        for r in reader:
            if r and not r[0].lstrip().startswith("#"):
                rows.append((reader.line_num, r))
    except csv.Error as exc:  # a stray carriage return, a NUL, an unclosed quote
        raise ValueError(f"{path}:{reader.line_num}: not CSV ({exc})") from None
    rows = [(n, r) for n, r in rows if any(c.strip() for c in r)]
    if not rows:
        raise ValueError(f"{path}: empty (expected a header: t and channel columns such as acc_x)")
    header_line, header = rows[0]
    names = [h.strip() for h in header]
    if "t" not in names:
        raise ValueError(f"{path}:{header_line}: no column 't' in the header (got {', '.join(names)[:200]})")
    where = {name: i for i, name in enumerate(names)}
    groups: dict[str, list[int]] = {}
    for group, cols in COLUMNS.items():
        present = [c for c in cols if c in where]
        if present and len(present) < len(cols):
            lacking = [c for c in cols if c not in where]
            raise ValueError(f"{path}:{header_line}: {', '.join(present)} without {', '.join(lacking)}")
        if present:
            groups[group] = [where[c] for c in cols]
    if not groups:
        raise ValueError(
            f"{path}:{header_line}: no channel columns (expected acc_x..z, gyr_x..z, mag_x..z or qw..qz)"
        )
    body = rows[1:]
    if not body:
        raise ValueError(f"{path}: a header and no samples")
    if len(body) > MOST_SAMPLES:
        raise ValueError(f"{path}: {len(body)} samples; at most {MOST_SAMPLES} in a gesture recording")
    wanted = [where["t"]] + [i for cols in groups.values() for i in cols]
    data = np.empty((len(body), len(wanted)))
    for k, (n, row) in enumerate(body):
        if len(row) != len(names):
            raise ValueError(f"{path}:{n}: {len(row)} values, the header has {len(names)}")
        for j, i in enumerate(wanted):
            cell = row[i].strip()
            try:
                v = float(cell)
            except ValueError:
                raise ValueError(
                    f"{path}:{n}: column {names[i]}: expected a number, got {cell[:40]!r}"
                ) from None
            if not math.isfinite(v):
                raise ValueError(
                    f"{path}:{n}: column {names[i]}: expected a finite number, got {cell[:40]!r}"
                )
            data[k, j] = v
        if k and not data[k, 0] > data[k - 1, 0]:
            raise ValueError(
                f"{path}:{n}: t = {data[k, 0]:g} does not increase (the sample before: {data[k - 1, 0]:g})"
            )
    out, at = {}, 1
    for group in groups:
        out[group] = data[:, at : at + CHANNELS[group]]
        at += CHANNELS[group]
    return Recording(label, str(path), data[:, 0].copy(), out)


def _is_recording(p: Path) -> bool:
    # (not is_file: a pipe or a dangling link named like a recording is read, and refused by name)
    return not p.is_dir() and (p.name.endswith(".csv") or p.name.endswith(".csv.gz"))


def read_folder(folder: str | os.PathLike[str]) -> list[Recording]:
    """Every recording of a folder laid out as ``DIR/<label>/<example>.csv``, labels and files sorted."""
    root = Path(folder)
    if not root.is_dir():
        raise ValueError(f"{root}: not a folder (expected DIR/<label>/<example>.csv)")
    out = []
    for sub in sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith(".")):
        for f in sorted(p for p in sub.iterdir() if _is_recording(p)):
            out.append(read_recording(f, sub.name))
    if not out:
        loose = [p.name for p in root.iterdir() if _is_recording(p)][:3]
        hint = f" ({', '.join(loose)} lie in it without a label folder)" if loose else ""
        raise ValueError(f"{root}: no recordings in DIR/<label>/<example>.csv{hint}")
    return out


def write_recording(path: str | os.PathLike[str], t: Sequence[float], groups: dict[str, Any]) -> None:
    """Write one recording as CSV (the layout :func:`read_recording` reads)."""
    cols = ["t"] + [c for g in groups for c in COLUMNS[g]]
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(cols)
        arrays = [np.asarray(groups[g], dtype=float) for g in groups]
        for k, tk in enumerate(t):
            w.writerow([repr(float(tk))] + [repr(float(v)) for a in arrays for v in a[k]])


# ------------------------------------------------------------------------------------------ models
def dump_model(
    path: str | os.PathLike[str], kind: str, channels: Sequence[str], size: int, examples: Sequence[Example]
) -> None:
    """Write a model file (atomically, synced: a crash mid-write leaves the old file whole)."""
    write_atomic(path, model_text(kind, channels, size, examples))


def model_text(kind: str, channels: Sequence[str], size: int, examples: Sequence[Example]) -> str:
    """A model file's text (what :func:`dump_model` writes; a node's saver writes it on its thread)."""
    doc = {
        "format": FORMAT,
        "version": VERSION,
        "kind": kind,
        "channels": list(channels),
        "size": int(size),
        "examples": [{"label": e.label, "t": e.t.tolist(), "frames": e.frames.tolist()} for e in examples],
    }
    return json.dumps(doc, separators=(",", ":"))


def _label(value: Any, where: str) -> str:
    try:
        return check_name("label", value)  # a label becomes a folder (export): never a path
    except BadName as exc:
        raise ValueError(f"{where}: {exc}") from None


KINDS = ("gesture", "posture", "follow")


def load_model(path: str | os.PathLike[str], kind: str | None) -> tuple[tuple[str, ...], int, list[Example]]:
    """Read a model file written by :func:`dump_model`: (channels, size, examples); ``ValueError``
    naming the file and the example for anything amiss.  ``kind``: the node's, or None for any."""
    p = Path(path)
    doc = read_json(p, "gesture model")  # a regular file of 256 MB at most, never a wait
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise ValueError(f'{p}: not a pointat gesture model (expected "format": "{FORMAT}")')
    if doc.get("version") != VERSION:
        raise ValueError(f"{p}: version {doc.get('version')!r}; this pointat reads version {VERSION}")
    if doc.get("kind") not in KINDS or (kind is not None and doc.get("kind") != kind):
        raise ValueError(f"{p}: a model of kind {doc.get('kind')!r}; this node learns {kind!r}")
    channels = doc.get("channels")
    if (
        not isinstance(channels, list)
        or not channels
        or not all(isinstance(c, str) and c in CHANNELS for c in channels)
    ):
        raise ValueError(f"{p}: channels: expected a list of {', '.join(CHANNELS)}; got {str(channels)[:80]}")
    if len(set(channels)) != len(channels):
        raise ValueError(f"{p}: channels: {channels} names one twice")
    size = doc.get("size", 0)
    if (
        not isinstance(size, int)
        or isinstance(size, bool)
        or not 0 <= size <= 1000
        or (("x" in channels) != (size > 0))
    ):
        raise ValueError(f"{p}: size: expected 1..1000 with channel x, 0 without; got {str(size)[:40]}")
    width = channel_slices(channels, size)[channels[-1]].stop
    items = doc.get("examples")
    if not isinstance(items, list):
        raise ValueError(f"{p}: examples: expected a list")
    if len(items) > MOST_EXAMPLES:
        raise ValueError(f"{p}: {len(items)} examples; at most {MOST_EXAMPLES}")
    examples = []
    for i, item in enumerate(items):
        where = f"{p}: examples[{i}]"
        if not isinstance(item, dict):
            raise ValueError(f"{where}: expected an object with label, t and frames")
        label = _label(item.get("label"), where)
        t, frames = item.get("t"), item.get("frames")
        if not isinstance(t, list) or not isinstance(frames, list) or not t or len(t) != len(frames):
            raise ValueError(f"{where}: expected t and frames, lists of the same length, at least one")
        if len(t) > MOST_SAMPLES:
            raise ValueError(f"{where}: {len(t)} samples; at most {MOST_SAMPLES}")
        for k, row in enumerate(frames):
            if not isinstance(row, list) or len(row) != width:
                got = len(row) if isinstance(row, list) else type(row).__name__
                raise ValueError(
                    f"{where}.frames[{k}]: expected {width} numbers ({' '.join(channels)}); got {got}"
                )
        try:
            ta = np.array(t, dtype=float)
            fa = np.array(frames, dtype=float)
        except (TypeError, ValueError, OverflowError):
            raise ValueError(f"{where}: t and frames must hold numbers only") from None
        if any(isinstance(v, bool) for v in t) or any(isinstance(v, bool) for r in frames for v in r):
            raise ValueError(f"{where}: t and frames must hold numbers, not true or false")
        try:
            examples.append(Example(label, ta, fa))
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None
    return tuple(channels), size, examples


def export_model(path: str | os.PathLike[str], folder: str | os.PathLike[str]) -> list[Path]:
    """A model file's examples as recordings, ``folder/<label>/<n>.csv`` (what ``pointat gestures
    evaluate`` reads): examples taught in rehearsal become a test set, or a training set, of their own.
    Files already there are never replaced; ``ValueError`` says what stood in the way."""
    channels, size, examples = load_model(path, None)
    if "x" in channels:
        raise ValueError(f"{path}: channel x has no CSV columns; only acc, gyr, mag and q export")
    root = Path(folder)
    counts: dict[str, int] = {}
    plan = []
    for e in examples:
        counts[e.label] = counts.get(e.label, 0) + 1
        dest = root / check_name("label", e.label) / f"{counts[e.label]}.csv"
        inside(root, dest)  # and again once resolved: a label folder that is a link out of DIR
        plan.append((dest, e))
    folded: dict[str, str] = {}  # labels one folder on a system that ignores case (macOS, Windows)
    for label in counts:
        other = folded.setdefault(unicodedata.normalize("NFC", label).casefold(), label)
        if other != label:
            raise ValueError(
                f"{path}: labels {other!r} and {label!r} would share a folder where case is ignored: nothing"
                " written"
            )
    there = [str(dest) for dest, _ in plan if dest.exists()]
    if there:
        raise ValueError(f"{there[0]} already there ({len(there)} files): nothing written")
    for dest, e in plan:
        dest.parent.mkdir(parents=True, exist_ok=True)
        inside(root, dest)
        write_recording(dest, e.t, {c: e.frames[:, sl] for c, sl in channel_slices(channels, size).items()})
    return [dest for dest, _ in plan]
