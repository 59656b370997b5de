"""offset, scaling and calibrate: known nulls and scales recovered, and the file used by the chain."""

import math
import re

import numpy as np
import pytest

from pointat.maths.calibration import Calibration, six_position_accel
from pointat.message import method, vector
from pointat.testing import patch


def test_offset_nulls_gyros_from_rest_and_keeps_gravity():
    rt = patch(
        "node nulls offset samples=10\nnode out collect\nnode status collect\nnulls -> out\nnulls.status -> status\n"
    )
    nulls = rt.nodes["nulls"]
    rest = [2050.0, 2040.0, 2049.0, 2048.0, 2048.0, 2559.0, 2448.0, 2048.0, 1606.0]
    for k in range(10):
        nulls.receive(0, vector(rest, k * 0.01))
    assert rt.nodes["out"].messages == []  # nothing while averaging
    assert rt.nodes["status"].values[-1][0] == "ready"
    nulls.receive(0, vector(rest, 0.1))
    got = rt.nodes["out"].values[0]
    assert list(got[:3]) == [0.0, 0.0, 0.0]  # gyro bias removed
    assert got[5] == 511.0 and got[8] == -442.0  # gravity and the field stay (mid-scale nulls)
    nulls.receive(0, method("recalibrate"))
    nulls.receive(0, vector(rest, 0.2))  # the output goes on, with the nulls it has, while it averages
    assert len(rt.nodes["out"].messages) == 2 and rt.nodes["out"].values[1][:3] == (0.0, 0.0, 0.0)


def test_offset_refuses_gyro_nulls_taken_while_the_glove_moved(caplog):
    rt = patch(
        "node nulls offset samples=20\nnode out collect\nnode status collect\nnulls -> out\nnulls.status -> status\n"
    )
    nulls = rt.nodes["nulls"]
    rest = [2051.0, 2046.0, 2049.0, 2048.0, 2048.0, 2559.0, 2448.0, 2048.0, 1606.0]

    def feed(t0, z_swing):  # z_swing: counts the gyro z swings by (a hand turning), 0 at rest
        for k in range(20):
            nulls.receive(0, vector([*rest[:2], rest[2] + z_swing * math.sin(k), *rest[3:]], t0 + k * 0.01))

    feed(0.0, 300.0)  # moved while the first nulls were taken: refused, and taken again
    assert rt.nodes["status"].values[-1][:2] == ("moved", "z") and rt.nodes["out"].messages == []
    assert "the glove moved while the gyro nulls were taken (gyro z varied by" in caplog.text
    feed(0.2, 0.0)
    assert rt.nodes["status"].values[-1] == ("ready", 2051.0, 2046.0, 2049.0)
    nulls.receive(0, method("recalibrate"))  # sent mid-performance, with the hand moving: the nulls stay
    feed(0.4, 300.0)
    assert rt.nodes["status"].values[-1][:2] == ("moved", "z") and nulls.nulls[:3] == (2051.0, 2046.0, 2049.0)
    assert len(rt.nodes["out"].messages) == 20  # the output went on all through it
    nulls.receive(0, vector(rest, 1.0))
    assert rt.nodes["out"].values[-1][:3] == (0.0, 0.0, 0.0)


def test_offset_with_the_files_gyro_nulls_outputs_at_once_until_todays_average_replaces_them(tmp_path):
    # a performer who starts the patch with the glove on and moving gets output from the first sample
    cal = Calibration()
    cal.gyro_null[:] = (2050.0, 2045.0, 2047.0)  # a day old: today's bias is a count or two off
    cal.acc_null[:] = (2048.0, 2048.0, 2048.0)
    cal.save(tmp_path / "cal.json")
    rt = patch(
        f"node nulls offset samples=20 calibration={tmp_path / 'cal.json'}\n"
        "node out collect\nnode status collect\nnulls -> out\nnulls.status -> status\n"
    )
    nulls, out = rt.nodes["nulls"], rt.nodes["out"]
    rest = [2051.0, 2046.0, 2049.0, 2048.0, 2048.0, 2559.0, 2448.0, 2048.0, 1606.0]
    for k in range(20):  # moving: the average is refused, the output flows with the file's nulls
        nulls.receive(0, vector([*rest[:2], rest[2] + 300.0 * math.sin(k), *rest[3:]], k * 0.01))
    assert len(out.messages) == 20 and out.values[0][:2] == (1.0, 1.0)
    assert rt.nodes["status"].values[-1][:2] == ("moved", "z")
    for k in range(20):  # still: taken again (not given up, as after an average of this run)
        nulls.receive(0, vector(rest, 0.2 + k * 0.01))
    assert rt.nodes["status"].values[-1] == ("ready", 2051.0, 2046.0, 2049.0)
    nulls.receive(0, vector(rest, 0.5))
    assert out.values[-1][:3] == (0.0, 0.0, 0.0) and len(out.messages) == 41


