r""":class:`~pointat.maths.tqt.TQTBank`'s robust update as one compiled loop over the sensors (numba).

numpy's per-call overhead makes a vectorised step cost about the same for 1 or 50 sensors (~0.3 ms):
for a body suit (~15 sensors) that is slower than 15 separate :class:`~pointat.maths.tqt.TQTFilter`\ s.
When numba is installed (``pip install "pointat[fast]"``), :class:`~pointat.maths.tqt.TQTBank` runs
this kernel instead: for every sensor, the float algorithm of :meth:`TQTFilter.update
<pointat.maths.tqt.TQTFilter.update>` in robust mode, line for line (initialisation by TRIAD, rest
detection and bias, earth-frame acceleration low-pass, gated heading correction) with the filter's own
``_rotate`` and ``_mul_exp``, on the bank's own state arrays.  It agrees with the filter to rounding;
``tests/maths/test_tqt.py`` holds the three (filter, numpy bank, compiled bank) together.  Without numba, or in paper mode, the bank keeps
its numpy path.

The kernel is compiled at the first bank update of a process (a few seconds; numba caches the machine
code beside this file when it may write there).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from pointat.maths.scalar import MAX_RATE_SQUARED
from pointat.maths.tqt import (
    _ACC_INVALID,
    _ACC_LIMIT_SQUARED,
    _DT_INVALID,
    _EXP_TAYLOR,
    _GYRO_INVALID,
    _INF,
    _MAG_DISTURBED,
    _MAG_INVALID,
    _REST,
    _UNINITIALISED,
    ACC_RELEARN,
    _mul_exp,
    _rotate,
)

__all__ = ["available", "robust_step"]

try:  # an optional dependency: the numpy path is used without it
    from numba import njit
except ImportError:  # pragma: no cover - depends on the environment
    njit = None

_PARALLEL_EPS = 1e-6  # as pointat.maths.scalar.accmag_matrix


def available() -> bool:
    """Whether numba is installed, so that :func:`robust_step` is compiled."""
    return njit is not None


def _triad(ax: float, ay: float, az: float, mx: float, my: float, mz: float) -> tuple:
    """:func:`pointat.maths.scalar.accmag_quat`: (ok, w, x, y, z)."""
    na = math.sqrt(ax * ax + ay * ay + az * az)
    nm = math.sqrt(mx * mx + my * my + mz * mz)
    if not (na > 0.0 and nm > 0.0 and math.isfinite(na) and math.isfinite(nm)):
        return False, 1.0, 0.0, 0.0, 0.0
    ux, uy, uz = ax / na, ay / na, az / na
    mx, my, mz = mx / nm, my / nm, mz / nm
    wx, wy, wz = uy * mz - uz * my, uz * mx - ux * mz, ux * my - uy * mx
    nw = math.sqrt(wx * wx + wy * wy + wz * wz)
    if nw < _PARALLEL_EPS:
        return False, 1.0, 0.0, 0.0, 0.0
    wx, wy, wz = wx / nw, wy / nw, wz / nw
    nx, ny, nz = wy * uz - wz * uy, wz * ux - wx * uz, wx * uy - wy * ux
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = nx, ny, nz, wx, wy, wz, ux, uy, uz
    tr = m00 + m11 + m22
    if tr >= m00 and tr >= m11 and tr >= m22:
        s = 2.0 * math.sqrt(max(1.0 + tr, 0.0))
        q0, q1, q2, q3 = 0.25 * s, (m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s
    elif m00 >= m11 and m00 >= m22:
        s = 2.0 * math.sqrt(max(1.0 + m00 - m11 - m22, 0.0))
        q0, q1, q2, q3 = (m21 - m12) / s, 0.25 * s, (m01 + m10) / s, (m02 + m20) / s
    elif m11 >= m22:
        s = 2.0 * math.sqrt(max(1.0 + m11 - m00 - m22, 0.0))
        q0, q1, q2, q3 = (m02 - m20) / s, (m01 + m10) / s, 0.25 * s, (m12 + m21) / s
    else:
        s = 2.0 * math.sqrt(max(1.0 + m22 - m00 - m11, 0.0))
        q0, q1, q2, q3 = (m10 - m01) / s, (m02 + m20) / s, (m12 + m21) / s, 0.25 * s
    n = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    q0, q1, q2, q3 = q0 / n, q1 / n, q2 / n, q3 / n
    if q0 < 0.0:
        q0, q1, q2, q3 = -q0, -q1, -q2, -q3
    return True, q0, q1, q2, q3


def _robust_step(g, a, m, dt, q, init, flags, bias, rest_t, lp_gyr, lp_acc, acc_e, acc_known, a2_max, a_over,  # noqa: PLR0913
                 mag_norm, mag_known, dip_ref, nref, has_dip, use_gyro, rest_gyro, rest_acc, rest_time,
                 bias_clip, mag_norm_tol, mag_dip_tol, c_acc, c_rest, c_bias, c_ref, alpha, alpha_mag):  # fmt: skip
    """One sample for every sensor: ``g``, ``a``, ``m`` of shape (n, 3); the state arrays are changed."""
    n = g.shape[0]
    for i in range(n):
        gx, gy, gz = g[i, 0], g[i, 1], g[i, 2]
        ax, ay, az = a[i, 0], a[i, 1], a[i, 2]
        mx, my, mz = m[i, 0], m[i, 1], m[i, 2]
        if not (0.0 < dt < _INF):
            flags[i] = _DT_INVALID | (0 if init[i] else _UNINITIALISED)
            continue
        g_ok = gx * gx + gy * gy + gz * gz < MAX_RATE_SQUARED
        a2 = ax * ax + ay * ay + az * az
        if a2 < a2_max[i]:  # TQTFilter._over_limit
            a_ok = 0.0 < a2
            a_over[i] = 0
        elif not a2 < _INF:
            a_ok = False
            a_over[i] = 0
        else:
            a_over[i] += 1
            a_ok = a_over[i] >= ACC_RELEARN
            if a_ok:
                a2_max[i] = _ACC_LIMIT_SQUARED * a2
                a_over[i] = 0
        m2 = mx * mx + my * my + mz * mz
        m_ok = 0.0 < m2 < _INF
        fl = (0 if g_ok else _GYRO_INVALID) | (0 if a_ok else _ACC_INVALID) | (0 if m_ok else _MAG_INVALID)
        if not (acc_known[i] and mag_known[i]):  # TQTFilter._learn
            was = init[i]
            if not init[i] and a_ok and m_ok:
                ok, q0, q1, q2, q3 = _triad(ax, ay, az, mx, my, mz)
                if ok:
                    q[0, i], q[1, i], q[2, i], q[3, i] = q0, q1, q2, q3
                    init[i] = True
            if init[i]:
                if not acc_known[i] and a_ok:
                    ex, ey, ez = _rotate(q[0, i], q[1, i], q[2, i], q[3, i], ax, ay, az)
                    acc_e[0, i], acc_e[1, i], acc_e[2, i] = ex, ey, ez
                    lp_acc[0, i], lp_acc[1, i], lp_acc[2, i] = ax, ay, az
                    a2_max[i] = _ACC_LIMIT_SQUARED * a2
                    if g_ok:
                        lp_gyr[0, i], lp_gyr[1, i], lp_gyr[2, i] = gx, gy, gz
                    else:
                        lp_gyr[0, i], lp_gyr[1, i], lp_gyr[2, i] = 0.0, 0.0, 0.0
                    acc_known[i] = True
                if not mag_known[i] and m_ok and (a_ok or has_dip):
                    mag_norm[i] = math.sqrt(m2)
                    if not has_dip:
                        up = math.sqrt(a2)
                        sin_dip = -(ax * mx + ay * my + az * mz) / (up * mag_norm[i])
                        d = math.asin(max(-1.0, min(1.0, sin_dip)))
                        dip_ref[i] = d
                        nref[0, i], nref[1, i], nref[2, i] = math.cos(d), 0.0, -math.sin(d)
                    mag_known[i] = True
            if not init[i]:
                flags[i] = fl | _UNINITIALISED
                continue
            if not was:  # this sample set the orientation
                flags[i] = fl
                continue
        m_use = m_ok and mag_known[i]
        # TQTFilter._update_robust
        w, x, y, z = q[0, i], q[1, i], q[2, i], q[3, i]
        bx, by, bz = bias[0, i], bias[1, i], bias[2, i]
        if g_ok and use_gyro:
            h = 0.5 * dt
            w, x, y, z = _mul_exp(w, x, y, z, h * (gx - bx), h * (gy - by), h * (gz - bz))
        rest = False
        if g_ok and a_ok:
            c = c_rest
            lgx = lp_gyr[0, i] + c * (gx - lp_gyr[0, i])
            lgy = lp_gyr[1, i] + c * (gy - lp_gyr[1, i])
            lgz = lp_gyr[2, i] + c * (gz - lp_gyr[2, i])
            lax = lp_acc[0, i] + c * (ax - lp_acc[0, i])
            lay = lp_acc[1, i] + c * (ay - lp_acc[1, i])
            laz = lp_acc[2, i] + c * (az - lp_acc[2, i])
            lp_gyr[0, i], lp_gyr[1, i], lp_gyr[2, i] = lgx, lgy, lgz
            lp_acc[0, i], lp_acc[1, i], lp_acc[2, i] = lax, lay, laz
            dgx, dgy, dgz = gx - lgx, gy - lgy, gz - lgz
            dax, day, daz = ax - lax, ay - lay, az - laz
            if (
                dgx * dgx + dgy * dgy + dgz * dgz < rest_gyro * rest_gyro
                and dax * dax + day * day + daz * daz
                < rest_acc * rest_acc * (lax * lax + lay * lay + laz * laz)
                and -bias_clip < lgx < bias_clip
                and -bias_clip < lgy < bias_clip
                and -bias_clip < lgz < bias_clip
            ):
                rest_t[i] += dt
                if rest_t[i] >= rest_time:
                    rest = True
                    fl |= _REST
                    bias[0, i] = bx + c_bias * (lgx - bx)
                    bias[1, i] = by + c_bias * (lgy - by)
                    bias[2, i] = bz + c_bias * (lgz - bz)
            else:
                rest_t[i] = 0.0
        else:
            rest_t[i] = 0.0
        if a_ok:
            ex, ey, ez = acc_e[0, i], acc_e[1, i], acc_e[2, i]
            aex, aey, aez = _rotate(w, x, y, z, ax, ay, az)
            ex += c_acc * (aex - ex)
            ey += c_acc * (aey - ey)
            ez += c_acc * (aez - ez)
            eh2 = ex * ex + ey * ey
            if eh2 > 0.0:
                eh = math.sqrt(eh2)
                f = 0.5 * alpha * math.atan2(eh, ez) / eh
                sx, sy = f * ey, -f * ex
                s2 = sx * sx + sy * sy
                if s2 < _EXP_TAYLOR:
                    cw, sinc = 1.0 - 0.5 * s2, 1.0 - s2 / 6.0
                else:
                    s = math.sqrt(s2)
                    cw, sinc = math.cos(s), math.sin(s) / s
                sx *= sinc
                sy *= sinc
                w, x, y, z = (
                    cw * w - sx * x - sy * y,
                    cw * x + sx * w + sy * z,
                    cw * y + sy * w - sx * z,
                    cw * z + sx * y - sy * x,
                )
                ex, ey, ez = _rotate(cw, sx, sy, 0.0, ex, ey, ez)
            acc_e[0, i], acc_e[1, i], acc_e[2, i] = ex, ey, ez
        if m_use:
            bex, bey, bez = _rotate(w, x, y, z, mx, my, mz)
            bh = math.hypot(bex, bey)
            norm = math.sqrt(bh * bh + bez * bez)
            dip = math.atan2(-bez, bh)
            ref = mag_norm[i]
            if abs(norm - ref) > mag_norm_tol * ref or abs(dip - dip_ref[i]) > mag_dip_tol:
                fl |= _MAG_DISTURBED
            elif bh > 0.0:
                half = -0.5 * alpha_mag * math.atan2(bey, bex)
                cz, sz = math.cos(half), math.sin(half)
                w, x, y, z = cz * w - sz * z, cz * x - sz * y, cz * y + sz * x, cz * z + sz * w
                if acc_known[i]:
                    ex, ey = acc_e[0, i], acc_e[1, i]
                    c2, s2 = cz * cz - sz * sz, 2.0 * sz * cz
                    acc_e[0, i], acc_e[1, i] = c2 * ex - s2 * ey, s2 * ex + c2 * ey
                if rest:
                    mag_norm[i] = ref + c_ref * (norm - ref)
                    dip_ref[i] = dip_ref[i] + c_ref * (dip - dip_ref[i])
        n2 = w * w + x * x + y * y + z * z
        if 0.0 < n2 < _INF:
            k = 1.0 / math.sqrt(n2)
            q[0, i], q[1, i], q[2, i], q[3, i] = w * k, x * k, y * k, z * k
        flags[i] = fl


def _compile() -> Callable[..., Any] | None:
    if njit is None:
        return None
    jit = njit(cache=True, nogil=True)
    global _rotate, _mul_exp, _triad  # the kernel calls compiled helpers (TQTFilter's own _rotate, _mul_exp)
    _rotate, _mul_exp, _triad = jit(_rotate), jit(_mul_exp), jit(_triad)
    return jit(_robust_step)


_compiled: Callable[..., Any] | None = None


def compiled() -> bool:
    """Whether :func:`robust_step` has run (numba compiled it, or loaded it from its cache), so that
    its next call costs only the update."""
    return _compiled is not None and bool(getattr(_compiled, "signatures", True))


def robust_step(*args: Any) -> None:
    """:func:`_robust_step`, compiled on the first call (numba must be installed: see :func:`available`)."""
    global _compiled
    if _compiled is None:
        _compiled = _compile()
        if _compiled is None:
            raise RuntimeError('numba is not installed: pip install "pointat[fast]"')
    _compiled(*args)
