"""The gesture-mapping nodes (map, smooth, threshold, deadband) in patches, with message time stamps."""

import logging
import math

import numpy as np
import pytest

from pointat.cli import main
from pointat.errors import PatchError
from pointat.maths.quaternion import quat_angle, quat_from_axis_angle
from pointat.message import Message, make, method
from pointat.registry import default_registry
from pointat.testing import patch


def one(node_line: str, upstream: bool = False):
    """A patch with the node under test named ``x`` feeding ``out``.

    With ``upstream``, messages pushed into ``src`` reach ``x`` over a send/receive bus, so a bad one
    goes through the engine, which logs it and drops it (the runtime is started for the bus).
    """
    text = f"node x {node_line}\nnode out collect\nx -> out\n"
    if upstream:
        text += "node src s to_x\nnode bus r to_x\nbus -> x\n"
    rt = patch(text)
    if upstream:
        rt.start()
    return rt


def push(rt, values, times, name="x"):
    for v, t in zip(values, times, strict=True):
        rt.nodes[name].receive(0, make(v, time=t))


def out_of(rt):
    return rt.nodes["out"].messages


# --- map -------------------------------------------------------------------------------------------


def test_map_scales_numbers_and_keeps_the_time_stamps():
    rt = one("map 0 127 -1 1")
    push(rt, [0, 31.75, 63.5, 127.0, 254], [0.0, 0.01, 0.02, 0.03, 0.04])
    assert [(m.kind, m.value, m.time) for m in out_of(rt)] == [
        ("float", -1.0, 0.0),
        ("float", -0.5, 0.01),
        ("float", 0.0, 0.02),
        ("float", 1.0, 0.03),
        ("float", 3.0, 0.04),  # no clip: extrapolates
    ]


def test_map_clip_invert_and_curves():
    rt = one("map 90 -90 0 127 clip=true")  # azimuth, + left -> pan, 0 left
    push(rt, [90.0, 45.0, 0.0, -90.0, -170.0, 170.0], [0.0] * 6)
    assert rt.nodes["out"].values == [0.0, 31.75, 63.5, 127.0, 127.0, 0.0]
    rt = one("map 0 1 0 100 invert=true clip=true")
    push(rt, [-1.0, 0.0, 0.25, 1.0, 2.0], [0.0] * 5)
    assert rt.nodes["out"].values == [100.0, 100.0, 75.0, 0.0, 0.0]
    rt = one("map 0 1 0 100 curve=pow gamma=2")
    push(rt, [0.0, 0.5, 1.0], [0.0] * 3)
    assert rt.nodes["out"].values == [0.0, 25.0, 100.0]
    rt = one("map 0 1 20 20000 curve=exp curvature=4")
    push(rt, [0.0, 0.5, 1.0], [0.0] * 3)
    expected = 20.0 + 19980.0 * (math.exp(2.0) - 1.0) / (math.exp(4.0) - 1.0)
    assert rt.nodes["out"].values == pytest.approx([20.0, expected, 20000.0], abs=1e-9)


def test_map_fold_pans_a_direction_behind_as_a_stereo_pan_hears_it():
    # turning round through 180: behind-left stays left, and the pan returns smoothly to the centre
    rt = one("map 90 -90 0 127 fold=true")
    push(rt, [90.0, 135.0, 179.0, 180.0, -179.0, -135.0, -90.0, 450.0], [0.0] * 8)
    assert rt.nodes["out"].values == pytest.approx(
        [0.0, 31.75, 62.794, 63.5, 64.206, 95.25, 127.0, 0.0], abs=1e-3
    )
    rt.nodes["x"].receive(0, make((135.0, -170.0), time=1.0))  # a list folds element by element
    assert out_of(rt)[-1].value == pytest.approx((31.75, 70.5556), abs=1e-4)
    with pytest.raises(ValueError, match="NaN"):  # still refused, never folded into a value
        rt.nodes["x"].receive(0, make(float("nan"), 2.0))
    assert len(out_of(rt)) == 9


def test_map_works_element_wise_on_lists_and_vectors():
    rt = one("map 0 10 0 1")
    rt.nodes["x"].receive(0, make((0.0, 5.0, 10.0), time=1.5))
    rt.nodes["x"].receive(0, make(np.array([[2.0, 4.0], [6.0, 8.0]]), time=2.5))
    lst, vec = out_of(rt)
    assert (lst.kind, lst.value, lst.time) == ("list", (0.0, 0.5, 1.0), 1.5)
    assert vec.kind == "vector" and vec.time == 2.5
    assert vec.value == pytest.approx((0.2, 0.4, 0.6, 0.8))  # a matrix travels row major


