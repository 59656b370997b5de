"""The body nodes: skeleton (offsets from the calibration pose, forward kinematics), point_ray and
osc_body, driven with known orientations."""

from __future__ import annotations

import json
import math
import socket

import pytest

from pointat.devices.osc_wire import decode_packet
from pointat.errors import PatchError
from pointat.loader import check
from pointat.maths import scalar as sq
from pointat.maths import skeleton as sk
from pointat.message import floats, method
from pointat.patchfile import parse_patch
from pointat.testing import patch, sink_port, test_registry

ARM = sk.Skeleton.load("pointat/data/arm.json")
YAW = sq.axis_angle_quat(0.0, 0.0, 1.0, math.radians(40.0))  # the performer faces 40 deg from north
MOUNT = [
    sq.axis_angle_quat(*axis, math.radians(a))
    for axis, a in (((1, 0, 0), 20.0), ((0, 1, 0), -15.0), ((0.6, 0.0, 0.8), 35.0))
]


def sensors(segments):
    """Each sensor's earth-frame orientation for segments given in the body frame: the body's heading
    applied, then the sensor's mounting (segment = sensor (x) offset, so sensor = segment (x) mount^-1)."""
    return [sq.multiply(sq.multiply(YAW, q), sq.conjugate(m)) for q, m in zip(segments, MOUNT, strict=True)]


def flat(qs):
    return floats(tuple(c for q in qs for c in q), 0.0)


def body_patch(extra=""):
    rt = patch(
        "node body skeleton front=40\nnode seg collect\nnode j collect\nnode e collect\nnode st collect\n"
        "body.segments -> seg\nbody.joints -> j\nbody.ends -> e\nbody.status -> st\n" + extra
    )
    rt.start()
    return rt


def test_the_calibration_pose_gives_each_sensor_its_offset_and_the_arm_its_joints():
    rt = body_patch()
    body = rt.nodes["body"]
    pose = [(1.0, 0.0, 0.0, 0.0)] * 3
    body.receive(0, flat(sensors(pose)))
    assert rt.nodes["st"].values == ["waiting for the pose"] and rt.nodes["seg"].values == []
    body.receive(0, method("calibrate"))
    body.receive(0, flat(sensors(pose)))
    assert rt.nodes["st"].values[-1] == "calibrated"
    # the upper arm raised 90 deg (pitch up), the elbow bent 90 deg further, the hand rolled
    up = sq.axis_angle_quat(0.0, 1.0, 0.0, -math.pi / 2)
    fore = sq.multiply(up, sq.axis_angle_quat(0.0, 1.0, 0.0, -math.pi / 2))
    hand = sq.multiply(fore, sq.axis_angle_quat(1.0, 0.0, 0.0, 0.7))
    body.receive(0, flat(sensors([up, fore, hand])))
    seg = rt.nodes["seg"].values[-1]
    for k, want in enumerate((up, fore, hand)):
        got = seg[4 * k : 4 * k + 4]
        assert abs(abs(sum(a * b for a, b in zip(got, want, strict=True))) - 1.0) < 1e-12
    joints = rt.nodes["j"].values[-1]
    shoulder, elbow, wrist = (joints[3 * k : 3 * k + 3] for k in range(3))
    assert shoulder == pytest.approx(ARM.root)
    assert elbow == pytest.approx((0.0, -0.2, 1.45 + 0.30))  # straight up from the shoulder
    assert wrist == pytest.approx((-0.25, -0.2, 1.75))  # the forearm points backwards, level
    fingertips = rt.nodes["e"].values[-1][6:9]
    assert fingertips == pytest.approx((-0.33, -0.2, 1.75))


def test_auto_takes_the_pose_by_itself_and_a_wrong_size_is_refused_at_the_node():
    rt = patch("node body skeleton auto=2\nnode st collect\nbody.status -> st\n")
    rt.start()
    body = rt.nodes["body"]
    pose = flat(sensors([(1.0, 0.0, 0.0, 0.0)] * 3))
    for t in (0.0, 1.0, 2.0):
        body.receive(0, pose._replace(time=t))
    assert rt.nodes["st"].values == ["waiting for the pose", "calibrated"]
    with pytest.raises(ValueError, match="expected 12 numbers"):
        body.receive(0, floats((1.0, 0.0, 0.0, 0.0), 3.0))


