r"""Bachmann's posture tracking end to end, at maths level: the simulated right arm
(:data:`pointat.devices.body_sim.ARM`, sensors with noise, gyro biases and 3° mounting errors, the body
facing a heading other than north) at 100 Hz, its three sensors through one :class:`TQTBank` (robust
mode), the offsets taken at the end of the calibration pose (:func:`pointat.maths.skeleton.offsets`),
then for the rest of a 60 s take the segments' orientations and the wrist (the hand's joint) from
:func:`~pointat.maths.skeleton.segment_orientations` and :func:`~pointat.maths.skeleton.forward`, against
the truth in the body frame.

The claims: each segment within 1° and the wrist within 1 cm, RMS over the take after the pose.  Three
readings of the error:

(a) *as is*: the estimate in its body frame (the heading of the calibration pose from the root's
    sensor taken out) against the truth in its own (its true heading taken out);
(b) *the global yaw removed*: (a) turned about the vertical by the yaw between the true heading and the
    estimated one at the calibration instant (the root sensor's mounting yaw and heading error), as a
    ``reference`` press would turn it;
(c) *the front known*: the offsets taken with the body's true heading instead of the root sensor's.

What the tests show (``pytest -s`` prints the figures):

* The root sensor's mounting yaw is **not** a global yaw of the estimated body.  The offsets make every
  segment equal its pose at the calibration instant, so there the estimate is exact whatever the front;
  the wrong front goes into every segment's offset, :math:`s_{est} = Y^{-1} s\,Y` (pose the identity,
  :math:`Y` the yaw of the estimated front from the true one), an error of :math:`2\sin(\theta/2)|Y|`
  for a segment tilted by :math:`\theta` from its pose: nothing while the arm only turns about the
  vertical, up to :math:`2|Y|` when it points up.  Turning the output (b) makes it worse; calibrating
  with the true front (c) takes it out exactly.  With 3° mountings the front is off by up to ~3°.
* The filter's default ``bias_clip`` (2°/s per axis) is below the glove simulator's gyro biases (±3°/s):
  a sensor with any axis beyond it is never "at rest", learns no bias, and drifts by tens of degrees.
  The tests give the bank ``bias_clip`` = 3.5°/s (the sensor's range: the one setting changed).
* A 3 s hold with the default gains does not settle the filter: rest (and the bias) is only found after
  1.5 s, the heading drifts by up to bias × 1.5 s before it and the heading correction (``k_heading`` =
  0.05, 20 s) takes a minute to remove that; what is left at the calibration instant is in the offsets,
  and decays into the performance.  A still hold has no acceleration to reject: the tests hold the pose
  5 s with fast gains (``k`` = 5, ``k_heading`` and ``k_heading_unrested`` = 2, ``acc_tau`` = 0.25 s),
  back to the defaults when the offsets are taken.
* What the filter errs by in motion, once calibrated, is the linear acceleration of sensors on moving
  segments (centripetal and tangential, 1.3 m/s² RMS at the hand) through its 2 s average of the vertical:
  tilt 0.6° RMS at the hand sensor, 1.3° at most, on ideal sensors; and a gyro sampled at the instant
  rather than over the sample (``gyro_sampling``) puts the estimate half a sample ahead, ω·Δt/2 (0.5° RMS
  at the hand).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pointat.devices.body_sim import ARM, BodySimulator
from pointat.maths import scalar as sq
from pointat.maths import skeleton as sk
from pointat.maths.quaternion import quat_angle, quat_conjugate, quat_multiply, quat_rotate
from pointat.maths.tqt import TQTBank, TQTFlags

TAKE = 60.0
REACH = 0.55  # shoulder to wrist, m
BIAS_CLIP = math.radians(3.5)  # the glove's gyro biases reach 3 deg/s per axis
# still in the pose: nothing to reject (the heading's gain before the bias is known, too: a 5 s hold is
# less than bias_tau of rest)
HOLD_GAINS = {"k": 5.0, "k_heading": 2.0, "k_heading_unrested": 2.0, "acc_tau": 0.25}


def track(sim, bank, hold_gains=None):
    """The take and each sample's sensor estimates; ``hold_gains`` are the bank's during the pose hold."""
    n = int(round(TAKE * sim.rate_hz))
    take = sim.take(n)
    k0 = int(round(sim.pose_seconds * sim.rate_hz)) - 1  # the calibration instant: the pose's last sample
    defaults = {name: getattr(bank, name) for name in hold_gains or {}}
    if hold_gains:
        bank.retune(**hold_gains)
    est = np.empty((n, sim.n_sensors, 4))
    for k in range(n):
        est[k] = bank.update(take.gyro[k], take.acc[k], take.mag[k], sim.period)
        if k == k0 and hold_gains:
            bank.retune(**defaults)
    return take, est, k0


def errors(sim, take, sensor_q, k0):
    """Per reading (a), (b), (c) of the module docstring: segment orientation errors (degrees, (N, 3)) and
    wrist position errors (cm, (N,)) after the calibration instant; and the global yaw, degrees."""
    skeleton = sim.skeleton
    at_pose = [tuple(q) for q in sensor_q[k0]]
    cal = sk.calibrate(skeleton, at_pose, front=ROOT_FRONT(skeleton, at_pose))
    front = cal.front
    true_front = tuple(sim.heading)
    yaw = sk.heading(sq.multiply(true_front, sq.conjugate(front)))
    known = [
        sq.normalize(
            sq.multiply(sq.conjugate(sq.multiply(sq.conjugate(true_front), at_pose[s.sensor - 1])), s.pose)
        )
        for s in skeleton.segments
    ]
    wrist = skeleton.index("hand")
    out = {m: ([], []) for m in "abc"}
    for k in range(k0 + 1, len(sensor_q)):
        q = [tuple(c) for c in sensor_q[k]]
        as_is = sk.segment_orientations(skeleton, q, cal)
        estimates = {
            "a": as_is,
            "b": [sq.multiply(yaw, s) for s in as_is],
            "c": sk.segment_orientations(skeleton, q, sk.BodyCalibration(true_front, tuple(known))),
        }
        truth = sk.forward(skeleton, [tuple(c) for c in take.q_body[k]])[0][wrist]
        for m, s in estimates.items():
            out[m][0].append(quat_angle(np.array(s), take.q_body[k]))
            out[m][1].append(math.dist(sk.forward(skeleton, s)[0][wrist], truth))
    result = {m: (np.degrees(np.array(o)), 100.0 * np.array(p)) for m, (o, p) in out.items()}
    return result, math.degrees(2.0 * math.atan2(yaw[3], yaw[0]))


def ROOT_FRONT(skeleton, at_pose):  # noqa: N802
    """The front as the first version of ``calibrate`` took it, from the root segment's sensor alone
    (what these tests measure: its mounting yaw in every offset); ``calibrate`` now averages all sensors."""
    root = skeleton.segments[0]
    return sk.heading(sq.multiply(at_pose[root.sensor - 1], sq.conjugate(root.pose)))


def rms(x, axis=0):
    return np.sqrt(np.mean(np.square(x), axis=axis))


def table(result, yaw_deg):
    """The figures, one line per reading (shown with ``pytest -s``)."""
    lines = [f"global yaw at the calibration instant: {yaw_deg:+.2f} deg"]
    for m, label in (("a", "as is"), ("b", "global yaw removed"), ("c", "front known")):
        o, p = result[m]
        lines.append(
            f"({m}) {label:18s} segments RMS {np.round(rms(o), 2).tolist()} max {np.round(o.max(axis=0), 2).tolist()}"
            f" deg | wrist RMS {rms(p):.2f} max {p.max():.2f} cm"
        )
    return "\n".join(lines)


# -- the claims -------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("seed", "heading", "sampling"),
    [
        pytest.param(0, 35.0, "instant", id="seed0"),
        pytest.param(2, -120.0, "instant", id="seed2_front_3deg_off", marks=pytest.mark.slow),
        pytest.param(0, 35.0, "mean", id="seed0_mean_rate_gyro", marks=pytest.mark.slow),
    ],
)
def test_each_segment_within_a_degree_and_the_wrist_within_a_centimetre(seed, heading, sampling):
    sim = BodySimulator(ARM, seed=seed, heading_deg=heading, pose_seconds=5.0, gyro_sampling=sampling)
    take, est, k0 = track(sim, TQTBank(3, bias_clip=BIAS_CLIP), HOLD_GAINS)
    result, yaw = errors(sim, take, est, k0)
    print(f"\nseed {seed}, heading {heading}, gyro {sampling}\n" + table(result, yaw))
    # the claims, with the body's front known (c)
    o, p = result["c"]
    assert rms(o).max() <= 1.0 and rms(p) <= 1.0
    assert o.max() <= 2.5 and p.max() <= 2.0
    # as is (a), the front from the root sensor: its yaw error Y adds at most 2|Y| to every segment and
    # 2|Y| x reach to the wrist (module docstring)
    y = math.radians(abs(yaw))
    a_o, a_p = result["a"]
    assert (rms(a_o) <= rms(o) + math.degrees(2.0 * y) + 1e-9).all()
    assert rms(a_p) <= rms(p) + 100.0 * 2.0 * y * REACH + 1e-9


def test_the_claims_as_is_hold_with_sensors_strapped_on_straight():
    """Without mounting errors the root sensor's front is the filter's heading alone: (a) meets the claims."""
    sim = BodySimulator(ARM, seed=0, heading_deg=35.0, pose_seconds=5.0, mounting_deg=0.0)
    take, est, k0 = track(sim, TQTBank(3, bias_clip=BIAS_CLIP), HOLD_GAINS)
    result, yaw = errors(sim, take, est, k0)
    print("\n" + table(result, yaw))
    assert abs(yaw) < 0.2
    o, p = result["a"]
    assert rms(o).max() <= 1.0 and rms(p) <= 1.0


@pytest.mark.slow
@pytest.mark.xfail(
    strict=True,
    reason="the filter's default bias_clip (2 deg/s) learns none of the glove's biases beyond it (+-3 deg/s), "
    "and a 3 s hold at the default gains leaves the heading unsettled: see the module docstring",
)
def test_the_claims_with_the_filter_as_it_comes():
    sim = BodySimulator(ARM, seed=0, heading_deg=35.0, pose_seconds=3.0)
    take, est, k0 = track(sim, TQTBank(3))
    result, yaw = errors(sim, take, est, k0)
    print("\n" + table(result, yaw))
    o, p = result["a"]
    assert rms(o).max() <= 1.0 and rms(p) <= 1.0


# -- why -----------------------------------------------------------------------------------------------------


def test_the_root_sensors_mounting_yaw_is_in_every_offset_not_a_global_yaw():
    """With exact sensor orientations (a perfect filter) the only error left is the front's."""
    sim = BodySimulator(ARM, seed=2, heading_deg=-120.0, noise=False)
    take = sim.take(int(TAKE * sim.rate_hz))
    k0 = int(sim.pose_seconds * sim.rate_hz) - 1
    result, yaw = errors(sim, take, take.sensor_q, k0)
    assert 2.0 < abs(yaw) <= 3.0  # the root sensor's mounting yaw, seed 2
    y = sq.axis_angle_quat(0.0, 0.0, 1.0, math.radians(-yaw))  # the estimated front from the true one
    at_pose = [tuple(q) for q in take.sensor_q[k0]]
    cal = sk.calibrate(ARM, at_pose, front=ROOT_FRONT(ARM, at_pose))
    assert np.allclose(sk.segment_orientations(ARM, at_pose, cal), [(1.0, 0.0, 0.0, 0.0)] * 3, atol=1e-15)
    for k in (k0 + 700, k0 + 2500, 5999):
        s = sk.segment_orientations(ARM, [tuple(q) for q in take.sensor_q[k]], cal)
        conjugated = quat_multiply(quat_multiply(quat_conjugate(y), take.q_body[k]), y)
        assert np.degrees(quat_angle(s, conjugated)).max() < 1e-9
    o_c, p_c = result["c"]
    assert o_c.max() < 1e-9 and p_c.max() < 1e-9
    # the error of a segment tilted by theta from its pose: 4 asin(sin(|Y|/2) sin(theta/2)) <= 2 sin(theta/2) |Y|
    o_a, p_a = result["a"]
    up = quat_rotate(take.q_body[k0 + 1 :], [0.0, 0.0, 1.0])[..., 2]
    tilt = np.arccos(np.clip(up, -1.0, 1.0))
    exact = np.degrees(4.0 * np.arcsin(math.sin(math.radians(abs(yaw)) / 2.0) * np.sin(tilt / 2.0)))
    assert np.abs(o_a - exact).max() < 1e-6
    assert rms(o_a).max() > 1.0 and rms(p_a) > 1.0  # 2.4 deg of yaw alone breaks the claims
    o_b, _ = result["b"]
    assert (rms(o_b) > rms(o_a)).all()  # and no global yaw takes it out


