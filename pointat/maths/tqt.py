r"""The Tuneable Quaternion Tracker (TQT): McGhee / Bachmann's Gauss-Newton MARG filter, with robust extensions.

One MARG sensor (gyro, accelerometer, magnetometer) in, one unit quaternion (sensor -> earth, NWU) out.
Conventions are those of :mod:`pointat.maths`; the gravity reference is *up* ``m = (0, 0, 1)``, which the
accelerometer measures as ``+g`` at rest, and the magnetic reference is ``n = (cos dip, 0, -sin dip)``.

Sources
-------
* McGhee, Bachmann, Yun, Zyda (2000), *Real-time tracking ... Part I: Theory*, NPS-MV-01-001 ("Theory"):
  rate quaternion Eq. 17, Gauss-Newton Eq. 32, the 4-column X matrix Eqs. 39-42, the Orthogonal Quaternion
  Theorem Eqs. 44-51, Table 1, the magnetometer weight rho Eq. 57, the crossover frequency Eq. 59.
* Bachmann, McGhee, Yun, Zyda (2001), VRST ("VRST"): the filter loop Eqs. 13-15, the reduced X Eqs. 20-27,
  accelerometer / magnetometer only tracking §4.4.
* Bachmann et al., US patent 7,089,148 (2006) ("Patent"): the 3x3 X matrix of Eq. 29, rho Eq. 30 and the
  "time weighted summing" of accelerations (col. 4).

The filter (Theory Fig. 1, VRST Eq. 15)
----------------------------------------
.. math::
    \dot{\hat q} = \tfrac12\,\hat q \otimes (0, p, q, r) + k\,\Delta q_{full}, \qquad
    \Delta q_{full} = \hat q \otimes (0, \Delta v), \qquad
    \Delta v = (X^T X)^{-1} X^T \varepsilon(\hat q)

With the reduced (orthogonal) correction both terms are :math:`\hat q \otimes (\text{pure vector})`, so the
whole right-hand side is a body rate :math:`\tfrac12 \hat q \otimes (0, \omega + 2k\Delta v)`; this module
integrates it *exactly* over one sample (zero-order hold), :math:`\hat q_{n+1} = \hat q_n \otimes
\exp\big(\tfrac{\Delta t}{2}(\omega + 2k\Delta v)\big)`, instead of the seeds' Euler step plus
normalisation.  The correction then turns the estimate by :math:`\alpha\theta` per step
(:math:`\alpha = k\Delta t`, VRST Eq. 14), so errors decay as :math:`e^{-kt}` and the complementary
crossover is :math:`f_c = k / 2\pi` Hz (Theory Eq. 59; in robust mode, which low-passes the acceleration
first, it is lower: :attr:`TQTFilter.crossover`).

Corrections of the seeds (see also the project's REFERENCE §7)
---------------------------------------------------------------
* Accelerometers measure the *reaction* to gravity, ``+g`` along the axis pointing up; the seeds compare the
  normalised accelerometer with "down" ``m = (0, 0, 0, 1)`` (VRST Eq. 5), which taken literally converges
  upside down.  Here the reference is up.
* VRST Eq. 26 / Patent Eq. 27 miss a transpose: :math:`\Delta v = (X_v^T X_v)^{-1} X_v^T \varepsilon`.
* Weighting the magnetometer residuals by :math:`\rho` (Theory Eq. 57) scales the magnetometer rows of X by
  :math:`\rho`, not :math:`\rho^2` (VRST §2.3, Patent col. 12).
* Theory Eqs. 35-38 are derivatives of :math:`q^*`, not of :math:`q^{-1}` (equal for unit q only).
* Patent Eq. 23 reads :math:`\partial y/\partial y_1` for :math:`\partial y/\partial v_1`.
* Theory Table 1 is captioned "RMS error" but, as its text says, is the *mean* error length over 100
  trials; it reproduces (``tests/maths/test_tqt.py``) with :func:`jacobian_full`, starts
  ``q_true + U(±0.1)`` per component not normalised, no normalisation between cycles
  (``gauss_newton(..., reduced=False, normalize=False)``) and a dip of about 62° (Monterey): every cell
  lies within the sampling spread of a 100-trial mean.  The 3x3 form's first cycles land closer than the
  table's; it matches the noise-limited cells only.  The noiseless 3-cycle cell (9.3e-8) is float32
  round-off; float64 stays below 1e-8.

>>> f = TQTFilter()
>>> for _ in range(3):
...     q = f.update((0.0, 0.0, 0.0), (0.0, 0.0, 9.81), (20.0, 0.0, -40.0), 0.01)
>>> [round(c, 9) for c in q]                  # level, facing magnetic north: the identity
[1.0, 0.0, 0.0, 0.0]
"""

from __future__ import annotations

import math
from enum import IntFlag
from typing import ClassVar, Literal

import numpy as np
from numpy.typing import ArrayLike

from pointat.maths.fusion import accmag_quat
from pointat.maths.quaternion import quat_multiply, quat_normalize
from pointat.maths.scalar import MAX_RATE_SQUARED

__all__ = [
    "ACC_LIMIT",
    "ACC_RELEARN",
    "GRAVITY_REF",
    "magnetic_reference",
    "gain_from_crossover",
    "crossover_from_gain",
    "measurement_vector",
    "measurement_model",
    "jacobian_full",
    "jacobian_reduced",
    "gauss_newton_step",
    "gauss_newton",
    "TQTFlags",
    "TQTFilter",
    "TQTBank",
]

#: Gravity reference in the NWU earth frame: *up*, as the accelerometer measures it (+g at rest).
GRAVITY_REF = np.array([0.0, 0.0, 1.0])

_INF = math.inf
#: A specific force more than this many times the one the filter started with (at rest: gravity) is not
#: taken for gravity, like NaN: no hand makes it, and one corrupt sample that large (a damaged recording,
#: a float sensor's glitch) would tilt the earth-frame low-pass for minutes.  The unit stays free.
ACC_LIMIT = 8.0
_ACC_LIMIT_SQUARED = ACC_LIMIT * ACC_LIMIT
#: Samples in a row beyond the limit after which the limit is learned again from the reading: a glitch is
#: a sample or a few, while a first reading that was too small (a sensor settling at power-on) must not
#: refuse gravity for good.
ACC_RELEARN = 50
_TWO_PI = 2.0 * math.pi
# below this squared half-angle the exponential map uses its Taylor series (error < 1e-18)
_EXP_TAYLOR = 1e-8


# ----------------------------------------------------------------------------------------------------------
# Pure functions (numpy, broadcasting over leading axes)
# ----------------------------------------------------------------------------------------------------------


def magnetic_reference(dip: float) -> np.ndarray:
    r"""Unit Earth-field reference in NWU for a dip (inclination) angle, Theory §3 ``n``.

    .. math:: n = (\cos\delta,\; 0,\; -\sin\delta)

    Parameters
    ----------
    dip : float
        Dip angle in radians, positive when the field points below the horizon (northern hemisphere).

    Returns
    -------
    numpy.ndarray, shape (3,)

    >>> np.round(magnetic_reference(np.pi / 6), 12).tolist()
    [0.866025403784, 0.0, -0.5]
    """
    return np.array([math.cos(dip), 0.0, -math.sin(dip)])


def gain_from_crossover(f_c: float) -> float:
    r"""Filter gain ``k`` (1/s) for a complementary crossover frequency (Theory Eq. 59 solved for k).

    .. math:: k = 2\pi f_c

    Parameters
    ----------
    f_c : float
        Crossover frequency in Hz: below it the accelerometer / magnetometer dominate, above it the gyro.

    Returns
    -------
    float
        ``k`` in 1/s.

    >>> round(gain_from_crossover(crossover_from_gain(0.5)), 12)
    0.5
    """
    return _TWO_PI * f_c


def crossover_from_gain(k: float) -> float:
    r"""Complementary crossover frequency (Hz) of the gain ``k`` (Theory Eq. 59).

    .. math:: f_c = \frac{k}{2\pi}

    Parameters
    ----------
    k : float
        Filter gain in 1/s.

    Returns
    -------
    float
        Hz.

    >>> round(crossover_from_gain(2.0 * np.pi), 12)
    1.0
    """
    return k / _TWO_PI


def measurement_vector(acc: ArrayLike, mag: ArrayLike) -> np.ndarray:
    r"""Measured vector :math:`y_0 = (h, b)` from raw accelerometer and magnetometer (VRST Eqs. 3-4).

    .. math:: y_0 = \left(\frac{a}{\lVert a\rVert},\; \frac{B}{\lVert B\rVert}\right)

    The accelerometer is used with its own sign (+g up at rest) against the reference up.

    Parameters
    ----------
    acc : array_like, shape (..., 3)
        Specific force, sensor frame, any unit (non-zero).
    mag : array_like, shape (..., 3)
        Magnetic field, sensor frame, any unit (non-zero).

    Returns
    -------
    numpy.ndarray, shape (..., 6)

    >>> measurement_vector([0.0, 0.0, 9.81], [3.0, 0.0, -4.0]).tolist()
    [0.0, 0.0, 1.0, 0.6, 0.0, -0.8]
    """
    a = np.asarray(acc, dtype=float)
    b = np.asarray(mag, dtype=float)
    return np.concatenate(
        [a / np.linalg.norm(a, axis=-1, keepdims=True), b / np.linalg.norm(b, axis=-1, keepdims=True)],
        axis=-1,
    )


def _pure(v: ArrayLike) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return np.concatenate([np.zeros(v.shape[:-1] + (1,)), v], axis=-1)


