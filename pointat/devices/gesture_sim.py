"""A simulated performer who points, rests, and now and then makes a trained gesture: known truth for the
gesture nodes' tests, benchmarks and the ``gestures`` patch.

Three gestures, each a few fast eased moves about where the hand points (so it is the same gesture
facing any loudspeaker), at a random amplitude (0.8..1.2) and speed (0.8..1.25) every time:

* ``circle`` -- the pointing direction draws a loop: up-left, left, down-left, back (4 moves);
* ``flick`` -- a quick roll of the wrist, 70 degrees out and back (2 moves);
* ``nod`` -- the hand dips twice (4 moves).

Between gestures the performer rests (0.6..1.2 s) and points somewhere else, slowly, as in a show
(1.5..3 s for up to 120 degrees of azimuth): ordinary pointing, which no gesture node may take for one.

>>> script, truth = performance(seed=3, count=4)
>>> [label for label, _, _ in truth]
['circle', 'flick', 'nod', 'circle']
>>> all(0 < a < b <= script.duration for _, a, b in truth)
True
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from pointat.devices.glove_sim import GloveSimulator, MotionScript, Segment, SensorModel, hold
from pointat.devices.mote_frame import DEFAULT_SPEC
from pointat.maths.gestures import Decided, Recorded

__all__ = [
    "GESTURES",
    "gesture_segments",
    "perform",
    "performance",
    "performed",
    "rehearse",
    "score",
    "sensor_stream",
]

GESTURES = ("circle", "flick", "nod")


def gesture_segments(
    label: str, pose: tuple[float, float, float], amplitude: float = 1.0, speed: float = 1.0
) -> list[Segment]:
    """The moves of gesture ``label`` about ``pose`` (azimuth, elevation, roll, degrees)."""
    az, el, roll = pose
    a, d = amplitude, 1.0 / speed
    if label == "circle":
        moves = [(az + 20 * a, el + 20 * a, roll, 0.18), (az + 40 * a, el, roll, 0.18)]
        moves += [(az + 20 * a, el - 20 * a, roll, 0.18), (az, el, roll, 0.18)]
    elif label == "flick":
        moves = [(az, el, roll + 70 * a, 0.15), (az, el, roll, 0.2)]
    elif label == "nod":
        moves = [(az, el - 25 * a, roll, 0.15), (az, el + 5 * a, roll, 0.15)]
        moves += [(az, el - 25 * a, roll, 0.15), (az, el, roll, 0.15)]
    else:
        raise ValueError(f"unknown gesture {label!r}; gestures: {', '.join(GESTURES)}")
    return [Segment(t * d, x, y, r, label=label) for x, y, r, t in moves]


def performance(
    seed: int = 0,
    count: int = 30,
    gestures: Sequence[str] = GESTURES,
    *,
    pointing: bool = True,
    loop: bool = False,
    lead: float = 1.0,
) -> tuple[MotionScript, list[tuple[str, float, float]]]:
    """A performance of ``count`` gestures (in turn) between rests and pointing, after ``lead`` s at rest
    (the gyro nulls are taken then); and its truth: (label, start, end) of every gesture, seconds."""
    rng = np.random.default_rng(seed)
    pose = (0.0, 0.0, 0.0)
    segments: list[Segment] = [hold(lead, "rest")]
    t = lead
    truth = []
    for i in range(count):
        if pointing:
            target = (float(rng.uniform(-120, 120)), float(rng.uniform(-10, 30)), 0.0)
            span = max(abs(target[0] - pose[0]), abs(target[1] - pose[1]))
            dur = max(1.5, 3.0 * span / 120.0) * float(rng.uniform(0.9, 1.1))
            segments.append(Segment(dur, *target, label="point"))
            pose = target
            t += dur
            rest = float(rng.uniform(0.8, 1.5))
            segments.append(hold(rest, "rest"))
            t += rest
        label = gestures[i % len(gestures)]
        moves = gesture_segments(label, pose, float(rng.uniform(0.8, 1.2)), float(rng.uniform(0.8, 1.25)))
        segments += moves
        length = sum(s.duration for s in moves)
        truth.append((label, t, t + length))
        t += length
        rest = float(rng.uniform(0.6, 1.2))
        segments.append(hold(rest, "rest"))
        t += rest
    if loop and pose != (0.0, 0.0, 0.0):
        segments += [Segment(2.0, 0.0, 0.0, 0.0, label="point"), hold(1.0, "rest")]
    return MotionScript(segments, loop=loop), truth


def sensor_stream(
    script: MotionScript, rate: float = 100.0, seed: int = 0, duration: float | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The glove's readings along ``script``, through its 12-bit ADC and back to units, as ``scaling``
    gives them: times (s), gyro (rad/s), accelerometer (m/s²), and the true orientation (w, x, y, z)."""
    sim = GloveSimulator(script, rate_hz=rate, seed=seed, sensor=SensorModel(seed=seed))
    n = int(math.floor((duration if duration is not None else script.duration) * rate))
    t = np.empty(n)
    gyr, acc, q = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 4))
    for k in range(n):
        s = sim.sample(k)
        units = DEFAULT_SPEC.to_units(s.frame.channels)
        t[k] = s.t
        gyr[k] = np.radians(units[0:3])
        acc[k] = units[3:6]
        q[k] = s.q
    return t, gyr, acc, q


