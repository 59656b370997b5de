"""A patch written in another form: ``pointat graph`` (Graphviz dot, SVG), ``convert`` (native .pat to
Pure Data .pd and back) and ``stubs`` (Pd abstractions for the node types Pd does not have)."""

from __future__ import annotations

import argparse
import errno
import os
import sys
from pathlib import Path
from typing import Any

from ..checking import check
from ..errors import PointatError
from ..expansion import read_spec
from ..registry import Registry
from ..spec import is_pd_file
from . import patch


def add_graph(sub: Any) -> None:
    """``pointat graph``: a patch as Graphviz dot."""
    p = sub.add_parser("graph", help="write the patch as Graphviz dot (and SVG when dot is installed)")
    patch.add_arguments(p)
    p.add_argument("-o", "--output", help="dot file to write (default: standard output)")


def add_conversions(sub: Any) -> None:
    """``pointat convert`` and ``stubs``: native patches to Pure Data and back."""
    p = sub.add_parser("convert", help="convert between native .pat and Pure Data .pd")
    p.add_argument("source")
    p.add_argument("target")
    p.add_argument("--no-stubs", action="store_true", help="with a .pd target: do not write pointat-stubs/")

    p = sub.add_parser(
        "stubs",
        help="write Pd stub abstractions (right inlets and outlets) for every node type Pd does not have",
    )
    p.add_argument("folder")


def cmd_graph(args: argparse.Namespace, registry: Registry) -> int:
    from ..dot import to_dot, write_svg

    text = to_dot(patch.check(args, registry), Path(args.patch).stem)
    if not args.output:
        sys.stdout.write(text)
        return 0
    _write(Path(args.output), text)
    svg = Path(args.output).with_suffix(".svg")
    if write_svg(text, svg):
        print(f"wrote {args.output} and {svg}")
    else:
        print(f"wrote {args.output} (install Graphviz's dot for SVG)")
    return 0


def cmd_convert(args: argparse.Namespace, registry: Registry) -> int:
    from ..expansion import rebase_paths
    from ..patchfile import write_patch

    spec = read_spec(args.source)
    target = Path(args.target)
    check(spec, registry)  # never convert a broken patch
    if is_pd_file(target):
        from ..expansion import flatten
        from ..pdfile import write_pd, write_stubs

        spec = flatten(spec)  # its header says which abstractions
        if target.stem in {d.type for d in spec.nodes}:  # Pd looks beside a patch first: itself
            print(
                f"error: {target.name} is named like its own [{target.stem}] box: in Pd that box would open "
                f"the patch itself instead of the {target.stem} stub; choose another name",
                file=sys.stderr,
            )
            return 2
        rebase_paths(spec, registry, target.parent)
        text = write_pd(spec, registry)
        if not args.no_stubs:  # first: where they cannot be written, the patch is not written either
            if not target.parent.is_dir():  # (nor a folder made for them where the patch cannot go)
                raise PointatError(f"cannot write {target}: {os.strerror(errno.ENOENT)}")
            write_stubs(target.parent / "pointat-stubs", registry)
        _write(target, text)
    else:
        rebase_paths(spec, registry, target.parent)
        _write(target, write_patch(spec))
    print(f"wrote {target}")
    return 0


def cmd_stubs(args: argparse.Namespace, registry: Registry) -> int:
    from ..pdfile import write_stubs

    paths = write_stubs(Path(args.folder), registry)
    print(f"wrote {len(paths)} stub abstractions to {args.folder}")
    return 0


def _write(path: Path, text: str) -> None:
    """Write an output file (UTF-8 on every system), or say clearly why it cannot be written."""
    try:
        path.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise PointatError(f"cannot write {path}: {exc.strerror or exc}") from None
