"""The heading gain that grows with sustained turning (``k_heading_turn``, robust mode).

A gyro's scale error makes it drift by a fraction of the angle it turns, not by a rate: a sensor that
turns steadily leaves its heading behind by drift / gain, and the gain that holds it must grow with the
turn rate, while a sensor that moves back and forth (whose drift cancels) keeps the slow field gain.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pointat.maths.quaternion import quat_angle, quat_from_axis_angle, quat_inverse_rotate
from pointat.maths.tqt import TQTFilter
from tests.maths.mcghee_reference import magnetic_reference

G = 9.81
FIELD = 45.0 * magnetic_reference(math.radians(65.0))  # µT, NWU
DT = 0.01
REST = 12.0  # s: more than bias_tau (10 s) of rest, the bias known, k_heading in force
RATE = 1.0  # rad/s about the vertical
SCALE = 0.995  # the gyro reads 0.5 % short


def _steady_turn(seconds: float, rest: float = REST) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A sensor level at rest for ``rest`` seconds, then turning at RATE about the vertical: the truth and the
    readings of an ideal accelerometer and magnetometer and of a gyro SCALE short."""
    n = int(round((rest + seconds) / DT))
    angle = RATE * np.clip(np.arange(1, n + 1) * DT - rest, 0.0, None)
    q = quat_from_axis_angle([0.0, 0.0, 1.0], angle)
    acc = quat_inverse_rotate(q, [0.0, 0.0, G])
    mag = quat_inverse_rotate(q, FIELD)
    gyro = np.zeros((n, 3))
    gyro[angle > 0.0, 2] = SCALE * RATE
    return q, gyro, acc, mag


def _heading_error(f: TQTFilter, q, gyro, acc, mag) -> np.ndarray:
    g, a, m = gyro.tolist(), acc.tolist(), mag.tolist()
    out = np.array([f.update(g[i], a[i], m[i], DT) for i in range(len(g))])
    return np.degrees(quat_angle(out, q))


@pytest.mark.parametrize("k_heading_turn", [0.01, 0.0])
def test_a_steady_turn_leaves_the_heading_behind_by_the_drift_over_the_gain_with_the_turn_in_it(
    k_heading_turn,
):
    """After 450 s of turning at 1 rad/s (six time constants and more), the heading lags by the gyro's drift
    (0.5 % of 1 rad/s) over k_heading + k_heading_turn x 1 rad/s: 11.5° with the turn's part, 19.1° without
    (the gain of the moment all the same: drift / k_heading)."""
    q, gyro, acc, mag = _steady_turn(450.0)
    f = TQTFilter(k_heading_turn=k_heading_turn)
    error = _heading_error(f, q, gyro, acc, mag)
    drift = (1.0 - SCALE) * RATE
    expected = math.degrees(drift / (f.k_heading + k_heading_turn * RATE))
    assert error[-1] == pytest.approx(expected, rel=0.03)
    assert error[-int(20 / DT) :].max() - error[-int(20 / DT) :].min() < 0.05 * expected  # settled


def test_the_turn_adds_nothing_while_the_accelerometer_is_at_its_rail():
    """A full scale told below gravity: every reading is at the rail, the tilt carried by the gyro alone and
    the field seen through it suspect; the heading gain is the plain one, turning or not (the estimate
    the very one of k_heading_turn = 0), where with a free accelerometer the turn's part changes it."""
    q, gyro, acc, mag = _steady_turn(120.0)
    at_rail = [
        _heading_error(TQTFilter(acc_range=0.9 * G, k_heading_turn=c), q, gyro, acc, mag) for c in (0.01, 0.0)
    ]
    np.testing.assert_array_equal(at_rail[0], at_rail[1])
    free = [_heading_error(TQTFilter(k_heading_turn=c), q, gyro, acc, mag) for c in (0.01, 0.0)]
    assert free[0][-1] < free[1][-1] - 0.5


@pytest.mark.parametrize("told", [True, False])
def test_a_gyro_at_its_rail_leans_the_heading_on_the_field(told):
    """A turn at 1 rad/s read by a gyro told to clip at 0.5 rad/s (half the turn lost to the rail): while
    the gyro is at its rail and for a second after, the heading is corrected at k_heading_unrested (0.1, a
    gyro not to be trusted) instead of the slow gain of a known bias.  Not told, the filter cannot know.  (The
    rest before is long enough for the heading's plain-mean start, a gain of 1 / t, to be over.)"""
    q, gyro, acc, mag = _steady_turn(2.0, rest=100.0)
    rail = 0.5 * RATE
    clipped = np.clip(gyro, -rail, rail)
    f = TQTFilter(gyro_range=rail if told else 0.0)
    error = _heading_error(f, q, clipped, acc, mag)
    end = len(q) - 1
    assert error[end] > 45.0  # (57°: half the turn's 2 rad lost)
    g, a, m = [0.0, 0.0, 0.0], acc[-1].tolist(), mag[-1].tolist()
    for _ in range(int(0.9 / DT)):  # the sensor still, the gyro off its rail: the spell's second
        q_now = f.update(g, a, m, DT)
    left = float(np.degrees(quat_angle(np.array([q_now]), q[-1:])[0]))
    decay = left / error[end]
    assert decay == pytest.approx(math.exp(-0.1 * 0.9) if told else math.exp(-f.k_heading * 0.9), abs=0.02)
