"""The gesture maths: DTW held to a plain reference, the recognizer on a simulated performer with known
truth (gestures spliced between rests and ordinary pointing), strokes with known directions and peaks,
postures, and following."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.performer import perform, performed, rehearse, score, sensor_stream
from pointat.devices.glove_sim import Burst, GloveSimulator, MotionScript, Segment, hold
from pointat.devices.mote_frame import DEFAULT_SPEC
from pointat.maths.dtw import Spring, dtw_distance, dtw_many, dtw_prefix, dtw_prefix_many
from pointat.maths.gestures import (
    NULL,
    Decided,
    Dropped,
    Ended,
    Example,
    Follower,
    GestureModel,
    PostureModel,
    Recognizer,
    Segmenter,
    Spotter,
    StrokeDetector,
)
from pointat.maths.quaternion import euler_to_quat


# ------------------------------------------------------------------------------------------- DTW
def _reference(a: np.ndarray, b: np.ndarray, w: int) -> np.ndarray:
    """The cumulative cost matrix by the recurrence, written plainly (the twin of the compiled loop)."""
    n, m = len(a), len(b)
    d = np.full((n + 1, m + 1), np.inf)
    d[0, 0] = 0.0
    for i in range(1, n + 1):
        for j in range(max(1, i - w), min(m, i + w) + 1):
            c = float(np.sum((a[i - 1] - b[j - 1]) ** 2))
            d[i, j] = c + min(d[i - 1, j - 1], d[i - 1, j], d[i, j - 1])
    return d


@pytest.mark.parametrize("seed", range(6))
def test_dtw_equals_the_plain_recurrence(seed):
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(int(rng.integers(2, 40)), 3))
    b = rng.normal(size=(int(rng.integers(2, 40)), 3))
    for fraction in (0.1, 0.3, 1.0):
        w = max(1, abs(len(a) - len(b)), math.ceil(fraction * max(len(a), len(b))))
        ref = _reference(a, b, w)
        assert dtw_distance(a, b, fraction) == pytest.approx(ref[-1, -1] / (len(a) + len(b)), rel=1e-12)
        # the open end: the best D(n, j) / (n + j) over j, with the band not widened
        wp = max(1, math.ceil(fraction * max(len(a), len(b))))
        refp = _reference(a, b, wp)[-1, 1:] / (len(a) + np.arange(1, len(b) + 1))
        cost, j = dtw_prefix(a, b, fraction)
        if np.isfinite(refp).any():
            assert cost == pytest.approx(refp.min(), rel=1e-12) and j == int(np.argmin(refp)) + 1
        # many at once, each feature alone (DTW_I) the sum of the single-feature distances
        many = dtw_many(a, [b, a], fraction, each=True)
        alone = sum(dtw_distance(a[:, [k]], b[:, [k]], fraction) for k in range(3))
        assert many[0] == pytest.approx(alone, rel=1e-12) and many[1] == 0.0
        rows = dtw_prefix_many(a, [b], fraction)
        assert rows[0, 0] == pytest.approx(cost, rel=1e-12, nan_ok=True)


@pytest.mark.parametrize("seed", range(5))
def test_spring_finds_a_template_in_a_stream_at_its_own_dtw_distance(seed):
    """Subsequence DTW (Spring): the best match ending at each frame; where a warped copy of the template
    lies in the stream, the match starts and ends there, at whole-series DTW's distance of that span."""
    rng = np.random.default_rng(seed)
    template = np.cumsum(rng.normal(0, 1, (20, 3)), axis=0)
    copy = template[np.sort(rng.integers(0, 20, 26))]  # warped: frames held or skipped
    copy[0], copy[-1] = template[0], template[-1]
    stream = np.vstack([rng.normal(50, 1, (30, 3)), copy, rng.normal(-50, 1, (30, 3))])
    spring = Spring([template, template[::-1]])
    rows = [spring.push(x).copy() for x in stream]
    end = int(np.argmin([r[0, 0] for r in rows]))
    start = int(rows[end][0, 1])
    assert 30 <= start <= 32 and 30 + len(copy) - 3 <= end <= 30 + len(copy) - 1  # (a held frame may be left)
    assert rows[end][0, 0] == pytest.approx(dtw_distance(stream[start : end + 1], template, 1.0), rel=1e-12)


