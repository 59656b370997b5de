r"""A virtual Pointing-at glove: scripted hand motion, a mote's sensor model, and its frames.

Three layers, each usable alone:

* :class:`MotionScript` -- ground truth.  A looping list of :class:`Segment` moves of the hand (azimuth,
  elevation and roll of the pointing axis, eased so that the angular rate is continuous), giving the
  orientation :math:`q(t)` (sensor -> NWU) and the angular rate :math:`\omega(t)` in the sensor frame.
* :class:`Burst` -- ground truth of the hand's translation: percussive strokes and shakes, bursts of
  linear acceleration (:func:`burst_acceleration`, earth frame) whose velocity and displacement come
  back to zero, so the hand returns to where it was.
* :class:`SensorModel` -- what the mote's sensors read in that pose, as 12-bit ADC counts: gyro (with a
  constant bias and white noise), accelerometer (specific force: gravity and the hand's linear
  acceleration) and magnetometer (the Earth's field with its dip), through a
  :class:`~pointat.devices.mote_frame.MoteSpec`; optionally saturating at a full scale of its own.
* :class:`GloveSimulator` -- samples them at a fixed rate into
  :class:`~pointat.devices.mote_frame.Frame` values with a running ``n_pack``, deterministically for a
  seed; :class:`PtyGlove` writes them in real time into a pseudo-terminal, so the real serial path
  (:class:`~pointat.devices.serial_reader.SerialMoteReader`) can be exercised without hardware.

Pose angles (degrees) follow pointat's conventions (:mod:`pointat.maths`): azimuth of the pointing axis
(sensor x), 0 = front = north, positive = left; elevation positive up; roll about the hand axis,
positive turns the back of the hand (sensor z) towards the right (for a right hand: thumb up).  The
orientation is :math:`q = q_z(\mathrm{az}) \otimes q_y(-\mathrm{el}) \otimes q_x(\mathrm{roll})`
(:func:`~pointat.maths.quaternion.euler_to_quat` with yaw = az, pitch = -el).  The hand rotates about
the sensor; it translates only in bursts (:class:`Burst`; without them the accelerometer sees gravity
only), and translation leaves the orientation as it is.  The earth frame is NWU (x north, y west, z up).

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
>>> drum = GloveSimulator(seed=1, bursts=[Burst(start=1.0, duration=2.0, peak_g=3.0, rate=4.0)])
>>> [drum.sample(k).frame == sim.sample(k).frame for k in (99, 124)]    # before, in the 1st impact
[True, False]
>>> drum.truth(124).linear_acceleration.round(1).tolist()                # up: it stops the strike
[0.0, 0.0, 22.1]
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
    adc_full_scale,
    encode_frame,
    encode_text,
)

__all__ = [
    "DEFAULT_RESOLUTION",
    "DEFAULT_SPEC",
    "GRAVITY",
    "IMPACT_S",
    "Burst",
    "GloveSimulator",
    "MoteSpec",
    "MotionScript",
    "PtyGlove",
    "Sample",
    "Segment",
    "SensorModel",
    "Truth",
    "adc_full_scale",
    "burst_acceleration",
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
# Translation: strokes and shakes
# --------------------------------------------------------------------------------------------------

IMPACT_S = 0.015
"""Width of a stroke's impact lobe, seconds (at most a fifth of the stroke period)."""

BurstAxis = Literal["vertical", "pointing", "both"] | tuple[float, float, float]
"""The direction of a :class:`Burst`: a name, or an earth-frame (NWU) vector."""

_AXES = ("vertical", "pointing", "both")
_KINDS = ("strokes", "shake")


