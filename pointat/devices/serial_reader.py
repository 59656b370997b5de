"""Read mote frames from a serial port, in a background thread or driven by an event loop, surviving unplugs.

:class:`SerialMoteReader` opens the base station's serial device with pyserial, parses the byte stream
with a :class:`~pointat.devices.mote_frame.FrameParser`, stamps every frame with the host's
:func:`time.monotonic` at receipt and hands it to ``on_frame(frame, host_time)``.  Parser events
(lost packets, corrupt frames, garbage) and device events (:class:`DeviceOpened`, :class:`DeviceLost`,
:class:`OpenFailed`, :class:`ReaderError`) go to ``on_event(event)``.

When the device disappears (a read raises :class:`serial.SerialException` or :class:`OSError`, or its
path vanishes or now names another device) the reader reports :class:`DeviceLost`, closes the port and
tries to reopen the path with a bounded exponential backoff until it comes back or :meth:`stop` is
called.  The parser keeps each mote's packet counter across a reconnection, so the samples missed
during the outage are reported as lost packets when the stream resumes.

A pseudo-terminal named by its number (``/dev/pts/3``, :func:`numbered_pty`) is the exception: it never
comes back, and the next terminal opened on the machine takes its number, so its loss (its other end
closed, its path gone) is final (``DeviceLost.final``): the reader ends instead of opening, and setting
raw, somebody's shell.  A link
to a pseudo-terminal (``simulate link=``, ``socat pty,link=``) is reopened when it is there again: its
owner makes it again for a new terminal.

The port is opened for this reader alone (pyserial's ``exclusive``: an ``flock`` on POSIX; Windows
never shares a port).  A second reader of the same port, a second patch, gets :class:`PortBusy`, reported
once as :class:`OpenFailed` ("busy: another program has PATH open"), and opens the port when the first
lets it go: shared, each would read part of the bytes, and every read the other left empty would look
like an unplugged device.  A program that opens the port without a lock (``cat``, ``screen``) is not
kept out.

Nothing raised in the thread kills it silently: callback errors are logged and reported as
:class:`ReaderError` and the loop goes on; an unexpected error in the loop itself is logged, reported,
and followed by a reopen.

Without the thread, an event loop drives the same reader (the ``mote`` node does, on pointat's
scheduler thread): :meth:`SerialMoteReader.open` with ``nonblocking=True``, then
:meth:`~SerialMoteReader.poll` whenever :meth:`~SerialMoteReader.fileno` is readable and
:meth:`~SerialMoteReader.check` now and then; each returns ``False`` once the device is lost (reported
and closed), and reopening is then the loop's to schedule (unless :attr:`~SerialMoteReader.ended`).

Examples
--------
A pseudo-terminal stands in for the base station:

>>> import os, time, tty
>>> from pointat.devices.mote_frame import Frame, encode_frame
>>> master, slave = os.openpty()
>>> _ = tty.setraw(slave)  # no echo, no line editing until the reader configures it
>>> got = []
>>> with SerialMoteReader(os.ttyname(slave), on_frame=lambda frame, t: got.append(frame)) as reader:
...     reader.wait_open(timeout=5.0)
...     _ = os.write(master, encode_frame(Frame(1, 0, (2048,) * 9)))
...     deadline = time.monotonic() + 5.0
...     while not got and time.monotonic() < deadline:
...         time.sleep(0.01)
True
>>> got[0].mote, got[0].n_pack, got[0].channels
(1, 0, (2048, 2048, 2048, 2048, 2048, 2048, 2048, 2048, 2048))
>>> os.close(master); os.close(slave)
"""

from __future__ import annotations

import errno
import logging
import os
import re
import threading
import time
from collections.abc import Callable
from typing import Any, NamedTuple

import serial

from pointat.devices._threads import join, start_daemon
from pointat.devices.mote_frame import Frame, FrameEvent, FrameFormat, FrameParser, ParserStats