def test_map_degenerate_ranges_are_errors_at_load():
    with pytest.raises(PatchError, match=r"node 'x' \(map\): the input range is empty: in_lo = in_hi = 3"):
        one("map 3 3 0 1")
    with pytest.raises(PatchError, match="the output range is empty"):
        one("map 0 1 5 5")
    with pytest.raises(PatchError, match="gamma must be > 0"):
        one("map curve=pow gamma=-1")
    with pytest.raises(PatchError, match="expects one of linear, exp, log, pow"):
        one("map curve=sigmoid")


def test_map_live_parameters_and_a_refused_change(caplog):
    rt = one("map 0 1 0 10", upstream=True)
    src = rt.nodes["src"]
    src.receive(0, make(0.5, time=0.0))
    src.receive(0, method("out_hi", 20.0))
    src.receive(0, make(0.5, time=0.1))
    with caplog.at_level(logging.ERROR):
        src.receive(0, method("in_hi", 0.0))  # would make the input range empty: refused, logged
    assert "node 'x' (map)" in caplog.text and "input range is empty" in caplog.text
    assert rt.nodes["x"].p.in_hi == 1.0
    src.receive(0, make(0.5, time=0.2))
    src.receive(0, method("input", 1.0, 0.0))  # both ends at once: flipping is fine
    src.receive(0, make(0.25, time=0.3))
    rt.set_param("x", "curve", "pow")  # from outside, by name
    rt.drain()
    src.receive(0, make(0.5, time=0.4))
    assert rt.nodes["out"].values == [5.0, 10.0, 10.0, 15.0, 5.0]


def test_map_drops_bad_messages_and_never_outputs_nan(caplog):
    rt = one("map 0 1 0 10", upstream=True)
    with caplog.at_level(logging.ERROR):
        for v in (0.1, math.nan, "left", (0.2, "x"), (0.3, math.inf), 0.4):
            rt.nodes["src"].receive(0, make(v, time=0.0))
    assert rt.nodes["out"].values == [1.0, 4.0]
    assert rt.nodes["x"].errors == 4  # each one dropped and counted; the first three are logged
    assert caplog.text.count("node 'x' (map), inlet 'in': dropped") == 3


# --- smooth: exp -----------------------------------------------------------------------------------


def step_response(rate, tau_ms=50.0, until=0.3):
    """Smooth a 0 -> 1 step sampled at ``rate`` Hz (0 at t = 0, 1 from the next sample on)."""
    rt = one(f"smooth exp {tau_ms}")
    times = np.arange(round(until * rate) + 1) / rate
    push(rt, [0.0] + [1.0] * (len(times) - 1), times.tolist())
    return {round(m.time, 9): m.value for m in out_of(rt)}


def test_exp_smoothing_is_rate_independent():
    slow, fast = step_response(100), step_response(1000)
    assert len(slow) == 31 and len(fast) == 301
    shared = sorted(slow)
    assert all(t in fast for t in shared)
    assert max(abs(slow[t] - fast[t]) for t in shared) < 1e-9
    for t in shared:  # and both follow 1 - e^(-t/tau)
        assert slow[t] == pytest.approx(1.0 - math.exp(-t / 0.05), abs=1e-12)
    assert slow[0.05] == pytest.approx(1.0 - math.exp(-1.0), abs=1e-12)  # 63 % at one time constant


def test_exp_smoothing_with_uneven_time_stamps():
    rt = one("smooth exp 100")
    push(rt, [0.0, 1.0, 1.0, 1.0], [10.0, 10.02, 10.03, 10.1])
    assert rt.nodes["out"].values == pytest.approx(
        [0.0, 1 - math.exp(-0.2), 1 - math.exp(-0.3), 1 - math.exp(-1.0)], abs=1e-12
    )
    # a repeated time stamp takes the nominal period 1/rate (here 10 ms)
    rt = one("smooth exp 100 rate=100")
    push(rt, [0.0, 1.0], [5.0, 5.0])
    assert rt.nodes["out"].values == pytest.approx([0.0, 1 - math.exp(-0.1)], abs=1e-12)


