"""Gesture-mapping nodes: map (range and curve), smooth (exp, 1€, slerp), threshold, deadband.

The table stakes of gesture-mapping tools (Glover, libmapper, OSCulator; Max's ``scale`` and ``slide``,
Pd's ``threshold~``).  The math is in :mod:`pointat.maths.smoothing`; these nodes move messages.

Every node works on a number, and element-wise on a list or a vector, and answers in the kind it was
given (a float for a number or an int, a list for a list, a vector of the same shape for a vector).
Parameters a performer tunes on stage are live: send ``time 50`` or ``high 0.7`` to the left inlet, or
set them from outside by name.  Parameters are checked together when the patch loads (``pointat check``
reports an empty range or ``low >= high``); a live change that would break a node is refused with an
error in the log and the old value stays.  A bad message (NaN, a symbol, a list of the wrong size) is an
error for that message only: it is logged and dropped, the node's state is untouched, and no NaN is ever
output.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from pointat.maths.smoothing import (
    CURVES,
    Deadband,
    ExpSmoother,
    OneEuroFilter,
    QuatSmoother,
    RangeMap,
    Schmitt,
)
from pointat.message import Message, as_float, as_vector, floats, make, vector
from pointat.node import REQUIRED, SKIP, Inlet, Node, Outlet, Param
from pointat.registry import register

NUMBERS = ("float", "int", "list", "vector")


def _numbers(msg: Message) -> float | np.ndarray:
    """The finite numbers a message carries: a float for a number, a float array (shape kept) for a
    list or a vector."""
    kind = msg.kind
    if kind in ("float", "int"):
        x = float(msg.value)
        if not math.isfinite(x):
            raise ValueError("NaN or infinite value")
        return x
    if kind not in ("list", "vector"):
        raise TypeError(f"expected a number, a list or a vector, got {kind} {msg.describe()[:40]!r}")
    a = np.asarray(as_vector(msg), dtype=float)
    if a.size == 0:
        raise TypeError("expected numbers, got an empty list")
    if not np.all(np.isfinite(a)):
        raise ValueError("NaN or infinite value")
    return a


def _like(msg: Message, a: float | np.ndarray) -> Message:
    """``a`` as a message of the kind of ``msg`` (number -> float, list -> list, vector -> vector)."""
    if msg.kind in ("float", "int"):
        return make(float(a), msg.time)
    if msg.kind == "list":
        return make(tuple(float(v) for v in np.ravel(a)), msg.time)
    return vector(a, msg.time)


def _pair(method: str, args: tuple) -> tuple[Any, Any]:
    if len(args) != 2:
        raise TypeError(f"'{method}' takes two numbers, got {len(args)}")
    return args[0], args[1]


# ----------------------------------------------------------------------------------------- map
#: An azimuth behind the listener mirrored to the front (``map`` and ``midi_out``'s ``fold``).
FOLD = Param(
    "fold",
    "bool",
    False,
    "the input is an azimuth (deg): mirror one behind the listener to the front (135 -> 45)",
    live=True,
)


@register("map")
class Map(Node):
    r"""Scale a range onto another, through a curve: the mapping every gesture tool starts with.

    u = (x - in_lo) / (in_hi - in_lo), clipped to 0..1 when ``clip``, turned into 1 - u when ``invert``,
    then out = out_lo + (out_hi - out_lo) * f(u) with the curve f:

    * ``linear``: f(u) = u (Max's ``scale``);
    * ``exp``:    f(u) = (e^(c u) - 1) / (e^c - 1), c = ``curvature`` (SuperCollider's ``lincurve``):
      c > 0 starts slowly (fine control at the bottom, for loudness or pitch), c < 0 starts fast;
    * ``log``:    f(u) = ln(1 + u (e^c - 1)) / c, the exact inverse of ``exp`` with the same c (c > 0
      starts fast): it undoes an ``exp`` mapping made elsewhere;
    * ``pow``:    f(u) = u^gamma (Max's ``scale`` exponent): gamma > 1 starts slowly, < 1 fast.

    Either range may run downwards (``map 90 -90 0 127``).  ``invert`` reads the input range backwards,
    the same as swapping in_lo and in_hi; the curve keeps its shape on the output side.  Without ``clip``
    an input beyond the range extrapolates along the straight line (curves shape only the inside).
    An empty range (in_lo = in_hi or out_lo = out_hi) is an error when the patch loads.

    ``fold=true`` reads the input as an azimuth in degrees and first mirrors one behind the listener to
    the front half, as a stereo pan hears it: 135 (behind left) maps as 45, 180 as 0.  Turning round
    then pans smoothly back to the centre; without it a pan map jumps from one side to the other where
    the azimuth crosses 180.

    Numbers give floats; lists and vectors are mapped element by element.  ``input LO HI`` and
    ``output LO HI`` set both ends of a range at once (flipping a range one end at a time would pass
    through an empty one, which is refused).
    """

    pure = True

    inlets = (Inlet("in", NUMBERS, "a number, list or vector to map"),)
    outlets = (Outlet("out", "any", "the mapped value, the same kind as the input"),)
    params = (
        Param("in_lo", "float", 0.0, "input value that maps to out_lo", live=True),
        Param("in_hi", "float", 1.0, "input value that maps to out_hi", live=True),
        Param("out_lo", "float", 0.0, "output at in_lo", live=True),
        Param("out_hi", "float", 1.0, "output at in_hi", live=True),
        Param("curve", "symbol", "linear", "shape of the mapping (see above)", choices=CURVES, live=True),
        Param(
            "curvature",
            "float",
            4.0,
            "c of exp and log, -100..100: exp starts slowly for c > 0, fast for c < 0",
            live=True,
        ),
        Param("gamma", "float", 2.0, "exponent of pow (> 0): > 1 starts slowly, < 1 fast", live=True),
        Param("clip", "bool", False, "keep the output within out_lo..out_hi", live=True),
        Param("invert", "bool", False, "read the input range backwards (in_hi maps to out_lo)", live=True),
        FOLD,
    )
    example = """
# azimuth (+ left) to a pan value (0 left, 127 right); behind the listener folded to the front
node dir  azi_ele
node pan  map 90 -90 0 127 fold=true
node show print prefix=pan
dir.azimuth -> pan -> show
"""

    @staticmethod
    def _range_map(values: Mapping[str, Any]) -> RangeMap:
        return RangeMap(
            values["in_lo"],
            values["in_hi"],
            values["out_lo"],
            values["out_hi"],
            curve=values["curve"],
            curvature=values["curvature"],
            gamma=values["gamma"],
            clip=values["clip"],
            invert=values["invert"],
            fold=values["fold"],
        )

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        cls._range_map(values)

    def setup(self) -> None:
        self._map = self._range_map(vars(self.p))

    def param_changed(self, name: str) -> None:
        self._map = self._range_map(vars(self.p))

    def on_in(self, msg: Message) -> None:
        if msg.kind == "float":  # one number, per sample
            self.out(0, make(self._map.number(msg.value), msg.time))
        else:
            self.out(0, _like(msg, self._map(_numbers(msg))))

    def do_input(self, *args: Any) -> None:
        lo, hi = _pair("input", args)
        self.set_params(in_lo=lo, in_hi=hi)

    def do_output(self, *args: Any) -> None:
        lo, hi = _pair("output", args)
        self.set_params(out_lo=lo, out_hi=hi)


# ----------------------------------------------------------------------------------------- smooth
SMOOTH_MODES = ("exp", "euro", "slerp")


@register("smooth")
class Smooth(Node):
    """Smooth a stream of numbers, vectors or quaternions, at any sample rate.

    The time between samples comes from the messages' time stamps (sensor time), so the same settings
    behave the same at 100 Hz and at 1 kHz.  The first sample passes through; ``reset`` starts over.

    * ``mode=exp``: one-pole exponential smoothing with the time constant ``time`` (ms): after a step
      the output has covered 63 % of the way in ``time``, 95 % in three times ``time``;
      y += (1 - exp(-dt / time)) (x - y).
    * ``mode=euro``: the 1€ filter (Casiez, Roussel & Vogel, "1€ Filter: A Simple Speed-based Low-pass
      Filter for Noisy Input in Interactive Systems", CHI 2012, doi:10.1145/2207676.2208639), exactly as
      the paper: a low-pass whose cutoff is ``min_cutoff + beta * |speed|``, the speed low-passed at
      ``d_cutoff``.  Smooth at rest, quick when moving.  Tune with beta = 0: lower ``min_cutoff`` until
      the jitter at rest is gone; then raise ``beta`` until fast gestures stop lagging.  Defaults are the
      paper's (1 Hz, 0, 1 Hz).
    * ``mode=slerp``: quaternions (w x y z): each sample pulls the orientation toward the new one by
      slerp, with the same time constant law as ``exp``; the short way round (sign-aligned), unit, and
      the output's sign never jumps.

    ``wrap=true`` (exp and euro) treats the values as angles in degrees, such as azimuth: the filter
    takes the short way across ±180 (179 then -179 is a 2 degree move, not 358) and outputs in
    [-180, 180).  Numbers, lists and vectors are smoothed element by element.
    """

    pure = True

    inlets = (Inlet("in", NUMBERS, "a number, list or vector (a quaternion w x y z for slerp)"),)
    outlets = (Outlet("out", "any", "the smoothed value, the same kind as the input"),)
    params = (
        Param("mode", "symbol", "exp", "exp, euro (1€ filter) or slerp (quaternions)", choices=SMOOTH_MODES),
        Param(
            "time",
            "float",
            100.0,
            "exp and slerp: time constant (63 % of a step); 0 = no smoothing",
            unit="ms",
            live=True,
        ),
        Param(
            "min_cutoff",
            "float",
            1.0,
            "euro: cutoff at rest; lower removes more jitter",
            unit="Hz",
            live=True,
        ),
        Param(
            "beta",
            "float",
            0.0,
            "euro: cutoff rise per unit of speed; higher lags less when moving",
            unit="Hz per unit/s",
            live=True,
        ),
        Param("d_cutoff", "float", 1.0, "euro: cutoff of the speed estimate", unit="Hz", live=True),
        Param("wrap", "bool", False, "exp and euro: values are angles in degrees, output in [-180, 180)"),
        Param(
            "rate",
            "float",
            100.0,
            "nominal sample rate, for a message stamped no later than the previous one",
            unit="Hz",
        ),
    )
    example = """
# a calm azimuth for the spatialiser: still when the hand rests, quick when it sweeps
node dir   azi_ele
node calm  smooth euro min_cutoff=0.5 beta=0.02 wrap=true
node show  print prefix=azimuth
dir.azimuth -> calm -> show
"""

    @staticmethod
    def _make_filter(values: Mapping[str, Any]) -> ExpSmoother | OneEuroFilter | QuatSmoother:
        mode = values["mode"]
        if mode == "euro":
            return OneEuroFilter(
                values["min_cutoff"], values["beta"], values["d_cutoff"], wrap=values["wrap"]
            )
        tau = float(values["time"])
        if not (math.isfinite(tau) and tau >= 0.0):  # the filters check it too, with their own names
            raise ValueError(f"time must be >= 0 ms, got {tau:g}")
        if mode == "slerp":
            if values["wrap"]:
                raise ValueError("wrap applies to exp and euro (angles as numbers), not to slerp")
            return QuatSmoother(tau / 1000.0)
        return ExpSmoother(tau / 1000.0, wrap=values["wrap"])

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        cls._make_filter(values)
        # every parameter is checked, also those the mode does not use, so a later mode change is safe
        OneEuroFilter(values["min_cutoff"], values["beta"], values["d_cutoff"])
        ExpSmoother(float(values["time"]) / 1000.0)
        if not 0.0 < float(values["rate"]) < math.inf:
            raise ValueError(f"rate must be > 0 Hz, got {values['rate']!r}")

    def setup(self) -> None:
        self._filter = self._make_filter(vars(self.p))
        self._last_t: float | None = None

    def param_changed(self, name: str) -> None:
        f = self._filter
        if name in ("mode", "wrap"):  # only before the patch runs: start over with the new filter
            self.setup()
        elif isinstance(f, OneEuroFilter):
            f.min_cutoff, f.beta, f.d_cutoff = self.p.min_cutoff, self.p.beta, self.p.d_cutoff
        else:
            f.tau = self.p.time / 1000.0

    def on_in(self, msg: Message) -> None:
        last = self._last_t
        dt = msg.time - last if last is not None and msg.time > last else 1.0 / self.p.rate
        f = self._filter
        if isinstance(f, QuatSmoother) and msg.kind == "vector":  # per sample: floats in, floats out
            y = floats(f.step(msg.value, dt), msg.time)
        else:
            y = _like(msg, f.update(_numbers(msg), dt))
        self._last_t = msg.time
        self.out(0, y)

    def do_reset(self) -> None:
        self._filter.reset()
        self._last_t = None


# ----------------------------------------------------------------------------------------- threshold
@register("threshold")
class Threshold(Node):
    """A Schmitt trigger: turn a continuous gesture into events that fire a note or a cue.

    A bang leaves the left outlet when the input rises to ``high`` and the middle outlet when it falls
    back to ``low`` (as Pd's ``threshold~`` and Max's ``togedge``); the right outlet says the new state,
    1 or 0, just before (for ``sel 1 0``, a gate, or a note's velocity).  Between the thresholds nothing
    happens, so a noisy signal hovering around one of them cannot flicker: make high - low larger than
    the noise.  It starts low: a first value at or above ``high`` fires at once.

    ``set HIGH LOW`` moves both thresholds at once (one at a time could briefly put low above high,
    which is refused); ``state 0|1`` sets the state without output; ``reset`` sets it low.
    """

    pure = True

    inlets = (Inlet("in", ("float", "int", "list"), "the value to watch"),)
    outlets = (
        Outlet("rise", "bang", "when the input reaches high"),
        Outlet("fall", "bang", "when the input comes back down to low"),
        Outlet("state", "int", "1 on rising, 0 on falling (output before the bang)"),
    )
    params = (
        Param("high", "float", 0.6, "rising threshold: state 1 at or above it", live=True),
        Param("low", "float", 0.4, "falling threshold: state 0 at or below it; below high", live=True),
    )
    example = """
# raise the hand above 45 degrees to fire a cue; lower it under 30 to re-arm
node dir   azi_ele
node raise threshold 45 30
node cue   print prefix=cue
node rearm print prefix=re-armed
dir.elevation -> raise
raise.rise -> cue
raise.fall -> rearm
"""

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        Schmitt(values["high"], values["low"])

    def setup(self) -> None:
        self._trigger = Schmitt(self.p.high, self.p.low)

    def param_changed(self, name: str) -> None:
        self._trigger.set_thresholds(self.p.high, self.p.low)

    def on_in(self, msg: Message) -> None:
        edge = self._trigger.update(as_float(msg))
        if edge > 0:
            self.emit(None, SKIP, 1)
        elif edge < 0:
            self.emit(SKIP, None, 0)

    def do_set(self, *args: Any) -> None:
        high, low = _pair("set", args)
        self.set_params(high=high, low=low)

    def do_state(self, value: Any = 0) -> None:
        if isinstance(value, str) or value not in (0, 1):
            raise TypeError(f"'state' takes 0 or 1, got {value!r}")
        self._trigger.state = bool(value)

    def do_reset(self) -> None:
        self._trigger.state = False


# ----------------------------------------------------------------------------------------- deadband
@register("deadband")
class DeadbandNode(Node):
    """Let a value through only when it moved more than ``width`` from the last value let through.

    Holds a reading still until the hand really moves, and saves the receiver from a flood of tiny
    updates.  The first value always passes; ``reset`` lets the next one through.  For lists and
    vectors the largest element-wise move counts.  ``wrap=true`` treats the values as angles in
    degrees: 179.5 to -179.8 is a move of 0.7, not 359.3.  The value passes unchanged (same kind,
    same time stamp).
    """

    pure = True

    inlets = (Inlet("in", NUMBERS, "a number, list or vector"),)
    outlets = (Outlet("out", "any", "the value, when it moved more than width"),)
    params = (
        Param("width", "float", REQUIRED, "how far a value must move to pass (>= 0), in its unit", live=True),
        Param("wrap", "bool", False, "values are angles in degrees (the short way across ±180)"),
    )
    example = """
# send the azimuth on only when it moved more than half a degree
node dir  azi_ele
node hold deadband 0.5 wrap=true
node show print prefix=azimuth
dir.azimuth -> hold -> show
"""

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        Deadband(values["width"])

    def setup(self) -> None:
        self._band = Deadband(self.p.width, wrap=self.p.wrap)

    def param_changed(self, name: str) -> None:
        if name == "wrap":  # only before the patch runs
            self._band = Deadband(self.p.width, wrap=self.p.wrap)
        self._band.width = self.p.width

    def on_in(self, msg: Message) -> None:
        if self._band.update(_numbers(msg)):
            self.out(0, msg)

    def do_reset(self) -> None:
        self._band.reset()
