r"""McGhee / Bachmann's Gauss-Newton equations in numpy: a reference implementation of the seeds' equations,
for the tests.

The filter (:mod:`pointat.maths.tqt`) runs its own float implementation of the reduced form
(:mod:`pointat.maths.tqt.paper`, and robust mode's exact decoupled fits in :mod:`pointat.maths.tqt.step`);
these functions write the papers' equations as printed (corrected where :mod:`pointat.maths.tqt` says
they are wrong), broadcasting over leading axes, so that ``test_tqt.py`` can reproduce McGhee's Table 1
with them (the 4-column X of Theory Eqs. 39-42 included, which the filter never uses), check the
Jacobians against numerical derivatives, and hold the filter's conventions (gravity *up*, rho on rows)
to the equations.  Nothing in the library imports this module; it ships with the tests, not the package.

Sources: McGhee, Bachmann, Yun, Zyda (2000), NPS-MV-01-001 ("Theory"); Bachmann et al. (2001), VRST
("VRST"); Bachmann et al., US patent 7,089,148 ("Patent").  Conventions are those of
:mod:`pointat.maths`: quaternions scalar first, sensor -> earth, NWU.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from pointat.maths.quaternion import quat_multiply, quat_normalize

__all__ = [
    "GRAVITY_REF",
    "magnetic_reference",
    "measurement_vector",
    "measurement_model",
    "jacobian_full",
    "jacobian_reduced",
    "gauss_newton_step",
    "gauss_newton",
]

#: Gravity reference in the NWU earth frame: *up*, as the accelerometer measures it (+g at rest).
GRAVITY_REF = np.array([0.0, 0.0, 1.0])


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
