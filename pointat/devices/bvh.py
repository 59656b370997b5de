r"""A BVH (Biovision Hierarchy) writer: body-worn IMU orientations as a motion-capture take.

pointat's filters give each body segment's orientation in the earth frame; animation and analysis tools
(Blender, MotionBuilder, most mocap toolkits) read skeletons as BVH.  This module writes one: a
hierarchy of :class:`BvhJoint` and, per frame, the root's position and each joint's rotation relative to
its parent (:func:`local_rotations` turns earth-frame orientations into those).  Nothing here imports the
engine; it needs numpy and :mod:`pointat.maths` only.

Conventions
-----------
* **Axes.**  pointat's earth frame is NWU (x north / front, y west / left, z up); BVH's world is Y up.
  Vectors map as ``X = y_nwu`` (left), ``Y = z_nwu`` (up), ``Z = x_nwu`` (front): a cyclic permutation,
  so a proper rotation (determinant +1) and the BVH frame is right-handed (``X × Y = Z``, left × up =
  front), with the figure facing +Z and its left on +X, as in most BVH files.  A rotation maps the same
  way, :math:`R_{bvh} = P R_{nwu} P^T`, i.e. the quaternion ``(w, x, y, z)`` becomes ``(w, y, z, x)``.
* **Body frames.**  Joint offsets (:attr:`BvhJoint.offset`, :attr:`BvhJoint.end`) are given on the
  body's own NWU-style axes (x front, y left, z up) with the figure standing at rest facing north, so
  that every rotation is the identity in the rest pose.
* **Units.**  Metres in, centimetres (default) or metres out (``units``); rotations in degrees.
* **Channels.**  The root has ``Xposition Yposition Zposition Zrotation Xrotation Yrotation``, every
  other joint ``Zrotation Xrotation Yrotation`` (:data:`ROTATION_CHANNELS`, the most common order, that
  of Biovision's own files).  The angles ``(z, x, y)`` compose as
  :math:`R = R_Z(z) R_X(x) R_Y(y)` (intrinsic Z, then X', then Y''), computed by :func:`euler_zxy`
  directly from the quaternion, exactly and without NaN at gimbal lock (``x = ±90°``).
* **Digits.**  Angles are written with 9 decimals (≤ 5e-10° of rounding), positions and offsets with 10
  (≤ 5e-11 of the unit); no exponent notation, which some readers refuse.  ``Frame Time`` is ``1 /
  rate_hz`` with the shortest digits that read back to the same double.  A take of an hour at 100 Hz
  with 15 joints is about 260 MB of text.

Examples
--------
>>> import io
>>> from pointat.maths.quaternion import quat_from_axis_angle
>>> arm = [BvhJoint("shoulder", None, (0.0, 0.0, 0.0)),
...        BvhJoint("hand", 0, (0.3, 0.0, 0.0), end=(0.1, 0.0, 0.0))]   # hand 30 cm in front
>>> turn_left = quat_from_axis_angle([0.0, 0.0, 1.0], np.radians(90.0))  # yaw: about up
>>> out = io.StringIO()
>>> with BvhWriter(out, arm, rate_hz=100.0) as take:
...     take.frame((0.0, 0.0, 1.5), [turn_left, (1.0, 0.0, 0.0, 0.0)])
>>> print(out.getvalue().replace("\t", "  "), end="")
HIERARCHY
ROOT shoulder
{
  OFFSET 0.0000000000 0.0000000000 0.0000000000
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT hand
  {
    OFFSET 0.0000000000 0.0000000000 30.0000000000
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0.0000000000 0.0000000000 10.0000000000
    }
  }
}
MOTION
Frames: 1
Frame Time: 0.01
0.0000000000 150.0000000000 0.0000000000 0.000000000 0.000000000 90.000000000 0.000000000 0.000000000 0.000000000
"""

from __future__ import annotations

import math
import os
import re
import shutil
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal, TextIO

import numpy as np
from numpy.typing import ArrayLike

from pointat.maths.quaternion import GIMBAL_EPS, quat_normalize
from pointat.maths.scalar import Quat, conjugate, multiply

__all__ = [
    "ANGLE_DECIMALS",
    "FRAME_COUNT_WIDTH",
    "NORM_TOLERANCE",
    "POSITION_CHANNELS",
    "POSITION_DECIMALS",
    "ROTATION_CHANNELS",
    "BvhJoint",
    "BvhWriter",
    "euler_zxy",
    "local_rotations",
]

