"""The simulated body: its skeletons, the consistency of its truth (the gyro integrates to the orientations,
the accelerometer is the second derivative of the positions), the calibration pose, the sensors' mounting,
noise and determinism."""

from __future__ import annotations

import inspect
import math
import time

import numpy as np
import pytest

from pointat.devices import body_sim
from pointat.devices.body_sim import (
    ARM,
    BODY,
    GRAVITY,
    BodyScript,
    BodySimulator,
    Joint,
    default_script,
)
from pointat.devices.glove_sim import SensorModel
from pointat.maths import skeleton as sk
from pointat.maths.quaternion import (
    quat_angle,
    quat_conjugate,
    quat_from_axis_angle,
    quat_inverse_rotate,
    quat_multiply,
    quat_rotate,
    rotvec_to_quat,
)

SKELETONS = pytest.mark.parametrize("skeleton", [ARM, BODY], ids=["arm", "body"])


def _multiply(a, b):
    return (
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    )


def integrate_gyro(sim, seconds, h):
    """Each sensor's orientation integrated from its noise-free gyro alone, at steps of ``h`` from its true
    start: the fourth-order Magnus step on the rates at the two Gauss points of each step,
    exp((h/2)(w1 + w2) + (sqrt(3)/12) h^2 (w1 x w2)), so that what is left is the simulator's error."""
    n = int(round(seconds / h))
    t = np.arange(n) * h
    c = math.sqrt(3.0) / 6.0
    w1 = sim.kinematics(t + h * (0.5 - c)).omega
    w2 = sim.kinematics(t + h * (0.5 + c)).omega
    steps = rotvec_to_quat(0.5 * h * (w1 + w2) + (math.sqrt(3.0) / 12.0) * h * h * np.cross(w1, w2))
    truth = sim.kinematics(np.arange(n + 1) * h).sensor_q
    out = np.empty_like(truth)
    for i in range(sim.n_sensors):
        q = tuple(truth[0, i])
        path = [q]
        for d in steps[:, i].tolist():
            q = _multiply(q, d)
            path.append(q)
        out[:, i] = path
    return out, truth


# -- the skeletons ---------------------------------------------------------------------------------------


def test_the_arm_is_a_right_arm_held_straight_ahead():
    assert [s.name for s in ARM.segments] == ["upper_arm", "forearm", "hand"]
    assert [s.sensor for s in ARM.segments] == [1, 2, 3]
    assert [s.length for s in ARM.segments] == [(0.30, 0.0, 0.0), (0.25, 0.0, 0.0), (0.08, 0.0, 0.0)]
    assert ARM.root == (0.0, -0.2, 1.45)
    assert all(s.pose == (1.0, 0.0, 0.0, 0.0) for s in ARM.segments)
    joints, ends = sk.forward(ARM, [s.pose for s in ARM.segments])
    assert np.allclose(joints, [(0.0, -0.2, 1.45), (0.30, -0.2, 1.45), (0.55, -0.2, 1.45)])
    assert np.allclose(ends[-1], (0.63, -0.2, 1.45))


def test_the_body_stands_in_an_n_pose():
    names = [s.name for s in BODY.segments]
    assert len(names) == 15 and BODY.sensors == 15
    assert sorted(s.sensor for s in BODY.segments) == list(range(1, 16))
    assert names[0] == "pelvis" and BODY.segments[0].parent is None
    assert all(s.pose == (1.0, 0.0, 0.0, 0.0) for s in BODY.segments)
    joints, ends = sk.forward(BODY, [s.pose for s in BODY.segments])
    end = dict(zip(names, ends, strict=True))
    joint = dict(zip(names, joints, strict=True))
    assert end["head"][2] == pytest.approx(1.70)
    for side, y in (("right", -1.0), ("left", 1.0)):
        assert joint[f"{side}_upper_arm"][1] == pytest.approx(0.18 * y)  # the shoulders, level
        assert end[f"{side}_hand"][2] < joint[f"{side}_forearm"][2] < joint[f"{side}_upper_arm"][2]  # hanging
        assert 0.0 < end[f"{side}_foot"][2] < 0.05 and end[f"{side}_foot"][0] > 0.15  # on the floor, forward
        assert joint[f"{side}_thigh"][1] == pytest.approx(0.09 * y)


