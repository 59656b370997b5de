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
``vector``  ``tuple`` of floats (a 3-vector, a          (no equivalent: one value,
            quaternion, a 3x3 matrix row major...)       not spread across inlets)
any other   ``tuple`` of arguments: a *method* message   ``anything`` (``set 3``,
            such as ``recalibrate`` or ``k 0.5``         ``stop``)
==========  ===========================================  ==========================

>>> m = make(0.5, time=1.25)
>>> m.kind, m.value, m.time
('float', 0.5, 1.25)
>>> make([1, 2, "a"]).kind
'list'
>>> v = make(np.array([0.0, 0.0, 1.0]))
>>> v.kind, v.value
('vector', (0.0, 0.0, 1.0))
>>> method("recalibrate").kind
'recalibrate'
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

__all__ = [
    "KINDS",
    "Message",
    "as_float",
    "as_floats",
    "as_vector",
    "bang",
    "floats",
    "make",
    "method",
    "vector",
]

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

    def human(self, decimals: int = 1) -> str:
        """The message as a person reads it (``print``): numbers to ``decimals`` places, no Pd type words.

        >>> make((12.3456, -0.04, 7)).human()
        '12.3 0.0 7'
        >>> make("mag_disturbed").human(), make(None).human(), method("ready", 2019.19).human()
        ('mag_disturbed', 'bang', 'ready 2019.2')
        """
        v = self.value
        if self.kind == "bang":
            return "bang"
        if self.kind == "vector":
            return " ".join(_rounded(float(x), decimals) for x in np.ravel(v))
        if self.kind == "list" or self.is_method:
            words = [_rounded(x, decimals) for x in v]
            return " ".join([self.kind, *words] if self.is_method else words)
        return _rounded(v, decimals)


#: ``tuple.__new__``: builds a message without the NamedTuple constructor's extra Python call (per sample,
#: every node builds one or more).
_new = tuple.__new__


def _rounded(x: Any, decimals: int) -> str:
    """A number to ``decimals`` places (never ``-0.0``); anything else as it is."""
    if isinstance(x, (float, np.floating)):
        if x != x or x in (math.inf, -math.inf):
            return str(float(x))
        text = f"{float(x):.{decimals}f}"
        return text[1:] if text.startswith("-") and float(text) == 0.0 else text
    return str(x)


def _atom(x: Any) -> str:
    """A number as ``print`` shows it: 6 significant digits, below 1e-9 as 0, and ``nan`` as itself.

    >>> " ".join(_atom(x) for x in (0.1 + 0.2, -3e-12, float("nan"), float("-inf"), "x"))
    '0.3 0 nan -inf x'
    """
    if isinstance(x, float):
        return f"{0.0 if abs(x) < 1e-9 else x:.6g}"
    return str(x)


def bang(time: float = 0.0) -> Message:
    """A bang."""
    return _new(Message, ("bang", None, time))


def vector(values: Any, time: float = 0.0) -> Message:
    """A vector message: the numbers as one flat tuple of floats (a matrix row major).

    A tuple cannot be changed, so nobody downstream can alter what another node received, and the
    per-sample math (:mod:`pointat.maths.scalar`) reads it without building an array.  Arrays and nested
    lists are flattened: a 3x3 matrix becomes its nine numbers, row by row.

    >>> vector(np.eye(2), 0.5)
    Message(kind='vector', value=(1.0, 0.0, 0.0, 1.0), time=0.5)
    """
    if type(values) is np.ndarray:
        return _new(Message, ("vector", tuple(values.ravel().tolist()), time))
    try:
        return _new(Message, ("vector", tuple(map(float, values)), time))
    except TypeError:  # nested (a matrix as rows) or not numbers at all
        return _new(Message, ("vector", tuple(np.ravel(np.asarray(values, dtype=float)).tolist()), time))


def floats(values: tuple[float, ...], time: float = 0.0) -> Message:
    """A vector message from a tuple that holds floats already (what float arithmetic returns).

    :func:`vector` without the conversion, for nodes that build a vector on every sample from the
    results of :mod:`pointat.maths.scalar`; anything else goes through :func:`vector`.

    >>> floats((0.5, 1.5), 2.0)
    Message(kind='vector', value=(0.5, 1.5), time=2.0)
    """
    return _new(Message, ("vector", values, time))


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
    if type(value) is float:  # the per-sample case first
        return _new(Message, ("float", value, time))
    if isinstance(value, Message):
        return value
    if value is None:
        return _new(Message, ("bang", None, time))
    if isinstance(value, float):
        return _new(Message, ("float", value, time))
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
    raise TypeError(f"expected a number, got {msg.describe()!r}")


def as_floats(msg: Message, *sizes: int) -> tuple[float, ...]:
    """The numbers a vector or list message carries, as a tuple of floats of one of the allowed ``sizes``.

    The per-sample accessor: a vector's tuple is returned as it is.  Raises ``TypeError`` saying what was
    expected and what came.

    >>> as_floats(make([1, 2, 3]), 3)
    (1.0, 2.0, 3.0)
    >>> as_floats(vector([1.0, 2.0]), 3, 4)
    Traceback (most recent call last):
    ...
    TypeError: expected a vector of 3 or 4 numbers, got 2
    """
    kind = msg.kind
    if kind == "vector":
        v = msg.value
    elif kind == "list":
        try:
            v = tuple(map(float, msg.value))
        except (TypeError, ValueError):
            raise TypeError(f"expected numbers, got {msg.describe()!r}") from None
    else:
        raise TypeError(f"expected a vector, got {kind} {msg.describe()[:40]!r}")
    if sizes and len(v) not in sizes:
        want = " or ".join(str(s) for s in sizes)
        raise TypeError(f"expected a vector of {want} numbers, got {len(v)}")
    return v


def as_vector(msg: Message, *sizes: int) -> np.ndarray:
    """The numbers a vector or list message carries, as a new float array of one of the allowed ``sizes``.

    For nodes that compute with numpy; per-sample nodes use :func:`as_floats`.  Raises ``TypeError``
    saying what was expected and what came.
    """
    return np.array(as_floats(msg, *sizes), dtype=float)
