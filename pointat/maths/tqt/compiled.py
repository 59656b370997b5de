r""":class:`~pointat.maths.tqt.TQTBank`'s robust update compiled by numba: one loop over the sensors.

Not a second copy of the filter: :func:`robust_bank` runs :func:`pointat.maths.tqt.step.robust_step`
itself, the very source :class:`~pointat.maths.tqt.TQTFilter` runs, compiled with its helpers by
:func:`pointat.jit.compile_module` (which is why the loop lives in :mod:`pointat.maths.tqt.step` and not
here).  In paper mode a bank loops over its sensors in Python (the same step, a few microseconds each).

The kernel is compiled at the first bank of a process (a few seconds; the machine code is cached in the
user's cache folder, :mod:`pointat.jit`).  Nothing imports this module (and numba, a quarter of a
second and ~50 MB) until a bank is built.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from pointat import jit
from pointat.maths.tqt import step

__all__ = ["compiled", "robust_bank"]

_compiled: Callable[..., Any] | None = None


def compiled() -> bool:
    """Whether :func:`robust_bank` has run (numba compiled it, or loaded it from its cache), so that
    its next call costs only the update."""
    return _compiled is not None and bool(getattr(_compiled, "signatures", True))


def robust_bank(*args: Any) -> None:
    """:func:`pointat.maths.tqt.step.robust_bank`, compiled on the first call."""
    global _compiled
    if _compiled is None:
        _compiled = jit.compile_module(step).robust_bank
    _compiled(*args)
