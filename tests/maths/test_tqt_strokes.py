"""Robust ``tqt`` through a performer's strongest gestures: strokes, shakes, clipping and a saturated gyro,
on the simulated glove with known truth (:class:`pointat.devices.glove_sim.Burst`).

The hand points slowly (the demo script) and makes a 6 s burst from t = 10 s.  Claims held here, each
against the truth: 1 s after any burst up to 15 g, with ideal sensors or with the accelerometer clipped at
the glove's ±4 g (its full scale given to the filter), the estimate is within 2° of the truth; with
noise and a gyro bias, the burst adds at most 2° to the error the same motion has without it.  How the
same rules fare on real recordings (BROAD, clipped by hand) is in benchmarks/README.md.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pointat.devices.glove_sim import GRAVITY, Burst, GloveSimulator, MotionScript, Segment, default_script
from pointat.maths.tqt import TQTFilter, TQTFlags

RATE = 100.0
START = 10.0
RANGE = 4.0 * GRAVITY  # the glove's accelerometer: ±4 g per axis


def readings(bursts, seconds, *, noise, script=None, seed=0):
    """Truth and float readings (rad/s, m/s², gauss) of the simulated hand; noise: white noise and a gyro
    bias of about half a degree per second, as a glove that has rested only 2 s has left."""
    sim = GloveSimulator(script, rate_hz=RATE, seed=seed, bursts=bursts)
    truth = [sim.truth(k) for k in range(int(seconds * RATE))]
    q = np.array([t.q for t in truth])
    g, a, m = (np.array([getattr(t, name) for t in truth]) for name in ("omega", "specific_force", "field"))
    if noise:
        rng = np.random.default_rng(seed)
        g = g + np.radians([0.5, -0.3, 0.2]) + rng.normal(0.0, math.radians(0.3), g.shape)
        a = a + rng.normal(0.0, 0.02, a.shape)
        m = m + rng.normal(0.0, 0.002, m.shape)
    return q, g, a, m


def run(f, g, a, m):
    g, a, m = g.tolist(), a.tolist(), m.tolist()
    out, flags = [], []
    for i in range(len(g)):
        out.append(f.update(g[i], a[i], m[i], 1.0 / RATE))
        flags.append(f.flag_bits)
    return np.array(out), np.array(flags)


def error_deg(q_est, q):
    return np.degrees(2.0 * np.arccos(np.clip(np.abs(np.sum(q_est * q, axis=1)), 0.0, 1.0)))


BURSTS = [
    (kind, axis, peak)
    for kind in ("strokes", "shake")
    for axis in ("vertical", "pointing", "both")
    for peak in (3.0, 10.0, 15.0)
]


@pytest.mark.parametrize("clipped", [False, True], ids=["ideal_range", "clipped_4g"])
@pytest.mark.parametrize(("kind", "axis", "peak"), BURSTS)
def test_within_two_degrees_one_second_after_any_burst(kind, axis, peak, clipped):
    burst = Burst(START, 6.0, peak_g=peak, rate=5.0 if kind == "strokes" else 3.0, axis=axis, kind=kind)
    end = START + burst.length
    q, g, a, m = readings([burst], end + 3.0, noise=False)
    if clipped:
        a = np.clip(a, -RANGE, RANGE)
    q_est, flags = run(TQTFilter(acc_range=RANGE if clipped else 0.0), g, a, m)
    e = error_deg(q_est, q)
    after = int((end + 1.0) * RATE)
    assert e[after] <= 2.0
    assert e[int(START * RATE) : int(end * RATE)].max() <= 4.0  # and it never sent the sound far away
    during = flags[int(START * RATE) : int(end * RATE)]
    if peak >= 10.0:  # a performer's console says what happened, and when it is over
        assert (during & TQTFlags.SHAKING).any()
        assert not flags[after + 100] & TQTFlags.SHAKING
    if clipped and peak >= 10.0:
        assert (during & TQTFlags.ACC_SATURATED).any()
        assert not flags[after] & TQTFlags.ACC_SATURATED
    assert not (flags & TQTFlags.ACC_INVALID).any()  # no reading a hand makes is refused


@pytest.mark.parametrize("clipped", [False, True], ids=["ideal_range", "clipped_4g"])
@pytest.mark.parametrize("axis", ["vertical", "pointing"])
def test_with_noise_and_bias_a_burst_adds_at_most_two_degrees(axis, clipped):
    burst = Burst(START, 6.0, peak_g=15.0, rate=5.0, axis=axis)
    end = START + burst.length
    q, g, a, m = readings([burst], end + 2.0, noise=True)
    q0, g0, a0, m0 = readings([], end + 2.0, noise=True)
    if clipped:
        a = np.clip(a, -RANGE, RANGE)
    r = RANGE if clipped else 0.0
    e = error_deg(run(TQTFilter(acc_range=r), g, a, m)[0], q)
    e0 = error_deg(run(TQTFilter(acc_range=r), g0, a0, m0)[0], q0)
    after = int((end + 1.0) * RATE)
    assert e[after] - e0[after] <= 2.0


def test_clipped_strokes_without_the_full_scale_find_it_from_the_data():
    """The same clipped strokes, the filter not told the full scale: the clipped side of the strokes meets
    ±4 g to the bit again and again, the third time is taken for the rail (issue 46, point 3), the
    average forgets what it took of the first two, and the estimate is within a degree 1 s after, as
    told; the flag says ACC_SATURATED.  (Before the rail was found from the data, not told was 8° off.)"""
    burst = Burst(START, 6.0, peak_g=10.0, rate=5.0, axis="pointing")
    end = START + burst.length
    q, g, a, m = readings([burst], end + 2.0, noise=False)
    a = np.clip(a, -RANGE, RANGE)
    unknown, flags = run(TQTFilter(), g, a, m)
    unknown = error_deg(unknown, q)
    known = error_deg(run(TQTFilter(acc_range=RANGE), g, a, m)[0], q)
    after = int((end + 1.0) * RATE)
    assert unknown[after] < 1.0 and known[after] < 1.0
    assert any(TQTFlags.ACC_SATURATED in TQTFlags(int(f)) for f in flags[int(START * RATE) :])
    assert not any(TQTFlags.ACC_SATURATED in TQTFlags(int(f)) for f in flags[: int(START * RATE)])


def test_a_saturated_gyro_is_flagged_and_changes_nothing_else():
    """The demo's 90° rolls (141 °/s) through a gyro that clips at 90 °/s.  The flag is up through each
    spell and down a second after it; the estimate is the one the filter makes without the full scale: a
    quicker catch-up after the spell fixed these rolls but made every BROAD recording with a clipped gyro
    worse (benchmarks/README.md), so there is none."""
    q, g, a, m = readings([], 41.0, noise=False)
    r = math.radians(90.0)
    saturated = np.any(np.abs(g) > r, axis=1)
    g = np.clip(g, -r, r)
    known, flags = run(TQTFilter(gyro_range=r), g, a, m)
    np.testing.assert_array_equal(known, run(TQTFilter(), g, a, m)[0])
    ends = np.flatnonzero(saturated[:-1] & ~saturated[1:])
    assert len(ends) == 2  # the roll there and the roll back
    for i in ends:
        assert flags[i] & TQTFlags.GYRO_SATURATED and not flags[i + 110] & TQTFlags.GYRO_SATURATED
    assert not (flags[: np.flatnonzero(saturated)[0]] & TQTFlags.GYRO_SATURATED).any()


def test_accel_mag_only_tracking_follows_slow_motion_within_two_degrees():
    """use_gyro=false in robust mode: no 2 s average in a frame nothing tracks (it lagged by 17° on average
    and 58° at worst); the demo script at a third of its speed (peak 47 °/s), noise-free."""
    slow = MotionScript(
        [
            Segment(s.duration * 3.0, s.azimuth, s.elevation, s.roll, s.label)
            for s in default_script().segments
        ]
    )
    q, g, a, m = readings([], 120.0, noise=False, script=slow)
    robust = error_deg(run(TQTFilter(use_gyro=False), np.full_like(g, np.nan), a, m)[0], q)
    paper = error_deg(run(TQTFilter(K_PAPER, mode="paper", use_gyro=False), g, a, m)[0], q)
    assert robust[10:].max() <= 2.0
    assert robust[10:].mean() <= 2.0 * paper[10:].mean() + 0.05


K_PAPER = 50.0


def _translation(seconds=20.0, peak_g=2.6, freq=1.5, tilt_deg=30.0, bias_dps=0.5, rate=285.0):
    """A hand tilted 30° about y, shaken back and forth along the earth's x at 1.5 Hz, peak 2.6 g (a fast
    translation, as BROAD's trial 15), with a gyro bias it never rested to learn (0.5 °/s about x):
    truth (sensor -> NWU, constant) and float readings with a little noise."""
    n = int(seconds * rate)
    t = np.arange(n) / rate
    c, s = math.cos(math.radians(tilt_deg)), math.sin(math.radians(tilt_deg))
    r = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])  # sensor -> earth
    q = np.array([math.cos(math.radians(tilt_deg) / 2), 0.0, math.sin(math.radians(tilt_deg) / 2), 0.0])
    force = np.zeros((n, 3))
    force[:, 0] = peak_g * GRAVITY * np.sin(2.0 * np.pi * freq * t)
    force[:, 2] = GRAVITY
    a = force @ r + np.random.default_rng(0).normal(0.0, 0.02, (n, 3))
    m = np.tile(np.array([0.2, 0.0, -0.45]) @ r, (n, 1))
    g = np.tile(np.radians([bias_dps, 0.0, 0.0]), (n, 1))
    return q, g, a, m, rate


def _tilt_deg(q_est, q):
    """The angle between the estimated and the true vertical, in the sensor frame (degrees)."""

    def up(v):
        w, x, y, z = v
        return np.array([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])

    return math.degrees(math.acos(min(1.0, float(np.dot(up(q_est), up(q))))))


@pytest.mark.parametrize("told", [False, True], ids=["not_told", "told"])
def test_a_long_run_at_the_rail_is_declipped_not_left_out(told):
    """A fast translation clipped at ±2 g (43 % of the samples at the rail, in runs of tens of samples):
    the runs have a shape, and the quadratic through the readings about each guesses what the rail cut
    off, so the gravity average keeps being fed and the tilt ends as near the truth as unclipped (1.8°:
    the bias the hand never rested to learn).  Leaving the runs out with the chunks about them, as
    strokes, left the tilt to the biased gyro: 7.3° at the end (the rule before, told or not)."""
    q, g, a, m, rate = _translation()
    clipped = np.clip(a, -2.0 * GRAVITY, 2.0 * GRAVITY)
    ends = []
    for acc, r in ((a, 0.0), (clipped, 2.0 * GRAVITY if told else 0.0)):
        f = TQTFilter(acc_range=r)
        gl, al, ml = g.tolist(), acc.tolist(), m.tolist()
        for i in range(len(gl)):
            est = f.update(gl[i], al[i], ml[i], 1.0 / rate)
        ends.append(_tilt_deg(np.array(est), q))
    unclipped, clip = ends
    assert unclipped < 2.5
    assert clip < unclipped + 0.7


def test_an_axis_held_at_the_rail_does_not_stop_the_gravity_average():
    """Arm circles about the vertical at 1 turn a second, the centripetal 3 g along the sensor's x held at
    the ±2 g rail for 20 s: each run at the rail is cut at the longest declipped (a stroke's, then), and
    the chunk under way is held open at most that long, so the average goes on taking chunks (the turn
    budget lets them in) a little at a time.  Holding the chunk for as long as runs followed one another
    froze the average for the whole 20 s, and then took the 20 s chunk in one step."""
    from pointat.maths.tqt import step

    rate, seconds = 200.0, 20.0
    n = int(rate * seconds)
    w = 2.0 * math.pi
    f = TQTFilter(acc_range=2.0 * GRAVITY)
    ages = []
    for i in range(n):
        psi = w * i / rate  # the heading: the field turns in the sensor's frame as the arm goes round
        mag = [0.2 * math.cos(psi), -0.2 * math.sin(psi), -0.45]
        f.update([0.0, 0.0, w], [2.0 * GRAVITY, 0.0, GRAVITY], mag, 1.0 / rate)
        if i % 20 == 0:
            ages.append(f.export_state()[0][step.S_E_AGE])
    steps = np.diff(ages)
    assert ages[-1] > 10.0  # (the rule before: 2.8 s, frozen)
    assert steps.max() < 2.0  # no chunk of many seconds at once
