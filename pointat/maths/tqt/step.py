r"""One sample of the TQT filter for one sensor, written once for every way it runs.

:class:`~pointat.maths.tqt.TQTFilter` (one sensor, plain Python floats) and
:class:`~pointat.maths.tqt.TQTBank` (many sensors: a Python loop, or this same source compiled by numba in
:mod:`pointat.maths.tqt.compiled`) all call :func:`robust_step` or
:func:`~pointat.maths.tqt.paper.paper_step` on a flat state vector ``s`` (a list, or one row of an array:
:data:`STATE_SIZE` floats laid out by the ``S_*`` indices) and a parameter vector ``p`` (:data:`PARAM_SIZE`
floats, ``P_*``; :func:`params` makes it).  There is no second copy of the algorithm to keep equal: the
compiled bank is this code (``tests/maths/test_tqt_implementations.py`` holds every way it runs equal to
the bit).

The algorithm is documented on :class:`~pointat.maths.tqt.TQTFilter`; the equations' sources are in
:mod:`pointat.maths.tqt`.  What robust mode does with accelerations no gravity estimate should swallow:

* **Nothing a hand can produce is refused.**  A reading is refused only when it is not a number, zero,
  beyond the sensor's own full scale by half again (``acc_range``: impossible, so corrupt), or, with no
  known full scale, more than :data:`ACC_LIMIT` (1000) times the first reading.
* **Saturation is known** when the source says its full scale (``acc_range``, ``gyro_range``), and
  **found** when it does not (:func:`_found_range`: a clipped axis reads its rail again and again, to the
  bit; the average then forgets what it took before the rail was known): an axis at its rail reads less
  than the truth.  A run of readings at the rail that has a shape (:data:`_RUN_SHAPE` samples or more,
  a fast translation's or a turn's) is **declipped** (:func:`_declip`: the quadratic through the
  readings about it guesses what the rail cut off, and that joins the average); leaving such runs out,
  with the chunks about them, left the gyro alone for most of a fast trial (BROAD clipped at ±2 g: 3.3°
  where unclipped gave 2.0°).
  An impact too short to have a shape, or one too violent to guess, is a stroke's.  Leaving out only its
  clipped samples would leave out one side of a zero-mean stroke, so the acceleration average is fed in
  *chunks* of :data:`CHUNK` seconds, and none joins it from a chunk before a spell of strokes (strokes
  less than :data:`SATURATION_SPELL` apart) to that long after the spell: the strokes are left out whole,
  swings with impacts.  Only once the gyro alone has turned the estimate by :data:`TURN_BUDGET` does a
  chunk join all the same: a long spell of fast turning would cost more in gyro drift than a clipped
  chunk costs in bias; and a spell longer than :data:`_SPELL_MAX` is the motion's own (running), not
  strokes.  The average is at most two chunks late (0.2 s, beside its time constant), and later while runs
  at the rail follow one another (each at most :data:`_RUN_MAX`: the chunk waits for their guesses).
* **The magnetic reference is learned over time** (:func:`_magnetic_gate`): it starts from the first
  sample, follows the accepted field, and is replaced by a candidate field that has held its norm and
  dip while the sensor turned, so that a start in motion or a place whose dip differs from the first
  sample's does not refuse the magnetometer for good (the heading drifting unseen).  The gate has
  hysteresis (the magnetometer ignored at once when the low-passed field leaves it, taken back after
  :data:`_MAG_CALM` seconds within it), and the disturbance flag the receiver is told has its own, wider
  (:func:`_report_flag`: raised beyond a quarter more than the gate's tolerances, lowered after
  :data:`_FLAG_CALM` seconds within less than them), so that a field wobbling about the gate's edge is
  one message, not one a wobble; the flag changes nothing in the estimate.
* **The heading gain grows with sustained turning** (:func:`_heading_gain`, ``k_heading_turn`` per rad/s of
  the rest detector's gyro low-pass, not while the accelerometer is at its rail): a gyro drifts with the
  angle it turns (its scale error), and a back-and-forth motion, whose drift cancels, cancels in the
  low-pass too.  The slow gain this allows (``k_heading`` 0.015) lets the gyro carry the heading through
  a field that varies over the room (BROAD's translations: 1.49 -> 0.49 and 1.82 -> 0.80 degrees).
* **The magnetometer's lag behind the gyro is learned and taken out** (:func:`_lag`): the field's heading
  error regressed on the turn rate about the vertical, within 0 and ``mag_lag_max``.
* **A saturated gyro** (``gyro_range`` told) has the heading corrected at ``k_heading_unrested`` at least
  while the spell lasts and the field is accepted (a disturbed field's late gain is left as it is): it
  loses the turn beyond its rail (BROAD clipped at 300 °/s: 27.62 -> 27.26 degrees, at
  500 °/s 8.57 -> 8.03).  Leaning the tilt on gravity too (the average started anew, a faster
  correction) fixed the simulated rolls but made every real recording with a clipped gyro worse.

The state and parameter layouts are private to :mod:`pointat.maths.tqt`; nothing else reads them.
"""

from __future__ import annotations

import math

from pointat.maths.scalar import MAX_RATE_SQUARED

__all__ = [
    "ACC_LIMIT",
    "ACC_RELEARN",
    "CHUNK",
    "begin",
    "params",
    "new_state",
    "robust_bank",
    "robust_batch",
    "robust_step",
    "robust_update",
]

_INF = math.inf

