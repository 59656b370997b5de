"""Tests for pointat.maths.fusion against seeded synthetic ground truth."""

import math

import numpy as np
import pytest

from pointat.maths.fusion import (
    R_UNWRAPPED,
    ComplementaryFilter,
    GyroIntegrator,
    RollDistance,
    accmag_matrix,
    accmag_quat,
    exact_increment,
    orthonormalize,
    torre_increment,
)
from pointat.maths.quaternion import (
    euler_to_quat,
    matrix_to_quat,
    quat_angle,
    quat_from_axis_angle,
    quat_inverse_rotate,
    quat_multiply,
    quat_to_matrix,
    rotvec_to_quat,
)

G = 9.80665
DIP = np.radians(64.0)
FIELD_NWU = 0.48 * np.array([np.cos(DIP), 0.0, -np.sin(DIP)])  # gauss, north and down
UP_NWU = np.array([0.0, 0.0, G])


def rodrigues(axis, angle):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def random_rotations(n, seed):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    return quat_to_matrix(q / np.linalg.norm(q, axis=-1, keepdims=True))


def assert_rotation(R, tol=1e-12):
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=tol)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=tol)


# --- increments ------------------------------------------------------------------------------------


def test_increments_single_axis_are_exact():
    for axis in np.eye(3):
        rate = 2.0 * axis
        for inc in (torre_increment, exact_increment):
            np.testing.assert_allclose(inc(rate, 0.3), rodrigues(axis, 0.6), atol=1e-15)


def test_exact_increment_matches_rodrigues_and_is_smooth_at_zero():
    rng = np.random.default_rng(1)
    rates = rng.normal(size=(200, 3)) * 3
    dts = rng.uniform(0.001, 1.0, 200)
    got = exact_increment(rates, dts)
    for r, dt, R in zip(rates, dts, got, strict=True):
        np.testing.assert_allclose(R, rodrigues(r, np.linalg.norm(r) * dt), atol=1e-14)
    np.testing.assert_array_equal(exact_increment([0, 0, 0], 0.01), np.eye(3))
    small = exact_increment([1e-9, 0, 0], 1.0)
    np.testing.assert_allclose(small, rodrigues([1, 0, 0], 1e-9), atol=1e-20)


def test_torre_increment_is_first_order():
    rate = np.array([0.7, -1.3, 2.1])
    errs = []
    for dt in (1e-2, 5e-3):
        diff = torre_increment(rate, dt) - exact_increment(rate, dt)
        errs.append(np.abs(diff).max())
        assert_rotation(torre_increment(rate, dt))
    # the per-step error is O(dt^2): halving dt quarters it
    assert errs[0] / errs[1] == pytest.approx(4.0, rel=0.02)
    # Torre's product order: yaw (w) outermost, roll (u) innermost
    dt = 0.1
    expected = (
        rodrigues([0, 0, 1], 2.1 * dt) @ rodrigues([0, 1, 0], -1.3 * dt) @ rodrigues([1, 0, 0], 0.7 * dt)
    )
    np.testing.assert_allclose(torre_increment(rate, dt), expected, atol=1e-15)


def test_flat_fast_paths_match_vectorised_increments():
    rng = np.random.default_rng(2)
    R0 = random_rotations(1, 3)[0]
    for mode, inc in (("exact", exact_increment), ("torre", torre_increment)):
        integ = GyroIntegrator(R0, mode=mode, renormalize_every=10**9)
        for rate in rng.normal(size=(20, 3)) * 4:
            expected = integ.R @ inc(rate, 0.01)
            np.testing.assert_allclose(integ.update(rate, 0.01), expected, atol=1e-15)
        # tiny angles take the series branch
        expected = integ.R @ inc([1e-6, -2e-6, 3e-6], 0.01)
        np.testing.assert_allclose(integ.update([1e-6, -2e-6, 3e-6], 0.01), expected, atol=1e-16)


