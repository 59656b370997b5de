"""The McGhee/Bachmann quaternion MARG filter as nodes: ``tqt`` for one sensor, ``tqt_bank`` for many.

The math is in :mod:`pointat.maths.tqt`; these nodes only move messages (conventions, time steps and
flags: :mod:`pointat.nodes.orientation`).
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Mapping
from functools import partial
from typing import Any, ClassVar

import numpy as np

from pointat.errors import worth_reporting
from pointat.maths.calibration import STANDARD_GRAVITY
from pointat.maths.tqt import TQTBank, TQTFilter, TQTFlags
from pointat.message import Message, as_floats, floats
from pointat.node import Inlet, Node, Outlet, Param
from pointat.nodes.orientation import FLAGS, RATE, Flagged, SampleClock, time_step
from pointat.registry import register

log = logging.getLogger("pointat.nodes.tqt")


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
    ``mag_disturbed``, ``bad_gyro``..., or ``ok``).  ``mag_disturbed`` has a hysteresis of its own, for
    the receiver: up when the field is off by a quarter more than the tolerances that make the filter
    ignore it, down two seconds after it is back within less than them, so that a hand swinging or
    running about the edge is one message, not one a swing.

    ``use_gyro=false`` tracks from accel/mag alone, heading and tilt at gain ``k`` (robust default 50:
    within 20 ms of the measurement).  Send the gyro last (the left inlet is hot): mote and scaling
    nodes output right to left, so wiring gyro, accel and mag outlets to the same-named inlets does this.

    ``backend=auto`` runs robust mode's step compiled by numba (one call a sample, the same results as
    ``backend=python``'s step in Python, several times sooner); the patch loads it as it loads.
    """

    pure = True
    fusable = True

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
            0.015,
            "heading-correction gain (robust mode)",
            unit="1/s",
            live=True,
            minimum=0.0,
        ),
        Param(
            "k_heading_turn",
            "float",
            0.01,
            "heading-correction gain added per rad/s of sustained turning (robust mode)",
            unit="1/rad",
            live=True,
            minimum=0.0,
        ),
        Param(
            "k_heading_rest",
            "float",
            0.2,
            "heading-correction gain while the sensor rests (robust mode; the larger of it and the gain of the moment)",
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
            "auto (numba when mode=robust), numba or python: the same results",
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

    def fused_state(self) -> dict[str, Any] | None:
        """The filter's vectors and flags (:meth:`~pointat.maths.tqt.TQTFilter.export_state`), the last
        time stamp (None: none) and the flags last reported, in robust mode (:mod:`pointat.compiled`
        compiles robust mode only)."""
        if self.filter.mode != "robust":
            return None
        return {"filter": self.filter.export_state(), "last_t": self._last_t, "bits": self._bits}

    def restore_fused(self, state: Mapping[str, Any]) -> None:
        self.filter.import_state(*state["filter"])
        self._last_t = state["last_t"]
        self._bits = state["bits"]

    def tell_flags(self, bits: int) -> None:
        """The filter's flag bits (rest apart) of this sample: the status text only when they change
        (:mod:`pointat.compiled` tells them too)."""
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
        "k_heading_rest": p.k_heading_rest,
        "k_heading_turn": p.k_heading_turn,
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
    :class:`pointat.maths.tqt.TQTBank`, one compiled loop over the sensors with numba (robust mode);
    each ``quatI`` sends its sensor's orientation, right to left, then ``quats`` all of them as one
    vector (4N numbers, sensor 1 first, a sensor not yet initialised as the identity).  Each sensor follows the filter of its own ``tqt`` node with the same settings, to the
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