#: Without a known full scale, a specific force more than this many times the first one read (at rest:
#: gravity) is taken for a corrupt sample (a damaged recording, a float sensor's glitch), like NaN.  No hand
#: makes a thousand g, and hardly any accelerometer measures it; the unit stays free.
ACC_LIMIT = 1000.0
_ACC_LIMIT_SQUARED = ACC_LIMIT * ACC_LIMIT
#: Samples in a row beyond :data:`ACC_LIMIT` after which the limit is learned again from the reading: a
#: first reading far too small (a sensor settling at power-on) must not refuse gravity for good.
ACC_RELEARN = 50
#: With a known full scale, a reading beyond it by this factor cannot come from the sensor: corrupt.
_RANGE_CORRUPT = 1.5
#: Seconds of acceleration summed into one chunk of the earth-frame average (robust mode).
CHUNK = 0.1
#: Saturations less than this many seconds apart are one spell (strokes or shakes at 1 Hz and faster): the
#: acceleration average takes nothing from a chunk before a spell, during it, and for this long after
#: it, and the saturation flag is up as long.
SATURATION_SPELL = 1.0
#: Radians the gyro may turn the estimate alone, the average taking nothing, before a chunk joins it spell
#: or not: a gyro's scale error (0.5-1 % for MEMS parts) costs about a degree a half turn, as much as a
#: clipped chunk's bias at one chunk a half turn.  Slow pointing rides through a spell on the gyro; fast
#: turning keeps the average fed.
TURN_BUDGET = math.pi
#: Shaking: the mean deviation of the specific force's norm from gravity, over :data:`_SHAKE_TAU`
#: seconds, above which the flag goes up and below which it goes down again (fractions of gravity).
_SHAKE_ON = 0.5
_SHAKE_OFF = 0.3
_SHAKE_TAU = 0.25
# time constant (s) of the gravity norm's refinement at rest
_GNORM_TAU = 5.0
# time constant (s) of the magnetic reference and of the candidate: learned while the field is accepted
_MAG_REF_TAU = 20.0
# seconds the field must stay within the gate before a disturbance is over (the gate's hysteresis)
_MAG_CALM = 0.5
# the reported flag (F_MAG_DISTURBED, a status message to the receiver at each change) has hysteresis of
# its own, apart from the gate that decides whether the magnetometer is used (the estimate does not see
# it): raised when the low-passed field is off the reference by _FLAG_RAISE times the gate's tolerances,
# lowered after _FLAG_CALM seconds in a row within _FLAG_LOWER times them.  Chosen leave-one-trial-out
# over BROAD and the Tyrex phones (benchmarks/MAGFLAGS.md): a phone swung or run with wobbles about the
# gate's edge, and the gate's own half second let each wobble through as a raising
_FLAG_RAISE = 1.25
_FLAG_LOWER = 0.85
_FLAG_CALM = 2.0
# a candidate field is timed only while the sensor turns at least this fast (rad/s, the gyro's 0.5 s
# low-pass): a field that keeps its norm and dip while the sensor turns is the earth's, not a magnet's
_MAG_NEW_GYRO = math.radians(20.0)
# seconds of steady turning that replace a reference never yet confirmed (the first sample's: a start in
# motion, or in a disturbed spot), and seconds of accepted field that confirm it
_MAG_NEW_FIRST = 5.0
# a single sample off the reference by this many times the gate corrects nothing, whatever the low-pass
# says: a magnet brought near is left out from its first sample (in the heading's plain-mean start, too)
_MAG_RAW = 3.0
# a spell of accelerometer saturation longer than this (s) is the motion's own (a runner's every step:
# the Tyrex phones clip at 2 g for two minutes), not strokes: the average takes its chunks again
_SPELL_MAX = 8.0
# with no full scale told, the largest reading (beyond _CLIP_LEAST g) met exactly _CLIP_REPEAT times is the
# rail (twice found a false rail in BROAD's five-decimal CSV); saturation is tested a hair under it
_CLIP_REPEAT = 3
_CLIP_LEAST = 1.5
_CLIP_MARGIN = 1e-3
# a run at the rail is declipped (_declip) when it lasts at least _RUN_SHAPE samples and the quadratic
# through the readings about it peaks at most _PEAK_MAX times the rail; else (an impact too short to have a
# shape, or too violent to guess) it is a stroke's, and the chunks about it are left out
_RUN_SHAPE = 2
_PEAK_MAX = 2.0
# seconds a run at the rail may last and still be declipped (the chunk under way waits for its end)
_RUN_MAX = 0.5
_RUN_ON = 1
_RUN_STROKE = 2
# after the magnetometer's rejection time is used up, the heading correction runs at this fraction
_MAG_LATE_FACTOR = 0.5
# time constant (s) of the low-passes taken off the field's heading error and the turn rate before _lag
# regresses one on the other: a lag shows in how the error follows the rate's changes at once, a gyro's
# scale error e in an error that grows with the angle turned, which passes as a lag of about e x _LAG_HP
# (2.5 ms for 0.5 %; the steady turn's error itself is left out).  0.5, 1, 2 and 4 s tie on both sets
# (benchmarks/README.md): the shortest that does
_LAG_HP = 0.5
# rad/s: _lag learns only from samples whose rate is this far from its low-pass (a change of the turn well
# above a gyro's noise) and holds what it learned through a rest or a steady turn, which tell nothing of it
_LAG_CHANGE = 0.05
# time constant (s) of the gyro / accelerometer low-pass the rest detector compares against (as VQF)
_REST_TAU = 0.5
# below this squared half-angle (1.8 degrees of turn a sample: 60 rad/s at 100 Hz) the exponential map
# uses its Taylor series to the n2**3 term: the first term left out is below 3e-17, a fraction of the last
# bit, and the step spends no sine and cosine on it (the gyro's and the heading's turns of a sample)
_EXP_TAYLOR = 1e-3
_PARALLEL_EPS = 1e-6  # as pointat.maths.scalar.accmag_matrix

# flag bits (pointat.maths.tqt.TQTFlags)
F_GYRO_INVALID = 1
F_ACC_INVALID = 2
F_MAG_INVALID = 4
F_DT_INVALID = 8
F_UNINITIALISED = 16
F_MAG_DISTURBED = 32
F_REST = 64
F_ACC_SATURATED = 128
F_GYRO_SATURATED = 256
F_SHAKING = 512

# -- the state vector ------------------------------------------------------------------------------------
S_QW, S_QX, S_QY, S_QZ = 0, 1, 2, 3
S_INIT = 4  # 1.0: the orientation is set
S_BIAS = 5  # 3: gyro bias (rad/s)
S_REST_T = 8  # seconds at rest so far
S_LPG = 9  # 3: gyro low-pass of the rest detector
S_LPA = 12  # 3: accelerometer low-pass of the rest detector
S_ACC_KNOWN = 15  # 1.0: the accelerometer has been read once (A2_MAX, LPA, GNORM set)
S_E = 16  # 3: earth-frame acceleration average
S_E_AGE = 19  # seconds of acceleration in the average (0: none yet, no gravity correction)
S_CUR = 20  # 3: the chunk being summed (earth-frame acceleration x seconds)
S_CUR_T = 23  # its seconds
S_PREV = 24  # 3: the chunk before, waiting for its successor's end to be judged
S_PREV_T = 27
S_A2_MAX = 28  # ACC_LIMIT times the first reading, squared
S_A_OVER = 29  # readings in a row beyond it
S_MAG_KNOWN = 30  # 1.0: the magnetic reference is set
S_MAG_NORM = 31
S_DIP = 32  # dip reference (rad)
S_NX = 33  # magnetic reference (cos dip, 0, -sin dip): paper mode's
S_NZ = 34
S_ACC_SAT_T = 35  # seconds since the accelerometer last saturated
S_GYRO_SAT_T = 36  # seconds since the gyro last saturated
S_SHAKE = 37  # low-pass of the relative deviation of |a| from gravity
S_SHAKING = 38  # 1.0: shaking (with hysteresis)
S_GNORM = 39  # |gravity| in the accelerometer's unit (first reading, refined at rest)
S_TURN = 40  # radians the gyro has turned the estimate since a chunk last joined the average
S_BIAS_T = 41  # seconds of rest in the bias estimate (a plain mean of them while fewer than bias_tau)
S_MAG_LPN = 42  # low-pass of the field's norm
S_MAG_LPD = 43  # and of its dip (rad), through the estimate
S_MAG_DIST = 44  # 1.0: the field is taken for disturbed (the flag)
S_MAG_CALM_T = 45  # seconds in a row the field has been within the gate
S_MAG_REJ_T = 46  # seconds of rejection used (the rejection time's budget)
S_CAND_N = 47  # candidate reference: norm
S_CAND_D = 48  # dip
S_CAND_T = 49  # seconds of turning it has held steady
S_MAG_T = 50  # seconds of field accepted (the heading gain's plain-mean start; confirms the reference)
S_SPELL_T = 51  # seconds the current spell of accelerometer saturation has lasted
S_ACC_PEAK = 52  # the largest reading on any axis so far (absolute)
S_ACC_PEAK_N = 53  # readings that met it exactly
S_ACC_FOUND = 54  # the full scale found from the data (0: none; used when none is told)
S_STROKE_T = 55  # seconds since a run at the rail ended that could not be declipped (a stroke's)
S_CLIP = 56  # 3 x _CLIP_SLOTS: each accelerometer axis's run at the rail (see _clip_axis)
# an axis's slots, from its first (S_CLIP + axis x _CLIP_SLOTS)
_C_Y2 = 0  # the reading two before the run
_C_Y1 = 1  # the reading just before it
_C_N = 2  # the run's length in samples (0: no run)
_C_SIGN = 3  # the rail's sign, +1 or -1
_C_AXIS = 4  # 3: the axis in the earth frame summed over the run, x dt
_C_YA = 7  # the first reading after the run
_C_WAIT = 8  # 1.0: the run has ended, its guess waits for the second reading after it
_C_KNOWN = 9  # readings before the run known (0, 1, 2)
_CLIP_SLOTS = 10
S_MAG_FLAG = S_CLIP + 3 * _CLIP_SLOTS  # 1.0: the reported flag (F_MAG_DISTURBED) is up
S_MAG_FLAG_T = S_MAG_FLAG + 1  # seconds in a row the field has been within its lowering band
S_LAG_XY = S_MAG_FLAG_T + 1  # low-pass of psi x the vertical turn rate (the magnetometer's lag, _lag)
S_LAG_XX = S_LAG_XY + 1  # and of the rate squared
S_LAG_P = S_LAG_XX + 1  # psi low-passed over _LAG_HP (what _lag regresses is psi and the rate less these)
S_LAG_W = S_LAG_P + 1  # the vertical turn rate low-passed over _LAG_HP
S_LAG = S_LAG_W + 1  # the lag learned (s), within 0 and mag_lag_max, taken out from the next sample on
S_LAG_ON = S_LAG + 1  # 1.0: _lag followed the field and the rate the sample before
STATE_SIZE = S_LAG_ON + 1

