"""The gesture nodes in patches: taught over live control as a performer would in rehearsal, saved,
loaded at the next start; the shipped patch and its examples; strokes, postures and following; osc_send
on a real socket; mistakes said with the node's name."""

from __future__ import annotations

import json
import logging
import math
import socket
from pathlib import Path

import numpy as np
import pytest

from benchmarks.performer import score
from pointat.control import control
from pointat.devices.gesture_sim import performance
from pointat.devices.osc_wire import decode_packet
from pointat.message import make, method, vector
from pointat.testing import patch, sink_port

PATCHES = Path(__file__).resolve().parents[2] / "patches"


def _gestures_patch(tmp_path: Path, model: str, seed: int = 0, extra: str = "") -> str:
    """patches/gestures.pat with the glove's counts wired straight in (no pty: the manual clock drives
    it), the model file and MIDI files in ``tmp_path``, and collectors on the gesture node."""
    text = (PATCHES / "gestures.pat").read_text()
    text = text.replace("output=pty", f"output=direct seed={seed}").replace(
        "glove.device -> base\nbase.m1 -> nulls", "glove.adc -> nulls"
    )
    text = text.replace("file=gestures.json", f"file={model}")
    # its ports off the show's: control on a free one, what it tells to the tests' sink
    text = text.replace("osc_in port=9001", "osc_in port=0").replace("port=9000", f"port={sink_port()}")
    for n in (1, 2, 3):
        text = text.replace(
            f"node n{n}     midi_out kind=note", f"node n{n}     midi_out file={tmp_path}/n{n}.mid kind=note"
        )
    return (
        text
        + "node got collect\nnode none collect\nnode st collect\nmoves.gesture -> got\nmoves.none -> none\nmoves.status -> st\n"
        + extra
    )


def _teach(rt, truth, per: int = 9) -> None:
    """``record LABEL`` just before each of the first ``per`` gestures, then ``train``, as live control."""
    for label, start, _ in truth[:per]:
        rt.advance(start - 0.4 - rt.clock.now())
        assert control(rt, "/pointat/moves/record", [label], rt.clock.now()) is None
    rt.advance(truth[per - 1][2] + 0.5 - rt.clock.now())
    assert control(rt, "/pointat/moves/train", [], rt.clock.now()) is None


def test_taught_over_live_control_saved_and_loaded_at_the_next_start(tmp_path):
    model = tmp_path / "moves.json"
    script, truth = performance(4, 30, loop=True, lead=3.0)
    rt = patch(_gestures_patch(tmp_path, str(model), seed=4), file=str(PATCHES / "gestures.pat"))
    try:
        _teach(rt, truth)
        assert control(rt, "/pointat/moves/save", [], rt.clock.now()) is None
        rt.advance(truth[19][2] + 0.5 - rt.clock.now())
        got = [(m.time, m.value[0]) for m in rt.nodes["got"].messages]
        status = [m.value for m in rt.nodes["st"].messages]
    finally:
        rt.shutdown()
    assert ("trained", 3, 9) in status and ("saved", str(model), 9) in status
    right, wrong, missed, false = score(got, truth[9:20])
    assert right >= 10 and wrong == false == 0, (right, wrong, missed, false)
    # every decision went out as OSC's /pointat/gesture LABEL SCORE and a MIDI note of its own
    assert all(0.0 <= m.value[1] <= 1.0 for m in rt.nodes["got"].messages)
    assert all((tmp_path / f"n{n}.mid").stat().st_size > 22 for n in (1, 2, 3))
    doc = json.loads(model.read_text())
    assert doc["format"] == "pointat-gestures" and doc["channels"] == ["gyr", "acc"]
    assert sorted(e["label"] for e in doc["examples"]) == ["circle"] * 3 + ["flick"] * 3 + ["nod"] * 3
    # the next start: the examples are loaded and recognised from the first gesture on
    rt = patch(_gestures_patch(tmp_path, str(model), seed=4), file=str(PATCHES / "gestures.pat"))
    try:
        rt.advance(truth[9][2] + 0.5)
        got = [(m.time, m.value[0]) for m in rt.nodes["got"].messages]
        assert rt.nodes["st"].messages[0].value == ("loaded", str(model), 9)
    finally:
        rt.shutdown()
    assert score(got, truth[:10])[0] >= 9


