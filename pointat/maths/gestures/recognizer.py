"""Trained movements found in a stream, frame by frame: the ``gesture`` node's loop."""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from pointat.maths.gestures.events import Adapted, Decided, Dropped, Ended, Event, Recorded, Started
from pointat.maths.gestures.features import Example
from pointat.maths.gestures.model import Decision, GestureModel
from pointat.maths.gestures.segmentation import Energy, Segmenter
from pointat.maths.gestures.spotter import Spotter

#: How a stream is cut into movements: from ``rest`` to rest (:class:`Segmenter`), or every template
#: matched anywhere (``spot``: :class:`Spotter`, for repetitions with no rest between them).
CUTS = ("rest", "spot")


class Recognizer:
    """Trained movements found in a stream, frame by frame: what the ``gesture`` node and
    ``pointat gestures evaluate`` run.

    Movements are cut by the :class:`Segmenter` (``gate=None``: rest and motion) or by a gate
    (:meth:`gate`: a button held, or each file of an evaluation).  Each movement gets at most one
    decision: early (:meth:`GestureModel.early`, checked every ``check`` s while it goes on) or when it
    ends; after a decision, movements that start within ``refractory`` s get none.  A movement ended
    while recording (``record`` set to a label) becomes an example instead.

    :meth:`push` and :meth:`gate` return lists of events (:mod:`~pointat.maths.gestures.events`):
    :class:`Started`, :class:`Ended`, :class:`Decided` (the decision, and the time of the movement's last
    frame: the decision's latency is the time of the frame that made it minus that), :class:`Recorded`,
    :class:`Adapted` and :class:`Dropped`.
    """

    def __init__(
        self,
        model: GestureModel,
        *,
        start: float = 0.3,
        settle: float = 0.1,
        refractory: float = 0.25,
        early: bool = True,
        share: float = 0.8,
        margin: float = 1.5,
        check: float = 0.04,
        longest: float = 4.0,
        adapt: bool = False,
        keep: int = 10,
        cut: str = "rest",
    ) -> None:
        if cut not in CUTS:
            raise ValueError(f"cut must be one of {', '.join(CUTS)}; got {cut!r}")
        self.model = model
        self.adapt, self.keep, self.cut = adapt, keep, cut
        self.spotter: Spotter | None = None
        self.start, self.settle, self.refractory = start, settle, refractory
        self.use_early, self.share, self.margin, self.check = early, share, margin, check
        self.longest_default = longest
        self.record: str | None = None
        self.gated: bool | None = None  # None: the segmenter cuts; False/True: a gate, closed/open
        self.energy = Energy(model.channels, model.size)
        self.frames: deque[tuple[float, np.ndarray]] = deque()
        self.retune()

    def retune(self) -> None:
        """Set the segmenter from the model (after training, or a change of settings)."""
        on = self.model.motion_level(self.start)
        longest = self.longest_default
        if self.model.durations:
            longest = max(1.0, 2.0 * max(d[1] for d in self.model.durations.values()))
        if self.record is not None:
            longest = max(longest, self.longest_default)
        self.segmenter = Segmenter(on, 0.5 * on, self.settle, longest=longest)
        self.reset()

    def recorded(
        self, t: np.ndarray, frames: np.ndarray, label: str, count: int | None = None
    ) -> list[Example]:
        """What ``record LABEL COUNT`` keeps of a whole stream (times ``t``, ``frames``): its movements (at
        most ``count``), cut from rest to rest as while recording, each an example of ``label``.  The
        recognizer starts afresh and is left recording what it recorded before."""
        before, self.record = self.record, label
        self.retune()
        out: list[Example] = []
        for ti, xi in zip(t, frames, strict=True):
            out += [e.example for e in self.push(float(ti), xi) if isinstance(e, Recorded)]
            if count is not None and len(out) >= count:
                break
        self.record = before
        self.retune()
        return out[:count]

    def reset(self) -> None:
        self.spotter = None
        self.frames.clear()
        self.energy.reset()
        self.segmenter.reset()
        self._open = False  # a movement under way
        self._decided: Decision | bool = False  # the decision told early, while the movement went on
        self._next_check = 0.0
        self._quiet_until = -math.inf

    def gate(self, on: bool | None, t: float) -> list[Event]:
        """Open (True) or close (False) the gate at time ``t``; ``None`` hands cutting back to the
        segmenter.  Closing it ends the movement (as the segmenter's end would)."""
        events: list[Event] = []
        if on and not self._open:
            self.frames.clear()
            self._open, self._decided = True, False
            self._next_check = t + self.check
            events.append(Started(t))
        elif not on and self._open and self.gated:
            self._open = False
            events += self._ended(list(self.frames))
        self.gated = on
        if on is None:
            self.reset()
        return events

    def push(self, t: float, frame: np.ndarray) -> list[Event]:
        """One frame at time ``t``: the events it brings."""
        if self.cut == "spot" and self.gated is None and self.record is None and self.model.trained:
            if self.spotter is None or self.spotter.made_from is not self.model.templates:  # (trained again)
                self.spotter = Spotter(self.model)
            return list(self.spotter.push(t, frame))
        events: list[Event] = []
        frames = self.frames
        frames.append((t, frame))
        if self.gated is not None:
            if not self._open:
                frames.clear()
                return events
        else:
            what = self.segmenter.push(t, self.energy(t, frame))
            keep = self.segmenter.longest + self.segmenter.preroll + self.settle + 0.1
            while frames and frames[0][0] < t - keep:
                frames.popleft()
            if what == "start":
                self._open, self._decided = True, False
                self._next_check = t + self.check
                events.append(Started(self.segmenter.began))
            elif what == "end":
                self._open = False
                first, last = self.segmenter.span
                events += self._ended([f for f in frames if first <= f[0] <= last])
            elif what == "drop":
                self._open = False
                events.append(Dropped("too short" if not self.segmenter.spoilt else "too long"))
        if (
            self._open
            and self.use_early
            and self.record is None
            and not self._decided
            and self.model.trained
            and t >= self._next_check
            and t >= self._quiet_until
        ):
            self._next_check = t + self.check
            span = [f for f in frames if f[0] >= self._began()]
            if len(span) >= 2:
                ts, xs = self._arrays(span)
                decision = self.model.early(ts, xs, share=self.share, margin=self.margin)
                if decision is not None:
                    self._decided = decision
                    self._quiet_until = t + self.refractory
                    events.append(Decided(decision, math.nan))
        return events

    def _began(self) -> float:
        return self.segmenter.began if self.gated is None else -math.inf

    @staticmethod
    def _arrays(span: list[tuple[float, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
        return np.array([f[0] for f in span]), np.array([f[1] for f in span])

    def _ended(self, span: list[tuple[float, np.ndarray]]) -> list[Event]:
        if not span:
            return [Dropped("empty")]
        ts, xs = self._arrays(span)
        ended: list[Event] = [Ended(float(ts[-1]))]
        if self.record is not None:
            return [*ended, Recorded(Example(self.record, ts, xs))]
        if not self.model.trained:
            return ended
        if isinstance(self._decided, Decision):
            return ended + self._adapted(self._decided, ts, xs)
        if self._decided:
            return ended
        if ts[0] < self._quiet_until:
            return [*ended, Dropped("refractory")]
        decision = self.model.classify(ts, xs)
        self._quiet_until = ts[-1] + self.refractory
        return [*ended, Decided(decision, float(ts[-1])), *self._adapted(decision, ts, xs)]

    def _adapted(self, decision: Decision, ts: np.ndarray, xs: np.ndarray) -> list[Event]:
        if not (self.adapt and len(ts) > 1 and self.model.clear_margin(decision)):
            return []
        n = self.model.adapt(Example(str(decision.label), ts, xs), self.keep)
        return [Adapted(str(decision.label), n)]
