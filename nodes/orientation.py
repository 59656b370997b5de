"""What the orientation nodes share: how they read an orientation, their time steps and their flags.

Orientations travel as one vector: a quaternion ``(w, x, y, z)`` or a 3x3 rotation matrix, mapping sensor
to earth (NWU: x north or the reference direction, y west, z up).  Rates are rad/s, accelerations m/s²,
fields any unit.  The nodes are in :mod:`pointat.nodes.torre` (Torre et al.'s chain),
:mod:`pointat.nodes.tqt` (the McGhee/Bachmann quaternion filter), :mod:`pointat.nodes.directions`
(reference, azimuth and elevation, the roll gesture) and :mod:`pointat.nodes.conversions`.

Filters take their time step from the messages' time stamps (sensor time), falling back to ``1/rate``
for the first sample and for gaps over a second.  A bad sample (zero or NaN vector, a gyro rate of
100 rad/s or more: :data:`~pointat.maths.scalar.MAX_RATE`) leaves a filter's state as it was and is
reported on its ``flags`` outlet; nothing downstream ever sees NaN.
"""

from __future__ import annotations

import math

from pointat.maths import scalar as sq
from pointat.message import Message, as_floats, floats
from pointat.node import Outlet, Param

ORIENTATION = ("vector", "list")


def as_quat(msg: Message) -> sq.Quat:
    """A unit quaternion (floats) from a quaternion or a rotation-matrix message; NaN is an error."""
    values = msg.value
    n = len(values) if msg.kind == "vector" else 0
    if n != 4 and n != 9:  # a list, or the wrong size: converted, or the error that says so
        values = as_floats(msg, 4, 9)
        n = len(values)
    if n == 4:
        w, x, y, z = values
        if abs(w * w + x * x + y * y + z * z - 1.0) <= 1e-15:  # unit already (every node's output): as is
            return values  # (False for NaN and infinity, which go on to the error below)
    if not math.isfinite(sum(values)):  # any NaN or infinity makes the sum one
        raise ValueError("orientation has NaN or infinite values")
    return sq.matrix_quat(values) if n == 9 else sq.normalize(values)


def matrix_message(q: sq.Quat, time: float) -> Message:
    """The 3x3 rotation matrix of ``q`` as a message stamped ``time``."""
    return floats(sq.quat_matrix(q), time)


class SampleClock:
    """Time steps from message time stamps, with ``1/rate`` when there is no usable previous stamp."""

    MAX_GAP = 1.0
    _last_t: float | None = None  # (a class default: a node that never called reset_clock has none)

    def reset_clock(self) -> None:
        self._last_t = None

    def step(self, t: float) -> float:
        last, self._last_t = self._last_t, t
        return time_step(last, t, 1.0 / self.p.rate, self.MAX_GAP)


def time_step(last: float | None, t: float, nominal: float, max_gap: float) -> float:
    """:func:`pointat.maths.scalar.time_step`, ``None`` for no previous stamp."""
    return sq.time_step(math.nan if last is None else last, t, nominal, max_gap)


class Flagged:
    """Report a filter's status on its ``flags`` outlet when it changes (``ok`` when all is well)."""

    FLAGS_OUTLET = 1
    _status = "ok"

    def report(self, status: str) -> None:
        if status != self._status:
            self._status = status
            self.out(self.FLAGS_OUTLET, status)


POLE = Param(
    "pole", "float", 1.0, "within this angle of straight up/down the azimuth holds", unit="deg", minimum=0.0
)


def check_pole(pole: float) -> None:
    """A ``pole`` parameter's range (at load, and for every live change)."""
    if not pole < 90.0:
        raise ValueError(f"pole must be >= 0 and < 90 deg, got {pole}")


RATE = Param("rate", "float", 100.0, "nominal sample rate, for the first step and gaps", unit="Hz", above=0.0)
FLAGS = Outlet("flags", "symbol", "status when it changes: ok, or what was wrong (bad_gyro, bad_accmag...)")
