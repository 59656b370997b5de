"""The ``pointat`` command: :func:`main`, the parser and the table of commands.

Cheat sheet::

    from pointat.cli import main
    main(["check", "glove_tqt"])            # the exit status: 0, 1 (a send or ls that found no one), 2
    python -m pointat.cli run glove_tqt      # as the console script ``pointat`` (pyproject's scripts)

A command is a module that declares its arguments (``add_NAME(sub)``, called by :func:`_parser` in the
order ``--help`` lists them) and runs (``cmd_NAME(args, registry)``, found in :data:`COMMANDS`):

- :mod:`~pointat.cli.run`: ``run``, its options and its steps; :mod:`~pointat.cli.session`, what
  surrounds the running patch (console, signals, ``--rt``, status lines)
- :mod:`~pointat.cli.check`: ``check``; :mod:`~pointat.cli.plot`: ``plot``
- :mod:`~pointat.cli.conversions`: ``graph``, ``convert``, ``stubs``
- :mod:`~pointat.cli.listings`: ``nodes``, ``patches``, ``help``
- :mod:`~pointat.cli.gestures`: ``gestures evaluate``, ``gestures export``
- :mod:`~pointat.cli.network`: ``send``, ``ls``

What they share: :mod:`~pointat.cli.patch` (the patch a command names: found, read, checked, made
ready) and :mod:`~pointat.cli.arguments` (numbers of seconds and milliseconds).
"""

from __future__ import annotations

import argparse
import functools
import logging
import sys

from .. import __version__
from ..errors import PatchError, PointatError
from ..registry import Registry, default_registry
from . import check, conversions, gestures, listings, network, patch, plot, run
from .check import cmd_check
from .conversions import cmd_convert, cmd_graph, cmd_stubs
from .gestures import cmd_gestures
from .listings import cmd_help, cmd_nodes, cmd_patches
from .network import cmd_ls, cmd_send
from .plot import cmd_plot
from .run import cmd_run
from .session import LOG_FORMAT

__all__ = ["COMMANDS", "main"]

EPILOG = """\
examples:
  pointat run pointing_at --for 30                 run the Pointing-at chain on the simulated glove
  pointat run glove_tqt --monitor                  and watch it at http://127.0.0.1:9002/monitor (OSCQuery too)
  pointat run record_glove --out takes             a shipped patch's files (take.csv) into takes/ (default: here)
  pointat patches --copy gestures --to mine        a shipped patch as your own, in mine/ (made if need be)
  pointat run my.pat --set fuse.k=0.2              override a parameter
  pointat run --rt my.pat                          at real-time priority, as Pd's -rt
  pointat run --spin 2 my.pat                      poll instead of sleeping: lower latency, a busy CPU
  pointat run glove_tqt --mapper eth0              the patch on the libmapper bus (webmapper maps it)
  pointat check my.pat                              validate without running (files read too)
  pointat nodes                                     list the node types
  pointat help tqt                                  a node's inlets, outlets, parameters, example
  pointat graph my.pat -o my.dot                    Graphviz (also my.svg when dot is installed)
  pointat convert my.pat my.pd                      to Pure Data (and back: my.pd my.pat)
  pointat gestures evaluate --train A --test B     gesture recognition on labelled recordings (DIR/LABEL/*.csv)
  pointat send 9001 /pointat/press/bang             live control of a running patch (OSC to port 9001)
  pointat ls --tree                                 the patches running with --monitor, here and on the network
  pointat plot take.csv                             a recorded take as take.png and take.html
"""


def _registry(plugins: list[str]) -> Registry:
    reg = default_registry.load_builtins().load_entry_points()
    for folder in plugins:
        reg.load_plugins(folder)
    return reg


def _parser() -> argparse.ArgumentParser:
    """The command line: the program's options, then one sub-parser per command (``COMMANDS``)."""
    ap = argparse.ArgumentParser(
        prog="pointat",
        description="Dataflow toolkit: a hand-worn IMU -> orientation -> azimuth/elevation/distance -> OSC and MIDI.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--version", action="version", version=f"pointat {__version__}")
    sub = ap.add_subparsers(dest="command", metavar="COMMAND")
    sub.add_parser = functools.partial(sub.add_parser, parents=[_common_options()])  # type: ignore[method-assign]
    for add in (  # (in this order in --help)
        run.add_run,
        check.add_check,
        plot.add_plot,
        conversions.add_graph,
        listings.add_listings,
        conversions.add_conversions,
        gestures.add_gestures,
        network.add_send,
        network.add_ls,
    ):
        add(sub)
    return ap


def _common_options() -> argparse.ArgumentParser:
    """The options every command takes (a parent parser: ``--plugins``, ``-v``)."""
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument(
        "--plugins", metavar="DIR", action="append", default=[], help="load node types from *.py in DIR"
    )
    common.add_argument("-v", "--verbose", action="count", default=0, help="more log output (-vv for debug)")
    return common


def main(argv: list[str] | None = None) -> int:
    ap = _parser()
    args = ap.parse_args(argv)
    args.verbose = getattr(args, "verbose", 0)
    args.plugins = getattr(args, "plugins", [])
    level = logging.WARNING if args.verbose == 0 else logging.INFO if args.verbose == 1 else logging.DEBUG
    logging.basicConfig(level=level, format=LOG_FORMAT, stream=sys.stderr)
    if args.command is None:
        ap.print_help()
        return 2
    try:
        if getattr(args, "patch", None):
            args.patch = patch.find(args.patch)
        registry = _registry(args.plugins)
        return COMMANDS[args.command](args, registry)
    except PatchError as exc:
        for problem in exc.problems:
            print(problem, file=sys.stderr)
        n = len([p for p in exc.problems if p.severity == "error"])
        print(f"{n} error{'s' if n != 1 else ''}", file=sys.stderr)
        return 2
    except PointatError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        return 0


#: What each command runs: ``fn(args, registry)``, its exit status returned.
COMMANDS = {
    "gestures": cmd_gestures,
    "run": cmd_run,
    "check": cmd_check,
    "plot": cmd_plot,
    "graph": cmd_graph,
    "nodes": cmd_nodes,
    "patches": cmd_patches,
    "help": cmd_help,
    "convert": cmd_convert,
    "stubs": cmd_stubs,
    "send": cmd_send,
    "ls": cmd_ls,
}