def test_dtw_refuses_what_it_cannot_compare():
    with pytest.raises(ValueError, match="shape"):
        dtw_distance(np.zeros((0, 3)), np.zeros((4, 3)))
    with pytest.raises(ValueError, match="features"):
        dtw_distance(np.zeros((4, 2)), np.zeros((4, 3)))


# ------------------------------------------------------------------------------ the recognizer
def _perform(rec: Recognizer, t, frames):
    return [(when, d.label) for when, d in perform(rec, t, frames)]


@pytest.fixture(scope="module")
def taught():
    """A recognizer taught as in rehearsal: three examples of each gesture, recorded from rest to rest."""
    rec = Recognizer(GestureModel(("gyr", "acc")))
    examples = rehearse(rec, seed=1)
    assert sorted(e.label for e in examples) == ["circle"] * 3 + ["flick"] * 3 + ["nod"] * 3
    return rec


@pytest.mark.slow
def test_gestures_between_rest_and_pointing_are_found_and_pointing_is_not(taught):
    """90 gestures of new performances (new amplitudes, speeds and directions): >= 90 % found and named,
    <= 5 % of the decisions false (on pointing, or a gesture's second)."""
    right = wrong = missed = false = decided = 0
    for seed in (21, 22, 23):
        t, frames, truth = performed(seed)
        decisions = [d for d in _perform(taught, t, frames) if d[1] is not None]
        r, w, m, f = score(decisions, truth)
        right, wrong, missed, false = right + r, wrong + w, missed + m, false + f
        decided += len(decisions)
    assert right / 90 >= 0.90, (right, wrong, missed, false)
    assert false / decided <= 0.05 and wrong / decided <= 0.05, (right, wrong, missed, false)


def test_without_the_null_class_pointing_fires(taught):
    """The rejection is what keeps ordinary pointing out: switched off, pointing fires gestures."""
    t, frames, truth = performed(21)
    saved, taught.model.reject = taught.model.reject, 0.0
    try:
        decisions = [d for d in _perform(taught, t, frames) if d[1] is not None]
    finally:
        taught.model.reject = saved
    assert score(decisions, truth)[3] >= 5


def test_null_examples_are_rejected(taught):
    """Movements recorded as null win over the gestures they resemble, and are told as no gesture."""
    model = taught.model
    point = MotionScript([hold(1.0), Segment(1.2, azimuth=50.0), hold(1.0)], loop=False)
    t, gyr, acc, _ = sensor_stream(point, 100.0, 5)
    frames = np.column_stack([gyr, acc])
    moving = np.linalg.norm(gyr, axis=1) > 0.3
    null = Example(NULL, t[moving], frames[moving])
    with_null = GestureModel(("gyr", "acc")).train([*model.examples, null])
    again = sensor_stream(
        MotionScript([hold(1.0), Segment(1.3, azimuth=-45.0), hold(1.0)], loop=False), 100.0, 6
    )
    moving = np.linalg.norm(again[1], axis=1) > 0.3
    d = with_null.classify(again[0][moving], np.column_stack([again[1], again[2]])[moving])
    assert d.label is None and d.nearest == NULL


def test_early_decisions_come_before_the_end_and_are_right(taught):
    t, frames, truth = performed(22)
    taught.reset()
    early = []
    for k in range(len(t)):
        for e in taught.push(float(t[k]), frames[k]):
            if isinstance(e, Decided) and e.decision.early:
                early.append((float(t[k]), e.decision.label))
    assert len(early) >= 10
    r, w, _, f = score(early, truth, slack=0.0)  # within the gesture itself: before it ended
    assert r == len(early) and w == f == 0


