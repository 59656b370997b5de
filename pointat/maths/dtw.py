r"""Dynamic time warping of multivariate series: whole against whole, and a prefix against a template.

Each series is an array of shape (T, D): T frames of D features.  The local cost of frames
:math:`a_i, b_j` is the squared Euclidean distance :math:`c(i, j) = \lVert a_i - b_j \rVert^2`, and the
cumulative cost (Sakoe and Chiba 1978, the symmetric step without weights)

.. math::
    D(i, j) = c(i, j) + \min\{D(i-1, j-1),\, D(i-1, j),\, D(i, j-1)\}, \qquad D(0, 0) = 0

over a band :math:`|i - j| \le w` (widened to :math:`|n - m|` so that the end stays reachable).  The
distance is :math:`D(n, m) / (n + m)`: a mean cost per step of the path, comparable between series of
different lengths.  The open end (:func:`dtw_prefix`) lets the template stop anywhere: the best
:math:`D(n, j) / (n + j)` over :math:`j`, and that :math:`j`, is how far through the template a gesture
in progress has come (early recognition).

The loops are compiled by numba on first use (:func:`pointat.jit.compile_module`; numba is imported
only when a distance is first asked for, so that a patch without gestures does not load it).

>>> import numpy as np
>>> a = np.array([[0.0], [1.0], [2.0], [1.0], [0.0]])
>>> dtw_distance(a, a, 0.2)
0.0
>>> b = np.array([[0.0], [0.0], [1.0], [2.0], [2.0], [1.0], [0.0]])   # a, slower in places
>>> dtw_distance(a, b, 1.0)
0.0
>>> cost, j = dtw_prefix(a[:3], b, 1.0)                                  # 0 1 2: up to the peak of b
>>> cost, j
(0.0, 4)
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

__all__ = ["Spring", "band", "dtw_distance", "dtw_many", "dtw_prefix", "dtw_prefix_many", "warm"]


def band(n: int, m: int, fraction: float) -> int:
    """The band's half-width in frames: ``fraction`` of the longer series, at least ``|n - m|`` and 1.

    >>> band(100, 80, 0.1), band(100, 60, 0.1), band(3, 3, 0.0)
    (20, 40, 1)
    """
    return max(1, abs(n - m), int(math.ceil(fraction * max(n, m))))


def _cumulative(a: np.ndarray, b: np.ndarray, w: int, last: np.ndarray) -> None:
    """The last row of :math:`D` (length m + 1, ``last[0]`` infinite) for ``a`` against ``b``."""
    n, m, d = a.shape[0], b.shape[0], a.shape[1]
    inf = np.inf
    prev = np.empty(m + 1)
    cur = np.empty(m + 1)
    for j in range(m + 1):
        prev[j] = inf
    prev[0] = 0.0
    for i in range(1, n + 1):
        for j in range(m + 1):
            cur[j] = inf
        lo = max(1, i - w)
        hi = min(m, i + w)
        for j in range(lo, hi + 1):
            c = 0.0
            for k in range(d):
                diff = a[i - 1, k] - b[j - 1, k]
                c += diff * diff
            best = prev[j - 1]
            if prev[j] < best:
                best = prev[j]
            if cur[j - 1] < best:
                best = cur[j - 1]
            cur[j] = c + best
        for j in range(m + 1):
            prev[j] = cur[j]
    for j in range(m + 1):
        last[j] = prev[j]


def _distance(a: np.ndarray, b: np.ndarray, w: int) -> float:
    last = np.empty(b.shape[0] + 1)
    _cumulative(a, b, w, last)
    return last[b.shape[0]] / (a.shape[0] + b.shape[0])


def _prefix(a: np.ndarray, b: np.ndarray, w: int) -> tuple[float, int]:
    last = np.empty(b.shape[0] + 1)
    _cumulative(a, b, w, last)
    n = a.shape[0]
    best, where = np.inf, 0
    for j in range(1, b.shape[0] + 1):
        v = last[j] / (n + j)
        if v < best:
            best, where = v, j
    return best, where


def _many(
    a: np.ndarray, bank: np.ndarray, starts: np.ndarray, fraction: float, each: bool, out: np.ndarray
) -> None:
    """:func:`_distance` of ``a`` against every template of a bank (concatenated, ``starts`` bounds);
    ``each``: the sum of the distances of each feature alone."""
    n = a.shape[0]
    for t in range(starts.shape[0] - 1):
        b = bank[starts[t] : starts[t + 1]]
        m = b.shape[0]
        w = band(n, m, fraction)
        if each:
            total = 0.0
            for k in range(a.shape[1]):
                total += _distance(a[:, k : k + 1], b[:, k : k + 1], w)
            out[t] = total
        else:
            out[t] = _distance(a, b, w)


def _prefix_many(
    a: np.ndarray, bank: np.ndarray, starts: np.ndarray, fraction: float, each: bool, out: np.ndarray
) -> None:
    """:func:`_prefix` of ``a`` against every template: ``out[t] = (cost, share of the template)``
    (``each``: the costs of each feature alone summed, the median share)."""
    n = a.shape[0]
    d = a.shape[1]
    shares = np.empty(d)
    for t in range(starts.shape[0] - 1):
        b = bank[starts[t] : starts[t + 1]]
        m = b.shape[0]
        w = max(1, int(math.ceil(fraction * max(n, m))))
        if each:
            total = 0.0
            for k in range(d):
                cost, j = _prefix(a[:, k : k + 1], b[:, k : k + 1], w)
                total += cost
                shares[k] = j / m
            out[t, 0] = total
            out[t, 1] = np.median(shares)
        else:
            cost, j = _prefix(a, b, w)
            out[t, 0] = cost
            out[t, 1] = j / m


def _spring(
    x: np.ndarray, bank: np.ndarray, starts: np.ndarray, t: int, d: np.ndarray, s: np.ndarray, out: np.ndarray
) -> None:
    """One frame ``x`` (D,) of a stream, its step ``t``, against every template of a bank, a match free to
    start at any step (SPRING: Sakurai, Faloutsos and Yamamuro 2007, subsequence DTW).  ``d`` and ``s``
    hold each template's column of cumulative costs and their paths' start steps (template ``j`` at
    ``starts[j] + j``, ``m + 1`` cells; ``d`` infinite but its first cell at the start), updated in place;
    ``out[j] = (cost, start)``: the best match ending now, :math:`D / (n + m)` as :func:`dtw_distance`'s."""
    for j in range(starts.shape[0] - 1):
        at = starts[j] + j
        m = starts[j + 1] - starts[j]
        diag, diag_s = d[at], s[at]
        d[at], s[at] = 0.0, t
        for i in range(1, m + 1):
            c = 0.0
            for k in range(x.shape[0]):
                diff = x[k] - bank[starts[j] + i - 1, k]
                c += diff * diff
            best, best_s = d[at + i - 1], s[at + i - 1]  # this step, the template's previous frame
            if diag < best:  # the previous step, the template's previous frame
                best, best_s = diag, diag_s
            old, old_s = d[at + i], s[at + i]
            if old < best:  # the previous step, this frame of the template
                best, best_s = old, old_s
            diag, diag_s = old, old_s
            d[at + i], s[at + i] = c + best, best_s
        out[j, 0] = d[at + m] / (t - s[at + m] + 1 + m)
        out[j, 1] = s[at + m]


