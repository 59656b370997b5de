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

__all__ = ["Collect", "make", "patch", "test_registry", "wait_until"]


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


def patch(text: str, *, realtime: bool = False, registry: Registry | None = None) -> Runtime:
    """Parse, check and build native patch text; a manual clock unless ``realtime``."""
    checked = check(parse_patch(text, "<test>"), registry or test_registry())
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
    """``--set NODE.port=0`` for every ``osc_in`` of ``patch`` (listening on any free port instead of
    the one in the file, 9001 in the shipped patches): a test that runs the patch runs beside one a
    performer has running."""
    from .expansion import expand, read_spec

    spec = expand(read_spec(patch))
    return [a for d in spec.nodes if d.type == "osc_in" for a in ("--set", f"{d.name}.port=0")]