#: The rotation channels of every joint, in the order their angles are written and composed.
ROTATION_CHANNELS = ("Zrotation", "Xrotation", "Yrotation")
#: The root's position channels, written before its rotation channels.
POSITION_CHANNELS = ("Xposition", "Yposition", "Zposition")
#: How far a quaternion's norm may stray from 1 and still be taken (and normalised): a filter's drift
#: is ~1e-12, a float32 round trip ~1e-7; anything beyond this is a bug upstream, refused.
NORM_TOLERANCE = 1e-3
#: Decimals of the angles (degrees): 5e-10° of rounding, far below the 1e-6° a reader needs.
ANGLE_DECIMALS = 9
#: Decimals of positions and offsets (in the chosen unit).
POSITION_DECIMALS = 10
#: Width of the ``Frames:`` field reserved in a file written in place (patched by ``close()``).
FRAME_COUNT_WIDTH = 10

_NAME = re.compile(r"[A-Za-z0-9_]+")
_SCALE = {"cm": 100.0, "m": 1.0}
_NWU_TO_BVH = [1, 2, 0]  # X = y_nwu, Y = z_nwu, Z = x_nwu
_QUAT_NWU_TO_BVH = [0, 2, 3, 1]  # (w, x, y, z) -> (w, y, z, x)


def _vector(v: Sequence[float], what: str) -> tuple[float, float, float]:
    try:
        x, y, z = (float(c) for c in v)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be three numbers (x, y, z), got {v!r}") from None
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        raise ValueError(f"{what} must be finite, got {(x, y, z)}")
    return (x, y, z)


def _unit(q: Sequence[float], what: str) -> Quat:
    """``q`` normalised, after checking it is a finite quaternion within :data:`NORM_TOLERANCE` of unit."""
    try:
        w, x, y, z = (float(c) for c in q)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be a quaternion (w, x, y, z), got {q!r}") from None
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if not math.isfinite(n):
        raise ValueError(f"{what} must be finite, got {(w, x, y, z)}")
    if abs(n - 1.0) > NORM_TOLERANCE:
        raise ValueError(f"{what} must be a unit quaternion, got norm {n:.6g}: {(w, x, y, z)}")
    return (w / n, x / n, y / n, z / n)


@dataclass(frozen=True)
class BvhJoint:
    """One joint of a BVH skeleton: a name, its parent, and where it sits on the parent at rest.

    Attributes
    ----------
    name : str
        ASCII letters, digits and underscores only: BVH readers split lines on whitespace, and some
        choke on anything else.  Unique within a skeleton (checked by :class:`BvhWriter`).
    parent : int or None
        Index of the parent joint in the skeleton's list; ``None`` for the root (exactly one, first).
    offset : (float, float, float)
        Where this joint sits in its parent's frame at rest, metres, on the body's NWU-style axes (x
        front, y left, z up).  The root's must be ``(0, 0, 0)``: its place is the position channels.
    end : (float, float, float) or None
        For a leaf joint, the ``End Site`` offset (the segment's far end, e.g. the fingertips), metres.
        A leaf without one gets an End Site at its own origin, which strict readers require.

    >>> BvhJoint("left hand", 0, (0.1, 0.0, 0.0))
    Traceback (most recent call last):
    ...
    ValueError: BVH joint name 'left hand': only ASCII letters, digits and underscores
    """

    name: str
    parent: int | None
    offset: tuple[float, float, float]
    end: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not _NAME.fullmatch(self.name):
            raise ValueError(f"BVH joint name {self.name!r}: only ASCII letters, digits and underscores")
        object.__setattr__(self, "offset", _vector(self.offset, f"the offset of joint {self.name!r}"))
        if self.end is not None:
            object.__setattr__(self, "end", _vector(self.end, f"the end site of joint {self.name!r}"))


