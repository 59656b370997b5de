"""Presets: named snapshots of a running patch's live parameters, kept in a JSON file beside the patch.

``/pointat/preset/save NAME`` takes every live parameter of every node (files and devices aside: live
control names none), ``recall NAME`` sets them again (each checked as any live change is; a node or a
parameter the patch no longer has is skipped and told), ``delete NAME`` forgets one; a name is a name,
never a path (:func:`pointat.names.check_name`).  The file is written on a thread of its own
(:class:`pointat.saving.Saver`: a flood of saves is a few writes, the latest state wins, and the patch is
never held up), whole to a temporary file, synced and renamed over the old one, so a crash never leaves
half a file; at most :data:`MOST_PRESETS` presets and :data:`MOST_BYTES` bytes (a save beyond is refused
and told).  A file that cannot be read (a pipe, a device, one too large, not JSON: read as every user
file is, :mod:`pointat.userfiles`) is never written over (the presets saved meanwhile stay in memory,
and the log says so).

The file (``glove_tqt.presets.json`` beside ``glove_tqt.pat``)::

    {"pointat_presets": 1, "presets": {"stage": {"tqt/fuse": {"k_heading": 0.05}, "out": {"rate": 50.0}}}}
"""

from __future__ import annotations

import json
import logging
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from .names import check_name
from .saving import Saver, clean_stray
from .shipped import is_shipped
from .userfiles import read_json

__all__ = ["Presets", "presets_path"]

log = logging.getLogger("pointat.presets")

FORMAT = 1

#: The most presets a patch keeps, and the most bytes their file may take: a save beyond either is refused.
MOST_PRESETS = 256
MOST_BYTES = 1_000_000


def presets_path(patch: str | os.PathLike[str], writable_dir: str | os.PathLike[str] | None = None) -> Path:
    """Where a patch's presets live: beside it, or in ``writable_dir`` (the current folder) for a
    shipped patch (read-only, installed or in a checkout: :func:`pointat.shipped.is_shipped`) or one
    whose own folder cannot be written."""
    p = Path(patch)
    name = p.stem + ".presets.json"
    folder = p.parent
    if is_shipped(p) or not os.access(folder, os.W_OK) or "site-packages" in folder.parts:
        folder = Path(writable_dir or os.getcwd())
    return folder / name


def _plain(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return [_plain(v) for v in value.tolist()]
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None  # NaN (a dip to learn) has no JSON: recall leaves it as it is
    return value


class Presets:
    """The presets of one running patch (``rt.presets``); ``save``, ``recall``, ``delete``, ``names``."""

    def __init__(self, rt: Any, path: str | os.PathLike[str]):
        self.rt = rt
        self.path = Path(path)
        self.presets: dict[str, dict[str, dict[str, Any]]] = {}
        self._sizes: dict[str, int] = {}  # each preset's bytes in the file, for MOST_BYTES
        self.writable = True
        self.saver = Saver("presets")
        clean_stray(self.path)  # a save a kill cut short
        if os.path.lexists(self.path):
            try:
                self.presets = _read(self.path)
                self._sizes = {name: _size(name, v) for name, v in self.presets.items()}
            except ValueError as exc:  # a pipe, a device, too large, not JSON, a bad name: with its place
                self.writable = False
                log.error(
                    "presets: %s cannot be read (%s); it is left as it is, and presets saved now are kept "
                    "in memory only",
                    self.path,
                    exc,
                )

    def names(self) -> list[str]:
        return sorted(self.presets)

    def snapshot(self) -> dict[str, dict[str, Any]]:
        """Every live parameter's value now (paths aside), by node."""
        out: dict[str, dict[str, Any]] = {}
        for name, node in self.rt.nodes.items():
            values = {
                p.name: _plain(getattr(node.p, p.name))
                for p in type(node).params
                if p.live and p.type != "path"
            }
            if values:
                out[name] = values
        return out

    def save(self, name: str) -> None:
        """Take every live parameter as preset ``name``; the file is written on the saver's thread
        (the latest state wins: a flood of saves is a few writes), refused past :data:`MOST_PRESETS`
        presets or :data:`MOST_BYTES` bytes."""
        check_name("preset", name)
        values = self.snapshot()
        size = _size(name, values)
        if name not in self.presets and len(self.presets) >= MOST_PRESETS:
            raise ValueError(
                f"preset '{name}' not saved: {len(self.presets)} presets already, the most a patch keeps"
                " (delete one, or save over one)"
            )
        total = sum(self._sizes.values()) - self._sizes.get(name, 0) + size
        if total > MOST_BYTES:
            raise ValueError(
                f"preset '{name}' not saved: the presets would take {total / 1e6:.1f} MB, more than the"
                f" {MOST_BYTES / 1e6:.0f} MB a presets file may (delete some)"
            )
        self.presets[name] = values
        self._sizes[name] = size
        self._write()
        self.rt.console(f"preset '{name}' saved ({sum(map(len, self.presets[name].values()))} settings)")

    def recall(self, name: str) -> None:
        check_name("preset", name)
        if name not in self.presets:
            raise KeyError(f"no preset '{name}' (presets: {', '.join(self.names()) or 'none yet'})")
        skipped = []
        n = 0
        for node_name, values in self.presets[name].items():
            node = self.rt.nodes.get(node_name)
            if node is None or not isinstance(values, dict):
                skipped.append(node_name)
                continue
            for param, value in values.items():
                spec = type(node).param(param)
                if spec is None or not spec.live or spec.type == "path" or value is None:
                    skipped.append(f"{node_name}.{param}")
                    continue
                self.rt.set_param(node_name, param, value)
                n += 1
        self.rt.console(
            f"preset '{name}' recalled ({n} settings)"
            + (f"; not in this patch, skipped: {', '.join(skipped[:8])}" if skipped else "")
        )

    def delete(self, name: str) -> None:
        if self.presets.pop(name, None) is None:
            raise KeyError(f"no preset '{name}'")
        self._sizes.pop(name, None)
        self._write()
        self.rt.console(f"preset '{name}' deleted")

    def _write(self) -> None:
        if not self.writable:
            log.warning("presets: %s could not be read at the start: not written over", self.path)
            return
        presets = dict(self.presets)  # (a preset's values are replaced whole, never changed in place)
        self.saver.submit(
            self.path,
            lambda: (
                json.dumps({"pointat_presets": FORMAT, "presets": presets}, indent=1, sort_keys=True) + "\n"
            ),
        )

    def close(self) -> None:
        """Write a save still waiting, and stop the saver's thread (the runtime's shutdown calls it)."""
        self.saver.close()


def _read(path: Path) -> dict[str, dict[str, dict[str, Any]]]:
    """The presets in a presets file, read as every user file is; ``ValueError`` naming the file."""
    data = read_json(path, "presets")
    if not isinstance(data, dict) or not isinstance(data.get("presets"), dict):
        raise ValueError(
            f'{path}: expected {{"pointat_presets": 1, "presets": {{NAME: {{NODE: {{PARAM: VALUE}}}}}}}}'
        )
    presets = {}
    for name, values in data["presets"].items():
        try:
            check_name("preset", name)
        except ValueError as exc:
            raise ValueError(f"{path}: presets: {exc}") from None
        if isinstance(values, dict):
            presets[name] = values
    return presets


def _size(name: str, values: dict[str, Any]) -> int:
    """What a preset adds to the file (its JSON, about)."""
    return len(json.dumps({name: values}, indent=1)) + 2
