"""Following one trained movement as it unfolds: progress and speed (a left-to-right HMM)."""

from __future__ import annotations

import math

import numpy as np

from pointat.maths.gestures.features import NULL, transform
from pointat.maths.gestures.model import GestureModel


class Follower:
    r"""Where a performance is within one trained movement, as it unfolds: progress 0..1 and speed.

    A left-to-right hidden Markov model with one state per frame of the template (the example nearest
    to the others, :func:`segment_features` at ``rate``), as XMM's hierarchical models and GVF's phase
    do: from state :math:`i` the next frame stays (:math:`p_0`), moves one on (:math:`p_1`) or two
    (:math:`p_2`), so speeds from 0 to twice the template's are followed; emissions are isotropic
    Gaussians of the features' spread :math:`\sigma` about the template's frames (from the examples'
    alignment to it, or 0.3 of the scaled features' unit with one example).  The forward variable
    :math:`\alpha` gives progress :math:`\sum_i \alpha_i\, i / (N - 1)`; speed is the progress made per
    second times the template's duration (1: as fast as the example), smoothed over ``smooth`` s.
    """

    STAY, NEXT, SKIP = 0.3, 0.4, 0.3

    def __init__(self, model: GestureModel, smooth: float = 0.15) -> None:
        if not model.trained:
            raise ValueError("the follower needs a trained model")
        self.model = model
        examples = [i for i, lab in enumerate(model.labels) if lab != NULL]
        tpl = model.templates
        if len(examples) > 1:
            d = np.array([[0.0 if i == j else 1.0 for j in examples] for i in examples])
            for a, i in enumerate(examples):
                others = [tpl[j] for j in examples if j != i]
                d[a, [b for b in range(len(examples)) if b != a]] = model._gauge(tpl[i], others)
            medoid = examples[int(np.argmin(d.sum(axis=1)))]
            self.sigma = max(0.1, float(np.sqrt(np.median(d[d > 0]) / max(1, tpl[0].shape[1]))))
        else:
            medoid = examples[0]
            self.sigma = 0.3
        self.template = tpl[medoid]
        self.duration = model.examples[medoid].duration
        self.smooth = smooth
        self.reset()

    def reset(self) -> None:
        n = len(self.template)
        self.alpha = np.zeros(n)
        self.alpha[0] = 1.0
        self.progress = 0.0
        self.speed = 0.0
        self._t: float | None = None
        self._next = -math.inf
        self._first = np.zeros(0)

    def push(self, t: float, frame: np.ndarray) -> tuple[float, float] | None:
        """One frame: (progress, speed) at each new feature frame (``1 / rate`` s), else ``None``."""
        frame = np.asarray(frame, dtype=float)
        if self._t is None:
            self._t, self._first = t, frame
            self._next = t + 1.0 / self.model.frame_rate
            return None
        if t < self._next:
            return None
        # this frame's features at the model's scale (q: relative to the movement's first frame)
        x = transform(
            np.array([self._first, frame]), self.model.channels, self.model.size, self.model.relative
        )[-1]
        x = x / self.model.scales
        dt = t - (self._next - 1.0 / self.model.frame_rate)
        self._next = t + 1.0 / self.model.frame_rate
        a = self.alpha
        pred = self.STAY * a
        pred[1:] += self.NEXT * a[:-1]
        pred[2:] += self.SKIP * a[:-2]
        pred[-1] += (self.NEXT + self.SKIP) * a[-1] + self.SKIP * a[-2] if len(a) > 1 else 0.0
        d2 = np.sum((self.template - x) ** 2, axis=1)
        like = np.exp(-0.5 * (d2 - d2.min()) / (self.sigma * self.sigma))
        post = pred * like
        total = post.sum()
        self.alpha = post / total if total > 0 and np.isfinite(total) else a
        before = self.progress
        n = len(self.alpha)
        self.progress = float(self.alpha @ np.arange(n)) / max(1, n - 1)
        rate = (self.progress - before) / max(dt, 1e-6) * self.duration
        keep = math.exp(-dt / self.smooth) if self.smooth > 0 else 0.0
        self.speed = keep * self.speed + (1.0 - keep) * rate
        return self.progress, self.speed
