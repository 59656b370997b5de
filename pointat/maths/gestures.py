r"""Gestures learnt from a performer's examples: trained movements, postures, strokes, and following.

Plain classes on numpy arrays; nothing here imports the engine.  The nodes of
:mod:`pointat.nodes.gestures` and ``pointat gestures evaluate`` (:mod:`pointat.gesture_eval`) run the very
same objects, so what the evaluation measures is what the patch does.

Conventions
-----------
* A *frame* is one sample of the channels a model uses, concatenated in the order of its ``channels``:
  ``acc`` (specific force, m/s², +g up at rest, sensor frame), ``gyr`` (rad/s), ``mag`` (any unit: only
  its direction is used), ``q`` (orientation w, x, y, z, sensor -> earth) and ``x`` (any other features,
  ``size`` numbers given by the model).  Times are seconds, strictly increasing.
* A gesture is the frames of one movement, from rest to rest (:class:`Segmenter`), between a gate's
  on and off, or wherever a template matches in a stream that never rests (:class:`Spotter`).  Its
  features (:func:`segment_features`) are resampled at a fixed ``rate`` (50 Hz), so that templates
  recorded at one sample rate match performances at another: ``acc`` in g as it is (gravity's direction
  tells the hand's attitude, which tells real gestures apart), or its change since the gesture began
  when ``relative`` says so; ``mag`` as a unit vector; ``q`` as the rotation since the gesture began (a
  rotation vector, radians: where the performer faces does not matter); each channel group then divided
  by its spread over the examples (:attr:`GestureModel.scales`), so that no unit outweighs another.
* Distances are dynamic time warping's (:mod:`pointat.maths.dtw`), all features warped together, nearest
  template wins (1-NN DTW, the baseline the literature holds every newer method against).
* The *null class* (:meth:`GestureModel.decide`): a movement farther from its nearest class than
  ``reject`` times the class's reach (its examples' distance from keeping still), or no nearer to it than
  three times its own distance from keeping still, or three times faster, slower, stronger or weaker than
  the class's examples, or whose nearest template is labelled ``null`` (movements the performer showed
  as "no gesture"), is no gesture.  Every default was chosen on real recordings and reported on others
  (``benchmarks/gesture_real.py``).

Examples
--------
>>> rng = np.random.default_rng(1)
>>> t = np.arange(60) / 50.0
>>> def wave(f):                        # a gyro trace (rad/s): one turn about z, f wiggles
...     return np.column_stack([0.3 * np.sin(f * np.pi * t), 0 * t, 4 * np.sin(np.pi * t / t[-1])])
>>> examples = [Example(label, t, wave(f) + rng.normal(0, 0.05, (60, 3)))
...             for label, f in (("one", 2), ("one", 2), ("two", 6), ("two", 6))]
>>> model = GestureModel(("gyr",)).train(examples)
>>> model.classify(t, wave(6)).label, model.classify(t, wave(2)).label
('two', 'one')
>>> model.classify(t, 0.1 * wave(2)).label is None                  # a tenth of the turn: no gesture
True
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pointat.maths.dtw import Spring, dtw_many, dtw_prefix_many
from pointat.maths.quaternion import quat_conjugate, quat_multiply, quat_to_matrix, quat_to_rotvec

__all__ = [
    "CHANNELS",
    "CUTS",
    "GRAVITY",
    "NULL",
    "REJECT",
    "RELATIVE",
    "Decision",
    "Energy",
    "Example",
    "Follower",
    "GestureModel",
    "PostureModel",
    "Recognizer",
    "Segmenter",
    "Spotter",
    "Stroke",
    "StrokeDetector",
    "channel_slices",
    "posture_features",
    "relative_channels",
    "resample",
    "segment_features",
    "transform",
]

GRAVITY = 9.80665

#: The channel groups a frame may hold, and their sizes (``x``'s size is the model's).
CHANNELS: dict[str, int] = {"acc": 3, "gyr": 3, "mag": 3, "q": 4, "x": 0}

#: How the features are warped: ``each`` on its own (DTW_I), or all ``together`` (DTW_D).
WARPS = ("each", "together")

#: The channel groups taken relative to how a movement began (:func:`transform`), by default: the
#: accelerometer as it is (the hand's attitude tells gestures apart), the turn since the start.
RELATIVE = ("q",)

#: The default ``reject`` (:class:`GestureModel`): the operating point chosen on real recordings, on the
#: curve of real gestures found against false triggers on real motion that is no gesture.
REJECT = 3.0

#: The channel groups whose peak strength a gesture's performances keep to (:meth:`GestureModel.strength`).
_STRONG = ("acc", "gyr")

#: How a stream is cut into movements: from ``rest`` to rest (:class:`Segmenter`), or every template
#: matched anywhere (``spot``: :class:`Spotter`, for repetitions with no rest between them).
CUTS = ("rest", "spot")

#: The label of examples of movements that are no gesture.
NULL = "null"

#: Energy (rad/s for ``gyr`` and ``q``; m/s² of acceleration off its slow mean for ``acc``; the field's
#: direction in rad/s for ``mag``) above which a movement starts before any example sets the level:
#: 1 rad/s is a brisk turn of the wrist, 3 m/s² a brisk jolt; the slow turns of pointing stay under.
DEFAULT_ON = {"gyr": 1.0, "q": 1.0, "acc": 3.0, "mag": 1.0, "x": 1.0}


def channel_slices(channels: Sequence[str], size: int = 0) -> dict[str, slice]:
    """Where each channel group sits in a frame.

    >>> channel_slices(("gyr", "acc"))
    {'gyr': slice(0, 3, None), 'acc': slice(3, 6, None)}
    """
    out, at = {}, 0
    for name in channels:
        if name not in CHANNELS:
            raise ValueError(f"unknown channel {name!r}; channels: {', '.join(CHANNELS)}")
        if name in out:
            raise ValueError(f"channel {name!r} given twice")
        n = size if name == "x" else CHANNELS[name]
        if n <= 0:
            raise ValueError("channel 'x' needs its size (the number of features)")
        out[name] = slice(at, at + n)
        at += n
    if not out:
        raise ValueError("no channels")
    return out


def _unit_rows(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=1, keepdims=True)
    return v / np.where(n > 1e-12, n, 1.0)


def _relative_rotation(q: np.ndarray) -> np.ndarray:
    r"""Rotation vectors (radians) of :math:`q_0^* \otimes q_t`: the turn since the first frame, in the
    sensor's frame at the start (the same gesture facing any way gives the same values)."""
    return quat_to_rotvec(quat_multiply(quat_conjugate(q[0]), q))


