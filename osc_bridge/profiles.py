r"""Receiver profiles and sensor formats: what each OSC peer sends or wants, as small tables.

pointat's own convention (ADM-OSC): azimuth in degrees, 0 front, **positive left**, -180..180; elevation
-90..90, positive up; distance 0..90 from the roll gesture (Torre: 0 far, 90 near).  A :class:`Profile`
lists, for one receiver, the messages of one update: an address template (``{n}`` is the source number,
counted from the profile's ``first``) and the *fields* that make its arguments.  Fields are the named
conversions in :data:`FIELDS`, each with its OSC type tag (``f`` float32, ``i`` int32).  Switching a
patch from one receiver to another is one parameter (``osc_out profile=...``).

======================  ======  ========================================================================
profile                 port    messages of one update (type tags)
======================  ======  ========================================================================
``pointat``             9000    ``/pointat/{n}/aed`` az el dist01 (``fff``)
``vbap`` (Pd/Max)       9000    ``/vbap/{n}`` az el spread (``fff``): the receiver feeds [vbap]'s cold
                                inlets 1-3 (azimuth, elevation, spread), then bangs inlet 0
``adm`` (ADM-OSC 1.0)   4001    ``/adm/obj/{n}/aed`` az el dist01 (``fff``), objects from 1, + left
``iem_stereo``          8000    ``/StereoEncoder/azimuth`` az, ``/StereoEncoder/elevation`` el (``f``)
``iem_multi``           8000    ``/MultiEncoder/azimuth{n}`` az, ``/MultiEncoder/elevation{n}`` el
                                (``f``), inputs from 0
``spat`` (SPAT Rev.)    9000    ``/source/{n}/aed`` az_right el dist_m (``fff``), + right, metres
``icst`` (AmbiEncoder)  50001   ``/icst/ambi/sourceindex/xyz`` n x y z (``ifff``), sources from 1
``reaper``              8000    ``/track/{n}/pan`` pan (``f``), 0 left .. 0.5 centre .. 1 right
``generic``             9000    the ``address`` parameter, arguments from the ``fields`` parameter
======================  ======  ========================================================================

Distances: ``dist01`` is ADM-OSC's normalised distance, 1 on the loudspeaker sphere (far) .. 0 at the
centre (near), :math:`d_{01} = 1 - d/90`; ``dist_m`` is that times a radius in metres.  ``x y z`` are
ADM-OSC's Cartesian axes (x right, y front, z up) at radius ``dist01``; ICST's AmbiPlugins (version 2,
current) use the same axes; their version 1 plug-ins had x to the front and will read a source turned
90 degrees.  ``pan`` folds rear directions onto the front (stereo has no rear):
:math:`p = \tfrac12 - a_f/180` with :math:`a_f` the azimuth mirrored into -90..90 (continuous all round).

>>> PROFILES["spat"].render(Source(1, az=30.0))
[('/source/1/aed', [-30.0, 0.0, 1.0])]
>>> PROFILES["adm"].render(Source(2, az=-45.0, el=10.0, dist=45.0))
[('/adm/obj/2/aed', [-45.0, 10.0, 0.5])]
>>> PROFILES["reaper"].render(Source(3, az=90.0))
[('/track/3/pan', [0.0])]

Sensor formats (``osc_in device=...``) are tables too: :data:`SENSORS` maps a device to :class:`Rule`
rows (address pattern, outlet, argument indices, scale to SI units).
"""

from __future__ import annotations

import fnmatch
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

from pointat.maths.scalar import fold_front

__all__ = [
    "FIELDS",
    "G",
    "PROFILES",
    "SENSORS",
    "SENSOR_OUTLETS",
    "Field",
    "Profile",
    "Rule",
    "Source",
    "check_fields",
    "field_dist",
    "field_dist01",
    "field_el",
    "field_spread",
    "fold_front",
    "parse_rule",
    "wrap180",
]

#: Standard gravity, m/s² per g.
G = 9.80665


class Source(NamedTuple):
    """One update of one source, in pointat's convention (a small immutable record, built per update).

    Parameters
    ----------
    n : int
        Source, object, track or input number, as the receiver counts.
    az, el : float
        Azimuth (+ left) and elevation (+ up), degrees.
    dist : float
        Roll-gesture distance, 0 (far, on the loudspeakers) .. 90 (near, at the centre).
    spread : float
        VBAP spread, 0..100.
    radius : float
        Metres at ``dist01 = 1`` (for receivers that want metres).
    """

    n: int
    az: float
    el: float = 0.0
    dist: float = 0.0
    spread: float = 0.0
    radius: float = 1.0


