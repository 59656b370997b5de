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

from pointat.maths import tqt_step
from pointat.maths.quaternion import quat_multiply, quat_normalize
from pointat.maths.tqt_step import ACC_LIMIT, ACC_RELEARN, _mul_exp

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
_TWO_PI = 2.0 * math.pi


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
    GYRO_INVALID = tqt_step.F_GYRO_INVALID
    #: accelerometer zero, not finite, or impossible (beyond half again its full scale; with no full scale
    #: known, :data:`ACC_LIMIT` times the first reading): no gravity correction this step
    ACC_INVALID = tqt_step.F_ACC_INVALID
    #: magnetometer zero or not finite: no magnetic correction this step
    MAG_INVALID = tqt_step.F_MAG_INVALID
    #: ``dt`` not a finite positive number: nothing done
    DT_INVALID = tqt_step.F_DT_INVALID
    #: no valid accelerometer + magnetometer pair seen yet: the output is the identity
    UNINITIALISED = tqt_step.F_UNINITIALISED
    #: robust mode: the field's norm or dip is off its reference, the magnetometer was ignored
    MAG_DISTURBED = tqt_step.F_MAG_DISTURBED
    #: robust mode: the sensor is at rest, the gyro bias is being learned
    REST = tqt_step.F_REST
    #: robust mode: an accelerometer axis reached its full scale (``acc_range``) within the last 0.5 s
    ACC_SATURATED = tqt_step.F_ACC_SATURATED
    #: robust mode: a gyro axis reached its full scale (``gyro_range``) within the last 0.5 s
    GYRO_SATURATED = tqt_step.F_GYRO_SATURATED
    #: robust mode: the specific force's norm is off gravity by more than half a g on average over 0.25 s
    #: (down again below 0.3 g)
    SHAKING = tqt_step.F_SHAKING


Mode = Literal["robust", "paper"]

#: ``k`` of robust mode without a gyro (``use_gyro=False``): nothing carries the orientation between
#: corrections, so they follow the measurement within 1/k = 20 ms.
K_NO_GYRO = 50.0