def relative_channels(relative: Sequence[str]) -> tuple[str, ...]:
    """``relative`` checked: the channel groups that can be taken relative to how a movement began.

    >>> relative_channels(["acc"])
    ('acc',)
    """
    out = tuple(str(c) for c in relative)
    if set(out) - {"acc", "q"}:
        raise ValueError(f"relative takes acc and q; got {' '.join(out)}")
    return out


def _up_in_hand(q: np.ndarray) -> np.ndarray:
    """The earth's up in the sensor frame (the third row of each rotation matrix): the hand's attitude,
    heading left out."""
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.column_stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])


def resample(t: np.ndarray, x: np.ndarray, rate: float) -> np.ndarray:
    """``x`` (T, D) at times ``t`` resampled at ``rate`` Hz from ``t[0]`` to ``t[-1]`` (linear); at least
    two frames.

    >>> resample(np.array([0.0, 0.1]), np.array([[0.0], [1.0]]), 50.0).ravel().tolist()
    [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]
    """
    n = max(2, int(round((t[-1] - t[0]) * rate)) + 1)
    grid = np.linspace(t[0], t[-1], n)
    return np.column_stack([np.interp(grid, t, x[:, k]) for k in range(x.shape[1])])


def transform(
    frames: np.ndarray, channels: Sequence[str], size: int = 0, relative: Sequence[str] = RELATIVE
) -> np.ndarray:
    """Feature frames of a movement's frames (T, F), unscaled and not resampled: ``acc`` in g, as it is
    (gravity's direction in the hand tells its attitude) or, when in ``relative``, its change since the
    first frame (whether the hand was raised or level as it began no longer matters); ``mag`` a unit
    vector; ``q`` the rotation since the first frame (a rotation vector, radians: where the performer
    faces does not matter)."""
    parts = []
    for name, sl in channel_slices(channels, size).items():
        v = frames[:, sl]
        if name == "acc":
            v = (v - v[0]) / GRAVITY if "acc" in relative else v / GRAVITY
        elif name == "mag":
            v = _unit_rows(v)
        elif name == "q":
            v = _relative_rotation(v) if "q" in relative else _up_in_hand(v)
        parts.append(v)
    return np.column_stack(parts)


