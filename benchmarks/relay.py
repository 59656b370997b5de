"""A bare python-osc relay, the benchmark's Python transport floor: read OSC over UDP, forward it over UDP.

Each datagram is parsed by python-osc's server and re-encoded by its client (as Pd's ``[oscparse]`` ->
``[oscformat]`` does), on 127.0.0.1 only.  It stops by itself after ``--for`` seconds.  With
``--out-port 0`` it only reads and drops what arrives (a sink that lets a sender run at full speed
without a receiver thread in the sender's own process).  With ``--pty PATH`` it is the floor of the mote
path instead: it reads mote frames from a pseudo-terminal with pointat's own frame parser and sends one
python-osc message per frame, ``/floor ID TAG`` (the sample tag of the frame's gyro x count, as the
benchmark's mote patches send it), so that the pty's own cost is measured as the UDP floors measure UDP.
With ``--busy-us N`` the relay spins N µs of busy work on each message before it sends it on: what a
chain of that cost would add to the floor (the benchmark shows what the 1.2 × goal asks with it).  With
``--poll MS`` it polls its input (``select`` with no timeout, in a busy loop) for MS ms after each input
instead of sleeping in ``select``, as ``pointat run --spin MS`` does: the floor for pointat's ``--spin``
rows, polling against polling.

    python -m benchmarks.relay --in-port 9100 --out-port 9101 --for 60
    python -m benchmarks.relay --pty /dev/pts/5 --out-port 9101 --for 60
    python -m benchmarks.relay --in-port 9100 --out-port 9101 --poll 2 --for 60
"""

from __future__ import annotations

import argparse
import math
import os
import select
import signal
import socket
import time
import tty

from pythonosc.dispatcher import Dispatcher
from pythonosc.osc_server import BlockingOSCUDPServer
from pythonosc.udp_client import SimpleUDPClient


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.relay", description=__doc__.splitlines()[0])
    src = ap.add_mutually_exclusive_group(required=True)
    src.add_argument("--in-port", type=int, help="UDP port to listen on (127.0.0.1)")
    src.add_argument("--pty", help="read mote frames from this pseudo-terminal instead")
    ap.add_argument("--out-port", type=int, required=True, help="UDP port to forward to (127.0.0.1)")
    ap.add_argument("--for", dest="seconds", type=float, default=600.0, help="stop after this long")
    ap.add_argument("--busy-us", type=float, default=0.0, help="busy work a message before it is sent, µs")
    ap.add_argument(
        "--poll", type=float, default=0.0, metavar="MS", help="poll for MS ms after each input (as --spin)"
    )
    args = ap.parse_args(argv)
    deadline = time.monotonic() + args.seconds
    poll = args.poll / 1000.0
    if args.pty:
        return _pty_relay(args.pty, args.out_port, deadline, poll)
    if args.out_port == 0:
        return _sink(args.in_port, deadline)
    server = osc_relay(args.in_port, args.out_port, args.busy_us)
    last_input = -math.inf
    try:
        while time.monotonic() < deadline:
            last_input = relay_one(server, poll, last_input)
    finally:
        server.server_close()
    return 0


def osc_relay(in_port: int, out_port: int, busy_us: float = 0.0) -> BlockingOSCUDPServer:
    """python-osc's server on 127.0.0.1:``in_port``, every message it parses sent on by python-osc's client
    to ``out_port`` (after ``busy_us`` µs of busy work); ``handle_request()`` relays one datagram."""
    client = SimpleUDPClient("127.0.0.1", out_port)
    busy = busy_us / 1e6

    def relay(address: str, *values: object) -> None:
        if busy:
            end = time.perf_counter() + busy
            while time.perf_counter() < end:
                pass
        client.send_message(address, list(values))

    dispatcher = Dispatcher()
    dispatcher.set_default_handler(relay)
    return BlockingOSCUDPServer(("127.0.0.1", in_port), dispatcher)


def relay_one(
    server: BlockingOSCUDPServer, poll: float = 0.0, last_input: float = -math.inf, wait: float = 0.2
) -> float:
    """Relay the next datagram if one comes within ``wait`` seconds; return when the last input came
    (``time.monotonic()``; ``last_input`` again when none did).

    For ``poll`` seconds after the last input it asks ``select`` with no timeout, in a busy loop, instead
    of sleeping in it (``pointat run --spin``'s policy, ``pointat.waiting.Waiter``): the next datagram
    finds the process awake.  Either way the same python-osc code relays it: ``handle_request()`` is a
    ``select`` and then ``_handle_request_noblock()``.
    """
    now = time.monotonic()
    if now - last_input < poll:
        until = min(now + wait, last_input + poll)
        while not select.select([server.socket], [], [], 0.0)[0]:
            if time.monotonic() >= until:
                return last_input
    elif not select.select([server.socket], [], [], wait)[0]:
        return last_input
    server._handle_request_noblock()
    return time.monotonic()


#: The benchmark's mote patches: gyro x count = TAG_BASE + tag (see benchmarks.latency).
TAG_BASE = 1548


def _pty_relay(path: str, out_port: int, deadline: float, poll: float = 0.0) -> int:
    from pointat.devices.mote_frame import FrameParser

    client = SimpleUDPClient("127.0.0.1", out_port)
    parser = FrameParser("binary")
    fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
    tty.setraw(fd)
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(True))
    last_input = -math.inf
    try:
        while (now := time.monotonic()) < deadline and not stop:
            # polling (select without a timeout) for ``poll`` seconds after an input, as --spin does
            if not select.select([fd], [], [], 0.0 if now - last_input < poll else 0.2)[0]:
                continue
            last_input = now
            for frame in parser.feed(os.read(fd, 4096)):
                client.send_message("/floor", [frame.mote, (frame.channels[0] - TAG_BASE) / 10.0])
    finally:
        os.close(fd)
    return 0


def _sink(port: int, deadline: float) -> int:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8 << 20)
    sock.bind(("127.0.0.1", port))
    sock.settimeout(0.2)
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(True))
    count = 0
    try:
        while time.monotonic() < deadline and not stop:
            try:
                sock.recv(65536)
                count += 1
            except (TimeoutError, InterruptedError):
                continue
    finally:
        sock.close()
        print(f"received {count}", flush=True)  # the benchmark reads this line
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