# -- the parameter vector --------------------------------------------------------------------------------
P_K, P_K_HEADING, P_ACC_TAU, P_BIAS_TAU = 0, 1, 2, 3
P_MAG_NORM_TOL, P_MAG_DIP_TOL = 4, 5
P_REST_TIME, P_REST_GYRO, P_REST_ACC, P_BIAS_CLIP = 6, 7, 8, 9
P_USE_GYRO, P_HAS_DIP = 10, 11
P_ACC_RANGE, P_GYRO_RANGE = 12, 13  # full scale per axis (0: not known)
# per-dt coefficients, recomputed when dt changes
P_MAG_NEW_TIME, P_MAG_REJECT_TIME, P_MOTION_BIAS_TAU, P_MAG_TAU, P_K_HEADING_UNRESTED = 14, 15, 16, 17, 18
P_DT, P_C_ACC, P_C_REST, P_C_BIAS, P_C_REF, P_ALPHA, P_ALPHA_MAG, P_C_SAT = 19, 20, 21, 22, 23, 24, 25, 26
P_C_MAGLP, P_C_GNORM, P_C_MBIAS, P_ALPHA_MAG_UNRESTED = 27, 28, 29, 30
P_K_HEADING_REST, P_ALPHA_MAG_REST = 31, 32
P_K_HEADING_TURN, P_ALPHA_MAG_TURN = 33, 34
P_MAG_LAG_TAU, P_MAG_LAG_MAX, P_C_LAG, P_C_LAG_HP = 35, 36, 37, 38
PARAM_SIZE = 39

_LONG_AGO = 1e9  # "seconds since" for a saturation never seen


def params(
    k: float,
    k_heading: float,
    acc_tau: float,
    bias_tau: float,
    mag_norm_tol: float,
    mag_dip_tol: float,
    rest_time: float,
    rest_gyro: float,
    rest_acc: float,
    bias_clip: float,
    use_gyro: bool,
    has_dip: bool,
    acc_range: float,
    gyro_range: float,
    mag_new_time: float,
    mag_reject_time: float,
    motion_bias_tau: float,
    mag_tau: float,
    k_heading_unrested: float,
    k_heading_rest: float,
    k_heading_turn: float,
    mag_lag_tau: float,
    mag_lag_max: float,
) -> list[float]:
    """The parameter vector (validated by the caller); its per-``dt`` coefficients are filled on the first
    step."""
    p = [0.0] * PARAM_SIZE
    p[P_K], p[P_K_HEADING], p[P_ACC_TAU], p[P_BIAS_TAU] = k, k_heading, acc_tau, bias_tau
    p[P_MAG_NORM_TOL], p[P_MAG_DIP_TOL] = mag_norm_tol, mag_dip_tol
    p[P_REST_TIME], p[P_REST_GYRO], p[P_REST_ACC], p[P_BIAS_CLIP] = rest_time, rest_gyro, rest_acc, bias_clip
    p[P_USE_GYRO], p[P_HAS_DIP] = float(use_gyro), float(has_dip)
    p[P_ACC_RANGE], p[P_GYRO_RANGE] = acc_range, gyro_range
    p[P_MAG_NEW_TIME], p[P_MAG_REJECT_TIME] = mag_new_time, mag_reject_time
    p[P_MOTION_BIAS_TAU], p[P_MAG_TAU], p[P_K_HEADING_UNRESTED] = motion_bias_tau, mag_tau, k_heading_unrested
    p[P_K_HEADING_REST], p[P_K_HEADING_TURN] = k_heading_rest, k_heading_turn
    p[P_MAG_LAG_TAU], p[P_MAG_LAG_MAX] = mag_lag_tau, mag_lag_max
    p[P_DT] = -1.0
    return p


def new_state(q: tuple[float, float, float, float] | None, dip: float | None) -> list[float]:
    """A fresh state: at ``q`` (a unit quaternion; initialised) or waiting for the first acc / mag pair."""
    s = [0.0] * STATE_SIZE
    s[S_QW] = 1.0
    if q is not None:
        s[S_QW], s[S_QX], s[S_QY], s[S_QZ] = q
        s[S_INIT] = 1.0
    s[S_A2_MAX] = _INF
    if dip is not None:
        s[S_DIP], s[S_NX], s[S_NZ] = dip, math.cos(dip), -math.sin(dip)
    s[S_ACC_SAT_T] = s[S_GYRO_SAT_T] = s[S_STROKE_T] = _LONG_AGO
    return s


def _coefficients(p, dt):  # type: ignore[no-untyped-def]
    p[P_DT] = dt
    p[P_C_ACC] = 1.0 - math.exp(-dt / p[P_ACC_TAU])
    p[P_C_REST] = 1.0 - math.exp(-dt / _REST_TAU)
    p[P_C_BIAS] = 1.0 - math.exp(-dt / p[P_BIAS_TAU])
    p[P_C_REF] = 1.0 - math.exp(-dt / _MAG_REF_TAU)
    no_gyro = p[P_USE_GYRO] == 0.0
    p[P_ALPHA] = min(p[P_K] * dt, 1.0)
    # without a gyro nothing carries the heading between corrections: it follows the field as fast as tilt
    p[P_ALPHA_MAG] = p[P_ALPHA] if no_gyro else min(p[P_K_HEADING] * dt, 1.0)
    p[P_ALPHA_MAG_UNRESTED] = p[P_ALPHA] if no_gyro else min(p[P_K_HEADING_UNRESTED] * dt, 1.0)
    p[P_C_SAT] = 1.0 - math.exp(-dt / _SHAKE_TAU)
    p[P_C_MAGLP] = 1.0 - math.exp(-dt / p[P_MAG_TAU]) if p[P_MAG_TAU] > 0.0 else 1.0
    p[P_C_GNORM] = 1.0 - math.exp(-dt / _GNORM_TAU)
    p[P_ALPHA_MAG_REST] = min(p[P_K_HEADING_REST] * dt, 1.0)
    # the heading gain added per rad/s of sustained turning (none without a gyro: the gain is k's already)
    p[P_ALPHA_MAG_TURN] = 0.0 if no_gyro else p[P_K_HEADING_TURN] * dt
    lag = p[P_MAG_LAG_TAU] > 0.0 and p[P_MAG_LAG_MAX] > 0.0
    p[P_C_LAG] = 1.0 - math.exp(-dt / p[P_MAG_LAG_TAU]) if lag else 0.0
    p[P_C_LAG_HP] = 1.0 - math.exp(-dt / _LAG_HP)
    # the heading correction's rate (k_heading psi) integrated into the bias over motion_bias_tau: k_heading / tau
    p[P_C_MBIAS] = p[P_K_HEADING_UNRESTED] / p[P_MOTION_BIAS_TAU] if p[P_MOTION_BIAS_TAU] > 0.0 else 0.0


def _rotate(w, x, y, z, vx, vy, vz):  # type: ignore[no-untyped-def]
    """:math:`q \\otimes v \\otimes q^*` for floats: ``v + w t + u x t`` with ``t = 2 u x v``."""
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (vx + w * tx + y * tz - z * ty, vy + w * ty + z * tx - x * tz, vz + w * tz + x * ty - y * tx)


def _exp(hx, hy, hz):  # type: ignore[no-untyped-def]
    """:math:`\\exp(0, h)`, the unit quaternion of half rotation vector ``h``, for floats."""
    n2 = hx * hx + hy * hy + hz * hz
    if n2 < _EXP_TAYLOR:
        c = 1.0 - n2 * (0.5 - n2 * (1.0 / 24.0 - n2 / 720.0))
        s = 1.0 - n2 * (1.0 / 6.0 - n2 * (1.0 / 120.0 - n2 / 5040.0))
    else:
        n = math.sqrt(n2)
        c, s = math.cos(n), math.sin(n) / n
    return c, hx * s, hy * s, hz * s


def _mul_exp(w, x, y, z, hx, hy, hz):  # type: ignore[no-untyped-def]
    """:math:`q \\otimes \\exp(0, h)` for floats (``h`` = half the rotation vector, body frame)."""
    c, hx, hy, hz = _exp(hx, hy, hz)
    return (
        w * c - x * hx - y * hy - z * hz,
        w * hx + x * c + y * hz - z * hy,
        w * hy - x * hz + y * c + z * hx,
        w * hz + x * hy - y * hx + z * c,
    )


