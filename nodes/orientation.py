"""Orientation nodes: Torre et al.'s chain and the McGhee/Bachmann quaternion filter.

The math is in :mod:`pointat.maths`; these nodes only move messages.  Orientations travel as one vector:
a quaternion ``(w, x, y, z)`` or a 3x3 rotation matrix, mapping sensor to earth (NWU: x north or the
reference direction, y west, z up).  Rates are rad/s, accelerations m/s², fields any unit.

Filters take their time step from the messages' time stamps (sensor time), falling back to ``1/rate``
for the first sample and for gaps over a second.  A bad sample (zero or NaN vector, a gyro rate of
100 rad/s or more: :data:`~pointat.maths.scalar.MAX_RATE`) leaves a filter's state as it was and is
reported on its ``flags`` outlet; nothing downstream ever sees NaN.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import logging
import math
from collections.abc import Mapping
from functools import partial
from typing import Any, ClassVar

import numpy as np

from pointat.errors import worth_reporting
from pointat.maths import scalar as sq
from pointat.maths.calibration import STANDARD_GRAVITY
from pointat.maths.fusion import GyroIntegrator, RollDistance
from pointat.maths.quaternion import (
    enu_to_nwu,
    ned_to_nwu,
    nwu_to_enu,
    nwu_to_ned,
    quat_identity,
)
from pointat.maths.tqt import TQTBank, TQTFilter, TQTFlags
from pointat.message import Message, as_floats, floats, vector
from pointat.node import Inlet, Node, Outlet, Param
from pointat.registry import register

log = logging.getLogger("pointat.nodes.orientation")

ORIENTATION = ("vector", "list")


def _as_quat(msg: Message) -> sq.Quat:
    """A unit quaternion (floats) from a quaternion or a rotation-matrix message; NaN is an error."""
    values = msg.value
    n = len(values) if msg.kind == "vector" else 0
    if n != 4 and n != 9:  # a list, or the wrong size: converted, or the error that says so
        values = as_floats(msg, 4, 9)
        n = len(values)
    if n == 4:
        w, x, y, z = values
        if abs(w * w + x * x + y * y + z * z - 1.0) <= 1e-15:  # unit already (every node's output): as is
            return values  # (False for NaN and infinity, which go on to the error below)
    if not math.isfinite(sum(values)):  # any NaN or infinity makes the sum one
        raise ValueError("orientation has NaN or infinite values")
    return _matrix_quat(values) if n == 9 else sq.normalize(values)


def _matrix(q: sq.Quat, time: float) -> Message:
    return floats(sq.quat_matrix(q), time)


def _matrix_quat(m: tuple[float, ...]) -> sq.Quat:
    """:func:`~pointat.maths.scalar.matrix_quat` of finite ``m``."""
    return sq.matrix_quat(m)


class SampleClock:
    """Time steps from message time stamps, with ``1/rate`` when there is no usable previous stamp."""

    MAX_GAP = 1.0
    _last_t: float | None = None  # (a class default: a node that never called reset_clock has none)

    def reset_clock(self) -> None:
        self._last_t = None

    def step(self, t: float) -> float:
        last, self._last_t = self._last_t, t
        return time_step(last, t, 1.0 / self.p.rate, self.MAX_GAP)


def time_step(last: float | None, t: float, nominal: float, max_gap: float) -> float:
    """:func:`pointat.maths.scalar.time_step`, ``None`` for no previous stamp."""
    return sq.time_step(math.nan if last is None else last, t, nominal, max_gap)


class Flagged:
    """Report a filter's status on its ``flags`` outlet when it changes (``ok`` when all is well)."""

    FLAGS_OUTLET = 1
    _status = "ok"

    def report(self, status: str) -> None:
        if status != self._status:
            self._status = status
            self.out(self.FLAGS_OUTLET, status)


POLE = Param(
    "pole", "float", 1.0, "within this angle of straight up/down the azimuth holds", unit="deg", minimum=0.0
)


def _check_pole(pole: float) -> None:
    if not pole < 90.0:
        raise ValueError(f"pole must be >= 0 and < 90 deg, got {pole}")


RATE = Param("rate", "float", 100.0, "nominal sample rate, for the first step and gaps", unit="Hz", above=0.0)
FLAGS = Outlet("flags", "symbol", "status when it changes: ok, or what was wrong (bad_gyro, bad_accmag...)")


@register("gyro_integrator")
class GyroIntegratorNode(SampleClock, Flagged, Node):
    """Integrate the gyro rates into an orientation matrix (Torre §3.2).

    ``mode=torre``: the paper's incremental rotation R(w)·R(v)·R(u) per sample; ``mode=exact``: the
    axis-angle exponential map.  The matrix is re-orthonormalised every ``renormalize`` samples so it
    stays a rotation over hours.  ``reset`` (or a matrix / quaternion at the right inlet) restarts it.
    """

    pure = True

    inlets = (
        Inlet("gyro", ("vector", "list"), "angular rate, rad/s, sensor frame"),
        Inlet("orientation", ORIENTATION, "set the orientation (matrix or quaternion)"),
    )
    outlets = (Outlet("orientation", "vector", "3x3 rotation matrix, sensor -> earth"), FLAGS)
    params = (
        Param(
            "mode",
            "symbol",
            "torre",
            "torre (the paper's product of axis rotations) or exact",
            choices=("torre", "exact"),
            live=True,
        ),
        Param("renormalize", "int", 100, "re-orthonormalise every N samples", minimum=1),
        RATE,
    )

    def setup(self) -> None:
        self.integrator = GyroIntegrator(mode=self.p.mode, renormalize_every=self.p.renormalize)
        self.reset_clock()

    def param_changed(self, name: str) -> None:
        self.integrator = GyroIntegrator(
            self.integrator.R, mode=self.p.mode, renormalize_every=self.p.renormalize
        )

    def on_gyro(self, msg: Message) -> None:
        wx, wy, wz = as_floats(msg, 3)
        try:  # the integrator refuses a NaN, infinite or glitched rate (MAX_RATE); self.step's dt is good
            R = self.integrator.step(wx, wy, wz, self.step(msg.time))
            self.report("ok")
        except ValueError:
            self.report("bad_gyro")
            R = self.integrator.flat
        self.out(0, floats(R, msg.time))

    def on_orientation(self, msg: Message) -> None:
        self.integrator.reset(np.reshape(sq.quat_matrix(_as_quat(msg)), (3, 3)))

    def do_reset(self) -> None:
        self.integrator.reset()
        self.reset_clock()


