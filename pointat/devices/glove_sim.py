r"""A virtual Pointing-at glove: scripted hand motion, a mote's sensor model, and its frames.

Three layers, each usable alone:

* :class:`MotionScript` -- ground truth.  A looping list of :class:`Segment` moves of the hand (azimuth,
  elevation and roll of the pointing axis, eased so that the angular rate is continuous), giving the
  orientation :math:`q(t)` (sensor -> NWU) and the angular rate :math:`\omega(t)` in the sensor frame.
* :class:`SensorModel` -- what the mote's sensors read in that pose, as 12-bit ADC counts: gyro (with a
  constant bias and white noise), accelerometer (specific force of gravity) and magnetometer (the
  Earth's field with its dip), through a :class:`~pointat.devices.mote_frame.MoteSpec`.
* :class:`GloveSimulator` -- samples both at a fixed rate into
  :class:`~pointat.devices.mote_frame.Frame` values with a running ``n_pack``, deterministically for a
  seed; :class:`PtyGlove` writes them in real time into a pseudo-terminal, so the real serial path
  (:class:`~pointat.devices.serial_reader.SerialMoteReader`) can be exercised without hardware.

Pose angles (degrees) follow pointat's conventions (:mod:`pointat.maths`): azimuth of the pointing axis
(sensor x), 0 = front = north, positive = left; elevation positive up; roll about the hand axis,
positive turns the back of the hand (sensor z) towards the right (for a right hand: thumb up).  The
orientation is :math:`q = q_z(\mathrm{az}) \otimes q_y(-\mathrm{el}) \otimes q_x(\mathrm{roll})`
(:func:`~pointat.maths.quaternion.euler_to_quat` with yaw = az, pitch = -el).  The hand rotates about
the sensor; its translation is not modelled (the accelerometer sees gravity only).

The ADC resolutions are :data:`~pointat.devices.mote_frame.DEFAULT_RESOLUTION` (Torre Table 1 units:
°/s, m/s², gauss per count), re-exported here with :class:`MoteSpec` and :data:`DEFAULT_SPEC`.

Examples
--------
>>> sim = GloveSimulator(seed=1)
>>> t, frame, q = sim.sample(0)
>>> t, frame.mote, frame.n_pack, q.round(12).tolist()
(0.0, 1, 0, [1.0, 0.0, 0.0, 0.0])
>>> round(DEFAULT_SPEC.to_units(frame.channels)[5], 1)     # accel z at rest: +g (specific force)
9.8
>>> GloveSimulator(seed=1).sample(250).frame == sim.sample(250).frame    # deterministic, random access
True
"""

from __future__ import annotations

import bisect
import logging
import math
import os
import threading
import time
import tty
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from pointat.devices._threads import join, start_daemon
from pointat.devices.mote_frame import (
    DEFAULT_RESOLUTION,
    DEFAULT_SPEC,
    Frame,
    MoteSpec,
    encode_frame,
    encode_text,
)

__all__ = [
    "DEFAULT_RESOLUTION",
    "DEFAULT_SPEC",
    "GRAVITY",
    "GloveSimulator",
    "MoteSpec",
    "MotionScript",
    "PtyGlove",
    "Sample",
    "Segment",
    "SensorModel",
    "Truth",
    "default_script",
    "hold",
]

log = logging.getLogger(__name__)

GRAVITY = 9.80665
"""Standard gravity, m/s²."""


# --------------------------------------------------------------------------------------------------
# Motion
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Segment:
    """Move the hand to a target pose in ``duration`` seconds (eased); ``None`` keeps that angle.

    Parameters
    ----------
    duration : float
        Seconds, > 0.
    azimuth, elevation, roll : float or None
        Target angles in degrees (see the module docstring for their sense).  A segment with all three
        ``None`` (or equal to the current pose) is a hold.
    label : str
        What the segment shows, for plots and test selection.
    """

    duration: float
    azimuth: float | None = None
    elevation: float | None = None
    roll: float | None = None
    label: str = ""


