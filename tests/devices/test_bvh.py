"""The BVH writer, checked by reading its files back with an independent parser (``bvh`` from PyPI).

A 4-joint arm (shoulder root, upper arm, forearm, hand with an End Site) moves through a few hundred
frames of known motion, defined as local rotations and composed into the earth-frame orientations that
pointat's filters would give; the writer gets those through :func:`local_rotations`.  Read back, the
hierarchy, the channels, the frame count and time, every joint's rotation (rebuilt here from the parsed
angles as ``Rz Rx Ry``) and the root's position must be what was given, converted to BVH axes, and the
hand's end site must land where forward kinematics in NWU puts it.  The quaternion -> ZXY Euler
conversion is tested on its own against a matrix composition, at and near gimbal lock.
"""

from __future__ import annotations

import importlib.util
import io
import math
import re

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from pointat.devices.bvh import (
    FRAME_COUNT_WIDTH,
    BvhJoint,
    BvhWriter,
    euler_zxy,
    local_rotations,
)
from pointat.maths.quaternion import (
    euler_to_quat,
    matrix_to_quat,
    quat_angle,
    quat_from_axis_angle,
    quat_multiply,
    quat_to_matrix,
)

# NWU -> BVH: X = y (left), Y = z (up), Z = x (front), as a matrix: v_bvh = P @ v_nwu
P = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
ROT = ["Zrotation", "Xrotation", "Yrotation"]
POS = ["Xposition", "Yposition", "Zposition"]


def rx(deg):
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def ry(deg):
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rz(deg):
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def zxy_matrix(z, x, y):
    """The rotation of BVH channels ``Zrotation Xrotation Yrotation``: intrinsic Z, X', Y''."""
    return rz(z) @ rx(x) @ ry(y)


def to_bvh(q_nwu):
    """A rotation of NWU vectors as a matrix on BVH axes, by conjugation with P (not the index shuffle)."""
    return P @ quat_to_matrix(q_nwu) @ P.T


def axis_quat(axis, deg):
    return quat_from_axis_angle(axis, np.radians(deg))


@pytest.fixture
def Bvh(require_tool):
    require_tool(
        importlib.util.find_spec("bvh") is not None,
        "the independent BVH parser `bvh` (PyPI) is not installed",
    )
    return pytest.importorskip("bvh").Bvh


# ----------------------------------------------------------------------------------------------------------
# The arm: known motion, defined joint by joint relative to the parent


ARM = [
    BvhJoint("shoulder", None, (0.0, 0.0, 0.0)),
    BvhJoint("upper_arm", 0, (0.0, -0.18, 0.02)),  # 18 cm to the right, 2 cm up
    BvhJoint("forearm", 1, (0.30, 0.01, -0.02)),  # the arm points forward at rest
    BvhJoint("hand", 2, (0.26, 0.0, 0.0), end=(0.19, -0.01, 0.005)),
]
PARENTS = [j.parent for j in ARM]
N = 300
RATE = 100.0
# frames where the upper arm's middle (X) angle is exactly at gimbal lock
LOCK_UP, LOCK_DOWN = (50, 120, 250), (30, 200)


