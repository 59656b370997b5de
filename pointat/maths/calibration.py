r"""Sensor calibration: null points, scale factors, hard and soft iron (Bachmann et al. 2001 §3.2.1).

Every sensor axis is modelled as linear,

.. math:: \text{raw} = \text{null} + \text{scale} \cdot \text{physical}
          \quad\Longleftrightarrow\quad \text{physical} = (\text{raw} - \text{null}) / \text{scale}

so ``scale`` is the *sensitivity* in raw units (ADC counts, volts) per physical unit: per m/s² for the
accelerometer, per rad/s for the gyro, per field unit for the magnetometer.  Bachmann's Eqs. 30 and 31
(and Torre 2008 §3.1's "rate resolution") give the reciprocal, the multiplier ``1 / scale``.

The magnetometer may also carry a symmetric soft-iron matrix :math:`W` from :func:`ellipsoid_fit`,
applied after the null and scale: :math:`m = W\,(\text{raw} - \text{null}) / \text{scale}`.

Cross-axis misalignment (the accelerometer and the gyro): three sensor axes that are not quite
orthogonal, or not quite along the board's, read a little of the other two.  The classical
12-parameter model (3 nulls, 3 scales, 6 cross-axis terms) is, per reading,

.. math:: \text{physical} = M\,\operatorname{diag}(1/\text{scale})\,(\text{raw} - \text{null}),
          \qquad M_{ii} = 1

with :math:`M_{ij}` (small, dimensionless: radians, near enough) how much of axis *j*'s scaled reading
belongs to board axis *i*.  The unit diagonal keeps the two apart: ``scale`` stays each axis's own
sensitivity, Eqs. 29-31's number (to second order in the angles), and :math:`M` is the identity for a
sensor without misalignment, so old files, and every rule about scales, read as before.  The
decomposition of a general correction :math:`K = M\operatorname{diag}(1/\text{scale})` is unique:
:math:`\text{scale}_i = 1/K_{ii}`, :math:`M_{ij} = K_{ij}\,\text{scale}_j`.  :math:`M` also holds the
small rotation from the sensor's axes to the board's, as the poses and turns define them (the frame the
user put the glove in): both sensors land in that one frame.

>>> null, scale = six_position_accel([[2148, 2048, 2048], [1948, 2048, 2048], [2048, 2148, 2048],
...                                   [2048, 1948, 2048], [2048, 2048, 2148], [2048, 2048, 1948]], g=1.0)
>>> null.tolist(), scale.tolist()
([2048.0, 2048.0, 2048.0], [100.0, 100.0, 100.0])
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import shutil
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar, Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from pointat.saving import sync_folder, temporary_path
from pointat.userfiles import read_text

__all__ = [
    "STANDARD_GRAVITY",
    "six_position_accel",
    "six_position_misalignment",
    "AccelFit",
    "gyro_misalignment",
    "minmax_magnetometer",
    "implausible",
    "gyro_null",
    "gyro_scale",
    "ellipsoid_fit",
    "Calibration",
    "MISALIGNMENT_LIMIT",
    "is_identity",
]

#: Standard gravity, m/s².
STANDARD_GRAVITY = 9.80665

#: The largest cross-axis term :func:`implausible` lets through: 5 degrees (0.087), ten times a real
#: part's; beyond, the poses or the turns were not about the board's axes.
MISALIGNMENT_LIMIT = math.radians(5.0)

_SENSORS = ("gyro", "acc", "mag")


def _samples(x: ArrayLike, name: str, min_rows: int = 1) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if x.ndim != 2 or x.shape[1] != 3 or x.shape[0] < min_rows:
        raise ValueError(f"{name} must have shape (n, 3) with n >= {min_rows}, got {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return x


def _pose_rows(means: ArrayLike, order: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The six poses' means, and which row has each axis up and which down (see :func:`six_position_accel`)."""
    m = _samples(means, "means", 6)
    if m.shape[0] != 6:
        raise ValueError(f"means must have shape (6, 3), got {m.shape}")
    if order == "fixed":
        up, down = np.array([0, 2, 4]), np.array([1, 3, 5])
    elif order == "auto":
        up, down = np.argmax(m, axis=0), np.argmin(m, axis=0)
        if len(set(up.tolist()) | set(down.tolist())) != 6:
            raise ValueError(
                "cannot tell the six poses apart: each axis needs its own up row (largest reading) and "
                f"down row (smallest reading); got up rows {up.tolist()}, down rows {down.tolist()}"
            )
    else:
        raise ValueError(f"order must be 'auto' or 'fixed', got {order!r}")
    return m, up, down


