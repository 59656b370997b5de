"""What the mote's sensors read in a pose, as 12-bit ADC counts (:class:`SensorModel`).

Gyro (with a constant bias and white noise), accelerometer (specific force: gravity and the hand's
linear acceleration) and magnetometer (the Earth's field with its dip), through a
:class:`~pointat.devices.mote_frame.MoteSpec`; optionally saturating at a full scale of its own.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from pointat.devices.mote_frame import DEFAULT_SPEC, MoteSpec

from .bursts import GRAVITY


def _cross_axis(given: ArrayLike | None, name: str) -> np.ndarray | None:
    """A :class:`SensorModel` cross-axis matrix from a 3x3 matrix or six angles in degrees (or None)."""
    if given is None:
        return None
    a = np.asarray(given, dtype=float)
    if a.shape == (6,):
        T = np.eye(3)
        T[~np.eye(3, dtype=bool)] = np.tan(np.radians(a))  # row major: xy, xz, yx, yz, zx, zy
        a = T / np.linalg.norm(T, axis=1, keepdims=True)
    if a.shape != (3, 3) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be a finite 3x3 matrix or 6 angles in degrees, got {given!r}")
    return a


class SensorModel:
    r"""The mote's nine sensors as seen through its 12-bit ADC.

    Physical readings in the sensor frame, in Torre's Table 1 units:

    * gyro (°/s): :math:`\omega + b + n_g`, with a constant bias :math:`b` per axis and white noise;
    * accelerometer (m/s², specific force): :math:`R(q)^T ((0, 0, g) + a) + n_a`, with :math:`a` the
      hand's linear acceleration in the earth frame (``accel_earth``, from bursts, :class:`Burst`; zero
      by default): it reads :math:`+g` on the axis pointing up at rest;
    * magnetometer (gauss): :math:`R(q)^T B (\cos\delta, 0, -\sin\delta) + n_m`, the Earth's field of
      strength :math:`B` pointing north and down by the dip :math:`\delta`;

    the gyro's and the accelerometer's true values first seen through their cross-axis matrices, where set
    (``gyro_misalignment``, ``acc_misalignment``: axes not orthogonal, or not along the board's; the bias
    is added after, per axis);
    then, if ``gyro_range`` or ``acc_range`` is set, each gyro or accelerometer axis clipped to
    ±range, as a MEMS part saturates at its full scale; then counts = round(null + value /
    resolution), clipped to 0..4095 (:meth:`MoteSpec.to_counts`).  That 12-bit clip is the glove's own
    full scale (:func:`adc_full_scale`): with :data:`DEFAULT_SPEC`, about ±4.0 g (±39.3 m/s²) for the
    accelerometer and ±204.8 °/s for the gyro, so the counts saturate there whatever the ranges.

    Parameters
    ----------
    spec : MoteSpec
        Nulls and resolutions (:data:`DEFAULT_SPEC`).
    gyro_bias_dps : array_like of 3 float, optional
        Gyro bias, °/s.  Default: drawn uniformly in ``±gyro_bias_range`` from ``seed``.
    gyro_bias_range : float
        Half-width of the default bias draw, °/s.
    gyro_noise_dps, accel_noise, mag_noise_gauss : float
        White-noise standard deviations, °/s, m/s², gauss.  Defaults suit the ADXRS150 / ADXL202 class
        of parts over a ~50 Hz bandwidth.
    gravity : float
        m/s².
    field_gauss : float
        Magnitude of the Earth's field, gauss (0.48 by default, mid-latitude Europe).
    dip_deg : float
        Magnetic inclination, degrees, positive down (67° by default, Ireland).
    seed : int
        Seeds the default bias.
    acc_range : float, optional
        Full scale of the accelerometer, m/s² (±, per axis, > 0): readings beyond are clipped.  Default
        none (only the ADC clips).
    gyro_range : float, optional
        Full scale of the gyro, °/s (±, per axis, > 0), likewise.
    gyro_misalignment, acc_misalignment : array_like, optional
        Cross-axis errors: a 3x3 matrix :math:`T`, the sensor reading :math:`T v` of the true value
        :math:`v` in the board frame (row *i*: axis *i*'s sensitive direction times its relative gain);
        or six small angles, degrees, ``(xy, xz, yx, yz, zx, zy)``: sensor axis *i* tipped towards board
        axis *j* by :math:`a_{ij}` (row *i* is :math:`e_i + \sum_j \tan a_{ij}\, e_j`, made of unit
        length).  Default none: the sensor's axes are the board's, and the readings are as they always
        were, to the bit.

    Examples
    --------
    >>> sensor = SensorModel.ideal(acc_range=2 * GRAVITY)
    >>> lift = [0.0, 0.0, 2 * GRAVITY]                  # 2 g up, on top of gravity: 3 g, clipped to 2 g
    >>> sensor.values([1.0, 0, 0, 0], [0.0, 0, 0], accel_earth=lift)[3:6].round(4).tolist()
    [0.0, 0.0, 19.6133]
    >>> tipped = SensorModel.ideal(acc_misalignment=[0.0, 0.0, 0.0, 0.0, 0.5, 0.0])  # z tipped 0.5 deg to x
    >>> tipped.values([1.0, 0, 0, 0], [0.0, 0, 0])[3:6].round(4).tolist()           # level: z feels g
    [0.0, 0.0, 9.8063]
    >>> tipped.acc_misalignment.round(6).tolist()[2]
    [0.008727, 0.0, 0.999962]
    """

    def __init__(
        self,
        spec: MoteSpec = DEFAULT_SPEC,
        *,
        gyro_bias_dps: ArrayLike | None = None,
        gyro_bias_range: float = 3.0,
        gyro_noise_dps: float = 0.3,
        accel_noise: float = 0.02,
        mag_noise_gauss: float = 0.002,
        gravity: float = GRAVITY,
        field_gauss: float = 0.48,
        dip_deg: float = 67.0,
        seed: int = 0,
        acc_range: float | None = None,
        gyro_range: float | None = None,
        gyro_misalignment: ArrayLike | None = None,
        acc_misalignment: ArrayLike | None = None,
    ) -> None:
        self.spec = spec
        self.gyro_misalignment = _cross_axis(gyro_misalignment, "gyro_misalignment")
        self.acc_misalignment = _cross_axis(acc_misalignment, "acc_misalignment")
        for name, r in (("acc_range", acc_range), ("gyro_range", gyro_range)):
            if r is not None and not (math.isfinite(r) and r > 0):
                raise ValueError(f"{name} must be a finite number > 0 or None, got {r!r}")
        self.acc_range = None if acc_range is None else float(acc_range)
        self.gyro_range = None if gyro_range is None else float(gyro_range)
        if gyro_bias_dps is None:
            bias = np.random.default_rng([seed, 0xB1A5]).uniform(-gyro_bias_range, gyro_bias_range, 3)
        else:
            bias = np.asarray(gyro_bias_dps, dtype=float)
            if bias.shape != (3,):
                raise ValueError(f"gyro_bias_dps needs 3 values, got shape {bias.shape}")
        self.gyro_bias_dps = bias
        self.noise_sd = np.repeat([gyro_noise_dps, accel_noise, mag_noise_gauss], 3).astype(float)
        if np.any(self.noise_sd < 0):
            raise ValueError(f"noise levels must be >= 0, got {self.noise_sd[::3]}")
        self.gravity = float(gravity)
        self.field_gauss = float(field_gauss)
        self.dip_deg = float(dip_deg)
        dip = math.radians(dip_deg)
        self.gravity_earth = np.array([0.0, 0.0, self.gravity])
        self.field_earth = self.field_gauss * np.array([math.cos(dip), 0.0, -math.sin(dip)])
        self._earth = (tuple(self.gravity_earth.tolist()), tuple(self.field_earth.tolist()))

    @classmethod
    def ideal(cls, spec: MoteSpec = DEFAULT_SPEC, **kwargs: float) -> SensorModel:
        """A model without bias or noise (quantisation only)."""
        return cls(
            spec,
            gyro_bias_dps=(0.0, 0.0, 0.0),
            gyro_noise_dps=0.0,
            accel_noise=0.0,
            mag_noise_gauss=0.0,
            **kwargs,
        )

    def true_values(self, q: ArrayLike, omega: ArrayLike, accel_earth: ArrayLike | None = None) -> np.ndarray:
        """Noiseless, unbiased, unclipped readings, shape (9,): gyro °/s, accel m/s², mag gauss (sensor
        frame); ``accel_earth`` is the hand's linear acceleration, m/s², earth frame (NWU)."""
        w, x, y, z = (float(c) for c in np.ravel(q))
        out = [math.degrees(float(r)) for r in np.ravel(omega)]
        earth = self._earth
        if accel_earth is not None:
            (gx, gy, gz), field = earth
            ax, ay, az = (float(c) for c in np.ravel(accel_earth))
            earth = ((gx + ax, gy + ay, gz + az), field)
        for vx, vy, vz in earth:  # each earth vector into the sensor frame: q* (0, v) q
            tx, ty, tz = 2.0 * (y * vz - z * vy), 2.0 * (z * vx - x * vz), 2.0 * (x * vy - y * vx)
            out += (
                vx - w * tx + (y * tz - z * ty),
                vy - w * ty + (z * tx - x * tz),
                vz - w * tz + (x * ty - y * tx),
            )
        return np.array(out)

    def values(
        self,
        q: ArrayLike,
        omega: ArrayLike,
        rng: np.random.Generator | None = None,
        *,
        accel_earth: ArrayLike | None = None,
    ) -> np.ndarray:
        """Readings through the cross-axis matrices (where set), with bias and (if ``rng`` is given)
        noise, clipped to ``gyro_range`` and ``acc_range`` where set, shape (9,), physical units."""
        v = self.true_values(q, omega, accel_earth)
        if self.gyro_misalignment is not None:
            v[:3] = self.gyro_misalignment @ v[:3]
        if self.acc_misalignment is not None:
            v[3:6] = self.acc_misalignment @ v[3:6]
        v[:3] += self.gyro_bias_dps
        if rng is not None:
            v += rng.standard_normal(9) * self.noise_sd
        if self.gyro_range is not None:
            np.clip(v[:3], -self.gyro_range, self.gyro_range, out=v[:3])
        if self.acc_range is not None:
            np.clip(v[3:6], -self.acc_range, self.acc_range, out=v[3:6])
        return v

    def counts(
        self,
        q: ArrayLike,
        omega: ArrayLike,
        rng: np.random.Generator | None = None,
        *,
        accel_earth: ArrayLike | None = None,
    ) -> tuple[int, ...]:
        """ADC counts 0..4095 of :meth:`values`."""
        return self.spec.to_counts(self.values(q, omega, rng, accel_earth=accel_earth).tolist())