def _conj(q: np.ndarray) -> np.ndarray:
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def measurement_model(q: ArrayLike, m: ArrayLike = GRAVITY_REF, n: ArrayLike | None = None) -> np.ndarray:
    r"""Computed measurement :math:`y(\hat q)`: the references seen from the sensor (Theory Eq. A-6, VRST Eq. 7).

    .. math:: y(q) = \big(\mathrm{vec}(q^* \otimes m \otimes q),\; \mathrm{vec}(q^* \otimes n \otimes q)\big)

    For a non-unit ``q`` the result scales with :math:`\lVert q\rVert^2` (the conjugate, as in Theory
    Eqs. 35-42, not the inverse), which is what lets the 4-column Gauss-Newton of :func:`jacobian_full`
    also correct the norm.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Sensor -> earth quaternions (need not be unit).
    m : array_like, shape (3,) or (..., 3)
        Gravity reference in the earth frame (default up, NWU).
    n : array_like, shape (3,) or (..., 3)
        Magnetic reference in the earth frame (default :func:`magnetic_reference` of 0).

    Returns
    -------
    numpy.ndarray, shape (..., 6)

    >>> measurement_model([1.0, 0.0, 0.0, 0.0], n=[0.6, 0.0, -0.8]).tolist()
    [0.0, 0.0, 1.0, 0.6, 0.0, -0.8]
    """
    q = np.asarray(q, dtype=float)
    n = magnetic_reference(0.0) if n is None else n
    qs = _conj(q)
    ym = quat_multiply(quat_multiply(qs, _pure(m)), q)[..., 1:]
    yn = quat_multiply(quat_multiply(qs, _pure(n)), q)[..., 1:]
    ym, yn = np.broadcast_arrays(ym, yn)
    return np.concatenate([ym, yn], axis=-1)


_BASIS = np.eye(4)


def jacobian_full(
    q: ArrayLike, m: ArrayLike = GRAVITY_REF, n: ArrayLike | None = None, *, rho: float = 1.0
) -> np.ndarray:
    r"""The 6x4 Gauss-Newton matrix :math:`X = \partial y / \partial q` of Theory Eqs. 39-42.

    .. math::
        \frac{\partial y}{\partial q_j} = \mathrm{vec}\big(e_j^* \otimes m \otimes q + q^* \otimes m \otimes e_j,
        \;\; e_j^* \otimes n \otimes q + q^* \otimes n \otimes e_j\big), \qquad e_j \in (1, i, j, k)

    (the derivatives of :math:`q^*`, Eqs. 35-38).  The magnetometer rows are multiplied by ``rho`` (Theory
    Eq. 57: weighting the residual by :math:`\rho` weights its rows of X by :math:`\rho`).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Current estimate (need not be unit).
    m, n : array_like, shape (3,)
        Gravity and magnetic references, earth frame.
    rho : float, keyword-only
        Magnetometer weight (Theory Eq. 57); 1 weighs both sensors equally.

    Returns
    -------
    numpy.ndarray, shape (..., 6, 4)

    >>> np.round(jacobian_full([1.0, 0.0, 0.0, 0.0], n=[1.0, 0.0, 0.0])[:, 0], 12).tolist()  # d/dw = 2y
    [0.0, 0.0, 2.0, 2.0, 0.0, 0.0]
    """
    q = np.asarray(q, dtype=float)
    n = magnetic_reference(0.0) if n is None else n
    qs = _conj(q)
    pm, pn = _pure(m), _pure(n)
    cols = []
    for e in _BASIS:
        es = _conj(e)
        dm = quat_multiply(quat_multiply(es, pm), q) + quat_multiply(quat_multiply(qs, pm), e)
        dn = quat_multiply(quat_multiply(es, pn), q) + quat_multiply(quat_multiply(qs, pn), e)
        dm, dn = np.broadcast_arrays(dm, dn)
        cols.append(np.concatenate([dm[..., 1:], rho * dn[..., 1:]], axis=-1))
    return np.stack(cols, axis=-1)


def jacobian_reduced(y: ArrayLike, *, rho: float = 1.0) -> np.ndarray:
    r"""The reduced 6x3 X matrix of the Orthogonal Quaternion Theorem (Patent Eq. 29; Theory Eqs. 46-49).

    With :math:`\Delta q = \hat q \otimes (0, v)` (Theory Eq. 44), :math:`y(\hat q \otimes (1, v)) \approx
    y + 2\,y \times v`, so

    .. math::
        X_v = 2\begin{bmatrix} [y_{1:3}]_\times \\ \rho\,[y_{4:6}]_\times \end{bmatrix}, \qquad
        [u]_\times = \begin{bmatrix} 0 & -u_3 & u_2 \\ u_3 & 0 & -u_1 \\ -u_2 & u_1 & 0 \end{bmatrix}

    filled with the computed (or measured, Patent col. 12) measurement vector.

    Parameters
    ----------
    y : array_like, shape (..., 6)
        Measurement vector :math:`(h, b)`.
    rho : float, keyword-only
        Magnetometer weight (rows 4-6 scaled by rho).

    Returns
    -------
    numpy.ndarray, shape (..., 6, 3)

    >>> (jacobian_reduced([0, 0, 1, 1, 0, 0])[:3] + 0.0).tolist()      # + 0.0 turns -0.0 into 0.0
    [[0.0, -2.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
    """
    y = np.asarray(y, dtype=float)

    def skew(u: np.ndarray) -> np.ndarray:
        x1, x2, x3 = u[..., 0], u[..., 1], u[..., 2]
        z = np.zeros_like(x1)
        return np.stack(
            [np.stack([z, -x3, x2], -1), np.stack([x3, z, -x1], -1), np.stack([-x2, x1, z], -1)], -2
        )

    return 2.0 * np.concatenate([skew(y[..., :3]), rho * skew(y[..., 3:])], axis=-2)


def gauss_newton_step(
    q: ArrayLike,
    y0: ArrayLike,
    m: ArrayLike = GRAVITY_REF,
    n: ArrayLike | None = None,
    *,
    rho: float = 1.0,
    reduced: bool = True,
) -> np.ndarray:
    r"""One full Gauss-Newton correction :math:`\Delta q_{full}` (Theory Eq. 32; VRST Eq. 11, Eqs. 26-27).

    .. math::
        \varepsilon = W\,(y_0 - y(\hat q)), \qquad W = \mathrm{diag}(1, 1, 1, \rho, \rho, \rho)

        \text{full: } \Delta q = (X^T X)^{-1} X^T \varepsilon \quad (X \text{ of Eqs. 39-42, 6x4})

        \text{reduced: } \Delta v = (X_v^T X_v)^{-1} X_v^T \varepsilon, \quad
        \Delta q = \hat q \otimes (0, \Delta v) \quad (X_v \text{ of Patent Eq. 29, 6x3; Theory Eqs. 50-51})

    The reduced form fits :math:`\Delta v` at :math:`\hat q / \lVert\hat q\rVert` (the theorem is about unit
    quaternions, and :math:`y` scales with :math:`\lVert\hat q\rVert^2`), then multiplies the estimate as
    given: :math:`\hat q + \Delta q = \hat q \otimes (1, \Delta v)`, a turn that does not depend on
    :math:`\lVert\hat q\rVert`.  The step from :math:`c\,\hat q` is :math:`c` times the step from
    :math:`\hat q`.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Current estimate, sensor -> earth.
    y0 : array_like, shape (..., 6)
        Measured :math:`(h, b)`, unit vectors in the sensor frame (:func:`measurement_vector`).
    m, n : array_like, shape (3,)
        Earth-frame references (gravity up, magnetic field).
    rho : float, keyword-only
        Magnetometer weight (Theory Eq. 57).
    reduced : bool, keyword-only
        Use the 3x3 form of the Orthogonal Quaternion Theorem (default) or the 4x4 form.

    Returns
    -------
    numpy.ndarray, shape (..., 4)
        :math:`\Delta q_{full}`, to be added to ``q`` (Theory Eq. 43).

    >>> y0, n = [0.0, 0.0, 1.0, 0.6, 0.0, -0.8], [0.6, 0.0, -0.8]
    >>> dq = gauss_newton_step([1.0, 0.0, 0.0, 0.0], y0, n=n)
    >>> bool(np.abs(dq).max() < 1e-15)
    True
    >>> q = np.array([0.9, 0.1, -0.1, 0.2])
    >>> bool(np.allclose(gauss_newton_step(2.0 * q, y0, n=n), 2.0 * gauss_newton_step(q, y0, n=n)))
    True
    """
    q = np.asarray(q, dtype=float)
    y0 = np.asarray(y0, dtype=float)
    n = magnetic_reference(0.0) if n is None else n
    w = np.array([1.0, 1.0, 1.0, rho, rho, rho])
    if reduced:
        y = measurement_model(quat_normalize(q), m, n)
        X = jacobian_reduced(y, rho=rho)
    else:
        y = measurement_model(q, m, n)
        X = jacobian_full(q, m, n, rho=rho)
    eps = w * (y0 - y)
    Xt = np.swapaxes(X, -1, -2)
    delta = np.linalg.solve(Xt @ X, (Xt @ eps[..., None]))[..., 0]
    if reduced:
        return quat_multiply(q, _pure(delta))
    return delta


def gauss_newton(
    q: ArrayLike,
    y0: ArrayLike,
    m: ArrayLike = GRAVITY_REF,
    n: ArrayLike | None = None,
    *,
    iterations: int = 1,
    rho: float = 1.0,
    reduced: bool = True,
    normalize: bool = True,
) -> np.ndarray:
    r"""Iterate :math:`\hat q \leftarrow \hat q + \Delta q_{full}` (Theory Eq. 43) a fixed number of times.

    This is the static estimation problem of Theory §6 (Table 1): find the orientation whose computed
    measurement best fits :math:`y_0` in the least-squares sense (Theory Eq. 22).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Starting estimate.
    y0 : array_like, shape (..., 6)
        Measured :math:`(h, b)` (:func:`measurement_vector`).
    m, n : array_like, shape (3,)
        Earth-frame references.
    iterations : int, keyword-only
        Number of Gauss-Newton cycles.
    rho : float, keyword-only
        Magnetometer weight.
    reduced : bool, keyword-only
        3x3 form (default) or the 4-column X of Theory Eqs. 39-42.
    normalize : bool, keyword-only
        Normalise after every cycle (Theory Eq. 34).  Table 1 is reproduced with the 4-column X and no
        normalisation: the 4-column step corrects the norm as well.  The 3x3 step keeps the norm it is
        given and turns ``c * q`` as it turns ``q``; both forms end at the same orientation.

    Returns
    -------
    numpy.ndarray, shape (..., 4)

    >>> q = gauss_newton([0.9, 0.1, -0.1, 0.2], [0.0, 0.0, 1.0, 0.6, 0.0, -0.8], n=[0.6, 0.0, -0.8],
    ...                  iterations=6)
    >>> np.round(q, 9).tolist()
    [1.0, 0.0, 0.0, 0.0]
    """
    q = np.asarray(q, dtype=float)
    for _ in range(iterations):
        q = q + gauss_newton_step(q, y0, m, n, rho=rho, reduced=reduced)
        if normalize:
            q = quat_normalize(q)
    return q


