"""Argument types the commands share: a finite number of seconds (``--for``, ``--status``) or of
milliseconds (``--spin``), with argparse's message when the text is not one."""

from __future__ import annotations

import argparse
import math


def _number(text: str, unit: str, maximum: float = math.inf) -> float:
    """A finite number of ``unit`` from 0 to ``maximum`` (argparse's message when not)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of {unit}, got {text!r}") from None
    if not (math.isfinite(value) and 0.0 <= value <= maximum):
        span = ">= 0" if maximum == math.inf else f"from 0 to {maximum:g}"
        raise argparse.ArgumentTypeError(f"expected a finite number of {unit} {span}, got {text!r}")
    return value


def seconds(text: str) -> float:
    """``--for``: a finite number of seconds, 0 or more."""
    return _number(text, "seconds")


def milliseconds(text: str) -> float:
    """``--spin``: a finite number of milliseconds, 0 to 1000."""
    return _number(text, "milliseconds", 1000.0)
