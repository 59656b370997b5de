"""The ``pointat`` command."""

from __future__ import annotations

import argparse
import contextlib
import errno
import functools
import logging
import math
import os
import signal
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from . import __version__, shipped
from .checking import check
from .console import about, banner
from .errors import PatchError, PointatError, did_you_mean
from .expansion import read_spec
from .loader import parse_overrides, ready
from .maths.vbap import parse_layout, read_layout
from .monitor import MonitorServer, Observer
from .presets import Presets, presets_path
from .registry import Registry, default_registry
from .reload import Reloader
from .scheduling import CPU_DMA_LATENCY, keep_cpus_awake, quiet_thread, realtime_priority
from .spec import is_pd_file
from .terminal import LineHandler, LineWriter

log = logging.getLogger("pointat")
LOG_FORMAT = "%(levelname)s %(name)s: %(message)s"
#: The monitor's port when ``--monitor`` names none (next to the patches' 9000 out and 9001 control).
MONITOR_PORT = 9002

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


def _number(text: str, unit: str, maximum: float = math.inf) -> float:
    """A finite number of ``unit`` from 0 to ``maximum`` (argparse's message when not)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of {unit}, got {text!r}") from None
    if not (math.isfinite(value) and 0.0 <= value <= maximum):
        span = ">= 0" if maximum == math.inf else f"from 0 to {maximum:g}"
        raise argparse.ArgumentTypeError(f"expected a finite number of {unit} {span}, got {text!r}")
    return value


def _seconds(text: str) -> float:
    """``--for``: a finite number of seconds, 0 or more."""
    return _number(text, "seconds")


def _milliseconds(text: str) -> float:
    """``--spin``: a finite number of milliseconds, 0 to 1000."""
    return _number(text, "milliseconds", 1000.0)


def _add_patch_args(p: argparse.ArgumentParser) -> None:
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
    for add in (
        _add_run,
        _add_check,
        _add_plot,
        _add_graph,
        _add_listings,
        _add_conversions,
        _add_gestures,
        _add_send,
        _add_ls,
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


def _add_run(sub: Any) -> None:
    """``pointat run``: the patch, how it is timed and compiled, the monitor, the status lines."""
    p = sub.add_parser("run", help="run a patch until Ctrl-C, --for SECONDS, or its sources end")
    _add_patch_args(p)
    _add_timing_args(p)
    _add_monitor_args(p)
    _add_mapper_args(p)
    _add_status_args(p)
    _add_reload_args(p)


def _add_timing_args(p: argparse.ArgumentParser) -> None:
    """``run``'s clock: how long (``--for``), at what priority (``--rt``), polling or sleeping (``--spin``),
    node by node or compiled (``--compiled``)."""
    p.add_argument(
        "--for", dest="duration", type=_seconds, metavar="SECONDS", help="stop after this many seconds"
    )
    p.add_argument(
        "--rt",
        action="store_true",
        help="real-time priority (SCHED_FIFO), as Pd's -rt, and the CPUs kept out of deep idle states "
        "(Linux /dev/cpu_dma_latency): steadier, shorter latency; needs root or an rtprio limit and write "
        "access to /dev/cpu_dma_latency",
    )
    p.add_argument(
        "--spin",
        type=_milliseconds,
        default=0.0,
        metavar="MS",
        help="after each input, poll for the next one for MS milliseconds instead of sleeping: the "
        "system's wake-up no longer adds to each sample's latency, and one CPU is busy while input flows "
        "(Pd's -sleepgrain makes the same trade, sleeping in short grains between polls).  Make it longer "
        "than the time between samples: two periods, 2 at 1 kHz, 20 at 100 Hz",
    )
    p.add_argument(
        "--compiled",
        choices=("auto", "on", "off"),
        default="auto",
        help="run each glove chain (mote -> offset -> scaling -> tqt -> reference -> azi_ele, "
        "roll_distance -> osc_out) as one compiled function, every glove of a base station in one call, "
        "the same datagrams to the bit.  auto (the default): when the compiled code is "
        "cached, else node by node while it is compiled in the background for the next run; on: compile "
        "now if need be (seconds); off: node by node.  -v says which chains run compiled and why the "
        "others do not",
    )


def _add_monitor_args(p: argparse.ArgumentParser) -> None:
    """``run``'s monitor page: its port, who may reach it, the loudspeakers it shows."""
    p.add_argument(
        "--monitor",
        nargs="?",
        const=MONITOR_PORT,
        type=int,
        metavar="PORT",
        help=f"serve the monitor page and OSCQuery on PORT (default {MONITOR_PORT}; 0: any free port): open "
        "http://127.0.0.1:PORT/monitor in a browser; tools that speak OSCQuery find the patch by zeroconf",
    )
    p.add_argument(
        "--monitor-host",
        default="127.0.0.1",
        metavar="HOST",
        help="address the monitor listens on (default 127.0.0.1, this machine only; 0.0.0.0: every "
        "interface, for a tablet on the stage's network: needs --monitor-allow, and the printed URL "
        "carries the token a browser there needs)",
    )
    p.add_argument(
        "--monitor-allow",
        default="",
        metavar="ADDRESSES",
        help="with --monitor-host beyond this machine: the machines that may connect to the monitor and "
        "its OSC port, addresses or networks, comma-separated (192.168.1.20,10.0.0.0/24)",
    )
    p.add_argument(
        "--layout",
        metavar="AZIMUTHS|FILE",
        help="the loudspeakers the monitor shows when the patch has no vbap node: azimuths (0,45,90,...), "
        "az:el pairs (0:0,90:0,0:90) or a layout file as vbap reads it (default: a ring of eight)",
    )


