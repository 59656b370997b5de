"""The patch a command names: its arguments (the patch, ``--set``, ``--out``), the file or shipped patch
it names, where its files go, and the patch read, checked or made ready as ``run`` makes it."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Any

from .. import checking, loader, shipped
from ..errors import PointatError, did_you_mean
from ..expansion import read_spec
from ..loader import parse_overrides
from ..registry import Registry


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The arguments of a command that reads a patch (run, check, graph): the patch, ``--set``, ``--out``."""
    p.add_argument(
        "patch",
        help="a patch file (.pat native, or .pd Pure Data), or a shipped patch by name: glove_tqt, "
        "pointing_at, replay_glove... (`pointat patches` lists them)",
    )
    p.add_argument(
        "--set",
        metavar="NODE.PARAM=VALUE",
        action="append",
        default=[],
        help="override a node parameter (repeatable); INSTANCE.ARG sets an abstraction instance's argument, "
        "INSTANCE/NODE.PARAM a node inside it",
    )
    p.add_argument(
        "--out",
        metavar="DIR",
        help="where a shipped patch's files go (default: this folder): takes, calibrations, BVH and MIDI "
        "files, gesture examples, presets; what it reads is your copy there first, else the shipped one.  "
        "A shipped patch is read-only: nothing is written beside it.  A patch of your own reads and "
        "writes beside itself, as in Pd; --set paths are relative to this folder",
    )


def find(name: str) -> str:
    """The patch a user named: the file, when there is one; else a shipped patch of that name
    (``pointat run glove_tqt`` from any folder, installed or in a checkout)."""
    if os.path.exists(name):
        return name
    found = shipped.find_patch(name)
    if found is not None:
        return str(found)
    if Path(name).suffix.lower() not in (".pat", ".pd"):  # a name, not a file: say which was meant
        names = shipped.patch_names()
        raise PointatError(
            f"no patch file or shipped patch {name!r}"
            + (did_you_mean(name, names) or did_you_mean(Path(name).name, names))
            + ": `pointat patches` lists the shipped ones"
        )
    return name  # (reading it says why it cannot be read)


def out_folder(args: argparse.Namespace) -> Path:
    """Where a shipped patch's files go: ``--out DIR`` (a folder that is there), else this folder."""
    if args.out is not None and not os.path.isdir(args.out):
        raise PointatError(f"--out {args.out}: no such folder (make it first: mkdir {args.out})")
    return Path(args.out or ".").absolute()


def read(args: argparse.Namespace) -> Any:
    """The patch read, told where its files go when it is a shipped one."""
    spec = read_spec(args.patch)
    spec.out = str(out_folder(args))
    return spec


def seed(args: argparse.Namespace) -> list[tuple[Path, Path]]:
    """A shipped patch's own files, which it reads and writes (gestures.json: the examples it loads and
    saves), copied into the output folder when they are not there yet: the user's own to teach more and
    save, where the shipped one stays as it is.  Returns (shipped, copy) pairs."""
    copied = []
    for src in shipped.seeds(args.patch):
        dest = out_folder(args) / src.name
        if not dest.exists():
            try:
                dest.write_bytes(src.read_bytes())
            except OSError as exc:
                raise PointatError(f"cannot copy {src.name} into {dest.parent}: {exc.strerror}") from None
            copied.append((src, dest))
    return copied


def check(args: argparse.Namespace, registry: Registry):
    """The patch checked (:func:`pointat.checking.check`), its warnings printed."""
    checked = checking.check(read(args), registry, parse_overrides(args.set))
    for w in checked.warnings:
        print(w, file=sys.stderr)
    return checked


def ready(args: argparse.Namespace, registry: Registry):
    """The patch checked, its files read, its nodes built and prepared: all that ``check`` does, and all
    that ``run`` does before it opens a port (:func:`pointat.loader.ready`)."""
    checked, rt = loader.ready(read(args), registry, parse_overrides(args.set))
    for w in checked.warnings:
        print(w, file=sys.stderr)
    return checked, rt
