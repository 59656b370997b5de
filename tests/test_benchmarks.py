"""The benchmark harness's own bookkeeping: rounds pooled, ratios given round by round."""

import numpy as np
import pytest

from benchmarks.gesture_real import BASELINE, DEFAULTS, goals_text, paired_interval
from benchmarks.latency import LatencyResult, pool
from benchmarks.report import _by_round
from pointat.message import make


def _round(values, error="", cpu=0.1, rss=1000):
    r = LatencyResult("torre", "pointat-udp", "torre", 1000.0, 1, "cmd", error=error)
    r.latencies_us = np.array(values, dtype=float)
    r.expected, r.refused, r.cpu_fraction, r.rss_peak_kb = len(values) + 1, 1, cpu, rss
    return r


def test_rounds_pool_their_samples_and_keep_each_rounds_figures():
    a = _round(np.arange(1, 101), cpu=0.1, rss=1000)
    b = _round(np.arange(101, 201), cpu=0.3, rss=3000)
    p = pool([a, b])
    assert p.received == 200 and p.expected == 202 and p.refused == 2
    assert p.p50 == np.percentile(np.arange(1, 201), 50)
    assert p.rounds == [(a.p50, a.p99), (b.p50, b.p99)]
    assert p.cpu_fraction == 0.2 and p.rss_peak_kb == 3000


def test_a_failed_round_adds_nothing_and_all_failed_keeps_every_error():
    good = _round([10.0, 20.0])
    p = pool([_round([], error="pd exited"), good, _round([])])  # the last ran but matched nothing
    assert p.received == 2 and not p.error
    assert p.rounds == [None, (good.p50, good.p99), None]
    failed = pool([_round([], error="pd exited"), _round([], error="again")])
    assert failed.error == "round 1: pd exited; round 2: again"
    assert pool([_round([], error="pd exited")]).error == "pd exited"


def test_ratios_by_round_pair_the_same_rounds():
    r = pool([_round([100.0] * 100), _round([300.0] * 100), _round([400.0] * 100)])
    floor = pool([_round([100.0] * 100), _round([200.0] * 100), _round([], error="refused")])
    assert _by_round(r, floor) == "; by round 1.00, 1.50, –"
    late = pool([_round([], error="slow start"), _round([300.0] * 100), _round([400.0] * 100)])
    assert _by_round(late, floor) == "; by round –, 1.50, –"
    assert _by_round(r, pool([_round([100.0] * 100)])) == ""


def test_python_calls_per_sample_are_counted_on_each_osc_in_path():
    from benchmarks.latency import python_calls
    from benchmarks.report import _where_the_time_goes
    from pointat.maths.evaluation import BROAD_SAMPLE, load_broad

    counts = {c.path: c for c in python_calls(load_broad(BROAD_SAMPLE), samples=5, warmup=20)}
    assert set(counts) == {"python-osc", "relay", "torre", "tqt"}
    for c in counts.values():
        assert 0 < c.distinct <= c.calls
    # the chains run the relay's path and the fusion on top of it
    assert (
        counts["torre"].calls > counts["relay"].calls + 30
        and counts["tqt"].calls > counts["relay"].calls + 30
    )
    relay = _round([60.0] * 100)
    relay.family, relay.chain = "pointat-udp", "relay"
    floor = _round([50.0] * 100)
    floor.family, floor.chain = "floor", "python-osc"
    text = "".join(_where_the_time_goes([relay, floor], per_node=False, calls=list(counts.values())))
    assert f"pointat's relay {counts['relay'].calls:.0f} ({counts['relay'].distinct} different" in text


def test_instructions_per_sample_take_out_warmup_and_driver_and_are_reported_as_ratios(monkeypatch):
    """The arithmetic of the callgrind counts (faked here: valgrind takes minutes) and their sentence."""
    import benchmarks.latency as lat
    from benchmarks.latency import CallCount
    from benchmarks.report import _instructions

    per_sample = {"none": 20_000, "python-osc": 320_000, "relay": 230_000, "tqt": 410_000}
    start_up = {"none": 1_000_000, "python-osc": 5_000_000, "relay": 9_000_000, "tqt": 11_000_000}
    ran = []

    def total(path, trial, samples):
        ran.append((path, samples))
        return start_up[path] + per_sample[path] * samples

    monkeypatch.setattr(lat, "_callgrind_total", total)
    monkeypatch.setattr(lat.shutil, "which", lambda name: "/usr/bin/valgrind")
    got = lat.instructions_per_sample("trial.csv.gz", ("python-osc", "relay", "tqt"), samples=100, warmup=30)
    assert got == {"python-osc": 300_000, "relay": 210_000, "tqt": 390_000}
    assert sorted(ran) == sorted((p, n) for p in per_sample for n in (30, 130))
    monkeypatch.setattr(lat.shutil, "which", lambda name: None)
    assert lat.instructions_per_sample("trial.csv.gz") is None

    names = {"python-osc": "the python-osc relay", "relay": "pointat's relay", "tqt": "tqt"}
    calls = [CallCount(p, 100.0, 50, n) for p, n in got.items()]
    text = _instructions(calls, names)
    assert "the python-osc relay 300 k; pointat's relay 210 k (0.70 ×); tqt 390 k (1.30 ×)" in text
    assert _instructions([CallCount("tqt", 100.0, 50)], names) == ""  # no counts: no sentence


