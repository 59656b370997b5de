"""From ADC counts to physical units: ``offset`` (nulls), ``scaling`` (resolutions) and ``calibrate``.

Torre §3.1 subtracts the average of the first thousand samples at rest from every channel.  That is the
right null for the gyros only: at rest they read their bias, but the accelerometers read gravity and the
magnetometers the Earth's field, so a rest average would erase the very vectors the orientation is
computed from.  Their nulls come from a calibration file (Bachmann et al. 2001 §3.2.1, made with the
``calibrate`` node) or, without one, from the ADC mid-scale.
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Mapping
from typing import Any

import numpy as np

from pointat.devices.mote_frame import ADC_MAX, ADC_NULL, DEFAULT_RESOLUTION, MoteSpec, adc_full_scale
from pointat.errors import worth_reporting
from pointat.maths.calibration import (
    MISALIGNMENT_LIMIT,
    Calibration,
    ellipsoid_fit,
    gyro_misalignment,
    gyro_null,
    gyro_scale,
    implausible,
    is_identity,
    minmax_magnetometer,
    six_position_accel,
    six_position_misalignment,
)
from pointat.message import Message, as_floats, as_vector, floats
from pointat.node import Inlet, Node, Outlet, Param, names_path
from pointat.registry import register
from pointat.saving import clean_stray
from pointat.userfiles import read_bytes

log = logging.getLogger(__name__)

ADC = Inlet("adc", ("vector", "list"), "nine ADC counts: gyro x y z, accel x y z, mag x y z")
STATUS = Outlet("status", "list", "what the node is doing: calibrating, ready, saved PATH...")


def _load(path: str) -> Calibration:
    try:
        return Calibration.load(path)  # its ValueError names the file and the key
    except UnicodeDecodeError as exc:
        raise ValueError(
            f"calibration file {path}: not UTF-8 text ({exc.reason} at byte {exc.start})"
        ) from exc
    except OSError as exc:
        raise ValueError(f"calibration file {path}: {exc.strerror or exc}") from exc


def _calibrated(cal: Calibration, sensor: str) -> bool:
    """Whether the file calibrates this sensor (an uncalibrated one has null 0 and scale 1)."""
    null, scale = getattr(cal, f"{sensor}_null"), getattr(cal, f"{sensor}_scale")
    return bool(np.any(null != 0.0) or np.any(scale != 1.0))


@register("offset")
class Offset(Node):
    """Subtract each channel's null from the nine ADC counts (Torre §3.1, done right).

    Gyro nulls: the average of the first ``samples`` samples at rest (the gyros' bias); ``recalibrate``
    starts a new average.  Accelerometer and magnetometer nulls: from ``calibration`` (a file written by
    ``calibrate``), else the ADC mid-scale ``null``.  Nothing is output while the first gyro average
    runs, unless the file has gyro nulls too: then the output flows from the first sample with the
    file's, until the average (the gyros' bias of today) replaces them.  During a ``recalibrate`` the
    output goes on with the nulls it has.  An average over which a
    gyro varied by more than ``still`` counts rms (50: 5 deg/s at the nominal resolution, well above a
    resting hand's tremor, which averages out) was taken while the glove moved: it is refused (a
    ``moved`` status and a warning) and the nulls stay as they were; until one average has been taken,
    it then starts again, until the glove is held still.
    """

    pure = True
    fusable = True

    inlets = (ADC,)
    outlets = (Outlet("adc", "vector", "nine counts relative to their nulls"), STATUS)
    params = (
        Param(
            "samples", "int", 1000, "samples averaged at rest for the gyro nulls (0: no averaging)", minimum=0
        ),
        Param(
            "null", "float", 2048.0, "null of channels without a calibration (ADC mid-scale)", unit="counts"
        ),
        Param("calibration", "path", "", "calibration file with accel/mag (and gyro) nulls", reads=True),
        Param(
            "still",
            "float",
            50.0,
            "refuse gyro nulls over which a gyro varied by more (rms; 0: never): a gesture, not a hand's"
            " tremor, whose mean is 0",
            unit="counts",
            minimum=0.0,
        ),
    )

    def setup(self) -> None:
        nulls = [self.p.null] * 9
        filed = False  # gyro nulls from the file
        if self.p.calibration:
            cal = _load(self.p.calibration)
            for i, sensor in enumerate(("gyro", "acc", "mag")):
                if _calibrated(cal, sensor):
                    nulls[3 * i : 3 * i + 3] = getattr(cal, f"{sensor}_null").tolist()
                    filed = filed or sensor == "gyro"
        self.nulls: tuple[float, ...] = tuple(float(n) for n in nulls)
        self._ready = self.p.samples == 0  # gyro nulls averaged once in this run
        self._flowing = self._ready or filed  # gyro nulls to subtract: the output may flow
        self._moved = 0  # averages refused in a row
        self.do_recalibrate()

    def do_recalibrate(self) -> None:
        self._sum = [0.0, 0.0, 0.0]
        self._sq = [0.0, 0.0, 0.0]
        self._n = 0

    def on_adc(self, msg: Message) -> None:
        counts = as_floats(msg, 9)
        if self._n < self.p.samples:
            flowing = self._flowing
            self._average(counts)
            if not flowing:  # the first average, and no nulls from a file: nothing to subtract yet
                return
        c, n = counts, self.nulls  # written out: a third of the time of a zip over the nine channels
        d = (
            c[0] - n[0], c[1] - n[1], c[2] - n[2],
            c[3] - n[3], c[4] - n[4], c[5] - n[5],
            c[6] - n[6], c[7] - n[7], c[8] - n[8],
        )  # fmt: skip
        self.out(0, floats(d, msg.time))

    def fused_state(self) -> dict[str, Any] | None:
        """The nulls, once no gyro average is under way and the output flows (:mod:`pointat.compiled`)."""
        if self._n < self.p.samples or not self._flowing:
            return None
        return {"nulls": self.nulls}

    def restore_fused(self, state: Mapping[str, Any]) -> None:
        self.nulls = tuple(state["nulls"])

    def health(self) -> dict[str, Any]:
        if self._ready:
            return {"gyro_nulls": "ready"}
        return {"gyro_nulls": f"calibrating {self._n}/{self.p.samples}"}

    def _moved_again(self) -> None:
        if self._ready:
            self._n = self.p.samples  # done: the old nulls stay
        else:
            self.do_recalibrate()

    def _average(self, counts: tuple[float, ...]) -> None:
        gx, gy, gz = counts[:3]
        if math.isfinite(gx + gy + gz):
            s, q = self._sum, self._sq
            self._sum = [s[0] + gx, s[1] + gy, s[2] + gz]
            self._sq = [q[0] + gx * gx, q[1] + gy * gy, q[2] + gz * gz]
            self._n += 1
        if self._n == 1:
            self.out(1, ("calibrating", self.p.samples))
        if self._n < self.p.samples:
            return
        n = self._n
        means = [s / n for s in self._sum]
        rms = [math.sqrt(max(0.0, q / n - m * m)) for q, m in zip(self._sq, means, strict=True)]
        worst = max(range(3), key=rms.__getitem__)
        if self.p.still and rms[worst] > self.p.still:
            self.out(1, ("moved", "xyz"[worst], round(rms[worst], 1)))
            self._moved += 1
            if not worth_reporting(self._moved):  # a take that starts moving: the 1st..3rd, 10th, 100th...
                return self._moved_again()
            log.warning(
                "offset '%s': the glove moved while the gyro nulls were taken (gyro %s varied by %.1f counts"
                " rms, more than still=%g): %s",
                self.name,
                "xyz"[worst],
                rms[worst],
                self.p.still,
                "kept the nulls it had; hold it still and recalibrate again"
                if self._ready
                else "hold it still; taking them again"
                + (" (the calibration file's meanwhile)" if self._flowing else ""),
            )
            return self._moved_again()
        self._moved = 0
        self.nulls = (*means, *self.nulls[3:])
        self._ready = self._flowing = True
        self.out(1, ("ready", *(round(x, 3) for x in self.nulls[:3])))


@register("scaling")
class Scaling(Node):
    """Counts relative to their nulls -> gyro rad/s, accelerometer m/s², magnetometer gauss (Torre Table 1).

    Per-sensor resolutions in the table's units (deg/s, m/s², gauss per count), or per-axis scales, the
    gyro's and the accelerometer's cross-axis misalignments (applied after the scales) and the soft-iron
    matrix from a ``calibration`` file; an axis the file has no scale for (a gyro axis never turned)
    keeps its resolution, with a warning.  A calibrated magnetometer reads in units of the local field
    (its strength is 1): the filters use its direction only.  A file whose gyro or accelerometer scales
    are more than 4 times off the resolutions (``PLAUSIBLE``), that has scales without nulls, a singular
    soft-iron matrix, or a cross-axis term beyond 5 degrees, is refused, naming the key.  Outputs right
    to left: mag, accel, then gyro, so a filter whose hot inlet is the gyro sees a complete sample.

    The 12-bit ADC clips: ``range`` says once, when the patch starts, how far the accelerometer and the
    gyro read before an axis sticks at its rail (m/s², rad/s; the nearer rail of the least sensitive
    axis), so that a ``tqt`` wired to it knows a saturated axis rather than guessing.  The nulls are the
    calibration file's; without them, mid-scale less 5 % of the span (``RAIL_COUNTS``), for nulls a little
    off the middle: a rail is then said a little early, never late.  A misalignment mixes a little of the
    other axes into each: the range is cut by its largest row of cross-axis terms, for the same reason.
    """

    pure = True
    fusable = True

    #: Counts from the null to the nearer rail when the file gives no nulls.
    RAIL_COUNTS = ADC_NULL - 0.05 * ADC_MAX

    inlets = (Inlet("adc", ("vector", "list"), "nine counts relative to their nulls (from offset)"),)
    outlets = (
        Outlet("gyro", "vector", "angular rate, rad/s"),
        Outlet("accel", "vector", "specific force, m/s²"),
        Outlet("mag", "vector", "magnetic field, gauss"),
        Outlet("range", "list", "full scale: accelerometer m/s², gyro rad/s, once at start (to tqt's range)"),
    )
    params = (
        Param("gyro", "float", DEFAULT_RESOLUTION["gyro"], "gyro resolution", unit="deg/s per count"),
        Param(
            "accel", "float", DEFAULT_RESOLUTION["accel"], "accelerometer resolution", unit="m/s² per count"
        ),
        Param("mag", "float", DEFAULT_RESOLUTION["mag"], "magnetometer resolution", unit="gauss per count"),
        Param(
            "calibration",
            "path",
            "",
            "calibration file (per-axis scales, soft iron); overrides the above",
            reads=True,
        ),
    )

    def setup(self) -> None:
        self.soft_iron: tuple[float, ...] | None = None  # row major
        # cross-axis misalignments, row major; None for the identity (nothing to multiply)
        self.gyro_misalignment: tuple[float, ...] | None = None
        self.acc_misalignment: tuple[float, ...] | None = None
        factor = [math.radians(self.p.gyro)] * 3 + [self.p.accel] * 3 + [self.p.mag] * 3
        cal = None
        if self.p.calibration:
            cal = _load(self.p.calibration)
            nominal = []
            for i, sensor in enumerate(("gyro", "acc", "mag")):
                scale = getattr(cal, f"{sensor}_scale")
                # a scale of 1 is an axis the file does not calibrate (a gyro axis never turned): it keeps
                # its resolution, not 1 count per rad/s; an ellipsoid fit's matrix holds the mag's scales
                whole = sensor == "mag" and cal.mag_soft_iron is not None
                measured = [whole or scale[a] != 1.0 for a in range(3)]
                for a in range(3):
                    if measured[a]:
                        factor[3 * i + a] = 1.0 / float(scale[a])
                    elif any(measured):  # some axes of this sensor calibrated, not this one: say so
                        nominal.append(f"{sensor} {'xyz'[a]}")
            if cal.mag_soft_iron is not None:
                self.soft_iron = tuple(np.ravel(cal.mag_soft_iron).tolist())
            for sensor in ("gyro", "acc"):
                M = getattr(cal, f"{sensor}_misalignment")
                if not is_identity(M):
                    setattr(self, f"{sensor}_misalignment", tuple(np.ravel(M).tolist()))
            self._plausible(cal, factor)
            if nominal:
                log.warning(
                    "scaling '%s': %s has no scale for %s: the nominal resolution is used there",
                    self.name,
                    self.p.calibration,
                    ", ".join(nominal),
                )
        self.factor: tuple[float, ...] = tuple(float(f) for f in factor)
        self.full_scale = self._full_scale(cal)

    def _full_scale(self, cal: Calibration | None) -> tuple[float, float]:
        """(accelerometer, gyro): the reading at which the least sensitive axis of each sticks."""

        def nulls(n: Any) -> list[float]:
            n = np.asarray(n, dtype=float)
            if cal is not None and np.all((n > 0.0) & (n < ADC_MAX)):
                return n.tolist()
            return [self.RAIL_COUNTS] * 3  # a null that far from a rail is that far from the nearer one

        spec = MoteSpec(
            null=nulls(cal.gyro_null if cal else 0) + nulls(cal.acc_null if cal else 0) + [ADC_NULL] * 3,
            resolution=[abs(f) or 1.0 for f in self.factor[:6]] + [1.0] * 3,
        )
        # a sensor scaled by 0 reads 0 whatever the counts: no rail to tell (0, not known)
        acc, gyro = (
            min(adc_full_scale(s, spec)) if all(self.factor[i : i + 3]) else 0.0
            for s, i in (("accel", 3), ("gyro", 0))
        )

        def cut(M: tuple[float, ...] | None) -> float:
            """An axis at its rail, the others at theirs against it: short by its cross-axis terms."""
            if M is None:
                return 1.0
            return max(0.0, 1.0 - max(sum(abs(M[3 * i + j]) for j in range(3) if j != i) for i in range(3)))

        return acc * cut(self.acc_misalignment), gyro * cut(self.gyro_misalignment)

    def loadbang(self) -> None:
        self.out(3, self.full_scale)

    def fused_state(self) -> dict[str, Any]:
        """The factors and matrices (row major; None: the identity) a sample is scaled with
        (:mod:`pointat.compiled`): set when the node is built, never moved on."""
        return {
            "factor": self.factor,
            "soft_iron": self.soft_iron,
            "acc_misalignment": self.acc_misalignment,
            "gyro_misalignment": self.gyro_misalignment,
        }

    def restore_fused(self, state: Mapping[str, Any]) -> None:
        """Nothing to take back: the chain only reads them."""

    #: How far (a factor) a file's gyro or accelerometer scale may be from the nominal resolution's.
    PLAUSIBLE = 4.0

    def _plausible(self, cal: Calibration, factor: list[float]) -> None:
        """Refuse a file whose numbers would make the output garbage or silence
        (:func:`~pointat.maths.calibration.implausible`)."""
        resolution = {"gyro": math.radians(self.p.gyro), "acc": self.p.accel}
        problems = implausible(cal, factor, resolution, self.PLAUSIBLE)
        if problems:
            raise ValueError(f"calibration file {self.p.calibration}: " + "; ".join(problems))

    def on_adc(self, msg: Message) -> None:
        c, f = as_floats(msg, 9), self.factor
        mx, my, mz = c[6] * f[6], c[7] * f[7], c[8] * f[8]
        W = self.soft_iron
        if W is not None:
            mx, my, mz = (
                W[0] * mx + W[1] * my + W[2] * mz,
                W[3] * mx + W[4] * my + W[5] * mz,
                W[6] * mx + W[7] * my + W[8] * mz,
            )
        t = msg.time
        self.out(2, floats((mx, my, mz), t))
        M = self.acc_misalignment  # the identity is None: the sample goes as it did (a few ns more)
        if M is None:
            self.out(1, floats((c[3] * f[3], c[4] * f[4], c[5] * f[5]), t))
        else:
            x, y, z = c[3] * f[3], c[4] * f[4], c[5] * f[5]
            self.out(1, floats((M[0] * x + M[1] * y + M[2] * z, M[3] * x + M[4] * y + M[5] * z,
                                M[6] * x + M[7] * y + M[8] * z), t))  # fmt: skip
        M = self.gyro_misalignment
        if M is None:
            self.out(0, floats((c[0] * f[0], c[1] * f[1], c[2] * f[2]), t))
        else:
            x, y, z = c[0] * f[0], c[1] * f[1], c[2] * f[2]
            self.out(0, floats((M[0] * x + M[1] * y + M[2] * z, M[3] * x + M[4] * y + M[5] * z,
                                M[6] * x + M[7] * y + M[8] * z), t))  # fmt: skip


def _strength_spread(samples: np.ndarray, null: np.ndarray, scale: np.ndarray, W: Any) -> float:
    """95th percentile of how far the calibrated field's strength is from its median, relative."""
    u = (samples - null) / scale
    if W is not None:
        u = u @ np.asarray(W).T
    r = np.linalg.norm(u, axis=1)
    median = float(np.median(r))
    return float(np.percentile(np.abs(r / median - 1.0), 95)) if median > 0.0 else math.inf


