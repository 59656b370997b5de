"""What surrounds a patch while ``pointat run`` runs it: the console's and the log's writers and the
signals that stop it (:func:`console`), real-time priority (:func:`realtime`, ``--rt``), and the run
itself with the monitor and the status lines started and stopped around it (:func:`run_until_done`)."""

from __future__ import annotations

import argparse
import contextlib
import logging
import os
import signal
import sys
import threading
from collections.abc import Iterator
from typing import Any

from ..monitor import Observer
from ..scheduling import CPU_DMA_LATENCY, keep_cpus_awake, quiet_thread, realtime_priority
from ..terminal import LineHandler, LineWriter

log = logging.getLogger("pointat")

#: The log's lines, here and before the run starts (:func:`pointat.cli.main`).
LOG_FORMAT = "%(levelname)s %(name)s: %(message)s"


@contextlib.contextmanager
def console(rt: Any) -> Iterator[LineWriter]:
    """The console's and the log's lines written by threads of their own, and Ctrl-C or a kill stopping
    the patch, while the block runs; yields the console's writer.

    A terminal paused with Ctrl-S, or a pipe nobody reads, must not stop the patch (lines that do not
    fit are counted).  Python's warnings go to the log too."""

    def reader_gone() -> None:  # pointat run ... | head: stop, quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        rt.stop()

    def on_signal(signum: int, _frame: object) -> None:
        log.info("signal %d: stopping", signum)
        rt.stop()

    root = logging.getLogger()
    saved_handlers = root.handlers[:]
    # (signals are the main thread's to set: main() embedded in another thread leaves them alone)
    ours = threading.current_thread() is threading.main_thread()
    saved_signals = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)} if ours else {}
    out = LineWriter(sys.stdout, on_broken=reader_gone, name="console")
    err = LineWriter(sys.stderr, name="log")
    try:
        # on one terminal, log lines go above the status lines too (one writer owns the screen)
        handler = LineHandler(out if out.tty and _same_terminal() else err)
        handler.setFormatter(logging.Formatter(LOG_FORMAT))
        root.handlers = [handler]
        logging.captureWarnings(True)
        rt.console = out.write
        for sig in saved_signals:
            signal.signal(sig, on_signal)
        yield out
    finally:
        logging.captureWarnings(False)
        root.handlers = saved_handlers
        # what waits is written before the end, as any program's output: a terminal still paused holds
        # the exit until Ctrl-Q (or Ctrl-C or a kill, which now end it at once)
        for sig in saved_signals:
            signal.signal(sig, signal.SIG_DFL)
        out.close(None)
        err.close(None)
        for sig, previous in saved_signals.items():
            signal.signal(sig, signal.SIG_DFL if previous is None else previous)


@contextlib.contextmanager
def realtime(wanted: bool) -> Iterator[None]:
    """``--rt``: real-time priority and the CPUs kept out of deep idle states while the block runs (each
    refusal logged, the patch run anyway)."""
    awake = None
    try:
        if wanted:
            refused = realtime_priority()
            if refused:
                log.warning("--rt: real-time priority %s; running at normal priority", refused)
            else:
                log.info("running at real-time priority (SCHED_FIFO)")
            awake, why = keep_cpus_awake()
            if why:
                log.warning("--rt: the CPUs may sleep deeply between samples: %s", why)
            else:
                log.info(
                    "the CPUs are kept out of deep idle states while the patch runs (%s)", CPU_DMA_LATENCY
                )
        yield
    finally:
        if awake is not None:
            os.close(awake)


def run_until_done(
    rt: Any, observer: Observer, server: Any, out: LineWriter, args: argparse.Namespace
) -> None:
    """Start the monitor, the patch and the status lines; run until the end; then stop them and write the
    observer's summary."""
    if server is not None:
        server.start()  # (before the clock starts: its threads and zeroconf take a moment)
    rt.start()
    if server is not None:  # the page's readings; the console takes its own when it writes
        observer.start()
    if rt.reloader is not None:
        rt.reloader.start()
    every = args.status if args.status is not None else 1.0 if out.tty else 5.0
    ticker = _Ticker(every, lambda: out.status(observer.status_lines())) if every > 0 else None
    try:
        rt.run(args.duration)
    finally:
        if rt.reloader is not None:
            rt.reloader.stop()
        if ticker is not None:
            ticker.stop()
        out.status([])
        for line in observer.summary():
            out.write(line)
        observer.stop()
        if server is not None:
            server.close()


class _Ticker:
    """Call ``fn`` every ``every`` seconds from a quiet thread until :meth:`stop`."""

    def __init__(self, every: float, fn: Any):
        self._stop = threading.Event()
        self._every, self._fn = every, fn
        self._thread = quiet_thread(threading.Thread(target=self._run, name="pointat-status", daemon=True))
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(self._every):
            try:
                self._fn()
            except Exception:  # a status line is never worth the patch
                log.debug("status line failed", exc_info=True)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(1.0)


def _same_terminal() -> bool:
    try:
        return os.isatty(sys.stderr.fileno()) and os.ttyname(sys.stderr.fileno()) == os.ttyname(
            sys.stdout.fileno()
        )
    except (OSError, ValueError, AttributeError):
        return False
