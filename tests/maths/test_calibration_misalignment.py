"""Cross-axis misalignment of the accelerometer and the gyro (pointat.maths.calibration): the model
(``physical = M @ ((raw - null) / scale)``, M unit-diagonal), its recovery from the six poses and the
three turns that ``calibrate`` already asks for, the file, and the simulated glove's sensor axes set
0.5-0.7 deg off (``SensorModel(acc_misalignment=..., gyro_misalignment=...)``) at the glove's noise.

Figures (seeds 0-19, the glove's default noise: 0.02 m/s² and 0.3 deg/s per sample, 12-bit counts):

* accelerometer, six poses of 200 samples: each cross-axis term within 0.017 deg (0.006 rms); the
  poses' residual 0.005-0.012 deg;
* gyro, three 90 deg turns in 1.5 s from the nulls of 200 samples at rest: 0.038 deg rms per term, the
  worst 0.10 deg (the turns' own noise, integrated, and the nulls'); three 180 deg turns in 2 s from
  1000 samples at rest: 0.015 deg rms, the worst 0.048 deg;
* gravity's direction over random orientations (each held for 50 samples): 0.66 deg rms (1.0 the
  worst) with Eqs. 29-30 alone, 0.025 deg rms (0.07 the worst) with the misalignment.
"""

import json
import math

import numpy as np
import pytest

from pointat.devices.glove_sim import GloveSimulator, SensorModel
from pointat.maths.calibration import (
    MISALIGNMENT_LIMIT,
    STANDARD_GRAVITY,
    Calibration,
    gyro_misalignment,
    gyro_null,
    gyro_scale,
    implausible,
    is_identity,
    six_position_accel,
    six_position_misalignment,
)
from pointat.maths.quaternion import quat_from_axis_angle, quat_inverse_rotate

G = STANDARD_GRAVITY
#: degrees, sensor axis i tipped towards board axis j: xy, xz, yx, yz, zx, zy
ACC_ANGLES = (0.6, -0.5, 0.7, 0.55, -0.65, 0.5)
GYRO_ANGLES = (-0.55, 0.6, 0.5, -0.7, 0.65, -0.6)
OFF = ~np.eye(3, dtype=bool)
#: the six poses, in calibrate's fixed order: +x, -x, +y, -y, +z, -z up
UP = [s * np.eye(3)[i] for i in range(3) for s in (1.0, -1.0)]


def expected(T):
    """The calibration's M for a sensor reading ``T @ v``: K = T^-1 with its diagonal made 1."""
    K = np.linalg.inv(T)
    M = K / np.diag(K)[np.newaxis, :]
    np.fill_diagonal(M, 1.0)
    return M


def q_up(d):
    """An orientation with board direction ``d`` pointing up."""
    d = np.asarray(d, dtype=float)
    c = float(d[2])
    if c > 1.0 - 1e-12:
        return np.array([1.0, 0.0, 0.0, 0.0])
    if c < -1.0 + 1e-12:
        return quat_from_axis_angle([1.0, 0.0, 0.0], math.pi)
    axis = np.cross(d, [0.0, 0.0, 1.0])
    return quat_from_axis_angle(axis / np.linalg.norm(axis), math.acos(c))


def misaligned(seed):
    return SensorModel(seed=seed, acc_misalignment=ACC_ANGLES, gyro_misalignment=GYRO_ANGLES)


def pose_means(sensor, rng, n=200):
    """The six poses' mean accelerometer counts (rows +x, -x, +y, -y, +z, -z up)."""
    means = []
    for d in UP:
        q = q_up(d)
        np.testing.assert_allclose(sensor.true_values(q, [0.0] * 3)[3:6], G * d, atol=1e-9)
        means.append(np.mean([sensor.counts(q, [0.0] * 3, rng)[3:6] for _ in range(n)], axis=0))
    return np.array(means)


def turn(sensor, rng, axis, degrees=90.0, seconds=1.5, rest=20, dt=0.01):
    """Gyro counts over a smooth turn about board ``axis`` (1 - cos rate), from rest to rest."""
    n = int(round(seconds / dt))
    peak = math.radians(degrees) / seconds
    rates = (
        [0.0] * rest + [peak * (1 - math.cos(2 * math.pi * (k + 0.5) / n)) for k in range(n)] + [0.0] * rest
    )
    return np.array([sensor.counts([1.0, 0, 0, 0], r * np.eye(3)[axis], rng)[:3] for r in rates], dtype=float)