def test_scaling_converts_to_si_right_to_left():
    rt = patch("""
node units scaling gyro=0.1 accel=0.02 mag=0.001
node log collect
units.gyro -> log
units.accel -> log
units.mag -> log
""")
    rt.nodes["units"].receive(0, vector([10, 0, -10, 0, 0, 490, 400, 0, -900]))
    g, a, m = rt.nodes["log"].values[2], rt.nodes["log"].values[1], rt.nodes["log"].values[0]
    assert [x.kind for x in rt.nodes["log"].messages] == ["vector"] * 3
    assert list(g) == pytest.approx([math.radians(1.0), 0.0, -math.radians(1.0)])
    assert list(a) == pytest.approx([0.0, 0.0, 9.8])
    assert list(m) == pytest.approx([0.4, 0.0, -0.9])


def test_calibrate_recovers_known_nulls_and_scales_and_the_chain_uses_the_file(tmp_path):
    rng = np.random.default_rng(7)
    acc_null, acc_scale = np.array([2040.0, 2060.0, 2050.0]), np.array([52.0, 49.0, 51.0])  # counts per m/s²
    gyro_null = np.array([2051.0, 2046.0, 2049.5])
    mag_null, mag_scale = np.array([2030.0, 2070.0, 2000.0]), np.array([1000.0, 1100.0, 950.0])  # per gauss
    g = 9.80665
    path = tmp_path / "glove1.json"
    rt = patch(f"node cal calibrate file={path} samples=50\nnode st collect\ncal -> st\n")
    cal = rt.nodes["cal"]
    t = [0.0]

    def feed(gyro_rate, acc, mag, n):
        for _ in range(n):
            counts = np.concatenate(
                [gyro_null + gyro_rate, acc_null + acc_scale * acc, mag_null + mag_scale * mag]
            )
            cal.receive(0, vector(counts + rng.normal(0, 0.2, 9), t[0]))
            t[0] += 0.01

    cal.receive(0, method("rest"))
    feed(0.0, np.array([0, 0, g]), np.array([0.2, 0, -0.4]), 50)
    for axis in range(3):
        for sign in (1, -1):
            cal.receive(0, method("pose"))
            up = np.zeros(3)
            up[axis] = sign * g
            feed(0.0, up, np.array([0.2, 0, -0.4]), 50)
    cal.receive(0, method("mag_begin"))
    for d in rng.normal(size=(400, 3)):
        feed(0.0, np.array([0, 0, g]), 0.45 * d / np.linalg.norm(d), 1)
    cal.receive(0, method("mag_end"))
    cal.receive(0, method("save"))
    saved = Calibration.load(path)
    assert saved.gyro_null == pytest.approx(gyro_null, abs=0.1)
    assert saved.acc_null == pytest.approx(acc_null, abs=0.2)
    assert saved.acc_scale == pytest.approx(acc_scale, rel=2e-3)
    assert saved.mag_null == pytest.approx(mag_null, abs=15)
    assert rt.nodes["st"].values[-1] == ("saved", str(path))
    # offset and scaling read the file: a level, still sensor reads (0, 0, g)
    rt2 = patch(f"""
node nulls offset samples=0 calibration={path}
node units scaling calibration={path}
node acc collect
nulls -> units
units.accel -> acc
""")
    counts = np.concatenate([gyro_null, acc_null + acc_scale * np.array([0, 0, g]), mag_null])
    rt2.nodes["nulls"].receive(0, vector(counts, 0.0))
    assert rt2.nodes["acc"].values[0] == pytest.approx([0, 0, g], abs=0.01)


def test_a_bad_calibration_file_is_a_load_error_naming_it(tmp_path):
    from pointat.errors import PatchError

    bad = tmp_path / "bad.json"
    bad.write_text('{"format": "pointat-calibration", "version": 1, "acc": {"null": [1, 2]}}')
    with pytest.raises(PatchError) as info:
        patch(f"node nulls offset calibration={bad}\n")
    assert "bad.json" in str(info.value) and "nulls" in str(info.value)


def test_a_calibration_file_names_itself_once_and_every_way_it_can_be_wrong(tmp_path):
    from pointat.errors import PatchError

    cases = {
        "huge": (
            '{"format": "pointat-calibration", "version": 1, "acc": {"null": [1e999, 2, 3]}}',
            "key 'acc.null'",
        ),
        "bigint": (
            '{"format": "pointat-calibration", "version": 1, "acc": {"null": [' + "9" * 400 + ", 2, 3]}}",
            "key 'acc.null'",
        ),
        "deep": ("[" * 100000 + "]" * 100000, "nested too deeply"),
        "latin1": (None, "not UTF-8 text"),
    }
    for name, (text, said) in cases.items():
        path = tmp_path / f"{name}.json"
        if text is None:
            path.write_bytes('{"format": "pointat-calibration", "version": 1} caf\xe9'.encode("latin-1"))
        else:
            path.write_text(text)
        with pytest.raises(PatchError) as info:
            patch(f"node units scaling calibration={path}\n")
        message = str(info.value)
        assert said in message and message.count(str(path)) == 1, message
    bom = tmp_path / "bom.json"  # saved by a Windows editor: taken, as patch files are
    bom.write_bytes(b"\xef\xbb\xbf" + b'{"format": "pointat-calibration", "version": 1}')
    patch(f"node units scaling calibration={bom}\n")


