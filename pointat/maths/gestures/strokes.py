"""Percussive strokes: onset, direction in the room, strength."""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from pointat.maths.gestures.features import GRAVITY
from pointat.maths.quaternion import quat_to_matrix


@dataclass(frozen=True)
class Stroke:
    """A percussive stroke: the time of its peak (s), the direction the hand struck towards (azimuth,
    elevation, degrees, pointat's conventions: + left, + up; in the sensor's frame without an
    orientation), its strength (peak linear acceleration, g) and its time of decision (s)."""

    t: float
    azimuth: float
    elevation: float
    strength: float
    decided: float


class StrokeDetector:
    r"""Percussive strokes in the acceleration: the sharp peak of an impact, at the sample after it.

    The linear acceleration is the specific force turned into the room by the orientation ``q`` minus
    gravity, :math:`a = R(q) f - (0, 0, g)`; without an orientation, the specific force minus its slow
    mean (0.3 s) in the sensor frame.  A stroke is a peak of :math:`|a|` over ``threshold`` g that is
    *sharp*: 20 ms before it, :math:`|a|` was under half the peak (an impact rises within a few
    milliseconds; the swing of an arm builds up over a tenth of a second).  It is told at the first
    sample that no longer rises (one sample after the peak, 10 ms at 100 Hz).  The hand struck towards
    :math:`-a` at the peak: the impact stops the hand, so its acceleration points back.  Another stroke
    may follow once :math:`|a|` has fallen under half the threshold, ``gap`` s after.
    """

    SHARP = 0.01

    def __init__(self, threshold: float = 1.5, gap: float = 0.06) -> None:
        self.threshold, self.gap = float(threshold), float(gap)
        self.reset()

    def reset(self) -> None:
        self._history: deque[tuple[float, float, np.ndarray]] = deque(maxlen=64)
        self._mean: np.ndarray | None = None
        self._t = -math.inf
        self._armed = True
        self._last = -math.inf

    def linear(self, t: float, acc: np.ndarray, q: np.ndarray | None) -> np.ndarray:
        """The linear acceleration (m/s²), room frame with ``q``, else sensor frame."""
        if q is not None:
            return quat_to_matrix(q) @ acc - np.array([0.0, 0.0, GRAVITY])
        dt = t - self._t
        if self._mean is None or not 0.0 < dt < 1.0:
            self._mean = acc.copy()
        else:
            self._mean += (acc - self._mean) * (1.0 - math.exp(-dt / 0.3))
        self._t = t
        return acc - self._mean

    def push(self, t: float, acc: np.ndarray, q: np.ndarray | None = None) -> Stroke | None:
        a = self.linear(t, np.asarray(acc, dtype=float), q)
        m = float(np.linalg.norm(a)) / GRAVITY
        h = self._history
        found = None
        if len(h) >= 2 and self._armed:
            tp, mp, ap = h[-1]
            if mp >= self.threshold and m <= mp and h[-2][1] < mp:
                before = [x[1] for x in h if x[0] <= tp - self.SHARP + 1e-9]
                if before and before[-1] < 0.5 * mp:
                    d = -ap / max(float(np.linalg.norm(ap)), 1e-12)
                    az = math.degrees(math.atan2(d[1], d[0]))
                    el = math.degrees(math.asin(max(-1.0, min(1.0, float(d[2])))))
                    found = Stroke(tp, az, el, mp, t)
                    self._armed = False
                    self._last = tp
        if not self._armed and m < 0.5 * self.threshold and t - self._last >= self.gap:
            self._armed = True
        h.append((t, m, a))
        return found