def gyro_fit(sensor, rng, rest=200, **kw):
    null = gyro_null([sensor.counts([1.0, 0, 0, 0], [0.0] * 3, rng)[:3] for _ in range(rest)])
    angle = math.radians(kw.get("degrees", 90.0))
    A = np.column_stack(
        [
            [gyro_scale(turn(sensor, rng, k, **kw), 0.01, angle, a, null=null) for a in range(3)]
            for k in range(3)
        ]
    )
    return gyro_misalignment(A)


# --- the simulated sensor ---------------------------------------------------------------------------


def test_the_simulated_axes_are_off_by_the_angles_given():
    sensor = SensorModel.ideal(acc_misalignment=ACC_ANGLES)
    T = sensor.acc_misalignment
    np.testing.assert_allclose(np.linalg.norm(T, axis=1), 1.0, rtol=1e-15)  # directions, unit gain
    tipped = np.degrees(np.arctan(T[OFF] / np.repeat(np.diag(T), 2)))
    np.testing.assert_allclose(tipped, ACC_ANGLES, rtol=1e-12)
    np.testing.assert_allclose(expected(T)[OFF], -np.radians(ACC_ANGLES), rtol=0.02)  # to first order
    np.testing.assert_array_equal(
        SensorModel.ideal(gyro_misalignment=np.eye(3) * 2).gyro_misalignment, np.eye(3) * 2
    )
    for bad in ([0.5] * 5, np.full((3, 3), np.nan), np.eye(2)):
        with pytest.raises(ValueError, match="acc_misalignment must be a finite 3x3 matrix or 6 angles"):
            SensorModel(acc_misalignment=bad)


def test_without_cross_axis_errors_the_simulated_glove_is_what_it_was_to_the_bit():
    plain = GloveSimulator(rate_hz=100.0)
    identity = GloveSimulator(
        rate_hz=100.0, sensor=SensorModel(seed=0, acc_misalignment=np.eye(3), gyro_misalignment=np.eye(3))
    )
    assert plain.sensor.acc_misalignment is None and plain.sensor.gyro_misalignment is None
    for k in range(0, 6000, 37):
        assert plain.sample(k).frame.channels == identity.sample(k).frame.channels


# --- recovery ---------------------------------------------------------------------------------------


def test_exact_poses_give_the_misalignment_exactly_in_any_order_and_with_an_axis_reversed():
    T = SensorModel.ideal(acc_misalignment=ACC_ANGLES).acc_misalignment
    null, gain = np.array([2051.5, 1987.25, 2100.0]), np.array([41.5, 39.75, -40.25])  # z mounted reversed
    poses = null + np.array([gain * (T @ (G * d)) for d in UP])
    fit = six_position_misalignment(poses, order="fixed")
    np.testing.assert_allclose(fit.null, null, rtol=1e-14)
    np.testing.assert_allclose(fit.misalignment, expected(T), atol=1e-14)
    assert fit.residual < 1e-12 and np.all(np.diag(fit.misalignment) == 1.0)
    cal = Calibration(acc_null=fit.null, acc_scale=fit.scale, acc_misalignment=fit.misalignment)
    f = quat_inverse_rotate(q_up([0.3, -0.5, 0.8] / np.linalg.norm([0.3, -0.5, 0.8])), [0.0, 0.0, G])
    np.testing.assert_allclose(cal.apply("acc", null + gain * (T @ f)), f, atol=1e-12)
    # the scales are Eqs. 29-30's to second order in the angles
    np.testing.assert_allclose(fit.scale, six_position_accel(poses, order="fixed")[1], rtol=5e-4)
    gain = np.abs(gain)  # positive sensitivities: any order of the rows
    poses = null + np.array([gain * (T @ (G * d)) for d in UP])
    perm = np.random.default_rng(1).permutation(6)
    shuffled = six_position_misalignment(poses[perm])
    np.testing.assert_allclose(shuffled.misalignment, expected(T), atol=1e-14)


