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
    IMPACT_S,
    Burst,
    GloveSimulator,
    MoteSpec,
    MotionScript,
    PtyGlove,
    Segment,
    SensorModel,
    adc_full_scale,
    burst_acceleration,
    default_script,
    hold,
)
from pointat.devices.mote_frame import ADC_MAX, Frame, FrameParser, LostPackets
from pointat.devices.serial_reader import SerialMoteReader
from pointat.maths.quaternion import (
    quat_angle,
    quat_conjugate,
    quat_from_axis_angle,
    quat_inverse_rotate,
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


# -- translation bursts: strokes and shakes --------------------------------------------------------------

STEP = 1e-5  # s: the fine grid the bursts are integrated on


def integrate(a: np.ndarray, h: float = STEP) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and displacement from rest (trapezoid rule) of accelerations sampled every ``h``."""
    v = np.concatenate([[0.0], np.cumsum((a[1:] + a[:-1]) * h / 2)])
    x = np.concatenate([[0.0], np.cumsum((v[1:] + v[:-1]) * h / 2)])
    return v, x


@pytest.mark.parametrize("rate", [1.3, 5.0, 20.0])
def test_every_stroke_is_zero_mean_and_brings_the_hand_back_at_peak_g(rate):
    b = Burst(start=0.25, duration=1.0, peak_g=7.0, rate=rate)
    n_per = round(1 / (rate * STEP))
    t = b.start + np.arange(b.count * n_per + 1) * (b.length / (b.count * n_per))
    a = b.profile(t)
    h = t[1] - t[0]
    v, x = integrate(a, h)
    ends = np.arange(0, len(t), n_per)  # the strokes' edges: at rest, where it started
    assert len(ends) == b.count + 1 >= 2
    vmax, xmax = np.abs(v).max(), np.abs(x).max()
    assert vmax > 0.1 and xmax > 1e-3  # it does move
    np.testing.assert_allclose(v[ends], 0.0, atol=1e-9 * vmax)
    np.testing.assert_allclose(x[ends], 0.0, atol=1e-9 * xmax)
    assert x.min() > -1e-9 * xmax  # lift along +axis, strike back down to the start, never beyond
    period = 1 / rate
    w = min(IMPACT_S, period / 5)
    impacts = b.start + (np.arange(b.count) + 1) * period - w / 2  # the middle of each impact lobe
    np.testing.assert_allclose(b.profile(impacts), 7.0 * GRAVITY, rtol=1e-14)  # the peak, upwards
    assert np.abs(a).max() <= 7.0 * GRAVITY * (1 + 1e-14)
    for i in range(b.count):  # each stroke: its own peak, and it is the sharp impact at its end
        stroke = a[ends[i] : ends[i + 1]]
        assert stroke.max() == pytest.approx(7.0 * GRAVITY, rel=1e-6)
        assert abs(stroke.mean()) < 1e-6 * stroke.max()
        sharp = np.flatnonzero(np.abs(stroke) > 0.9 * 7.0 * GRAVITY) * h
        assert sharp.min() >= period - w and sharp.max() - sharp.min() < w / 2
        assert stroke.min() < -0.05 * 7.0 * GRAVITY  # the broad swing back before it
    assert b.profile(b.start - 1e-3) == 0.0 and b.profile(b.start + b.length) == 0.0


@pytest.mark.parametrize("rate, duration", [(5.0, 2.0), (7.0, 0.3), (3.3, 1.9)])
def test_a_shake_is_a_sinusoid_whose_velocity_and_displacement_end_at_zero(rate, duration):
    b = Burst(start=0.5, duration=duration, peak_g=4.0, rate=rate, kind="shake")
    assert b.count == math.floor(duration * rate) and b.length == pytest.approx(b.count / rate)
    n = round(b.length / STEP)
    t = b.start + np.arange(n + 1) * (b.length / n)
    a = b.profile(t)
    v, x = integrate(a, t[1] - t[0])
    vmax, xmax = np.abs(v).max(), np.abs(x).max()
    assert abs(v[-1]) < 1e-9 * vmax and abs(x[-1]) < 1e-9 * xmax
    assert abs(a.mean()) < 1e-9 * 4.0 * GRAVITY
    peak = 4.0 * GRAVITY
    assert np.abs(a).max() <= peak * (1 + 1e-14)
    assert b.profile(b.start + 1.0 / rate) == pytest.approx(-peak, rel=1e-14)  # ramp done, cos = 1
    omega = 2 * math.pi * rate
    assert xmax == pytest.approx(2 * peak / omega**2 * 10 / 9, rel=1e-3)  # as documented
    # a sinusoid at the rate: two sign changes a cycle, faded in and out (continuous at both ends)
    crossings = np.count_nonzero(np.diff(np.sign(a[1:-1])) != 0)
    assert crossings == 2 * b.count
    assert (
        abs(b.profile(b.start + 1e-5)) < 1e-6 * peak
        and abs(b.profile(b.start + b.length - 1e-5)) < 1e-6 * peak
    )


def test_a_repeating_burst_is_the_same_every_time_and_rest_between():
    b = Burst(start=2.0, duration=1.0, peak_g=3.0, rate=4.0, every=5.0)
    t = np.linspace(2.0, 3.0, 1001)
    first = b.profile(t)
    assert np.abs(first).max() > 0.5 * 3.0 * GRAVITY
    for k in (1, 2, 7):
        np.testing.assert_allclose(b.profile(t + 5.0 * k), first, atol=1e-9 * 3.0 * GRAVITY)
    between = np.linspace(3.0, 7.0, 400, endpoint=False)
    assert not b.profile(between).any() and not b.profile(np.linspace(0, 2.0, 200, endpoint=False)).any()
    assert b.active(2.0) and b.active(12.9) and not b.active(13.0) and not b.active(1.99)


def test_the_pointing_axis_follows_the_orientation_and_the_others_do_not():
    rng = np.random.default_rng(5)
    qs = quat_normalize(rng.standard_normal((200, 4)))
    t = np.full(200, 0.2 - 0.0075)  # the middle of the first impact: the peak, along +axis
    peak = 2.0 * GRAVITY
    kw = dict(start=0.0, duration=0.2, peak_g=2.0, rate=5.0)
    pointing = quat_rotate(qs, [1.0, 0.0, 0.0])
    np.testing.assert_allclose(Burst(**kw, axis="pointing").acceleration(t, qs), peak * pointing, atol=1e-12)
    both = pointing + [0.0, 0.0, 1.0]
    both /= np.linalg.norm(both, axis=1, keepdims=True)
    np.testing.assert_allclose(Burst(**kw, axis="both").acceleration(t, qs), peak * both, atol=1e-12)
    np.testing.assert_allclose(Burst(**kw).acceleration(t, qs), np.tile([0, 0, peak], (200, 1)), atol=0)
    own = Burst(**kw, axis=(3.0, -4.0, 0.0))
    assert own.axis == (0.6, -0.8, 0.0)
    np.testing.assert_allclose(own.acceleration(t, qs), np.tile([0.6 * peak, -0.8 * peak, 0], (200, 1)))
    # one sample at a time is the same as all at once; several bursts add up
    scalar = [
        burst_acceleration([Burst(**kw, axis="pointing")], ti, qi)
        for ti, qi in zip(t[:5], qs[:5], strict=True)
    ]
    np.testing.assert_array_equal(scalar, Burst(**kw, axis="pointing").acceleration(t[:5], qs[:5]))
    two = burst_acceleration([Burst(**kw), Burst(**kw, axis="pointing")], t, qs)
    np.testing.assert_allclose(two, peak * (pointing + [0, 0, 1]), atol=1e-12)
    with pytest.raises(ValueError, match="needs the orientation"):
        burst_acceleration(Burst(**kw, axis="pointing"), 0.1)


def test_in_the_simulator_a_pointing_stroke_goes_along_the_hand_as_it_sweeps(script):
    # strokes along the pointing axis during the sweep right across the front (7.5 .. 11.5 s)
    b = Burst(start=7.5, duration=4.0, peak_g=2.0, rate=5.0, axis="pointing")
    sim = GloveSimulator(script, bursts=[b])
    seen = []
    for k in range(750, 1150):
        tr = sim.truth(k)
        a = tr.linear_acceleration
        if np.linalg.norm(a) > 1.0:
            direction = quat_rotate(tr.q, [1.0, 0.0, 0.0])
            np.testing.assert_allclose(a, float(b.profile(tr.t)) * direction, atol=1e-12)
            seen.append(math.degrees(math.atan2(direction[1], direction[0])))
    assert max(seen) > 60 and min(seen) < -60  # the direction turned with the hand


def test_the_truth_has_the_bursts_in_the_specific_force_and_the_same_orientation(script):
    bursts = [
        Burst(start=1.0, duration=1.0, peak_g=3.0, rate=4.0),
        Burst(start=17.5, duration=1.0, peak_g=2.0, rate=6.0, axis="both", kind="shake"),
    ]
    plain, drum = GloveSimulator(script, seed=4), GloveSimulator(script, seed=4, bursts=bursts)
    up = np.array([0.0, 0.0, GRAVITY])
    moved = 0
    for k in [*range(90, 210), *range(1740, 1860)]:
        p, d = plain.truth(k), drum.truth(k)
        for name in ("t", "q", "omega", "field"):  # translation turns nothing
            np.testing.assert_array_equal(getattr(p, name), getattr(d, name))
        a = burst_acceleration(bursts, d.t, d.q)
        np.testing.assert_array_equal(d.linear_acceleration, a)
        np.testing.assert_allclose(d.specific_force, quat_inverse_rotate(d.q, up + a), atol=1e-12)
        np.testing.assert_allclose(quat_rotate(d.q, d.specific_force) - up, a, atol=1e-12)
        moved += bool(np.any(a))
        assert np.any(a) == (not np.array_equal(p.specific_force, d.specific_force))
        np.testing.assert_array_equal(p.linear_acceleration, np.zeros(3))
    assert 150 < moved < 220  # in the bursts only: 1.0 .. 2.0 s and 17.5 .. 18.5 s


def test_an_ideal_glove_in_bursts_decodes_to_the_truth_within_quantisation(script):
    bursts = [
        Burst(start=0.5, duration=3.0, peak_g=2.5, rate=3.0, axis="pointing", every=10.0),
        Burst(start=5.0, duration=3.0, peak_g=2.0, rate=4.0, axis="both", kind="shake", every=10.0),
    ]
    sim = GloveSimulator(script, sensor=SensorModel.ideal(), bursts=bursts)
    res = np.array(DEFAULT_SPEC.resolution)
    strong = 0
    for k in range(0, 4100, 3):
        _, frame, _ = sim.sample(k)
        truth = sim.truth(k)
        decoded = np.array(DEFAULT_SPEC.to_units(frame.channels))
        expected = np.concatenate([np.degrees(truth.omega), truth.specific_force, truth.field])
        assert np.all(np.abs(decoded - expected) <= res / 2 + 1e-9), k
        strong += np.linalg.norm(truth.linear_acceleration) > GRAVITY
    assert strong > 100


def test_without_bursts_the_glove_is_as_it_was_and_a_burst_changes_only_its_window():
    plain = GloveSimulator(seed=6)
    none = GloveSimulator(seed=6, bursts=())
    b = Burst(start=2.0, duration=0.5, peak_g=3.0, rate=4.0, kind="shake")
    shaken = GloveSimulator(seed=6, bursts=[b])
    changed = []
    for k in range(0, 400):
        f, g, h = plain.sample(k), none.sample(k), shaken.sample(k)
        assert f.frame == g.frame and np.array_equal(f.q, g.q)
        assert f.frame.gyro == h.frame.gyro and f.frame.mag == h.frame.mag and np.array_equal(f.q, h.q)
        if f.frame.accel != h.frame.accel:
            changed.append(f.t)
    assert min(changed) >= 2.0 and max(changed) < 2.5 and len(changed) >= 48  # 2.0 .. 2.49 s, a = 0 at 2.0
    # deterministic and random access, bursts or not
    assert [shaken.sample(k).frame for k in reversed(range(190, 260))] == [
        s.frame for s in GloveSimulator(seed=6, bursts=[b]).samples(70, 190)
    ][::-1]


def test_the_adc_is_the_gloves_full_scale_and_clips_a_hard_strike():
    assert adc_full_scale("accel") == (2047 * 0.0192,) * 3
    assert adc_full_scale("gyro") == pytest.approx((204.7,) * 3)
    assert adc_full_scale("accel")[0] / GRAVITY == pytest.approx(4.0, abs=0.01)
    lopsided = MoteSpec(null=(1000.0,) * 9)
    assert adc_full_scale("mag", lopsided) == pytest.approx((1.0,) * 3)  # 1000 counts below the null
    spans = [min(-lo, hi) for lo, hi in DEFAULT_SPEC.full_scale]  # counts 0 and 4095, whichever is nearer
    assert (*adc_full_scale("gyro"), *adc_full_scale("accel"), *adc_full_scale("mag")) == tuple(spans)
    with pytest.raises(ValueError, match="sensor"):
        adc_full_scale("baro")  # type: ignore[arg-type]
    # a 10 g stroke upwards at rest: the accelerometer's z count saturates at 4095, as the real glove's
    b = Burst(start=0.0, duration=0.2, peak_g=10.0, rate=5.0)
    sim = GloveSimulator(MotionScript([hold(1.0)]), rate_hz=1000.0, sensor=SensorModel.ideal(), bursts=[b])
    z = np.array([sim.sample(k).frame.channels[5] for k in range(200)])
    force = np.array([sim.truth(k).specific_force[2] for k in range(200)])
    assert force.max() == pytest.approx(11 * GRAVITY, rel=0.02)  # the peak falls between two samples
    over = force > adc_full_scale("accel")[2]
    assert 5 <= over.sum() <= 15 and np.all(z[over] == ADC_MAX)  # the impact's top
    assert np.all(z[~over] < ADC_MAX)


def test_the_sensor_clips_each_axis_at_its_own_full_scale(script):
    sensor = SensorModel(seed=2, acc_range=1.5 * GRAVITY, gyro_range=60.0)
    free = SensorModel(seed=2)
    b = Burst(start=0.5, duration=1.0, peak_g=3.0, rate=4.0, axis=(1.0, 1.0, 1.0), kind="shake")
    sim = GloveSimulator(script, seed=2, sensor=sensor, bursts=[b])
    acc_clipped = gyro_clipped = 0
    for k in [*range(50, 150), *range(2500, 2600)]:  # the shake, and the roll gesture (141 °/s)
        tr = sim.truth(k)
        rng = np.random.default_rng([2, 1, k])  # the sample's own noise, as the simulator draws it
        v = sensor.values(tr.q, tr.omega, rng, accel_earth=tr.linear_acceleration)
        rng = np.random.default_rng([2, 1, k])
        raw = free.values(tr.q, tr.omega, rng, accel_earth=tr.linear_acceleration)
        np.testing.assert_array_equal(v[:3], np.clip(raw[:3], -60.0, 60.0))
        np.testing.assert_array_equal(v[3:6], np.clip(raw[3:6], -1.5 * GRAVITY, 1.5 * GRAVITY))
        np.testing.assert_array_equal(v[6:], raw[6:])
        counts = sim.sample(k).frame.channels
        assert counts == DEFAULT_SPEC.to_counts(v.tolist())  # the counts are of the clipped readings
        decoded = np.abs(DEFAULT_SPEC.to_units(counts))
        assert np.all(decoded[:3] <= 60.0 + 0.05) and np.all(decoded[3:6] <= 1.5 * GRAVITY + 0.0096)
        acc_clipped += np.any(np.abs(raw[3:6]) > 1.5 * GRAVITY)
        gyro_clipped += np.any(np.abs(raw[:3]) > 60.0)
    assert acc_clipped > 30 and gyro_clipped > 30
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="acc_range"):
            SensorModel(acc_range=bad)
        with pytest.raises(ValueError, match="gyro_range"):
            SensorModel(gyro_range=bad)


@pytest.mark.parametrize(
    "kwargs, said",
    [
        (dict(start=-1.0), "start must be >= 0"),
        (dict(duration=0.0), "duration must be > 0"),
        (dict(peak_g=0.0), "peak_g must be > 0"),
        (dict(peak_g=float("nan")), "peak_g must be finite"),
        (dict(rate=-5.0), "rate must be > 0"),
        (dict(rate="fast"), "rate must be a number"),
        (dict(kind="drum"), "kind must be 'strokes' or 'shake'"),
        (dict(axis="sideways"), "axis must be 'vertical', 'pointing', 'both' or 3 numbers"),
        (dict(axis=(0.0, 0.0, 0.0)), "zero vector"),
        (dict(axis=(1.0, 2.0)), "3 finite numbers"),
        (dict(duration=0.15, rate=5.0), "needs at least 1 stroke"),
        (dict(duration=0.3, rate=5.0, kind="shake"), "needs at least 2 shake cycles"),
        (dict(every=0.5), "every must be 0 .once. or >= duration"),
    ],
)
def test_burst_parameters_are_checked(kwargs, said):
    with pytest.raises(ValueError, match=said):
        Burst(**{"start": 0.0, "duration": 1.0, **kwargs})


def test_bursts_must_be_bursts():
    with pytest.raises(ValueError, match="Burst values"):
        GloveSimulator(bursts=[(1.0, 2.0)])  # type: ignore[list-item]


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
        # deadline scheduling: the count catches up with wall time (a loaded machine lets it fall behind
        # for a moment; a schedule that drifts would fall further behind at every sample)
        assert wait_until(lambda: abs(glove.index - n0 - (time.monotonic() - t0) * 500.0) <= 25, 30.0)


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