def _add_mapper_args(p: argparse.ArgumentParser) -> None:
    """``run``'s libmapper bus: the interface it joins, the device's name."""
    p.add_argument(
        "--mapper",
        metavar="IFACE",
        help="make the patch a libmapper device on the bus of network interface IFACE (eth0, wlan0; lo: "
        "this machine alone): its gloves and gestures are signals other machines map, its live "
        "parameters signals they set (webmapper shows them).  The bus has no access control: a show's "
        "own network only.  Needs the extra: pip install 'pointat[mapper]'",
    )
    p.add_argument(
        "--mapper-name",
        metavar="NAME",
        default="",
        help="with --mapper: the device's name on the bus (default: pointat_ and the patch's name; the bus "
        "adds .1, .2...)",
    )


def _add_status_args(p: argparse.ArgumentParser) -> None:
    """``run``'s status lines on the console."""
    p.add_argument(
        "--status",
        type=_seconds,
        metavar="SECONDS",
        help="a status line per glove every SECONDS (default: 1, redrawn in place, on a terminal; 5 on a "
        "pipe or file; 0: none)",
    )


def _add_reload_args(p: argparse.ArgumentParser) -> None:
    """``run --watch``: hot reload."""
    p.add_argument(
        "--watch",
        action="store_true",
        help="reload the patch when its file (or an abstraction it uses) is saved: the nodes whose name, "
        "type and parameters did not change keep their state (orientation, calibration, trained models, "
        "open ports), the swap falls between two samples; a file that does not check is refused with its "
        "file:line and the patch running goes on.  /pointat/patch/reload (OSC) reloads with or without it",
    )


def _add_check(sub: Any) -> None:
    """``pointat check``: a patch validated as run does before it starts."""
    p = sub.add_parser(
        "check",
        help="validate a patch as run does before it starts, without opening a device, a port or a socket: "
        "the files its nodes read (calibrations, loudspeaker layouts, recordings) are read and every node "
        "is built and prepared, so a patch check passes is one run starts",
    )
    _add_patch_args(p)


def _add_plot(sub: Any) -> None:
    """``pointat plot``: a recorded take drawn."""
    p = sub.add_parser(
        "plot",
        help="draw a recorded take as PNG and HTML: where the hand points, the sensor norms, the filter's "
        "flags and, where the take has truth, the error against it (needs matplotlib)",
    )
    p.add_argument(
        "take",
        metavar="TAKE",
        help="a take: record's CSV (record_glove.pat's ADC counts, or gyro/accel/mag columns) or a BROAD "
        "trial (.csv.gz)",
    )
    p.add_argument(
        "-o",
        "--output",
        metavar="OUT",
        help="write OUT.png and OUT.html (default: the take's path without its extension)",
    )
    p.add_argument(
        "--truth",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="draw the orientation error against the take's truth, when it has one (BROAD's optical "
        "quaternions; default: --truth)",
    )