def _triad(ax, ay, az, mx, my, mz):  # type: ignore[no-untyped-def]
    """:func:`pointat.maths.fusion.accmag_quat` on floats: ``(ok, w, x, y, z)``."""
    na = math.sqrt(ax * ax + ay * ay + az * az)
    nm = math.sqrt(mx * mx + my * my + mz * mz)
    if not (na > 0.0 and nm > 0.0 and math.isfinite(na) and math.isfinite(nm)):
        return False, 1.0, 0.0, 0.0, 0.0
    ux, uy, uz = ax / na, ay / na, az / na
    mx, my, mz = mx / nm, my / nm, mz / nm
    wx, wy, wz = uy * mz - uz * my, uz * mx - ux * mz, ux * my - uy * mx
    nw = math.sqrt(wx * wx + wy * wy + wz * wz)
    if nw < _PARALLEL_EPS:
        return False, 1.0, 0.0, 0.0, 0.0
    wx, wy, wz = wx / nw, wy / nw, wz / nw
    nx, ny, nz = wy * uz - wz * uy, wz * ux - wx * uz, wx * uy - wy * ux
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = nx, ny, nz, wx, wy, wz, ux, uy, uz
    tr = m00 + m11 + m22
    if tr >= m00 and tr >= m11 and tr >= m22:
        r = 2.0 * math.sqrt(max(1.0 + tr, 0.0))
        q0, q1, q2, q3 = 0.25 * r, (m21 - m12) / r, (m02 - m20) / r, (m10 - m01) / r
    elif m00 >= m11 and m00 >= m22:
        r = 2.0 * math.sqrt(max(1.0 + m00 - m11 - m22, 0.0))
        q0, q1, q2, q3 = (m21 - m12) / r, 0.25 * r, (m01 + m10) / r, (m02 + m20) / r
    elif m11 >= m22:
        r = 2.0 * math.sqrt(max(1.0 + m11 - m00 - m22, 0.0))
        q0, q1, q2, q3 = (m02 - m20) / r, (m01 + m10) / r, 0.25 * r, (m12 + m21) / r
    else:
        r = 2.0 * math.sqrt(max(1.0 + m22 - m00 - m11, 0.0))
        q0, q1, q2, q3 = (m10 - m01) / r, (m02 + m20) / r, (m12 + m21) / r, 0.25 * r
    n = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    q0, q1, q2, q3 = q0 / n, q1 / n, q2 / n, q3 / n
    if q0 < 0.0:
        q0, q1, q2, q3 = -q0, -q1, -q2, -q3
    return True, q0, q1, q2, q3


def _store(s, w, x, y, z):  # type: ignore[no-untyped-def]
    n2 = w * w + x * x + y * y + z * z
    if 0.0 < n2 < _INF:
        n = 1.0 / math.sqrt(n2)
        s[S_QW], s[S_QX], s[S_QY], s[S_QZ] = w * n, x * n, y * n, z * n


def _accept_acc(s, p, ax, ay, az, a2):  # type: ignore[no-untyped-def]
    """Whether a reading can be a specific force at all (see the module head); keeps the relearn count."""
    if not 0.0 < a2 < _INF:
        s[S_A_OVER] = 0.0
        return False
    r = p[P_ACC_RANGE]
    if r > 0.0:
        lim = _RANGE_CORRUPT * r
        return -lim <= ax <= lim and -lim <= ay <= lim and -lim <= az <= lim
    if a2 < s[S_A2_MAX]:
        s[S_A_OVER] = 0.0
        return True
    s[S_A_OVER] += 1.0
    if s[S_A_OVER] < ACC_RELEARN:
        return False
    s[S_A2_MAX], s[S_A_OVER] = _ACC_LIMIT_SQUARED * a2, 0.0
    return True


def begin(s, p, gx, gy, gz, ax, ay, az, mx, my, mz, dt):  # type: ignore[no-untyped-def]
    """Validate the sample and learn what is still unknown (TRIAD start, first readings, magnetic
    reference): the first part of every mode's step.  Returns ``(flags, go)``: ``go`` false when this
    sample is done with (no valid ``dt``, not initialised yet, or the sample that set the orientation)."""
    if not 0.0 < dt < _INF:  # also catches NaN
        return F_DT_INVALID, False
    if dt != p[P_DT]:
        _coefficients(p, dt)
    g_ok = gx * gx + gy * gy + gz * gz < MAX_RATE_SQUARED  # NaN compares False
    a2 = ax * ax + ay * ay + az * az
    a_ok = _accept_acc(s, p, ax, ay, az, a2)
    m2 = mx * mx + my * my + mz * mz
    m_ok = 0.0 < m2 < _INF
    flags = (0 if g_ok else F_GYRO_INVALID) | (0 if a_ok else F_ACC_INVALID) | (0 if m_ok else F_MAG_INVALID)
    if s[S_ACC_KNOWN] != 0.0 and s[S_MAG_KNOWN] != 0.0:
        return flags, True
    was = s[S_INIT] != 0.0
    if not was and a_ok and m_ok:
        ok, w, x, y, z = _triad(ax, ay, az, mx, my, mz)
        if ok:
            s[S_QW], s[S_QX], s[S_QY], s[S_QZ], s[S_INIT] = w, x, y, z, 1.0
    if s[S_INIT] == 0.0:
        return flags | F_UNINITIALISED, False
    if s[S_ACC_KNOWN] == 0.0 and a_ok:
        s[S_ACC_KNOWN] = 1.0
        if p[P_ACC_RANGE] <= 0.0:
            s[S_A2_MAX] = _ACC_LIMIT_SQUARED * a2
        s[S_GNORM] = math.sqrt(a2)
        s[S_LPA], s[S_LPA + 1], s[S_LPA + 2] = ax, ay, az
        if g_ok:
            s[S_LPG], s[S_LPG + 1], s[S_LPG + 2] = gx, gy, gz
    if s[S_MAG_KNOWN] == 0.0 and m_ok and (a_ok or p[P_HAS_DIP] != 0.0):
        # dip from the angle between the measured vectors (independent of the estimate)
        s[S_MAG_KNOWN] = 1.0
        s[S_MAG_NORM] = math.sqrt(m2)
        if p[P_HAS_DIP] == 0.0:
            sin_dip = -(ax * mx + ay * my + az * mz) / (math.sqrt(a2) * s[S_MAG_NORM])
            d = math.asin(max(-1.0, min(1.0, sin_dip)))
            s[S_DIP], s[S_NX], s[S_NZ] = d, math.cos(d), -math.sin(d)
        s[S_MAG_LPN] = s[S_CAND_N] = s[S_MAG_NORM]
        s[S_MAG_LPD] = s[S_CAND_D] = s[S_DIP]
    if not was:  # this sample set the orientation: nothing more to do
        return flags, False
    return flags, True


def _turn_average(s, cw, sx, sy, sz):  # type: ignore[no-untyped-def]
    """Turn the acceleration average, its pending chunks and the runs at the rail's axis sums (what a
    declipped run adds to the chunk) with a correction of the estimate."""
    for i in (S_E, S_CUR, S_PREV):
        s[i], s[i + 1], s[i + 2] = _rotate(cw, sx, sy, sz, s[i], s[i + 1], s[i + 2])
    for j in (S_CLIP, S_CLIP + _CLIP_SLOTS, S_CLIP + 2 * _CLIP_SLOTS):
        if s[j + _C_N] > 0.0:  # (a run under way: its sum is still to be used)
            i = j + _C_AXIS
            s[i], s[i + 1], s[i + 2] = _rotate(cw, sx, sy, sz, s[i], s[i + 1], s[i + 2])