class _TQTParams:
    """Parameters shared by :class:`TQTFilter` and :class:`TQTBank` (validated once, documented there)."""

    #: The gain ``k`` of each mode when none is given (robust without a gyro: :data:`K_NO_GYRO`).
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
        bias_tau: float = 10.0,
        bias_clip: float = math.radians(2.0),
        acc_range: float = 0.0,
        gyro_range: float = 0.0,
    ) -> None:
        if mode not in ("robust", "paper"):
            raise ValueError(f"mode must be 'robust' or 'paper', got {mode!r}")
        if k is None:
            k = self.default_k(mode, use_gyro)
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
            ("acc_range", acc_range),
            ("gyro_range", gyro_range),
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
        self.acc_range = float(acc_range)
        self.gyro_range = float(gyro_range)
        self._p = self._params()
        self._step = tqt_step.robust_step if mode == "robust" else _paper_step
        self.reset()

    @classmethod
    def default_k(cls, mode: Mode, use_gyro: bool = True) -> float:
        """The gain ``k`` a filter of this mode takes when none is given.

        >>> TQTFilter.default_k("robust"), TQTFilter.default_k("robust", use_gyro=False)
        (1.0, 50.0)
        """
        if mode == "robust" and not use_gyro:
            return K_NO_GYRO
        return cls.DEFAULT_K[mode]

    def _params(self) -> list[float]:
        """The parameter vector of :mod:`pointat.maths.tqt_step`, paper mode's ``rho`` and ``iterations``
        after it."""
        return tqt_step.params(
            self.k,
            self.k_heading,
            self.acc_tau,
            self.bias_tau,
            self.mag_norm_tol,
            self.mag_dip_tol,
            self.rest_time,
            self.rest_gyro,
            self.rest_acc,
            self.bias_clip,
            self.use_gyro,
            self.dip is not None,
            self.acc_range,
            self.gyro_range,
        ) + [self.rho, float(self.iterations)]

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
        correction of robust mode has its own, :attr:`heading_crossover`.  Without a gyro there is no
        low-pass: :math:`k / 2\pi`.

        >>> round(TQTFilter(1.0, mode="paper").crossover, 4), round(TQTFilter(1.0).crossover, 4)
        (0.1592, 0.0667)
        """
        if self.mode == "paper" or not self.use_gyro:
            return crossover_from_gain(self.k)
        k2, a2 = self.k * self.k, 1.0 / (self.acc_tau * self.acc_tau)
        w2 = 0.5 * (math.sqrt((k2 + a2) ** 2 + 4.0 * k2 * a2) - (k2 + a2))
        return math.sqrt(w2) / _TWO_PI

    @property
    def heading_crossover(self) -> float:
        r"""robust mode: the heading correction's crossover in Hz, :math:`k_{heading} / 2\pi` (below it the
        heading follows the magnetometer, above it the gyro; 0.008 Hz at the default 0.05)."""
        return crossover_from_gain(self.k_heading if self.use_gyro else self.k)

    def reset(self, q: ArrayLike | None = None) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    _TUNABLE = (
        "k", "rho", "k_heading", "acc_tau", "mag_norm_tol", "mag_dip_tol", "bias_tau", "acc_range", "gyro_range",
    )  # fmt: skip

    def retune(self, **gains: float) -> None:
        """Change gains while running (``k``, ``rho``, ``k_heading``, ``acc_tau``, ``acc_range``...); the
        state is kept.

        >>> f = TQTFilter()
        >>> f.retune(k=0.5, k_heading=0.1)
        >>> f.k, f.k_heading
        (0.5, 0.1)
        """
        new = {}
        for name, value in gains.items():  # all checked before any is set: a refusal changes nothing
            if name not in self._TUNABLE:
                raise ValueError(f"cannot retune {name!r}; tunable: {', '.join(self._TUNABLE)}")
            value = float(value)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
            if value == 0.0 and name in ("acc_tau", "bias_tau"):  # time constants: as the constructor says
                raise ValueError(f"{name} must be > 0, got {value!r}")
            new[name] = value
        for name, value in new.items():
            setattr(self, name, value)
        self._p[:] = self._params()  # in place: a bank's compiled kernel holds the same vector


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
    :math:`\hat q^- = \hat q_n \otimes \exp(\tfrac{\Delta t}{2}(\omega - b))`, plus five extensions
    (:mod:`pointat.maths.tqt_step`, the one implementation every form runs):

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
       acceleration averaged in the earth frame, :math:`e \leftarrow e + (1 - e^{-T/\tau_a})(\bar a^e_T -
       e)`, fed with the means :math:`\bar a^e_T` of 0.1 s chunks of :math:`\hat q^- \otimes a \otimes
       \hat q^{-*}` (a plain mean while less than ``acc_tau`` is in); every correction of :math:`\hat q`
       turns :math:`e` with it, so past samples stay in the current frame.  Linear accelerations average
       out, gravity does not: the error a hand's motion leaves in :math:`e` is its velocity over
       :math:`\tau_a`, however hard it strikes.  The gravity rows' Gauss-Newton fit, solved exactly (the
       rotation by :math:`\theta = \angle(e, \text{up})` about :math:`e \times \text{up}`), is applied with
       :math:`\alpha = k\Delta t`.
    4. *Magnetic gating.*  The magnetometer is ignored while its norm deviates more than
       ``mag_norm_tol`` (relative) or its dip more than ``mag_dip_tol`` from the reference, learned on the
       first sample and refined at rest (within the gate only).  Gating on the accelerometer norm is not
       done: it made every variant worse on BROAD.
    5. *Saturation* (when the source gives ``acc_range`` / ``gyro_range``, the sensor's full scale per
       axis).  No chunk of acceleration goes into :math:`e` from just before a spell of accelerometer
       saturation (clips less than 1 s apart) to 1 s after it: strokes are left out whole, swing and
       impact, never one side of them, so the average stays unbiased; once the gyro alone has turned
       the estimate by half a turn a chunk goes in all the same.  A saturated gyro is flagged only.

    Nothing a hand can produce is refused: a reading counts as corrupt only beyond half again the full
    scale, or with none known beyond :data:`ACC_LIMIT` (1000) times the first reading.  :attr:`flags`
    says ``ACC_SATURATED``, ``GYRO_SATURATED`` and ``SHAKING`` while they last.

    ``use_gyro=False`` gives accelerometer / magnetometer only tracking (VRST §4.4): no propagation, the
    corrections alone.  Robust mode then takes each reading as it comes (no average: there is no frame to
    average in), heading and tilt at the one gain ``k`` (default :data:`K_NO_GYRO`), the field gated by
    its norm.

    Bad input never poisons the state: a non-finite gyro skips the propagation, a zero or non-finite
    accelerometer or magnetometer skips that correction, a bad ``dt`` skips the step; :attr:`flags` says
    what happened and the output is never NaN.  A *zero* gyro is valid (perfect rest).

    Parameters
    ----------
    k : float, optional
        Gravity-correction gain (1/s), :math:`\alpha = k\Delta t` (VRST Eq. 14, capped at 1), errors decay
        as :math:`e^{-kt}`; crossover :attr:`crossover` (paper :math:`f_c = k/2\pi`, Theory Eq. 59,
        :func:`gain_from_crossover`; robust lower, as it low-passes the acceleration first).  Default: robust
        1.0 (50 without a gyro), paper 0.1.
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
        Robust mode: time constant (s) of the earth-frame acceleration average.  Default 2.0.
    mag_norm_tol, mag_dip_tol : float, keyword-only
        Robust mode: magnetic gate, relative norm deviation (0.1) and dip deviation in radians (5°).
    rest_time, rest_gyro, rest_acc, bias_tau, bias_clip : float, keyword-only
        Robust mode rest detection: minimum duration (s, 1.5), gyro deviation (rad/s, 2°/s), accelerometer
        deviation relative to its norm (0.05, ~0.5 m/s²), bias time constant (s, 10.0), largest bias learned
        (rad/s per axis, 2°/s).
    acc_range, gyro_range : float, keyword-only
        Robust mode: the sensor's full scale per axis, in the readings' units (m/s² or whatever the
        accelerometer reads in; rad/s), 0 (default) when not known.  A reading at or beyond it is
        saturated (extension 5).

    Notes
    -----
    The evidence for the defaults: ``benchmarks/LOO.md`` (leave-one-trial-out over the ten BROAD trials,
    Laidig et al. 2021, one vendored in ``pointat/data``, choosing only among settings that keep the strike
    claim) and ``tests/maths/test_tqt_strokes.py`` (simulated strokes, shakes and clipping with known
    truth).  Each default is what nine of the ten leave-one-out folds chose:

    * ``k = 1`` and ``acc_tau = 2`` s (f_c ≈ 0.067 Hz together): the tilt follows the vertical averaged
      over 2 s (the patent's "time weighted summing", extension 3).  BROAD cannot tell k = 0.5 with a 1 s
      average from this pair, but a shake at 3 Hz then tips the estimate 3-6° (the strike claim bars
      every average shorter than 2 s).
    * ``k_heading = 0.05`` (a 20 s time constant): heading errors are dominated by the field varying over
      the room; a slow heading correction lets the gyro carry the heading through them.
    * ``bias_tau = 10`` s: the bias is the mean of every rest until 10 s of rest are in, then a running
      average over 10 s (a glove that rested 3 s knows its bias; one that warms up follows it).  The rest
      and gate thresholds are VQF's (Laidig & Seel 2023) and the REFERENCE's (10 %, 5°).
    * Paper mode: ``k = 0.1, rho = 0.5`` (f_c ≈ 0.016 Hz) is the best plain setting; McGhee suggests
      0.1 <= k <= 1.

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

        The gyro bias, rest timer, acceleration average and magnetic reference are cleared too (the dip
        given to the constructor is kept).

        Parameters
        ----------
        q : array_like, shape (4,), optional
            Known orientation; normalised here.
        """
        q0 = None if q is None else tuple(float(c) for c in quat_normalize(q))
        self._s = tqt_step.new_state(q0, self.dip)  # type: ignore[arg-type]
        self._flags = 0 if q0 is not None else tqt_step.F_UNINITIALISED

    @property
    def q(self) -> tuple[float, float, float, float]:
        """Current orientation ``(w, x, y, z)``, sensor -> NWU."""
        s = self._s
        return (s[0], s[1], s[2], s[3])

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
        return self._s[tqt_step.S_INIT] != 0.0

    @property
    def bias(self) -> tuple[float, float, float]:
        """Gyro bias learned at rest (rad/s, sensor frame; robust mode)."""
        b = tqt_step.S_BIAS
        return (self._s[b], self._s[b + 1], self._s[b + 2])

    @property
    def magnetic_dip(self) -> float | None:
        """Dip reference in radians (``None`` until learned)."""
        if self.dip is None and not self._s[tqt_step.S_MAG_KNOWN]:
            return None
        return self._s[tqt_step.S_DIP]

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
        # plain Python floats are several times faster than numpy scalars in the arithmetic
        gx, gy, gz = gyro.tolist() if isinstance(gyro, np.ndarray) else gyro
        ax, ay, az = acc.tolist() if isinstance(acc, np.ndarray) else acc
        mx, my, mz = mag.tolist() if isinstance(mag, np.ndarray) else mag
        s = self._s
        self._flags = self._step(s, self._p, gx, gy, gz, ax, ay, az, mx, my, mz, float(dt))
        return (s[0], s[1], s[2], s[3])