def segment_features(
    t: np.ndarray,
    frames: np.ndarray,
    channels: Sequence[str],
    rate: float,
    size: int = 0,
    relative: Sequence[str] = RELATIVE,
) -> np.ndarray:
    """A movement's feature frames (:func:`transform`), resampled at ``rate`` Hz (:func:`resample`)."""
    x = transform(frames, channels, size, relative)
    if len(t) < 2:
        return np.vstack([x, x])
    return resample(t, x, rate)


def _groups(channels: Sequence[str], size: int) -> list[slice]:
    """Where each channel group sits among the features (``q``'s four numbers become three)."""
    out, at = [], 0
    for name in channels:
        n = 3 if name == "q" else size if name == "x" else CHANNELS[name]
        out.append(slice(at, at + n))
        at += n
    return out


@dataclass
class Example:
    """One recorded example: its label, times (s) and frames (T, F) in the model's channel order."""

    label: str
    t: np.ndarray
    frames: np.ndarray

    def __post_init__(self) -> None:
        self.t = np.asarray(self.t, dtype=float)
        self.frames = np.asarray(self.frames, dtype=float)
        if self.frames.ndim != 2 or len(self.t) != len(self.frames) or len(self.t) == 0:
            raise ValueError(
                f"example {self.label!r}: {len(self.t)} times and frames of shape {self.frames.shape}"
            )
        if not (np.all(np.isfinite(self.t)) and np.all(np.isfinite(self.frames))):
            raise ValueError(f"example {self.label!r}: a time or value is not a finite number")
        if len(self.t) > 1 and not np.all(np.diff(self.t) > 0):
            raise ValueError(f"example {self.label!r}: times must increase")

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])


# --------------------------------------------------------------------------------------------------
# Motion energy and segmentation
# --------------------------------------------------------------------------------------------------


class Energy:
    """How much the hand moves, frame by frame, from the model's channels: ``|gyro|`` (rad/s) when
    there is a gyro, else the rate of turn of ``q`` or of the field's direction, else the acceleration
    off its slow mean (a 0.3 s low-pass; m/s²), else the features' rate of change."""

    TAU = 0.3

    def __init__(self, channels: Sequence[str], size: int = 0) -> None:
        sl = channel_slices(channels, size)
        self.kind = next(k for k in ("gyr", "q", "acc", "mag", "x") if k in sl)
        self.slice = sl[self.kind]
        self.reset()

    def reset(self) -> None:
        self._last: np.ndarray | None = None
        self._t = 0.0

    def __call__(self, t: float, frame: np.ndarray) -> float:
        v = frame[self.slice]
        if self.kind == "gyr":
            return float(math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]))
        last, dt = self._last, t - self._t
        self._t = t
        if self.kind == "acc":
            if last is None or not 0.0 < dt < 1.0:
                self._last = v.copy()
                return 0.0
            last += (v - last) * (1.0 - math.exp(-dt / self.TAU))
            return float(np.linalg.norm(v - last))
        if self.kind in ("q", "mag"):
            v = v / max(float(np.linalg.norm(v)), 1e-12)
        self._last = v.copy()
        if last is None or not 0.0 < dt < 1.0:
            return 0.0
        if self.kind == "q":
            return 2.0 * math.acos(min(1.0, abs(float(v @ last)))) / dt
        if self.kind == "mag":
            return math.acos(max(-1.0, min(1.0, float(v @ last)))) / dt
        return float(np.linalg.norm(v - last)) / dt