def test_the_counted_child_runs_samples_through_a_real_osc_in_path():
    """What valgrind runs: real sockets, the real patch, every sample out at the far end."""
    import socket as socket_

    import benchmarks.latency as lat
    from benchmarks.work import main
    from pointat.maths.evaluation import BROAD_SAMPLE

    sent = []
    real = lat._drain

    def counting(sock: socket_.socket, into: list) -> None:
        real(sock, sent)

    lat._drain = counting
    try:
        lat.run_osc_path("tqt", BROAD_SAMPLE, 51)  # drains after samples 0 and 50
    finally:
        lat._drain = real
    assert len(sent) == 51  # loopback delivers within the send: every output is there to drain
    assert all(data.startswith(b"/bench/1") for _, data in sent)
    assert main(["tqt", str(BROAD_SAMPLE), "many"]) == 2


def test_a_send_to_a_sleeping_receiver_and_a_burst_of_sends_are_measured_and_reported():
    """The report's 'waking the receiver': three real costs from real sockets, and the sentence on bursts."""
    from benchmarks.report import _throughput_section
    from benchmarks.throughput import ThroughputResults, udp_hole, udp_sink, wake_cost

    with udp_sink(seconds=60) as port, udp_hole() as hole:
        asleep, nobody, burst = wake_cost(port, hole, n=160)
    assert 0 < nobody and 0 < burst and 0 < asleep
    text = "\n".join(_throughput_section(ThroughputResults(wake=(asleep, nobody, burst))))
    assert f"costs {asleep:.1f} µs" in text and f"16 sends back to back cost {burst:.1f} µs each" in text


def _cells(lines):
    """A Markdown table's rows as lists of cells, by their first cell."""
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in lines if line.startswith("| ")]
    return {row[0]: row[1:] for row in rows}


def test_spin_rows_are_goals_of_their_own_against_the_polling_relay():
    """A ``--spin`` run is judged apart from the default one (never mistaken for it): polling against the
    python-osc relay polling, the default run against the relay asleep; a miss says by how much."""
    from dataclasses import replace

    from benchmarks.report import Run, _latency_section, _summary

    floor = replace(_round([100.0] * 100), label="python-osc relay", family="floor", chain="python-osc")
    polling = replace(floor, label="python-osc relay, polling (--poll 2)", spin=2.0)
    polling.latencies_us = np.array([60.0] * 100)
    slept = replace(_round([150.0] * 100), label="pointat torre (osc_in, UDP)")
    spun = replace(_round([90.0] * 100), label="pointat torre (osc_in, UDP, --spin 2)", spin=2.0)
    lat = [floor, polling, spun, slept]
    run = Run(command="x", quick=True, machine={}, data_note="", started="", latency=lat)
    goals = _cells(_summary(run))
    plain = "Pointing-at (torre_fusion), osc_in path, 1 kHz: p99 ≤ 1.2 × python-osc relay"
    spin = "Pointing-at (torre_fusion) --spin 2, osc_in path, 1 kHz: p99 ≤ 1.2 × python-osc relay, polling as --spin does"
    assert goals[plain][0].startswith("1.50 ×") and goals[plain][1] == "**missed**: 1.50 ×, goal 1.2 ×"
    assert goals[spin][0].startswith("1.50 ×") and goals[spin][1] == "**missed**: 1.50 ×, goal 1.2 ×"
    # the table gives each row over both relays, the like-against-like one in bold
    table = _cells(_latency_section(run))
    assert table["pointat torre (osc_in, UDP, --spin 2)"][5:7] == ["0.90 / 0.90", "**1.50 / 1.50**"]
    assert table["pointat torre (osc_in, UDP)"][5:7] == ["**1.50 / 1.50**", "2.50 / 2.50"]
    assert table["python-osc relay, polling (--poll 2)"][5:7] == ["0.60 / 0.60", "**1 / 1**"]
    # without a polling relay measured, a --spin row is not judged at all (not against the sleeping one)
    goals = _cells(_summary(replace(run, latency=[floor, spun, slept])))
    assert not any("--spin" in goal for goal in goals)


