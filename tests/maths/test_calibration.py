"""Tests for pointat.maths.calibration against seeded synthetic sensors."""

import json
import os
import stat
import sys

import numpy as np
import pytest

from pointat.maths.calibration import (
    STANDARD_GRAVITY,
    Calibration,
    ellipsoid_fit,
    gyro_null,
    gyro_scale,
    minmax_magnetometer,
    six_position_accel,
)
from pointat.maths.fusion import GyroIntegrator
from pointat.maths.quaternion import quat_inverse_rotate

G = STANDARD_GRAVITY
NULL = np.array([2051.5, 1987.25, 2100.0])
SCALE = np.array([41.5, 39.75, -40.25])  # counts per m/s^2; z axis mounted reversed


def random_unit(n, rng):
    u = rng.normal(size=(n, 3))
    return u / np.linalg.norm(u, axis=1, keepdims=True)


def six_poses(null, scale, g=G):
    """Rows +x, -x, +y, -y, +z, -z up: specific force +g along the up axis."""
    f = np.repeat(np.eye(3), 2, axis=0) * np.tile([1.0, -1.0], 3)[:, None] * g
    return null + scale * f


# --- accelerometer ---------------------------------------------------------------------------------


def test_six_position_fixed_order_exact():
    null, scale = six_position_accel(six_poses(NULL, SCALE), order="fixed")
    np.testing.assert_allclose(null, NULL, rtol=0, atol=1e-12)
    np.testing.assert_allclose(scale, SCALE, rtol=1e-15)


def test_six_position_auto_detects_shuffled_rows():
    scale = np.abs(SCALE)
    poses = six_poses(NULL, scale)
    perm = np.random.default_rng(1).permutation(6)
    null, got = six_position_accel(poses[perm])
    np.testing.assert_allclose(null, NULL, atol=1e-12)
    np.testing.assert_allclose(got, scale, rtol=1e-15)
    # in g
    null, got = six_position_accel(six_poses(NULL, scale, g=1.0)[perm], g=1.0)
    np.testing.assert_allclose(got, scale, rtol=1e-15)


def test_six_position_with_noise_and_tilt():
    rng = np.random.default_rng(2)
    scale = np.abs(SCALE)
    # each pose averaged from 500 noisy samples, and the "level" table tilted by 0.5 deg
    tilt = np.radians(0.5)
    f = np.repeat(np.eye(3), 2, axis=0) * np.tile([1.0, -1.0], 3)[:, None] * G
    f = f * np.cos(tilt) + np.roll(f, 1, axis=1) * np.sin(tilt)
    samples = NULL + scale * f[:, None, :] + rng.normal(scale=2.0, size=(6, 500, 3))
    null, got = six_position_accel(samples.mean(axis=1))
    np.testing.assert_allclose(null, NULL, atol=0.5)  # counts
    np.testing.assert_allclose(got, scale, rtol=1e-3)


def test_six_position_errors():
    with pytest.raises(ValueError, match="shape"):
        six_position_accel(np.zeros((5, 3)))
    with pytest.raises(ValueError, match="apart"):
        six_position_accel(np.zeros((6, 3)) + np.arange(6)[:, None])  # same up row for every axis
    with pytest.raises(ValueError, match="order"):
        six_position_accel(six_poses(NULL, SCALE), order="xyz")
    with pytest.raises(ValueError, match="scale 0"):
        six_position_accel(np.full((6, 3), 2048.0), order="fixed")


# --- magnetometer ----------------------------------------------------------------------------------