@register("accmag_matrix")
class AccMagMatrix(Flagged, Node):
    """The orientation matrix from gravity and the Earth's magnetic field (Torre §3.3, corrected).

    TRIAD: up from the accelerometer, west = up x field, north = west x up.  Unlike the paper's matrix
    it is a proper rotation whatever the magnetic dip.  Zero, NaN or parallel vectors output nothing and
    raise ``bad_accmag`` on ``flags``.

    The matrix is only right while the hand does not accelerate and the field is the Earth's.  Beyond the
    paper, samples are therefore skipped (``accelerating`` / ``mag_disturbed`` on ``flags``) when |accel|
    is off g by more than ``accel_tolerance``, or the field's strength or dip is off its reference (learned
    from the samples accepted so far) by more than ``mag_tolerance`` or ``dip_tolerance``; a fusion node
    downstream then rides on the gyro.  A tolerance of 0 turns that check off.
    """

    pure = True

    inlets = (
        Inlet("accel", ("vector", "list"), "specific force (+g up at rest), sensor frame"),
        Inlet("mag", ("vector", "list"), "magnetic field, sensor frame"),
    )
    outlets = (Outlet("orientation", "vector", "3x3 rotation matrix, sensor -> earth (NWU)"), FLAGS)
    params = (
        Param("gravity", "float", 9.80665, "the accelerometer's reading at rest", unit="m/s²", above=0.0),
        Param(
            "accel_tolerance",
            "float",
            0.1,
            "skip when | |accel| - g | > this x g (0: never)",
            live=True,
            minimum=0.0,
        ),
        Param(
            "mag_tolerance",
            "float",
            0.1,
            "skip when |field| is off its reference by this fraction (0: never)",
            live=True,
            minimum=0.0,
        ),
        Param(
            "dip_tolerance",
            "float",
            5.0,
            "skip when the dip is off its reference by more (0: never)",
            unit="deg",
            live=True,
            minimum=0.0,
        ),
    )

    #: How fast the field's reference strength and dip follow accepted samples (per sample).
    LEARN = 0.001

    def setup(self) -> None:
        self._norm_ref: float | None = None
        self._dip_ref = 0.0

    def on_accel(self, msg: Message) -> None:
        mag = self.cold.get("mag")
        if mag is None:
            self.report("bad_accmag")
            return
        triad = sq.accmag_triad(as_floats(msg, 3), as_floats(mag, 3))
        if triad is None:
            self.report("bad_accmag")
            return
        C, na, nm, sin_dip = triad
        p = self.p
        if p.accel_tolerance and abs(na - p.gravity) > p.accel_tolerance * p.gravity:
            self.report("accelerating")
            return
        dip = math.degrees(math.asin(sin_dip))
        if self._norm_ref is None:
            self._norm_ref, self._dip_ref = nm, dip
        elif (p.mag_tolerance and abs(nm - self._norm_ref) > p.mag_tolerance * self._norm_ref) or (
            p.dip_tolerance and abs(dip - self._dip_ref) > p.dip_tolerance
        ):
            self.report("mag_disturbed")
            return
        self._norm_ref += self.LEARN * (nm - self._norm_ref)
        self._dip_ref += self.LEARN * (dip - self._dip_ref)
        self.report("ok")
        self.out(0, floats(C, msg.time))


@register("complementary")
class Complementary(SampleClock, Flagged, Node):
    """Fuse the gyro orientation (short term) with the accel/mag orientation (long term), on rotations.

    Each gyro orientation's change since the previous one is applied to the estimate, which is then
    pulled toward the accel/mag orientation by slerp with alpha = dt/(tau + dt), tau = 1/(2 pi crossover):
    a first-order complementary pair crossing at ``crossover`` Hz (Torre §3: "short-term precision of the
    gyroscopes with the long-term precision of accelerometers and magnetometers").
    """

    pure = True

    inlets = (
        Inlet("gyro_orientation", ORIENTATION, "orientation from gyro_integrator (matrix or quaternion)"),
        Inlet("accmag", ORIENTATION, "orientation from accmag_matrix (matrix or quaternion)"),
    )
    outlets = (Outlet("orientation", "vector", "fused 3x3 rotation matrix, sensor -> earth"), FLAGS)
    params = (
        Param(
            "crossover",
            "float",
            0.2,
            "crossover frequency of the complementary pair",
            unit="Hz",
            live=True,
            above=0.0,
        ),
        RATE,
    )
    example = """
node gyro gyro_integrator
node am   accmag_matrix
node fuse complementary crossover=0.2
gyro -> fuse.gyro_orientation
am -> fuse.accmag
"""

    def setup(self) -> None:
        self.q: sq.Quat | None = None
        self._prev_gyro: sq.Quat | None = None
        self.reset_clock()

    def on_gyro_orientation(self, msg: Message) -> None:
        g = _as_quat(msg)
        dt = self.step(msg.time)
        am_msg = self.cold.pop("accmag", None)
        am = _as_quat(am_msg) if am_msg is not None else None
        if self.q is None:
            if am is None:
                self.report("waiting_accmag")
                self._prev_gyro = g
                return
            self.q = am
        elif self._prev_gyro is not None:
            delta = sq.multiply(sq.conjugate(self._prev_gyro), g)  # body-frame increment
            self.q = sq.normalize(sq.multiply(self.q, delta))
        self._prev_gyro = g
        if am is not None:
            tau = 1.0 / (2.0 * math.pi * self.p.crossover)
            self.q = sq.slerp(self.q, am, dt / (tau + dt))  # unit, along the shorter arc
            self.report("ok")
        else:
            self.report("gyro_only")
        self.out(0, _matrix(self.q, msg.time))

    def do_reset(self) -> None:
        self.setup()