def test_adapt_takes_clear_performances_as_examples_and_save_keeps_them(tmp_path):
    """adapt set live after training: movements recognised with a clear margin become examples of their
    class (told on status, at most keep a class, the taught ones kept), and save writes them."""
    model = tmp_path / "moves.json"
    script, truth = performance(4, 30, loop=True, lead=3.0)
    rt = patch(_gestures_patch(tmp_path, str(model), seed=4), file=str(PATCHES / "gestures.pat"))
    try:
        _teach(rt, truth)
        assert control(rt, "/pointat/moves/keep", [4], rt.clock.now()) is None
        assert control(rt, "/pointat/moves/adapt", [1], rt.clock.now()) is None
        rt.advance(truth[24][2] + 0.5 - rt.clock.now())
        assert control(rt, "/pointat/moves/save", [], rt.clock.now()) is None
        rt.advance(0.5)
        got = [(m.time, m.value[0]) for m in rt.nodes["got"].messages]
        adapted = [m.value for m in rt.nodes["st"].messages if m.value[0] == "adapted"]
    finally:
        rt.shutdown()
    right, wrong, missed, false = score(got, truth[9:25])
    assert right >= 14 and wrong == false == 0, (right, wrong, missed, false)
    assert adapted and all(label in ("circle", "flick", "nod") and n <= 4 for _, label, n in adapted)
    saved = [e["label"] for e in json.loads(model.read_text())["examples"]]
    assert all(saved.count(label) <= 4 for label in set(saved)) and len(saved) > 9


def test_adapt_asked_of_a_spotter_is_said_to_do_nothing(caplog):
    """cut=spot tells gestures only: adapt set at load or live is said to do nothing there, with the node's
    name, and a rest-to-rest cut says nothing of it."""
    with caplog.at_level(logging.WARNING):
        rt = patch(
            "node g gesture channels=[gyr acc] cut=spot adapt=1\nnode h gesture channels=[gyr acc] adapt=1\n"
        )
    try:
        assert "gesture 'g': adapt does nothing with cut=spot" in caplog.text and "'h'" not in caplog.text
        caplog.clear()
        with caplog.at_level(logging.WARNING):
            assert control(rt, "/pointat/g/adapt", [0], 0.0) is None
            assert "adapt does nothing" not in caplog.text
            assert control(rt, "/pointat/g/adapt", [1], 0.0) is None
        assert "gesture 'g': adapt does nothing with cut=spot" in caplog.text
    finally:
        rt.shutdown()


def test_the_shipped_patch_recognises_the_simulated_glove(tmp_path):
    """patches/gestures.json (taught from the simulated glove's first nine gestures) on the rest of its
    performance: the patch works as it ships."""
    script, truth = performance(0, 30, loop=True, lead=3.0)
    rt = patch(_gestures_patch(tmp_path, str(PATCHES / "gestures.json")), file=str(PATCHES / "gestures.pat"))
    try:
        rt.advance(truth[29][2] + 0.5)
        got = [(m.time, m.value[0]) for m in rt.nodes["got"].messages]
    finally:
        rt.shutdown()
    right, wrong, missed, false = score(got, truth)
    assert right >= 27 and wrong + false <= 1, (right, wrong, missed, false)


def test_mistakes_are_said_and_nothing_is_lost(tmp_path, caplog):
    bad = tmp_path / "bad.json"
    bad.write_text('{"format": "pointat-gestures", "version": 1, "kind": "gesture", "channels": ["gyr"]')
    rt = patch(f"node g gesture channels=[gyr acc] file={bad}\nnode st collect\ng.status -> st\n")
    g = rt.nodes["g"]
    with caplog.at_level(logging.WARNING):
        rt.start()
    try:
        assert f"{bad}:1: not JSON" in caplog.text and not g.running
        with pytest.raises(TypeError, match="record needs a label"):
            g.receive(0, method("record"))
        with pytest.raises(ValueError, match="run: nothing trained yet"):
            g.receive(0, method("run"))
        with pytest.raises(ValueError, match="train on"):
            g.receive(0, method("train"))
        with pytest.raises(ValueError, match="did not read at the start"):
            g.receive(0, method("save"))
        with pytest.raises(TypeError, match="3 numbers, got 2"):
            g.receive(0, vector([1.0, 2.0]))
        other = tmp_path / "posture.json"
        other.write_text(
            json.dumps(
                {
                    "format": "pointat-gestures",
                    "version": 1,
                    "kind": "posture",
                    "channels": ["q"],
                    "size": 0,
                    "examples": [],
                }
            )
        )
        with pytest.raises(ValueError, match="kind 'posture'; this node learns 'gesture'"):
            g.receive(0, method("load", str(other)))
        assert bad.read_text().endswith('["gyr"]')  # the file that did not read is still as it was
    finally:
        rt.shutdown()


