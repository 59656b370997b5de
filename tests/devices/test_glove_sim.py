"""The virtual glove: motion ground truth, sensor model, determinism, and frames through a real pty."""

from __future__ import annotations

import math
import os
import threading
import time

import numpy as np
import pytest

from pointat.devices import glove_sim
from pointat.devices.glove_sim import (
    DEFAULT_SPEC,
    GRAVITY,
    GloveSimulator,
    MoteSpec,
    MotionScript,
    PtyGlove,
    Segment,
    SensorModel,
    default_script,
    hold,
)
from pointat.devices.mote_frame import ADC_MAX, Frame, FrameParser, LostPackets
from pointat.devices.serial_reader import SerialMoteReader
from pointat.maths.quaternion import (
    quat_angle,
    quat_conjugate,
    quat_from_axis_angle,
    quat_multiply,
    quat_normalize,
    quat_rotate,
    rotvec_to_quat,
)
from pointat.testing import wait_until

WAIT = 5.0


@pytest.fixture(scope="module")
def script() -> MotionScript:
    return default_script()


# -- motion script -----------------------------------------------------------------------------------


def test_default_script_shape(script):
    assert 30.0 <= script.duration <= 60.0 and script.loop
    labels = " ".join(s.label for s in script.segments)
    for word in ("roll 90", "raise", "lower", "sweep", "speaker", "distance"):
        assert word in labels
    ts = np.arange(0.0, script.duration, 0.01)
    poses = np.array([script.pose(t) for t in ts])
    assert poses[:, 0].max() >= 100 and poses[:, 0].min() <= -100  # sweeps left and right
    assert poses[:, 1].max() >= 40 and poses[:, 1].min() <= -25  # raise and lower
    assert poses[:, 2].max() == pytest.approx(90.0)
    rates = np.degrees([np.linalg.norm(script.angular_rate(t)) for t in ts])
    assert 60.0 < rates.max() < 0.8 * 204.8  # lively, but inside the gyro range


def test_orientation_is_unit_and_matches_pose(script):
    for t in np.linspace(0.0, script.duration, 97):
        q = script.orientation(t)
        assert np.linalg.norm(q) == pytest.approx(1.0, abs=1e-12)
        az, el, _ = script.pose(t)
        d = quat_rotate(q, [1.0, 0.0, 0.0])  # the pointing axis in NWU
        assert math.degrees(math.asin(d[2])) == pytest.approx(el, abs=1e-9)
        if abs(el) < 80:
            assert math.degrees(math.atan2(d[1], d[0])) == pytest.approx(az, abs=1e-9)


def test_rates_equal_central_difference_of_q(script):
    h = 1e-5
    for t in np.linspace(0.013, script.duration - 0.013, 211):
        q = script.orientation(t)
        q_dot = (script.orientation(t + h) - script.orientation(t - h)) / (2 * h)
        omega = 2.0 * quat_multiply(quat_conjugate(q), q_dot)  # ω_body = 2 q* ⊗ q̇
        assert abs(omega[0]) < 1e-6
        np.testing.assert_allclose(omega[1:], script.angular_rate(t), atol=2e-6)


def test_rates_are_continuous(script):
    """No jumps anywhere, in particular at segment boundaries and at the loop point."""
    eps = 1e-7
    for b in script.boundaries:
        np.testing.assert_allclose(script.angular_rate(b - eps), script.angular_rate(b + eps), atol=1e-5)
        np.testing.assert_allclose(script.angular_rate(b), 0.0, atol=1e-12)
    assert quat_angle(script.orientation(script.duration - 1e-9), script.orientation(0.0)) < 1e-8


def test_integrated_rates_reproduce_the_orientation(script):
    """Integrate the noiseless body rates at 100 Hz (midpoint rule) over the whole script: < 0.5°."""
    dt = 0.01
    n = round(script.duration / dt)
    q = script.orientation(0.0)
    worst = 0.0
    for k in range(n):
        omega = script.angular_rate((k + 0.5) * dt)
        q = quat_normalize(quat_multiply(q, rotvec_to_quat(omega * dt)))  # body rates: right-multiply
        worst = max(worst, float(quat_angle(q, script.orientation((k + 1) * dt))))
    assert math.degrees(worst) < 0.5
    assert math.degrees(quat_angle(q, script.orientation(0.0))) < 0.05  # and the loop closes