def arm_motion():
    """(root positions, local NWU quaternions (N, 4, 4), the upper arm's intended BVH angles (N, 3))."""
    t = np.arange(N) / RATE
    pos = np.stack(
        [0.1 * np.sin(2 * np.pi * 0.4 * t), 0.05 * np.cos(2 * np.pi * 0.3 * t), 1.4 + 0.02 * np.sin(5 * t)],
        axis=-1,
    )
    local = np.empty((N, 4, 4))
    # shoulder: the torso turns, leans and rolls a little (NWU yaw / pitch / roll)
    local[:, 0] = euler_to_quat(
        40 * np.sin(2 * np.pi * 0.5 * t), 10 * np.sin(2 * np.pi * 0.3 * t), 5 * np.cos(7 * t), degrees=True
    )
    # upper arm: built in BVH's own order: about front (BVH Z), then left (X), then up (Y); X sweeps through
    # +-90 deg and beyond, with some frames exactly at +-90
    z = 70 * np.sin(2 * np.pi * 0.7 * t)
    x = np.linspace(-130.0, 130.0, N)
    x[list(LOCK_UP)] = 90.0
    x[list(LOCK_DOWN)] = -90.0
    y = 175 * np.sin(2 * np.pi * 0.2 * t + 0.3)
    for k in range(N):
        local[k, 1] = quat_multiply(
            quat_multiply(axis_quat([1, 0, 0], z[k]), axis_quat([0, 1, 0], x[k])), axis_quat([0, 0, 1], y[k])
        )
    # forearm: the elbow bends (about up at rest pointing forward) and twists
    local[:, 2] = euler_to_quat(120 * np.sin(np.pi * t / t[-1]) ** 2, 0.0, 30 * np.sin(3 * t), degrees=True)
    # hand: the wrist, with roll through +-180
    local[:, 3] = euler_to_quat(
        20 * np.cos(4 * t), -35 * np.sin(2 * t), 179.0 * np.sin(1.5 * t) + 5, degrees=True
    )
    return pos, local, np.stack([z, x, y], axis=-1)


def earth_from_local(local):
    earth = np.empty_like(local)
    for i, p in enumerate(PARENTS):
        earth[:, i] = local[:, i] if p is None else quat_multiply(earth[:, p], local[:, i])
    return earth


def write_arm(target, units):
    pos, local, _ = arm_motion()
    earth = earth_from_local(local)
    with BvhWriter(target, ARM, RATE, units=units) as take:
        for k in range(N):
            take.frame(pos[k], local_rotations(earth[k], PARENTS))
    assert take.frames == N
    return take


@pytest.fixture(params=[("cm", "path"), ("m", "stream")], ids=["cm-path", "m-stream"])
def arm_take(request, tmp_path):
    """(text of the written take, scale of its unit)."""
    units, target = request.param
    if target == "path":
        path = tmp_path / "arm.bvh"
        write_arm(path, units)
        text = path.read_text(encoding="ascii")
    else:
        out = io.StringIO()
        write_arm(out, units)
        assert not out.closed  # the caller's stream stays open
        text = out.getvalue()
    return text, {"cm": 100.0, "m": 1.0}[units]


def test_local_rotations_undo_the_composition():
    _, local, _ = arm_motion()
    earth = earth_from_local(local)
    for k in range(0, N, 7):
        got = np.array(local_rotations(earth[k], PARENTS))
        assert np.max(quat_angle(got, local[k])) < 1e-12


def test_hierarchy_read_back(Bvh, arm_take):
    text, scale = arm_take
    parsed = Bvh(text)
    names = [j.name for j in ARM]
    assert parsed.get_joints_names() == names
    assert [parsed.joint_parent_index(n) for n in names] == [-1, 0, 1, 2]
    for j in ARM:
        np.testing.assert_allclose(
            parsed.joint_offset(j.name), P @ np.array(j.offset) * scale, rtol=0, atol=1e-9
        )
    end = next(parsed.get_joint("hand").filter("End"))
    np.testing.assert_allclose(
        [float(v) for v in end["OFFSET"]], P @ np.array(ARM[3].end) * scale, rtol=0, atol=1e-9
    )
    assert parsed.joint_channels("shoulder") == POS + ROT
    assert parsed.get_joint("shoulder")["CHANNELS"][0] == "6"
    for name in names[1:]:
        assert parsed.joint_channels(name) == ROT
        assert parsed.get_joint(name)["CHANNELS"][0] == "3"
    assert parsed.nframes == N == len(parsed.frames)
    assert parsed.frame_time == 1.0 / RATE
    assert all(len(f) == 6 + 3 * (len(ARM) - 1) for f in parsed.frames)


