"""Messages: the small immutable values that travel along wires.

A message has a *kind* and a *value*, and carries the *time* it refers to (sensor time when the source
knows it, otherwise the scheduler's logical time), in seconds.

==========  ===========================================  ==========================
kind        value                                        Pd equivalent
==========  ===========================================  ==========================
``bang``    ``None``                                     ``bang``
``float``   ``float``                                    ``float``
``int``     ``int``                                      (a float in Pd)
``symbol``  ``str``                                      ``symbol``
``list``    ``tuple`` of floats, ints and strings         ``list``
``vector``  read-only ``numpy.ndarray`` (3-vector,       (no equivalent: one value,
            quaternion, 3x3 matrix...)                   not spread across inlets)
any other   ``tuple`` of arguments: a *method* message   ``anything`` (``set 3``,
            such as ``recalibrate`` or ``k 0.5``         ``stop``)
==========  ===========================================  ==========================

>>> m = make(0.5, time=1.25)
>>> m.kind, m.value, m.time
('float', 0.5, 1.25)
>>> make([1, 2, "a"]).kind
'list'
>>> v = make(np.array([0.0, 0.0, 1.0]))
>>> v.kind, v.value.flags.writeable
('vector', False)
>>> method("recalibrate").kind
'recalibrate'
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

__all__ = ["KINDS", "Message", "as_float", "as_vector", "bang", "make", "method", "vector"]

#: The kinds of plain data; any other kind is a method selector.
KINDS = frozenset({"bang", "float", "int", "symbol", "list", "vector"})


class Message(NamedTuple):
    """One value on a wire. Build it with :func:`make`, :func:`bang`, :func:`vector` or :func:`method`."""

    kind: str
    value: Any
    time: float = 0.0

    @property
    def is_method(self) -> bool:
        """True for a method message (``recalibrate``, ``k 0.5``), false for plain data."""
        return self.kind not in KINDS

    def describe(self) -> str:
        """A short, human-readable rendering for logs and ``print``."""
        v = self.value
        if self.kind == "bang":
            return "bang"
        if self.kind == "vector":
            return "vector " + " ".join(_atom(float(x)) for x in np.ravel(v))
        if self.kind == "list":  # as Pd prints it: "list" only before a symbol or nothing
            head = "list " if not v or isinstance(v[0], str) else ""
            return head + " ".join(_atom(x) for x in v)
        if self.is_method:
            return " ".join([self.kind, *(_atom(x) for x in v)])
        if self.kind == "symbol":  # as Pd prints it
            return f"symbol {v}"
        return _atom(v)


def _atom(x: Any) -> str:
    if isinstance(x, float):
        return f"{x if abs(x) >= 1e-9 else 0.0:.6g}"
    return str(x)


def bang(time: float = 0.0) -> Message:
    """A bang."""
    return Message("bang", None, time)


def vector(values: Any, time: float = 0.0, shape: tuple[int, ...] | None = None) -> Message:
    """A vector message; the array is copied and made read-only so that nobody downstream can change it.

    ``shape`` reshapes the copy (9 floats into a 3x3 matrix) without a second copy.
    """
    a = np.array(values, dtype=float)
    if shape is not None:
        a = a.reshape(shape)
    a.setflags(write=False)
    return Message("vector", a, time)


def method(selector: str, *args: Any, time: float = 0.0) -> Message:
    """A method message such as ``recalibrate`` or ``k 0.5``."""
    if selector in KINDS:
        raise ValueError(f"'{selector}' is a data kind, not a method selector")
    return Message(selector, tuple(args), time)


def make(value: Any, time: float = 0.0) -> Message:
    """Wrap a Python value in a message of the matching kind.

    ``None`` is a bang, ``bool`` and ``int`` are ints, ``float`` a float, ``str`` a symbol, a tuple or
    list of scalars a list, and a numpy array a vector.  A message is returned as it is.
    """
    if isinstance(value, Message):
        return value
    if value is None:
        return Message("bang", None, time)
    if isinstance(value, float):
        return Message("float", value, time)
    if isinstance(value, (bool, int, np.integer)):
        return Message("int", int(value), time)
    if isinstance(value, np.floating):
        return Message("float", float(value), time)
    if isinstance(value, str):
        return Message("symbol", value, time)
    if isinstance(value, np.ndarray):
        return vector(value, time)
    if isinstance(value, (tuple, list)):
        return Message("list", tuple(value), time)
    raise TypeError(f"cannot make a message of {type(value).__name__} {value!r}")


def as_float(msg: Message) -> float:
    """The number a message carries (a float, an int, or the first element of a list).

    Raises ``TypeError`` naming the kind that was received otherwise.
    """
    kind = msg.kind
    if kind == "float" or kind == "int":
        return float(msg.value)
    if kind == "list" and msg.value and isinstance(msg.value[0], (int, float)):
        return float(msg.value[0])
    raise TypeError(f"expected a number, got {kind} {msg.describe()!r}")


def as_vector(msg: Message, *sizes: int) -> np.ndarray:
    """The numbers a vector or list message carries, as a float array of one of the allowed ``sizes``.

    Raises ``TypeError`` saying what was expected and what came.
    """
    if msg.kind == "vector":
        a = msg.value
    elif msg.kind == "list":
        try:
            a = np.array(msg.value, dtype=float)
        except (TypeError, ValueError):
            raise TypeError(f"expected numbers, got {msg.describe()!r}") from None
    else:
        raise TypeError(f"expected a vector, got {msg.kind} {msg.describe()[:40]!r}")
    if sizes and a.size not in sizes:
        want = " or ".join(str(s) for s in sizes)
        raise TypeError(f"expected a vector of {want} numbers, got {a.size}")
    return a
