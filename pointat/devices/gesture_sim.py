"""A simulated performer who points, rests, and now and then makes a trained gesture: known truth for the
gesture nodes' tests, benchmarks and the ``gestures`` patch (``sim script=gestures``).  Playing it to a
recognizer and scoring what it told is test and benchmark code: ``benchmarks/performer.py``.

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

from collections.abc import Sequence

import numpy as np

from pointat.devices.glove_sim import MotionScript, Segment, hold

__all__ = ["GESTURES", "gesture_segments", "performance"]

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
