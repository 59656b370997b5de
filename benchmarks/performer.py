"""The simulated performer (:mod:`pointat.devices.gesture_sim`) played to a recognizer, and what it told
scored against the truth: for the gesture tests and benchmarks only, so it lives outside the installed
package."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from pointat.devices.gesture_sim import GESTURES, performance
from pointat.devices.glove_sim import GloveSimulator, MotionScript, SensorModel
from pointat.devices.mote_frame import DEFAULT_SPEC
from pointat.maths.gestures import Decided, Recorded

__all__ = ["perform", "performed", "rehearse", "score", "sensor_stream"]


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
