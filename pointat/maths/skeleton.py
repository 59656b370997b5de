r"""A body as a tree of rigid segments, one sensor on each (Bachmann et al., VRST 2001; US 7,089,148).

Bachmann's posture tracker gives every limb segment its own MARG sensor and filter, and composes the
segments' orientations along the body's kinematic chain into positions (the patent's position
translation, :math:`p_{trans}`).  Here:

* A :class:`Skeleton` names its segments, each with its parent, where its proximal joint sits in the
  parent's frame (``at``; the root's: in the body frame, from :attr:`Skeleton.root`), the vector from that
  joint to the segment's far end in the segment's own frame (``length``), the sensor on it (1-based, as
  ``tqt_bank``'s ``sensorI``; none: the segment moves with its parent) and its orientation in the
  calibration pose (``pose``).  A JSON file holds it (:meth:`Skeleton.load`).
* **Offsets.**  A sensor is strapped on at some angle to its segment.  Standing in the calibration pose,
  each segment's orientation is known (its ``pose``), so the sensor-to-segment offset is
  :math:`q_{off} = q_{sensor}^{-1} \otimes F \otimes q_{pose}` and from then on :math:`q_{segment} =
  F^{-1} \otimes q_{sensor} \otimes q_{off}` (:func:`calibrate`, :func:`segment_orientations`), where
  :math:`F` is the heading the body faced in the pose: the pose is in the *body frame* (x where the
  body faced, y to its left, z up), so a performer may calibrate facing anywhere.  :math:`F` must be
  right: a heading off by Y does not turn the whole body by Y (which a ``reference`` press would undo)
  but conjugates every segment's orientation by it, up to 2Y of error on a segment tilted far from its
  pose.  Each sensor's heading in the pose carries its own yaw mounting error, so :func:`calibrate`
  takes the circular mean over all the sensors (the errors average down as 1/sqrt(n)), or a heading the
  caller knows (``front``: a ``reference`` press toward the front loudspeaker, say).
* **Forward kinematics** (:func:`forward`): each joint is its parent's joint plus the parent's
  orientation applied to ``at``; each segment's end is its joint plus its own orientation applied to
  ``length``.
* **Pointing with the arm** (:func:`ray_sphere`, :func:`ray_floor`): the ray from one joint through
  another (shoulder through hand) meets the loudspeaker sphere or the floor: a place in the room.

Plain floats (tuples) throughout: one body update is a few dozen small rotations, which numpy would make
slower.  Nothing here imports the engine.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pointat.userfiles import read_text

from . import scalar as sq

__all__ = [
    "BodyCalibration",
    "Segment",
    "Skeleton",
    "forward",
    "calibrate",
    "heading",
    "pointing",
    "ray_floor",
    "ray_sphere",
    "segment_orientations",
]

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]
_IDENTITY: Quat = (1.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Segment:
    """One rigid segment of a :class:`Skeleton` (see the module docstring)."""

    name: str
    parent: str | None
    at: Vec3
    length: Vec3
    sensor: int | None = None
    pose: Quat = _IDENTITY


@dataclass(frozen=True)
class Skeleton:
    """Segments, parents before children; :attr:`root` places the root segment's joint (metres)."""

    segments: tuple[Segment, ...]
    root: Vec3 = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        names: dict[str, int] = {}
        sensors: dict[int, str] = {}
        for k, s in enumerate(self.segments):
            if not s.name or not s.name.replace("_", "").isalnum():
                raise ValueError(f"segment {k + 1}: name {s.name!r}: letters, digits and _ only")
            if s.name in names:
                raise ValueError(f"segment '{s.name}' is named twice")
            if k == 0 and s.parent is not None:
                raise ValueError(f"segment '{s.name}': the first segment is the root (no parent)")
            if k > 0 and s.parent not in names:
                why = "is not a segment before it" if s.parent is not None else "is missing (one root only)"
                raise ValueError(f"segment '{s.name}': parent {s.parent!r} {why}")
            if s.sensor is not None:
                if s.sensor < 1:
                    raise ValueError(f"segment '{s.name}': sensor {s.sensor}: sensors count from 1")
                if s.sensor in sensors:
                    raise ValueError(f"segment '{s.name}': sensor {s.sensor} is on '{sensors[s.sensor]}' too")
                sensors[s.sensor] = s.name
            names[s.name] = k
        if not self.segments:
            raise ValueError("a skeleton needs a segment")
        if self.segments[0].sensor is None:
            raise ValueError(
                f"segment '{self.segments[0].name}': the root needs a sensor (it carries the body)"
            )

    @property
    def parents(self) -> tuple[int | None, ...]:
        index = {s.name: k for k, s in enumerate(self.segments)}
        return tuple(None if s.parent is None else index[s.parent] for s in self.segments)

    @property
    def sensors(self) -> int:
        """How many sensors the body carries: the highest sensor number."""
        return max(s.sensor or 0 for s in self.segments)

    def index(self, name: str) -> int:
        for k, s in enumerate(self.segments):
            if s.name == name:
                return k
        raise KeyError(f"no segment '{name}' (segments: {', '.join(s.name for s in self.segments)})")

    # -- files ------------------------------------------------------------------------------------------
    @classmethod
    def from_json(cls, text: str, where: str = "<skeleton>") -> Skeleton:
        """Read a skeleton file::

            {"root": [0, 0, 1.45],
             "segments": [
               {"name": "upper_arm", "sensor": 1, "length": [0.30, 0, 0]},
               {"name": "forearm", "parent": "upper_arm", "sensor": 2, "length": [0.25, 0, 0]},
               {"name": "hand", "parent": "forearm", "sensor": 3, "length": [0.08, 0, 0]}]}

        ``at`` defaults to the parent's ``length`` (the child starts where the parent ends; the root: at
        ``root``), ``pose`` to the identity (the segment along the body's axes: an arm held straight ahead,
        level, palm down), ``sensor`` to none.  Errors name the file and the segment.

        >>> arm = Skeleton.from_json('{"segments": [{"name": "a", "sensor": 1, "length": [0.3, 0, 0]},'
        ...                          '{"name": "b", "parent": "a", "sensor": 2, "length": [0.25, 0, 0]}]}')
        >>> arm.segments[1].at, arm.sensors
        ((0.3, 0.0, 0.0), 2)
        """
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(f"{where}: not JSON ({exc})") from None
        except RecursionError:
            raise ValueError(f"{where}: JSON nested too deeply: expected a skeleton") from None
        if not isinstance(data, dict) or not isinstance(data.get("segments"), list):
            raise ValueError(f'{where}: expected {{"segments": [...], "root": [x, y, z]}}')
        lengths: dict[str, Vec3] = {}
        segments = []
        for k, item in enumerate(data["segments"]):
            label = f"{where}: segment {k + 1}" + (
                f" ('{item.get('name')}')" if isinstance(item, dict) else ""
            )
            if not isinstance(item, dict):
                raise ValueError(f"{label}: expected an object")
            unknown = set(item) - {"name", "parent", "at", "length", "sensor", "pose"}
            if unknown:
                raise ValueError(
                    f"{label}: unknown key {sorted(unknown)[0]!r} (keys: name parent at length sensor pose)"
                )
            try:
                name = item["name"]
                parent = item.get("parent")
                for key, value in (("name", name), ("parent", parent)):
                    if not isinstance(value, str) and not (key == "parent" and value is None):
                        raise ValueError(f"{key}: expected a segment's name, got {value!r}")
                length = _vector(item.get("length", (0.0, 0.0, 0.0)), 3, "length")
                default_at = lengths.get(parent, (0.0, 0.0, 0.0)) if parent is not None else (0.0, 0.0, 0.0)
                at = _vector(item.get("at", default_at), 3, "at")
                pose = sq.normalize(_vector(item.get("pose", _IDENTITY), 4, "pose"))
                sensor = item.get("sensor")
                if sensor is not None and (isinstance(sensor, bool) or not isinstance(sensor, int)):
                    raise ValueError(f"sensor: expected a whole number from 1, got {sensor!r}")
            except KeyError:
                raise ValueError(f"{label}: no name") from None
            except ValueError as exc:
                raise ValueError(f"{label}: {exc}") from None
            lengths[name] = length
            segments.append(Segment(name, parent, at, length, sensor, pose))
        try:
            root = _vector(data.get("root", (0.0, 0.0, 0.0)), 3, "root")
            return cls(tuple(segments), root)
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None

    @classmethod
    def load(cls, path: str | Path) -> Skeleton:
        text = read_text(path, "skeleton")  # a regular file of 4 MB at most: never a wait on a pipe
        return cls.from_json(text, str(path))


