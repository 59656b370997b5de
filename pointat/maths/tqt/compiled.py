r"""The robust step compiled by numba: :class:`~pointat.maths.tqt.TQTFilter`'s update and
:class:`~pointat.maths.tqt.TQTBank`'s loop over the sensors.

Not a second copy of the filter: :func:`robust_update` and :func:`robust_bank` run
:func:`pointat.maths.tqt.step.robust_step` itself, the very source the plain Python form runs, compiled
with its helpers.  When numba is installed a filter or a bank in robust mode takes this path (one call
from Python a sample, the state a float64 array the compiled code changes in place); without it, or in
paper mode, they run the same step in Python (several microseconds a sample).

Compiled without numba's reference counting (``_nrt=False``): the step allocates nothing, and the
counts numba keeps of the arrays it hands from one helper to the next (atomic, a few tens of them a
sample) cost a third of the step.  :func:`robust_update` has one signature, floats in (a Python ``int``
is converted, never compiled for), so that no new type stalls a live patch to compile.

The code is compiled at the first filter or bank of a process (seconds; numba caches the machine code
in the user's cache folder (:mod:`pointat.maths.numba_cache`), keyed by the source file of the step,
:mod:`pointat.maths.tqt.step`, which is why the loops live there and not here).  Nothing imports this
module (and numba, a quarter of a second and ~50 MB) until a robust filter or a bank is built.
"""

from __future__ import annotations

import types
from collections.abc import Callable
from typing import Any

from pointat.maths.numba_cache import user_cache
from pointat.maths.tqt import step

__all__ = ["available", "bank_kernel", "compiled", "robust_bank", "robust_update", "update_kernel"]

try:  # an optional dependency: the Python loop is used without it
    from numba import njit
except ImportError:  # pragma: no cover - depends on the environment
    njit = None

#: :func:`robust_update`'s one signature: the state and parameter vectors, then ten floats.
_UPDATE_SIGNATURE = (
    "Tuple((int64, float64, float64, float64, float64))(float64[::1], float64[::1]" + (", float64" * 10) + ")"
)


def available() -> bool:
    """Whether numba is installed, so that :func:`robust_bank` and :func:`robust_update` are compiled."""
    return njit is not None


def _compile() -> dict[str, Any] | None:
    """numba functions call only numba functions: every function of :mod:`pointat.maths.tqt.step` is
    compiled into a namespace of its own (the module keeps its Python functions for the plain forms);
    :func:`~pointat.maths.tqt.step.robust_bank` and :func:`~pointat.maths.tqt.step.robust_update` are
    the entries."""
    if njit is None:
        return None
    import numba

    jit = njit(cache=True, nogil=True, _nrt=False)
    space = dict(vars(step))
    with user_cache(numba):
        for name, value in vars(step).items():
            if isinstance(value, types.FunctionType) and value.__module__ == step.__name__:
                fn = types.FunctionType(value.__code__, space, name, value.__defaults__)
                if name == "robust_update":
                    update = njit(_UPDATE_SIGNATURE, cache=True, nogil=True, _nrt=False)(fn)
                    update.disable_compile()  # (ints are converted to the one signature)
                    space[name] = update
                else:
                    space[name] = jit(fn)
    return space


_space: dict[str, Any] | None = None


def _kernels() -> dict[str, Any]:
    global _space
    if _space is None:
        _space = _compile()
        if _space is None:
            raise RuntimeError('numba is not installed: pip install "pointat[fast]"')
    return _space


def compiled() -> bool:
    """Whether :func:`robust_bank` has run (numba compiled it, or loaded it from its cache), so that
    its next call costs only the update."""
    return _space is not None and bool(_space["robust_bank"].signatures)


def update_kernel() -> Callable[..., Any]:
    """:func:`pointat.maths.tqt.step.robust_update` compiled (at the first call of a process, or loaded
    from numba's cache): what a :class:`~pointat.maths.tqt.TQTFilter` holds and calls a sample."""
    return _kernels()["robust_update"]  # type: ignore[no-any-return]


def bank_kernel() -> Callable[..., Any]:
    """:func:`pointat.maths.tqt.step.robust_bank` compiled (typed at its first call): what a
    :class:`~pointat.maths.tqt.TQTBank` holds and calls an update."""
    return _kernels()["robust_bank"]  # type: ignore[no-any-return]


def robust_update(*args: Any) -> tuple[int, float, float, float, float]:
    """:func:`pointat.maths.tqt.step.robust_update`, compiled on the first call (numba must be
    installed: see :func:`available`)."""
    return update_kernel()(*args)  # type: ignore[no-any-return]


def robust_bank(*args: Any) -> None:
    """:func:`pointat.maths.tqt.step.robust_bank`, compiled on the first call (numba must be installed:
    see :func:`available`)."""
    bank_kernel()(*args)
