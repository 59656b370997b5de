r"""Paper mode (the seeds' filter, VRST Eq. 15) on the state vector of :mod:`pointat.maths.tqt.step`, and the
complementary crossover of a gain (Theory Eq. 59).

:func:`paper_step` is what :class:`~pointat.maths.tqt.TQTFilter` and :class:`~pointat.maths.tqt.TQTBank`
run in ``mode="paper"``: the validation and start of :func:`pointat.maths.tqt.step.begin` (shared with
robust mode), then one (or ``iterations``) reduced Gauss-Newton cycle on plain floats,
:func:`_gauss_newton_floats`, fed back with gain ``k`` over one sample.  Plain floats, as in robust mode:
several times faster than numpy scalars on one sensor's three-vectors.  numba compiles robust mode only
(:mod:`pointat.maths.tqt.compiled`); a bank in paper mode loops over its sensors in Python.

The numpy form of the same equations, broadcasting over many quaternions, with which McGhee's Table 1 is
reproduced, is a reference for the tests only (``tests/maths/mcghee_reference.py``); the library ships
this one.
"""

from __future__ import annotations

import math

from pointat.maths.tqt import step
from pointat.maths.tqt.step import _mul_exp

__all__ = ["crossover_from_gain", "gain_from_crossover", "paper_step"]

_TWO_PI = 2.0 * math.pi


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

    >>> round(crossover_from_gain(2.0 * math.pi), 12)
    1.0
    """
    return k / _TWO_PI


# paper mode's two settings ride at the end of the parameter vector
_P_RHO = step.PARAM_SIZE
_P_ITERATIONS = step.PARAM_SIZE + 1


def paper_step(s, p, gx, gy, gz, ax, ay, az, mx, my, mz, dt):  # type: ignore[no-untyped-def]
    """One sample of paper mode on the state vector of :mod:`pointat.maths.tqt.step` (``p`` holds ``k``;
    ``rho`` and ``iterations`` ride after the robust parameters)."""
    flags, go = step.begin(s, p, gx, gy, gz, ax, ay, az, mx, my, mz, dt)
    if not go:
        return flags
    a_ok = not flags & step.F_ACC_INVALID
    m_ok = not flags & step.F_MAG_INVALID and s[step.S_MAG_KNOWN] != 0.0  # no reference yet: no field
    w, x, y, z = s[0], s[1], s[2], s[3]
    vx = vy = vz = 0.0
    if a_ok or m_ok:
        ia = 1.0 / math.sqrt(ax * ax + ay * ay + az * az) if a_ok else 0.0
        im = 1.0 / math.sqrt(mx * mx + my * my + mz * mz) if m_ok else 0.0
        vx, vy, vz = _gauss_newton_floats(
            w, x, y, z, ax * ia, ay * ia, az * ia, mx * im, my * im, mz * im, a_ok, m_ok,
            (s[step.S_NX], 0.0, s[step.S_NZ]), p[_P_RHO], int(p[_P_ITERATIONS]),
        )  # fmt: skip
    alpha = p[step.P_ALPHA]
    if not flags & step.F_GYRO_INVALID and p[step.P_USE_GYRO]:
        h = 0.5 * dt
        hx, hy, hz = h * gx + alpha * vx, h * gy + alpha * vy, h * gz + alpha * vz
    else:
        hx, hy, hz = alpha * vx, alpha * vy, alpha * vz
    step._store(s, *_mul_exp(w, x, y, z, hx, hy, hz))
    return flags


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