@register("tqt")
class TQT(SampleClock, Flagged, Node):
    """McGhee/Bachmann's quaternion MARG filter: gyro rates corrected by gravity and the magnetic field.

    Gauss-Newton correction with the reduced 3x3 X matrix (Bachmann patent Eq. 29), gain ``k`` (errors
    decay as e^(-k t)), magnetometer weight ``rho``.  ``mode=paper`` is the seeds' filter exactly (glitches
    aside); ``mode=robust`` (default) corrects heading only from the magnetometer, learns the gyro bias
    while the glove rests, averages gravity in the room's frame over 2 s and ignores a disturbed field.

    Strikes, shakes and drumming: the gravity average takes every reading a hand can make (only a
    corrupt one, NaN or a thousand g, is dropped), and a hand's pushes and pulls cancel in it, so hard
    strokes do not tip the sound.  When an axis clips at its full scale the reading is wrong, so that
    whole stretch of motion is left out of the average (never only the clipped peaks, which would tip
    it) and the gyro carries the orientation through it.  A gyro that clips (a turn faster than it
    measures) leaves the orientation behind the hand: the flag says so, and gravity and the field bring
    it back at the usual pace (a quicker catch-up made real recordings worse).  To know a clipped axis
    the filter needs the sensor's full scale: wire a ``range`` outlet to the ``range`` inlet
    (``scaling``'s knows the glove's ADC; ``replay``'s and ``osc_in``'s send the ``acc_range`` and
    ``gyro_range`` you give them from the sensor's data sheet), or set ``acc_range`` and ``gyro_range``.
    ``flags`` says ``acc_saturated``, ``gyro_saturated`` and ``shaking`` while they last (and
    ``mag_disturbed``, ``bad_gyro``..., or ``ok``).

    ``use_gyro=false`` tracks from accel/mag alone, heading and tilt at gain ``k`` (robust default 50:
    within 20 ms of the measurement).  Send the gyro last (the left inlet is hot): mote and scaling
    nodes output right to left, so wiring gyro, accel and mag outlets to the same-named inlets does this.

    ``backend=auto`` runs robust mode's step compiled by numba where it is installed (one call a sample,
    the same results as ``backend=python``'s step in Python, several times sooner); the patch loads it
    as it loads.
    """

    pure = True

    inlets = (
        Inlet("gyro", ("vector", "list"), "angular rate, rad/s, sensor frame"),
        Inlet("accel", ("vector", "list"), "specific force (+g up at rest), sensor frame"),
        Inlet("mag", ("vector", "list"), "magnetic field, sensor frame"),
        Inlet(
            "range",
            ("list",),
            "full scale per axis, accelerometer then gyro, in the accel and gyro inlets' units (scaling.range)",
        ),
    )
    outlets = (Outlet("quat", "vector", "orientation quaternion (w, x, y, z), sensor -> earth (NWU)"), FLAGS)
    params = (
        Param(
            "mode",
            "symbol",
            "robust",
            "robust (default) or paper (the seeds' filter)",
            choices=("robust", "paper"),
        ),
        Param(
            "k",
            "float",
            0.0,
            "gravity-correction gain (0: the mode's default: robust 0.5, without gyro 50; paper 0.1)",
            unit="1/s",
            live=True,
            minimum=0.0,
        ),
        Param("rho", "float", 0.5, "magnetometer weight (paper mode)", live=True, minimum=0.0),
        Param("iterations", "int", 1, "Gauss-Newton cycles per sample (paper mode)", minimum=1),
        Param("use_gyro", "bool", True, "false: accel/mag-only tracking"),
        Param(
            "k_heading",
            "float",
            0.05,
            "heading-correction gain (robust mode)",
            unit="1/s",
            live=True,
            minimum=0.0,
        ),
        Param(
            "k_heading_unrested",
            "float",
            0.1,
            "heading-correction gain before the sensor has rested long enough to know its gyro's bias (robust mode)",
            unit="1/s",
            live=True,
            minimum=0.0,
        ),
        Param("dip", "float", float("nan"), "magnetic dip; NaN: learned from the first sample", unit="deg"),
        Param(
            "acc_range",
            "float",
            0.0,
            "accelerometer full scale per axis, for accel in m/s² (0: not known; the range inlet sets it too)",
            unit="g",
            live=True,
            minimum=0.0,
        ),
        Param(
            "gyro_range",
            "float",
            0.0,
            "gyro full scale per axis (0: not known; the range inlet sets it too)",
            unit="deg/s",
            live=True,
            minimum=0.0,
        ),
        RATE,
        Param(
            "backend",
            "symbol",
            "auto",
            "auto (numba when installed and mode=robust), numba or python: the same results",
            choices=("auto", "numba", "python"),
        ),
    )
    example = """
node glove simulate
node nulls offset samples=150
node cal   scaling
node fuse  tqt mode=robust
node state print prefix=glove
glove -> nulls -> cal
cal.range -> fuse.range
cal.gyro -> fuse.gyro
cal.accel -> fuse.accel
cal.mag -> fuse.mag
fuse.flags -> state
"""

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        """The ranges the filter's settings mean something in (at load, and for every live change)."""
        if not (math.isnan(values["dip"]) or -90.0 <= values["dip"] <= 90.0):
            raise ValueError(f"dip must be -90..90 deg (or nan: learned), got {values['dip']}")
        if values["backend"] == "numba" and values["mode"] != "robust":
            raise ValueError("backend=numba runs mode=robust only (paper: backend=python or auto)")
        # find_spec, not an import: numba costs a quarter of a second and ~50 MB to import, which a patch
        # pays only when it builds a filter or a bank that runs it
        if values["backend"] == "numba" and importlib.util.find_spec("numba") is None:
            raise ValueError('backend=numba needs numba: pip install "pointat[fast]" (or backend=auto)')

    def setup(self) -> None:
        self.filter = TQTFilter(self.p.k or None, backend=self.p.backend, **_settings(self.p))
        self._bits = 0  # the flags last reported ("ok" until a flag is up)
        self.reset_clock()

    def param_changed(self, name: str) -> None:
        _retune(self.filter, self.p, name)

    def on_range(self, msg: Message) -> None:
        acc, gyro = as_floats(msg, 2)
        self.filter.retune(acc_range=acc, gyro_range=gyro)  # (refuses what the constructor refuses)

    def health(self) -> dict[str, Any]:
        """Rest and bias learning (robust mode), and the magnetic dip learned, for the monitor."""
        f = self.filter
        bits = f.flag_bits
        bias = math.degrees(math.sqrt(sum(b * b for b in f.bias)))
        dip = f.magnetic_dip
        return {
            "resting": bool(bits & TQTFlags.REST),
            "bias_dps": round(bias, 3),
            "bias_learned_s": round(f.bias_seconds, 1),
            "dip_deg": None if dip is None else round(math.degrees(dip), 1),
        }

    def on_gyro(self, msg: Message) -> None:
        gyro = as_floats(msg, 3)
        acc, mag = self.cold.get("accel"), self.cold.get("mag")
        nan3 = (math.nan, math.nan, math.nan)
        q = self.filter.update(
            gyro,
            as_floats(acc, 3) if acc is not None else nan3,
            as_floats(mag, 3) if mag is not None else nan3,
            self.step(msg.time),
        )
        self.tell_flags(self.filter.flag_bits & _NOT_REST)
        if self.filter.initialised:
            self.out(0, floats(q, msg.time))

    def tell_flags(self, bits: int) -> None:
        """The filter's flag bits (rest apart) of this sample: the status text only when they change
        (:mod:`pointat.fusion` tells them too)."""
        if bits != self._bits:
            self._bits = bits
            self.report("ok" if not bits else _status(bits))

    def do_reset(self) -> None:
        self.filter.reset()
        self.reset_clock()