def test_motion_read_back(Bvh, arm_take):
    text, scale = arm_take
    parsed = Bvh(text)
    pos, local, upper_angles = arm_motion()
    earth = earth_from_local(local)

    got_pos = np.array(parsed.frames_joint_channels("shoulder", POS))
    np.testing.assert_allclose(got_pos, pos @ P.T * scale, rtol=0, atol=1e-9)

    worst_deg = 0.0
    rebuilt = {}
    for i, j in enumerate(ARM):
        angles = np.array(parsed.frames_joint_channels(j.name, ROT))
        assert np.all(np.abs(angles[:, 1]) <= 90.0) and np.all(np.abs(angles[:, [0, 2]]) <= 180.0)
        mats = np.array([zxy_matrix(*a) for a in angles])
        want = to_bvh(local[:, i])
        np.testing.assert_allclose(mats, want, rtol=0, atol=1e-8)
        worst_deg = max(
            worst_deg, float(np.degrees(np.max(quat_angle(matrix_to_quat(mats), matrix_to_quat(want)))))
        )
        rebuilt[j.name] = mats
    assert worst_deg < 1e-6

    # where the upper arm's X angle is strictly inside (-90, 90), the angles are the very ones it was built from
    upper = np.array(parsed.frames_joint_channels("upper_arm", ROT))
    inside = np.abs(upper_angles[:, 1]) < 89.0
    assert inside.sum() > 100
    diff = (upper[inside] - upper_angles[inside] + 180.0) % 360.0 - 180.0
    assert np.max(np.abs(diff)) < 1e-6
    # at gimbal lock the middle angle is exactly +-90 and Y carries nothing
    for k in LOCK_UP + LOCK_DOWN:
        assert abs(abs(upper[k, 1]) - 90.0) < 1e-6 and upper[k, 2] == 0.0

    # forward kinematics on the parsed file (BVH axes) puts the hand's end site where NWU puts it
    offsets = [np.array(parsed.joint_offset(j.name)) for j in ARM]
    end_offset = np.array([float(v) for v in next(parsed.get_joint("hand").filter("End"))["OFFSET"]])
    for k in range(0, N, 3):
        world = np.eye(3)
        p = got_pos[k].copy()
        p_nwu = pos[k].copy()
        for i, j in enumerate(ARM):
            if i:
                p = p + world @ offsets[i]
                p_nwu = p_nwu + quat_to_matrix(earth[k, i - 1]) @ np.array(j.offset)
            world = world @ rebuilt[j.name][k]
        p = p + world @ end_offset
        p_nwu = p_nwu + quat_to_matrix(earth[k, 3]) @ np.array(ARM[3].end)
        np.testing.assert_allclose(p, P @ p_nwu * scale, rtol=0, atol=1e-7 * scale)


def test_file_layout_suits_simple_readers(arm_take):
    text, _ = arm_take
    lines = text.split("\n")
    assert text.endswith("\n")  # `bvh` drops a last line without one
    assert all(line.strip() in ("{", "}") for line in lines if "{" in line or "}" in line)
    # plain decimals only (no exponent, no nan / inf), as many values per line as there are channels
    motion = lines[lines.index("MOTION") + 3 : -1]
    assert len(motion) == N
    assert all(len(line.split()) == 3 + 3 * len(ARM) for line in motion)
    assert all(re.fullmatch(r"-?\d+\.\d+", v) for line in motion for v in line.split())
    assert lines[0] == "HIERARCHY" and lines[1] == "ROOT shoulder"


# ----------------------------------------------------------------------------------------------------------
# Axes, units and digits, read without the parser


def last_frame(text):
    return [float(v) for v in text.rstrip("\n").split("\n")[-1].split()]


def one_frame(rotation_nwu, position=(0.0, 0.0, 0.0), units="cm"):
    out = io.StringIO()
    with BvhWriter(out, [BvhJoint("root", None, (0, 0, 0))], 50.0, units=units) as take:
        take.frame(position, [rotation_nwu])
    return last_frame(out.getvalue())


def test_axis_mapping_is_a_right_handed_y_up_frame():
    assert np.linalg.det(P) == pytest.approx(1.0)
    front, left, up = np.eye(3)
    assert np.allclose(np.cross(P @ left, P @ up), P @ front)  # X x Y = Z: right-handed, facing +Z
    assert (P @ up).tolist() == [0.0, 1.0, 0.0]


