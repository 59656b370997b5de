r"""Gesture mapping: range scaling with curves, smoothing filters, a Schmitt trigger and a deadband.

The table stakes of every gesture-mapping tool (Glover, libmapper, OSCulator, Max's ``scale`` and
``slide``, Pd's ``threshold~``) as plain functions and small stateful classes on floats and numpy
arrays.  Nothing here imports the engine; the nodes in :mod:`pointat.nodes.mapping` are thin wrappers.

Conventions
-----------
* Values are numbers or arrays of any shape; filters work **element-wise** and keep the shape of the
  first sample they see (a different shape later is an error until ``reset``).  A number in gives a
  Python float out, computed with plain floats (a few microseconds, not numpy's tens).
* Time steps ``dt`` are seconds (``> 0``), time constants are given in seconds here (the nodes take
  milliseconds), cutoff frequencies in Hz.
* Angles (``wrap=True``) are degrees; a wrap-aware filter takes the short way across ±180° and outputs
  in ``[-180, 180)`` (:func:`pointat.maths.quaternion.wrap_degrees`).
* Quaternions are scalar first ``(w, x, y, z)``, as everywhere in :mod:`pointat.maths`.
* Filters raise ``ValueError`` for a non-finite sample and leave their state as it was: no NaN ever
  comes out.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from pointat.maths.quaternion import unwrap_degrees, wrap_degrees
from pointat.maths.scalar import fold_front

__all__ = [
    "CURVES",
    "MAX_CURVATURE",
    "Deadband",
    "ExpSmoother",
    "OneEuroFilter",
    "QuatSmoother",
    "RangeMap",
    "Schmitt",
    "apply_curve",
    "cutoff_alpha",
    "exp_alpha",
]

#: The curve shapes of :func:`apply_curve` and :class:`RangeMap`.
CURVES = ("linear", "exp", "log", "pow")

#: Largest ``|curvature|`` of the ``exp`` and ``log`` curves (beyond it the curve is a step anyway, and
#: :math:`e^c` heads for overflow).
MAX_CURVATURE = 100.0

#: Below this ``|curvature|`` the ``exp`` and ``log`` curves are the straight line (their limit).
_FLAT = 1e-9


def _finite(x: ArrayLike, what: str = "value") -> np.ndarray:
    """``x`` as a float array; ``ValueError`` if any element is NaN or infinite."""
    a = np.asarray(x, dtype=float)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{what} has NaN or infinite elements: {np.ravel(a)[:8].tolist()}")
    return a


Value = float | np.ndarray
"""A single number (a Python float: the fast path) or an array of any shape."""


def _value(x: ArrayLike, what: str) -> Value:
    """A finite float for a single number, a finite float array (a copy) otherwise."""
    if isinstance(x, (float, int, np.floating, np.integer)) and not isinstance(x, bool):
        v = float(x)
        if not math.isfinite(v):
            raise ValueError(f"{what} is NaN or infinite: {v!r}")
        return v
    a = np.array(x, dtype=float)
    if a.ndim == 0:
        return _value(float(a), what)
    return _finite(a, what)


def _shape(v: Value) -> tuple[int, ...]:
    return () if isinstance(v, float) else v.shape


def _all_finite(v: Value) -> bool:
    return math.isfinite(v) if isinstance(v, float) else bool(np.all(np.isfinite(v)))


def _copy(v: Value) -> Value:
    return v if isinstance(v, float) else v.copy()


def _check_number(name: str, value: float, *, low: float | None = None, strict: bool = True) -> float:
    """``value`` as a finite float, above ``low`` (strictly or not); ``ValueError`` says what is wrong."""
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    if low is not None and (v <= low if strict else v < low):
        raise ValueError(f"{name} must be {'>' if strict else '>='} {low:g}, got {v:g}")
    return v


def _check_dt(dt: float) -> float:
    dt = float(dt)
    if not (dt > 0.0 and math.isfinite(dt)):
        raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
    return dt


# --------------------------------------------------------------------------------- range mapping
def apply_curve(u: ArrayLike, curve: str = "linear", *, curvature: float = 4.0, gamma: float = 2.0) -> Value:
    r"""Shape a normalised value: :math:`f : [0, 1] \to [0, 1]` with :math:`f(0) = 0`, :math:`f(1) = 1`.

    ==========  ===========================================================  ======================
    curve       :math:`f(u)` on :math:`[0, 1]`                               after
    ==========  ===========================================================  ======================
    ``linear``  :math:`u`                                                    Max ``scale``
    ``exp``     :math:`\dfrac{e^{c u} - 1}{e^{c} - 1}`                       SuperCollider
                                                                             ``lincurve``
    ``log``     :math:`\dfrac{\ln\!\big(1 + u\,(e^{c} - 1)\big)}{c}`,        (inverse of ``exp``)
                the inverse of ``exp`` with the same :math:`c`
    ``pow``     :math:`u^{\gamma}`                                           Max ``scale`` exponent,
                                                                             display gamma
    ==========  ===========================================================  ======================

    ``exp`` with curvature :math:`c > 0` starts slowly (fine control near the bottom of the range, as a
    fader for loudness or frequency wants); :math:`c < 0` starts fast; :math:`c \to 0` is the straight
    line.  ``log`` undoes ``exp`` exactly (``log(exp(u)) = u`` for the same :math:`c`), so
    :math:`c > 0` starts fast.  ``pow`` with :math:`\gamma > 1` starts slowly, :math:`\gamma < 1` fast.

    Outside :math:`[0, 1]` every curve continues as the straight line :math:`f(u) = u` (continuous at
    both ends because :math:`f(0) = 0` and :math:`f(1) = 1`): overshoot past the input range extrapolates
    linearly and never blows up or turns into NaN.

    Parameters
    ----------
    u : array_like
        Normalised input, 0 at the bottom of the input range and 1 at the top.
    curve : {"linear", "exp", "log", "pow"}
        Shape.
    curvature : float
        :math:`c` of ``exp`` and ``log``; ``|c| <=`` :data:`MAX_CURVATURE`.
    gamma : float
        :math:`\gamma > 0` of ``pow``.

    Returns
    -------
    float for a number, numpy.ndarray of the shape of ``u`` otherwise

    >>> apply_curve([0.0, 0.5, 1.0], "exp", curvature=4.0).round(6).tolist()
    [0.0, 0.119203, 1.0]
    >>> round(apply_curve(apply_curve(0.3, "exp", curvature=4.0), "log", curvature=4.0), 12)
    0.3
    >>> apply_curve([-0.5, 0.5, 1.5], "pow", gamma=2.0).tolist()
    [-0.5, 0.25, 1.5]
    """
    if curve not in CURVES:
        raise ValueError(f"curve must be one of {', '.join(CURVES)}; got {curve!r}")
    if isinstance(u, (float, int)) and not isinstance(u, bool):  # one number: plain floats, fast
        u = float(u)
        if curve == "linear" or not 0.0 <= u <= 1.0:
            return u
        if curve == "pow":
            return u ** float(gamma)
        c = float(curvature)
        if abs(c) < _FLAT:
            return u
        if curve == "exp":
            return math.expm1(c * u) / math.expm1(c)
        return math.log1p(u * math.expm1(c)) / c
    u = np.asarray(u, dtype=float)
    if curve == "linear":
        return u
    inside = (u >= 0.0) & (u <= 1.0)
    v = np.clip(u, 0.0, 1.0)
    if curve == "exp" or curve == "log":
        c = float(curvature)
        if abs(c) < _FLAT:
            return u
        if curve == "exp":
            shaped = np.expm1(c * v) / math.expm1(c)
        else:
            shaped = np.log1p(v * math.expm1(c)) / c
    else:
        shaped = v ** float(gamma)
    return np.where(inside, shaped, u)[()]


@dataclass(frozen=True)
class RangeMap:
    r"""Scale ``in_lo..in_hi`` to ``out_lo..out_hi`` through a curve, optionally clipped and inverted.

    .. math::
        x \leftarrow \mathrm{fold}(x) \ \text{(fold)}, \qquad
        u = \frac{x - x_{lo}}{x_{hi} - x_{lo}}, \qquad
        u \leftarrow \min(\max(u, 0), 1) \ \text{(clip)}, \qquad
        u \leftarrow 1 - u \ \text{(invert)}, \qquad
        y = y_{lo} + (y_{hi} - y_{lo})\, f(u)

    with :math:`f` from :func:`apply_curve`.  ``fold`` reads the input as an azimuth in degrees and
    mirrors one behind the listener to the front half, as a stereo pan hears it
    (:func:`pointat.maths.scalar.fold_front`: 135 -> 45, 180 -> 0).  ``invert`` reads the input range backwards (the same as
    swapping ``in_lo`` and ``in_hi``); the curve keeps its shape on the output side.  Either range may
    run downwards (``in_lo > in_hi`` or ``out_lo > out_hi``).  The parameters are checked when the map is
    made: an empty range (``in_lo == in_hi`` or ``out_lo == out_hi``), a non-finite bound, an unknown
    curve, ``gamma <= 0`` or ``|curvature| >`` :data:`MAX_CURVATURE` raise ``ValueError``.

    >>> m = RangeMap(0.0, 127.0, -1.0, 1.0)
    >>> m(np.array([0.0, 63.5, 127.0])).tolist()
    [-1.0, 0.0, 1.0]
    >>> RangeMap(0.0, 1.0, 0.0, 100.0, clip=True, invert=True)(np.array([-1.0, 0.25, 2.0])).tolist()
    [100.0, 75.0, 0.0]
    >>> RangeMap(90.0, -90.0, 0.0, 127.0, fold=True)(np.array([0.0, 135.0, -170.0])).tolist()
    [63.5, 31.75, 70.55555555555556]
    >>> RangeMap(1.0, 1.0, 0.0, 1.0)
    Traceback (most recent call last):
    ...
    ValueError: the input range is empty: in_lo = in_hi = 1
    """

    in_lo: float
    in_hi: float
    out_lo: float
    out_hi: float
    curve: str = "linear"
    curvature: float = 4.0
    gamma: float = 2.0
    clip: bool = False
    invert: bool = False
    fold: bool = False

    def __post_init__(self) -> None:
        for name in ("in_lo", "in_hi", "out_lo", "out_hi", "curvature", "gamma"):
            object.__setattr__(self, name, _check_number(name, getattr(self, name)))
        if self.in_lo == self.in_hi:
            raise ValueError(f"the input range is empty: in_lo = in_hi = {self.in_lo:g}")
        if self.out_lo == self.out_hi:
            raise ValueError(
                f"the output range is empty: out_lo = out_hi = {self.out_lo:g} (every input would give it)"
            )
        if not math.isfinite(self.in_hi - self.in_lo) or not math.isfinite(self.out_hi - self.out_lo):
            raise ValueError("the ranges are too wide to compute with")
        if self.curve not in CURVES:
            raise ValueError(f"curve must be one of {', '.join(CURVES)}; got {self.curve!r}")
        if abs(self.curvature) > MAX_CURVATURE:
            raise ValueError(f"curvature must be within ±{MAX_CURVATURE:g}, got {self.curvature:g}")
        if self.gamma <= 0.0:
            raise ValueError(f"gamma must be > 0, got {self.gamma:g}")

    def __call__(self, x: ArrayLike) -> Value:
        """Map ``x``: a float for a number, an array of the same shape otherwise.

        Raises ``ValueError`` if ``x`` or the result is not finite.
        """
        x = _value(x, "input")
        if type(x) is float:  # one number: float arithmetic overflows to inf, never warns
            return self.number(x)
        with np.errstate(over="ignore", invalid="ignore"):
            y = self._map(x)
        if not _all_finite(y):
            raise ValueError(f"the mapped value is not finite (input {x!r} is too far out of range)")
        return y

    def number(self, x: float) -> float:
        """:meth:`__call__` for one float, with the same result and errors: the per-sample path of the
        ``map`` node (no type dispatch, no array).

        >>> RangeMap(0.0, 1000.0, 0.0, 100.0).number(250.0)
        25.0
        """
        if not math.isfinite(x):
            raise ValueError(f"input is NaN or infinite: {x!r}")
        y = self._map(x)
        if not math.isfinite(y):
            raise ValueError(f"the mapped value is not finite (input {x!r} is too far out of range)")
        return y

    def _map(self, x: Value) -> Value:
        if self.fold:
            if isinstance(x, float):
                x = fold_front(x)
            else:
                a = (x + 180.0) % 360.0 - 180.0
                x = np.where(a > 90.0, 180.0 - a, np.where(a < -90.0, -180.0 - a, a))
        u = (x - self.in_lo) / (self.in_hi - self.in_lo)
        if self.clip:
            u = min(max(u, 0.0), 1.0) if isinstance(u, float) else np.clip(u, 0.0, 1.0)
        if self.invert:
            u = 1.0 - u
        f = apply_curve(u, self.curve, curvature=self.curvature, gamma=self.gamma)
        return self.out_lo + (self.out_hi - self.out_lo) * f


# --------------------------------------------------------------------------------- smoothing factors
def exp_alpha(dt: float, tau: float) -> float:
    r"""Smoothing factor of a one-pole filter with time constant ``tau`` over a step ``dt``.

    .. math:: \alpha = 1 - e^{-\Delta t / \tau}

    This is the exact discretisation of :math:`\tau \dot y = x - y` with the input held over the step,
    so a chain of steps gives the same response whatever the sample rate: two steps of ``dt`` equal one
    of ``2 dt``, :math:`(1 - \alpha_{dt})^2 = 1 - \alpha_{2dt}`.  ``tau = 0`` gives 1 (no smoothing).

    Parameters
    ----------
    dt : float
        Time step, seconds (``>= 0``).
    tau : float
        Time constant, seconds (``>= 0``): a step input covers 63.2 % of the way in ``tau``.

    Returns
    -------
    float, in ``[0, 1]``

    >>> round(exp_alpha(0.1, 0.1), 6)
    0.632121
    >>> round((1 - exp_alpha(0.01, 0.2)) ** 2 - (1 - exp_alpha(0.02, 0.2)), 15)
    0.0
    """
    if tau <= 0.0:
        return 1.0
    return -math.expm1(-dt / tau)


def cutoff_alpha(dt: float, cutoff: float) -> float:
    r"""Smoothing factor of the 1€ filter's low-pass stage for a cutoff frequency (Casiez et al. 2012).

    .. math:: \alpha = \frac{1}{1 + \tau / T_e}, \qquad \tau = \frac{1}{2 \pi f_c}

    with :math:`T_e` the sampling period (here the measured step ``dt``).

    Parameters
    ----------
    dt : float
        Sampling period :math:`T_e`, seconds (``> 0``).
    cutoff : float
        Cutoff frequency :math:`f_c`, Hz (``> 0``; ``inf`` gives 1).

    Returns
    -------
    float, in ``(0, 1]``

    >>> round(cutoff_alpha(1 / 120, 1.0), 9)
    0.049754726
    """
    tau = 1.0 / (2.0 * math.pi * cutoff)
    return 1.0 / (1.0 + tau / dt)


# --------------------------------------------------------------------------------- filters
class _Stateful:
    """Shared state and shape bookkeeping of the element-wise filters."""

    def __init__(self, *, wrap: bool = False) -> None:
        self.wrap = bool(wrap)
        self._y: Value | None = None

    @property
    def value(self) -> Value | None:
        """The current output (a float, or a copy of the array), or ``None`` before the first sample."""
        return None if self._y is None else _copy(self._y)

    def reset(self) -> None:
        """Forget the state: the next sample passes through unchanged and sets the shape."""
        self._y = None

    def _sample(self, x: ArrayLike) -> Value:
        v = _value(x, "sample")
        if self._y is not None and _shape(v) != _shape(self._y):
            raise ValueError(
                f"sample of shape {_shape(v)} after samples of shape {_shape(self._y)}; reset to change shape"
            )
        return v

    def _store(self, y: ArrayLike) -> Value:
        """Wrap (for angles), keep as the state, and return a copy."""
        if self.wrap:
            y = wrap_degrees(y)
        self._y = float(y) if np.ndim(y) == 0 else np.asarray(y, dtype=float)
        return _copy(self._y)


class ExpSmoother(_Stateful):
    r"""One-pole exponential smoothing with a time constant, independent of the sample rate.

    .. math:: y_k = y_{k-1} + \alpha_k\,(x_k - y_{k-1}), \qquad \alpha_k = 1 - e^{-\Delta t_k / \tau}

    (:func:`exp_alpha`); :math:`y_0 = x_0`.  With ``wrap=True`` the values are angles in degrees:
    :math:`x_k` is first replaced by its representative nearest :math:`y_{k-1}`
    (:func:`~pointat.maths.quaternion.unwrap_degrees`), so the filter goes the short way across ±180°,
    and the output is wrapped into ``[-180, 180)``.  A number gives a float, an array an array of the
    same shape.

    Parameters
    ----------
    tau : float
        Time constant, seconds (``>= 0``; 0 passes the input through).
    wrap : bool
        Treat values as angles in degrees.

    >>> s = ExpSmoother(0.1, wrap=True)
    >>> s.update(179.0, 0.01), round(s.update(-179.0, 0.1), 6)
    (179.0, -179.735759)
    """

    def __init__(self, tau: float, *, wrap: bool = False) -> None:
        super().__init__(wrap=wrap)
        self.tau = tau

    @property
    def tau(self) -> float:
        """Time constant, seconds (settable; the state is kept)."""
        return self._tau

    @tau.setter
    def tau(self, value: float) -> None:
        self._tau = _check_number("tau", value, low=0.0, strict=False)

    def update(self, x: ArrayLike, dt: float) -> Value:
        """Filter one sample ``x`` taken ``dt`` seconds after the previous one; returns the output."""
        x = self._sample(x)
        dt = _check_dt(dt)
        prev = self._y
        if prev is None:
            return self._store(x)
        if self.wrap:
            x = unwrap_degrees(x, prev)
        return self._store(prev + exp_alpha(dt, self._tau) * (x - prev))


class OneEuroFilter(_Stateful):
    r"""The 1€ filter: a low-pass whose cutoff rises with speed (Casiez, Roussel & Vogel, CHI 2012).

    G. Casiez, N. Roussel and D. Vogel, "1€ Filter: A Simple Speed-based Low-pass Filter for Noisy Input
    in Interactive Systems", CHI 2012, pp. 2527-2530, doi:10.1145/2207676.2208639.  At each sample, with
    :math:`T_e` the measured period:

    .. math::
        \dot X_i &= (X_i - \hat X_{i-1}) / T_e \\
        \hat{\dot X}_i &= \hat{\dot X}_{i-1} + \alpha(T_e, d_{cutoff})\,(\dot X_i - \hat{\dot X}_{i-1}) \\
        f_c &= f_{c,min} + \beta\,|\hat{\dot X}_i| \\
        \hat X_i &= \hat X_{i-1} + \alpha(T_e, f_c)\,(X_i - \hat X_{i-1}) \\
        \alpha(T_e, f) &= \frac{1}{1 + \tau / T_e}, \quad \tau = \frac{1}{2\pi f}

    initialised with :math:`\hat X_1 = X_1` and :math:`\hat{\dot X}_1 = 0`.  The derivative is taken from
    the previous *filtered* value, as in the paper's pseudocode (and the authors' reference code since
    2023).  Defaults are the paper's: ``min_cutoff = 1`` Hz, ``beta = 0``, ``d_cutoff = 1`` Hz.
    Tuning, after the paper: with ``beta = 0`` lower ``min_cutoff`` until the jitter at rest is gone, then
    raise ``beta`` until fast movements no longer lag.

    Element-wise for arrays (each element has its own cutoff).  ``wrap=True`` treats values as angles in
    degrees: the sample is unwrapped next to :math:`\hat X_{i-1}` (so speed is measured the short way
    across ±180°) and the output is wrapped into ``[-180, 180)``.

    Parameters
    ----------
    min_cutoff : float
        :math:`f_{c,min}`, Hz (``> 0``).
    beta : float
        Speed coefficient :math:`\beta` (``>= 0``), Hz per (input unit / s).
    d_cutoff : float
        Cutoff of the derivative's low-pass, Hz (``> 0``).
    wrap : bool
        Treat values as angles in degrees.

    >>> f = OneEuroFilter(min_cutoff=1.0, beta=0.1)
    >>> [round(f.update(x, 1 / 120), 7) for x in (-0.0385099, -0.0280664, 0.048622)]
    [-0.0385099, -0.0379872, -0.0334426]
    """

    def __init__(
        self, min_cutoff: float = 1.0, beta: float = 0.0, d_cutoff: float = 1.0, *, wrap: bool = False
    ) -> None:
        super().__init__(wrap=wrap)
        self.min_cutoff = min_cutoff
        self.beta = beta
        self.d_cutoff = d_cutoff
        self._dx: Value = 0.0

    @property
    def min_cutoff(self) -> float:
        """Minimum cutoff frequency, Hz (settable; the state is kept)."""
        return self._min_cutoff

    @min_cutoff.setter
    def min_cutoff(self, value: float) -> None:
        self._min_cutoff = _check_number("min_cutoff", value, low=0.0)

    @property
    def beta(self) -> float:
        """Speed coefficient (settable; the state is kept)."""
        return self._beta

    @beta.setter
    def beta(self, value: float) -> None:
        self._beta = _check_number("beta", value, low=0.0, strict=False)

    @property
    def d_cutoff(self) -> float:
        """Cutoff frequency of the derivative's low-pass, Hz (settable; the state is kept)."""
        return self._d_cutoff

    @d_cutoff.setter
    def d_cutoff(self, value: float) -> None:
        self._d_cutoff = _check_number("d_cutoff", value, low=0.0)

    @property
    def speed(self) -> Value | None:
        r"""The filtered speed :math:`\hat{\dot X}` (input units per second), or ``None``."""
        return None if self._y is None else _copy(self._dx)

    def reset(self) -> None:
        super().reset()
        self._dx = 0.0

    def update(self, x: ArrayLike, dt: float) -> Value:
        """Filter one sample ``x`` taken ``dt`` seconds after the previous one; returns the output."""
        x = self._sample(x)
        dt = _check_dt(dt)
        prev = self._y
        if prev is None:
            self._dx = 0.0 if isinstance(x, float) else np.zeros_like(x)
            return self._store(x)
        if self.wrap:
            x = unwrap_degrees(x, prev)
        with np.errstate(over="ignore", invalid="ignore"):
            dx = (x - prev) / dt
            edx = self._dx + cutoff_alpha(dt, self._d_cutoff) * (dx - self._dx)
            fc = self._min_cutoff + self._beta * abs(edx)
            y = prev + (x - prev) / (1.0 + 1.0 / (2.0 * math.pi * fc * dt))
        if not (_all_finite(edx) and _all_finite(y)):
            raise ValueError("the filter would overflow (time step too small for this jump); sample dropped")
        self._dx = float(edx) if np.ndim(edx) == 0 else np.asarray(edx, dtype=float)
        return self._store(y)


