"""The runtime: logical clock, deadline timers, metro drift, sources in threads, clean shutdown."""

import contextlib
import io
import math
import signal
import socket
import subprocess
import sys
import threading
import time

import pytest

from pointat import scheduling as scheduling_module
from pointat.message import make, vector
from pointat.node import Node, Outlet, Param
from pointat.runtime import Runtime
from pointat.terminal import LineWriter
from pointat.testing import Collect, patch, wait_until
from pointat.waiting import Waiter


def test_manual_clock_runs_timers_in_order():
    rt = patch("""
node lb loadbang
node d1 delay 30
node d2 delay 10
node t trigger b b
node m1 msg thirty
node m2 msg ten
node out collect
lb -> t
t.0 -> d1 -> m1 -> out
t.1 -> d2 -> m2 -> out
""")
    rt.advance(0.005)
    assert rt.nodes["out"].messages == []
    rt.advance(0.1)
    got = [(m.kind, round(m.time, 9)) for m in rt.nodes["out"].messages]
    assert got == [("ten", 0.01), ("thirty", 0.03)]


def test_metro_does_not_drift_over_simulated_minutes():
    rt = patch("node lb loadbang\nnode m metro 10\nnode out collect\nlb -> m -> out\n")
    rt.advance(600.0)  # ten simulated minutes at 100 Hz
    times = [m.time for m in rt.nodes["out"].messages]
    assert len(times) == 60001
    assert times[-1] == 600.0  # tick n is at exactly n * period: no accumulated error
    assert max(abs(t - i * 0.01) for i, t in enumerate(times)) < 1e-9


def test_metro_interval_change_counts_from_the_last_tick():
    rt = patch("node lb loadbang\nnode m metro 100\nnode out collect\nlb -> m -> out\n")
    rt.advance(0.15)  # ticks at 0 and 0.1
    rt.nodes["m"].receive(1, make(20.0))
    rt.advance(0.05)  # now 0.2: ticks at 0.12, 0.14, 0.16, 0.18, 0.2
    assert [round(m.time, 6) for m in rt.nodes["out"].messages] == [0, 0.1, 0.12, 0.14, 0.16, 0.18, 0.2]


@pytest.mark.parametrize("interval", ["0", "-5"])
def test_metro_of_zero_or_less_ticks_every_millisecond_as_pds(interval):
    rt = patch(f"node lb loadbang\nnode m metro {interval}\nnode out collect\nlb -> m -> out\n")
    rt.advance(0.0105)
    assert [round(m.time, 6) for m in rt.nodes["out"].messages] == [k / 1000 for k in range(11)]
    assert rt.nodes["m"].errors == 0


def test_speedlim_keeps_the_last_message():
    rt = patch("node s speedlim 100\nnode out collect\ns -> out\n")
    rt.start()
    for v in (1.0, 2.0, 3.0):
        rt.nodes["s"].receive(0, make(v))
    assert rt.nodes["out"].values == [1.0]
    rt.advance(0.1)
    assert rt.nodes["out"].values == [1.0, 3.0]


def test_realtime_metro_holds_its_deadlines():
    rt = patch("node lb loadbang\nnode m metro 5\nnode out collect\nlb -> m -> out\n", realtime=True)
    rt.run(0.5)
    times = [m.time for m in rt.nodes["out"].messages]
    # logical stamps are the deadlines themselves; the count shows the loop kept up in real time
    assert 90 <= len(times) <= 101
    assert all(abs(t - times[0] - i * 0.005) < 1e-9 for i, t in enumerate(times))


class Counter(Node):
    """A test source: a thread that posts ``count`` numbers, then ends."""

    type_name = "counter_test"
    outlets = (Outlet("out", "float"),)
    params = (Param("count", "int", 100),)

    def start(self):
        self.active = True
        self.spawn(self._run, "reader")

    def _run(self):
        for i in range(self.p.count):
            if not self.post(self.out, 0, make(float(i))):
                return
        self.post(self._done)

    def _done(self):
        self.active = False


def test_source_thread_feeds_the_scheduler_and_the_patch_ends_by_itself():
    rt = Runtime(queue_size=16)  # small: the source must wait for the graph, not flood memory
    src = rt.add(Counter("src", {"count": 5000}))
    out = rt.add(Collect("out"))
    rt.connect(src, 0, out, 0)
    th = rt.run_in_thread()
    th.join(timeout=20)
    assert not th.is_alive()
    assert out.values == [float(i) for i in range(5000)]
    assert not any(t.is_alive() for t in rt._threads)