def _add_graph(sub: Any) -> None:
    """``pointat graph``: a patch as Graphviz dot."""
    p = sub.add_parser("graph", help="write the patch as Graphviz dot (and SVG when dot is installed)")
    _add_patch_args(p)
    p.add_argument("-o", "--output", help="dot file to write (default: standard output)")


def _add_listings(sub: Any) -> None:
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


def _add_conversions(sub: Any) -> None:
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


def _add_gestures(sub: Any) -> None:
    """``pointat gestures evaluate`` and ``export``."""
    p = sub.add_parser(
        "gestures",
        help="evaluate gesture recognition on folders of labelled recordings (evaluate), or turn a gesture "
        "node's saved examples into such a folder (export)",
    )
    gsub = p.add_subparsers(dest="gestures_command", metavar="ACTION")
    _add_gestures_evaluate(gsub)
    _add_gestures_export(gsub)


def _add_gestures_evaluate(gsub: Any) -> None:
    """``pointat gestures evaluate``: train on one folder, test on another."""
    g = gsub.add_parser(
        "evaluate",
        help="train on one folder, test on another: accuracy, recall, confusion, decision latency",
        description="Train the gesture node's recognizer on --train and test it on --test, each laid out as "
        "DIR/<label>/<example>.csv (columns t and any of acc_x..z, gyr_x..z, mag_x..z, qw..qz). Each test "
        "recording is fed frame by frame, bracketed as one movement, as the gesture node runs it.",
    )
    g.add_argument("--train", required=True, metavar="DIR", help="labelled recordings to learn from")
    g.add_argument("--test", required=True, metavar="DIR", help="labelled recordings to test on")
    g.add_argument(
        "--channels",
        nargs="+",
        choices=("acc", "gyr", "mag", "q"),
        help="channel groups to use (default: every group all the recordings have)",
    )
    g.add_argument("--json", action="store_true", help="print the evaluation as JSON (with every decision)")
    g.add_argument("--no-early", action="store_true", help="decide only when each movement has ended")
    g.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        dest="sets",
        help="a gesture node parameter, as in a patch (reject=2, early=false, warp=each, relative=[acc q])",
    )
    g.add_argument(
        "--baseline",
        action="store_true",
        help="score plain 1-NN DTW on the same split beside it (raw channels warped together, no rejection)",
    )


def _add_gestures_export(gsub: Any) -> None:
    """``pointat gestures export``: a model file's examples as a folder of recordings."""
    g = gsub.add_parser(
        "export",
        help="a model file's examples (what a gesture node saved) as DIR/<label>/<n>.csv, for evaluate",
    )
    g.add_argument("model", help="a model file: what gesture, posture or follow saved (gestures.json)")
    g.add_argument("folder", help="where the recordings go (DIR/<label>/<n>.csv); files there stay")


def _add_send(sub: Any) -> None:
    """``pointat send``: one OSC message to a running patch."""
    p = sub.add_parser(
        "send", help="send one OSC message over UDP: live control of a running patch from a shell"
    )
    p.add_argument("to", metavar="[HOST:]PORT", help="where: a port on 127.0.0.1, or host:port")
    p.add_argument("address", help="OSC address, e.g. /pointat/press/bang or /pointat/tqt/fuse/k_heading")
    p.add_argument(
        "values",
        nargs="*",
        help="arguments: whole numbers go as int32, other numbers as float32, the rest as strings "
        "(put -- before the address for values such as -1e3)",
    )


def _add_ls(sub: Any) -> None:
    """``pointat ls``: the patches running here and on the network."""
    p = sub.add_parser(
        "ls",
        help="list the patches running with --monitor, here and on the network (zeroconf): patch, host, "
        "OSCQuery and OSC ports, monitor page",
    )
    p.add_argument(
        "--for",
        dest="duration",
        type=_seconds,
        default=2.0,
        metavar="SECONDS",
        help="how long to listen for answers (default 2); zeroconf's port is open that long",
    )
    p.add_argument("--local", action="store_true", help="this machine's patches only (loopback)")
    p.add_argument("--tree", action="store_true", help="also each one's OSCQuery address space, over HTTP")


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
            args.patch = _patch_path(args.patch)
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


def _patch_path(name: str) -> str:
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


