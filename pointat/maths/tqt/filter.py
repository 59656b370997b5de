"""The TQT filter for one sensor: :class:`TQTFilter` (documented here; the theory and its sources are in
:mod:`pointat.maths.tqt`).

Its state is the flat vector of :mod:`pointat.maths.tqt.step`, and each update runs the step of its mode:
in robust mode (``backend="numba"``, what ``"auto"`` takes) one call
of :func:`~pointat.maths.tqt.step.robust_update` compiled (:mod:`pointat.maths.tqt.compiled`), the state
a float64 array it changes in place; otherwise (``backend="python"``, paper mode)
:func:`~pointat.maths.tqt.step.robust_step` or :func:`~pointat.maths.tqt.paper.paper_step` on plain
floats, the state a Python list.  The two give the same bits
(``tests/maths/test_tqt_implementations.py``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from pointat.maths.quaternion import quat_normalize
from pointat.maths.tqt import step
from pointat.maths.tqt.params import TQTFlags, _TQTParams

__all__ = ["TQTFilter"]


class TQTFilter(_TQTParams):
    r"""McGhee / Bachmann's quaternion MARG filter for one sensor, ``mode="robust"`` or ``"paper"``.

    ``update(gyro, acc, mag, dt)`` returns the orientation ``(w, x, y, z)`` (sensor -> NWU earth) as plain
    floats.  The filter starts from the first valid accelerometer / magnetometer pair (TRIAD,
    :func:`pointat.maths.fusion.accmag_quat`) and learns the magnetic dip from the angle between the two
    measured vectors there, unless ``dip`` is given.  Every step ends with a normalisation.

    **paper** -- the seeds' filter (VRST Eq. 15, Patent Eq. 16) with the sign of gravity fixed: every step
    one (or ``iterations``) Gauss-Newton cycle of the 3x3 reduced form (Patent Eq. 29) on the normalised
    accelerometer and magnetometer, magnetometer rows weighted by ``rho``, fed back with gain ``k``:

    .. math::
        \hat q_{n+1} = \hat q_n \otimes \exp\!\Big(\tfrac{\Delta t}{2}\big(\omega + 2k\,\Delta v\big)\Big),
        \qquad \Delta v = (X_v^T X_v)^{-1} X_v^T \varepsilon(\hat q_n)

    the exact integral over one sample of Theory Eqs. 17-18 (both terms are :math:`\hat q \otimes` a pure
    vector).  As in VRST Eq. 15 the residual compares the *new* measurement with the *previous* estimate, so
    under a constant rate the estimate settles one sample *ahead* of the motion, by :math:`\omega\Delta t`
    (0.57 deg at 1 rad/s and 100 Hz).  With one of the two vectors invalid,
    :math:`\Delta v` is the minimum-norm Gauss-Newton step of the other alone.

    **robust** (default) -- the same Gauss-Newton corrections, decoupled, after the propagation
    :math:`\hat q^- = \hat q_n \otimes \exp(\tfrac{\Delta t}{2}(\omega - b))`, plus five extensions
    (:mod:`pointat.maths.tqt.step`, the one implementation every form runs):

    1. *The magnetometer corrects heading only.*  Gravity rows and magnetometer rows are solved separately;
       the magnetic correction is projected onto the earth vertical: the one-parameter Gauss-Newton fit of
       the heading, solved exactly, :math:`\psi = \mathrm{atan2}(B^e_y, B^e_x)` with
       :math:`B^e = \hat q \otimes B \otimes \hat q^*`, applied as :math:`q_z(-\alpha_\psi \psi) \otimes
       \hat q` with its own small gain, :math:`\alpha_\psi = k_{heading}\Delta t`.  Magnetic disturbances
       can then never tilt the estimate.
    2. *Gyro bias learned at rest*, not by an integral term (which would also learn acceleration errors
       as bias).  Rest = gyro and accelerometer within ``rest_gyro`` / ``rest_acc`` of their 0.5 s low-pass
       for ``rest_time`` seconds, with the gyro low-pass below ``bias_clip``; at rest the bias follows the
       gyro low-pass, :math:`b \leftarrow b + (1 - e^{-\Delta t/\tau_b})(\bar\omega - b)`.
    3. *Time-weighted summing of acceleration* (Patent col. 4): the vertical is the direction of the
       acceleration averaged in the earth frame, :math:`e \leftarrow e + (1 - e^{-T/\tau_a})(\bar a^e_T -
       e)`, fed with the means :math:`\bar a^e_T` of 0.1 s chunks of :math:`\hat q^- \otimes a \otimes
       \hat q^{-*}` (a plain mean while less than ``acc_tau`` is in); every correction of :math:`\hat q`
       turns :math:`e` with it, so past samples stay in the current frame.  Linear accelerations average
       out, gravity does not: the error a hand's motion leaves in :math:`e` is its velocity over
       :math:`\tau_a`, however hard it strikes.  The gravity rows' Gauss-Newton fit, solved exactly (the
       rotation by :math:`\theta = \angle(e, \text{up})` about :math:`e \times \text{up}`), is applied with
       :math:`\alpha = k\Delta t`.
    4. *Magnetic gating, with a reference learned over time* (after VQF, Laidig & Seel 2023 §IV-C).  The
       field's norm and dip seen through the estimate, low-passed over ``mag_tau`` seconds, are compared
       with a reference; while either is off by more than ``mag_norm_tol`` (relative) or ``mag_dip_tol`` the field
       is taken for disturbed, the heading correction stops, and it is taken back only after half a
       second within the gate.  The flag ``MAG_DISTURBED`` has its own, wider hysteresis (raised beyond
       1.25 times the tolerances, lowered after 2 s within 0.85 times them): each change is a message to
       the receiver, and the flag changes nothing in the estimate.  The reference starts from the
       first sample (its dip from the angle between the measured vectors) and follows the accepted field
       over 20 s.  Beside it a *candidate* follows the field as it is lately; a candidate that keeps its
       norm and dip while the sensor turns (above 20°/s: a field that holds while the sensor turns is
       the earth's, not a magnet's it carries) for ``mag_new_time`` seconds replaces a reference the
       field disagrees with, and within 5 s a first reference never confirmed by 5 s of accepted field
       (a start in motion, a first sample near steel, a place whose dip differs).  After
       ``mag_reject_time`` seconds of disturbance in all, the field corrects the heading at half the
       gain until it is accepted again.  The heading follows the plain mean of the accepted field over
       its first 1 / ``k_heading`` seconds (gain :math:`\max(k_{heading}, 1/t)`), so that a start in
       motion does not leave its TRIAD heading for 20 s.  Until the sensor has rested ``bias_tau`` seconds in
       all (its gyro's bias not known), the heading is corrected at ``k_heading_unrested`` instead of
       ``k_heading`` and the correction's rate is taken into the gyro bias about the vertical
       (``motion_bias_tau``): a bias a sensor that never rests cannot learn would otherwise hold the
       heading off by bias / gain.  While the sensor rests (``REST``) the heading is corrected at
       ``k_heading_rest`` if that is more: the field seen through the estimate is right at rest (the tilt
       is, and a magnetometer that lags the gyro, BROAD's by ~10 ms, has nothing to lag behind), so the
       heading error the gyro left behind after fast turning is taken back in a pause, not over the
       next 20 s of motion.  In fast motion the field is wrong by that lag (the sensor turns several
       degrees in 10 ms) and by the tilt's error times the dip's tangent.  The gyro, though, drifts with
       the angle it turns (its scale error), not with time alone: the heading gain grows with the
       sustained turn rate, ``k_heading_turn`` per rad/s of the rest detector's 0.5 s low-pass of the
       gyro (in which a back-and-forth motion cancels, as its drift does), except while the accelerometer
       is at its rail (strokes: the tilt, and the field seen through it, are the gyro's alone).
       Gating on the accelerometer norm is not done: it made every variant worse on BROAD.
    5. *Saturation* (when the source gives ``acc_range`` / ``gyro_range``, the sensor's full scale per
       axis; when it gives no ``acc_range``, the accelerometer's is found from the data: the largest
       reading beyond 1.5 g met to the bit three times is the rail, and the average forgets what it took
       before).  No chunk of acceleration goes into :math:`e` from just before a spell of accelerometer
       saturation (clips less than 1 s apart) to 1 s after it: strokes are left out whole, swing and
       impact, never one side of them, so the average stays unbiased; once the gyro alone has turned
       the estimate by half a turn, or the spell has lasted 8 s (a runner's every step clips: the
       motion's own), a chunk goes in all the same.  While the gyro is saturated (and a second after) the
       heading is corrected at ``k_heading_unrested`` at least, the field accepted: the turn beyond the
       rail is lost.

    Nothing a hand can produce is refused: a reading counts as corrupt only beyond half again the full
    scale, or with none known beyond :data:`~pointat.maths.tqt.ACC_LIMIT` (1000) times the first
    reading.  :attr:`flags` says ``ACC_SATURATED``, ``GYRO_SATURATED`` and ``SHAKING`` while they last.

    ``use_gyro=False`` gives accelerometer / magnetometer only tracking (VRST §4.4): no propagation, the
    corrections alone.  Robust mode then takes each reading as it comes (no average: there is no frame to
    average in), heading and tilt at the one gain ``k`` (default :data:`~pointat.maths.tqt.K_NO_GYRO`),
    the field gated by its norm.

    Bad input never poisons the state: a non-finite gyro skips the propagation, a zero or non-finite
    accelerometer or magnetometer skips that correction, a bad ``dt`` skips the step; :attr:`flags` says
    what happened and the output is never NaN.  A *zero* gyro is valid (perfect rest).

    Parameters
    ----------
    k : float, optional
        Gravity-correction gain (1/s), :math:`\alpha = k\Delta t` (VRST Eq. 14, capped at 1), errors decay
        as :math:`e^{-kt}`; crossover :attr:`crossover` (paper :math:`f_c = k/2\pi`, Theory Eq. 59,
        :func:`~pointat.maths.tqt.gain_from_crossover`; robust lower, as it low-passes the acceleration
        first).  Default: robust 0.5 (50 without a gyro), paper 0.1.
    rho : float, keyword-only
        Magnetometer weight (Theory Eq. 57), paper mode.  Default 0.5.
    iterations : int, keyword-only
        Gauss-Newton cycles per sample, paper mode (robust mode solves its decoupled fits exactly).
    mode : {"robust", "paper"}, keyword-only
    use_gyro : bool, keyword-only
        ``False``: accelerometer / magnetometer only tracking.
    dip : float, optional, keyword-only
        Magnetic dip (radians, positive below the horizon); default: learned from the first valid sample.
        Robust mode learns on from either (extension 4): a dip given for another place is replaced.
    k_heading : float, keyword-only
        Robust mode: heading-correction gain (1/s) once the gyro's bias is known from rest (``bias_tau``
        seconds of rest in all).  Default 0.015.
    k_heading_unrested : float, keyword-only
        Robust mode: the heading-correction gain (1/s) before that: a gyro whose bias is not known drifts,
        and the heading leans more on the field.  Default 0.1.
    k_heading_turn : float, keyword-only
        Robust mode: the heading-correction gain added per rad/s of sustained turning (1/rad: the gain is
        ``k_heading + k_heading_turn * |w|``, ``w`` the gyro low-passed over 0.5 s), to every gain but the
        rest's.  Default 0.01; 0: the gain of the moment alone.
    mag_lag_tau, mag_lag_max : float, keyword-only
        Robust mode: the magnetometer's lag behind the gyro is learned as it runs (:attr:`magnetometer_lag`:
        the field's heading error regressed on the turn rate about the vertical, over ``mag_lag_tau``
        seconds, 10; 0: neither learned nor taken out) and taken out of the field's heading, within 0
        and ``mag_lag_max`` seconds (0.02; 0: not at all).  Both chosen leave-one-trial-out on BROAD and
        the phones (``benchmarks/README.md``).
        It is learned from the rate's changes (the error and the rate less their half-second low-passes,
        in motion), so that a gyro's scale error, whose heading error follows the rate slowly, passes
        for a lag of only a few milliseconds; a rest or a steady turn holds what was learned.  What is
        learned is any heading error of the field that follows the rate's changes, the lag's and
        (through the dip) the tilt's.
    k_heading_rest : float, keyword-only
        Robust mode: the heading-correction gain (1/s) while the sensor rests, when it is more than the
        gain of the moment.  Default 0.2; 0: as in motion.
    acc_tau : float, keyword-only
        Robust mode: time constant (s) of the earth-frame acceleration average.  Default 2.0.
    mag_norm_tol, mag_dip_tol : float, keyword-only
        Robust mode: magnetic gate, relative norm deviation (0.1) and dip deviation in radians (10°).
    mag_new_time, mag_reject_time : float, keyword-only
        Robust mode: seconds a new field must hold its norm and dip while the sensor turns before it
        replaces the reference (20), and seconds of disturbance after which the field corrects the heading
        at half its gain all the same (60).
    mag_tau : float, keyword-only
        Robust mode: time constant (s) of the low-pass of the field's norm and dip that the gate judges
        (0.2, chosen leave-one-trial-out on BROAD and the phones; VQF's is 0.05): a moment's tilt error or
        noise does not flip the flag.
    motion_bias_tau : float, keyword-only
        Robust mode: time constant (s, 30) with which the heading correction's rate is learned as gyro
        bias about the vertical, while the sensor has rested less than ``bias_tau`` in all (a phone in the
        hand, which never rests long enough; a sensor that has rested knows its bias); 0: at rest only.
    rest_time, rest_gyro, rest_acc, bias_tau, bias_clip : float, keyword-only
        Robust mode rest detection: minimum duration (s, 1.5), gyro deviation (rad/s, 2°/s), accelerometer
        deviation relative to its norm (0.05, ~0.5 m/s²), bias time constant (s, 10.0), largest bias learned
        (rad/s per axis, 2°/s).
    acc_range, gyro_range : float, keyword-only
        Robust mode: the sensor's full scale per axis, in the readings' units (m/s² or whatever the
        accelerometer reads in; rad/s), 0 (default) when not known (the accelerometer's is then found
        from the data if it clips).  A reading at or beyond it is saturated (extension 5).
    backend : {"auto", "numba", "python"}, keyword-only
        How the update runs (the results agree to the bit): ``numba`` the robust step compiled, one call
        a sample (robust mode); ``python`` the same step in Python, several times slower.  ``auto``
        (default) takes numba in robust mode.  The first compiled filter of a process compiles the step, or loads it from numba's
        cache: here, where a patch loads, not at the first update.

    Notes
    -----
    The evidence for the defaults: ``benchmarks/LOO.md`` (leave-one-trial-out over BROAD's ten trials,
    Laidig et al. 2021, one vendored in ``pointat/data``, and the 42 Tyrex smartphone trials together, each
    set's mean counting as much, choosing only among settings that keep the strike claim) and
    ``tests/maths/test_tqt_strokes.py`` (simulated strokes, shakes and clipping with known truth):

    * ``k = 0.5`` and ``acc_tau = 2`` s (f_c ≈ 0.051 Hz together): the tilt follows the vertical averaged
      over 2 s (the patent's "time weighted summing", extension 3), corrected at half a radian per second
      per radian: what 50 of the 52 folds chose (BROAD 2.06°, phones 4.66° in-sample; k = 1 with a 4 s
      average 2.12° and 4.62°).  k = 1 with a 2 s average fails the strike claim once the heading leans on
      the field before the bias is known (``k_heading_unrested``).
    * ``k_heading = 0.015`` (a 67 s time constant) once the bias is known from rest, plus
      ``k_heading_turn = 0.01`` per rad/s of sustained turning: the field varies over the room (BROAD's
      translations, little turned, want the slowest gain: 0.49° and 0.80° where 0.05 gave 1.49° and
      1.82°), while the gyro drifts with the angle it turns (the rotations want more).  With one gain
      for both, 0.03 and 0.05 tied on BROAD's mean (2.00° each) and the folds flipped between them; with
      the turn's part the grid's means by k_heading_turn are 2.05 / **1.86** / 1.98° (0 / 0.01 / 0.02),
      the defaults 1.72° in-sample, 1.80° leave-one-trial-out (``benchmarks/LOO.md``).
      ``k_heading_unrested = 0.1`` before the bias is known (the phones, which never rest: 4.85°
      against 5.66° at 0.05, BROAD the same).
    * ``mag_lag_tau = 10`` s, ``mag_lag_max = 0.02`` s: their own 12-point leave-one-trial-out (BROAD
      1.85° → 1.73° in-sample with the lag taken out, 1.72° leave-one-trial-out; the phones 4.54°
      either way).
    * ``k_heading_rest = 0.2`` (a 5 s time constant at rest): what the heading left behind by fast
      turning needs (``benchmarks/LOO.md``, a grid of it and ``k_heading``): BROAD's slow rotation with
      breaks 1.58 → 1.43°, the attached magnet 1.88 → 1.44°, the others within 0.01°, the phones (which
      never rest) unchanged.
    * ``bias_tau = 10`` s: the bias is the mean of every rest until 10 s of rest are in, then a running
      average over 10 s (a glove that rested 3 s knows its bias; one that warms up follows it); chosen on
      BROAD's 81-point grid before the phones.  The rest thresholds are VQF's (Laidig & Seel 2023).
    * The magnetic settings: ``mag_dip_tol = 10°`` and ``mag_norm_tol = 0.1`` (VQF's), ``mag_tau = 0.2``
      s, ``motion_bias_tau = 30`` s chosen leave-one-trial-out; ``mag_new_time = 20`` s is VQF's (10 s
      scored the same).  The structure's constants (the reference's 20 s, the candidate's 20°/s and 5 s,
      the flag's 0.5 s hysteresis, the 60 s rejection time and half gain after it) are VQF's.
    * Paper mode: ``k = 0.1, rho = 0.5`` (f_c ≈ 0.016 Hz) is the best plain setting; McGhee suggests
      0.1 <= k <= 1.

    >>> f = TQTFilter(mode="paper")
    >>> _ = f.update((0.0, 0.0, 0.0), (0.0, 0.0, 9.81), (20.0, 0.0, -40.0), 0.01)
    >>> q = f.update((float("nan"), 0.0, 0.0), (0.0, 0.0, 0.0), (20.0, 0.0, -40.0), 0.01)
    >>> f.flags == TQTFlags.GYRO_INVALID | TQTFlags.ACC_INVALID
    True
    >>> [round(c, 9) for c in q]
    [1.0, 0.0, 0.0, 0.0]
    """

    def __init__(self, k: float | None = None, *, backend: str = "auto", **params: object) -> None:
        if backend not in ("auto", "numba", "python"):
            raise ValueError(f"backend must be 'auto', 'numba' or 'python', got {backend!r}")
        self._kernel = None  # (reset, which the settings' constructor calls, asks)
        super().__init__(k, **params)  # type: ignore[arg-type]
        if backend == "numba" and self.mode != "robust":
            raise ValueError(f"backend='numba' runs mode='robust' only, got mode {self.mode!r}")
        numba = backend == "numba" or (backend == "auto" and self.mode == "robust")
        self.backend = "numba" if numba else "python"
        if numba:
            from pointat.maths.tqt import compiled  # here: numba loads only where it runs

            self._kernel = compiled.update_kernel()
            self._p = np.array(self._p)
            self._s = np.array(self._s)

    # -- state ---------------------------------------------------------------------------------------------

    def reset(self, q: ArrayLike | None = None) -> None:
        """Forget everything; start again from ``q`` (sensor -> NWU) or from the next valid acc / mag pair.

        The gyro bias, rest timer, acceleration average and magnetic reference are cleared too (the dip
        given to the constructor is kept).

        Parameters
        ----------
        q : array_like, shape (4,), optional
            Known orientation; normalised here.
        """
        q0 = None if q is None else tuple(float(c) for c in quat_normalize(q))
        s = step.new_state(q0, self.dip)  # type: ignore[arg-type]
        self._s = s if self._kernel is None else np.array(s)
        self._flags = 0 if q0 is not None else step.F_UNINITIALISED

    def export_state(self) -> tuple[list[float], list[float], int]:
        """Copies of what the step runs on: the state vector (:data:`~pointat.maths.tqt.step.STATE_SIZE`),
        the parameter vector (the step keeps per-step coefficients at its end) and the flag bits, for a
        compiled copy of the step to go on from (:mod:`pointat.compiled`)."""
        return [float(x) for x in self._s], [float(x) for x in self._p], int(self._flags)

    def import_state(self, s: Sequence[float], p: Sequence[float], flags: int) -> None:
        """Go on from :meth:`export_state`'s values, moved on elsewhere (in place: the vectors keep their
        identity)."""
        self._s[:] = [float(x) for x in s]
        self._p[:] = [float(x) for x in p]
        self._flags = int(flags)

    @property
    def q(self) -> tuple[float, float, float, float]:
        """Current orientation ``(w, x, y, z)``, sensor -> NWU."""
        return self._floats(step.S_QW, 4)  # type: ignore[return-value]

    def _floats(self, at: int, n: int) -> tuple[float, ...]:
        """``n`` values of the state from ``at``, as Python floats."""
        part = self._s[at : at + n]
        return tuple(part.tolist() if isinstance(part, np.ndarray) else part)

    @property
    def flags(self) -> TQTFlags:
        """:class:`TQTFlags` of the last update."""
        return TQTFlags(self._flags)

    @property
    def flag_bits(self) -> int:
        """:attr:`flags` as a plain ``int``, for a caller on every sample (an enum flag costs ~0.5 µs)."""
        return self._flags

    @property
    def initialised(self) -> bool:
        """Whether the orientation has been set (first valid acc / mag pair, or :meth:`reset` with ``q``)."""
        return bool(self._s[step.S_INIT] != 0.0)

    @property
    def bias(self) -> tuple[float, float, float]:
        """Gyro bias learned at rest (rad/s, sensor frame; robust mode)."""
        return self._floats(step.S_BIAS, 3)  # type: ignore[return-value]

    @property
    def bias_seconds(self) -> float:
        """Seconds of rest the bias estimate has taken in so far (robust mode)."""
        return float(self._s[step.S_BIAS_T])

    @property
    def magnetometer_ignored(self) -> bool:
        """Robust mode: whether the gate refuses the field this sample (the heading correction stopped, or
        at half gain once ``mag_reject_time`` is used up).  ``MAG_DISTURBED`` reports the same judgement
        with a wider hysteresis of its own, for the receiver; this is what the estimate runs on."""
        return bool(self._s[step.S_MAG_DIST] != 0.0)

    @property
    def magnetometer_lag(self) -> float:
        """Robust mode: the magnetometer's lag behind the gyro (s) as learned from the turning so far (0
        until the turn rate has changed in motion, and with the learning off; at most ``mag_lag_max``),
        taken out of the field's heading."""
        return float(step.mag_lag(self._s, self._p))

    @property
    def magnetic_dip(self) -> float | None:
        """Dip reference in radians (``None`` until learned)."""
        if self.dip is None and not self._s[step.S_MAG_KNOWN]:
            return None
        return float(self._s[step.S_DIP])

    # -- update --------------------------------------------------------------------------------------------

    def update(
        self, gyro: ArrayLike, acc: ArrayLike, mag: ArrayLike, dt: float
    ) -> tuple[float, float, float, float]:
        r"""Advance by one sample.

        Parameters
        ----------
        gyro : sequence of 3 floats
            Angular rate (rad/s), sensor frame.
        acc : sequence of 3 floats
            Specific force (+g up at rest; m/s² or any unit), sensor frame.
        mag : sequence of 3 floats
            Magnetic field (any unit), sensor frame.
        dt : float
            Time since the previous sample, seconds.

        Returns
        -------
        tuple of 4 floats
            ``(w, x, y, z)``, sensor -> NWU; never NaN.
        """
        kernel = self._kernel
        if kernel is not None:  # compiled: any sequence of three numbers, converted to floats by numba
            gx, gy, gz = gyro
            ax, ay, az = acc
            mx, my, mz = mag
            self._flags, w, x, y, z = kernel(self._s, self._p, gx, gy, gz, ax, ay, az, mx, my, mz, dt)
            return (w, x, y, z)
        # plain Python floats are several times faster than numpy scalars in the arithmetic
        gx, gy, gz = gyro.tolist() if isinstance(gyro, np.ndarray) else gyro
        ax, ay, az = acc.tolist() if isinstance(acc, np.ndarray) else acc
        mx, my, mz = mag.tolist() if isinstance(mag, np.ndarray) else mag
        s = self._s
        self._flags = self._step(s, self._p, gx, gy, gz, ax, ay, az, mx, my, mz, float(dt))
        return (s[0], s[1], s[2], s[3])