def test_a_posture_is_told_as_the_hand_takes_it(tmp_path):
    from pointat.maths.quaternion import euler_to_quat

    rt = patch(
        f"node hand posture file={tmp_path}/hand.json samples=30 hold=50\nnode p collect\nnode n collect\nnode st collect\nhand.posture -> p\nhand.none -> n\nhand.status -> st\n"
    )
    hand = rt.nodes["hand"]
    rng = np.random.default_rng(0)
    t = 0.0

    def hold(yaw, pitch, roll, seconds):
        nonlocal t
        for _ in range(int(seconds * 100)):
            a = np.radians(np.array([yaw, pitch, roll]) + rng.normal(0, 1.5, 3))
            hand.receive(0, vector(euler_to_quat(*a), t))
            t += 0.01

    for label, pose in (("level", (0, 0, 0)), ("palm_up", (0, 0, 180)), ("up", (0, -70, 0))):
        hand.receive(0, method("record", label))
        hold(*pose, 0.5)
    hand.receive(0, method("train"))
    rt.nodes["p"].messages.clear()
    hold(90, 0, 180, 0.5)  # palm up, facing left
    hold(90, -35, 90, 0.5)  # in between: no posture
    hold(-120, -70, 0, 0.5)  # up, facing behind
    assert rt.nodes["p"].values == ["palm_up", "up"] and len(rt.nodes["n"].messages) == 1
    hand.receive(0, method("save"))
    assert [m.value[0] for m in rt.nodes["st"].messages][-2:] == ["trained", "saved"]
    rt.shutdown()


def test_strokes_through_the_glove_chain_point_into_the_room():
    """simulate (strikes down, then forward along the pointing axis) -> offset -> scaling -> tqt ->
    stroke: every strike told once, the direction struck towards in the room."""
    out = {}
    for axis in ("vertical", "pointing"):
        rt = patch(
            f"""
node glove simulate rate=100 burst=strokes burst_g=5 burst_rate=4 burst_length=2 burst_every=8 burst_axis={axis}
node nulls offset samples=150
node units scaling
node tqt   tqt rate=100
node hit   stroke
node got   collect
node q     collect
glove.adc -> nulls -> units
units.mag -> tqt.mag
units.accel -> tqt.accel
units.gyro -> tqt.gyro
units.accel -> hit.acc
tqt.quat -> hit.q
hit.stroke -> got
glove.truth -> q
"""
        )
        rt.advance(11.0)
        truth = {round(m.time, 3): m.value for m in rt.nodes["q"].messages}
        out[axis] = [(m.value, truth[round(m.time, 3)]) for m in rt.nodes["got"].messages]
        rt.shutdown()
    assert len(out["vertical"]) == 8 and all(el < -85 for (_, el, _), _ in out["vertical"])
    # along the pointing axis the hand lifts forward and strikes back towards the performer: the
    # direction struck is the pointing direction's opposite, as the sweep turns it
    assert len(out["pointing"]) == 8
    for (az, el, strength), (w, x, y, z) in out["pointing"]:
        pointing = math.degrees(math.atan2(2 * (x * y + w * z), 1 - 2 * (y * y + z * z)))
        assert abs((az - pointing - 180.0 + 180.0) % 360.0 - 180.0) < 5.0 and abs(el) < 5.0
        assert 3.0 < strength < 5.5  # 5 g, as the 12-bit accelerometer clipping at ~4 g per axis sees it


