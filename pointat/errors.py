"""One error hierarchy for everything a user can get wrong, each error naming its place."""

from __future__ import annotations

import difflib
import math
import time
from collections.abc import Hashable, Iterable
from dataclasses import dataclass

__all__ = [
    "FeedbackError",
    "PatchError",
    "PointatError",
    "Problem",
    "Where",
    "closest",
    "did_you_mean",
    "worth_reporting",
]


@dataclass(frozen=True)
class Where:
    """A place in a patch file: ``file:line`` (and the box index for Pd files)."""

    file: str
    line: int = 0
    box: int | None = None

    def __str__(self) -> str:
        s = f"{self.file}:{self.line}" if self.line else self.file
        return s if self.box is None else f"{s} (box {self.box})"


@dataclass(frozen=True)
class Problem:
    """One finding of the loader or checker."""

    where: Where | None
    message: str
    severity: str = "error"  # or "warning"

    def __str__(self) -> str:
        place = f"{self.where}: " if self.where else ""
        return f"{place}{self.severity}: {self.message}"


class PointatError(Exception):
    """Base of every error pointat raises on purpose."""


class PatchError(PointatError):
    """A patch could not be loaded; ``problems`` lists every error found, all at once."""

    def __init__(self, problems: list[Problem] | Problem | str, where: Where | None = None):
        if isinstance(problems, str):
            problems = [Problem(where, problems)]
        elif isinstance(problems, Problem):
            problems = [problems]
        self.problems = list(problems)
        super().__init__("\n".join(str(p) for p in self.problems))


class FeedbackError(PointatError):
    """Messages went round a loop deeper than the depth guard allows (a feedback loop without a delay)."""


def worth_reporting(n: int, first: int = 3) -> bool:
    """Whether the ``n``-th repeat of a run-time problem should be logged: the ``first`` few, then the
    10th, 100th, 1000th... so a receiver that is off for a whole show, or a noisy link, stays readable.

    >>> [n for n in range(1, 2001) if worth_reporting(n)]
    [1, 2, 3, 10, 100, 1000]
    >>> [n for n in range(1, 2001) if worth_reporting(n, first=1)]
    [1, 10, 100, 1000]
    """
    return 1 <= n <= first or (n >= 10 and 10 ** (len(str(n)) - 1) == n)


class Repeats:
    """Counts a run-time problem by its kind and says whether to log this one: the 1st, 2nd, 3rd, 10th,
    100th... of its kind (:func:`worth_reporting`) and, with ``quiet``, any that comes ``quiet`` seconds
    or more after the last of its kind (a person trying a command again, not a flood).  Past ``kinds``
    different kinds, a new one counts under the ``fallback`` kind given with it, so that a flood of
    made-up ones stays a few lines and a few entries.

    >>> r = Repeats(kinds=2)
    >>> [r.add(k) for k in ("a", "a", "b", "c", "d")]
    [(1, True), (2, True), (1, True), (1, True), (2, True)]
    """

    def __init__(self, kinds: int, quiet: float | None = None) -> None:
        self.kinds, self.quiet = kinds, quiet
        self.counts: dict[Hashable, int] = {}
        self._last: dict[Hashable, float] = {}  # monotonic time of the last one, by kind (with quiet)

    def add(self, kind: Hashable, fallback: Hashable = None) -> tuple[int, bool]:
        """Count one of ``kind``: how many of its kind so far, this one included, and whether to log it."""
        if kind not in self.counts and len(self.counts) >= self.kinds:
            kind = fallback
        n = self.counts[kind] = self.counts.get(kind, 0) + 1
        tell = worth_reporting(n)
        if self.quiet is not None:
            now = time.monotonic()
            tell = tell or now - self._last.get(kind, -math.inf) >= self.quiet
            self._last[kind] = now
        return n, tell


def shorten(text: str, most: int = 80) -> str:
    """``text``, its middle left out when it is longer than ``most`` (a name of 300 characters in a
    message).

    >>> shorten("x" * 100, 10)
    'xxxxx…xxxxx'
    """
    return text if len(text) <= most else f"{text[: most // 2]}…{text[-most // 2 :]}"


def closest(name: str, names: Iterable[str]) -> str | None:
    """The one of ``names`` closest to a misspelt ``name``, or ``None`` when none is close."""
    close = difflib.get_close_matches(name, list(names), n=1)
    return close[0] if close else None


def did_you_mean(name: str, names: Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` for the closest of ``names``, or nothing: the tail of an error message.

    >>> did_you_mean("k_headng", ["k", "k_heading"]), did_you_mean("zzz", ["k"])
    (" (did you mean 'k_heading'?)", '')
    """
    hint = closest(name, names)
    return f" (did you mean '{hint}'?)" if hint else ""