def six_position_accel(
    means: ArrayLike, g: float = STANDARD_GRAVITY, *, order: Literal["auto", "fixed"] = "auto"
) -> tuple[np.ndarray, np.ndarray]:
    r"""Accelerometer null and scale from six static poses, each axis up and down (Bachmann 2001, Eqs. 29-30).

    .. math::
        \text{null}_i = \frac{\text{up}_i + \text{down}_i}{2} \quad (29), \qquad
        \text{scale}_i = \frac{\text{up}_i - \text{down}_i}{2g} \quad (\text{reciprocal of } 30)

    where :math:`\text{up}_i` is axis *i*'s reading with that axis pointing up (it senses :math:`+g`,
    the specific force at rest) and :math:`\text{down}_i` with it pointing down.

    Parameters
    ----------
    means : array_like, shape (6, 3)
        Mean raw reading (counts or volts) of each pose, one row per pose.
    g : float
        Gravity in the output unit (default m/s²; ``g=1`` calibrates in g).
    order : {"auto", "fixed"}
        ``"fixed"``: rows are the poses with +x, -x, +y, -y, +z, -z pointing up.  ``"auto"``: any row
        order; for each axis the row with the largest reading is "up" and the smallest "down" (assumes
        positive sensitivities); the six rows must be distinct.

    Returns
    -------
    null : numpy.ndarray, shape (3,)
        Raw reading at zero specific force.
    scale : numpy.ndarray, shape (3,)
        Raw units per unit of ``g`` (default counts per m/s²).

    Raises
    ------
    ValueError
        Wrong shape, non-finite values, ``order="auto"`` cannot tell the poses apart, or a zero scale.

    >>> poses = [[0, 0, 120], [0, 0, -80], [120, 0, 20], [-80, 0, 20], [20, 100, 20], [20, -100, 20]]
    >>> [a.tolist() for a in six_position_accel(poses, g=1.0)]    # rows in any order
    [[20.0, 0.0, 20.0], [100.0, 100.0, 100.0]]
    """
    m, up, down = _pose_rows(means, order)
    cols = np.arange(3)
    hi, lo = m[up, cols], m[down, cols]
    null = 0.5 * (hi + lo)
    scale = (hi - lo) / (2.0 * float(g))
    if np.any(scale == 0.0):
        raise ValueError(
            f"an axis reads the same up and down (scale 0): up {hi.tolist()}, down {lo.tolist()}"
        )
    return null, scale


def _split(sensitivity: np.ndarray, what: str) -> tuple[np.ndarray, np.ndarray]:
    r"""Scales and unit-diagonal misalignment from a sensitivity matrix :math:`A` (raw units per
    physical unit, ``raw - null = A @ physical``): :math:`K = A^{-1}`, :math:`\text{scale}_i = 1/K_{ii}`,
    :math:`M_{ij} = K_{ij}\,\text{scale}_j`."""
    with np.errstate(all="ignore"):
        cond = np.linalg.cond(sensitivity)
    if not cond < 1e6:
        raise ValueError(
            f"the {what} do not tell the three axes apart (sensitivity matrix singular, condition number"
            f" {cond:.3g}): {np.round(sensitivity, 6).tolist()}"
        )
    K = np.linalg.inv(sensitivity)
    d = np.diag(K).copy()
    if np.any(d == 0.0):
        raise ValueError(f"the {what} give an axis no sensitivity of its own: {np.round(K, 9).tolist()}")
    scale = 1.0 / d
    M = K * scale[np.newaxis, :]
    np.fill_diagonal(M, 1.0)  # (1 to the last bit: K_ii / K_ii may round)
    return scale, M


class AccelFit(NamedTuple):
    """What :func:`six_position_misalignment` recovers: ``null`` and ``scale`` (shape (3,)), the
    misalignment ``M`` (3x3, unit diagonal) and how far the poses disagree with the model, ``residual``
    (radians, rms, per degree of freedom of the fit: an estimate of the cross-axis terms' error)."""

    null: np.ndarray
    scale: np.ndarray
    misalignment: np.ndarray
    residual: float


