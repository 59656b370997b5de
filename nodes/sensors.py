"""Sources of motion data: the serial ``mote`` base station and the built-in simulated glove.

Both output each sample as one vector of the nine raw ADC counts (gyro x y z, accel x y z, mag x y z;
see :mod:`pointat.devices.mote_frame`), time-stamped with the sensor's time.
"""

from __future__ import annotations

import logging
import math
import os
import time
from collections.abc import Mapping
from typing import Any

import numpy as np
from serial import SerialException

from pointat.devices.gesture_sim import performance
from pointat.devices.glove_sim import Burst, GloveSimulator, PtyGlove, SensorModel
from pointat.devices.mote_frame import (
    CorruptFrame,
    CounterJump,
    Frame,
    Garbage,
    LostPackets,
)
from pointat.devices.serial_reader import (
    DeviceLost,
    DeviceOpened,
    OpenFailed,
    ReaderError,
    SerialMoteReader,
)
from pointat.errors import worth_reporting
from pointat.maths.calibration import STANDARD_GRAVITY
from pointat.message import Message, method, vector
from pointat.node import Inlet, Node, Outlet, Param, names_path
from pointat.registry import register
from pointat.runtime import Timer

log = logging.getLogger("pointat.nodes.sensors")

ADC_DOC = "nine ADC counts 0..4095: gyro x y z, accel x y z, mag x y z"

# ----------------------------------------------------------------------------- sensor full scale
#: The sensor full scale, for a source that delivers readings of sensors it cannot see (``replay``,
#: ``osc_in``): the user says it, the ``range`` outlet (:data:`RANGE_OUTLET`) tells ``tqt``'s ``range``.
FULL_SCALE_PARAMS = (
    Param(
        "acc_range",
        "float",
        0.0,
        "the accelerometer's full scale per axis, as its data sheet gives it (0: not known)",
        unit="g",
        minimum=0.0,
    ),
    Param(
        "gyro_range", "float", 0.0, "the gyro's full scale per axis (0: not known)", unit="deg/s", minimum=0.0
    ),
)
RANGE_OUTLET = Outlet(
    "range",
    "list",
    "full scale: accelerometer m/s², gyro rad/s, once at start when acc_range or gyro_range is set",
)


def full_scale(node: Node) -> None:
    """Send ``node``'s full scale (:data:`FULL_SCALE_PARAMS`) from its ``range`` outlet, when one is set."""
    if node.p.acc_range or node.p.gyro_range:
        outlet = [o.name for o in type(node).outlets].index("range")
        node.out(outlet, (node.p.acc_range * STANDARD_GRAVITY, math.radians(node.p.gyro_range)))


class _MoteClock:
    """Sensor time of one mote from its frames: a frame is as many sample periods after the last one as its
    packet counter moved (packets lost, or dropped on the way, advance time); a counter jump (the parser's
    verdict, ``frame.jump``: a restart, or more than the mote could have sent since its last frame)
    re-anchors on the host's time, as does the first frame.

    Its state is a column of the ``mote`` node's clock array (rows: t0, NaN until the first frame; the
    count of periods since; the last counter), which the compiled chains' scan of plain frames
    (:func:`pointat.compiled.kernel.scan_plain`) moves on too."""

    def __init__(self, clock: np.ndarray, mote: int, rate: float):
        self.clock, self.mote, self.rate = clock, mote, rate

    def time(self, frame: Frame, host_time: float) -> float:
        c, m = self.clock, self.mote
        t0 = float(c[0, m])
        if t0 != t0 or frame.jump:
            c[0, m], c[1, m], c[2, m] = host_time, 0.0, frame.n_pack
            return host_time
        count = float(c[1, m]) + ((frame.n_pack - int(c[2, m])) & 0xFFFF)
        c[1, m], c[2, m] = count, frame.n_pack
        return t0 + count / self.rate