@pytest.mark.parametrize(
    "sections, said",
    [  # each loaded without a word, and then the output was garbage or silence
        (
            '"gyro": {"null": [2048, 2048, 2048], "scale": [0.1, 0.1, 0.1]}',
            "gyro.scale [0.1 0.1 0.1] (counts per unit) is up to 5.73e+03 times off the nominal 573",
        ),
        ('"acc": {"scale": [52, 52, 52]}', "acc has scales but no nulls"),
        (
            '"acc": {"null": [2048, 2048, 2048], "scale": [1e-320, 52, 52]}',
            "acc.scale [9.99989e-321 52 52] (counts per unit) is up to inf times off",
        ),
        (  # the same with an axis flipped by hand
            '"acc": {"null": [2048, 2048, 2048], "scale": [52, 52, -0.0192]}',
            "acc.scale [52 52 -0.0192] (counts per unit) is up to",
        ),
        (
            '"mag": {"null": [2048, 2048, 2048], "scale": [1, 1, 1], "soft_iron": [[0, 0, 0], [0, 0, 0], [0, 0, 0]]}',
            "mag.soft_iron is singular",
        ),
        (  # a cross-axis term of 5.7 deg: poses that were not about the board's axes
            '"acc": {"null": [2048, 2048, 2048], "scale": [52, 52, 52],'
            ' "misalignment": [[1, 0.1, 0], [0, 1, 0], [0, 0, 1]]}',
            "acc.misalignment has a cross-axis term of 0.1 (5.7 deg, x from y), more than 0.0873 (5 deg)",
        ),
    ],
)
def test_a_calibration_that_would_make_garbage_or_silence_is_refused_naming_the_key(tmp_path, sections, said):
    from pointat.errors import PatchError

    bad = tmp_path / "bad.json"
    bad.write_text('{"format": "pointat-calibration", "version": 1, ' + sections + "}")
    with pytest.raises(PatchError, match=re.escape(f"calibration file {bad}: {said}")):
        patch(f"node units scaling calibration={bad}\n")


@pytest.mark.parametrize(
    "span, fit, taken",
    [
        (
            (48.5, 84.5),
            "minmax",
            False,
        ),  # the simulated glove's sweep misses directions: min/max is off centre
        ((48.5, 84.5), "ellipsoid", True),  # an ellipsoid fit needs less of the sphere
        ((36.5, 42.5), "minmax", False),  # the glove held still all through the "sweep"
        ((36.5, 42.5), "ellipsoid", False),
    ],
)
def test_mag_end_refuses_a_sweep_that_would_turn_every_heading(span, fit, taken):
    from pointat.devices.glove_sim import GloveSimulator

    sim = GloveSimulator(rate_hz=100.0)
    rt = patch(f"node cal calibrate mag_fit={fit}\nnode st collect\ncal -> st\n")
    cal = rt.nodes["cal"]
    cal.receive(0, method("mag_begin"))
    for k in range(int(span[0] * 100), int(span[1] * 100)):
        cal.receive(0, vector(np.array(sim.sample(k).frame.channels, float), k / 100.0))
    if taken:
        cal.receive(0, method("mag_end"))
        assert cal.calibration.mag_null == pytest.approx([2048.0] * 3, abs=10)  # the simulator's true centre
    else:
        with pytest.raises(ValueError, match="the sweep did not cover enough directions"):
            cal.receive(0, method("mag_end"))
        assert rt.nodes["st"].values[-1][0] == "mag_refused"
        assert not np.any(cal.calibration.mag_null)  # unchanged: nothing taken


def test_reference_makes_the_captured_heading_azimuth_zero():
    from pointat.maths.quaternion import euler_to_quat

    rt = patch("""
node ref reference
node dir azi_ele
node az collect
node el collect
ref -> dir
dir.azimuth -> az
dir.elevation -> el
""")
    ref = rt.nodes["ref"]
    pointing = euler_to_quat(40.0, -10.0, 0.0, degrees=True)  # 40 left, 10 up
    ref.receive(0, vector(pointing))
    assert rt.nodes["az"].values[-1] == pytest.approx(40.0)
    ref.receive(0, method("set"))
    ref.receive(0, vector(pointing))
    assert rt.nodes["az"].values[-1] == pytest.approx(0.0, abs=1e-9)
    assert rt.nodes["el"].values[-1] == pytest.approx(10.0)  # heading mode keeps the true elevation
    ref.receive(0, vector(euler_to_quat(70.0, 0.0, 0.0, degrees=True)))
    assert rt.nodes["az"].values[-1] == pytest.approx(30.0)