def test_the_python_osc_relay_polls_as_spin_does_and_relays_the_same():
    """``--poll``: for a while after an input the relay asks select without a timeout (never sleeping in
    it), then sleeps again; either way a datagram is relayed unchanged by the same python-osc code."""
    import math
    import socket
    import time

    from pythonosc.udp_client import SimpleUDPClient

    from benchmarks.relay import osc_relay, relay_one

    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(5.0)
    server = osc_relay(0, rx.getsockname()[1])
    tx = SimpleUDPClient("127.0.0.1", server.server_address[1])
    try:
        assert relay_one(server, poll=0.002, wait=0.0) == -math.inf  # nothing came, no input yet
        tx.send_message("/x", [1, 2.5])
        first = relay_one(server, poll=0.002, wait=5.0)  # asleep in select: no input before
        assert first > -math.inf and rx.recv(100).startswith(b"/x\0\0,if")
        tx.send_message("/y", [3])
        polled = relay_one(server, poll=60.0, last_input=time.monotonic(), wait=5.0)  # polling
        assert polled >= first and rx.recv(100).startswith(b"/y\0\0,i")
        # polling ends with the poll time (or the wait) and hands back the last input's time
        assert relay_one(server, poll=60.0, last_input=polled, wait=0.0) == polled
    finally:
        server.server_close()
        rx.close()


def test_the_checked_in_mote_patches_are_what_the_benchmark_writes():
    from benchmarks.latency import PATCHES, mote_patch_text

    names = sorted(p.name for p in PATCHES.glob("mote_*_*.pat") if not p.name.startswith("mote_relay"))
    assert names == [
        f"mote_{c}_{n}.pat"
        for c, n in (
            ("torre", 1),
            ("torre", 16),
            ("tqt", 1),
            ("tqt", 16),
            ("tqt", 64),
            ("tqt_bank", 16),
            ("tqt_plain", 16),
            ("tqt_plain", 64),
        )
    ]
    for name in names:
        chain, motes = name[5:-4].rsplit("_", 1)
        assert (PATCHES / name).read_text() == mote_patch_text(chain, int(motes)), name


@pytest.mark.slow
def test_sixteen_gloves_through_one_tqt_bank_are_measured_on_the_mote_path(tmp_path):
    """Real mote frames for 16 motes into a pseudo-terminal, the whole patch in a child process, every
    glove's OSC matched to its frame at a UDP socket (the benchmark's own path, briefly)."""
    from benchmarks.latency import Phases, run_pointat_mote
    from pointat.maths.evaluation import BROAD_SAMPLE, load_broad

    r = run_pointat_mote("tqt_bank", 200.0, 16, Phases(measure=1.0), load_broad(BROAD_SAMPLE), tmp_path)
    assert not r.error, r.error
    assert r.label == "pointat tqt_bank (mote, pty)" and r.motes == 16
    assert r.expected >= 16 * 150 and r.received == r.expected
    assert np.isfinite(r.latencies_us).all() and (r.latencies_us > 0).all()


def test_the_sixteen_glove_rows_are_set_side_by_side():
    from benchmarks.report import _sixteen_gloves

    rows = []
    for chain, values, cpu in (
        ("tqt", [700.0] * 98 + [30000.0] * 2, 0.75),
        ("tqt_bank", [600.0] * 100, 0.58),
    ):
        r = LatencyResult(chain, "pointat-mote", chain, 1000.0, 16, "cmd")
        r.latencies_us = np.array(values)
        r.expected, r.cpu_fraction = 100, cpu
        rows.append(r)
    [text, _] = _sixteen_gloves(rows)
    assert "at 1000 Hz p50 0.60 / p99 0.60 ms against 0.70 / 30.00 ms, CPU 58 against 75 %" in text
    assert _sixteen_gloves(rows[:1]) == []