def test_a_gate_brackets_a_movement_and_a_refractory_period_follows():
    rng = np.random.default_rng(0)
    t = np.arange(50) / 50.0
    shape = np.column_stack([np.sin(2 * np.pi * t), np.cos(2 * np.pi * t), t])
    model = GestureModel(("x",), size=3).train(
        [Example("loop", t, shape + rng.normal(0, 0.01, shape.shape)) for _ in range(3)]
    )
    rec = Recognizer(model, early=False, refractory=1.0)
    rec.gate(True, 0.0)
    for k in range(50):
        assert not [e for e in rec.push(float(t[k]), shape[k]) if isinstance(e, Decided)]
    events = rec.gate(False, float(t[-1]))
    assert [type(e) for e in events] == [Ended, Decided] and events[1].decision.label == "loop"
    rec.gate(True, 1.1)  # within a second of the decision: no decision
    for k in range(50):
        rec.push(1.1 + float(t[k]), shape[k])
    events = rec.gate(False, 2.1)
    assert [type(e) for e in events] == [Ended, Dropped] and events[1] == Dropped("refractory")


def test_warp_auto_takes_the_warp_that_names_more_of_the_examples_left_out():
    """Two classes told apart by the order of two bumps on two axes, each bump at its own random time:
    warping the axes together keeps their order, each on its own loses it (DTW_I cannot tell them)."""
    rng = np.random.default_rng(4)
    t = np.arange(80) / 50.0

    def bump(at: float) -> np.ndarray:
        return np.exp(-0.5 * ((t - at) / 0.08) ** 2)

    examples = []
    for label, (a, b) in (("xy", (0.4, 1.1)), ("yx", (1.1, 0.4))):
        for _ in range(4):
            x = np.column_stack([bump(a + rng.normal(0, 0.05)), bump(b + rng.normal(0, 0.05)), 0 * t])
            examples.append(Example(label, t, x + rng.normal(0, 0.02, x.shape)))
    model = GestureModel(("x",), size=3).train(examples)
    assert model.named_left_out("together") == 8 and model.named_left_out("each") < 8
    assert model.warped == "together"
    fixed = GestureModel(("x",), size=3, warp="each").train(examples)
    assert fixed.warped == "each"
    # DTW_I names, the null class is judged with DTW_D: the decision's distance is DTW_D's to the class
    probe = Example("probe", t, np.column_stack([bump(0.5), bump(1.0), 0 * t]))
    d = fixed.classify(probe.t, probe.frames)
    x = fixed.features(probe.t, probe.frames)
    own = [tpl for tpl, label in zip(fixed.templates, fixed.labels, strict=True) if label == d.nearest]
    assert d.distance == pytest.approx(float(np.min(dtw_many(x, own, fixed.band))))
    assert d.per_class[d.nearest] == pytest.approx(float(np.min(dtw_many(x, own, fixed.band, each=True))))
    assert d.per_class[d.nearest] < d.distance  # (each warped on its own comes nearer: why it only names)


def test_segmenter_cuts_from_rest_to_rest():
    seg = Segmenter(on=1.0, off=0.5, settle=0.1, shortest=0.15, longest=2.0)
    energy = [0.0] * 10 + [0.6, 0.8, 1.5, 2.0, 1.5, 0.8, 0.6] + [0.1] * 20
    events = [(k, seg.push(k / 100.0, e)) for k, e in enumerate(energy)]
    said = [(k, e) for k, e in events if e]
    assert said[0] == (12, "start") and said[1][1] == "drop"  # 0.06 s: too short for a gesture
    seg = Segmenter(on=1.0, off=0.5, settle=0.1, shortest=0.05, longest=2.0)
    said = [(k, e) for k, e in ((k, seg.push(k / 100.0, e)) for k, e in enumerate(energy)) if e]
    assert said == [(12, "start"), (26, "end")] and seg.span == (0.10, 0.16)
    seg = Segmenter(on=1.0, off=0.5, longest=0.5)
    said = [e for e in (seg.push(k / 100.0, 2.0) for k in range(100)) if e]
    assert said == ["start", "drop"]  # a movement that goes on is no gesture