def test_wrap_aware_azimuth_smoothing_across_the_back():
    rt = one("smooth exp 100 wrap=true")
    times = [k * 0.01 for k in range(200)]
    push(rt, [179.0] + [-179.0] * 199, times)
    out = rt.nodes["out"].values
    assert out[0] == 179.0
    assert all(-180.0 <= y < 180.0 for y in out)
    assert all(abs(y) > 178.9 for y in out)  # never swings through the front (0)
    for k in (1, 5, 50):  # y_k = wrap(179 + 2 (1 - e^(-k dt / tau)))
        y = 179.0 + 2.0 * (1.0 - math.exp(-k * 0.01 / 0.1))
        assert out[k] == pytest.approx(y - 360.0 if y >= 180.0 else y, abs=1e-9)
    assert out[-1] == pytest.approx(-179.0, abs=1e-6)


# --- smooth: euro ----------------------------------------------------------------------------------


def test_one_euro_node_follows_the_paper_by_hand_with_message_time_stamps():
    # the hand computation is written out in tests/maths/test_smoothing.py: 0, 1, 1.5, 1.4 at t = 0,
    # 10, 25, 30 ms with min_cutoff 1 Hz, beta 0.5, d_cutoff 1 Hz (uneven steps: dt from the stamps)
    rt = one("smooth euro min_cutoff=1 beta=0.5 d_cutoff=1")
    push(rt, [0.0, 1.0, 1.5, 1.4], [2.0, 2.010, 2.025, 2.030])
    assert rt.nodes["out"].values == pytest.approx([0.0, 0.199073895, 0.735131710, 0.885028936], abs=1e-9)
    assert [m.time for m in out_of(rt)] == [2.0, 2.010, 2.025, 2.030]


def test_one_euro_defaults_are_the_papers_and_parameters_are_live():
    rt = one("smooth euro", upstream=True)
    p = rt.nodes["x"].p
    assert (p.min_cutoff, p.beta, p.d_cutoff) == (1.0, 0.0, 1.0)
    src = rt.nodes["src"]
    src.receive(0, make(0.0, time=0.0))
    src.receive(0, method("beta", 0.5))
    src.receive(0, make(1.0, time=0.01))
    assert rt.nodes["out"].values[-1] == pytest.approx(0.199073895, abs=1e-9)
    src.receive(0, method("min_cutoff", 0.0))  # refused: a cutoff must be > 0
    assert rt.nodes["x"].p.min_cutoff == 1.0
    with pytest.raises(ValueError, match="cannot change while running"):
        rt.nodes["x"].receive(0, method("mode", "exp"))


def test_one_euro_on_vectors_and_wrapped_angles():
    rt = one("smooth euro beta=0.1 wrap=true")
    rt.nodes["x"].receive(0, make(np.array([179.0, -30.0]), time=0.0))
    for k in range(1, 300):
        rt.nodes["x"].receive(0, make(np.array([-179.0, -30.0]), time=k * 0.01))
    out = np.array(rt.nodes["out"].values)
    assert out.shape == (300, 2)
    assert np.all(np.abs(out[:, 0]) > 178.9) and np.all(out[:, 1] == -30.0)
    assert out[-1, 0] == pytest.approx(-179.0, abs=1e-3)


# --- smooth: slerp ---------------------------------------------------------------------------------


def test_slerp_smoothing_stays_unit_and_converges():
    target = quat_from_axis_angle([0.0, 0.6, 0.8], 2.0)
    rt = one("smooth slerp 50")
    rt.nodes["x"].receive(0, make(np.array([1.0, 0.0, 0.0, 0.0]), time=0.0))
    for k in range(1, 101):
        q = target if k % 2 else -target  # the source flips sign: harmless
        rt.nodes["x"].receive(0, make(np.array(q), time=k * 0.01))
    out = np.array(rt.nodes["out"].values)
    assert np.max(np.abs(np.linalg.norm(out, axis=1) - 1.0)) < 1e-12
    assert np.all(np.sum(out[1:] * out[:-1], axis=1) > 0.0)  # no sign jumps in the output
    angles = quat_angle(out, target)
    assert np.all(np.diff(angles) < 0.0)
    assert angles[10] == pytest.approx(2.0 * math.exp(-10 * 0.01 / 0.05), abs=1e-9)
    assert angles[-1] < 1e-8
    # a list of four numbers works too, and anything else is an error for that message only
    rt.nodes["x"].receive(0, make(tuple(target.tolist()), time=1.01))
    assert rt.nodes["out"].messages[-1].kind == "list"
    with pytest.raises(ValueError, match="4 numbers"):
        rt.nodes["x"].receive(0, make(1.0, time=1.02))