def test_roll_gesture_is_90_degrees_about_sensor_x(script):
    bounds = script.boundaries
    rolls = [i for i, s in enumerate(script.segments) if s.roll is not None]
    assert len(rolls) == 2
    for i, sign in zip(rolls, (1.0, -1.0), strict=True):
        t0, t1 = bounds[i], bounds[i + 1]
        q0, q1 = script.orientation(t0), script.orientation(t1)
        expected = quat_multiply(q0, quat_from_axis_angle([1.0, 0.0, 0.0], sign * math.pi / 2))
        assert quat_angle(q1, expected) < 1e-12
        for t in np.linspace(t0, t1, 23):
            w = script.angular_rate(t)
            assert abs(w[1]) < 1e-12 and abs(w[2]) < 1e-12 and sign * w[0] >= 0
        # the pointing direction does not move during the roll
        np.testing.assert_allclose(quat_rotate(q0, [1.0, 0, 0]), quat_rotate(q1, [1.0, 0, 0]), atol=1e-12)


def test_script_looping_and_non_looping():
    s = MotionScript([Segment(1.0, azimuth=90.0), hold(0.5), Segment(1.0, azimuth=0.0)])
    np.testing.assert_allclose(s.orientation(0.3), s.orientation(0.3 + 5 * s.duration), atol=1e-12)
    np.testing.assert_allclose(s.orientation(-0.2), s.orientation(s.duration - 0.2), atol=1e-12)
    once = MotionScript([Segment(1.0, azimuth=90.0, elevation=10.0)], loop=False)
    assert once.pose(7.0) == (90.0, 10.0, 0.0) and once.pose(-1.0) == (0.0, 0.0, 0.0)
    assert once.angular_rate(7.0).tolist() == [0.0, 0.0, 0.0]
    assert once.segment_at(0.5) == (0, once.segments[0])


@pytest.mark.parametrize(
    "segments, kwargs",
    [
        ([], {}),
        ([Segment(0.0, azimuth=1.0), Segment(1.0, azimuth=0.0)], {}),
        ([Segment(1.0, elevation=89.0), Segment(1.0, elevation=0.0)], {}),
        ([Segment(1.0, azimuth=10.0)], {}),  # a loop that does not come back
    ],
)
def test_script_validation(segments, kwargs):
    with pytest.raises(ValueError):
        MotionScript(segments, **kwargs)


# -- sensor model ------------------------------------------------------------------------------------


def test_mote_spec_is_shared_and_documented():
    assert glove_sim.MoteSpec is MoteSpec and glove_sim.DEFAULT_SPEC is DEFAULT_SPEC
    assert glove_sim.DEFAULT_RESOLUTION == {"gyro": 0.1, "accel": 0.0192, "mag": 0.001}


def test_ideal_sensor_decodes_to_truth_within_quantisation(script):
    sim = GloveSimulator(script, sensor=SensorModel.ideal())
    res = np.array(DEFAULT_SPEC.resolution)
    for k in range(0, round(script.duration * 100), 37):
        _, frame, q = sim.sample(k)
        truth = sim.truth(k)
        np.testing.assert_array_equal(q, truth.q)
        decoded = np.array(DEFAULT_SPEC.to_units(frame.channels))
        expected = np.concatenate([np.degrees(truth.omega), truth.specific_force, truth.field])
        assert np.all(np.abs(decoded - expected) <= res / 2 + 1e-9), k