def _out(args: argparse.Namespace) -> Path:
    """Where a shipped patch's files go: ``--out DIR`` (a folder that is there), else this folder."""
    if args.out is not None and not os.path.isdir(args.out):
        raise PointatError(f"--out {args.out}: no such folder (make it first: mkdir {args.out})")
    return Path(args.out or ".").absolute()


def _spec(args: argparse.Namespace) -> Any:
    """The patch read, told where its files go when it is a shipped one."""
    spec = read_spec(args.patch)
    spec.out = str(_out(args))
    return spec


def _seed(args: argparse.Namespace) -> list[tuple[Path, Path]]:
    """A shipped patch's own files, which it reads and writes (gestures.json: the examples it loads and
    saves), copied into the output folder when they are not there yet: the user's own to teach more and
    save, where the shipped one stays as it is.  Returns (shipped, copy) pairs."""
    copied = []
    for src in shipped.seeds(args.patch):
        dest = _out(args) / src.name
        if not dest.exists():
            try:
                dest.write_bytes(src.read_bytes())
            except OSError as exc:
                raise PointatError(f"cannot copy {src.name} into {dest.parent}: {exc.strerror}") from None
            copied.append((src, dest))
    return copied


def _checked(args: argparse.Namespace, registry: Registry):
    checked = check(_spec(args), registry, parse_overrides(args.set))
    for w in checked.warnings:
        print(w, file=sys.stderr)
    return checked


def _ready(args: argparse.Namespace, registry: Registry):
    """The patch checked, its files read, its nodes built and prepared: all that ``check`` does, and all
    that ``run`` does before it opens a port (:func:`pointat.loader.ready`)."""
    checked, rt = ready(_spec(args), registry, parse_overrides(args.set))
    for w in checked.warnings:
        print(w, file=sys.stderr)
    return checked, rt


def cmd_run(args: argparse.Namespace, registry: Registry) -> int:
    _refuse_spin_with_rt(args)
    copied = _seed(args)  # (before the patch reads them, as it is made ready)
    rt, observer, server = _made_ready(args, registry)
    with _console(rt) as out, _realtime(args.rt):
        _say_spin(rt, args.spin)
        log.info("running %s (%d nodes)", args.patch, len(rt.nodes))
        lines = banner(rt, args.patch, monitor=server, presets=rt.presets, copied=copied)
        for line in lines:
            out.write(line)  # (before the loadbangs print anything)
        _run_until_done(rt, observer, server, out, args)
    return 0


def _refuse_spin_with_rt(args: argparse.Namespace) -> None:
    """``--spin`` and ``--rt`` together: refused, with why."""
    if args.rt and args.spin:
        raise PointatError(
            "--spin with --rt would keep a real-time thread polling on a CPU that other programs (the "
            "serial port's own interrupt thread among them) then hardly get; use one of them: --rt "
            "already keeps the CPUs out of deep idle states, which takes much of the wake-up's cost away"
        )


def _made_ready(args: argparse.Namespace, registry: Registry) -> tuple[Any, Observer, Any]:
    """The runtime made ready (what check does, no more and no less), with its observer, its presets
    and the monitor's server when ``--monitor`` asks for one (made, not started)."""
    layout = _layout(args.layout) if args.layout else None
    checked, rt = _ready(args, registry)
    rt.spin = args.spin / 1000.0
    rt.compiled = args.compiled
    observer = Observer(rt, layout=layout, patch=Path(args.patch).stem, about=about(args.patch)).attach()
    if os.path.isfile(args.patch):
        rt.presets = Presets(rt, presets_path(args.patch, _out(args)))
        rt.reloader = _reloader(args, registry, rt, checked)
        rt.reloader.listen(observer.reattach)
    server = _monitor(rt, observer, args) if args.monitor is not None else None
    if args.mapper is not None:
        _mapper(rt, registry, args)
    return rt, observer, server


def _mapper(rt: Any, registry: Registry, args: argparse.Namespace) -> None:
    """``--mapper IFACE``: a ``mapper`` node added to the patch (it joins the bus as the patch starts)."""
    from . import mapper

    if not args.mapper:
        raise PointatError("--mapper: name the network interface to join (eth0, wlan0, lo)")
    mapper.load()  # the extra missing: said now, before anything opens
    cls = registry.get("mapper")
    if cls is None:
        raise PointatError("--mapper: no node type 'mapper' (pointat's osc_bridge.mapper did not load)")
    name = "mapper"
    while name in rt.nodes:
        name += "_"
    device = args.mapper_name or mapper.device_name(Path(args.patch).stem)
    rt.add(cls(name, {"interface": args.mapper, "device": device}))