def _vector(value: Any, n: int, what: str) -> tuple[float, ...]:
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise ValueError(f"{what}: expected {n} numbers, got {value!r}")
    try:
        out = tuple(float(v) for v in value)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{what}: expected {n} numbers, got {value!r}") from None
    if not all(math.isfinite(v) for v in out) or any(isinstance(v, bool) for v in value):
        raise ValueError(f"{what}: expected {n} finite numbers, got {value!r}")
    return out


# -- orientations ---------------------------------------------------------------------------------------
def _yaw(q: Quat) -> float:
    """Where ``q`` turns x, seen from above, radians from x toward y (its x axis projected on the
    horizontal; pointing straight up or down, its z axis instead)."""
    fx, fy, fz = sq.rotate(q, 1.0, 0.0, 0.0)
    if math.hypot(fx, fy) < 1e-6:
        fx, fy, _ = sq.rotate(q, 0.0, 0.0, -1.0 if fz > 0 else 1.0)
    return math.atan2(fy, fx)


def heading(q: Quat) -> Quat:
    """The yaw-only part of ``q``: the rotation about the vertical that turns x to where q's x points,
    seen from above (:func:`_yaw`).

    >>> [round(c, 6) for c in heading(sq.axis_angle_quat(0.0, 0.0, 1.0, math.radians(30)))]
    [0.965926, 0.0, 0.0, 0.258819]
    """
    return sq.axis_angle_quat(0.0, 0.0, 1.0, _yaw(q))