def test_slerp_smoothing_of_vectors_equals_the_reference_update():
    rng = np.random.default_rng(5)
    qs = rng.normal(size=(80, 4))  # neither unit nor sign-continuous
    vec, lst = one("smooth slerp 30"), one("smooth slerp 30")
    for k, q in enumerate(qs):
        t = 0.001 * k * (1 + k % 3)  # uneven steps
        vec.nodes["x"].receive(0, make(q, time=t))  # a vector: the per-sample float path
        lst.nodes["x"].receive(0, make(tuple(q.tolist()), time=t))  # a list: QuatSmoother.update
    a, b = np.array(vec.nodes["out"].values), np.array(lst.nodes["out"].values)
    assert a.shape == (80, 4) and [m.kind for m in out_of(vec)] == ["vector"] * 80
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="4 numbers"):
        vec.nodes["x"].receive(0, make(np.array([1.0, 0.0, 0.0]), time=1.0))
    with pytest.raises(ValueError, match="NaN or infinite"):
        vec.nodes["x"].receive(0, make(np.array([1.0, math.nan, 0.0, 0.0]), time=1.0))
    assert np.array_equal(vec.nodes["x"]._filter.value, a[-1])  # a bad sample leaves the state as it was


def test_smooth_parameter_errors_at_load():
    with pytest.raises(PatchError, match="wrap applies to exp and euro"):
        one("smooth slerp wrap=true")
    with pytest.raises(PatchError, match="time must be >= 0 ms"):
        one("smooth exp -5")
    with pytest.raises(PatchError, match="d_cutoff must be > 0"):
        one("smooth euro d_cutoff=0")
    with pytest.raises(PatchError, match="expects one of exp, euro, slerp"):
        one("smooth kalman")


def test_smooth_drops_bad_messages_keeps_its_state_and_resets(caplog):
    rt = one("smooth exp 100", upstream=True)
    src = rt.nodes["src"]
    with caplog.at_level(logging.ERROR):
        src.receive(0, make(0.0, time=0.0))
        src.receive(0, make(math.nan, time=0.05))
        src.receive(0, make("up", time=0.06))
        src.receive(0, make((1.0, 2.0), time=0.07))  # a list after numbers: the shape changed
        src.receive(0, make(1.0, time=0.1))
    assert caplog.text.count("node 'x' (smooth), inlet 'in': dropped") == 3
    assert rt.nodes["out"].values == pytest.approx([0.0, 1 - math.exp(-1.0)], abs=1e-12)
    src.receive(0, method("reset"))
    src.receive(0, make((1.0, 2.0), time=0.2))
    assert rt.nodes["out"].values[-1] == (1.0, 2.0)
    assert all(np.all(np.isfinite(v)) for v in rt.nodes["out"].values)


# --- threshold -------------------------------------------------------------------------------------


def threshold_patch(args):
    return patch(
        f"""
node x threshold {args}
node out collect
x.rise -> out
x.fall -> out
x.state -> out
"""
    )


def events(rt):
    return [(m.kind, m.value, m.time) for m in out_of(rt)]


def test_threshold_fires_on_rise_and_fall_state_first():
    rt = threshold_patch("0.6 0.4")
    push(rt, [0.5, 0.6, 0.7, 0.5, 0.41, 0.4, 0.3, 0.9], [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7])
    assert events(rt) == [
        ("int", 1, 0.1),
        ("bang", None, 0.1),  # rise: state 1, then the bang on the left outlet
        ("int", 0, 0.5),
        ("bang", None, 0.5),  # fall: state 0, then the bang on the middle outlet
        ("int", 1, 0.7),
        ("bang", None, 0.7),
    ]
    rise_to = [n.name for n, _ in rt.nodes["x"]._targets[0]]
    assert rise_to == ["out"]


def test_threshold_does_not_flicker_on_a_noisy_signal():
    rng = np.random.default_rng(2)
    t = np.arange(600) * 0.01
    level = np.where((t >= 2.0) & (t < 4.0), 0.65, 0.5)  # hover at the threshold, up, back
    noisy = level + rng.uniform(-0.08, 0.08, size=t.size)
    rt = threshold_patch("high=0.6 low=0.4")
    push(rt, noisy.tolist(), t.tolist())
    states = [(m.value, m.time) for m in out_of(rt) if m.kind == "int"]
    assert [s for s, _ in states] == [1]  # one rise, no chatter, no fall (0.5 +- 0.08 stays above 0.4)
    assert 2.0 <= states[0][1] < 2.1
    # the same signal with no hysteresis gap chatters
    rt = threshold_patch("high=0.6 low=0.5999")
    push(rt, noisy.tolist(), t.tolist())
    assert sum(m.kind == "bang" for m in out_of(rt)) > 20