# ----------------------------------------------------------------------------------------------------------
# The filter
# ----------------------------------------------------------------------------------------------------------


class TQTFlags(IntFlag):
    """Status of the last :meth:`TQTFilter.update` (bits; test with ``flag in f.flags``)."""

    NONE = 0
    #: gyro not finite, or beyond :data:`~pointat.maths.scalar.MAX_RATE`: no rate propagation this step
    GYRO_INVALID = 1
    #: accelerometer zero, not finite, or beyond :data:`ACC_LIMIT` times the first reading (for fewer
    #: than :data:`ACC_RELEARN` samples in a row): no gravity correction this step
    ACC_INVALID = 2
    #: magnetometer zero or not finite: no magnetic correction this step
    MAG_INVALID = 4
    #: ``dt`` not a finite positive number: nothing done
    DT_INVALID = 8
    #: no valid accelerometer + magnetometer pair seen yet: the output is the identity
    UNINITIALISED = 16
    #: robust mode: the field's norm or dip is off its reference, the magnetometer was ignored
    MAG_DISTURBED = 32
    #: robust mode: the sensor is at rest, the gyro bias is being learned
    REST = 64


_GYRO_INVALID = int(TQTFlags.GYRO_INVALID)
_ACC_INVALID = int(TQTFlags.ACC_INVALID)
_MAG_INVALID = int(TQTFlags.MAG_INVALID)
_DT_INVALID = int(TQTFlags.DT_INVALID)
_UNINITIALISED = int(TQTFlags.UNINITIALISED)
_MAG_DISTURBED = int(TQTFlags.MAG_DISTURBED)
_REST = int(TQTFlags.REST)

# learning rate (time constant, s) of the magnetic norm / dip reference at rest (robust mode)
_MAG_REF_TAU = 5.0
# time constant (s) of the gyro / accelerometer low-pass the rest detector compares against (as VQF)
_REST_TAU = 0.5

Mode = Literal["robust", "paper"]


class _TQTParams:
    """Parameters shared by :class:`TQTFilter` and :class:`TQTBank` (validated once, documented there)."""

    #: The gain ``k`` of each mode when none is given.
    DEFAULT_K: ClassVar[dict[str, float]] = {"robust": 1.0, "paper": 0.1}

    def __init__(
        self,
        k: float | None = None,
        *,
        rho: float = 0.5,
        iterations: int = 1,
        mode: Mode = "robust",
        use_gyro: bool = True,
        dip: float | None = None,
        k_heading: float = 0.05,
        acc_tau: float = 2.0,
        mag_norm_tol: float = 0.1,
        mag_dip_tol: float = math.radians(5.0),
        rest_time: float = 1.5,
        rest_gyro: float = math.radians(2.0),
        rest_acc: float = 0.05,
        bias_tau: float = 5.0,
        bias_clip: float = math.radians(2.0),
    ) -> None:
        if mode not in ("robust", "paper"):
            raise ValueError(f"mode must be 'robust' or 'paper', got {mode!r}")
        if k is None:
            k = self.DEFAULT_K[mode]
        for name, value in (
            ("k", k),
            ("rho", rho),
            ("k_heading", k_heading),
            ("acc_tau", acc_tau),
            ("mag_norm_tol", mag_norm_tol),
            ("mag_dip_tol", mag_dip_tol),
            ("rest_time", rest_time),
            ("rest_gyro", rest_gyro),
            ("rest_acc", rest_acc),
            ("bias_tau", bias_tau),
            ("bias_clip", bias_clip),
        ):
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
        if acc_tau <= 0.0 or bias_tau <= 0.0:
            raise ValueError("acc_tau and bias_tau must be > 0")
        if int(iterations) != iterations or iterations < 1:
            raise ValueError(f"iterations must be an integer >= 1, got {iterations!r}")
        if dip is not None and not math.isfinite(dip):
            raise ValueError(f"dip must be finite radians, got {dip!r}")
        self.k = float(k)
        self.rho = float(rho)
        self.iterations = int(iterations)
        self.mode: Mode = mode
        self.use_gyro = bool(use_gyro)
        self.dip = dip
        self.k_heading = float(k_heading)
        self.acc_tau = float(acc_tau)
        self.mag_norm_tol = float(mag_norm_tol)
        self.mag_dip_tol = float(mag_dip_tol)
        self.rest_time = float(rest_time)
        self.rest_gyro = float(rest_gyro)
        self.rest_acc = float(rest_acc)
        self.bias_tau = float(bias_tau)
        self.bias_clip = float(bias_clip)
        self.reset()

    def _coefficients(self, dt: float) -> None:
        self._dt = dt
        self._c_acc = 1.0 - math.exp(-dt / self.acc_tau)
        self._c_rest = 1.0 - math.exp(-dt / _REST_TAU)
        self._c_bias = 1.0 - math.exp(-dt / self.bias_tau)
        self._c_ref = 1.0 - math.exp(-dt / _MAG_REF_TAU)
        self._alpha = min(self.k * dt, 1.0)
        self._alpha_mag = min(self.k_heading * dt, 1.0)

    @property
    def crossover(self) -> float:
        r"""The gravity correction's crossover in Hz: below it the tilt follows the accelerometer, above it
        the gyro (the -3 dB point of the accelerometer's path to the estimate).

        paper: :math:`k / 2\pi` (Theory Eq. 59).  robust: the acceleration is low-passed in the earth
        frame (``acc_tau``) before the gain-``k`` correction sees it, two first-order low-passes in a
        row, so the crossover is lower:

        .. math:: \omega_c^2 = \tfrac12\Big(\sqrt{(k^2 + a^2)^2 + 4k^2a^2} - (k^2 + a^2)\Big), \qquad
                  a = 1 / \tau_a, \qquad f_c = \omega_c / 2\pi

        (0.067 Hz at the defaults k = 1, acc_tau = 2 s, where k / 2 pi would say 0.16 Hz).  The heading
        correction of robust mode has its own, :attr:`heading_crossover`.

        >>> round(TQTFilter(1.0, mode="paper").crossover, 4), round(TQTFilter(1.0).crossover, 4)
        (0.1592, 0.0667)
        """
        if self.mode == "paper":
            return crossover_from_gain(self.k)
        k2, a2 = self.k * self.k, 1.0 / (self.acc_tau * self.acc_tau)
        w2 = 0.5 * (math.sqrt((k2 + a2) ** 2 + 4.0 * k2 * a2) - (k2 + a2))
        return math.sqrt(w2) / _TWO_PI

    @property
    def heading_crossover(self) -> float:
        r"""robust mode: the heading correction's crossover in Hz, :math:`k_{heading} / 2\pi` (below it the
        heading follows the magnetometer, above it the gyro; 0.008 Hz at the default 0.05)."""
        return crossover_from_gain(self.k_heading)

    def reset(self, q: ArrayLike | None = None) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    _TUNABLE = ("k", "rho", "k_heading", "acc_tau", "mag_norm_tol", "mag_dip_tol", "bias_tau")

    def retune(self, **gains: float) -> None:
        """Change gains while running (``k``, ``rho``, ``k_heading``, ``acc_tau``...); the state is kept.

        >>> f = TQTFilter()
        >>> f.retune(k=0.5, k_heading=0.1)
        >>> f.k, f.k_heading
        (0.5, 0.1)
        """
        for name, value in gains.items():
            if name not in self._TUNABLE:
                raise ValueError(f"cannot retune {name!r}; tunable: {', '.join(self._TUNABLE)}")
            value = float(value)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
            if value == 0.0 and name in ("acc_tau", "bias_tau"):  # time constants: as the constructor says
                raise ValueError(f"{name} must be > 0, got {value!r}")
            setattr(self, name, value)
        self._dt = -1.0  # recompute the per-step coefficients


