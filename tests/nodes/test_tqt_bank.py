"""tqt_bank: many sensors through the tqt filter together, as one node in a patch."""

import logging
import math

import numpy as np
import pytest

from pointat.errors import PatchError
from pointat.message import floats, method
from pointat.testing import patch

GLOVE = """
node g{i} simulate rate=100 seed={i}
node n{i} offset samples=150
node u{i} scaling
node f{i} tqt
node e{i} collect
node b{i} collect
g{i}.adc -> n{i} -> u{i}
u{i}.mag -> f{i}.mag
u{i}.accel -> f{i}.accel
u{i}.gyro -> f{i}.gyro
u{i}.mag -> bank.mag{i}
u{i}.accel -> bank.accel{i}
u{i}.gyro -> bank.gyro{i}
f{i} -> e{i}
bank.quat{i} -> b{i}
"""


def gloves(n, backend):
    """``n`` simulated gloves, each into its own tqt node and into one tqt_bank."""
    text = f"node bank tqt_bank sensors={n} backend={backend}\nnode all collect\nbank.quats -> all\n"
    return patch(text + "".join(GLOVE.format(i=i) for i in range(1, n + 1)))


@pytest.mark.parametrize("backend", ["python", "numba"])
def test_each_sensor_of_the_bank_follows_its_own_tqt_node(backend):
    rt = gloves(3, backend)
    rt.advance(20.0)
    for i in (1, 2, 3):
        alone = rt.nodes[f"e{i}"].messages
        banked = rt.nodes[f"b{i}"].messages
        assert len(alone) > 1800 and len(banked) == len(alone)
        assert [m.time for m in banked] == [m.time for m in alone]
        diff = np.abs(np.array([m.value for m in banked]) - np.array([m.value for m in alone]))
        assert diff.max() < 1e-9
    # quats: every sensor's quaternion in one vector, sensor 1 first
    last = rt.nodes["all"].values[-1]
    assert len(last) == 12
    assert np.allclose(last[4:8], rt.nodes["b2"].values[-1])


def bank2(extra=""):
    rt = patch(
        "node bank tqt_bank sensors=2 rate=100\nnode q1 collect\nnode q2 collect\nnode flags collect\n"
        "bank.quat1 -> q1\nbank.quat2 -> q2\nbank.flags -> flags\n" + extra
    )
    rt.start()
    return rt, rt.nodes["bank"]


GYRO = (0.0, 0.0, 0.5)  # turning about the vertical at 0.5 rad/s


def tick(bank, k, sensors=(1, 2)):
    """Sample k (t = k / 100 s) from each of ``sensors``: mag, accel, then the hot gyro."""
    for s in sensors:
        i = 1 + 3 * (s - 1)  # inlet 0 is range
        bank.receive(i + 2, floats((0.2, 0.0, -0.4), k / 100))
        bank.receive(i + 1, floats((0.0, 0.0, 9.81), k / 100))
        bank.receive(i, floats(GYRO, k / 100))


def test_a_tick_is_sent_when_its_last_sensor_arrives():
    rt, bank = bank2()
    tick(bank, 0, sensors=(1,))
    assert rt.nodes["q1"].values == []  # sensor 2 still to come
    tick(bank, 0, sensors=(2,))
    assert len(rt.nodes["q1"].values) == len(rt.nodes["q2"].values) == 1


def test_a_lost_packet_leaves_that_sensor_where_it_was_for_one_tick():
    rt, bank = bank2()
    for k in range(20):
        tick(bank, k)
    held = rt.nodes["q2"].values[-1]
    tick(bank, 20, sensors=(1,))  # sensor 2's sample 20 is lost
    tick(bank, 21)  # sensor 1's sample 21 comes first: tick 20 goes out without sensor 2
    q1, q2 = rt.nodes["q1"].messages, rt.nodes["q2"].messages
    assert [m.time for m in q1[-2:]] == [0.20, 0.21]
    assert [m.time for m in q2[-2:]] == [0.19, 0.21]  # nothing for sensor 2 at tick 20
    assert rt.nodes["flags"].values == []  # one lost packet is not a missing sensor
    assert np.isfinite(q2[-1].value).all() and q2[-1].value != held  # it moved on from where it was
    assert bank.bank.initialised.all()
    for k in (22, 23):  # two lost in a row: missing, until it is heard again
        tick(bank, k, sensors=(1,))
    assert rt.nodes["flags"].values == []  # tick 23 waits for sensor 2's sample (or sensor 1's next)
    tick(bank, 24, sensors=(1,))
    assert rt.nodes["flags"].values == [(2, "missing")]
    tick(bank, 25)
    assert rt.nodes["flags"].values == [(2, "missing"), (2, "ok")]


