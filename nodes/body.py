"""Body posture: segments from many sensors, joints in the room, and pointing with the whole arm.

After Bachmann et al. (VRST 2001; US 7,089,148): one sensor per limb segment, each through its own
filter (``tqt_bank``), each segment's orientation its sensor's turned by an offset taken in a
calibration pose, and positions down the body's kinematic chain.  The maths is
:mod:`pointat.maths.skeleton`; these nodes are its doors into a patch.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar

from pointat import shipped
from pointat.devices.body_sim import BodySimulator
from pointat.devices.bvh import BvhJoint, BvhWriter, local_rotations
from pointat.maths import scalar as sq
from pointat.maths import skeleton as sk
from pointat.message import Message, as_floats, floats, make
from pointat.node import Inlet, Node, Outlet, Param
from pointat.nodes.sensors import PacedSource
from pointat.registry import register

__all__ = ["BvhRecord", "PointRay", "SimulateBody", "SkeletonNode"]

#: The skeleton a ``skeleton`` node uses when none is named: the right arm of pointat/data/arm.json.
ARM = "pointat:data/arm.json"


def _load(path: str) -> sk.Skeleton:
    return sk.Skeleton.load(shipped.resolve(path))


@register("skeleton")
class SkeletonNode(Node):
    """Many sensors -> the body's segments and joints (Bachmann's posture tracking).

    ``file`` describes the body (JSON: segments, each with its parent, length, the sensor on it and its
    orientation in the calibration pose; :class:`pointat.maths.skeleton.Skeleton`; the default is a
    right arm of 0.63 m, ``pointat:data/arm.json``).  The ``quats`` inlet takes every sensor's orientation
    at once, as ``tqt_bank``'s ``quats`` outlet sends them (4N numbers, sensor 1 first).

    **Calibration pose.**  Stand in the pose the file gives (the arm: straight ahead, level, palm down)
    and send ``calibrate`` (``/pointat/body/calibrate``): each sensor's offset to its segment is taken
    from that sample, and the direction the body faced becomes the front (x; y to the left, z up).  That
    direction is the mean of the sensors' headings (each off by its strap's yaw) unless ``front`` gives
    it: a wrong front does not turn the body as a whole but skews every segment that leaves its pose
    (up to twice the error), so give it when you know it (``pointat.maths.skeleton``).  With
    ``auto=S`` the pose is taken by itself S seconds after the first sample (a simulation, a performer
    who starts in the pose).  Until then nothing is sent and ``status`` says ``waiting for the pose``.

    Out, right to left, each update: ``ends`` (each segment's far end), ``joints`` (each segment's
    proximal joint: shoulder, elbow, wrist...), metres in the body frame with the root at ``root``, and
    ``segments`` (each segment's orientation in the body frame), in the file's order.
    """

    pure = True

    inlets = (
        Inlet("quats", ("vector", "list"), "every sensor's orientation, 4N numbers (tqt_bank's quats)"),
        Inlet("root", ("vector", "list"), "where the root joint is, metres (x y z)", hot=False),
    )
    outlets = (
        Outlet("segments", "vector", "each segment's orientation (w x y z), body frame, 4M numbers"),
        Outlet("joints", "vector", "each segment's proximal joint, metres, 3M numbers"),
        Outlet("ends", "vector", "each segment's far end, metres, 3M numbers"),
        Outlet("status", "symbol", "waiting for the pose, calibrated"),
    )
    params = (
        Param("file", "path", ARM, "the skeleton (JSON); pointat:data/arm.json is a right arm", reads=True),
        Param(
            "auto",
            "float",
            0.0,
            "take the calibration pose by itself this long after the first sample; 0: wait for calibrate",
            unit="s",
            minimum=0.0,
        ),
        Param(
            "front",
            "float",
            float("nan"),
            "the heading the body faces in the pose, from north (+ west); NaN: the mean of the sensors' headings",
            unit="deg",
        ),
    )
    example = """
node phones osc_in port=9002 map=["/1/gyro=gyro", "/1/acc=accel", "/1/mag=mag"]
node suit   tqt_bank sensors=3
node body   skeleton file=pointat:data/arm.json
node out    osc_body port=9000
phones.mag -> suit.mag1
phones.accel -> suit.accel1
phones.gyro -> suit.gyro1
suit.quats -> body
body.ends -> out.ends
body.joints -> out.joints
body.segments -> out.segments
"""

    @classmethod
    def check_files(cls, values: Mapping[str, Any]) -> None:
        _load(values["file"])

    def setup(self) -> None:
        self.body = _load(self.p.file)
        self._n = self.body.sensors
        self._cal: sk.BodyCalibration | None = None
        self._root = self.body.root
        self._want = False
        self._first: float | None = None
        self._told = False

    def do_calibrate(self) -> None:
        """Take the next sample as the calibration pose."""
        self._want = True

    def on_root(self, msg: Message) -> None:
        self._root = tuple(as_floats(msg, 3))  # type: ignore[assignment]

    def on_quats(self, msg: Message) -> None:
        v = as_floats(msg)
        if len(v) != 4 * self._n:
            raise ValueError(
                f"expected {4 * self._n} numbers (4 for each of {self._n} sensors), got {len(v)}"
            )
        q = [tuple(v[4 * i : 4 * i + 4]) for i in range(self._n)]
        if self._first is None:
            self._first = msg.time
        if self.p.auto and self._cal is None and msg.time - self._first >= self.p.auto:
            self._want = True
        if self._want:
            self._want = False
            front = (
                None
                if math.isnan(self.p.front)
                else sq.axis_angle_quat(0.0, 0.0, 1.0, math.radians(self.p.front))
            )
            self._cal = sk.calibrate(self.body, q, front)  # type: ignore[arg-type]
            self.out(3, make("calibrated", msg.time))
        if self._cal is None:
            if not self._told:
                self._told = True
                self.out(3, make("waiting for the pose", msg.time))
            return
        segs = sk.segment_orientations(self.body, q, self._cal)  # type: ignore[arg-type]
        joints, ends = sk.forward(self.body, segs, self._root)
        t = msg.time
        self.out(2, floats(tuple(c for p in ends for c in p), t))
        self.out(1, floats(tuple(c for p in joints for c in p), t))
        self.out(0, floats(tuple(c for q_ in segs for c in q_), t))


@register("point_ray")
class PointRay(Node):
    """Point with the whole arm: the ray from one joint through another meets the room.

    ``start`` and ``through`` name points of the skeleton (``file``, as the ``skeleton`` node's): a
    segment's name is its proximal joint (``upper_arm``: the shoulder), ``NAME.end`` its far end
    (``hand.end``: the fingertips).  The ray meets ``target=sphere`` (the loudspeaker sphere: ``radius``
    around ``centre``, the listening position) or ``target=floor`` (the plane z = ``floor``).  Out, right
    to left: ``xyz`` (where, metres), ``distance`` (from ``centre``, metres), ``elevation`` and
    ``azimuth`` (degrees, ADM-OSC: 0 front, + left, + up, seen from ``centre``).  A ray that meets nothing
    (pointing at the ceiling with ``target=floor``) sends nothing, and ``xyz`` holds.
    """

    pure = True

    inlets = (
        Inlet("joints", ("vector", "list"), "the skeleton's joints (3M numbers)"),
        Inlet("ends", ("vector", "list"), "the skeleton's ends (3M numbers)", hot=False),
    )
    outlets = (
        Outlet("azimuth", "float", "degrees, + left, seen from centre"),
        Outlet("elevation", "float", "degrees, + up"),
        Outlet("distance", "float", "metres from centre"),
        Outlet("xyz", "vector", "where the ray meets the target, metres"),
    )
    params = (
        Param("file", "path", ARM, "the skeleton (JSON), as the skeleton node's", reads=True),
        Param("start", "symbol", "upper_arm", "where the ray starts: a segment (its joint) or SEGMENT.end"),
        Param("through", "symbol", "hand.end", "the point it goes through"),
        Param(
            "target",
            "symbol",
            "sphere",
            "sphere (the loudspeakers) or floor",
            choices=("sphere", "floor"),
            live=True,
        ),
        Param("radius", "float", 3.0, "the sphere's radius", unit="m", above=0.0, live=True),
        Param(
            "centre",
            "vector",
            (0.0, 0.0, 1.2),
            "the listening position (the sphere's centre)",
            size=3,
            live=True,
        ),
        Param("floor", "float", 0.0, "the floor's height", unit="m", live=True),
    )

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        body = _load(values["file"]) if values.get("file") else None
        if body is not None:
            for name in ("start", "through"):
                _point_index(body, values[name], name)
            if values["start"] == values["through"]:
                raise ValueError(f"start and through are the same point ({values['start']}): no ray")

    @classmethod
    def check_files(cls, values: Mapping[str, Any]) -> None:
        _load(values["file"])

    def setup(self) -> None:
        body = _load(self.p.file)
        self._a = _point_index(body, self.p.start, "start")
        self._b = _point_index(body, self.p.through, "through")
        self._ends: tuple[float, ...] | None = None

    def on_ends(self, msg: Message) -> None:
        self._ends = as_floats(msg)

    def on_joints(self, msg: Message) -> None:
        joints = as_floats(msg)
        a, b = self._point(joints, self._a), self._point(joints, self._b)
        if a is None or b is None:
            return
        if self.p.target == "sphere":
            hit = sk.ray_sphere(a, b, tuple(self.p.centre), self.p.radius)
        else:
            hit = sk.ray_floor(a, b, self.p.floor)
        if hit is None:
            return
        az, el, dist = sk.pointing(hit, tuple(self.p.centre))
        t = msg.time
        self.out(3, floats(hit, t))
        self.out(2, dist)
        self.out(1, el)
        self.out(0, az)

    def _point(self, joints: tuple[float, ...], where: tuple[int, bool]) -> sk.Vec3 | None:
        k, end = where
        source = self._ends if end else joints
        if source is None or len(source) < 3 * k + 3:
            return None
        p = source[3 * k : 3 * k + 3]
        return p if all(math.isfinite(c) for c in p) else None  # type: ignore[return-value]


def _point_index(body: sk.Skeleton, name: str, what: str) -> tuple[int, bool]:
    """``SEGMENT`` -> (its index, False: the joint); ``SEGMENT.end`` -> (index, True)."""
    segment, dot, part = str(name).partition(".")
    if dot and part != "end":
        raise ValueError(f"{what}: {name!r}: a segment's name, or NAME.end")
    try:
        return body.index(segment), bool(dot)
    except KeyError as exc:
        raise ValueError(f"{what}: {exc.args[0]}") from None


@register("bvh_record")
class BvhRecord(Node):
    """Record the body as a BVH motion-capture take (Blender, MotionBuilder and most mocap tools read it).

    Wire a ``skeleton`` node's ``joints`` and ``segments`` outlets to the inlets of the same names.  The
    hierarchy is the skeleton's (``file``, the same one): each segment a joint at its ``at`` in its
    parent, a last segment's ``length`` an End Site; every frame the root joint's position and each segment's rotation
    relative to its parent.  BVH's world is Y up: x front, y left, z up become Z, X, Y
    (:mod:`pointat.devices.bvh`).  ``rate`` is the frame rate the file declares (the skeleton's updates,
    one frame each).  The file is written as the take goes (an hour at 100 Hz with 15 segments is about
    260 MB) and its frame count is set when the patch stops; a take cut short still reads.
    """

    needs_input = True
    role = "output"

    inlets = (
        Inlet("segments", ("vector", "list"), "each segment's orientation, 4M numbers (skeleton.segments)"),
        Inlet("joints", ("vector", "list"), "each segment's joint, 3M numbers (skeleton.joints)", hot=False),
    )
    params = (
        Param("file", "path", doc="the take to write (.bvh)", writes=True),
        Param("skeleton", "path", ARM, "the skeleton (JSON), the skeleton node's", reads=True),
        Param("rate", "float", 100.0, "frames per second the file declares", unit="Hz", above=0.0),
        Param("units", "symbol", "cm", "cm (most tools) or m", choices=("cm", "m")),
    )
    example = """
node suit tqt_bank sensors=3
node body skeleton auto=3
node take bvh_record file=take.bvh
suit.quats -> body
body.joints -> take.joints
body.segments -> take.segments
"""

    @classmethod
    def check_files(cls, values: Mapping[str, Any]) -> None:
        _load(values["skeleton"])

    def describe(self) -> str:
        return f"records into {self.p.file}"

    def setup(self) -> None:
        self.body = _load(self.p.skeleton)
        parents = self.body.parents
        leaves = set(range(len(parents))) - set(parents)
        self._joints_spec = [  # (BVH gives a leaf only its End Site: the others' ends are their children)
            BvhJoint(
                s.name,
                parents[k],
                (0.0, 0.0, 0.0) if parents[k] is None else s.at,
                s.length if k in leaves else None,
            )
            for k, s in enumerate(self.body.segments)
        ]
        self._writer: BvhWriter | None = None
        self._root: tuple[float, ...] = self.body.root
        self.frames = 0

    def start(self) -> None:
        self._writer = BvhWriter(self.p.file, self._joints_spec, self.p.rate, units=self.p.units)

    def on_joints(self, msg: Message) -> None:
        self._root = as_floats(msg, 3 * len(self.body.segments))[:3]

    def on_segments(self, msg: Message) -> None:
        v = as_floats(msg, 4 * len(self.body.segments))
        q = [v[4 * k : 4 * k + 4] for k in range(len(self.body.segments))]
        if self._writer is None or not all(math.isfinite(c) for c in v):
            return
        self._writer.frame(self._root, local_rotations(q, self.body.parents))
        self.frames += 1

    def close(self) -> None:
        writer, self._writer = self._writer, None
        if writer is not None:
            writer.close()


@register("simulate_body")
class SimulateBody(PacedSource):
    """A virtual body: a skeleton's sensors moving with known truth (arm or whole body).

    The body (``file``; the arm by default, ``pointat:data/body15.json`` a whole body) first holds the
    calibration pose for ``pose`` seconds, then performs: the arm swings, rises and bends (up to
    ~4 rad/s at the hand), the body walks in place, turns and swings its arms
    (:class:`pointat.devices.body_sim.BodySimulator`).  Each sensor, strapped on ``mounting`` degrees
    off its segment at random, reads its segment's turn (gyro, rad/s, with noise and a constant bias of
    up to ``bias`` °/s), the acceleration of its place on the segment plus gravity (m/s²) and the Earth's
    field with dip (gauss), sent from ``gyroI``, ``accelI`` and ``magI`` as ``tqt_bank``'s inlets take
    them (mag, accel, then the hot gyro).  ``truth`` is every segment's true orientation in the body
    frame (4M numbers), to compare.  ``heading``: where the body faces (degrees from north, + to the west,
    left); ``duration`` ends it (0: never).  ``gyro=mean`` (the default) samples the rate as body-suit
    IMUs deliver it, integrated over each period on the sensor (strapdown increments: Xsens MTw's SDI);
    ``gyro=instant`` as a plain MEMS gyro read at the sample's instant, which puts a filter stepping by
    whole samples half a sample ahead (0.5 deg at the hand at 3 rad/s and 100 Hz).
    """

    sample_outlets = "gyro[0-9]+"
    role = "input"

    outlets = (Outlet("truth", "vector", "every segment's true orientation, body frame, 4M numbers"),)
    #: Pd's stub is drawn for the 15-sensor body, so that it connects as any smaller one does.
    stub_values: ClassVar[dict[str, Any]] = {"file": "pointat:data/body15.json"}
    params = (
        Param("file", "path", ARM, "the skeleton (JSON)", reads=True),
        Param("rate", "float", 100.0, "sample rate", unit="Hz", above=0.0),
        Param("seed", "int", 0, "mountings, biases and noise (the same seed, the same data)", minimum=0),
        Param("noise", "bool", True, "false: ideal sensors (no noise, no bias)"),
        Param(
            "mounting",
            "float",
            3.0,
            "largest angle a sensor is strapped off its segment",
            unit="deg",
            minimum=0.0,
        ),
        Param("bias", "float", 1.0, "largest gyro bias per axis", unit="deg/s", minimum=0.0),
        Param("heading", "float", 0.0, "where the body faces, from north (+ west)", unit="deg"),
        Param("pose", "float", 5.0, "seconds in the calibration pose before moving", unit="s", minimum=0.0),
        Param(
            "gyro",
            "symbol",
            "mean",
            "mean (each sample the mean rate over its period, as a mocap IMU's strapdown increments) or instant",
            choices=("mean", "instant"),
        ),
        Param(
            "duration",
            "float",
            0.0,
            "stop after this long; 0: run until the patch stops",
            unit="s",
            minimum=0.0,
        ),
    )

    #: Samples computed at once (the simulator is vectorised; one block a second at 100 Hz).
    BLOCK = 100

    @classmethod
    def layout(cls, values: Mapping[str, Any]) -> tuple[tuple[Inlet, ...], tuple[Outlet, ...]]:
        n = _load(values.get("file") or ARM).sensors
        outs = [cls.outlets[0]]
        for i in range(1, n + 1):
            outs += [
                Outlet(f"gyro{i}", "vector", f"sensor {i}: angular rate, rad/s"),
                Outlet(f"accel{i}", "vector", f"sensor {i}: specific force, m/s²"),
                Outlet(f"mag{i}", "vector", f"sensor {i}: magnetic field, gauss"),
            ]
        return (), tuple(outs)

    @classmethod
    def check_files(cls, values: Mapping[str, Any]) -> None:
        _load(values["file"])

    def describe(self) -> str:
        return f"a simulated body, {self.p.rate:g} Hz"

    def setup(self) -> None:
        self.sim = BodySimulator(
            _load(self.p.file),
            rate_hz=self.p.rate,
            seed=self.p.seed,
            noise=self.p.noise,
            mounting_deg=self.p.mounting,
            heading_deg=self.p.heading,
            pose_seconds=self.p.pose,
            gyro_bias_dps=self.p.bias,
            gyro_sampling=self.p.gyro,
        )
        self._n = self.sim.skeleton.sensors
        self._block: Any = None

    def start(self) -> None:
        self.pace()

    def sample(self, k: int, t: float) -> None:
        j = k % self.BLOCK
        if j == 0:
            self._block = self.sim.take(self.BLOCK, k)
        b = self._block
        gyro, acc, mag = b.gyro[j].tolist(), b.acc[j].tolist(), b.mag[j].tolist()
        for i in range(self._n):  # each sensor's mag, accel, then the hot gyro
            self.out(3 + 3 * i, floats(tuple(mag[i]), t))
            self.out(2 + 3 * i, floats(tuple(acc[i]), t))
            self.out(1 + 3 * i, floats(tuple(gyro[i]), t))
        self.out(0, floats(tuple(b.q_body[j].ravel().tolist()), t))