def _paper_step(s, p, gx, gy, gz, ax, ay, az, mx, my, mz, dt):  # type: ignore[no-untyped-def]
    """One sample of paper mode on the state vector of :mod:`pointat.maths.tqt_step` (``p`` holds ``k``;
    ``rho`` and ``iterations`` ride after the robust parameters)."""
    flags, go = tqt_step.begin(s, p, gx, gy, gz, ax, ay, az, mx, my, mz, dt)
    if not go:
        return flags
    a_ok = not flags & tqt_step.F_ACC_INVALID
    m_ok = not flags & tqt_step.F_MAG_INVALID and s[tqt_step.S_MAG_KNOWN] != 0.0  # no reference yet: no field
    w, x, y, z = s[0], s[1], s[2], s[3]
    vx = vy = vz = 0.0
    if a_ok or m_ok:
        ia = 1.0 / math.sqrt(ax * ax + ay * ay + az * az) if a_ok else 0.0
        im = 1.0 / math.sqrt(mx * mx + my * my + mz * mz) if m_ok else 0.0
        vx, vy, vz = _gauss_newton_floats(
            w, x, y, z, ax * ia, ay * ia, az * ia, mx * im, my * im, mz * im, a_ok, m_ok,
            (s[tqt_step.S_NX], 0.0, s[tqt_step.S_NZ]), p[_P_RHO], int(p[_P_ITERATIONS]),
        )  # fmt: skip
    alpha = p[tqt_step.P_ALPHA]
    if not flags & tqt_step.F_GYRO_INVALID and p[tqt_step.P_USE_GYRO]:
        h = 0.5 * dt
        hx, hy, hz = h * gx + alpha * vx, h * gy + alpha * vy, h * gz + alpha * vz
    else:
        hx, hy, hz = alpha * vx, alpha * vy, alpha * vz
    tqt_step._store(s, *_mul_exp(w, x, y, z, hx, hy, hz))
    return flags


