"""The float fast path agrees with the numpy reference functions."""

import math

import numpy as np
import pytest

from pointat.maths import quaternion as Q
from pointat.maths import scalar as S
from pointat.maths.fusion import accmag_matrix

rng = np.random.default_rng(11)
QUATS = Q.quat_normalize(rng.normal(size=(500, 4)))


def test_multiply_rotate_and_matrices_match_numpy():
    for p, q in zip(QUATS[:-1], QUATS[1:], strict=True):
        assert S.multiply(p, q) == pytest.approx(Q.quat_multiply(p, q).tolist(), abs=1e-14)
        v = rng.normal(size=3)
        assert S.rotate(p, *v) == pytest.approx(Q.quat_rotate(p, v).tolist(), abs=1e-13)
        assert S.quat_matrix(p) == pytest.approx(Q.quat_to_matrix(p).ravel().tolist(), abs=1e-14)
        assert S.matrix_quat(S.quat_matrix(p)) == pytest.approx(Q.quat_positive(p).tolist(), abs=1e-12)


def test_polar_step_is_newton_schulz_and_pulls_a_drifted_matrix_back_to_the_rotation():
    for q in QUATS[:50]:
        R = Q.quat_to_matrix(q)
        drifted = R + 1e-7 * rng.normal(size=(3, 3))
        step = np.array(S.polar_step(drifted.ravel().tolist())).reshape(3, 3)
        np.testing.assert_allclose(step, 0.5 * drifted @ (3.0 * np.eye(3) - drifted.T @ drifted), atol=1e-15)
        # quadratic: a 1e-7 departure from orthogonality leaves ~1e-14
        assert np.abs(step.T @ step - np.eye(3)).max() < 1e-12 < np.abs(drifted.T @ drifted - np.eye(3)).max()
        assert S.polar_step(R.ravel().tolist()) == pytest.approx(R.ravel().tolist(), abs=1e-15)


def test_matrix_quat_is_robust_at_half_turns():
    for axis in np.eye(3):
        R = Q.quat_to_matrix(Q.quat_from_axis_angle(axis, math.pi))
        assert S.matrix_quat(R.ravel().tolist()) == pytest.approx(Q.matrix_to_quat(R).tolist(), abs=1e-12)


def test_slerp_matches_numpy_including_nearly_equal_and_opposite_signs():
    for p, q in zip(QUATS[:-1], QUATS[1:], strict=True):
        for t in (0.0, 0.3, 1.0):
            ref = Q.quat_slerp(p, q, t)
            got = np.array(S.slerp(p, -q, t))
            assert min(np.abs(got - ref).max(), np.abs(got + ref).max()) < 1e-12
    p = QUATS[0]
    near = Q.quat_normalize(p + 1e-9)
    assert S.slerp(p, near, 0.5) == pytest.approx(Q.quat_slerp(p, near, 0.5).tolist(), abs=1e-12)


def test_accmag_matches_triad_and_refuses_bad_vectors():
    for _ in range(200):
        acc, mag = rng.normal(size=3), rng.normal(size=3)
        assert S.accmag_matrix(acc, mag) == pytest.approx(accmag_matrix(acc, mag).ravel().tolist(), abs=1e-12)
        C, na, nm, sin_dip = S.accmag_triad(acc, mag)
        assert C == S.accmag_matrix(acc, mag)
        assert (na, nm) == pytest.approx((np.linalg.norm(acc), np.linalg.norm(mag)), rel=1e-14)
        assert sin_dip == pytest.approx(-np.dot(acc, mag) / (na * nm), abs=1e-14)
        assert -1.0 <= sin_dip <= 1.0
    steep = S.accmag_triad((0.0, 0.0, 9.8), (1e-5, 0.0, -0.5))  # a field nearly straight down
    assert steep is not None and -1.0 <= steep[3] <= 1.0 and steep[3] == pytest.approx(1.0)
    assert S.accmag_matrix((0.0, 0.0, 0.0), (1.0, 0.0, 0.0)) is None
    assert S.accmag_matrix((0.0, 0.0, 1.0), (0.0, 0.0, 2.0)) is None
    assert S.accmag_matrix((math.nan, 0.0, 1.0), (1.0, 0.0, 0.0)) is None
    assert S.accmag_triad((0.0, 0.0, 1.0), (0.0, 0.0, 2.0)) is None
    with pytest.raises(ValueError):
        S.normalize((0.0, 0.0, 0.0, 0.0))


def test_euler_azimuth_and_axis_angle_match_numpy():
    for q in QUATS:
        assert S.euler(q) == pytest.approx([float(a) for a in Q.quat_to_euler(q)], abs=1e-9)
        az, el = S.azimuth_elevation(q, previous=12.0)
        ref = Q.azimuth_elevation(Q.pointing_direction(q), previous_azimuth=12.0)
        assert (az, el) == pytest.approx([float(r) for r in ref], abs=1e-9)
        angle, axis = Q.quat_to_axis_angle(q)
        assert S.axis_angle(q) == pytest.approx([float(angle), *axis.tolist()], abs=1e-9)
    up = Q.euler_to_quat(0.3, -math.pi / 2, 0.0)  # pointing straight up: the azimuth holds
    assert S.azimuth_elevation(up, previous=33.0) == pytest.approx((33.0, 90.0))
    for pitch in (math.pi / 2, -math.pi / 2):
        q = Q.euler_to_quat(0.7, pitch, 0.0)
        assert S.euler(q) == pytest.approx([float(a) for a in Q.quat_to_euler(q)], abs=1e-6)


def test_roll_is_eulers_roll_including_at_the_poles():
    poles = [Q.euler_to_quat(0.7, p, 0.4) for p in (math.pi / 2, -math.pi / 2)]
    for q in [*QUATS, *poles]:
        assert S.roll(q) == S.euler(q)[2]
    assert S.roll(poles[0]) == 0.0
