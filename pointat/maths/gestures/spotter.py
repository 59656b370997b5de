"""Trained movements found in a stream that never rests: subsequence DTW on every template."""

from __future__ import annotations

import math
from collections import deque
from typing import NamedTuple

import numpy as np

from pointat.maths.dtw import Spring, dtw_many
from pointat.maths.gestures.events import Decided
from pointat.maths.gestures.features import NULL, segment_features, transform
from pointat.maths.gestures.model import Decision, GestureModel


class _Match(NamedTuple):
    """A template matched in the stream, waiting to be told: its cost as a share of its class's
    threshold, the template's index, and the steps of the match's first and last feature frames."""

    share: float
    template: int
    start: int
    end: int


class Spotter:
    """Trained movements found in a stream that never rests (repetitions one after another): every
    template matched anywhere, frame by frame (:class:`~pointat.maths.dtw.Spring`, subsequence DTW on
    the features at the model's frame rate, taken as they are: nothing is relative to a start; a match
    that does not begin and end as its template does costs more, :attr:`ENDS`), the best match of those
    that overlap (one that keeps the rhythm of the last told counts as better, :attr:`RHYTHM`) told once
    no better one can follow (``hold`` s after its end), under the model's rules of rejection
    (:meth:`GestureModel.decide`: reach, keeping still, pace and strength).  :meth:`push` returns decisions
    (:class:`~pointat.maths.gestures.events.Decided`: the decision and the time of the match's last
    frame).
    """

    #: A match is no longer nor shorter than this many times its template.
    STRETCH = 2.5
    #: A match's cost also counts how far its first and last feature frames are from its template's first
    #: and last (their squared distance, as a frame of the warping path counts it), this many times: in a
    #: stream of repetitions with no rest between them, the span from the middle of one repetition to the
    #: middle of the next can match another gesture's template as cheaply as a whole repetition matches
    #: its own (raising the arm forward or sideways, turning it in or out), but it does not begin and end
    #: as a template does.  Chosen on seglearn people 1-5 (``benchmarks/GESTURES_REAL.md``).
    ENDS = 0.5
    #: Of the matches that overlap, the one told is the cheapest as a share of its class's threshold, that
    #: share weighed by ``1 + RHYTHM * min(|gap|, 2 n) / n`` against the last match told when they are
    #: compared (``n`` its steps, ``gap`` the steps between its end and this start): a performer who
    #: repeats a movement with no rest keeps a rhythm, each repetition beginning where the last one
    #: ended, and a span from the middle of one to the middle of the next breaks it.  It chooses only:
    #: whether a match is a gesture at all stays the model's rules' alone.  Chosen on seglearn people
    #: 1-5 (``benchmarks/GESTURES_REAL.md``); 0: off.
    RHYTHM = 0.5

    def __init__(self, model: GestureModel, hold: float | None = None) -> None:
        self.model = model
        self.made_from = model.templates  # (training anew makes another list: a spotter anew)
        self.templates = [
            segment_features(e.t, e.frames, model.channels, model.frame_rate, model.size, ()) / model.scales
            for e in model.examples
        ]
        # a match is told once no better one can follow: half a typical template after its end
        self.hold = (
            hold
            if hold is not None
            else 0.5 * float(np.median([len(x) for x in self.templates])) / model.frame_rate
        )
        self.spring = Spring(self.templates)
        self.span = max(len(x) for x in self.templates) * model.PACE + 2
        self.reset()

    def reset(self) -> None:
        self.spring.reset()
        self.raw: deque[tuple[float, np.ndarray]] = deque()
        self.feats: deque[np.ndarray] = deque()
        self.times: deque[float] = deque()
        self._next = math.nan
        self._last: tuple[float, np.ndarray] | None = None
        self._pending: list[_Match] = []
        self._free = 0  # steps before this one belong to a match already told
        self._told: tuple[int, int] | None = None  # the first and last steps of the last match told

    def push(self, t: float, frame: np.ndarray) -> list[Decided]:
        out: list[Decided] = []
        m = self.model
        self.raw.append((t, frame))
        while self.raw and self.raw[0][0] < t - self.span / m.frame_rate - 1.0:
            self.raw.popleft()
        if self._last is None or not math.isfinite(self._next):
            self._last, self._next = (t, frame), t
        t0, f0 = self._last
        while self._next <= t:  # feature frames on the model's grid, between the last two frames
            w = 0.0 if t <= t0 else (self._next - t0) / (t - t0)
            x = transform((f0 + w * (frame - f0))[None, :], m.channels, m.size, ())[0] / m.scales
            out += self._step(self._next, x)
            self._next += 1.0 / m.frame_rate
        self._last = (t, frame)
        return out

    def _step(self, t: float, x: np.ndarray) -> list[Decided]:
        step = self.spring.step
        rows = self.spring.push(x)
        self.feats.append(x)
        self.times.append(t)
        if len(self.feats) > self.span:
            self.feats.popleft()
            self.times.popleft()
        first = step - len(self.feats) + 1  # the step of feats[0]
        pending = self._pending
        for j, (cost, start) in enumerate(rows):
            start = int(start)
            label = self.model.labels[j]
            if start < self._free or start < first or label == NULL:
                continue
            m = len(self.templates[j])
            if not m / self.STRETCH <= step - start + 1 <= m * self.STRETCH:
                continue
            if self.ENDS:
                x0, tj = self.feats[start - first], self.templates[j]
                ends = float(np.sum((x0 - tj[0]) ** 2)) + float(np.sum((self.feats[-1] - tj[-1]) ** 2))
                cost += self.ENDS * 0.5 * ends
            share = cost / self.model.threshold(label)  # (the classes compared at their own scale)
            if share > 1.0:
                continue
            for k, p in enumerate(pending):  # the best of the matches that overlap by half or more
                if (
                    min(step, p.end) - max(start, p.start) + 1
                    > 0.5 * min(step - start, p.end - p.start) + 0.5
                ):
                    if self._weigh(share, start) < self._weigh(p.share, p.start):
                        pending[k] = _Match(float(share), j, start, step)
                    break
            else:
                pending.append(_Match(float(share), j, start, step))
        out = []
        pending.sort(key=lambda p: p.end)
        while pending and (step - pending[0].end) / self.model.frame_rate >= self.hold:
            p = pending.pop(0)
            if p.start < self._free or p.start < first:
                continue
            decision = self._decide(p, first)
            if decision is not None:
                self._free = (
                    p.end + 1 - len(self.templates[p.template]) // 4
                )  # (a next one may begin as it ends)
                out.append(Decided(decision, self.times[p.end - first]))
                self._told = (p.start, p.end)
        return out

    def _weigh(self, share: float, start: int) -> float:
        """A match's share as it is compared with those it overlaps: weighed by how it keeps the rhythm of
        the last match told (:attr:`RHYTHM`), as that is now."""
        if not self.RHYTHM or self._told is None:
            return share
        gap, n = start - self._told[1] - 1, self._told[1] - self._told[0] + 1
        return share * (1.0 + self.RHYTHM * min(abs(gap), 2 * n) / n)

    def _decide(self, p: _Match, first: int) -> Decision | None:
        start, end = p.start, p.end
        m = self.model
        x = np.array([self.feats[k - first] for k in range(start, end + 1)])
        ts = [self.times[k - first] for k in range(start, end + 1)]
        raw = np.array([f for ti, f in self.raw if ts[0] <= ti <= ts[-1]] or [self.raw[-1][1]])
        gauge = dtw_many(x, self.templates, 1.0)
        decision = m.decide(
            gauge if m.warped == "together" else dtw_many(x, self.templates, 1.0, each=True),
            duration=ts[-1] - ts[0],
            still=m.still(x),
            strength=m.strength(raw),
            gauge=gauge,
        )
        return decision if decision.label is not None else None