class TQTFilter(_TQTParams):
    r"""McGhee / Bachmann's quaternion MARG filter for one sensor, ``mode="robust"`` or ``"paper"``.

    ``update(gyro, acc, mag, dt)`` returns the orientation ``(w, x, y, z)`` (sensor -> NWU earth) as plain
    floats.  The filter starts from the first valid accelerometer / magnetometer pair (TRIAD,
    :func:`pointat.maths.fusion.accmag_quat`) and learns the magnetic dip from the angle between the two
    measured vectors there, unless ``dip`` is given.  Every step ends with a normalisation.

    **paper** -- the seeds' filter (VRST Eq. 15, Patent Eq. 16) with the sign of gravity fixed: every step
    one (or ``iterations``) Gauss-Newton cycle of the 3x3 reduced form (Patent Eq. 29) on the normalised
    accelerometer and magnetometer, magnetometer rows weighted by ``rho``, fed back with gain ``k``:

    .. math::
        \hat q_{n+1} = \hat q_n \otimes \exp\!\Big(\tfrac{\Delta t}{2}\big(\omega + 2k\,\Delta v\big)\Big),
        \qquad \Delta v = (X_v^T X_v)^{-1} X_v^T \varepsilon(\hat q_n)

    the exact integral over one sample of Theory Eqs. 17-18 (both terms are :math:`\hat q \otimes` a pure
    vector).  As in VRST Eq. 15 the residual compares the *new* measurement with the *previous* estimate, so
    under a constant rate the estimate settles one sample *ahead* of the motion, by :math:`\omega\Delta t`
    (0.57 deg at 1 rad/s and 100 Hz).  With one of the two vectors invalid,
    :math:`\Delta v` is the minimum-norm Gauss-Newton step of the other alone.

    **robust** (default) -- the same Gauss-Newton corrections, decoupled, after the propagation
    :math:`\hat q^- = \hat q_n \otimes \exp(\tfrac{\Delta t}{2}(\omega - b))`, plus four extensions:

    1. *The magnetometer corrects heading only.*  Gravity rows and magnetometer rows are solved separately;
       the magnetic correction is projected onto the earth vertical: the one-parameter Gauss-Newton fit of
       the heading, solved exactly, :math:`\psi = \mathrm{atan2}(B^e_y, B^e_x)` with
       :math:`B^e = \hat q \otimes B \otimes \hat q^*`, applied as :math:`q_z(-\alpha_\psi \psi) \otimes
       \hat q` with its own small gain, :math:`\alpha_\psi = k_{heading}\Delta t`.  Magnetic disturbances
       can then never tilt the estimate.
    2. *Gyro bias learned at rest*, not by an integral term (which would also learn acceleration errors
       as bias).  Rest = gyro and accelerometer within ``rest_gyro`` / ``rest_acc`` of their 0.5 s low-pass
       for ``rest_time`` seconds, with the gyro low-pass below ``bias_clip``; at rest the bias follows the
       gyro low-pass, :math:`b \leftarrow b + (1 - e^{-\Delta t/\tau_b})(\bar\omega - b)`.
    3. *Time-weighted summing of acceleration* (Patent col. 4): the vertical is the direction of the
       acceleration low-passed in the earth frame, :math:`e \leftarrow e + (1 - e^{-\Delta t/\tau_a})
       (\hat q^- \otimes a \otimes \hat q^{-*} - e)`; every correction of :math:`\hat q` turns
       :math:`e` with it, so past samples stay in the current frame.  Linear accelerations average out,
       gravity does not.  The gravity rows' Gauss-Newton fit, solved exactly (the rotation by
       :math:`\theta = \angle(e, \text{up})` about :math:`e \times \text{up}`), is applied with
       :math:`\alpha = k\Delta t`.
    4. *Magnetic gating.*  The magnetometer is ignored while its norm deviates more than
       ``mag_norm_tol`` (relative) or its dip more than ``mag_dip_tol`` from the reference, learned on the
       first sample and refined at rest (within the gate only).  Gating on the accelerometer norm is not
       done: it made every variant worse on BROAD.

    ``use_gyro=False`` gives accelerometer / magnetometer only tracking (VRST §4.4): no propagation, the
    corrections alone (give ``k`` - and in robust mode ``k_heading`` - values fast enough for the motion,
    e.g. 5-20 1/s).

    Bad input never poisons the state: a non-finite gyro skips the propagation, a zero or non-finite
    accelerometer or magnetometer skips that correction, a bad ``dt`` skips the step; :attr:`flags` says
    what happened and the output is never NaN.  A *zero* gyro is valid (perfect rest).

    Parameters
    ----------
    k : float, optional
        Gravity-correction gain (1/s), :math:`\alpha = k\Delta t` (VRST Eq. 14, capped at 1), errors decay
        as :math:`e^{-kt}`; crossover :attr:`crossover` (paper :math:`f_c = k/2\pi`, Theory Eq. 59,
        :func:`gain_from_crossover`; robust lower, as it low-passes the acceleration first).  Default: robust
        1.0, paper 0.1.
    rho : float, keyword-only
        Magnetometer weight (Theory Eq. 57), paper mode.  Default 0.5.
    iterations : int, keyword-only
        Gauss-Newton cycles per sample, paper mode (robust mode solves its decoupled fits exactly).
    mode : {"robust", "paper"}, keyword-only
    use_gyro : bool, keyword-only
        ``False``: accelerometer / magnetometer only tracking.
    dip : float, optional, keyword-only
        Magnetic dip (radians, positive below the horizon); default: learned from the first valid sample.
    k_heading : float, keyword-only
        Robust mode: heading-correction gain (1/s).  Default 0.05.
    acc_tau : float, keyword-only
        Robust mode: time constant (s) of the earth-frame acceleration low-pass.  Default 2.0.
    mag_norm_tol, mag_dip_tol : float, keyword-only
        Robust mode: magnetic gate, relative norm deviation (0.1) and dip deviation in radians (5°).
    rest_time, rest_gyro, rest_acc, bias_tau, bias_clip : float, keyword-only
        Robust mode rest detection: minimum duration (s, 1.5), gyro deviation (rad/s, 2°/s), accelerometer
        deviation relative to its norm (0.05, ~0.5 m/s²), bias time constant (s, 5.0), largest bias learned
        (rad/s per axis, 2°/s).

    Notes
    -----
    One parameter set for every motion, chosen on the ten BROAD trials (Laidig et al. 2021; one is vendored
    in ``pointat/data``), with round values on a flat optimum (mean total RMSE 1.94°, leave-one-trial-out
    2.04°; VQF, the state of the art, 2.45° tuned):

    * ``k = 1`` (f_c ≈ 0.16 Hz): the tilt follows the averaged vertical within about a second; the
      smoothing is the 2 s summing of extension 3 (the patent's "time weighted summing"; 2-3 s are within
      0.04° of each other).
    * ``k_heading = 0.05`` (a 20 s time constant): heading errors are dominated by the field varying over
      the room; a slow heading correction lets the gyro carry the heading through them (0.03-0.07 differ
      by < 0.1°).
    * ``bias_tau = 5`` s averages the gyro noise at rest; the rest and gate thresholds are VQF's
      (Laidig & Seel 2023) and the REFERENCE's (10 %, 5°).
    * Paper mode: ``k = 0.1, rho = 0.5`` (f_c ≈ 0.016 Hz) is the best plain setting (5.09°); McGhee
      suggests 0.1 <= k <= 1.

    >>> f = TQTFilter(mode="paper")
    >>> _ = f.update((0.0, 0.0, 0.0), (0.0, 0.0, 9.81), (20.0, 0.0, -40.0), 0.01)
    >>> q = f.update((float("nan"), 0.0, 0.0), (0.0, 0.0, 0.0), (20.0, 0.0, -40.0), 0.01)
    >>> f.flags == TQTFlags.GYRO_INVALID | TQTFlags.ACC_INVALID
    True
    >>> [round(c, 9) for c in q]
    [1.0, 0.0, 0.0, 0.0]
    """

    # -- state ---------------------------------------------------------------------------------------------

    def reset(self, q: ArrayLike | None = None) -> None:
        """Forget everything; start again from ``q`` (sensor -> NWU) or from the next valid acc / mag pair.

        The gyro bias, rest timer, acceleration low-pass and magnetic reference are cleared too (the dip
        given to the constructor is kept).

        Parameters
        ----------
        q : array_like, shape (4,), optional
            Known orientation; normalised here.
        """
        self._initialised = False
        self._w, self._x, self._y, self._z = 1.0, 0.0, 0.0, 0.0
        if q is not None:
            qn = quat_normalize(q)
            self._w, self._x, self._y, self._z = (float(c) for c in qn)
            self._initialised = True
        self._flags = 0 if self._initialised else _UNINITIALISED
        self._bias = (0.0, 0.0, 0.0)
        self._rest_t = 0.0
        self._lp_gyr: tuple[float, float, float] | None = None
        self._lp_acc = (0.0, 0.0, 0.0)
        self._acc_e: tuple[float, float, float] | None = None  # earth-frame acceleration low-pass
        self._a2_max = _INF  # ACC_LIMIT times the first reading, squared, once there is one
        self._a_over = 0  # samples in a row beyond it
        self._mag_norm: float | None = None  # reference |B|
        self._dip_ref: float | None = self.dip
        self._n = (0.0, 0.0, 0.0) if self.dip is None else (math.cos(self.dip), 0.0, -math.sin(self.dip))
        self._dt = -1.0

    @property
    def q(self) -> tuple[float, float, float, float]:
        """Current orientation ``(w, x, y, z)``, sensor -> NWU."""
        return (self._w, self._x, self._y, self._z)

    @property
    def flags(self) -> TQTFlags:
        """:class:`TQTFlags` of the last update."""
        return TQTFlags(self._flags)

    @property
    def flag_bits(self) -> int:
        """:attr:`flags` as a plain ``int``, for a caller on every sample (an enum flag costs ~0.5 µs)."""
        return self._flags

    @property
    def initialised(self) -> bool:
        """Whether the orientation has been set (first valid acc / mag pair, or :meth:`reset` with ``q``)."""
        return self._initialised

    @property
    def bias(self) -> tuple[float, float, float]:
        """Gyro bias learned at rest (rad/s, sensor frame; robust mode)."""
        return self._bias

    @property
    def magnetic_dip(self) -> float | None:
        """Dip reference in radians (``None`` until learned)."""
        return self._dip_ref

    # -- update --------------------------------------------------------------------------------------------

    def update(
        self, gyro: ArrayLike, acc: ArrayLike, mag: ArrayLike, dt: float
    ) -> tuple[float, float, float, float]:
        r"""Advance by one sample.

        Parameters
        ----------
        gyro : sequence of 3 floats
            Angular rate (rad/s), sensor frame.
        acc : sequence of 3 floats
            Specific force (+g up at rest; m/s² or any unit), sensor frame.
        mag : sequence of 3 floats
            Magnetic field (any unit), sensor frame.
        dt : float
            Time since the previous sample, seconds.

        Returns
        -------
        tuple of 4 floats
            ``(w, x, y, z)``, sensor -> NWU; never NaN.
        """
        # plain Python floats are several times faster than numpy scalars in the arithmetic below
        gx, gy, gz = gyro.tolist() if isinstance(gyro, np.ndarray) else gyro
        ax, ay, az = acc.tolist() if isinstance(acc, np.ndarray) else acc
        mx, my, mz = mag.tolist() if isinstance(mag, np.ndarray) else mag
        dt = float(dt)
        if not 0.0 < dt < _INF:  # also catches NaN
            self._flags = _DT_INVALID | (0 if self._initialised else _UNINITIALISED)
            return (self._w, self._x, self._y, self._z)
        g_ok = gx * gx + gy * gy + gz * gz < MAX_RATE_SQUARED  # NaN compares False
        a2 = ax * ax + ay * ay + az * az
        if a2 < self._a2_max:
            a_ok = 0.0 < a2
            if self._a_over:
                self._a_over = 0
        else:  # beyond the limit (or NaN): a glitch, unless it lasts
            a_ok = self._over_limit(a2)
        m2 = mx * mx + my * my + mz * mz
        m_ok = 0.0 < m2 < _INF
        flags = (0 if g_ok else _GYRO_INVALID) | (0 if a_ok else _ACC_INVALID) | (0 if m_ok else _MAG_INVALID)
        if self._acc_e is None or self._mag_norm is None:
            was_initialised = self._initialised
            self._learn(a_ok, m_ok, g_ok, (gx, gy, gz), (ax, ay, az), (mx, my, mz))
            if not self._initialised:
                self._flags = flags | _UNINITIALISED
                return (self._w, self._x, self._y, self._z)
            if not was_initialised:  # this sample set the orientation: nothing more to do
                self._flags = flags
                return (self._w, self._x, self._y, self._z)
        m_use = m_ok and self._mag_norm is not None  # no reference yet: nothing to compare with
        if self.mode == "paper":
            flags |= self._update_paper(g_ok, gx, gy, gz, a_ok, ax, ay, az, a2, m_use, mx, my, mz, m2, dt)
        else:
            flags |= self._update_robust(g_ok, gx, gy, gz, a_ok, ax, ay, az, m_use, mx, my, mz, dt)
        self._flags = flags
        return (self._w, self._x, self._y, self._z)

    def _over_limit(self, a2: float) -> bool:
        """A reading beyond :data:`ACC_LIMIT`: refused, but the :data:`ACC_RELEARN`-th in a row sets the
        limit anew (NaN and infinity are never taken)."""
        if not a2 < _INF:
            self._a_over = 0
            return False
        self._a_over += 1
        if self._a_over < ACC_RELEARN:
            return False
        self._a2_max, self._a_over = _ACC_LIMIT_SQUARED * a2, 0
        return True

    def _learn(
        self,
        a_ok: bool,
        m_ok: bool,
        g_ok: bool,
        gyro: tuple[float, float, float],
        acc: tuple[float, float, float],
        mag: tuple[float, float, float],
    ) -> None:
        """Learn what is still unknown: the orientation (TRIAD), the low-pass states, the magnetic reference."""
        if not self._initialised:
            if not (a_ok and m_ok):
                return
            q0 = accmag_quat(acc, mag)
            if q0 is None:  # acc and mag (nearly) parallel: no heading, wait for a better sample
                return
            self._w, self._x, self._y, self._z = (float(c) for c in q0)
            self._initialised = True
        if self._acc_e is None and a_ok:
            self._acc_e = _rotate(self._w, self._x, self._y, self._z, *acc)
            self._a2_max = _ACC_LIMIT_SQUARED * (acc[0] * acc[0] + acc[1] * acc[1] + acc[2] * acc[2])
            self._lp_acc = acc
            self._lp_gyr = gyro if g_ok else (0.0, 0.0, 0.0)
        if self._mag_norm is None and m_ok and (a_ok or self._dip_ref is not None):
            # dip from the angle between the measured vectors (independent of the estimate)
            self._mag_norm = math.sqrt(mag[0] * mag[0] + mag[1] * mag[1] + mag[2] * mag[2])
            if self._dip_ref is None:
                up = math.sqrt(acc[0] * acc[0] + acc[1] * acc[1] + acc[2] * acc[2])
                sin_dip = -(acc[0] * mag[0] + acc[1] * mag[1] + acc[2] * mag[2]) / (up * self._mag_norm)
                self._dip_ref = math.asin(max(-1.0, min(1.0, sin_dip)))
                self._n = (math.cos(self._dip_ref), 0.0, -math.sin(self._dip_ref))

    def _update_paper(
        self,
        g_ok: bool,
        gx: float,
        gy: float,
        gz: float,
        a_ok: bool,
        ax: float,
        ay: float,
        az: float,
        a2: float,
        m_ok: bool,
        mx: float,
        my: float,
        mz: float,
        m2: float,
        dt: float,
    ) -> int:
        if dt != self._dt:
            self._coefficients(dt)
        w, x, y, z = self._w, self._x, self._y, self._z
        vx = vy = vz = 0.0
        if a_ok or m_ok:
            ia = 1.0 / math.sqrt(a2) if a_ok else 0.0
            im = 1.0 / math.sqrt(m2) if m_ok else 0.0
            vx, vy, vz = _gauss_newton_floats(
                w,
                x,
                y,
                z,
                ax * ia,
                ay * ia,
                az * ia,
                mx * im,
                my * im,
                mz * im,
                a_ok,
                m_ok,
                self._n,
                self.rho,
                self.iterations,
            )
        alpha = self._alpha
        if g_ok and self.use_gyro:
            h = 0.5 * dt
            hx, hy, hz = h * gx + alpha * vx, h * gy + alpha * vy, h * gz + alpha * vz
        else:
            hx, hy, hz = alpha * vx, alpha * vy, alpha * vz
        w, x, y, z = _mul_exp(w, x, y, z, hx, hy, hz)
        self._store(w, x, y, z)
        return 0

    def _update_robust(
        self,
        g_ok: bool,
        gx: float,
        gy: float,
        gz: float,
        a_ok: bool,
        ax: float,
        ay: float,
        az: float,
        m_ok: bool,
        mx: float,
        my: float,
        mz: float,
        dt: float,
    ) -> int:
        if dt != self._dt:
            self._coefficients(dt)
        flags = 0
        w, x, y, z = self._w, self._x, self._y, self._z
        bx, by, bz = self._bias
        # (0) propagation with the bias-corrected rate, exact over the sample
        if g_ok and self.use_gyro:
            h = 0.5 * dt
            w, x, y, z = _mul_exp(w, x, y, z, h * (gx - bx), h * (gy - by), h * (gz - bz))
        # (2) rest detection and gyro bias
        rest = False
        if g_ok and a_ok:
            c = self._c_rest
            lgx, lgy, lgz = self._lp_gyr  # type: ignore[misc]
            lax, lay, laz = self._lp_acc
            lgx += c * (gx - lgx)
            lgy += c * (gy - lgy)
            lgz += c * (gz - lgz)
            lax += c * (ax - lax)
            lay += c * (ay - lay)
            laz += c * (az - laz)
            self._lp_gyr = (lgx, lgy, lgz)
            self._lp_acc = (lax, lay, laz)
            dgx, dgy, dgz = gx - lgx, gy - lgy, gz - lgz
            dax, day, daz = ax - lax, ay - lay, az - laz
            clip = self.bias_clip
            thr = self.rest_acc
            if (
                dgx * dgx + dgy * dgy + dgz * dgz < self.rest_gyro * self.rest_gyro
                and dax * dax + day * day + daz * daz < thr * thr * (lax * lax + lay * lay + laz * laz)
                and -clip < lgx < clip
                and -clip < lgy < clip
                and -clip < lgz < clip
            ):
                self._rest_t += dt
                if self._rest_t >= self.rest_time:
                    rest = True
                    flags |= _REST
                    c = self._c_bias
                    self._bias = (bx + c * (lgx - bx), by + c * (lgy - by), bz + c * (lgz - bz))
            else:
                self._rest_t = 0.0
        else:
            self._rest_t = 0.0
        # (3) gravity: earth-frame acceleration low-pass, Gauss-Newton alignment with the vertical
        if a_ok:
            ex, ey, ez = self._acc_e  # type: ignore[misc]
            aex, aey, aez = _rotate(w, x, y, z, ax, ay, az)
            c = self._c_acc
            ex += c * (aex - ex)
            ey += c * (aey - ey)
            ez += c * (aez - ez)
            eh2 = ex * ex + ey * ey
            if eh2 > 0.0:
                eh = math.sqrt(eh2)
                f = 0.5 * self._alpha * math.atan2(eh, ez) / eh  # half the correction angle, per |e_h|
                sx, sy = f * ey, -f * ex  # half rotation vector about (e x up)
                s2 = sx * sx + sy * sy
                if s2 < _EXP_TAYLOR:
                    cw, sinc = 1.0 - 0.5 * s2, 1.0 - s2 / 6.0
                else:
                    s = math.sqrt(s2)
                    cw, sinc = math.cos(s), math.sin(s) / s
                sx *= sinc
                sy *= sinc
                # q <- C q and e <- C e, C = (cw, sx, sy, 0) in the earth frame
                w, x, y, z = (
                    cw * w - sx * x - sy * y,
                    cw * x + sx * w + sy * z,
                    cw * y + sy * w - sx * z,
                    cw * z + sx * y - sy * x,
                )
                ex, ey, ez = _rotate(cw, sx, sy, 0.0, ex, ey, ez)
            self._acc_e = (ex, ey, ez)
        # (1) + (4) magnetometer: gated heading-only correction
        if m_ok:
            bex, bey, bez = _rotate(w, x, y, z, mx, my, mz)
            bh = math.hypot(bex, bey)
            norm = math.sqrt(bh * bh + bez * bez)
            dip = math.atan2(-bez, bh)
            ref = self._mag_norm
            if abs(norm - ref) > self.mag_norm_tol * ref or abs(dip - self._dip_ref) > self.mag_dip_tol:  # type: ignore[operator]
                flags |= _MAG_DISTURBED
            elif bh > 0.0:
                half = -0.5 * self._alpha_mag * math.atan2(bey, bex)
                cz, sz = math.cos(half), math.sin(half)
                w, x, y, z = cz * w - sz * z, cz * x - sz * y, cz * y + sz * x, cz * z + sz * w
                if self._acc_e is not None:  # the low-pass lives in the estimated earth frame: turn it too
                    ex, ey, ez = self._acc_e
                    c2, s2 = cz * cz - sz * sz, 2.0 * sz * cz
                    self._acc_e = (c2 * ex - s2 * ey, s2 * ex + c2 * ey, ez)
                if rest:
                    c = self._c_ref
                    self._mag_norm = ref + c * (norm - ref)  # type: ignore[operator]
                    self._dip_ref = self._dip_ref + c * (dip - self._dip_ref)  # type: ignore[operator]
        self._store(w, x, y, z)
        return flags

    def _store(self, w: float, x: float, y: float, z: float) -> None:
        n2 = w * w + x * x + y * y + z * z
        if 0.0 < n2 < _INF:
            n = 1.0 / math.sqrt(n2)
            self._w, self._x, self._y, self._z = w * n, x * n, y * n, z * n