def test_recording_a_chain_sees_every_message_each_node_gets():
    # node_costs replays what each node received: the spy must watch out's direct delivery as well
    from benchmarks.latency import udp_hole
    from benchmarks.throughput import _adc_messages, _spy, push_rate
    from pointat.testing import patch

    with udp_hole() as hole:
        _, recorded, _ = push_rate("torre", _adc_messages(260), hole.getsockname()[1], record=True)
    counts = {name: len(msgs) for name, msgs in recorded.items()}
    assert counts["g/nulls"] == 60  # the 260 less the 200 of the warm-up, one ADC vector each
    assert counts["g/torre/fuse"] == 2 * 60  # gyro orientation and accel/mag orientation
    assert counts["g/out"] == 3 * 60  # azimuth, elevation, distance
    # a type with its own receive (trigger) is watched at that door
    rt = patch("node src msg 1\nnode t trigger f f\nnode c collect\nsrc -> t\nt.0 -> c\n")
    seen = _spy(rt.nodes["t"])
    rt.nodes["src"].receive(0, make(None))
    assert [(i, m.value) for i, m in seen] == [(0, 1.0)] and rt.nodes["c"].values == [1.0]


def test_the_scheduler_timers_are_measured_beside_a_sleeping_loop_and_reported():
    """A real metro on the real-time runtime and a bare sleeping loop, each tick's lateness recorded
    (never early: a timer runs at or after its time), then the report's table of both."""
    from benchmarks.latency import timers
    from benchmarks.report import _timers

    metro, floor = timers(200.0, 0.6, rounds=2)
    # 0.3 s a round at 200 Hz: ~60 ticks, the first 10 of each round left out
    assert 80 <= metro.size <= 110 and 80 <= floor.size <= 110
    assert (metro >= 0.0).all() and (floor >= 0.0).all()
    text = "\n".join(_timers({200.0: (metro, floor)}))
    m50, f50 = np.percentile(metro, 50), np.percentile(floor, 50)
    assert f"| 200 Hz | {m50 / 1000:.2f} |" in text and f"| {m50 / f50:.2f} |" in text


def test_the_python_osc_relay_spins_its_busy_work_before_it_sends():
    """The floor with a chain's worth of plain work (``--busy-us``): a real relay on 127.0.0.1 holds each
    message that long, then sends it on unchanged."""
    import socket
    import time

    from pythonosc.udp_client import SimpleUDPClient

    from benchmarks.relay import osc_relay

    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(5.0)
    server = osc_relay(0, rx.getsockname()[1], busy_us=30_000)
    try:
        SimpleUDPClient("127.0.0.1", server.server_address[1]).send_message("/x", [1, 2.5])
        t0 = time.perf_counter()
        server.handle_request()
        assert time.perf_counter() - t0 >= 0.03
        assert rx.recv(100).startswith(b"/x\0\0,if")
    finally:
        server.server_close()
        rx.close()


def test_the_busy_relays_are_set_beside_the_chains():
    from benchmarks.report import _busy_relays

    def row(family, chain, values):
        r = LatencyResult(chain, family, chain, 1000.0, 1, "cmd")
        r.latencies_us, r.expected = np.array(values, dtype=float), len(values)
        return r

    lat = [  # p50 the first value, p99 the second
        row("floor", "python-osc", [100.0] * 60 + [200.0] * 40),
        row("floor", "python-osc+20us", [110.0] * 60 + [250.0] * 40),
        row("pointat-udp", "tqt", [130.0] * 60 + [300.0] * 40),
    ]
    text = _busy_relays(lat)
    assert "against its own p50 and p99, with 20 µs, p50 +10 µs and p99 1.25 ×." in text
    assert "tqt (tqt_fusion) p50 +30 µs and p99 1.50 ×." in text
    assert _busy_relays(lat[:1] + lat[2:]) == ""  # no busy relay measured: nothing to say


def test_a_quick_or_partial_run_never_replaces_the_full_report(tmp_path):
    from benchmarks.__main__ import FULL_REPORT, PARTIAL_REPORT, report_path

    assert FULL_REPORT.name == "REPORT.md" and PARTIAL_REPORT.parent.name == "results"
    assert report_path(None, False, None) == FULL_REPORT
    assert report_path(None, True, None) == PARTIAL_REPORT
    assert report_path(None, False, ["throughput"]) == PARTIAL_REPORT
    assert report_path(tmp_path / "r.md", True, ["memory"]) == tmp_path / "r.md"
    assert "/benchmarks/results/" in (FULL_REPORT.parents[1] / ".gitignore").read_text().split()


def test_a_failed_child_is_reported_with_the_end_of_what_it_printed(tmp_path):
    from benchmarks.latency import _last_words

    log = tmp_path / "child.log"
    log.write_text(
        "INFO starting\n\nerror: node 'ctl' (osc_in): cannot start: port 40000 is in use\n3 errors\n"
    )
    assert _last_words(log) == (
        "; it printed: INFO starting | error: node 'ctl' (osc_in): cannot start: port 40000 is in use | 3 errors"
    )
    log.write_text("")
    assert _last_words(log) == "; it printed nothing"
    assert _last_words(tmp_path / "none.log") == ""


