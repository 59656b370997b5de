r"""The robust step compiled by numba: :class:`~pointat.maths.tqt.TQTFilter`'s update and
:class:`~pointat.maths.tqt.TQTBank`'s loop over the sensors.

Not a second copy of the filter: :func:`robust_update`, :func:`robust_bank` and
:func:`~pointat.maths.tqt.step.robust_batch` (a bank over a block of samples, :func:`batch_kernel`) run
:func:`pointat.maths.tqt.step.robust_step` itself, the very source the plain Python form runs, compiled
with its helpers by :func:`pointat.jit.compile_module` (which is why the entries live in
:mod:`pointat.maths.tqt.step` and not here).  A filter or a bank in robust mode takes this path (one call
from Python a sample, the state a float64 array the compiled code changes in place); in paper mode, or
told ``backend="python"``, they run the same step in Python (several microseconds a sample).

Compiled without numba's reference counting (``_nrt=False``): the step allocates nothing, and the
counts numba keeps of the arrays it hands from one helper to the next (atomic, a few tens of them a
sample) cost a third of the step.  :func:`robust_update` is compiled for one signature, floats in, and
no other (a Python ``int`` is converted, never compiled for), so that no new type stalls a live patch.

The code is compiled at the first filter or bank of a process (seconds; the machine code is cached in
the user's cache folder, :mod:`pointat.jit`).  Nothing imports this module (and numba, a quarter of a
second and ~50 MB) until a robust filter or a bank is built.
"""

from __future__ import annotations

import types
from collections.abc import Callable
from typing import Any

from pointat import jit
from pointat.maths.tqt import step

__all__ = ["bank_kernel", "batch_kernel", "compiled", "robust_bank", "robust_update", "update_kernel"]

#: numba's options for the step (see the module head).
OPTIONS = {"_nrt": False}
#: :func:`robust_update`'s one signature: the state and parameter vectors, then ten floats.
_UPDATE_SIGNATURE = "Tuple((int64, float64, float64, float64, float64))(float64[::1], float64[::1]" + (
    ", float64" * 10 + ")"
)

_space: types.SimpleNamespace | None = None


def _kernels() -> types.SimpleNamespace:
    global _space
    if _space is None:
        space = jit.compile_module(step, options=OPTIONS)
        update = space.robust_update
        if not update.signatures:
            update.compile(_UPDATE_SIGNATURE)
        update.disable_compile()  # (ints and other numbers are converted to the one signature)
        _space = space
    return _space


def compiled() -> bool:
    """Whether :func:`robust_bank` has run (numba compiled it, or loaded it from its cache), so that
    its next call costs only the update."""
    return _space is not None and bool(_space.robust_bank.signatures)


def update_kernel() -> Callable[..., Any]:
    """:func:`pointat.maths.tqt.step.robust_update` compiled (at the first call of a process, or loaded
    from the cache): what a :class:`~pointat.maths.tqt.TQTFilter` holds and calls a sample."""
    return _kernels().robust_update  # type: ignore[no-any-return]


def bank_kernel() -> Callable[..., Any]:
    """:func:`pointat.maths.tqt.step.robust_bank` compiled (typed at its first call): what a
    :class:`~pointat.maths.tqt.TQTBank` holds and calls an update."""
    return _kernels().robust_bank  # type: ignore[no-any-return]


def batch_kernel() -> Callable[..., Any]:
    """:func:`pointat.maths.tqt.step.robust_batch` compiled (typed at its first call): what
    :meth:`~pointat.maths.tqt.TQTBank.update_batch` calls once for a block of samples."""
    return _kernels().robust_batch  # type: ignore[no-any-return]


def robust_update(*args: Any) -> tuple[int, float, float, float, float]:
    """:func:`pointat.maths.tqt.step.robust_update`, compiled on the first call."""
    return update_kernel()(*args)  # type: ignore[no-any-return]


def robust_bank(*args: Any) -> None:
    """:func:`pointat.maths.tqt.step.robust_bank`, compiled on the first call."""
    bank_kernel()(*args)