def hold(duration: float, label: str = "hold") -> Segment:
    """A segment that keeps the pose for ``duration`` seconds."""
    return Segment(duration, label=label)


def _ease(s: float) -> tuple[float, float]:
    """Cosine easing on [0, 1] and its derivative: zero slope at both ends, so rates are continuous."""
    return 0.5 - 0.5 * math.cos(math.pi * s), 0.5 * math.pi * math.sin(math.pi * s)


class MotionScript:
    r"""A scripted hand motion: a sequence of eased moves between poses, looping by default.

    Within a segment from pose :math:`p_0` to :math:`p_1` (azimuth, elevation, roll) of duration
    :math:`T`, :math:`p(t) = p_0 + e(s)(p_1 - p_0)` with :math:`s = t/T` and the cosine easing
    :math:`e(s) = (1 - \cos \pi s)/2`, whose slope is zero at both ends: the angular rate is continuous
    (and zero between segments).  With yaw :math:`\psi` = az, pitch :math:`\theta` = -el, roll
    :math:`\phi`, the rate in the sensor frame is the Z-Y'-X'' kinematic relation

    .. math::
        \omega_x = \dot\phi - \dot\psi \sin\theta, \quad
        \omega_y = \dot\theta \cos\phi + \dot\psi \cos\theta \sin\phi, \quad
        \omega_z = -\dot\theta \sin\phi + \dot\psi \cos\theta \cos\phi

    which equals :math:`2\,q^* \otimes \dot q` (vector part).

    Parameters
    ----------
    segments : sequence of Segment
        The moves, in order.
    start : tuple of 3 float
        Initial (azimuth, elevation, roll) in degrees.
    loop : bool
        Repeat forever (``t`` is taken modulo :attr:`duration`); the last pose must then equal
        ``start``.  Otherwise the pose is held after the end (and before 0).

    Raises
    ------
    ValueError
        A non-positive duration, an elevation beyond ±85° (too near the gimbal-locked vertical), or a
        looping script that does not come back to its start.

    Examples
    --------
    >>> s = MotionScript([Segment(2.0, azimuth=90.0), Segment(2.0, azimuth=0.0)])
    >>> s.duration, s.pose(1.0), s.pose(2.0), s.pose(5.0)
    (4.0, (45.0, 0.0, 0.0), (90.0, 0.0, 0.0), (45.0, 0.0, 0.0))
    >>> [round(float(w), 6) for w in s.angular_rate(1.0)]            # peak yaw rate: pi/2 * 90 deg / 2 s
    [0.0, 0.0, 1.233701]
    """

    def __init__(
        self,
        segments: Sequence[Segment],
        *,
        start: tuple[float, float, float] = (0.0, 0.0, 0.0),
        loop: bool = True,
    ) -> None:
        if not segments:
            raise ValueError("a motion script needs at least one segment")
        poses = [tuple(float(a) for a in start)]
        times = [0.0]
        for i, seg in enumerate(segments):
            if not seg.duration > 0:
                raise ValueError(f"segment {i} ({seg.label!r}): duration must be > 0, got {seg.duration}")
            prev = poses[-1]
            pose = (
                prev[0] if seg.azimuth is None else float(seg.azimuth),
                prev[1] if seg.elevation is None else float(seg.elevation),
                prev[2] if seg.roll is None else float(seg.roll),
            )
            if abs(pose[1]) > 85.0:
                raise ValueError(f"segment {i} ({seg.label!r}): elevation must be within ±85°, got {pose[1]}")
            poses.append(pose)
            times.append(times[-1] + float(seg.duration))
        if abs(poses[0][1]) > 85.0:
            raise ValueError(f"start elevation must be within ±85°, got {poses[0][1]}")
        if loop and not np.allclose(poses[-1], poses[0], atol=1e-9):
            raise ValueError(f"a looping script must end at its start pose {poses[0]}, ends at {poses[-1]}")
        self.segments: tuple[Segment, ...] = tuple(segments)
        self.loop = loop
        self._poses = poses
        self._times = times

    @property
    def duration(self) -> float:
        """Length of one pass through the script, seconds."""
        return self._times[-1]

    @property
    def boundaries(self) -> tuple[float, ...]:
        """Start time of every segment, and the end time (seconds, one pass)."""
        return tuple(self._times)

    def _locate(self, t: float) -> tuple[int, float]:
        """Segment index and eased-from-zero local fraction for time ``t``."""
        if self.loop:
            t = math.fmod(t, self.duration)
            if t < 0:
                t += self.duration
        if t <= 0.0:
            return 0, 0.0
        if t >= self.duration:
            return len(self.segments) - 1, 1.0
        i = bisect.bisect_right(self._times, t) - 1
        return i, (t - self._times[i]) / self.segments[i].duration

    def segment_at(self, t: float) -> tuple[int, Segment]:
        """Index and segment active at time ``t``."""
        i, _ = self._locate(t)
        return i, self.segments[i]

    def pose(self, t: float) -> tuple[float, float, float]:
        """(azimuth, elevation, roll) in degrees at time ``t`` seconds."""
        i, s = self._locate(t)
        e, _ = _ease(s)
        p0, p1 = self._poses[i], self._poses[i + 1]
        return tuple(a + e * (b - a) for a, b in zip(p0, p1, strict=True))  # type: ignore[return-value]

    def pose_rate(self, t: float) -> tuple[float, float, float]:
        """Time derivative of :meth:`pose`, degrees per second."""
        i, s = self._locate(t)
        if s <= 0.0 or s >= 1.0:
            return (0.0, 0.0, 0.0)
        _, de = _ease(s)
        p0, p1 = self._poses[i], self._poses[i + 1]
        d = self.segments[i].duration
        return tuple(de * (b - a) / d for a, b in zip(p0, p1, strict=True))  # type: ignore[return-value]

    def orientation(self, t: float) -> np.ndarray:
        """Unit quaternion ``(w, x, y, z)``, sensor -> NWU, at time ``t`` seconds: yaw = az, pitch = -el,
        roll, as :func:`~pointat.maths.quaternion.euler_to_quat` (on floats: one sample at a time)."""
        az, el, roll = self.pose(t)
        ca, sa = math.cos(math.radians(az) / 2), math.sin(math.radians(az) / 2)
        cb, sb = math.cos(math.radians(-el) / 2), math.sin(math.radians(-el) / 2)
        cc, sc = math.cos(math.radians(roll) / 2), math.sin(math.radians(roll) / 2)
        return np.array(
            [
                ca * cb * cc + sa * sb * sc,
                ca * cb * sc - sa * sb * cc,
                ca * sb * cc + sa * cb * sc,
                sa * cb * cc - ca * sb * sc,
            ]
        )

    def angular_rate(self, t: float) -> np.ndarray:
        """Angular rate in the sensor frame, rad/s, shape (3,), at time ``t`` seconds (analytic)."""
        az, el, roll = (math.radians(a) for a in self.pose(t))
        d_az, d_el, d_roll = (math.radians(a) for a in self.pose_rate(t))
        theta, d_theta = -el, -d_el
        s_phi, c_phi = math.sin(roll), math.cos(roll)
        return np.array(
            [
                d_roll - d_az * math.sin(theta),
                d_theta * c_phi + d_az * math.cos(theta) * s_phi,
                -d_theta * s_phi + d_az * math.cos(theta) * c_phi,
            ]
        )