def test_sensors_delivered_in_no_fixed_order_are_each_updated_once_a_sample():
    """Three sources each on its own clock (phones over OSC) arrive in a different order every tick:
    every sample of every sensor goes out once, as it would in turn, and no sensor is reported missing."""

    def run(order):
        rt = patch(
            "node bank tqt_bank sensors=3 rate=100\nnode flags collect\nbank.flags -> flags\n"
            + "".join(f"node q{i} collect\nbank.quat{i} -> q{i}\n" for i in (1, 2, 3))
        )
        rt.start()
        for k in range(300):
            for s in order(k) if k < 299 else (1, 2, 3):  # the last in turn, so nothing is left pending
                i = 1 + 3 * (s - 1)  # inlet 0 is range
                wobble = 0.3 * np.sin(0.05 * k + s)
                rt.nodes["bank"].receive(i + 2, floats((0.2, 0.05 * s, -0.4), k / 100))
                rt.nodes["bank"].receive(i + 1, floats((wobble, 0.0, 9.81), k / 100))
                rt.nodes["bank"].receive(i, floats((0.1 * s, wobble, 0.5), k / 100))
        return rt

    rng = np.random.default_rng(7)
    shuffled = run(lambda k: rng.permutation([1, 2, 3]).tolist())
    in_turn = run(lambda k: [1, 2, 3])
    flags = shuffled.nodes["flags"].values
    assert flags == in_turn.nodes["flags"].values  # the filter's own flags, as in turn
    assert "missing" not in {status for _, status in flags}
    for i in (1, 2, 3):
        got, want = shuffled.nodes[f"q{i}"].messages, in_turn.nodes[f"q{i}"].messages
        assert [m.time for m in got] == [m.time for m in want] and len(got) > 290
        assert np.abs(np.array([m.value for m in got]) - np.array([m.value for m in want])).max() < 1e-12


def test_a_silent_sensor_is_not_waited_for_and_is_waited_for_again_when_back(caplog):
    rt, bank = bank2()
    caplog.set_level(logging.WARNING, "pointat.nodes.tqt")  # a glove lost in a show: said plainly
    for k in range(10):
        tick(bank, k)
    for k in range(10, 30):  # sensor 2 switched off
        tick(bank, k, sensors=(1,))
    q1 = rt.nodes["q1"].messages
    assert q1[-1].time == 0.29  # sample 29 out at once: the bank no longer waits for sensor 2
    assert "sensor 2 missed 5 ticks in a row" in caplog.text
    tick(bank, 30)  # back, after sensor 1's sample 30 went out alone: waited for from the next tick
    assert "sensor 2 is back" in caplog.text and q1[-1].time == 0.30
    tick(bank, 31, sensors=(1,))  # the next tick starts: sensor 2's sample 30 goes out
    assert rt.nodes["q2"].messages[-1].time == 0.30
    assert q1[-1].time == 0.30  # and sample 31 of sensor 1 waits for sensor 2's
    tick(bank, 31, sensors=(2,))
    assert q1[-1].time == rt.nodes["q2"].messages[-1].time == 0.31


def test_a_sensor_that_keeps_dropping_out_is_told_of_a_few_times_not_every_time(caplog):
    rt, bank = bank2()
    caplog.set_level(logging.WARNING, "pointat.nodes.tqt")
    k = 0
    for _ in range(12):  # out of range, back, out again... 12 times
        for _ in range(8):
            tick(bank, k, sensors=(1,))
            k += 1
        tick(bank, k)
        k += 1
    lost = [r.getMessage() for r in caplog.records if "ticks in a row" in r.getMessage()]
    assert [m.partition("again")[2] for m in lost] == ["", " (dropout 2)", " (dropout 3)", " (dropout 10)"]
    assert caplog.text.count("sensor 2 is back") == 4


def test_sensors_that_start_at_different_ticks_are_kept_in_step():
    """Sensor 2 starts 8 ticks after sensor 1 (its nulls took longer, its mote was switched on later):
    from its first tick on, every update holds sample k of both, not sensor 1's k+1 with sensor 2's k."""
    rt, bank = bank2()
    for k in range(8):
        tick(bank, k, sensors=(1,))
    for k in range(8, 20):
        tick(bank, k)
    q1, q2 = rt.nodes["q1"].messages, rt.nodes["q2"].messages
    assert [m.time for m in q2] == [k / 100 for k in range(8, 20)]
    assert [m.time for m in q1[-12:]] == [m.time for m in q2]


def test_bank_gains_are_live_and_the_layout_follows_sensors():
    rt, bank = bank2()
    bank.receive(0, method("k_heading", 0.2))
    assert bank.bank.k_heading == 0.2
    with pytest.raises(ValueError, match="cannot change while running"):
        bank.receive(0, method("sensors", 3))
    assert [i.name for i in bank.in_specs] == ["range", "gyro1", "accel1", "mag1", "gyro2", "accel2", "mag2"]
    assert [o.name for o in bank.out_specs] == ["quats", "flags", "quat1", "quat2"]


def test_the_range_inlet_gives_every_sensor_its_full_scale_and_saturation_is_flagged():
    rt, bank = bank2()
    bank.receive(0, floats((4 * 9.80665, math.radians(500.0)), 0.0))
    assert bank.bank.acc_range == pytest.approx(4 * 9.80665)
    assert bank.bank.gyro_range == pytest.approx(math.radians(500.0))
    for k in range(200):
        tick(bank, k)
    i = 1 + 3  # sensor 2 strikes: its accelerometer sticks at the rail on x
    bank.receive(i + 2, floats((0.2, 0.0, -0.4), 2.0))
    bank.receive(i + 1, floats((4 * 9.80665, 0.0, 9.81), 2.0))
    bank.receive(i, floats(GYRO, 2.0))
    tick(bank, 200, sensors=(1,))
    reports = rt.nodes["flags"].values
    assert (2, "acc_saturated") in [(r[0], r[1]) for r in reports if r[1] != "ok"]
    assert not [r for r in reports if r[0] == 1 and r[1] != "ok"]


