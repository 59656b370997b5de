"""What the runtime's scheduler is made of: clocks, timers, the descriptor set it sleeps on, and the
operating system's real-time settings (``pointat run --rt``).  Nothing here knows of nodes or patches."""

from __future__ import annotations

import logging
import math
import os
import select
import selectors
import struct
import threading
import time
import weakref
from collections.abc import Callable
from typing import Any, Protocol

__all__ = [
    "CPU_DMA_LATENCY",
    "ManualClock",
    "RealClock",
    "Scheduler",
    "Timer",
    "keep_cpus_awake",
    "quiet_thread",
    "realtime_priority",
]

log = logging.getLogger("pointat.runtime")


def realtime_priority(priority: int = 10) -> str | None:
    """Ask the system to run the calling thread, and the threads it starts later, at real-time
    (``SCHED_FIFO``) priority ``priority``, as Pd's ``-rt`` does: other work on the machine then cannot
    delay the scheduler.  Returns ``None`` when granted, else why not (the thread keeps its priority).
    """
    setter = getattr(os, "sched_setscheduler", None)
    if setter is None:
        return "real-time scheduling is not available on this system"
    try:
        setter(0, os.SCHED_FIFO, os.sched_param(priority))
    except PermissionError:
        return "not permitted: run as root, or allow it with an rtprio limit (/etc/security/limits.conf)"
    except OSError as exc:
        return str(exc)
    return None


#: Linux's PM QoS request for CPU wake-up latency: while a process holds it open with a number of
#: microseconds written, no CPU enters an idle state that takes longer than that to leave.
CPU_DMA_LATENCY = "/dev/cpu_dma_latency"


def keep_cpus_awake(max_wake_us: int = 0) -> tuple[int | None, str | None]:
    """Keep every CPU out of idle states slower to leave than ``max_wake_us`` µs, for as long as the
    returned descriptor stays open (Linux PM QoS, ``/dev/cpu_dma_latency``, as ``cyclictest`` and tuned's
    latency-performance profile do).  A sample that arrives at a CPU in a deep sleep state waits for it to
    wake (tens to hundreds of µs on a laptop); the price is power and heat while the patch runs.

    Returns ``(descriptor, None)``; close it to end the request (the system ends it when the process
    does).  Else ``(None, why not)``.
    """
    try:
        fd = os.open(CPU_DMA_LATENCY, os.O_WRONLY)
    except FileNotFoundError:
        return None, f"not available on this system (no {CPU_DMA_LATENCY})"
    except PermissionError:
        return None, f"not permitted: run as root, or give write access to {CPU_DMA_LATENCY} (a udev rule)"
    except OSError as exc:
        return None, str(exc)
    try:
        os.write(fd, struct.pack("=i", max_wake_us))
    except OSError as exc:
        os.close(fd)
        return None, str(exc)
    return fd, None


#: Threads that sleep until they are handed work and then want the interpreter only for a moment.
_QUIET: weakref.WeakSet[threading.Thread] = weakref.WeakSet()


def quiet_thread(thread: threading.Thread) -> threading.Thread:
    """Mark ``thread`` as one that sleeps until it is handed work and then wants the interpreter only for a
    moment (the console's and the log's writers): a spinning scheduler (``pointat run --spin``) polls
    without pauses beside it, as if it were not there.  Such a thread may wait for the interpreter up to
    :func:`sys.getswitchinterval` (5 ms) when it wakes.  Returns ``thread``."""
    _QUIET.add(thread)
    return thread


class RealClock:
    """Seconds since :meth:`reset`, from ``time.monotonic``."""

    def __init__(self) -> None:
        self.t0 = time.monotonic()

    def reset(self) -> None:
        self.t0 = time.monotonic()

    def now(self) -> float:
        return time.monotonic() - self.t0

    def from_monotonic(self, t: float) -> float:
        """Logical time of a ``time.monotonic()`` reading (a source thread's receive time)."""
        return t - self.t0


class ManualClock:
    """A clock that moves only when told to (tests)."""

    def __init__(self) -> None:
        self.t = 0.0

    def reset(self) -> None:
        self.t = 0.0

    def now(self) -> float:
        return self.t

    def from_monotonic(self, t: float) -> float:
        return self.t


class Timer:
    """A scheduled call; :meth:`cancel` it to drop it.  A ``daemon`` timer (a heartbeat) does not keep
    a patch running whose sources have all ended."""

    __slots__ = ("when", "seq", "node", "fn", "args", "cancelled", "daemon")

    def __init__(self, when: float, seq: int, node: Any, fn: Callable, args: tuple):
        self.when, self.seq, self.node, self.fn, self.args = when, seq, node, fn, args
        self.cancelled = False
        self.daemon = False

    def __lt__(self, other: Timer) -> bool:
        return (self.when, self.seq) < (other.when, other.seq)

    def cancel(self) -> None:
        self.cancelled = True


class _Reader:
    """A watched descriptor's callback, and how often in a row it has failed."""

    #: Consecutive failures after which a descriptor is no longer watched (a callback that raises before
    #: reading leaves its descriptor readable: the scheduler would spin on it).
    GIVE_UP = 100

    __slots__ = ("fileobj", "node", "callback", "failures", "watched")

    def __init__(self, fileobj: Any, node: Any, callback: Callable[[], Any]) -> None:
        self.fileobj, self.node, self.callback, self.failures = fileobj, node, callback, 0
        self.watched = True  # False once removed: a reader earlier in the same wake-up may remove it


#: The descriptors ``select`` can watch are those below this number (the C library's ``FD_SETSIZE``).
_FD_SETSIZE = 1024