def test_constants_are_the_glove_simulators():
    sensor = SensorModel()
    assert sensor.noise_sd[::3].tolist() == [
        body_sim.GYRO_NOISE_DPS,
        body_sim.ACCEL_NOISE,
        body_sim.MAG_NOISE_GAUSS,
    ]
    assert (sensor.field_gauss, sensor.dip_deg, sensor.gravity) == (
        body_sim.FIELD_GAUSS,
        body_sim.DIP_DEG,
        GRAVITY,
    )
    assert inspect.signature(SensorModel).parameters["gyro_bias_range"].default == body_sim.GYRO_BIAS_DPS
    sim = BodySimulator(ARM)
    assert np.allclose(sim.field_earth, sensor.field_earth)


# -- the motion ------------------------------------------------------------------------------------------


def test_the_arm_covers_its_workspace_at_performer_speeds():
    sim = BodySimulator(ARM, noise=False)
    k = sim.kinematics(np.arange(0.0, 60.0, 0.01))
    x = quat_rotate(k.q_body[:, 0], [1.0, 0.0, 0.0])  # the upper arm's direction, body frame
    azimuth = np.degrees(np.arctan2(x[:, 1], x[:, 0]))
    elevation = np.degrees(np.arcsin(np.clip(x[:, 2], -1.0, 1.0)))
    assert -70.0 <= azimuth.min() < -65.0 and 65.0 < azimuth.max() <= 70.0
    assert -30.0 <= elevation.min() < -28.0 and 75.0 < elevation.max() <= 80.0
    elbow = np.degrees(quat_angle(k.q_body[:, 0], k.q_body[:, 1]))  # (flexion and roll together)
    assert elbow.max() > 95.0
    spans = {(name, j.axis): j.span for name, js in sim.script.joints.items() for j in js}
    assert spans[("forearm", "y")] == (-100.0, 0.0)  # elbow flexion 0-100 (negative about y: the hand up)
    assert spans[("forearm", "x")] == (-60.0, 60.0)  # forearm roll
    rate = np.linalg.norm(k.omega, axis=-1)[300:]
    rms = np.sqrt((rate**2).mean(axis=0))
    assert (rms > 0.8).all() and (rms < 2.5).all()
    assert rate.max() < 4.5  # ~3 rad/s, briefly more at the hand when shoulder, elbow and wrist add up


def test_the_body_walks_in_place():
    sim = BodySimulator(BODY, noise=False)
    k = sim.kinematics(np.arange(0.0, 30.0, 0.01))
    right, left = BODY.index("right_thigh"), BODY.index("left_thigh")
    down = np.array([0.0, 0.0, -1.0])
    lift = [
        np.degrees(np.arccos(np.clip(quat_rotate(k.q_body[:, i], down) @ down, -1, 1))) for i in (right, left)
    ]
    assert 45.0 < lift[0].max() <= 51.0 and 45.0 < lift[1].max() <= 51.0
    assert np.corrcoef(lift[0][500:], lift[1][500:])[0, 1] < -0.5  # in opposition
    chest = quat_rotate(k.q_body[:, BODY.index("chest")], [1.0, 0.0, 0.0])
    turn = np.degrees(np.arctan2(chest[:, 1], chest[:, 0]))
    assert 30.0 < np.abs(turn).max() < 42.0  # the torso turns +-30 on a pelvis turning +-10
    assert np.linalg.norm(k.omega, axis=-1).max() < 4.5