class Segmenter:
    """Rest and motion, with hysteresis: a movement starts when the energy reaches ``on``, and ends when
    it has stayed under ``off`` for ``settle`` seconds.  It begins where the energy last rose past
    ``off`` (at most ``preroll`` s earlier), and ends at its last frame over ``off``.

    :meth:`push` returns ``None``, ``"start"``, ``"end"`` (a movement of ``shortest`` to ``longest``
    s has ended: :attr:`span` holds its first and last frame times) or ``"drop"`` (too short, or still
    going after ``longest``: no gesture; a movement that goes on is only taken again after rest).
    """

    def __init__(
        self,
        on: float,
        off: float,
        settle: float = 0.1,
        shortest: float = 0.15,
        longest: float = 4.0,
        preroll: float = 0.3,
    ) -> None:
        if not 0.0 <= off <= on:
            raise ValueError(f"off ({off}) must be within 0..on ({on})")
        self.on, self.off, self.settle = on, off, settle
        self.shortest, self.longest, self.preroll = shortest, longest, preroll
        self.reset()

    def reset(self) -> None:
        self.moving = False
        self.spoilt = False  # a movement too long: wait for rest
        self.span = (0.0, 0.0)
        self._rise = math.nan  # when the energy last rose past off
        self._last_over = math.nan  # the last frame over off
        self.began = math.nan

    def push(self, t: float, energy: float) -> str | None:
        over = energy > self.off
        if over and not self._last_over >= self._rise:  # (a NaN rise too)
            self._rise = t
        if over:
            self._last_over = t
        if not over:
            self._rise = math.nan
        if self.spoilt:
            if not over and t - self._last_over >= self.settle:
                self.spoilt = False
            return None
        if not self.moving:
            if energy >= self.on:
                rise = self._rise if self._rise == self._rise else t
                self.began = max(rise, t - self.preroll)
                self.moving = True
                return "start"
            return None
        if t - self.began > self.longest:
            self.moving, self.spoilt = False, True
            return "drop"
        if not over and t - self._last_over >= self.settle:
            self.moving = False
            self.span = (self.began, self._last_over)
            return "end" if self._last_over - self.began >= self.shortest else "drop"
        return None


