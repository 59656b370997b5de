r"""The hand's translation, the simulated glove's ground truth: percussive strokes and shakes.

A :class:`Burst` is a stretch of linear acceleration (:func:`burst_acceleration`, earth frame) whose
velocity and displacement come back to zero, so the hand returns to where it was.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

GRAVITY = 9.80665
"""Standard gravity, m/s²."""


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