def _reloader(args: argparse.Namespace, registry: Registry, rt: Any, checked: Any) -> Reloader:
    """What reloads the patch from its file (``--watch``, ``/pointat/patch/reload``): the file read and
    checked as it was for the start (its files read too, the same ``--set``)."""
    overrides = parse_overrides(args.set)

    def read() -> Any:
        new = check(_spec(args), registry, overrides, read_files=True)
        for w in new.warnings:
            log.warning("%s", w)
        return new

    return Reloader(rt, checked, read, path=args.patch, watch=args.watch)


@contextlib.contextmanager
def _console(rt: Any) -> Iterator[LineWriter]:
    """The console's and the log's lines written by threads of their own, and Ctrl-C or a kill stopping
    the patch, while the block runs; yields the console's writer.

    A terminal paused with Ctrl-S, or a pipe nobody reads, must not stop the patch (lines that do not
    fit are counted).  Python's warnings go to the log too."""

    def reader_gone() -> None:  # pointat run ... | head: stop, quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        rt.stop()

    def on_signal(signum: int, _frame: object) -> None:
        log.info("signal %d: stopping", signum)
        rt.stop()

    root = logging.getLogger()
    saved_handlers = root.handlers[:]
    # (signals are the main thread's to set: main() embedded in another thread leaves them alone)
    ours = threading.current_thread() is threading.main_thread()
    saved_signals = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)} if ours else {}
    out = LineWriter(sys.stdout, on_broken=reader_gone, name="console")
    err = LineWriter(sys.stderr, name="log")
    try:
        # on one terminal, log lines go above the status lines too (one writer owns the screen)
        handler = LineHandler(out if out.tty and _same_terminal() else err)
        handler.setFormatter(logging.Formatter(LOG_FORMAT))
        root.handlers = [handler]
        logging.captureWarnings(True)
        rt.console = out.write
        for sig in saved_signals:
            signal.signal(sig, on_signal)
        yield out
    finally:
        logging.captureWarnings(False)
        root.handlers = saved_handlers
        # what waits is written before the end, as any program's output: a terminal still paused holds
        # the exit until Ctrl-Q (or Ctrl-C or a kill, which now end it at once)
        for sig in saved_signals:
            signal.signal(sig, signal.SIG_DFL)
        out.close(None)
        err.close(None)
        for sig, previous in saved_signals.items():
            signal.signal(sig, signal.SIG_DFL if previous is None else previous)


@contextlib.contextmanager
def _realtime(wanted: bool) -> Iterator[None]:
    """``--rt``: real-time priority and the CPUs kept out of deep idle states while the block runs (each
    refusal logged, the patch run anyway)."""
    awake = None
    try:
        if wanted:
            refused = realtime_priority()
            if refused:
                log.warning("--rt: real-time priority %s; running at normal priority", refused)
            else:
                log.info("running at real-time priority (SCHED_FIFO)")
            awake, why = keep_cpus_awake()
            if why:
                log.warning("--rt: the CPUs may sleep deeply between samples: %s", why)
            else:
                log.info(
                    "the CPUs are kept out of deep idle states while the patch runs (%s)", CPU_DMA_LATENCY
                )
        yield
    finally:
        if awake is not None:
            os.close(awake)


def _say_spin(rt: Any, spin: float) -> None:
    if rt.spin:
        log.info("polling for input for %g ms after each input (--spin): one CPU busy while it flows", spin)


def _run_until_done(
    rt: Any, observer: Observer, server: Any, out: LineWriter, args: argparse.Namespace
) -> None:
    """Start the monitor, the patch and the status lines; run until the end; then stop them and write the
    observer's summary."""
    if server is not None:
        server.start()  # (before the clock starts: its threads and zeroconf take a moment)
    rt.start()
    if server is not None:  # the page's readings; the console takes its own when it writes
        observer.start()
    if rt.reloader is not None:
        rt.reloader.start()
    every = args.status if args.status is not None else 1.0 if out.tty else 5.0
    ticker = _Ticker(every, lambda: out.status(observer.status_lines())) if every > 0 else None
    try:
        rt.run(args.duration)
    finally:
        if rt.reloader is not None:
            rt.reloader.stop()
        if ticker is not None:
            ticker.stop()
        out.status([])
        for line in observer.summary():
            out.write(line)
        observer.stop()
        if server is not None:
            server.close()