def test_orthonormalize():
    rng = np.random.default_rng(4)
    R = random_rotations(100, 5)
    noisy = R + 1e-3 * rng.normal(size=R.shape)
    out = orthonormalize(noisy)
    for Ri, Oi in zip(R, out, strict=True):
        assert_rotation(Oi)
        np.testing.assert_allclose(Oi, Ri, atol=5e-3)
    np.testing.assert_allclose(orthonormalize(R), R, atol=1e-14)
    # a reflection is mapped to a proper rotation
    assert np.linalg.det(orthonormalize(np.diag([1.0, 1.0, -1.0]))) == pytest.approx(1.0)
    with pytest.raises(ValueError):
        orthonormalize(np.full((3, 3), np.nan))


# --- integrator ------------------------------------------------------------------------------------


def test_integrator_side_constant_rate_against_analytic():
    """Body rates: C(t) = C0 expm([w t x]); from a non-identity C0 this fixes the side."""
    C0 = random_rotations(1, 6)[0]
    rate = np.array([0.4, -0.9, 1.7])
    dt, n = 0.01, 1000
    integ = GyroIntegrator(C0, mode="exact")
    for _ in range(n):
        R = integ.update(rate, dt)
    analytic = C0 @ rodrigues(rate, np.linalg.norm(rate) * n * dt)
    np.testing.assert_allclose(R, analytic, atol=1e-12)
    wrong_side = rodrigues(rate, np.linalg.norm(rate) * n * dt) @ C0
    assert np.abs(R - wrong_side).max() > 0.1
    q = quat_multiply(matrix_to_quat(C0), rotvec_to_quat(rate * n * dt))
    assert quat_angle(integ.quaternion, q) < 1e-12


def test_torre_mode_drift_is_first_order_in_dt():
    C0 = random_rotations(1, 7)[0]
    rate = np.array([0.4, -0.9, 1.7])
    T = 10.0
    analytic = C0 @ rodrigues(rate, np.linalg.norm(rate) * T)
    errors = []
    for dt in (0.01, 0.005):
        integ = GyroIntegrator(C0, mode="torre")
        for _ in range(round(T / dt)):
            R = integ.update(rate, dt)
        assert_rotation(R)
        errors.append(quat_angle(matrix_to_quat(R), matrix_to_quat(analytic)))
    # bound: t * dt * |w|^2 / 2 (commutator of the three factors)
    assert errors[0] < T * 0.01 * np.dot(rate, rate) / 2
    assert errors[0] / errors[1] == pytest.approx(2.0, rel=0.05)


@pytest.mark.slow
def test_integrator_stays_a_rotation_for_a_million_steps():
    rng = np.random.default_rng(8)
    rates = rng.normal(size=(1_000_000, 3)) * 3.0
    integ = GyroIntegrator(mode="exact", renormalize_every=100)
    R = integ.update_many(rates, 0.01)
    assert np.abs(R.T @ R - np.eye(3)).max() < 1e-9
    assert np.abs(R.T @ R - np.eye(3)).max() < 1e-14  # in fact, to rounding
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-14)


def test_update_many_equals_repeated_update():
    rng = np.random.default_rng(15)
    rates = rng.normal(size=(500, 3)) * 2.0
    dts = rng.uniform(0.005, 0.02, 500)
    for mode in ("exact", "torre"):
        a = GyroIntegrator(mode=mode, renormalize_every=7)
        b = GyroIntegrator(mode=mode, renormalize_every=7)
        for rate, dt in zip(rates, dts, strict=True):
            Ra = a.update(rate, dt)
        np.testing.assert_array_equal(b.update_many(rates, dts), Ra)
    with pytest.raises(ValueError):
        GyroIntegrator().update_many(np.zeros((4, 2)), 0.01)


def test_integrator_reset_and_errors():
    integ = GyroIntegrator(mode="torre")
    integ.update([1.0, 2.0, 3.0], 0.1)
    integ.reset()
    np.testing.assert_array_equal(integ.R, np.eye(3))
    C0 = random_rotations(1, 9)[0]
    integ.reset(C0)
    np.testing.assert_allclose(integ.R, C0, atol=1e-15)
    with pytest.raises(ValueError):
        integ.update([np.nan, 0, 0], 0.01)
    with pytest.raises(ValueError):
        integ.update([0, 0, 0], -0.01)
    np.testing.assert_allclose(integ.R, C0, atol=1e-15)
    with pytest.raises(ValueError):
        integ.reset(np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ValueError):
        GyroIntegrator(mode="euler")