class QuatSmoother:
    r"""Exponential smoothing of rotations: slerp toward each new quaternion by a time-constant factor.

    .. math:: q_k = \mathrm{slerp}\big(q_{k-1},\ s_k\,x_k,\ \alpha_k\big),
              \qquad \alpha_k = 1 - e^{-\Delta t_k / \tau}, \qquad
              s_k = \operatorname{sign}(q_{k-1} \cdot x_k)

    (:func:`exp_alpha`).  The new sample is sign-aligned with the state first, so the filter always
    turns the short way, and the output's sign is continuous: it never jumps between :math:`q` and
    :math:`-q` even when the input does.  The rotation angle to the target shrinks by
    :math:`e^{-\Delta t/\tau}` per step, the same law as :class:`ExpSmoother` on a number.  Slerp is
    Shoemake's form (equal to :func:`~pointat.maths.quaternion.quat_slerp`, cheaper for one pair):

    .. math:: \mathrm{slerp}(p, q, t) = \frac{\sin((1-t)\Omega)}{\sin\Omega}\,p
              + \frac{\sin(t\Omega)}{\sin\Omega}\,q, \qquad
              \Omega = 2\,\mathrm{atan2}(\lVert q - p \rVert, \lVert q + p \rVert)

    (the nlerp limit below :math:`\Omega = 10^{-6}`).  Inputs are normalised; the output is unit.

    Parameters
    ----------
    tau : float
        Time constant, seconds (``>= 0``; 0 passes the input through, normalised).

    >>> s = QuatSmoother(0.1)
    >>> s.update([1.0, 0.0, 0.0, 0.0], 0.01).tolist()
    [1.0, 0.0, 0.0, 0.0]
    >>> q = s.update([0.0, 0.0, 0.0, -1.0], 0.1)     # 180 deg about z, given with either sign
    >>> round(float(np.linalg.norm(q)), 12), round(float(np.degrees(2 * np.arccos(q[0]))), 6)
    (1.0, 113.781701)
    """

    def __init__(self, tau: float) -> None:
        self.tau = tau
        self._q: tuple[float, float, float, float] | None = None

    @property
    def tau(self) -> float:
        """Time constant, seconds (settable; the state is kept)."""
        return self._tau

    @tau.setter
    def tau(self, value: float) -> None:
        self._tau = _check_number("tau", value, low=0.0, strict=False)

    @property
    def value(self) -> np.ndarray | None:
        """The current output quaternion (a copy), or ``None`` before the first sample."""
        return None if self._q is None else np.array(self._q)

    def reset(self) -> None:
        """Forget the state: the next quaternion passes through (normalised)."""
        self._q = None

    def update(self, q: ArrayLike, dt: float) -> np.ndarray:
        """Filter one quaternion ``q`` (4 numbers) taken ``dt`` seconds after the previous one."""
        a = _finite(q, "quaternion")
        if a.shape != (4,):
            raise ValueError(f"a quaternion is 4 numbers (w, x, y, z), got shape {a.shape}")
        return np.array(self.step(a.tolist(), dt))

    def step(self, q: Sequence[float], dt: float) -> tuple[float, float, float, float]:
        """:meth:`update` on four plain floats, returning four: the per-sample path, without arrays."""
        if len(q) != 4:
            raise ValueError(f"a quaternion is 4 numbers (w, x, y, z), got {len(q)}")
        qw, qx, qy, qz = q
        if not math.isfinite(qw + qx + qy + qz):  # NaN or infinity anywhere makes the sum so
            raise ValueError(f"quaternion has NaN or infinite elements: {list(q)}")
        dt = _check_dt(dt)
        n = math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
        if n < 1e-9:
            raise ValueError("zero quaternion")
        qw, qx, qy, qz = qw / n, qx / n, qy / n, qz / n
        p = self._q
        if p is None:
            self._q = (qw, qx, qy, qz)
            return self._q
        pw, px, py, pz = p
        if pw * qw + px * qx + py * qy + pz * qz < 0.0:
            qw, qx, qy, qz = -qw, -qx, -qy, -qz
        t = exp_alpha(dt, self._tau)
        dw, dx, dy, dz = qw - pw, qx - px, qy - py, qz - pz
        sw, sx, sy, sz = qw + pw, qx + px, qy + py, qz + pz
        omega = 2.0 * math.atan2(
            math.sqrt(dw * dw + dx * dx + dy * dy + dz * dz), math.sqrt(sw * sw + sx * sx + sy * sy + sz * sz)
        )
        if omega < 1e-6:
            ow, ox, oy, oz = pw + t * dw, px + t * dx, py + t * dy, pz + t * dz
        else:
            a, b, s = math.sin((1.0 - t) * omega), math.sin(t * omega), math.sin(omega)
            ow, ox, oy, oz = (
                (a * pw + b * qw) / s,
                (a * px + b * qx) / s,
                (a * py + b * qy) / s,
                (a * pz + b * qz) / s,
            )
        n = math.sqrt(ow * ow + ox * ox + oy * oy + oz * oz)
        self._q = (ow / n, ox / n, oy / n, oz / n)
        return self._q


