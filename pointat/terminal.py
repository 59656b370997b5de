"""Console and log lines that never hold up a running patch.

Writing to a terminal blocks when nobody reads it: a terminal paused with Ctrl-S (XOFF), a pipe into a
pager or a slow program.  Written on the scheduler's thread, the next ``print`` node's line or warning
would then stop the whole patch (no OSC out, no serial in) until the reader comes back.  A
:class:`LineWriter` takes lines at once and writes them from a thread of its own; when
:attr:`LineWriter.limit` lines wait, the newest are dropped and counted, and the count is written when
the stream takes lines again.

>>> import io
>>> out = io.StringIO()
>>> w = LineWriter(out)
>>> w.write("azimuth 12.5")
>>> w.close()
True
>>> out.getvalue()
'azimuth 12.5\\n'
"""

from __future__ import annotations

import logging
import threading
from collections import deque
from collections.abc import Callable
from typing import TextIO

from .runtime import quiet_thread

__all__ = ["LineHandler", "LineWriter"]


class LineWriter:
    """Lines for ``stream``, written by a daemon thread; :meth:`write` never blocks.

    ``on_broken`` is called (in the writer's thread) when the stream's reader has gone for good
    (``BrokenPipeError``, as with ``pointat run ... | head``); lines are dropped from then on.
    """

    #: Lines kept while the stream does not take them (a few seconds of a busy ``print``).
    limit = 2000

    def __init__(self, stream: TextIO, on_broken: Callable[[], None] | None = None, name: str = "console"):
        self.stream = stream
        self.on_broken = on_broken
        self.dropped = 0  # lines dropped since the last notice
        self.lost = 0  # lines the stream refused (closed, or no stream at all)
        self.broken = False
        self._lines: deque[str] = deque()
        #: The status lines kept at the foot of a terminal, redrawn in place (:meth:`status`).
        self._footer: list[str] = []
        self._shown = 0  # footer lines on the screen now
        self._redraw = False
        try:
            self.tty = bool(stream.isatty())
        except (AttributeError, ValueError):
            self.tty = False
        self._cond = threading.Condition()
        self._busy = False  # the thread is writing lines it took
        self._closing = False
        # It sleeps until a line comes: a spinning scheduler need not pause for it (quiet_thread).
        self._thread = quiet_thread(threading.Thread(target=self._run, name=f"pointat-{name}", daemon=True))
        self._thread.start()

    def write(self, line: str) -> None:
        with self._cond:
            if self.broken or self._closing:
                return
            if len(self._lines) >= self.limit:
                self.dropped += 1
                return
            self._lines.append(line)
            self._cond.notify()

    def status(self, lines: list[str]) -> None:
        """Show ``lines`` as the status at the foot of a terminal, redrawn in place (other lines scroll
        above it); on a pipe or a file they are written as ordinary lines."""
        if not self.tty:
            for line in lines:
                self.write(line)
            return
        with self._cond:
            if self.broken or self._closing:
                return
            self._footer = list(lines)
            self._redraw = True
            self._cond.notify()

    def close(self, timeout: float | None = 1.0) -> bool:
        """Write what waits (for at most ``timeout`` seconds, ``None``: until it is written) and stop the
        thread; whether everything was written."""
        with self._cond:
            self._closing = True
            self._cond.notify()
            done = self._cond.wait_for(lambda: not self._lines and not self._busy, timeout)
        self._thread.join(timeout if done else 0.0)
        return done

    def _run(self) -> None:
        while True:
            with self._cond:
                self._busy = False
                self._cond.notify_all()
                self._cond.wait_for(lambda: self._lines or self._closing or self._redraw)
                if not self._lines and not self._redraw:
                    if self._shown:  # the status stays on the screen, the cursor goes below it
                        self._write("\n")
                    return
                lines = list(self._lines)
                self._lines.clear()
                footer, self._redraw = (self._footer if self.tty else []), False
                dropped, self.dropped = self.dropped, 0
                self._busy = True
            if dropped:
                lines.append(
                    f"({dropped} lines not shown: the terminal did not take them; paused with Ctrl-S?)"
                )
            text = "".join(line + "\n" for line in lines)
            if self.tty:  # wipe the status, write the lines, draw the status again below them
                up = f"\x1b[{self._shown - 1}A" if self._shown > 1 else ""
                wipe = f"\r{up}\x1b[J" if self._shown else ""
                text = wipe + text + "\n".join(footer)
                self._shown = len(footer)
            try:
                self._write(text)
            except BrokenPipeError:
                with self._cond:
                    self.broken = True
                    self._lines.clear()
                if self.on_broken is not None:
                    self.on_broken()
            except Exception:  # a closed stream, or none (pythonw): the lines are lost, the thread goes on
                with self._cond:
                    self.lost += len(lines)

    def _write(self, text: str) -> None:
        try:
            self.stream.write(text)
        except UnicodeEncodeError:  # a terminal that cannot show a character (°, µ): escaped, not lost
            encoding = getattr(self.stream, "encoding", None) or "ascii"
            self.stream.write(text.encode(encoding, "backslashreplace").decode(encoding))
        self.stream.flush()


class LineHandler(logging.Handler):
    """A logging handler that hands its formatted records to a :class:`LineWriter`."""

    def __init__(self, writer: LineWriter):
        super().__init__()
        self.writer = writer

    def emit(self, record: logging.LogRecord) -> None:
        try:
            self.writer.write(self.format(record))
        except Exception:
            self.handleError(record)