class Port(Node):
    """A test node holding a resource, to see that close() runs."""

    type_name = "port_test"
    closed: list = []

    def start(self):
        self.active = True
        self.spawn(self._wait, "io")

    def _wait(self):
        while not self.rt.stopping.wait(0.01):
            pass

    def close(self):
        Port.closed.append(self.name)


def test_stop_from_another_thread_closes_every_node_and_joins_threads():
    rt = Runtime()
    for n in ("a", "b"):
        rt.add(Port(n))
    th = rt.run_in_thread()
    time.sleep(0.1)
    assert th.is_alive()  # an active source keeps it running
    threading.Timer(0.05, rt.stop).start()
    th.join(timeout=5)
    assert not th.is_alive()
    assert Port.closed == ["b", "a"]  # reverse order
    assert not any(t.is_alive() for t in rt._threads)


def test_live_control_from_outside_by_name():
    rt = patch("node m metro 100\nnode out collect\nm -> out\nnode lb loadbang\nlb -> m\n", realtime=True)
    th = rt.run_in_thread()
    rt.set_param("m", "interval", 5)
    rt.send("m", "bang")
    assert wait_until(lambda: len(rt.nodes["out"].messages) >= 10, 60.0)
    rt.stop()
    th.join(5)
    assert rt.nodes["m"].p.interval == 5.0
    assert len(rt.nodes["out"].messages) >= 10


def test_sigterm_and_sigint_stop_a_running_patch_cleanly(tmp_path):
    pat = tmp_path / "p.pat"
    pat.write_text(
        "node lb loadbang\nnode m metro 10\nnode p print\nnode s speedlim 200\nlb -> m -> s -> p\n"
    )
    for sig in (signal.SIGTERM, signal.SIGINT):
        proc = subprocess.Popen(
            [sys.executable, "-m", "pointat.cli", "run", str(pat)],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        banner = [proc.stdout.readline()]  # what runs, ..., then how to stop it
        while banner[-1] and banner[-1].strip() != "Ctrl-C stops.":
            banner.append(proc.stdout.readline())
        assert banner[0].startswith("pointat ") and banner[-1].strip() == "Ctrl-C stops.", banner
        line = proc.stdout.readline()  # it runs
        assert line.startswith("print: bang")
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=10)
        assert proc.returncode == 0, err
        assert "Traceback" not in err