def wrap180(a: float) -> float:
    """An angle in degrees wrapped into (-180, 180].

    >>> wrap180(190.0), wrap180(-180.0), wrap180(30.0)
    (-170.0, 180.0, 30.0)
    """
    return 0.0 - ((180.0 - a) % 360.0 - 180.0)  # 0.0 - x: never -0.0


# The clamps are comparisons, not min(max()): these run for every update osc_out sends.  (NaN passes
# through them as it does through min and max.)
def field_dist(s: Source) -> float:
    """Field ``dist``: the roll distance clamped to 0..90."""
    d = s.dist
    return 90.0 if d > 90.0 else 0.0 if d < 0.0 else d


def field_dist01(s: Source) -> float:
    """Field ``dist01``: ADM-OSC's distance, 1 far .. 0 near."""
    return 1.0 - field_dist(s) / 90.0


def field_el(s: Source) -> float:
    """Field ``el``: the elevation clamped to -90..90."""
    e = s.el
    return 90.0 if e > 90.0 else -90.0 if e < -90.0 else e


def field_spread(s: Source) -> float:
    """Field ``spread``: the spread clamped to 0..100."""
    v = s.spread
    return 100.0 if v > 100.0 else 0.0 if v < 0.0 else v


def _xyz(s: Source) -> tuple[float, float, float]:
    r = field_dist01(s)
    a, e = math.radians(s.az), math.radians(field_el(s))
    return -r * math.cos(e) * math.sin(a), r * math.cos(e) * math.cos(a), r * math.sin(e)


@dataclass(frozen=True)
class Field:
    """A named conversion from a :class:`Source` to one OSC argument, with its type tag and doc."""

    fn: Callable[[Source], float]
    tag: str
    doc: str


#: Named conversions from a :class:`Source` to one OSC argument.
FIELDS: dict[str, Field] = {
    "n": Field(lambda s: s.n, "i", "the source number"),
    "az": Field(lambda s: wrap180(s.az), "f", "azimuth, deg, + left, -180..180"),
    "az_right": Field(lambda s: wrap180(-s.az), "f", "azimuth, deg, + right, -180..180"),
    "az360": Field(lambda s: s.az % 360.0, "f", "azimuth, deg, + left, 0..360"),
    "el": Field(field_el, "f", "elevation, deg, + up"),
    "dist": Field(field_dist, "f", "roll distance, 0 far .. 90 near"),
    "dist01": Field(field_dist01, "f", "ADM-OSC distance, 1 far (loudspeakers) .. 0 centre"),
    "dist_m": Field(lambda s: s.radius * field_dist01(s), "f", "distance in metres (radius x dist01)"),
    "spread": Field(field_spread, "f", "VBAP spread, 0..100"),
    "x": Field(lambda s: _xyz(s)[0], "f", "x, + right, radius dist01"),
    "y": Field(lambda s: _xyz(s)[1], "f", "y, + front, radius dist01"),
    "z": Field(lambda s: _xyz(s)[2], "f", "z, + up, radius dist01"),
    "pan": Field(lambda s: 0.5 - fold_front(s.az) / 180.0, "f", "stereo pan, 0 left .. 1 right"),
}


def _value(field: str | int | float, source: Source) -> int | float:
    if isinstance(field, str):
        f = FIELDS[field]
        v = f.fn(source)
        return int(v) if f.tag == "i" else float(v)
    return field  # a constant


def _getter(field: str | int | float, n: int) -> Callable[[Source], int | float]:
    if field == "n":  # fixed for a compiled encoder: a constant
        field = n
    if isinstance(field, str):
        f = FIELDS[field]
        return (lambda s, fn=f.fn: int(fn(s))) if f.tag == "i" else f.fn
    return lambda s, c=field: c  # a constant


def check_fields(fields: Sequence[Any]) -> tuple[str | int | float, ...]:
    """Validate a generic field list: names from :data:`FIELDS`, or numeric constants.

    >>> check_fields(["az", "el", 1])
    ('az', 'el', 1)
    >>> check_fields(["azimuth"])
    Traceback (most recent call last):
    ...
    ValueError: unknown field 'azimuth' (fields: n az az_right az360 el dist dist01 dist_m spread x y z pan, or a number)
    """
    out: list[str | int | float] = []
    for f in fields:
        if isinstance(f, bool) or not isinstance(f, (str, int, float)):
            raise ValueError(f"field {f!r}: expected a field name or a number")
        if isinstance(f, str) and f not in FIELDS:
            raise ValueError(f"unknown field '{f}' (fields: {' '.join(FIELDS)}, or a number)")
        if isinstance(f, int) and not -(2**31) <= f < 2**31:
            raise ValueError(f"field {f}: an OSC int is 32 bits (-2147483648 .. 2147483647)")
        if isinstance(f, float) and math.isfinite(f) and abs(f) > 3.4028234663852886e38:
            raise ValueError(f"field {f:g}: beyond an OSC float (float32, at most 3.403e+38)")
        out.append(f)
    return tuple(out)