_NOT_REST = ~int(TQTFlags.REST)  # resting is normal, not a status to report


def _settings(p: Any) -> dict[str, Any]:
    """The filter's keyword settings from a ``tqt`` or ``tqt_bank`` node's parameters (its ``k`` apart:
    0 there is the mode's own), full scales from g and deg/s into m/s² and rad/s."""
    return {
        "rho": p.rho,
        "iterations": p.iterations,
        "mode": p.mode,
        "use_gyro": p.use_gyro,
        "dip": None if math.isnan(p.dip) else math.radians(p.dip),
        "k_heading": p.k_heading,
        "k_heading_unrested": p.k_heading_unrested,
        "acc_range": p.acc_range * STANDARD_GRAVITY,
        "gyro_range": math.radians(p.gyro_range),
    }


def _retune(target: TQTFilter | TQTBank, p: Any, name: str) -> None:
    """A ``tqt`` or ``tqt_bank`` node's live parameter ``name`` changed: into its filter, in the filter's
    units (``k`` 0: the mode's own gain, live as at load)."""
    if name == "k":
        target.retune(k=p.k or target.default_k(p.mode, p.use_gyro))
    elif name in ("acc_range", "gyro_range"):
        target.retune(**{name: _settings(p)[name]})
    else:
        target.retune(**{name: getattr(p, name)})


#: (bit, name) of every flag, lowest bit first: the order the ``flags`` outlet names them in.
_FLAG_NAMES = tuple((int(f), f.name.lower()) for f in TQTFlags.__members__.values() if int(f))


def _status(bits: int) -> str:
    """``uninitialised,mag_disturbed``: the flags that are up, as the ``flags`` outlet reports them.

    Read bit by bit, not from the flag's ``name`` or ``str``, which differ between Python 3.10 and 3.11+.

    >>> _status(TQTFlags.MAG_DISTURBED | TQTFlags.UNINITIALISED)
    'uninitialised,mag_disturbed'
    """
    return ",".join(name for bit, name in _FLAG_NAMES if bits & bit)


_NAN3 = (math.nan, math.nan, math.nan)