def _rotate(
    w: float, x: float, y: float, z: float, vx: float, vy: float, vz: float
) -> tuple[float, float, float]:
    """:math:`q \\otimes v \\otimes q^*` for floats: ``v + w t + u x t`` with ``t = 2 u x v``."""
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (vx + w * tx + y * tz - z * ty, vy + w * ty + z * tx - x * tz, vz + w * tz + x * ty - y * tx)


def _mul_exp(
    w: float, x: float, y: float, z: float, hx: float, hy: float, hz: float
) -> tuple[float, float, float, float]:
    """:math:`q \\otimes \\exp(0, h)` for floats (``h`` = half the rotation vector, body frame)."""
    n2 = hx * hx + hy * hy + hz * hz
    if n2 < _EXP_TAYLOR:
        c, s = 1.0 - 0.5 * n2, 1.0 - n2 / 6.0
    else:
        n = math.sqrt(n2)
        c, s = math.cos(n), math.sin(n) / n
    hx *= s
    hy *= s
    hz *= s
    return (
        w * c - x * hx - y * hy - z * hz,
        w * hx + x * c + y * hz - z * hy,
        w * hy - x * hz + y * c + z * hx,
        w * hz + x * hy - y * hx + z * c,
    )


def _normal_equations(rw, rx, ry, rz, hx, hy, hz, bx, by, bz, nx, nz, r2):  # type: ignore[no-untyped-def]
    r"""One reduced Gauss-Newton system, on floats or (element-wise) on arrays.

    With :math:`a, c` the computed up and field of :math:`\hat q` (rows of its matrix) and :math:`h, b` the
    measured ones: :math:`X^TX = 4[(I - aa^T) + \rho^2(I - cc^T)]`,
    :math:`X^T\varepsilon = 2(h\times a + \rho^2\, b\times c)`.  Returns the gravity and the field
    residual cross products :math:`h\times a`, :math:`b\times c`, the determinant of the bracket, and a
    ``solve(det=det)`` giving :math:`\Delta v` (only meaningful where the determinant is not ~0).
    """
    # computed up = R[2, :], computed field = nx R[0, :] + nz R[2, :]
    ux = 2.0 * (rx * rz - rw * ry)
    uy = 2.0 * (ry * rz + rw * rx)
    uz = 1.0 - 2.0 * (rx * rx + ry * ry)
    cx = nx * (1.0 - 2.0 * (ry * ry + rz * rz)) + nz * ux
    cy = nx * 2.0 * (rx * ry - rw * rz) + nz * uy
    cz = nx * 2.0 * (rx * rz + rw * ry) + nz * uz
    ha = (hy * uz - hz * uy, hz * ux - hx * uz, hx * uy - hy * ux)
    bc = (by * cz - bz * cy, bz * cx - bx * cz, bx * cy - by * cx)
    d = 1.0 + r2
    m00 = d - ux * ux - r2 * cx * cx
    m11 = d - uy * uy - r2 * cy * cy
    m22 = d - uz * uz - r2 * cz * cz
    m01 = -ux * uy - r2 * cx * cy
    m02 = -ux * uz - r2 * cx * cz
    m12 = -uy * uz - r2 * cy * cz
    c00 = m11 * m22 - m12 * m12
    c01 = m02 * m12 - m01 * m22
    c02 = m01 * m12 - m02 * m11
    det = m00 * c00 + m01 * c01 + m02 * c02

    def solve(det=det):  # type: ignore[no-untyped-def]
        gx, gy, gz = ha[0] + r2 * bc[0], ha[1] + r2 * bc[1], ha[2] + r2 * bc[2]
        c11 = m00 * m22 - m02 * m02
        c12 = m01 * m02 - m00 * m12
        c22 = m00 * m11 - m01 * m01
        k = 0.5 / det
        return (
            k * (c00 * gx + c01 * gy + c02 * gz),
            k * (c01 * gx + c11 * gy + c12 * gz),
            k * (c02 * gx + c12 * gy + c22 * gz),
        )

    return ha, bc, det, solve


