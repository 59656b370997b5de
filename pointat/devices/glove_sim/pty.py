"""The simulated glove in real time on a pseudo-terminal, for the real serial path without hardware.

:class:`PtyGlove` writes :class:`~pointat.devices.glove_sim.GloveSimulator` frames on their schedule, so
:class:`~pointat.devices.serial_reader.SerialMoteReader` can be exercised as with a base station.
"""

from __future__ import annotations

import logging
import os
import threading
import time
import tty
from typing import Literal

from pointat.devices._threads import join, start_daemon
from pointat.devices.mote_frame import encode_frame, encode_text

from .simulator import GloveSimulator

log = logging.getLogger(__name__)


class PtyGlove:
    """A simulated glove behind a pseudo-terminal: open :attr:`device_path` like a real base station.

    A thread writes one encoded frame per sample period to the pty master, on a deadline schedule
    (``next += period``), so the rate does not drift.  The master is non-blocking: when nobody reads the
    device, bytes pile up in the pty (~18 kB on Linux) and then in a buffer of ``max_pending`` bytes,
    beyond which they are dropped (counted in :attr:`dropped_bytes`), as a radio would.

    Parameters
    ----------
    simulator : GloveSimulator, optional
        Source of the frames (default ``GloveSimulator()``).
    format : {"binary", "text"}
        Framing written to the device.
    start_index : int
        First sample index to send.
    max_pending : int
        Bytes kept while the device is not read.

    Examples
    --------
    >>> with PtyGlove(GloveSimulator(rate_hz=200.0)) as glove:
    ...     glove.device_path.startswith("/dev/")
    True
    """

    def __init__(
        self,
        simulator: GloveSimulator | None = None,
        *,
        format: Literal["binary", "text"] = "binary",
        start_index: int = 0,
        max_pending: int = 65536,
    ) -> None:
        if format not in ("binary", "text"):
            raise ValueError(f"format must be 'binary' or 'text', got {format!r}")
        self.simulator = simulator if simulator is not None else GloveSimulator()
        self.format = format
        self.max_pending = int(max_pending)
        self._encode = encode_frame if format == "binary" else encode_text
        self._index = int(start_index)
        self._pending = bytearray()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()
        self.sent = 0
        self.dropped_bytes = 0
        self._master, self._slave = os.openpty()
        try:
            tty.setraw(self._slave)  # no echo into the master, no line discipline before a reader opens it
            os.set_blocking(self._master, False)
            self.device_path: str = os.ttyname(self._slave)
        except OSError:
            os.close(self._master)
            os.close(self._slave)
            raise
        self._closed = False

    @property
    def index(self) -> int:
        """Index of the next sample to send."""
        return self._index

    @property
    def is_running(self) -> bool:
        """True while the writer thread is alive."""
        return self._thread is not None and self._thread.is_alive()

    def start(self) -> PtyGlove:
        """Start sending (no-op if running).  Returns ``self``."""
        if self._closed:
            raise RuntimeError("PtyGlove is closed")
        if not self.is_running:
            self._stop.clear()
            self._thread = start_daemon(self._run, f"pty-glove:{self.device_path}")
        return self

    def stop(self, timeout: float = 2.0) -> None:
        """Stop sending; idempotent.  The device stays open (see :meth:`close`)."""
        self._stop.set()
        join(self._thread, timeout)

    def skip(self, n: int) -> None:
        """Leave out the next ``n`` samples: frames lost on the way (a glove out of radio range)."""
        with self._lock:
            self._index += max(0, int(n))

    def close(self) -> None:
        """Stop and close the pseudo-terminal (readers then see the device vanish); idempotent."""
        self.stop()
        if not self._closed:
            self._closed = True
            for fd in (self._master, self._slave):
                try:
                    os.close(fd)
                except OSError as exc:
                    log.debug("closing pty fd %d: %s", fd, exc)

    def __enter__(self) -> PtyGlove:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def send(self, k: int | None = None) -> None:
        """Encode sample ``k`` (default: the next one) and write it now; used by the thread and tests."""
        with self._lock:
            if k is None:
                k = self._index
                self._index += 1
            self._pending += self._encode(self.simulator.sample(k).frame)
            self.sent += 1
            try:
                n = os.write(self._master, self._pending)
                del self._pending[:n]
            except BlockingIOError:
                pass
            if len(self._pending) > self.max_pending:
                self.dropped_bytes += len(self._pending)
                log.debug(
                    "pty glove %s: nobody reads, dropped %d bytes", self.device_path, len(self._pending)
                )
                self._pending.clear()

    def _run(self) -> None:
        period = self.simulator.period
        deadline = time.monotonic()
        while not self._stop.is_set():
            try:
                self.send()
            except OSError as exc:
                log.error("pty glove %s: write failed: %s", self.device_path, exc)
                break
            except Exception:  # never die silently
                log.exception("pty glove %s: unexpected error", self.device_path)
                break
            deadline += period
            late = time.monotonic() - deadline
            if late > 0.25:  # stalled (debugger, suspended VM): restart the schedule instead of bursting
                log.warning("pty glove %s: %.3f s late, restarting the schedule", self.device_path, late)
                deadline = time.monotonic()
            elif late < 0:
                self._stop.wait(-late)
