"""SerialMoteReader through real pseudo-terminals (no mocks): order, garbage, loss, unplug and replug."""

from __future__ import annotations

import logging
import os
import threading
import time
import tty
from pathlib import Path

import pytest
import serial

from pointat.devices.mote_frame import Frame, LostPackets, encode_frame, encode_text
from pointat.devices.serial_reader import (
    DeviceLost,
    DeviceOpened,
    OpenFailed,
    ReaderError,
    SerialMoteReader,
    driver_low_latency,
    numbered_pty,
    request_low_latency,
)
from pointat.testing import wait_until

pytestmark = pytest.mark.skipif(not hasattr(os, "openpty"), reason="needs pseudo-terminals")

WAIT = 5.0  # upper bound of every wait; the normal case takes milliseconds


class Pty:
    """A pseudo-terminal whose slave is the 'device'; bytes written to the master come out of it."""

    def __init__(self) -> None:
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)  # no echo back into the master, no line discipline
        self.path = os.ttyname(self.slave)

    def write(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            view = view[os.write(self.master, view) :]

    def close(self) -> None:
        for fd in (self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass


class Collector:
    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.frames: list[tuple[Frame, float]] = []
        self.events: list[object] = []

    def on_frame(self, frame: Frame, host_time: float) -> None:
        with self.lock:
            self.frames.append((frame, host_time))

    def on_event(self, event: object) -> None:
        with self.lock:
            self.events.append(event)

    def got(self) -> list[Frame]:
        with self.lock:
            return [f for f, _ in self.frames]

    def of(self, kind: type) -> list:
        with self.lock:
            return [e for e in self.events if isinstance(e, kind)]


def frame(n: int, mote: int = 1) -> Frame:
    return Frame(mote, n & 0xFFFF, tuple((n * 37 + k * 411) % 4096 for k in range(9)))


@pytest.fixture
def pty():
    p = Pty()
    yield p
    p.close()


def make_reader(path: str, col: Collector, **kw) -> SerialMoteReader:
    return SerialMoteReader(
        path, on_frame=col.on_frame, on_event=col.on_event, backoff=(0.01, 0.1), read_timeout=0.02, **kw
    )


def test_frames_arrive_in_order_with_counts_and_timestamps(pty):
    col = Collector()
    with make_reader(pty.path, col) as reader:
        assert reader.wait_open(WAIT)
        t0 = time.monotonic()
        sent = [frame(n) for n in range(300)]
        for k in range(0, 300, 30):  # bursts of 30 frames
            pty.write(b"".join(encode_frame(f) for f in sent[k : k + 30]))
        assert wait_until(lambda: len(col.got()) >= 300)
        stats = reader.stats()
    assert col.got() == sent
    times = [t for _, t in col.frames]
    assert times == sorted(times) and t0 <= times[0] <= times[-1] <= time.monotonic()
    assert stats.motes[1].received == 300 and stats.motes[1].lost == 0 and stats.garbage_bytes == 0
    assert [type(e) for e in col.events[:2]] == [DeviceOpened, type(col.events[1])]
    assert col.of(DeviceOpened)[0].count == 1 and not col.of(DeviceLost)
    assert not reader.is_running and not reader.is_open


def test_garbage_between_frames_and_text_lines_survive(pty):
    col = Collector()
    with make_reader(pty.path, col) as reader:
        assert reader.wait_open(WAIT)
        sent = [frame(n // 2, mote=1 + n % 2) for n in range(60)]  # two interleaved motes
        for n, f in enumerate(sent):
            junk = bytes([0xA5, 0x5A, n, 0x00, 0xFF]) if n % 3 == 0 else b"boot junk\r\n"
            pty.write(junk + (encode_text(f) if n % 4 == 0 else encode_frame(f)))
        assert wait_until(lambda: len(col.got()) >= 60)
        stats = reader.stats()
    assert col.got() == sent
    assert stats.garbage_bytes > 0 and stats.text_frames == 15
    assert not col.of(LostPackets) and not col.of(ReaderError)


def test_lost_packets_are_reported(pty):
    col = Collector()
    with make_reader(pty.path, col) as reader:
        assert reader.wait_open(WAIT)
        ns = [65533, 65534, 1, 2, 3, 7, 8]  # 65535 and 0 lost across the wrap; 4, 5, 6 lost
        pty.write(b"".join(encode_frame(frame(n)) for n in ns))
        assert wait_until(lambda: len(col.got()) >= len(ns))
        assert wait_until(lambda: len(col.of(LostPackets)) >= 2)
        assert reader.stats().motes[1].lost == 5
    assert col.of(LostPackets) == [LostPackets(1, 65535, 1, 2), LostPackets(1, 4, 7, 3)]


def test_device_vanishes_and_comes_back(tmp_path: Path):
    link = tmp_path / "ttyMOTE"
    first = Pty()
    link.symlink_to(first.path)
    col = Collector()
    second = None
    try:
        with make_reader(link, col) as reader:
            assert reader.wait_open(WAIT)
            first.write(b"".join(encode_frame(frame(n)) for n in range(10)) + encode_frame(frame(10))[:7])
            assert wait_until(lambda: len(col.got()) >= 10)

            first.close()  # unplug: the pty hangs up and its path goes away
            link.unlink()
            assert wait_until(lambda: bool(col.of(DeviceLost)))
            assert wait_until(lambda: not reader.is_open)
            assert wait_until(lambda: bool(col.of(OpenFailed)))  # retrying a path that is not there

            second = Pty()  # plug in again, maybe under another /dev/pts number
            link.symlink_to(second.path)
            assert wait_until(lambda: len(col.of(DeviceOpened)) >= 2)
            assert reader.wait_open(WAIT)
            second.write(b"".join(encode_frame(frame(n)) for n in range(15, 25)))
            assert wait_until(lambda: len(col.got()) >= 20)
            stats = reader.stats()
            assert reader.is_running and reader.open_count == 2
    finally:
        first.close()
        if second is not None:
            second.close()
    assert col.got() == [frame(n) for n in range(10)] + [frame(15)._replace(lost=5)] + [
        frame(n) for n in range(16, 25)
    ]
    assert LostPackets(1, 10, 15, 5) in col.of(LostPackets)  # the outage, counted by n_pack
    assert stats.motes[1].received == 20 and stats.motes[1].lost == 5
    assert len(col.of(OpenFailed)) == 1  # once per outage, not once per retry
    assert not col.of(ReaderError)


def test_a_pty_named_by_its_number_is_not_reopened_once_it_closes():
    # the next terminal opened takes the number: reopened, it would be somebody's shell, set raw
    first = Pty()
    col = Collector()
    try:
        with make_reader(first.path, col) as reader:
            assert reader.wait_open(WAIT)
            first.close()  # the simulator (or socat) ends
            assert wait_until(lambda: not reader.is_running)  # the thread ends by itself
            assert reader.ended and not reader.is_open
    finally:
        first.close()
    assert [type(e) for e in col.events] == [DeviceOpened, DeviceLost]
    assert col.of(DeviceLost)[0].final
    with pytest.raises(serial.SerialException, match="not reopened"):
        reader.open()


def test_a_pty_named_by_its_number_that_reads_empty_while_it_is_there_is_not_lost_for_good(pty):
    # another program that does not lock the port took the bytes: the read comes back empty, as when
    # the other end closes, but the terminal is still there
    col = Collector()
    reader = make_reader(pty.path, col)
    reader.open(nonblocking=True)
    try:
        pty.write(encode_frame(frame(0)))
        assert os.read(pty.slave, 100)  # the thief
        assert not reader.poll()
        assert not col.of(DeviceLost)[0].final and not reader.ended
        reader.open(nonblocking=True)  # the owner may try again
        pty.write(encode_frame(frame(1)))
        assert wait_until(lambda: reader.poll() and col.got() == [frame(1)])
    finally:
        reader.close()


def test_numbered_pty_tells_a_pseudo_terminal_by_number_from_a_link_or_a_serial_port(tmp_path: Path, pty):
    link = tmp_path / "glove"
    link.symlink_to(pty.path)
    assert numbered_pty(pty.path) and not numbered_pty(link)
    assert not any(map(numbered_pty, ["/dev/ttyUSB0", "/dev/ttyACM0", "/dev/ttyS0", "/dev/pts/ptmx"]))


def test_a_second_reader_of_a_port_hears_it_is_busy_once_and_opens_it_when_the_first_lets_go(pty):
    first, second = Collector(), Collector()
    a = make_reader(pty.path, first).start()
    try:
        assert a.wait_open(WAIT)
        with make_reader(pty.path, second) as b:
            assert wait_until(lambda: bool(second.of(OpenFailed)))
            pty.write(b"".join(encode_frame(frame(n)) for n in range(20)))
            assert wait_until(lambda: len(first.got()) == 20)
            assert not b.is_open and b.is_running  # retrying quietly
            a.stop()  # the first patch ends
            assert b.wait_open(WAIT)
            pty.write(encode_frame(frame(20)))
            assert wait_until(lambda: second.got() == [frame(20)])
    finally:
        a.stop()
    assert first.got() == [frame(n) for n in range(20)] and not first.of(DeviceLost)
    (busy,) = second.of(OpenFailed)  # once, not at every retry
    assert busy.reason.startswith(f"busy: another program has {pty.path} open")
    assert not second.of(DeviceLost)


def test_path_missing_at_start_then_appears(tmp_path: Path, pty):
    link = tmp_path / "later"
    col = Collector()
    with make_reader(link, col) as reader:
        assert wait_until(lambda: bool(col.of(OpenFailed)))
        assert not reader.is_open and reader.is_running
        link.symlink_to(pty.path)
        assert reader.wait_open(WAIT)
        pty.write(encode_frame(frame(1)))
        assert wait_until(lambda: col.got() == [frame(1)])


def test_repointed_symlink_is_noticed_while_idle(tmp_path: Path):
    a, b = Pty(), Pty()
    link = tmp_path / "mote"
    link.symlink_to(a.path)
    col = Collector()
    try:
        with make_reader(link, col) as reader:
            assert reader.wait_open(WAIT)
            tmp = tmp_path / "mote.new"
            tmp.symlink_to(b.path)
            os.replace(tmp, link)  # atomic, as udev does: the old device still exists, the path names another
            assert wait_until(lambda: len(col.of(DeviceOpened)) >= 2)
            assert reader.wait_open(WAIT)
            b.write(encode_frame(frame(3)))
            assert wait_until(lambda: col.got() == [frame(3)])
        assert "another device" in col.of(DeviceLost)[0].reason
    finally:
        a.close()
        b.close()


def test_callback_errors_are_reported_and_the_thread_lives_on(pty, caplog):
    col = Collector()

    def bad_on_frame(f: Frame, t: float) -> None:
        col.on_frame(f, t)
        if f.n_pack == 1:
            raise RuntimeError("boom")

    def bad_on_event(e: object) -> None:
        col.on_event(e)
        raise KeyError("event sink broken")

    reader = SerialMoteReader(pty.path, on_frame=bad_on_frame, on_event=bad_on_event, read_timeout=0.02)
    with reader:
        assert reader.wait_open(WAIT)
        pty.write(b"".join(encode_frame(frame(n)) for n in range(3)))
        assert wait_until(lambda: len(col.got()) >= 3)
        assert wait_until(lambda: bool(col.of(ReaderError)))
        assert reader.is_running
    err = col.of(ReaderError)[0]
    assert err.where == "on_frame" and "boom" in err.reason
    assert "on_frame failed" in caplog.text and "on_event failed" in caplog.text


def test_loop_error_is_reported_backed_off_and_recovered(pty):
    """Fault injection: the parser breaks; the thread reports, backs off, reopens, and goes on."""
    col = Collector()
    reader = make_reader(pty.path, col)
    real_feed = reader._parser.feed

    def broken_feed(data: bytes, now: float | None = None) -> list[Frame]:
        raise RuntimeError("parser bug")

    reader._parser.feed = broken_feed  # type: ignore[method-assign]
    with reader:
        assert reader.wait_open(WAIT)
        t0 = time.monotonic()
        while time.monotonic() - t0 < 0.4:  # keep data coming while the parser is broken
            pty.write(encode_frame(frame(0)))
            time.sleep(0.01)
        errors = col.of(ReaderError)
        assert errors and errors[0].where == "loop" and "parser bug" in errors[0].reason
        assert reader.is_running
        assert len(col.of(DeviceOpened)) <= 8  # backoff 10, 20, 40, 80, 100 ms...: no spinning
        reader._parser.feed = real_feed  # type: ignore[method-assign]
        assert wait_until(lambda: reader.is_open)
        for n in range(1, 200):
            pty.write(encode_frame(frame(n)))
            if wait_until(lambda: len(col.got()) > 0, timeout=0.02):
                break
        assert col.got() and reader.is_running


def test_start_stop_idempotent_and_bounded(pty):
    reader = SerialMoteReader(pty.path, read_timeout=0.05)
    reader.stop()  # before start: harmless
    assert reader.start() is reader and reader.start() is reader
    assert reader.wait_open(WAIT)
    t0 = time.monotonic()
    reader.stop()
    reader.stop()
    assert time.monotonic() - t0 < 30.0  # bounded (a hang would not end at all)
    assert not reader.is_running and not reader.is_open
    reader.start()  # restartable
    assert reader.wait_open(WAIT)
    reader.stop()
    assert not reader.is_running


def test_constructor_validates():
    with pytest.raises(ValueError):
        SerialMoteReader("/dev/null", read_timeout=0)
    with pytest.raises(ValueError):
        SerialMoteReader("/dev/null", backoff=(1.0, 0.5))
    with pytest.raises(ValueError):
        SerialMoteReader("/dev/null", format="csv")  # type: ignore[arg-type]


def test_low_latency_mode_is_asked_for_and_a_device_without_it_still_runs(pty, caplog):
    col = Collector()
    with caplog.at_level("INFO", logger="pointat.devices.serial_reader"):
        with make_reader(pty.path, col) as reader:
            assert reader.wait_open(WAIT)
            pty.write(encode_frame(frame(1)))
            assert wait_until(lambda: col.got() == [frame(1)])
            # a pseudo-terminal has no serial_struct: the driver says so and the port runs as it is
            assert reader.low_latency.startswith("unsupported: ")  # ENOTTY, in the C library's words
    assert "low-latency mode unsupported" in caplog.text
    assert not [r for r in caplog.records if r.levelname == "WARNING"]  # not a USB adapter: no advice


def test_low_latency_mode_not_asked_for(pty):
    col = Collector()
    with make_reader(pty.path, col, low_latency=False) as reader:
        assert reader.wait_open(WAIT)
        assert reader.low_latency == "off"


class _FtdiDriver:
    """The ``serial_struct`` flag of an adapter whose driver has the low-latency mode (a pty has none)."""

    def __init__(self, monkeypatch, on: bool):
        self.on, self.calls = on, []
        monkeypatch.setattr("pointat.devices.serial_reader.driver_low_latency", lambda port: self.on)
        monkeypatch.setattr("serial.Serial.set_low_latency_mode", self.set, raising=False)

    def set(self, on: bool) -> None:  # bound to this driver, called by the port
        self.calls.append(on)
        self.on = on


def test_a_low_latency_mode_it_turned_on_is_turned_off_when_the_port_closes(pty, monkeypatch):
    driver = _FtdiDriver(monkeypatch, on=False)
    with make_reader(pty.path, Collector()) as reader:
        assert reader.wait_open(WAIT)
        assert reader.low_latency == "on" and driver.calls == [True]
    assert driver.calls == [True, False] and not driver.on  # the adapter is left as it was found


@pytest.mark.parametrize("timer_ms, warned", [("16\n", True), ("1\n", False)])
def test_a_driver_that_takes_the_mode_but_keeps_its_timer_is_named(
    pty, monkeypatch, tmp_path, caplog, timer_ms, warned
):
    # some drivers accept the request and leave the adapter's timer at 16 ms: the frames still wait
    _FtdiDriver(monkeypatch, on=False)
    timer = tmp_path / "latency_timer"
    timer.write_text(timer_ms)
    monkeypatch.setattr("pointat.devices.serial_reader._latency_timer", lambda path: str(timer))
    caplog.set_level(logging.WARNING)
    with make_reader(pty.path, Collector()) as reader:
        assert reader.wait_open(WAIT)
        assert reader.low_latency == "on"
    said = [r.getMessage() for r in caplog.records if "latency timer" in r.getMessage()]
    assert said == (
        [
            f"mote port {pty.path}: the driver took the low-latency mode, but the adapter's latency timer is still 16 ms: it may hold frames back that long. As root: echo 1 > {timer}"
        ]
        if warned
        else []
    )


def test_a_low_latency_mode_already_on_is_left_as_it_was(pty, monkeypatch):
    driver = _FtdiDriver(monkeypatch, on=True)  # a udev rule, or setserial, turned it on for good
    with make_reader(pty.path, Collector()) as reader:
        assert reader.wait_open(WAIT)
        assert reader.low_latency == "already on"
    assert driver.calls == [] and driver.on


def test_driver_low_latency_says_none_where_the_port_cannot_say(pty):
    import serial

    port = serial.Serial(pty.path)
    try:
        assert driver_low_latency(port) is None  # a pseudo-terminal has no serial_struct
    finally:
        port.close()
    assert driver_low_latency(object()) is None


def test_request_low_latency_on_systems_without_the_mode():
    from serial.serialposix import PlatformSpecificBase

    class WindowsPort:  # pyserial's Serial on Windows has no set_low_latency_mode
        pass

    class MacPort(PlatformSpecificBase):  # pyserial's own base of Serial on macOS and the BSDs: it raises
        pass

    assert request_low_latency(WindowsPort()) == "unsupported: not on this system"
    assert request_low_latency(MacPort()) == "unsupported: not on this system"
