"""The settings :class:`~pointat.maths.tqt.TQTFilter` and :class:`~pointat.maths.tqt.TQTBank` share, and the
flags they report.

:class:`_TQTParams` validates the settings once for both, keeps them as attributes (documented on
:class:`~pointat.maths.tqt.TQTFilter`) and packs them into the parameter vector of
:mod:`pointat.maths.tqt.step`, which the step of either mode reads (in place: a bank's compiled kernel
holds the same vector, so :meth:`~_TQTParams.retune` reaches it).
"""

from __future__ import annotations

import math
from enum import IntFlag
from typing import ClassVar, Literal

from numpy.typing import ArrayLike

from pointat.maths.tqt import step
from pointat.maths.tqt.paper import crossover_from_gain, paper_step

__all__ = ["K_NO_GYRO", "Mode", "TQTFlags"]


class TQTFlags(IntFlag):
    """Status of a filter's last update (bits; test with ``flag in f.flags``)."""

    NONE = 0
    #: gyro not finite, or beyond :data:`~pointat.maths.scalar.MAX_RATE`: no rate propagation this step
    GYRO_INVALID = step.F_GYRO_INVALID
    #: accelerometer zero, not finite, or impossible (beyond half again its full scale; with no full scale
    #: known, :data:`~pointat.maths.tqt.step.ACC_LIMIT` times the first reading): no gravity correction this
    #: step
    ACC_INVALID = step.F_ACC_INVALID
    #: magnetometer zero or not finite: no magnetic correction this step
    MAG_INVALID = step.F_MAG_INVALID
    #: ``dt`` not a finite positive number: nothing done
    DT_INVALID = step.F_DT_INVALID
    #: no valid accelerometer + magnetometer pair seen yet: the output is the identity
    UNINITIALISED = step.F_UNINITIALISED
    #: robust mode: the field's norm or dip is off its reference, the magnetometer ignored (after
    #: ``mag_reject_time`` seconds of it, used at half gain); raised when the field (low-passed over ``mag_tau``)
    #: is off by 1.25 times the gate's tolerances, lowered after 2 s within 0.85 times them (the gate that
    #: decides whether the magnetometer is used has its own half second: the flag only reports)
    MAG_DISTURBED = step.F_MAG_DISTURBED
    #: robust mode: the sensor is at rest, the gyro bias is being learned
    REST = step.F_REST
    #: robust mode: an accelerometer axis reached its full scale (``acc_range``, or the rail found in the
    #: data when none is told) within the last second
    ACC_SATURATED = step.F_ACC_SATURATED
    #: robust mode: a gyro axis reached its full scale (``gyro_range``) within the last second
    GYRO_SATURATED = step.F_GYRO_SATURATED
    #: robust mode: the specific force's norm is off gravity by more than half a g on average over 0.25 s
    #: (down again below 0.3 g)
    SHAKING = step.F_SHAKING


Mode = Literal["robust", "paper"]

#: ``k`` of robust mode without a gyro (``use_gyro=False``): nothing carries the orientation between
#: corrections, so they follow the measurement within 1/k = 20 ms.
K_NO_GYRO = 50.0