def test_physics_of_the_truth(script):
    sim = GloveSimulator(script)
    dip = math.radians(67.0)
    for k in range(0, 4500, 53):
        tr = sim.truth(k)
        assert np.linalg.norm(tr.specific_force) == pytest.approx(GRAVITY)
        assert np.linalg.norm(tr.field) == pytest.approx(0.48)
        # field and gravity keep the dip angle between them: angle(B, up) = 90° + dip
        cos_angle = tr.field @ tr.specific_force / (0.48 * GRAVITY)
        assert cos_angle == pytest.approx(math.cos(math.pi / 2 + dip))
        np.testing.assert_allclose(quat_rotate(tr.q, tr.specific_force), [0, 0, GRAVITY], atol=1e-9)
    rest = sim.truth(0)
    np.testing.assert_allclose(rest.specific_force, [0, 0, GRAVITY], atol=1e-12)
    np.testing.assert_allclose(rest.field, [0.48 * math.cos(dip), 0, -0.48 * math.sin(dip)], atol=1e-12)


def test_noisy_sensor_decodes_to_truth_plus_bias_within_noise(script):
    sensor = SensorModel(seed=3)
    assert np.all(np.abs(sensor.gyro_bias_dps) <= 3.0) and np.any(np.abs(sensor.gyro_bias_dps) > 0.3)
    sim = GloveSimulator(script, seed=3, sensor=sensor)
    residuals = []
    for k in range(0, 4500, 3):
        _, frame, _ = sim.sample(k)
        tr = sim.truth(k)
        decoded = np.array(DEFAULT_SPEC.to_units(frame.channels))
        expected = np.concatenate([np.degrees(tr.omega), tr.specific_force, tr.field])
        residuals.append(decoded - expected)
    r = np.array(residuals)
    np.testing.assert_allclose(r[:, :3].mean(axis=0), sensor.gyro_bias_dps, atol=0.05)
    np.testing.assert_allclose(r[:, 3:].mean(axis=0), 0.0, atol=0.003)
    res = np.array(DEFAULT_SPEC.resolution)
    expected_sd = np.sqrt(sensor.noise_sd**2 + res**2 / 12)  # noise plus rounding
    np.testing.assert_allclose(r.std(axis=0), expected_sd, rtol=0.12)
    assert np.all(np.abs(r - r.mean(axis=0)) < 6 * expected_sd)


def test_quantisation_stays_in_range():
    wild = SensorModel(
        gyro_bias_dps=(0.0, 0.0, 0.0), gyro_noise_dps=50.0, accel_noise=30.0, mag_noise_gauss=3.0
    )
    fast = MotionScript([Segment(0.5, azimuth=180.0), Segment(0.5, azimuth=0.0)])  # 565 °/s peak
    sim = GloveSimulator(fast, sensor=wild, seed=9)
    counts = np.array([sim.sample(k).frame.channels for k in range(100)])
    assert counts.dtype.kind == "i" and counts.min() == 0 and counts.max() == ADC_MAX
    assert all(isinstance(c, int) for c in sim.sample(25).frame.channels)


def test_determinism_and_random_access():
    a, b, c = GloveSimulator(seed=11), GloveSimulator(seed=11), GloveSimulator(seed=12)
    seq = [s.frame for s in a.samples(50)]
    assert [b.sample(k).frame for k in reversed(range(50))] == seq[::-1]
    assert [s.frame for _, s in zip(range(50), iter(b), strict=False)] == seq
    assert [s.frame for s in c.samples(50)] != seq
    assert a.sample(10).t == pytest.approx(0.1)
    wrap = GloveSimulator(mote_id=7, n_pack_start=65534)
    assert [s.frame.n_pack for s in wrap.samples(4)] == [65534, 65535, 0, 1]
    assert all(s.frame.mote == 7 for s in wrap.samples(4))
    with pytest.raises(ValueError):
        GloveSimulator(rate_hz=0)
    with pytest.raises(ValueError):
        a.sample(-1)


# -- through a pseudo-terminal -------------------------------------------------------------------------