def _gauss_newton_floats(
    w: float,
    x: float,
    y: float,
    z: float,
    hx: float,
    hy: float,
    hz: float,
    bx: float,
    by: float,
    bz: float,
    a_ok: bool,
    m_ok: bool,
    n: tuple[float, float, float],
    rho: float,
    iterations: int,
) -> tuple[float, float, float]:
    r"""Reduced Gauss-Newton :math:`\Delta v` (Patent Eq. 29 with the transpose; rho on the magnetometer rows).

    With :math:`a, c` the computed up and field (unit) and :math:`h, b` the measured ones:
    :math:`X^TX = 4[(I - aa^T) + \rho^2(I - cc^T)]`, :math:`X^T\varepsilon = 2(h\times a + \rho^2\, b\times c)`.
    Iterations compose :math:`\hat q \otimes \exp(\Delta v_i)`; the total is returned as one log.
    """
    nx, _, nz = n
    r2 = rho * rho
    rw, rx, ry, rz = w, x, y, z
    vx = vy = vz = 0.0
    for i in range(iterations):
        if i:
            rw, rx, ry, rz = _mul_exp(rw, rx, ry, rz, vx, vy, vz)
        (ax_, ay_, az_), (mx_, my_, mz_), det, solve = _normal_equations(
            rw, rx, ry, rz, hx, hy, hz, bx, by, bz, nx, nz, r2
        )
        if a_ok and m_ok and det > 1e-9 * r2:
            vx, vy, vz = solve()
        elif a_ok:  # gravity rows alone (minimum-norm step), also when the field is parallel to gravity
            vx, vy, vz = 0.5 * ax_, 0.5 * ay_, 0.5 * az_
        else:  # magnetometer rows alone
            vx, vy, vz = 0.5 * mx_, 0.5 * my_, 0.5 * mz_
        if iterations == 1:
            return vx, vy, vz
    rw, rx, ry, rz = _mul_exp(rw, rx, ry, rz, vx, vy, vz)
    # total step = log(q* r), w >= 0
    tw = w * rw + x * rx + y * ry + z * rz
    tx = w * rx - x * rw - y * rz + z * ry
    ty = w * ry + x * rz - y * rw - z * rx
    tz = w * rz - x * ry + y * rx - z * rw
    if tw < 0.0:
        tw, tx, ty, tz = -tw, -tx, -ty, -tz
    s = math.sqrt(tx * tx + ty * ty + tz * tz)
    if s < 1e-300:
        return 0.0, 0.0, 0.0
    f = math.atan2(s, tw) / s
    return f * tx, f * ty, f * tz


# ----------------------------------------------------------------------------------------------------------
# The same filter for N sensors at once
# ----------------------------------------------------------------------------------------------------------


