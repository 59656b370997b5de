"""``pointat check``: a patch validated as ``run`` does before it starts, nothing opened."""

from __future__ import annotations

import argparse
from typing import Any

from ..registry import Registry
from . import patch


def add_check(sub: Any) -> None:
    """``pointat check``: a patch validated as run does before it starts."""
    p = sub.add_parser(
        "check",
        help="validate a patch as run does before it starts, without opening a device, a port or a socket: "
        "the files its nodes read (calibrations, loudspeaker layouts, recordings) are read and every node "
        "is built and prepared, so a patch check passes is one run starts",
    )
    patch.add_arguments(p)


def cmd_check(args: argparse.Namespace, registry: Registry) -> int:
    checked, rt = patch.ready(args, registry)  # what run does before it opens a port: nothing opened
    rt.shutdown()
    counts = [_count(len(checked.nodes), "node"), _count(len(checked.wires), "wire")]
    if checked.warnings:
        counts.append(_count(len(checked.warnings), "warning"))
    print(f"{args.patch}: ok ({', '.join(counts)})")
    return 0


def _count(n: int, what: str) -> str:
    return f"{n} {what}{'s' * (n != 1)}"