@register("tqt_bank")
class TQTBankNode(Node):
    """The ``tqt`` filter for many sensors at once (a body suit, several gloves): one update for all.

    ``sensors=N`` gives sensor ``I`` (1..N) the inlets ``gyroI``, ``accelI`` and ``magI`` (as ``tqt``'s:
    send the gyro last, it is the hot one) and the outlet ``quatI``, after the two outlets every bank has:
    ``quats`` and ``flags``.  When every sensor has sent its gyro, all of them are updated together by
    :class:`pointat.maths.tqt.TQTBank`, one compiled loop over the sensors with numba (``pip install
    "pointat[fast]"``, robust mode); each ``quatI`` sends its sensor's orientation, right to left, then
    ``quats`` all of them as one vector (4N numbers, sensor 1 first, a sensor not yet initialised as the
    identity).  Each sensor follows the filter of its own ``tqt`` node with the same settings, to the
    bit (``tests/maths/test_tqt_implementations.py``), at a fraction of the cost per sample.

    A tick is one sample from every sensor; it starts with the lowest-numbered sensor that is heard (as
    a base station that sends its motes in turn delivers them) and is complete with the last.  The time
    step is the first sensor's of the tick (sensor time, as ``tqt``'s).  A sensor that misses a tick (a
    lost packet: the next tick starts without it) stays where it was for that tick; one that misses
    5 ticks in a row (``MISSES``) is not waited for until it is heard again, so a glove switched off does
    not hold the others back.  Sensors that arrive in no fixed order (phones over OSC, each on its own
    clock) are updated once per sample all the same, some ticks in two updates.  ``flags`` sends ``I
    status`` when sensor I's status changes: ``ok``, ``missing`` (it missed 2 ticks in a row, ``MISSING``:
    a single lost packet, or a sample that came out of turn, is not reported), or the filter's flags as
    ``tqt`` reports them.  ``range`` (first inlet; from ``scaling``'s ``range``) gives every sensor
    of the bank the full scale of its accelerometer and gyro, as ``tqt``'s does.
    """

    pure = True

    #: Ticks in a row a sensor may miss before the bank stops waiting for it.
    MISSES = 5
    #: Ticks in a row a sensor misses before ``flags`` reports it ``missing``.
    MISSING = 2
    #: Pd's stub of the type is drawn for 16 sensors (a body suit), so that it connects as any bank of up
    #: to 16 does: the ports that do not depend on ``sensors`` come first.
    stub_values: ClassVar[dict[str, Any]] = {"sensors": 16}
    MAX_GAP = SampleClock.MAX_GAP

    params = (
        Param(
            "sensors",
            "int",
            2,
            "number of sensors (inlets gyroI, accelI, magI; outlet quatI)",
            minimum=1,
            maximum=1024,
        ),
        *TQT.params,
    )
    example = """
node left  scaling
node right scaling
node suit  tqt_bank sensors=2
left.mag -> suit.mag1
left.accel -> suit.accel1
left.gyro -> suit.gyro1
right.mag -> suit.mag2
right.accel -> suit.accel2
right.gyro -> suit.gyro2
"""

    @classmethod
    def layout(cls, values: Mapping[str, Any]) -> tuple[tuple[Inlet, ...], tuple[Outlet, ...]]:
        inlets = [dataclasses.replace(TQT.inlets[-1], hot=False)]  # range: first, as the ports that do not
        # depend on sensors are (Pd's stub is drawn for 16 sensors)
        outlets = [
            Outlet("quats", "vector", "every sensor's quaternion, 4N numbers, sensor 1 first"),
            Outlet(
                "flags", "list", "I status, when sensor I's status changes (ok, missing, mag_disturbed...)"
            ),
        ]
        for i in range(1, int(values.get("sensors", 2)) + 1):
            inlets += [
                Inlet(f"gyro{i}", ("vector", "list"), f"sensor {i}: angular rate, rad/s", hot=True),
                Inlet(f"accel{i}", ("vector", "list"), f"sensor {i}: specific force, m/s²", hot=False),
                Inlet(f"mag{i}", ("vector", "list"), f"sensor {i}: magnetic field", hot=False),
            ]
            outlets.append(
                Outlet(f"quat{i}", "vector", f"sensor {i}: quaternion (w, x, y, z), sensor -> NWU")
            )
        return tuple(inlets), tuple(outlets)

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        TQT.validate(values)

    def setup(self) -> None:
        p, n = self.p, self.p.sensors
        self.bank = TQTBank(n, p.k or None, backend=p.backend, **_settings(p))
        self._gyro = [_NAN3] * n
        self._accel = [_NAN3] * n
        self._mag = [_NAN3] * n
        self._stamp = [0.0] * n  # of each sensor's pending sample
        self._last: list[float | None] = [None] * n  # of each sensor's previous update
        self._fresh = [False] * n
        self._nfresh = 0
        self._live = [True] * n
        self._nlive = n
        self._lead = 0  # the lowest-numbered live sensor: its sample starts a tick
        self._misses = [0] * n  # updates in a row without the sensor (the leader's measure)
        self._ticks = 0  # ticks started: the leader's samples
        self._heard = [0] * n  # the tick in which each sensor was last heard
        self._dropouts = [0] * n  # times each sensor stopped being waited for (the log tells a few)
        self._reported = ["ok"] * n
        self._bits: np.ndarray | None = None  # the flags of the last update
        self._complete = False  # whether the last tick had every sensor
        self._ready = False  # whether every sensor is initialised (then none can stop being)
        self._initialised = [False] * n

    def param_changed(self, name: str) -> None:
        _retune(self.bank, self.p, name)

    def on_range(self, msg: Message) -> None:
        acc, gyro = as_floats(msg, 2)
        self.bank.retune(acc_range=acc, gyro_range=gyro)  # every sensor: one model of sensor in a bank

    def _make_handler(self, index: int, inlet: Inlet) -> Any:
        if index == 0:
            return self.on_range
        sensor, part = divmod(index - 1, 3)
        return partial((self._on_gyro, self._on_accel, self._on_mag)[part], sensor)

    def _on_accel(self, i: int, msg: Message) -> None:
        if self._fresh[i]:  # this sensor's next sample begins while its last is pending: send that first
            self._update()
        self._accel[i] = as_floats(msg, 3)

    def _on_mag(self, i: int, msg: Message) -> None:
        if self._fresh[i]:
            self._update()
        self._mag[i] = as_floats(msg, 3)

    def _on_gyro(self, i: int, msg: Message) -> None:
        gyro = as_floats(msg, 3)
        if not self._live[i]:
            self._live[i] = True
            self._nlive += 1
            self._lead = min(self._lead, i)
            if worth_reporting(self._dropouts[i]):
                log.warning("node '%s': sensor %d is back", self.name, i + 1)
        # A new tick: this sensor's sample is in the pending one already, or the leader's sample comes
        # while one is pending (which keeps a tick from holding one sensor's next sample for good, as it
        # would after sensors started at different times): update the pending tick without the missing.
        if self._fresh[i] or (i == self._lead and self._nfresh):
            self._update()
        if i == self._lead:
            self._ticks += 1
        self._heard[i] = self._ticks
        self._gyro[i] = gyro
        self._stamp[i] = msg.time
        self._fresh[i] = True
        self._nfresh += 1
        if self._nfresh >= self._nlive:
            self._update()

    def _update(self) -> None:
        """Update every sensor with a sample this tick; the others stay exactly as they were."""
        n, fresh, stamps = self.p.sensors, self._fresh, self._stamp
        first = fresh.index(True)
        dt = time_step(self._last[first], stamps[first], 1.0 / self.p.rate, self.MAX_GAP)
        complete = self._nfresh == n
        present = None
        if complete:  # the usual tick: every sensor is in it
            self._last, self._misses = list(stamps), [0] * n
        else:  # the missing sensors' inputs are their last samples, which the bank leaves unused
            self._count_missing()
            present = fresh
        q = self.bank.update(np.array(self._gyro), np.array(self._accel), np.array(self._mag), dt, present)
        self._fresh, self._nfresh = [False] * n, 0
        # right to left: quatN ... quat1, flags (only when they may have changed), quats
        rows = q.tolist()
        if not self._ready:
            self._initialised = self.bank.initialised.tolist()
            self._ready = all(self._initialised)
        for i in range(n - 1, -1, -1):
            if fresh[i] and (self._ready or self._initialised[i]):
                self.out(2 + i, floats(tuple(rows[i]), stamps[i]))
        bits = self.bank.flags
        if not (complete and self._complete) or not np.array_equal(bits, self._bits):
            self._bits = bits
            for i, b in reversed(list(enumerate((bits & _NOT_REST).tolist()))):
                if not fresh[i] and self._missed(i) < self.MISSING:
                    continue  # one tick late or lost: not missing yet
                status = "missing" if not fresh[i] else _status(b) if b else "ok"
                if status != self._reported[i]:
                    self._reported[i] = status
                    self.out(1, (i + 1, status), stamps[i])
        self._complete = complete
        self.out(0, floats(tuple(q.ravel().tolist()), stamps[first]))

    def _count_missing(self) -> None:
        """Count the misses of the sensors missing from this tick; stop waiting for a silent one."""
        for i in range(self.p.sensors):
            if self._fresh[i]:
                self._last[i] = self._stamp[i]
                self._misses[i] = 0
                continue
            self._misses[i] += 1
            if self._live[i] and self._missed(i) >= self.MISSES:
                self._live[i] = False
                self._nlive -= 1
                self._lead = next((j for j, live in enumerate(self._live) if live), 0)
                self._dropouts[i] += 1
                if worth_reporting(self._dropouts[i]):
                    log.warning(
                        "node '%s': sensor %d missed %d ticks in a row; not waited for until it is heard again%s",
                        self.name,
                        i + 1,
                        self.MISSES,
                        f" (dropout {self._dropouts[i]})" if self._dropouts[i] > 1 else "",
                    )

    def _missed(self, i: int) -> int:
        """Ticks in a row sensor i has missed.  Counted in the leader's samples, not in updates: sensors
        in no fixed order make some ticks two updates, and one that is late in one tick and early in the
        next has missed none.  The leader itself starts every tick it is in; its misses are updates."""
        return self._misses[i] if i == self._lead else self._ticks - self._heard[i]

    def do_reset(self) -> None:
        self.setup()


