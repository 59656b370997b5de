"""Receiver profiles: how each spatial-sound system wants a source's direction, as small tables.

pointat's own convention (ADM-OSC): azimuth in degrees, 0 front, **positive left**, -180..180; elevation
-90..90, positive up; distance 0..90 from the roll gesture (Torre: 0 far, 90 near).  A profile lists,
for one receiver, the messages to send per update: an address template (``{n}`` is the source number,
counted from the profile's ``first``) and the *fields* that make its arguments.  Fields are the named
conversions in :data:`FIELDS`; switching a patch from one receiver to another is one parameter.

======================  ======  ========================================================================
profile                 port    messages (arguments)
======================  ======  ========================================================================
``pointat``             9000    ``/pointat/{n}/aed`` az el dist01
``vbap`` (Pd/Max)       9000    ``/vbap/{n}`` az el spread: the receiver patch feeds [vbap]'s inlets
``adm`` (ADM-OSC 1.0)   4001    ``/adm/obj/{n}/aed`` az el dist01 (objects from 1, + left)
``iem_stereo``          8000    ``/StereoEncoder/azimuth`` az, ``/StereoEncoder/elevation`` el
``iem_multi``           8000    ``/MultiEncoder/azimuth{n}``, ``/MultiEncoder/elevation{n}`` (n from 0)
``spat`` (SPAT Rev.)    9000    ``/source/{n}/aed`` az_right el dist01 (+ right)
``icst`` (AmbiEncoder)  50001   ``/icst/ambi/sourceindex/xyz`` n x y z
``reaper``              8000    ``/track/{n}/pan`` pan (0 left .. 1 right)
``generic``             9000    ``address`` parameter, fields from the ``fields`` parameter
======================  ======  ========================================================================

Distances: ``dist01`` is ADM-OSC's normalised distance, 0 at the centre (near) .. 1 on the loudspeaker
sphere (far) = 1 - dist/90.  ``x y z`` are ADM-OSC's Cartesian axes: x right, y front, z up, at radius
``dist01``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

__all__ = ["FIELDS", "PROFILES", "Profile", "Source"]


@dataclass(frozen=True)
class Source:
    """One update of one source, in pointat's convention."""

    n: int
    az: float
    el: float = 0.0
    dist: float = 0.0
    spread: float = 0.0


def _xyz(s: Source) -> tuple[float, float, float]:
    r = 1.0 - min(max(s.dist, 0.0), 90.0) / 90.0
    a, e = math.radians(s.az), math.radians(s.el)
    return -r * math.cos(e) * math.sin(a), r * math.cos(e) * math.cos(a), r * math.sin(e)


#: Named conversions from a :class:`Source` to one OSC argument.
FIELDS: dict[str, Callable[[Source], float | int]] = {
    "n": lambda s: s.n,
    "az": lambda s: s.az,
    "az_right": lambda s: -s.az if s.az != -180.0 else 180.0,
    "az360": lambda s: s.az % 360.0,
    "el": lambda s: s.el,
    "dist": lambda s: s.dist,
    "dist01": lambda s: 1.0 - min(max(s.dist, 0.0), 90.0) / 90.0,
    "spread": lambda s: s.spread,
    "x": lambda s: _xyz(s)[0],
    "y": lambda s: _xyz(s)[1],
    "z": lambda s: _xyz(s)[2],
    "pan": lambda s: min(max(0.5 - s.az / 180.0, 0.0), 1.0),
}


@dataclass(frozen=True)
class Profile:
    """A receiver: default port, first source number, and the messages of one update."""

    name: str
    port: int
    first: int
    messages: tuple[tuple[str, tuple[str, ...]], ...]
    doc: str = ""

    def render(
        self, source: Source, address: str = "", fields: tuple[str, ...] = ()
    ) -> list[tuple[str, list]]:
        """The (address, arguments) pairs of one update; ``generic`` takes ``address`` and ``fields``."""
        messages = self.messages if self.name != "generic" else ((address, fields),)
        out = []
        for template, names in messages:
            args = [FIELDS[f](source) for f in names]
            out.append((template.format(n=source.n), args))
        return out


PROFILES: dict[str, Profile] = {
    p.name: p
    for p in (
        Profile("pointat", 9000, 1, (("/pointat/{n}/aed", ("az", "el", "dist01")),), "pointat's own"),
        Profile("vbap", 9000, 1, (("/vbap/{n}", ("az", "el", "spread")),), "Pd/Max [vbap] receiver patch"),
        Profile("adm", 4001, 1, (("/adm/obj/{n}/aed", ("az", "el", "dist01")),), "ADM-OSC 1.0"),
        Profile(
            "iem_stereo",
            8000,
            1,
            (("/StereoEncoder/azimuth", ("az",)), ("/StereoEncoder/elevation", ("el",))),
            "IEM StereoEncoder",
        ),
        Profile(
            "iem_multi",
            8000,
            0,
            (("/MultiEncoder/azimuth{n}", ("az",)), ("/MultiEncoder/elevation{n}", ("el",))),
            "IEM MultiEncoder (inputs from 0)",
        ),
        Profile("spat", 9000, 1, (("/source/{n}/aed", ("az_right", "el", "dist01")),), "SPAT Revolution"),
        Profile(
            "icst", 50001, 1, (("/icst/ambi/sourceindex/xyz", ("n", "x", "y", "z")),), "ICST AmbiEncoder"
        ),
        Profile("reaper", 8000, 1, (("/track/{n}/pan", ("pan",)),), "REAPER track pan"),
        Profile("generic", 9000, 1, (), "any address, any fields"),
    )
}