def test_minmax_magnetometer_recovers_null_and_scale():
    rng = np.random.default_rng(3)
    field = 0.5  # gauss
    mag_null, mag_scale = np.array([120.0, -35.0, 7.5]), np.array([900.0, 1100.0, 1000.0])
    m = random_unit(20000, rng) * field
    raw = mag_null + mag_scale * m
    null, scale = minmax_magnetometer(raw, field=field)
    np.testing.assert_allclose(null, mag_null, atol=2.0)  # extremes of a finite sample: slightly inside
    np.testing.assert_allclose(scale, mag_scale, rtol=3e-3)
    # with the six extremes present it is exact
    raw_exact = np.concatenate([raw, mag_null + mag_scale * np.concatenate([np.eye(3), -np.eye(3)]) * field])
    null, scale = minmax_magnetometer(raw_exact, field=field)
    np.testing.assert_allclose(null, mag_null, atol=1e-12)
    np.testing.assert_allclose(scale, mag_scale, rtol=1e-15)
    cal = Calibration(mag_null=null, mag_scale=scale)
    np.testing.assert_allclose(np.linalg.norm(cal.apply("mag", raw), axis=1), field, atol=1e-12)
    with pytest.raises(ValueError):
        minmax_magnetometer(np.ones((10, 3)))


def test_ellipsoid_fit_exact_points():
    rng = np.random.default_rng(4)
    A = np.array([[1.3, 0.2, -0.1], [0.2, 0.8, 0.15], [-0.1, 0.15, 1.1]]) * 400.0  # symmetric distortion
    b = np.array([150.0, -80.0, 35.0])
    raw = random_unit(300, rng) @ A.T + b
    offset, W = ellipsoid_fit(raw)
    np.testing.assert_allclose(offset, b, rtol=1e-9)
    np.testing.assert_allclose(W, np.linalg.inv(A), rtol=1e-9, atol=1e-14)
    np.testing.assert_allclose(W, W.T, atol=1e-15)


def test_ellipsoid_fit_noisy_points():
    rng = np.random.default_rng(5)
    A = np.array([[1.3, 0.2, -0.1], [0.2, 0.8, 0.15], [-0.1, 0.15, 1.1]]) * 400.0
    b = np.array([150.0, -80.0, 35.0])
    m = random_unit(3000, rng)
    raw = m @ A.T + b + rng.normal(scale=4.0, size=m.shape)  # 1 % of the radius
    offset, W = ellipsoid_fit(raw, field=0.48)
    assert np.linalg.norm(offset - b) / np.linalg.norm(A, 2) < 1e-2
    W_true = 0.48 * np.linalg.inv(A)
    assert np.linalg.norm(W - W_true) / np.linalg.norm(W_true) < 1e-2
    corrected = Calibration(mag_null=offset, mag_soft_iron=W).apply("mag", raw)
    assert np.abs(np.linalg.norm(corrected, axis=1) / 0.48 - 1.0).mean() < 1e-2


def test_ellipsoid_fit_rejects_degenerate_data():
    rng = np.random.default_rng(6)
    with pytest.raises(ValueError):
        ellipsoid_fit(random_unit(5, rng))
    flat = random_unit(100, rng) * [1.0, 1.0, 0.0]
    with pytest.raises(ValueError):
        ellipsoid_fit(flat)


# --- gyroscope -------------------------------------------------------------------------------------


def test_gyro_null_and_scale_exact():
    null_true = np.array([2048.0, 2010.5, 2075.25])
    scale_true = np.array([150.0, 147.5, -152.0])  # counts per rad/s
    rest = np.tile(null_true, (1000, 1))
    null = gyro_null(rest)
    np.testing.assert_array_equal(null, null_true)
    dt = 0.01
    for axis in range(3):
        # a smooth 90 deg turn about +axis in 2 s, rest to rest
        t = np.arange(200) * dt
        rate = np.zeros((200, 3))
        rate[:, axis] = (np.pi / 2) / 2.0 * (1 - np.cos(2 * np.pi * t / 2.0))  # integrates to pi/2
        raw = null_true + scale_true * rate
        got = gyro_scale(raw, dt, np.pi / 2, axis, null=null)
        assert got == pytest.approx(scale_true[axis], rel=1e-12)
        assert gyro_scale(raw[:, axis] - null[axis], np.full(200, dt), np.pi / 2, axis) == pytest.approx(
            scale_true[axis], rel=1e-12
        )