def _integrated(samples: np.ndarray, dt: np.ndarray, axis: int, null: np.ndarray) -> float:
    """A gyro axis's output integrated over a turn (count-seconds): Eq. 31's sum, by :func:`gyro_scale`
    for a turn of 1 rad; 0 where the axis saw no rotation."""
    try:
        return gyro_scale(samples, dt, 1.0, axis, null=null)
    except ValueError:  # nothing integrated on this axis
        return 0.0


def _worst_cross_axis(M: np.ndarray) -> float:
    """The largest cross-axis term of a misalignment, in absolute value (NaN: infinite)."""
    off = np.abs(M[~np.eye(3, dtype=bool)])
    return float(off.max()) if np.all(np.isfinite(off)) else math.inf


def _cross_axis_terms(M: np.ndarray) -> list[float]:
    """A misalignment's six cross-axis terms, row by row (xy, xz, yx, yz, zx, zy), for the status."""
    return M[~np.eye(3, dtype=bool)].tolist()


@register("calibrate")
class Calibrate(Node):
    """Calibrate a mote by Bachmann et al.'s procedures (VRST 2001 §3.2.1), driven by messages.

    Feed it the raw counts continuously, then send, in any order (but ``rest`` before any turn, in the
    same run: nulls from the file are not taken, as a gyro's bias drifts from day to day):

    * ``rest``: hold still; the next ``samples`` samples give the gyro nulls (refused, with a
      ``moved`` status, when a gyro varied by more than ``still`` counts rms).
    * ``pose``: six times, with each accelerometer axis up and then down (any order), held still:
      accelerometer nulls and scales (Eqs. 29-30); refused, as ``rest``, when the glove moved.  The six
      also give the accelerometer's cross-axis misalignment (status ``acc_misalignment`` and its six
      cross-axis terms, before ``accel``), by a least-squares fit of nulls, scales and misalignment
      together: taken only when the poses agree with one another to ``POSE_SPREAD`` degrees (a jig or
      a box squared on a level table; a hand-held pose is degrees off, and its error would go into the
      misalignment) and no term is beyond 5 degrees; else ``acc_misalignment_refused`` (the log says
      why), and the nulls and scales of Eqs. 29-30 are taken with the misalignment the calibration had.
    * ``mag_begin`` ... turn the mote every way ... ``mag_end``: magnetometer nulls and scales from min/max,
      or a hard/soft-iron ellipsoid fit with ``mag_fit=ellipsoid`` (which needs less of the sphere).
      Refused, with a ``mag_refused`` status, when the field's strength still varies by more than 10 %
      once calibrated: the sweep missed directions, and its nulls would turn every heading.
    * ``turn_begin`` ... rotate by a known angle about one axis ... ``turn_end ANGLE AXIS`` (degrees,
      0/1/2 for x/y/z; a positive angle is counter-clockwise seen from the axis's tip): that gyro
      axis's scale (Eq. 31).  Refused when the glove turned mostly about another axis, or when the
      scale is more than 2x off the nominal ``gyro`` resolution's (the angle given is not the one turned).
      Once the three axes are turned in one run, the three turns together give the gyro's cross-axis
      misalignment and its scales (status ``gyro_misalignment`` and its six cross-axis terms, before
      ``gyro_scale``): each turn must be about the board's own axis (flat against a square edge), as a
      turn a degree off puts that degree into it; refused (``gyro_misalignment_refused``) beyond 5 degrees.
    * ``save`` (to ``file``, or ``save PATH``); ``load`` reads it back.  ``offset`` and ``scaling`` read
      the file through their ``calibration`` parameter.

    When ``file`` exists as the patch starts, the calibration starts from it (status ``loaded``): redo one
    step and ``save``, and the others stay as they were.  ``clear`` starts from no calibration.  A file
    that does not read (a hand edit gone wrong) is not replaced by ``save`` until ``clear`` is sent.
    """

    needs_input = True
    role = "output"

    #: How far (a factor) a gyro scale from a turn may be from the nominal ``gyro`` resolution's.
    TURN_FACTOR = 2.0
    #: How much the field's strength may still vary over the sweep once calibrated (95th percentile of
    #: its relative deviation): a full sweep leaves ~1 %, one that missed directions 30 %.
    MAG_SPREAD = 0.1
    #: How far (degrees, rms) the six poses may disagree with one another for the accelerometer's
    #: misalignment to be taken: it is about as far off as they disagree.  The glove's noise over 200
    #: samples leaves ~0.01 degrees; poses held by hand, a degree or more.
    POSE_SPREAD = 0.2

    inlets = (ADC,)
    outlets = (STATUS,)
    params = (
        Param(
            "file",
            "path",
            "calibration.json",
            "where save and load go; read at start when there",
            reads=True,
            writes=True,
            optional=True,
        ),
        Param("samples", "int", 200, "samples averaged per rest or pose", minimum=2),
        Param(
            "mag_fit",
            "symbol",
            "minmax",
            "minmax (Bachmann) or ellipsoid (hard and soft iron)",
            choices=("minmax", "ellipsoid"),
        ),
        Param("gravity", "float", 9.80665, "local gravity", unit="m/s²", above=0.0),
        Param(
            "gyro",
            "float",
            DEFAULT_RESOLUTION["gyro"],
            "the gyro's nominal resolution: a turn giving a scale 2x off it is refused",
            unit="deg/s per count",
            above=0.0,
        ),
        Param(
            "still",
            "float",
            10.0,
            "rest and pose: refused when a gyro varied by more (rms; 0: never)",
            unit="counts",
            minimum=0.0,
        ),
    )

    def describe(self) -> str:
        return f"calibration, writes {self.p.file} (steps by OSC: /pointat/{self.name}/rest ...)"

    def setup(self) -> None:
        self.calibration = Calibration()
        self.poses: list[np.ndarray] = []
        self._collect: str | None = None
        self._turned = False  # a turn ended and no scale taken from it yet: turn_end may be sent again
        self._buf: list[np.ndarray] = []
        self._times: list[float] = []
        self._rested = False  # gyro nulls taken in this run (a file's may be days old: the bias drifts)
        self._unread: str | None = None  # the file, when it was there but did not read at the start
        # counts per rad/s seen on the three gyro axes in this run's turn about each axis (the columns of
        # the gyro's sensitivity matrix), for its misalignment once all three are there
        self._columns: dict[int, np.ndarray] = {}

    def health(self) -> dict[str, Any]:
        """The step under way, or what the next could be, for the console and the monitor."""
        if self._collect is not None:
            return {"step": f"{self._collect}: {len(self._buf)} samples"}
        done = ["gyro nulls"] if self._rested else []
        done += [f"{len(self.poses)} poses"] if self.poses else []
        return {
            "step": f"waiting for a step (/pointat/{self.name}/rest, pose, mag_begin, turn_begin, save)",
            "done": ", ".join(done) or "nothing yet",
        }

    @classmethod
    def check_files(cls, values: Mapping[str, Any]) -> None:
        """``file`` is read at start when there (:meth:`loadbang`): a pipe, a device or a file far too
        large is refused before the show (a spoilt file only warns there: the node starts from nothing)."""
        path = str(values["file"])
        if path and os.path.exists(path):
            read_bytes(path, "calibration")

    def loadbang(self) -> None:
        """Start from the calibration already in ``file``: a step taken again replaces its part, and
        ``save`` keeps the rest (redoing the gyro nulls the next day must not wipe the accelerometer's)."""
        path = self.p.file
        clean_stray(path)  # a save a kill cut short
        if not os.path.exists(path):
            return
        try:
            self.calibration = _load(path)
        except ValueError as exc:
            self._unread = path
            log.warning(
                "calibrate '%s': %s; starting from no calibration (save refuses to replace the file until"
                " clear is sent)",
                self.name,
                exc,
            )
            return
        log.info("calibrate '%s': starting from %s (clear: from nothing)", self.name, path)
        self.out(0, ("loaded", path))

    def do_clear(self) -> None:
        """Start from no calibration at all (the file is not touched until ``save``)."""
        self.calibration = Calibration()
        self.poses = []
        self._rested = False
        self._unread = None
        self._columns = {}
        self.out(0, ("cleared",))

    def _start(self, what: str) -> None:
        self._collect, self._buf, self._times, self._turned = what, [], [], False
        self.out(0, ("collecting", what))

    def do_rest(self) -> None:
        self._start("rest")

    def do_pose(self) -> None:
        if len(self.poses) >= 6:
            self.poses = []
        self._start("pose")

    def _six_poses(self) -> None:
        """The accelerometer's nulls and scales from six poses; when two of them point the same way, the
        later one is dropped and the log says which direction is still to come."""
        m = np.array(self.poses)
        try:
            null, scale = six_position_accel(m, self.p.gravity)
        except ValueError as exc:
            used = set(np.argmax(m, axis=0).tolist()) | set(np.argmin(m, axis=0).tolist())
            again = [k for k in range(6) if k not in used] or [5]
            self.poses = [p for k, p in enumerate(self.poses) if k not in again]
            self.out(0, ("poses_refused", len(self.poses), 6))
            log.warning(
                "calibrate '%s': the six poses do not point each accelerometer axis both up and down (%s):"
                " pose %s dropped; %d kept: point the axis direction still missing and send pose again",
                self.name,
                exc,
                ", ".join(str(k + 1) for k in again),
                len(self.poses),
            )
            return
        try:
            fit = six_position_misalignment(m, self.p.gravity)
            spread, worst = math.degrees(fit.residual), _worst_cross_axis(fit.misalignment)
            if spread > self.POSE_SPREAD:
                raise ValueError(
                    f"the six poses disagree by {spread:.2f} deg rms (more than {self.POSE_SPREAD:g}): they"
                    " were not each straight up and down (a jig, or a box squared on a level table)"
                )
            if worst > MISALIGNMENT_LIMIT:
                raise ValueError(
                    f"a cross-axis term of {math.degrees(worst):.1f} deg, more than"
                    f" {math.degrees(MISALIGNMENT_LIMIT):.0f}: the poses were not about the board axes"
                )
        except ValueError as exc:
            self.out(0, ("acc_misalignment_refused",))
            log.warning(
                "calibrate '%s': %s: the accelerometer's misalignment is not taken (the one the calibration"
                " had is kept); the nulls and scales are (Eqs. 29-30)",
                self.name,
                exc,
            )
        else:
            null, scale = fit.null, fit.scale
            self.calibration.acc_misalignment = fit.misalignment
            self.out(0, ("acc_misalignment", *_cross_axis_terms(fit.misalignment)))
        self.calibration.acc_null, self.calibration.acc_scale = null, scale
        self.out(0, ("accel", *null.tolist(), *scale.tolist()))

    def do_mag_begin(self) -> None:
        self._start("mag")

    def do_turn_begin(self) -> None:
        self._need_rest("turn_begin")
        self._start("turn")

    def _need_rest(self, what: str) -> None:
        if not self._rested:  # nulls loaded from the file do not count: the bias drifts from day to day
            raise ValueError(
                f"{what}: the gyro nulls of this run are not known yet (the turn is integrated from them):"
                " send rest first and hold still, then turn"
            )

    def do_mag_end(self) -> None:
        samples = self._take("mag")[:, 6:9]
        if len(samples) < 10:
            raise ValueError(f"mag_end: only {len(samples)} samples since mag_begin; turn the mote longer")
        if self.p.mag_fit == "ellipsoid":
            null, W = ellipsoid_fit(samples)
            scale = np.ones(3)
        else:
            (null, scale), W = minmax_magnetometer(samples), None
        # calibrated, the field's strength is the same whichever way the mote points: where it is not,
        # the sweep missed directions (min/max then puts the nulls off centre) and the file would turn
        # every heading; refused, the calibration stays as it was
        spread = _strength_spread(samples, null, scale, W)
        if not spread <= self.MAG_SPREAD:
            self.out(0, ("mag_refused", round(100.0 * spread, 1)))
            hint = (
                ""
                if W is not None
                else ", or fit an ellipsoid (mag_fit=ellipsoid), which needs less of the sphere"
            )
            raise ValueError(
                f"mag_end: the sweep did not cover enough directions: calibrated with it, the field's strength"
                f" still varies by {100.0 * spread:.0f} % (a good sweep: a few %); nulls not taken. Send"
                f" mag_begin again and turn the mote every way, upside down too{hint}"
            )
        cal = self.calibration
        cal.mag_null, cal.mag_scale, cal.mag_soft_iron = null, scale, W
        self.out(0, ("mag", *self.calibration.mag_null.tolist()))

    def do_turn_end(self, angle_deg: Any = 90.0, axis: Any = 2) -> None:
        try:
            angle, ax = float(angle_deg), int(axis)
        except (TypeError, ValueError):
            angle, ax = math.nan, -1
        if not (math.isfinite(angle) and angle != 0.0 and ax in (0, 1, 2)):
            raise ValueError(
                f"turn_end takes ANGLE_DEG (the degrees turned, not 0) and AXIS (0, 1 or 2: x, y, z); got"
                f" {angle_deg!r} {axis!r}; the turn is kept: send turn_end again"
            )
        if self._collect == "turn":  # the turn is kept until a scale is taken from it or another step begins,
            self._collect, self._turned = None, True  # so that a refused turn_end can be sent again
        if not self._turned:
            raise ValueError("turn_end without turn_begin")
        samples = np.array(self._buf).reshape(-1, 9)
        if len(samples) < 2:
            raise ValueError("turn_end: no samples since turn_begin")
        self._need_rest("turn_end")
        dt = np.diff(self._times, prepend=self._times[0] - (self._times[1] - self._times[0]))
        null = self.calibration.gyro_null
        integrals = [_integrated(samples[:, 0:3], dt, a, null) for a in range(3)]  # count-seconds
        turned = [abs(x) for x in integrals]
        most = max(range(3), key=turned.__getitem__)
        if most != ax and turned[most] > 2.0 * turned[ax]:
            raise ValueError(
                f"turn_end: the glove turned mostly about {'xyz'[most]} ({turned[most]:.0f} count-seconds,"
                f" against {turned[ax]:.0f} about {'xyz'[ax]}), not about the axis given: scale not taken;"
                f" send turn_end {angle:g} {most} if that was the turn, or turn again"
            )
        scale = gyro_scale(samples[:, 0:3], dt, math.radians(angle), ax, null=null)
        nominal = 180.0 / (math.pi * self.p.gyro)  # counts per rad/s
        off = max(abs(scale) / nominal, nominal / max(abs(scale), 1e-9))  # a factor, >= 1
        if off > self.TURN_FACTOR:
            raise ValueError(
                f"turn_end: the turn gives {abs(scale):.1f} counts per rad/s, {off:.1f}"
                f" times off the gyro's nominal {nominal:.0f} (gyro={self.p.gyro:g} deg/s per count):"
                f" the angle given ({angle:g} deg) is not the one turned, or the glove hardly"
                f" turned between turn_begin and turn_end: scale not taken; turn again"
            )
        if not scale > 0.0:
            raise ValueError(
                f"turn_end: the glove turned the other way ({angle:g} deg about {'xyz'[ax]} means"
                f" counter-clockwise seen from the axis's tip, right-hand rule): scale not taken; turn again"
                f" (or send turn_end {-angle:g} {ax} after a turn that way)"
            )
        self.calibration.gyro_scale[ax] = scale
        self._turned = False
        self._columns[ax] = np.array(integrals) / math.radians(angle)  # (Eq. 31 on each axis)
        if len(self._columns) == 3:
            self._gyro_misalignment()
        self.out(0, ("gyro_scale", ax, float(self.calibration.gyro_scale[ax])))

    def _gyro_misalignment(self) -> None:
        """The gyro's scales and misalignment from this run's three turns, when they are plausible."""
        A = np.column_stack([self._columns[k] for k in range(3)])
        try:
            scale, M = gyro_misalignment(A)
            worst = _worst_cross_axis(M)
            if worst > MISALIGNMENT_LIMIT:
                raise ValueError(
                    f"a cross-axis term of {math.degrees(worst):.1f} deg, more than"
                    f" {math.degrees(MISALIGNMENT_LIMIT):.0f}: the turns were not about the board axes"
                    " (turn flat on a table, against a square edge)"
                )
            if np.any(scale <= 0.0):
                raise ValueError(f"a negative scale {scale.tolist()}")
        except ValueError as exc:
            self.out(0, ("gyro_misalignment_refused",))
            log.warning(
                "calibrate '%s': the three turns give no gyro misalignment (%s): the one the calibration"
                " had is kept; the scales of each turn are taken (Eq. 31)",
                self.name,
                exc,
            )
            return
        self.calibration.gyro_scale, self.calibration.gyro_misalignment = scale, M
        self.out(0, ("gyro_misalignment", *_cross_axis_terms(M)))

    @names_path
    def do_save(self, path: Any = None) -> None:
        target = str(path) if path is not None else self.p.file
        if self._unread is not None and os.path.realpath(target) == os.path.realpath(self._unread):
            raise ValueError(
                f"save: {target} did not read at the start (see the warning then), and what it holds"
                " would be lost: mend it and send load, send clear to replace it, or save PATH elsewhere"
            )
        self.calibration.save(target)
        self.out(0, ("saved", target))

    @names_path
    def do_load(self, path: Any = None) -> None:
        target = str(path) if path is not None else self.p.file
        self.calibration = _load(target)
        self._unread = None
        self._columns = {}
        self.out(0, ("loaded", target))

    def _take(self, what: str) -> np.ndarray:
        if self._collect != what:
            raise ValueError(f"{what}_end without {what}_begin")
        self._collect = None
        return np.array(self._buf).reshape(-1, 9)

    def on_adc(self, msg: Message) -> None:
        if self._collect is None:
            return
        counts = as_vector(msg, 9)
        self._buf.append(counts.copy())
        self._times.append(msg.time)
        if self._collect in ("rest", "pose") and len(self._buf) >= self.p.samples:
            data = np.array(self._buf)
            what, self._collect = self._collect, None
            spread = data[:, 0:3].std(axis=0)
            if self.p.still and spread.max() > self.p.still:
                axis = "xyz"[int(spread.argmax())]
                self.out(0, ("moved", axis, round(float(spread.max()), 1)))
                # a refusal, not a bad sample: logged as such (an error here read as data dropped)
                log.warning(
                    "calibrate '%s': %s: the glove moved (gyro %s varied by %.1f counts rms, more than"
                    " still=%g): %s not taken; hold it still and send %s again",
                    self.name,
                    what,
                    axis,
                    spread.max(),
                    self.p.still,
                    "nulls" if what == "rest" else "pose",
                    what,
                )
                return
            if what == "rest":
                self.calibration.gyro_null = gyro_null(data[:, 0:3])
                self._rested = True
                self.out(0, ("rest", *self.calibration.gyro_null.tolist()))
            else:
                self.poses.append(data[:, 3:6].mean(axis=0))
                self.out(0, ("pose", len(self.poses), 6))
                if len(self.poses) == 6:
                    self._six_poses()
