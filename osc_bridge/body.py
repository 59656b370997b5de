"""``osc_body``: a whole body over OSC, each segment's orientation and joint position, for motion-capture
receivers (TouchDesigner, Unity, Max, a game engine) as much as for a spatialiser.

The address space, in the style of pointat's own profile (``/pointat/N/aed``), one bundle an update::

    /pointat/body/SEGMENT/quat  w x y z     the segment's orientation (body frame: x front, y left, z up)
    /pointat/body/SEGMENT/pos   x y z       its proximal joint, metres (the root placed by the skeleton)
    /pointat/body/SEGMENT/end   x y z       its far end (the fingertips of a hand), metres

float32 throughout, as every OSC receiver reads it.  Sockets, destinations, refusals and lost
datagrams are ``osc_out``'s (:class:`~pointat.osc_bridge.sender.UdpSender`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from pointat.devices.osc_wire import encode_message
from pointat.message import Message, as_floats
from pointat.node import Inlet, Param
from pointat.nodes.body import ARM, _load
from pointat.registry import register

from .sender import Destination, UdpSender, destinations

__all__ = ["OscBody"]


@register("osc_body")
class OscBody(UdpSender):
    """Send a skeleton over OSC: every segment's orientation, joint and end, one bundle an update.

    Wire a ``skeleton`` node's ``ends``, ``joints`` and ``segments`` outlets to the inlets of the same
    names (it sends them right to left, so ``segments``, the hot one, comes last).  Addresses:
    ``PREFIX/SEGMENT/quat w x y z``, ``PREFIX/SEGMENT/pos x y z``, ``PREFIX/SEGMENT/end x y z`` (metres;
    body frame: x front, y left, z up), segment names from ``file``.  A segment with a NaN is skipped for
    that update.  As ``osc_out``: non-blocking UDP, an absent receiver counted and said once.
    """

    needs_input = True

    inlets = (
        Inlet("segments", ("vector", "list"), "each segment's orientation, 4M numbers (skeleton.segments)"),
        Inlet("joints", ("vector", "list"), "each segment's joint, 3M numbers (skeleton.joints)", hot=False),
        Inlet("ends", ("vector", "list"), "each segment's far end, 3M numbers (skeleton.ends)", hot=False),
    )
    outlets = ()
    params = (
        Param("host", "symbol", "127.0.0.1", "receiver address (name or IP)"),
        Param("port", "int", 9000, "receiver UDP port", minimum=1, maximum=65535),
        Param("to", "list", (), "more destinations: host:port, or a port on the same host"),
        Param("prefix", "symbol", "/pointat/body", "the addresses' start"),
        Param("file", "path", ARM, "the skeleton (JSON): the segments' names", reads=True),
        Param("bundle", "bool", True, "one bundle an update (false: the messages one by one)"),
    )
    example = """
node suit tqt_bank sensors=3
node body skeleton
node out  osc_body port=9000
suit.quats -> body
body.ends -> out.ends
body.joints -> out.joints
body.segments -> out.segments
"""

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        prefix = values["prefix"]
        if not prefix.startswith("/") or prefix.endswith("/") or any(c in prefix for c in " #*,?[]{}"):
            raise ValueError(
                f"prefix {prefix!r}: an OSC address starts with / and holds no space or # * , ? [ ] {{ }}"
            )
        destinations(values["host"], values["port"], values["to"])

    @classmethod
    def check_files(cls, values: Mapping[str, Any]) -> None:
        _load(values["file"])

    def describe(self) -> str:
        return f"OSC skeleton to {self.p.host}:{self.p.port}"

    def setup(self) -> None:
        body = _load(self.p.file)
        self.names = [s.name for s in body.segments]
        self._addresses = [
            (f"{self.p.prefix}/{n}/quat", f"{self.p.prefix}/{n}/pos", f"{self.p.prefix}/{n}/end")
            for n in self.names
        ]
        self.dests = [Destination(h, p) for h, p in destinations(self.p.host, self.p.port, self.p.to)]
        self._joints: tuple[float, ...] = ()
        self._ends: tuple[float, ...] = ()
        self._timer = None
        self._outbox: list[bytes] = []
        self.updates = self.sent = self.failed = self.refused = 0

    def on_joints(self, msg: Message) -> None:
        self._joints = as_floats(msg, 3 * len(self.names))

    def on_ends(self, msg: Message) -> None:
        self._ends = as_floats(msg, 3 * len(self.names))

    def on_segments(self, msg: Message) -> None:
        q = as_floats(msg, 4 * len(self.names))
        out = []
        for k, (aq, ap, ae) in enumerate(self._addresses):
            part = q[4 * k : 4 * k + 4]
            if not all(math.isfinite(c) for c in part):
                continue
            out.append(encode_message(aq, list(part)))
            for address, values in ((ap, self._joints), (ae, self._ends)):
                p = values[3 * k : 3 * k + 3]
                if len(p) == 3 and all(math.isfinite(c) for c in p):
                    out.append(encode_message(address, list(p)))
        if out:
            self.updates += 1
            self.send(out)