def test_leave_one_out_scores_each_trial_with_the_point_best_on_the_others():
    from benchmarks.loo import grid_points, leave_one_out

    s = np.array([[1.0, 1.0, 9.0], [2.0, 2.0, 1.0], [5.0, 0.5, 5.0]])
    chosen, loo = leave_one_out(s)
    # held out 0: point 1 is best on trials 1, 2 (mean 1.5); held out 1: point 1 (1.5); held out 2: point 0 (1.0)
    assert chosen.tolist() == [1, 1, 0] and loo.tolist() == [2.0, 2.0, 9.0]
    assert grid_points({"a": (1, 2), "b": (3,)}) == [{"a": 1, "b": 3}, {"a": 2, "b": 3}]
    # two sets: each set's mean counts as much, however many trials it has
    s = np.array([[1.0] * 8 + [3.5], [2.0] * 8 + [1.0]])
    groups = np.array(["broad"] * 8 + ["tyrex"])
    assert leave_one_out(s)[0].tolist() == [0] * 9
    assert leave_one_out(s, groups=groups)[0].tolist() == [1] * 8 + [
        0
    ]  # (the tyrex trial held out: none left)


def test_the_flag_statistics_count_raisings_and_what_the_truth_calls_disturbed():
    from benchmarks.magflags import flag_stats
    from benchmarks.realdata import trial_set

    flag = np.array([True, False, False, True, True, False])
    truth = np.array([False, False, False, True, False, True])
    # two of the four undisturbed samples flagged all the same: 50 % wrong
    assert flag_stats(flag, truth, 10.0) == (2, 2.0, 50.0, 50.0, 50.0)
    assert flag_stats(flag, ~truth, 10.0)[3:] == (50.0, 50.0)
    assert np.isnan(flag_stats(flag, np.zeros(6, bool), 10.0)[3])  # nothing truly disturbed: nothing to catch
    assert trial_set("Guillaume_iPhone5_Dist_AR.csv.gz") == "tyrex"
    assert trial_set("32_disturbed_attached_magnet_1cm.csv.gz") == "broad"


