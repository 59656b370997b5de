"""Running patches reached from a shell: ``pointat send`` (one OSC message over UDP) and ``ls`` (the
patches running with ``--monitor``, here and on the network, found by zeroconf)."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from ..registry import Registry
from .arguments import seconds


def add_send(sub: Any) -> None:
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


def add_ls(sub: Any) -> None:
    """``pointat ls``: the patches running here and on the network."""
    p = sub.add_parser(
        "ls",
        help="list the patches running with --monitor, here and on the network (zeroconf): patch, host, "
        "OSCQuery and OSC ports, monitor page",
    )
    p.add_argument(
        "--for",
        dest="duration",
        type=seconds,
        default=2.0,
        metavar="SECONDS",
        help="how long to listen for answers (default 2); zeroconf's port is open that long",
    )
    p.add_argument("--local", action="store_true", help="this machine's patches only (loopback)")
    p.add_argument("--tree", action="store_true", help="also each one's OSCQuery address space, over HTTP")


def cmd_send(args: argparse.Namespace, registry: Registry) -> int:
    import socket

    from ..devices.osc_wire import encode_message, udp_port

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


#: Seconds ``pointat send`` waits for the host to say that nothing listens on the port (this machine,
#: or one on the network that answers with ICMP "port unreachable"; a silent one cannot be told).
SEND_WAIT = 0.2


def cmd_ls(args: argparse.Namespace, registry: Registry) -> int:
    from ..discovery import browse, fetch_tree, tree_lines

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