def test_for_seconds_bounds_a_run(tmp_path):
    pat = tmp_path / "p.pat"
    pat.write_text("node lb loadbang\nnode m metro 100\nnode p print\nlb -> m -> p\n")
    t0 = time.monotonic()
    out = subprocess.run(
        [sys.executable, "-m", "pointat.cli", "run", str(pat), "--for", "0.55"],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert out.returncode == 0
    assert out.stdout.count("print: bang") == 6
    assert time.monotonic() - t0 < 10


def test_pure_nodes_whose_outputs_reach_nothing_are_not_fed():
    rt = patch("""
node t trigger a a
node conv quat2axis
node dir azi_ele
node out collect
t.1 -> conv
t.0 -> dir
dir.azimuth -> out
""")
    assert "conv" in rt.nodes  # still there for live control
    assert [d.name for d, _ in rt.nodes["t"]._targets[1]] == []  # quat2axis leads nowhere: not fed
    assert [d.name for d, _ in rt.nodes["t"]._targets[0]] == ["dir"]
    rt.nodes["t"].receive(0, vector([1.0, 0.0, 0.0, 0.0]))
    assert rt.nodes["out"].values == [0.0]


class Echo(Node):
    """Posts to itself from the scheduler thread: with a full queue this must not deadlock."""

    type_name = "echo_test"
    outlets = (Outlet("out", "float"),)

    def start(self):
        self.active = True
        self.call_later(0.0, self._burst)

    def _burst(self):
        for i in range(50):  # more than the queue holds
            self.post(self.out, 0, make(float(i)))
        self.active = False


def test_posting_from_the_scheduler_thread_never_deadlocks(caplog):
    rt = Runtime(queue_size=8)
    src = rt.add(Echo("echo"))
    out = rt.add(Collect("out"))
    rt.connect(src, 0, out, 0)
    th = rt.run_in_thread(5.0)
    th.join(10)
    assert not th.is_alive()
    assert len(out.values) == 8 and rt.dropped == 42  # what did not fit was dropped and counted
    said = [r.getMessage() for r in caplog.records if "queue is full" in r.getMessage()]
    assert len(said) == 4  # and said, sparingly: the 1st, 2nd, 3rd and 10th of 42
    assert "(8 events): an event from node 'echo' was dropped (1 so far)" in said[0]


class Socketed(Node):
    """A test source read by the scheduler itself: one float per datagram; 'boom' raises in the callback."""

    type_name = "socketed_test"
    outlets = (Outlet("out", "float"),)

    def start(self):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.setblocking(False)
        self.threads = []
        self.active = True
        self.rt.add_reader(self.sock, self.readable, self)

    def readable(self):
        data = self.sock.recv(100)
        self.threads.append(threading.current_thread())
        if data == b"boom":
            raise ValueError("a callback that fails")
        self.out(0, float(data))

    def close(self):
        self.rt.remove_reader(self.sock)
        self.rt.remove_reader(self.sock)  # idempotent
        self.sock.close()


@contextlib.contextmanager
def socketed_runtime(**kw):
    """A running Runtime(**kw) on its own thread, its ``Socketed`` source wired to a ``Collect``;
    yields (runtime, source, sink, a socket to send from); stopped and joined on the way out."""
    rt = Runtime(**kw)
    rt.IDLE = 10.0  # with nothing due the select sleeps 10 s: only input or a wake-up can end it sooner
    src = rt.add(Socketed("src"))
    out = rt.add(Collect("out"))
    rt.connect(src, 0, out, 0)
    th = rt.run_in_thread(duration=600)  # (stopped on the way out; the limit only bounds a select's sleep)
    tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        assert wait_until(lambda: hasattr(src, "sock"))
        yield rt, src, out, tx
        assert set(src.threads) == {th}  # no thread of its own: the scheduler read every datagram
    finally:
        tx.close()
        rt.stop()
        th.join(timeout=5)
    assert not th.is_alive()


def test_descriptors_are_read_on_the_scheduler_thread_and_a_failing_reader_does_not_stop_it(caplog):
    with socketed_runtime() as (rt, src, out, tx):
        for data in (b"1.5", b"boom", b"2.5"):
            tx.sendto(data, src.sock.getsockname())
        assert wait_until(lambda: len(out.values) == 2)
        assert out.values == [1.5, 2.5]
        assert "a callback that fails" in caplog.text and "src" in caplog.text
        # a post from another thread wakes the select at once, whatever its timeout: here ten minutes at
        # least (the run's limit; the scheduler asleep by now), and the post served within the wait's minute
        rt.IDLE = 3600.0
        time.sleep(0.5)
        rt.send("out", 7.0)
        assert wait_until(lambda: out.values[-1:] == [7.0], 60.0)


def test_spin_polls_after_an_input_for_its_window_then_sleeps_again():
    """``spin``: after an input the scheduler polls (select with no timeout) instead of sleeping, for
    ``spin`` seconds; then it sleeps as before, so an idle patch does not keep a CPU busy."""
    polls = []  # the timeout of every select the scheduler makes
    with socketed_runtime(spin=0.2) as (rt, src, out, tx):
        sel = rt._waiter.descriptors()
        real_select, real_wait = sel.select, sel.wait

        def select(timeout):
            polls.append(timeout)
            return real_select(timeout)

        def wait(timeout):  # a poll that waits a grain (other threads about: this test's own)
            polls.append(0.0)
            return real_wait(timeout)

        sel.select, sel.wait = select, wait
        tx.sendto(b"1.5", src.sock.getsockname())
        assert wait_until(lambda: out.values == [1.5])
        time.sleep(0.5)  # the window closes 0.2 s after the input
        after = len(polls)
        time.sleep(0.3)
        assert len(polls) - after <= 2, "still polling after the spin window"
        assert polls.count(0.0) > 50, "no polling after the input"
        assert polls[-1] > 1.0  # asleep again, until the next timer (IDLE) or input
        # a datagram that comes while it sleeps is read as ever, and starts a new window
        tx.sendto(b"2.5", src.sock.getsockname())
        assert wait_until(lambda: out.values == [1.5, 2.5])
        n = polls.count(0.0)
        assert wait_until(lambda: polls.count(0.0) > n + 50)


def test_spinning_leaves_the_interpreter_to_the_other_threads_of_the_process():
    """A source thread in the same process (a simulated glove's writer, a replay) keeps its pace while the
    scheduler spins: with other Python threads about, the polling waits in select between polls."""
    with socketed_runtime(spin=5.0) as (rt, src, out, tx):
        tx.sendto(b"1.5", src.sock.getsockname())
        assert wait_until(lambda: out.values == [1.5])  # the scheduler spins from now on, for 5 s
        switch = sys.getswitchinterval()
        sys.setswitchinterval(0.05)  # a scheduler that held the interpreter: 50 ms a sleep, 10 s in all
        try:
            t0 = time.monotonic()
            for _ in range(200):  # this thread needs the interpreter after each of 200 short sleeps
                time.sleep(0.001)
            assert time.monotonic() - t0 < 5.0  # about 0.25 s when it gets it at once
        finally:
            sys.setswitchinterval(switch)


def test_a_quiet_thread_leaves_a_spinning_scheduler_polling_without_pauses(monkeypatch):
    """The console's and the log's writers (``pointat run`` always has them) sleep until a line comes:
    with them alone beside it the scheduler polls without pauses, as ``--spin`` promises (with pauses,
    ``--spin`` gave no lower latency than sleeping); a thread of any other kind still gets its grains."""
    rt = Runtime(spin=1.0)
    writer = LineWriter(io.StringIO(), name="test-quiet")
    stop = threading.Event()
    plain = threading.Thread(target=stop.wait, daemon=True)
    plain.start()
    try:
        assert writer._thread in scheduling_module._QUIET and plain not in scheduling_module._QUIET
        monkeypatch.setattr(threading, "active_count", lambda: 2)  # the scheduler and one other
        assert rt._waiter.spin_grain() == 0.0  # one quiet thread alive: it is the other
        monkeypatch.setattr(threading, "active_count", lambda: 3)  # and one that is not quiet
        assert rt._waiter.spin_grain() == Waiter.SPIN_GRAIN
        writer.close()
        monkeypatch.setattr(threading, "active_count", lambda: 2)  # the writer has ended: the other is not it
        assert rt._waiter.spin_grain() == Waiter.SPIN_GRAIN
    finally:
        writer.close()
        stop.set()
        plain.join(5)


def test_spin_must_be_a_finite_number_of_seconds():
    for bad in (-0.001, float("nan"), float("inf"), "2"):
        with pytest.raises(ValueError, match="spin"):
            Runtime(spin=bad)
    rt = Runtime()
    with pytest.raises(ValueError, match="spin"):
        rt.spin = -1.0
    assert rt.spin == 0.0


class Stuck(Node):
    """A test source whose callback raises before it reads: its socket stays readable."""

    type_name = "stuck_test"

    def start(self):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.setblocking(False)
        self.calls = 0
        self.active = True
        self.add_reader(self.sock, self.readable)

    def readable(self):
        self.calls += 1
        raise OSError("the device is in a bad state")

    def close(self):
        self.remove_reader(self.sock)
        self.sock.close()


def test_a_reader_that_keeps_failing_is_dropped_and_the_patch_goes_on(caplog):
    rt = patch("node lb loadbang\nnode tick metro 10\nnode n collect\nlb -> tick -> n\n", realtime=True)
    stuck = rt.add(Stuck("stuck"))
    th = rt.run_in_thread(duration=20)
    try:
        assert wait_until(lambda: hasattr(stuck, "sock"))
        tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        tx.sendto(b"x", stuck.sock.getsockname())
        tx.close()
        assert wait_until(lambda: "no longer read" in caplog.text)
        assert stuck.calls == 100  # then it is not called again, though its datagram is still there
        ticks = len(rt.nodes["n"].messages)
        assert wait_until(lambda: len(rt.nodes["n"].messages) > ticks + 5)  # timers run on
        assert stuck.calls == 100
    finally:
        rt.stop()
        th.join(timeout=5)
    assert not th.is_alive()


@pytest.mark.parametrize("epoll", [True, False], ids=["epoll", "selectors"])
def test_a_reader_removed_by_another_in_the_same_wake_up_is_not_called(epoll, monkeypatch):
    import functools
    import select

    from pointat import waiting

    if epoll and not hasattr(select, "epoll"):
        pytest.skip("no epoll on this system")
    monkeypatch.setattr(waiting, "_Descriptors", functools.partial(waiting._Descriptors, epoll=epoll))
    rt = Runtime()
    a, b = (socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(2))
    calls = []
    try:
        for s in (a, b):
            s.bind(("127.0.0.1", 0))
            s.setblocking(False)

        def read(me, other):
            calls.append(me)
            me.recv(100)
            rt.remove_reader(other)  # the other one's datagram waits too, but it is no longer watched

        rt.add_reader(a, lambda: read(a, b))
        rt.add_reader(b, lambda: read(b, a))
        tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        tx.sendto(b"1", a.getsockname())
        tx.sendto(b"2", b.getsockname())
        tx.close()
        time.sleep(0.05)  # both readable before the one poll
        assert rt.drain(1.0) == 1
        assert len(calls) == 1
        assert rt.drain(0.0) == 0  # the other datagram is still there, but nobody watches for it
    finally:
        rt.shutdown()
        a.close()
        b.close()


@pytest.mark.parametrize("epoll", [True, False], ids=["epoll", "selectors"])
def test_descriptors_watched_by_number_or_object_and_forgotten_once_closed(epoll):
    import os
    import select

    from pointat.scheduling import _Descriptors

    if epoll and not hasattr(select, "epoll"):
        pytest.skip("no epoll on this system")
    watch = _Descriptors(epoll=epoll)
    r, w = os.pipe()
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        watch.register(r, "pipe")
        watch.register(sock, "socket")
        with pytest.raises(KeyError, match="watched already"):
            watch.register(r, "again")
        assert watch.select(0.0) == []
        os.write(w, b"x")
        assert watch.select(1.0) == ["pipe"]
        sock.close()  # closed before it is unregistered: found by the object, the system forgot it
        assert watch.unregister(sock) == "socket"
        assert watch.unregister(r) == "pipe"
        with pytest.raises(KeyError, match="not watched"):
            watch.unregister(r)
        assert watch.select(0.0) == []
        # watched as an object, forgotten by its number: the object is not watched any more either
        again = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        watch.register(again, "again")
        assert watch.unregister(again.fileno()) == "again"
        with pytest.raises(KeyError, match="not watched"):
            watch.unregister(again)
        again.close()
    finally:
        watch.close()
        os.close(r)
        os.close(w)


class _RecordingEpoll:
    """A real epoll whose ``poll`` timeouts are recorded (as milliseconds, rounded up as CPython does)."""

    def __init__(self, epoll):
        self.epoll, self.asked = epoll, []

    def poll(self, timeout):
        self.asked.append(math.ceil(round(timeout * 1e9) / 1e6))  # seconds -> ns -> ms, as CPython
        return self.epoll.poll(timeout)

    def __getattr__(self, name):
        return getattr(self.epoll, name)


@pytest.mark.skipif(not hasattr(__import__("select"), "epoll"), reason="no epoll on this system")
@pytest.mark.parametrize("timeout", [0.0003, 0.001, 0.0019, 0.0097, 0.02])
def test_a_sleep_asks_epoll_for_no_more_than_its_timeout_and_the_rest_in_select(monkeypatch, timeout):
    """epoll counts whole milliseconds, rounded up: asked for 9.7 ms it would sleep 10, and every timer
    ran up to a millisecond late (p50 0.7 ms at 100 Hz).  The whole milliseconds go to epoll, the rest to
    a select, which counts microseconds."""
    import select

    from pointat.scheduling import _Descriptors

    watch = _Descriptors(epoll=True)
    watch._epoll = spy = _RecordingEpoll(watch._epoll)
    rests = []
    real_select = select.select

    def recording_select(r, w, x, t):
        rests.append(t)
        return real_select(r, w, x, t)

    monkeypatch.setattr(select, "select", recording_select)
    try:
        assert watch.select(timeout) == []
    finally:
        watch.close()
    asked = [ms for ms in spy.asked if ms]  # the poll(0) after a select that found input is not a sleep
    assert asked == ([math.floor(timeout * 1000)] if timeout >= 0.001 else [])
    assert all(0.0 < t <= timeout - sum(asked) / 1000 + 1e-9 for t in rests)
    if timeout < 0.001:
        assert rests == [timeout]  # all of it in select


class _BlindEpoll(_RecordingEpoll):
    """An epoll that sees nothing while it sleeps: every input is left for the select after it."""

    def poll(self, timeout):
        return super().poll(0.0) if timeout == 0.0 else []


@pytest.mark.skipif(not hasattr(__import__("select"), "epoll"), reason="no epoll on this system")
@pytest.mark.parametrize("blind", [False, True], ids=["in epoll's whole ms", "in the select after them"])
def test_input_ends_a_sleep_in_either_part(blind):
    from pointat.scheduling import _Descriptors

    watch = _Descriptors(epoll=True)
    if blind:
        watch._epoll = _BlindEpoll(watch._epoll)
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        rx.bind(("127.0.0.1", 0))
        watch.register(rx, "rx")
        tx.sendto(b"x", rx.getsockname())
        t0 = time.monotonic()
        assert watch.select(600.0097) == ["rx"]
        assert time.monotonic() - t0 < 300.0  # at once, not after the timeout (a loaded machine: late)
    finally:
        watch.close()
        rx.close()
        tx.close()


@pytest.mark.skipif(not hasattr(__import__("select"), "epoll"), reason="no epoll on this system")
def test_a_process_with_more_than_1024_files_open_sleeps_to_the_millisecond_and_sees_input():
    """select() cannot watch a descriptor numbered 1024 or more: an epoll made past that sleeps in epoll
    alone (to the millisecond) instead of raising 'filedescriptor out of range' and stopping the patch."""
    import os
    import resource

    from pointat.scheduling import _Descriptors

    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if hard != resource.RLIM_INFINITY and hard < 1200:
        pytest.skip(f"the hard limit on open files is {hard}")
    resource.setrlimit(
        resource.RLIMIT_NOFILE, (max(soft, 1200) if soft != resource.RLIM_INFINITY else soft, hard)
    )
    held = []
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        held.append(os.open(os.devnull, os.O_RDONLY))
        while held[-1] < 1030:
            held.append(os.dup(held[0]))
        watch = _Descriptors(epoll=True)
        assert watch._epoll.fileno() >= 1024
        rx.bind(("127.0.0.1", 0))
        watch.register(rx, "rx")
        assert watch.select(0.0105) == [] and watch.wait(0.0002) == []
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as tx:
            tx.sendto(b"x", rx.getsockname())
        assert watch.select(5.0005) == ["rx"]
        watch.close()
    finally:
        rx.close()
        for fd in held:
            os.close(fd)
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))