__all__ = [
    "DeviceLost",
    "DeviceOpened",
    "OpenFailed",
    "PortBusy",
    "ReaderError",
    "ReaderEvent",
    "SerialMoteReader",
    "driver_low_latency",
    "numbered_pty",
    "release_low_latency",
    "request_low_latency",
]

log = logging.getLogger(__name__)


class DeviceOpened(NamedTuple):
    """The port at ``path`` (resolving to ``device``) was opened; ``count`` opens so far, this included."""

    path: str
    device: str
    count: int


class DeviceLost(NamedTuple):
    """The open port at ``path`` failed or vanished; it was closed and will be reopened, unless ``final``
    (a pseudo-terminal named by its number: see :func:`numbered_pty`)."""

    path: str
    reason: str
    final: bool = False


class OpenFailed(NamedTuple):
    """Opening ``path`` failed (reported once per outage; retries go on quietly)."""

    path: str
    reason: str


class PortBusy(serial.SerialException):
    """The port is open in another program that locked it (every reader here does: ``exclusive``)."""


class ReaderError(NamedTuple):
    """An exception in a callback (``where`` = ``"on_frame"``) or in the reader loop (``"loop"``)."""

    path: str
    where: str
    reason: str


#: The ``serial_struct`` flag of the driver's low-latency mode (``linux/tty_flags.h``).
ASYNC_LOW_LATENCY = 0x2000


def request_low_latency(port: Any) -> str:
    """Ask the driver of an open port for its low-latency mode: ``"on"`` when the driver accepted the
    request, ``"already on"`` when the port was in that mode (left as it is), else
    ``"unsupported: REASON"``.  Never raises: a port without the mode runs as it is.

    On Linux this sets ``ASYNC_LOW_LATENCY`` (``TIOCSSERIAL``, allowed without privileges).  The
    ``ftdi_sio`` driver then sets the adapter's latency timer to 1 ms instead of 16 ms, so a 21-byte mote
    frame leaves the adapter within a millisecond instead of waiting for 62 bytes or the timer.  The
    driver keeps the setting after the port closes, so whoever turned it on turns it off again
    (:func:`release_low_latency`; the reader does when it closes a port it set).  Some drivers accept the
    request and ignore it.  Pseudo-terminals refuse it, and pyserial has it on Linux only.
    """
    setter = getattr(port, "set_low_latency_mode", None)
    if setter is None:  # Windows
        return "unsupported: not on this system"
    if driver_low_latency(port):
        return "already on"
    try:
        setter(True)
    except NotImplementedError:  # pyserial on macOS and the BSDs
        return "unsupported: not on this system"
    except Exception as exc:  # pyserial raises the ioctl's OSError as a ValueError
        cause = exc if isinstance(exc, OSError) else exc.__context__
        return f"unsupported: {getattr(cause, 'strerror', None) or exc}"
    return "on"


def release_low_latency(port: Any) -> None:
    """Turn the low-latency mode that :func:`request_low_latency` turned on off again (before closing the
    port).  Never raises: an adapter already unplugged has nothing to restore."""
    try:
        port.set_low_latency_mode(False)
    except Exception as exc:  # the device vanished, or the driver changed its mind
        log.debug("low-latency mode of %s not restored: %s", getattr(port, "port", port), exc)


def driver_low_latency(port: Any) -> bool | None:
    """Whether the driver of an open port is in its low-latency mode (Linux ``TIOCGSERIAL``), ``None``
    when the port cannot say (a pseudo-terminal, another system)."""
    try:
        import array
        import fcntl
        import termios

        buf = array.array("i", [0] * 32)  # struct serial_struct, as pyserial reads it; flags at [4]
        fcntl.ioctl(port.fileno(), termios.TIOCGSERIAL, buf)
    except (ImportError, AttributeError, OSError, ValueError):
        return None
    return bool(buf[4] & ASYNC_LOW_LATENCY)


_NUMBERED_PTY = re.compile(r"/dev/pts/[0-9]+|/dev/ttys[0-9]+")  # Linux and the BSDs; macOS