def test_reference_takes_the_heading_of_the_axis_that_points():
    # a sensor mounted turned 35 deg on the hand: azi_ele and reference are told the same axis, and the
    # pose captured as the reference reads azimuth 0 (the heading of sensor x said -35)
    from pointat.maths.quaternion import euler_to_quat

    axis = [math.cos(math.radians(-35.0)), math.sin(math.radians(-35.0)), 0.0]
    rt = patch(f"""
node ref reference axis={axis} capture_first=true
node dir azi_ele axis={axis}
node az collect
ref -> dir
dir.azimuth -> az
""")
    ref = rt.nodes["ref"]
    ref.receive(0, vector(euler_to_quat(75.0, 5.0, 10.0, degrees=True)))
    assert rt.nodes["az"].values[-1] == pytest.approx(0.0, abs=1e-9)
    ref.receive(0, vector(euler_to_quat(105.0, 5.0, 10.0, degrees=True)))  # 30 deg further left
    assert rt.nodes["az"].values[-1] == pytest.approx(30.0, abs=1e-6)


def test_reference_capture_waits_for_an_orientation_with_a_heading():
    from pointat.maths.quaternion import euler_to_quat

    rt = patch("node ref reference\nnode dir azi_ele\nnode az collect\nref -> dir\ndir.azimuth -> az\n")
    ref = rt.nodes["ref"]
    ref.receive(0, method("set"))
    ref.receive(0, vector(euler_to_quat(60.0, -90.0, 0.0, degrees=True)))  # straight up: no heading
    assert ref.offset == (1.0, 0.0, 0.0, 0.0)
    ref.receive(0, vector(euler_to_quat(60.0, -20.0, 0.0, degrees=True)))  # the next one is taken
    assert rt.nodes["az"].values[-1] == pytest.approx(0.0, abs=1e-9)
    ref.receive(0, vector(euler_to_quat(80.0, -20.0, 0.0, degrees=True)))
    assert rt.nodes["az"].values[-1] == pytest.approx(20.0, abs=1e-6)


def test_reference_full_makes_the_reference_pose_the_identity_tilt_included():
    from pointat.maths.quaternion import euler_to_quat

    rt = patch("node ref reference mode=full\nnode out collect\nref -> out\n")
    ref = rt.nodes["ref"]
    pose = euler_to_quat(40.0, -10.0, 20.0, degrees=True)
    ref.receive(0, method("set"))
    ref.receive(0, vector(pose))
    assert rt.nodes["out"].values[-1] == pytest.approx((1.0, 0.0, 0.0, 0.0), abs=1e-12)


def test_reference_axis_must_not_be_zero():
    from pointat.errors import PatchError

    with pytest.raises(PatchError, match="axis must be a non-zero vector"):
        patch("node ref reference axis=[0, 0, 0]\n")


def test_calibrate_finds_a_gyro_scale_from_a_known_rotation(tmp_path):
    rt = patch(f"node cal calibrate file={tmp_path / 'c.json'} samples=20\nnode st collect\ncal -> st\n")
    cal = rt.nodes["cal"]
    null, scale = 2048.0, 573.0  # counts at rest, counts per rad/s on z
    t = 0.0
    cal.receive(0, method("rest"))
    for _ in range(20):
        cal.receive(0, vector([2048, 2048, null] + [2048] * 6, t))
        t += 0.01
    cal.receive(0, method("turn_begin"))
    for k in range(100):  # a quarter turn about z in one second, smooth: rate = (pi/4) * pi * sin(pi t)
        rate = (math.pi / 4) * math.pi * math.sin(math.pi * (k + 0.5) / 100)
        cal.receive(0, vector([2048, 2048, null + scale * rate] + [2048] * 6, t))
        t += 0.01
    cal.receive(0, method("turn_end", 90, 2))
    assert rt.nodes["st"].values[-1][:2] == ("gyro_scale", 2)
    assert cal.calibration.gyro_scale[2] == pytest.approx(scale, rel=2e-3)


def test_a_gyro_axis_the_file_has_no_scale_for_keeps_its_resolution(tmp_path, caplog):
    # rest and one turn about z: x and y were never turned, their scale in the file is the "none" of 1
    path = tmp_path / "partial.json"
    Calibration(gyro_null=[2050.0, 2040.0, 2049.0], gyro_scale=[1.0, 1.0, 570.0]).save(path)
    rt = patch(f"node units scaling gyro=0.1 calibration={path}\nnode g collect\nunits.gyro -> g\n")
    rt.nodes["units"].receive(0, vector([10.0, -10.0, 570.0] + [0.0] * 6))
    assert list(rt.nodes["g"].values[0]) == pytest.approx([math.radians(1.0), -math.radians(1.0), 1.0])
    assert "has no scale for gyro x, gyro y: the nominal resolution is used" in caplog.text


def test_a_turn_before_rest_is_refused(tmp_path):
    rt = patch(f"node cal calibrate file={tmp_path / 'c.json'} samples=20\nnode st collect\ncal -> st\n")
    cal = rt.nodes["cal"]
    with pytest.raises(
        ValueError, match="turn_begin: the gyro nulls of this run are not known yet.*send rest first"
    ):
        cal.receive(0, method("turn_begin"))  # said before the user turns, not after
    cal._start("turn")  # and had it started anyway (a null loaded as 0): turn_end refuses it too
    for k in range(50):
        cal.receive(0, vector([2048.0, 2048.0, 2600.0] + [2048.0] * 6, k * 0.01))
    with pytest.raises(ValueError, match="turn_end: the gyro nulls of this run are not known yet"):
        cal.receive(0, method("turn_end", 90, 2))
    assert cal.calibration.gyro_scale[2] == 1.0  # nothing stored: not a scale against a null of 0