_compiled: Any = None


def _kernel(name: str) -> Callable[..., Any]:
    """The compiled form of this module's function ``name`` (numba, cached in the user's cache folder)."""
    global _compiled
    if _compiled is None:
        from pointat import jit  # here: numba costs ~0.25 s to import, only once gestures are compared

        _compiled = jit.compile_module(sys.modules[__name__])
    return getattr(_compiled, name)  # type: ignore[no-any-return]


def _frames(x: Any, what: str) -> np.ndarray:
    a = np.ascontiguousarray(x, dtype=float)
    if a.ndim != 2 or a.shape[0] == 0 or a.shape[1] == 0:
        raise ValueError(f"{what} must be frames of features, shape (T, D) with T, D >= 1; got {a.shape}")
    return a


def dtw_distance(a: Any, b: Any, fraction: float = 0.2) -> float:
    """The DTW distance of series ``a`` (n, D) and ``b`` (m, D): mean squared step cost, >= 0.

    ``fraction``: the band's half-width as a fraction of the longer series (:func:`band`); 1 is no band.
    """
    a, b = _frames(a, "a"), _frames(b, "b")
    if a.shape[1] != b.shape[1]:
        raise ValueError(f"the series have {a.shape[1]} and {b.shape[1]} features")
    return float(_kernel("_distance")(a, b, band(a.shape[0], b.shape[0], fraction)))