def test_bad_bank_wiring_and_settings_name_the_place():
    with pytest.raises(
        PatchError, match=r"<test>:3: .*no inlet 'gyro3'; inlets are range \(0\), gyro1 \(1\)"
    ):
        patch("node bank tqt_bank sensors=2\nnode x tqt\nx -> bank.gyro3\n")
    with pytest.raises(PatchError, match="sensors"):
        patch("node bank tqt_bank sensors=0\n")
    with pytest.raises(PatchError, match="dip"):
        patch("node bank tqt_bank dip=120\n")
    with pytest.raises(PatchError, match=r"<test>:1: .*backend=numba runs mode=robust only"):
        patch("node bank tqt_bank mode=paper backend=numba\n")


@pytest.mark.slow
def test_the_shipped_three_glove_patch_sends_three_sources_over_osc():
    """patches/gloves_bank.pat, run as a user runs it: three simulated gloves through one bank, three
    sources out as OSC to a UDP socket; the gloves follow the same script, so their directions agree."""
    import socket
    import subprocess
    import sys
    from pathlib import Path

    from pythonosc.osc_message import OscMessage

    root = Path(__file__).resolve().parents[2]
    with (
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as rx,
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as c,
    ):
        rx.bind(("127.0.0.1", 0))
        c.bind(("127.0.0.1", 0))
        port, ctl = rx.getsockname()[1], c.getsockname()[1]
        c.close()
        sets = [a for i in (1, 2, 3) for a in ("--set", f"out{i}.port={port}")] + ["--set", f"ctl.port={ctl}"]
        cmd = [sys.executable, "-m", "pointat.cli", "run", "patches/gloves_bank.pat", "--for", "4", *sets]
        proc = subprocess.Popen(cmd, cwd=root, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        rx.settimeout(0.5)
        got: dict[str, list[tuple[float, ...]]] = {}
        while True:
            try:
                msg = OscMessage(rx.recv(1024))
            except TimeoutError:
                if proc.poll() is not None:
                    break
                continue
            got.setdefault(msg.address, []).append(tuple(msg.params))
        err = proc.stderr.read()
    assert proc.returncode == 0 and "ERROR" not in err and "WARNING" not in err, err
    statuses = {a: got.pop(a) for a in list(got) if a.endswith("/status")}  # the heartbeats
    assert sorted(statuses) == ["/pointat/1/status", "/pointat/2/status", "/pointat/3/status"]
    assert all(v[-1][0] == "ok" for v in statuses.values()), statuses
    assert sorted(got) == ["/pointat/1/aed", "/pointat/2/aed", "/pointat/3/aed"]
    counts = [len(v) for v in got.values()]
    assert min(counts) > 150, counts  # 100 Hz for 4 s, less the 1.5 s of gyro nulls
    n = min(counts)
    last = np.array([got[f"/pointat/{i}/aed"][n - 1] for i in (1, 2, 3)])
    assert np.isfinite(last).all()
    assert np.ptp(last[:, 0]) < 5.0 and np.ptp(last[:, 1]) < 5.0, last  # degrees


def test_numba_is_imported_only_by_a_patch_that_builds_a_bank(tmp_path):
    """numba costs a quarter of a second and ~50 MB to import: listing every node type and checking a
    patch without a compiled filter must not pay it (every patch would); building the bank does, and so
    does checking it (check builds every node, as run does).  A ``tqt`` node in paper mode, or told
    ``backend=python``, runs the step in Python and does not pay it either."""
    import subprocess
    import sys

    pat = tmp_path / "bank.pat"
    pat.write_text("node bank tqt_bank sensors=2 backend=numba\n")
    plain = tmp_path / "plain.pat"
    plain.write_text(
        "node fuse tqt backend=python\nnode old tqt mode=paper\nnode p print\nfuse -> p\nold -> p\n"
    )
    code = (
        "import contextlib, io, sys\n"
        "from pointat.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        f"    codes = (main(['nodes']), main(['check', {str(plain)!r}]))\n"
        "before = 'numba' in sys.modules\n"
        "from pointat.loader import load\n"
        f"load({str(pat)!r}, realtime=False)\n"
        "print(codes, before, 'numba' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["(0,", "0)", "False", "True"], out.stdout + out.stderr


def test_the_help_gives_the_tick_counts_the_node_uses():
    from pointat.nodes.tqt import TQTBankNode

    doc = " ".join(TQTBankNode.__doc__.split())
    assert f"misses {TQTBankNode.MISSES} ticks in a row (``MISSES``)" in doc
    assert f"missed {TQTBankNode.MISSING} ticks in a row, ``MISSING``" in doc