class _Ticker:
    """Call ``fn`` every ``every`` seconds from a quiet thread until :meth:`stop`."""

    def __init__(self, every: float, fn: Any):
        self._stop = threading.Event()
        self._every, self._fn = every, fn
        self._thread = quiet_thread(threading.Thread(target=self._run, name="pointat-status", daemon=True))
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(self._every):
            try:
                self._fn()
            except Exception:  # a status line is never worth the patch
                log.debug("status line failed", exc_info=True)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(1.0)


def _same_terminal() -> bool:
    try:
        return os.isatty(sys.stderr.fileno()) and os.ttyname(sys.stderr.fileno()) == os.ttyname(
            sys.stdout.fileno()
        )
    except (OSError, ValueError, AttributeError):
        return False


def _layout(text: str) -> Any:
    """``--layout``: azimuths, az:el pairs, or a layout file."""
    if os.path.isfile(text):
        return read_layout(text)
    try:
        items = [x for x in text.replace(";", ",").split(",") if x.strip()]
        if any(":" in x for x in items):
            return parse_layout([[float(v) for v in x.split(":")] for x in items])
        return parse_layout([float(x) for x in items])
    except ValueError as exc:
        raise PointatError(
            f"--layout {text!r}: expected azimuths (0,45,90), az:el pairs (0:0,90:0,0:90) or a layout file; {exc}"
        ) from None


def _monitor(rt: Any, observer: Any, args: argparse.Namespace) -> Any:
    name = f"pointat {Path(args.patch).stem}"
    allow = [a.strip() for a in args.monitor_allow.split(",") if a.strip()]
    try:
        return MonitorServer(rt, observer, args.monitor_host, args.monitor, name=name, allow=allow)
    except ValueError as exc:  # no allow-list beyond loopback, or a bad one
        raise PointatError(str(exc)) from None
    except OSError as exc:
        if args.monitor == 0:
            raise PointatError(f"--monitor: cannot listen on {args.monitor_host}: {exc}") from None
        log.warning(
            "--monitor: port %d is taken (%s): serving on a free port instead", args.monitor, exc.strerror
        )
        return MonitorServer(rt, observer, args.monitor_host, 0, name=name, allow=allow)


def cmd_check(args: argparse.Namespace, registry: Registry) -> int:
    checked, rt = _ready(args, registry)  # what run does before it opens a port: nothing opened
    rt.shutdown()
    counts = [_count(len(checked.nodes), "node"), _count(len(checked.wires), "wire")]
    if checked.warnings:
        counts.append(_count(len(checked.warnings), "warning"))
    print(f"{args.patch}: ok ({', '.join(counts)})")
    return 0


def cmd_plot(args: argparse.Namespace, registry: Registry) -> int:
    from .plotting import plot_take

    for path in plot_take(args.take, args.output, truth=args.truth):
        print(path)
    return 0


def _count(n: int, what: str) -> str:
    return f"{n} {what}{'s' * (n != 1)}"


def cmd_graph(args: argparse.Namespace, registry: Registry) -> int:
    from .dot import to_dot, write_svg

    text = to_dot(_checked(args, registry), Path(args.patch).stem)
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


def _write(path: Path, text: str) -> None:
    """Write an output file (UTF-8 on every system), or say clearly why it cannot be written."""
    try:
        path.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise PointatError(f"cannot write {path}: {exc.strerror or exc}") from None


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


def cmd_convert(args: argparse.Namespace, registry: Registry) -> int:
    from .expansion import rebase_paths
    from .patchfile import write_patch

    spec = read_spec(args.source)
    target = Path(args.target)
    check(spec, registry)  # never convert a broken patch
    if is_pd_file(target):
        from .expansion import flatten
        from .pdfile import write_pd, write_stubs

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
    from .pdfile import write_stubs

    paths = write_stubs(Path(args.folder), registry)
    print(f"wrote {len(paths)} stub abstractions to {args.folder}")
    return 0