def test_the_scheduler_sleeps_until_the_next_timer_at_most_idle():
    rt = Runtime(realtime=False)
    rt.start()
    assert rt._run_due() == Runtime.IDLE  # no timer
    rt.call_at(0.1, None, lambda: None)
    assert rt._run_due() == pytest.approx(0.1)
    far = rt.call_at(5.0, None, lambda: None)
    rt.clock.t = 0.1  # the first is due: it runs, the next is 4.9 s away
    assert rt._run_due() == Runtime.IDLE
    far.cancel()
    rt.call_at(0.2, None, rt.stop)
    rt.clock.t = 0.2
    assert rt._run_due() == 0.0  # stopping
    rt.shutdown()


def test_a_timer_that_costs_more_than_its_period_cannot_starve_the_readers_nor_the_time_limit(caplog):
    """A machine too slow for a patch: a 1 ms tick that takes 3 ms falls behind (as Pd's clocks do), but
    the sockets are still read between ticks and ``run(duration)`` ends on time (wall clock)."""
    rt = Runtime()
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.setblocking(False)
    got: list[float] = []
    ticks = []

    def tick(when: float) -> None:
        ticks.append(when)
        time.sleep(0.003)  # the work (sleeping, not spinning: the test's thread needs the GIL too)
        rt.call_at(when + 0.001, None, tick, when + 0.001)  # a deadline schedule: the backlog grows

    rt.call_at(0.0, None, tick, 0.0)
    rt.add_reader(rx, lambda: (rx.recv(100), got.append(time.monotonic())))
    tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    th = threading.Thread(target=rt.run, args=(0.5,))
    try:
        th.start()
        assert wait_until(lambda: len(ticks) > 10, 30.0)  # the ticks behind by now
        tx.sendto(b"x", rx.getsockname())
        th.join(60.0)
        assert not th.is_alive()
        # the datagram read between ticks before the end; the end at the 0.5 s limit of wall time, when
        # the ticks' logical time was far short of it (about one per 3 ms: fewer on a loaded machine)
        assert got and ticks[-1] < 0.3
        late = [r.getMessage() for r in caplog.records if "behind its timers" in r.getMessage()]
        assert len(late) == 1 and "cannot keep up" in late[0]  # said once (then every 10 s at most)
    finally:
        rt.stop()
        th.join(5.0)
        rx.close()
        tx.close()


