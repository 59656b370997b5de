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


def _turning(lag: float, angle, rate, seconds: float, **settings: float) -> tuple[TQTFilter, np.ndarray]:
    """A level sensor at rest, then turning about the vertical by ``angle(u)`` (rad, ``u`` seconds into the
    motion; ``rate`` its derivative), an ideal gyro and accelerometer, the magnetometer read ``lag``
    seconds late: the filter after it all and its error (degrees) at every sample."""
    t = np.arange(1, int(round((REST + seconds) / DT)) + 1) * DT
    q = quat_from_axis_angle([0.0, 0.0, 1.0], angle(np.clip(t - REST, 0.0, None)))
    late = quat_from_axis_angle([0.0, 0.0, 1.0], angle(np.clip(t - lag - REST, 0.0, None)))
    gyro = np.zeros((len(t), 3))
    gyro[:, 2] = np.where(t > REST, rate(t - REST), 0.0)
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