class _TQTParams:
    """Parameters shared by :class:`TQTFilter` and :class:`TQTBank` (validated once, documented there)."""

    #: The gain ``k`` of each mode when none is given (robust without a gyro: :data:`K_NO_GYRO`).
    DEFAULT_K: ClassVar[dict[str, float]] = {"robust": 0.5, "paper": 0.1}

    def __init__(
        self,
        k: float | None = None,
        *,
        rho: float = 0.5,
        iterations: int = 1,
        mode: Mode = "robust",
        use_gyro: bool = True,
        dip: float | None = None,
        k_heading: float = 0.015,
        acc_tau: float = 2.0,
        mag_norm_tol: float = 0.1,
        mag_dip_tol: float = math.radians(10.0),
        mag_new_time: float = 20.0,
        mag_reject_time: float = 60.0,
        motion_bias_tau: float = 30.0,
        mag_tau: float = 0.2,
        k_heading_unrested: float = 0.1,
        k_heading_rest: float = 0.2,
        k_heading_turn: float = 0.01,
        mag_lag_tau: float = 10.0,
        mag_lag_max: float = 0.02,
        rest_time: float = 1.5,
        rest_gyro: float = math.radians(2.0),
        rest_acc: float = 0.05,
        bias_tau: float = 10.0,
        bias_clip: float = math.radians(2.0),
        acc_range: float = 0.0,
        gyro_range: float = 0.0,
    ) -> None:
        if mode not in ("robust", "paper"):
            raise ValueError(f"mode must be 'robust' or 'paper', got {mode!r}")
        if k is None:
            k = self.default_k(mode, use_gyro)
        for name, value in (
            ("k", k),
            ("rho", rho),
            ("k_heading", k_heading),
            ("acc_tau", acc_tau),
            ("mag_norm_tol", mag_norm_tol),
            ("mag_dip_tol", mag_dip_tol),
            ("mag_new_time", mag_new_time),
            ("mag_reject_time", mag_reject_time),
            ("motion_bias_tau", motion_bias_tau),
            ("mag_tau", mag_tau),
            ("k_heading_unrested", k_heading_unrested),
            ("k_heading_rest", k_heading_rest),
            ("k_heading_turn", k_heading_turn),
            ("mag_lag_tau", mag_lag_tau),
            ("mag_lag_max", mag_lag_max),
            ("rest_time", rest_time),
            ("rest_gyro", rest_gyro),
            ("rest_acc", rest_acc),
            ("bias_tau", bias_tau),
            ("bias_clip", bias_clip),
            ("acc_range", acc_range),
            ("gyro_range", gyro_range),
        ):
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
        if acc_tau <= 0.0 or bias_tau <= 0.0:
            raise ValueError("acc_tau and bias_tau must be > 0")
        if int(iterations) != iterations or iterations < 1:
            raise ValueError(f"iterations must be an integer >= 1, got {iterations!r}")
        if dip is not None and not math.isfinite(dip):
            raise ValueError(f"dip must be finite radians, got {dip!r}")
        self.k = float(k)
        self.rho = float(rho)
        self.iterations = int(iterations)
        self.mode: Mode = mode
        self.use_gyro = bool(use_gyro)
        self.dip = dip
        self.k_heading = float(k_heading)
        self.acc_tau = float(acc_tau)
        self.mag_norm_tol = float(mag_norm_tol)
        self.mag_dip_tol = float(mag_dip_tol)
        self.mag_new_time = float(mag_new_time)
        self.mag_reject_time = float(mag_reject_time)
        self.motion_bias_tau = float(motion_bias_tau)
        self.mag_tau = float(mag_tau)
        self.k_heading_unrested = float(k_heading_unrested)
        self.k_heading_rest = float(k_heading_rest)
        self.k_heading_turn = float(k_heading_turn)
        self.mag_lag_tau = float(mag_lag_tau)
        self.mag_lag_max = float(mag_lag_max)
        self.rest_time = float(rest_time)
        self.rest_gyro = float(rest_gyro)
        self.rest_acc = float(rest_acc)
        self.bias_tau = float(bias_tau)
        self.bias_clip = float(bias_clip)
        self.acc_range = float(acc_range)
        self.gyro_range = float(gyro_range)
        self._p = self._params()
        self._step = step.robust_step if mode == "robust" else paper_step
        self.reset()

    @classmethod
    def default_k(cls, mode: Mode, use_gyro: bool = True) -> float:
        """The gain ``k`` a filter of this mode takes when none is given.

        >>> from pointat.maths.tqt import TQTFilter
        >>> TQTFilter.default_k("robust"), TQTFilter.default_k("robust", use_gyro=False)
        (0.5, 50.0)
        """
        if mode == "robust" and not use_gyro:
            return K_NO_GYRO
        return cls.DEFAULT_K[mode]

    def _params(self) -> list[float]:
        """The parameter vector of :mod:`pointat.maths.tqt.step`, paper mode's ``rho`` and ``iterations``
        after it."""
        return step.params(
            self.k,
            self.k_heading,
            self.acc_tau,
            self.bias_tau,
            self.mag_norm_tol,
            self.mag_dip_tol,
            self.rest_time,
            self.rest_gyro,
            self.rest_acc,
            self.bias_clip,
            self.use_gyro,
            self.dip is not None,
            self.acc_range,
            self.gyro_range,
            self.mag_new_time,
            self.mag_reject_time,
            self.motion_bias_tau,
            self.mag_tau,
            self.k_heading_unrested,
            self.k_heading_rest,
            self.k_heading_turn,
            self.mag_lag_tau,
            self.mag_lag_max,
        ) + [self.rho, float(self.iterations)]

    @property
    def crossover(self) -> float:
        r"""The gravity correction's crossover in Hz: below it the tilt follows the accelerometer, above it
        the gyro (the -3 dB point of the accelerometer's path to the estimate).

        paper: :math:`k / 2\pi` (Theory Eq. 59).  robust: the acceleration is low-passed in the earth
        frame (``acc_tau``) before the gain-``k`` correction sees it, two first-order low-passes in a
        row, so the crossover is lower:

        .. math:: \omega_c^2 = \tfrac12\Big(\sqrt{(k^2 + a^2)^2 + 4k^2a^2} - (k^2 + a^2)\Big), \qquad
                  a = 1 / \tau_a, \qquad f_c = \omega_c / 2\pi

        (0.051 Hz at the defaults k = 0.5, acc_tau = 2 s, where k / 2 pi would say 0.08 Hz).  The heading
        correction of robust mode has its own, :attr:`heading_crossover`.  Without a gyro there is no
        low-pass: :math:`k / 2\pi`.

        >>> from pointat.maths.tqt import TQTFilter
        >>> round(TQTFilter(1.0, mode="paper").crossover, 4), round(TQTFilter(1.0).crossover, 4)
        (0.1592, 0.0667)
        """
        if self.mode == "paper" or not self.use_gyro:
            return crossover_from_gain(self.k)
        k2, a2 = self.k * self.k, 1.0 / (self.acc_tau * self.acc_tau)
        w2 = 0.5 * (math.sqrt((k2 + a2) ** 2 + 4.0 * k2 * a2) - (k2 + a2))
        return crossover_from_gain(math.sqrt(w2))

    @property
    def heading_crossover(self) -> float:
        r"""robust mode: the heading correction's crossover in Hz, :math:`k_{heading} / 2\pi` (below it the
        heading follows the magnetometer, above it the gyro; 0.0024 Hz at the default 0.015; more while
        turning, ``k_heading_turn``)."""
        return crossover_from_gain(self.k_heading if self.use_gyro else self.k)

    def reset(self, q: ArrayLike | None = None) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    _TUNABLE = (
        "k", "rho", "k_heading", "acc_tau", "mag_norm_tol", "mag_dip_tol", "mag_new_time", "mag_reject_time",
        "motion_bias_tau", "mag_tau", "k_heading_unrested", "k_heading_rest", "k_heading_turn", "mag_lag_tau",
        "mag_lag_max", "bias_tau", "acc_range", "gyro_range",
    )  # fmt: skip

    def retune(self, **gains: float) -> None:
        """Change gains while running (``k``, ``rho``, ``k_heading``, ``acc_tau``, ``acc_range``...); the
        state is kept.

        >>> from pointat.maths.tqt import TQTFilter
        >>> f = TQTFilter()
        >>> f.retune(k=0.5, k_heading=0.1)
        >>> f.k, f.k_heading
        (0.5, 0.1)
        """
        new = {}
        for name, value in gains.items():  # all checked before any is set: a refusal changes nothing
            if name not in self._TUNABLE:
                raise ValueError(f"cannot retune {name!r}; tunable: {', '.join(self._TUNABLE)}")
            value = float(value)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
            if value == 0.0 and name in ("acc_tau", "bias_tau"):  # time constants: as the constructor says
                raise ValueError(f"{name} must be > 0, got {value!r}")
            new[name] = value
        for name, value in new.items():
            setattr(self, name, value)
        self._p[:] = self._params()  # in place: a bank's compiled kernel holds the same vector