def test_a_flood_of_queued_events_runs_over_several_passes_in_order_with_the_readers_in_between():
    """A fast replay fills the queue with 4096 hand-overs: one pass runs QUEUE_BUDGET seconds of them,
    the descriptors (OSC control) and the timers get their turn between passes, and nothing is lost."""
    rt = Runtime()
    rt.QUEUE_BUDGET = 0.0  # one event a pass, however fast this machine is
    rx, tx = socket.socketpair()
    rx.setblocking(False)
    order: list = []
    try:
        rt.add_reader(rx, lambda: order.append(rx.recv(1)))
        for k in range(4):
            rt.post(None, order.append, k)
        tx.send(b"ab")
        assert rt.drain() == 2 and order == [b"a", 0]
        assert rt.drain() == 2 and order == [b"a", 0, b"b", 1]
        while rt.drain():
            pass
        assert order == [b"a", 0, b"b", 1, 2, 3]
    finally:
        rt.shutdown()
        rx.close()
        tx.close()


def test_what_runs_at_the_end_of_a_pass_runs_after_everything_due_in_it(caplog):
    """at_pass_end: after every timer of the pass, in the order asked, including what those calls ask
    for; a failing one is logged with its node and the others still run; outside a pass, at once."""
    rt = Runtime(realtime=False)
    who = rt.add(Collect("who"))
    log = []

    def failing():
        log.append("end2")
        rt.at_pass_end(None, lambda: log.append("end3"))
        raise RuntimeError("a flush that fails")

    def first():
        log.append("timer1")
        rt.at_pass_end(None, lambda: log.append("end1"))
        rt.at_pass_end(who, failing)

    rt.call_at(0.1, None, first)
    rt.call_at(0.1, None, lambda: log.append("timer2"))
    rt.call_at(0.2, None, lambda: log.append("timer3"))
    rt.advance(0.15)
    assert log == ["timer1", "timer2", "end1", "end2", "end3"]
    assert "node 'who'" in caplog.text and "a flush that fails" in caplog.text
    rt.advance(0.1)
    assert log[-1] == "timer3"
    rt.at_pass_end(None, lambda: log.append("now"))
    assert log[-1] == "now"
    rt.shutdown()