def euler_zxy(q: ArrayLike) -> np.ndarray:
    r"""BVH angles ``(z, x, y)`` in degrees of rotations already on BVH axes: :math:`R = R_Z R_X R_Y`.

    With :math:`A, B, C` the half angles of ``z, x, y``, the quaternion
    :math:`q = q_Z(z) \otimes q_X(x) \otimes q_Y(y)` satisfies

    .. math::
        w + x_q = (\cos B + \sin B)\cos(A + C), \qquad z_q + y_q = (\cos B + \sin B)\sin(A + C)

        w - x_q = (\cos B - \sin B)\cos(A - C), \qquad z_q - y_q = (\cos B - \sin B)\sin(A - C)

    so :math:`A \pm C` and :math:`B + \pi/4 = \mathrm{atan2}(\cos B + \sin B, \cos B - \sin B)` come from
    well-conditioned ``atan2`` calls: no ``asin`` losing digits near ±90°, no NaN.  At gimbal lock
    (``x = ±90°``, up to :data:`~pointat.maths.quaternion.GIMBAL_EPS`) only ``z ± y`` is defined: ``y``
    is set to 0 and the whole turn goes into ``z``.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Quaternions ``(w, x, y, z)`` on BVH axes (normalised here).

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        ``(z, x, y)`` degrees; ``z, y`` in ``[-180, 180)``, ``x`` in ``[-90, 90]``.

    >>> s = np.sqrt(0.5)
    >>> euler_zxy([s, 0.0, s, 0.0]).round(9).tolist()            # 90 deg about Y (up)
    [0.0, 0.0, 90.0]
    >>> euler_zxy([0.5, 0.5, 0.5, 0.5]).round(9).tolist()        # X at +90: gimbal lock, y = 0
    [90.0, 90.0, 0.0]
    """
    q = quat_normalize(q)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    plus = np.hypot(z + y, w + x)  # cos B + sin B (>= 0), zero at x = -90 deg
    minus = np.hypot(z - y, w - x)  # cos B - sin B (>= 0), zero at x = +90 deg
    rx = 2.0 * np.arctan2(plus, minus) - 0.5 * np.pi
    s = np.arctan2(z + y, w + x)  # A + C
    d = np.arctan2(z - y, w - x)  # A - C
    lock_up = minus < GIMBAL_EPS
    lock_down = plus < GIMBAL_EPS
    rz = np.where(lock_up, 2.0 * s, np.where(lock_down, 2.0 * d, s + d))
    ry = np.where(lock_up | lock_down, 0.0, s - d)
    return np.stack([_wrap180(np.degrees(rz)), np.degrees(rx), _wrap180(np.degrees(ry))], axis=-1)


def _wrap180(a: np.ndarray) -> np.ndarray:
    """Degrees into ``[-180, 180)``, exactly: ``np.mod`` may round up to the modulus itself."""
    a = np.mod(a + 180.0, 360.0) - 180.0
    return np.where(a >= 180.0, a - 360.0, a)


def local_rotations(earth_q: Sequence[Sequence[float]], parents: Sequence[int | None]) -> list[Quat]:
    r"""Each segment's orientation relative to its parent: :math:`q_{local} = q_{parent}^{-1} \otimes q`.

    pointat's filters give every segment's orientation in the earth frame (segment -> NWU); BVH wants
    each joint's rotation in its parent's frame.  The root's stays relative to the earth frame.

    Parameters
    ----------
    earth_q : sequence of quaternions ``(w, x, y, z)``
        Segment -> earth orientations, one per joint (normalised here; a norm further than
        :data:`NORM_TOLERANCE` from 1, or a non-finite value, is refused).
    parents : sequence of int or None
        The parent index of each joint (``BvhJoint.parent``); ``None`` for the root.

    Returns
    -------
    list of tuple
        Unit quaternions, one per joint, each mapping the segment's frame to its parent's (the
        root's: to the earth frame).

    >>> s = math.sqrt(0.5)
    >>> local_rotations([(s, 0.0, 0.0, s), (s, 0.0, 0.0, s)], [None, 0])[1]   # both turned alike
    (1.0, 0.0, 0.0, 0.0)
    """
    if len(earth_q) != len(parents):
        raise ValueError(f"{len(earth_q)} orientations for {len(parents)} parents")
    unit = [_unit(q, f"orientation {i}") for i, q in enumerate(earth_q)]
    out: list[Quat] = []
    for i, (q, p) in enumerate(zip(unit, parents, strict=True)):
        if p is None:
            out.append(q)
            continue
        if isinstance(p, bool) or not isinstance(p, (int, np.integer)) or not 0 <= p < len(unit) or p == i:
            raise ValueError(f"parent of joint {i} must be None or another joint's index, got {p!r}")
        out.append(multiply(conjugate(unit[p]), q))
    return out