def test_the_default_bias_clip_refuses_the_glove_simulators_biases():
    sim = BodySimulator(ARM, seed=0, heading_deg=35.0, pose_seconds=5.0, noise=True)
    take = sim.take(500)
    bank = TQTBank(3)
    rest = np.zeros(3, dtype=bool)
    for k in range(500):
        bank.update(take.gyro[k], take.acc[k], take.mag[k], sim.period)
        rest |= (bank.flags & TQTFlags.REST) != 0
    beyond = (np.abs(sim.gyro_bias) >= bank.bias_clip).any(axis=1)
    assert beyond.tolist() == [True, False, True]  # seed 0: sensors 1 and 3 have an axis beyond 2 deg/s
    assert (rest == ~beyond).all()
    # no bias from rest; only what the heading's correction lends it in motion (motion_bias_tau), slowly
    assert np.degrees(np.abs(bank.bias[beyond])).max() < 0.01
    assert np.degrees(np.abs(bank.bias[~beyond] - sim.gyro_bias[~beyond])).max() < 0.1


def test_what_the_filter_errs_by_on_a_moving_arm():
    """Ideal sensors: a mean-rate gyro and gravity alone track to rounding; an instant-rate gyro leads by
    half a sample; the sensors' linear acceleration tilts the estimate by a fraction of a degree."""
    figures = {}
    for sampling in ("mean", "instant"):
        sim = BodySimulator(ARM, noise=False, heading_deg=35.0, gyro_sampling=sampling)
        take = sim.take(int(TAKE * sim.rate_hz))
        gravity_only = quat_rotate(quat_conjugate(take.sensor_q), [0.0, 0.0, 9.80665])
        for label, acc in (("gravity", gravity_only), ("moving", take.acc)):
            bank = TQTBank(3)
            est = np.array(
                [bank.update(take.gyro[k], acc[k], take.mag[k], sim.period) for k in range(len(acc))]
            )
            figures[sampling, label] = np.degrees(quat_angle(est, take.sensor_q))[300:]
            if sampling == "instant" and label == "gravity":
                ahead = sim.kinematics(take.t + 0.5 * sim.period).sensor_q
                figures["ahead"] = np.degrees(quat_angle(est, ahead))[300:]
    assert figures["mean", "gravity"].max() < 0.05
    assert rms(figures["instant", "gravity"]).max() > 0.4  # half a sample at ~1.8 rad/s RMS
    assert rms(figures["ahead"]).max() < 0.2  # ... which is the truth half a sample on
    moving = figures["mean", "moving"]
    assert 0.3 < rms(moving).max() < 0.8 and moving.max() < 1.5
