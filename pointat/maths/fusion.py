r"""Orientation from gyroscopes, accelerometers and magnetometers (Torre et al. 2008, §3 and §5.2).

Conventions (see :mod:`pointat.maths`): rotation matrices and quaternions map the sensor frame to the
earth frame (NWU: x north, y west, z up), ``R @ v_sensor = v_earth``; angular rates are sensor-frame
rad/s; accelerometers read specific force (``+g`` along up at rest).

Which side the gyro increment multiplies
----------------------------------------
A gyro measures the body rate :math:`\omega` in sensor coordinates.  The sensor -> earth matrix :math:`C`
obeys :math:`\dot C = C\,[\omega\times]`, so over one sample, with :math:`\omega` held constant,

.. math:: C(k+1) = C(k)\,\Delta R(k+1), \qquad \Delta R = \exp([\omega\,\Delta t \times])
   \quad\text{(right multiplication, body-frame increment)}

and for quaternions :math:`q(k+1) = q(k) \otimes \exp(\tfrac{1}{2}\omega\Delta t)`.  Torre 2008 §3.2 writes
*Orientation(k+1) = Rotation(k+1) · Orientation(k)*, a left multiplication.  That is the same update
for the earth -> sensor matrix :math:`C^T` with the transposed increment,
:math:`C^T(k+1) = \Delta R^T\,C^T(k)`; applied literally to a sensor -> earth matrix it would turn the
sensor about *earth* axes, which is only right while the rotation axis stays put.  This module keeps
the sensor -> earth matrix and multiplies on the right.

Corrections to Torre 2008 §3.3 (accelerometer + magnetometer)
------------------------------------------------------------
Torre builds the earth -> sensor matrix column by column: first column = magnetometer / H, third column
= accelerometer / g, middle column = a cross product.  :func:`accmag_matrix` keeps the idea and fixes
three things:

1. the middle column's second row reads :math:`a_{31}a_{13} - a_{11}a_{23}`; the cross product of the
   first and third columns needs :math:`a_{31}a_{13} - a_{11}a_{33}` (index typo);
2. the Earth field dips below the horizon, so the magnetometer is *not* perpendicular to gravity and
   the first column is not orthogonal to the third: the matrix is not a rotation.  North must be the
   horizontal part of the field, obtained by two cross products (TRIAD);
3. x north, y west, z down is left-handed, and an accelerometer at rest reads *up*.  With NWU the
   columns are north, west = up × north and up, a proper rotation (det +1).
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from pointat.maths import scalar as _sq
from pointat.maths.quaternion import (
    matrix_to_quat,
    quat_normalize,
)

__all__ = [
    "torre_increment",
    "exact_increment",
    "orthonormalize",
    "GyroIntegrator",
    "accmag_matrix",
    "accmag_quat",
    "ComplementaryFilter",
    "RollDistance",
    "roll_distance_step",
    "PARALLEL_EPS",
]

#: ``accmag_matrix`` refuses when the angle between gravity and the field is below about this (rad).
PARALLEL_EPS = 1e-6


def _as_rate(rate: ArrayLike) -> np.ndarray:
    rate = np.asarray(rate, dtype=float)
    if rate.shape[-1:] != (3,):
        raise ValueError(f"an angular rate needs a last axis of length 3, got shape {rate.shape}")
    return rate


def torre_increment(rate: ArrayLike, dt: ArrayLike) -> np.ndarray:
    r"""Torre 2008 §3.2 incremental rotation, a product of three elementary rotations.

    .. math::
        \Delta\theta = r_z \Delta t, \quad \Delta\phi = r_y \Delta t, \quad \Delta\alpha = r_x \Delta t

        \mathrm{Rotation}(k+1) = R(w, \Delta\theta)\, R(v, \Delta\phi)\, R(u, \Delta\alpha)
        = R_z(\Delta\theta)\, R_y(\Delta\phi)\, R_x(\Delta\alpha)

    It agrees with :func:`exact_increment` to first order; the error per step is
    :math:`O(\lVert\omega\rVert^2 \Delta t^2)` (the three factors do not commute), so the integrated
    orientation has an error growing like :math:`t\,\Delta t\,\lVert\omega\rVert^2`.  Use it as
    ``C(k+1) = C(k) @ torre_increment(...)`` (see the module notes on the side).

    Parameters
    ----------
    rate : array_like, shape (..., 3)
        Angular rate about the sensor axes (u, v, w) = (x, y, z), rad/s.
    dt : array_like, shape (...)
        Sample interval, s.

    Returns
    -------
    numpy.ndarray, shape (..., 3, 3)

    >>> np.round(torre_increment([0.0, 0.0, np.pi / 2], 1.0), 12).tolist()
    [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    """
    angles = _as_rate(rate) * np.asarray(dt, dtype=float)[..., None]
    ca, cp, ct = np.cos(angles[..., 0]), np.cos(angles[..., 1]), np.cos(angles[..., 2])
    sa, sp, st = np.sin(angles[..., 0]), np.sin(angles[..., 1]), np.sin(angles[..., 2])
    r = np.stack(_torre_entries(ca, sa, cp, sp, ct, st), axis=-1)
    return r.reshape(r.shape[:-1] + (3, 3))


def exact_increment(rate: ArrayLike, dt: ArrayLike) -> np.ndarray:
    r"""Exact incremental rotation for a rate held constant over ``dt`` (exponential map, Rodrigues).

    .. math::
        \Delta R = \exp([\mathbf{v}\times]) = I + \frac{\sin\theta}{\theta}[\mathbf{v}\times]
                   + \frac{1 - \cos\theta}{\theta^2}[\mathbf{v}\times]^2,
        \qquad \mathbf{v} = \omega\,\Delta t,\ \theta = \lVert\mathbf{v}\rVert

    The coefficients are written as ``sinc`` functions, exact and smooth at :math:`\theta = 0`.

    Parameters
    ----------
    rate : array_like, shape (..., 3)
        Angular rate in the sensor frame, rad/s.
    dt : array_like, shape (...)
        Sample interval, s.

    Returns
    -------
    numpy.ndarray, shape (..., 3, 3)

    >>> np.round(exact_increment([np.pi, 0.0, 0.0], 0.5), 12).tolist()
    [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]
    """
    v = _as_rate(rate) * np.asarray(dt, dtype=float)[..., None]
    theta = np.linalg.norm(v, axis=-1)[..., None, None]
    a = np.sinc(theta / np.pi)  # sin(theta) / theta
    b = 0.5 * np.sinc(theta / (2.0 * np.pi)) ** 2  # (1 - cos theta) / theta^2
    zero = np.zeros(v.shape[:-1])
    k = np.stack([zero, -v[..., 2], v[..., 1], v[..., 2], zero, -v[..., 0], -v[..., 1], v[..., 0], zero], -1)
    k = k.reshape(k.shape[:-1] + (3, 3))
    return np.eye(3) + a * k + b * (k @ k)


def orthonormalize(R: ArrayLike) -> np.ndarray:
    r"""Nearest rotation matrix (Frobenius norm) by the SVD polar decomposition.

    .. math:: R = U \Sigma V^T \;\mapsto\; U \,\mathrm{diag}(1, 1, \det(U V^T))\, V^T

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Matrices close to rotations (finite).

    Returns
    -------
    numpy.ndarray, shape (..., 3, 3)
        Proper rotations: :math:`R^T R = I`, :math:`\det R = +1`.

    >>> np.round(orthonormalize(np.diag([2.0, 0.5, 1.0])), 12).tolist()
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    """
    R = np.asarray(R, dtype=float)
    if R.shape[-2:] != (3, 3):
        raise ValueError(f"a rotation matrix needs shape (..., 3, 3), got {R.shape}")
    if not np.all(np.isfinite(R)):
        raise ValueError("cannot orthonormalise a matrix with NaN or infinite entries")
    u, _, vt = np.linalg.svd(R)
    d = np.sign(np.linalg.det(u @ vt))
    d = np.where(d == 0.0, 1.0, d)
    u = u.copy()
    u[..., :, 2] *= d[..., None]
    return u @ vt


def _exact_flat(wx: float, wy: float, wz: float, dt: float) -> tuple[float, ...]:
    """Scalar fast path of :func:`exact_increment`, row-major 9-tuple."""
    vx, vy, vz = wx * dt, wy * dt, wz * dt
    theta = math.sqrt(vx * vx + vy * vy + vz * vz)
    if theta < 1e-4:
        t2 = theta * theta
        a = 1.0 - t2 / 6.0 * (1.0 - t2 / 20.0)
        b = 0.5 - t2 / 24.0 * (1.0 - t2 / 30.0)
    else:
        a = math.sin(theta) / theta
        h = math.sin(0.5 * theta) / (0.5 * theta)
        b = 0.5 * h * h
    bxy, bxz, byz = b * vx * vy, b * vx * vz, b * vy * vz
    return (
        1.0 - b * (vy * vy + vz * vz),
        bxy - a * vz,
        bxz + a * vy,
        bxy + a * vz,
        1.0 - b * (vx * vx + vz * vz),
        byz - a * vx,
        bxz - a * vy,
        byz + a * vx,
        1.0 - b * (vx * vx + vy * vy),
    )


def _torre_flat(wx: float, wy: float, wz: float, dt: float) -> tuple[float, ...]:
    """Scalar fast path of :func:`torre_increment`, row-major 9-tuple."""
    return _torre_entries(
        math.cos(wx * dt),
        math.sin(wx * dt),
        math.cos(wy * dt),
        math.sin(wy * dt),
        math.cos(wz * dt),
        math.sin(wz * dt),
    )


def _torre_entries(ca: Any, sa: Any, cp: Any, sp: Any, ct: Any, st: Any) -> tuple[Any, ...]:
    """R(w)·R(v)·R(u), row major, from the cosines and sines of the three angles (floats or arrays)."""
    return (
        ct * cp,
        ct * sp * sa - st * ca,
        ct * sp * ca + st * sa,
        st * cp,
        st * sp * sa + ct * ca,
        st * sp * ca - ct * sa,
        -sp,
        cp * sa,
        cp * ca,
    )


class GyroIntegrator:
    r"""Dead reckoning of the sensor -> earth matrix from gyro rates (Torre 2008 §3.2, corrected side).

    .. math:: C(k+1) = C(k)\,\Delta R(\omega(k+1), \Delta t), \qquad C(0) = C_0

    with :math:`\Delta R` from :func:`torre_increment` (``mode="torre"``, Torre's three-factor product) or
    :func:`exact_increment` (``mode="exact"``).  Rounding makes :math:`C` drift away from a rotation;
    every ``renormalize_every`` steps it is pulled back to the nearest rotation by one Newton-Schulz
    polar step :math:`C \leftarrow \tfrac{1}{2} C (3I - C^T C)` (quadratically convergent to the
    :func:`orthonormalize` result, so exact to rounding for the tiny drift of a few hundred steps), and it
    stays one over hours of samples.  Gyro bias is *not* corrected: the estimate drifts by
    ``bias * t``, which is what :class:`ComplementaryFilter` is for.

    Parameters
    ----------
    R : array_like, shape (3, 3), optional
        Initial sensor -> earth matrix (default identity); the nearest rotation is used.
    mode : {"exact", "torre"}
        Increment formula.
    renormalize_every : int
        Steps between re-orthonormalisations (>= 1).

    >>> integ = GyroIntegrator()
    >>> for _ in range(100):
    ...     R = integ.update([0.0, 0.0, np.pi / 2], 0.01)    # 90 deg/s left for 1 s
    >>> np.round(R @ [1.0, 0.0, 0.0], 12).tolist()
    [0.0, 1.0, 0.0]
    """

    def __init__(
        self,
        R: ArrayLike | None = None,
        *,
        mode: Literal["exact", "torre"] = "exact",
        renormalize_every: int = 100,
    ) -> None:
        if mode not in ("exact", "torre"):
            raise ValueError(f"mode must be 'exact' or 'torre', got {mode!r}")
        if int(renormalize_every) < 1:
            raise ValueError(f"renormalize_every must be >= 1, got {renormalize_every!r}")
        self.mode = mode
        self.renormalize_every = int(renormalize_every)
        self._increment = _exact_flat if mode == "exact" else _torre_flat
        self._R: tuple[float, ...] = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
        self._steps = 0
        self.reset(R)

    @property
    def R(self) -> np.ndarray:
        """Current sensor -> earth rotation matrix, shape (3, 3) (a copy)."""
        return np.array(self._R).reshape(3, 3)

    @property
    def flat(self) -> tuple[float, ...]:
        """Current sensor -> earth matrix as nine floats, row major (no array is built)."""
        return self._R

    @property
    def quaternion(self) -> np.ndarray:
        """Current orientation as a unit quaternion ``(w, x, y, z)`` with ``w >= 0``, shape (4,)."""
        return matrix_to_quat(self.R)

    def reset(self, R: ArrayLike | None = None) -> None:
        """Restart from ``R`` (shape (3, 3), sensor -> earth; nearest rotation used) or the identity.

        Raises
        ------
        ValueError
            If ``R`` is not a finite 3x3 matrix with positive determinant.
        """
        if R is None:
            self._R = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
        else:
            R = np.asarray(R, dtype=float)
            if R.shape != (3, 3) or not np.all(np.isfinite(R)) or np.linalg.det(R) <= 0.0:
                raise ValueError("initial orientation must be a finite 3x3 rotation matrix (det > 0)")
            self._R = tuple(orthonormalize(R).ravel().tolist())
        self._steps = 0

    def update(self, rate: ArrayLike, dt: float) -> np.ndarray:
        r"""Advance by one gyro sample: :math:`C \leftarrow C\,\Delta R(\omega, \Delta t)`.

        Parameters
        ----------
        rate : array_like, shape (3,)
            Sensor-frame angular rate, rad/s (already nulled and scaled).
        dt : float
            Time since the previous sample, s (>= 0).

        Returns
        -------
        numpy.ndarray, shape (3, 3)
            The new sensor -> earth matrix.

        Raises
        ------
        ValueError
            On a rate that is not finite or not below :data:`~pointat.maths.scalar.MAX_RATE`, or a
            negative or non-finite ``dt``; the state is unchanged.
        """
        wx, wy, wz = rate
        self.step(float(wx), float(wy), float(wz), float(dt))
        return self.R

    def update_many(self, rates: ArrayLike, dt: ArrayLike) -> np.ndarray:
        r"""Advance by a sequence of gyro samples, exactly as repeated :meth:`update` calls would.

        For recorded data: it skips building an output matrix per sample.

        Parameters
        ----------
        rates : array_like, shape (n, 3)
            Sensor-frame angular rates, rad/s, oldest first.
        dt : float or array_like, shape (n,)
            Sample interval(s), s.

        Returns
        -------
        numpy.ndarray, shape (3, 3)
            The sensor -> earth matrix after the last sample.

        Raises
        ------
        ValueError
            On a bad rate (as :meth:`step`) or ``dt``; the samples before the bad one have been applied.
        """
        rates = np.asarray(rates, dtype=float)
        if rates.ndim != 2 or rates.shape[1] != 3:
            raise ValueError(f"rates must have shape (n, 3), got {rates.shape}")
        dts = np.broadcast_to(np.asarray(dt, dtype=float), rates.shape[:1]).tolist()
        step = self.step
        for (wx, wy, wz), d in zip(rates.tolist(), dts, strict=True):
            step(wx, wy, wz, d)
        return self.R

    def step(self, wx: float, wy: float, wz: float, dt: float) -> tuple[float, ...]:
        """:meth:`update` on plain floats, returning the matrix as nine floats, row major (no array is built).

        The per-sample path of the ``gyro_integrator`` node; raises ``ValueError`` as :meth:`update` does.
        """
        if not wx * wx + wy * wy + wz * wz < _sq.MAX_RATE_SQUARED:  # (False for NaN)
            raise ValueError(
                f"angular rate must be finite and below {_sq.MAX_RATE:g} rad/s, got {(wx, wy, wz)}"
            )
        if not (math.isfinite(dt) and dt >= 0.0):
            raise ValueError(f"dt must be a finite non-negative number of seconds, got {dt}")
        d00, d01, d02, d10, d11, d12, d20, d21, d22 = self._increment(wx, wy, wz, dt)
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = self._R
        self._R = (
            r00 * d00 + r01 * d10 + r02 * d20,
            r00 * d01 + r01 * d11 + r02 * d21,
            r00 * d02 + r01 * d12 + r02 * d22,
            r10 * d00 + r11 * d10 + r12 * d20,
            r10 * d01 + r11 * d11 + r12 * d21,
            r10 * d02 + r11 * d12 + r12 * d22,
            r20 * d00 + r21 * d10 + r22 * d20,
            r20 * d01 + r21 * d11 + r22 * d21,
            r20 * d02 + r21 * d12 + r22 * d22,
        )
        self._steps += 1
        if self._steps % self.renormalize_every == 0:
            # One Newton-Schulz step towards the polar factor, on the nine floats: no array on the
            # per-sample path (a handful of numpy calls here cost a sample ~100 us once in 100, cold)
            self._R = _sq.polar_step(self._R)
        return self._R


def accmag_matrix(acc: ArrayLike, mag: ArrayLike) -> np.ndarray | None:
    r"""Sensor -> earth (NWU) rotation from one accelerometer and one magnetometer sample (TRIAD).

    Torre 2008 §3.3, corrected (see the module notes): the earth axes expressed in sensor coordinates are

    .. math::
        \hat{z}_s = \frac{a}{\lVert a\rVert} \ (\text{up}), \qquad
        \hat{y}_s = \frac{\hat{z}_s \times m}{\lVert \hat{z}_s \times m \rVert} \ (\text{west}), \qquad
        \hat{x}_s = \hat{y}_s \times \hat{z}_s \ (\text{north}),

    the columns of Torre's inverse orientation matrix; the sensor -> earth matrix has them as rows,
    :math:`C = [\hat{x}_s\ \hat{y}_s\ \hat{z}_s]^T`.  Only the horizontal part of the field is used, so
    the dip angle and the field's magnitude do not matter, nor does the magnitude of ``acc``.

    Parameters
    ----------
    acc : array_like, shape (3,)
        Accelerometer (specific force; reads ``+g`` along up at rest), any unit.
    mag : array_like, shape (3,)
        Magnetometer, any unit.

    Returns
    -------
    numpy.ndarray, shape (3, 3), or None
        ``None`` when either vector is zero or non-finite, or they are (nearly, :data:`PARALLEL_EPS`)
        parallel: heading is then undefined and the caller keeps its state.

    >>> dip = np.radians(65.0)
    >>> C = accmag_matrix([0.0, 0.0, 9.81], [np.cos(dip), 0.0, -np.sin(dip)])   # level, facing north
    >>> np.round(C, 12).tolist()
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    >>> accmag_matrix([0.0, 0.0, 9.81], [0.0, 0.0, -1.0]) is None
    True
    """
    a = np.asarray(acc, dtype=float)
    m = np.asarray(mag, dtype=float)
    if a.shape != (3,) or m.shape != (3,):
        raise ValueError(f"acc and mag must have shape (3,), got {a.shape} and {m.shape}")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(m))):
        return None
    na, nm = np.linalg.norm(a), np.linalg.norm(m)
    if na == 0.0 or nm == 0.0:
        return None
    up = a / na
    west = np.cross(up, m / nm)
    nw = np.linalg.norm(west)
    if nw < PARALLEL_EPS:
        return None
    west /= nw
    north = np.cross(west, up)
    return np.stack([north, west, up])


def accmag_quat(acc: ArrayLike, mag: ArrayLike) -> np.ndarray | None:
    r"""Sensor -> earth quaternion (``w >= 0``) of :func:`accmag_matrix`, or ``None`` when it is undefined.

    .. math:: q = \mathrm{matrix\_to\_quat}\big([\hat{x}_s\ \hat{y}_s\ \hat{z}_s]^T\big)

    Parameters
    ----------
    acc : array_like, shape (3,)
        Accelerometer (specific force), any unit.
    mag : array_like, shape (3,)
        Magnetometer, any unit.

    Returns
    -------
    numpy.ndarray, shape (4,), or None

    >>> np.round(accmag_quat([0.0, 0.0, 1.0], [0.0, -0.5, -0.8]), 12).tolist()   # facing west
    [0.707106781187, 0.0, 0.0, 0.707106781187]
    """
    C = accmag_matrix(acc, mag)
    return None if C is None else matrix_to_quat(C)


class ComplementaryFilter:
    r"""Gyro prediction pulled toward the accelerometer/magnetometer orientation (Torre 2008 §3, on SO(3)).

    Torre combines "the short-term precision of the gyroscopes with the long-term precision of
    accelerometers and magnetometers".  Done on rotations rather than on angles, one step is

    .. math::
        q^- = q(k) \otimes \exp(\tfrac{1}{2}\omega\,\Delta t), \qquad
        q(k+1) = \mathrm{slerp}(q^-, q_{am}, \alpha), \qquad
        \alpha = \frac{\Delta t}{\tau + \Delta t}, \quad \tau = \frac{1}{2\pi f_c}

    with :math:`q_{am}` = :func:`accmag_quat` taken in the hemisphere of :math:`q^-` (slerp along the
    shorter arc).  Linearised for small errors this is the complementary pair
    :math:`\hat\theta = \frac{1}{1+\tau s}\theta_{am} + \frac{\tau s}{1+\tau s}\theta_{gyro}`: a first-order
    low-pass on acc/mag and the matching high-pass on the gyro, which sum to one and cross (both at
    -3 dB) at ``crossover_hz`` :math:`= f_c`.  :math:`\alpha` is the backward-Euler discretisation.
    Lower :math:`f_c` trusts the gyro longer (smoother, less disturbed by hand acceleration); a gyro bias
    :math:`b` leaves a steady error of about :math:`b\tau`.

    The filter starts from the first valid acc/mag sample (snapped, not blended); before that it
    integrates the gyro from :meth:`reset`'s ``q`` (identity by default).

    Parameters
    ----------
    crossover_hz : float
        Crossover frequency :math:`f_c` of the complementary pair, Hz (> 0).
    q0 : array_like, shape (4,), optional
        Known initial orientation; if given, the first acc/mag sample is blended, not snapped.
    accel_tolerance : float, optional
        If set, an acc/mag sample is rejected (gyro only) when
        :math:`|\,\lVert a\rVert - g\,| > \text{accel\_tolerance}\cdot g`, i.e. the hand is accelerating.
    gravity : float
        :math:`g` for ``accel_tolerance``, in the accelerometer's unit (default m/s²).

    >>> f = ComplementaryFilter(crossover_hz=0.5)
    >>> q, ok = f.update([0.0, 0.0, 0.0], [0.0, 0.0, 9.81], [0.4, 0.0, -0.9], 0.01)
    >>> ok, np.round(q, 12).tolist()
    (True, [1.0, 0.0, 0.0, 0.0])
    >>> f.update([0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.4, 0.0, -0.9], 0.01)[1]   # no gravity: gyro only
    False
    """

    def __init__(
        self,
        crossover_hz: float = 0.1,
        *,
        q0: ArrayLike | None = None,
        accel_tolerance: float | None = None,
        gravity: float = 9.80665,
    ) -> None:
        if not (math.isfinite(crossover_hz) and crossover_hz > 0.0):
            raise ValueError(f"crossover_hz must be a positive number of hertz, got {crossover_hz!r}")
        if accel_tolerance is not None and not accel_tolerance > 0.0:
            raise ValueError(f"accel_tolerance must be positive or None, got {accel_tolerance!r}")
        self.crossover_hz = float(crossover_hz)
        self.accel_tolerance = accel_tolerance
        self.gravity = float(gravity)
        self._q: _sq.Quat = (1.0, 0.0, 0.0, 0.0)
        self.initialized = False
        self.reset(q0)

    @property
    def q(self) -> np.ndarray:
        """The orientation now, sensor -> earth, shape (4,) (a copy)."""
        return np.array(self._q)

    @property
    def tau(self) -> float:
        r"""Time constant :math:`\tau = 1 / (2\pi f_c)`, s."""
        return 1.0 / (2.0 * math.pi * self.crossover_hz)

    def reset(self, q: ArrayLike | None = None) -> None:
        """Forget the state; start from ``q`` (shape (4,)) or wait for the next valid acc/mag sample."""
        if q is None:
            self._q = (1.0, 0.0, 0.0, 0.0)
            self.initialized = False
        else:
            self._q = tuple(quat_normalize(np.asarray(q, dtype=float).reshape(4)).tolist())
            self.initialized = True

    def _accmag(self, acc: ArrayLike, mag: ArrayLike) -> tuple[float, float, float, float] | None:
        a = tuple(float(v) for v in np.ravel(acc))
        if self.accel_tolerance is not None:
            na = math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
            if not abs(na - self.gravity) <= self.accel_tolerance * self.gravity:
                return None
        return _sq.accmag_quat(a, tuple(float(v) for v in np.ravel(mag)))

    def update(self, gyro: ArrayLike, acc: ArrayLike, mag: ArrayLike, dt: float) -> tuple[np.ndarray, bool]:
        """Advance by one sample.

        Parameters
        ----------
        gyro : array_like, shape (3,)
            Sensor-frame angular rate, rad/s.
        acc : array_like, shape (3,)
            Accelerometer (specific force), m/s² (any unit if ``accel_tolerance`` is None).
        mag : array_like, shape (3,)
            Magnetometer, any unit.
        dt : float
            Time since the previous sample, s (>= 0).

        Returns
        -------
        q : numpy.ndarray, shape (4,)
            Sensor -> earth quaternion.
        used_accmag : bool
            False when acc/mag was invalid (zero, NaN, parallel, or rejected) and only the gyro was used.

        Raises
        ------
        ValueError
            On a gyro rate that is not finite or not below :data:`~pointat.maths.scalar.MAX_RATE`, or a
            negative ``dt`` (the state is unchanged).
        """
        wx, wy, wz = (float(v) for v in np.ravel(gyro))
        dt = float(dt)
        if not wx * wx + wy * wy + wz * wz < _sq.MAX_RATE_SQUARED:  # (False for NaN)
            raise ValueError(f"gyro rate must be finite and below {_sq.MAX_RATE:g} rad/s, got {[wx, wy, wz]}")
        if not (math.isfinite(dt) and dt >= 0.0):
            raise ValueError(f"dt must be a finite non-negative number of seconds, got {dt}")
        # the per-sample work runs on plain floats (pointat.maths.scalar): numpy costs more than the maths
        rate = math.sqrt(wx * wx + wy * wy + wz * wz)
        delta = (
            _sq.axis_angle_quat(wx / rate, wy / rate, wz / rate, rate * dt)
            if rate > 0.0 and dt > 0.0
            else None
        )
        q_am = self._accmag(acc, mag)
        return np.array(self.fuse(delta, q_am, dt)), q_am is not None

    def fuse(self, delta: _sq.Quat | None, q_am: _sq.Quat | None, dt: float) -> _sq.Quat:
        r"""One step on rotations, from the gyro's increment and the acc/mag orientation: the whole filter
        but for where those come from.  The ``complementary`` node runs it with the increment between two
        of ``gyro_integrator``'s orientations, :math:`\delta = g_{k-1}^{*} \otimes g_k`; :meth:`update`
        with the gyro's own, :math:`\delta = \exp(\tfrac12\omega\,\Delta t)`.

        Parameters
        ----------
        delta : tuple of 4 floats, or None
            Body-frame increment since the previous sample, a unit quaternion ``(w, x, y, z)``; None: none.
        q_am : tuple of 4 floats, or None
            Acc/mag orientation, sensor -> earth, unit; None: this sample has none (gyro only).
        dt : float
            Time since the previous sample, s (>= 0).

        Returns
        -------
        tuple of 4 floats
            The orientation, sensor -> earth: :math:`q^- = q \otimes \delta`, then
            :math:`\mathrm{slerp}(q^-, q_{am}, \alpha)`; the first ``q_am`` is taken as it is (snapped)
            unless a ``q0`` was given.

        >>> f = ComplementaryFilter(crossover_hz=1.0)
        >>> f.fuse(None, (1.0, 0.0, 0.0, 0.0), 0.01)        # the first acc/mag orientation: snapped
        (1.0, 0.0, 0.0, 0.0)
        >>> [round(v, 6) for v in f.fuse(None, (0.0, 0.0, 0.0, 1.0), 0.01)]   # then pulled by alpha
        [0.995691, 0.0, 0.0, 0.092728]
        """
        q = self._q
        if delta is not None:
            q = _sq.normalize(_sq.multiply(q, delta))
        if q_am is not None and not self.initialized:
            q = q_am
            self.initialized = True
        elif q_am is not None:
            alpha = dt / (self.tau + dt) if dt > 0.0 else 0.0
            q = _sq.normalize(_sq.slerp(q, q_am, alpha))  # along the shorter arc: the sign stays continuous
        self._q = q
        return q


class RollDistance:
    r"""Torre 2008 §5.2 / Fig. 6: a roll of about 90° turns the azimuth into a distance control.

    Two modes, with hysteresis on :math:`|\text{roll}|` so the mode does not flicker:

    * ``"azimuth"``: the azimuth passes through; the distance holds.  Enter ``"distance"`` when
      :math:`|\text{roll}| \ge` ``enter_deg`` (70°).
    * ``"distance"``: the azimuth output holds the last passed-through value; leave when
      :math:`|\text{roll}| <` ``leave_deg`` (45°), the azimuth then passes through again.

    In distance mode, with :math:`a_0` the azimuth when the roll began, :math:`d_0` the distance then,
    and :math:`\Delta a` the change of azimuth since, unwrapped across ±180° (so it can exceed a turn):

    .. math:: d = \mathrm{clip}(d_0 + g\,\Delta a,\ 0,\ 90), \qquad \Delta a = a - a_0

    The roll is read only while the hand points within ``max_elevation_deg`` (75°) of the horizon: a
    hand pointing (nearly) straight up or down has no roll of its own (its roll and its heading are
    the same turn, and the Euler roll there swings wildly with the slightest jitter), so there the
    mode stays as it is.

    0 = farthest, 90 = closest (Torre's range).  With the default gain :math:`g = 1`, sweeping the
    rolled hand 1° to the **left** brings the source 1° (of the 0..90 range) **closer**.  Because the
    value is :math:`d_0 + g\Delta a` clipped, overshooting an end and coming back returns along the same
    path (the control is absolute within one roll gesture, like a knob with a fixed pointer).

    Parameters
    ----------
    enter_deg : float
        :math:`|\text{roll}|` (degrees) at which distance mode starts.
    leave_deg : float
        :math:`|\text{roll}|` (degrees) below which it ends; ``leave_deg < enter_deg``.
    gain : float
        Distance units per degree of azimuth change (negative flips the direction).
    distance : float
        Initial distance, 0..90.
    max_elevation_deg : float
        :math:`|\text{elevation}|` (degrees) above which the roll is not read and the mode holds.

    >>> rd = RollDistance()
    >>> rd.update(30.0, 0.0)
    ('azimuth', 30.0, 0.0)
    >>> rd.update(31.0, 85.0)        # roll the hand: the azimuth holds
    ('distance', 30.0, 0.0)
    >>> rd.update(51.0, 80.0)        # sweep 20 deg left: 20 closer
    ('distance', 30.0, 20.0)
    >>> rd.update(60.0, 50.0)        # still rolled past leave_deg
    ('distance', 30.0, 29.0)
    >>> rd.update(60.0, 10.0)
    ('azimuth', 60.0, 29.0)
    >>> rd.update(60.0, 85.0, elevation_deg=89.5)   # pointing at the zenith: no roll to read
    ('azimuth', 60.0, 29.0)
    """

    def __init__(
        self,
        enter_deg: float = 70.0,
        leave_deg: float = 45.0,
        gain: float = 1.0,
        distance: float = 0.0,
        max_elevation_deg: float = 75.0,
    ) -> None:
        self.check(enter_deg, leave_deg, max_elevation_deg)
        self.max_elevation_deg = float(max_elevation_deg)
        self.enter_deg = float(enter_deg)
        self.leave_deg = float(leave_deg)
        self.gain = float(gain)
        self._initial_distance = float(np.clip(distance, 0.0, 90.0))
        self.reset()

    @staticmethod
    def check(enter_deg: float, leave_deg: float, max_elevation_deg: float) -> None:
        """Raise ``ValueError`` for thresholds that make no gesture (also for a change while running)."""
        if not 0.0 <= leave_deg < enter_deg <= 180.0:
            raise ValueError(f"need 0 <= leave < enter <= 180, got leave={leave_deg} enter={enter_deg}")
        if not 0.0 <= max_elevation_deg <= 90.0:
            raise ValueError(f"max_elevation must be 0..90 deg, got {max_elevation_deg}")

    def reset(self, distance: float | None = None) -> None:
        """Back to azimuth mode; distance set to ``distance`` (clipped to 0..90) or the initial value."""
        d = self._initial_distance if distance is None else float(np.clip(distance, 0.0, 90.0))
        #: The state :func:`roll_distance_step` carries (``R_*``): a list here, a row of an array in the
        #: compiled chain (:mod:`pointat.compiled.kernel`).
        self.s = [0.0, d, math.nan, 0.0, d, 0.0]

    @property
    def mode(self) -> str:
        """``"azimuth"`` or ``"distance"``."""
        return "distance" if self.s[R_MODE] else "azimuth"

    @property
    def distance(self) -> float:
        """The current distance, 0 (far) .. 90 (near)."""
        return self.s[R_DIST]

    @property
    def azimuth(self) -> float | None:
        """The azimuth output (held in distance mode); ``None`` before the first sample."""
        a = self.s[R_AZ]
        return None if a != a else a

    def update(
        self, azimuth_deg: float, roll_deg: float, elevation_deg: float = 0.0
    ) -> tuple[str, float, float]:
        """Process one (azimuth, roll) sample, degrees.

        Parameters
        ----------
        azimuth_deg : float
            Pointing azimuth, degrees (ADM-OSC: positive left).
        roll_deg : float
            Roll about the pointing axis, degrees.
        elevation_deg : float
            Pointing elevation, degrees: beyond ``max_elevation_deg`` the roll is not read.

        Returns
        -------
        mode : str
            ``"azimuth"`` or ``"distance"``.
        azimuth : float
            Output azimuth, degrees (held in distance mode).
        distance : float
            Distance, 0 (far) .. 90 (near).
        """
        az, roll = float(azimuth_deg), float(roll_deg)
        if not (math.isfinite(az) and math.isfinite(roll)):
            raise ValueError(f"azimuth and roll must be finite, got {az}, {roll}")
        s = self.s
        roll_distance_step(
            s, az, roll, elevation_deg, self.enter_deg, self.leave_deg, self.gain, self.max_elevation_deg
        )
        return ("distance" if s[R_MODE] else "azimuth"), s[R_AZ], s[R_DIST]


# -- roll_distance_step's state (a list, or a row of an array) ------------------------------------------
R_MODE = 0  # 1.0 in distance mode
R_DIST = 1  # the distance
R_AZ = 2  # the azimuth output (NaN: none yet)
R_ANCHOR_AZ = 3  # the azimuth when the roll began
R_ANCHOR_DIST = 4  # the distance then
R_UNWRAPPED = 5  # the azimuth since, unwrapped across +-180
R_SIZE = 6


def roll_distance_step(s, az, roll, elevation, enter, leave, gain, max_elevation):  # type: ignore[no-untyped-def]
    """One sample of :class:`RollDistance` on its state ``s`` (``R_*``), in place: finite ``az`` and
    ``roll``, degrees.  Plain arithmetic on floats, so that numba compiles it into the fused chain
    (:mod:`pointat.compiled.kernel`) and the class runs the same source."""
    steep = abs(elevation) > max_elevation  # no roll of its own to read: the mode holds
    if s[R_MODE] == 0.0:
        if abs(roll) >= enter and not steep:
            s[R_MODE] = 1.0
            if s[R_AZ] != s[R_AZ]:
                s[R_AZ] = az
            s[R_ANCHOR_AZ] = az
            s[R_ANCHOR_DIST] = s[R_DIST]
            s[R_UNWRAPPED] = az
        else:
            s[R_AZ] = az
    elif abs(roll) < leave and not steep:
        s[R_MODE] = 0.0
        s[R_AZ] = az
    if s[R_MODE] != 0.0:
        w = (az - s[R_UNWRAPPED] + 180.0) % 360.0 - 180.0  # unwrap_degrees, on one float
        s[R_UNWRAPPED] += w - 360.0 if w >= 180.0 else w
        delta = s[R_UNWRAPPED] - s[R_ANCHOR_AZ]
        s[R_DIST] = min(max(s[R_ANCHOR_DIST] + gain * delta, 0.0), 90.0)
