"""Orientation conversions: matrix and quaternion, axis-angle, Euler angles, and earth frames.

The math is in :mod:`pointat.maths`; these nodes only move messages (conventions:
:mod:`pointat.nodes.orientation`).
"""

from __future__ import annotations

import math

from pointat.maths import scalar as sq
from pointat.maths.quaternion import (
    enu_to_nwu,
    ned_to_nwu,
    nwu_to_enu,
    nwu_to_ned,
    quat_identity,
)
from pointat.message import Message, as_floats, floats, vector
from pointat.node import Inlet, Node, Outlet, Param
from pointat.nodes.orientation import ORIENTATION, as_quat, matrix_message
from pointat.registry import register


@register("matrix2quat")
class Matrix2Quat(Node):
    """Rotation matrix -> quaternion (w, x, y, z), w >= 0; robust for every rotation (Shepperd)."""

    pure = True

    inlets = (Inlet("matrix", ("vector", "list"), "3x3 rotation matrix (9 numbers, row major)"),)
    outlets = (Outlet("quat", "vector", "quaternion (w, x, y, z)"),)

    def on_matrix(self, msg: Message) -> None:
        m = as_floats(msg, 9)  # raises for anything but a matrix: a quaternion here is a wiring mistake
        if not math.isfinite(sum(m)):
            raise ValueError("orientation has NaN or infinite values")
        self.out(0, floats(sq.matrix_quat(m), msg.time))


@register("quat2matrix")
class Quat2Matrix(Node):
    """Quaternion (w, x, y, z) -> 3x3 rotation matrix."""

    pure = True

    inlets = (Inlet("quat", ("vector", "list"), "quaternion (w, x, y, z)"),)
    outlets = (Outlet("matrix", "vector", "3x3 rotation matrix"),)

    def on_quat(self, msg: Message) -> None:
        self.out(0, matrix_message(as_quat(msg), msg.time))


@register("quat2axis")
class Quat2Axis(Node):
    """Quaternion -> angle, x, y, z (Torre's "angle, x, y, z format"): rotation angle and unit axis."""

    pure = True

    inlets = (Inlet("quat", ORIENTATION, "quaternion or matrix"),)
    outlets = (Outlet("axis", "vector", "(angle, x, y, z), angle in degrees unless degrees=false"),)
    params = (Param("degrees", "bool", True, "angle in degrees (false: radians)"),)

    def on_quat(self, msg: Message) -> None:
        angle, x, y, z = sq.axis_angle(as_quat(msg))
        self.out(0, vector([math.degrees(angle) if self.p.degrees else angle, x, y, z], msg.time))


@register("quat2euler")
class Quat2Euler(Node):
    """Quaternion -> yaw, pitch, roll: the intrinsic Z-Y'-X'' (aerospace) sequence, degrees.

    Yaw about earth z (up, positive left), pitch about the new y, roll about the hand's own x axis.
    At pitch +-90 deg all heading goes into yaw and roll is 0.
    """

    pure = True

    inlets = (Inlet("quat", ORIENTATION, "quaternion or matrix"),)
    outlets = (
        Outlet("yaw", "float", "degrees"),
        Outlet("pitch", "float", "degrees"),
        Outlet("roll", "float", "degrees"),
    )

    def on_quat(self, msg: Message) -> None:
        self.emit(*(math.degrees(a) for a in sq.euler(as_quat(msg))))


_FRAMES = {
    ("nwu", "enu"): nwu_to_enu,
    ("enu", "nwu"): enu_to_nwu,
    ("nwu", "ned"): nwu_to_ned,
    ("ned", "nwu"): ned_to_nwu,
}


@register("reframe")
class Reframe(Node):
    """Re-express an orientation in another earth frame (NWU inside pointat; ENU, NED at the edges).

    Also ``positive=true`` makes w >= 0 (one sign for each rotation).
    """

    pure = True

    inlets = (Inlet("quat", ORIENTATION, "quaternion or matrix, sensor -> earth"),)
    outlets = (Outlet("quat", "vector", "quaternion in the target frame"),)
    params = (
        Param("source", "symbol", "nwu", "the frame it comes in", choices=("nwu", "enu", "ned")),
        Param("target", "symbol", "enu", "the frame it goes out in", choices=("nwu", "enu", "ned")),
        Param("positive", "bool", True, "make w >= 0"),
    )

    def setup(self) -> None:
        pair = (self.p.source, self.p.target)
        if pair[0] == pair[1]:
            convert = None
        elif pair in _FRAMES:
            convert = _FRAMES[pair]
        else:  # through NWU
            a, b = _FRAMES[(pair[0], "nwu")], _FRAMES[("nwu", pair[1])]

            def convert(q):
                return b(a(q))

        # Each change of frame multiplies by a fixed rotation on the left: the conversion of the identity
        # is that rotation, and one product per sample on floats does the conversion.
        self._frame = None if convert is None else tuple(convert(quat_identity()).tolist())

    def on_quat(self, msg: Message) -> None:
        q = as_quat(msg)
        if self._frame is not None:
            q = sq.multiply(self._frame, q)
        if self.p.positive and q[0] < 0.0:
            q = (-q[0], -q[1], -q[2], -q[3])
        self.out(0, floats(q, msg.time))