def test_following_a_taught_movement(tmp_path):
    from benchmarks.performer import sensor_stream
    from pointat.devices.glove_sim import MotionScript, Segment, hold

    rt = patch(
        f"node bow follow file={tmp_path}/bow.json\nnode p collect\nnode s collect\nbow.progress -> p\nbow.speed -> s\n"
    )
    bow = rt.nodes["bow"]

    def play(speed, seed, t0):
        moves = [Segment(0.5 / speed, 60.0, 20.0), Segment(0.5 / speed, 0.0, 0.0)]
        script = MotionScript([hold(0.6), *moves, hold(0.6)], loop=False)
        t, gyr, acc, _ = sensor_stream(script, 100.0, seed)
        for k in range(len(t)):
            bow.receive(1, vector(acc[k], t0 + t[k]))
            bow.receive(0, vector(gyr[k], t0 + t[k]))
        return t0 + t[-1] + 0.01

    t0 = 0.0
    for seed in range(3):
        bow.receive(0, method("record", "bow"))
        t0 = play(1.0, seed, t0)
    bow.receive(0, method("train"))
    for speed in (1.0, 2.0):
        rt.nodes["p"].messages.clear()
        rt.nodes["s"].messages.clear()
        t0 = play(speed, 10 + int(speed), t0)
        progress = rt.nodes["p"].values
        assert progress[-1] > 0.85 and progress[0] < 0.2
        speeds = rt.nodes["s"].values
        assert np.median(speeds[len(speeds) // 4 : 3 * len(speeds) // 4]) == pytest.approx(speed, rel=0.35)
    rt.shutdown()


def test_osc_send_on_a_real_socket():
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(2.0)
    try:
        rt = patch(f"node tell osc_send address=/pointat/gesture port={rx.getsockname()[1]}\n")
        rt.start()
        tell = rt.nodes["tell"]
        tell.receive(0, make(("circle", 0.75)))
        tell.receive(0, make(3))
        tell.receive(0, make(None))
        tell.receive(0, method("/cue/go", 2.5))
        tell.receive(0, method("next"))
        got = [decode_packet(rx.recv(1500)) for _ in range(5)]
        rt.shutdown()
    finally:
        rx.close()
    assert got == [
        [("/pointat/gesture", ["circle", 0.75])],
        [("/pointat/gesture", [3])],
        [("/pointat/gesture", [])],
        [("/cue/go", [2.5])],
        [("/pointat/gesture/next", [])],
    ]


def test_record_refuses_a_label_that_is_no_word():
    rt = patch("node g gesture\n")
    g = rt.nodes["g"]
    for bad in ("two words", "", "x" * 101, "../../escaped", "/abs/dir", ".."):  # (a label becomes a folder)
        with pytest.raises(ValueError, match="^label: expected"):
            g.receive(0, method("record", bad))
    with pytest.raises(ValueError, match="count is 1..1000"):
        g.receive(0, method("record", "circle", 0))
    rt.shutdown()


def test_check_reads_the_examples_file_when_it_is_there(tmp_path):
    """`pointat check` finds a spoilt examples file before the show; a missing one is no problem (the
    examples are still to be taught)."""
    from pointat.cli import main

    pat = tmp_path / "moves.pat"
    pat.write_text("node g gesture channels=[gyr acc] file=moves.json\nnode p print\ng.gesture -> p\n")
    assert main(["check", str(pat)]) == 0
    (tmp_path / "moves.json").write_text(
        '{"format": "pointat-gestures", "version": 1, "kind": "gesture",\n oops'
    )
    assert main(["check", str(pat)]) == 2
    (tmp_path / "moves.json").write_text(
        json.dumps(
            {
                "format": "pointat-gestures",
                "version": 1,
                "kind": "gesture",
                "channels": ["acc"],
                "size": 0,
                "examples": [],
            }
        )
    )
    assert main(["check", str(pat)]) == 2


def test_check_names_the_spoilt_file_and_its_line(tmp_path, capsys):
    from pointat.cli import main

    pat = tmp_path / "moves.pat"
    pat.write_text("node g gesture file=moves.json\nnode p print\ng.gesture -> p\n")
    (tmp_path / "moves.json").write_text('{"format": "pointat-gestures",\n "version": 1 "kind"}')
    assert main(["check", str(pat)]) == 2
    err = capsys.readouterr().err
    assert "moves.pat:1" in err and "moves.json:2: not JSON" in err