def _osc_value(text: str) -> int | float | str:
    """A command-line argument as OSC sends it: int32 when it is a whole number that fits, float32 when
    it is a number, else a string."""
    try:
        number = int(text)
    except ValueError:
        try:
            return float(text)
        except ValueError:
            return text
    return number if -(2**31) <= number < 2**31 else float(number)


def cmd_send(args: argparse.Namespace, registry: Registry) -> int:
    import socket

    from .devices.osc_wire import encode_message, udp_port

    host, _, text = args.to.rpartition(":")
    if host.startswith("[") and host.endswith("]"):  # [::1]:9001, as IPv6 addresses are written with a port
        host = host[1:-1]
    try:
        port = udp_port(text, f"{args.to!r}: expected a port 1..65535 or host:port; port")
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if not args.address.startswith("/"):
        print(f"error: OSC address {args.address!r} must start with '/'", file=sys.stderr)
        return 2
    values = [_osc_value(v) for v in args.values]
    target = host or "127.0.0.1"
    try:
        family, _, _, _, addr = socket.getaddrinfo(target, port, type=socket.SOCK_DGRAM)[0]
        with socket.socket(family, socket.SOCK_DGRAM) as sock:
            sock.connect(addr)  # connected: the host's "port unreachable" comes back as an error
            sock.send(encode_message(args.address, values))
            sock.settimeout(SEND_WAIT)
            try:
                sock.recv(1)
            except TimeoutError:  # no word back: delivered as far as UDP can tell
                pass
    except ConnectionRefusedError:
        print(
            f"error: nothing listens on UDP {target}:{port}: is the patch running, with osc_in port={port}?",
            file=sys.stderr,
        )
        return 1
    except OSError as exc:
        print(f"error: cannot send to {target}:{port}: {exc.strerror or exc}", file=sys.stderr)
        return 1
    return 0


#: Seconds ``pointat send`` waits for the host to say that nothing listens on the port (this machine,
#: or one on the network that answers with ICMP "port unreachable"; a silent one cannot be told).
SEND_WAIT = 0.2


def cmd_gestures(args: argparse.Namespace, registry: Registry) -> int:
    from . import gesture_eval
    from .gesture_files import read_folder

    if args.gestures_command == "export":
        from .gesture_files import export_model

        try:
            written = export_model(args.model, args.folder)
        except (ValueError, OSError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        print(f"{len(written)} recordings into {args.folder}")
        return 0
    if args.gestures_command != "evaluate":
        print(
            "usage: pointat gestures evaluate --train DIR --test DIR [--baseline] [--set NAME=VALUE] [--json]"
            "  |  pointat gestures export MODEL DIR",
            file=sys.stderr,
        )
        return 2
    try:
        model_options, recognizer_options = gesture_eval.options(
            [*args.sets, *(["early=false"] if args.no_early else [])]
        )
        train, test = read_folder(args.train), read_folder(args.test)
        ev = gesture_eval.evaluate(train, test, args.channels, model_options, recognizer_options)
        plain = gesture_eval.baseline(train, test, ev.channels) if args.baseline else None
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.json:
        print(gesture_eval.to_json(ev, plain))
    else:
        print(gesture_eval.format_report(ev))
        if plain is not None:
            print(f"baseline, plain 1-NN DTW on the same split: accuracy {100 * plain.accuracy:.1f} %")
    return 0


def cmd_ls(args: argparse.Namespace, registry: Registry) -> int:
    from .discovery import browse, fetch_tree, tree_lines

    try:
        found = browse(args.duration, local=args.local)
    except (RuntimeError, OSError) as exc:
        print(f"error: cannot browse the network: {exc}", file=sys.stderr)
        return 1
    if not found:
        where = "on this machine" if args.local else "here or on the network"
        print(f"no patch answered {where} in {args.duration:g} s (run one with --monitor)", file=sys.stderr)
        return 1
    width = max(len(s.patch) for s in found)
    for s in found:
        osc = f"OSC {s.osc_port}/udp" if s.osc_port else "OSC -"
        print(f"{s.patch:<{width}}  {s.host:<15}  OSCQuery {s.port}/tcp  {osc}  {s.url('/monitor')}")
        if args.tree:
            try:
                lines = tree_lines(fetch_tree(s))
            except (OSError, ValueError) as exc:
                lines = [f"(no tree: {exc})"]
            for line in lines:
                print(f"    {line}")
    return 0


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

if __name__ == "__main__":
    sys.exit(main())