def test_a_segment_the_script_does_not_move_stays_with_its_parent():
    script = BodyScript({"upper_arm": [Joint("z", 0.0, ((30.0, 4.0, 0.0),))]}, ramp=1.0)
    k = BodySimulator(ARM, noise=False, script=script).kinematics([0.0, 5.0, 7.5])
    assert np.allclose(quat_angle(k.q[:, 0], k.q[:, 2]), 0.0)
    assert np.degrees(quat_angle(k.q[0, 0], k.q[2, 0])) > 10.0


def test_the_performance_leaves_the_pose_smoothly():
    sim = BodySimulator(ARM, noise=False, pose_seconds=3.0)
    k = sim.kinematics([2.99, 3.0, 3.0 + 1e-6, 3.0001])
    assert (k.omega[:2] == 0.0).all() and np.array_equal(k.specific_force[0], k.specific_force[1])
    # rate and linear acceleration start from zero: the gyro and the accelerometer see no step
    assert np.abs(k.omega[2]).max() < 1e-10 and np.abs(k.omega[3]).max() < 1e-7
    assert np.abs(k.specific_force[2] - k.specific_force[0]).max() < 1e-5
    assert np.abs(k.specific_force[3] - k.specific_force[0]).max() < 1e-3


# -- consistency ------------------------------------------------------------------------------------------


def test_the_gyro_integrates_to_the_orientations_over_a_minute():
    q, truth = integrate_gyro(BodySimulator(ARM, noise=False, heading_deg=30.0), 60.0, 1e-3)
    assert np.degrees(quat_angle(q, truth)).max() < math.degrees(1e-6)


def test_the_body_gyros_integrate_to_the_orientations():
    q, truth = integrate_gyro(BodySimulator(BODY, noise=False, heading_deg=-100.0), 15.0, 1e-3)
    assert np.degrees(quat_angle(q, truth)).max() < math.degrees(1e-6)


@SKELETONS
def test_the_accelerometer_reads_the_second_derivative_of_the_position_minus_gravity(skeleton):
    sim = BodySimulator(skeleton, noise=False, heading_deg=-50.0)
    t = np.linspace(0.0, 60.0, 1501) + 0.0123  # (not on the ramp's ends: the jerk steps there)
    h = 1e-4
    before, now, after = (sim.kinematics(t + d) for d in (-h, 0.0, h))
    acceleration = (before.sensor_position - 2.0 * now.sensor_position + after.sensor_position) / (h * h)
    force = quat_rotate(now.sensor_q, now.specific_force)  # back in the earth frame
    assert np.abs(force - (acceleration + [0.0, 0.0, GRAVITY])).max() < 2e-5
    assert np.abs(acceleration).max() > 2.0  # (there is something to see)


@SKELETONS
def test_sensors_sit_mid_segment_and_positions_are_forward_kinematics(skeleton):
    sim = BodySimulator(skeleton, noise=False, heading_deg=120.0)
    k = sim.take(3000)
    for i in (0, 700, 2999):
        joints, ends = sk.forward(skeleton, [tuple(q) for q in k.q[i]])
        assert np.allclose(joints, k.joints[i], atol=1e-12) and np.allclose(ends, k.ends[i], atol=1e-12)
        middle = 0.5 * (k.joints[i] + k.ends[i])
        assert np.allclose(k.sensor_position[i], middle[sim.sensor_segment], atol=1e-12)
        # the body frame: the heading taken out
        body = quat_multiply(quat_conjugate(sim.heading), k.q[i])
        assert np.allclose(body, k.q_body[i], atol=1e-15)
        joints_body, _ = sk.forward(skeleton, [tuple(q) for q in k.q_body[i]])
        turned = skeleton.root + quat_rotate(sim.heading, np.subtract(joints_body, skeleton.root))
        assert np.allclose(turned, k.joints[i], atol=1e-12)
    # the field: the glove's, north and down by its dip, in each sensor's frame
    assert np.allclose(quat_rotate(k.sensor_q, k.field), sim.field_earth, atol=1e-15)


