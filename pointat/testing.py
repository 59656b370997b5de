"""Helpers for testing patches and node types: push values in, collect the output into a list.

>>> rt = patch('''
... node t trigger f b
... node out collect
... t.1 -> out
... t.0 -> out
... ''')
>>> rt.nodes["t"].receive(0, make(3.0))
>>> [m.kind for m in rt.nodes["out"].messages]
['bang', 'float']
"""

from __future__ import annotations

import os
import socket
import time
from collections.abc import Callable
from typing import Any

from .checking import check
from .loader import build
from .message import Message, make
from .node import Inlet, Node
from .patchfile import parse_patch
from .registry import Registry, default_registry
from .runtime import Runtime

__all__ = [
    "Collect",
    "beside",
    "free_udp_port",
    "make",
    "patch",
    "sink_port",
    "test_registry",
    "wait_until",
]


class Collect(Node):
    """Store every message it receives (``messages``; ``values`` for their values)."""

    type_name = "collect"
    inlets = (Inlet("in", ("any",), "anything"),)

    def setup(self) -> None:
        self.messages: list[Message] = []

    def on_in(self, msg: Message) -> None:
        self.messages.append(msg)

    @property
    def values(self) -> list[Any]:
        """The values of the messages so far (a new list: append to ``messages``, not to this)."""
        return [m.value for m in self.messages]


def test_registry() -> Registry:
    """The built-in node types plus ``collect``."""
    reg = default_registry.load_builtins().copy()
    reg.add(Collect, "pointat.testing")
    return reg


test_registry.__test__ = False  # type: ignore[attr-defined]  # not a pytest test


def patch(
    text: str, *, realtime: bool = False, registry: Registry | None = None, file: str = "<test>"
) -> Runtime:
    """Parse, check and build native patch text; a manual clock unless ``realtime``.  ``file``: where the
    text is taken to be written (its abstractions and relative paths are found beside it)."""
    checked = check(parse_patch(text, file), registry or test_registry())
    rt = build(checked, realtime=realtime)
    return rt


def wait_until(predicate: Callable[[], bool], timeout: float = 5.0, poll: float = 0.005) -> bool:
    """Poll ``predicate`` until it is true or ``timeout`` seconds pass (threads, ports); its last answer."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(poll)
    return bool(predicate())


wait_until.__test__ = False  # type: ignore[attr-defined]


def beside(patch: str | os.PathLike[str]) -> list[str]:
    """``--set`` arguments that move every port of ``patch`` off the ones in the file (9000 out and 9001
    control in the shipped patches): each ``osc_in`` listens on a free port (``port=0``), and each sender
    (``osc_out``, ``osc_send``, ``osc_body``, their ``to`` too) sends to :func:`sink_port`.  A test that
    runs the patch runs beside one a performer has running, and sends nothing to the performer's
    renderer.  Put a test's own ``--set`` after these: the last one given wins."""
    from .expansion import expand, read_spec

    sets = []
    for d in expand(read_spec(patch)).nodes:
        if d.type == "osc_in":
            sets.append(f"{d.name}.port=0")
        elif d.type in ("osc_out", "osc_send", "osc_body"):
            sets.append(f"{d.name}.port={sink_port()}")
            if "to" in d.params:
                sets.append(f"{d.name}.to=[{sink_port()}]")
    return [a for s in sets for a in ("--set", s)]


_sink: socket.socket | None = None


def free_udp_port() -> int:
    """A UDP port on 127.0.0.1 that nothing held when asked (closed again at once: until something binds
    it, loopback refuses what is sent there; anything on the machine may take it meanwhile)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def sink_port() -> int:
    """A UDP port on 127.0.0.1 that this process holds open and never reads (the kernel drops what does
    not fit): where :func:`beside` sends a patch's output."""
    global _sink
    if _sink is None:
        _sink = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        _sink.bind(("127.0.0.1", 0))
    return _sink.getsockname()[1]
