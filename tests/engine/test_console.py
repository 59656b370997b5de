"""What the console tells a performer, in process: live control acknowledged (a press at once, a fader's
stream a line a second, ending on its last value), and a banner that names every output (a gesture
patch's OSC messages too)."""

from __future__ import annotations

from pathlib import Path

from pointat.checking import check
from pointat.console import banner
from pointat.control import Told, control
from pointat.expansion import read_spec
from pointat.loader import build, parse_overrides
from pointat.registry import Registry
from pointat.testing import patch

ROOT = Path(__file__).resolve().parents[2]


def _said(rt) -> list[str]:
    said: list[str] = []
    rt.console = said.append
    return said


def test_a_press_is_acknowledged_at_once_and_a_fader_a_line_a_second_ending_on_its_value():
    rt = patch("node press trigger b\nnode lim speedlim 100\n")
    said = _said(rt)
    rt.advance(0.0)
    assert control(rt, "/pointat/press/bang", [], rt.clock.now()) is None
    assert said == ["live control: /pointat/press/bang"]
    # a fader: 50 values in half a second, one line at once, the rest told once when the second is up
    for i in range(50):
        rt.advance(0.01)
        assert control(rt, "/pointat/lim/interval", [100.0 + i], rt.clock.now()) is None
    assert said[1:] == ["live control: /pointat/lim/interval 100"]
    rt.advance(1.0)
    assert said[2:] == ["live control: /pointat/lim/interval 149 (the last of 49 in 1 s)"]
    assert rt.nodes["lim"].p.interval == 149.0
    # a second press a moment after the first is told too: one message held, then told alone
    rt.advance(0.5)
    control(rt, "/pointat/press/bang", [], rt.clock.now())
    assert said[3:] == ["live control: /pointat/press/bang"]
    rt.advance(0.2)
    control(rt, "/pointat/press/bang", [], rt.clock.now())
    assert said[4:] == []
    rt.advance(1.0)
    assert said[4:] == ["live control: /pointat/press/bang"]
    # what is refused is not acknowledged (its sender's log says why), nor a preset (it says itself)
    assert control(rt, "/pointat/nobody/bang", [], rt.clock.now()) is not None
    rt.advance(2.0)
    assert len(said) == 5
    rt.shutdown()


def test_told_says_an_osc_float_as_it_was_typed():
    rt = patch("node lim speedlim 100\n")
    said = _said(rt)
    Told(rt).tell("/pointat/fuse/k_heading", [0.05000000074505806, "two words", 3])
    assert said == ["live control: /pointat/fuse/k_heading 0.05 'two words' 3"]
    rt.shutdown()


def test_the_gestures_banner_lists_its_osc_outputs():
    path = ROOT / "patches" / "gestures.pat"
    rt = build(check(read_spec(str(path)), Registry().load_builtins(), parse_overrides([])))
    try:
        lines = banner(rt, str(path))
    finally:
        rt.shutdown()
    assert "  out  osc_send 'tell': OSC /pointat/gesture to 127.0.0.1:9000" in lines, lines
    assert "  out  osc_send 'hits': OSC /pointat/stroke to 127.0.0.1:9000" in lines, lines
    midi = [line for line in lines if "midi_out 'n1'" in line]
    assert midi and "(the first)" not in midi[0], lines


TWO_GLOVES = """
node g1 simulate rate=100
node u1 scaling
node f1 tqt
node d1 azi_ele
node o1 osc_out port=9
node g2 simulate rate=100
node u2 scaling
node f2 tqt
node d2 azi_ele
node o2 osc_out port=9
g1.adc -> u1
u1.mag -> f1.mag
u1.accel -> f1.accel
u1.gyro -> f1.gyro
f1.quat -> d1
d1.azimuth -> o1.azimuth
f1.flags -> o1.flags
g2.adc -> u2
u2.mag -> f2.mag
u2.accel -> f2.accel
u2.gyro -> f2.gyro
f2.quat -> d2
d2.azimuth -> o2.azimuth
f2.flags -> o2.flags
"""


def test_a_filter_has_no_input_only_when_its_own_glove_is_down_and_the_other_gloves_line_stays_clear():
    from pointat.monitor.observe import Observer, _worst_flag

    rt = patch(TWO_GLOVES)
    try:
        obs = Observer(rt).attach()
        assert {name: [s.key for s in streams] for name, streams in obs.fed_by.items()} == {
            "f1": ["g1.adc"],
            "f2": ["g2.adc"],
        }
    finally:
        rt.shutdown()
    # the flag the status lines show beside every pointer: a filter's, never "no input"
    assert _worst_flag({"f1": {"flag": "no input"}, "f2": {"flag": "ok"}}) == ""
    assert _worst_flag({"f1": {"flag": "no input"}, "f2": {"flag": "mag_disturbed"}}) == "mag_disturbed"


def test_before_any_data_the_status_lines_say_waiting_not_ok_at_0_hz():
    from pointat.monitor.observe import Observer

    rt = patch(TWO_GLOVES)
    try:
        lines = Observer(rt).attach().status_lines()
    finally:
        rt.shutdown()
    assert lines == [
        "o1: waiting for a direction (none sent yet)",
        "o2: waiting for a direction (none sent yet)",
        "g1.adc: waiting for data",
        "g2.adc: waiting for data",
    ], lines


def test_a_glove_gone_silent_is_a_dropout_of_its_pointer_and_no_input_of_its_filter_only(monkeypatch):
    """The observer on a clock of the test's: glove 1 sends, then falls silent for a second; glove 2 has
    sent nothing yet."""
    from types import SimpleNamespace

    from pointat.monitor import observe

    now = [100.0]
    monkeypatch.setattr(observe, "time", SimpleNamespace(monotonic=lambda: now[0], sleep=lambda s: None))
    rt = patch(TWO_GLOVES)
    try:
        obs = observe.Observer(rt).attach()
        glove1 = next(s for s in obs.streams if s.key == "g1.adc")
        for _ in range(10):  # 100 Hz for a tenth of a second
            glove1.hits(1)
            rt.nodes["o1"].heard += 1
            now[0] += 0.01
        snap = obs.read()
        o1, o2 = snap["pointers"]
        assert (o1["state"], o2["state"]) == ("ok", "waiting")
        assert snap["flags"]["f1"]["flag"] == "ok"
        now[0] += 1.0  # nothing more from glove 1
        snap = obs.read()
        o1, o2 = snap["pointers"]
        assert o1["state"] == "dropout" and 0.9 < o1["silent_s"] < 1.1, o1
        assert o2["state"] == "waiting", o2
        assert snap["flags"]["f1"]["flag"] == "no input" and snap["flags"]["f2"]["flag"] == "ok", snap[
            "flags"
        ]
        lines = obs.status_lines()
        assert lines[0].startswith("o1: NO DATA for 1.") and lines[2].startswith("g1.adc: NO DATA for 1."), (
            lines
        )
    finally:
        rt.shutdown()