def test_the_mean_rate_gyro_is_what_a_zero_order_hold_step_integrates():
    sim = BodySimulator(ARM, noise=False, gyro_sampling="mean", heading_deg=10.0)
    k = sim.take(2000)
    q = k.sensor_q[0]
    for i in range(1, 2000):
        q = quat_multiply(q, rotvec_to_quat(k.gyro[i] * sim.period))
    assert np.degrees(quat_angle(q, k.sensor_q[-1])).max() < 1e-9
    assert np.allclose(k.omega, BodySimulator(ARM, noise=False, heading_deg=10.0).take(2000).omega)


# -- the calibration pose ------------------------------------------------------------------------------------


@SKELETONS
def test_the_pose_is_held_still_facing_the_heading(skeleton):
    sim = BodySimulator(skeleton, noise=False, heading_deg=35.0, pose_seconds=2.0)
    k = sim.take(200)
    pose = np.array([s.pose for s in skeleton.segments])
    assert np.allclose(k.q_body, pose, atol=1e-15)
    assert np.allclose(k.q, quat_multiply(quat_from_axis_angle([0.0, 0.0, 1.0], math.radians(35.0)), pose))
    assert (k.gyro == 0.0).all() and (k.omega == 0.0).all()
    assert np.allclose(np.linalg.norm(k.acc, axis=-1), GRAVITY, rtol=1e-15)
    assert np.allclose(k.acc, quat_inverse_rotate(k.sensor_q, [0.0, 0.0, GRAVITY]))
    assert np.allclose(k.joints, k.joints[0]) and np.allclose(k.sensor_position, k.sensor_position[0])


def test_at_rest_a_noisy_gyro_reads_its_bias():
    sim = BodySimulator(ARM, seed=4, pose_seconds=20.0)
    k = sim.take(2000)
    bias_dps = np.degrees(sim.gyro_bias)
    assert (np.abs(bias_dps) <= body_sim.GYRO_BIAS_DPS).all() and np.abs(bias_dps).max() > 1.0
    sd = math.radians(body_sim.GYRO_NOISE_DPS) / math.sqrt(2000)
    assert np.abs(k.gyro.mean(axis=0) - sim.gyro_bias).max() < 4.5 * sd
    assert np.degrees(k.gyro.std(axis=0)) == pytest.approx(np.full((3, 3), body_sim.GYRO_NOISE_DPS), rel=0.1)
    assert np.linalg.norm(k.acc.mean(axis=0), axis=-1) == pytest.approx(np.full(3, GRAVITY), abs=0.01)
    assert k.acc.std(axis=0) == pytest.approx(np.full((3, 3), body_sim.ACCEL_NOISE), rel=0.1)
    assert k.mag.std(axis=0) == pytest.approx(np.full((3, 3), body_sim.MAG_NOISE_GAUSS), rel=0.1)
    assert np.allclose(k.mag.mean(axis=0), k.field[0], atol=4.5 * body_sim.MAG_NOISE_GAUSS / math.sqrt(2000))


# -- mounting, noise, determinism --------------------------------------------------------------------------


@SKELETONS
def test_sensors_are_mounted_askew_within_the_bound(skeleton):
    sim = BodySimulator(skeleton, seed=2, noise=False, mounting_deg=3.0)
    k = sim.take(1000, 500)
    seg = k.q[:, sim.sensor_segment]
    angle = np.degrees(quat_angle(seg, k.sensor_q))
    assert np.allclose(angle, angle[0], atol=1e-9)  # fixed on the segment
    assert (angle[0] > 0.0).all() and (angle[0] <= 3.0 + 1e-9).all()
    assert len(set(np.round(angle[0], 9))) == sim.n_sensors
    assert np.allclose(quat_multiply(seg, sim.mounting), k.sensor_q)
    straight = BodySimulator(skeleton, seed=2, noise=False, mounting_deg=0.0).take(1000, 500)
    assert np.allclose(straight.sensor_q, straight.q[:, sim.sensor_segment], atol=1e-15)
    # the mounting shows in the readings: each sensor reads its segment's rate and forces turned by it
    assert np.allclose(quat_rotate(sim.mounting, k.gyro), straight.gyro, atol=1e-12)
    assert np.allclose(quat_rotate(sim.mounting, k.acc), straight.acc, atol=1e-12)
    assert not np.allclose(k.gyro, straight.gyro, atol=1e-3)


