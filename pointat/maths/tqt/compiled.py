r""":class:`~pointat.maths.tqt.TQTBank`'s robust update compiled by numba: one loop over the sensors.

Not a second copy of the filter: :func:`robust_bank` runs :func:`pointat.maths.tqt.step.robust_step`
itself, the very source :class:`~pointat.maths.tqt.TQTFilter` runs, compiled with its helpers.  When numba
is installed (``pip install "pointat[fast]"``) a bank takes this path; without it, or in paper mode, the
bank loops over its sensors in Python (the same step, a few microseconds each).

The kernel is compiled at the first bank of a process (a few seconds; numba caches the machine code in
the user's cache folder (:mod:`pointat.maths.numba_cache`), keyed by the source file of the step,
:mod:`pointat.maths.tqt.step`, which is why the loop lives there and not here).  Nothing imports this
module (and numba, a quarter of a second and ~50 MB) until a bank is built.
"""

from __future__ import annotations

import types
from collections.abc import Callable
from typing import Any

from pointat.maths.numba_cache import user_cache
from pointat.maths.tqt import step

__all__ = ["available", "compiled", "robust_bank"]

try:  # an optional dependency: the Python loop is used without it
    from numba import njit
except ImportError:  # pragma: no cover - depends on the environment
    njit = None


def available() -> bool:
    """Whether numba is installed, so that :func:`robust_bank` is compiled."""
    return njit is not None


def _compile() -> Callable[..., Any] | None:
    """numba functions call only numba functions: every function of :mod:`pointat.maths.tqt.step` is
    compiled into a namespace of its own (the module keeps its Python functions for
    :class:`~pointat.maths.tqt.TQTFilter`); :func:`~pointat.maths.tqt.step.robust_bank` is the loop."""
    if njit is None:
        return None
    import numba

    jit = njit(cache=True, nogil=True)
    space = dict(vars(step))
    with user_cache(numba):
        for name, value in vars(step).items():
            if isinstance(value, types.FunctionType) and value.__module__ == step.__name__:
                space[name] = jit(types.FunctionType(value.__code__, space, name, value.__defaults__))
    return space["robust_bank"]  # type: ignore[no-any-return]


_compiled: Callable[..., Any] | None = None


def compiled() -> bool:
    """Whether :func:`robust_bank` has run (numba compiled it, or loaded it from its cache), so that
    its next call costs only the update."""
    return _compiled is not None and bool(getattr(_compiled, "signatures", True))


def robust_bank(*args: Any) -> None:
    """:func:`pointat.maths.tqt.step.robust_bank`, compiled on the first call (numba must be installed: see
    :func:`available`)."""
    global _compiled
    if _compiled is None:
        _compiled = _compile()
        if _compiled is None:
            raise RuntimeError('numba is not installed: pip install "pointat[fast]"')
    _compiled(*args)