def _repetition(first: float, second: float, rate: float = 50.0) -> tuple[np.ndarray, np.ndarray]:
    """One second of a turn and back (gyro, rad/s): ``first`` of one cycle about x, ``second`` of two."""
    u = np.arange(int(rate) + 1) / rate
    gyr = np.zeros((len(u), 3))
    gyr[:, 0] = first * np.sin(2 * np.pi * u) + second * np.sin(4 * np.pi * u)
    gyr[:, 1] = 0.1 * first * np.sin(2 * np.pi * u)
    return u, gyr


@pytest.mark.parametrize("rhythm", [Spotter.RHYTHM, 0.0])
def test_a_spotter_keeps_the_rhythm_of_repetitions_with_no_rest(rhythm, monkeypatch):
    """Eight repetitions of a turn out and back with no rest between them, after a second of rest: the
    span from the middle of one to the middle of the next is a turn back and out, taught as another
    gesture a little nearer to it than the performed turns are to their own example (known truth: the
    repetitions begin where the rest ends).  With the rhythm (each repetition begins where the last one
    told ended) every repetition is named ``out``; without it, the spotter drifts to the other phase."""
    monkeypatch.setattr(Spotter, "RHYTHM", rhythm)
    t_out, g_out = _repetition(0.9 * 3.0, 0.6)  # the examples: a little weaker than the performance
    t_back, g_back = _repetition(-0.9 * 3.0, 0.6)  # (the middle-to-middle span: -3 sin + 0.6 sin 2x)
    model = GestureModel(("gyr",)).train([Example("out", t_out, g_out), Example("back", t_back, g_back)])
    _, one = _repetition(3.0, 0.6)
    stream = np.vstack([np.zeros((50, 3)), *([one[:-1]] * 8), np.zeros((50, 3))])
    spotter = Spotter(model)
    told = [d.decision.label for k, f in enumerate(stream) for d in spotter.push(k / 50.0, f)]
    if rhythm:
        assert told == ["out"] * len(told) and len(told) >= 7, told
    else:  # (the case is a real one: the test above could fail)
        assert told.count("back") >= 2, told


# ------------------------------------------------------------------------------------- strokes
def _strokes(burst: Burst | None, seconds: float, threshold: float = 1.5, seed: int = 0):
    sim = GloveSimulator(seed=seed, bursts=[burst] if burst else [])
    det = StrokeDetector(threshold)
    found = []
    for k in range(int(seconds * 100)):
        s = sim.sample(k)
        u = DEFAULT_SPEC.to_units(s.frame.channels)
        hit = det.push(s.t, np.array(u[3:6]), s.q)
        if hit:
            found.append(hit)
    return found, sim


@pytest.mark.parametrize("axis", ["vertical", "pointing", "both"])
@pytest.mark.parametrize(("peak_g", "rate"), [(3.0, 2.0), (5.0, 4.0), (10.0, 8.0)])
def test_every_stroke_is_found_with_its_direction_within_15_ms(axis, peak_g, rate):
    """Simulated strikes (lift, swing, a 15 ms impact that stops the hand; 10 g clips at the glove's
    4 g): each is told once, at most 15 ms after its true peak, towards where the hand struck."""
    burst = Burst(start=1.0, duration=2.0, peak_g=peak_g, rate=rate, axis=axis, every=6.0)
    found, sim = _strokes(burst, 12.0)
    w = min(0.015, 0.2 / rate)
    peaks = [burst.start + r * 6.0 + (i + 1) / rate - w / 2 for r in range(2) for i in range(burst.count)]
    assert len(found) == len(peaks)
    for hit, peak in zip(found, peaks, strict=True):
        assert 0.0 <= hit.decided - peak <= 0.015
        d = -burst.direction(sim.script.orientation(peak))
        el, az = math.radians(hit.elevation), math.radians(hit.azimuth)
        told = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
        assert math.degrees(math.acos(min(1.0, float(told @ d)))) < 10.0
        assert hit.strength > 0.4 * min(peak_g, 4.0)


