"""The gesture model's channel weighting (``scale``) and the null class's rules on what its reach alone
lets through: the examples' spread and classes that are themselves nearly still (issue 43)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pointat.gesture_eval import options
from pointat.maths.gestures import GRAVITY, Example, GestureModel, group_scales

T = np.arange(60) / 50.0


def _turn(f: float, amplitude: float = 4.0) -> np.ndarray:
    """A gyro trace (rad/s): a turn about z of ``amplitude``, with ``f`` wiggles about x."""
    return np.column_stack([0.3 * np.sin(f * np.pi * T), 0 * T, amplitude * np.sin(np.pi * T / T[-1])])


def _examples(noise: float, seed: int = 1) -> list[Example]:
    rng = np.random.default_rng(seed)
    return [
        Example(label, T, _turn(f) + rng.normal(0, noise, (60, 3)))
        for label, f in (("one", 2), ("one", 2), ("one", 2), ("two", 6), ("two", 6), ("two", 6))
    ]


def test_scale_weighs_the_groups_by_their_own_spread_or_by_their_units():
    rng = np.random.default_rng(3)
    x = np.column_stack([rng.normal(0, 0.5, (200, 3)), rng.normal(0, 2.0, (200, 3))])  # acc g, gyr rad/s
    spread = group_scales(x, ("acc", "gyr"))
    common = group_scales(x, ("acc", "gyr"), scale="common")
    si = group_scales(x, ("acc", "gyr"), scale="si")
    assert spread[:3] == pytest.approx([0.5] * 3, rel=0.1) and spread[3:] == pytest.approx([2.0] * 3, rel=0.1)
    assert np.all(common == common[0])  # one spread: g and rad/s weigh as they are
    assert si[3:] == pytest.approx(si[:3] * GRAVITY)  # an acc of 1 g weighs as 9.8 rad/s: m/s² against rad/s
    with pytest.raises(ValueError, match="scale must be one of spread, common, si; got 'g'"):
        GestureModel(("acc", "gyr"), scale="g")


def test_scale_is_an_option_of_evaluate_and_changes_what_the_model_divides_by():
    model_opts, _ = options(["scale=si"])
    assert model_opts["scale"] == "si"
    with pytest.raises(ValueError, match="scale"):
        options(["scale=inches"])
    rng = np.random.default_rng(2)
    frames = [np.column_stack([rng.normal(0, 2.0, (40, 3)) + [0, 0, GRAVITY], rng.normal(0, 1.0, (40, 3))])]
    examples = [Example(label, T[:40], f + rng.normal(0, 0.1, f.shape)) for label in "ab" for f in frames]
    by = {s: GestureModel(("acc", "gyr"), scale=s).train(examples).scales for s in ("spread", "common", "si")}
    assert by["spread"][0] / by["spread"][3] == pytest.approx(0.2, rel=0.2)  # acc's spread 0.2 g, gyr's 1
    assert by["common"][0] == by["common"][3]
    assert by["si"][3] / by["si"][0] == pytest.approx(GRAVITY)


def _spread_on(channels=("gyr",)) -> GestureModel:
    """A model with the examples' spread rule on (off by default), at the factor once chosen."""
    model = GestureModel(channels)
    model.SPREAD = 0.93
    return model


def test_the_examples_spread_refuses_what_the_reach_alone_would_take():
    """Examples far more alike than the gesture is far from keeping still: a movement well within the
    reach but far beyond how the examples vary is no gesture; with the spread left out, it was one."""
    model = _spread_on().train(_examples(noise=0.02))
    sloppy = _turn(2, amplitude=2.5)  # the turn, at 60 % of its size
    d = model.classify(T, sloppy)
    assert d.nearest == "one" and d.distance < model.reject * model.reach["one"]
    assert model.spread < model.reach["one"] and d.label is None
    model.spread = math.inf
    assert model.classify(T, sloppy).label == "one"
    # the examples' own performances still pass
    assert _spread_on().train(_examples(0.02)).classify(T, _turn(2)).label == "one"
    # off by default (a rehearsal's examples vary less than performances: the simulated performer)
    default = GestureModel(("gyr",)).train(_examples(noise=0.02))
    assert default.spread == math.inf and default.classify(T, sloppy).label == "one"


def test_the_spread_is_pooled_over_classes_and_unknown_without_two_of_one():
    model = _spread_on().train(_examples(noise=0.1))
    spread, classes = model.examples_spread()
    assert spread > 0 and math.isfinite(model.spread) and classes == {"one", "two"}
    one_each = GestureModel(("gyr",)).train([Example("one", T, _turn(2)), Example("two", T, _turn(6))])
    assert one_each.spread == math.inf and one_each.classify(T, _turn(2)).label == "one"


def test_the_spread_caps_only_the_classes_taught_two_examples_and_never_learns_from_adapt():
    """Two close examples of "one" say nothing of how "two", taught once, varies: its threshold stays
    its reach; and a performance taken by ``adapt`` (taken for being near its class) does not narrow the
    spread, so adapting one class cannot make the others refuse what they took before."""
    rng = np.random.default_rng(4)
    taught = [
        Example("one", T, _turn(2) + rng.normal(0, 0.02, (60, 3))),
        Example("one", T, _turn(2) + rng.normal(0, 0.02, (60, 3))),
        Example("two", T, _turn(6)),
    ]
    model = _spread_on().train(taught)
    assert model.spread_classes == {"one"} and model.spread < model.reach["one"]
    assert model.threshold("one") < model.reject * model.reach["one"]
    assert model.threshold("two") == model.reject * model.reach["two"]  # (not capped by one's pair)
    before = model.spread
    model.adapt(Example("one", T, _turn(2) + rng.normal(0, 0.001, (60, 3))), keep=5)
    assert model.spread == pytest.approx(before, rel=1e-3) and model.spread_classes == {"one"}


def test_a_class_that_is_itself_nearly_still_is_told_for_stillness_not_for_motion():
    """BasicMotions' "standing" beside classes that move: the floor keeps it from being refused for
    every tremble, and a movement far from keeping still is not it, however near its template (one
    example's jolt lets the strength rule pass it)."""
    rng = np.random.default_rng(4)
    t = np.arange(100) / 20.0
    examples = [Example("standing", t, rng.normal(0, 0.02, (100, 3))) for _ in range(3)]
    examples[0].frames[50, 0] = 1.0  # a jolt
    for label, f in (("walking", 1.0), ("running", 3.0)):
        examples += [
            Example(
                label,
                t,
                np.column_stack([3 * np.sin(2 * np.pi * f * t), 0 * t, 0 * t]) + rng.normal(0, 0.3, (100, 3)),
            )
            for _ in range(3)
        ]
    model = GestureModel(("gyr",), warp="together").train(examples)
    assert "standing" in model.quiet and "walking" not in model.quiet
    assert model.classify(t, rng.normal(0, 0.03, (100, 3))).label == "standing"
    drift = np.column_stack([0.6 * np.sin(np.pi * t / t[-1]), 0 * t, 0 * t])  # a slow turn, nearest standing
    d = model.classify(t, drift)
    assert d.nearest == "standing" and d.label is None
    model.quiet = {}
    assert model.classify(t, drift).label == "standing"
