"""The gesture node's defaults on real people's motion (samples of seglearn's watch set and of BROAD in
``tests/data/gestures``, with their sources and licences): taught by others or by the performer in a
first take, never much below plain 1-NN DTW on the same split, and real motion that is no gesture rarely
taken for one.  The defaults were chosen on other recordings (``benchmarks/gesture_real.py``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from benchmarks.gesture_sets import G, Take, cut_repetitions
from benchmarks.performer import perform
from pointat.gesture_eval import baseline, evaluate
from pointat.maths.gestures import NULL, Adapted, GestureModel, Recognizer

DATA = Path(__file__).resolve().parent.parent / "data" / "gestures"
CH = ("acc", "gyr")


@pytest.fixture(scope="module")
def reps() -> dict[tuple[int, str], list]:
    """Person, exercise -> the recording's repetitions (as a pedal pressed at each would cut them)."""
    z = np.load(DATA / "watch_sample.npz")
    ends = np.cumsum(z["lengths"])
    out = {}
    for k, (a, b) in enumerate(zip(np.r_[0, ends[:-1]], ends, strict=True)):
        acc, gyr = z["acc"][a:b] / 4000.0 * G, z["gyr"][a:b] / 1000.0
        take = Take(
            str(z["label"][k]), int(z["person"][k]), 1, np.arange(b - a) / 50.0, {"acc": acc, "gyr": gyr}
        )
        out[(take.person, take.label)] = cut_repetitions(take)
    return out


@pytest.fixture(scope="module")
def no_gesture() -> list[tuple[np.ndarray, np.ndarray]]:
    """Four minutes of BROAD's real hand motion (fast rotation; fast translation, jolts up to 5 g): times,
    frames.  Cut from trials the defaults were chosen on (01-15), never from the reported ones."""
    z = np.load(DATA / "broad_sample.npz")
    return [
        (z[f"{k}_t"].astype(float), np.column_stack([z[f"{k}_acc"] / 200.0, z[f"{k}_gyr"] / 1000.0]))
        for k in ("06", "15")
    ]


def _new_person(reps, person):
    train = [r[1] for (p, _), r in reps.items() if p != person]
    test = [x for (p, _), r in reps.items() if p == person for x in r]
    return train, test


def _three(reps, person):
    mine = [r for (p, _), r in reps.items() if p == person]
    return [x for r in mine for x in r[:3]], [r[k] for k in range(3, 40) for r in mine if k < len(r)]


def test_a_new_person_taught_by_two_others_is_named_as_plain_dtw_names_them(reps):
    """Each of three people taught by the two others (one repetition of each exercise from each): the
    node's defaults, rejection and early decisions on, beside plain 1-NN DTW without rejection."""
    ours, plain = [], []
    for person in (1, 2, 3):
        train, test = _new_person(reps, person)
        ours.append(evaluate(train, test, CH).accuracy)
        plain.append(baseline(train, test, CH).accuracy)
    assert np.mean(ours) >= np.mean(plain) - 0.03 and min(ours) >= 0.4, (ours, plain)


@pytest.mark.parametrize("person", [1, 3])
def test_three_examples_of_a_first_take_hold_for_the_rest_of_it(reps, person):
    train, test = _three(reps, person)
    ours, plain = evaluate(train, test, CH).accuracy, baseline(train, test, CH).accuracy
    assert ours >= 0.8 and ours >= plain - 0.03, (ours, plain)


def test_the_null_class_costs_few_real_gestures(reps):
    """The failure this default replaced: a reach fitted on three examples refused half of a person's
    gestures on another day.  The null class's reach is the gesture's own distance from keeping still."""
    lost = []
    for person in (1, 2, 3):
        train, test = _new_person(reps, person)
        on = evaluate(train, test, CH, {}, {"early": False}).accuracy  # (the rejection's claim: at the end)
        off = evaluate(train, test, CH, {"reject": 0.0}, {"early": False}).accuracy
        lost.append(off - on)
    assert max(lost) <= 0.08 and np.mean(lost) <= 0.04, lost


@pytest.mark.parametrize("channels", [("acc", "gyr"), ("acc",)])
def test_real_motion_that_is_no_gesture_is_rarely_taken_for_one(reps, no_gesture, channels):
    """A model of 21 exercises' examples (three people's) over BROAD's fast rotation, then its fast
    translation (jolts up to 5 g: the hardest of these for a model with a gyro)."""
    train = [x for r in reps.values() for x in r[:3]]
    model = GestureModel(channels).train([r.example(channels) for r in train])
    told = []
    for t, frames in no_gesture:
        x = frames if channels == CH else frames[:, :3]
        told.append(sum(d.label is not None for _, d in perform(Recognizer(model), t, x)))
    # two minutes each: the goal, 0.5 a minute, holds on the rotation; on the fast translation these
    # defaults give up to 1.5 a minute (acc gyr; the examples' spread, off by default, held it to the
    # goal), held here so that it gets no worse
    assert told[0] <= 1 and told[1] <= 3, f"false triggers in two minutes: {told}"