def _add_to_average(s, p, ex, ey, ez, dt, calm, hold):  # type: ignore[no-untyped-def]
    """Sum one earth-frame acceleration into the current chunk; when the chunk is full (and not ``hold``:
    a run at the rail under way, its declipping still to come), the chunk before it joins the average if
    all is still ``calm`` (no stroke for :data:`SATURATION_SPELL` seconds)."""
    s[S_CUR] += ex * dt
    s[S_CUR + 1] += ey * dt
    s[S_CUR + 2] += ez * dt
    s[S_CUR_T] += dt
    # (a run under way holds the chunk open for its guess, but never beyond the longest run declipped: an
    # axis held at the rail must not stop the average, nor its ways out, TURN_BUDGET and _SPELL_MAX)
    if s[S_CUR_T] < CHUNK * (1.0 - 1e-9) or (hold and s[S_CUR_T] < CHUNK + _RUN_MAX):
        return
    t = s[S_PREV_T]
    if t > 0.0 and (calm or s[S_TURN] >= TURN_BUDGET):
        s[S_TURN] = 0.0
        age = s[S_E_AGE]
        c = 1.0 - math.exp(-t / p[P_ACC_TAU])
        if age < p[P_ACC_TAU]:  # (re)starting: the plain mean of what there is, until a time constant is in
            c = max(c, t / (age + t))
        inv = 1.0 / t
        s[S_E] += c * (s[S_PREV] * inv - s[S_E])
        s[S_E + 1] += c * (s[S_PREV + 1] * inv - s[S_E + 1])
        s[S_E + 2] += c * (s[S_PREV + 2] * inv - s[S_E + 2])
        s[S_E_AGE] = age + t
    s[S_PREV], s[S_PREV + 1], s[S_PREV + 2], s[S_PREV_T] = s[S_CUR], s[S_CUR + 1], s[S_CUR + 2], s[S_CUR_T]
    s[S_CUR] = s[S_CUR + 1] = s[S_CUR + 2] = s[S_CUR_T] = 0.0


def robust_step(s, p, gx, gy, gz, ax, ay, az, mx, my, mz, dt):  # type: ignore[no-untyped-def]
    """One sample of robust mode (:class:`~pointat.maths.tqt.TQTFilter`): changes ``s`` (and ``p``'s
    per-``dt`` coefficients), returns the flag bits."""
    flags, go = begin(s, p, gx, gy, gz, ax, ay, az, mx, my, mz, dt)
    if not go:
        return flags
    g_ok = (flags & F_GYRO_INVALID) == 0
    a_ok = (flags & F_ACC_INVALID) == 0
    m_use = (flags & F_MAG_INVALID) == 0 and s[S_MAG_KNOWN] != 0.0
    use_gyro = p[P_USE_GYRO] != 0.0
    # saturation: an axis at the full scale the source gave
    r = p[P_GYRO_RANGE]
    g_sat = g_ok and r > 0.0 and (abs(gx) >= r or abs(gy) >= r or abs(gz) >= r)
    r = p[P_ACC_RANGE]
    if r <= 0.0 and a_ok:  # not told: found from the data, if the sensor clips
        r = _found_range(s, ax, ay, az)
    a_sat = a_ok and r > 0.0 and (abs(ax) >= r or abs(ay) >= r or abs(az) >= r)
    if g_sat:
        s[S_GYRO_SAT_T] = 0.0
    elif s[S_GYRO_SAT_T] < _LONG_AGO:
        s[S_GYRO_SAT_T] += dt
    if a_sat:
        s[S_ACC_SAT_T] = 0.0
    elif s[S_ACC_SAT_T] < _LONG_AGO:
        s[S_ACC_SAT_T] += dt
    if s[S_ACC_SAT_T] < SATURATION_SPELL:
        flags |= F_ACC_SATURATED
    if s[S_STROKE_T] < _LONG_AGO:
        s[S_STROKE_T] += dt
    if s[S_GYRO_SAT_T] < SATURATION_SPELL:
        flags |= F_GYRO_SATURATED
    # without a gyro to carry the tilt between corrections it lags the motion, and the dip seen through it
    # is no test of the field
    dip_gate = use_gyro
    w, x, y, z = s[S_QW], s[S_QX], s[S_QY], s[S_QZ]
    bx, by, bz = s[S_BIAS], s[S_BIAS + 1], s[S_BIAS + 2]
    # (0) propagation with the bias-corrected rate, exact over the sample
    if g_ok and use_gyro:
        h = 0.5 * dt
        w, x, y, z = _mul_exp(w, x, y, z, h * (gx - bx), h * (gy - by), h * (gz - bz))
        if s[S_TURN] < TURN_BUDGET:
            s[S_TURN] += dt * math.sqrt((gx - bx) ** 2 + (gy - by) ** 2 + (gz - bz) ** 2)
    # (2) rest detection and gyro bias; shaking
    if a_ok:
        a = math.sqrt(ax * ax + ay * ay + az * az)
        s[S_SHAKE] += p[P_C_SAT] * (abs(a - s[S_GNORM]) / s[S_GNORM] - s[S_SHAKE])
        if s[S_SHAKING] == 0.0 and s[S_SHAKE] > _SHAKE_ON:
            s[S_SHAKING] = 1.0
        elif s[S_SHAKING] != 0.0 and s[S_SHAKE] < _SHAKE_OFF:
            s[S_SHAKING] = 0.0
    if s[S_SHAKING] != 0.0:
        flags |= F_SHAKING
    if g_ok and a_ok:
        c = p[P_C_REST]
        lgx = s[S_LPG] + c * (gx - s[S_LPG])
        lgy = s[S_LPG + 1] + c * (gy - s[S_LPG + 1])
        lgz = s[S_LPG + 2] + c * (gz - s[S_LPG + 2])
        lax = s[S_LPA] + c * (ax - s[S_LPA])
        lay = s[S_LPA + 1] + c * (ay - s[S_LPA + 1])
        laz = s[S_LPA + 2] + c * (az - s[S_LPA + 2])
        s[S_LPG], s[S_LPG + 1], s[S_LPG + 2] = lgx, lgy, lgz
        s[S_LPA], s[S_LPA + 1], s[S_LPA + 2] = lax, lay, laz
        dgx, dgy, dgz = gx - lgx, gy - lgy, gz - lgz
        dax, day, daz = ax - lax, ay - lay, az - laz
        clip = p[P_BIAS_CLIP]
        thr = p[P_REST_ACC]
        la2 = lax * lax + lay * lay + laz * laz
        if (
            dgx * dgx + dgy * dgy + dgz * dgz < p[P_REST_GYRO] * p[P_REST_GYRO]
            and dax * dax + day * day + daz * daz < thr * thr * la2
            and -clip < lgx < clip
            and -clip < lgy < clip
            and -clip < lgz < clip
        ):
            s[S_REST_T] += dt
            if s[S_REST_T] >= p[P_REST_TIME]:
                flags |= F_REST
                # the mean of every rest so far until bias_tau of it is in, then a running average that
                # forgets: a glove that rested 3 s knows its bias, and one that warms up follows it
                t = s[S_BIAS_T] + dt
                s[S_BIAS_T] = t
                c = max(p[P_C_BIAS], dt / t)
                s[S_BIAS], s[S_BIAS + 1], s[S_BIAS + 2] = (
                    bx + c * (lgx - bx),
                    by + c * (lgy - by),
                    bz + c * (lgz - bz),
                )
                s[S_GNORM] += p[P_C_GNORM] * (math.sqrt(la2) - s[S_GNORM])
        else:
            s[S_REST_T] = 0.0
    else:
        s[S_REST_T] = 0.0
    # (3) gravity: the earth-frame acceleration average, Gauss-Newton alignment with the vertical
    correct = False
    if use_gyro:
        if a_ok:
            hold = False
            if r > 0.0:  # the runs at the rail: declipped into the chunk, or a stroke's
                # in a spell of strokes longer than _SPELL_MAX (the motion's own) the runs join as they are
                fix = s[S_STROKE_T] >= SATURATION_SPELL or s[S_SPELL_T] < _SPELL_MAX
                o = (
                    _clip_axis(s, S_CLIP, ax, r, w, x, y, z, 1.0, 0.0, 0.0, dt, fix)
                    | _clip_axis(s, S_CLIP + _CLIP_SLOTS, ay, r, w, x, y, z, 0.0, 1.0, 0.0, dt, fix)
                    | _clip_axis(s, S_CLIP + 2 * _CLIP_SLOTS, az, r, w, x, y, z, 0.0, 0.0, 1.0, dt, fix)
                )
                if o & _RUN_STROKE:
                    if s[S_STROKE_T] >= SATURATION_SPELL:  # a new spell begins
                        s[S_SPELL_T] = 0.0
                    s[S_STROKE_T] = 0.0
                hold = (o & _RUN_ON) != 0
            if s[S_STROKE_T] < SATURATION_SPELL:
                s[S_SPELL_T] += dt
            # a spell longer than _SPELL_MAX is the motion's own (a runner's every step), not strokes
            calm = s[S_STROKE_T] >= SATURATION_SPELL or s[S_SPELL_T] >= _SPELL_MAX
            aex, aey, aez = _rotate(w, x, y, z, ax, ay, az)
            _add_to_average(s, p, aex, aey, aez, dt, calm, hold)
        correct = s[S_E_AGE] > 0.0
    elif a_ok and not a_sat:  # accelerometer / magnetometer only: no frame to average in, the reading itself
        s[S_E], s[S_E + 1], s[S_E + 2] = _rotate(w, x, y, z, ax, ay, az)
        correct = True
    if correct:
        ex, ey, ez = s[S_E], s[S_E + 1], s[S_E + 2]
        eh2 = ex * ex + ey * ey
        if eh2 > 0.0:
            eh = math.sqrt(eh2)
            f = 0.5 * p[P_ALPHA] * math.atan2(eh, ez) / eh  # half the correction angle, per |e_h|
            cw, sx, sy, _ = _exp(f * ey, -f * ex, 0.0)  # half rotation vector about (e x up)
            # q <- C q, and the average with it, C = (cw, sx, sy, 0) in the earth frame
            w, x, y, z = (
                cw * w - sx * x - sy * y,
                cw * x + sx * w + sy * z,
                cw * y + sy * w - sx * z,
                cw * z + sx * y - sy * x,
            )
            _turn_average(s, cw, sx, sy, 0.0)
    # (1) + (4) magnetometer: gated heading-only correction
    lag_on = s[S_LAG_ON]  # (a sample without the lag's low-passes breaks their run: _lag starts them anew)
    s[S_LAG_ON] = 0.0
    if m_use:
        bex, bey, bez = _rotate(w, x, y, z, mx, my, mz)
        bh = math.sqrt(bex * bex + bey * bey)
        norm, dip = math.sqrt(bh * bh + bez * bez), math.atan2(-bez, bh)
        if _magnetic_gate(s, p, norm, dip, dt, dip_gate):
            flags |= F_MAG_DISTURBED
        k = _heading_gain(s, p, dt, flags)
        ref = s[S_MAG_NORM]
        if abs(norm - ref) > _MAG_RAW * p[P_MAG_NORM_TOL] * ref or (
            dip_gate and abs(dip - s[S_DIP]) > _MAG_RAW * p[P_MAG_DIP_TOL]
        ):
            k = 0.0
        if k > 0.0 and bh > 0.0:
            psi = math.atan2(bey, bex)
            if p[P_C_LAG] > 0.0 and g_ok and use_gyro:
                psi = _lag(s, p, psi, w, x, y, z, gx - bx, gy - by, gz - bz, flags & F_REST == 0, lag_on)
            if (
                p[P_C_MBIAS] > 0.0
                and dt < k * s[S_MAG_T]
                and flags & F_REST == 0
                and s[S_BIAS_T] < p[P_BIAS_TAU]
            ):
                _motion_bias(s, p, w, x, y, z, psi)
            cz, _, _, sz = _exp(0.0, 0.0, -0.5 * k * psi)
            w, x, y, z = cz * w - sz * z, cz * x - sz * y, cz * y + sz * x, cz * z + sz * w
            _turn_average(s, cz, 0.0, 0.0, sz)
    _store(s, w, x, y, z)
    return flags