class BvhWriter:
    """Write a BVH take frame by frame, in bounded memory.

    Parameters
    ----------
    file : str, os.PathLike or text stream
        A path is created (overwritten) and written in place: the header reserves a fixed-width
        ``Frames:`` field (:data:`FRAME_COUNT_WIDTH`) that :meth:`close` patches; after a crash the file
        still parses, saying ``Frames: 0`` above the frames that reached the disk.  A stream (which may not seek back: a pipe, a
        gzip file) gets the whole take at :meth:`close`: the frames wait in an anonymous temporary
        file on disk meanwhile.  The writer closes a file it opened, and only flushes a stream it was
        given.
    joints : sequence of BvhJoint
        The skeleton: the root first, every parent before its children.  The file lists the joints
        depth first (children in list order); :meth:`frame` takes them in *list* order regardless.
    rate_hz : float
        Frame rate; ``Frame Time`` is its inverse.
    units : "cm" or "m", keyword-only
        Unit of offsets and positions in the file (most BVH tools expect centimetres).

    Memory: one frame's line at a time plus the stream buffers, whatever the take's length (O(number of
    joints)); an hour at 100 Hz with 15 joints (~260 MB of text) never sits in memory.  Closing is also
    O(1) in memory: the in-place header patch writes ten characters, the stream copy goes in 1 MiB
    chunks.

    Also a context manager: leaving the ``with`` block closes the take (with the frames written so far,
    even on an exception).
    """

    def __init__(
        self,
        file: str | os.PathLike | TextIO,
        joints: Sequence[BvhJoint],
        rate_hz: float,
        *,
        units: Literal["cm", "m"] = "cm",
    ) -> None:
        if units not in _SCALE:
            raise ValueError(f"units must be 'cm' or 'm', got {units!r}")
        rate = float(rate_hz)
        if not (math.isfinite(rate) and rate > 0.0):
            raise ValueError(f"rate_hz must be a positive finite number, got {rate_hz!r}")
        self._joints = tuple(joints)
        self._order = _depth_first(self._joints)
        self._order_index = np.array(self._order, dtype=np.intp)
        self._scale = _SCALE[units]
        self.units = units
        self.rate_hz = rate
        self.frames = 0
        self._closed = False
        n = len(self._joints)
        pos = f"{{:.{POSITION_DECIMALS}f}}"
        ang = f"{{:.{ANGLE_DECIMALS}f}}"
        self._line = " ".join([pos] * 3 + [ang] * (3 * n)) + "\n"
        self._hierarchy = _hierarchy(self._joints, self._scale)
        self._frame_time = np.format_float_positional(1.0 / rate, unique=True, trim="-")
        self._owned = isinstance(file, (str, os.PathLike))
        if self._owned:
            self._out: TextIO = open(file, "w", encoding="ascii", newline="\n")
            try:
                self._out.write(self._hierarchy + "MOTION\nFrames: ")
                self._count_at = self._out.tell()
                self._out.write(f"{0:<{FRAME_COUNT_WIDTH}d}\nFrame Time: {self._frame_time}\n")
            except BaseException:
                self._out.close()
                raise
            self._body: TextIO = self._out
        else:
            self._out = file  # type: ignore[assignment]
            self._body = tempfile.TemporaryFile("w+", encoding="ascii", newline="\n")

    @property
    def joints(self) -> tuple[BvhJoint, ...]:
        """The skeleton, in the order :meth:`frame` takes the rotations."""
        return self._joints

    @property
    def file_order(self) -> tuple[int, ...]:
        """Indices of the joints in the order the file lists them (depth first)."""
        return self._order

    def frame(self, root_position: Sequence[float], rotations: Sequence[Sequence[float]]) -> None:
        """Append one frame.

        Parameters
        ----------
        root_position : (float, float, float)
            The root's position, metres, NWU earth frame.
        rotations : sequence of quaternions ``(w, x, y, z)``
            Each joint's orientation relative to its parent (the root's: relative to the earth frame),
            in the order of ``joints``: :func:`local_rotations` of the segments' earth orientations.
            Normalised here; a norm further than :data:`NORM_TOLERANCE` from 1 is refused.

        Raises
        ------
        ValueError
            After :meth:`close`, or for a wrong number of rotations, a non-finite value or a non-unit
            quaternion; nothing is written then.
        """
        if self._closed:
            raise ValueError("frame() on a closed BvhWriter")
        n = len(self._joints)
        try:
            q = np.asarray(rotations, dtype=float)
            pos = np.asarray(root_position, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(
                f"rotations must be {n} quaternions (w, x, y, z), root_position 3 numbers"
            ) from None
        if q.shape != (n, 4):
            raise ValueError(
                f"rotations must be {n} quaternions (w, x, y, z), one per joint; got shape {q.shape}"
            )
        if pos.shape != (3,) or not np.isfinite(pos).all():
            raise ValueError(f"root_position must be 3 finite numbers (metres, NWU), got {root_position!r}")
        norm = np.sqrt(np.einsum("ij,ij->i", q, q))
        bad = ~(np.abs(norm - 1.0) <= NORM_TOLERANCE)  # NaN and inf land here too
        if bad.any():
            i = int(np.argmax(bad))
            what = "a non-finite value" if not np.isfinite(q[i]).all() else f"norm {norm[i]:.6g}"
            raise ValueError(
                f"rotation of joint {self._joints[i].name!r} must be a finite unit quaternion, got {what}: {q[i].tolist()}"
            )
        order = self._order_index
        angles = euler_zxy(q[order][:, _QUAT_NWU_TO_BVH] / norm[order, None])
        if self.frames >= 10**FRAME_COUNT_WIDTH - 1:
            raise ValueError(f"a BVH take here holds at most {10**FRAME_COUNT_WIDTH - 1} frames")
        self._body.write(
            self._line.format(*(pos[_NWU_TO_BVH] * self._scale).tolist(), *angles.ravel().tolist())
        )
        self.frames += 1

    def close(self) -> None:
        """Finish the take: write the frame count (and, for a stream, the whole file).  Idempotent."""
        if self._closed:
            return
        self._closed = True
        if self._owned:
            try:
                self._out.seek(self._count_at)
                self._out.write(f"{self.frames:<{FRAME_COUNT_WIDTH}d}")
            finally:
                self._out.close()
            return
        try:
            self._out.write(
                f"{self._hierarchy}MOTION\nFrames: {self.frames}\nFrame Time: {self._frame_time}\n"
            )
            self._body.seek(0)
            shutil.copyfileobj(self._body, self._out, 1 << 20)
            self._out.flush()
        finally:
            self._body.close()

    def __enter__(self) -> BvhWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _depth_first(joints: tuple[BvhJoint, ...]) -> tuple[int, ...]:
    """Check the skeleton's structure; the joints' indices in depth-first (file) order."""
    if not joints:
        raise ValueError("a BVH skeleton needs at least one joint")
    names: set[str] = set()
    children: list[list[int]] = [[] for _ in joints]
    for i, j in enumerate(joints):
        if not isinstance(j, BvhJoint):
            raise ValueError(f"joint {i} must be a BvhJoint, got {j!r}")
        if j.name in names:
            raise ValueError(f"joint name {j.name!r} appears twice")
        names.add(j.name)
        if i == 0:
            if j.parent is not None:
                raise ValueError(f"the first joint, {j.name!r}, must be the root (parent None)")
            if j.offset != (0.0, 0.0, 0.0):
                raise ValueError(
                    f"the root {j.name!r} must have offset (0, 0, 0): its place is root_position "
                    "(readers disagree on whether a root OFFSET adds to the position channels)"
                )
        elif (
            isinstance(j.parent, bool) or not isinstance(j.parent, (int, np.integer)) or not 0 <= j.parent < i
        ):
            raise ValueError(
                f"joint {j.name!r} (index {i}) needs the index of an earlier joint as parent, got {j.parent!r}"
                " (one root, first; every parent before its children)"
            )
        else:
            children[j.parent].append(i)
    for i, j in enumerate(joints):
        if j.end is not None and children[i]:
            raise ValueError(f"joint {j.name!r} has children: only a leaf joint has an end site")
    order: list[int] = []
    stack = [0]
    while stack:
        i = stack.pop()
        order.append(i)
        stack.extend(reversed(children[i]))
    return tuple(order)


def _hierarchy(joints: tuple[BvhJoint, ...], scale: float) -> str:
    """The ``HIERARCHY`` section, braces on lines of their own (some readers, ``bvh`` among them, need it)."""
    children: list[list[int]] = [[] for _ in joints]
    for i, j in enumerate(joints[1:], start=1):
        children[j.parent].append(i)  # type: ignore[index]

    def offset(v: tuple[float, float, float]) -> str:
        return " ".join(f"{v[k] * scale:.{POSITION_DECIMALS}f}" for k in _NWU_TO_BVH)

    lines = ["HIERARCHY"]

    def emit(i: int, depth: int) -> None:
        tab = "\t" * depth
        j = joints[i]
        lines.append(f"{tab}{'ROOT' if i == 0 else 'JOINT'} {j.name}")
        lines.append(f"{tab}{{")
        lines.append(f"{tab}\tOFFSET {offset(j.offset)}")
        channels = (POSITION_CHANNELS if i == 0 else ()) + ROTATION_CHANNELS
        lines.append(f"{tab}\tCHANNELS {len(channels)} {' '.join(channels)}")
        for c in children[i]:
            emit(c, depth + 1)
        if not children[i]:
            lines.append(f"{tab}\tEnd Site")
            lines.append(f"{tab}\t{{")
            lines.append(f"{tab}\t\tOFFSET {offset(j.end or (0.0, 0.0, 0.0))}")
            lines.append(f"{tab}\t}}")
        lines.append(f"{tab}}}")

    emit(0, 0)
    return "\n".join(lines) + "\n"
