"""What a :class:`~pointat.maths.gestures.Recognizer` tells as a stream goes by: one small named value a
kind, read by its fields (``isinstance(event, Decided)``, or ``match``)."""

from __future__ import annotations

from dataclasses import dataclass

from pointat.maths.gestures.features import Example
from pointat.maths.gestures.model import Decision

__all__ = ["Adapted", "Decided", "Dropped", "Ended", "Event", "Recorded", "Started"]


@dataclass(frozen=True)
class Started:
    """A movement began; ``t`` its first frame's time (s)."""

    t: float


@dataclass(frozen=True)
class Ended:
    """A movement ended; ``t`` its last frame's time (s)."""

    t: float


@dataclass(frozen=True)
class Decided:
    """What a movement was.  ``t`` is the time of its last frame (s; the decision's latency is the time of
    the frame that made it minus that), NaN for a decision told early, while the movement went on."""

    decision: Decision
    t: float


@dataclass(frozen=True)
class Recorded:
    """A movement ended while recording: a new example (the model is not trained on it yet)."""

    example: Example


@dataclass(frozen=True)
class Adapted:
    """A performance recognised with a clear margin joined its class's examples (``adapt``): the class's
    ``label`` and how many examples it has now."""

    label: str
    examples: int


@dataclass(frozen=True)
class Dropped:
    """A movement that gets no decision, and ``why`` (too short, too long, refractory, empty)."""

    why: str


Event = Started | Ended | Decided | Recorded | Adapted | Dropped