def dtw_prefix(a: Any, b: Any, fraction: float = 0.2) -> tuple[float, int]:
    """``a`` (n, D), a gesture so far, against template ``b`` (m, D) with an open end: the least
    :math:`D(n, j) / (n + j)` and the ``j`` (1..m, frames of ``b``) where it is reached."""
    a, b = _frames(a, "a"), _frames(b, "b")
    if a.shape[1] != b.shape[1]:
        raise ValueError(f"the series have {a.shape[1]} and {b.shape[1]} features")
    w = max(1, int(math.ceil(fraction * max(a.shape[0], b.shape[0]))))
    cost, j = _kernel("_prefix")(a, b, w)
    return float(cost), int(j)


def _bank(a: Any, templates: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    a = _frames(a, "a")
    bank = np.ascontiguousarray(np.concatenate([_frames(t, "a template") for t in templates]))
    if bank.shape[1] != a.shape[1]:
        raise ValueError(f"the series have {a.shape[1]} and {bank.shape[1]} features")
    return a, bank, np.cumsum([0] + [len(t) for t in templates]).astype(np.int64)


def dtw_many(
    a: Any, templates: Sequence[np.ndarray], fraction: float = 0.2, *, each: bool = False
) -> np.ndarray:
    """:func:`dtw_distance` of ``a`` against each of ``templates``, in one compiled call.

    ``each``: the sum over features of each feature's own distance (DTW_I in Shokoohi-Yekta et al.
    2017: every feature warped on its own), instead of one warping of all features together (DTW_D).
    """
    if not len(templates):
        return np.empty(0)
    a, bank, starts = _bank(a, templates)
    out = np.empty(len(templates))
    _kernel("_many")(a, bank, starts, float(fraction), bool(each), out)
    return out


def dtw_prefix_many(
    a: Any, templates: Sequence[np.ndarray], fraction: float = 0.2, *, each: bool = False
) -> np.ndarray:
    """:func:`dtw_prefix` of ``a`` against each of ``templates``: rows of (cost, share of the template
    matched, 0..1); ``each`` as :func:`dtw_many`'s (the share is then the features' median)."""
    if not len(templates):
        return np.empty((0, 2))
    a, bank, starts = _bank(a, templates)
    out = np.empty((len(templates), 2))
    _kernel("_prefix_many")(a, bank, starts, float(fraction), bool(each), out)
    return out


class Spring:
    """Matches of templates anywhere in a stream, frame by frame (:func:`_spring`): :meth:`push` gives,
    for each template, the cost of the best match ending at this frame and the step it started at."""

    def __init__(self, templates: Sequence[np.ndarray]):
        if not len(templates):
            raise ValueError("no templates")
        self.bank = np.ascontiguousarray(np.concatenate([_frames(t, "a template") for t in templates]))
        self.starts = np.cumsum([0, *(len(t) for t in templates)]).astype(np.int64)
        self.out = np.empty((len(templates), 2))
        self.reset()

    def reset(self) -> None:
        self.step = 0
        self.d = np.full(len(self.bank) + len(self.starts) - 1, np.inf)
        self.d[self.starts[:-1] + np.arange(len(self.starts) - 1)] = 0.0
        self.s = np.zeros(len(self.d))

    def push(self, x: np.ndarray) -> np.ndarray:
        """One feature frame (D,): rows (cost, start step) per template."""
        _kernel("_spring")(
            np.ascontiguousarray(x, dtype=float), self.bank, self.starts, self.step, self.d, self.s, self.out
        )
        self.step += 1
        return self.out


def warm() -> None:
    """Compile (or load from numba's cache) every kernel now, not at its first use: a patch calls this
    before its clock starts, so that the first gesture's early check holds no timer up."""
    a = np.zeros((3, 2))
    dtw_many(a, [a])
    dtw_prefix_many(a, [a])
    dtw_distance(a, a)
    dtw_prefix(a, a)
    Spring([a]).push(a[0])