# --- accelerometer + magnetometer ------------------------------------------------------------------


def test_accmag_recovers_random_orientations():
    Rs = random_rotations(500, 10)
    for R in Rs:
        acc = R.T @ UP_NWU  # what the sensor reads: earth vectors in sensor coordinates
        mag = R.T @ FIELD_NWU
        C = accmag_matrix(acc, mag)
        np.testing.assert_allclose(C, R, atol=1e-12)
        assert_rotation(C)
        q = accmag_quat(acc * 3.0, mag * 0.1)  # magnitudes do not matter
        assert q[0] >= 0
        np.testing.assert_allclose(quat_to_matrix(q), R, atol=1e-12)


def test_accmag_torre_columns_corrected():
    """Torre's inverse-orientation columns: north ~ mag (after removing dip), up = acc, west = up x north."""
    R = random_rotations(1, 11)[0]
    acc, mag = R.T @ UP_NWU, R.T @ FIELD_NWU
    inv = accmag_matrix(acc, mag).T  # earth -> sensor, Torre's Orientation^-1
    a1, a2, a3 = inv[:, 0], inv[:, 1], inv[:, 2]
    np.testing.assert_allclose(a3, acc / G, atol=1e-14)
    # Torre's literal first column (mag / H) is not orthogonal to the third because of the dip
    assert abs(np.dot(mag / np.linalg.norm(mag), a3)) == pytest.approx(np.sin(DIP), abs=1e-12)
    assert abs(np.dot(a1, a3)) < 1e-14
    np.testing.assert_allclose(a2, np.cross(a3, a1), atol=1e-14)


@pytest.mark.parametrize(
    "acc, mag",
    [
        ([0, 0, 0], [1, 0, 0]),
        ([0, 0, 9.8], [0, 0, 0]),
        ([np.nan, 0, 9.8], [1, 0, 0]),
        ([0, 0, 9.8], [0, np.inf, 0]),
        ([0, 0, 9.8], [0, 0, -0.5]),
        ([1, 1, 1], [2, 2, 2 + 1e-9]),
    ],
)
def test_accmag_invalid_returns_none(acc, mag):
    assert accmag_matrix(acc, mag) is None
    assert accmag_quat(acc, mag) is None


# --- complementary filter --------------------------------------------------------------------------