def _clocks(ids: Any, rate: float) -> tuple[np.ndarray, dict[int, _MoteClock]]:
    """A clock array for mote ids 0..255 (none started), and a clock of each of ``ids``."""
    clock = np.zeros((3, 256))
    clock[0] = math.nan
    return clock, {int(i): _MoteClock(clock, int(i), rate) for i in ids}


@register("mote")
class Mote(Node):
    """Read IMU motes from a wireless base station on a serial port (Torre §3.1).

    Binary frames or text lines (auto-detected, see ``pointat.devices.mote_frame``).  One outlet per mote
    id in ``ids``; each sample is a vector of nine ADC counts stamped with sensor time (from the packet
    counter at ``rate``, so lost packets keep the timing right; a counter that moved on further than the
    mote could have counted since its last frame is a restart, ``counter_jump``, and its time starts
    again from the host's).  Garbage is skipped, corrupt frames dropped and counted, lost packets
    reported on ``events``; when the device vanishes the port is reopened as soon as it comes
    back.  ``open PATH`` / ``close`` switch device while running; a symbol at the left inlet opens that
    path (wire ``simulate``'s ``device`` outlet here: it sends ``close`` when the simulation ends).  A
    closed mote's part in the patch is over until the next ``open``: a patch whose sources have all
    ended stops by itself.  A pseudo-terminal named by its number (``/dev/pts/3``) is not reopened when
    it closes, since the next terminal opened on the machine takes that number: the mote closes.  The
    port is the mote's alone: a second patch reading it hears once that it is busy ("another program has
    PATH open") and opens it when the first lets it go.  ``stats`` (or a bang) sends ``stats received
    corrupt lost garbage_bytes`` on ``events``.  The port is read on the scheduler thread itself (no
    thread hand-off between the device and the chain).

    ``events`` carries each ``lost``, ``corrupt``, ``counter_jump``, ``unknown_mote``, ``reader_error``,
    ``opened``, ``open_failed`` and ``device_lost``; the log tells the same in a few lines, for patches
    that leave ``events`` unwired: a mote silent for a second and its return, lost packets and damaged
    frames summed up every 5 s, a device lost and back.

    A USB-serial adapter holds short frames back: an FTDI chip passes on what it has every 16 ms by
    default, which would be most of a sample's latency.  ``low_latency`` (on by default) asks the
    driver for its low-latency mode at every open; on Linux the FTDI driver then sends within 1 ms.
    The mode is turned off again when the port closes, unless it was on already (the adapter is left
    as it was found).  The log says whether the driver accepted the request; where an FTDI adapter's
    driver refuses it, or takes it and leaves the adapter's timer above 1 ms, a warning names the
    ``latency_timer`` file to set instead.
    """

    sample_outlets = "m[0-9]+"
    role = "input"

    inlets = (
        Inlet("control", ("symbol", "bang"), "a device path to open; methods: open PATH, close, stats"),
    )
    params = (
        Param("device", "path", "", "serial device (/dev/ttyUSB0...); empty: wait for 'open'"),
        Param("ids", "list", (1,), "mote ids, one outlet each, in this order"),
        Param("baud", "int", 115200, "line speed"),
        Param("format", "symbol", "auto", "auto, binary or text", choices=("auto", "binary", "text")),
        Param(
            "rate",
            "float",
            100.0,
            "the motes' sample rate, for time stamps and to tell loss from a restart",
            unit="Hz",
            above=0.0,
        ),
        Param(
            "low_latency",
            "bool",
            True,
            "ask the serial driver for low latency (Linux: an FTDI adapter's timer 16 -> 1 ms)",
        ),
    )
    example = """
node base  mote device=/dev/ttyUSB0 ids=[1, 2]
node nulls1 offset samples=150
node nulls2 offset samples=150
node left  scaling
node right scaling
base.0 -> nulls1 -> left
base.1 -> nulls2 -> right
"""

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        ids = list(values["ids"])
        bad = [i for i in ids if not (isinstance(i, int) and 0 <= i <= 255)]
        if bad:
            raise ValueError(f"ids must be mote ids 0..255, got {bad[0]!r}")
        if not ids:
            raise ValueError("ids is empty: name the motes to read, e.g. ids=[1, 2]")
        twice = sorted({i for i in ids if ids.count(i) > 1})
        if twice:
            raise ValueError(f"ids names mote {twice[0]} twice: each mote has one outlet")

    @classmethod
    def layout(cls, values):
        ids = values.get("ids", (1,)) or (1,)
        outs = tuple(Outlet(f"m{int(i)}", "vector", f"mote {int(i)}: {ADC_DOC}") for i in ids)
        return cls.inlets, (
            *outs,
            Outlet("events", "list", "lost, corrupt, counter_jump, device_lost, opened..."),
        )

    #: Seconds between attempts to reopen a device that is gone: the first, and the largest (doubling).
    BACKOFF = (0.05, 1.0)
    #: Seconds between checks that the device is still where its path says (a udev symlink replugged).
    CHECK_EVERY = 0.25
    #: Where select cannot wait on a serial port (Windows), the reader runs in a thread of its own.
    READ_IN_THREAD = os.name != "posix"
    #: Seconds without a frame from an open device before the log says so (the glove off, out of range).
    SILENT = 1.0
    #: Seconds over which the log sums up lost packets and damaged frames: one line, not one a frame.
    REPORT_EVERY = 5.0
    #: Bytes of noise in one summary's span below which it is not worth a line (opening a port in the
    #: middle of a frame, or losing it, leaves a partial one).
    NOISE_BYTES = 64

    _fused: Any = None  # the compiled chains behind the outlets (see fuse)

    def fuse(self, chains: Any) -> None:
        """Hand the frames of the outlets whose chains run compiled to ``chains`` (a
        :class:`pointat.compiled.Group`: its ``take`` queues a frame, or says no and the frame goes the
        node's way; ``scan`` takes a run of plain frames from the reader's buffer; ``flush`` runs what a
        read queued; ``silences_changed`` hears that a mote fell silent or spoke again), or, given None,
        send every frame the node's way again."""
        self._fused = chains

    def silent(self, mote: int) -> bool:
        """Whether mote ``mote`` (an id) has sent nothing for :attr:`SILENT` seconds since the device
        opened."""
        return mote in self._silent

    def describe(self) -> str:
        device = self.p.device or "the simulated glove's pseudo-terminal"
        return f"base station on {device}, motes {list(self.p.ids)}"

    def setup(self) -> None:
        self._outlet = {int(i): k for k, i in enumerate(self.p.ids)}
        self._clock, self._clocks = _clocks(self._outlet, self.p.rate)
        self._reader: SerialMoteReader | None = None
        self._fd: int | None = None
        self._timer: Timer | None = None
        self._failing = False
        self._unknown: set[int] = set()
        self.received = 0
        self._trouble: dict[str, int] = {}  # since the last summary: lost, corrupt, jumps, garbage bytes
        self._reported = 0.0  # monotonic time of the last summary, or of the open
        self._last_frame: dict[int, float] = {}  # per mote: monotonic time of its last frame, or the open
        self._silent: set[int] = set()
        self._silences: dict[int, int] = {}  # per mote: its silences so far (the log tells a few)
        self._was_lost = False

    def start(self) -> None:
        self.active = True  # a base station runs until the patch is stopped
        if self.p.device:
            self.do_open(self.p.device)

    @names_path
    def on_control(self, msg: Message) -> None:
        if msg.kind == "symbol":
            self.do_open(msg.value)
        elif msg.kind == "bang":
            self.do_stats()

    @names_path
    def do_open(self, path: Any) -> None:
        self.do_close()
        self.active = True
        self.p.device = str(path)
        if self.READ_IN_THREAD:  # the reader's own thread, handing each frame and event to the scheduler
            on_frame = lambda frame, t: self.post(self._on_frame, frame, t, block=False)  # noqa: E731
            on_event = lambda event: self.post(self._event, event, block=False)  # noqa: E731
        else:  # read on the scheduler thread itself: the callbacks run there
            on_frame, on_event = self._on_frame, self._event
        self._clock, self._clocks = _clocks(self._outlet, self.p.rate)  # a new reader: new time lines
        self._reader = SerialMoteReader(
            self.p.device,
            self.p.baud,
            on_frame,
            on_event,
            format=self.p.format,
            backoff=self.BACKOFF,
            rate=self.p.rate,
            low_latency=self.p.low_latency,
            plain=None if self.READ_IN_THREAD or self._fused is None else self._plain,
        )
        if self.READ_IN_THREAD:
            self._reader.start()  # it opens, reads and reopens by itself; the log hears of it here
            self._timer = self.call_later(self.CHECK_EVERY, self._health_tick)
        else:
            self._failing = False
            self._try_open()

    def do_close(self) -> None:
        self._unwatch()
        self.active = False  # nothing to read until the next open
        if self._reader is not None:
            self._reader.stop()  # joins the thread if there is one; closes the port
            self._reader = None

    def health(self) -> dict[str, Any]:
        reader = self._reader
        if reader is None:
            return {"device": "closed"}
        s = reader.stats()
        return {"lost": s.lost, "corrupt": s.corrupt}

    def do_stats(self) -> None:
        if self._reader is None:
            return
        s = self._reader.stats()
        self.out(len(self.out_specs) - 1, ("stats", self.received, s.corrupt, s.lost, s.garbage_bytes))

    def close(self) -> None:
        self.do_close()

    # The device is read on the scheduler thread (Runtime.add_reader): a frame goes from the kernel
    # into the chain with no thread hand-off.  Opening, losing and reopening are events on the same thread.
    def _try_open(self) -> None:
        self._timer = None
        reader = self._reader
        if reader is None:
            return
        try:
            reader.open(nonblocking=True)
            self._fd = reader.fileno()
            self.add_reader(self._fd, self._readable)
        except (SerialException, OSError, ValueError) as exc:
            reader.close()
            self._fd = None
            if not self._failing:  # once per outage; the retries go on quietly
                self._failing = True
                log.warning("mote '%s': cannot open %s: %s (retrying)", self.name, self.p.device, exc)
                self._event(OpenFailed(self.p.device, str(exc)))
            self._timer = self.call_later(reader.reopen.next(), self._try_open)
            return
        self._failing = False
        self._timer = self.call_later(self.CHECK_EVERY, self._check)

    def _readable(self) -> None:
        reader = self._reader
        if reader is not None and not reader.poll():
            self._reopen_later()
        if self._fused is not None:  # the read's frames of the compiled chains (pointat.compiled)
            self._fused.flush()

    def _check(self) -> None:
        self._timer = None
        reader = self._reader
        if reader is None:
            return
        if reader.check():
            self._timer = self.call_later(self.CHECK_EVERY, self._check)
            self._health(time.monotonic())
        else:
            self._reopen_later()

    def _health_tick(self) -> None:
        self._health(time.monotonic())
        self._timer = self.call_later(self.CHECK_EVERY, self._health_tick)

    def _health(self, now: float) -> None:
        """The link's troubles, in the log in a few lines: a mote's silence when it starts, the packets
        lost and frames damaged summed up every :attr:`REPORT_EVERY` seconds (the ``events`` outlet has
        each one)."""
        if not self._last_frame:  # not open yet
            return
        for mote, last in self._last_frame.items():
            if mote not in self._silent and now - last > self.SILENT:
                self._silent.add(mote)
                if self._fused is not None:  # (a silent mote's frames go the node's way: it says so)
                    self._fused.silences_changed()
                n = self._silences[mote] = self._silences.get(mote, 0) + 1
                if worth_reporting(n):  # a glove at the edge of the radio's range comes and goes
                    log.warning(
                        "mote '%s': no frames from mote %d on %s for %.0f s (the glove off, or out of range?)%s",
                        self.name,
                        mote,
                        self.p.device,
                        now - last,
                        f" (silence {n})" if n > 1 else "",
                    )
        if self._trouble.get("garbage", 0) < self.NOISE_BYTES:
            self._trouble.pop("garbage", None)
        if self._trouble and now - self._reported >= self.REPORT_EVERY:
            t = self._trouble
            parts = [
                f"{t['lost']} packets lost" if t.get("lost") else "",
                f"{t['corrupt']} damaged frames" if t.get("corrupt") else "",
                f"{t['jump']} counter jumps (a mote restarted?)" if t.get("jump") else "",
                f"{t['garbage']} bytes of noise" if t.get("garbage") else "",
                f"{t['error']} reader errors" if t.get("error") else "",
            ]
            log.warning(
                "mote '%s' on %s, in the last %.0f s: %s",
                self.name,
                self.p.device,
                now - self._reported,
                ", ".join(p for p in parts if p),
            )
            self._trouble, self._reported = {}, now

    def _count(self, what: str, n: int = 1) -> None:
        self._trouble[what] = self._trouble.get(what, 0) + n

    def _reopen_later(self) -> None:
        """Lost: a device that delivered data is tried again at once, one that fails right after opening
        backs off (a broken but openable device must not make the patch spin)."""
        self._unwatch()
        if self._reader is None:
            return
        if self._reader.delivered:
            self._reader.reopen.reset()
        self._timer = self.call_later(self._reader.reopen.next(), self._try_open)

    def _unwatch(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        if self._fd is not None:
            self.remove_reader(self._fd)
            self._fd = None

    def _on_frame(self, frame: Frame, host_time: float) -> None:
        self._frame(frame, host_time, self._runtime().clock.from_monotonic(host_time))

    def _frame(self, frame: Frame, seen: float, host_time: float) -> None:
        """One frame: ``seen`` its read's monotonic stamp, ``host_time`` the same on the patch's clock."""
        k = self._outlet.get(frame.mote)
        if k is None:
            if frame.mote not in self._unknown:
                self._unknown.add(frame.mote)
                if worth_reporting(len(self._unknown)):  # noise that reads as frames brings many ids
                    log.warning(
                        "mote '%s': frames from mote %d, which ids=%s does not list: dropped%s",
                        self.name,
                        frame.mote,
                        list(self.p.ids),
                        f" ({len(self._unknown)} such ids so far)" if len(self._unknown) > 1 else "",
                    )
                self.out(len(self.out_specs) - 1, ("unknown_mote", frame.mote))
            return
        self.received += 1
        if frame.mote in self._silent:
            self._silent.discard(frame.mote)
            if self._fused is not None:
                self._fused.silences_changed()
            if worth_reporting(self._silences[frame.mote]):
                log.warning("mote '%s': frames again from mote %d", self.name, frame.mote)
        self._last_frame[frame.mote] = seen
        t = self._clocks[frame.mote].time(frame, host_time)
        if self._fused is None or not self._fused.take(k, frame.channels, t):
            self.out(k, vector(frame.channels, t))

    def _plain(
        self, buf: bytearray, pos: int, end: int, last: np.ndarray, held: np.ndarray, now: float | None
    ) -> tuple[int, int, dict[int, int]] | None:
        """The reader's parser hands runs of plain frames to the compiled chains
        (:attr:`pointat.devices.mote_frame.FrameParser.plain`): what :meth:`_frame` does for each, done
        for all (the chains' arrays take them; the counters, the silences and the observer's counts
        move on here)."""
        if self._fused is None:  # (handed back while the reader read)
            return None
        took = self._fused.scan(buf, pos, end, last, held, self._clock, self.p.rate)  # (rate is not live)
        if took is not None:
            self.received += took[0]
            seen = time.monotonic() if now is None else now
            for mote in took[2]:
                self._last_frame[mote] = seen
        return took

    def _event(self, event: object) -> None:
        ev = len(self.out_specs) - 1
        self.time = self.now
        if isinstance(event, LostPackets):
            self._count("lost", event.count)
            self.out(ev, ("lost", event.mote, event.count))
        elif isinstance(event, CorruptFrame):
            self._count("corrupt")
            self.out(ev, ("corrupt", event.reason))
        elif isinstance(event, CounterJump):
            self._count("jump")
            self.out(ev, ("counter_jump", event.mote, event.expected, event.got))
        elif isinstance(event, Garbage):
            self._count("garbage", event.nbytes)
        elif isinstance(event, ReaderError):
            self._count("error")
            self.out(ev, ("reader_error", event.where, event.reason[:80]))
        elif isinstance(event, DeviceLost) and event.final:
            log.warning(
                "mote '%s': device %s closed (%s): it was a pseudo-terminal, whose writer ended (a simulator?)"
                "; not reopened, since the next terminal opened takes its number. The mote is closed",
                self.name,
                self.p.device,
                event.reason,
            )
            self.out(ev, ("device_lost", self.p.device))
            self.do_close()
        elif isinstance(event, DeviceLost):
            self._was_lost = True
            log.warning(
                "mote '%s': device %s lost: %s; waiting for it to come back",
                self.name,
                self.p.device,
                getattr(event, "reason", ""),
            )
            self.out(ev, ("device_lost", self.p.device))
        elif isinstance(event, DeviceOpened):
            now = time.monotonic()  # every mote's silence and the summaries count from the open
            self._last_frame, self._silent, self._reported = dict.fromkeys(self._outlet, now), set(), now
            if self._was_lost:
                self._was_lost = False
                log.warning("mote '%s': device %s is back", self.name, self.p.device)
            self.out(ev, ("opened", self.p.device))
        elif isinstance(event, OpenFailed):
            self.out(ev, ("open_failed", self.p.device))


class PacedSource(Node):
    """A source that samples on the scheduler's timers: sample ``k`` at ``k / rate`` seconds, until its
    ``duration`` runs out (0: until the patch stops; then :meth:`finish`, the source ends, the patch may
    end with it).  A subclass has the ``rate`` and ``duration`` parameters and writes :meth:`sample`."""

    _timer: Timer | None = None
    _k = 0

    def pace(self) -> None:
        """Start sampling (from ``start``)."""
        self.active = True
        self._k = 0
        self._timer = self.call_at(0.0, self._tick)

    def _tick(self) -> None:
        k = self._k
        t = k / self.p.rate
        if self.p.duration and t >= self.p.duration:
            self.ended = True
            self.finish(t)
            self.close()
            return
        self._k += 1
        self._timer = self.call_at((k + 1) / self.p.rate, self._tick)
        self.sample(k, t)

    def sample(self, k: int, t: float) -> None:
        """Send sample ``k`` (time ``t``)."""
        raise NotImplementedError

    def finish(self, t: float) -> None:
        """The last thing said when the duration has run out, before :meth:`close`."""

    def close(self) -> None:
        self.active = False
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None


@register("simulate")
class Simulate(PacedSource):
    """A virtual Pointing-at glove: scripted hand motion through a realistic sensor model.

    Pointing sweeps, holds at loudspeaker directions, raising and lowering, a 90 deg roll gesture
    (``script=pointing``), or a performer who points, rests and makes the three gestures of
    ``pointat.devices.gesture_sim`` in turn, circle, flick and nod, one every 4 s or so
    (``script=gestures``: what ``patches/gestures.pat`` is taught); gyro
    bias and noise, accelerometer and magnetometer noise, the Earth field with dip, 12-bit counts.  The
    script loops (``duration`` ends it).  ``output=direct`` sends the counts from the ``adc`` outlet;
    ``output=pty`` writes real mote frames into a pseudo-terminal instead and sends its path from the
    ``device`` outlet (wire it to a ``mote``), so the whole serial path runs; when ``duration`` ends
    it, the outlet sends ``close`` before the pseudo-terminal goes, so the mote is done too and the
    patch can end.  ``truth`` is the true orientation quaternion (sensor -> NWU).  ``dropout SECONDS``
    (a method: ``/pointat/glove/dropout 2``) makes the glove go silent, as one out of radio range, to
    rehearse what the receiver and the monitor are told.

    ``burst=strokes`` or ``burst=shake`` adds bursts of hand translation, as a performer drums, strikes
    or shakes: one starts every ``burst_every`` seconds (the first at ``burst_every``) and lasts the
    whole strokes or shake cycles that fit in ``burst_length`` seconds, at ``burst_rate`` strokes or
    cycles per second and a peak linear acceleration of ``burst_g`` times standard gravity.  A stroke
    is a broad lift and swing back, then a sharp impact (15 ms; a fifth of the stroke above 13 Hz)
    that stops the hand where it started; a shake is a sinusoidal back and forth, faded in and out
    over a cycle.  Either way the hand comes back to where it was and the orientation is as without
    bursts: the accelerometer reads gravity plus the burst (specific force), the gyro and magnetometer
    are unchanged.  ``burst_axis``: ``vertical`` (up and down), ``pointing`` (along the pointing axis,
    as it points then) or ``both`` (the diagonal between them).  The counts still go through the
    12-bit ADC, which clips at about ±4 g per axis (±39.3 m/s², the glove's full scale), so the
    default 10 g strokes saturate there, as the real glove would.  Outside the bursts the samples are
    the same as with ``burst=none``.  See ``pointat.devices.glove_sim.Burst``.
    """

    sample_outlets = "adc"
    role = "input"

    outlets = (
        Outlet("adc", "vector", ADC_DOC + " (output=direct)"),
        Outlet("truth", "vector", "true orientation quaternion (w, x, y, z), sensor -> NWU"),
        Outlet("device", "symbol", "the pseudo-terminal's path at start, close at the end (output=pty)"),
    )
    params = (
        Param("rate", "float", 100.0, "sample rate", unit="Hz", above=0.0),
        Param(
            "output",
            "symbol",
            "direct",
            "direct (counts from the adc outlet) or pty (frames into a pseudo-terminal)",
            choices=("direct", "pty"),
        ),
        Param("format", "symbol", "binary", "frame format written to the pty", choices=("binary", "text")),
        Param("mote", "int", 1, "mote id in the frames", minimum=0, maximum=255),
        Param("seed", "int", 0, "noise and bias seed (the same seed, the same data)", minimum=0),
        Param("noise", "bool", True, "false: ideal sensors (no bias, no noise)"),
        Param("duration", "float", 0.0, "stop after this long; 0: run until the patch stops", unit="s"),
        Param("link", "path", "", "also make this path a symlink to the pty (output=pty)", writes=True),
        Param(
            "burst",
            "symbol",
            "none",
            "hand translation bursts: none, strokes (drumming, striking) or shake",
            choices=("none", "strokes", "shake"),
        ),
        Param("burst_g", "float", 10.0, "peak linear acceleration of a burst", unit="g", above=0.0),
        Param("burst_rate", "float", 5.0, "strokes, or shake cycles, per second", unit="Hz", above=0.0),
        Param("burst_length", "float", 6.0, "length of each burst", unit="s", above=0.0),
        Param(
            "burst_every",
            "float",
            30.0,
            "a burst starts every this long, the first one then",
            unit="s",
            above=0.0,
        ),
        Param(
            "burst_axis",
            "symbol",
            "vertical",
            "vertical, pointing (along the pointing axis) or both (the diagonal between them)",
            choices=("vertical", "pointing", "both"),
        ),
        Param(
            "script",
            "symbol",
            "pointing",
            "the hand's motion: pointing (sweeps, holds, the roll gesture) or gestures (circle, flick, nod)",
            choices=("pointing", "gestures"),
        ),
    )
    example = """
node glove simulate rate=100
node nulls offset samples=150
node cal   scaling
glove -> nulls -> cal
"""

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        if values["burst"] == "none":
            return
        length, every, rate = values["burst_length"], values["burst_every"], values["burst_rate"]
        if length > every:
            raise ValueError(
                f"burst_length {length:g} s is longer than burst_every {every:g} s: the bursts would overlap"
            )
        least = 1 if values["burst"] == "strokes" else 2
        if length * rate + 1e-9 < least:
            what = "a whole stroke" if least == 1 else "two whole shake cycles"
            raise ValueError(
                f"burst_length {length:g} s at burst_rate {rate:g} Hz holds less than {what}: "
                f"make burst_length at least {least / rate:g} s"
            )
        cls._bursts(values)  # anything else the burst itself refuses

    @staticmethod
    def _bursts(values: Mapping[str, Any]) -> tuple[Burst, ...]:
        if values["burst"] == "none":
            return ()
        return (
            Burst(
                start=values["burst_every"],
                duration=values["burst_length"],
                peak_g=values["burst_g"],
                rate=values["burst_rate"],
                axis=values["burst_axis"],
                kind=values["burst"],
                every=values["burst_every"],
            ),
        )

    def describe(self) -> str:
        return f"the simulated glove, {self.p.rate:g} Hz" + (
            " (through a pseudo-terminal, as a real base station)" if self.p.output == "pty" else ""
        )

    def setup(self) -> None:
        sensor = SensorModel(seed=self.p.seed) if self.p.noise else SensorModel.ideal()
        script = performance(self.p.seed, 30, loop=True, lead=3.0)[0] if self.p.script == "gestures" else None
        self.sim = GloveSimulator(
            script,
            rate_hz=self.p.rate,
            mote_id=self.p.mote,
            seed=self.p.seed,
            sensor=sensor,
            bursts=self._bursts(vars(self.p)),
        )
        self._pty: PtyGlove | None = None

    def start(self) -> None:
        if self.p.output == "pty":
            self._pty = PtyGlove(self.sim, format=self.p.format).start()
            if self.p.link:
                if os.path.islink(self.p.link):
                    os.unlink(self.p.link)
                os.symlink(self._pty.device_path, self.p.link)
        self.pace()

    def loadbang(self) -> None:
        if self._pty is not None:
            self.time = self.now
            self.out(2, self.p.link or self._pty.device_path)

    def do_dropout(self, seconds: float = 1.0) -> None:
        """Go silent for ``seconds``, as a glove out of radio range: the samples of that time are lost
        (the pseudo-terminal gets no frames), then the glove is back where its script has got to."""
        seconds = float(seconds)
        if not 0.0 < seconds <= 3600.0:
            raise ValueError(f"dropout takes 0 < seconds <= 3600, got {seconds}")
        if self._pty is not None:
            self._pty.stop()
        self._silent_until = self.now + seconds
        self.call_later(seconds, self._back)

    def _back(self) -> None:
        if self._pty is not None and self.active:
            self._pty.skip(self._k - self._pty.index)  # to the sample the script is at now
            self._pty.start()

    def finish(self, t: float) -> None:
        if self._pty is not None:  # its reader is done too, before the pseudo-terminal goes
            self.out(2, method("close", time=t))

    _silent_until = -math.inf

    def sample(self, k: int, t: float) -> None:
        if self._pty is not None:
            self.out(1, vector(self.sim.truth(k).q, t))
            return
        if t < self._silent_until:  # a dropout: nothing arrives
            return
        s = self.sim.sample(k)
        self.out(1, vector(s.q, t))
        self.out(0, vector(s.frame.channels, t))

    def close(self) -> None:
        super().close()
        if self._pty is not None:
            self._pty.close()
            self._pty = None
            if self.p.link and os.path.islink(self.p.link):
                os.unlink(self.p.link)