def _magnetic_gate(s, p, norm, dip, dt, dip_gate):  # type: ignore[no-untyped-def]
    """Judge the field (its norm and dip through the estimate, low-passed) against the reference, learn the
    reference while it is accepted, and replace it by a candidate that has held steady while the sensor
    turned (VQF's rejection, Laidig & Seel 2023 §IV-C).  The field is taken for disturbed (``S_MAG_DIST``:
    the heading correction stops) at once when the low-passed field leaves the gate, and over only after
    :data:`_MAG_CALM` seconds within it.  Returns the reported flag (:func:`_report_flag`), which has
    hysteresis of its own and changes nothing else."""
    c = p[P_C_MAGLP]
    ln = s[S_MAG_LPN] + c * (norm - s[S_MAG_LPN])
    ld = s[S_MAG_LPD] + c * (dip - s[S_MAG_LPD])
    s[S_MAG_LPN], s[S_MAG_LPD] = ln, ld
    tol_n, tol_d = p[P_MAG_NORM_TOL], p[P_MAG_DIP_TOL]
    ref = s[S_MAG_NORM]
    off_n, off_d = abs(ln - ref), abs(ld - s[S_DIP]) if dip_gate else 0.0
    _report_flag(s, off_n, tol_n * ref, off_d, tol_d, dt)
    if off_n > tol_n * ref or off_d > tol_d:
        s[S_MAG_DIST], s[S_MAG_CALM_T] = 1.0, 0.0
    else:
        s[S_MAG_CALM_T] += dt
        if s[S_MAG_CALM_T] >= _MAG_CALM:
            s[S_MAG_DIST] = 0.0
    cr = p[P_C_REF]
    if s[S_MAG_DIST] == 0.0:
        s[S_MAG_NORM] = ref + cr * (ln - ref)
        _set_dip(s, s[S_DIP] + cr * (ld - s[S_DIP]))
    # a candidate: the field as it has been lately, timed while the sensor turns and the field holds
    cn = s[S_CAND_N]
    if abs(ln - cn) <= tol_n * cn and (not dip_gate or abs(ld - s[S_CAND_D]) <= tol_d):
        g2 = s[S_LPG] * s[S_LPG] + s[S_LPG + 1] * s[S_LPG + 1] + s[S_LPG + 2] * s[S_LPG + 2]
        if g2 >= _MAG_NEW_GYRO * _MAG_NEW_GYRO:
            s[S_CAND_T] += dt
        s[S_CAND_N] = cn + cr * (ln - cn)
        s[S_CAND_D] += cr * (ld - s[S_CAND_D])
        new = p[P_MAG_NEW_TIME] if s[S_MAG_T] >= _MAG_NEW_FIRST else min(_MAG_NEW_FIRST, p[P_MAG_NEW_TIME])
        if s[S_MAG_DIST] != 0.0 and s[S_CAND_T] >= new:
            s[S_MAG_NORM] = s[S_CAND_N]
            _set_dip(s, s[S_CAND_D])
            s[S_MAG_DIST], s[S_MAG_CALM_T] = 0.0, _MAG_CALM
    else:
        s[S_CAND_N], s[S_CAND_D], s[S_CAND_T] = ln, ld, 0.0
    return s[S_MAG_FLAG] != 0.0


def _report_flag(s, off_n, tol_n, off_d, tol_d, dt):  # type: ignore[no-untyped-def]
    """The flag the receiver is told (``F_MAG_DISTURBED``), from the low-passed field's distance to the
    reference (``off_n`` in the field's unit against the norm tolerance ``tol_n``, ``off_d`` radians of dip
    against ``tol_d``): raised when either is beyond :data:`_FLAG_RAISE` times its tolerance, lowered once
    both have been within :data:`_FLAG_LOWER` times theirs for :data:`_FLAG_CALM` seconds in a row.  A
    field that wobbles about the gate's edge (a phone swung, a runner's) raises it once, not at every
    wobble; the gate itself (``S_MAG_DIST``) is left as it is, and so is the estimate."""
    if off_n <= _FLAG_LOWER * tol_n and off_d <= _FLAG_LOWER * tol_d:
        s[S_MAG_FLAG_T] += dt
    else:
        s[S_MAG_FLAG_T] = 0.0
    if off_n > _FLAG_RAISE * tol_n or off_d > _FLAG_RAISE * tol_d:
        s[S_MAG_FLAG] = 1.0
    elif s[S_MAG_FLAG_T] >= _FLAG_CALM:
        s[S_MAG_FLAG] = 0.0