def simulate(n, dt, seed, bias=(0.01, -0.008, 0.006), gyro_noise=0.01, acc_noise=0.05, mag_noise=0.005):
    """A hand waving smoothly; exact body rates, truth integrated with the exponential map."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    omega = np.stack(
        [1.5 * np.sin(0.7 * t), 1.0 * np.sin(1.1 * t + 1.0), 2.0 * np.sin(0.5 * t + 2.0)], axis=-1
    )
    q = np.empty((n, 4))
    q_k = euler_to_quat(0.3, -0.2, 0.1)
    for k in range(n):
        q_k = quat_multiply(q_k, rotvec_to_quat(omega[k] * dt))
        q[k] = q_k
    gyro = omega + np.asarray(bias) + gyro_noise * rng.normal(size=(n, 3))
    acc = quat_inverse_rotate(q, UP_NWU) + acc_noise * rng.normal(size=(n, 3))
    mag = quat_inverse_rotate(q, FIELD_NWU) + mag_noise * rng.normal(size=(n, 3))
    return q, gyro, acc, mag


def test_complementary_filter_converges_and_stays_bounded():
    dt, n = 0.02, 3000  # 60 s at 50 Hz
    q_true, gyro, acc, mag = simulate(n, dt, seed=12)
    f = ComplementaryFilter(crossover_hz=0.2, q0=quat_from_axis_angle([1, 1, 0], 2.5))  # 143 deg off
    err = np.empty(n)
    prev = f.q
    for k in range(n):
        q, ok = f.update(gyro[k], acc[k], mag[k], dt)
        assert ok
        assert np.dot(q, prev) > 0.99  # the output sign is continuous (no hemisphere flips)
        prev = q
        err[k] = quat_angle(q, q_true[k])
    gyro_only = GyroIntegrator(quat_to_matrix(q_true[0]))
    for k in range(1, n):
        R_gyro = gyro_only.update(gyro[k], dt)
    assert err[0] > np.radians(100)
    settle = int(5 * f.tau / dt)  # five time constants
    assert np.degrees(err[settle:].max()) < 2.0
    assert np.degrees(err[n // 2 :].mean()) < 1.0
    # gyro only (perfect start, same bias) drifts roughly like |bias| * t
    drift = quat_angle(matrix_to_quat(R_gyro), q_true[-1])
    assert np.degrees(drift) > 3.0
    assert drift > 5 * err[n // 2 :].mean()


def test_complementary_filter_initialises_from_first_valid_sample():
    dt, n = 0.02, 200
    q_true, gyro, acc, mag = simulate(n, dt, seed=13, acc_noise=0.0, mag_noise=0.0)
    f = ComplementaryFilter()
    assert not f.initialized
    q, ok = f.update(gyro[0], [0, 0, 0], mag[0], dt)
    assert not ok and not f.initialized
    q, ok = f.update(gyro[1], acc[1], mag[1], dt)
    assert ok and f.initialized
    assert quat_angle(q, q_true[1]) < 1e-12  # snapped, not blended


def test_complementary_filter_invalid_accmag_keeps_gyro_prediction():
    f = ComplementaryFilter(q0=[1.0, 0.0, 0.0, 0.0])
    rate = np.array([0.0, 0.0, np.pi / 2])
    for _ in range(100):
        q, ok = f.update(rate, [0, 0, 0], [1, 0, 0], 0.01)
        assert not ok
    np.testing.assert_allclose(q, quat_from_axis_angle([0, 0, 1], np.pi / 2), atol=1e-12)
    # parallel acc and mag: also gyro only
    assert f.update([0, 0, 0], [0, 0, 1], [0, 0, -1], 0.01)[1] is False


def test_complementary_filter_alpha_and_accel_rejection():
    f = ComplementaryFilter(crossover_hz=1.0, q0=[1.0, 0.0, 0.0, 0.0], accel_tolerance=0.1)
    assert f.tau == pytest.approx(1 / (2 * np.pi))
    q_target = quat_from_axis_angle([0, 0, 1], 0.5)
    acc = quat_inverse_rotate(q_target, UP_NWU)
    mag = quat_inverse_rotate(q_target, FIELD_NWU)
    dt = 0.01
    q, ok = f.update([0, 0, 0], acc, mag, dt)
    assert ok
    assert quat_angle(q, [1, 0, 0, 0]) == pytest.approx(0.5 * dt / (f.tau + dt), rel=1e-9)
    q2, ok = f.update([0, 0, 0], 1.5 * acc, mag, dt)  # 1.5 g: the hand is accelerating
    assert not ok
    np.testing.assert_allclose(q2, q, atol=1e-15)
    with pytest.raises(ValueError):
        ComplementaryFilter(crossover_hz=0.0)
    with pytest.raises(ValueError):
        f.update([np.nan, 0, 0], acc, mag, dt)


# --- roll -> distance ------------------------------------------------------------------------------


def run(rd, samples):
    return [rd.update(a, r) for a, r in samples]


def test_roll_distance_passes_azimuth_through():
    rd = RollDistance()
    out = run(rd, [(10, 0), (-170, 30), (179, -60), (5, 69.9)])
    assert out == [("azimuth", 10, 0), ("azimuth", -170, 0), ("azimuth", 179, 0), ("azimuth", 5, 0)]


def test_roll_distance_hysteresis():
    rd = RollDistance(enter_deg=70, leave_deg=45)
    rolls = [0, 60, 71, 60, 50, 46, 44, 60, 69, -75, -46, -30]
    modes = [m for m, _, _ in run(rd, [(0.0, r) for r in rolls])]
    assert modes == ["azimuth"] * 2 + ["distance"] * 4 + ["azimuth"] * 3 + ["distance"] * 2 + ["azimuth"]


def test_roll_distance_maps_azimuth_change_and_holds_azimuth():
    rd = RollDistance(distance=10.0)
    rd.update(20.0, 0.0)
    out = run(rd, [(22.0, 90.0), (42.0, 90.0), (2.0, 88.0), (-50.0, 90.0), (200.0, 90.0)])
    # anchor azimuth 22, anchor distance 10; the azimuth output holds the last passed-through value, 20
    assert [o[1] for o in out] == [20.0] * 5
    assert [o[2] for o in out] == [10.0, 30.0, 0.0, 0.0, 0.0]  # 200 deg = -160 after unwrapping: clipped
    # leaving: azimuth passes through again, distance is kept for the next gesture
    assert rd.update(33.0, 0.0) == ("azimuth", 33.0, 0.0)
    rd.update(33.0, -80.0)
    assert rd.update(123.0, -80.0)[2] == 90.0  # clipped at near


def test_roll_distance_unwraps_across_180_and_overshoot_returns():
    rd = RollDistance(gain=0.5, distance=45.0)
    rd.update(170.0, 0.0)
    d = [rd.update(a, 80.0)[2] for a in (170.0, -170.0, -100.0, 170.0)]
    # +20 deg across the seam -> +10; +90 total -> 45 + 45 = 90 (clip); back to the start -> 45
    assert d == [45.0, 55.0, 90.0, 45.0]


def test_roll_distance_reset_and_errors():
    rd = RollDistance()
    rd.update(0.0, 80.0)
    rd.update(30.0, 80.0)
    rd.reset()
    assert rd.mode == "azimuth" and rd.distance == 0.0
    rd.reset(distance=120.0)
    assert rd.distance == 90.0
    with pytest.raises(ValueError):
        RollDistance(enter_deg=40, leave_deg=45)
    with pytest.raises(ValueError):
        rd.update(float("nan"), 0.0)


def test_roll_distance_unwraps_as_unwrap_degrees_does_at_the_edges():
    from pointat.maths.quaternion import unwrap_degrees

    prev = 10.0
    edges = [180.0, -180.0, math.nextafter(-180.0, -math.inf), math.nextafter(180.0, math.inf), 1e9, -1e9]
    for d in [*edges, *np.random.default_rng(3).uniform(-720, 720, 200)]:
        rd = RollDistance(gain=1.0, distance=45.0)
        rd.update(prev, 80.0)  # rolled: the unwrapping starts at prev
        az = prev + float(d)
        rd.update(az, 80.0)
        expected = float(unwrap_degrees(az, prev))
        assert rd.s[R_UNWRAPPED] == expected, (d, rd.s[R_UNWRAPPED], expected)
        assert rd.distance == min(max(45.0 + (expected - prev), 0.0), 90.0)


@pytest.mark.parametrize("rate", [(1e30, 0.0, 0.0), (math.nan, 0.0, 0.0), (0.0, 0.0, -100.0)])
def test_integrator_and_complementary_refuse_rates_beyond_max_rate(rate):
    integ, comp = GyroIntegrator(), ComplementaryFilter(0.2)
    R, q = integ.R.copy(), comp.q.copy()
    with pytest.raises(ValueError, match="finite and below 100 rad/s"):
        integ.step(*rate, 0.01)
    with pytest.raises(ValueError, match="finite and below 100 rad/s"):
        comp.update(rate, (0.0, 0.0, G), (20.0, 0.0, -40.0), 0.01)
    np.testing.assert_array_equal(integ.R, R)
    np.testing.assert_array_equal(comp.q, q)
    integ.step(0.0, 0.0, 99.0, 0.01)  # inside: integrated
    assert not np.allclose(integ.R, R)