@pytest.mark.parametrize("fmt", ["binary", "text"])
def test_pty_glove_frames_read_back_through_the_serial_reader(fmt):
    sim = GloveSimulator(rate_hz=200.0, seed=4, mote_id=3)
    got: list[tuple[Frame, float]] = []
    events: list[object] = []
    lock = threading.Lock()

    def on_frame(f: Frame, t: float) -> None:
        with lock:
            got.append((f, t))

    with PtyGlove(sim, format=fmt) as glove:
        reader = SerialMoteReader(
            glove.device_path, on_frame=on_frame, on_event=events.append, read_timeout=0.02
        )
        with reader:
            assert reader.wait_open(WAIT)
            assert wait_until(lambda: len(got) >= 60)
            stats = reader.stats()
        assert glove.is_running
    assert not glove.is_running
    frames = [f for f, _ in got]
    first = frames[0].n_pack  # frames sent before the reader opened the port were flushed by it
    assert [f.n_pack for f in frames] == list(range(first, first + len(frames)))
    assert frames == [sim.sample(f.n_pack).frame for f in frames]
    assert not [e for e in events if isinstance(e, LostPackets)]
    assert stats.corrupt == 0 and stats.motes[3].lost == 0
    times = [t for _, t in got]
    rate = (len(times) - 1) / (times[-1] - times[0])
    assert 100.0 < rate < 400.0  # about 200 Hz (loose: a loaded CI machine)


def test_pty_glove_schedule_does_not_drift():
    sim = GloveSimulator(rate_hz=500.0)
    with PtyGlove(sim) as glove:
        t0, n0 = time.monotonic(), glove.index
        time.sleep(0.4)
        n = glove.index - n0
        elapsed = time.monotonic() - t0
    assert abs(n - elapsed * 500.0) <= 25  # deadline scheduling: count tracks wall time


def test_pty_glove_without_reader_drops_instead_of_blocking():
    glove = PtyGlove(GloveSimulator(rate_hz=100.0), max_pending=1000)
    try:
        for _ in range(2000):  # 42 kB into a pty nobody reads
            glove.send()
        assert glove.sent == 2000 and glove.dropped_bytes > 0
        # what the pty kept reads back as good frames in order (a frame cut by the drop is left pending)
        os.set_blocking(glove._slave, False)
        data = bytearray()
        while True:
            try:
                chunk = os.read(glove._slave, 65536)
            except BlockingIOError:
                break
            if not chunk:
                break
            data += chunk
        parser = FrameParser()
        frames = parser.feed(bytes(data))
        assert len(frames) > 100 and parser.stats.corrupt == 0
        assert [f.n_pack for f in frames] == list(range(len(frames)))  # the pty kept the head of the stream
    finally:
        glove.close()
    glove.close()
    glove.stop()
    with pytest.raises(RuntimeError):
        glove.start()


def test_pty_glove_start_stop_idempotent():
    glove = PtyGlove(GloveSimulator(rate_hz=100.0), start_index=10)
    assert glove.index == 10
    glove.stop()
    assert glove.start() is glove and glove.start() is glove
    assert wait_until(lambda: glove.index > 12)
    glove.stop()
    glove.stop()
    stopped_at = glove.index
    time.sleep(0.05)
    assert glove.index == stopped_at and not glove.is_running
    glove.close()
    with pytest.raises(ValueError):
        PtyGlove(format="csv")  # type: ignore[arg-type]


def test_the_per_sample_float_path_is_the_array_maths(script):
    # orientation and true_values run on floats, one sample at a time (the simulator's own cost); the
    # reference is pointat.maths.quaternion on arrays (equal here to the last bit; a libm may differ)
    from pointat.maths.quaternion import euler_to_quat, quat_inverse_rotate

    sensor = SensorModel(seed=3)
    earth = np.stack([sensor.gravity_earth, sensor.field_earth])
    for t in np.random.default_rng(2).uniform(0.0, script.duration, 500):
        az, el, roll = script.pose(t)
        q = script.orientation(t)
        assert np.allclose(q, euler_to_quat(az, -el, roll, degrees=True), rtol=0, atol=1e-15)
        w = script.angular_rate(t)
        want = np.concatenate([np.degrees(w), *quat_inverse_rotate(q, earth)])
        assert np.allclose(sensor.true_values(q, w), want, rtol=0, atol=1e-12)