def test_no_strokes_from_pointing_or_a_shake():
    assert _strokes(None, 40.0)[0] == []
    assert _strokes(Burst(start=1.0, duration=3.0, peak_g=3.0, rate=5.0, kind="shake"), 5.0)[0] == []


# ------------------------------------------------------------------------------------ postures
def test_postures_are_named_whichever_way_the_performer_faces():
    rng = np.random.default_rng(2)

    def held(yaw, pitch, roll, n=50, sd=2.0):
        angles = np.radians(np.array([yaw, pitch, roll]) + rng.normal(0, sd, (n, 3)))
        return euler_to_quat(angles[:, 0], angles[:, 1], angles[:, 2])

    poses = {"level": (0.0, 0.0, 0.0), "palm_up": (0.0, 0.0, 180.0), "up": (0.0, -70.0, 0.0)}
    model = PostureModel(("q",)).train([Example(k, np.arange(50) / 100, held(*v)) for k, v in poses.items()])
    for label, (_, pitch, roll) in poses.items():
        for yaw in (-150.0, 40.0, 120.0):
            got = [model.classify(q)[0] for q in held(yaw, pitch, roll, 20)]
            assert got.count(label) >= 19, (label, yaw, got)
    between = [model.classify(q)[0] for q in held(0.0, -35.0, 90.0, 20)]
    assert between.count(None) >= 19


# ------------------------------------------------------------------------------------ following
def test_following_tells_progress_and_speed():
    def circle(speed, seed):
        moves = [Segment(0.4 / speed, 40.0, 30.0), Segment(0.4 / speed, 80.0, 0.0)]
        moves += [Segment(0.4 / speed, 40.0, -30.0), Segment(0.4 / speed, 0.0, 0.0)]
        script = MotionScript([hold(0.5), *moves, hold(0.5)], loop=False)
        t, gyr, acc, _ = sensor_stream(script, 100.0, seed)
        keep = (t >= 0.5) & (t <= 0.5 + 1.6 / speed)
        return t[keep], np.column_stack([gyr, acc])[keep]

    model = GestureModel(("gyr", "acc")).train(
        [Example("c", *circle(s, k)) for k, s in enumerate((0.9, 1.0, 1.1))]
    )
    for speed in (0.7, 1.0, 1.6):
        f = Follower(model)
        out = [f.push(float(tk), x) for tk, x in zip(*circle(speed, 9), strict=True)]
        out = [o for o in out if o is not None]
        progress = np.array([o[0] for o in out])
        assert progress[-1] > 0.85 and np.all(np.diff(progress) > -0.05)
        middle = np.array([o[1] for o in out[len(out) // 4 : 3 * len(out) // 4]])
        assert np.median(middle) == pytest.approx(speed, rel=0.3), speed


def test_one_gesture_taught_once_is_told_and_stillness_is_not(taught):
    """A single class of a single example trains (the gap to the hand held still stands in for the
    spread it cannot learn): its next performances are told, a tremble is not."""
    circles = [e for e in taught.model.examples if e.label == "circle"]
    model = GestureModel(("gyr", "acc")).train(circles[:1])
    assert math.isfinite(model.threshold("circle"))
    assert model.classify(circles[1].t, circles[1].frames).label == "circle"
    rng = np.random.default_rng(3)
    still = np.concatenate([np.zeros(3), circles[0].frames[0, 3:]])  # not turning, gravity as it was
    tremble = still + rng.normal(0, 0.05, (60, 6))
    assert model.classify(np.arange(60) / 100.0, tremble).label is None