def test_gyro_calibration_with_noise_feeds_the_integrator():
    rng = np.random.default_rng(7)
    null_true = np.array([2048.0, 2010.5, 2075.25])
    scale_true = np.array([150.0, 147.5, 152.0])
    null = gyro_null(null_true + rng.normal(scale=3.0, size=(5000, 3)))
    np.testing.assert_allclose(null, null_true, atol=0.2)
    dt, n = 0.005, 1000
    t = np.arange(n) * dt
    rate = np.zeros((n, 3))
    rate[:, 2] = np.pi / (n * dt) * (1 - np.cos(2 * np.pi * t / (n * dt)))  # 180 deg about z
    raw = null_true + scale_true * rate + rng.normal(scale=3.0, size=(n, 3))
    scale = gyro_scale(raw, dt, np.pi, 2, null=null)
    assert scale == pytest.approx(scale_true[2], rel=2e-3)
    cal = Calibration(gyro_null=null, gyro_scale=[scale_true[0], scale_true[1], scale])
    R = GyroIntegrator().update_many(cal.apply("gyro", raw), dt)
    np.testing.assert_allclose(R @ [1.0, 0, 0], [-1.0, 0, 0], atol=2e-2)


def test_gyro_scale_errors():
    with pytest.raises(ValueError):
        gyro_scale(np.zeros((10, 3)), 0.01, np.pi, 0)
    with pytest.raises(ValueError):
        gyro_scale(np.ones((10, 3)), 0.01, 0.0, 0)
    with pytest.raises(ValueError):
        gyro_scale(np.ones((10, 3)), 0.01, 1.0, 3)


# --- the Calibration object ------------------------------------------------------------------------


def full_calibration():
    rng = np.random.default_rng(8)
    return Calibration(
        gyro_null=rng.normal(2048, 30, 3),
        gyro_scale=rng.normal(150, 5, 3),
        acc_null=rng.normal(2048, 30, 3),
        acc_scale=rng.normal(40, 2, 3),
        mag_null=rng.normal(0, 100, 3),
        mag_scale=rng.normal(1000, 50, 3),
        mag_soft_iron=np.eye(3) + 0.01 * rng.normal(size=(3, 3)),
    )


def test_apply_inverts_the_sensor_model():
    cal = full_calibration()
    rng = np.random.default_rng(9)
    w, a, m = rng.normal(size=(3, 50, 3))
    raw_w = cal.gyro_null + cal.gyro_scale * w
    raw_a = cal.acc_null + cal.acc_scale * a
    raw_m = cal.mag_null + cal.mag_scale * (m @ np.linalg.inv(cal.mag_soft_iron).T)
    gw, ga, gm = cal.apply_all(raw_w, raw_a, raw_m)
    np.testing.assert_allclose(gw, w, atol=1e-12)
    np.testing.assert_allclose(ga, a, atol=1e-12)
    np.testing.assert_allclose(gm, m, atol=1e-12)
    np.testing.assert_allclose(cal.apply("acc", raw_a[0]), a[0], atol=1e-12)  # single sample
    np.testing.assert_array_equal(Calibration().apply("mag", raw_m), raw_m)  # defaults pass through
    with pytest.raises(ValueError):
        cal.apply("baro", raw_a)


def test_accel_calibration_end_to_end():
    poses = six_poses(NULL, np.abs(SCALE))
    null, scale = six_position_accel(poses)
    cal = Calibration(acc_null=null, acc_scale=scale)
    q = np.array([0.9, 0.1, -0.3, 0.2])
    q /= np.linalg.norm(q)
    f = quat_inverse_rotate(q, [0.0, 0.0, G])
    np.testing.assert_allclose(cal.apply("acc", NULL + np.abs(SCALE) * f), f, atol=1e-12)