def _clip_axis(s, j, v, r, w, x, y, z, ux, uy, uz, dt, fix):  # type: ignore[no-untyped-def]
    r"""Follow one accelerometer axis (reading ``v``, unit vector ``u`` in the sensor frame) at the rail
    ``r``; its slots from ``s[j]`` (the ``_C_*`` offsets): the two readings before the run, the run's
    length in samples, its sign, :math:`A = \sum_k R_k u \, dt` (the axis in the earth frame over the
    run), the first reading after it, whether it waits for the second, and how many of the two readings
    before it are known (:func:`_declip` guesses what the rail cut off).  The chunk under way waits while a run lasts
    (``hold``).  A run that flips rail or lasts beyond :data:`_RUN_MAX` is a stroke's, and so is what
    follows it at the rail (no reading before it is known).  Returns bits: :data:`_RUN_ON` (a run under
    way or waiting) and :data:`_RUN_STROKE` (a stroke's run ended)."""
    at = v >= r or v <= -r
    out = 0
    closed = s[j + _C_WAIT] != 0.0
    if closed:  # the run ended with the reading before this one: declip it now
        s[j + _C_WAIT] = 0.0
        out = _declip(s, j, r, v, not at, fix)
        if at:  # another run after one reading off the rail: before it, the last of the run and that one
            s[j + _C_Y2], s[j + _C_Y1] = s[j + _C_SIGN] * r, s[j + _C_YA]
        else:
            s[j + _C_Y2], s[j + _C_Y1] = s[j + _C_YA], v
        s[j + _C_KNOWN] = 2.0
    n = s[j + _C_N]
    if at:
        sg = 1.0 if v > 0.0 else -1.0
        out |= _RUN_ON
        if n > 0.0 and (sg != s[j + _C_SIGN] or n * dt >= _RUN_MAX):
            out, n = out | _RUN_STROKE, 0.0
            s[j + _C_KNOWN] = 0.0  # (the readings before it are those before the stroke's run)
        if n == 0.0:
            s[j + _C_SIGN] = sg
            s[j + _C_AXIS] = s[j + _C_AXIS + 1] = s[j + _C_AXIS + 2] = 0.0
        ex, ey, ez = _rotate(w, x, y, z, ux, uy, uz)
        s[j + _C_AXIS] += ex * dt
        s[j + _C_AXIS + 1] += ey * dt
        s[j + _C_AXIS + 2] += ez * dt
        s[j + _C_N] = n + 1.0
        return out
    if n > 0.0:  # the run has ended: the next reading too, then the guess
        s[j + _C_YA], s[j + _C_WAIT] = v, 1.0
        return out | _RUN_ON
    if not closed:
        s[j + _C_Y2], s[j + _C_Y1] = s[j + _C_Y1], v
        s[j + _C_KNOWN] = min(2.0, s[j + _C_KNOWN] + 1.0)
    return out


def _declip(s, j, r, yb, use_b, fix):  # type: ignore[no-untyped-def]
    r"""Guess what the rail cut off a run of ``n`` samples, as audio declippers do: the least-squares
    quadratic :math:`\hat y(k) = c_0 + c_1 k + c_2 k^2` through the two readings before the run (samples
    -2, -1) and the two after it (``n``, ``n + 1``; the second left out when ``use_b`` is false: it is at
    the rail again), and

    .. math:: X = \sum_{k=0}^{n-1} \max(\sigma \hat y(k) - r, 0)

    (:math:`\sigma` the rail's sign).  When ``fix``, :math:`\sigma X A / n` (the excess along the run's
    mean earth-frame axis; m/s² x s) joins the chunk under way.  A run shorter than :data:`_RUN_SHAPE`
    samples (an impact: no shape to fit), without two readings known before it, or whose quadratic peaks
    beyond :data:`_PEAK_MAX` times the rail (too violent to guess) is a stroke's: returns
    :data:`_RUN_STROKE`, else 0."""
    n = s[j + _C_N]
    s[j + _C_N] = 0.0
    if n < _RUN_SHAPE or s[j + _C_KNOWN] < 2.0:  # (no shape, or not two readings known before it)
        return _RUN_STROKE
    wb = 1.0 if use_b else 0.0
    ta, tb = n, n + 1.0
    # normal equations of the fit through (-2, y2), (-1, y1), (ta, ya), (tb, yb) weighted (1, 1, 1, wb)
    s0 = 3.0 + wb
    s1 = -3.0 + ta + wb * tb
    s2 = 5.0 + ta * ta + wb * tb * tb
    s3 = -9.0 + ta * ta * ta + wb * tb * tb * tb
    s4 = 17.0 + ta * ta * ta * ta + wb * tb * tb * tb * tb
    y2, y1, ya = s[j + _C_Y2], s[j + _C_Y1], s[j + _C_YA]
    q0 = y2 + y1 + ya + wb * yb
    q1 = -2.0 * y2 - y1 + ta * ya + wb * tb * yb
    q2 = 4.0 * y2 + y1 + ta * ta * ya + wb * tb * tb * yb
    det = s0 * (s2 * s4 - s3 * s3) - s1 * (s1 * s4 - s3 * s2) + s2 * (s1 * s3 - s2 * s2)
    if det == 0.0:
        return _RUN_STROKE
    c0 = (q0 * (s2 * s4 - s3 * s3) - s1 * (q1 * s4 - s3 * q2) + s2 * (q1 * s3 - s2 * q2)) / det
    c1 = (s0 * (q1 * s4 - q2 * s3) - q0 * (s1 * s4 - s3 * s2) + s2 * (s1 * q2 - q1 * s2)) / det
    c2 = (s0 * (s2 * q2 - s3 * q1) - s1 * (s1 * q2 - s2 * q1) + q0 * (s1 * s3 - s2 * s2)) / det
    sg = s[j + _C_SIGN]
    excess = peak = 0.0
    for i in range(int(n)):
        k = float(i)
        e = sg * (c0 + k * (c1 + k * c2))
        peak = max(peak, e)
        if e > r:
            excess += e - r
    if peak > _PEAK_MAX * r:
        return _RUN_STROKE
    if fix:
        c = sg * excess / n
        s[S_CUR] += c * s[j + _C_AXIS]
        s[S_CUR + 1] += c * s[j + _C_AXIS + 1]
        s[S_CUR + 2] += c * s[j + _C_AXIS + 2]
    return 0


def _found_range(s, ax, ay, az):  # type: ignore[no-untyped-def]
    """The accelerometer's full scale found from the readings when the source does not tell it: the
    largest reading on any axis, beyond :data:`_CLIP_LEAST` g, met exactly :data:`_CLIP_REPEAT` times (a
    clipped axis reads its rail again and again; a hand's real peaks never repeat to the last bit).
    Returns the full scale to test against (a hair under the rail: resampled data smear it), or 0."""
    m = max(abs(ax), abs(ay), abs(az))
    if m > s[S_ACC_PEAK]:
        s[S_ACC_PEAK], s[S_ACC_PEAK_N] = m, 1.0
    elif m == s[S_ACC_PEAK]:
        s[S_ACC_PEAK_N] += 1.0
        if s[S_ACC_PEAK_N] >= _CLIP_REPEAT and m >= _CLIP_LEAST * s[S_GNORM] and m > s[S_ACC_FOUND]:
            if s[S_ACC_FOUND] == 0.0:
                # the average took the clipped readings before the rail was known: it forgets them (the
                # tilt held where it is, the chunk waiting dropped) and learns on from calm chunks
                e = math.sqrt(s[S_E] * s[S_E] + s[S_E + 1] * s[S_E + 1] + s[S_E + 2] * s[S_E + 2])
                s[S_E], s[S_E + 1], s[S_E + 2] = 0.0, 0.0, e
                s[S_PREV] = s[S_PREV + 1] = s[S_PREV + 2] = s[S_PREV_T] = 0.0
            s[S_ACC_FOUND] = m
    return s[S_ACC_FOUND] * (1.0 - _CLIP_MARGIN)


def _motion_bias(s, p, w, x, y, z, psi):  # type: ignore[no-untyped-def]
    """Take the heading correction's rate, :math:`k_{heading}\\psi`, into the gyro bias about the earth
    vertical (in the sensor frame) with time constant ``motion_bias_tau``: a bias the sensor never rests
    long enough to learn (a phone in the hand) would otherwise hold the heading off by
    :math:`b / k_{heading}`.  Only until the sensor has rested ``bias_tau`` seconds in all: a bias
    learned at rest is better than one learned from a field that varies over the room (BROAD's trials,
    which start at rest, lost 0.3° with it).  The bias stays within ``bias_clip`` per axis."""
    ux, uy, uz = _rotate(w, -x, -y, -z, 0.0, 0.0, 1.0)
    c = p[P_C_MBIAS] * psi * p[P_DT]
    clip = p[P_BIAS_CLIP]
    s[S_BIAS] = max(-clip, min(clip, s[S_BIAS] + c * ux))
    s[S_BIAS + 1] = max(-clip, min(clip, s[S_BIAS + 1] + c * uy))
    s[S_BIAS + 2] = max(-clip, min(clip, s[S_BIAS + 2] + c * uz))


