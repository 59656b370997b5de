r"""The hand's rotation, the simulated glove's ground truth: a looping script of eased moves.

A :class:`MotionScript` is a looping list of :class:`Segment` moves of the hand (azimuth, elevation and
roll of the pointing axis, eased so that the angular rate is continuous), giving the orientation
:math:`q(t)` (sensor -> NWU) and the angular rate :math:`\omega(t)` in the sensor frame.  Conventions:
:mod:`pointat.devices.glove_sim`.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


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
