"""Spatialisation nodes: loudspeaker gains computed inside pointat.

The math is in :mod:`pointat.maths.vbap`; this module only moves messages.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from pointat.maths.vbap import Layout, Panner, parse_layout, read_layout
from pointat.message import Message, as_float, vector
from pointat.node import Inlet, Node, Outlet, Param
from pointat.registry import register

__all__ = ["Vbap"]


@register("vbap")
class Vbap(Node):
    """Vector base amplitude panning (Pulkki 1997): one gain per loudspeaker for a source direction.

    The loudspeakers come from ``layout`` (azimuths for a ring, ``[az, el]`` pairs for 3-D, or pd-vbap's
    flat ``az el az el ...`` with ``dim=3``) or from a layout ``file`` (``.json`` or pd-vbap's
    ``define_loudspeakers`` text; see ``pointat.maths.vbap``).  Angles follow pointat (0 front, + left,
    elevation + up), which are also pd-vbap's angles when its loudspeakers are written the same way.
    3-D triplets come from the convex hull of the loudspeakers and never overlap, also for a ring plus
    a few elevated loudspeakers (where pd-vbap's own triangulation goes wrong).

    Gains have unit power (the squares sum to 1) and are never negative.  A direction no loudspeakers
    cover (below a dome's ring, in a gap of more than 170° in 2-D) gets the gains of the nearest covered
    direction, which leaves by ``direction``.  ``spread`` (0..100) widens the source as pd-vbap does.

    A number at the left inlet (or a list ``azimuth elevation [spread]``) computes and outputs, right to
    left: ``direction``, then one ``index gain`` list per loudspeaker (index from 0, as pd-vbap's outlet,
    ready for ``route 0 1 2 ...``), then the ``gains`` vector.  A bang outputs again.  To drive a mixer or
    a DAW, route each loudspeaker's gain to an ``osc_out`` (``profile=generic fields=[az]`` sends the
    number that reaches its first inlet, at ``address``).  To let Pd do the panning instead, send the
    direction with ``osc_out profile=vbap`` to ``examples/pd/vbap_receiver.pd``.
    """

    needs_input = True

    inlets = (
        Inlet(
            "azimuth",
            ("float", "int", "list", "bang"),
            "degrees, + left (a list: azimuth elevation [spread]); bang: output again",
        ),
        Inlet("elevation", ("float", "int"), "degrees, + up (ignored by a 2-D layout)"),
        Inlet("spread", ("float", "int"), "source spread 0..100 (pd-vbap's)", param="spread"),
    )
    outlets = (
        Outlet("gains", "vector", "one gain per loudspeaker, in layout order, squares summing to 1"),
        Outlet("speaker", "list", "index gain, once per loudspeaker (index from 0, as pd-vbap)"),
        Outlet("direction", "list", "azimuth elevation actually panned (the nearest covered one outside)"),
    )
    params = (
        Param(
            "layout",
            "list",
            (),
            "loudspeaker azimuths (2-D), [az, el] pairs (3-D), or az el ... with dim=3",
            unit="deg",
            live=True,
        ),
        Param("dim", "int", 0, "2 or 3 (0: 3 when any elevation is not 0)"),
        Param(
            "file",
            "path",
            "",
            "layout file (.json or define_loudspeakers text), instead of layout",
            reads=True,
        ),
        Param("spread", "float", 0.0, "source spread, 0 (a point) .. 100 (all loudspeakers)", live=True),
    )
    example = """
node dir  azi_ele
node spk  vbap layout=[0, 45, 90, 135, 180, -135, -90, -45]
node ch   route 0 1 2 3 4 5 6 7
node ch1  osc_out profile=generic address=/mixer/1/gain fields=[az] port=8000
node ch2  osc_out profile=generic address=/mixer/2/gain fields=[az] port=8000
dir.elevation -> spk.elevation
dir.azimuth -> spk.azimuth
spk.speaker -> ch
ch.0 -> ch1
ch.1 -> ch2
"""

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        # what building the node would refuse, refused by check (with the patch line) and by a live change
        listed = cls._listed(values)
        if listed is not None:
            Panner(listed)

    @classmethod
    def _listed(cls, values: Mapping[str, Any]) -> Layout | None:
        """The loudspeakers given by ``layout``, or None when they are in ``file`` (read as the node is
        built, and by ``pointat check``); refuses a ``dim``, or a choice of the two, that cannot work."""
        if values["dim"] not in (0, 2, 3):
            raise ValueError(f"dim must be 2 or 3 (or 0: inferred); got {values['dim']}")
        if values["file"] and values["layout"]:
            raise ValueError("give the loudspeakers by layout or by file, not both")
        if values["file"]:
            return None
        if not values["layout"]:
            raise ValueError("no loudspeakers: give layout=[az, ...] or file=LAYOUT")
        return parse_layout(values["layout"], dim=values["dim"])

    def setup(self) -> None:
        self.layout = self._load()
        self._layout_param = self.p.layout
        self.panner = Panner(self.layout)
        self._az = 0.0
        self._el = 0.0

    def _load(self) -> Layout:
        listed = self._listed(vars(self.p))
        if listed is not None:
            return listed
        layout = read_layout(self.p.file)
        if self.p.dim and layout.dim != self.p.dim:
            raise ValueError(f"{self.p.file} is a {layout.dim}-D layout, but dim={self.p.dim}")
        return layout

    def param_changed(self, name: str) -> None:
        if name == "layout":
            try:
                self.layout = self._load()
            except ValueError:
                self.p.layout = self._layout_param  # a bad layout changes nothing
                raise
            self._layout_param = self.p.layout
            self.panner = Panner(self.layout)

    def on_elevation(self, msg: Message) -> None:
        el = as_float(msg)
        if not math.isfinite(el):
            raise ValueError(f"elevation {el} refused: not a finite number; the last good one stays")
        self._el = el

    def on_azimuth(self, msg: Message) -> None:
        az, el, spread = self._az, self._el, None
        if msg.kind == "list":
            values = [float(v) for v in msg.value]
            if not values:
                raise TypeError("expected azimuth [elevation [spread]], got an empty list")
            az = values[0]
            if len(values) > 1:
                el = values[1]
            if len(values) > 2:
                spread = values[2]
        elif msg.kind != "bang":
            az = as_float(msg)
        if not (math.isfinite(az) and math.isfinite(el)):  # refused whole: the last good direction stays
            raise ValueError(f"direction ({az}, {el}) is NaN or infinite: refused")
        if spread is not None:
            self.set_param("spread", spread)  # validated: a bad spread refuses the message too
        self._az, self._el = az, el
        gains = self.panner.gains(self._az, self._el, self.p.spread)
        az, el = self.panner.direction
        self.out(2, (az, el))
        for i, g in enumerate(gains.tolist()):
            self.out(1, (i, g))
        self.out(0, vector(gains))