@pytest.mark.parametrize(
    ("axis", "expected"),
    [([1, 0, 0], [30.0, 0.0, 0.0]), ([0, 1, 0], [0.0, 30.0, 0.0]), ([0, 0, 1], [0.0, 0.0, 30.0])],
    ids=["roll-about-front-is-Z", "pitch-about-left-is-X", "yaw-about-up-is-Y"],
)
def test_nwu_rotations_land_on_bvh_axes(axis, expected):
    values = one_frame(axis_quat(axis, 30.0))
    assert values[3:] == pytest.approx(expected, abs=1e-9)


@pytest.mark.parametrize(("units", "scale"), [("cm", 100.0), ("m", 1.0)])
def test_positions_are_converted_and_scaled(units, scale):
    assert one_frame((1, 0, 0, 0), (1.0, 2.0, 3.0), units)[:3] == [2.0 * scale, 3.0 * scale, 1.0 * scale]


@pytest.mark.parametrize("rate", [100.0, 120.0, 60.0, 1000.0, 29.97, 7.0])
def test_frame_time_reads_back_exactly(rate):
    out = io.StringIO()
    BvhWriter(out, [BvhJoint("root", None, (0, 0, 0))], rate).close()
    line = [ln for ln in out.getvalue().split("\n") if ln.startswith("Frame Time:")][0]
    assert float(line.split()[-1]) == 1.0 / rate
    assert "e" not in line.split()[-1]


def test_small_drift_is_normalised():
    q = axis_quat([0.3, -0.5, 0.8], 70.0)
    assert one_frame(q * (1.0 + 5e-4)) == one_frame(q)


# ----------------------------------------------------------------------------------------------------------
# Files, streams, order, closing


def test_path_gets_the_count_patched_in_place(tmp_path):
    path = tmp_path / "take.bvh"
    take = BvhWriter(path, ARM, RATE)
    for _ in range(3):
        take.frame((0, 0, 1), [(1, 0, 0, 0)] * 4)
    take.close()
    take.close()  # idempotent
    text = path.read_text()
    assert f"Frames: {3:<{FRAME_COUNT_WIDTH}d}\n" in text
    assert len(text.rstrip("\n").split("\n")) == text[: text.index("MOTION")].count("\n") + 3 + 3
    with pytest.raises(ValueError, match="closed"):
        take.frame((0, 0, 1), [(1, 0, 0, 0)] * 4)


def test_an_exception_inside_with_still_closes_the_take(tmp_path):
    path = tmp_path / "take.bvh"
    with pytest.raises(RuntimeError), BvhWriter(path, ARM, RATE) as take:
        take.frame((0, 0, 1), [(1, 0, 0, 0)] * 4)
        raise RuntimeError("the glove fell off")
    assert "Frames: 1 " in path.read_text()


def test_file_order_is_depth_first_and_frame_takes_list_order(Bvh):
    joints = [
        BvhJoint("hips", None, (0, 0, 0)),
        BvhJoint("left_leg", 0, (0, 0.1, -0.1)),
        BvhJoint("spine", 0, (0, 0, 0.1)),
        BvhJoint("left_foot", 1, (0, 0, -0.8)),
    ]
    rots = [(1, 0, 0, 0), axis_quat([0, 1, 0], 10.0), axis_quat([0, 0, 1], 20.0), axis_quat([1, 0, 0], 30.0)]
    out = io.StringIO()
    with BvhWriter(out, joints, RATE) as take:
        take.frame((0, 0, 0), rots)
    assert take.file_order == (0, 1, 3, 2)
    parsed = Bvh(out.getvalue())
    assert parsed.get_joints_names() == ["hips", "left_leg", "left_foot", "spine"]
    assert parsed.frame_joint_channels(0, "left_leg", ROT) == pytest.approx([0, 10, 0], abs=1e-9)
    assert parsed.frame_joint_channels(0, "spine", ROT) == pytest.approx([0, 0, 20], abs=1e-9)
    assert parsed.frame_joint_channels(0, "left_foot", ROT) == pytest.approx([30, 0, 0], abs=1e-9)
    # leaves without an end get an End Site at their own origin
    assert next(parsed.get_joint("spine").filter("End"))["OFFSET"] == ["0.0000000000"] * 3