# --------------------------------------------------------------------------------------------------
# Trained movements: 1-NN DTW with a null class
# --------------------------------------------------------------------------------------------------


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
        reach away (:meth:`threshold`: the class's distance from keeping still), or when it is not nearer
        to its class than :attr:`STILL` times its own distance from keeping still; 0: never rejected,
        but by ``null`` examples.
    warp : str
        ``together``: all features warped as one (DTW_D), or ``each`` on its own (DTW_I).
    relative : sequence of str
        The channel groups taken relative to how the movement began (:func:`transform`).
    """

    #: A movement is no performance of a class when it is this many times faster than its fastest
    #: example or slower than its slowest.
    PACE = 3.0
    #: ... or when its accelerometer's or gyro's peak is this many times stronger than its strongest
    #: example's, or weaker than its weakest's (a tap, a jolt: far stronger than any gesture taught).
    STRENGTH = 3.0
    #: The least reach of a class, as a share of the median class's: a class that is itself nearly
    #: still (standing, a hand held) is then not refused for every tremble of its performance.
    FLOOR = 0.25
    #: A movement is no gesture when it is not nearer to its class than this many times its own distance
    #: from keeping still (a tremble, a small turn of the wrist: near keeping still, so near every
    #: gesture's reach from it).
    STILL = 3.0
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
        warp: str = "together",
        relative: Sequence[str] = RELATIVE,
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
        self.examples: list[Example] = []
        self.templates: list[np.ndarray] = []
        self.labels: list[str] = []
        self.scales = np.ones(0)
        self.reach: dict[str, float] = {}
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

    def train(self, examples: Sequence[Example] | None = None) -> GestureModel:
        """Learn the templates, the scales and each class's reach from the examples.

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
        pooled = np.vstack(raw)
        scales = np.empty(pooled.shape[1])
        for g in _groups(self.channels, self.size):
            spread = float(np.sqrt(np.mean(np.var(pooled[:, g], axis=0))))
            scales[g] = spread if spread > 1e-9 else 1.0
        self.scales = scales
        self.templates = [x / scales for x in raw]
        self.labels = [e.label for e in self.examples]
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

    def still(self, x: np.ndarray) -> float:
        """The distance of feature frames ``x`` from keeping still: from their first frame held as long,
        the gyro at 0."""
        rest = np.repeat(x[:1], len(x), axis=0)
        for name, g in zip(self.channels, _groups(self.channels, self.size), strict=True):
            if name == "gyr":
                rest[:, g] = 0.0
        return float(self._dtw(x, [rest])[0])

    def _dtw(self, x: np.ndarray, templates: Sequence[np.ndarray]) -> np.ndarray:
        return dtw_many(x, templates, self.band, each=self.warp == "each")

    def threshold(self, label: str) -> float:
        """The distance beyond which a movement nearest to ``label`` is no gesture: ``reject`` times the
        class's reach (its examples' distance from keeping still)."""
        if self.reject <= 0:
            return math.inf
        return self.reject * self.reach[label]

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
    ) -> Decision:
        """The decision from the distances to each template (and the movement's duration, s, and its
        distance from keeping still, told with the decision)."""
        per_class: dict[str, float] = {}
        for label, d in zip(self.labels, distances, strict=True):
            if d < per_class.get(label, math.inf):
                per_class[label] = float(d)
        nearest = min(per_class, key=per_class.__getitem__)
        d = per_class[nearest]
        if nearest == NULL:
            return Decision(None, d, nearest, 0.0, per_class, early, still, duration)
        limit = self.threshold(nearest)
        score = 1.0 - d / limit if math.isfinite(limit) and limit > 0 else 1.0
        ok = (
            d <= limit
            and (self.reject <= 0 or d < self.STILL * still)
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
        return self.decide(
            self._dtw(x, self.templates),
            duration=float(t[-1] - t[0]),
            still=self.still(x),
            strength=self.strength(frames),
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
        rows = dtw_prefix_many(x, self.templates, self.band, each=self.warp == "each")
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
        if self.reject > 0 and cost >= self.STILL * self.still(x):
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
        self.train()
        return own

    def clear_margin(self, decision: Decision) -> bool:
        """Whether a decision is sure enough to learn from: within half its threshold, and every other
        class at least twice as far."""
        if decision.label is None or self.reject <= 0:
            return False
        others = [v for c, v in decision.per_class.items() if c != decision.label]
        return decision.distance <= 0.5 * self.threshold(decision.label) and all(
            v >= 2.0 * decision.distance for v in others
        )

    def motion_level(self, start: float) -> float:
        """The segmenter's ``on`` level: ``start`` times the median peak energy of the examples (the
        built-in level of :data:`DEFAULT_ON` before any)."""
        kind = Energy(self.channels, self.size).kind
        return start * float(np.median(self.peaks)) if self.peaks else DEFAULT_ON[kind]


class Spotter:
    """Trained movements found in a stream that never rests (repetitions one after another): every
    template matched anywhere, frame by frame (:class:`~pointat.maths.dtw.Spring`, subsequence DTW on
    the features at the model's frame rate, taken as they are: nothing is relative to a start), the
    best match of those that overlap told once no better one can follow (``hold`` s after its end),
    under the model's rules of rejection (:meth:`GestureModel.decide`: reach, keeping still, pace and
    strength).  :meth:`push` returns decisions: (Decision, time of the match's last frame).
    """

    #: A match is no longer nor shorter than this many times its template.
    STRETCH = 2.5

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
        self._pending: list[tuple[float, int, int, int]] = []  # cost, template, start and end steps
        self._free = 0  # steps before this one belong to a match already told

    def push(self, t: float, frame: np.ndarray) -> list[tuple[Decision, float]]:
        out: list[tuple[Decision, float]] = []
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

    def _step(self, t: float, x: np.ndarray) -> list[tuple[Decision, float]]:
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
            share = cost / self.model.threshold(label)  # (the classes compared at their own scale)
            if share > 1.0:
                continue
            for k, p in enumerate(pending):  # the best of the matches that overlap by half or more
                if min(step, p[3]) - max(start, p[2]) + 1 > 0.5 * min(step - start, p[3] - p[2]) + 0.5:
                    if share < p[0]:
                        pending[k] = (float(share), j, start, step)
                    break
            else:
                pending.append((float(share), j, start, step))
        out = []
        pending.sort(key=lambda p: p[3])
        while pending and (step - pending[0][3]) / self.model.frame_rate >= self.hold:
            p = pending.pop(0)
            if p[2] < self._free or p[2] < first:
                continue
            decision = self._decide(p, first)
            if decision is not None:
                self._free = p[3] + 1 - len(self.templates[p[1]]) // 4  # (a next one may begin as it ends)
                out.append((decision, self.times[p[3] - first]))
        return out

    def _decide(self, p: tuple[float, int, int, int], first: int) -> Decision | None:
        _, _, start, end = p
        m = self.model
        x = np.array([self.feats[k - first] for k in range(start, end + 1)])
        ts = [self.times[k - first] for k in range(start, end + 1)]
        raw = np.array([f for ti, f in self.raw if ts[0] <= ti <= ts[-1]] or [self.raw[-1][1]])
        decision = m.decide(
            dtw_many(x, self.templates, 1.0),
            duration=ts[-1] - ts[0],
            still=m.still(x),
            strength=m.strength(raw),
        )
        return decision if decision.label is not None else None


class Recognizer:
    """Trained movements found in a stream, frame by frame: what the ``gesture`` node and
    ``pointat gestures evaluate`` run.

    Movements are cut by the :class:`Segmenter` (``gate=None``: rest and motion) or by a gate
    (:meth:`gate`: a button held, or each file of an evaluation).  Each movement gets at most one
    decision: early (:meth:`GestureModel.early`, checked every ``check`` s while it goes on) or when it
    ends; after a decision, movements that start within ``refractory`` s get none.  A movement ended
    while recording (``record`` set to a label) becomes an example instead.

    :meth:`push` returns a list of events: ``("start", t)``, ``("end", t_last)``, ``("decision", Decision, t_last)`` (the
    decision, and the time of the movement's last frame: the decision's latency is the time of the
    frame that made it minus that), ``("example", Example)``, ``("adapted", label, examples of the class)``, ``("drop", why)``.
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

    def reset(self) -> None:
        self.spotter = None
        self.frames.clear()
        self.energy.reset()
        self.segmenter.reset()
        self._open = False  # a movement under way
        self._decided: Decision | bool = False  # the decision told early, while the movement went on
        self._next_check = 0.0
        self._quiet_until = -math.inf

    def gate(self, on: bool | None, t: float) -> list[tuple[Any, ...]]:
        """Open (True) or close (False) the gate at time ``t``; ``None`` hands cutting back to the
        segmenter.  Closing it ends the movement (as the segmenter's end would)."""
        events: list[tuple[Any, ...]] = []
        if on and not self._open:
            self.frames.clear()
            self._open, self._decided = True, False
            self._next_check = t + self.check
            events.append(("start", t))
        elif not on and self._open and self.gated:
            self._open = False
            events += self._ended(list(self.frames))
        self.gated = on
        if on is None:
            self.reset()
        return events

    def push(self, t: float, frame: np.ndarray) -> list[tuple[Any, ...]]:
        """One frame at time ``t``: the events it brings."""
        if self.cut == "spot" and self.gated is None and self.record is None and self.model.trained:
            if self.spotter is None or self.spotter.made_from is not self.model.templates:  # (trained again)
                self.spotter = Spotter(self.model)
            return [("decision", d, when) for d, when in self.spotter.push(t, frame)]
        events: list[tuple[Any, ...]] = []
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
                events.append(("start", self.segmenter.began))
            elif what == "end":
                self._open = False
                first, last = self.segmenter.span
                events += self._ended([f for f in frames if first <= f[0] <= last])
            elif what == "drop":
                self._open = False
                events.append(("drop", "too short" if not self.segmenter.spoilt else "too long"))
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
                    events.append(("decision", decision, math.nan))
        return events

    def _began(self) -> float:
        return self.segmenter.began if self.gated is None else -math.inf

    @staticmethod
    def _arrays(span: list[tuple[float, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
        return np.array([f[0] for f in span]), np.array([f[1] for f in span])

    def _ended(self, span: list[tuple[float, np.ndarray]]) -> list[tuple[Any, ...]]:
        if not span:
            return [("drop", "empty")]
        ts, xs = self._arrays(span)
        ended: list[tuple[Any, ...]] = [("end", float(ts[-1]))]
        if self.record is not None:
            return [*ended, ("example", Example(self.record, ts, xs))]
        if not self.model.trained:
            return ended
        if isinstance(self._decided, Decision):
            return ended + self._adapted(self._decided, ts, xs)
        if self._decided:
            return ended
        if ts[0] < self._quiet_until:
            return [*ended, ("drop", "refractory")]
        decision = self.model.classify(ts, xs)
        self._quiet_until = ts[-1] + self.refractory
        return [*ended, ("decision", decision, float(ts[-1])), *self._adapted(decision, ts, xs)]

    def _adapted(self, decision: Decision, ts: np.ndarray, xs: np.ndarray) -> list[tuple[Any, ...]]:
        if not (self.adapt and len(ts) > 1 and self.model.clear_margin(decision)):
            return []
        n = self.model.adapt(Example(str(decision.label), ts, xs), self.keep)
        return [("adapted", decision.label, n)]


# --------------------------------------------------------------------------------------------------
# Postures: k-NN on the hand's attitude and any features
# --------------------------------------------------------------------------------------------------


def posture_features(
    frame: np.ndarray, channels: Sequence[str], size: int = 0, heading: bool = False
) -> np.ndarray:
    """The features of one frame for postures: ``q`` as the direction of gravity in the hand's frame
    (where the hand faces does not matter), or with ``heading`` its whole rotation matrix; ``acc`` and
    ``mag`` as unit vectors (at rest the accelerometer gives gravity's direction); ``gyr`` and ``x`` as
    they are.

    >>> posture_features(np.array([1.0, 0.0, 0.0, 0.0]), ("q",)).tolist()     # level: gravity along z
    [0.0, 0.0, 1.0]
    """
    parts = []
    for name, sl in channel_slices(channels, size).items():
        v = np.asarray(frame[sl], dtype=float)
        if name == "q":
            r = quat_to_matrix(v)  # gravity's direction in the hand is its third row (R^T z)
            v = np.concatenate([r[2], r[:, 0], r[:, 1]]) if heading else r[2]
        elif name in ("acc", "mag"):
            v = v / max(float(np.linalg.norm(v)), 1e-12)
        parts.append(v)
    return np.concatenate(parts)


class PostureModel:
    """Postures by k-NN over the examples' frames, with rejection.

    A frame is taken for the posture of the majority of its ``k`` nearest example frames when the
    nearest of those is within ``reject`` times the posture's spread (the 90th percentile of its
    examples' distances to their posture's centre, at least ``floor``: a held hand trembles a few
    degrees, a model whose examples were all one frame must still take the hand back).  ``floor`` is
    in feature units: for ``q`` (unit vectors), 0.1 is about 6 degrees.

    >>> m = PostureModel(("q",)).train([Example("level", [0.0], [[1.0, 0, 0, 0]]),
    ...                                  Example("up", [0.0], [[0.7071, 0, -0.7071, 0]])])
    >>> m.classify(np.array([1.0, 0, 0, 0]))[0], m.classify(np.array([0.7071, 0, 0.7071, 0]))[0]
    ('level', None)
    """

    def __init__(
        self,
        channels: Sequence[str],
        *,
        size: int = 0,
        k: int = 5,
        reject: float = 3.0,
        floor: float = 0.1,
        heading: bool = False,
    ) -> None:
        self.channels, self.size = tuple(channels), int(size)
        self.width = channel_slices(self.channels, self.size)[self.channels[-1]].stop
        self.k, self.reject, self.floor, self.heading = int(k), float(reject), float(floor), bool(heading)
        self.examples: list[Example] = []
        self.points = np.zeros((0, 0))
        self.labels: list[str] = []
        self.spread: dict[str, float] = {}

    @property
    def trained(self) -> bool:
        return bool(self.labels)

    @property
    def classes(self) -> list[str]:
        return sorted({e.label for e in self.examples if e.label != NULL})

    def features(self, frame: np.ndarray) -> np.ndarray:
        return posture_features(frame, self.channels, self.size, self.heading)

    def train(self, examples: Sequence[Example] | None = None) -> PostureModel:
        if examples is not None:
            self.examples = list(examples)
        if not self.classes:
            raise ValueError("no examples to train on (record some first: record LABEL, and hold)")
        points, labels = [], []
        for e in self.examples:
            if e.frames.shape[1] != self.width:
                raise ValueError(
                    f"example {e.label!r} has {e.frames.shape[1]} values a frame; channels"
                    f" {' '.join(self.channels)} make {self.width}"
                )
            for f in e.frames:
                points.append(self.features(f))
                labels.append(e.label)
        self.points, self.labels = np.array(points), labels
        lab = np.array(labels)
        self.spread = {}
        for c in self.classes:
            own = self.points[lab == c]
            d = np.linalg.norm(own - own.mean(axis=0), axis=1)
            self.spread[c] = max(self.floor, float(np.percentile(d, 90)))
        return self

    def classify(self, frame: np.ndarray) -> tuple[str | None, float]:
        """The posture of one frame (``None``: none), and the distance to its nearest example frame."""
        x = self.features(frame)
        d = np.linalg.norm(self.points - x, axis=1)
        k = min(self.k, len(d))
        nearest = np.argpartition(d, k - 1)[:k] if k < len(d) else np.arange(len(d))
        votes: dict[str, int] = {}
        for i in nearest:
            votes[self.labels[i]] = votes.get(self.labels[i], 0) + 1
        label = max(votes, key=lambda c: (votes[c], -min(d[i] for i in nearest if self.labels[i] == c)))
        best = float(min(d[i] for i in nearest if self.labels[i] == label))
        if label == NULL or (self.reject > 0 and best > self.reject * self.spread[label]):
            return None, best
        return label, best


# --------------------------------------------------------------------------------------------------
# Strokes: onset, direction in the room, strength
# --------------------------------------------------------------------------------------------------


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


# --------------------------------------------------------------------------------------------------
# Following one movement as it unfolds
# --------------------------------------------------------------------------------------------------


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
                d[a, [b for b in range(len(examples)) if b != a]] = model._dtw(tpl[i], others)
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