def default_script() -> MotionScript:
    """The demo: 41 s, looping.  Sweeps and holds at 5.0 speaker directions, raise and lower, roll gesture.

    ============  =======================================================================
    time (s)      motion
    ============  =======================================================================
    0 - 2         rest, pointing front
    2 - 12.5      to the front-left (+30°) and rear-left (+110°) speakers, then a slow
                  sweep right across the front to the rear-right (-110°), holds between
    12.5 - 17     to the front-right speaker (-30°) and back to front
    17 - 25       raise to +45°, lower to -30°, back to the horizon
    25 - 34.5     roll 90° about the hand axis (Torre's distance gesture), sweep the
                  azimuth in that pose (+60° then +20°: the distance changes), roll back
    34.5 - 41     back to front; rest
    ============  =======================================================================

    The peak rate is 141 °/s (the 90° rolls), inside the gyro's ±204.8 °/s.
    """
    return MotionScript(
        [
            hold(2.0, "rest, front"),
            Segment(1.5, azimuth=30.0, label="to front-left speaker"),
            hold(1.0, "at +30"),
            Segment(2.0, azimuth=110.0, label="to rear-left speaker"),
            hold(1.0, "at +110"),
            Segment(4.0, azimuth=-110.0, label="sweep right across the front"),
            hold(1.0, "at -110"),
            Segment(1.5, azimuth=-30.0, label="to front-right speaker"),
            hold(1.0, "at -30"),
            Segment(1.5, azimuth=0.0, label="back to front"),
            hold(0.5, "front"),
            Segment(1.5, elevation=45.0, label="raise"),
            hold(1.0, "up 45"),
            Segment(2.0, elevation=-30.0, label="lower"),
            hold(1.0, "down 30"),
            Segment(1.5, elevation=0.0, label="back to horizon"),
            hold(1.0, "horizon"),
            Segment(1.0, roll=90.0, label="roll 90 (distance mode)"),
            hold(1.0, "rolled"),
            Segment(2.0, azimuth=60.0, label="distance sweep"),
            hold(1.0, "distance held"),
            Segment(1.5, azimuth=20.0, label="distance back"),
            hold(1.0, "distance held"),
            Segment(1.0, roll=0.0, label="roll back -90"),
            hold(1.0, "unrolled"),
            Segment(1.5, azimuth=0.0, label="back to front"),
            hold(5.0, "rest, front"),
        ]
    )


