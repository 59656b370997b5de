"""Trained movements: 1-NN DTW over the examples' templates, with the null class (rejection: reach,
keeping still, pace and strength) and adaptation."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pointat.maths.dtw import dtw_many, dtw_prefix_many
from pointat.maths.gestures.features import (
    NULL,
    RELATIVE,
    SCALES,
    WARPS,
    Example,
    channel_slices,
    feature_groups,
    group_scales,
    relative_channels,
    segment_features,
)
from pointat.maths.gestures.segmentation import DEFAULT_ON, Energy

#: The default ``reject`` (:class:`GestureModel`): the operating point chosen on real recordings, on the
#: curve of real gestures found against false triggers on real motion that is no gesture.
REJECT = 3.0

#: The channel groups whose peak strength a gesture's performances keep to (:meth:`GestureModel.strength`).
_STRONG = ("acc", "gyr")


@dataclass(frozen=True)
class Decision:
    """What a movement was: ``label`` (``None``: no gesture), the DTW ``distance`` to the nearest
    template, ``nearest`` (its label, null or not), ``score`` (1 at a template, 0 at the class's
    rejection threshold) and, per class, the nearest distance."""

    label: str | None
    distance: float
    nearest: str
    score: float
    per_class: dict[str, float] = field(default_factory=dict)
    early: bool = False
    still: float = math.inf  # the movement's distance from keeping still
    duration: float = math.nan  # s


class GestureModel:
    """Templates of movements and their classes' spreads: 1-NN DTW with rejection.

    Parameters
    ----------
    channels : sequence of str
        The channel groups of a frame, in order (:data:`CHANNELS`).
    size : int
        How many numbers channel ``x`` holds (0 without it).
    rate : float
        Feature frames per second (:func:`segment_features`), or the examples' own rate when lower.
    band : float
        DTW's band, a fraction of the longer series.
    reject : float
        A movement is no gesture when its nearest template is more than ``reject`` times its class's
        reach away (:meth:`threshold`: the class's distance from keeping still, or the examples' spread
        when nearer and :attr:`SPREAD` is set), or when it is not nearer to its class than :attr:`STILL`
        times its own distance from keeping still, or (:attr:`QUIET`) its class is nearly still and it
        is not; 0: never rejected, but by ``null`` examples.
    warp : str
        ``together``: all features warped as one (DTW_D), ``each`` on its own (DTW_I), or ``auto``
        (:meth:`choose_warp`: the one that names more of the examples, each left out in turn, together
        on a tie; :attr:`warped` says which).
    relative : sequence of str
        The channel groups taken relative to how the movement began (:func:`transform`).
    scale : str
        How the channel groups are weighed against each other (:data:`SCALES`, :func:`group_scales`):
        each by its own spread over the examples, or all in their units by one spread.
    """

    #: A movement is no performance of a class when it is this many times faster than its fastest
    #: example or slower than its slowest.  Not tighter: 1.5 cut the false triggers on BROAD (seglearn
    #: people 1-5's worst model 0.79 -> 0.43 a minute, as many found and named) and widening it by the
    #: examples' pooled spread of tempo kept that, but real people's tempi differ more than a few
    #: examples show: in the tests' sample of seglearn, the two who teach take 2.2 s where the new person
    #: takes 1.1 s, and 47 % of her gestures were refused (``benchmarks/GESTURES_REAL.md``, the rules).
    PACE = 3.0
    #: ... or when its accelerometer's or gyro's peak is this many times stronger than its strongest
    #: example's, or weaker than its weakest's (a tap, a jolt: far stronger than any gesture taught).
    STRENGTH = 3.0
    #: The least reach of a class, as a share of the median class's: a class that is itself nearly
    #: still (standing, a hand held) is then not refused for every tremble of its performance.
    FLOOR = 0.25
    #: ... but such a class (its own reach under the floor) is told only for a movement nearly as still
    #: as its examples: within this many times their own distance from keeping still (a performer
    #: expects "standing" of standing, not of any motion slow enough to be near it).  On BROAD 01-15
    #: BasicMotions' model told 0.18, 0.24 and 0.79 false triggers a minute at 3, 6 and 12, and 3 cost
    #: seglearn people 1-5 1.1 points; on the reported trials 12 would find BasicMotions' one standing
    #: recording that 6 refuses (``benchmarks/GESTURES_REAL.md``, the rules).
    QUIET = 6.0
    #: A movement is no gesture when it is not nearer to its class than this many times its own distance
    #: from keeping still (a tremble, a small turn of the wrist: near keeping still, so near every
    #: gesture's reach from it).
    STILL = 3.0
    #: ... or, when set (off by default), when it is farther from its class than ``reject`` times
    #: :attr:`spread`, this many times the examples' spread (:meth:`examples_spread`).  It held every
    #: model's false triggers on BROAD to the goal (worst 1.40 -> 0.32 a minute, factor 0.93 chosen on
    #: seglearn people 1-5) but it is the rule the issue warned of: a rehearsal's examples, however
    #: pooled, vary less than performances on another day, and the simulated performer, who performs at
    #: other elevations than he rehearsed, was found 98 -> 49 % with it (benchmarks/GESTURES.md,
    #: GESTURES_REAL.md's table of the rules).  ``math.inf``: off.
    SPREAD = math.inf
    #: The share of the examples' leave-one-out distances under which the spread lies (pooled over every
    #: class: a class of three examples alone says little of how a gesture varies).
    SPREAD_QUANTILE = 90.0
    #: How near a movement under way must be to a class to be told early, as a share of its reach.
    EARLY = 0.35

    def __init__(
        self,
        channels: Sequence[str],
        *,
        size: int = 0,
        rate: float = 50.0,
        band: float = 0.5,
        reject: float = REJECT,
        warp: str = "auto",
        relative: Sequence[str] = RELATIVE,
        scale: str = "spread",
    ) -> None:
        self.channels = tuple(channels)
        self.relative = relative_channels(relative)
        self.size = int(size)
        self.width = channel_slices(self.channels, self.size)[self.channels[-1]].stop
        self.rate, self.band, self.reject = float(rate), float(band), float(reject)
        self.frame_rate = self.rate  # the examples' own rate when it is lower (train)
        if warp not in WARPS:
            raise ValueError(f"warp must be one of {', '.join(WARPS)}; got {warp!r}")
        self.warp = warp
        if scale not in SCALES:
            raise ValueError(f"scale must be one of {', '.join(SCALES)}; got {scale!r}")
        self.scale = scale
        self.warped = "together" if warp == "auto" else warp  # the one in use (auto: set by train)
        self.examples: list[Example] = []
        self.templates: list[np.ndarray] = []
        self.labels: list[str] = []
        self.scales = np.ones(0)
        self.reach: dict[str, float] = {}
        # the classes nearly still: the farthest a movement may be from keeping still to be one of them
        self.quiet: dict[str, float] = {}
        self.spread = math.inf  # the examples' spread (:meth:`_reaches`)
        self.spread_classes: set[str] = set()  # the classes it caps: those taught two examples or more
        self._taken: set[int] = set()  # examples taken from performances (adapt), not taught
        self.peaks: list[float] = []
        self.durations: dict[str, tuple[float, float]] = {}
        self.strengths: dict[str, tuple[np.ndarray, np.ndarray]] = {}

    @property
    def trained(self) -> bool:
        return bool(self.templates)

    @property
    def classes(self) -> list[str]:
        return sorted({e.label for e in self.examples if e.label != NULL})

    def features(self, t: np.ndarray, frames: np.ndarray) -> np.ndarray:
        """Scaled feature frames of a movement (:func:`segment_features`)."""
        x = segment_features(t, frames, self.channels, self.frame_rate, self.size, self.relative)
        return x / self.scales if self.scales.size else x

    def train(self, examples: Sequence[Example] | None = None, *, choose: bool = True) -> GestureModel:
        """Learn the templates, the scales, the warp (``auto``; not when ``choose`` is false: the one
        chosen before is kept) and each class's reach from the examples.

        A class's reach is the median distance of its examples from keeping still (:meth:`still`):
        how far the gesture is from doing nothing (at least :attr:`FLOOR` of the median class's).  It is known from one example, and unlike the spread
        among a few examples of one rehearsal it does not shrink when they happen to be alike: a
        performance on another day or by another person strays from the examples by a share of the
        gesture itself, which ``reject`` sets (chosen on real recordings: ``benchmarks/GESTURES_REAL.md``).
        Raises ``ValueError`` with no gesture example.
        """
        if examples is not None:
            self.examples = list(examples)
        for e in self.examples:
            if e.frames.shape[1] != self.width:
                raise ValueError(
                    f"example {e.label!r} has {e.frames.shape[1]} values a frame; channels"
                    f" {' '.join(self.channels)} make {self.width}"
                )
        if not self.classes:
            raise ValueError("no examples to train on (record some first: record LABEL, then move)")
        steps = np.concatenate([np.diff(e.t) for e in self.examples if len(e.t) > 1] or [np.zeros(0)])
        native = 1.0 / float(np.median(steps)) if steps.size else self.rate
        self.frame_rate = min(self.rate, native)  # resampling finer than the sensor adds cost, no detail
        raw = [
            segment_features(e.t, e.frames, self.channels, self.frame_rate, self.size, self.relative)
            for e in self.examples
        ]
        scales = group_scales(np.vstack(raw), self.channels, self.size, self.scale)
        self.scales = scales
        self.templates = [x / scales for x in raw]
        self.labels = [e.label for e in self.examples]
        if choose:
            self.warped = self.choose_warp()
        energy = Energy(self.channels, self.size)
        self.peaks = []
        for e in self.examples:
            if e.label != NULL:
                energy.reset()
                self.peaks.append(max(energy(float(ti), f) for ti, f in zip(e.t, e.frames, strict=True)))
        self.durations, self.strengths = {}, {}
        for c in self.classes:
            own = [e for e in self.examples if e.label == c]
            self.durations[c] = (min(e.duration for e in own), max(e.duration for e in own))
            peaks = np.array([self.strength(e.frames) for e in own])
            self.strengths[c] = (peaks.min(axis=0), peaks.max(axis=0))
        self._reaches()
        return self

    def _reaches(self) -> None:
        labels = np.array(self.labels)
        still = np.array([self.still(x) for x in self.templates])
        reach = {c: float(np.median(still[labels == c])) for c in self.classes}
        least = self.FLOOR * float(np.median(list(reach.values())))
        self.reach = {c: max(r, least) for c, r in reach.items()}
        # (a class whose examples are all alike to the bit still takes a performance as still as they are)
        self.quiet = {c: self.QUIET * max(r, 0.01 * least) for c, r in reach.items() if r < least}
        self.spread, self.spread_classes = math.inf, set()
        if math.isfinite(self.SPREAD):  # (its leave-one-out DTW only when the rule is on)
            spread, self.spread_classes = self.examples_spread()
            self.spread = self.SPREAD * spread if spread > 0.0 else math.inf

    def examples_spread(self) -> tuple[float, set[str]]:
        """How far a taught example of a class lies from its class's others: the :attr:`SPREAD_QUANTILE`
        percentile of each example's DTW distance to the nearest other of its class (left out in turn),
        pooled over the classes taught two examples or more; and those classes (the spread is evidence of
        theirs only).  ``inf`` when no class has two.  Examples taken from performances (``adapt``) are
        left out: taken for being near their class, they would only narrow it."""
        taught = [i for i, e in enumerate(self.examples) if id(e) not in self._taken]
        near, classes = [], set()
        for i in taught:
            label = self.labels[i]
            same = [self.templates[j] for j in taught if j != i and self.labels[j] == label != NULL]
            if same:
                near.append(float(np.min(self._gauge(self.templates[i], same))))
                classes.add(label)
        return (float(np.percentile(near, self.SPREAD_QUANTILE)) if near else math.inf), classes

    def still(self, x: np.ndarray) -> float:
        """The distance of feature frames ``x`` from keeping still: from their first frame held as long,
        the gyro at 0."""
        rest = np.repeat(x[:1], len(x), axis=0)
        for name, g in zip(self.channels, feature_groups(self.channels, self.size), strict=True):
            if name == "gyr":
                rest[:, g] = 0.0
        return float(self._gauge(x, [rest])[0])

    def _dtw(self, x: np.ndarray, templates: Sequence[np.ndarray]) -> np.ndarray:
        """The distances that name a movement: with the warp in use (:attr:`warped`)."""
        return dtw_many(x, templates, self.band, each=self.warped == "each")

    def _gauge(self, x: np.ndarray, templates: Sequence[np.ndarray]) -> np.ndarray:
        """The distances the null class is judged by: all features warped together, whatever the warp
        that names (each warped on its own, ordinary motion comes nearer every gesture: on BROAD a model
        of DTW_I told three times as many false triggers)."""
        return dtw_many(x, templates, self.band, each=False)

    def named_left_out(self, warp: str) -> int:
        """How many of the templates 1-NN DTW with ``warp`` names right from the others (each left out in
        turn; a template whose class has no other is not counted)."""
        right = 0
        for i, x in enumerate(self.templates):
            others = [j for j in range(len(self.templates)) if j != i]
            if self.labels[i] == NULL or not any(self.labels[j] == self.labels[i] for j in others):
                continue
            d = dtw_many(x, [self.templates[j] for j in others], self.band, each=warp == "each")
            right += self.labels[others[int(np.argmin(d))]] == self.labels[i]
        return right

    def choose_warp(self) -> str:
        """``warp=auto``: DTW_I (``each``) when it names more of the examples left out one at a time than
        DTW_D (``together``), else DTW_D.  Chosen on seglearn people 1-5 over always DTW_D (a new person,
        mean and worst person: 71.9 / 57.6 -> 73.6 / 64.0 %, acc gyr; three examples the same);
        ``benchmarks/GESTURES_REAL.md``."""
        if self.warp != "auto":
            return self.warp
        each, together = self.named_left_out("each"), self.named_left_out("together")
        return "each" if each > together else "together"

    def too_lively(self, label: str, still: float) -> bool:
        """Whether a movement ``still`` from keeping still is too lively for ``label``, a class itself
        nearly still (:attr:`QUIET`; never for another class, nor when its stillness is not known)."""
        return math.isfinite(still) and still > self.quiet.get(label, math.inf)

    def threshold(self, label: str) -> float:
        """The distance beyond which a movement nearest to ``label`` is no gesture: ``reject`` times the
        class's reach (its examples' distance from keeping still) or the examples' spread
        (:attr:`spread`), the nearer."""
        if self.reject <= 0:
            return math.inf
        cap = self.spread if label in self.spread_classes else math.inf
        return self.reject * min(self.reach[label], cap)

    def early_limit(self, label: str) -> float:
        """The farthest a movement under way may be from ``label`` to be told early: :attr:`EARLY` of the
        class's reach, whatever ``reject``, 0 included (a prefix of ordinary motion matches some
        template's prefix far more often than a whole movement matches a whole template)."""
        return self.EARLY * self.reach[label]

    def strength(self, frames: np.ndarray) -> np.ndarray:
        """The peak of each of the accelerometer's and the gyro's norms over a movement's frames (m/s²,
        rad/s; none without them)."""
        sl = channel_slices(self.channels, self.size)
        return np.array([float(np.max(np.linalg.norm(frames[:, sl[g]], axis=1))) for g in _STRONG if g in sl])

    def fits(self, label: str, duration: float, strength: np.ndarray | None = None) -> bool:
        """Whether a movement of ``duration`` s and peak ``strength`` (:meth:`strength`) could be a
        performance of ``label``: within :attr:`PACE` times the examples' shortest and longest, and
        within :attr:`STRENGTH` times their weakest and strongest (always, when rejection is off)."""
        if self.reject <= 0 or label not in self.durations:
            return True
        if math.isfinite(duration):
            lo, hi = self.durations[label]
            if not lo / self.PACE <= duration <= hi * self.PACE:
                return False
        if strength is not None and strength.size:
            lo, hi = self.strengths[label]
            if np.any(strength > hi * self.STRENGTH) or np.any(strength < lo / self.STRENGTH):
                return False
        return True

    def decide(
        self,
        distances: np.ndarray,
        early: bool = False,
        duration: float = math.nan,
        still: float = math.inf,
        strength: np.ndarray | None = None,
        gauge: np.ndarray | None = None,
    ) -> Decision:
        """The decision from the distances to each template that name it (and the movement's duration,
        s, and its distance from keeping still, told with the decision); ``gauge``: the distances the
        null class is judged by (:meth:`_gauge`), when they are not those."""
        per_class: dict[str, float] = {}
        for label, d in zip(self.labels, distances, strict=True):
            if d < per_class.get(label, math.inf):
                per_class[label] = float(d)
        nearest = min(per_class, key=per_class.__getitem__)
        d = per_class[nearest]
        if gauge is not None:
            d = float(min(g for label, g in zip(self.labels, gauge, strict=True) if label == nearest))
        if nearest == NULL:
            return Decision(None, d, nearest, 0.0, per_class, early, still, duration)
        limit = self.threshold(nearest)
        score = 1.0 - d / limit if math.isfinite(limit) and limit > 0 else 1.0
        ok = (
            d <= limit
            and (self.reject <= 0 or d < self.STILL * still)
            and (self.reject <= 0 or not self.too_lively(nearest, still))
            and self.fits(nearest, duration, strength)
        )
        return Decision(
            nearest if ok else None, d, nearest, max(0.0, score), per_class, early, still, duration
        )

    def classify(self, t: Any, frames: Any) -> Decision:
        """The decision on one whole movement, its times (s) and frames (T, F)."""
        if not self.trained:
            raise ValueError("the model is not trained")
        x = self.features(np.asarray(t, dtype=float), np.asarray(frames, dtype=float))
        t = np.asarray(t, dtype=float)
        frames = np.asarray(frames, dtype=float)
        names = self._dtw(x, self.templates)
        return self.decide(
            names,
            duration=float(t[-1] - t[0]),
            still=self.still(x),
            strength=self.strength(frames),
            gauge=None if self.warped == "together" else self._gauge(x, self.templates),
        )

    def early(self, t: np.ndarray, frames: np.ndarray, *, share: float, margin: float) -> Decision | None:
        """A decision on a movement still under way, when the evidence allows, else ``None``.

        Every template is matched with an open end (:func:`~pointat.maths.dtw.dtw_prefix`).  The
        movement is taken for class *c* when its best match has come through at least ``share`` of a
        template of *c*, at a distance within half of *c*'s threshold, and every other class (null included) is at least ``margin`` times farther: a gesture that
        begins as another one does is never decided before they part.  Never without the gyro or the
        orientation: on the accelerometer alone, the beginning of a gesture is too like any movement's
        (on BROAD's real motion, early decisions doubled a model's false triggers, 0.35 to 0.71 a minute).
        """
        if not {"gyr", "q"} & set(self.channels):
            return None  # (the accelerometer alone: early decisions doubled false triggers on real motion)
        x = self.features(t, frames)
        per_class: dict[str, tuple[float, float]] = {}
        rows = dtw_prefix_many(x, self.templates, self.band)  # (warped together: judged as the null class is)
        for label, (cost, through) in zip(self.labels, rows, strict=True):
            if cost < per_class.get(label, (math.inf, 0.0))[0]:
                per_class[label] = (float(cost), float(through))
        if not per_class:  # longer than every template by more than the band: no prefix of any
            return None
        best = min(per_class, key=lambda c: per_class[c][0])
        cost, through = per_class[best]
        if best == NULL or through < share or cost > min(self.early_limit(best), self.threshold(best)):
            return None
        if any(v[0] < margin * cost for c, v in per_class.items() if c != best):
            return None
        still = self.still(x)
        if self.reject > 0 and (cost >= self.STILL * still or self.too_lively(best, still)):
            return None
        if self.reject > 0 and np.any(self.strength(frames) > self.strengths[best][1] * self.STRENGTH):
            return None
        limit = self.threshold(best)
        score = 1.0 - cost / limit if math.isfinite(limit) and limit > 0 else 1.0
        return Decision(best, cost, best, max(0.0, score), {c: v[0] for c, v in per_class.items()}, True)

    def adapt(self, example: Example, keep: int) -> int:
        """Take a performance recognised with a clear margin as an example of its class, and train again
        (uWave's adaptation, Liu et al. 2009: a performer's drift over days is followed).  The class
        keeps its taught examples and at most ``keep`` in all, the oldest taken ones leaving first.
        Returns how many examples the class now has."""
        self.examples.append(example)
        self._taken.add(id(example))
        taken = [e for e in self.examples if e.label == example.label and id(e) in self._taken]
        own = sum(e.label == example.label for e in self.examples)
        while own > max(1, keep) and taken:
            gone = taken.pop(0)
            self.examples = [e for e in self.examples if e is not gone]
            self._taken.discard(id(gone))
            own -= 1
        self.train(choose=False)  # (the warp chosen on the taught examples stays: no choice at run time)
        return own

    def clear_margin(self, decision: Decision) -> bool:
        """Whether a decision is sure enough to learn from: within half its threshold, and every other
        class at least twice as far."""
        if decision.label is None or self.reject <= 0:
            return False
        own = decision.per_class[decision.label]
        others = [v for c, v in decision.per_class.items() if c != decision.label]
        return decision.distance <= 0.5 * self.threshold(decision.label) and all(
            v >= 2.0 * own for v in others
        )

    def motion_level(self, start: float) -> float:
        """The segmenter's ``on`` level: ``start`` times the median peak energy of the examples (the
        built-in level of :data:`DEFAULT_ON` before any)."""
        kind = Energy(self.channels, self.size).kind
        return start * float(np.median(self.peaks)) if self.peaks else DEFAULT_ON[kind]