# paper mode's two settings ride at the end of the parameter vector
_P_RHO = tqt_step.PARAM_SIZE
_P_ITERATIONS = tqt_step.PARAM_SIZE + 1


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
    r""":class:`TQTFilter` for ``n`` sensors at once (a body suit: ~15), same parameters, same results.

    State is one row per sensor; :meth:`update` takes ``(n, 3)`` arrays and one ``dt`` and returns ``(n, 4)``
    quaternions (sensor -> NWU).  Every sensor runs the very step of :class:`TQTFilter`
    (:mod:`pointat.maths.tqt_step`), so a bank agrees with ``n`` independent filters to the last bit.

    Two ways to run it (``backend``): ``numba`` runs the robust step compiled, as one loop over the sensors
    (:mod:`pointat.maths.tqt_compiled`; ``pip install "pointat[fast]"``), well under a microsecond per
    sensor; ``python`` loops over the sensors in Python, a few microseconds each.  ``auto`` (default)
    takes numba when it is installed and the mode is robust.

    Parameters
    ----------
    n : int
        Number of sensors.
    k, **params
        As :class:`TQTFilter`.
    backend : {"auto", "numba", "python"}
        How the update runs (the results agree).

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
        from pointat.maths import tqt_compiled

        if backend not in ("auto", "numba", "python"):
            raise ValueError(f"backend must be 'auto', 'numba' or 'python', got {backend!r}")
        super().__init__(k, **params)  # type: ignore[arg-type]
        if backend == "numba" and (not tqt_compiled.available() or self.mode != "robust"):
            raise ValueError(
                "backend='numba' needs numba (pip install \"pointat[fast]\") and mode='robust'"
                f" (numba installed: {tqt_compiled.available()}, mode: {self.mode})"
            )
        numba = backend == "numba" or (
            backend == "auto" and tqt_compiled.available() and self.mode == "robust"
        )
        self.backend = "numba" if numba else "python"
        self._kernel = tqt_compiled.robust_bank if numba else None
        self._p = np.array(self._p) if numba else self._p
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
        qs = [None] * self.n if q is None else np.broadcast_to(quat_normalize(q), (self.n, 4)).tolist()
        self._s = np.array([tqt_step.new_state(qi, self.dip) for qi in qs])
        self._flags = np.full(self.n, 0 if q is not None else tqt_step.F_UNINITIALISED, dtype=np.int64)

    @property
    def q(self) -> np.ndarray:
        """Current orientations, shape (n, 4), sensor -> NWU (a copy)."""
        return self._s[:, :4].copy()

    @property
    def flags(self) -> np.ndarray:
        """Per-sensor :class:`TQTFlags` bits of the last update, int array of shape (n,)."""
        return self._flags.copy()

    @property
    def initialised(self) -> np.ndarray:
        """Per-sensor bool, shape (n,)."""
        return self._s[:, tqt_step.S_INIT] != 0.0

    @property
    def bias(self) -> np.ndarray:
        """Gyro biases learned at rest, shape (n, 3), rad/s (robust mode)."""
        return self._s[:, tqt_step.S_BIAS : tqt_step.S_BIAS + 3].copy()

    @property
    def magnetic_dip(self) -> np.ndarray:
        """Dip references in radians, shape (n,) (NaN until learned)."""
        known = (self._s[:, tqt_step.S_MAG_KNOWN] != 0.0) | (self.dip is not None)
        return np.where(known, self._s[:, tqt_step.S_DIP], np.nan)

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
        shape = (self.n, 3)
        g = np.asarray(gyro, dtype=float)
        a = np.asarray(acc, dtype=float)
        m = np.asarray(mag, dtype=float)
        if g.shape != shape or a.shape != shape or m.shape != shape:
            raise ValueError(
                f"gyro, acc and mag must have shape {shape}, got {g.shape}, {a.shape}, {m.shape}"
            )
        if present is None:
            here = np.ones(self.n, dtype=bool)
        else:
            here = np.asarray(present, dtype=bool)
            if here.shape != (self.n,):
                raise ValueError(f"present must have shape ({self.n},), got {here.shape}")
        dt = float(dt)
        if self._kernel is not None:
            self._kernel(np.ascontiguousarray(g), np.ascontiguousarray(a), np.ascontiguousarray(m), dt, here,
                         self._s, self._p, self._flags)  # fmt: skip
            return self._s[:, :4].copy()
        step, p = self._step, self._p
        for i, (gi, ai, mi) in enumerate(zip(g.tolist(), a.tolist(), m.tolist(), strict=True)):
            if here[i]:
                s = self._s[i].tolist()
                self._flags[i] = step(s, p, *gi, *ai, *mi, dt)
                self._s[i] = s
        return self._s[:, :4].copy()
