"""Tests for pointat.maths.quaternion against seeded synthetic ground truth."""

import numpy as np
import pytest

from pointat.maths.quaternion import (
    azimuth_elevation,
    enu_to_nwu,
    euler_to_quat,
    matrix_to_quat,
    ned_to_nwu,
    nwu_to_enu,
    nwu_to_ned,
    pointing_direction,
    quat_angle,
    quat_conjugate,
    quat_from_axis_angle,
    quat_identity,
    quat_inverse_rotate,
    quat_multiply,
    quat_normalize,
    quat_positive,
    quat_rotate,
    quat_slerp,
    quat_to_axis_angle,
    quat_to_euler,
    quat_to_matrix,
    quat_to_rotvec,
    rotvec_to_quat,
    unwrap_degrees,
    wrap_degrees,
)

N = 1000
TOL = 1e-12


def random_quats(n: int, seed: int = 1) -> np.ndarray:
    """Uniform random unit quaternions with both signs of w (all quadrants)."""
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def same_rotation(p, q, tol=TOL):
    """p and q are the same rotation: equal up to sign, component by component."""
    p, q = np.asarray(p), np.asarray(q)
    sign = np.where(np.sum(p * q, axis=-1) < 0, -1.0, 1.0)[..., None]
    return np.max(np.abs(p - sign * q)) < tol


