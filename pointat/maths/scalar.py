r"""The per-sample quaternion operations on plain Python floats.

numpy pays a few microseconds per call on arrays of three or four numbers; these functions do the same
work on tuples of floats in a fraction of that, which is what a node running at 1 kHz needs.  They follow
the conventions of :mod:`pointat.maths` (scalar-first quaternions, sensor -> earth, NWU) and are tested
against :mod:`pointat.maths.quaternion` and :mod:`pointat.maths.fusion`, which remain the reference.

>>> q = axis_angle_quat(0.0, 0.0, 1.0, math.pi / 2)
>>> [round(c, 12) for c in rotate(q, 1.0, 0.0, 0.0)]
[0.0, 1.0, 0.0]
"""

from __future__ import annotations

import math
from collections.abc import Sequence

__all__ = [
    "MAX_RATE",
    "MAX_RATE_SQUARED",
    "Quat",
    "accmag_matrix",
    "accmag_quat",
    "accmag_triad",
    "axis_angle",
    "azimuth_elevation",
    "euler",
    "axis_angle_quat",
    "fold_front",
    "conjugate",
    "matrix_quat",
    "multiply",
    "normalize",
    "quat_matrix",
    "roll",
    "rotate",
    "slerp",
    "time_step",
    "ulp",
]

Quat = tuple[float, float, float, float]

#: The fastest angular rate a reading may have, rad/s (5,730 °/s).  No MEMS gyro measures more (the
#: widest ranges are ±4,000 °/s, 70 rad/s) and no hand turns so fast: a reading at or beyond it is a
#: glitch (a corrupt packet, a wrong unit), refused like NaN rather than spun into the orientation.
MAX_RATE = 100.0
#: What the per-sample checks compare a reading's squared norm with (``x*x + y*y + z*z < MAX_RATE_SQUARED``
#: is one comparison, and False for NaN).
MAX_RATE_SQUARED = MAX_RATE * MAX_RATE


def multiply(p: Sequence[float], q: Sequence[float]) -> Quat:
    r"""Hamilton product :math:`p \otimes q`."""
    pw, px, py, pz = p
    qw, qx, qy, qz = q
    return (
        pw * qw - px * qx - py * qy - pz * qz,
        pw * qx + px * qw + py * qz - pz * qy,
        pw * qy - px * qz + py * qw + pz * qx,
        pw * qz + px * qy - py * qx + pz * qw,
    )


def conjugate(q: Sequence[float]) -> Quat:
    r""":math:`q^*`."""
    return (q[0], -q[1], -q[2], -q[3])


def normalize(q: Sequence[float]) -> Quat:
    """``q / |q|``; raises ``ValueError`` for a zero or non-finite quaternion."""
    w, x, y, z = q
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if not (n > 0.0 and math.isfinite(n)):
        raise ValueError(f"cannot normalise the quaternion {tuple(q)}")
    return (w / n, x / n, y / n, z / n)


def rotate(q: Sequence[float], vx: float, vy: float, vz: float) -> tuple[float, float, float]:
    r""":math:`q \otimes v \otimes q^*` for a unit ``q`` (sensor -> earth)."""
    w, x, y, z = q
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (vx + w * tx + y * tz - z * ty, vy + w * ty + z * tx - x * tz, vz + w * tz + x * ty - y * tx)


def axis_angle_quat(ax: float, ay: float, az: float, angle: float) -> Quat:
    """Rotation of ``angle`` radians about the unit axis ``(ax, ay, az)``."""
    s = math.sin(0.5 * angle)
    return (math.cos(0.5 * angle), ax * s, ay * s, az * s)


def quat_matrix(q: Sequence[float]) -> tuple[float, ...]:
    """The 3x3 rotation matrix of a unit quaternion, row major (9 floats)."""
    w, x, y, z = q
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz, wx, wy, wz = x * y, x * z, y * z, w * x, w * y, w * z
    return (
        1.0 - 2.0 * (yy + zz), 2.0 * (xy - wz), 2.0 * (xz + wy),
        2.0 * (xy + wz), 1.0 - 2.0 * (xx + zz), 2.0 * (yz - wx),
        2.0 * (xz - wy), 2.0 * (yz + wx), 1.0 - 2.0 * (xx + yy),
    )  # fmt: skip