def test_the_throughput_report_gives_medians_ranges_whole_process_and_batch_against_batch():
    """From a made-up result (nothing timed): the patch table and the goals on the medians, a miss said
    with its ratio, in process and whole process; the bank against the peers' batch APIs; the body
    suit; start-up."""
    from benchmarks.report import Run, _summary, _throughput_section
    from benchmarks.throughput import (
        BANK_CALLS,
        BATCH,
        BODY_ROW,
        PUSHED,
        WHOLE,
        FilterCost,
        PatchRate,
        Startup,
        ThroughputResults,
    )

    pushed = PatchRate.pooled(
        [PatchRate("torre", PUSHED, 4000, [40.0, 25.0]), PatchRate("torre", PUSHED, 4000, [45.0])]
    )
    assert pushed.us == [40.0, 25.0, 45.0] and pushed.median_us == 40.0 and pushed.per_second == 25000
    whole = PatchRate.pooled(
        [
            PatchRate("torre", WHOLE, 5000, [60.0], whole_process=True, received=(5000, 5000)),
            PatchRate("torre", WHOLE, 5000, [50.0], whole_process=True, received=(4990, 5000)),
            PatchRate("torre", WHOLE, 5000, [80.0], whole_process=True, received=(5000, 5000)),
        ]
    )
    assert whole.received == (14990, 15000) and whole.median_us == 60.0
    filters = [
        FilterCost("TQTFilter robust", "pointat", [6.0, 12.0, 11.0]),
        FilterCost("TQTBank robust, 15 sensors, numba", "pointat", [0.30, 0.40, 0.36], "", BANK_CALLS),
        FilterCost("Ahrs (update + get_quaternion)", "imufusion 1.3.3", [0.70, 0.80, 0.75]),
        FilterCost("VQF updateBatch", "vqf 2.1.2", [0.25, 0.30, 0.28], "", BATCH),
        FilterCost("BasicVQF updateBatch", "vqf 2.1.2", [0.20, 0.24, 0.22], "", BATCH),
        FilterCost(BODY_ROW, "pointat", [60.0, 64.0, 62.5], "per frame"),
    ]
    startup = [
        Startup("pointat run glove_tqt --for 0", "pointat run ...", [0.5, 0.4, 0.45]),
        Startup("pointat check glove_tqt", "pointat check glove_tqt", error="exit 1: no such patch"),
    ]
    tp = ThroughputResults(patches=[pushed, whole], filters=filters, startup=startup)
    text = "\n".join(_throughput_section(tp))
    assert (
        "| Pointing-at (torre_fusion) | ADC vectors pushed into the chain's first node | in process |" in text
    )
    assert "| 4,000 | 40.0 | 25.0–45.0 | 25,000 |" in text
    assert (
        "| whole process | 5,000 | 60.0 | 50.0–80.0 | 16,667 | – | 14,990 of 15,000 directions received |"
        in text
    )
    assert "in process (b) 25,000 /s (median of 3; range 22,222–40,000): **met**" in text
    assert (
        "whole process (d) 16,667 /s (median of 3; range 12,500–20,000): **missed**: 0.83 × the goal" in text
    )
    assert "| TQTFilter robust | pointat | one sensor-sample a call | 11.00 | 6.00–12.00 |" in text
    assert "VQF updateBatch 0.28 µs (range 0.25–0.30): the bank 1.29 × its time" in text
    assert "BasicVQF updateBatch 0.22 µs (range 0.20–0.24): the bank 1.64 × its time" in text
    assert (
        "**A body suit** (15 sensors" in text
        and "62.5 µs per frame of all 15 (median; range 60.0–64.0)" in text
    )
    assert "| pointat run glove_tqt --for 0 | 0.45 | 0.40–0.50 | 3 |" in text
    assert "| pointat check glove_tqt | – | – | – | failed: exit 1: no such patch |" in text

    goals = _cells(
        _summary(Run(command="x", quick=True, machine={}, data_note="", started="", throughput=tp))
    )
    rate = "Pointing-at chain: ≥ 20,000 samples/s on one core, "
    [in_process] = [v for k, v in goals.items() if k.startswith(rate + "in process")]
    [whole_process] = [v for k, v in goals.items() if k.startswith(rate + "whole process")]
    assert in_process == ["25,000 /s (median of 3; range 22,222–40,000)", "**met**"]
    assert whole_process[1] == "**missed**: 0.83 × the goal"
    assert goals["tqt, one sensor: ≤ 10 µs per update"] == [
        "11.0 µs (median; range 6.0–12.0)",
        "**missed**: 1.10 × the goal",
    ]
    peers = "15 sensors at once: per sensor-sample, faster than the compiled peers "
    assert goals[peers + "called once a sensor-sample"][1] == "**met**"
    assert goals[peers + "batch APIs, batch against batch"] == [
        "0.36 µs (numba) vs 0.22 µs (vqf, BasicVQF updateBatch), medians",
        "**missed**: 1.64 × its time",
    ]


def test_the_whole_process_command_is_what_a_user_types():
    from pathlib import Path

    from benchmarks.latency import shown
    from benchmarks.throughput import whole_process_command

    cmd = shown(whole_process_command("tqt", Path("/tmp/head.csv.gz"), 9100))
    assert cmd == (
        "pointat run --status 0 patches/replay_tqt.pat --set source.file=/tmp/head.csv.gz "
        "--set source.speed=0 --set out.port=9100 --for 120"
    )


def test_many_gloves_goals_are_judged_on_the_compiled_rows_and_the_untagged_cost():
    """64 gloves at 1 kHz: the compiled row's p99 against 2 ms (the node-by-node row beside it, never
    mistaken for it), one compiled glove against the relays, and the cost per glove-sample from the
    untagged rounds; a miss says by how much."""
    from dataclasses import replace

    from benchmarks.latency import CostResult
    from benchmarks.report import Run, _cost_section, _summary

    floor = replace(_round([100.0] * 100), label="python-osc relay", family="floor", chain="python-osc")
    many = replace(_round([1500.0] * 100), label="pointat tqt (mote, pty, compiled)", compiled=True)
    many = replace(many, family="pointat-mote", chain="tqt", motes=64, expected=100)
    nodes = replace(many, label="pointat tqt (mote, pty)", compiled=False)
    nodes.latencies_us = np.array([9000.0] * 100)
    one = replace(many, motes=1, label="pointat tqt (mote, pty, compiled)")
    one.latencies_us = np.array([110.0] * 100)
    costs = [
        CostResult(
            "pointat tqt mote x64, compiled", 64, 1000.0, True, "x", us=[8.0, 8.4, 9.0], delivered=[1.0] * 3
        ),
        CostResult(
            "pointat tqt mote x64", 64, 1000.0, False, "x", us=[31.0, 32.0, 33.0], delivered=[0.5] * 3
        ),
    ]
    run = Run(
        command="x", quick=True, machine={}, data_note="", started="", latency=[floor, nodes, many, one]
    )
    run.costs = costs
    goals = _cells(_summary(run))
    p99 = "tqt chain compiled, 64 gloves at 1 kHz on one base station, one core: p99 ≤ 2 ms"
    assert goals[p99] == ["1.50 ms, 100/100 out; node by node 9.00 ms, 100/100 out", "**met**"]
    cost = next(g for g in goals if g.startswith("tqt chain compiled, 64 gloves at 1 kHz: ≤ 5 µs"))
    assert goals[cost] == ["8.4 µs (range 8.0–9.0); node by node 32.0 µs", "**missed**: 1.68 × the goal"]
    relay = "tqt chain compiled, mote path, 1 kHz, 1 glove: p99 ≤ 1.2 × python-osc relay, both asleep"
    assert goals[relay][1] == "**met**"
    table = _cells(_cost_section(run))
    assert table["pointat tqt mote x64"] == ["32.0", "31.0–33.0", "0.500"]