class _Descriptors:
    """The descriptors the scheduler sleeps on, each with its data: ``epoll`` itself where there is one.

    :mod:`selectors` does the same in Python around the system call (a key object and an event mask per
    ready descriptor, about a microsecond a wake-up); the scheduler needs only the data.  Elsewhere
    (macOS, Windows) the :mod:`selectors` default does the work.
    """

    def __init__(self, epoll: bool = hasattr(select, "epoll")) -> None:
        self._epoll = select.epoll() if epoll else None
        # select() takes descriptors below FD_SETSIZE only: an epoll made in a process with more files
        # open than that sleeps to the millisecond, as epoll does by itself
        self._fine = self._epoll is not None and self._epoll.fileno() < _FD_SETSIZE
        self._fallback = None if self._epoll is not None else selectors.DefaultSelector()
        self._data: dict[int, Any] = {}  # fd -> data
        # fd -> the object registered, held so that its id stays its own while it is watched; and that
        # id -> fd, to find the descriptor of an object closed before it is unregistered
        self._objs: dict[int, Any] = {}
        self._fds: dict[int, int] = {}

    def register(self, fileobj: Any, data: Any) -> None:
        fd = fileobj if isinstance(fileobj, int) else fileobj.fileno()
        if fd in self._data:
            raise KeyError(f"descriptor {fd} is watched already")
        if self._epoll is not None:
            self._epoll.register(fd, select.EPOLLIN)
        else:
            self._fallback.register(fd, selectors.EVENT_READ, data)
        self._data[fd] = data
        self._objs[fd] = fileobj
        self._fds[id(fileobj)] = fd

    def unregister(self, fileobj: Any) -> Any:
        """Stop watching ``fileobj`` (a descriptor, or an object with ``fileno()``, closed or not); return
        its data.  ``KeyError`` when it is not watched."""
        fd = self._fds.get(id(fileobj))
        if fd is None or self._objs[fd] is not fileobj:  # registered the other way (number / object)
            fd = fileobj if isinstance(fileobj, int) else fileobj.fileno()
        if fd not in self._data:
            raise KeyError(f"descriptor {fd} is not watched")
        data = self._data.pop(fd)
        del self._fds[id(self._objs.pop(fd))]
        try:
            if self._epoll is not None:
                self._epoll.unregister(fd)
            else:
                self._fallback.unregister(fd)
        except (KeyError, ValueError, OSError):  # closed already: the system forgot it by itself
            pass
        return data

    def select(self, timeout: float) -> list[Any]:
        """The data of the descriptors ready to read, waiting up to ``timeout`` seconds (0: do not wait).

        The wait ends within the system's timer slack of ``timeout`` (50 µs for a normal thread on
        Linux), not at the next whole millisecond: epoll counts its timeout in milliseconds, rounded up,
        and a timer 0.3 ms away would run 0.7 ms late.  So epoll sleeps the whole milliseconds and
        :meth:`wait` the rest.  Input wakes either at once.  Input that comes while epoll sleeps costs
        one system call, as before; while a timer is due within the millisecond (a 1 kHz ``metro`` or
        simulated glove: at every sleep), it costs two (``select``, then ``epoll_wait`` at once).
        """
        if self._epoll is None:
            return [key.data for key, _ in self._fallback.select(timeout)]
        if timeout > 0.0 and self._fine:
            whole = math.floor(timeout * 1000.0)
            if not whole:
                return self.wait(timeout)
            end = time.monotonic() + timeout
            ready = self._epoll.poll((whole - 0.5) / 1000.0)  # rounded up: exactly `whole` ms
            if not ready:
                rest = end - time.monotonic()
                return self.wait(rest) if rest > 0.0 else []
        else:
            ready = self._epoll.poll(max(timeout, 0.0))  # a signal: retried (PEP 475)
        data = self._data
        return [data[fd] for fd, _ in ready if fd in data]

    def wait(self, timeout: float) -> list[Any]:
        """As :meth:`select`, in one ``select`` on the epoll descriptor itself (readable when a watched
        one is), which counts microseconds; the spinning scheduler's short waits, and the rest of a
        :meth:`select` after its whole milliseconds."""
        if not self._fine:
            return self.select(timeout)
        if not select.select([self._epoll.fileno()], [], [], timeout)[0]:
            return []
        return self.select(0.0)

    def close(self) -> None:
        if self._epoll is not None:
            self._epoll.close()
        else:
            self._fallback.close()
        self._data.clear()
        self._objs.clear()
        self._fds.clear()


class Scheduler(Protocol):
    """What a node may ask of the runtime it runs in (:class:`pointat.runtime.Runtime` is the one): so
    that the node model names the runtime's surface without importing the runtime."""

    nodes: dict[str, Any]  # name -> node
    bus: dict[str, list[Any]]  # send/receive buses: name -> receive nodes
    clock: RealClock | ManualClock
    depth: int  # nested synchronous dispatch (Node.out)
    running: bool
    stopping: threading.Event
    console: Callable[[str], None]

    def call_at(self, when: float, node: Any, fn: Callable, *args: Any) -> Timer: ...

    def at_pass_end(self, node: Any, fn: Callable[[], Any]) -> None: ...

    def post(self, node: Any, fn: Callable, *args: Any, block: bool = True) -> bool: ...

    def add_reader(self, fileobj: Any, callback: Callable[[], Any], node: Any = None) -> None: ...

    def remove_reader(self, fileobj: Any) -> None: ...

    def spawn(self, node: Any, target: Callable[[], Any], what: str = "") -> threading.Thread: ...

    @staticmethod
    def message(selector: str | Any, *args: Any) -> Any: ...