def _lag(s, p, psi, w, x, y, z, gx, gy, gz, moving, on):  # type: ignore[no-untyped-def]
    r"""The field's heading ``psi`` (radians off the estimate's) with the magnetometer's lag behind the gyro
    taken out: a field read :math:`\tau` late, seen through the estimate of now, is turned by
    :math:`\tau\omega_v` (:math:`\omega_v` the bias-corrected turn rate about the earth vertical), so
    :math:`\tau` is the regression of :math:`\psi` on :math:`\omega_v` and :math:`\psi - \hat\tau\omega_v`
    is used, :math:`\hat\tau` within 0 and ``mag_lag_max`` (a sensor read late, never early).  Both are
    regressed less their :data:`_LAG_HP` low-passes (products low-passed over ``mag_lag_tau`` seconds, of
    the samples whose field corrects the heading, in motion, with the rate changing by more than
    :data:`_LAG_CHANGE`; the low-passes run at rest too, and start anew after a sample without them,
    ``on`` false, as after a refused field, whose drift would read as a step of the error): a gyro's
    scale error also makes a turn's heading error follow the rate, but slowly, over the heading
    correction's time, and a lag follows its changes at once.  BROAD's magnetometer trails its gyro by
    about 10 ms (``benchmarks/HEADING.md``); a fixed compensation helped its fast rotation and hurt its
    fast combined trial: each sensor's own lag, learned as it runs."""
    _, _, wv = _rotate(w, x, y, z, gx, gy, gz)
    out = psi - mag_lag(s, p) * wv  # (as learned up to the sample before: no division)
    s[S_LAG_ON] = 1.0
    if on == 0.0:
        s[S_LAG_P], s[S_LAG_W] = psi, wv
    else:
        h = p[P_C_LAG_HP]
        s[S_LAG_P] += h * (psi - s[S_LAG_P])
        s[S_LAG_W] += h * (wv - s[S_LAG_W])
        dp, dw = psi - s[S_LAG_P], wv - s[S_LAG_W]
        if moving and dw * dw > _LAG_CHANGE * _LAG_CHANGE:
            c = p[P_C_LAG]
            xy = s[S_LAG_XY] + c * (dp * dw - s[S_LAG_XY])
            xx = s[S_LAG_XX] + c * (dw * dw - s[S_LAG_XX])
            s[S_LAG_XY], s[S_LAG_XX] = xy, xx
            s[S_LAG] = max(0.0, min(p[P_MAG_LAG_MAX], xy / xx))
    return out


def mag_lag(s, p):  # type: ignore[no-untyped-def]
    """The magnetometer's lag behind the gyro (s) :func:`_lag` takes out now: 0 until the turn rate has
    changed in motion (then held through rests and steady turns), and 0 with the learning off
    (``mag_lag_tau`` or ``mag_lag_max`` 0)."""
    return min(s[S_LAG], p[P_MAG_LAG_MAX]) if p[P_MAG_LAG_TAU] > 0.0 else 0.0


def _set_dip(s, d):  # type: ignore[no-untyped-def]
    """Robust mode's dip reference (its reference vector, ``S_NX``, ``S_NZ``, is paper mode's alone)."""
    s[S_DIP] = d


def _heading_gain(s, p, dt, flags):  # type: ignore[no-untyped-def]
    """The heading correction's fraction this sample: none while the field is disturbed, until the
    rejection time is used up (then a fraction of it); a plain mean of the accepted field at the start."""
    # the gyro's bias not yet known from rest: its own gain (the heading leans more on the field)
    k = p[P_ALPHA_MAG] if s[S_BIAS_T] >= p[P_BIAS_TAU] else p[P_ALPHA_MAG_UNRESTED]
    # the gyro's heading drift grows with the angle it turns (its scale error), not with time alone: the
    # gain grows with the sustained turn rate (the rest detector's 0.5 s low-pass of the gyro, in which a
    # back-and-forth motion cancels, as its drift does)
    if flags & F_ACC_SATURATED == 0 and p[P_ALPHA_MAG_TURN] > 0.0:
        g2 = s[S_LPG] * s[S_LPG] + s[S_LPG + 1] * s[S_LPG + 1] + s[S_LPG + 2] * s[S_LPG + 2]
        k = min(k + p[P_ALPHA_MAG_TURN] * math.sqrt(g2), 1.0)
    # a gyro at its told rail loses the turn beyond it: an accepted field takes the heading back faster
    if flags & F_GYRO_SATURATED and s[S_MAG_DIST] == 0.0 and k < p[P_ALPHA_MAG_UNRESTED]:
        k = p[P_ALPHA_MAG_UNRESTED]
    if flags & F_REST and p[P_ALPHA_MAG_REST] > k:
        k = p[P_ALPHA_MAG_REST]
    if s[S_MAG_DIST] != 0.0:
        if s[S_MAG_REJ_T] < p[P_MAG_REJECT_TIME]:
            s[S_MAG_REJ_T] += dt
            return 0.0
        return _MAG_LATE_FACTOR * k
    s[S_MAG_REJ_T] = max(s[S_MAG_REJ_T] - dt / _MAG_LATE_FACTOR, 0.0)
    t = s[S_MAG_T] + dt
    s[S_MAG_T] = t
    return max(k, dt / t)


def robust_update(s, p, gx, gy, gz, ax, ay, az, mx, my, mz, dt):  # type: ignore[no-untyped-def]
    """:func:`robust_step` and its result in one call: ``(flags, w, x, y, z)``.  Compiled by
    :mod:`pointat.maths.tqt.compiled`, it is :class:`~pointat.maths.tqt.TQTFilter`'s whole update: one
    call from Python a sample, the state an array that stays where it is."""
    flags = robust_step(s, p, gx, gy, gz, ax, ay, az, mx, my, mz, dt)
    return flags, s[S_QW], s[S_QX], s[S_QY], s[S_QZ]


def robust_bank(g, a, m, dt, here, state, p, flags):  # type: ignore[no-untyped-def]
    """:func:`robust_step` for every sensor present: ``g``, ``a``, ``m`` of shape (n, 3), ``here`` (n,)
    bool; ``state`` (n, :data:`STATE_SIZE`) and ``flags`` (n,) change in place.  Compiled by
    :mod:`pointat.maths.tqt.compiled` (it lives here so that numba's cache, keyed by this file, is
    renewed with any change to the step it inlines)."""
    for i in range(g.shape[0]):
        if here[i]:
            flags[i] = robust_step(state[i], p, g[i, 0], g[i, 1], g[i, 2], a[i, 0], a[i, 1], a[i, 2],
                                   m[i, 0], m[i, 1], m[i, 2], dt)  # fmt: skip


def robust_batch(g, a, m, dt, here, state, p, flags, q_out, flags_out):  # type: ignore[no-untyped-def]
    """:func:`robust_bank` over a block of samples in one call: ``g``, ``a``, ``m`` of shape (t, n, 3),
    ``dt`` (t,), ``here`` (t, n) bool; ``state`` and ``flags`` change in place as ``t`` calls of
    :func:`robust_bank` would change them, and every sample's quaternions and flags go to ``q_out``
    (t, n, 4) and ``flags_out`` (t, n).  What :meth:`~pointat.maths.tqt.TQTBank.update_batch` runs to
    replay a recording: numba's dispatch and the copies out paid once for the block, not a sample."""
    for t in range(g.shape[0]):
        d = dt[t]
        for i in range(g.shape[1]):
            if here[t, i]:
                flags[i] = robust_step(state[i], p, g[t, i, 0], g[t, i, 1], g[t, i, 2], a[t, i, 0],
                                       a[t, i, 1], a[t, i, 2], m[t, i, 0], m[t, i, 1], m[t, i, 2], d)  # fmt: skip
            flags_out[t, i] = flags[i]
            q_out[t, i, 0] = state[i, S_QW]
            q_out[t, i, 1] = state[i, S_QX]
            q_out[t, i, 2] = state[i, S_QY]
            q_out[t, i, 3] = state[i, S_QZ]