def test_a_pass_inside_a_pass_end_call_runs_each_call_once():
    """A pass-end call that drains (a pass of its own): every call runs once, none is lost."""
    rt = Runtime(realtime=False)
    log = []

    def draining():
        log.append("draining")
        rt.at_pass_end(None, lambda: log.append("added"))
        rt.drain()

    rt.call_at(
        0.1, None, lambda: [rt.at_pass_end(None, draining), rt.at_pass_end(None, lambda: log.append("next"))]
    )
    rt.advance(0.2)
    assert sorted(log) == ["added", "draining", "next"] and log[0] == "draining"
    rt.shutdown()


def test_readers_woken_together_share_one_pass_end():
    """Two sockets readable in one wake-up: what their callbacks leave for the end runs after both."""
    rt = Runtime()
    log = []
    socks = [socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(2)]
    tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        for i, s in enumerate(socks):
            s.bind(("127.0.0.1", 0))
            s.setblocking(False)

            def readable(s=s, i=i):
                s.recv(64)
                log.append(f"read{i}")
                rt.at_pass_end(None, lambda: log.append(f"end{i}"))

            rt.add_reader(s, readable)
        for s in socks:
            tx.sendto(b"x", s.getsockname())
        time.sleep(0.05)  # both are readable before the scheduler looks
        rt.drain(0.5)
        assert sorted(log[:2]) == ["read0", "read1"] and sorted(log[2:]) == ["end0", "end1"]
    finally:
        rt.shutdown()
        tx.close()
        for s in socks:
            s.close()