@register("reference")
class Reference(Node):
    """Outputs relative to a captured reference pose: "point at the front speaker and press".

    A bang at the right inlet (or ``set`` at the left one, ``/pointat/NODE/set`` over OSC) captures the
    next orientation as the reference; ``clear`` forgets it.  ``mode=heading`` (the default) removes only
    the reference's heading: azimuth 0 is where the hand pointed and elevations stay true to the room.  The
    heading is that of the sensor ``axis`` that points, as ``azi_ele``'s (give both the same ``axis`` when
    the hand's x is not the one that points); pointing within 1 deg of straight up or down there is no
    heading, and the capture waits for the next orientation that has one.  ``mode=full`` removes the whole
    reference orientation: the reference pose becomes the identity, its tilt and roll too, so with a
    reference that is not level every later direction is measured from its tilted horizon (capture a level
    pose, or use heading).

    The offset quaternion is applied in the earth frame, q_rel = q_offset ⊗ q (the reference turns the
    room, not the sensor); Bachmann et al.'s offset quaternions (VRST 2001 Eqs. 32-34) are the sensor-frame
    counterpart, q ⊗ q_offset, which aligns a sensor with the limb it is strapped to.
    """

    pure = True

    inlets = (
        Inlet("quat", ORIENTATION, "orientation (quaternion or matrix)"),
        Inlet("capture", ("bang",), "capture the next orientation as the reference", hot=False),
    )
    outlets = (Outlet("quat", "vector", "orientation relative to the reference"),)
    params = (
        Param(
            "mode",
            "symbol",
            "heading",
            "heading (remove the reference's heading) or full",
            choices=("heading", "full"),
            live=True,
        ),
        Param("capture_first", "bool", False, "capture the first orientation that arrives"),
        Param(
            "axis",
            "vector",
            (1.0, 0.0, 0.0),
            "the sensor axis that points (heading mode), as azi_ele's",
            size=3,
        ),
    )

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        if not math.hypot(*values["axis"]) > 0.0:
            raise ValueError(f"axis must be a non-zero vector, got {list(values['axis'])}")

    def setup(self) -> None:
        self.offset: sq.Quat = (1.0, 0.0, 0.0, 0.0)
        self._capture = self.p.capture_first

    def on_capture(self, msg: Message) -> None:
        self._capture = True

    def do_set(self) -> None:
        self._capture = True

    def do_clear(self) -> None:
        self.offset = (1.0, 0.0, 0.0, 0.0)

    def on_quat(self, msg: Message) -> None:
        q = _as_quat(msg)
        if self._capture:
            self._take(q)
        # the reference earth frame is the earth frame turned by the reference: q_rel = offset ⊗ q
        self.out(0, floats(sq.normalize(sq.multiply(self.offset, q)), msg.time))

    def _take(self, q: sq.Quat) -> None:
        if self.p.mode == "full":
            self.offset = sq.conjugate(q)
        else:
            # azi_ele's heading, with its pole: within 1 deg of straight up or down it gives back
            # 'previous', here NaN: no heading yet, and the capture waits
            az, _ = sq.azimuth_elevation(q, self.p.axis, previous=math.nan, pole_deg=1.0)
            if math.isnan(az):
                return
            yaw = math.radians(az)
            self.offset = (math.cos(yaw / 2), 0.0, 0.0, -math.sin(yaw / 2))
        self._capture = False