@dataclass(frozen=True)
class Profile:
    """A receiver: its default UDP port, its first source number, and the messages of one update.

    ``messages`` pairs an address template (``{n}``: the source number) with field names; a profile
    without messages (``generic``) takes them from the node's ``address`` and ``fields`` parameters.
    """

    name: str
    port: int
    first: int
    messages: tuple[tuple[str, tuple[str | int | float, ...]], ...]
    doc: str = ""
    #: False for a receiver known to ignore a bundle's time tag (``osc_out``'s ``delay`` would do nothing).
    time_tags: bool = True
    #: Whether ``osc_out`` sends its heartbeat and state (``/pointat/N/status``) unless told: True for
    #: receivers a patch of one's own reads (Pd, Max: route it), False for products that would log every
    #: address they do not know.
    status: bool = True

    def render(
        self, source: Source, messages: Sequence[tuple[str, Sequence[str | int | float]]] | None = None
    ) -> list[tuple[str, list[int | float]]]:
        """The (address, arguments) pairs of one update; ``messages`` replaces the profile's own."""
        return [
            (template.format(n=source.n), [_value(f, source) for f in fields])
            for template, fields in (self.messages if messages is None else messages)
        ]

    def compile(
        self, n: int, messages: Sequence[tuple[str, Sequence[str | int | float]]] | None = None
    ) -> tuple[tuple[str, str, tuple[Callable[[Source], int | float], ...]], ...]:
        """For source ``n``: each message's address, its type tags and one function per argument.

        What :meth:`render` works out on every update, worked out once; ``osc_out`` encodes from it.

        >>> [(address, tags) for address, tags, _ in PROFILES["icst"].compile(2)]
        [('/icst/ambi/sourceindex/xyz', 'ifff')]
        """
        msgs = self.messages if messages is None else messages
        return tuple(
            (template.format(n=n), tags, tuple(_getter(f, n) for f in fields))
            for (template, fields), tags in zip(msgs, self.type_tags(msgs), strict=True)
        )

    def type_tags(
        self, messages: Sequence[tuple[str, Sequence[str | int | float]]] | None = None
    ) -> list[str]:
        """The OSC type tags of each message, e.g. ``['fff']``.

        >>> PROFILES["icst"].type_tags()
        ['ifff']
        """
        out = []
        for _, fields in self.messages if messages is None else messages:
            tags = ""
            for f in fields:
                tags += FIELDS[f].tag if isinstance(f, str) else ("i" if isinstance(f, int) else "f")
            out.append(tags)
        return out


#: The receivers, by name.
PROFILES: dict[str, Profile] = {
    p.name: p
    for p in (
        Profile("pointat", 9000, 1, (("/pointat/{n}/aed", ("az", "el", "dist01")),), "pointat's own"),
        Profile(
            "vbap",
            9000,
            1,
            (("/vbap/{n}", ("az", "el", "spread")),),
            "Pd/Max [vbap]: azimuth elevation spread",
        ),
        Profile(
            "adm",
            4001,
            1,
            (("/adm/obj/{n}/aed", ("az", "el", "dist01")),),
            "ADM-OSC 1.0 (objects from 1)",
            status=False,
        ),
        Profile(
            "iem_stereo",
            8000,
            1,
            (("/StereoEncoder/azimuth", ("az",)), ("/StereoEncoder/elevation", ("el",))),
            "IEM StereoEncoder (one plug-in per port)",
            time_tags=False,
            status=False,
        ),
        Profile(
            "iem_multi",
            8000,
            0,
            (("/MultiEncoder/azimuth{n}", ("az",)), ("/MultiEncoder/elevation{n}", ("el",))),
            "IEM MultiEncoder (inputs from 0)",
            time_tags=False,
            status=False,
        ),
        Profile(
            "spat",
            9000,
            1,
            (("/source/{n}/aed", ("az_right", "el", "dist_m")),),
            "SPAT Revolution (+ right)",
            status=False,
        ),
        Profile(
            "icst",
            50001,
            1,
            (("/icst/ambi/sourceindex/xyz", ("n", "x", "y", "z")),),
            "ICST AmbiEncoder (sources from 1)",
            status=False,
        ),
        Profile(
            "reaper",
            8000,
            1,
            (("/track/{n}/pan", ("pan",)),),
            "REAPER track pan (tracks from 1)",
            status=False,
        ),
        Profile("generic", 9000, 1, (), "any address, any fields"),
    )
}


# --------------------------------------------------------------------------- sensors (osc_in)
#: The sensor outlets of ``osc_in`` and the number of values each one carries.
SENSOR_OUTLETS: dict[str, int] = {"gyro": 3, "accel": 3, "mag": 3, "quat": 4}