@pytest.mark.parametrize("seed", range(10))
def test_six_poses_recover_the_accelerometer_misalignment_within_005_deg(seed):
    sensor = misaligned(seed)
    fit = six_position_misalignment(pose_means(sensor, np.random.default_rng([seed, 1])), G)
    truth = expected(sensor.acc_misalignment)
    assert np.all(np.abs(np.degrees(truth[OFF])) > 0.45)  # what is to be found: 0.5-0.7 deg
    error = np.degrees(np.abs(fit.misalignment - truth)[OFF])
    assert error.max() < 0.05, error  # 0.006-0.017 deg
    assert math.degrees(fit.residual) < 0.03  # the poses agree: 0.005-0.011 deg
    np.testing.assert_allclose(fit.null, 2048.0, atol=1.0)
    np.testing.assert_allclose(fit.scale, 1.0 / 0.0192, rtol=1e-3)


def tilted(d, degrees, rng):
    """``d`` tipped by ``degrees`` in a random direction."""
    off = rng.normal(size=3)
    off -= (off @ d) * d
    a = math.radians(degrees)
    return d * math.cos(a) + off / np.linalg.norm(off) * math.sin(a)


def test_poses_a_degree_off_show_in_the_residual_and_the_misalignment_as_far():
    sensor = misaligned(0)
    rng = np.random.default_rng(3)
    residuals, errors = [], []
    for _ in range(10):  # each pose a degree off its axis, at random: held by hand
        qs = [q_up(tilted(d, 1.0, rng)) for d in UP]
        means = [np.mean([sensor.counts(q, [0.0] * 3, rng)[3:6] for _ in range(50)], axis=0) for q in qs]
        fit = six_position_misalignment(means)
        residuals.append(math.degrees(fit.residual))
        errors.append(np.degrees(fit.misalignment - expected(sensor.acc_misalignment))[OFF])
    # the residual estimates the misalignment's error (within ~15 % on average): calibrate refuses it
    assert 0.5 < np.sqrt(np.mean(np.square(residuals))) < 1.0, residuals
    assert 0.4 < np.sqrt(np.mean(np.square(errors))) < 1.0


@pytest.mark.parametrize("seed", range(10))
def test_three_turns_recover_the_gyro_misalignment(seed):
    sensor = misaligned(seed)
    truth = expected(sensor.gyro_misalignment)
    assert np.all(np.abs(np.degrees(truth[OFF])) > 0.45)
    # what calibrate asks for: 90 deg turns from the nulls of 200 samples at rest
    scale, M = gyro_fit(sensor, np.random.default_rng([seed, 2]))
    error = np.degrees(np.abs(M - truth)[OFF])
    assert error.max() < 0.12 and np.sqrt(np.mean(error**2)) < 0.07, error  # 0.036 deg rms over the seeds
    np.testing.assert_allclose(scale, 1.0 / math.radians(0.1), rtol=2e-3)
    # half turns from the nulls of 1000 samples: within 0.05 deg
    scale, M = gyro_fit(sensor, np.random.default_rng([seed, 3]), rest=1000, degrees=180.0, seconds=2.0)
    error = np.degrees(np.abs(M - truth)[OFF])
    assert error.max() < 0.05, error  # 0.014 deg rms, the worst 0.04


@pytest.mark.parametrize("seed", range(3))
def test_calibrated_gravity_direction_error_drops_from_06_to_under_01_deg(seed):
    sensor = misaligned(seed)
    rng = np.random.default_rng([seed, 4])
    poses = pose_means(sensor, rng)
    null, scale = six_position_accel(poses, G)
    plain = Calibration(acc_null=null, acc_scale=scale)  # Eqs. 29-30 alone
    fit = six_position_misalignment(poses, G)
    full = Calibration(acc_null=fit.null, acc_scale=fit.scale, acc_misalignment=fit.misalignment)
    before, after = [], []
    for q in rng.normal(size=(100, 4)):
        q /= np.linalg.norm(q)
        truth = quat_inverse_rotate(q, [0.0, 0.0, 1.0])
        counts = np.mean([sensor.counts(q, [0.0] * 3, rng)[3:6] for _ in range(50)], axis=0)  # held still
        for cal, errors in ((plain, before), (full, after)):
            f = cal.apply("acc", counts)
            errors.append(math.degrees(math.acos(min(1.0, f @ truth / np.linalg.norm(f)))))
    rms = [math.sqrt(np.mean(np.square(e))) for e in (before, after)]
    assert 0.4 < rms[0] < 0.9, rms  # 0.6-0.7 deg
    assert max(after) < 0.1 and rms[1] < 0.04, (max(after), rms)