def test_pointing_with_the_arm_meets_the_loudspeaker_sphere_and_the_floor():
    rt = body_patch(
        "node ray point_ray radius=3 centre=[0, 0, 1.2]\nnode floor point_ray target=floor\n"
        "node az collect\nnode el collect\nnode d collect\nnode xyz collect\nnode fxyz collect\n"
        "body.ends -> ray.ends\nbody.joints -> ray.joints\nbody.ends -> floor.ends\nbody.joints -> floor.joints\n"
        "ray.azimuth -> az\nray.elevation -> el\nray.distance -> d\nray.xyz -> xyz\nfloor.xyz -> fxyz\n"
    )
    body = rt.nodes["body"]
    body.receive(0, method("calibrate"))
    body.receive(0, flat(sensors([(1.0, 0.0, 0.0, 0.0)] * 3)))  # straight ahead, level
    x = math.sqrt(9.0 - 0.2**2 - 0.25**2)  # on the sphere of 3 m around (0, 0, 1.2), at y -0.2, z 1.45
    assert rt.nodes["xyz"].values[-1] == pytest.approx((x, -0.2, 1.45))
    assert rt.nodes["d"].values[-1] == pytest.approx(3.0)
    assert rt.nodes["az"].values[-1] == pytest.approx(math.degrees(math.atan2(-0.2, x)))  # a little right
    assert rt.nodes["el"].values[-1] == pytest.approx(math.degrees(math.asin(0.25 / 3.0)))
    assert rt.nodes["fxyz"].values == []  # level: it never meets the floor
    down = sq.axis_angle_quat(0.0, 1.0, 0.0, math.radians(45.0))  # the whole arm 45 deg down
    body.receive(0, flat(sensors([down] * 3)))
    assert rt.nodes["fxyz"].values[-1] == pytest.approx((1.45, -0.2, 0.0))


def test_osc_body_sends_every_segment_as_one_bundle_over_real_udp():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as rx:
        rx.bind(("127.0.0.1", 0))
        rx.settimeout(5.0)
        rt = body_patch(
            f"node out osc_body port={rx.getsockname()[1]}\n"
            "body.ends -> out.ends\nbody.joints -> out.joints\nbody.segments -> out.segments\n"
        )
        body = rt.nodes["body"]
        body.receive(0, method("calibrate"))
        body.receive(0, flat(sensors([(1.0, 0.0, 0.0, 0.0)] * 3)))
        rt.drain()
        messages = dict((a, v) for a, v in decode_packet(rx.recv(65536)))
        rt.shutdown()
    assert sorted(messages) == sorted(
        f"/pointat/body/{n}/{k}" for n in ("upper_arm", "forearm", "hand") for k in ("quat", "pos", "end")
    )
    assert messages["/pointat/body/forearm/pos"] == pytest.approx([0.30, -0.2, 1.45], abs=1e-6)
    assert messages["/pointat/body/hand/end"] == pytest.approx([0.63, -0.2, 1.45], abs=1e-6)
    assert messages["/pointat/body/hand/quat"] == pytest.approx([1.0, 0.0, 0.0, 0.0], abs=1e-6)