def performed(seed: int, count: int = 30, rate: float = 100.0):
    """Performance ``seed`` (:func:`performance`) as a gesture node with ``channels=[gyr acc]`` gets it:
    times (s), frames (gyro rad/s, then accelerometer m/s²), and the truth."""
    script, truth = performance(seed, count)
    t, gyr, acc, _ = sensor_stream(script, rate, seed)
    return t, np.column_stack([gyr, acc]), truth


def perform(recognizer, t: np.ndarray, frames: np.ndarray) -> list:
    """Feed a stream to ``recognizer`` (a :class:`~pointat.maths.gestures.Recognizer`) from its start,
    frame by frame: its decisions, as (time of the frame that made it, decision)."""
    recognizer.reset()
    out = []
    for k in range(len(t)):
        for e in recognizer.push(float(t[k]), frames[k]):
            if isinstance(e, Decided):
                out.append((float(t[k]), e.decision))
    return out


def rehearse(recognizer, seed: int = 1, per_gesture: int = 3, rate: float = 100.0) -> list:
    """Teach ``recognizer`` (a :class:`~pointat.maths.gestures.Recognizer`) the gestures as a performer
    would in rehearsal: ``record LABEL`` before each gesture of a performance, the movement cut from rest
    to rest; returns the examples taken (the model is trained on them)."""
    script, truth = performance(seed, per_gesture * len(GESTURES), pointing=False)
    t, gyr, acc, _ = sensor_stream(script, rate, seed)
    examples = []
    recognizer.record = truth[0][0]
    recognizer.retune()
    for k in range(len(t)):
        upcoming = [g for g in truth if g[1] - 0.5 <= t[k] <= g[2]]
        if upcoming:
            recognizer.record = upcoming[0][0]
        for e in recognizer.push(float(t[k]), np.concatenate([gyr[k], acc[k]])):
            if isinstance(e, Recorded):
                examples.append(e.example)
    recognizer.record = None
    recognizer.model.train(examples)
    recognizer.retune()
    return examples


def score(
    decisions: Sequence[tuple[float, str | None]],
    truth: Sequence[tuple[str, float, float]],
    slack: float = 0.3,
):
    """Match decisions (time, label) to the true gestures: a decision within a gesture's span (or
    ``slack`` s after it) is that gesture's.  Returns (found and labelled right, labelled wrong, missed,
    false triggers: decisions that match no gesture, or a gesture's second)."""
    right = wrong = false = 0
    taken = set()
    for when, label in decisions:
        hit = [i for i, (_, a, b) in enumerate(truth) if a <= when <= b + slack]
        if not hit or hit[0] in taken:
            false += 1
            continue
        taken.add(hit[0])
        if label == truth[hit[0]][0]:
            right += 1
        else:
            wrong += 1
    return right, wrong, len(truth) - len(taken), false
