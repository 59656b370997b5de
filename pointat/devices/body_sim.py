r"""A simulated body: a skeleton of rigid segments moving with known truth, and the MARG sensors on it.

The posture tracker of :mod:`pointat.maths.skeleton` (Bachmann et al., VRST 2001) gives every segment its
own sensor and filter; this module is its test bench, as :mod:`pointat.devices.glove_sim` is the single
glove's.

* :data:`ARM` -- a right arm of 0.63 m (upper arm, forearm, hand; sensors 1-3), the shoulder at
  (0, -0.2, 1.45) m, held straight ahead, level, palm down in its calibration pose.
* :data:`BODY` -- 15 segments, one sensor each (:data:`BODY` documents them), standing in an *N-pose*:
  upright, arms hanging at the sides, feet forward; every segment's frame is the body frame in that pose
  (all poses are the identity), its ``length`` points where the segment goes (down for arms and legs).
* :class:`Joint` and :class:`BodyScript` -- the motion: each segment turns, relative to its calibration
  pose in its parent, by a chain of rotations about its own axes whose angles are smooth sums of sines
  (:func:`default_script`: an arm that swings, raises, bends and rolls; a body that walks in place).
* :class:`BodySimulator` -- samples it: ``truth(k)`` (:class:`BodyTruth`) for one sample, ``take(n)``
  for many at once, ``kinematics(t)`` noise-free at any instants.

Frames and conventions (those of :mod:`pointat.maths`): quaternions scalar-first ``(w, x, y, z)``, segment
or sensor frame -> earth frame; the earth frame is NWU (x north, y west, z up).  The performer faces
``heading_deg`` of yaw (from north, positive turning left): the body frame is the earth frame turned by
that yaw, and a segment's body-frame orientation is :math:`q_z(\text{heading})^{-1} \otimes q` (field
``q_body``), what :func:`~pointat.maths.skeleton.segment_orientations` estimates.  Positions are those of
:func:`~pointat.maths.skeleton.forward` applied to the earth-frame orientations: earth axes (NWU), the
origin placed so that the root's joint is at ``skeleton.root`` (plus the root's ``at``), which does not
move.  The body-frame positions are ``forward(skeleton, q_body)``.

Everything is analytic: the joint angles, their rates and accelerations; from them every segment's
angular velocity and acceleration down the chain, every sensor's acceleration
(:math:`a = a_{joint} + \alpha \times r + \omega \times (\omega \times r)`), so the gyro and the
accelerometer agree with the orientations and positions to rounding (``tests/devices/test_body_sim.py``
integrates the one and differentiates the other twice).

Sensors
-------
Sensor ``i`` (1-based, ``Segment.sensor``) sits at the middle of its segment's ``length`` vector, turned on
it by a fixed random mounting rotation :math:`M_i` (rotation vector uniform in the ball of radius
``mounting_deg``, from ``seed``): :math:`q_{sensor} = q_{segment} \otimes M_i`.  It reads, in its own frame,
the segment's angular velocity (rad/s), the specific force :math:`R^T (a + (0, 0, g))` (m/s², +g up at
rest) and the Earth's field with its dip (gauss), as the glove simulator's
:class:`~pointat.devices.glove_sim.SensorModel` (its default levels: :data:`GYRO_NOISE_DPS`,
:data:`ACCEL_NOISE`, :data:`MAG_NOISE_GAUSS`, a constant gyro bias uniform in :data:`GYRO_BIAS_DPS` per
axis, :data:`FIELD_GAUSS`, :data:`DIP_DEG`); as floats, without ADC counts or clipping.

>>> sim = BodySimulator(ARM, seed=1)
>>> truth = sim.truth(0)
>>> truth.q.round(12).tolist()          # the calibration pose: every segment straight ahead
[[1.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]]
>>> truth.joints[2].round(12).tolist()  # the wrist, 0.55 m ahead of the shoulder
[0.55, -0.2, 1.45]
>>> round(float(np.linalg.norm(truth.specific_force[0])), 5)  # at rest: g
9.80665
>>> take = sim.take(300)
>>> take.gyro.shape, bool((take.gyro[17] == sim.truth(17).gyro).all())
((300, 3, 3), True)
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from pointat.devices.glove_sim import GRAVITY
from pointat.maths.quaternion import (
    quat_conjugate,
    quat_from_axis_angle,
    quat_multiply,
    quat_normalize,
    quat_rotate,
    quat_to_rotvec,
    rotvec_to_quat,
)
from pointat.maths.skeleton import Skeleton

__all__ = [
    "ACCEL_NOISE",
    "ARM",
    "BODY",
    "DIP_DEG",
    "FIELD_GAUSS",
    "GRAVITY",
    "GYRO_BIAS_DPS",
    "GYRO_NOISE_DPS",
    "MAG_NOISE_GAUSS",
    "BodyScript",
    "BodySimulator",
    "BodyTruth",
    "Joint",
    "default_script",
]

#: White noise of the gyro, °/s (the glove simulator's ``SensorModel`` default).
GYRO_NOISE_DPS = 0.3
#: White noise of the accelerometer, m/s² (likewise).
ACCEL_NOISE = 0.02
#: White noise of the magnetometer, gauss (likewise).
MAG_NOISE_GAUSS = 0.002
#: Half-width of the uniform draw of each gyro axis's constant bias, °/s (likewise).
GYRO_BIAS_DPS = 3.0
#: The Earth's field, gauss, and its dip below the horizon, degrees (likewise: mid-latitude Europe).
FIELD_GAUSS = 0.48
DIP_DEG = 67.0

_NOISE_BLOCK = 1024  # samples of noise drawn from one generator: random access at a block's cost

# -- skeletons ---------------------------------------------------------------------------------------------

_DATA = Path(__file__).resolve().parents[1] / "data"

ARM = Skeleton.load(_DATA / "arm.json")
"""A right arm (``pointat/data/arm.json``): upper arm 0.30 m (the root, sensor 1), forearm 0.25 m
(sensor 2), hand 0.08 m (sensor 3), each along its own x axis; the shoulder at (0, -0.2, 1.45) m (20 cm
right of the body's axis).  Poses are the identity: the calibration pose is the arm straight ahead,
level, palm down."""

BODY = Skeleton.load(_DATA / "body15.json")
"""A whole body of 15 segments and sensors (``pointat/data/body15.json``), 1.70 m tall, in the N-pose
(upright, arms hanging at the sides, feet pointing forward); all poses are the identity (every segment's
frame is the body frame in the pose) and each ``length`` points along the segment in that pose.  The
root joint (mid-hip) is at 0.95 m.

====  ===============  =========  ==================================================
 #    segment          parent     joint (``at``, in the parent) -> length, metres
====  ===============  =========  ==================================================
 1    pelvis           --         root -> (0, 0, 0.10) up to the waist
 2    chest            pelvis     waist -> (0, 0, 0.40) up to the neck (1.45 m)
 3    head             chest      neck -> (0, 0, 0.25) (top of the head at 1.70 m)
 4-6  right upper arm, forearm, hand: shoulder (0, -0.18, 0.32) on the chest, then 0.30, 0.25, 0.08 down
 7-9  left upper arm, forearm, hand: the same on the left (y = +0.18)
10-12 right thigh, shank, foot: hip (0, -0.09, 0) on the pelvis, 0.45 and 0.43 down, the foot (0.18, 0, -0.05)
13-15 left thigh, shank, foot: the same on the left (y = +0.09)
====  ===============  =========  =================================================="""


# -- motion ----------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Joint:
    r"""One rotation of a segment about an axis of its own frame, by an angle (degrees) that is
    :math:`\theta(\tau) = S(\tau)\,\big(c + \sum_i a_i \sin(2\pi\tau/T_i + \varphi_i)\big)` at
    :math:`\tau` seconds into the performance (0 before: the calibration pose), :math:`S` a ramp from 0
    to 1 (:class:`BodyScript`).

    ``centre`` is :math:`c`; ``waves`` the :math:`(a_i, T_i, \varphi_i)`: amplitude (degrees), period
    (seconds) and phase (degrees).  The angle stays between :math:`c \pm \sum |a_i|` (and 0 in the ramp).
    """

    axis: Literal["x", "y", "z"]
    centre: float = 0.0
    waves: tuple[tuple[float, float, float], ...] = ()

    def __post_init__(self) -> None:
        if self.axis not in ("x", "y", "z"):
            raise ValueError(f"Joint axis must be 'x', 'y' or 'z', got {self.axis!r}")
        for a, period, phase in self.waves:
            if not (math.isfinite(a) and math.isfinite(phase) and math.isfinite(period) and period > 0):
                raise ValueError(
                    f"a wave needs a finite amplitude and phase and a period > 0, got {(a, period, phase)}"
                )

    @property
    def span(self) -> tuple[float, float]:
        """The least and greatest angle the joint can reach after its ramp, degrees."""
        reach = sum(abs(a) for a, _, _ in self.waves)
        return self.centre - reach, self.centre + reach

    def angle(self, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The wave without its ramp at ``tau`` (s): angle, rate, acceleration (radians, rad/s, rad/s²)."""
        f = np.full(tau.shape, math.radians(self.centre))
        df = np.zeros(tau.shape)
        ddf = np.zeros(tau.shape)
        for a, period, phase in self.waves:
            w = 2.0 * math.pi / period
            x = w * tau + math.radians(phase)
            s, c = np.sin(x), np.cos(x)
            a = math.radians(a)
            f += a * s
            df += a * w * c
            ddf -= a * w * w * s
        return f, df, ddf


class BodyScript:
    r"""The performance: for each segment (by name), its :class:`Joint` rotations, applied in order in the
    segment's own frame (intrinsic: the second turns about the axis as the first left it).

    A segment's body-frame orientation is its parent's, times its calibration pose relative to its parent
    (:math:`p_{parent}^{-1} \otimes p`), times :math:`J = R_{a_1}(\theta_1) \otimes R_{a_2}(\theta_2)
    \otimes \dots`; the root's is its pose times :math:`J`.  A segment the script does not name moves with
    its parent, rigidly, at its pose.

    Every angle is multiplied by the ramp :math:`S(\tau/\text{ramp})`, :math:`S(x) = 10x^3 - 15x^4 +
    6x^5` (1 from ``ramp`` seconds on), whose value, slope and curvature are 0 at the start: the
    performance leaves the calibration pose with continuous angular rates and accelerations.
    """

    def __init__(self, joints: Mapping[str, Sequence[Joint]], ramp: float = 2.0) -> None:
        if not (math.isfinite(ramp) and ramp > 0):
            raise ValueError(f"ramp must be a finite number of seconds > 0, got {ramp!r}")
        self.joints: dict[str, tuple[Joint, ...]] = {name: tuple(js) for name, js in joints.items()}
        for name, js in self.joints.items():
            bad = [j for j in js if not isinstance(j, Joint)]
            if bad:
                raise ValueError(f"segment '{name}': expected Joint values, got {bad[0]!r}")
        self.ramp = float(ramp)

    def angles(self, joint: Joint, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``joint``'s angle, rate and acceleration (radians, rad/s, rad/s²) at ``tau`` seconds into the
        performance, ramp included (0 for ``tau <= 0``)."""
        x = np.clip(tau / self.ramp, 0.0, 1.0)
        s = x * x * x * (10.0 + x * (-15.0 + 6.0 * x))
        ds = 30.0 * x * x * (1.0 - x) ** 2 / self.ramp
        dds = 60.0 * x * (1.0 - x) * (1.0 - 2.0 * x) / (self.ramp * self.ramp)
        f, df, ddf = joint.angle(np.maximum(tau, 0.0))
        return s * f, ds * f + s * df, dds * f + 2.0 * ds * df + s * ddf


def _arm_joints() -> dict[str, tuple[Joint, ...]]:
    """The arm held forward (:data:`ARM`): yaw, elevation and roll at the shoulder, elbow, wrist."""
    return {
        "upper_arm": (
            # swing left/right, ±70° (the yaw about the body's vertical)
            Joint("z", 0.0, ((45.0, 6.1, 0.0), (25.0, 3.7, 40.0))),
            # up/down: elevation -30°..+80° (positive about y turns x down, hence the signs)
            Joint("y", -25.0, ((-35.0, 7.3, 20.0), (-20.0, 3.1, 70.0))),
            # humeral rotation, ±20°
            Joint("x", 0.0, ((20.0, 4.9, 10.0),)),
        ),
        "forearm": (
            # elbow flexion 0-100°, in the upper arm's vertical plane (the hand comes up)
            Joint("y", -50.0, ((-30.0, 4.1, 0.0), (-20.0, 3.1, 69.0))),
            # forearm roll (pronation/supination), ±60°
            Joint("x", 0.0, ((40.0, 4.3, 0.0), (20.0, 2.9, 30.0))),
        ),
        "hand": (
            Joint("y", 0.0, ((25.0, 3.3, 0.0), (10.0, 2.1, 50.0))),  # wrist flexion ±35°
            Joint("z", 0.0, ((15.0, 3.9, 20.0),)),  # ulnar/radial deviation ±15°
        ),
    }


def _body_joints() -> dict[str, tuple[Joint, ...]]:
    """Walking in place (1.2 s strides), the torso turning, the head looking about, the arms swinging."""
    step = 1.2
    joints: dict[str, tuple[Joint, ...]] = {
        "pelvis": (Joint("z", 0.0, ((10.0, 6.7, 0.0),)), Joint("x", 0.0, ((3.0, step, 0.0),))),
        "chest": (
            Joint("z", 0.0, ((20.0, 5.9, 0.0), (10.0, 3.1, 60.0))),
            Joint("y", 0.0, ((8.0, 4.4, 0.0),)),
        ),
        "head": (
            Joint("z", 0.0, ((30.0, 4.7, 0.0), (10.0, 2.2, 30.0))),
            Joint("y", 0.0, ((15.0, 3.3, 0.0),)),
        ),
    }
    for side, sign, phase in (("right", -1.0, 0.0), ("left", 1.0, 180.0)):
        joints |= {
            f"{side}_thigh": (Joint("y", -25.0, ((25.0, step, 90.0 + phase),)),),  # hip flexion 0-50°
            f"{side}_shank": (Joint("y", 35.0, ((-35.0, step, 90.0 + phase),)),),  # knee 0-70°
            f"{side}_foot": (Joint("y", 0.0, ((15.0, step, phase),)),),  # ankle ±15°
            # arms swing against the leg of their side, abduct slowly, bend at the elbow
            f"{side}_upper_arm": (
                Joint("y", 0.0, ((-20.0, step, 90.0 + phase),)),
                Joint("x", 20.0 * sign, ((20.0 * sign, 7.7, phase),)),
                Joint("z", 0.0, ((20.0, 5.3, phase),)),
            ),
            f"{side}_forearm": (
                Joint("y", -45.0, ((-35.0, 3.7, phase),)),  # elbow 10-80°
                Joint("z", 0.0, ((30.0 * sign, 3.9, phase),)),  # pronation about the hanging forearm
            ),
            f"{side}_hand": (Joint("y", 0.0, ((20.0, 2.9, phase),)),),
        }
    return joints


def default_script(skeleton: Skeleton | None = None) -> BodyScript:
    r"""The demo performance, for the segments of :data:`ARM` and :data:`BODY` by name (others hold still).

    **Arm** (the calibration pose: straight ahead, level, palm down): the shoulder swings left/right up to
    ±70° (periods 6.1 and 3.7 s) and up/down between -30° and +80° of elevation (7.3, 3.1 s), with ±20° of
    humeral rotation (4.9 s); the elbow flexes 0-100° (4.1, 2.3 s) and the forearm rolls ±60° (3.3, 1.9 s);
    the wrist flexes ±35° (2.7, 1.3 s) and deviates ±15° (3.9 s).  No two periods are commensurate over a
    minute, so the arm wanders over its workspace; the hand turns at up to about 3 rad/s.

    **Body** (N-pose): walking in place, 1.2 s strides (hips 0-50°, knees 0-70°, ankles ±15°, the legs in
    opposition), the pelvis turning ±10° and rocking ±3°, the chest turning ±30° on it and leaning ±8°,
    the head turning ±40° and nodding ±15°; the arms swing ±25° against the legs, abduct 0-40° slowly,
    rotate ±20°, bend 10-80° at the elbow, the forearms roll ±40°, the wrists flex ±30°.

    ``skeleton``: keep only the segments it has (default: all of them, as the simulator does anyway).
    """
    joints = _arm_joints() | _body_joints()
    if skeleton is not None:
        names = {s.name for s in skeleton.segments}
        joints = {name: js for name, js in joints.items() if name in names}
    return BodyScript(joints)


# -- the simulator ---------------------------------------------------------------------------------------


class BodyTruth(NamedTuple):
    r"""A sample, or with a leading time axis a take, of the simulated body.

    Segments are in skeleton order (S of them), sensors by number (``[i]`` is sensor ``i + 1``, n of them).

    ``t``: seconds.  ``q`` (S, 4): each segment's orientation, segment -> earth (NWU).  ``q_body`` (S, 4):
    the same in the body frame (the body's heading taken out).  ``joints``, ``ends`` (S, 3): each
    segment's proximal joint and far end, metres, earth axes, origin such that the root's joint is at
    ``skeleton.root`` (as :func:`~pointat.maths.skeleton.forward` gives them from ``q``).
    ``sensor_q`` (n, 4): each sensor's orientation, sensor -> earth, mounting included;
    ``sensor_position`` (n, 3): where it is (the middle of its segment).  ``omega`` (rad/s),
    ``specific_force`` (m/s², :math:`R^T(a + g\hat z)`) and ``field`` (gauss), (n, 3): the true values in
    each sensor's frame; ``gyro``, ``acc``, ``mag`` (n, 3): the readings (the true values, the gyro's
    sampled as the simulator's ``gyro_sampling`` says, plus the gyro bias and white noise when the
    simulator has noise).
    """

    t: np.ndarray
    q: np.ndarray
    q_body: np.ndarray
    joints: np.ndarray
    ends: np.ndarray
    sensor_q: np.ndarray
    sensor_position: np.ndarray
    omega: np.ndarray
    specific_force: np.ndarray
    field: np.ndarray
    gyro: np.ndarray
    acc: np.ndarray
    mag: np.ndarray


_AXES = {"x": 0, "y": 1, "z": 2}
_UNIT = np.eye(3)


class BodySimulator:
    r"""A body performing :class:`BodyScript` with a MARG sensor on each segment, sampled at ``rate_hz``.

    The body holds its calibration pose (every segment at its ``pose``, facing ``heading_deg``) for
    ``pose_seconds``, still, then performs the script.  ``truth(k)`` and ``take(n, start)`` give the same
    values for a sample however it is asked for (the noise of each block of samples comes from its own
    generator), deterministically for a seed.

    Parameters
    ----------
    skeleton : Skeleton
        The body; sensors must be numbered 1..n without a gap.
    rate_hz : float
        Sample rate, Hz.
    seed : int
        Seeds the mounting rotations, the gyro biases and the noise.
    noise : bool
        Add a constant gyro bias per sensor (uniform within ±:data:`GYRO_BIAS_DPS` per axis) and white noise
        (:data:`GYRO_NOISE_DPS`, :data:`ACCEL_NOISE`, :data:`MAG_NOISE_GAUSS`) to the readings.
    mounting_deg : float
        Largest angle of a sensor's mounting rotation on its segment (0: sensors aligned with segments).
    heading_deg : float
        Yaw of the body frame in the earth frame (from north, positive turning left).
    pose_seconds : float
        How long the calibration pose is held before the performance.
    script : BodyScript, optional
        Default :func:`default_script`.  Every name in it must be a segment of ``skeleton``.
    gyro_bias_dps : float, keyword-only
        Half-width of the bias draw, °/s (default :data:`GYRO_BIAS_DPS`).
    gyro_sampling : {"instant", "mean"}, keyword-only
        What a gyro sample is: ``"instant"`` (default), the angular velocity at the sample's instant;
        ``"mean"``, the mean rate over the period ending there, the rotation vector of
        :math:`q(t_{k-1})^{-1} \otimes q(t_k)` over the period, as an IMU that integrates its rate
        internally (delta angles) reads it, and exactly what a filter's zero-order-hold step integrates.
        A filter fed instant rates carries a timing error of half a sample (it leads the truth by
        :math:`\omega\,\Delta t / 2`, 0.86° at 3 rad/s and 100 Hz).  ``omega`` stays the instant rate.
    """

    def __init__(
        self,
        skeleton: Skeleton,
        *,
        rate_hz: float = 100.0,
        seed: int = 0,
        noise: bool = True,
        mounting_deg: float = 3.0,
        heading_deg: float = 0.0,
        pose_seconds: float = 3.0,
        script: BodyScript | None = None,
        gyro_bias_dps: float = GYRO_BIAS_DPS,
        gyro_sampling: Literal["instant", "mean"] = "instant",
    ) -> None:
        for name, value in (
            ("rate_hz", rate_hz),
            ("mounting_deg", mounting_deg),
            ("heading_deg", heading_deg),
            ("pose_seconds", pose_seconds),
            ("gyro_bias_dps", gyro_bias_dps),
        ):
            if not math.isfinite(value):
                raise ValueError(f"{name} must be finite, got {value!r}")
        if not rate_hz > 0:
            raise ValueError(f"rate_hz must be > 0, got {rate_hz!r}")
        if mounting_deg < 0 or pose_seconds < 0 or gyro_bias_dps < 0:
            raise ValueError("mounting_deg, pose_seconds and gyro_bias_dps must be >= 0")
        if gyro_sampling not in ("instant", "mean"):
            raise ValueError(f"gyro_sampling must be 'instant' or 'mean', got {gyro_sampling!r}")
        self.gyro_sampling = gyro_sampling
        self.skeleton = skeleton
        self.script = script if script is not None else default_script(skeleton)
        names = {s.name for s in skeleton.segments}
        unknown = sorted(set(self.script.joints) - names)
        if unknown:
            raise ValueError(f"the script moves '{unknown[0]}', which the skeleton has not")
        n = skeleton.sensors
        on = {s.sensor: k for k, s in enumerate(skeleton.segments) if s.sensor is not None}
        missing = [i for i in range(1, n + 1) if i not in on]
        if missing:
            raise ValueError(f"sensor {missing[0]} is on no segment (sensors must be numbered 1..{n})")
        self.rate_hz = float(rate_hz)
        self.seed = int(seed)
        self.noise = bool(noise)
        self.mounting_deg = float(mounting_deg)
        self.heading_deg = float(heading_deg)
        self.pose_seconds = float(pose_seconds)
        self.n_sensors = n
        #: segment index of each sensor (sensor i + 1 is on segment ``sensor_segment[i]``)
        self.sensor_segment = np.array([on[i] for i in range(1, n + 1)])
        self.heading = quat_from_axis_angle([0.0, 0.0, 1.0], math.radians(heading_deg))
        rng = np.random.default_rng([self.seed, 0x3047])
        direction = rng.standard_normal((n, 3))
        direction /= np.linalg.norm(direction, axis=1, keepdims=True)
        radius = math.radians(mounting_deg) * np.cbrt(rng.uniform(0.0, 1.0, n))
        #: each sensor's mounting rotation on its segment, sensor -> segment, (n, 4)
        self.mounting = rotvec_to_quat(direction * radius[:, None])
        bias = rng.uniform(-gyro_bias_dps, gyro_bias_dps, (n, 3))
        #: each sensor's gyro bias, rad/s, (n, 3) (zero without noise)
        self.gyro_bias = np.radians(bias) if self.noise else np.zeros((n, 3))
        self._noise_sd = np.repeat([math.radians(GYRO_NOISE_DPS), ACCEL_NOISE, MAG_NOISE_GAUSS], 3)
        dip = math.radians(DIP_DEG)
        #: the Earth's field, gauss, earth frame (NWU): north and down by the dip
        self.field_earth = FIELD_GAUSS * np.array([math.cos(dip), 0.0, -math.sin(dip)])
        self._parents = skeleton.parents
        self._rel0 = [
            np.array(s.pose)
            if p is None
            else quat_multiply(quat_conjugate(skeleton.segments[p].pose), s.pose)
            for s, p in zip(skeleton.segments, self._parents, strict=True)
        ]

    @property
    def period(self) -> float:
        """Sample period, seconds."""
        return 1.0 / self.rate_hz

    def time(self, k: int) -> float:
        """Time of sample ``k``, seconds."""
        return k / self.rate_hz

    # -- noise-free kinematics at any instants ---------------------------------------------------------
    def kinematics(self, t: ArrayLike) -> BodyTruth:
        """The truth at the instants ``t`` (seconds, shape (N,)), without noise or bias: a
        :class:`BodyTruth` with a leading axis of N (readings equal to the true values)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if t.ndim != 1:
            raise ValueError(f"t must be a 1-D array of instants, got shape {t.shape}")
        size = t.shape[0]
        tau = t - self.pose_seconds
        skel = self.skeleton
        qs, ws, als, joints, joint_a, ends, sensor_p, sensor_a = [], [], [], [], [], [], [], []
        zero = np.zeros((size, 3))
        for k, (seg, parent) in enumerate(zip(skel.segments, self._parents, strict=True)):
            at = np.array(seg.at)
            if parent is None:
                q = np.broadcast_to(quat_multiply(self.heading, self._rel0[k]), (size, 4))
                w, al = zero, zero
                p = np.broadcast_to(np.add(skel.root, at), (size, 3))
                a = zero
            else:
                qp, w, al = qs[parent], ws[parent], als[parent]
                r = quat_rotate(qp, at)
                p = joints[parent] + r
                a = joint_a[parent] + np.cross(al, r) + np.cross(w, np.cross(w, r))
                q = quat_multiply(qp, self._rel0[k])
            for joint in self.script.joints.get(seg.name, ()):
                th, dth, ddth = self.script.angles(joint, tau)
                e = _UNIT[_AXES[joint.axis]]
                e_earth = quat_rotate(q, e)
                q = quat_multiply(q, quat_from_axis_angle(e, th))
                spin = e_earth * dth[:, None]
                al = al + np.cross(w, spin) + e_earth * ddth[:, None]
                w = w + spin
            qs.append(q)
            ws.append(w)
            als.append(al)
            joints.append(p)
            joint_a.append(a)
            half = quat_rotate(q, 0.5 * np.array(seg.length))
            ends.append(p + 2.0 * half)
            sensor_p.append(p + half)
            sensor_a.append(a + np.cross(al, half) + np.cross(w, np.cross(w, half)))
        q_seg = np.stack(qs, axis=1)
        idx = self.sensor_segment
        q_sensor = quat_normalize(quat_multiply(q_seg[:, idx], self.mounting))
        inv = quat_conjugate(q_sensor)
        omega = quat_rotate(inv, np.stack(ws, axis=1)[:, idx])
        force = quat_rotate(inv, np.stack(sensor_a, axis=1)[:, idx] + np.array([0.0, 0.0, GRAVITY]))
        field = quat_rotate(inv, self.field_earth)
        q_body = quat_multiply(quat_conjugate(self.heading), q_seg)
        return BodyTruth(
            t,
            q_seg,
            q_body,
            np.stack(joints, axis=1),
            np.stack(ends, axis=1),
            q_sensor,
            np.stack(sensor_p, axis=1)[:, idx],
            omega,
            force,
            field,
            omega,
            force,
            field,
        )

    # -- sampled, with noise ----------------------------------------------------------------------------
    def _noise(self, start: int, n: int) -> np.ndarray:
        """White noise of samples ``start .. start + n - 1``, (n, sensors, 9), standard deviations applied."""
        out = np.empty((n, self.n_sensors, 9))
        k = start
        while k < start + n:
            block, offset = divmod(k, _NOISE_BLOCK)
            rng = np.random.default_rng([self.seed, 0xB0D1, block])
            chunk = rng.standard_normal((_NOISE_BLOCK, self.n_sensors, 9))
            take = min(_NOISE_BLOCK - offset, start + n - k)
            out[k - start : k - start + take] = chunk[offset : offset + take]
            k += take
        return out * self._noise_sd

    def take(self, n: int, start: int = 0) -> BodyTruth:
        """Samples ``start .. start + n - 1`` as one :class:`BodyTruth` with a leading axis of ``n``."""
        if n < 0 or start < 0:
            raise ValueError(f"n and start must be >= 0, got {n}, {start}")
        t = np.arange(start, start + n) / self.rate_hz
        truth = self.kinematics(t)
        if self.gyro_sampling == "mean":
            before = self.kinematics(t - self.period).sensor_q
            turn = quat_to_rotvec(quat_multiply(quat_conjugate(before), truth.sensor_q))
            truth = truth._replace(gyro=turn * self.rate_hz)
        if not self.noise:
            return truth
        noise = self._noise(start, n)
        return truth._replace(
            gyro=truth.gyro + self.gyro_bias + noise[..., 0:3],
            acc=truth.specific_force + noise[..., 3:6],
            mag=truth.field + noise[..., 6:9],
        )

    def truth(self, k: int) -> BodyTruth:
        """Sample ``k``: the :class:`BodyTruth` of one instant (no leading axis)."""
        if k < 0:
            raise ValueError(f"sample index must be >= 0, got {k}")
        one = self.take(1, k)
        return BodyTruth(*(np.asarray(field)[0] for field in one))
