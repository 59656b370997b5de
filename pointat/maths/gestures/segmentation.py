"""Rest and motion: how much the hand moves (:class:`Energy`) and where a movement begins and ends
(:class:`Segmenter`)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from pointat.maths.gestures.features import channel_slices

#: Energy (rad/s for ``gyr`` and ``q``; m/s² of acceleration off its slow mean for ``acc``; the field's
#: direction in rad/s for ``mag``) above which a movement starts before any example sets the level:
#: 1 rad/s is a brisk turn of the wrist, 3 m/s² a brisk jolt; the slow turns of pointing stay under.
DEFAULT_ON = {"gyr": 1.0, "q": 1.0, "acc": 3.0, "mag": 1.0, "x": 1.0}


class Energy:
    """How much the hand moves, frame by frame, from the model's channels: ``|gyro|`` (rad/s) when
    there is a gyro, else the rate of turn of ``q`` or of the field's direction, else the acceleration
    off its slow mean (a 0.3 s low-pass; m/s²), else the features' rate of change."""

    TAU = 0.3

    def __init__(self, channels: Sequence[str], size: int = 0) -> None:
        sl = channel_slices(channels, size)
        self.kind = next(k for k in ("gyr", "q", "acc", "mag", "x") if k in sl)
        self.slice = sl[self.kind]
        self.reset()

    def reset(self) -> None:
        self._last: np.ndarray | None = None
        self._t = 0.0

    def __call__(self, t: float, frame: np.ndarray) -> float:
        v = frame[self.slice]
        if self.kind == "gyr":
            return float(math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]))
        last, dt = self._last, t - self._t
        self._t = t
        if self.kind == "acc":
            if last is None or not 0.0 < dt < 1.0:
                self._last = v.copy()
                return 0.0
            last += (v - last) * (1.0 - math.exp(-dt / self.TAU))
            return float(np.linalg.norm(v - last))
        if self.kind in ("q", "mag"):
            v = v / max(float(np.linalg.norm(v)), 1e-12)
        self._last = v.copy()
        if last is None or not 0.0 < dt < 1.0:
            return 0.0
        if self.kind == "q":
            return 2.0 * math.acos(min(1.0, abs(float(v @ last)))) / dt
        if self.kind == "mag":
            return math.acos(max(-1.0, min(1.0, float(v @ last)))) / dt
        return float(np.linalg.norm(v - last)) / dt


class Segmenter:
    """Rest and motion, with hysteresis: a movement starts when the energy reaches ``on``, and ends when
    it has stayed under ``off`` for ``settle`` seconds.  It begins where the energy last rose past
    ``off`` (at most ``preroll`` s earlier), and ends at its last frame over ``off``.

    :meth:`push` returns ``None``, ``"start"``, ``"end"`` (a movement of ``shortest`` to ``longest``
    s has ended: :attr:`span` holds its first and last frame times) or ``"drop"`` (too short, or still
    going after ``longest``: no gesture; a movement that goes on is only taken again after rest).
    """

    def __init__(
        self,
        on: float,
        off: float,
        settle: float = 0.1,
        shortest: float = 0.15,
        longest: float = 4.0,
        preroll: float = 0.3,
    ) -> None:
        if not 0.0 <= off <= on:
            raise ValueError(f"off ({off}) must be within 0..on ({on})")
        self.on, self.off, self.settle = on, off, settle
        self.shortest, self.longest, self.preroll = shortest, longest, preroll
        self.reset()

    def reset(self) -> None:
        self.moving = False
        self.spoilt = False  # a movement too long: wait for rest
        self.span = (0.0, 0.0)
        self._rise = math.nan  # when the energy last rose past off
        self._last_over = math.nan  # the last frame over off
        self.began = math.nan

    def push(self, t: float, energy: float) -> str | None:
        over = energy > self.off
        if over and not self._last_over >= self._rise:  # (a NaN rise too)
            self._rise = t
        if over:
            self._last_over = t
        if not over:
            self._rise = math.nan
        if self.spoilt:
            if not over and t - self._last_over >= self.settle:
                self.spoilt = False
            return None
        if not self.moving:
            if energy >= self.on:
                rise = self._rise if self._rise == self._rise else t
                self.began = max(rise, t - self.preroll)
                self.moving = True
                return "start"
            return None
        if t - self.began > self.longest:
            self.moving, self.spoilt = False, True
            return "drop"
        if not over and t - self._last_over >= self.settle:
            self.moving = False
            self.span = (self.began, self._last_over)
            return "end" if self._last_over - self.began >= self.shortest else "drop"
        return None
