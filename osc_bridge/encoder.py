"""The OSC messages of one ``osc_out`` update, encoded once and packed per update."""

from __future__ import annotations

import struct
from collections.abc import Sequence
from typing import Any

from pointat.devices.osc_wire import _fit, _padded

from .profiles import Profile, Source


class UpdateEncoder:
    """The OSC messages of one update, their addresses and type tags encoded once (:meth:`Profile.compile`):
    per update only the numbers are packed.  The same bytes as :func:`encode_message` of
    :meth:`Profile.render`.

    >>> from pointat.devices.osc_wire import encode_message
    >>> from pointat.osc_bridge.profiles import PROFILES
    >>> enc = UpdateEncoder(PROFILES["adm"], 3)
    >>> enc.encode(Source(3, az=30.0)) == [encode_message("/adm/obj/3/aed", [30.0, 0.0, 1.0])]
    True
    """

    def __init__(self, profile: Profile, n: int, messages: Sequence[tuple[str, Sequence[Any]]] | None = None):
        self.parts = tuple(
            (_padded(address) + _padded("," + tags), getters, struct.Struct(">" + tags).pack)
            for address, tags, getters in profile.compile(n, messages)
        )

    def encode(self, source: Source) -> list[bytes]:
        try:
            return [head + pack(*[g(source) for g in getters]) for head, getters, pack in self.parts]
        except (struct.error, OverflowError):  # a number beyond float32 / int32: the nearest that fits
            return [head + pack(*[_fit(g(source)) for g in getters]) for head, getters, pack in self.parts]