def test_keeping_the_cpus_awake_writes_the_request_or_says_why_not(monkeypatch, tmp_path):
    """keep_cpus_awake: the PM QoS request is a native 32-bit int of microseconds, held by an open
    descriptor; a missing device or a refusal comes back as a reason, never as an exception."""
    import os
    import struct

    from pointat import scheduling

    monkeypatch.setattr(scheduling, "CPU_DMA_LATENCY", str(tmp_path / "absent"))
    assert scheduling.keep_cpus_awake() == (None, f"not available on this system (no {tmp_path / 'absent'})")
    stand_in = tmp_path / "cpu_dma_latency"
    stand_in.write_bytes(b"")
    monkeypatch.setattr(scheduling, "CPU_DMA_LATENCY", str(stand_in))
    fd, why = scheduling.keep_cpus_awake(5)
    assert why is None and fd is not None
    os.close(fd)
    assert stand_in.read_bytes() == struct.pack("=i", 5)

    def refused(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(scheduling.os, "open", refused)
    fd, why = scheduling.keep_cpus_awake()
    assert fd is None and why.startswith("not permitted: run as root, or give write access to")


def test_a_timer_that_falls_behind_keeps_no_other_timer_from_running():
    # /pointat/tick/interval 0.000001 (seconds typed where milliseconds go): that metro can never catch
    # up, and it was always the earliest timer, so the glove's and every other timer stopped for good
    rt = patch(
        "node go loadbang\nnode fast metro 0.000001\nnode slow metro 50\nnode n collect\n"
        "go -> fast\ngo -> slow\nslow -> n\nnode sink collect\nfast -> sink\n",
        realtime=True,
    )
    rt.run(1.0)
    assert 10 <= len(rt.nodes["n"].messages) <= 21  # the slow metro's 20 ticks a second (not 1)
    assert len(rt.nodes["sink"].messages) > 100  # and the fast one as fast as the passes go


def test_a_delay_0_that_triggers_itself_is_an_error_on_a_manual_clock_not_a_hang():
    # live, the passes keep it from holding anything up; on a test's manual clock advance() never returned
    from pointat.errors import FeedbackError

    rt = patch("node go loadbang\nnode d delay 0\nnode n collect\ngo -> d\nd -> d\nd -> n\n", realtime=False)
    with pytest.raises(FeedbackError, match=r"more than 100000 timers at 0 s: .*\(node 'd'\).*delay 0"):
        rt.advance(0.01)
    assert len(rt.nodes["n"].messages) == Runtime.MANUAL_PASS
    rt.shutdown()


def test_an_event_that_fails_at_every_tick_is_told_of_a_few_times(caplog):
    # a 300-node chain (loop-free, but deeper than the depth guard) fed by a metro logged at every tick
    from pointat.errors import FeedbackError

    rt = patch("node m metro 10\nnode go loadbang\ngo -> m\n", realtime=False)
    rt.start()

    def fails() -> None:
        raise FeedbackError("feedback loop: more than 250 nested messages, last from node 'x' outlet 0")

    for _ in range(120):
        rt._guard(rt.nodes["m"], fails)
    said = [r.getMessage() for r in caplog.records if "feedback loop" in r.getMessage()]
    assert len(said) == 5 and said[-1].endswith("(100 so far)")  # the 1st, 2nd, 3rd, 10th, 100th

    # the same failure with other numbers counts on; another failure of the same type is told at once
    # (a soundcheck's three ValueErrors hid the show's "disk full" for good)
    def failing(text: str):
        def fail() -> None:
            raise ValueError(text)

        return fail

    for text in ("moved 3.25 deg", "moved 4.5 deg", "moved 5.5 deg", "moved 6.5 deg", "the disk is full"):
        rt._guard(rt.nodes["m"], failing(text))
    said = [r.getMessage() for r in caplog.records if "ValueError" in r.getMessage()]
    assert len(said) == 4 and "moved 5.5 deg" in said[2] and "the disk is full" in said[3]
    rt.shutdown()