def polar_step(m: Sequence[float]) -> tuple[float, ...]:
    r"""One Newton-Schulz step of a row-major 3x3 matrix towards its polar factor (nearest rotation),
    :math:`M \leftarrow \tfrac{1}{2} M (3I - M^T M)`: quadratically convergent near a rotation, so the
    drift of a few hundred integration steps (~1e-15) is gone to rounding.  9 floats in, 9 out."""
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = m
    # A = 3I - M^T M (symmetric), halved
    a00 = 1.5 - 0.5 * (m00 * m00 + m10 * m10 + m20 * m20)
    a11 = 1.5 - 0.5 * (m01 * m01 + m11 * m11 + m21 * m21)
    a22 = 1.5 - 0.5 * (m02 * m02 + m12 * m12 + m22 * m22)
    a01 = -0.5 * (m00 * m01 + m10 * m11 + m20 * m21)
    a02 = -0.5 * (m00 * m02 + m10 * m12 + m20 * m22)
    a12 = -0.5 * (m01 * m02 + m11 * m12 + m21 * m22)
    return (
        m00 * a00 + m01 * a01 + m02 * a02, m00 * a01 + m01 * a11 + m02 * a12, m00 * a02 + m01 * a12 + m02 * a22,
        m10 * a00 + m11 * a01 + m12 * a02, m10 * a01 + m11 * a11 + m12 * a12, m10 * a02 + m11 * a12 + m12 * a22,
        m20 * a00 + m21 * a01 + m22 * a02, m20 * a01 + m21 * a11 + m22 * a12, m20 * a02 + m21 * a12 + m22 * a22,
    )  # fmt: skip


def matrix_quat(m: Sequence[float]) -> Quat:
    """Shepperd's method on a row-major rotation matrix (9 floats): robust for every rotation, w >= 0."""
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = m
    tr = m00 + m11 + m22
    if tr >= m00 and tr >= m11 and tr >= m22:
        s = 2.0 * math.sqrt(max(1.0 + tr, 0.0))
        q = (0.25 * s, (m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s)
    elif m00 >= m11 and m00 >= m22:
        s = 2.0 * math.sqrt(max(1.0 + m00 - m11 - m22, 0.0))
        q = ((m21 - m12) / s, 0.25 * s, (m01 + m10) / s, (m02 + m20) / s)
    elif m11 >= m22:
        s = 2.0 * math.sqrt(max(1.0 + m11 - m00 - m22, 0.0))
        q = ((m02 - m20) / s, (m01 + m10) / s, 0.25 * s, (m12 + m21) / s)
    else:
        s = 2.0 * math.sqrt(max(1.0 + m22 - m00 - m11, 0.0))
        q = ((m10 - m01) / s, (m02 + m20) / s, (m12 + m21) / s, 0.25 * s)
    w, x, y, z = q  # normalised here, with the sign (normalize's work without its call)
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if not (n > 0.0 and math.isfinite(n)):
        raise ValueError(f"cannot normalise the quaternion {q}")
    if w < 0.0:
        n = -n
    return (w / n, x / n, y / n, z / n)


def slerp(p: Sequence[float], q: Sequence[float], t: float) -> Quat:
    """Spherical interpolation from unit ``p`` (t=0) to unit ``q`` (t=1) along the shorter arc."""
    pw, px, py, pz = p
    qw, qx, qy, qz = q
    d = pw * qw + px * qx + py * qy + pz * qz
    if d < 0.0:
        qw, qx, qy, qz, d = -qw, -qx, -qy, -qz, -d
    if d > 0.9995:  # nearly equal: linear interpolation is exact to rounding
        return normalize((pw + t * (qw - pw), px + t * (qx - px), py + t * (qy - py), pz + t * (qz - pz)))
    theta = math.acos(d)
    s = math.sin(theta)
    a, b = math.sin((1.0 - t) * theta) / s, math.sin(t * theta) / s
    return (a * pw + b * qw, a * px + b * qx, a * py + b * qy, a * pz + b * qz)


def accmag_matrix(acc: Sequence[float], mag: Sequence[float]) -> tuple[float, ...] | None:
    """TRIAD sensor -> NWU matrix (row major) from gravity and the field, as
    :func:`pointat.maths.fusion.accmag_matrix`; ``None`` when undefined (zero, NaN, parallel)."""
    r = accmag_triad(acc, mag)
    return None if r is None else r[0]


def accmag_triad(
    acc: Sequence[float], mag: Sequence[float]
) -> tuple[tuple[float, ...], float, float, float] | None:
    """:func:`accmag_matrix` with what checking the sample takes, worked out on the way: (matrix,
    ``|acc|``, ``|mag|``, sine of the field's dip below the horizon, in [-1, 1]); ``None`` when undefined."""
    ax, ay, az = acc
    mx, my, mz = mag
    na = math.sqrt(ax * ax + ay * ay + az * az)
    nm = math.sqrt(mx * mx + my * my + mz * mz)
    if not (na > 0.0 and nm > 0.0 and math.isfinite(na) and math.isfinite(nm)):
        return None
    ux, uy, uz = ax / na, ay / na, az / na
    mx, my, mz = mx / nm, my / nm, mz / nm
    wx, wy, wz = uy * mz - uz * my, uz * mx - ux * mz, ux * my - uy * mx  # west = up x field
    nw = math.sqrt(wx * wx + wy * wy + wz * wz)
    if nw < 1e-6:
        return None
    wx, wy, wz = wx / nw, wy / nw, wz / nw
    nx, ny, nz = wy * uz - wz * uy, wz * ux - wx * uz, wx * uy - wy * ux  # north = west x up
    sin_dip = -(ux * mx + uy * my + uz * mz)  # of two unit vectors: within [-1, 1] but for rounding
    sin_dip = 1.0 if sin_dip > 1.0 else -1.0 if sin_dip < -1.0 else sin_dip
    return (nx, ny, nz, wx, wy, wz, ux, uy, uz), na, nm, sin_dip


def accmag_quat(acc: Sequence[float], mag: Sequence[float]) -> Quat | None:
    """:func:`accmag_matrix` as a quaternion (w >= 0), or ``None``."""
    m = accmag_matrix(acc, mag)
    return None if m is None else matrix_quat(m)


def euler(q: Sequence[float]) -> tuple[float, float, float]:
    """(yaw, pitch, roll) in radians, intrinsic Z-Y'-X'', as :func:`pointat.maths.quaternion.quat_to_euler`.

    At pitch +-90 degrees all of the heading goes into yaw and roll is 0.
    """
    w, x, y, z = q
    s = 2.0 * (w * y - z * x)
    if s >= 1.0 - 1e-12 or s <= -1.0 + 1e-12:
        sign = 1.0 if s > 0 else -1.0
        return _wrap_pi(-2.0 * sign * math.atan2(x, w)), sign * math.pi / 2, 0.0
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    return yaw, math.asin(s), roll


def roll(q: Sequence[float]) -> float:
    """The roll of :func:`euler` alone (radians, about the hand's own x axis; 0 at pitch +-90 degrees)."""
    w, x, y, z = q
    s = 2.0 * (w * y - z * x)
    if s >= 1.0 - 1e-12 or s <= -1.0 + 1e-12:
        return 0.0
    return math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))