def test_mounting_angles_fill_the_ball():
    angles = np.concatenate(
        [
            np.degrees(quat_angle(BodySimulator(BODY, seed=s).mounting, [1.0, 0.0, 0.0, 0.0]))
            for s in range(20)
        ]
    )
    assert angles.max() <= 3.0 and angles.max() > 2.9 and np.median(angles) > 2.0  # uniform in the ball


def test_the_same_seed_gives_the_same_take_however_it_is_asked_for():
    sim = BodySimulator(ARM, seed=7, heading_deg=20.0)
    whole = sim.take(2600)
    again = BodySimulator(ARM, seed=7, heading_deg=20.0).take(2600)
    for a, b in zip(whole, again, strict=True):
        assert np.array_equal(a, b)
    for k in (0, 1023, 1024, 2047, 2500):  # (noise comes in blocks of 1024 samples)
        one = sim.truth(k)
        for field, a, b in zip(one._fields, one, whole, strict=True):
            assert np.array_equal(a, b[k]), field
    part = sim.take(600, 1000)
    assert np.array_equal(part.gyro, whole.gyro[1000:1600]) and np.array_equal(part.mag, whole.mag[1000:1600])
    other = BodySimulator(ARM, seed=8, heading_deg=20.0).take(10)
    assert not np.allclose(other.gyro, whole.gyro[:10])
    assert not np.allclose(BodySimulator(ARM, seed=8).mounting, sim.mounting)


def test_without_noise_the_readings_are_the_truth():
    k = BodySimulator(BODY, noise=False).take(500, 400)
    assert np.array_equal(k.gyro, k.omega) and np.array_equal(k.acc, k.specific_force)
    assert np.array_equal(k.mag, k.field)


def test_a_minute_of_arm_takes_well_under_a_second():
    sim = BodySimulator(ARM, seed=1)
    start = time.process_time()  # this process's CPU time: a loaded machine shares the cores, not the work
    k = sim.take(6000)
    elapsed = time.process_time() - start
    assert k.gyro.shape == (6000, 3, 3) and k.q.shape == (6000, 3, 4)
    assert elapsed < 1.0, elapsed


# -- refusals -----------------------------------------------------------------------------------------------


def test_bad_settings_are_refused():
    with pytest.raises(ValueError, match="rate_hz"):
        BodySimulator(ARM, rate_hz=0.0)
    with pytest.raises(ValueError, match="finite"):
        BodySimulator(ARM, heading_deg=float("nan"))
    with pytest.raises(ValueError, match=">= 0"):
        BodySimulator(ARM, mounting_deg=-1.0)
    with pytest.raises(ValueError, match="gyro_sampling"):
        BodySimulator(ARM, gyro_sampling="sum")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="'elbow'"):
        BodySimulator(ARM, script=BodyScript({"elbow": [Joint("y")]}))
    with pytest.raises(ValueError, match="axis"):
        Joint("w")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="period"):
        Joint("x", 0.0, ((10.0, 0.0, 0.0),))
    with pytest.raises(ValueError, match="ramp"):
        BodyScript({}, ramp=0.0)
    gap = sk.Skeleton(
        (sk.Segment("a", None, (0, 0, 0), (1, 0, 0), 1), sk.Segment("b", "a", (1, 0, 0), (1, 0, 0), 3))
    )
    with pytest.raises(ValueError, match="sensor 2 is on no segment"):
        BodySimulator(gap)
    with pytest.raises(ValueError, match=">= 0"):
        BodySimulator(ARM).truth(-1)


def test_the_default_script_moves_only_the_skeletons_segments():
    assert set(default_script(ARM).joints) == {"upper_arm", "forearm", "hand"}
    assert set(default_script(BODY).joints) == {s.name for s in BODY.segments}
