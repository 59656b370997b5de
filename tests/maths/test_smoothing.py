"""Tests for pointat.maths.smoothing: curves, range maps, the smoothers, the Schmitt trigger, the deadband."""

import math

import numpy as np
import pytest

from pointat.maths.quaternion import quat_angle, quat_from_axis_angle, quat_slerp
from pointat.maths.smoothing import (
    CURVES,
    Deadband,
    ExpSmoother,
    OneEuroFilter,
    QuatSmoother,
    RangeMap,
    Schmitt,
    apply_curve,
    cutoff_alpha,
    exp_alpha,
)

U = np.linspace(0.0, 1.0, 101)


# --- curves and range maps -------------------------------------------------------------------------


@pytest.mark.parametrize("curve", CURVES)
@pytest.mark.parametrize("shape", [-6.0, -0.5, 0.5, 4.0, 20.0])
def test_every_curve_fixes_the_ends_and_rises(curve, shape):
    kw = {"curvature": shape, "gamma": abs(shape)}
    f = apply_curve(U, curve, **kw)
    assert f[0] == 0.0 and abs(f[-1] - 1.0) < 1e-12
    assert np.all(np.diff(f) >= 0.0)
    outside = np.array([-2.0, -0.1, 1.1, 3.0])
    assert apply_curve(outside, curve, **kw).tolist() == outside.tolist()  # straight line outside


def test_exp_curve_is_supercollider_lincurve_and_log_is_its_inverse():
    for c in (-8.0, -1.0, 0.3, 4.0, 50.0):
        expected = (1.0 - np.exp(c * U)) / (1.0 - np.exp(c))  # SuperCollider's lincurve, normalised
        assert np.max(np.abs(apply_curve(U, "exp", curvature=c) - expected)) < 1e-12
        back = apply_curve(apply_curve(U, "exp", curvature=c), "log", curvature=c)
        assert np.max(np.abs(back - U)) < 1e-12
    # slow start for c > 0, fast for c < 0, and the straight line in the limit
    assert apply_curve(0.5, "exp", curvature=4.0) < 0.5 < apply_curve(0.5, "exp", curvature=-4.0)
    assert np.max(np.abs(apply_curve(U, "exp", curvature=1e-12) - U)) == 0.0
    assert np.max(np.abs(apply_curve(U, "exp", curvature=1e-6) - U)) < 1e-6
    assert apply_curve(0.5, "pow", gamma=2.0) == 0.25 and apply_curve(0.25, "pow", gamma=0.5) == 0.5


def test_range_map_values():
    m = RangeMap(0.0, 127.0, -1.0, 1.0)
    assert m(np.array([0.0, 31.75, 63.5, 127.0, 254.0])).tolist() == [-1.0, -0.5, 0.0, 1.0, 3.0]
    # downward ranges (azimuth + left onto a pan 0 left .. 127 right)
    pan = RangeMap(90.0, -90.0, 0.0, 127.0, clip=True)
    assert pan(np.array([90.0, 0.0, -90.0, -120.0, 170.0])).tolist() == [0.0, 63.5, 127.0, 127.0, 0.0]
    # invert reads the input backwards: the same as swapping in_lo and in_hi, curve included
    x = np.linspace(-0.5, 1.5, 41)
    for curve in CURVES:
        a = RangeMap(0.0, 1.0, 10.0, 20.0, curve=curve, invert=True)(x)
        b = RangeMap(1.0, 0.0, 10.0, 20.0, curve=curve)(x)
        assert np.max(np.abs(a - b)) < 1e-12
    # the curve stays on the output side under invert: fine control near out_lo either way
    up = RangeMap(0.0, 1.0, 0.0, 1.0, curve="exp")(np.array(0.9))
    down = RangeMap(0.0, 1.0, 0.0, 1.0, curve="exp", invert=True)(np.array(0.1))
    assert up == pytest.approx(down, abs=1e-15) and up < 0.9
    clipped = RangeMap(0.0, 1.0, 0.0, 100.0, clip=True, curve="pow", gamma=2.0)(np.array([-1.0, 0.5, 9.0]))
    assert clipped.tolist() == [0.0, 25.0, 100.0]