def _finite(name: str, value: float, *, above: float | None = None, minimum: float | None = None) -> float:
    """``value`` as a float, or a ValueError naming ``name``, the bound and what came."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"Burst {name} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"Burst {name} must be finite, got {value!r}")
    if above is not None and not v > above:
        raise ValueError(f"Burst {name} must be > {above:g}, got {value!r}")
    if minimum is not None and not v >= minimum:
        raise ValueError(f"Burst {name} must be >= {minimum:g}, got {value!r}")
    return v


def _cos2(x: np.ndarray, centre: float, width: float) -> np.ndarray:
    """A cos² pulse: 1 at ``centre``, 0 with zero slope at ``centre ± width/2`` and 0 beyond."""
    z = (x - centre) / width
    return np.where(np.abs(z) < 0.5, np.cos(np.pi * z) ** 2, 0.0)


@dataclass(frozen=True)
class Burst:
    r"""A burst of hand translation: percussive strokes or a shake, at known linear acceleration.

    The burst adds a linear acceleration :math:`a(t)\,\hat u(t)` (m/s², earth frame NWU) to the hand:
    a signed profile :math:`a(t)` (:meth:`profile`) along a unit direction :math:`\hat u`
    (:meth:`direction`).  Within each stroke, and over a whole shake, the earth-frame velocity and
    displacement come back to exactly zero (analytically, for a fixed :math:`\hat u`): the hand returns
    to where it was.  The largest :math:`|a|` is exactly ``peak_g`` × :data:`GRAVITY`.

    **Strokes** (drumming, striking).  The burst holds :attr:`count` = ⌊duration · rate⌋ whole strokes
    of period :math:`T = 1/\mathrm{rate}`, back to back.  Each stroke's acceleration is three cos²
    lobes :math:`c(\tau; \text{centre}, \text{width})` that do not overlap, with
    :math:`w = \min(\text{IMPACT\_S}, T/5)` (15 ms) and :math:`s = (T - w)/2`:

    .. math::
        a(\tau) = A \left[ a_1\, c(\tau; s/2, s) - a_2\, c(\tau; 3s/2, s) + c(\tau; T - w/2, w) \right],
        \quad a_1 = \frac{w (s + w)}{2 s^2}, \quad a_2 = a_1 + \frac{w}{s}

    a broad lift along :math:`+\hat u` (:math:`0 \le \tau < s`), a broad swing back along
    :math:`-\hat u` (:math:`s \le \tau < 2s`), and the sharp impact that stops the swing
    (the last :math:`w` seconds, acceleration along :math:`+\hat u`).  :math:`a_1` and :math:`a_2` make
    the integral and the first moment of :math:`a` over the stroke zero (velocity and displacement
    back to zero); since :math:`w \le T/5`, :math:`a_1 \le 3/8` and :math:`a_2 \le 7/8`, so the peak
    :math:`A` is the impact's.  The displacement is :math:`\ge 0` along :math:`\hat u` throughout (for
    ``vertical``: lift the hand, strike down, stop at the drum head, where it started).  The
    acceleration and its derivative are continuous (the position is a C³ bump).

    **Shake.**  :attr:`count` = ⌊duration · rate⌋ whole cycles (at least 2) of

    .. math::
        a(\tau) = -A\, e(\tau) \cos(2\pi\, \mathrm{rate}\, \tau)

    with the envelope :math:`e` rising as :math:`\sin^2(\pi u / 2)` over the first cycle (:math:`u` =
    τ · rate, in cycles), 1 in between and falling symmetrically over the last cycle, so that :math:`a`
    and its derivative are continuous.  For these one-cycle ramps :math:`\int e \cos = 0` over the
    burst, which gives zero velocity at its end, and :math:`e \cos` is symmetric about the burst's
    middle, so :math:`\int \tau\, a = 0` too: zero displacement.  :math:`|a| \le A`, reached where
    :math:`e = 1` and :math:`\cos = \pm 1`.  The hand swings back and forth between (about) its start
    and :math:`2A/\omega^2` along :math:`+\hat u` (:math:`\omega = 2\pi\,\mathrm{rate}`; up to 10/9 of
    that in the ramps).

    Parameters
    ----------
    start : float
        Start of the burst, seconds, >= 0.
    duration : float
        Seconds, > 0.  The burst ends after its last whole stroke or cycle (:attr:`length`).
    peak_g : float
        Peak \|linear acceleration\|, in standard gravities (:data:`GRAVITY`), > 0.
    rate : float
        Strokes, or shake cycles, per second (Hz), > 0.
    axis : {"vertical", "pointing", "both"} or 3 floats
        ``"vertical"``: up (NWU z).  ``"pointing"``: the sensor x axis (the pointing axis) in the earth
        frame, from the orientation at that instant.  ``"both"``: the unit vector along their sum (a
        diagonal, 45° up from the pointing axis when the hand is level; taken as vertical when the hand
        points straight down).  Or an explicit earth-frame vector (normalised here).
        With ``"pointing"`` or ``"both"`` the direction turns with the hand; while the hand rotates
        during a stroke, velocity and displacement come back to zero only approximately.
    kind : {"strokes", "shake"}
        See above.
    every : float
        Repeat the burst every ``every`` seconds from ``start`` (>= ``duration``); 0: once.

    Raises
    ------
    ValueError
        A parameter out of its range, an unknown kind or axis, a zero axis vector, fewer than one
        stroke or two shake cycles in ``duration``, or repeats that would overlap.

    Examples
    --------
    >>> b = Burst(start=1.0, duration=1.0, peak_g=2.0, rate=4.0)
    >>> b.count, b.length, round(float(b.profile(1.25 - 0.0075)), 3)   # the 1st impact's middle: 2 g
    (4, 1.0, 19.613)
    >>> float(b.profile(0.5)), float(b.profile(2.5))                    # before and after: at rest
    (0.0, 0.0)
    >>> Burst(0.0, 1.0, axis=(0.0, 3.0, 4.0)).axis
    (0.0, 0.6, 0.8)
    """

    start: float
    duration: float
    peak_g: float = 10.0
    rate: float = 5.0
    axis: BurstAxis = "vertical"
    kind: Literal["strokes", "shake"] = "strokes"
    every: float = 0.0

    def __post_init__(self) -> None:
        start = _finite("start", self.start, minimum=0.0)
        duration = _finite("duration", self.duration, above=0.0)
        peak_g = _finite("peak_g", self.peak_g, above=0.0)
        rate = _finite("rate", self.rate, above=0.0)
        every = _finite("every", self.every, minimum=0.0)
        if self.kind not in _KINDS:
            raise ValueError(f"Burst kind must be 'strokes' or 'shake', got {self.kind!r}")
        axis: BurstAxis
        if isinstance(self.axis, str):
            if self.axis not in _AXES:
                raise ValueError(
                    f"Burst axis must be 'vertical', 'pointing', 'both' or 3 numbers, got {self.axis!r}"
                )
            axis = self.axis
        else:
            try:
                u = np.asarray(self.axis, dtype=float)
            except (TypeError, ValueError):
                raise ValueError(f"Burst axis must be a name or 3 numbers, got {self.axis!r}") from None
            if u.shape != (3,) or not np.all(np.isfinite(u)):
                raise ValueError(f"Burst axis must be 3 finite numbers, got {self.axis!r}")
            norm = float(np.linalg.norm(u))
            if norm == 0.0:
                raise ValueError("Burst axis must not be the zero vector")
            axis = tuple(float(c) for c in u / norm)  # type: ignore[assignment]
        count = math.floor(duration * rate + 1e-9)
        least = 1 if self.kind == "strokes" else 2
        if count < least:
            what = "1 stroke" if least == 1 else "2 shake cycles"
            raise ValueError(
                f"Burst of {duration:g} s at {rate:g} Hz holds {duration * rate:.3g} {self.kind} periods; "
                f"it needs at least {what} (duration >= {least / rate:g} s)"
            )
        if every and every < duration:
            raise ValueError(f"Burst every must be 0 (once) or >= duration {duration:g} s, got {every:g}")
        for name, value in (
            ("start", start),
            ("duration", duration),
            ("peak_g", peak_g),
            ("rate", rate),
            ("every", every),
            ("axis", axis),
        ):
            object.__setattr__(self, name, value)

    @property
    def count(self) -> int:
        """Whole strokes, or shake cycles, in one burst."""
        return math.floor(self.duration * self.rate + 1e-9)

    @property
    def length(self) -> float:
        """Seconds from the start to the end of the last whole stroke or cycle (<= ``duration``)."""
        return self.count / self.rate

    @property
    def peak(self) -> float:
        """Peak \\|linear acceleration\\|, m/s²."""
        return self.peak_g * GRAVITY

    def active(self, t: float) -> bool:
        """True when time ``t`` (s) is inside the burst (or one of its repeats): its strokes or cycles."""
        tau = t - self.start
        if self.every and tau >= 0.0:
            tau = math.fmod(tau, self.every)
        return 0.0 <= tau < self.length

    def _local(self, t: np.ndarray) -> np.ndarray:
        """Time since the start of the burst occurrence covering ``t``; NaN outside every occurrence."""
        tau = t - self.start
        if self.every:
            tau = np.where(tau >= 0.0, np.fmod(tau, self.every), tau)
        return np.where((tau >= 0.0) & (tau < self.length), tau, np.nan)

    def profile(self, t: ArrayLike) -> np.ndarray:
        """Signed linear acceleration along :meth:`direction`, m/s², at time(s) ``t`` (s); 0 outside."""
        tau = self._local(np.asarray(t, dtype=float))
        inside = ~np.isnan(tau)
        tau = np.where(inside, tau, 0.0)
        if self.kind == "strokes":
            period = 1.0 / self.rate
            tau = tau - np.floor(tau * self.rate) * period  # time into the stroke
            tau = np.clip(tau, 0.0, period)  # rounding at a stroke's edge, where a is 0 anyway
            w = min(IMPACT_S, period / 5.0)
            s = (period - w) / 2.0
            a1 = w * (s + w) / (2.0 * s * s)
            a2 = a1 + w / s
            shape = a1 * _cos2(tau, s / 2, s) - a2 * _cos2(tau, 1.5 * s, s) + _cos2(tau, period - w / 2, w)
        else:
            u = tau * self.rate  # cycles
            n = self.count
            ramp = np.minimum(np.minimum(u, n - u), 1.0)
            shape = -(np.sin(0.5 * np.pi * np.clip(ramp, 0.0, 1.0)) ** 2) * np.cos(2.0 * np.pi * u)
        return np.where(inside, self.peak * shape, 0.0)

    def direction(self, q: ArrayLike | None = None) -> np.ndarray:
        """Earth-frame unit direction, shape (3,) or (N, 3) for orientations ``q`` (w, x, y, z) of shape
        (4,) or (N, 4), sensor -> NWU; ``q`` is needed for ``"pointing"`` and ``"both"``."""
        if not isinstance(self.axis, str):
            return np.array(self.axis)
        up = np.array([0.0, 0.0, 1.0])
        if self.axis == "vertical":
            return up
        if q is None:
            raise ValueError(f"a Burst along {self.axis!r} needs the orientation q")
        w, x, y, z = np.moveaxis(np.asarray(q, dtype=float), -1, 0)
        pointing = np.stack([1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + w * z), 2.0 * (x * z - w * y)], -1)
        if self.axis == "pointing":
            return pointing
        both = pointing + up
        norm = np.linalg.norm(both, axis=-1, keepdims=True)
        return np.where(norm > 1e-9, both / np.where(norm > 1e-9, norm, 1.0), up)

    def acceleration(self, t: ArrayLike, q: ArrayLike | None = None) -> np.ndarray:
        """Earth-frame (NWU) linear acceleration, m/s², shape (3,) for a scalar ``t`` or (N, 3)."""
        return self.profile(t)[..., None] * self.direction(q)


def burst_acceleration(
    bursts: Burst | Sequence[Burst], t: ArrayLike, q: ArrayLike | None = None
) -> np.ndarray:
    r"""The hand's linear acceleration from ``bursts`` at time(s) ``t``, earth frame (NWU), m/s².

    The sum of each burst's :meth:`Burst.acceleration` (bursts that overlap add up).

    Parameters
    ----------
    bursts : Burst or sequence of Burst
        The bursts.
    t : float or array_like, shape (N,)
        Time(s), seconds.
    q : array_like, shape (4,) or (N, 4), optional
        True orientation(s) (w, x, y, z), sensor -> NWU, at ``t``: the ``"pointing"`` and ``"both"``
        axes need it.

    Returns
    -------
    numpy.ndarray, shape (3,) or (N, 3)
        m/s²; zero outside the bursts.

    Examples
    --------
    >>> b = Burst(start=0.0, duration=0.2, peak_g=1.0, rate=5.0, axis="pointing")
    >>> q = [math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4)]     # pointing west (+y)
    >>> burst_acceleration(b, 0.2 - 0.0075, q).round(5).tolist()         # the impact's middle
    [0.0, 9.80665, 0.0]
    >>> burst_acceleration([b], [0.3, 0.4], [q, q]).tolist()
    [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
    """
    if isinstance(bursts, Burst):
        bursts = (bursts,)
    t = np.asarray(t, dtype=float)
    out = np.zeros((*t.shape, 3))
    for b in bursts:
        if t.ndim or b.active(float(t)):  # one sample at a time (the simulator): most are at rest
            out += b.acceleration(t, q)
    return out


# --------------------------------------------------------------------------------------------------
# Sensors
# --------------------------------------------------------------------------------------------------


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


# --------------------------------------------------------------------------------------------------
# Simulator
# --------------------------------------------------------------------------------------------------


class Sample(NamedTuple):
    """One simulated sample: time (s), the mote frame, the true orientation (sensor -> NWU)."""

    t: float
    frame: Frame
    q: np.ndarray


class Truth(NamedTuple):
    r"""Noiseless, unclipped ground truth of a sample.

    ``omega`` (rad/s), ``specific_force`` (m/s², :math:`R(q)^T ((0, 0, g) + a)`) and ``field`` (gauss)
    in the sensor frame; ``linear_acceleration`` :math:`a` (m/s²) of the hand in the earth frame
    (NWU), zero outside bursts (:class:`Burst`).
    """

    t: float
    q: np.ndarray
    omega: np.ndarray
    specific_force: np.ndarray
    field: np.ndarray
    linear_acceleration: np.ndarray


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
    bursts : sequence of Burst
        Strokes and shakes of the hand: their linear acceleration (:func:`burst_acceleration`, with the
        true orientation) adds to the specific force the accelerometer reads; the orientation is
        unchanged.  Empty by default: the accelerometer sees gravity only.
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
        bursts: Sequence[Burst] = (),
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
        self.bursts: tuple[Burst, ...] = tuple(bursts)
        bad = [b for b in self.bursts if not isinstance(b, Burst)]
        if bad:
            raise ValueError(f"bursts must be Burst values, got {bad[0]!r}")

    @property
    def period(self) -> float:
        """Sample period, seconds."""
        return 1.0 / self.rate_hz

    def time(self, k: int) -> float:
        """Time of sample ``k``, seconds."""
        return k / self.rate_hz

    def linear_acceleration(self, t: float, q: np.ndarray) -> np.ndarray | None:
        """The bursts' earth-frame acceleration at ``t`` (m/s²), or None without bursts."""
        return burst_acceleration(self.bursts, t, q) if self.bursts else None

    def truth(self, k: int) -> Truth:
        """Noiseless ground truth of sample ``k``."""
        t = self.time(k)
        q = self.script.orientation(t)
        omega = self.script.angular_rate(t)
        a = self.linear_acceleration(t, q)
        v = self.sensor.true_values(q, omega, a)
        return Truth(t, q, omega, v[3:6], v[6:9], np.zeros(3) if a is None else a)

    def sample(self, k: int) -> Sample:
        """Sample ``k``: ``(t, frame, q_true)``."""
        if k < 0:
            raise ValueError(f"sample index must be >= 0, got {k}")
        t = self.time(k)
        q = self.script.orientation(t)
        rng = np.random.default_rng([self.seed, 1, k])
        a = self.linear_acceleration(t, q)
        counts = self.sensor.counts(q, self.script.angular_rate(t), rng, accel_earth=a)
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

    def skip(self, n: int) -> None:
        """Leave out the next ``n`` samples: frames lost on the way (a glove out of radio range)."""
        with self._lock:
            self._index += max(0, int(n))

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