@dataclass(frozen=True)
class Rule:
    """One sensor reading: messages whose address matches ``pattern`` feed ``outlet``.

    ``pattern`` is an OSC address where ``*`` matches anything (``*/quaternion`` matches
    ``/ZIGSIM/<uuid>/quaternion``); ``indices`` picks the arguments (``None``: the first ones, as many as
    the outlet carries); each value is multiplied by ``scale``.
    """

    pattern: str
    outlet: str
    indices: tuple[int, ...] | None = None
    scale: float = 1.0

    def matches(self, address: str) -> bool:
        return fnmatch.fnmatchcase(address, self.pattern)

    def extract(self, args: Sequence[Any]) -> list[float]:
        """The outlet's values from a message's arguments; ``ValueError`` if they do not fit.

        >>> Rule("/quaternion", "quat", (3, 0, 1, 2)).extract([0.1, 0.2, 0.3, 0.9])
        [0.9, 0.1, 0.2, 0.3]
        """
        idx = self.indices if self.indices is not None else _FIRST[self.outlet]
        scale = float(self.scale)  # so that ints come out as floats
        try:
            values = [args[i] * scale for i in idx if type(args[i]) is float or type(args[i]) is int]
        except IndexError:
            raise ValueError(
                f"{self.pattern}: expected at least {max(idx) + 1} arguments, got {len(args)}"
            ) from None
        if len(values) != len(idx):  # a string, a blob, True... (bool is not int here)
            raise ValueError(f"{self.pattern}: expected numbers, got {[args[i] for i in idx]!r}")
        if not math.isfinite(sum(values)):  # rare: a NaN or an infinity, sent as such or made by the scale
            for v, i in zip(values, idx, strict=True):
                if not math.isfinite(v) and math.isfinite(args[i]):
                    raise ValueError(
                        f"{self.pattern}: argument {i} = {args[i]!r} times the scale {scale:g} is not a finite number"
                    )
        return values


#: The arguments an outlet takes when a rule names none: the first ones, as many as the outlet carries.
_FIRST = {name: tuple(range(n)) for name, n in SENSOR_OUTLETS.items()}

_DEG = math.pi / 180.0

#: Sensor formats by device: NGIMU (x-io: gyro deg/s, accel g, mag uT, quaternion w x y z), ZIG SIM
#: (quaternion x y z w, gyro rad/s, gravity g pointing down; its ``accel`` is user acceleration without
#: gravity, so the accel outlet is fed from ``gravity``).  Outputs: gyro rad/s, accel m/s² (specific
#: force, +g up at rest), mag gauss (as ``scaling``), quat (w, x, y, z) as the device sends it.
SENSORS: dict[str, tuple[Rule, ...]] = {
    "none": (),
    "ngimu": (
        Rule("/sensors", "gyro", (0, 1, 2), _DEG),
        Rule("/sensors", "accel", (3, 4, 5), G),
        Rule("/sensors", "mag", (6, 7, 8), 0.01),
        Rule("/quaternion", "quat", (0, 1, 2, 3)),
    ),
    "zigsim": (
        Rule("*/quaternion", "quat", (3, 0, 1, 2)),
        Rule("*/gyro", "gyro", (0, 1, 2)),
        Rule("*/gravity", "accel", (0, 1, 2), -G),
    ),
}


def parse_rule(text: str) -> Rule:
    """A generic mapping ``ADDRESS=OUTLET`` or ``ADDRESS=OUTLET*SCALE`` -> :class:`Rule`.

    >>> parse_rule("/imu/acc=accel*9.80665")
    Rule(pattern='/imu/acc', outlet='accel', indices=None, scale=9.80665)
    >>> parse_rule("/imu/gyro=gyro").scale
    1.0
    """
    pattern, eq, rest = str(text).rpartition("=")
    outlet, star, scale = rest.partition("*")
    if not eq or not pattern.startswith(("/", "*")):
        raise ValueError(f"map entry {text!r}: expected /address=outlet or /address=outlet*scale")
    if outlet not in SENSOR_OUTLETS:
        raise ValueError(
            f"map entry {text!r}: unknown outlet '{outlet}' (outlets: {' '.join(SENSOR_OUTLETS)})"
        )
    try:
        factor = float(scale) if star else 1.0
    except ValueError:
        raise ValueError(f"map entry {text!r}: scale '{scale}' is not a number") from None
    if not math.isfinite(factor):  # 1e400, inf, nan: every reading would come out as infinity or NaN
        raise ValueError(f"map entry {text!r}: scale '{scale}' is not a finite number")
    return Rule(pattern, outlet, None, factor)