class TQTBank(_TQTParams):
    r""":class:`TQTFilter` vectorised over ``n`` sensors (a body suit: ~15), same parameters, same results.

    State is ``(n, 4)``; :meth:`update` takes ``(n, 3)`` arrays and one ``dt`` and returns ``(n, 4)``
    quaternions (sensor -> NWU).  Every sensor follows exactly the algorithm of :class:`TQTFilter` (its own
    initialisation, rest detection, bias, references and flags), so a bank agrees with ``n`` independent
    filters to rounding (~1e-13).

    Two ways to run it (``backend``): ``numba`` runs the robust update as one compiled loop over the
    sensors (:mod:`pointat.maths.tqt_compiled`; ``pip install "pointat[fast]"``), well under a
    microsecond per sensor; ``numpy`` vectorises across the sensors, whose per-call overhead makes one
    step cost about as much as ~50 scalar updates (~0.3 ms) whatever ``n``, so that it only pays off from
    about 50 sensors.  ``auto`` (default) takes numba when it is installed and the mode is robust.

    Parameters
    ----------
    n : int
        Number of sensors.
    k, **params
        As :class:`TQTFilter`.
    backend : {"auto", "numba", "numpy"}
        How the update runs (the results agree to rounding).

    >>> bank = TQTBank(2)
    >>> acc = np.array([[0.0, 0.0, 9.81], [0.0, 0.0, 0.0]])           # sensor 1: accelerometer dropped out
    >>> q = bank.update(np.zeros((2, 3)), acc, np.tile([20.0, 0.0, -40.0], (2, 1)), 0.01)
    >>> np.round(q, 9).tolist()
    [[1.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]]
    >>> bank.flags.tolist() == [0, TQTFlags.ACC_INVALID | TQTFlags.UNINITIALISED]
    True
    """

    def __init__(self, n: int, k: float | None = None, *, backend: str = "auto", **params: object) -> None:
        if int(n) != n or n < 1:
            raise ValueError(f"n must be a positive integer, got {n!r}")
        self.n = int(n)
        super().__init__(k, **params)  # type: ignore[arg-type]
        from pointat.maths import tqt_compiled

        if backend not in ("auto", "numba", "numpy"):
            raise ValueError(f"backend must be 'auto', 'numba' or 'numpy', got {backend!r}")
        if backend == "numba" and (not tqt_compiled.available() or self.mode != "robust"):
            raise ValueError(
                "backend='numba' needs numba (pip install \"pointat[fast]\") and mode='robust'"
                f" (numba installed: {tqt_compiled.available()}, mode: {self.mode})"
            )
        numba = backend == "numba" or (
            backend == "auto" and tqt_compiled.available() and self.mode == "robust"
        )
        self.backend = "numba" if numba else "numpy"
        self._kernel = tqt_compiled.robust_step if numba else None
        if numba and not tqt_compiled.compiled():
            # numba compiles the kernel (or loads it from its cache) on its first call, up to a second or
            # two: here, where a patch loads, not on the first update, where it would stall a live one
            zeros = np.zeros((self.n, 3))
            self.update(zeros, zeros, zeros, 0.01)
            self.reset()

    def reset(self, q: ArrayLike | None = None) -> None:
        """Forget everything (all sensors); start from ``q`` or from each sensor's next valid acc / mag pair.

        Parameters
        ----------
        q : array_like, shape (4,) or (n, 4), optional
            Known orientations (sensor -> NWU); normalised here.
        """
        n = self.n
        # state stored component-major, (4, n) and (3, n): rows are cheap views for the arithmetic
        self._q = np.zeros((4, n))
        self._q[0] = 1.0
        self._initialised = np.zeros(n, dtype=bool)
        if q is not None:
            self._q = np.array(np.broadcast_to(quat_normalize(q), (n, 4)).T)
            self._initialised[:] = True
        self._flags = np.where(self._initialised, 0, _UNINITIALISED).astype(np.int64)
        self._bias = np.zeros((3, n))
        self._rest_t = np.zeros(n)
        self._lp_gyr = np.zeros((3, n))
        self._lp_acc = np.zeros((3, n))
        self._acc_e = np.zeros((3, n))
        self._acc_known = np.zeros(n, dtype=bool)
        self._a2_max = np.full(n, _INF)  # as TQTFilter's
        self._a_over = np.zeros(n, dtype=np.int64)
        self._mag_norm = np.zeros(n)
        self._mag_known = np.zeros(n, dtype=bool)
        dip = math.nan if self.dip is None else self.dip
        self._dip_ref = np.full(n, dip)
        self._nref = np.tile([[math.cos(dip)], [0.0], [-math.sin(dip)]], (1, n))
        self._dt = -1.0

    @property
    def q(self) -> np.ndarray:
        """Current orientations, shape (n, 4), sensor -> NWU (a copy)."""
        return self._q.T.copy()

    @property
    def flags(self) -> np.ndarray:
        """Per-sensor :class:`TQTFlags` bits of the last update, int array of shape (n,)."""
        return self._flags.copy()

    @property
    def initialised(self) -> np.ndarray:
        """Per-sensor bool, shape (n,)."""
        return self._initialised.copy()

    @property
    def bias(self) -> np.ndarray:
        """Gyro biases learned at rest, shape (n, 3), rad/s (robust mode)."""
        return self._bias.T.copy()

    @property
    def magnetic_dip(self) -> np.ndarray:
        """Dip references in radians, shape (n,) (NaN until learned)."""
        return np.where(self._mag_known | (self.dip is not None), self._dip_ref, np.nan)

    #: The per-sensor state, each array's last axis the sensor: what an absent sensor keeps.
    _STATE = (
        "_q", "_initialised", "_flags", "_bias", "_rest_t", "_lp_gyr", "_lp_acc", "_acc_e", "_acc_known",
        "_a2_max", "_a_over", "_mag_norm", "_mag_known", "_dip_ref", "_nref",
    )  # fmt: skip

    def update(
        self, gyro: ArrayLike, acc: ArrayLike, mag: ArrayLike, dt: float, present: ArrayLike | None = None
    ) -> np.ndarray:
        """Advance all sensors by one sample.

        Parameters
        ----------
        gyro : array_like, shape (n, 3)
            Angular rates, rad/s.
        acc : array_like, shape (n, 3)
            Specific forces (+g up at rest).
        mag : array_like, shape (n, 3)
            Magnetic fields.
        dt : float
            Seconds since the previous sample (common to all sensors).
        present : array_like of bool, shape (n,), optional
            Which sensors have a sample in this update (default: all).  An absent sensor is left exactly
            as it was, its flags included: a lost packet is not a bad sample (which, as in
            :class:`TQTFilter`, also ends a rest).

        Returns
        -------
        numpy.ndarray, shape (n, 4)
            Orientations ``(w, x, y, z)``, sensor -> NWU; never NaN.
        """
        if present is None:
            return self._step(gyro, acc, mag, dt)
        absent = ~np.asarray(present, dtype=bool)
        if absent.shape != (self.n,):
            raise ValueError(f"present must have shape ({self.n},), got {absent.shape}")
        if not absent.any():
            return self._step(gyro, acc, mag, dt)
        kept = [getattr(self, name)[..., absent].copy() for name in self._STATE]
        self._step(gyro, acc, mag, dt)
        for name, value in zip(self._STATE, kept, strict=True):
            getattr(self, name)[..., absent] = value
        return self._q.T.copy()

    def _step(self, gyro: ArrayLike, acc: ArrayLike, mag: ArrayLike, dt: float) -> np.ndarray:
        shape = (self.n, 3)
        g = np.asarray(gyro, dtype=float)
        a = np.asarray(acc, dtype=float)
        m = np.asarray(mag, dtype=float)
        if g.shape != shape or a.shape != shape or m.shape != shape:
            raise ValueError(
                f"gyro, acc and mag must have shape {shape}, got {g.shape}, {a.shape}, {m.shape}"
            )
        dt = float(dt)
        if not 0.0 < dt < _INF:
            self._flags = np.where(self._initialised, _DT_INVALID, _DT_INVALID | _UNINITIALISED)
            return self._q.T.copy()
        if self._kernel is not None:
            return self._update_compiled(g, a, m, dt)
        g, a, m = g.T, a.T, m.T
        with np.errstate(all="ignore"):
            g2 = g[0] * g[0] + g[1] * g[1] + g[2] * g[2]
            a2 = a[0] * a[0] + a[1] * a[1] + a[2] * a[2]
            m2 = m[0] * m[0] + m[1] * m[1] + m[2] * m[2]
            g_ok = g2 < MAX_RATE_SQUARED
            under = a2 < self._a2_max
            self._a_over = np.where(~under & (a2 < _INF), self._a_over + 1, 0)  # as TQTFilter._over_limit
            relearn = self._a_over >= ACC_RELEARN
            if relearn.any():
                self._a2_max = np.where(relearn, _ACC_LIMIT_SQUARED * a2, self._a2_max)
                self._a_over[relearn] = 0
            a_ok = (a2 > 0.0) & (under | relearn)
            m_ok = (m2 > 0.0) & (m2 < _INF)
            flags = np.where(g_ok, 0, _GYRO_INVALID) | np.where(a_ok, 0, _ACC_INVALID)
            flags |= np.where(m_ok, 0, _MAG_INVALID)
            was = self._initialised.copy()
            if not (self._acc_known.all() and self._mag_known.all()):
                self._learn(g_ok, a_ok, m_ok, a2, m2, g, a, m)
            active = was & self._initialised
            flags |= np.where(self._initialised, 0, _UNINITIALISED)
            m_use = m_ok & self._mag_known
            if dt != self._dt:
                self._coefficients(dt)
            if self.mode == "paper":
                q = self._update_paper(g_ok & active, a_ok, m_use, a2, m2, g, a, m, dt)
                more = 0
            else:
                q, more = self._update_robust(g_ok, a_ok, m_use, g, a, m, dt, active)
            n2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]
            good = active & (n2 > 0.0) & (n2 < _INF)
            self._q = np.where(good, q / np.sqrt(np.where(good, n2, 1.0)), self._q)
            self._flags = flags | np.where(active, more, 0)
        return self._q.T.copy()

    def _update_compiled(self, g: np.ndarray, a: np.ndarray, m: np.ndarray, dt: float) -> np.ndarray:
        if dt != self._dt:
            self._coefficients(dt)
        self._kernel(  # type: ignore[misc]
            np.ascontiguousarray(g),
            np.ascontiguousarray(a),
            np.ascontiguousarray(m),
            dt,
            self._q,
            self._initialised,
            self._flags,
            self._bias,
            self._rest_t,
            self._lp_gyr,
            self._lp_acc,
            self._acc_e,
            self._acc_known,
            self._a2_max,
            self._a_over,
            self._mag_norm,
            self._mag_known,
            self._dip_ref,
            self._nref,
            self.dip is not None,
            self.use_gyro,
            self.rest_gyro,
            self.rest_acc,
            self.rest_time,
            self.bias_clip,
            self.mag_norm_tol,
            self.mag_dip_tol,
            self._c_acc,
            self._c_rest,
            self._c_bias,
            self._c_ref,
            self._alpha,
            self._alpha_mag,
        )
        return self._q.T.copy()

    def _learn(
        self,
        g_ok: np.ndarray,
        a_ok: np.ndarray,
        m_ok: np.ndarray,
        a2: np.ndarray,
        m2: np.ndarray,
        g: np.ndarray,
        a: np.ndarray,
        m: np.ndarray,
    ) -> None:
        for i in np.flatnonzero(~self._initialised & a_ok & m_ok):
            q0 = accmag_quat(a[:, i], m[:, i])
            if q0 is not None:
                self._q[:, i] = q0
                self._initialised[i] = True
        new_acc = self._initialised & ~self._acc_known & a_ok
        if new_acc.any():
            w, x, y, z = self._q[:, new_acc]
            self._acc_e[:, new_acc] = _rotate(w, x, y, z, *a[:, new_acc])
            self._lp_acc[:, new_acc] = a[:, new_acc]
            self._lp_gyr[:, new_acc] = np.where(g_ok[new_acc], g[:, new_acc], 0.0)
            self._a2_max[new_acc] = _ACC_LIMIT_SQUARED * a2[new_acc]
            self._acc_known |= new_acc
        has_dip = self.dip is not None
        new_mag = self._initialised & ~self._mag_known & m_ok & (a_ok | has_dip)
        if new_mag.any():
            norm = np.sqrt(m2[new_mag])
            self._mag_norm[new_mag] = norm
            if not has_dip:
                an, mn = a[:, new_mag], m[:, new_mag]
                sin_dip = -(an[0] * mn[0] + an[1] * mn[1] + an[2] * mn[2]) / (np.sqrt(a2[new_mag]) * norm)
                dip = np.arcsin(np.clip(sin_dip, -1.0, 1.0))
                self._dip_ref[new_mag] = dip
                self._nref[:, new_mag] = np.array([np.cos(dip), np.zeros_like(dip), -np.sin(dip)])
            self._mag_known |= new_mag

    def _update_paper(
        self,
        g_ok: np.ndarray,
        a_ok: np.ndarray,
        m_ok: np.ndarray,
        a2: np.ndarray,
        m2: np.ndarray,
        g: np.ndarray,
        a: np.ndarray,
        m: np.ndarray,
        dt: float,
    ) -> np.ndarray:
        w, x, y, z = self._q
        ia = 1.0 / np.sqrt(np.where(a_ok, a2, 1.0))
        im = 1.0 / np.sqrt(np.where(m_ok, m2, 1.0))
        h, b = a * ia, m * im
        vx, vy, vz = _gauss_newton_arrays(
            w, x, y, z, *h, *b, a_ok, m_ok, self._nref, self.rho, self.iterations
        )
        alpha = self._alpha
        if self.use_gyro:
            half = 0.5 * dt
            prop = g_ok
            hx = np.where(prop, half * g[0] + alpha * vx, alpha * vx)
            hy = np.where(prop, half * g[1] + alpha * vy, alpha * vy)
            hz = np.where(prop, half * g[2] + alpha * vz, alpha * vz)
        else:
            hx, hy, hz = alpha * vx, alpha * vy, alpha * vz
        return np.array(_mul_exp_arrays(w, x, y, z, hx, hy, hz))

    def _update_robust(
        self,
        g_ok: np.ndarray,
        a_ok: np.ndarray,
        m_ok: np.ndarray,
        g: np.ndarray,
        a: np.ndarray,
        m: np.ndarray,
        dt: float,
        active: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:
        flags = np.zeros(self.n, dtype=int)
        w, x, y, z = self._q
        bias = self._bias
        # (0) propagation
        if self.use_gyro:
            prop = active & g_ok
            half = 0.5 * dt
            pw, px, py, pz = _mul_exp_arrays(w, x, y, z, *(half * (g - bias)))
            w, x, y, z = (
                np.where(prop, pw, w),
                np.where(prop, px, x),
                np.where(prop, py, y),
                np.where(prop, pz, z),
            )
        # (2) rest detection and bias
        both = active & g_ok & a_ok
        c = self._c_rest
        lpg = np.where(both, self._lp_gyr + c * (g - self._lp_gyr), self._lp_gyr)
        lpa = np.where(both, self._lp_acc + c * (a - self._lp_acc), self._lp_acc)
        self._lp_gyr, self._lp_acc = lpg, lpa
        dg, da = g - lpg, a - lpa
        thr, clip = self.rest_acc, self.bias_clip
        still = (
            both
            & (dg[0] * dg[0] + dg[1] * dg[1] + dg[2] * dg[2] < self.rest_gyro * self.rest_gyro)
            & (
                da[0] * da[0] + da[1] * da[1] + da[2] * da[2]
                < thr * thr * (lpa[0] ** 2 + lpa[1] ** 2 + lpa[2] ** 2)
            )
            & (np.abs(lpg) < clip).all(axis=0)
        )
        rest_t = np.where(still, self._rest_t + dt, 0.0)
        self._rest_t = np.where(active, rest_t, self._rest_t)
        rest = still & (rest_t >= self.rest_time)
        flags |= np.where(rest, _REST, 0)
        self._bias = np.where(rest, bias + self._c_bias * (lpg - bias), bias)
        # (3) gravity from the earth-frame acceleration low-pass
        tilt = active & a_ok
        if tilt.any():
            ex, ey, ez = self._acc_e
            c = self._c_acc
            aex, aey, aez = _rotate(w, x, y, z, *a)
            ex = ex + c * (aex - ex)
            ey = ey + c * (aey - ey)
            ez = ez + c * (aez - ez)
            eh2 = ex * ex + ey * ey
            corr = tilt & (eh2 > 0.0)
            eh = np.sqrt(np.where(corr, eh2, 1.0))
            f = 0.5 * self._alpha * np.arctan2(eh, ez) / eh
            sx, sy = f * ey, -f * ex
            s2 = sx * sx + sy * sy
            small = s2 < _EXP_TAYLOR
            s = np.sqrt(s2)
            cw = np.where(small, 1.0 - 0.5 * s2, np.cos(s))
            sinc = np.where(small, 1.0 - s2 / 6.0, np.sin(s) / np.where(small, 1.0, s))
            sx = sx * sinc
            sy = sy * sinc
            nw = cw * w - sx * x - sy * y
            nx = cw * x + sx * w + sy * z
            ny = cw * y + sy * w - sx * z
            nz = cw * z + sx * y - sy * x
            w, x, y, z = (
                np.where(corr, nw, w),
                np.where(corr, nx, x),
                np.where(corr, ny, y),
                np.where(corr, nz, z),
            )
            rx, ry, rz = _rotate(cw, sx, sy, 0.0, ex, ey, ez)
            ex, ey, ez = np.where(corr, rx, ex), np.where(corr, ry, ey), np.where(corr, rz, ez)
            self._acc_e = np.where(tilt, np.array([ex, ey, ez]), self._acc_e)
        # (1) + (4) gated heading-only magnetic correction
        mag = active & m_ok
        if mag.any():
            bex, bey, bez = _rotate(w, x, y, z, *m)
            bh = np.hypot(bex, bey)
            norm = np.sqrt(bh * bh + bez * bez)
            dip = np.arctan2(-bez, bh)
            ref = self._mag_norm
            off = (np.abs(norm - ref) > self.mag_norm_tol * ref) | (
                np.abs(dip - self._dip_ref) > self.mag_dip_tol
            )
            gated = mag & off
            flags |= np.where(gated, _MAG_DISTURBED, 0)
            head = mag & ~off & (bh > 0.0)
            half = -0.5 * self._alpha_mag * np.arctan2(bey, bex)
            cz, sz = np.cos(half), np.sin(half)
            nw, nx, ny, nz = cz * w - sz * z, cz * x - sz * y, cz * y + sz * x, cz * z + sz * w
            w, x, y, z = (
                np.where(head, nw, w),
                np.where(head, nx, x),
                np.where(head, ny, y),
                np.where(head, nz, z),
            )
            turn = head & self._acc_known
            c2, s2 = cz * cz - sz * sz, 2.0 * sz * cz
            ex, ey, ez = self._acc_e
            self._acc_e = np.where(turn, np.array([c2 * ex - s2 * ey, s2 * ex + c2 * ey, ez]), self._acc_e)
            learn = head & rest
            cr = self._c_ref
            self._mag_norm = np.where(learn, ref + cr * (norm - ref), ref)
            self._dip_ref = np.where(learn, self._dip_ref + cr * (dip - self._dip_ref), self._dip_ref)
        return np.array([w, x, y, z]), flags


def _mul_exp_arrays(
    w: np.ndarray, x: np.ndarray, y: np.ndarray, z: np.ndarray, hx: np.ndarray, hy: np.ndarray, hz: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Element-wise :func:`_mul_exp` (the same formulas, the Taylor branch by mask)."""
    n2 = hx * hx + hy * hy + hz * hz
    small = n2 < _EXP_TAYLOR
    n = np.sqrt(n2)
    c = np.where(small, 1.0 - 0.5 * n2, np.cos(n))
    s = np.where(small, 1.0 - n2 / 6.0, np.sin(n) / np.where(small, 1.0, n))
    hx, hy, hz = hx * s, hy * s, hz * s
    return (
        w * c - x * hx - y * hy - z * hz,
        w * hx + x * c + y * hz - z * hy,
        w * hy - x * hz + y * c + z * hx,
        w * hz + x * hy - y * hx + z * c,
    )


def _gauss_newton_arrays(
    w: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    z: np.ndarray,
    hx: np.ndarray,
    hy: np.ndarray,
    hz: np.ndarray,
    bx: np.ndarray,
    by: np.ndarray,
    bz: np.ndarray,
    a_ok: np.ndarray,
    m_ok: np.ndarray,
    n: np.ndarray,
    rho: float,
    iterations: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Element-wise :func:`_gauss_newton_floats` (the branches by mask; zero where neither vector is valid)."""
    nx, _, nz = n
    r2 = rho * rho
    both = a_ok & m_ok
    rw, rx, ry, rz = w, x, y, z
    vx = vy = vz = np.zeros_like(w)
    for i in range(iterations):
        if i:
            rw, rx, ry, rz = _mul_exp_arrays(rw, rx, ry, rz, vx, vy, vz)
        (ax_, ay_, az_), (mx_, my_, mz_), det, solve = _normal_equations(
            rw, rx, ry, rz, hx, hy, hz, bx, by, bz, nx, nz, r2
        )
        full = both & (det > 1e-9 * r2)
        fx, fy, fz = solve(np.where(full, det, 1.0))
        acc_only = a_ok & ~full
        vx = np.where(full, fx, np.where(acc_only, 0.5 * ax_, 0.5 * mx_))
        vy = np.where(full, fy, np.where(acc_only, 0.5 * ay_, 0.5 * my_))
        vz = np.where(full, fz, np.where(acc_only, 0.5 * az_, 0.5 * mz_))
        none = ~(a_ok | m_ok)
        vx, vy, vz = np.where(none, 0.0, vx), np.where(none, 0.0, vy), np.where(none, 0.0, vz)
        if iterations == 1:
            return vx, vy, vz
    rw, rx, ry, rz = _mul_exp_arrays(rw, rx, ry, rz, vx, vy, vz)
    tw = w * rw + x * rx + y * ry + z * rz
    tx = w * rx - x * rw - y * rz + z * ry
    ty = w * ry + x * rz - y * rw - z * rx
    tz = w * rz - x * ry + y * rx - z * rw
    sign = np.where(tw < 0.0, -1.0, 1.0)
    tw, tx, ty, tz = sign * tw, sign * tx, sign * ty, sign * tz
    s = np.sqrt(tx * tx + ty * ty + tz * tz)
    tiny = s < 1e-300
    f = np.where(tiny, 0.0, np.arctan2(s, tw) / np.where(tiny, 1.0, s))
    return f * tx, f * ty, f * tz
