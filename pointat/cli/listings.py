"""What there is to run and build with: ``pointat nodes`` (the node types), ``patches`` (the shipped
patches; ``--copy`` one to make it your own) and ``help`` (a node type's page)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from .. import shipped
from ..errors import did_you_mean
from ..registry import Registry


def add_listings(sub: Any) -> None:
    """``pointat nodes``, ``patches`` and ``help``: what there is to run and build with."""
    sub.add_parser("nodes", help="list the node types")
    p = sub.add_parser(
        "patches", help="list the patches pointat ships (run one by name: pointat run glove_tqt)"
    )
    p.add_argument(
        "--copy",
        metavar="NAME",
        help="copy shipped patch NAME into --to (with the examples or settings it loads, and its lib/ "
        "abstractions) to make it your own: what it saves then lands beside your copy",
    )
    p.add_argument("--to", metavar="DIR", default=".", help="where --copy puts it (default: this folder)")
    p = sub.add_parser("help", help="show a node type's inlets, outlets, parameters and an example")
    p.add_argument("node", help="node type name")


def cmd_nodes(args: argparse.Namespace, registry: Registry) -> int:
    for cls in registry:
        first = (cls.__doc__ or "").strip().splitlines()[0] if cls.__doc__ else ""
        names = cls.type_name + (f" ({', '.join(cls.aliases)})" if cls.aliases else "")
        print(f"{names:<24} {first}")
    return 0


def cmd_patches(args: argparse.Namespace, registry: Registry) -> int:
    if args.copy:
        try:
            written = shipped.copy_patch(args.copy, Path(args.to))
        except (ValueError, OSError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        for path in written:
            print(path)
        return 0
    for name in shipped.patch_names():
        path = shipped.find_patch(name)
        first = next((line[1:].strip() for line in path.read_text().splitlines() if line.startswith("#")), "")
        print(f"{name:<24} {first}")
    return 0


def cmd_help(args: argparse.Namespace, registry: Registry) -> int:
    cls = registry.get(args.node)
    if cls is None:
        print(
            f"error: unknown node type '{args.node}'" + did_you_mean(args.node, registry.names()),
            file=sys.stderr,
        )
        return 2
    print(cls.help_text())
    return 0