# --------------------------------------------------------------------------------------------------
# Sensors
# --------------------------------------------------------------------------------------------------


class SensorModel:
    r"""The mote's nine sensors as seen through its 12-bit ADC.

    Physical readings in the sensor frame, in Torre's Table 1 units:

    * gyro (°/s): :math:`\omega + b + n_g`, with a constant bias :math:`b` per axis and white noise;
    * accelerometer (m/s², specific force): :math:`R(q)^T (0, 0, g) + n_a` (reads :math:`+g` on the
      axis pointing up at rest; hand translation is not modelled);
    * magnetometer (gauss): :math:`R(q)^T B (\cos\delta, 0, -\sin\delta) + n_m`, the Earth's field of
      strength :math:`B` pointing north and down by the dip :math:`\delta`;

    then counts = round(null + value / resolution), clipped to 0..4095 (:meth:`MoteSpec.to_counts`).

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
    ) -> None:
        self.spec = spec
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

    def true_values(self, q: ArrayLike, omega: ArrayLike) -> np.ndarray:
        """Noiseless, unbiased readings, shape (9,): gyro °/s, accel m/s², mag gauss (sensor frame)."""
        w, x, y, z = (float(c) for c in np.ravel(q))
        out = [math.degrees(float(r)) for r in np.ravel(omega)]
        for vx, vy, vz in self._earth:  # each earth vector into the sensor frame: q* (0, v) q
            tx, ty, tz = 2.0 * (y * vz - z * vy), 2.0 * (z * vx - x * vz), 2.0 * (x * vy - y * vx)
            out += (
                vx - w * tx + (y * tz - z * ty),
                vy - w * ty + (z * tx - x * tz),
                vz - w * tz + (x * ty - y * tx),
            )
        return np.array(out)

    def values(self, q: ArrayLike, omega: ArrayLike, rng: np.random.Generator | None = None) -> np.ndarray:
        """Readings with bias and (if ``rng`` is given) noise, shape (9,), physical units."""
        v = self.true_values(q, omega)
        v[:3] += self.gyro_bias_dps
        if rng is not None:
            v += rng.standard_normal(9) * self.noise_sd
        return v

    def counts(
        self, q: ArrayLike, omega: ArrayLike, rng: np.random.Generator | None = None
    ) -> tuple[int, ...]:
        """ADC counts 0..4095 of :meth:`values`."""
        return self.spec.to_counts(self.values(q, omega, rng).tolist())


# --------------------------------------------------------------------------------------------------
# Simulator
# --------------------------------------------------------------------------------------------------


class Sample(NamedTuple):
    """One simulated sample: time (s), the mote frame, the true orientation (sensor -> NWU)."""

    t: float
    frame: Frame
    q: np.ndarray


class Truth(NamedTuple):
    """Noiseless ground truth of a sample (sensor frame): rad/s, m/s², gauss."""

    t: float
    q: np.ndarray
    omega: np.ndarray
    specific_force: np.ndarray
    field: np.ndarray


class GloveSimulator:
    """A glove sampled at a fixed rate: frames with ground truth, deterministic for a seed.

    ``sample(k)`` depends only on ``k`` and the seed (each sample draws its noise from its own
    generator), so samples can be produced in any order, again and again.

    Parameters
    ----------
    script : MotionScript, optional
        The motion (default :func:`default_script`).
    rate_hz : float
        Sample rate, Hz.
    mote_id : int
        Mote id in the frames, 0..255.
    seed : int
        Seeds the noise and, for the default sensor model, the gyro bias.
    sensor : SensorModel, optional
        Default ``SensorModel(seed=seed)``.
    n_pack_start : int
        Counter of sample 0 (the counter wraps at 65536).
    """

    def __init__(
        self,
        script: MotionScript | None = None,
        rate_hz: float = 100.0,
        mote_id: int = 1,
        seed: int = 0,
        sensor: SensorModel | None = None,
        *,
        n_pack_start: int = 0,
    ) -> None:
        if not rate_hz > 0:
            raise ValueError(f"rate_hz must be > 0, got {rate_hz}")
        if not 0 <= mote_id <= 255:
            raise ValueError(f"mote_id must be 0..255, got {mote_id}")
        self.script = script if script is not None else default_script()
        self.rate_hz = float(rate_hz)
        self.mote_id = int(mote_id)
        self.seed = int(seed)
        self.sensor = sensor if sensor is not None else SensorModel(seed=seed)
        self.n_pack_start = int(n_pack_start)

    @property
    def period(self) -> float:
        """Sample period, seconds."""
        return 1.0 / self.rate_hz

    def time(self, k: int) -> float:
        """Time of sample ``k``, seconds."""
        return k / self.rate_hz

    def truth(self, k: int) -> Truth:
        """Noiseless ground truth of sample ``k``."""
        t = self.time(k)
        q = self.script.orientation(t)
        omega = self.script.angular_rate(t)
        v = self.sensor.true_values(q, omega)
        return Truth(t, q, omega, v[3:6], v[6:9])

    def sample(self, k: int) -> Sample:
        """Sample ``k``: ``(t, frame, q_true)``."""
        if k < 0:
            raise ValueError(f"sample index must be >= 0, got {k}")
        t = self.time(k)
        q = self.script.orientation(t)
        rng = np.random.default_rng([self.seed, 1, k])
        counts = self.sensor.counts(q, self.script.angular_rate(t), rng)
        return Sample(t, Frame(self.mote_id, (self.n_pack_start + k) & 0xFFFF, counts), q)

    def samples(self, n: int, start: int = 0) -> list[Sample]:
        """Samples ``start .. start + n - 1``."""
        return [self.sample(k) for k in range(start, start + n)]

    def __iter__(self) -> Iterator[Sample]:
        """Samples 0, 1, 2, ... without end (the default script loops)."""
        k = 0
        while True:
            yield self.sample(k)
            k += 1


# --------------------------------------------------------------------------------------------------
# Pseudo-terminal glove
# --------------------------------------------------------------------------------------------------


class PtyGlove:
    """A simulated glove behind a pseudo-terminal: open :attr:`device_path` like a real base station.

    A thread writes one encoded frame per sample period to the pty master, on a deadline schedule
    (``next += period``), so the rate does not drift.  The master is non-blocking: when nobody reads the
    device, bytes pile up in the pty (~18 kB on Linux) and then in a buffer of ``max_pending`` bytes,
    beyond which they are dropped (counted in :attr:`dropped_bytes`), as a radio would.

    Parameters
    ----------
    simulator : GloveSimulator, optional
        Source of the frames (default ``GloveSimulator()``).
    format : {"binary", "text"}
        Framing written to the device.
    start_index : int
        First sample index to send.
    max_pending : int
        Bytes kept while the device is not read.

    Examples
    --------
    >>> with PtyGlove(GloveSimulator(rate_hz=200.0)) as glove:
    ...     glove.device_path.startswith("/dev/")
    True
    """

    def __init__(
        self,
        simulator: GloveSimulator | None = None,
        *,
        format: Literal["binary", "text"] = "binary",
        start_index: int = 0,
        max_pending: int = 65536,
    ) -> None:
        if format not in ("binary", "text"):
            raise ValueError(f"format must be 'binary' or 'text', got {format!r}")
        self.simulator = simulator if simulator is not None else GloveSimulator()
        self.format = format
        self.max_pending = int(max_pending)
        self._encode = encode_frame if format == "binary" else encode_text
        self._index = int(start_index)
        self._pending = bytearray()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()
        self.sent = 0
        self.dropped_bytes = 0
        self._master, self._slave = os.openpty()
        try:
            tty.setraw(self._slave)  # no echo into the master, no line discipline before a reader opens it
            os.set_blocking(self._master, False)
            self.device_path: str = os.ttyname(self._slave)
        except OSError:
            os.close(self._master)
            os.close(self._slave)
            raise
        self._closed = False

    @property
    def index(self) -> int:
        """Index of the next sample to send."""
        return self._index

    @property
    def is_running(self) -> bool:
        """True while the writer thread is alive."""
        return self._thread is not None and self._thread.is_alive()

    def start(self) -> PtyGlove:
        """Start sending (no-op if running).  Returns ``self``."""
        if self._closed:
            raise RuntimeError("PtyGlove is closed")
        if not self.is_running:
            self._stop.clear()
            self._thread = start_daemon(self._run, f"pty-glove:{self.device_path}")
        return self

    def stop(self, timeout: float = 2.0) -> None:
        """Stop sending; idempotent.  The device stays open (see :meth:`close`)."""
        self._stop.set()
        join(self._thread, timeout)

    def close(self) -> None:
        """Stop and close the pseudo-terminal (readers then see the device vanish); idempotent."""
        self.stop()
        if not self._closed:
            self._closed = True
            for fd in (self._master, self._slave):
                try:
                    os.close(fd)
                except OSError as exc:
                    log.debug("closing pty fd %d: %s", fd, exc)

    def __enter__(self) -> PtyGlove:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def send(self, k: int | None = None) -> None:
        """Encode sample ``k`` (default: the next one) and write it now; used by the thread and tests."""
        with self._lock:
            if k is None:
                k = self._index
                self._index += 1
            self._pending += self._encode(self.simulator.sample(k).frame)
            self.sent += 1
            try:
                n = os.write(self._master, self._pending)
                del self._pending[:n]
            except BlockingIOError:
                pass
            if len(self._pending) > self.max_pending:
                self.dropped_bytes += len(self._pending)
                log.debug(
                    "pty glove %s: nobody reads, dropped %d bytes", self.device_path, len(self._pending)
                )
                self._pending.clear()

    def _run(self) -> None:
        period = self.simulator.period
        deadline = time.monotonic()
        while not self._stop.is_set():
            try:
                self.send()
            except OSError as exc:
                log.error("pty glove %s: write failed: %s", self.device_path, exc)
                break
            except Exception:  # never die silently
                log.exception("pty glove %s: unexpected error", self.device_path)
                break
            deadline += period
            late = time.monotonic() - deadline
            if late > 0.25:  # stalled (debugger, suspended VM): restart the schedule instead of bursting
                log.warning("pty glove %s: %.3f s late, restarting the schedule", self.device_path, late)
                deadline = time.monotonic()
            elif late < 0:
                self._stop.wait(-late)