class Schmitt:
    r"""A Schmitt trigger: a two-state switch with hysteresis, for turning a gesture into an event.

    .. math::
        s_k = \begin{cases} 1 & x_k \ge h \\ 0 & x_k \le l \\ s_{k-1} & l < x_k < h \end{cases}
        \qquad (l < h)

    Between the thresholds the state holds, so noise smaller than :math:`h - l` around a threshold
    cannot make it flicker.  Starts low (or at ``state``).

    Parameters
    ----------
    high : float
        Rising threshold :math:`h`: the state goes to 1 when the input reaches it.
    low : float
        Falling threshold :math:`l < h`: the state goes to 0 when the input gets down to it.
    state : bool
        Initial state.

    >>> t = Schmitt(high=0.6, low=0.4)
    >>> [t.update(x) for x in (0.5, 0.61, 0.5, 0.59, 0.4, 0.45, 0.7)]
    [0, 1, 0, 0, -1, 0, 1]
    """

    def __init__(self, high: float, low: float, *, state: bool = False) -> None:
        self.set_thresholds(high, low)
        self.state = bool(state)

    def set_thresholds(self, high: float, low: float) -> None:
        """Set both thresholds; ``ValueError`` unless ``low < high`` (the state is kept)."""
        h = _check_number("high", high)
        lo = _check_number("low", low)
        if not lo < h:
            raise ValueError(f"low ({lo:g}) must be below high ({h:g}): no hysteresis otherwise")
        self.high, self.low = h, lo

    def update(self, x: float) -> int:
        """Feed one value; returns ``1`` when the state rose, ``-1`` when it fell, ``0`` otherwise."""
        x = _value(x, "value")
        if not isinstance(x, float):
            raise ValueError(f"a threshold watches one number, got shape {x.shape}")
        if not self.state and x >= self.high:
            self.state = True
            return 1
        if self.state and x <= self.low:
            self.state = False
            return -1
        return 0


