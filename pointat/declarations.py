r"""What a node type declares: its parameters (:class:`Param`), inlets (:class:`Inlet`), outlets
(:class:`Outlet`) and readings (:class:`Reading`), and its parameter values as a node holds them
(:class:`Params`).  The node model that reads these declarations is :mod:`pointat.node`, which exports
every name here too (``from pointat.node import Inlet, Node, Param``)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from .patchfile import parse_value

__all__ = [
    "PARAM_TYPES",
    "REQUIRED",
    "ROLES",
    "Inlet",
    "Outlet",
    "Param",
    "ParamError",
    "Params",
    "Reading",
]

#: Default of a parameter that must be given.
REQUIRED: Any = type("Required", (), {"__repr__": lambda self: "REQUIRED"})()
PARAM_TYPES = ("float", "int", "bool", "symbol", "path", "list", "vector")


def _shown(value: Any, most: int = 60) -> str:
    """``repr(value)``, its middle left out when it is long (a 300-digit number, a pasted paragraph).

    >>> _shown(10**100)
    '1000000000000000000000000…0000000000000000000000000 (101 characters)'
    """
    text = repr(value)
    if len(text) <= most:
        return text
    half = (most - 10) // 2
    return f"{text[:half]}…{text[-half:]} ({len(text)} characters)"


class ParamError(ValueError):
    """A parameter value does not fit its declaration; the loader adds the place.

    ``partial``: from :meth:`Node.resolve_params`, the values that did fit, defaults for the others (what
    the loader checks the node's ranges and wires with, so that one run finds every problem).
    """

    def __init__(self, message: str, partial: dict[str, Any] | None = None):
        super().__init__(message)
        self.partial = partial


@dataclass(frozen=True)
class Param:
    """A node parameter: its type, default, unit and documentation.

    ``type`` is one of ``float``, ``int``, ``bool``, ``symbol``, ``path``, ``list`` (numbers and symbols)
    and ``vector`` (numbers, ``size`` of them when given).  ``choices`` restricts a symbol.  ``variadic``
    collects every remaining positional creation argument (``trigger b b f``).  ``live`` parameters can be
    set while the patch runs (by a message to the node, or from outside by name).  ``reads`` marks a
    ``path`` the node reads when it starts: ``pointat check`` warns when nothing is there, and reads it
    when it is (:meth:`Node.check_files`), unless it is ``optional`` (a file the node starts without,
    such as examples still to be taught: read when there, never missed); ``writes`` marks one it writes:
    ``check`` refuses a folder, or a file in a folder that does not exist.  A ``float``
    is a finite number, or NaN where NaN is the default (its "none", such as a dip still to learn);
    ``minimum``, ``above`` and ``maximum`` bound a number (``pointat help`` shows them, ``check`` and live
    changes refuse a value outside).
    """

    name: str
    type: str
    default: Any = REQUIRED
    doc: str = ""
    unit: str = ""
    live: bool = False
    choices: tuple[str, ...] = ()
    variadic: bool = False
    size: int | None = None
    reads: bool = False
    writes: bool = False
    optional: bool = False
    #: Bounds of a number: ``minimum`` it may equal, ``above`` it must exceed, ``maximum`` it may equal
    #: (``None``: unbounded).
    minimum: float | None = None
    above: float | None = None
    maximum: float | None = None

    def coerce(self, value: Any) -> Any:
        """The value converted to the declared type, within its bounds; :class:`ParamError` says expected
        and got."""
        number = self._coerce(value)
        if self.type in ("float", "int") and not (isinstance(number, float) and math.isnan(number)):
            if (
                (self.minimum is not None and number < self.minimum)
                or (self.above is not None and number <= self.above)
                or (self.maximum is not None and number > self.maximum)
            ):
                kind = "a whole number" if self.type == "int" else "a number"
                raise ParamError(
                    f"parameter '{self.name}' expects {kind} {self._range()}; got {_shown(value)}"
                )
        return number

    def _range(self) -> str:
        """``> x``, ``>= x``, ``<= y`` or ``x..y`` for a bounded number, else nothing."""

        def num(x: float) -> str:  # 2147483647 as it is, not 2.14748e+09
            return str(int(x)) if float(x).is_integer() and abs(x) < 1e15 else f"{x:g}"

        if self.above is not None:
            low = f"> {num(self.above)}"
        else:
            low = f">= {num(self.minimum)}" if self.minimum is not None else ""
        if self.maximum is None:
            return low
        if low.startswith(">="):
            return f"{num(self.minimum)}..{num(self.maximum)}"
        return f"{low} and <= {num(self.maximum)}" if low else f"<= {num(self.maximum)}"

    def _coerce(self, value: Any) -> Any:
        t = self.type
        try:
            if t == "float":
                if isinstance(value, bool) or not isinstance(value, (int, float, np.number, str)):
                    raise TypeError
                number = float(value)
                if not math.isfinite(number) and not (math.isnan(number) and self._nan_default):
                    # NaN and infinity mean nothing as a setting, but where NaN is the default's "none"
                    raise ParamError(f"parameter '{self.name}' expects a finite number; got {_shown(value)}")
                return number
            if t == "int":
                if isinstance(value, float) and value.is_integer():
                    return int(value)
                if isinstance(value, bool) or not isinstance(value, (int, np.integer, str)):
                    raise TypeError
                return int(value)
            if t == "bool":
                if isinstance(value, str):
                    low = value.lower()
                    if low in ("true", "yes", "on", "1"):
                        return True
                    if low in ("false", "no", "off", "0"):
                        return False
                    raise ValueError
                if isinstance(value, (bool, int, float)) and value in (0, 1):
                    return bool(value)
                raise TypeError
            if t in ("symbol", "path"):
                if isinstance(value, (list, tuple, np.ndarray)):
                    raise TypeError
                s = str(value) if not isinstance(value, float) else repr(value)
                if self.choices and s not in self.choices:
                    raise ParamError(
                        f"parameter '{self.name}' expects one of {', '.join(self.choices)}; got {_shown(s)}"
                    )
                return s
            if t == "list":
                items = value if isinstance(value, (list, tuple)) else _atoms(value)
                return tuple(items)
            if t == "vector":
                items = value if isinstance(value, (list, tuple, np.ndarray)) else _atoms(value)
                arr = np.array([float(x) for x in items], dtype=float)
                if self.size is not None and arr.size != self.size:
                    raise ParamError(
                        f"parameter '{self.name}' expects a vector of {self.size} numbers; got {arr.size}"
                    )
                return tuple(arr.tolist())
        except ParamError:
            raise
        except (TypeError, ValueError):
            pass
        expected = {"float": "a number", "int": "a whole number", "bool": "true or false"}.get(t, f"a {t}")
        raise ParamError(f"parameter '{self.name}' expects {expected}; got {_shown(value)}")

    @property
    def _nan_default(self) -> bool:
        return isinstance(self.default, float) and math.isnan(self.default)

    def describe_type(self) -> str:
        if self.choices:
            return "|".join(self.choices)
        if self.type == "vector" and self.size:
            return f"vector[{self.size}]"
        if self._range():
            return f"{self.type} {self._range()}"
        return self.type + ("..." if self.variadic else "")


def _atoms(value: Any) -> list[Any]:
    """A single value given where a list is expected: its atoms, as Pd reads a message (``--set
    moves.relative="acc q"`` is two, like ``[acc q]``; a word with a space in it is kept whole inside
    brackets, ``["two words"]``).

    >>> _atoms("acc q"), _atoms("1 2.5"), _atoms(3), _atoms("one"), _atoms('"two words" x')
    (['acc', 'q'], [1, 2.5], [3], ['one'], ['two words', 'x'])
    """
    if isinstance(value, str) and len(value.split()) > 1:
        return parse_value(f"[{value}]")  # (the patch's own list syntax: quotes and brackets kept whole)
    return [value]


@dataclass(frozen=True)
class Inlet:
    """An inlet: name, accepted message kinds (``any`` for all), doc; hot when leftmost unless said."""

    name: str
    accepts: tuple[str, ...] = ("any",)
    doc: str = ""
    hot: bool | None = None
    param: str | None = None

    def is_hot(self, index: int) -> bool:
        """Whether a message here computes and outputs, this being inlet ``index`` of its node."""
        return self.hot if self.hot is not None else index == 0


@dataclass(frozen=True)
class Outlet:
    """An outlet: name, the kind of message it sends (``any`` when it varies), doc."""

    name: str
    kind: str = "any"
    doc: str = ""


@dataclass(frozen=True)
class Reading:
    """A value a node lets people read while it runs, given by :meth:`Node.read`: the monitor shows it,
    OSCQuery serves it read-only at ``/pointat/NODE/NAME``.

    ``units``: one per number (their count is the reading's size; ``deg``, ``Hz``... or ``""``);
    ``minimum`` and ``maximum``: the range of every number, when it has one.  ``direction=True`` says
    the three numbers are where the node points, azimuth (degrees, + left), elevation (degrees, + up) and
    distance (0 far .. 90 near): the console writes them and the monitor draws them as a pointer.
    """

    name: str
    doc: str = ""
    units: tuple[str, ...] = ("",)
    minimum: float | None = None
    maximum: float | None = None
    direction: bool = False

    @property
    def size(self) -> int:
        """How many numbers it is."""
        return len(self.units)


#: A node's roles (:attr:`Node.role`).
ROLES = ("input", "output", "process")


class Params:
    """A node's parameter values as attributes (``node.p.rate``), what :func:`vars` gives as a dict.

    A plain class rather than :class:`types.SimpleNamespace`: nodes read their parameters on every sample,
    and an attribute of a Python class's instance is read in 8 ns against 23 (CPython 3.11).
    """

    def __init__(self, values: Mapping[str, Any]):
        self.__dict__.update(values)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Params) and vars(self) == vars(other)

    __hash__ = None  # type: ignore[assignment]  # (mutable, as SimpleNamespace)

    def __repr__(self) -> str:
        return "Params(" + ", ".join(f"{k}={v!r}" for k, v in vars(self).items()) + ")"