@register("matrix2quat")
class Matrix2Quat(Node):
    """Rotation matrix -> quaternion (w, x, y, z), w >= 0; robust for every rotation (Shepperd)."""

    pure = True

    inlets = (Inlet("matrix", ("vector", "list"), "3x3 rotation matrix (9 numbers, row major)"),)
    outlets = (Outlet("quat", "vector", "quaternion (w, x, y, z)"),)

    def on_matrix(self, msg: Message) -> None:
        m = as_floats(msg, 9)  # raises for anything but a matrix: a quaternion here is a wiring mistake
        if not math.isfinite(sum(m)):
            raise ValueError("orientation has NaN or infinite values")
        self.out(0, floats(_matrix_quat(m), msg.time))


@register("quat2matrix")
class Quat2Matrix(Node):
    """Quaternion (w, x, y, z) -> 3x3 rotation matrix."""

    pure = True

    inlets = (Inlet("quat", ("vector", "list"), "quaternion (w, x, y, z)"),)
    outlets = (Outlet("matrix", "vector", "3x3 rotation matrix"),)

    def on_quat(self, msg: Message) -> None:
        self.out(0, _matrix(_as_quat(msg), msg.time))


@register("quat2axis")
class Quat2Axis(Node):
    """Quaternion -> angle, x, y, z (Torre's "angle, x, y, z format"): rotation angle and unit axis."""

    pure = True

    inlets = (Inlet("quat", ORIENTATION, "quaternion or matrix"),)
    outlets = (Outlet("axis", "vector", "(angle, x, y, z), angle in degrees unless degrees=false"),)
    params = (Param("degrees", "bool", True, "angle in degrees (false: radians)"),)

    def on_quat(self, msg: Message) -> None:
        angle, x, y, z = sq.axis_angle(_as_quat(msg))
        self.out(0, vector([math.degrees(angle) if self.p.degrees else angle, x, y, z], msg.time))


@register("quat2euler")
class Quat2Euler(Node):
    """Quaternion -> yaw, pitch, roll: the intrinsic Z-Y'-X'' (aerospace) sequence, degrees.

    Yaw about earth z (up, positive left), pitch about the new y, roll about the hand's own x axis.
    At pitch +-90 deg all heading goes into yaw and roll is 0.
    """

    pure = True

    inlets = (Inlet("quat", ORIENTATION, "quaternion or matrix"),)
    outlets = (
        Outlet("yaw", "float", "degrees"),
        Outlet("pitch", "float", "degrees"),
        Outlet("roll", "float", "degrees"),
    )

    def on_quat(self, msg: Message) -> None:
        self.emit(*(math.degrees(a) for a in sq.euler(_as_quat(msg))))


_pointing = sq.azimuth_elevation
_HAND_X = (1.0, 0.0, 0.0)