@dataclass(frozen=True)
class BodyCalibration:
    """What :func:`calibrate` takes from the calibration pose: the body's heading then, and each segment's
    sensor-to-segment offset (the identity for a segment without a sensor)."""

    front: Quat
    offsets: tuple[Quat, ...]


def calibrate(skeleton: Skeleton, sensor_q: Sequence[Quat], front: Quat | None = None) -> BodyCalibration:
    """The calibration pose: ``sensor_q[i]``, sensor i+1's orientation (earth frame) while every segment
    holds its ``pose``.  ``front``: the body's heading then (a yaw-only quaternion), when known; else the
    circular mean of every sensor's heading with its segment's pose taken out.

    >>> arm = Skeleton((Segment("a", None, (0, 0, 0), (0.3, 0, 0), 1),))
    >>> turned = sq.axis_angle_quat(0.0, 0.0, 1.0, math.radians(40.0))
    >>> cal = calibrate(arm, [turned])
    >>> [round(c, 9) for c in segment_orientations(arm, [turned], cal)[0]]
    [1.0, 0.0, 0.0, 0.0]
    """
    if front is None:
        yaws = [
            _yaw(sq.multiply(sensor_q[s.sensor - 1], sq.conjugate(s.pose)))
            for s in skeleton.segments
            if s.sensor
        ]
        mean = math.atan2(sum(math.sin(y) for y in yaws), sum(math.cos(y) for y in yaws))
        front = sq.axis_angle_quat(0.0, 0.0, 1.0, mean)
    out = []
    for s in skeleton.segments:
        if s.sensor is None:
            out.append(_IDENTITY)
            continue
        # the segment in the body frame is F^-1 q_s off = pose at the calibration pose
        q_body = sq.multiply(sq.conjugate(front), sensor_q[s.sensor - 1])
        out.append(sq.normalize(sq.multiply(sq.conjugate(q_body), s.pose)))
    return BodyCalibration(front, tuple(out))


def segment_orientations(
    skeleton: Skeleton, sensor_q: Sequence[Quat], calibration: BodyCalibration
) -> list[Quat]:
    """Each segment's orientation in the body frame: its sensor's, the heading of the calibration pose
    taken out, turned by the segment's offset; a segment without a sensor moves with its parent."""
    inv_front = sq.conjugate(calibration.front)
    out: list[Quat] = []
    for s, parent, off in zip(skeleton.segments, skeleton.parents, calibration.offsets, strict=True):
        if s.sensor is None:
            out.append(out[parent] if parent is not None else _IDENTITY)  # (the root has a sensor)
        else:
            out.append(sq.multiply(sq.multiply(inv_front, sensor_q[s.sensor - 1]), off))
    return out