def test_a_turn_needs_the_nulls_of_this_run_not_those_loaded_from_the_file(tmp_path):
    # the file's nulls are a day old: the bias drifted 10 counts (1 deg/s), and a turn integrated from
    # them stored a scale 9 % off, inside the 2x check, without a word
    path = tmp_path / "c.json"
    Calibration(gyro_null=[2048.0, 2048.0, 2048.0]).save(path)
    rt = patch(f"node cal calibrate file={path} samples=20\nnode st collect\ncal -> st\n")
    rt.start()
    cal = rt.nodes["cal"]
    assert rt.nodes["st"].values[0] == ("loaded", str(path))
    with pytest.raises(ValueError, match="turn_begin: the gyro nulls of this run are not known yet"):
        cal.receive(0, method("turn_begin"))
    cal.receive(0, method("rest"))
    for k in range(20):
        cal.receive(0, vector([2058.0, 2058.0, 2058.0] + [2048.0] * 6, k * 0.01))
    cal.receive(0, method("turn_begin"))  # now it is taken
    assert rt.nodes["st"].values[-1] == ("collecting", "turn")
    cal.receive(0, method("clear"))  # and after clear, the nulls are gone again
    with pytest.raises(ValueError, match="send rest first"):
        cal.receive(0, method("turn_begin"))
    rt.shutdown()


def test_a_turn_the_other_way_is_refused_not_stored_as_a_negative_scale(tmp_path):
    rt = patch(f"node cal calibrate file={tmp_path / 'c.json'} samples=20\nnode st collect\ncal -> st\n")
    cal = rt.nodes["cal"]
    cal.receive(0, method("rest"))
    for k in range(20):
        cal.receive(0, vector([2048.0] * 9, k * 0.01))
    cal.receive(0, method("turn_begin"))
    for k in range(100):  # clockwise about z: the rate is negative (90 deg in 1 s at 573 counts per rad/s)
        cal.receive(0, vector([2048.0, 2048.0, 2048.0 - 900.0] + [2048.0] * 6, 1.0 + k * 0.01))
    with pytest.raises(ValueError, match="turned the other way.*send turn_end -90 2"):
        cal.receive(0, method("turn_end", 90, 2))
    assert cal.calibration.gyro_scale[2] == 1.0


@pytest.mark.parametrize(
    "said, refusal",
    [
        ((30, 0), "turned mostly about z .* not about the axis given.*send turn_end 30 2"),
        ((90, 2), r"3\.0 times off the gyro's nominal 573.*the angle given \(90 deg\) is not the one turned"),
        ((90, 1), "turned mostly about z"),
    ],
)
def test_a_turn_end_that_does_not_match_the_turn_is_refused(tmp_path, said, refusal):
    # the glove turned 30 deg about z (at the nominal 573 counts per rad/s); what the user said does not match
    rt = patch(f"node cal calibrate file={tmp_path / 'c.json'} samples=20\nnode st collect\ncal -> st\n")
    cal = rt.nodes["cal"]
    cal.receive(0, method("rest"))
    for k in range(20):
        cal.receive(0, vector([2048.0] * 9, k * 0.01))
    cal.receive(0, method("turn_begin"))
    for k in range(100):
        cal.receive(
            0, vector([2048.0, 2048.0, 2048.0 + 573.0 * math.radians(30.0)] + [2048.0] * 6, 1.0 + k * 0.01)
        )
    with pytest.raises(ValueError, match=refusal):
        cal.receive(0, method("turn_end", *said))
    assert list(cal.calibration.gyro_scale) == [1.0, 1.0, 1.0]  # nothing stored
    for bad in ((90, 3), (90, "z"), (0, 2)):  # said wrongly: the turn is kept all the same
        with pytest.raises(ValueError, match="turn_end takes ANGLE_DEG .* and AXIS .*; the turn is kept"):
            cal.receive(0, method("turn_end", *bad))
    cal.receive(0, method("turn_end", 30, 2))  # what the refusal said to send: taken from the same turn
    assert cal.calibration.gyro_scale[2] == pytest.approx(573.0, rel=0.02)
    with pytest.raises(ValueError, match="turn_end without turn_begin"):  # and only once
        cal.receive(0, method("turn_end", 30, 2))


