"""Postures: k-NN on the hand's attitude and any features, with rejection."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pointat.maths.gestures.features import NULL, Example, channel_slices
from pointat.maths.quaternion import quat_to_matrix


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
