"""Presets: named snapshots of a running patch's live parameters, kept in a JSON file beside the patch.

``/pointat/preset/save NAME`` takes every live parameter of every node (files and devices aside: live
control names none), ``recall NAME`` sets them again (each checked as any live change is; a node or a
parameter the patch no longer has is skipped and told), ``delete NAME`` forgets one.  The file is
written whole to a temporary file and renamed over the old one, so a crash never leaves half a file; a
file that cannot be read is never written over (the presets saved meanwhile stay in memory, and the log
says so).

The file (``glove_tqt.presets.json`` beside ``glove_tqt.pat``)::

    {"pointat_presets": 1, "presets": {"stage": {"tqt/fuse": {"k_heading": 0.05}, "out": {"rate": 50.0}}}}
"""

from __future__ import annotations

import json
import logging
import math
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from .names import check_name
from .userfiles import read_json

__all__ = ["Presets", "presets_path"]

log = logging.getLogger("pointat.presets")

FORMAT = 1


def presets_path(patch: str | os.PathLike[str], writable_dir: str | os.PathLike[str] | None = None) -> Path:
    """Where a patch's presets live: beside it, or in ``writable_dir`` (the current folder) when the
    patch's own folder cannot be written (a patch shipped inside an installed package)."""
    p = Path(patch)
    name = p.stem + ".presets.json"
    folder = p.parent
    if not os.access(folder, os.W_OK) or "site-packages" in folder.parts:
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
        self.writable = True
        if os.path.lexists(self.path):
            try:
                self.presets = _read(self.path)
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
        check_name("preset", name)
        self.presets[name] = self.snapshot()
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
        self._write()
        self.rt.console(f"preset '{name}' deleted")

    def _write(self) -> None:
        if not self.writable:
            log.warning("presets: %s could not be read at the start: not written over", self.path)
            return
        text = json.dumps({"pointat_presets": FORMAT, "presets": self.presets}, indent=1, sort_keys=True)
        fd, tmp = tempfile.mkstemp(prefix=".presets-", dir=self.path.parent)
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(text + "\n")
            os.replace(tmp, self.path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise


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