def test_ordinary_motion_taught_as_null_is_no_longer_taken_for_a_gesture(reps, no_gesture):
    """What the README tells a performer whose gestures fire on ordinary moves: ``record null`` while
    moving as between gestures, then ``train``.  Taught the movements of the first minute of BROAD's fast
    translation as no gesture (cut from rest to rest as the node cuts them while it records), a model of
    three people's exercises takes none of the next minute's movements for a gesture, and names the
    people's other repetitions as well as before."""
    train = [x for r in reps.values() for x in r[:3]]
    test = [x for r in reps.values() for x in r[3:]]
    examples = [r.example(CH) for r in train]
    model = GestureModel(CH).train(examples)
    t, frames = no_gesture[1]
    nulls = Recognizer(model).recorded(t[t < 60.0], frames[t < 60.0], NULL)
    assert nulls and all(e.label == NULL and e.t[-1] < 60.0 for e in nulls)
    taught = GestureModel(CH).train(examples + nulls)

    def told(m):
        return [d.label for ti, d in perform(Recognizer(m), t, frames) if ti > 60.0 and d.label is not None]

    def named(m):
        return np.mean([m.classify(e.t, e.frames).label == e.label for e in (r.example(CH) for r in test)])

    assert len(told(model)) >= 2, "the second minute has false triggers to take away"
    assert told(taught) == [], told(taught)
    assert named(taught) >= named(model) - 0.01, (named(taught), named(model))


@pytest.fixture(scope="module")
def takes() -> dict[tuple[int, str], tuple[np.ndarray, np.ndarray]]:
    """Person, exercise -> the whole recording (times, frames acc gyr): repetitions with no rest."""
    z = np.load(DATA / "watch_sample.npz")
    ends = np.cumsum(z["lengths"])
    return {
        (int(z["person"][k]), str(z["label"][k])): (
            np.arange(b - a) / 50.0,
            np.column_stack([z["acc"][a:b] / 4000.0 * G, z["gyr"][a:b] / 1000.0]),
        )
        for k, (a, b) in enumerate(zip(np.r_[0, ends[:-1]], ends, strict=True))
    }


def test_repetitions_with_no_rest_between_them_are_spotted(reps, takes):
    """Each person's seven recordings streamed whole, taught with the first three repetitions of each:
    from rest to rest finds few (there is no rest), ``cut=spot`` finds them."""
    for person in (1, 2, 3):
        model = GestureModel(CH).train(
            [x.example(CH) for (p, _), r in reps.items() if p == person for x in r[:3]]
        )
        found = {}
        for cut in ("rest", "spot"):
            right = wrong = total = 0
            for (p, label), (t, frames) in takes.items():
                if p != person:
                    continue
                told = [
                    d.label for _, d in perform(Recognizer(model, cut=cut), t, frames) if d.label is not None
                ]
                n = len(reps[(p, label)])
                right += min(n, told.count(label))
                wrong += len(told) - min(n, told.count(label))
                total += n
            found[cut] = (right / total, wrong / total)
        assert found["rest"][0] < 0.5 and found["spot"][0] >= 0.8 and found["spot"][1] <= 0.25, (
            person,
            found,
        )


def test_a_new_person_s_repetitions_are_spotted_from_the_others_examples(reps, takes):
    """Each person's recordings streamed whole (``cut=spot``), taught by the two others (one repetition of
    each exercise each): most repetitions found and named, few told wrong.  On this sample, taught by two
    people, the spotter's :attr:`~pointat.maths.gestures.Spotter.ENDS` (chosen on nine teachers) finds
    51, 69 and 63 % (without it 52, 66 and 76 %), with its :attr:`~pointat.maths.gestures.Spotter.RHYTHM`
    51, 69 and 65 %: held here so that it gets no worse."""
    found, wrong = [], []
    for person in (1, 2, 3):
        train, _ = _new_person(reps, person)
        model = GestureModel(CH).train([r.example(CH) for r in train])
        right = told_wrong = total = 0
        for (p, label), (t, frames) in takes.items():
            if p != person:
                continue
            told = [
                d.label for _, d in perform(Recognizer(model, cut="spot"), t, frames) if d.label is not None
            ]
            n = len(reps[(p, label)])
            right += min(n, told.count(label))
            told_wrong += len(told) - min(n, told.count(label))
            total += n
        found.append(right / total)
        wrong.append(told_wrong / total)
    assert np.mean(found) >= 0.58 and min(found) >= 0.45 and max(wrong) <= 0.5, (found, wrong)


def test_adapt_follows_the_performer_and_keeps_the_taught_examples(reps):
    train, test = _three(reps, 1)
    plain = evaluate(train, test, CH, {}, {"early": False})
    adapted = evaluate(train, test, CH, {}, {"adapt": True, "keep": 5, "early": False})
    assert adapted.accuracy >= plain.accuracy - 0.02, (adapted.accuracy, plain.accuracy)
    model = GestureModel(CH).train([r.example(CH) for r in train])
    rec = Recognizer(model, adapt=True, keep=5, early=False)
    taught = list(model.examples)
    events = []
    for r in test:
        e = r.example(CH)
        rec.reset()
        rec.gate(True, float(e.t[0]))
        for t, f in zip(e.t, e.frames, strict=True):
            events += rec.push(float(t), f)
        events += rec.gate(False, float(e.t[-1]))
    told = [e for e in events if isinstance(e, Adapted)]
    assert told, "nothing was recognised with a clear margin"
    for label in model.classes:
        own = [x for x in model.examples if x.label == label]
        assert len(own) <= 5
        if any(e.label == label for e in told):
            assert all(any(x is y for y in own) for x in taught if x.label == label)