def test_a_skeleton_file_that_cannot_be_names_the_file_and_the_segment(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text(
        json.dumps({"segments": [{"name": "a", "sensor": 1}, {"name": "b", "parent": "c", "sensor": 2}]})
    )
    text = f"node body skeleton file={bad}\nnode p print\nbody.segments -> p\n"
    with pytest.raises(
        PatchError, match=r"p.pat:1: .*bad.json: segment 'b': parent 'c' is not a segment before it"
    ):
        check(parse_patch(text, "p.pat"), test_registry(), read_files=True)
    with pytest.raises(PatchError, match=r"start and through are the same point"):
        patch("node r point_ray start=hand through=hand\n")
    with pytest.raises(
        PatchError, match=r"through: no segment 'elbow' \(segments: upper_arm, forearm, hand\)"
    ):
        patch("node r point_ray through=elbow\n")


def test_bvh_record_writes_a_take_that_an_independent_parser_reads_back(tmp_path):
    bvh = pytest.importorskip("bvh")
    take = tmp_path / "take.bvh"
    rt = body_patch(
        f"node rec bvh_record file={take}\nbody.joints -> rec.joints\nbody.segments -> rec.segments\n"
    )
    body = rt.nodes["body"]
    body.receive(0, method("calibrate"))
    for k in range(50):
        up = sq.axis_angle_quat(0.0, 1.0, 0.0, -math.radians(k))  # raise the arm, a degree a frame
        body.receive(0, flat(sensors([up, up, up]))._replace(time=k / 100))
    rt.shutdown()
    read = bvh.Bvh(take.read_text())
    assert read.nframes == 50 and len(read.frames) == 50
    assert read.get_joints_names() == ["upper_arm", "forearm", "hand"]
    assert [float(v) for v in read.joint_offset("forearm")] == pytest.approx(
        [0.0, 0.0, 30.0]
    )  # 0.3 m ahead: +Z
    # the upper arm pitched up 49 deg at the last frame: about BVH's X (the body's left)
    assert float(read.frame_joint_channel(49, "upper_arm", "Xrotation")) == pytest.approx(-49.0, abs=1e-6)
    assert float(read.frame_joint_channel(49, "forearm", "Xrotation")) == pytest.approx(0.0, abs=1e-6)
    assert [float(read.frame_joint_channel(0, "upper_arm", f"{a}position")) for a in "XYZ"] == pytest.approx(
        [-20.0, 145.0, 0.0]
    )


def arm_errors(seed=0, heading=35.0):
    """patches/arm_pointing.pat on its simulated arm (3 sensors strapped up to 3 deg off their segments,
    biases up to 1 deg/s, noise), 60 s on the manual clock: after the calibration pose, each segment's
    orientation RMS error (degrees) and the wrist's position RMS error (metres) against the truth."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "patches" / "arm_pointing.pat").read_text()
    text = (
        text.replace("osc_in port=9001", "osc_in port=0")
        .replace("port=9000", f"port={sink_port()}")
        .replace("port=9003", f"port={sink_port()}")
    )
    text = text.replace(
        "simulate_body pose=6 heading=35", f"simulate_body pose=6 heading={heading} seed={seed}"
    )
    text = text.replace("auto=5 front=35", f"auto=5 front={heading}")
    text += "node seg collect\nnode truth collect\nbody.segments -> seg\narm.truth -> truth\n"
    rt = patch(text)
    rt.start()
    rt.advance(60.0)
    rt.shutdown()
    est, truth = rt.nodes["seg"].messages, {m.time: m.value for m in rt.nodes["truth"].messages}
    assert len(est) > 5000
    errors, wrist = [], []
    for m in est:
        if m.time < 6.5:  # (the arm starts moving at 6 s)
            continue
        q_est = [tuple(m.value[4 * k : 4 * k + 4]) for k in range(3)]
        q_true = [tuple(truth[m.time][4 * k : 4 * k + 4]) for k in range(3)]
        errors.append(
            [
                2 * math.degrees(math.acos(min(1.0, abs(sum(a * b for a, b in zip(e, t, strict=True))))))
                for e, t in zip(q_est, q_true, strict=True)
            ]
        )
        wrist.append(math.dist(sk.forward(ARM, q_est)[0][2], sk.forward(ARM, q_true)[0][2]))
    rms = [math.sqrt(sum(e[k] ** 2 for e in errors) / len(errors)) for k in range(3)]
    return rms, math.sqrt(sum(w * w for w in wrist) / len(wrist))


def test_the_shipped_arm_patch_tracks_the_simulated_arm_within_a_degree_and_a_centimetre():
    """The draw the patch's settings (the fast gains in the pose, its length) were chosen on."""
    rms, wrist = arm_errors()
    assert max(rms) <= 1.0, rms
    assert wrist <= 0.01, wrist


@pytest.mark.slow
def test_the_arm_patch_holds_on_draws_it_was_not_tuned_on():
    """Eight other arms (mountings, biases, noise) facing eight other ways.  Measured when this test was
    written: hands 0.60-1.01 deg RMS (one draw of eight above 1 deg), forearms and upper arms 0.25-0.63
    deg, wrists 0.23-0.34 cm.  The claim (1 deg, 1 cm) holds on the median; no draw is far off it."""
    hands = []
    for seed, heading in [
        (1, -70.0),
        (2, 150.0),
        (3, 10.0),
        (4, -160.0),
        (5, 95.0),
        (6, -5.0),
        (7, 220.0),
        (8, 60.0),
    ]:
        rms, wrist = arm_errors(seed, heading)
        assert max(rms) <= 1.1 and wrist <= 0.01, (seed, rms, wrist)
        hands.append(rms[2])
    assert sorted(hands)[len(hands) // 2] <= 1.0, hands