@pytest.mark.parametrize(
    "args, kwargs, match",
    [
        ((1.0, 1.0, 0.0, 1.0), {}, "input range is empty"),
        ((0.0, 1.0, 5.0, 5.0), {}, "output range is empty"),
        ((0.0, math.nan, 0.0, 1.0), {}, "in_hi must be a finite number"),
        ((0.0, 1.0, 0.0, math.inf), {}, "out_hi must be a finite number"),
        ((0.0, 1.0, 0.0, 1.0), {"curve": "sigmoid"}, "curve must be one of"),
        ((0.0, 1.0, 0.0, 1.0), {"gamma": 0.0}, "gamma must be > 0"),
        ((0.0, 1.0, 0.0, 1.0), {"curvature": 150.0}, "curvature must be within"),
        ((-1e308, 1e308, 0.0, 1.0), {}, "too wide"),
    ],
)
def test_range_map_rejects_what_cannot_work(args, kwargs, match):
    with pytest.raises(ValueError, match=match):
        RangeMap(*args, **kwargs)


def test_range_map_never_outputs_nan_or_inf():
    m = RangeMap(0.0, 1e-300, 0.0, 1e300)
    with pytest.raises(ValueError, match="not finite|NaN or infinite"):
        m(np.array(1e300))
    with pytest.raises(ValueError, match="NaN or infinite"):
        RangeMap(0.0, 1.0, 0.0, 1.0)(np.array([0.5, np.nan]))


# --- exponential smoothing -------------------------------------------------------------------------


def test_exp_alpha_composes_across_rates():
    tau = 0.123
    for dt in (0.001, 0.004, 0.01):
        n = round(0.04 / dt)
        assert (1.0 - exp_alpha(dt, tau)) ** n == pytest.approx(1.0 - exp_alpha(0.04, tau), rel=1e-12)
    assert exp_alpha(0.01, 0.0) == 1.0
    assert exp_alpha(0.1, 0.1) == pytest.approx(1.0 - math.exp(-1.0), abs=1e-15)


