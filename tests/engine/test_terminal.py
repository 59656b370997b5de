"""Console and log lines from a running patch never wait for a terminal that does not read them."""

import io
import os
import threading
import time

from pointat.terminal import LineWriter


def test_a_stream_nobody_reads_holds_up_no_writer_and_hears_what_it_missed():
    r, w = os.pipe()
    stream = os.fdopen(w, "w")
    writer = LineWriter(stream)
    done = threading.Event()

    def flood() -> None:
        for k in range(20_000):  # far more than the pipe (64 KiB) and the writer (2000 lines) hold
            writer.write(f"line {k} " + "x" * 40)
        done.set()

    threading.Thread(target=flood, daemon=True).start()
    assert done.wait(30), "write() blocked on a pipe nobody reads"
    # (not writer.dropped > 0 here: the writer thread may already hold the count, with its notice, in the
    # write the pipe blocks; the notices read below tell every dropped line)
    got = bytearray()
    reading = threading.Thread(target=lambda: got.extend(iter_read(r)), daemon=True)
    reading.start()  # the reader comes back
    assert writer.close(10)
    stream.close()
    reading.join(10)
    lines = got.decode().splitlines()
    assert lines[0] == "line 0 " + "x" * 40
    shown = [ln for ln in lines if ln.startswith("line ")]
    numbers = [int(ln.split()[1]) for ln in shown]
    assert numbers[0] == 0 and numbers == sorted(set(numbers))  # in order, from the first
    notices = [ln for ln in lines if "lines not shown: the terminal did not take them" in ln]
    assert notices and len(shown) + sum(int(n[1:].split()[0]) for n in notices) == 20_000  # all told of


def iter_read(fd: int):
    while chunk := os.read(fd, 65536):
        yield from chunk
    os.close(fd)


def test_a_reader_gone_for_good_is_told_once_and_lines_are_dropped():
    r, w = os.pipe()
    os.close(r)
    gone = []
    writer = LineWriter(os.fdopen(w, "w"), on_broken=lambda: gone.append(True))
    writer.write("first")
    writer.close(5)
    writer.write("second")  # dropped, quietly
    assert gone == [True] and writer.broken


def test_no_stream_at_all_loses_the_lines_and_never_holds_up_the_end():
    writer = LineWriter(None)  # sys.stdout is None under pythonw, a service, a GUI launcher
    writer.write("azimuth 12")
    assert writer.close(5) and writer.lost == 1  # it ends (close waited for a thread that had died)


def test_a_character_the_terminal_cannot_show_is_escaped_not_lost():
    import io

    raw = io.BytesIO()
    stream = io.TextIOWrapper(raw, encoding="ascii")
    writer = LineWriter(stream)
    for line in ("line 1", "azimuth 30°", "line 3"):
        writer.write(line)
    assert writer.close(5)
    assert raw.getvalue().decode() == "line 1\nazimuth 30\\xb0\nline 3\n" and writer.lost == 0


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_on_a_terminal_the_status_stays_at_the_foot_and_lines_scroll_above_it():
    screen = _Terminal()
    w = LineWriter(screen)
    w.status(["out: az  12.0°", "base.m1: ok, 100 Hz"])
    deadline = time.monotonic() + 2
    while "base.m1" not in screen.getvalue() and time.monotonic() < deadline:
        time.sleep(0.01)
    first = screen.getvalue()
    assert first == "out: az  12.0°\nbase.m1: ok, 100 Hz"  # drawn, the cursor at its end
    w.write("gyro nulls: ready")
    w.status(["out: az  13.0°", "base.m1: ok, 100 Hz"])
    w.close()
    rest = screen.getvalue()[len(first) :]
    # back to the status's first line, wiped to the end of the screen, the line, the status again
    assert rest.startswith("\r\x1b[1A\x1b[J" + "gyro nulls: ready\n"), repr(rest)
    assert rest.rstrip("\n").endswith("out: az  13.0°\nbase.m1: ok, 100 Hz"), repr(rest)
    assert rest.endswith("\n")  # at the end the cursor goes below the status


def test_on_a_pipe_status_lines_are_plain_lines():
    out = io.StringIO()
    w = LineWriter(out)
    w.status(["out: az  12.0°"])
    w.write("x")
    w.close()
    assert out.getvalue() == "out: az  12.0°\nx\n"