def numbered_pty(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` names a pseudo-terminal by its number (``/dev/pts/3``; macOS ``/dev/ttys003``),
    not through a link.  Such a name belongs to no device: when the terminal closes, the next one opened
    on the machine takes it, so a reader does not open it again.

    >>> numbered_pty("/dev/pts/3"), numbered_pty("/dev/ttyUSB0"), numbered_pty("/dev/ttyS0")
    (True, False, False)
    """
    path = os.fspath(path)
    return _NUMBERED_PTY.fullmatch(os.path.abspath(path)) is not None and not os.path.islink(path)


def _latency_timer(path: str) -> str | None:
    """The ``latency_timer`` file of the Linux USB-serial adapter at ``path`` (FTDI), or ``None``."""
    name = os.path.basename(os.path.realpath(path))
    timer = f"/sys/bus/usb-serial/devices/{name}/latency_timer"
    return timer if os.path.exists(timer) else None


def _read_number(path: str) -> float | None:
    """The number in a small sysfs file, or ``None`` when it cannot be read."""
    try:
        with open(path) as f:
            return float(f.read().strip())
    except (OSError, ValueError):
        return None


ReaderEvent = DeviceOpened | DeviceLost | OpenFailed | ReaderError
"""Device-level events of a :class:`SerialMoteReader` (parser events come through too)."""

FrameCallback = Callable[[Frame, float], Any]
EventCallback = Callable[[Any], Any]


class Backoff:
    """Delays between attempts to reopen a lost device: ``first``, doubling up to ``largest``.

    Whoever drives the reader (its own thread, or an event loop such as the ``mote`` node's) follows the
    same policy: :meth:`reset` once the device has delivered data, so a device that comes back is tried
    again at once, while one that fails right after opening backs off and cannot make the loop spin.

    >>> b = Backoff(0.05, 0.15)
    >>> [b.next() for _ in range(4)], b.reset(), b.next()
    ([0.05, 0.1, 0.15, 0.15], None, 0.05)
    """

    def __init__(self, first: float, largest: float) -> None:
        if not 0 < first <= largest:
            raise ValueError(
                f"backoff must be (first, largest) with 0 < first <= largest, got {(first, largest)}"
            )
        self.first, self.largest = float(first), float(largest)
        self._delay = self.first

    def next(self) -> float:
        """The delay before the next attempt; the one after it doubles (up to ``largest``)."""
        delay = self._delay
        self._delay = min(2.0 * delay, self.largest)
        return delay

    def reset(self) -> None:
        """Back to ``first``."""
        self._delay = self.first


class SerialMoteReader:
    """Background reader of mote frames from a serial device, reopening it when it comes back.

    Parameters
    ----------
    port_path : str
        Serial device path (``/dev/ttyUSB0``, a udev symlink, a pseudo-terminal slave...).
    baudrate : int
        Line speed; ignored by pseudo-terminals.
    on_frame : callable, optional
        ``on_frame(frame, host_time)``, called in the reader thread for every good frame, in stream
        order; ``host_time`` is :func:`time.monotonic` (seconds) when the bytes that completed the
        frame were read (frames completed by one read share it).
    on_event : callable, optional
        ``on_event(event)``, called in the reader thread with every parser event
        (:data:`~pointat.devices.mote_frame.FrameEvent`) and device event (:data:`ReaderEvent`).
        The parser events of one read come after that read's frames.
    format : {"auto", "binary", "text"}
        Framing, passed to :class:`~pointat.devices.mote_frame.FrameParser`.
    read_timeout : float
        Seconds a read waits for data; bounds how quickly :meth:`stop` and path checks react.
    backoff : tuple of float
        ``(first, largest)`` delay in seconds between attempts to reopen; doubles up to ``largest``.
    max_gap : int
        Passed to the parser (largest counter gap counted as lost packets).
    rate : float, optional
        The motes' sample rate (Hz), passed to the parser with the time of each read: a counter gap
        larger than a mote could have sent since its last frame is a restart, not loss.
    low_latency : bool
        Ask the serial driver for its low-latency mode at every open (Linux: ``ASYNC_LOW_LATENCY``, see
        :func:`request_low_latency`).  A USB-serial adapter otherwise holds a short frame back: an FTDI
        chip sends what it has every 16 ms by default, 1 ms in this mode.  Devices without the mode (a
        pseudo-terminal, many adapters) open as they are; :attr:`low_latency` says what happened.
    plain : callable, optional
        The parser's :attr:`~pointat.devices.mote_frame.FrameParser.plain`: a consumer that takes runs of
        plain frames itself (the ``mote`` node's compiled chains); ``on_frame`` hears the others.

    Notes
    -----
    Callbacks run in the reader thread: keep them short, or hand the work to a queue.
    """

    def __init__(
        self,
        port_path: str | os.PathLike[str],
        baudrate: int = 115200,
        on_frame: FrameCallback | None = None,
        on_event: EventCallback | None = None,
        *,
        format: FrameFormat = "auto",
        read_timeout: float = 0.05,
        backoff: tuple[float, float] = (0.05, 1.0),
        max_gap: int = 0x7FFF,
        rate: float | None = None,
        low_latency: bool = True,
        plain: Any = None,
    ) -> None:
        if read_timeout <= 0:
            raise ValueError(f"read_timeout must be > 0, got {read_timeout}")
        self.port_path = os.fspath(port_path)
        self.baudrate = baudrate
        self.on_frame = on_frame
        self.on_event = on_event
        self.read_timeout = read_timeout
        self.backoff = (float(backoff[0]), float(backoff[1]))
        #: The reopening policy, for the reader's thread and for an event loop that drives it.
        self.reopen = Backoff(*self.backoff)
        self._parser = FrameParser(format, max_gap=max_gap, rate=rate)
        self._parser.plain = plain  # (a consumer that takes plain frames itself: FrameParser.plain)
        self._lock = threading.Lock()  # guards the parser stats against concurrent snapshots
        self._stop = threading.Event()
        self._opened = threading.Event()
        self._thread: threading.Thread | None = None
        self._port: serial.Serial | None = None
        self._rdev: int | None = None
        self._open_count = 0
        self._got_data = False
        self._numbered_pty = False
        #: True once the device is lost for good (:func:`numbered_pty`): the reader opens it no more.
        self.ended = False
        self._nonblocking = False
        self._want_low_latency = low_latency
        #: After an open: ``"on"`` (the driver accepted the low-latency request; turned off again when
        #: the reader closes the port), ``"already on"`` (left as it was), ``"off"`` (not asked for), or
        #: ``"unsupported: REASON"`` (the device has no such mode; it runs as it is).
        self.low_latency = "off"
        self._latency_warned = False

    # -- public -----------------------------------------------------------------------------------

    @property
    def is_running(self) -> bool:
        """True while the reader thread is alive."""
        return self._thread is not None and self._thread.is_alive()

    @property
    def is_open(self) -> bool:
        """True while the device is open."""
        return self._opened.is_set()

    @property
    def delivered(self) -> bool:
        """Whether the device delivered data since it was last opened."""
        return self._got_data

    @property
    def open_count(self) -> int:
        """How many times the device was opened (reconnections + 1)."""
        return self._open_count

    def stats(self) -> ParserStats:
        """A snapshot of the parser's counters (frames, garbage, per-mote received / lost / corrupt)."""
        with self._lock:
            return self._parser.stats.copy()

    def start(self) -> SerialMoteReader:
        """Start the reader thread (no-op if running).  Returns ``self``."""
        if self.is_running:
            return self
        self._stop.clear()
        self._thread = start_daemon(self._run, f"mote-reader:{self.port_path}")
        return self

    def stop(self, timeout: float = 2.0) -> None:
        """Stop the thread and close the port; idempotent.  Waits at most ``timeout`` seconds."""
        self._stop.set()
        join(self._thread, timeout)
        self._close()  # idempotent; if the thread is stuck in a callback, its next read fails and it ends

    def wait_open(self, timeout: float) -> bool:
        """Block until the device is open or ``timeout`` seconds pass; return whether it is open."""
        return self._opened.wait(timeout)

    def __enter__(self) -> SerialMoteReader:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # -- thread -----------------------------------------------------------------------------------

    def _run(self) -> None:
        self.reopen.reset()
        failed_since_open = False
        while not self._stop.is_set() and not self.ended:
            if self._port is None:
                try:
                    self.open(nonblocking=False)
                except (serial.SerialException, OSError, ValueError) as exc:
                    if not failed_since_open:
                        log.warning("cannot open mote port %s: %s (retrying)", self.port_path, exc)
                        self._emit(OpenFailed(self.port_path, str(exc)))
                        failed_since_open = True
                    self._stop.wait(self.reopen.next())
                    continue
                failed_since_open = False
            if not self.poll() and not self._stop.is_set() and not self.ended:
                # lost: a device that delivered data retries at once; one that fails right after
                # opening backs off, so a broken but openable device cannot make the loop spin
                if self._got_data:
                    self.reopen.reset()
                else:
                    self._stop.wait(self.reopen.next())
        self._close()

    # -- driven by an event loop ----------------------------------------------------------------

    def open(self, *, nonblocking: bool = True) -> None:
        """Open the device now and report :class:`DeviceOpened` (for an event loop, not the thread).

        Raises :class:`serial.SerialException`, :class:`OSError` or :class:`ValueError` when it cannot be
        opened; the caller decides when to try again, unless :attr:`ended`.  ``nonblocking`` makes
        :meth:`poll` return at once.
        """
        if self.ended:
            raise serial.SerialException(f"{self.port_path} was a pseudo-terminal that closed: not reopened")
        self._open(timeout=0 if nonblocking else self.read_timeout)
        self._nonblocking = nonblocking
        self._emit(DeviceOpened(self.port_path, os.path.realpath(self.port_path), self._open_count))

    def fileno(self) -> int:
        """The open device's file descriptor (to wait on with ``select``); ``ValueError`` when closed."""
        if self._port is None:
            raise ValueError(f"{self.port_path} is not open")
        return self._port.fileno()

    def poll(self) -> bool:
        """Read and parse what the device has now, calling ``on_frame`` and ``on_event``.

        Returns ``False`` when the device was lost (reported as :class:`DeviceLost` and closed).
        """
        if self._port is None:
            return False
        try:
            self._poll()
        except (serial.SerialException, OSError) as exc:
            # a pty whose other end closed is gone from /dev at once; one that read empty while it is
            # still there lost its bytes to another reader (a program that does not lock the port)
            final = self._numbered_pty and bool(self._path_problem())
            self._lose(str(exc) or type(exc).__name__, final=final)
        except Exception as exc:  # keep the reader alive whatever happens, but say so
            log.exception("mote reader on %s: unexpected error", self.port_path)
            self._emit(ReaderError(self.port_path, "loop", repr(exc)))
            self._lose(repr(exc))
        return self._port is not None

    def check(self) -> bool:
        """Is the device still where its path says?  If not, report it lost, close it, return ``False``."""
        if self._port is None:
            return False
        reason = self._path_problem()
        if reason:
            self._lose(reason, final=self._numbered_pty)
        return self._port is not None

    def close(self) -> None:
        """Close the device (idempotent); nothing is reported."""
        self._close()

    # -- internals ------------------------------------------------------------------------------

    def _open(self, timeout: float | None = None) -> None:
        try:  # exclusive: a second reader would take half the bytes, and each read the other left empty
            port = serial.Serial(
                self.port_path,
                self.baudrate,
                timeout=self.read_timeout if timeout is None else timeout,
                exclusive=True,
            )
        except serial.SerialException as exc:
            if exc.errno in (errno.EAGAIN, errno.EWOULDBLOCK):  # the lock (flock) is held
                raise PortBusy(
                    f"busy: another program has {self.port_path} open (a second pointat? a serial monitor?)"
                ) from exc
            raise
        try:
            self._rdev = os.stat(self.port_path).st_rdev
        except OSError:
            self._rdev = None
        self._port = port
        self._got_data = False
        self._numbered_pty = numbered_pty(self.port_path)
        self._open_count += 1
        self.low_latency = request_low_latency(port) if self._want_low_latency else "off"
        self._opened.set()
        log.info("opened mote port %s (low-latency mode %s)", self.port_path, self.low_latency)
        timer = _latency_timer(self.port_path) if self.low_latency != "off" else None
        if timer is None or self._latency_warned:
            return
        if self.low_latency.startswith("unsupported"):
            self._latency_warned = True  # once, not at every reconnection
            log.warning(
                "mote port %s: the driver refused the low-latency mode (%s); the adapter may hold frames"
                " back for up to its latency timer (FTDI: 16 ms). As root: echo 1 > %s",
                self.port_path,
                self.low_latency,
                timer,
            )
            return
        ms = _read_number(timer)
        if ms is not None and ms > 1:  # some drivers accept the request and leave the timer as it was
            self._latency_warned = True
            log.warning(
                "mote port %s: the driver took the low-latency mode, but the adapter's latency timer is"
                " still %g ms: it may hold frames back that long. As root: echo 1 > %s",
                self.port_path,
                ms,
                timer,
            )

    def _poll(self) -> None:
        port = self._port
        assert port is not None
        if self._nonblocking:  # woken by select: one read of what is there (pyserial's read adds a select)
            try:
                data = os.read(port.fd, 65536)
            except (BlockingIOError, InterruptedError):
                return
            if not data:
                raise serial.SerialException(
                    "device reports readiness to read but returned no data (unplugged?)"
                )
        else:
            data = port.read(max(1, port.in_waiting))
        if not data:  # idle: is the device still where its path says?
            self.check()
            return
        host_time = time.monotonic()
        with self._lock:
            frames = self._parser.feed(data, host_time)
            events = self._parser.pop_events()
        for frame in frames:
            if self.on_frame is not None:
                try:
                    self.on_frame(frame, host_time)
                except Exception as exc:
                    log.exception("mote reader on %s: on_frame failed", self.port_path)
                    self._emit(ReaderError(self.port_path, "on_frame", repr(exc)))
        for event in events:
            self._emit(event)
        self._got_data = True

    def _path_problem(self) -> str:
        try:
            rdev = os.stat(self.port_path).st_rdev
        except FileNotFoundError:
            return "device path vanished"
        except OSError as exc:
            return f"device path unreadable: {exc}"
        if self._rdev is not None and rdev != self._rdev:
            return "device path now names another device"
        return ""

    def _lose(self, reason: str, *, final: bool = False) -> None:
        log.info("lost mote port %s: %s", self.port_path, reason)  # the owner hears of it: DeviceLost
        self._close()
        with self._lock:
            self._parser.flush()  # a frame cut by the outage is garbage
            events = self._parser.pop_events()
        for event in events:
            self._emit(event)
        self.ended = final
        self._emit(DeviceLost(self.port_path, reason, final))

    def _close(self) -> None:
        port, self._port = self._port, None
        self._opened.clear()
        if port is not None:
            if self.low_latency == "on":  # what this reader turned on, it turns off
                release_low_latency(port)
            try:
                port.close()
            except (serial.SerialException, OSError) as exc:
                log.debug("closing %s: %s", self.port_path, exc)

    def _emit(self, event: FrameEvent | ReaderEvent) -> None:
        if self.on_event is None:
            return
        try:
            self.on_event(event)
        except Exception:
            log.exception("mote reader on %s: on_event failed for %r", self.port_path, event)
