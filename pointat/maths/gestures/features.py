"""A movement's features: the channel groups of a frame, how they are taken (relative to the
movement's start or as they are), resampled at a fixed rate; and the recorded :class:`Example`."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pointat.maths.quaternion import quat_conjugate, quat_multiply, quat_to_rotvec

GRAVITY = 9.80665

#: The channel groups a frame may hold, and their sizes (``x``'s size is the model's).
CHANNELS: dict[str, int] = {"acc": 3, "gyr": 3, "mag": 3, "q": 4, "x": 0}

#: How the features are warped: ``each`` on its own (DTW_I), all ``together`` (DTW_D), or ``auto``: the
#: one of the two that names more of the model's own examples left out one at a time (together on a tie).
WARPS = ("auto", "each", "together")

#: The channel groups taken relative to how a movement began (:func:`transform`), by default: the
#: accelerometer as it is (the hand's attitude tells gestures apart), the turn since the start.
RELATIVE = ("q",)

#: How the channel groups are weighed against each other before DTW (:class:`GestureModel`'s ``scale``):
#: ``spread``: each group divided by its own spread over the examples; ``common``: the groups in their
#: feature units (``acc`` in g, ``gyr`` in rad/s, ``q`` in rad), all divided by one spread; ``si``: as
#: plain DTW weighs raw frames (``acc`` in m/s², ``gyr`` in rad/s), all divided by one spread.
SCALES = ("spread", "common", "si")

#: The label of examples of movements that are no gesture.
NULL = "null"


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


def feature_groups(channels: Sequence[str], size: int) -> list[slice]:
    """Where each channel group sits among the features (``q``'s four numbers become three)."""
    out, at = [], 0
    for name in channels:
        n = 3 if name == "q" else size if name == "x" else CHANNELS[name]
        out.append(slice(at, at + n))
        at += n
    return out


def group_scales(x: np.ndarray, channels: Sequence[str], size: int = 0, scale: str = "spread") -> np.ndarray:
    r"""What each feature is divided by before DTW, from the pooled feature frames ``x`` (N, D) of a
    model's examples (:data:`SCALES`): per group *g*, :math:`s_g = \sqrt{\overline{\operatorname{var}}(x_g)}`
    (``spread``), or one :math:`s = \sqrt{\overline{\operatorname{var}}(w x)}` over all features with
    each group's unit weight :math:`w_g` (1, but ``acc`` in m/s² per g for ``si``) and :math:`s_g = s / w_g`
    (``common``, ``si``).  A spread of 0 counts as 1.

    >>> x = np.column_stack([np.ones(4), np.array([0.0, 2.0, 0.0, 2.0])[:, None] * [1, 1, 1],
    ...                      np.array([0.0, 1.0, 0.0, 1.0])[:, None] * [1, 1, 1]])[:, 1:]
    >>> group_scales(x, ("acc", "gyr")).tolist()
    [1.0, 1.0, 1.0, 0.5, 0.5, 0.5]
    >>> group_scales(x, ("acc", "gyr"), scale="common").round(3).tolist()
    [0.791, 0.791, 0.791, 0.791, 0.791, 0.791]
    """
    if scale not in SCALES:
        raise ValueError(f"scale must be one of {', '.join(SCALES)}; got {scale!r}")
    groups = feature_groups(channels, size)
    weights = np.ones(x.shape[1])
    if scale == "si":
        for name, g in zip(channels, groups, strict=True):
            if name == "acc":
                weights[g] = GRAVITY
    out = np.empty(x.shape[1])
    if scale == "spread":
        for g in groups:
            spread = float(np.sqrt(np.mean(np.var(x[:, g], axis=0))))
            out[g] = spread if spread > 1e-9 else 1.0
        return out
    spread = float(np.sqrt(np.mean(np.var(x * weights, axis=0))))
    return (spread if spread > 1e-9 else 1.0) / weights


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
