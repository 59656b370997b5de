"""``pointat run``: its options (timing, monitor, libmapper, status lines, reload) and its steps: the
patch made ready with its observer, presets, reloader, monitor server and mapper node, then run inside
the console's session (:mod:`pointat.cli.session`)."""

from __future__ import annotations

import argparse
import logging
import os
from pathlib import Path
from typing import Any

from ..checking import check
from ..console import about, banner
from ..errors import PointatError
from ..loader import parse_overrides
from ..maths.vbap import parse_layout, read_layout
from ..monitor import MonitorServer, Observer
from ..presets import Presets, presets_path
from ..registry import Registry
from ..reload import Reloader
from . import patch, session
from .arguments import milliseconds, seconds

log = logging.getLogger("pointat")

#: The monitor's port when ``--monitor`` names none (next to the patches' 9000 out and 9001 control).
MONITOR_PORT = 9002


def add_run(sub: Any) -> None:
    """``pointat run``: the patch, how it is timed and compiled, the monitor, the status lines."""
    p = sub.add_parser("run", help="run a patch until Ctrl-C, --for SECONDS, or its sources end")
    patch.add_arguments(p)
    _add_timing_args(p)
    _add_monitor_args(p)
    _add_mapper_args(p)
    _add_status_args(p)
    _add_reload_args(p)


def _add_timing_args(p: argparse.ArgumentParser) -> None:
    """``run``'s clock: how long (``--for``), at what priority (``--rt``), polling or sleeping (``--spin``),
    node by node or compiled (``--compiled``)."""
    p.add_argument(
        "--for", dest="duration", type=seconds, metavar="SECONDS", help="stop after this many seconds"
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
        type=milliseconds,
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
        type=seconds,
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


def cmd_run(args: argparse.Namespace, registry: Registry) -> int:
    _refuse_spin_with_rt(args)
    copied = patch.seed(args)  # (before the patch reads them, as it is made ready)
    rt, observer, server = _made_ready(args, registry)
    with session.console(rt) as out, session.realtime(args.rt):
        _say_spin(rt, args.spin)
        log.info("running %s (%d nodes)", args.patch, len(rt.nodes))
        lines = banner(rt, args.patch, monitor=server, presets=rt.presets, copied=copied)
        for line in lines:
            out.write(line)  # (before the loadbangs print anything)
        session.run_until_done(rt, observer, server, out, args)
    return 0


def _refuse_spin_with_rt(args: argparse.Namespace) -> None:
    """``--spin`` and ``--rt`` together: refused, with why."""
    if args.rt and args.spin:
        raise PointatError(
            "--spin with --rt would keep a real-time thread polling on a CPU that other programs (the "
            "serial port's own interrupt thread among them) then hardly get; use one of them: --rt "
            "already keeps the CPUs out of deep idle states, which takes much of the wake-up's cost away"
        )


def _say_spin(rt: Any, spin: float) -> None:
    if rt.spin:
        log.info("polling for input for %g ms after each input (--spin): one CPU busy while it flows", spin)


def _made_ready(args: argparse.Namespace, registry: Registry) -> tuple[Any, Observer, Any]:
    """The runtime made ready (what check does, no more and no less), with its observer, its presets
    and the monitor's server when ``--monitor`` asks for one (made, not started)."""
    layout = _layout(args.layout) if args.layout else None
    checked, rt = patch.ready(args, registry)
    rt.spin = args.spin / 1000.0
    rt.compiled = args.compiled
    observer = Observer(rt, layout=layout, patch=Path(args.patch).stem, about=about(args.patch)).attach()
    if os.path.isfile(args.patch):
        rt.presets = Presets(rt, presets_path(args.patch, patch.out_folder(args)))
        rt.reloader = _reloader(args, registry, rt, checked)
        rt.reloader.listen(observer.reattach)
    server = _monitor(rt, observer, args) if args.monitor is not None else None
    if args.mapper is not None:
        _mapper(rt, registry, args)
    return rt, observer, server


def _mapper(rt: Any, registry: Registry, args: argparse.Namespace) -> None:
    """``--mapper IFACE``: a ``mapper`` node added to the patch (it joins the bus as the patch starts)."""
    from .. import mapper

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
        new = check(patch.read(args), registry, overrides, read_files=True)
        for w in new.warnings:
            log.warning("%s", w)
        return new

    return Reloader(rt, checked, read, path=args.patch, watch=args.watch)


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
