r"""Unit quaternions, rotation matrices, Euler angles and azimuth / elevation.

Conventions (see :mod:`pointat.maths`): quaternions are scalar first ``(w, x, y, z)``, unit, and map the
sensor frame to the earth frame, :math:`v_e = q \otimes (0, v_s) \otimes q^*`; the earth frame is NWU
(x north, y west, z up); radians inside, degrees only in azimuth / elevation and where ``degrees=True``.

Every function accepts one quaternion of shape ``(4,)`` or a batch ``(..., 4)`` (vectors ``(..., 3)``,
matrices ``(..., 3, 3)``) and broadcasts over the leading axes.  Results are numpy arrays (0-d results
come back as numpy scalars).

Sources: McGhee et al. 2000 (quaternion product and rotation, Eqs. 1-5), Bachmann et al. 2001 (Eq. 7,
:math:`v_e = q \otimes v_s \otimes q^{-1}`), Torre et al. 2008 §3.2 (``matrix2quat``, ``quat2axis``,
``azi_ele``).  Matrix to quaternion follows Shepperd, J. Guidance Control 1(3), 1978.

>>> import numpy as np
>>> q = quat_from_axis_angle([0.0, 0.0, 1.0], np.pi / 2)      # yaw 90 deg: the hand turns left
>>> np.round(quat_rotate(q, [1.0, 0.0, 0.0]), 12).tolist()    # x (north) goes to y (west)
[0.0, 1.0, 0.0]
>>> [round(float(a), 9) for a in azimuth_elevation(pointing_direction(q))]
[90.0, 0.0]
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "quat_identity",
    "quat_multiply",
    "quat_conjugate",
    "quat_normalize",
    "quat_positive",
    "quat_rotate",
    "quat_inverse_rotate",
    "quat_from_axis_angle",
    "quat_to_axis_angle",
    "rotvec_to_quat",
    "quat_to_rotvec",
    "quat_to_matrix",
    "matrix_to_quat",
    "quat_to_euler",
    "euler_to_quat",
    "quat_slerp",
    "quat_angle",
    "nwu_to_enu",
    "enu_to_nwu",
    "ned_to_nwu",
    "nwu_to_ned",
    "pointing_direction",
    "azimuth_elevation",
    "wrap_degrees",
    "unwrap_degrees",
    "GIMBAL_EPS",
    "POLE_DEG",
]

#: Below this value of ``cos(pitch)`` (up to a factor ~sqrt 2) :func:`quat_to_euler` treats the pose as
#: gimbal locked: roll is set to 0 and the whole heading goes into yaw.
GIMBAL_EPS = 1e-12

#: Default angular radius (degrees) of the caps around straight up / down where azimuth is undefined.
POLE_DEG = 0.1

_SQRT_HALF = np.sqrt(0.5)


def _as_quat(q: ArrayLike) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    if q.shape[-1:] != (4,):
        raise ValueError(f"a quaternion needs a last axis of length 4 (w, x, y, z), got shape {q.shape}")
    return q


def _as_vec(v: ArrayLike, name: str = "vector") -> np.ndarray:
    v = np.asarray(v, dtype=float)
    if v.shape[-1:] != (3,):
        raise ValueError(f"{name} needs a last axis of length 3, got shape {v.shape}")
    return v


def quat_identity() -> np.ndarray:
    """The identity rotation ``(1, 0, 0, 0)``.

    Returns
    -------
    numpy.ndarray, shape (4,)

    >>> quat_identity().tolist()
    [1.0, 0.0, 0.0, 0.0]
    """
    return np.array([1.0, 0.0, 0.0, 0.0])


def quat_multiply(p: ArrayLike, q: ArrayLike) -> np.ndarray:
    r"""Hamilton product :math:`p \otimes q` (McGhee 2000, Eq. 2; Bachmann 2001, Eq. 7).

    .. math::
        p \otimes q = (p_w q_w - \mathbf{p}\cdot\mathbf{q},\;
                       p_w \mathbf{q} + q_w \mathbf{p} + \mathbf{p}\times\mathbf{q})

    The rotation ``p ⊗ q`` applies ``q`` first, then ``p``.

    Parameters
    ----------
    p, q : array_like, shape (..., 4)
        Quaternions ``(w, x, y, z)``; leading axes broadcast.

    Returns
    -------
    numpy.ndarray, shape (..., 4)

    >>> quat_multiply([0, 1, 0, 0], [0, 0, 1, 0]).tolist()   # i j = k
    [0.0, 0.0, 0.0, 1.0]
    """
    p = _as_quat(p)
    q = _as_quat(q)
    pw, px, py, pz = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    qw, qx, qy, qz = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack(
        [
            pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw,
        ],
        axis=-1,
    )


def quat_conjugate(q: ArrayLike) -> np.ndarray:
    r"""Conjugate :math:`q^* = (w, -x, -y, -z)`, the inverse of a unit quaternion.

    Parameters
    ----------
    q : array_like, shape (..., 4)

    Returns
    -------
    numpy.ndarray, shape (..., 4)

    >>> quat_conjugate([1.0, 2.0, 3.0, 4.0]).tolist()
    [1.0, -2.0, -3.0, -4.0]
    """
    q = _as_quat(q)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def quat_normalize(q: ArrayLike) -> np.ndarray:
    r"""Scale to unit norm, :math:`q / \lVert q \rVert`.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Non-zero quaternions.

    Returns
    -------
    numpy.ndarray, shape (..., 4)

    Raises
    ------
    ValueError
        If a quaternion has zero (or non-finite) norm.

    >>> quat_normalize([2.0, 0.0, 0.0, 0.0]).tolist()
    [1.0, 0.0, 0.0, 0.0]
    """
    q = _as_quat(q)
    n = np.sqrt(np.sum(q * q, axis=-1, keepdims=True))
    if not (np.isfinite(n).all() and (n > 0.0).all()):
        raise ValueError("cannot normalise a zero or non-finite quaternion")
    return q / n


def quat_positive(q: ArrayLike) -> np.ndarray:
    """The sign representative with ``w >= 0`` (``q`` and ``-q`` are the same rotation).

    Parameters
    ----------
    q : array_like, shape (..., 4)

    Returns
    -------
    numpy.ndarray, shape (..., 4)

    >>> quat_positive([-1.0, 0.0, 0.0, 0.0]).tolist()
    [1.0, 0.0, 0.0, 0.0]
    """
    q = _as_quat(q)
    return np.where(q[..., :1] < 0.0, -q, q)


def quat_rotate(q: ArrayLike, v: ArrayLike) -> np.ndarray:
    r"""Rotate a sensor-frame vector into the earth frame (McGhee 2000, Eq. 5; Bachmann 2001, Eq. 7).

    .. math::
        v_e = q \otimes (0, v_s) \otimes q^* = v_s + 2w(\mathbf{u}\times v_s)
              + 2\,\mathbf{u}\times(\mathbf{u}\times v_s), \qquad q = (w, \mathbf{u})

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit quaternions, sensor -> earth.
    v : array_like, shape (..., 3)
        Vectors in sensor coordinates (any unit; the unit is kept).

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        The same vectors in earth (NWU) coordinates.

    >>> q = quat_from_axis_angle([1.0, 0.0, 0.0], np.pi / 2)
    >>> np.round(quat_rotate(q, [0.0, 1.0, 0.0]), 12).tolist()
    [0.0, 0.0, 1.0]
    """
    q = _as_quat(q)
    v = _as_vec(v)
    w = q[..., :1]
    u = q[..., 1:]
    t = 2.0 * _cross(u, v)
    return v + w * t + _cross(u, t)


def quat_inverse_rotate(q: ArrayLike, v: ArrayLike) -> np.ndarray:
    r"""Rotate an earth-frame vector into the sensor frame: :math:`v_s = q^* \otimes (0, v_e) \otimes q`.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit quaternions, sensor -> earth.
    v : array_like, shape (..., 3)
        Vectors in earth (NWU) coordinates.

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        The same vectors in sensor coordinates.

    >>> q = quat_from_axis_angle([0.0, 0.0, 1.0], np.pi / 2)
    >>> np.round(quat_inverse_rotate(q, [0.0, 1.0, 0.0]), 12).tolist()   # west seen by a hand facing west
    [1.0, 0.0, 0.0]
    """
    return quat_rotate(quat_conjugate(q), v)


def quat_from_axis_angle(axis: ArrayLike, angle: ArrayLike) -> np.ndarray:
    r"""Quaternion of a right-handed rotation by ``angle`` about ``axis`` (McGhee 2000, Eq. 3).

    .. math:: q = (\cos\tfrac{\theta}{2},\; \hat{n}\sin\tfrac{\theta}{2})

    Parameters
    ----------
    axis : array_like, shape (..., 3)
        Rotation axis (normalised here; must be non-zero).
    angle : array_like, shape (...)
        Rotation angle in radians.

    Returns
    -------
    numpy.ndarray, shape (..., 4)

    >>> np.round(quat_from_axis_angle([0.0, 0.0, 2.0], np.pi), 12).tolist()
    [0.0, 0.0, 0.0, 1.0]
    """
    axis = _as_vec(axis, "axis")
    n = np.linalg.norm(axis, axis=-1, keepdims=True)
    if not np.all(np.isfinite(n) & (n > 0.0)):
        raise ValueError("rotation axis must be a non-zero finite vector")
    half = 0.5 * np.asarray(angle, dtype=float)[..., None]
    vec = np.sin(half) * axis / n
    return np.concatenate([np.broadcast_to(np.cos(half), vec.shape[:-1] + (1,)), vec], axis=-1)


def quat_to_axis_angle(q: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    r"""Angle and unit axis of a rotation (Torre 2008 §4, ``quat2axis``; McGhee 2000, Eq. 3).

    .. math:: \theta = 2\,\mathrm{atan2}(\lVert\mathbf{u}\rVert, |w|), \qquad
              \hat{n} = \mathrm{sign}(w)\,\mathbf{u} / \lVert\mathbf{u}\rVert

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Quaternions (normalised here).

    Returns
    -------
    angle : numpy.ndarray, shape (...)
        Radians in ``[0, pi]``.
    axis : numpy.ndarray, shape (..., 3)
        Unit axis; ``(1, 0, 0)`` when the angle is (numerically) zero.

    >>> angle, axis = quat_to_axis_angle(quat_from_axis_angle([0.0, -1.0, 0.0], 0.5))
    >>> round(float(angle), 12), np.round(axis, 12).tolist()
    (0.5, [0.0, -1.0, 0.0])
    """
    q = quat_positive(quat_normalize(q))
    u = q[..., 1:]
    s = np.linalg.norm(u, axis=-1)
    angle = 2.0 * np.arctan2(s, q[..., 0])
    tiny = s < 1e-300
    axis = np.where(tiny[..., None], np.array([1.0, 0.0, 0.0]), u / np.where(tiny, 1.0, s)[..., None])
    return angle, axis


def rotvec_to_quat(rv: ArrayLike) -> np.ndarray:
    r"""Exponential map: rotation vector (axis times angle, radians) to quaternion.

    .. math:: q = \exp(\tfrac{1}{2}\mathbf{r}) = (\cos\tfrac{\lVert r\rVert}{2},\;
              \tfrac{1}{2}\,\mathrm{sinc}(\tfrac{\lVert r\rVert}{2})\,\mathbf{r})

    Exact and smooth at ``r = 0`` (no division).

    Parameters
    ----------
    rv : array_like, shape (..., 3)
        Rotation vectors, radians.

    Returns
    -------
    numpy.ndarray, shape (..., 4)

    >>> rotvec_to_quat([0.0, 0.0, 0.0]).tolist()
    [1.0, 0.0, 0.0, 0.0]
    """
    rv = _as_vec(rv, "rotation vector")
    theta = np.linalg.norm(rv, axis=-1, keepdims=True)
    # sin(theta/2)/theta = 0.5 * sinc(theta / (2 pi)) with numpy's normalised sinc
    return np.concatenate([np.cos(0.5 * theta), 0.5 * np.sinc(theta / (2.0 * np.pi)) * rv], axis=-1)


def quat_to_rotvec(q: ArrayLike) -> np.ndarray:
    r"""Logarithm map: quaternion to rotation vector (radians), angle in ``[0, pi]``.

    .. math:: \mathbf{r} = \theta\,\hat{n} = \frac{2}{\mathrm{sinc}(\theta/2)}\,\mathrm{sign}(w)\,\mathbf{u},
              \qquad \theta = 2\,\mathrm{atan2}(\lVert\mathbf{u}\rVert, |w|)

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Quaternions (normalised here).

    Returns
    -------
    numpy.ndarray, shape (..., 3)

    >>> np.round(quat_to_rotvec(quat_from_axis_angle([0.0, 1.0, 0.0], 0.25)), 12).tolist()
    [0.0, 0.25, 0.0]
    """
    q = quat_positive(quat_normalize(q))
    u = q[..., 1:]
    angle = 2.0 * np.arctan2(np.linalg.norm(u, axis=-1, keepdims=True), q[..., :1])
    return 2.0 / np.sinc(angle / (2.0 * np.pi)) * u


def quat_to_matrix(q: ArrayLike) -> np.ndarray:
    r"""Rotation matrix of a quaternion, sensor -> earth: ``R @ v_sensor == v_earth``.

    Torre 2008 §3.2 calls this the *Orientation* matrix (IMU frame expressed in the earth frame).

    .. math::
        R = \begin{pmatrix}
        1-2(y^2+z^2) & 2(xy-wz) & 2(xz+wy) \\
        2(xy+wz) & 1-2(x^2+z^2) & 2(yz-wx) \\
        2(xz-wy) & 2(yz+wx) & 1-2(x^2+y^2)
        \end{pmatrix}

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Quaternions (normalised here).

    Returns
    -------
    numpy.ndarray, shape (..., 3, 3)

    >>> np.round(quat_to_matrix(quat_from_axis_angle([0.0, 0.0, 1.0], np.pi / 2)), 12).tolist()
    [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    """
    q = quat_normalize(q)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    r = np.stack(
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
        axis=-1,
    )
    return r.reshape(r.shape[:-1] + (3, 3))


def matrix_to_quat(R: ArrayLike) -> np.ndarray:
    r"""Quaternion (``w >= 0``) of a rotation matrix, robust for every rotation (Torre 2008, ``matrix2quat``).

    Shepperd's method: of the four equivalent formulas, use the one whose pivot is largest,

    .. math::
        4w^2 = 1 + \mathrm{tr} R, \quad 4x^2 = 1 + 2R_{00} - \mathrm{tr} R, \quad
        4y^2 = 1 + 2R_{11} - \mathrm{tr} R, \quad 4z^2 = 1 + 2R_{22} - \mathrm{tr} R,

    so the divisor is never below 1/2 and 180° rotations (trace -1) are exact.  A slightly non-orthogonal
    input gives the quaternion of a nearby rotation (the result is normalised).

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrices, sensor -> earth (``R @ v_sensor = v_earth``).

    Returns
    -------
    numpy.ndarray, shape (..., 4)

    >>> matrix_to_quat(np.diag([1.0, -1.0, -1.0])).tolist()   # 180 deg about x
    [0.0, 1.0, 0.0, 0.0]
    """
    R = np.asarray(R, dtype=float)
    if R.shape[-2:] != (3, 3):
        raise ValueError(f"a rotation matrix needs shape (..., 3, 3), got {R.shape}")
    r00, r01, r02 = R[..., 0, 0], R[..., 0, 1], R[..., 0, 2]
    r10, r11, r12 = R[..., 1, 0], R[..., 1, 1], R[..., 1, 2]
    r20, r21, r22 = R[..., 2, 0], R[..., 2, 1], R[..., 2, 2]
    tr = r00 + r11 + r22
    # Each candidate is 4*pivot times the quaternion; the pivot component is the large one.
    cand = np.stack(
        [
            np.stack([1.0 + tr, r21 - r12, r02 - r20, r10 - r01], axis=-1),
            np.stack([r21 - r12, 1.0 + 2.0 * r00 - tr, r01 + r10, r02 + r20], axis=-1),
            np.stack([r02 - r20, r01 + r10, 1.0 + 2.0 * r11 - tr, r12 + r21], axis=-1),
            np.stack([r10 - r01, r02 + r20, r12 + r21, 1.0 + 2.0 * r22 - tr], axis=-1),
        ],
        axis=-2,
    )
    choice = np.argmax(np.stack([tr, r00, r11, r22], axis=-1), axis=-1)
    q = np.take_along_axis(cand, choice[..., None, None], axis=-2)[..., 0, :]
    return quat_positive(quat_normalize(q))


def quat_to_euler(q: ArrayLike, *, degrees: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Yaw, pitch, roll of the intrinsic Z-Y'-X'' (aerospace) sequence.

    ``q = q_z(yaw) ⊗ q_y(pitch) ⊗ q_x(roll)``, i.e. ``R = R_z(yaw) R_y(pitch) R_x(roll)``.

    In NWU with the glove frame, yaw turns the hand about up (positive = toward the left / west), pitch
    about the hand's left axis y' and roll about the pointing axis x''.  All right-handed, so **positive
    pitch points the hand down** (the elevation of the pointing axis is ``-pitch``).  Torre 2008 §2
    names the same three angles.

    The angles are read from half-angle sums of the quaternion, which stay well conditioned up to the
    singularity (with :math:`a, b, c` = yaw/2, pitch/2, roll/2):

    .. math::
        w \pm y = (\cos b \pm \sin b)\cos(a \mp c), \qquad z \mp x = (\cos b \pm \sin b)\sin(a \mp c)

        a + c = \mathrm{atan2}(z + x, w - y), \quad a - c = \mathrm{atan2}(z - x, w + y), \quad
        b + \tfrac{\pi}{4} = \mathrm{atan2}(\lVert(z-x, w+y)\rVert, \lVert(z+x, w-y)\rVert)

    At gimbal lock (pitch = ±90°, :data:`GIMBAL_EPS`) only yaw ∓ roll is defined: roll is set to 0 and
    the whole heading goes into yaw.  No NaN anywhere.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Quaternions, sensor -> earth (normalised here).
    degrees : bool, keyword-only
        Return degrees instead of radians.

    Returns
    -------
    yaw : numpy.ndarray, shape (...)
        In ``[-pi, pi)`` (or degrees ``[-180, 180)``).
    pitch : numpy.ndarray, shape (...)
        In ``[-pi/2, pi/2]``.
    roll : numpy.ndarray, shape (...)
        In ``[-pi, pi)``.

    >>> [round(float(a), 9) for a in quat_to_euler(euler_to_quat(30, -20, 10, degrees=True), degrees=True)]
    [30.0, -20.0, 10.0]
    >>> [round(float(a), 9) for a in quat_to_euler(euler_to_quat(30, 90, 10, degrees=True), degrees=True)]
    [20.0, 90.0, 0.0]
    """
    q = quat_normalize(q)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    minus = np.hypot(z + x, w - y)  # cos b - sin b  (>= 0), zero at pitch = +90 deg
    plus = np.hypot(z - x, w + y)  # cos b + sin b  (>= 0), zero at pitch = -90 deg
    pitch = 2.0 * np.arctan2(plus, minus) - 0.5 * np.pi
    s = np.arctan2(z + x, w - y)  # a + c
    d = np.arctan2(z - x, w + y)  # a - c
    lock_up = minus < GIMBAL_EPS
    lock_down = plus < GIMBAL_EPS
    yaw = np.where(lock_up, 2.0 * d, np.where(lock_down, 2.0 * s, s + d))
    roll = np.where(lock_up | lock_down, 0.0, s - d)
    yaw = _wrap_pi(yaw)
    roll = _wrap_pi(roll)
    if degrees:
        return np.degrees(yaw), np.degrees(pitch), np.degrees(roll)
    return yaw, pitch, roll


def euler_to_quat(yaw: ArrayLike, pitch: ArrayLike, roll: ArrayLike, *, degrees: bool = False) -> np.ndarray:
    r"""Quaternion of intrinsic Z-Y'-X'' angles: :math:`q = q_z(\psi) \otimes q_y(\theta) \otimes q_x(\phi)`.

    .. math::
        q = \begin{pmatrix}
        c_\psi c_\theta c_\phi + s_\psi s_\theta s_\phi \\
        c_\psi c_\theta s_\phi - s_\psi s_\theta c_\phi \\
        c_\psi s_\theta c_\phi + s_\psi c_\theta s_\phi \\
        s_\psi c_\theta c_\phi - c_\psi s_\theta s_\phi
        \end{pmatrix}, \qquad c_\psi = \cos\tfrac{\psi}{2},\ s_\psi = \sin\tfrac{\psi}{2},\ \ldots

    Parameters
    ----------
    yaw, pitch, roll : array_like, shape (...)
        Angles in radians (degrees if ``degrees=True``); broadcast together.
    degrees : bool, keyword-only

    Returns
    -------
    numpy.ndarray, shape (..., 4)

    >>> np.round(euler_to_quat(90.0, 0.0, 0.0, degrees=True), 12).tolist()
    [0.707106781187, 0.0, 0.0, 0.707106781187]
    """
    yaw, pitch, roll = (np.asarray(a, dtype=float) for a in (yaw, pitch, roll))
    if degrees:
        yaw, pitch, roll = np.radians(yaw), np.radians(pitch), np.radians(roll)
    ca, sa = np.cos(0.5 * yaw), np.sin(0.5 * yaw)
    cb, sb = np.cos(0.5 * pitch), np.sin(0.5 * pitch)
    cc, sc = np.cos(0.5 * roll), np.sin(0.5 * roll)
    return np.stack(
        [
            ca * cb * cc + sa * sb * sc,
            ca * cb * sc - sa * sb * cc,
            ca * sb * cc + sa * cb * sc,
            sa * cb * cc - ca * sb * sc,
        ],
        axis=-1,
    )


def quat_slerp(p: ArrayLike, q: ArrayLike, t: ArrayLike) -> np.ndarray:
    r"""Spherical linear interpolation along the shorter arc.

    .. math:: \mathrm{slerp}(p, q, t) = p \otimes \exp\!\big(t \log(p^* \otimes q)\big)

    with :math:`p^* \otimes q` taken with ``w >= 0`` (shortest path).  Written with the exponential and
    logarithm maps, so it needs no special case for nearly identical inputs.

    Parameters
    ----------
    p, q : array_like, shape (..., 4)
        Unit quaternions; ``t = 0`` gives ``p``, ``t = 1`` gives ``q`` (up to sign).
    t : array_like, shape (...)
        Interpolation fraction (values outside [0, 1] extrapolate).

    Returns
    -------
    numpy.ndarray, shape (..., 4)

    >>> q = quat_slerp(quat_identity(), quat_from_axis_angle([0.0, 0.0, 1.0], 1.0), 0.25)
    >>> round(float(quat_angle(quat_identity(), q)), 12)
    0.25
    """
    p = quat_normalize(p)
    rel = quat_multiply(quat_conjugate(p), quat_normalize(q))
    rv = quat_to_rotvec(rel)  # shortest path: quat_to_rotvec takes w >= 0
    t = np.asarray(t, dtype=float)[..., None]
    return quat_multiply(p, rotvec_to_quat(t * rv))


def quat_angle(p: ArrayLike, q: ArrayLike) -> np.ndarray:
    r"""Angle (radians, ``[0, pi]``) of the rotation taking ``p`` to ``q``; invariant to the sign of either.

    .. math:: \theta = 2\,\mathrm{atan2}(\lVert \mathbf{u} \rVert, |w|),
              \qquad (w, \mathbf{u}) = p^* \otimes q

    Parameters
    ----------
    p, q : array_like, shape (..., 4)
        Quaternions (normalised here).

    Returns
    -------
    numpy.ndarray, shape (...)

    >>> round(float(quat_angle([1, 0, 0, 0], [0, 0, 0, -1])), 12) == round(np.pi, 12)
    True
    """
    rel = quat_multiply(quat_conjugate(quat_normalize(p)), quat_normalize(q))
    return 2.0 * np.arctan2(np.linalg.norm(rel[..., 1:], axis=-1), np.abs(rel[..., 0]))


_Q_NWU_TO_ENU = np.array([_SQRT_HALF, 0.0, 0.0, _SQRT_HALF])  # q_z(+90 deg)
_Q_ENU_TO_NWU = np.array([_SQRT_HALF, 0.0, 0.0, -_SQRT_HALF])  # q_z(-90 deg)
_Q_NED_TO_NWU = np.array([0.0, 1.0, 0.0, 0.0])  # q_x(+180 deg)
_Q_NWU_TO_NED = np.array([0.0, -1.0, 0.0, 0.0])  # q_x(-180 deg), so the round trip returns q itself


def nwu_to_enu(q: ArrayLike) -> np.ndarray:
    r"""Re-express a sensor -> NWU quaternion as sensor -> ENU (x east, y north, z up).

    .. math:: q_{ENU} = q_z(+90^\circ) \otimes q_{NWU}, \qquad
              v_{ENU} = R_z(90^\circ)\, v_{NWU}: \text{north } (1,0,0) \mapsto (0,1,0)

    Parameters
    ----------
    q : array_like, shape (..., 4)

    Returns
    -------
    numpy.ndarray, shape (..., 4)

    >>> np.round(quat_rotate(nwu_to_enu(quat_identity()), [1.0, 0.0, 0.0]), 12).tolist()
    [0.0, 1.0, 0.0]
    """
    return quat_multiply(_Q_NWU_TO_ENU, q)


def enu_to_nwu(q: ArrayLike) -> np.ndarray:
    r"""Inverse of :func:`nwu_to_enu`: :math:`q_{NWU} = q_z(-90^\circ) \otimes q_{ENU}`.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Sensor -> ENU quaternions.

    Returns
    -------
    numpy.ndarray, shape (..., 4)
        Sensor -> NWU quaternions.

    >>> np.round(quat_rotate(enu_to_nwu(quat_identity()), [1.0, 0.0, 0.0]), 12).tolist()   # east is -west
    [0.0, -1.0, 0.0]
    """
    return quat_multiply(_Q_ENU_TO_NWU, q)


def ned_to_nwu(q: ArrayLike) -> np.ndarray:
    r"""Re-express a sensor -> NED quaternion (McGhee / Bachmann's frame) as sensor -> NWU.

    .. math:: q_{NWU} = q_x(180^\circ) \otimes q_{NED}, \qquad (n, e, d) \mapsto (n, -e, -d)

    Parameters
    ----------
    q : array_like, shape (..., 4)

    Returns
    -------
    numpy.ndarray, shape (..., 4)

    >>> np.round(quat_rotate(ned_to_nwu(quat_identity()), [0.0, 0.0, 1.0]), 12).tolist()   # down
    [0.0, 0.0, -1.0]
    """
    return quat_multiply(_Q_NED_TO_NWU, q)


def nwu_to_ned(q: ArrayLike) -> np.ndarray:
    r"""Inverse of :func:`ned_to_nwu`: :math:`q_{NED} = q_x(-180^\circ) \otimes q_{NWU}`.

    Parameters
    ----------
    q : array_like, shape (..., 4)

    Returns
    -------
    numpy.ndarray, shape (..., 4)

    >>> np.round(quat_rotate(nwu_to_ned(quat_identity()), [0.0, 1.0, 0.0]), 12).tolist()   # west
    [0.0, -1.0, 0.0]
    """
    return quat_multiply(_Q_NWU_TO_NED, q)


def pointing_direction(q: ArrayLike, axis: ArrayLike = (1.0, 0.0, 0.0)) -> np.ndarray:
    r"""Earth-frame unit vector of the sensor's pointing axis, :math:`d = q \otimes \hat{a} \otimes q^*`.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Sensor -> earth quaternions (normalised here).
    axis : array_like, shape (3,) or (..., 3)
        Pointing axis in sensor coordinates; default x, along the hand (Torre's u).

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        Unit vectors in NWU.

    >>> np.round(pointing_direction(euler_to_quat(0.0, -90.0, 0.0, degrees=True)), 12).tolist()
    [0.0, 0.0, 1.0]
    """
    axis = _as_vec(axis, "axis")
    n = np.linalg.norm(axis, axis=-1, keepdims=True)
    if not np.all(n > 0.0):
        raise ValueError("pointing axis must be non-zero")
    return quat_rotate(quat_normalize(q), axis / n)


def azimuth_elevation(
    direction: ArrayLike,
    *,
    previous_azimuth: ArrayLike | None = None,
    pole_deg: float = POLE_DEG,
) -> tuple[np.ndarray, np.ndarray]:
    r"""Azimuth and elevation (degrees, ADM-OSC) of an earth-frame direction (Torre 2008 §4 ``azi_ele``).

    .. math::
        \mathrm{az} = \mathrm{atan2}(d_y, d_x), \qquad
        \mathrm{el} = \mathrm{atan2}(d_z, \sqrt{d_x^2 + d_y^2})

    0° azimuth = front = +x (north, or the reference pose), positive = left = +y (west), range
    ``[-180, 180)``; elevation positive up, ``[-90, 90]``.  Within ``pole_deg`` of straight up or down the
    azimuth is undefined: ``previous_azimuth`` is returned (held) if given, else 0.

    Parameters
    ----------
    direction : array_like, shape (..., 3)
        Earth-frame (NWU) direction; need not be unit length.
    previous_azimuth : array_like, shape (...), optional
        Azimuth (degrees) to hold near the poles; wrapped into ``[-180, 180)``.
    pole_deg : float
        Angular radius in degrees of the polar caps where the azimuth is held.

    Returns
    -------
    azimuth : numpy.ndarray, shape (...)
        Degrees in ``[-180, 180)``.
    elevation : numpy.ndarray, shape (...)
        Degrees in ``[-90, 90]``.

    >>> [float(a) for a in azimuth_elevation([-1.0, -1.0, 0.0])]
    [-135.0, 0.0]
    >>> [float(a) for a in azimuth_elevation([0.0, 0.0, 2.0], previous_azimuth=30.0)]
    [30.0, 90.0]
    """
    d = _as_vec(direction, "direction")
    horizontal = np.hypot(d[..., 0], d[..., 1])
    elevation = np.degrees(np.arctan2(d[..., 2], horizontal))
    azimuth = wrap_degrees(np.degrees(np.arctan2(d[..., 1], d[..., 0])))
    norm = np.linalg.norm(d, axis=-1)
    at_pole = horizontal <= norm * np.sin(np.radians(pole_deg))
    held = 0.0 if previous_azimuth is None else wrap_degrees(previous_azimuth)
    azimuth = np.where(at_pole, held, azimuth)
    return azimuth[()], elevation[()]


def wrap_degrees(a: ArrayLike) -> np.ndarray:
    r"""Wrap angles into ``[-180, 180)`` degrees: :math:`((a + 180) \bmod 360) - 180`.

    Parameters
    ----------
    a : array_like, shape (...)
        Degrees.

    Returns
    -------
    numpy.ndarray, shape (...)

    >>> wrap_degrees([180.0, -180.0, 540.0, 179.5, -190.0]).tolist()
    [-180.0, -180.0, -180.0, 179.5, 170.0]
    """
    a = np.asarray(a, dtype=float)
    w = np.mod(a + 180.0, 360.0) - 180.0
    # (a + 180) mod 360 can round up to exactly 360 for a just below -180
    return np.where(w >= 180.0, w - 360.0, w)[()]


def unwrap_degrees(a: ArrayLike, previous: ArrayLike) -> np.ndarray:
    r"""The representative of ``a`` (mod 360) nearest to ``previous``, for wrap-aware smoothing.

    .. math:: a' = p + \mathrm{wrap}(a - p) \in [p - 180, p + 180)

    Parameters
    ----------
    a : array_like, shape (...)
        New angle, degrees.
    previous : array_like, shape (...)
        Previous (unwrapped) angle, degrees.

    Returns
    -------
    numpy.ndarray, shape (...)

    >>> float(unwrap_degrees(-179.0, 179.0))
    181.0
    """
    previous = np.asarray(previous, dtype=float)
    return (previous + wrap_degrees(np.asarray(a, dtype=float) - previous))[()]


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product along the last axis (cheaper than ``np.cross`` for small arrays)."""
    ax, ay, az = a[..., 0], a[..., 1], a[..., 2]
    bx, by, bz = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx], axis=-1)


def _wrap_pi(a: np.ndarray) -> np.ndarray:
    w = np.mod(a + np.pi, 2.0 * np.pi) - np.pi
    return np.where(w >= np.pi, w - 2.0 * np.pi, w)[()]