def _wrap_pi(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def azimuth_elevation(
    q: Sequence[float],
    axis: Sequence[float] = (1.0, 0.0, 0.0),
    previous: float | None = None,
    pole_deg: float = 0.1,
) -> tuple[float, float]:
    """Azimuth and elevation (degrees, + left, + up) of the sensor ``axis`` rotated by ``q``, as
    :func:`pointat.maths.quaternion.azimuth_elevation` of :func:`~pointat.maths.quaternion.pointing_direction`:
    within ``pole_deg`` of straight up or down the azimuth holds ``previous`` (or 0)."""
    dx, dy, dz = rotate(q, *axis)
    horizontal = math.hypot(dx, dy)
    norm = math.sqrt(horizontal * horizontal + dz * dz)
    elevation = math.degrees(math.atan2(dz, horizontal))
    if horizontal <= norm * math.sin(math.radians(pole_deg)):
        az = 0.0 if previous is None else previous
    else:
        az = math.degrees(math.atan2(dy, dx))
    az = (az + 180.0) % 360.0 - 180.0
    return (az if az < 180.0 else az - 360.0), elevation


def fold_front(deg: float) -> float:
    """An azimuth (degrees) as a stereo pan hears it: one behind the listener mirrored to the front half.

    The result is in [-90, 90]: ``a`` wrapped to [-180, 180), then 180 - a beyond +90 and -180 - a
    beyond -90.  Behind-left stays left (135 -> 45) and the mapping is continuous all the way round, so a
    performer turning through 180 degrees pans smoothly back to the centre instead of jumping from hard
    left to hard right.  NaN stays NaN.

    >>> [fold_front(a) for a in (0.0, 90.0, 135.0, 180.0, -180.0, -100.0, 450.0)]
    [0.0, 90.0, 45.0, 0.0, 0.0, -80.0, 90.0]
    """
    a = (deg + 180.0) % 360.0 - 180.0
    if a > 90.0:
        return 180.0 - a
    if a < -90.0:
        return -180.0 - a
    return a


def axis_angle(q: Sequence[float]) -> tuple[float, float, float, float]:
    """(angle in [0, pi], axis x, y, z) of a unit quaternion; axis (1, 0, 0) for no rotation."""
    w, x, y, z = q
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    s = math.sqrt(x * x + y * y + z * z)
    if s < 1e-15:
        return 0.0, 1.0, 0.0, 0.0
    return 2.0 * math.atan2(s, w), x / s, y / s, z / s


def ulp(x: float) -> float:
    """:func:`math.ulp`, in arithmetic numba compiles (it has no ``math.ulp``)."""
    x = abs(x)
    if x == 0.0:
        return 5e-324
    if not x < math.inf:  # infinity, NaN
        return x
    u = math.ldexp(1.0, math.frexp(x)[1] - 53)
    return u if u > 0.0 else 5e-324  # a subnormal's


def time_step(last: float, t: float, nominal: float, max_gap: float) -> float:
    """The step from stamp ``last`` to ``t``: ``nominal`` when there is no usable previous stamp (NaN for
    none, not before ``t``, or more than ``max_gap`` before it) and when the two differ by rounding only."""
    if last != last:
        return nominal
    dt = t - last
    off = abs(dt - nominal)
    if off <= 1e-6 * nominal or off <= 4.0 * ulp(t):  # (the ulp for stamps many days large)
        # sensor time from a packet counter (t0 + n / rate) differs from 1/rate by the stamps' rounding
        # only: the nominal step keeps a filter's per-step coefficients cached, not recomputed
        return nominal
    return dt if 0.0 < dt <= max_gap else nominal