def six_position_misalignment(
    means: ArrayLike, g: float = STANDARD_GRAVITY, *, order: Literal["auto", "fixed"] = "auto"
) -> AccelFit:
    r"""Accelerometer null, scale and cross-axis misalignment from the six poses of :func:`six_position_accel`.

    Each pose *k* has a board axis straight up, so the specific force it senses is :math:`g\,d_k`
    with :math:`d_k = \pm e_i` known (the rows are told apart as :func:`six_position_accel` does).  The
    model :math:`\text{raw}_k = \text{null} + A\,g\,d_k` is linear in the null and the full sensitivity
    matrix :math:`A` (12 unknowns, 18 equations): a least-squares fit in counts, where the noise is.  Then
    :math:`K = A^{-1}` splits into ``scale`` and the unit-diagonal ``M`` (module notes).  With six poses,
    ``null`` is the mean of the six readings and column *j* of :math:`A` half the difference of axis
    *j*'s up and down readings over :math:`g`: Eqs. 29-30 applied to all three axes of each pair.

    The six residual degrees of freedom are the three pairs' nulls disagreeing: half of each pose's tilt
    away from its axis shows there; the other half (a pair tilted alike) goes into ``M`` unseen, so
    ``residual`` is also about how far ``M`` is off (within ~15 % for poses tilted at random).  The
    poses define the board frame: ``M`` is only as good as they are (a jig or a squared box, not a hand).

    Parameters
    ----------
    means : array_like, shape (6, 3)
        Mean raw reading of each pose.
    g : float
        Gravity in the output unit.
    order : {"auto", "fixed"}
        As for :func:`six_position_accel`.

    Returns
    -------
    AccelFit
        ``(null, scale, misalignment, residual)``; ``physical = M @ ((raw - null) / scale)``.

    Raises
    ------
    ValueError
        As :func:`six_position_accel`, or axes that do not tell the poses apart (a singular matrix).

    >>> M_true = np.array([[1.0, 0.01, -0.005], [0.008, 1.0, 0.012], [-0.01, 0.006, 1.0]])
    >>> A = np.diag([100.0, 98.0, 103.0]) @ np.linalg.inv(M_true)      # counts per g
    >>> poses = 2048.0 + np.vstack([A[:, i] * s for i in range(3) for s in (1, -1)])
    >>> null, scale, M, residual = six_position_misalignment(poses, g=1.0)
    >>> null.tolist(), np.round(scale, 9).tolist()
    ([2048.0, 2048.0, 2048.0], [100.0, 98.0, 103.0])
    >>> bool(np.allclose(M, M_true, atol=1e-12)), round(residual, 12)
    (True, 0.0)
    """
    m, up, down = _pose_rows(means, order)
    directions = np.zeros((6, 3))
    directions[up, np.arange(3)] = 1.0
    directions[down, np.arange(3)] = -1.0
    # the least-squares solution, in closed form (the design's columns [1, g d] are orthogonal)
    null = m.mean(axis=0)
    A = (m[up] - m[down]).T / (2.0 * float(g))  # raw - null = A @ (g d)
    scale, M = _split(A, "six poses")
    residual = m - null - float(g) * directions @ A.T  # counts; as an angle: over g and the sensitivity
    angle = residual / (float(g) * np.abs(np.diag(A)))
    return AccelFit(null, scale, M, float(np.sqrt(np.sum(angle**2) / (18 - 12))))