def test_a_pose_taken_twice_is_dropped_and_the_missing_one_can_still_be_given(tmp_path, caplog):
    # x up was sent twice and z down never: the sixth pose failed as "dropped vector", and the next
    # pose threw away all six
    rt = patch(f"node cal calibrate file={tmp_path / 'c.json'} samples=20\nnode st collect\ncal -> st\n")
    cal = rt.nodes["cal"]
    up = {"x+": (2560, 2048, 2048), "x-": (1536, 2048, 2048), "y+": (2048, 2560, 2048)}
    up |= {"y-": (2048, 1536, 2048), "z+": (2048, 2048, 2560), "z-": (2048, 2048, 1536)}

    def pose(name):
        cal.receive(0, method("pose"))
        for k in range(20):
            cal.receive(0, vector([2048.0] * 3 + list(map(float, up[name])) + [2048.0] * 3, k * 0.01))

    for name in ("x+", "x-", "x+", "y+", "y-", "z+"):
        pose(name)
    assert rt.nodes["st"].values[-1] == ("poses_refused", 5, 6)
    assert "pose 3 dropped; 5 kept: point the axis direction still missing" in caplog.text
    assert "dropped vector" not in caplog.text
    pose("z-")  # the one missing: the six are complete
    assert rt.nodes["st"].values[-1][0] == "accel"
    assert list(cal.calibration.acc_null) == [2048.0] * 3


def test_a_pose_during_which_the_glove_moved_is_refused(tmp_path, caplog):
    rt = patch(f"node cal calibrate file={tmp_path / 'c.json'} samples=20\nnode st collect\ncal -> st\n")
    cal = rt.nodes["cal"]
    cal.receive(0, method("pose"))
    for k in range(20):
        cal.receive(0, vector([2048.0, 2048.0 + 200.0 * math.sin(k)] + [2048.0] * 7, k * 0.01))
    assert "pose: the glove moved (gyro y varied by" in caplog.text
    assert "pose not taken; hold it still and send pose again" in caplog.text
    assert rt.nodes["st"].values[-1][:2] == ("moved", "y") and cal.poses == []


def test_a_rest_during_which_the_glove_moved_is_refused(tmp_path, caplog):
    rt = patch(f"node cal calibrate file={tmp_path / 'c.json'} samples=20\nnode st collect\ncal -> st\n")
    cal = rt.nodes["cal"]
    cal.receive(0, method("rest"))
    for k in range(20):  # z turning: 2048 .. 2238 counts
        cal.receive(0, vector([2048.0, 2048.0, 2048.0 + 10 * k] + [2048.0] * 6, k * 0.01))
    refusals = [r for r in caplog.records if "the glove moved" in r.getMessage()]
    assert [r.levelname for r in refusals] == ["WARNING"]  # a refusal, not an error about a dropped sample
    assert re.search(r"rest: the glove moved \(gyro z varied by .* than still=10\)", refusals[0].getMessage())
    assert rt.nodes["st"].values[-1][:2] == ("moved", "z")
    assert not np.any(cal.calibration.gyro_null)  # nothing taken


def test_redoing_one_step_and_saving_keeps_the_rest_of_the_calibration(tmp_path, caplog):
    # the next day the gyro nulls are taken again: save wiped the accelerometer and magnetometer
    path = tmp_path / "c.json"
    full = Calibration()
    full.acc_null, full.acc_scale = np.full(3, 2050.0), np.full(3, 52.0)
    full.mag_null, full.mag_scale = np.full(3, 2040.0), np.full(3, 400.0)
    full.save(path)
    rt = patch(f"node cal calibrate file={path} samples=20\nnode st collect\ncal -> st\n")
    rt.start()
    cal = rt.nodes["cal"]
    assert rt.nodes["st"].values[0] == ("loaded", str(path))
    cal.receive(0, method("rest"))
    for k in range(20):
        cal.receive(0, vector([2001.0, 2002.0, 2003.0] + [2048.0] * 6, k * 0.01))
    cal.receive(0, method("save"))
    saved = Calibration.load(path)
    assert list(saved.gyro_null) == [2001.0, 2002.0, 2003.0]
    assert list(saved.acc_scale) == [52.0] * 3 and list(saved.mag_null) == [2040.0] * 3  # kept
    assert not list(tmp_path.glob("*.part")) and not list(tmp_path.glob(".*.tmp"))
    cal.receive(0, method("clear"))  # from nothing, on request
    cal.receive(0, method("save"))
    assert list(Calibration.load(path).acc_scale) == [1.0] * 3
    rt.shutdown()
    # a file that does not read (a hand edit gone wrong): the patch starts all the same, and save does not
    # throw away what the file holds (it replaced it with what this run took) until clear is sent
    edited = path.read_text().replace('"acc": {', '"acc": {,')
    path.write_text(edited)
    rt = patch(f"node cal calibrate file={path}\n")
    rt.start()
    assert f"calibration file {path}" in caplog.text and "starting from no calibration" in caplog.text
    cal = rt.nodes["cal"]
    with pytest.raises(ValueError, match="did not read at the start.*send clear to replace it"):
        cal.receive(0, method("save"))
    assert path.read_text() == edited
    cal.receive(0, method("save", str(tmp_path / "other.json")))  # elsewhere: fine
    cal.receive(0, method("clear"))
    cal.receive(0, method("save"))
    assert Calibration.load(path).acc_scale.tolist() == [1.0] * 3
    rt.shutdown()


# --- cross-axis misalignment ------------------------------------------------------------------------


