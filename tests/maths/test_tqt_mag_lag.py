"""The magnetometer's lag behind the gyro, learned as the filter runs and taken out of the field's heading
(``mag_lag_tau``, ``mag_lag_max``; robust mode).

A field read late, seen through the estimate of now, is turned by the lag times the turn rate about the
vertical: a sensor turning steadily follows the late field and points behind by that much; the lag is the
regression of the field's heading error on the turn rate.
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
DT = 0.005
REST = 12.0  # s at rest first: the bias known


def _turning(
    lag: float, angle, rate, seconds: float, scale: float = 1.0, **settings: float
) -> tuple[TQTFilter, np.ndarray]:
    """A level sensor at rest, then turning about the vertical by ``angle(u)`` (rad, ``u`` seconds into the
    motion; ``rate`` its derivative), an ideal accelerometer, a gyro reading ``scale`` times the rate, the
    magnetometer read ``lag`` seconds late: the filter after it all and its error (degrees) at every
    sample."""
    t = np.arange(1, int(round((REST + seconds) / DT)) + 1) * DT
    q = quat_from_axis_angle([0.0, 0.0, 1.0], angle(np.clip(t - REST, 0.0, None)))
    late = quat_from_axis_angle([0.0, 0.0, 1.0], angle(np.clip(t - lag - REST, 0.0, None)))
    gyro = np.zeros((len(t), 3))
    gyro[:, 2] = np.where(t > REST, scale * rate(t - REST), 0.0)
    g, a = gyro.tolist(), quat_inverse_rotate(q, [0.0, 0.0, G]).tolist()
    m = quat_inverse_rotate(late, FIELD).tolist()
    f = TQTFilter(**settings)
    out = np.array([f.update(g[i], a[i], m[i], DT) for i in range(len(t))])
    return f, np.degrees(quat_angle(out, q))


def _swinging(lag: float) -> float:
    """The lag learned from 60 s of turning back and forth (1.5 rad at 0.3 Hz), the field ``lag`` late."""
    w = 2.0 * math.pi * 0.3
    f, _ = _turning(lag, lambda u: 1.5 * np.sin(w * u), lambda u: 1.5 * w * np.cos(w * u), 60.0)
    return f.magnetometer_lag


@pytest.mark.parametrize("lag", [0.004, 0.008, 0.016])
def test_the_lag_learned_is_the_magnetometers(lag):
    """Over and above what the integration's own half sample shows with a field on time (the gyro's rate
    held over the sample before it: 2.5 ms at 200 Hz), the lag learned is the field's, to a fifth of a
    millisecond."""
    on_time = _swinging(0.0)
    assert on_time == pytest.approx(0.5 * DT, abs=2e-4)
    assert _swinging(lag) - on_time == pytest.approx(lag, abs=2e-4)


def test_a_steady_turn_points_where_it_is_not_behind_the_late_field():
    """Turning at 1 rad/s with the field 10 ms late: the heading follows the late field 0.57° behind when
    the lag is not taken out (``mag_lag_max`` 0), and stays on the truth when it is."""
    steady = (lambda u: 1.0 * u, lambda u: np.ones_like(u))
    f, error = _turning(0.01, *steady, 100.0)
    assert f.magnetometer_lag == pytest.approx(0.01, abs=1e-4) and error[-1] < 0.01
    f, error = _turning(0.01, *steady, 100.0, mag_lag_max=0.0)
    assert f.magnetometer_lag == 0.0 and error[-1] == pytest.approx(math.degrees(0.01), rel=0.15)


@pytest.mark.parametrize("scale", [1.005, 0.995])
def test_a_gyros_scale_error_is_not_taken_for_a_lag(scale):
    """A gyro reading 0.5 % long leaves a steady turn's heading behind by a drift that follows the turn rate,
    as a late field's would, but over the heading correction's minute, not at once: the lag learned from
    the turn's start is a few milliseconds (0.5 % of the 0.5 s the error and the rate are taken less their
    low-passes over), and the heading ends within 2 % of the filter that learns no lag (before, the lag
    was held at its cap, 20 ms, and the heading was 10 % further off)."""
    steady = (lambda u: 1.0 * u, lambda u: np.ones_like(u))
    f, error = _turning(0.0, *steady, 200.0, scale=scale)
    _, unlearned = _turning(0.0, *steady, 200.0, scale=scale, mag_lag_max=0.0)
    assert f.magnetometer_lag < 0.005
    assert error[-1] == pytest.approx(unlearned[-1], rel=0.02)


def test_nothing_is_learned_from_a_sensor_that_never_turns():
    """Sixty seconds still, the gyro's bias and noise and the field's noise in the readings: nothing of the
    rate changes, so no lag (before, the noise's products held it at its cap)."""
    rng = np.random.default_rng(7)
    n = int(60.0 / DT)
    gyro = 0.01 + rng.normal(0.0, 0.005, (n, 3))
    mag = FIELD + rng.normal(0.0, 0.5, (n, 3))
    f = TQTFilter()
    lags = []
    for i in range(n):
        f.update(gyro[i].tolist(), [0.0, 0.0, G], mag[i].tolist(), DT)
        lags.append(f.magnetometer_lag)
    assert max(lags) == 0.0


def test_the_lag_is_none_once_its_learning_is_turned_off():
    """``retune(mag_lag_tau=0)`` turns the learning off, and what was learned is no longer taken out; any
    other retune leaves it as it was."""
    w = 2.0 * math.pi * 0.3
    f, _ = _turning(0.01, lambda u: 1.5 * np.sin(w * u), lambda u: 1.5 * w * np.cos(w * u), 20.0)
    learned = f.magnetometer_lag
    assert learned > 0.005
    f.retune(k=0.6)
    assert f.magnetometer_lag == learned
    f.retune(mag_lag_tau=0.0)
    assert f.magnetometer_lag == 0.0
    f.update([0.0, 0.0, 0.0], [0.0, 0.0, G], FIELD.tolist(), DT)
    assert f.magnetometer_lag == 0.0


@pytest.mark.parametrize("bias", [0.01, -0.01])
def test_a_refused_field_does_not_teach_a_lag_when_it_comes_back(bias):
    """Turning back and forth with the field on time (the half sample learned), then a magnet near the hand
    for 20 s (the field refused) while the gyro's bias moves: when the field comes back, the heading has
    drifted, and the lag's low-passes, stopped while it was refused, start anew rather than read the drift
    as a step of the error (before: 2.5 -> 0.0 or 7.9 ms)."""
    w = 2.0 * math.pi * 0.3
    t = np.arange(1, int(round((REST + 70.0) / DT)) + 1) * DT
    u = np.clip(t - REST, 0.0, None)
    q = quat_from_axis_angle([0.0, 0.0, 1.0], 1.5 * np.sin(w * u))
    gyro = np.zeros((len(t), 3))
    gyro[:, 2] = np.where(t > REST, 1.5 * w * np.cos(w * u), 0.0) + np.where(t > REST + 30.0, bias, 0.0)
    acc, mag = quat_inverse_rotate(q, [0.0, 0.0, G]), quat_inverse_rotate(q, FIELD)
    mag[(t > REST + 30.0) & (t < REST + 50.0)] *= 1.6
    f = TQTFilter()
    lags = []
    for g, a, m in zip(gyro.tolist(), acc.tolist(), mag.tolist(), strict=True):
        f.update(g, a, m, DT)
        lags.append(f.magnetometer_lag)
    before = lags[int((REST + 30.0) / DT) - 1]
    assert before == pytest.approx(0.5 * DT, abs=2e-4)
    after = np.array(lags[int((REST + 50.0) / DT) :])
    assert np.abs(after - before).max() < 3e-4