def test_threshold_live_thresholds_methods_and_errors(caplog):
    with pytest.raises(PatchError, match=r"low \(0.6\) must be below high \(0.4\)"):
        threshold_patch("0.4 0.6")
    rt = patch(
        "node src s to_x\nnode bus r to_x\nnode x threshold 10 5\nnode out collect\n"
        "bus -> x\nx.state -> out\n"
    )
    rt.start()
    src = rt.nodes["src"]
    push(rt, [11.0, 4.0], [0.0, 0.1], name="src")
    src.receive(0, method("set", 30.0, 20.0))
    push(rt, [25.0, 31.0, 21.0, 19.0], [0.2, 0.3, 0.4, 0.5], name="src")
    with caplog.at_level(logging.ERROR):
        src.receive(0, method("low", 40.0))  # above high: refused
        src.receive(0, make(math.nan, time=0.6))  # dropped
        src.receive(0, make("loud", time=0.7))  # dropped
    assert rt.nodes["x"].p.low == 20.0
    assert caplog.text.count("node 'x' (threshold)") == 3
    src.receive(0, method("state", 1))  # set without output
    src.receive(0, make(31.0, time=0.8))
    src.receive(0, method("reset"))
    src.receive(0, make(31.0, time=0.9))
    assert [(m.value, m.time) for m in out_of(rt)] == [(1, 0.0), (0, 0.1), (1, 0.3), (0, 0.5), (1, 0.9)]


# --- deadband --------------------------------------------------------------------------------------


def test_deadband_passes_values_that_moved_more_than_width():
    rt = one("deadband 0.5")
    push(rt, [0.0, 0.3, 0.5, 0.51, 0.2, 0.0, -0.5, -0.6], [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7])
    assert [(m.value, m.time) for m in out_of(rt)] == [(0.0, 0.0), (0.51, 0.3), (0.0, 0.5), (-0.6, 0.7)]


def test_deadband_wrap_vectors_live_width_and_reset():
    rt = one("deadband 2 wrap=true", upstream=True)
    push(rt, [179.0, -179.5, -178.0, 170.0], [0.0, 0.1, 0.2, 0.3], name="src")
    assert rt.nodes["out"].values == [179.0, -178.0, 170.0]
    src = rt.nodes["src"]
    src.receive(0, method("width", 10.0))
    push(rt, [175.0, -175.0], [0.4, 0.5], name="src")
    assert rt.nodes["out"].values[-1] == -175.0  # 15 degrees the short way round
    src.receive(0, method("reset"))
    push(rt, [-175.0], [0.6], name="src")
    assert rt.nodes["out"].values[-1] == -175.0 and len(rt.nodes["out"].values) == 5
    rt = one("deadband 1")
    vecs = [np.array([0.0, 0.0, 0.0]), np.array([0.5, -0.9, 0.2]), np.array([0.0, 1.2, 0.0])]
    push(rt, vecs, [0.0, 0.1, 0.2])
    passed = out_of(rt)
    assert [m.kind for m in passed] == ["vector", "vector"] and passed[1].value == (0.0, 1.2, 0.0)
    assert isinstance(passed[1], Message) and passed[1].time == 0.2


def test_deadband_errors():
    with pytest.raises(PatchError, match="parameter 'width' is required"):
        one("deadband")
    with pytest.raises(PatchError, match="width must be >= 0"):
        one("deadband -1")
    rt = one("deadband 1")
    with pytest.raises(ValueError, match="NaN"):
        rt.nodes["x"].receive(0, make(math.nan))
    with pytest.raises(TypeError, match="expected a number"):
        rt.nodes["x"].receive(0, make("far"))
    assert rt.nodes["out"].values == []


# --- help ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["map", "smooth", "threshold", "deadband"])
def test_help_pages(name, capsys):
    cls = default_registry.load_builtins().get(name)
    text = cls.help_text()
    assert text.startswith(name) and "inlets:" in text and "outlets:" in text and "example:" in text
    for p in cls.params:
        assert p.name in text and p.doc
    assert main(["help", name]) == 0
    assert capsys.readouterr().out.strip() == text.strip()


def test_help_names_the_1_euro_paper():
    text = default_registry.load_builtins().get("smooth").help_text()
    assert "Casiez, Roussel & Vogel" in text and "CHI 2012" in text and "10.1145/2207676.2208639" in text
