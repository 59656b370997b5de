"""TQT on real data: the BROAD trial shipped in pointat/data (Laidig et al. 2021, CC BY 4.0).

Causal, from sample 0 (the filter starts from the first sample's TRIAD), one parameter set (the defaults),
output converted NWU -> ENU, scored with BROAD's own metric over the movement phase.  Peers on this trial
(pointat/data/README.md, BROAD README): VQF 1.99° (defaults) / 1.50° (tuned), ahrs Madgwick 2.11°,
imufusion 5.02°, TRIAD alone 13.03°.
"""

import numpy as np
import pytest

from pointat.maths.evaluation import BROAD_RATE, BROAD_SAMPLE, broad_rmse, load_broad
from pointat.maths.quaternion import matrix_to_quat, nwu_to_enu
from pointat.maths.tqt import TQTFilter, TQTFlags


@pytest.fixture(scope="module")
def trial():
    return load_broad(BROAD_SAMPLE)


def test_the_vendored_trial_loads(trial):
    n = 56940
    assert trial["t"].shape == (n,)
    assert trial["gyr"].shape == trial["acc"].shape == trial["mag"].shape == (n, 3)
    assert trial["q_gt"].shape == (n, 4) and trial["movement"].dtype == bool
    assert trial["movement"].sum() == 36007
    assert np.isnan(trial["q_gt"][:, 0]).sum() == 162
    assert np.diff(trial["t"]) == pytest.approx(1.0 / BROAD_RATE, abs=1e-6)
    # at rest the accelerometer reads +g up: rotated to ENU by the ground truth it points up
    first = trial["q_gt"][0]
    w, v = first[0], first[1:]
    a = trial["acc"][0]
    up = a + 2 * w * np.cross(v, a) + 2 * np.cross(v, np.cross(v, a))
    assert up[2] == pytest.approx(9.9, abs=0.1)


def test_metric_reproduces_the_published_triad_baseline(trial):
    """acc + mag TRIAD alone, no gyro: 13.03° on this trial in the BROAD export's README (ahrs-free check
    of the conventions, the metric and the NWU -> ENU conversion)."""
    up = trial["acc"] / np.linalg.norm(trial["acc"], axis=1, keepdims=True)
    west = np.cross(up, trial["mag"])
    west /= np.linalg.norm(west, axis=1, keepdims=True)
    q_nwu = matrix_to_quat(np.stack([np.cross(west, up), west, up], axis=-2))
    total, heading, incl = broad_rmse(nwu_to_enu(q_nwu), trial["q_gt"], trial["movement"])
    assert total == pytest.approx(13.03, abs=0.01)
    perfect = broad_rmse(trial["q_gt"], trial["q_gt"], trial["movement"])
    assert perfect == pytest.approx((0.0, 0.0, 0.0), abs=1e-5)


def run_filter(trial, **params):
    f = TQTFilter(**params)
    dt = 1.0 / BROAD_RATE
    g, a, m = trial["gyr"].tolist(), trial["acc"].tolist(), trial["mag"].tolist()
    q = np.array([f.update(g[i], a[i], m[i], dt) for i in range(len(g))])
    assert np.isfinite(q).all()
    return broad_rmse(nwu_to_enu(q), trial["q_gt"], trial["movement"])


def test_robust_mode_on_broad(trial):
    """Measured: total 1.56°, heading 1.38°, inclination 0.72° (VQF's defaults 1.99°).  Before issue 46's
    defaults (a 2 s acceleration average, the field learned only at rest) this trial was 1.58°, 1.59°
    before the heading gain that grows with turning (k_heading 0.05 then, 0.015 + 0.01 per rad/s now),
    and 1.75° with it before the magnetometer's lag was learned from the rate's changes alone (a lag at
    its cap learned from a steady turn): the defaults are chosen on BROAD and the Tyrex phones together
    (benchmarks/LOO.md)."""
    total, heading, incl = run_filter(trial)
    assert total < 1.7
    assert heading < 1.5
    assert incl < 0.8


def test_the_disturbance_flag_does_not_flicker_on_an_undisturbed_trial(trial):
    """The issue's replay: on this trial (undisturbed, slow rotation) the flag changed 1,220 times in 200 s,
    each change a status message to the receiver.  With the field low-passed and the hysteresis it is
    never raised (measured: 0)."""
    f = TQTFilter()
    dt = 1.0 / BROAD_RATE
    g, a, m = trial["gyr"].tolist(), trial["acc"].tolist(), trial["mag"].tolist()
    flags = []
    for i in range(len(g)):
        f.update(g[i], a[i], m[i], dt)
        flags.append(TQTFlags.MAG_DISTURBED in f.flags)
    changes = int(np.sum(np.diff(np.array(flags, dtype=int)) != 0))
    assert changes <= 4


def test_no_rail_is_found_where_the_accelerometer_does_not_clip(trial):
    """Not told a full scale, the filter looks for one in the data (a reading beyond 1.5 g met exactly three
    times): this trial's readings never clip, and nothing is flagged saturated."""
    f = TQTFilter()
    dt = 1.0 / BROAD_RATE
    g, a, m = trial["gyr"].tolist(), trial["acc"].tolist(), trial["mag"].tolist()
    for i in range(len(g)):
        f.update(g[i], a[i], m[i], dt)
        assert TQTFlags.ACC_SATURATED not in f.flags


def test_paper_mode_on_broad(trial):
    """The seeds' filter (k = 0.1, rho = 0.5).  Measured: total 3.26°, heading 2.36°, inclination 2.25°."""
    total, heading, incl = run_filter(trial, mode="paper")
    assert total < 3.5
    assert heading < 2.6
    assert incl < 2.5