def forward(skeleton: Skeleton, q: Sequence[Quat], root: Vec3 | None = None) -> tuple[list[Vec3], list[Vec3]]:
    """Joint positions (each segment's proximal joint) and end positions (its far end), metres, in the
    body frame, from the segments' orientations ``q`` (Bachmann's p_trans down the chain).

    >>> arm = Skeleton((Segment("a", None, (0, 0, 0), (0.3, 0, 0), 1), Segment("b", "a", (0.3, 0, 0), (0.25, 0, 0), 2)))
    >>> up = sq.axis_angle_quat(0.0, 1.0, 0.0, -math.pi / 2)  # the upper arm raised straight up
    >>> joints, ends = forward(arm, [up, (1.0, 0.0, 0.0, 0.0)])
    >>> [round(c, 9) for c in joints[1]], [round(c, 9) for c in ends[1]]
    ([0.0, 0.0, 0.3], [0.25, 0.0, 0.3])
    """
    base = skeleton.root if root is None else root
    joints: list[Vec3] = []
    ends: list[Vec3] = []
    for s, parent, qs in zip(skeleton.segments, skeleton.parents, q, strict=True):
        if parent is None:
            j = (base[0] + s.at[0], base[1] + s.at[1], base[2] + s.at[2])
        else:
            a = sq.rotate(q[parent], *s.at)
            pj = joints[parent]
            j = (pj[0] + a[0], pj[1] + a[1], pj[2] + a[2])
        d = sq.rotate(qs, *s.length)
        joints.append(j)
        ends.append((j[0] + d[0], j[1] + d[1], j[2] + d[2]))
    return joints, ends


# -- pointing with the arm ------------------------------------------------------------------------------
def ray_sphere(origin: Vec3, through: Vec3, centre: Vec3, radius: float) -> Vec3 | None:
    """Where the ray from ``origin`` through ``through`` leaves the sphere (the loudspeaker ring, the
    dome); None when it misses it (an origin outside, pointing away) or the two points coincide.

    >>> ray_sphere((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 0.0), 3.0)
    (3.0, 0.0, 0.0)
    """
    d = (through[0] - origin[0], through[1] - origin[1], through[2] - origin[2])
    n = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    if n < 1e-9:
        return None
    d = (d[0] / n, d[1] / n, d[2] / n)
    o = (origin[0] - centre[0], origin[1] - centre[1], origin[2] - centre[2])
    b = o[0] * d[0] + o[1] * d[1] + o[2] * d[2]
    c = o[0] * o[0] + o[1] * o[1] + o[2] * o[2] - radius * radius
    disc = b * b - c
    if disc < 0.0:
        return None
    t = -b + math.sqrt(disc)  # the far crossing: from inside, the one ahead
    if t < 0.0:
        return None
    return (origin[0] + t * d[0], origin[1] + t * d[1], origin[2] + t * d[2])


def ray_floor(origin: Vec3, through: Vec3, height: float = 0.0) -> Vec3 | None:
    """Where the ray from ``origin`` through ``through`` meets the horizontal plane z = ``height``; None
    when it points level or up (it never does).

    >>> ray_floor((0.0, 0.0, 1.5), (0.5, 0.0, 1.0))
    (1.5, 0.0, 0.0)
    """
    dz = through[2] - origin[2]
    if dz > -1e-9:
        return None
    t = (height - origin[2]) / dz
    if t < 0.0:
        return None
    return (
        origin[0] + t * (through[0] - origin[0]),
        origin[1] + t * (through[1] - origin[1]),
        height,
    )


def pointing(point: Vec3, centre: Vec3 = (0.0, 0.0, 0.0)) -> tuple[float, float, float]:
    """Azimuth and elevation (degrees, ADM-OSC: 0 front, + left, + up) and distance (metres) of a point
    seen from ``centre`` (the listening position).

    >>> [round(v, 6) for v in pointing((1.0, 1.0, 0.0))]
    [45.0, 0.0, 1.414214]
    """
    x, y, z = point[0] - centre[0], point[1] - centre[1], point[2] - centre[2]
    flat = math.hypot(x, y)
    return math.degrees(math.atan2(y, x)), math.degrees(math.atan2(z, flat)), math.sqrt(flat * flat + z * z)