@register("azi_ele")
class AziEle(Node):
    """Pointing direction -> azimuth and elevation (degrees), ready for VBAP and spatialisers.

    ADM-OSC convention: 0 = front (earth x: north, or the reference pose), positive = left, -180..180;
    elevation positive up.  Pointing straight up or down the azimuth is undefined: the last one is held.
    """

    pure = True

    inlets = (Inlet("quat", ORIENTATION, "orientation, quaternion or matrix"),)
    outlets = (Outlet("azimuth", "float", "degrees, + left"), Outlet("elevation", "float", "degrees, + up"))
    params = (
        Param("axis", "vector", (1.0, 0.0, 0.0), "the sensor axis that points (the hand's x)", size=3),
        POLE,
    )

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        _check_pole(values["pole"])

    def setup(self) -> None:
        self._az: float | None = None

    def on_quat(self, msg: Message) -> None:
        self._az, el = _pointing(_as_quat(msg), self.p.axis, self._az, self.p.pole)
        self.out(1, el)  # right to left, as emit does (written out: a call less per sample)
        self.out(0, self._az)


@register("roll_distance")
class RollDistanceNode(Node):
    """Torre §5.2: roll the hand 90 deg and the azimuth becomes a distance, 0 (far) .. 90 (near).

    Hysteresis: distance mode starts at |roll| >= ``enter`` and ends below ``leave``.  In distance mode
    the azimuth output holds, and sweeping the rolled hand left brings the source closer.  When the
    hand unrolls, the azimuth goes to where the hand points in one step; for a receiver that does not
    glide, put a ``smooth wrap=true`` between this node and it.  The roll is only read while
    the hand points within ``max_elevation`` of the horizon: pointing (nearly) straight up or down, its
    roll is its heading and jitters wildly, so the mode stays as it is.
    """

    pure = True

    inlets = (Inlet("quat", ORIENTATION, "orientation, quaternion or matrix"),)
    outlets = (
        Outlet("azimuth", "float", "degrees (held in distance mode)"),
        Outlet("distance", "float", "0 far .. 90 near"),
        Outlet("mode", "symbol", "azimuth or distance, when it changes"),
    )
    params = (
        Param("enter", "float", 70.0, "|roll| that starts distance mode", unit="deg", live=True),
        Param("leave", "float", 45.0, "|roll| below which it ends", unit="deg", live=True),
        Param("gain", "float", 1.0, "distance per degree of azimuth", live=True),
        Param("distance", "float", 0.0, "initial distance, 0..90"),
        Param(
            "max_elevation",
            "float",
            75.0,
            "above this |elevation| the roll is not read (the mode holds)",
            unit="deg",
            live=True,
        ),
        POLE,
    )

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        """What a live change must keep too: leave below enter, angles in their ranges."""
        RollDistance.check(values["enter"], values["leave"], values["max_elevation"])
        _check_pole(values["pole"])

    def setup(self) -> None:
        self.state = RollDistance(
            self.p.enter, self.p.leave, self.p.gain, self.p.distance, self.p.max_elevation
        )
        self._mode = self.state.mode
        self._az: float | None = None

    def param_changed(self, name: str) -> None:
        self.state.enter_deg, self.state.leave_deg, self.state.gain = self.p.enter, self.p.leave, self.p.gain
        self.state.max_elevation_deg = self.p.max_elevation

    def on_quat(self, msg: Message) -> None:
        q = _as_quat(msg)
        self._az, el = _pointing(q, _HAND_X, self._az, self.p.pole)
        mode, az_out, dist = self.state.update(self._az, math.degrees(sq.roll(q)), el)
        self.tell_mode(mode)
        self.out(1, dist)  # right to left, as emit does
        self.out(0, az_out)

    def tell_mode(self, mode: str) -> None:
        """The gesture's mode of this sample, told when it changes (:mod:`pointat.fusion` tells it too)."""
        if mode != self._mode:
            self._mode = mode
            self.out(2, mode)


_FRAMES = {
    ("nwu", "enu"): nwu_to_enu,
    ("enu", "nwu"): enu_to_nwu,
    ("nwu", "ned"): nwu_to_ned,
    ("ned", "nwu"): ned_to_nwu,
}


@register("reframe")
class Reframe(Node):
    """Re-express an orientation in another earth frame (NWU inside pointat; ENU, NED at the edges).

    Also ``positive=true`` makes w >= 0 (one sign for each rotation).
    """

    pure = True

    inlets = (Inlet("quat", ORIENTATION, "quaternion or matrix, sensor -> earth"),)
    outlets = (Outlet("quat", "vector", "quaternion in the target frame"),)
    params = (
        Param("source", "symbol", "nwu", "the frame it comes in", choices=("nwu", "enu", "ned")),
        Param("target", "symbol", "enu", "the frame it goes out in", choices=("nwu", "enu", "ned")),
        Param("positive", "bool", True, "make w >= 0"),
    )

    def setup(self) -> None:
        pair = (self.p.source, self.p.target)
        if pair[0] == pair[1]:
            convert = None
        elif pair in _FRAMES:
            convert = _FRAMES[pair]
        else:  # through NWU
            a, b = _FRAMES[(pair[0], "nwu")], _FRAMES[("nwu", pair[1])]

            def convert(q):
                return b(a(q))

        # Each change of frame multiplies by a fixed rotation on the left: the conversion of the identity
        # is that rotation, and one product per sample on floats does the conversion.
        self._frame = None if convert is None else tuple(convert(quat_identity()).tolist())

    def on_quat(self, msg: Message) -> None:
        q = _as_quat(msg)
        if self._frame is not None:
            q = sq.multiply(self._frame, q)
        if self.p.positive and q[0] < 0.0:
            q = (-q[0], -q[1], -q[2], -q[3])
        self.out(0, floats(q, msg.time))