def test_degenerate_input_is_refused():
    with pytest.raises(ValueError, match="shape"):
        six_position_misalignment(np.zeros((5, 3)))
    with pytest.raises(ValueError, match="apart"):
        six_position_misalignment(np.zeros((6, 3)) + np.arange(6)[:, None])
    y_as_z = np.array([2048.0 + 100.0 * np.array([d[0], d[1], d[1]]) for d in UP])  # z reads y
    with pytest.raises(ValueError, match="the six poses do not tell the three axes apart"):
        six_position_misalignment(y_as_z, order="fixed")
    A = np.diag([573.0, 560.0, 580.0])
    for bad, said in (
        (np.eye(2), "finite 3x3"),
        (A + np.nan, "finite 3x3"),
        (A[:, [0, 2, 1]], "the turn about y showed most on gyro z.*mislabelled"),
        (np.diag([573.0, 560.0, 0.0]), "the turn about z showed most on gyro x.*or one was not made"),
    ):
        with pytest.raises(ValueError, match=said):
            gyro_misalignment(bad)
    twin = np.array([[1.0, 1.0 - 1e-9, 0], [1.0 - 1e-9, 1.0, 0], [0, 0, 1.0]]) * 573.0  # y reads x
    with pytest.raises(ValueError, match="the three turns do not tell the three axes apart"):
        gyro_misalignment(twin)


# --- the file ---------------------------------------------------------------------------------------


def calibration():
    return Calibration(
        gyro_null=[2051.0, 2046.0, 2049.5],
        gyro_scale=[573.1, 560.2, 580.3],
        acc_null=[2040.0, 2060.0, 2050.0],
        acc_scale=[52.0, 49.0, 51.0],
        gyro_misalignment=expected(SensorModel.ideal(gyro_misalignment=GYRO_ANGLES).gyro_misalignment),
        acc_misalignment=expected(SensorModel.ideal(acc_misalignment=ACC_ANGLES).acc_misalignment),
    )


def test_the_misalignment_round_trips_through_the_file(tmp_path):
    cal = calibration()
    path = tmp_path / "glove.json"
    cal.save(path)
    again = Calibration.load(path)
    assert again == cal
    for name in ("gyro_misalignment", "acc_misalignment"):
        assert getattr(again, name).tobytes() == getattr(cal, name).tobytes()  # to the bit
    data = json.loads(path.read_text())
    assert data["version"] == 1 and data["acc"]["misalignment"] == cal.acc_misalignment.tolist()
    assert again != Calibration(
        **{k: getattr(cal, k) for k in ("gyro_null", "gyro_scale", "acc_null", "acc_scale")}
    )
    assert json.loads(Calibration().to_json())["gyro"]["misalignment"] == np.eye(3).tolist()


def test_a_file_written_before_the_misalignment_loads_as_the_identity(tmp_path):
    path = tmp_path / "old.json"
    path.write_text(
        '{"format": "pointat-calibration", "version": 1,\n'
        ' "gyro": {"null": [2051.0, 2046.0, 2049.5], "scale": [573.0, 560.0, 580.0]},\n'
        ' "acc": {"null": [2040.0, 2060.0, 2050.0], "scale": [52.0, 49.0, 51.0]},\n'
        ' "mag": {"null": [2030.0, 2070.0, 2000.0], "scale": [1000.0, 1100.0, 950.0], "soft_iron": null}}\n'
    )
    old = Calibration.load(path)
    assert is_identity(old.gyro_misalignment) and is_identity(old.acc_misalignment)
    raw = np.array([[2100.0, 2000.0, 2500.0]])
    np.testing.assert_array_equal(old.apply("acc", raw), (raw - old.acc_null) / old.acc_scale)  # as before
    assert Calibration.from_json('{"version": 1, "acc": {"misalignment": null}}') == Calibration()