def test_json_round_trip_is_exact(tmp_path):
    cal = full_calibration()
    again = Calibration.from_json(cal.to_json())
    assert again == cal
    path = tmp_path / "glove.json"
    cal.save(path)
    loaded = Calibration.load(path)
    assert loaded == cal
    for name in ("gyro_null", "acc_scale", "mag_null"):
        assert getattr(loaded, name).tobytes() == getattr(cal, name).tobytes()  # bit for bit
    data = json.loads(path.read_text())
    assert data["version"] == 1 and data["format"] == "pointat-calibration"
    assert Calibration.load(path) != Calibration()
    partial = Calibration.from_json('{"version": 1, "acc": {"null": [1, 2, 3]}}')
    assert partial == Calibration(acc_null=[1, 2, 3])
    assert Calibration.from_json(Calibration().to_json()).mag_soft_iron is None


@pytest.mark.parametrize(
    "mutate, key",
    [
        (lambda d: d.pop("version"), "version"),
        (lambda d: d.update(version=2), "version"),
        (lambda d: d.update(format="other"), "format"),
        (lambda d: d.update(extra=1), "extra"),
        (lambda d: d["gyro"].update(scale=[1.0, 0.0, 1.0]), "gyro.scale"),
        (lambda d: d["acc"].update(null=[1.0, 2.0]), "acc.null"),
        (lambda d: d["acc"].update(null=[1.0, "2", 3.0]), "acc.null"),
        (lambda d: d["mag"].update(offset=[0, 0, 0]), "mag.offset"),
        (lambda d: d["mag"].update(soft_iron=[[1, 0, 0], [0, 1, 0]]), "mag.soft_iron"),
        (lambda d: d["mag"].update(soft_iron=[[1, 0, 0], [0, 1, 0], [0, 0, None]]), "mag.soft_iron[2]"),
        (lambda d: d.update(gyro=[1, 2, 3]), "gyro"),
    ],
)
def test_bad_file_names_file_and_key(tmp_path, mutate, key):
    data = full_calibration().to_dict()
    mutate(data)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError) as info:
        Calibration.load(path)
    message = str(info.value)
    assert str(path) in message
    assert f"'{key}'" in message


def test_not_json_names_file(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text("{version: 1")
    with pytest.raises(ValueError, match="broken.json"):
        Calibration.load(path)
    path.write_text("[1, 2]")
    with pytest.raises(ValueError, match="broken.json"):
        Calibration.load(path)


def test_constructor_validates():
    with pytest.raises(ValueError, match="acc_scale"):
        Calibration(acc_scale=[1.0, 0.0, 1.0])
    with pytest.raises(ValueError, match="gyro_null"):
        Calibration(gyro_null=[1.0, np.nan, 0.0])
    with pytest.raises(ValueError, match="mag_soft_iron"):
        Calibration(mag_soft_iron=np.eye(2))


@pytest.mark.skipif(not hasattr(os, "symlink") or sys.platform == "win32", reason="POSIX links and modes")
def test_save_writes_through_a_link_and_keeps_the_files_mode(tmp_path):
    # one glove's file shared by two patches through a link: save replaced the link by a file of its own
    # (the shared file kept the old nulls), and a file made group-writable came back 0644
    shared = tmp_path / "glove1.json"
    Calibration().save(shared)
    os.chmod(shared, 0o664)
    link = tmp_path / "calibration.json"
    os.symlink(shared, link)
    Calibration(gyro_null=[2001.0, 2002.0, 2003.0]).save(link)
    assert link.is_symlink()
    assert list(Calibration.load(shared).gyro_null) == [2001.0, 2002.0, 2003.0]
    assert stat.S_IMODE(os.stat(shared).st_mode) == 0o664
    assert sorted(p.name for p in tmp_path.iterdir()) == ["calibration.json", "glove1.json"]  # no .part left