@pytest.mark.parametrize(
    ("joints", "message"),
    [
        ([], "at least one"),
        ([BvhJoint("a", 0, (0, 0, 0))], "must be the root"),
        ([BvhJoint("a", None, (0, 0, 0.1))], "offset \\(0, 0, 0\\)"),
        ([BvhJoint("a", None, (0, 0, 0)), BvhJoint("a", 0, (1, 0, 0))], "twice"),
        ([BvhJoint("a", None, (0, 0, 0)), BvhJoint("b", None, (1, 0, 0))], "earlier joint"),
        (
            [BvhJoint("a", None, (0, 0, 0)), BvhJoint("b", 2, (1, 0, 0)), BvhJoint("c", 0, (0, 1, 0))],
            "earlier",
        ),
        ([BvhJoint("a", None, (0, 0, 0)), BvhJoint("b", True, (1, 0, 0))], "earlier joint"),
        ([BvhJoint("a", None, (0, 0, 0), end=(0, 0, 1)), BvhJoint("b", 0, (1, 0, 0))], "only a leaf"),
        (["not a joint"], "BvhJoint"),
    ],
)
def test_bad_skeletons_are_refused(joints, message):
    with pytest.raises(ValueError, match=message):
        BvhWriter(io.StringIO(), joints, RATE)


@pytest.mark.parametrize("name", ["left hand", "hand-1", "épaule", "", "a{", "x\n"])
def test_bad_names_are_refused(name):
    with pytest.raises(ValueError, match="joint name"):
        BvhJoint(name, None, (0, 0, 0))


@pytest.mark.parametrize(
    ("offset", "end"),
    [((0, 0, math.nan), None), ((0, 0), None), ((0, 0, 0), (math.inf, 0, 0)), ("abc", None)],
)
def test_bad_offsets_are_refused(offset, end):
    with pytest.raises(ValueError, match="offset|end site"):
        BvhJoint("j", None, offset, end=end)


@pytest.mark.parametrize(
    ("rate", "units"), [(0.0, "cm"), (-100.0, "cm"), (math.nan, "cm"), (math.inf, "cm"), (100.0, "mm")]
)
def test_bad_writer_arguments_are_refused(rate, units):
    with pytest.raises(ValueError, match="rate_hz|units"):
        BvhWriter(io.StringIO(), ARM, rate, units=units)


UNIT = (1.0, 0.0, 0.0, 0.0)


@pytest.mark.parametrize(
    ("position", "rotations", "message"),
    [
        ((0, 0, 0), [UNIT] * 3, "4 quaternions"),
        ((0, 0, 0), [UNIT] * 5, "4 quaternions"),
        ((0, 0, 0), [UNIT] * 3 + [(1, 0, 0)], "4 quaternions"),
        ((0, 0, 0), [UNIT, UNIT, (math.nan, 0, 0, 0), UNIT], "'forearm'.*non-finite"),
        ((0, 0, 0), [UNIT, (1, math.inf, 0, 0), UNIT, UNIT], "'upper_arm'.*non-finite"),
        ((0, 0, 0), [UNIT, UNIT, UNIT, (1.1, 0, 0, 0)], "'hand'.*norm 1.1"),
        ((0, 0, 0), [(0, 0, 0, 0)] + [UNIT] * 3, "'shoulder'.*norm 0"),
        ((0, 0, math.nan), [UNIT] * 4, "root_position"),
        ((0, 0), [UNIT] * 4, "root_position"),
    ],
)
def test_bad_frames_are_refused_and_nothing_is_written(position, rotations, message):
    out = io.StringIO()
    take = BvhWriter(out, ARM, RATE)
    with pytest.raises(ValueError, match=message):
        take.frame(position, rotations)
    take.close()
    assert take.frames == 0 and "Frames: 0\n" in out.getvalue()


