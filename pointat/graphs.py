"""Small graph walks the engine and the checker share (nothing else of pointat here)."""

from __future__ import annotations

from collections.abc import Callable, Hashable, Iterable
from typing import TypeVar

__all__ = ["reached"]

T = TypeVar("T", bound=Hashable)


def reached(start: Iterable[T], step: Callable[[T], Iterable[T]]) -> set[T]:
    """Every item reachable from ``start`` (included) by ``step``, iteratively (no recursion: a chain of
    thousands of nodes is fine).

    >>> sorted(reached([1], lambda n: [n + 1] if n < 4 else []))
    [1, 2, 3, 4]
    """
    seen = set(start)
    stack = list(seen)
    while stack:
        for nxt in step(stack.pop()):
            if nxt not in seen:
                seen.add(nxt)
                stack.append(nxt)
    return seen