def gyro_misalignment(sensitivity: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    r"""Gyro scales and cross-axis misalignment from three known turns, one about each board axis.

    A turn by :math:`\theta_k` about board axis *k*, integrated on all three gyro axes from their nulls,
    gives :math:`\int(\text{raw} - \text{null})\,dt = A\,\theta_k e_k`: column *k* of the sensitivity
    matrix :math:`A` times the angle (Eq. 31 on every axis at once; :func:`gyro_scale` of each axis,
    ``gyro_scale(samples, dt, theta_k, axis=i, null=null)`` is :math:`A_{ik}`).  Then :math:`K = A^{-1}`
    splits into ``scale`` and the unit-diagonal ``M`` (module notes).  Nine equations, nine unknowns: a
    turn about an axis a degree off the board's puts that degree into ``M``, unseen (turn flat on a table
    against a square edge).

    Parameters
    ----------
    sensitivity : array_like, shape (3, 3)
        Raw units per rad/s; column *k* from the turn about axis *k*.

    Returns
    -------
    scale : numpy.ndarray, shape (3,)
        Raw units per rad/s (Eq. 31's, to second order in the cross-axis terms).
    misalignment : numpy.ndarray, shape (3, 3)
        Unit diagonal: ``rate = M @ ((raw - null) / scale)``.

    Raises
    ------
    ValueError
        Not a finite 3x3 matrix, a turn that showed more on another axis than on its own (the turns
        mislabelled), or a singular matrix.

    >>> A = [[573.0, 5.0, -3.0], [-4.0, 560.0, 6.0], [2.0, -7.0, 580.0]]   # counts per rad/s
    >>> scale, M = gyro_misalignment(A)
    >>> np.round(scale, 3).tolist()                 # Eq. 31 alone: the diagonal, 573, 560, 580
    [573.046, 560.107, 580.085]
    >>> np.round(np.degrees(M - np.eye(3)), 3).tolist()     # the cross-axis terms, in degrees
    [[0.0, -0.496, 0.305], [0.411, 0.0, -0.612], [-0.193, 0.693, 0.0]]
    >>> bool(np.allclose(M @ np.diag(1 / scale) @ A, np.eye(3)))   # rates come out whole
    True
    """
    A = np.asarray(sensitivity, dtype=float)
    if A.shape != (3, 3) or not np.all(np.isfinite(A)):
        raise ValueError(f"sensitivity must be a finite 3x3 matrix, got {np.asarray(sensitivity).tolist()}")
    for k in range(3):
        column = np.abs(A[:, k])
        if column.argmax() != k or column[k] == 0.0:
            raise ValueError(
                f"the turn about {'xyz'[k]} showed most on gyro {'xyz'[int(column.argmax())]}"
                f" ({A[:, k].tolist()} counts per rad/s): the turns are mislabelled, or one was not made"
            )
    return _split(A, "three turns")


def minmax_magnetometer(samples: ArrayLike, field: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    r"""Magnetometer null and scale from the extremes seen while turning the sensor (Bachmann 2001 §3.2.1).

    Each axis is swung through the field's direction both ways, as for the accelerometer (Eqs. 29-30):

    .. math::
        \text{null}_i = \frac{\max_i + \min_i}{2}, \qquad \text{scale}_i = \frac{\max_i - \min_i}{2F}

    so a calibrated axis reads :math:`\pm F` at its extremes.  Hard iron only (per-axis offset and gain);
    see :func:`ellipsoid_fit` for soft iron.

    Parameters
    ----------
    samples : array_like, shape (n, 3)
        Raw readings covering all orientations (n >= 2).
    field : float
        Field magnitude :math:`F` that the extremes map to (1.0: unit field; or e.g. gauss, µT).

    Returns
    -------
    null : numpy.ndarray, shape (3,)
    scale : numpy.ndarray, shape (3,)
        Raw units per unit of ``field``.

    >>> [a.tolist() for a in minmax_magnetometer([[300, -50, 10], [-100, 150, 410], [100, 50, 210]])]
    [[100.0, 50.0, 210.0], [200.0, 100.0, 200.0]]
    """
    x = _samples(samples, "samples", 2)
    hi, lo = x.max(axis=0), x.min(axis=0)
    if np.any(hi == lo):
        raise ValueError(f"an axis never changed while turning (min == max): {hi.tolist()}")
    return 0.5 * (hi + lo), (hi - lo) / (2.0 * float(field))


def gyro_null(rest_samples: ArrayLike) -> np.ndarray:
    r"""Gyro null point: the mean output of the sensor at rest (Bachmann 2001 §3.2.1).

    .. math:: \text{null} = \frac{1}{n}\sum_{k=1}^{n} \text{raw}_k

    Torre 2008 §3.1 uses the first thousand samples.

    Parameters
    ----------
    rest_samples : array_like, shape (n, 3)
        Raw readings of the motionless sensor.

    Returns
    -------
    numpy.ndarray, shape (3,)

    >>> gyro_null([[2047, 2050, 2046], [2049, 2048, 2046]]).tolist()
    [2048.0, 2049.0, 2046.0]
    """
    return _samples(rest_samples, "rest_samples").mean(axis=0)


def gyro_scale(
    samples: ArrayLike, dt: ArrayLike, angle_rad: float, axis: int, *, null: ArrayLike = 0.0
) -> float:
    r"""Gyro scale of one axis from a known rotation about it (Bachmann 2001, Eq. 31).

    Eq. 31's multiplier is *known rotation / estimated rotation*, the estimate being the output
    integrated with unit scale.  As a sensitivity (raw units per rad/s) that is

    .. math:: \text{scale} = \frac{\sum_k (\text{raw}_k - \text{null})\,\Delta t_k}{\theta_{known}}

    The sum is the rectangle rule that :class:`pointat.maths.fusion.GyroIntegrator` also uses (each sample
    held over its interval).  Record from rest to rest so nothing is cut off.

    Parameters
    ----------
    samples : array_like, shape (n, 3) or (n,)
        Raw readings during the rotation (all three axes, or just the one).
    dt : float or array_like, shape (n,)
        Sample interval(s), s.
    angle_rad : float
        Known rotation about ``+axis``, radians (right-handed; non-zero).
    axis : int
        0, 1 or 2 for x, y, z.
    null : float or array_like, shape (3,)
        Null point(s) from :func:`gyro_null` (default 0: samples already nulled).

    Returns
    -------
    float
        Raw units per rad/s for that axis.

    >>> raw = np.full((100, 3), 2048.0)
    >>> raw[:, 2] += 50.0                                     # 50 counts above null for 1 s...
    >>> gyro_scale(raw, 0.01, np.pi / 2, 2, null=2048.0)      # ...turned 90 deg: 31.8 counts per rad/s
    31.830988618379
    """
    x = np.asarray(samples, dtype=float)
    if axis not in (0, 1, 2):
        raise ValueError(f"axis must be 0, 1 or 2, got {axis!r}")
    nul = np.broadcast_to(np.asarray(null, dtype=float), (3,))[axis]
    if x.ndim == 2 and x.shape[1] == 3:
        x = x[:, axis]
    elif x.ndim != 1:
        raise ValueError(f"samples must have shape (n, 3) or (n,), got {x.shape}")
    if not (np.all(np.isfinite(x)) and math.isfinite(angle_rad) and angle_rad != 0.0):
        raise ValueError("samples must be finite and angle_rad finite and non-zero")
    dts = np.broadcast_to(np.asarray(dt, dtype=float), x.shape)
    estimated = float(np.sum((x - nul) * dts))
    if estimated == 0.0:
        raise ValueError("the integrated output is zero: no rotation was seen on this axis")
    return estimated / float(angle_rad)


def ellipsoid_fit(samples: ArrayLike, field: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    r"""Hard- and soft-iron magnetometer calibration by a least-squares ellipsoid (general quadric) fit.

    Readings of a constant field :math:`F` in every orientation lie on an ellipsoid
    :math:`\text{raw} = A\,m + b,\ \lVert m\rVert = F`.  Fit the quadric
    :math:`x^T M x + 2 n^T x + d = 0` (10 coefficients, the smallest right singular vector of the design
    matrix, after centring and scaling the data for conditioning), then

    .. math::
        b = -M^{-1} n, \qquad k = b^T M b - d, \qquad (x - b)^T \tfrac{M}{k} (x - b) = 1,
        \qquad W = F\,(M/k)^{1/2}

    so that :math:`\lVert W(\text{raw} - b)\rVert = F`.  :math:`W` is the symmetric positive-definite
    correction; with a symmetric distortion it is :math:`A^{-1}` (a rotation part of :math:`A` is not
    observable from magnitudes alone).

    Parameters
    ----------
    samples : array_like, shape (n, 3)
        Raw magnetometer readings covering many orientations (n >= 10, not all in a plane).
    field : float
        Magnitude the corrected field should have.

    Returns
    -------
    offset : numpy.ndarray, shape (3,)
        Hard-iron offset :math:`b`, raw units.
    soft_iron : numpy.ndarray, shape (3, 3)
        Symmetric correction :math:`W`: ``m = soft_iron @ (raw - offset)``.

    Raises
    ------
    ValueError
        Too few points, or the best quadric is not an ellipsoid (e.g. the points span only a plane).

    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=(200, 3))
    >>> u /= np.linalg.norm(u, axis=1, keepdims=True)
    >>> offset, W = ellipsoid_fit(u * [2.0, 3.0, 4.0] + [10.0, -5.0, 1.0])
    >>> np.round(offset, 9).tolist(), np.round(np.diag(W), 9).tolist()
    ([10.0, -5.0, 1.0], [0.5, 0.333333333, 0.25])
    """
    x = _samples(samples, "samples", 10)
    c = x.mean(axis=0)
    s = float(np.sqrt(np.mean(np.sum((x - c) ** 2, axis=1))))
    if s == 0.0:
        raise ValueError("all samples are identical")
    u, v, w = ((x - c) / s).T
    one = np.ones_like(u)
    design = np.stack(
        [u * u, v * v, w * w, 2 * u * v, 2 * u * w, 2 * v * w, 2 * u, 2 * v, 2 * w, one], axis=1
    )
    p = np.linalg.svd(design, full_matrices=False)[2][-1]
    M = np.array([[p[0], p[3], p[4]], [p[3], p[1], p[5]], [p[4], p[5], p[2]]])
    try:
        centre = -np.linalg.solve(M, p[6:9])
    except np.linalg.LinAlgError:
        raise ValueError("the samples do not determine an ellipsoid (singular quadric)") from None
    k = centre @ M @ centre - p[9]
    evals, evecs = np.linalg.eigh(M / k) if k != 0.0 else (np.zeros(3), np.eye(3))
    if not np.all(evals > 0.0):
        raise ValueError(f"the best-fitting quadric is not an ellipsoid (eigenvalues {evals.tolist()})")
    W_u = float(field) * (evecs * np.sqrt(evals)) @ evecs.T
    return c + s * centre, W_u / s


def _zeros() -> np.ndarray:
    return np.zeros(3)


def _ones() -> np.ndarray:
    return np.ones(3)


def _eye() -> np.ndarray:
    return np.eye(3)


def is_identity(matrix: ArrayLike) -> bool:
    """Whether a misalignment is the identity to the last bit (nothing to apply).

    >>> is_identity(np.eye(3)), is_identity([[1, 0, 0], [0, 1, 1e-17], [0, 0, 1]])
    (True, False)
    """
    return bool(np.array_equal(np.asarray(matrix, dtype=float), np.eye(3)))


#: The sensors that carry a cross-axis misalignment.
_ALIGNED = ("gyro", "acc")


@dataclass(eq=False)
class Calibration:
    r"""Null points, scales, cross-axis misalignments and an optional magnetometer soft-iron matrix, with a
    JSON file format.

    .. math:: \text{physical} = M\,(\text{raw} - \text{null}) / \text{scale}, \qquad
              m = W\,(\text{raw}_m - \text{null}_m) / \text{scale}_m

    Units: ``scale`` is raw units per rad/s (gyro), per m/s² (acc), per field unit (mag); see the module
    notes, which also say why the misalignment :math:`M` (gyro and acc, unit diagonal) is kept apart from
    the scales.  The defaults (null 0, scale 1, identity misalignment, no soft iron) pass readings
    through unchanged.

    Attributes
    ----------
    gyro_null, gyro_scale, acc_null, acc_scale, mag_null, mag_scale : numpy.ndarray, shape (3,)
    mag_soft_iron : numpy.ndarray, shape (3, 3), or None
    gyro_misalignment, acc_misalignment : numpy.ndarray, shape (3, 3)
        1 on the diagonal (None given: the identity).

    File format (JSON, floats at full precision)::

        {"format": "pointat-calibration", "version": 1,
         "gyro": {"null": [x, y, z], "scale": [x, y, z], "misalignment": [[1, ., .], [., 1, .], [., ., 1]]},
         "acc":  {"null": [...], "scale": [...], "misalignment": [[...], [...], [...]]},
         "mag":  {"null": [...], "scale": [...], "soft_iron": [[...], [...], [...]] or null}}

    A missing sensor section means "uncalibrated" (defaults); a missing (or null) ``misalignment`` the
    identity, as in the files written before it was modelled; unknown keys are an error.

    >>> cal = Calibration(acc_null=[2048.0] * 3, acc_scale=[100.0] * 3)
    >>> cal.apply("acc", [2048.0, 2148.0, 1948.0]).tolist()
    [0.0, 1.0, -1.0]
    >>> Calibration.from_json(cal.to_json()) == cal
    True
    """

    gyro_null: np.ndarray = field(default_factory=_zeros)
    gyro_scale: np.ndarray = field(default_factory=_ones)
    acc_null: np.ndarray = field(default_factory=_zeros)
    acc_scale: np.ndarray = field(default_factory=_ones)
    mag_null: np.ndarray = field(default_factory=_zeros)
    mag_scale: np.ndarray = field(default_factory=_ones)
    mag_soft_iron: np.ndarray | None = None
    gyro_misalignment: np.ndarray = field(default_factory=_eye)
    acc_misalignment: np.ndarray = field(default_factory=_eye)

    FORMAT: ClassVar[str] = "pointat-calibration"
    VERSION: ClassVar[int] = 1

    def __post_init__(self) -> None:
        for sensor in _SENSORS:
            for part in ("null", "scale"):
                name = f"{sensor}_{part}"
                value = np.array(getattr(self, name), dtype=float)
                if value.shape != (3,) or not np.all(np.isfinite(value)):
                    raise ValueError(f"{name} must be 3 finite numbers, got {getattr(self, name)!r}")
                if part == "scale" and np.any(value == 0.0):
                    raise ValueError(f"{name} must not contain 0, got {value.tolist()}")
                setattr(self, name, value)
        if self.mag_soft_iron is not None:
            W = np.array(self.mag_soft_iron, dtype=float)
            if W.shape != (3, 3) or not np.all(np.isfinite(W)):
                raise ValueError(f"mag_soft_iron must be a finite 3x3 matrix, got {self.mag_soft_iron!r}")
            self.mag_soft_iron = W
        for sensor in _ALIGNED:
            name = f"{sensor}_misalignment"
            given = getattr(self, name)
            M = np.eye(3) if given is None else np.array(given, dtype=float)
            if M.shape != (3, 3) or not np.all(np.isfinite(M)):
                raise ValueError(f"{name} must be a finite 3x3 matrix, got {given!r}")
            if np.any(np.diag(M) != 1.0):
                raise ValueError(
                    f"{name} must have 1 on its diagonal (the scales hold the rest), got {given!r}"
                )
            setattr(self, name, M)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Calibration):
            return NotImplemented
        same = all(
            np.array_equal(getattr(self, f"{s}_{p}"), getattr(other, f"{s}_{p}"))
            for s in _SENSORS
            for p in ("null", "scale")
        ) and all(
            np.array_equal(getattr(self, f"{s}_misalignment"), getattr(other, f"{s}_misalignment"))
            for s in _ALIGNED
        )
        if self.mag_soft_iron is None or other.mag_soft_iron is None:
            return same and self.mag_soft_iron is None and other.mag_soft_iron is None
        return same and np.array_equal(self.mag_soft_iron, other.mag_soft_iron)

    __hash__ = None  # type: ignore[assignment]  # mutable

    def apply(self, sensor: Literal["gyro", "acc", "mag"], raw: ArrayLike) -> np.ndarray:
        r"""Convert raw readings of one sensor to physical units: :math:`M\,(\text{raw} - \text{null}) / \text{scale}`.

        Parameters
        ----------
        sensor : {"gyro", "acc", "mag"}
        raw : array_like, shape (..., 3)
            Raw readings.

        Returns
        -------
        numpy.ndarray, shape (..., 3)
            rad/s (gyro), m/s² (acc), field units (mag, soft iron applied if set); the misalignment
            applied (gyro, acc) unless it is the identity.
        """
        if sensor not in _SENSORS:
            raise ValueError(f"sensor must be one of {_SENSORS}, got {sensor!r}")
        raw = np.asarray(raw, dtype=float)
        if raw.shape[-1:] != (3,):
            raise ValueError(f"raw {sensor} readings need a last axis of length 3, got shape {raw.shape}")
        out = (raw - getattr(self, f"{sensor}_null")) / getattr(self, f"{sensor}_scale")
        if sensor == "mag" and self.mag_soft_iron is not None:
            out = out @ self.mag_soft_iron.T
        elif sensor != "mag" and not is_identity(M := getattr(self, f"{sensor}_misalignment")):
            out = out @ M.T
        return out

    def apply_all(
        self, raw_gyro: ArrayLike, raw_acc: ArrayLike, raw_mag: ArrayLike
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Apply :meth:`apply` to the three sensors; shapes (..., 3) each; returns (gyro, acc, mag)."""
        return self.apply("gyro", raw_gyro), self.apply("acc", raw_acc), self.apply("mag", raw_mag)

    def to_dict(self) -> dict[str, Any]:
        """The JSON-ready dictionary (plain floats and lists)."""
        d: dict[str, Any] = {"format": self.FORMAT, "version": self.VERSION}
        for sensor in _SENSORS:
            d[sensor] = {
                "null": getattr(self, f"{sensor}_null").tolist(),
                "scale": getattr(self, f"{sensor}_scale").tolist(),
            }
        for sensor in _ALIGNED:
            d[sensor]["misalignment"] = getattr(self, f"{sensor}_misalignment").tolist()
        d["mag"]["soft_iron"] = None if self.mag_soft_iron is None else self.mag_soft_iron.tolist()
        return d

    def to_json(self, indent: int | None = 2) -> str:
        """JSON text; floats are written with ``repr`` precision, so :meth:`from_json` restores them exactly."""
        return json.dumps(self.to_dict(), indent=indent, allow_nan=False)

    @classmethod
    def from_dict(cls, data: Any, *, source: str = "calibration") -> Calibration:
        """Build from a dictionary as written by :meth:`to_dict`; ``source`` names it in error messages."""

        def bad(key: str, expected: str, got: Any) -> ValueError:
            return ValueError(f"{source}: key '{key}': expected {expected}, got {got!r}")

        if not isinstance(data, dict):
            raise bad("<top level>", "a JSON object", type(data).__name__)
        allowed = {"format", "version", *_SENSORS}
        for key in data:
            if key not in allowed:
                raise bad(key, f"one of {sorted(allowed)}", "an unknown key")
        if "format" in data and data["format"] != cls.FORMAT:
            raise bad("format", repr(cls.FORMAT), data["format"])
        if "version" not in data:
            raise bad("version", f"the format version {cls.VERSION}", "nothing (missing)")
        if data["version"] != cls.VERSION or isinstance(data["version"], bool):
            raise bad("version", f"the format version {cls.VERSION}", data["version"])

        def numbers(key: str, value: Any, nonzero: bool = False) -> list[float]:
            try:
                ok = (
                    isinstance(value, list)
                    and len(value) == 3
                    and all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
                    and all(math.isfinite(v) and (v != 0 or not nonzero) for v in value)
                )
            except OverflowError:  # an integer too large for a float (10**400)
                ok = False
            if not ok:
                raise bad(key, "a list of 3 finite" + (" non-zero" if nonzero else "") + " numbers", value)
            return [float(v) for v in value]

        kwargs: dict[str, Any] = {}
        for sensor in _SENSORS:
            if sensor not in data:
                continue
            section = data[sensor]
            if not isinstance(section, dict):
                raise bad(sensor, "an object with 'null' and 'scale'", section)
            allowed_keys = {"null", "scale", "soft_iron" if sensor == "mag" else "misalignment"}
            for key in section:
                if key not in allowed_keys:
                    raise bad(f"{sensor}.{key}", f"one of {sorted(allowed_keys)}", "an unknown key")
            if "null" in section:
                kwargs[f"{sensor}_null"] = numbers(f"{sensor}.null", section["null"])
            if "scale" in section:
                kwargs[f"{sensor}_scale"] = numbers(f"{sensor}.scale", section["scale"], nonzero=True)
            if section.get("soft_iron") is not None:
                rows = section["soft_iron"]
                if not (isinstance(rows, list) and len(rows) == 3):
                    raise bad("mag.soft_iron", "a 3x3 list of finite numbers or null", rows)
                kwargs["mag_soft_iron"] = [numbers(f"mag.soft_iron[{i}]", r) for i, r in enumerate(rows)]
            if section.get("misalignment") is not None:
                key, rows = f"{sensor}.misalignment", section["misalignment"]
                if not (isinstance(rows, list) and len(rows) == 3):
                    raise bad(key, "a 3x3 list of finite numbers, 1 on the diagonal, or null", rows)
                M = [numbers(f"{key}[{i}]", r) for i, r in enumerate(rows)]
                if any(M[i][i] != 1.0 for i in range(3)):
                    raise bad(key, "1 on the diagonal (the scales hold the rest)", rows)
                kwargs[f"{sensor}_misalignment"] = M
        return cls(**kwargs)

    @classmethod
    def from_json(cls, text: str, *, source: str = "calibration") -> Calibration:
        """Parse JSON text (see the class notes); ValueError names ``source`` and the bad key."""
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(f"{source}: not valid JSON: {exc}") from None
        except ValueError as exc:  # an integer of more than 4300 digits (sys.get_int_max_str_digits)
            raise ValueError(f"{source}: not a calibration: {exc}") from None
        except RecursionError:
            raise ValueError(f"{source}: nested too deeply to be a calibration") from None
        return cls.from_dict(data, source=source)

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the JSON file at ``path`` (UTF-8): whole or not at all (a full disk, or the power going,
        leaves the old one), keeping its permissions; a symbolic link is followed (the file it names is
        written, as one glove's file shared by two patches).  Anything but a regular file (a device, a
        pipe) is written to as it is."""
        text = self.to_json() + "\n"
        path = os.path.realpath(path)
        if os.path.exists(path) and not os.path.isfile(path):
            with open(path, "w", encoding="utf-8") as fh:
                fh.write(text)
            return
        part = str(temporary_path(Path(path)))  # (.NAME.PID-N.tmp: a kill's is cleaned at the next start)
        try:
            with open(part, "w", encoding="utf-8") as fh:
                fh.write(text)
                fh.flush()
                os.fsync(fh.fileno())
            with contextlib.suppress(OSError):  # none yet, or not ours to read: the default mode
                shutil.copymode(path, part)
            os.replace(part, path)
            sync_folder(os.path.dirname(path))
        except BaseException:
            with contextlib.suppress(OSError):
                os.remove(part)
            raise

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Calibration:
        """Read a JSON file written by :meth:`save`; a bad file raises ValueError naming the file and key."""
        # a regular file of 1 MB at most (a pipe is refused, never waited on); a byte-order mark is fine
        text = read_text(path, "calibration")
        return cls.from_json(text, source=f"calibration file {os.fspath(path)}")


def implausible(
    cal: Calibration, factor: Sequence[float], resolution: Mapping[str, float], plausible: float = 4.0
) -> list[str]:
    """What makes a calibration's numbers garbage or silence for ``scaling``: a gyro or accelerometer
    scale more than ``plausible`` times off the sensor's nominal ``resolution`` (units per count, by
    ``gyro`` and ``acc``: a resolution written where counts per unit go), a factor that is 0 or not
    finite, scales without nulls, a soft-iron matrix that flattens the field, a misalignment with a
    cross-axis term beyond :data:`MISALIGNMENT_LIMIT` (5 degrees) or not finite.  ``factor``: the nine
    units per count ``scaling`` would use (gyro, accelerometer, magnetometer x y z).

    >>> cal = Calibration(acc_null=np.array([2048.0] * 3), acc_scale=np.array([4.0, 4.0, 4.0]))
    >>> implausible(cal, [1e-3] * 3 + [0.25] * 3 + [1.0] * 3, {"gyro": 1e-3, "acc": 0.0196})
    ['acc.scale [4 4 4] (counts per unit) is up to 12.8 times off the nominal 51.02 (a resolution written where counts per unit go?)']
    >>> cal = Calibration(gyro_misalignment=[[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    >>> implausible(cal, [1e-3] * 9, {})
    ['gyro.misalignment has a cross-axis term of 0.1 (5.7 deg, x from y), more than 0.0873 (5 deg): the turns were not about the board axes']
    """
    problems = []
    for i, sensor in enumerate(("gyro", "acc", "mag")):
        scale, null = getattr(cal, f"{sensor}_scale"), getattr(cal, f"{sensor}_null")
        worst = 0.0
        for a in range(3):
            f = factor[3 * i + a]
            if not math.isfinite(f) or f == 0.0:
                worst = math.inf
            elif sensor in resolution and scale[a] != 1.0:
                f = abs(f)  # an axis flipped by hand is no less off
                worst = max(worst, f / resolution[sensor], resolution[sensor] / f)
        if worst > plausible:
            values = " ".join(f"{v:g}" for v in scale)
            problems.append(
                f"{sensor}.scale [{values}] makes no number of a count"
                if sensor not in resolution
                else f"{sensor}.scale [{values}] (counts per unit) is up to {worst:.3g} times off the nominal"
                f" {1.0 / resolution[sensor]:.4g} (a resolution written where counts per unit go?)"
            )
        if np.any(scale != 1.0) and not np.any(null != 0.0) and sensor != "gyro":
            problems.append(f"{sensor} has scales but no nulls (null 0 is no 12-bit count's middle)")
    if cal.mag_soft_iron is not None:
        W = np.asarray(cal.mag_soft_iron, dtype=float)
        with np.errstate(over="ignore"):  # (absurd values: the determinant overflows, and is refused)
            det = np.linalg.det(W)
        if not abs(det) > 1e-9 * max(np.abs(W).max(), 1e-300) ** 3:  # (finite: Calibration)
            problems.append("mag.soft_iron is singular: it would flatten the field")
    for sensor in _ALIGNED:
        M = np.asarray(getattr(cal, f"{sensor}_misalignment"), dtype=float)
        if not np.all(np.isfinite(M)):
            problems.append(f"{sensor}.misalignment is not finite: {M.tolist()}")
            continue
        off = np.abs(M - np.diag(np.diag(M)))
        i, j = np.unravel_index(int(off.argmax()), off.shape)
        if off[i, j] > MISALIGNMENT_LIMIT:
            problems.append(
                f"{sensor}.misalignment has a cross-axis term of {M[i, j]:.3g}"
                f" ({math.degrees(off[i, j]):.2g} deg, {'xyz'[i]} from {'xyz'[j]}), more than"
                f" {MISALIGNMENT_LIMIT:.3g} ({math.degrees(MISALIGNMENT_LIMIT):.0f} deg): the"
                f" {'turns' if sensor == 'gyro' else 'poses'} were not about the board axes"
            )
    return problems