def test_the_warm_start_up_of_pointat_run_is_a_goal_of_its_own():
    from benchmarks.report import Run, _summary
    from benchmarks.throughput import Startup, ThroughputResults

    tp = ThroughputResults(startup=[Startup("pointat run glove_tqt --for 0", "x", seconds=[0.7, 0.66, 1.2])])
    goals = _cells(
        _summary(Run(command="x", quick=True, machine={}, data_note="", started="", throughput=tp))
    )
    (row,) = [g for g in goals if g.startswith("start-up warm")]
    assert goals[row] == ["0.70 s (median of 3; range 0.66–1.20)", "**met**"]


def _fake_uwave(root, people=3, days=3, reps=3):
    """uWave's layout (``U<p> (<d>)/<prefix><gesture>-<repeat>.txt``, lines x y z in g): two gestures a
    person (a bump along x or along y), each person with their own amplitude."""
    rng = np.random.default_rng(0)
    for p in range(1, people + 1):
        for d in range(1, days + 1):
            folder = root / f"U{p} ({d})"
            folder.mkdir(parents=True)
            for g, axis in ((1, 0), (2, 1)):
                for r in range(1, reps + 1):
                    x = np.zeros((60, 3))
                    x[:, 2] = 1.0
                    x[:, axis] += (0.8 + 0.1 * p) * np.sin(np.linspace(0, np.pi, 60)) + rng.normal(
                        0, 0.02, 60
                    )
                    np.savetxt(folder / f"A_Template_Acceleration{g}-{r}.txt", x)
    (root / "readme.txt").write_text("not a recording")


def test_uwave_is_read_from_its_own_layout_and_both_protocols_run(tmp_path):
    from benchmarks.gestures import uwave_recordings, uwave_table

    _fake_uwave(tmp_path)
    data = uwave_recordings(tmp_path)
    assert sorted(data) == [(p, d) for p in (1, 2, 3) for d in (1, 2, 3)]
    assert sorted({r.label for r in data[(2, 3)]}) == ["g1", "g2"] and len(data[(2, 3)]) == 6
    goals = []
    text = uwave_table(tmp_path, lambda s: None, goals)
    assert "| pointat's defaults | 100.0 % | 100.0 % | 100.0 % | 100.0 % |" in text
    assert "plain 1-NN DTW" in text and [g[2] for g in goals] == ["**met**", "**met**"]


@pytest.mark.slow
def test_a_gesture_latency_round_runs_a_real_patch_and_reports_goals(tmp_path):
    """One short round of each latency path: pointat run, OSC in at 100 Hz, the gesture and stroke
    messages back; every gated gesture is told, and the table and goal rows say so."""
    from benchmarks.gestures import latency_rounds, latency_table

    res = latency_rounds(1, 3, lambda s: None, auto=1, bursts=1)
    assert res.gated[0].size == 3 and np.all(res.gated[0] > 0) and np.all(res.gated[0] < 500)
    assert res.strokes[0].size == 8 and res.strokes_found[0] == 1.0
    goals = []
    text = latency_table(res, goals)
    assert (
        "gesture, gated" in text and len(goals) == 3 and all(g[2] in ("**met**", "**missed**") for g in goals)
    )