def test_exp_smoother_step_response_is_the_same_at_every_rate():
    tau = 0.05
    responses = {}
    for rate in (50, 100, 1000, 8000):
        s = ExpSmoother(tau)
        s.update(0.0, 1.0 / rate)
        t, out = 0.0, {}
        for k in range(1, round(0.3 * rate) + 1):
            t = k / rate
            y = float(s.update(1.0, 1.0 / rate))
            if k % (rate // 50) == 0:
                out[round(t, 6)] = y
        responses[rate] = out
    for t, y in responses[50].items():
        exact = 1.0 - math.exp(-t / tau)  # the step, as seen from the last 0 sample at t = 0
        for rate in (100, 1000, 8000):
            assert responses[rate][t] == pytest.approx(exact, abs=1e-12)
        assert y == pytest.approx(exact, abs=1e-12)


def test_exp_smoother_wraps_azimuth_the_short_way():
    s = ExpSmoother(0.1, wrap=True)
    assert float(s.update(179.0, 0.01)) == 179.0
    out = [float(s.update(-179.0, 0.01)) for _ in range(300)]
    assert all(-180.0 <= y < 180.0 for y in out)
    unwrapped = np.unwrap(np.radians([179.0, *out]))
    assert np.all(np.diff(unwrapped) >= 0)  # it crosses +-180 going up, never back through 0
    assert np.degrees(unwrapped[-1]) == pytest.approx(181.0, abs=1e-9)
    for k, y in enumerate(out[:20], 1):  # y_k = wrap(179 + 2 (1 - e^(-k dt / tau)))
        expected = 179.0 + 2.0 * (1.0 - math.exp(-k * 0.01 / 0.1))
        assert y == pytest.approx(expected - 360.0 if expected >= 180.0 else expected, abs=1e-9)


def test_exp_smoother_elementwise_state_and_errors():
    s = ExpSmoother(0.0)
    assert s.update([1.0, 2.0], 0.01).tolist() == [1.0, 2.0]
    assert s.update([3.0, -2.0], 0.01).tolist() == [3.0, -2.0]  # tau 0: no smoothing
    s.tau = 0.1
    with pytest.raises(ValueError, match="NaN"):
        s.update([np.nan, 0.0], 0.01)
    with pytest.raises(ValueError, match="shape"):
        s.update(1.0, 0.01)
    with pytest.raises(ValueError, match="dt must be"):
        s.update([3.0, -2.0], 0.0)
    assert s.value.tolist() == [3.0, -2.0]  # untouched by the bad samples
    with pytest.raises(ValueError, match="tau must be >= 0"):
        s.tau = -1.0
    s.reset()
    assert s.value is None and float(s.update(7.0, 0.01)) == 7.0


# --- the 1 euro filter -----------------------------------------------------------------------------


def test_one_euro_filter_against_the_paper_by_hand():
    r"""min_cutoff 1 Hz, beta 0.5, d_cutoff 1 Hz; samples 0, 1, 1.5, 1.4 at t = 0, 10, 25, 30 ms.

    alpha(Te, f) = 1 / (1 + tau/Te), tau = 1 / (2 pi f).
    i=1: X^ = 0, dX^ = 0.
    i=2 (Te = 0.010): dX = (1 - 0)/0.01 = 100; alpha(0.01, 1) = 1/(1 + 15.9154943) = 0.0591173974;
         dX^ = 5.91173974; fc = 1 + 0.5 * 5.91173974 = 3.95586987; alpha(0.01, fc) = 0.199073895;
         X^ = 0.199073895.
    i=3 (Te = 0.015): dX = (1.5 - 0.199073895)/0.015 = 86.7284070; alpha(0.015, 1) = 0.0861522...;
         dX^ = 12.8724954; fc = 7.43624771; alpha = 0.412058620; X^ = 0.735131710.
    i=4 (Te = 0.005): dX = 132.973658; dX^ = 16.5306601; fc = 9.26533004; alpha = 0.225454015;
         X^ = 0.885028936.
    """
    f = OneEuroFilter(min_cutoff=1.0, beta=0.5, d_cutoff=1.0)
    t = [0.0, 0.010, 0.025, 0.030]
    x = [0.0, 1.0, 1.5, 1.4]
    out = [float(f.update(x[0], 0.01))]
    for i in range(1, 4):
        out.append(float(f.update(x[i], t[i] - t[i - 1])))
        if i == 1:
            assert float(f.speed) == pytest.approx(5.911739744, abs=1e-8)
    assert out == pytest.approx([0.0, 0.199073895, 0.735131710, 0.885028936], abs=1e-9)
    assert float(f.speed) == pytest.approx(16.5306601, abs=1e-6)


def test_one_euro_filter_matches_the_authors_ground_truth():
    """The first rows of groundTruth.csv in github.com/casiez/OneEuroFilter (BSD-3-Clause; made with
    their C++ implementation, 120 Hz, min_cutoff 1, beta 0.1, d_cutoff 1): timestamp, noisy, filtered,
    printed to 6 significant digits."""
    rows = [
        (0.0, -0.0385099, -0.0385099),
        (0.00833333, -0.0280664, -0.0379872),
        (0.0166667, 0.048622, -0.0334427),
        (0.025, 0.111498, -0.0252696),
        (0.0333333, 0.053026, -0.0207099),
        (0.0416667, 0.120548, -0.0119912),
        (0.05, 0.00972308, -0.0106507),
        (0.0583333, 0.074193, -0.00526521),
        (0.0666667, -0.0236801, -0.00641239),
        (0.075, 0.0462396, -0.00308863),
    ]
    f = OneEuroFilter(1.0, 0.1, 1.0)
    last = None
    for t, noisy, filtered in rows:
        y = float(f.update(noisy, 1 / 120 if last is None else t - last))
        last = t
        assert y == pytest.approx(filtered, abs=2e-7)


def test_one_euro_filter_with_beta_zero_is_a_fixed_cutoff_low_pass():
    rng = np.random.default_rng(3)
    x = rng.normal(size=200)
    f = OneEuroFilter(min_cutoff=2.5, beta=0.0)
    a = cutoff_alpha(0.01, 2.5)
    y_ref = x[0]
    assert float(f.update(x[0], 0.01)) == x[0]
    for v in x[1:]:
        y_ref = y_ref + a * (v - y_ref)
        assert float(f.update(v, 0.01)) == pytest.approx(y_ref, abs=1e-12)


def test_one_euro_filter_cuts_jitter_at_rest_and_follows_movement():
    rng = np.random.default_rng(7)
    t = np.arange(0, 4.0, 0.01)
    clean = np.where(t < 2.0, 0.0, 50.0 * (t - 2.0))  # still, then a 50 unit/s sweep
    noisy = clean + rng.normal(scale=0.5, size=t.size)
    slow = OneEuroFilter(min_cutoff=0.5, beta=0.0)
    euro = OneEuroFilter(min_cutoff=0.5, beta=0.1)
    ys = np.array([float(slow.update(v, 0.01)) for v in noisy])
    ye = np.array([float(euro.update(v, 0.01)) for v in noisy])
    rest = (t > 1.0) & (t < 2.0)
    moving = t > 3.0
    assert np.std(ye[rest] - clean[rest]) < 0.25  # jitter halved at rest at least
    lag_slow = np.mean(clean[moving] - ys[moving])
    lag_euro = np.mean(clean[moving] - ye[moving])
    assert lag_euro < lag_slow / 5.0


def test_one_euro_filter_wraps_azimuth_and_rejects_bad_parameters():
    f = OneEuroFilter(min_cutoff=1.0, beta=0.1, wrap=True)
    f.update(179.0, 0.01)
    out = [float(f.update(-179.0, 0.01)) for _ in range(500)]
    assert all(-180.0 <= y < 180.0 for y in out)
    assert float(f.speed) == pytest.approx(0.0, abs=0.5)  # the 2 degree move, not -358
    assert out[-1] == pytest.approx(-179.0, abs=1e-3)
    for kw, match in (
        ({"min_cutoff": 0.0}, "min_cutoff"),
        ({"beta": -1.0}, "beta"),
        ({"d_cutoff": -2}, "d_cutoff"),
    ):
        with pytest.raises(ValueError, match=match):
            OneEuroFilter(**kw)


def test_one_euro_filter_refuses_an_overflowing_step_and_keeps_its_state():
    f = OneEuroFilter(beta=1.0)
    f.update(0.0, 0.01)
    f.update(1.0, 0.01)
    before = (f.value, f.speed)
    with pytest.raises(ValueError, match="overflow"):
        f.update(1e300, 1e-300)
    assert f.value == before[0] and f.speed == before[1]
    assert np.isfinite(float(f.update(1.0, 0.01)))


# --- rotations -------------------------------------------------------------------------------------


def test_quat_smoother_stays_unit_converges_and_never_flips_sign():
    rng = np.random.default_rng(11)
    target = quat_from_axis_angle([0.3, -0.5, 0.8] / np.linalg.norm([0.3, -0.5, 0.8]), 2.5)
    s = QuatSmoother(0.05)
    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    prev = s.update(q0, 0.01)
    angle = float(quat_angle(prev, target))
    for k in range(200):
        sign = -1.0 if rng.random() < 0.5 else 1.0  # the source flips sign at random
        q = s.update(sign * target * 3.0, 0.01)  # not unit either
        assert abs(np.linalg.norm(q) - 1.0) < 1e-12
        assert float(np.dot(q, prev)) > 0.0  # continuous sign
        new_angle = float(quat_angle(q, target))
        if k < 20:  # the angle to the target shrinks by e^(-dt/tau) each step
            assert new_angle == pytest.approx(angle * math.exp(-0.01 / 0.05), abs=1e-9)
        angle, prev = new_angle, q
    assert angle < 1e-12


def test_quat_smoother_step_is_quat_slerp():
    rng = np.random.default_rng(12)
    p = rng.normal(size=(60, 4))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    q = rng.normal(size=(60, 4))
    q[:20] = p[:20] + 1e-8 * q[:20]  # nearly equal pairs take the small-angle branch
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    for dt in (0.001, 0.02, 0.3):
        expected = quat_slerp(p, q, exp_alpha(dt, 0.05))
        for i in range(len(p)):
            s = QuatSmoother(0.05)
            s.update(p[i], 1.0)
            out = s.update(q[i], dt)
            sign = 1.0 if float(out @ expected[i]) > 0 else -1.0
            assert np.max(np.abs(out - sign * expected[i])) < 1e-12
            assert float(out @ p[i]) > 0.0  # the output keeps the state's sign


def test_quat_smoother_turns_the_short_way():
    s = QuatSmoother(0.1)
    s.update([1.0, 0.0, 0.0, 0.0], 0.01)
    # 350 degrees about z is -10 degrees: the output must turn by negative angles only
    target = quat_from_axis_angle([0.0, 0.0, 1.0], np.radians(350.0))
    for _ in range(100):
        q = s.update(target, 0.01)
        assert q[3] * q[0] <= 1e-15  # sin(theta/2) z-component against cos: theta <= 0
    assert float(quat_angle(q, target)) < 1e-4
    with pytest.raises(ValueError, match="4 numbers"):
        s.update([1.0, 0.0, 0.0], 0.01)
    with pytest.raises(ValueError, match="zero quaternion"):
        s.update([0.0, 0.0, 0.0, 0.0], 0.01)


# --- triggers --------------------------------------------------------------------------------------


def test_schmitt_does_not_flicker_on_noise_around_the_threshold():
    rng = np.random.default_rng(5)
    noise = rng.uniform(-0.09, 0.09, size=400)  # smaller than half the 0.2 hysteresis
    signal = np.concatenate([0.5 + noise[:200], 0.5 + 0.3 + noise[200:]])  # hover at 0.5, then rise
    plain = Schmitt(high=0.5 + 1e-9, low=0.5)  # almost no hysteresis: flickers
    hyst = Schmitt(high=0.6, low=0.4)
    edges_plain = [plain.update(v) for v in signal]
    edges = [hyst.update(v) for v in signal]
    assert sum(e != 0 for e in edges_plain) > 50
    assert [(i, e) for i, e in enumerate(edges) if e] == [(200, 1)]
    falls = [hyst.update(v) for v in 0.5 + noise]  # back to hovering: stays up
    assert not any(falls)
    assert hyst.update(0.4) == -1 and hyst.update(0.41) == 0


def test_schmitt_thresholds_must_leave_a_gap():
    for high, low in ((0.5, 0.5), (0.4, 0.6), (math.nan, 0.0)):
        with pytest.raises(ValueError):
            Schmitt(high, low)
    t = Schmitt(1.0, 0.0, state=True)
    with pytest.raises(ValueError):
        t.set_thresholds(0.0, 1.0)
    assert (t.high, t.low, t.state) == (1.0, 0.0, True)
    with pytest.raises(ValueError, match="NaN"):
        t.update(math.nan)


def test_deadband_passes_only_real_moves():
    d = Deadband(0.5)
    xs = [0.0, 0.3, 0.5, 0.51, 0.2, 0.0, -0.5, -0.6]
    assert [d.update(x) for x in xs] == [True, False, False, True, False, True, False, True]
    d = Deadband(2.0, wrap=True)
    assert [d.update(x) for x in (179.0, -179.5, -178.0, 170.0)] == [True, False, True, True]
    d = Deadband(1.0)
    assert [d.update(v) for v in ([0, 0, 0], [0.5, -0.9, 0.2], [0, 1.1, 0], [0, 1.1])] == [
        True,
        False,
        True,
        True,  # a new shape always passes
    ]
    d.width = 0.0
    assert d.update([0, 1.1]) is False and d.update([0, 1.1000001]) is True
    with pytest.raises(ValueError):
        d.width = -1.0


@pytest.mark.parametrize("curve", ["linear", "exp", "log", "pow"])
@pytest.mark.parametrize("clip", [False, True])
@pytest.mark.parametrize("invert", [False, True])
def test_range_map_number_is_call_for_one_float(curve, clip, invert):
    m = RangeMap(-90.0, 90.0, 0.0, 127.0, curve=curve, clip=clip, invert=invert, curvature=-3.0, gamma=0.5)
    for x in (-200.0, -90.0, -12.5, 0.0, 33.0, 90.0, 1e3):
        assert m.number(x) == m(x)
    for bad in (math.nan, math.inf):
        with pytest.raises(ValueError, match="NaN or infinite"):
            m.number(bad)
    with pytest.raises(ValueError, match="not finite"):
        RangeMap(0.0, 1e-300, 0.0, 1e300).number(1e300)