def test_local_rotations_refuses_bad_input():
    with pytest.raises(ValueError, match="3 orientations for 2 parents"):
        local_rotations([UNIT] * 3, [None, 0])
    with pytest.raises(ValueError, match="parent of joint 1"):
        local_rotations([UNIT] * 2, [None, 1])
    with pytest.raises(ValueError, match="parent of joint 1"):
        local_rotations([UNIT] * 2, [None, 5])
    with pytest.raises(ValueError, match="orientation 1 must be a unit"):
        local_rotations([UNIT, (2.0, 0, 0, 0)], [None, 0])
    with pytest.raises(ValueError, match="orientation 0 must be finite"):
        local_rotations([(math.nan, 0, 0, 0)], [None])


# ----------------------------------------------------------------------------------------------------------
# quaternion -> ZXY Euler, against a matrix composition


def bvh_quat(z, x, y):
    """q_Z(z) ⊗ q_X(x) ⊗ q_Y(y) on BVH axes, degrees."""
    return quat_multiply(
        quat_multiply(axis_quat([0, 0, 1], z), axis_quat([1, 0, 0], x)), axis_quat([0, 1, 0], y)
    )


def assert_round_trip(q, atol=1e-12):
    z, x, y = euler_zxy(q)
    assert -180.0 <= z < 180.0 and -90.0 <= x <= 90.0 and -180.0 <= y < 180.0
    np.testing.assert_allclose(zxy_matrix(z, x, y), quat_to_matrix(q), rtol=0, atol=atol)


components = st.floats(-1.0, 1.0, allow_nan=False)


@settings(deadline=None, derandomize=True, max_examples=200)
@given(st.tuples(components, components, components, components).filter(lambda v: np.linalg.norm(v) > 1e-3))
@example((0.0, 0.390625, 0.0, 0.125))  # a half turn: z came out as 180.0, outside [-180, 180)
def test_euler_round_trip_any_rotation(v):
    q = np.array(v) / np.linalg.norm(v)
    assert_round_trip(q)
    assert_round_trip(-q)


near_lock = st.sampled_from([0.0, 1e-15, -1e-15, 1e-12, -1e-12, 1e-9, -1e-9, 1e-7, -1e-7, 1e-5, -1e-4, 1e-3])


@settings(deadline=None, derandomize=True, max_examples=200)
@given(st.floats(-180.0, 180.0), st.sampled_from([90.0, -90.0]), near_lock, st.floats(-180.0, 180.0))
def test_euler_round_trip_near_gimbal_lock(z, lock, delta, y):
    x = lock - math.copysign(delta, lock) if delta else lock  # approach from inside the range
    q = bvh_quat(z, x, y)
    assert_round_trip(q)
    assert abs(euler_zxy(q)[1] - x) < 1e-6


@settings(deadline=None, derandomize=True, max_examples=200)
@given(st.floats(-179.9, 179.9), st.floats(-89.9, 89.9), st.floats(-179.9, 179.9))
def test_euler_recovers_the_angles_inside_the_range(z, x, y):
    np.testing.assert_allclose(euler_zxy(bvh_quat(z, x, y)), [z, x, y], rtol=0, atol=1e-9)


@pytest.mark.parametrize("x", [90.0, -90.0])
def test_exact_gimbal_lock_puts_the_turn_into_z(x):
    z, got_x, y = euler_zxy(bvh_quat(10.0, x, 25.0))
    assert got_x == pytest.approx(x, abs=1e-12) and y == 0.0
    # at +90 only z + y is defined, at -90 only z - y
    assert z == pytest.approx(35.0 if x > 0 else -15.0, abs=1e-9)


def test_euler_broadcasts():
    qs = np.array([bvh_quat(10.0 * i, 5.0 * j, -3.0 * i) for i in range(5) for j in range(7)]).reshape(
        5, 7, 4
    )
    got = euler_zxy(qs)
    assert got.shape == (5, 7, 3)
    assert got[2, 3].tolist() == pytest.approx([20.0, 15.0, -6.0], abs=1e-9)