def skew_rotation_matrix(axis, angle):
    """Rodrigues formula, independent of the quaternion code."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


# --- known rotations -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "axis, v, expected",
    [
        ((1, 0, 0), (0, 1, 0), (0, 0, 1)),
        ((1, 0, 0), (0, 0, 1), (0, -1, 0)),
        ((1, 0, 0), (1, 0, 0), (1, 0, 0)),
        ((0, 1, 0), (0, 0, 1), (1, 0, 0)),
        ((0, 1, 0), (1, 0, 0), (0, 0, -1)),
        ((0, 1, 0), (0, 1, 0), (0, 1, 0)),
        ((0, 0, 1), (1, 0, 0), (0, 1, 0)),
        ((0, 0, 1), (0, 1, 0), (-1, 0, 0)),
        ((0, 0, 1), (0, 0, 1), (0, 0, 1)),
    ],
)
def test_ninety_degrees_about_each_axis(axis, v, expected):
    q = quat_from_axis_angle(axis, np.pi / 2)
    np.testing.assert_allclose(quat_rotate(q, v), expected, atol=TOL)
    np.testing.assert_allclose(quat_to_matrix(q) @ np.asarray(v, float), expected, atol=TOL)
    np.testing.assert_allclose(quat_inverse_rotate(q, expected), v, atol=TOL)


def test_rotate_matches_sandwich_product_and_rodrigues():
    q = random_quats(N)
    rng = np.random.default_rng(2)
    v = rng.normal(size=(N, 3))
    vq = np.concatenate([np.zeros((N, 1)), v], axis=-1)
    sandwich = quat_multiply(quat_multiply(q, vq), quat_conjugate(q))
    np.testing.assert_allclose(sandwich[:, 0], 0.0, atol=TOL)
    np.testing.assert_allclose(quat_rotate(q, v), sandwich[:, 1:], atol=1e-12)
    angle, axis = quat_to_axis_angle(q)
    for i in range(20):
        np.testing.assert_allclose(quat_to_matrix(q[i]), skew_rotation_matrix(axis[i], angle[i]), atol=TOL)


def test_multiply_composes_rotations():
    p, q = random_quats(N, 3), random_quats(N, 4)
    np.testing.assert_allclose(
        quat_to_matrix(quat_multiply(p, q)), quat_to_matrix(p) @ quat_to_matrix(q), atol=1e-12
    )


def test_identity_normalize_positive():
    np.testing.assert_array_equal(quat_identity(), [1, 0, 0, 0])
    np.testing.assert_allclose(np.linalg.norm(quat_normalize(3 * random_quats(10)), axis=-1), 1.0)
    assert np.all(quat_positive(random_quats(N))[:, 0] >= 0)
    with pytest.raises(ValueError):
        quat_normalize([0, 0, 0, 0])
    with pytest.raises(ValueError):
        quat_multiply([1, 0, 0], [1, 0, 0, 0])
    with pytest.raises(ValueError):
        quat_from_axis_angle([0, 0, 0], 1.0)


# --- round trips ---------------------------------------------------------------------------------


def test_round_trip_matrix():
    q = random_quats(N)
    back = matrix_to_quat(quat_to_matrix(q))
    assert np.all(back[:, 0] >= 0)
    np.testing.assert_allclose(back, quat_positive(q), atol=1e-12)


def test_round_trip_axis_angle():
    q = random_quats(N)
    angle, axis = quat_to_axis_angle(q)
    assert np.all((angle >= 0) & (angle <= np.pi))
    np.testing.assert_allclose(np.linalg.norm(axis, axis=-1), 1.0, atol=TOL)
    assert same_rotation(quat_from_axis_angle(axis, angle), q)


def test_round_trip_rotvec():
    q = random_quats(N)
    rv = quat_to_rotvec(q)
    assert np.all(np.linalg.norm(rv, axis=-1) <= np.pi + 1e-12)
    assert same_rotation(rotvec_to_quat(rv), q)
    rng = np.random.default_rng(5)
    rv = rng.uniform(-1, 1, size=(N, 3)) * 1.7  # norms below pi
    np.testing.assert_allclose(quat_to_rotvec(rotvec_to_quat(rv)), rv, atol=1e-12)


def test_round_trip_euler():
    q = random_quats(N)
    yaw, pitch, roll = quat_to_euler(q)
    assert np.all((yaw >= -np.pi) & (yaw < np.pi))
    assert np.all((pitch >= -np.pi / 2) & (pitch <= np.pi / 2))
    assert np.all((roll >= -np.pi) & (roll < np.pi))
    assert same_rotation(euler_to_quat(yaw, pitch, roll), q)
    rng = np.random.default_rng(6)
    angles = np.stack(
        [rng.uniform(-np.pi, np.pi, N), rng.uniform(-np.pi / 2, np.pi / 2, N), rng.uniform(-np.pi, np.pi, N)]
    )
    np.testing.assert_allclose(np.stack(quat_to_euler(euler_to_quat(*angles))), angles, atol=1e-9)


def test_euler_matches_matrix_product():
    yaw, pitch, roll = 0.3, -1.1, 2.5
    rz = skew_rotation_matrix((0, 0, 1), yaw)
    ry = skew_rotation_matrix((0, 1, 0), pitch)
    rx = skew_rotation_matrix((1, 0, 0), roll)
    np.testing.assert_allclose(quat_to_matrix(euler_to_quat(yaw, pitch, roll)), rz @ ry @ rx, atol=TOL)
    np.testing.assert_allclose(
        np.degrees(quat_to_euler(euler_to_quat(30, 40, 50, degrees=True))), (30, 40, 50), atol=1e-9
    )
    # positive pitch points the hand down (right-handed about y = left)
    el = azimuth_elevation(pointing_direction(euler_to_quat(0, 20, 0, degrees=True)))[1]
    assert el == pytest.approx(-20.0, abs=1e-12)


@pytest.mark.parametrize("sign", [1.0, -1.0])
@pytest.mark.parametrize("offset", [0.0, 1e-9, -1e-9, 1e-13])
def test_near_gimbal_lock(sign, offset):
    rng = np.random.default_rng(7)
    yaw = rng.uniform(-np.pi, np.pi, 200)
    roll = rng.uniform(-np.pi, np.pi, 200)
    pitch = sign * (np.pi / 2 + offset)  # beyond +-90 deg wraps to the other branch
    q = euler_to_quat(yaw, pitch, roll)
    out = quat_to_euler(q)
    assert all(np.all(np.isfinite(a)) for a in out)
    # inside GIMBAL_EPS the dropped roll costs about |offset|; outside, only rounding
    assert same_rotation(euler_to_quat(*out), q, tol=1e-14 + (abs(offset) if abs(offset) < 1e-12 else 0.0))
    np.testing.assert_allclose(out[1], sign * (np.pi / 2 - abs(offset)), atol=1e-12)
    np.testing.assert_allclose(quat_to_matrix(euler_to_quat(*out)), quat_to_matrix(q), atol=1e-12)
    if offset == 0.0:
        np.testing.assert_array_equal(out[2], 0.0)
        # all of the heading in yaw: the pointing direction is vertical, the back of the hand faces yaw
        heading = yaw - roll if sign > 0 else yaw + roll
        np.testing.assert_allclose(np.cos(out[0] - heading), 1.0, atol=1e-12)


def test_gimbal_lock_exact_quaternion():
    # straight up, built without trigonometry: rotation of -90 deg about y
    q = np.array([np.sqrt(0.5), 0.0, -np.sqrt(0.5), 0.0])
    yaw, pitch, roll = quat_to_euler(q, degrees=True)
    assert (float(yaw), float(pitch), float(roll)) == pytest.approx((0.0, -90.0, 0.0), abs=1e-12)


# --- 180 degree rotations ---------------------------------------------------------------------------


def test_matrix_to_quat_half_turns():
    rng = np.random.default_rng(8)
    axes = rng.normal(size=(N, 3))
    axes /= np.linalg.norm(axes, axis=-1, keepdims=True)
    axes = np.concatenate([axes, np.eye(3), -np.eye(3), [[1, 1, 0], [0, 1, -1], [1, 1, 1]]])
    for angle in (np.pi, np.pi - 1e-9, np.pi + 1e-9):
        q = quat_from_axis_angle(axes, angle)
        back = matrix_to_quat(quat_to_matrix(q))
        assert np.all(np.isfinite(back))
        assert same_rotation(back, q, tol=1e-14)
        np.testing.assert_allclose(np.linalg.norm(back, axis=-1), 1.0, atol=TOL)
    np.testing.assert_allclose(matrix_to_quat(np.diag([-1.0, 1.0, -1.0])), [0, 0, 1, 0], atol=TOL)
    np.testing.assert_allclose(matrix_to_quat(np.diag([-1.0, -1.0, 1.0])), [0, 0, 0, 1], atol=TOL)
    np.testing.assert_allclose(matrix_to_quat(np.eye(3)), [1, 0, 0, 0], atol=TOL)


def test_half_turn_axis_angle_and_rotvec():
    q = quat_from_axis_angle([0, 0, 1], np.pi)
    angle, axis = quat_to_axis_angle(q)
    assert angle == pytest.approx(np.pi)
    np.testing.assert_allclose(np.abs(axis), [0, 0, 1], atol=TOL)
    np.testing.assert_allclose(np.abs(quat_to_rotvec(q)), [0, 0, np.pi], atol=TOL)


def test_zero_rotation_axis_angle_rotvec():
    angle, axis = quat_to_axis_angle(quat_identity())
    assert angle == 0.0
    np.testing.assert_array_equal(axis, [1.0, 0.0, 0.0])
    np.testing.assert_array_equal(quat_to_rotvec(quat_identity()), [0, 0, 0])
    q = rotvec_to_quat([1e-20, 0, 0])
    np.testing.assert_allclose(q, [1, 5e-21, 0, 0], rtol=1e-12)
    np.testing.assert_allclose(quat_to_rotvec(q), [1e-20, 0, 0], rtol=1e-12)


# --- slerp and angle -------------------------------------------------------------------------------


def test_slerp():
    p, q = random_quats(N, 9), random_quats(N, 10)
    total = quat_angle(p, q)
    for t in (0.0, 0.3, 1.0):
        s = quat_slerp(p, q, t)
        np.testing.assert_allclose(np.linalg.norm(s, axis=-1), 1.0, atol=TOL)
        np.testing.assert_allclose(quat_angle(p, s), t * total, atol=1e-9)
        np.testing.assert_allclose(quat_angle(s, q), (1 - t) * total, atol=1e-9)
    # shortest path: sign of q does not matter
    assert same_rotation(quat_slerp(p, -q, 0.4), quat_slerp(p, q, 0.4))
    # nearly identical inputs
    r = quat_multiply(p, rotvec_to_quat(np.tile([1e-12, 0, 0], (N, 1))))
    s = quat_slerp(p, r, 0.5)
    assert np.all(np.isfinite(s))
    np.testing.assert_allclose(quat_angle(p, s), 0.5e-12, atol=1e-15)
    assert same_rotation(quat_slerp(p, p, 0.5), p)


def test_quat_angle_sign_invariant():
    p = random_quats(N, 11)
    q = quat_from_axis_angle([0.3, -1, 2], 0.7)
    a = quat_angle(p, quat_multiply(p, q))
    np.testing.assert_allclose(a, 0.7, atol=1e-12)
    np.testing.assert_allclose(quat_angle(-p, quat_multiply(p, q)), 0.7, atol=1e-12)


# --- frames ----------------------------------------------------------------------------------------


def test_nwu_to_enu():
    north_in_enu = quat_rotate(nwu_to_enu(quat_identity()), [1, 0, 0])
    np.testing.assert_allclose(north_in_enu, [0, 1, 0], atol=TOL)  # NWU north = ENU +y
    west_in_enu = quat_rotate(nwu_to_enu(quat_identity()), [0, 1, 0])
    np.testing.assert_allclose(west_in_enu, [-1, 0, 0], atol=TOL)
    q = random_quats(N)
    v = np.random.default_rng(12).normal(size=(N, 3))
    v_nwu = quat_rotate(q, v)
    v_enu = quat_rotate(nwu_to_enu(q), v)
    np.testing.assert_allclose(v_enu, np.stack([-v_nwu[:, 1], v_nwu[:, 0], v_nwu[:, 2]], -1), atol=1e-12)
    np.testing.assert_allclose(enu_to_nwu(nwu_to_enu(q)), q, atol=1e-15)


def test_ned_nwu():
    q = random_quats(N)
    v = np.random.default_rng(13).normal(size=(N, 3))
    v_ned = quat_rotate(q, v)
    v_nwu = quat_rotate(ned_to_nwu(q), v)
    np.testing.assert_allclose(v_nwu, v_ned * [1, -1, -1], atol=1e-12)
    np.testing.assert_allclose(nwu_to_ned(ned_to_nwu(q)), q, atol=1e-15)
    np.testing.assert_allclose(ned_to_nwu(nwu_to_ned(q)), q, atol=1e-15)


# --- azimuth / elevation ---------------------------------------------------------------------------


@pytest.mark.parametrize("sx", [1, -1])
@pytest.mark.parametrize("sy", [1, -1])
@pytest.mark.parametrize("sz", [1, -1])
def test_azimuth_elevation_octants(sx, sy, sz):
    az_true = np.degrees(np.arctan2(sy * 1.0, sx * np.sqrt(3.0)))  # 30 deg from the x axis
    el_true = sz * 40.0
    el = np.radians(el_true)
    d = np.array([np.cos(el) * sx * np.sqrt(3) / 2, np.cos(el) * sy * 0.5, np.sin(el)]) * 2.5
    az, ele = azimuth_elevation(d)
    assert az == pytest.approx(az_true, abs=1e-12)
    assert ele == pytest.approx(el_true, abs=1e-12)
    assert abs(az) in (pytest.approx(30.0), pytest.approx(150.0))


def test_azimuth_cardinal_directions():
    dirs = np.array([[1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0], [-1, -0.0, 0], [-1, -1e-300, 0]])
    az, el = azimuth_elevation(dirs)
    np.testing.assert_allclose(az, [0, 90, -180, -90, -180, -180], atol=1e-12)
    np.testing.assert_allclose(el, 0, atol=0)
    assert np.all((az >= -180) & (az < 180))


def test_azimuth_follows_pointing():
    # hand yawed 50 deg left and pitched 30 deg up points at azimuth 50, elevation 30, whatever the roll
    q = euler_to_quat(50.0, -30.0, np.linspace(-180, 180, 13), degrees=True)
    az, el = azimuth_elevation(pointing_direction(q))
    np.testing.assert_allclose(az, 50.0, atol=1e-10)
    np.testing.assert_allclose(el, 30.0, atol=1e-10)


def test_poles_hold_previous_azimuth():
    up, down = [0, 0, 1.0], [0, 0, -3.0]
    assert azimuth_elevation(up) == (0.0, 90.0)
    assert azimuth_elevation(down) == (0.0, -90.0)
    assert azimuth_elevation(up, previous_azimuth=42.0) == (42.0, 90.0)
    assert azimuth_elevation(down, previous_azimuth=190.0)[0] == pytest.approx(-170.0)
    near = [np.cos(np.radians(89.99)), 0.0, np.sin(np.radians(89.99))]
    az, el = azimuth_elevation(near, previous_azimuth=-12.0)
    assert az == -12.0 and el == pytest.approx(89.99)
    az, _ = azimuth_elevation(near, previous_azimuth=-12.0, pole_deg=0.001)
    assert az == pytest.approx(0.0, abs=1e-9)
    az, el = azimuth_elevation([[0, 0, 1], [0, 1, 0]], previous_azimuth=[5.0, 5.0])
    np.testing.assert_allclose(az, [5.0, 90.0])
    np.testing.assert_allclose(el, [90.0, 0.0])
    assert np.all(np.isfinite(azimuth_elevation([0.0, 0.0, 0.0])))


def test_wrap_degrees_edges():
    a = np.array([-180.0, 180.0, 179.999, -179.999, 360.0, -360.0, 540.0, -540.0, 0.0, -1e-14 - 180.0])
    w = wrap_degrees(a)
    np.testing.assert_allclose(w[:9], [-180, -180, 179.999, -179.999, 0, 0, -180, -180, 0], atol=1e-9)
    assert np.all((w >= -180.0) & (w < 180.0))
    assert wrap_degrees(np.nextafter(-180.0, -np.inf)) < 180.0
    assert wrap_degrees(1e6 + 10) == pytest.approx(wrap_degrees(10 + 1e6 - 360 * 2777))


def test_unwrap_degrees():
    assert unwrap_degrees(-179.0, 179.0) == pytest.approx(181.0)
    assert unwrap_degrees(179.0, -179.0) == pytest.approx(-181.0)
    assert unwrap_degrees(10.0, 725.0) == pytest.approx(730.0)
    np.testing.assert_allclose(unwrap_degrees([0.0, 90.0], [350.0, -260.0]), [360.0, -270.0])