@pytest.mark.parametrize(
    "misalignment, key",
    [
        ([1, 0, 0], "acc.misalignment[0]"),
        ([[1, 0, 0], [0, 1, 0]], "acc.misalignment"),
        ("identity", "acc.misalignment"),
        ([[1, 0, 0], [0, 1, 0], [0, 0]], "acc.misalignment[2]"),
        ([[1, 0, 0], [0, 1, float("inf")], [0, 0, 1]], "acc.misalignment[1]"),
        ([[1, 0, 0], [0, True, 0], [0, 0, 1]], "acc.misalignment[1]"),
        ([[1.01, 0, 0], [0, 1, 0], [0, 0, 1]], "acc.misalignment"),  # a scale in the wrong place
    ],
)
def test_a_bad_misalignment_names_the_file_and_the_key(tmp_path, misalignment, key):
    data = calibration().to_dict()
    data["acc"]["misalignment"] = misalignment
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))  # (inf is written Infinity, which the reader takes, and refuses)
    with pytest.raises(ValueError) as info:
        Calibration.load(path)
    message = str(info.value)
    assert message.startswith(f"calibration file {path}: key '{key}'"), message
    data["gyro"]["extra"] = 1
    with pytest.raises(ValueError, match="key 'gyro.extra'"):
        Calibration.from_dict(data | {"acc": calibration().to_dict()["acc"]})
    mag = calibration().to_dict()
    mag["mag"]["misalignment"] = np.eye(3).tolist()  # the magnetometer has its soft iron instead
    with pytest.raises(ValueError, match="key 'mag.misalignment'"):
        Calibration.from_dict(mag)


def test_the_constructor_validates_the_misalignment():
    with pytest.raises(ValueError, match="acc_misalignment must be a finite 3x3 matrix"):
        Calibration(acc_misalignment=np.eye(2))
    with pytest.raises(ValueError, match="gyro_misalignment must be a finite 3x3 matrix"):
        Calibration(gyro_misalignment=np.full((3, 3), np.nan))
    with pytest.raises(ValueError, match="gyro_misalignment must have 1 on its diagonal"):
        Calibration(gyro_misalignment=np.eye(3) * 2)
    assert is_identity(Calibration(acc_misalignment=None).acc_misalignment)


def test_apply_undoes_the_misalignment_and_the_identity_is_not_applied():
    cal = calibration()
    rng = np.random.default_rng(9)
    w, a = rng.normal(size=(2, 50, 3))
    raw_w = cal.gyro_null + cal.gyro_scale * (w @ np.linalg.inv(cal.gyro_misalignment).T)
    raw_a = cal.acc_null + cal.acc_scale * (a @ np.linalg.inv(cal.acc_misalignment).T)
    np.testing.assert_allclose(cal.apply("gyro", raw_w), w, atol=1e-12)
    np.testing.assert_allclose(cal.apply("acc", raw_a), a, atol=1e-12)
    raw = np.array([[-0.0, np.inf, 1.0]])  # the identity is skipped: -0 and inf pass as they are
    assert (
        np.signbit(Calibration().apply("acc", raw)[0, 0]) and Calibration().apply("gyro", raw)[0, 1] == np.inf
    )


def test_implausible_names_a_misalignment_beyond_5_deg_or_not_finite():
    factor = [1e-3] * 9
    assert implausible(calibration(), factor, {}) == []
    just = np.eye(3)
    just[0, 2] = MISALIGNMENT_LIMIT  # 5 deg: let through
    assert implausible(Calibration(acc_misalignment=just), factor, {}) == []
    beyond = np.eye(3)
    beyond[2, 1] = -0.09
    (problem,) = implausible(Calibration(acc_null=[2048.0] * 3, acc_misalignment=beyond), factor, {})
    assert problem.startswith("acc.misalignment has a cross-axis term of -0.09 (5.2 deg, z from y)"), problem
    cal = Calibration()
    cal.gyro_misalignment[1, 0] = np.nan  # (set after the constructor, which refuses it)
    assert implausible(cal, factor, {}) == [
        "gyro.misalignment is not finite: [[1.0, 0.0, 0.0], [nan, 1.0, 0.0], [0.0, 0.0, 1.0]]"
    ]