def test_the_gesture_section_and_its_goals_are_in_the_report():
    from benchmarks.report import Run, render

    run = Run("python -m benchmarks --only gestures", False, {"CPU": "x"}, "", "now")
    run.gestures = "### Accuracy\n\nrows"
    run.gesture_goals = [["BasicMotions (UEA) >= 97.5 %", "100.0 %", "**met**"]]
    text = render(run)
    assert "## 6. Gesture recognition (`python -m benchmarks.gestures`)" in text
    assert "| BasicMotions (UEA) >= 97.5 % | 100.0 % | **met** |" in text


def test_a_reload_round_saves_a_running_patch_and_counts_what_the_receiver_got():
    """Two saves of a patch streaming at 100 Hz: both run, no index lost or twice, and the table says
    so beside the sample period."""
    from benchmarks.reload import one_rate

    r = one_rate(100.0, 2, 0.2, lambda s: None)
    assert r["reloads"] == 2 and len(r["swap"]) == 2 and len(r["save_to_running"]) == 2
    assert r["samples"] > 100 and r["lost"] == 0 and r["doubled"] == 0 and r["in_order"]
    assert r["directions"] > 0


def test_the_reload_section_is_in_the_report():
    from benchmarks.report import Run, render

    run = Run("python -m benchmarks --only reload", False, {"CPU": "x"}, "", "now")
    run.reload = "| rate | save → running |"
    assert "## 7. Hot reload (`python -m benchmarks.reload`)\n\n| rate | save → running |" in render(run)


def test_the_mapper_soak_finds_a_loss_at_the_socket_that_had_it():
    """A socket left unread with a small buffer drops what does not fit: its own counter says so (by its
    inode, among this process's sockets), and a buffer asked for that socket alone is given to it."""
    import os
    import socket

    from benchmarks.mapper import _enlarge, socket_inodes, udp_drops

    with (
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as full,
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as other,
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as out,
    ):
        full.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        full.bind(("127.0.0.1", 0))
        other.bind(("127.0.0.1", 0))
        inode, other_inode = os.fstat(full.fileno()).st_ino, os.fstat(other.fileno()).st_ino
        assert {inode, other_inode} <= socket_inodes(os.getpid())
        before = udp_drops()
        for _ in range(200):
            out.sendto(b"x" * 64, full.getsockname())
        after = udp_drops()
        assert after[inode] - before[inode] > 100
        assert after[other_inode] == before[other_inode]
        default = other.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF)
        assert _enlarge({inode}, 65536) >= 65536
        assert other.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF) == default


def test_the_gap_to_plain_dtw_is_told_with_its_paired_interval():
    same = paired_interval([0.9, 0.8, 1.0, 0.7], [0.9, 0.8, 1.0, 0.7])
    assert same == (0.0, 0.0, 0.0)
    # one person far better, the others a little worse: the mean is positive, but the interval spans 0
    mean, lo, hi = paired_interval([0.99, 0.78, 0.77, 0.80], [0.70, 0.80, 0.80, 0.82])
    assert mean == pytest.approx(0.055) and lo < 0.0 < hi
    # every pair worse by about as much: the interval does not reach 0
    mean, lo, hi = paired_interval([0.80, 0.81, 0.79, 0.80, 0.80], [0.85, 0.85, 0.84, 0.86, 0.85])
    assert hi < 0.0 and lo <= mean <= hi
    assert paired_interval([1, 0, 1], [0, 1, 1]) == paired_interval([1, 0, 1], [0, 1, 1])  # seeded

    accuracy = {DEFAULTS: {"a new person, acc": 0.765}, BASELINE: {"a new person, acc": 0.775}}
    gaps = {"a new person, acc": paired_interval([0.7, 0.8, 0.8], [0.72, 0.8, 0.81])}
    text = goals_text(accuracy, {}, {}, gaps)
    assert "**missed**" in text and "-1.0 points; paired, 95 % interval" in text
    # the false triggers' goal is judged on the defaults; a null class taught is told beside it, not for it
    text = goals_text(
        accuracy, {"seglearn, 3 examples, acc": 1.28}, {}, None, {"seglearn, 3 examples, acc": 0.06}
    )
    assert (
        "**missed**: at most 0.5 false triggers" in text
        and "null examples" in text
        and "the worst 0.06" in text
    )
    # ordinary motion of another person and device is told beside the goal (which names BROAD), not judged
    text = goals_text(accuracy, {}, {}, None, None, ({"a": 1.09, "b": 0.2}, {"a": 0.4, "b": 0.53}))
    [line] = [x for x in text.splitlines() if "Tyrex" in x]
    assert "the worst 1.09 (a)" in line and "null examples 0.53 (b)" in line
    assert "met" not in line and "missed" not in line