def test_scaling_applies_the_files_misalignments_after_the_scales(tmp_path):
    M_acc = np.array([[1.0, 0.010, -0.008], [0.012, 1.0, 0.009], [-0.011, 0.007, 1.0]])
    M_gyro = np.array([[1.0, -0.009, 0.011], [0.008, 1.0, -0.012], [0.010, -0.007, 1.0]])
    plain = Calibration(
        gyro_null=[2050.0, 2045.0, 2047.0],
        gyro_scale=[573.0, 560.0, 580.0],
        acc_null=[2040.0, 2060.0, 2050.0],
        acc_scale=[52.0, 49.0, 51.0],
        mag_null=[2048.0] * 3,
        mag_scale=[1000.0] * 3,
    )
    both = Calibration(**vars(plain) | {"acc_misalignment": M_acc, "gyro_misalignment": M_gyro})
    plain.save(tmp_path / "plain.json")
    both.save(tmp_path / "both.json")
    counts = np.array([120.0, -340.0, 55.0, 30.0, -80.0, 490.0, 400.0, 0.0, -900.0])  # from offset: nulled
    out = {}
    for name in ("plain", "both"):
        rt = patch(
            f"node units scaling calibration={tmp_path / name}.json\n"
            "node g collect\nnode a collect\nnode m collect\nunits.gyro -> g\nunits.accel -> a\nunits.mag -> m\n"
        )
        rt.nodes["units"].receive(0, vector(counts, 1.5))
        out[name] = [rt.nodes[n].values[0] for n in "gam"] + [rt.nodes["units"].full_scale]
    g, a, m, full = out["plain"]  # the identity: not applied, each axis as it was, to the bit
    assert list(g) == [counts[i] * (1.0 / plain.gyro_scale[i]) for i in range(3)]
    assert list(a) == [counts[3 + i] * (1.0 / plain.acc_scale[i]) for i in range(3)]
    g, a, m2, full2 = out["both"]
    assert list(g) == pytest.approx(M_gyro @ (counts[:3] / plain.gyro_scale), rel=1e-14)
    assert list(a) == pytest.approx(M_acc @ (counts[3:6] / plain.acc_scale), rel=1e-14)
    assert m2 == m  # the magnetometer keeps its own (soft iron)
    # the rails are said early rather than late: cut by the largest row of cross-axis terms
    assert full2 == pytest.approx((full[0] * (1 - 0.021), full[1] * (1 - 0.020)), rel=1e-12)


def _misaligned_glove(seed):
    from tests.maths.test_calibration_misalignment import misaligned

    return misaligned(seed), np.random.default_rng([seed, 5])


def _feed(cal, sensor, rng, clock, q, omega=(0.0, 0.0, 0.0), n=1):
    for _ in range(n):
        cal.receive(0, vector(np.array(sensor.counts(q, omega, rng), dtype=float), clock[0]))
        clock[0] += 0.01


def _angles(got, want):
    """Degrees between the rows of ``got`` and ``want``."""
    got, want = np.array(got), np.array(want)
    cos = np.sum(got * want, axis=1) / np.linalg.norm(got, axis=1) / np.linalg.norm(want, axis=1)
    return np.degrees(np.arccos(np.minimum(cos, 1.0)))