class Deadband:
    r"""Let a value through only when it moved more than ``width`` from the last value let through.

    .. math:: \text{pass } x_k \iff \max_j \big|d(x_{k,j},\, p_j)\big| > w, \qquad p \leftarrow x_k
              \text{ when it passes}

    with :math:`d(a, b) = a - b`, or with ``wrap=True`` the angle difference
    :math:`\mathrm{wrap}(a - b) \in [-180, 180)` degrees (so 179 → -179 moved 2°).  For arrays the
    largest element-wise move counts (any element moving enough lets the whole value through).  The
    first value, and a value of a new shape, always pass.

    Parameters
    ----------
    width : float
        Dead band half-width, in the input's unit (``>= 0``; 0 passes every change).
    wrap : bool
        Treat values as angles in degrees.

    >>> d = Deadband(1.0, wrap=True)
    >>> [d.update(x) for x in (179.5, -179.8, -179.0, 10.0)]
    [True, False, True, True]
    """

    def __init__(self, width: float, *, wrap: bool = False) -> None:
        self.width = width
        self.wrap = bool(wrap)
        self._last: Value | None = None

    @property
    def width(self) -> float:
        """Dead band width (settable)."""
        return self._width

    @width.setter
    def width(self, value: float) -> None:
        self._width = _check_number("width", value, low=0.0, strict=False)

    def reset(self) -> None:
        """Forget the last value: the next one passes."""
        self._last = None

    def update(self, x: ArrayLike) -> bool:
        """True when ``x`` moved more than ``width`` (and becomes the new reference)."""
        x = _value(x, "value")
        last = self._last
        if last is None or _shape(last) != _shape(x):
            self._last = _copy(x)
            return True
        diff = wrap_degrees(x - last) if self.wrap else x - last
        moved = abs(float(diff)) if np.ndim(diff) == 0 else float(np.max(np.abs(diff), initial=0.0))
        if moved > self._width:
            self._last = _copy(x)
            return True
        return False
