"""How the scheduler thread waits for input: one select (epoll) over the descriptors it reads and a
socket pair that another thread writes to wake it; slept in until input, a post or the next timer, or,
with ``spin`` seconds (``pointat run --spin MS``), polled for that long after each input.

The scheduler sleeps in :meth:`Waiter.wait`; :meth:`Waiter.wake` ends that sleep from any thread (a
post).  What is read, and what runs when a descriptor is ready, is the runtime's
(:mod:`pointat.runtime`); the selector itself is :class:`pointat.scheduling._Descriptors`.
"""

from __future__ import annotations

import math
import socket
import threading
import time
from typing import Any

from .scheduling import _QUIET, _Descriptors

__all__ = ["Waiter"]


class Waiter:
    """The scheduler's wait: the descriptors it sleeps on (made when first needed, closed by
    :meth:`close`), the wake-up socket among them (its data: None), and the spin window."""

    #: While other Python threads share the process (a simulated glove's writer, a replay, MIDI input),
    #: spinning waits this long in select between polls, so that they get the interpreter: a thread that
    #: only polls would hold it nearly all the time.  The wait ends at once when input comes.  Threads
    #: marked with :func:`quiet_thread <pointat.scheduling.quiet_thread>` (the console's and the log's
    #: writers) do not count.
    SPIN_GRAIN = 50e-6

    def __init__(self) -> None:
        self._selector: _Descriptors | None = None
        self._wake_r: socket.socket | None = None
        self._wake_w: socket.socket | None = None
        self._sleeping = False
        #: Seconds after each input during which :meth:`wait` polls instead of sleeping (0: never).
        self.spin_for = 0.0
        self._input_at = -math.inf  # when a pass last served input (time.monotonic)

    def descriptors(self) -> _Descriptors:
        """The descriptors the scheduler sleeps on, with the wake-up socket (made on first use)."""
        if self._selector is None:
            self._selector = _Descriptors()
            self._wake_r, self._wake_w = socket.socketpair()
            self._wake_r.setblocking(False)
            self._wake_w.setblocking(False)
            self._selector.register(self._wake_r, None)
        return self._selector

    def unregister(self, fileobj: Any) -> Any:
        """Stop watching ``fileobj``; its data, or None when it was not watched (or nothing ever was)."""
        if self._selector is None:
            return None
        try:
            return self._selector.unregister(fileobj)
        except (KeyError, ValueError, OSError):
            return None

    def wake(self) -> None:
        """Wake the scheduler's select when it sleeps (a posted event is waiting)."""
        if self._sleeping and self._wake_w is not None:
            try:
                self._wake_w.send(b"\0")
            except (BlockingIOError, OSError):  # already full of wake-ups, or closed at shutdown
                pass

    def woken(self) -> None:
        """Empty the wake-up socket (it was among the ready: its data is None)."""
        try:
            while self._wake_r.recv(4096):  # type: ignore[union-attr]
                pass
        except (BlockingIOError, OSError):
            pass

    def wait(self, timeout: float, waiting: Any, realtime: bool) -> list[Any]:
        """The data of the descriptors ready to read, once one is, a post comes (``waiting``: the queue,
        non-empty) or ``timeout`` passes; spinning first when :attr:`spin_for` says so (real time only)."""
        selector = self.descriptors()
        if self.spin_for and realtime and timeout > 0.0 and not waiting:
            return self._spin(selector, timeout, waiting)
        return self._sleep(selector, timeout, waiting)

    def served(self) -> None:
        """Input was served: the spin window starts again from now."""
        if self.spin_for:
            self._input_at = time.monotonic()

    def _sleep(self, selector: _Descriptors, timeout: float, waiting: Any) -> list[Any]:
        """Sleep in select until a descriptor is readable, a post comes or ``timeout`` passes."""
        self._sleeping = True
        try:
            if waiting:  # checked after _sleeping is set: a post from now on wakes us
                timeout = 0.0
            return selector.select(timeout)
        finally:
            self._sleeping = False

    def spin_grain(self) -> float:
        """:attr:`SPIN_GRAIN` while a thread that may want the interpreter shares the process, else 0."""
        others = threading.active_count() - 1 - sum(1 for t in list(_QUIET) if t.is_alive())
        return self.SPIN_GRAIN if others > 0 else 0.0

    def _spin(self, selector: _Descriptors, timeout: float, waiting: Any) -> list[Any]:
        """Poll while the last input is less than :attr:`spin_for` old (and ``timeout`` has not passed),
        then sleep for the rest of ``timeout``.

        A scheduler that sleeps between samples is woken by the system when the next one arrives, which
        costs tens of microseconds (more on a virtual machine, or a CPU in a deep idle state); polling
        keeps that wake-up out of every sample's latency, for a CPU kept busy while input flows.  A post
        from another thread is seen at the next poll (it need not wake anyone).
        """
        start = now = time.monotonic()
        end = start + timeout
        until = min(self._input_at + self.spin_for, end)
        grain = self.spin_grain()
        while now < until:
            ready = selector.select(0.0) if not grain else selector.wait(min(grain, until - now))
            if ready or waiting:
                return ready
            now = time.monotonic()
        return self._sleep(selector, max(0.0, end - now), waiting)

    def close(self) -> None:
        """Close the descriptors' selector and the wake-up sockets (when they were made)."""
        if self._selector is not None:
            self._selector.close()
            self._wake_r.close()  # type: ignore[union-attr]
            self._wake_w.close()  # type: ignore[union-attr]