def test_calibrate_takes_both_misalignments_from_its_poses_and_turns_and_the_chain_uses_them(tmp_path):
    from tests.maths.test_calibration_misalignment import OFF, UP, expected, q_up

    sensor, rng = _misaligned_glove(0)  # sensor axes 0.5-0.7 deg off, the glove's noise
    path = tmp_path / "glove.json"
    rt = patch(f"node cal calibrate file={path} samples=200\nnode st collect\ncal -> st\n")
    cal, status, clock = rt.nodes["cal"], rt.nodes["st"], [0.0]
    level = np.array([1.0, 0.0, 0.0, 0.0])
    cal.receive(0, method("rest"))
    _feed(cal, sensor, rng, clock, level, n=200)
    for k in (4, 1, 2, 5, 0, 3):  # the six poses in any order
        cal.receive(0, method("pose"))
        _feed(cal, sensor, rng, clock, q_up(UP[k]), n=200)
    assert [v[0] for v in status.values[-2:]] == ["acc_misalignment", "accel"]
    assert np.degrees(np.abs(status.values[-2][1:])) == pytest.approx([0.6] * 6, abs=0.15)
    for axis in range(3):  # 90 deg about each axis in 1.5 s, from rest to rest
        cal.receive(0, method("turn_begin"))
        _feed(cal, sensor, rng, clock, level, n=20)
        for j in range(150):
            rate = math.radians(90.0) / 1.5 * (1 - math.cos(2 * math.pi * (j + 0.5) / 150))
            _feed(cal, sensor, rng, clock, level, rate * np.eye(3)[axis])
        _feed(cal, sensor, rng, clock, level, n=20)
        cal.receive(0, method("turn_end", 90, axis))
    assert [v[0] for v in status.values[-2:]] == ["gyro_misalignment", "gyro_scale"]
    assert status.values[-1][2] == cal.calibration.gyro_scale[2]  # the scale stored, the full model's
    cal.receive(0, method("save"))
    saved = Calibration.load(path)
    acc_error = np.degrees(np.abs(saved.acc_misalignment - expected(sensor.acc_misalignment))[OFF])
    gyro_error = np.degrees(np.abs(saved.gyro_misalignment - expected(sensor.gyro_misalignment))[OFF])
    assert acc_error.max() < 0.05 and gyro_error.max() < 0.12, (acc_error, gyro_error)
    # offset and scaling read the file: gravity's and a turn's directions, against the same file without
    # the misalignments (Eqs. 29-31 alone)
    plain = tmp_path / "plain.json"
    Calibration(**vars(saved) | {"acc_misalignment": None, "gyro_misalignment": None}).save(plain)
    errors = {}
    for name, file in (("full", path), ("plain", plain)):
        chain = patch(f"""
node nulls offset samples=0 calibration={file}
node units scaling calibration={file}
node acc collect
node gyro collect
nulls -> units
units.accel -> acc
units.gyro -> gyro
""")
        orientations = np.random.default_rng(6).normal(size=(60, 4))
        orientations /= np.linalg.norm(orientations, axis=1, keepdims=True)
        rates = np.random.default_rng(7).normal(size=(60, 3))
        rates *= 2.0 / np.linalg.norm(rates, axis=1, keepdims=True)  # 2 rad/s (115 deg/s), every way
        for q, w in zip(orientations, rates, strict=True):  # held, turning steadily
            counts = np.mean([sensor.counts(q, w, rng) for _ in range(100)], axis=0)
            chain.nodes["nulls"].receive(0, vector(counts))
        gravity = [sensor.true_values(q, [0.0] * 3)[3:6] for q in orientations]
        errors[name] = (
            _angles(chain.nodes["acc"].values, gravity),
            _angles(chain.nodes["gyro"].values, rates),
        )
    (acc, gyro), (acc0, gyro0) = errors["full"], errors["plain"]
    assert acc.max() < 0.1 and math.sqrt(np.mean(acc0**2)) > 0.4, (acc.max(), acc0)  # 0.04 worst, 0.6 rms
    assert gyro.max() < 0.15 and math.sqrt(np.mean(gyro0**2)) > 0.4, (gyro.max(), gyro0)  # 0.08, 0.8 rms


def test_poses_held_by_hand_give_nulls_and_scales_but_not_the_misalignment(tmp_path, caplog):
    from tests.maths.test_calibration_misalignment import UP, q_up, tilted

    sensor, rng = _misaligned_glove(1)
    path = tmp_path / "glove.json"
    kept = np.eye(3)
    kept[0, 1] = 0.01  # the misalignment the file had (from a jig, last week): kept
    Calibration(acc_misalignment=kept).save(path)
    rt = patch(f"node cal calibrate file={path} samples=50\nnode st collect\ncal -> st\n")
    rt.start()
    cal, clock = rt.nodes["cal"], [0.0]
    for d in UP:
        cal.receive(0, method("pose"))
        _feed(cal, sensor, rng, clock, q_up(tilted(d, 1.0, rng)), n=50)  # a degree off, each
    assert [v[0] for v in rt.nodes["st"].values[-2:]] == ["acc_misalignment_refused", "accel"]
    assert re.search(r"the six poses disagree by 0\.\d\d deg rms \(more than 0\.2\)", caplog.text), (
        caplog.text
    )
    assert (
        "the accelerometer's misalignment is not taken (the one the calibration had is kept)" in caplog.text
    )
    null, scale = six_position_accel(cal.poses, 9.80665)  # Eqs. 29-30
    assert list(cal.calibration.acc_null) == list(null) and list(cal.calibration.acc_scale) == list(scale)
    assert np.array_equal(cal.calibration.acc_misalignment, kept)
    rt.shutdown()


def test_three_turns_that_were_not_about_the_board_axes_give_no_gyro_misalignment(tmp_path, caplog):
    rt = patch(f"node cal calibrate file={tmp_path / 'c.json'} samples=20\nnode st collect\ncal -> st\n")
    cal = rt.nodes["cal"]
    cal.receive(0, method("rest"))
    for k in range(20):
        cal.receive(0, vector([2048.0] * 9, k * 0.01))
    for axis in range(3):  # 90 deg about each axis; the one about z seen 10 % on x: tipped 6 deg
        rate = np.eye(3)[axis] * 573.0 * math.radians(90.0)
        if axis == 2:
            rate[0] = 0.1 * rate[2]
        cal.receive(0, method("turn_begin"))
        for k in range(100):
            cal.receive(0, vector([*(2048.0 + rate), *[2048.0] * 6], 1.0 + axis + k * 0.01))
        cal.receive(0, method("turn_end", 90, axis))
    assert [v[0] for v in rt.nodes["st"].values[-2:]] == ["gyro_misalignment_refused", "gyro_scale"]
    assert "a cross-axis term of 5.7 deg, more than 5: the turns were not about the board axes" in caplog.text
    assert np.array_equal(cal.calibration.gyro_misalignment, np.eye(3))
    assert cal.calibration.gyro_scale == pytest.approx([573.0] * 3)  # each turn's own (Eq. 31)
