"""The Markdown report (tables, goals met or missed) and its SVG figures, from the measurements."""

from __future__ import annotations

import math
import statistics
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .accuracy import PUBLISHED_MEAN, PUBLISHED_ORDER, PUBLISHED_TRIALS, AccuracyResults
from .latency import CallCount, CostResult, LatencyResult
from .memory import MemoryResult
from .throughput import (
    BATCH,
    BODY_ROW,
    CHAINS,
    CHUNKS,
    PER_CALL,
    PUSH_ROUNDS,
    PUSHED,
    REPLAYED,
    WAKE_BURST,
    WHOLE,
    WHOLE_RUNS,
    PatchRate,
    ThroughputResults,
)


@dataclass
class Run:
    """Everything one ``python -m benchmarks`` run measured, and how."""

    command: str
    quick: bool
    machine: dict[str, str]
    data_note: str
    started: str
    seconds: float = 0.0
    latency: list[LatencyResult] = field(default_factory=list)
    handoff: np.ndarray | None = None
    #: rate -> (metro lateness, bare sleep loop lateness), µs (:func:`benchmarks.latency.timers`)
    timers: dict[float, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    calls: list[CallCount] = field(default_factory=list)
    throughput: ThroughputResults | None = None
    accuracy: AccuracyResults | None = None
    memory: MemoryResult | None = None
    #: what a glove-sample costs the whole process, untagged (:func:`benchmarks.latency.costs`)
    costs: list[CostResult] = field(default_factory=list)
    #: benchmarks.monitor's tables (Markdown, without its title)
    monitor: str = ""
    #: benchmarks.gestures' tables (Markdown, without its title) and its goals' rows
    gestures: str = ""
    gesture_goals: list[list[str]] = field(default_factory=list)
    #: benchmarks.reload's table (Markdown, without its title)
    reload: str = ""
    notes: list[str] = field(default_factory=list)


def _f(x: float | None, digits: int = 0) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    return f"{x:,.{digits}f}"


def _ms(us: float) -> str:
    return "–" if not math.isfinite(us) else f"{us / 1000:.2f}"


def _table(header: Sequence[str], rows: Sequence[Sequence[Any]], align: str = "") -> list[str]:
    align = align or "l" + "r" * (len(header) - 1)
    sep = ["---:" if a == "r" else ":---:" if a == "c" else "---" for a in align]
    out = ["| " + " | ".join(header) + " |", "| " + " | ".join(sep) + " |"]
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return out + [""]


def _ok(flag: bool | None) -> str:
    return "–" if flag is None else ("**met**" if flag else "**missed**")


def _verdict(met: bool, ratio: str) -> str:
    """``**met**``, or ``**missed**: 0.85 × the goal``: by how much, said where it is missed."""
    return "**met**" if met else f"**missed**: {ratio}"


# ------------------------------------------------------------------------------------------ latency
def _find(
    lat: list[LatencyResult],
    family: str,
    chain: str,
    rate: float,
    motes: int = 1,
    realtime: bool = False,
    spin: bool = False,
    compiled: bool = False,
) -> LatencyResult | None:
    for r in lat:
        if (
            r.family == family
            and r.chain == chain
            and r.rate == rate
            and r.motes == motes
            and r.realtime == realtime
            and bool(r.spin) == spin
            and r.compiled == compiled
            and not r.error
        ):
            return r
    return None


def _rounds(lat: list[LatencyResult]) -> int:
    return max((len(r.rounds) for r in lat), default=1) or 1


def _round_tail(lat: list[LatencyResult]) -> str:
    """How many samples the p99 of one round of the 1 kHz floor rests on (thin in ``--quick``)."""
    floor = _find(lat, "floor", "python-osc", 1000.0)
    if not floor or not floor.rounds:
        return ""
    per_round = floor.expected / (len(floor.rounds) - floor.rounds.count(None))
    return f" (a round of the 1 kHz floor has {per_round:,.0f} samples: its p99 rests on the {per_round / 100:,.0f} slowest)"


def _ratios(r: LatencyResult, floor: LatencyResult | None) -> str:
    """``0.95 / 1.37``: ``r``'s p50 and p99 over ``floor``'s (``1 / 1`` for the floor itself)."""
    if floor is None or not (floor.p50 > 0 and floor.p99 > 0):
        return "–"
    if r is floor:
        return "1 / 1"
    return f"{r.p50 / floor.p50:.2f} / {r.p99 / floor.p99:.2f}"


def _by_round(r: LatencyResult, floor: LatencyResult) -> str:
    """``; by round 1.10, 1.25, 1.05``: the p99 ratio in each round both measured (– where one failed)."""
    if len(r.rounds) < 2 or len(r.rounds) != len(floor.rounds):
        return ""
    ratios = [f"{a[1] / b[1]:.2f}" if a and b else "–" for a, b in zip(r.rounds, floor.rounds, strict=True)]
    return "; by round " + ", ".join(ratios)


def _latency_section(run: Run) -> list[str]:
    lat = run.latency
    out = ["## 1. End-to-end latency and jitter", ""]
    out += [
        "A sample goes in, its OSC datagram comes out at a UDP socket on 127.0.0.1.  Latency = the kernel's "
        "receive time stamp of the datagram minus the time taken just before the input was written; one "
        "input per tick, paced on a deadline schedule.  *Mote* rows write real 21-byte mote frames into a "
        "pseudo-terminal read by the `mote` node (all motes of a tick in one write, as a base station "
        "delivers them) and run the whole chain to `osc_out`; *osc_in* rows send the same sample as one OSC "
        "datagram into `osc_in` (UDP in, UDP out, like the floors).  Jitter = p99 − p50.  Ratios are "
        "pointat's p50 and p99 over the python-osc relay's at the same rate.  The machine is shared and its "
        "load drifts, so "
        + (
            f"every configuration was measured in {_rounds(lat)} rounds: all of them in turn for a part of "
            "their time, then all again, and each row pools its rounds; the goals above also give the p99 "
            f"ratio round by round{_round_tail(lat)}.  "
            if _rounds(lat) > 1
            else "the floors were measured next to the runs they are compared with.  "
        )
        + "The ratios are the figures to compare across machines: each row is given over the python-osc "
        "relay asleep in `select` between inputs and over the same relay polling (`--poll`, as `--spin` "
        "polls); the one like against like, which the goals use, is in bold (polling for the `--spin` rows, "
        "asleep for the others).  Times in ms.",
        "",
    ]
    rates = sorted({r.rate for r in lat})
    for rate in rates:
        floors = {rt: _find(lat, "floor", "python-osc", rate, realtime=rt) for rt in (False, True)}
        polling = _find(lat, "floor", "python-osc", rate, spin=True)
        pty_floors = {spin: _find(lat, "floor", "pty", rate, spin=spin) for spin in (False, True)}
        out.append(f"### {rate:g} Hz input")
        out.append("")
        rows = []
        for r in [x for x in lat if x.rate == rate]:
            if r.error:
                rows.append([r.label, r.motes, "–", "–", "–", "–", "–", "–", "–", "–", f"failed: {r.error}"])
                continue
            asleep = floors[r.realtime] or floors[False]  # --rt rows against the relay at real-time priority
            over = {"asleep": _ratios(r, asleep), "polling": _ratios(r, polling)}
            like = "polling" if r.spin else "asleep"
            if over[like] != "–":
                over[like] = f"**{over[like]}**"
            delivered = f"{r.received}/{r.expected}"
            note = []
            if r.refused:
                note.append(f"{r.refused} ticks refused by the pty (patch fell behind)")
            if r.received < 0.99 * r.expected or r.refused > 0.01 * (
                r.expected / max(1, r.motes) + r.refused
            ):
                note.append("**overloaded**: does not keep up; the latency is its buffers filling")
            if r.duplicates:
                note.append(f"{r.duplicates} ambiguous matches")
            if None in r.rounds:
                note.append(f"pooled {len(r.rounds) - r.rounds.count(None)} of {len(r.rounds)} rounds")
            pds = [_find(lat, "floor", kind, rate) for kind in ("pd", "pd-sg0.1")]
            if r.family.startswith("pointat") and all(pds):
                note.append(
                    "p50 / p99 over Pd's: "
                    + ", ".join(f"{r.p50 / pd.p50:.2f} / {r.p99 / pd.p99:.2f}" for pd in pds)  # type: ignore[union-attr]
                    + " (default, -sleepgrain 0.1)"
                )
            if r.family == "pointat-mote" and pty_floors[False]:
                note.append(
                    "p50 / p99 over the pty relay's: "
                    + ", ".join(
                        f"{_ratios(r, f)} {how}"
                        for how, f in (("asleep", pty_floors[False]), ("polling", pty_floors[True]))
                        if f
                    )
                )
            rows.append(
                [
                    r.label,
                    r.motes,
                    _ms(r.p50),
                    _ms(r.p99),
                    _ms(r.max),
                    _ms(r.jitter),
                    over["asleep"],
                    over["polling"],
                    delivered,
                    _f(100 * r.cpu_fraction) + " %" if r.cpu_fraction is not None else "–",
                    "; ".join(note),
                ]
            )
        out += _table(
            [
                "path",
                "motes",
                "p50",
                "p99",
                "max",
                "jitter",
                "p50 / p99 over the relay asleep",
                "over the relay polling",
                "matched",
                "CPU",
                "notes",
            ],
            rows,
            "lrrrrrrrrrl",
        )
    out += [
        "*The relay asleep* = the python-osc relay at the same rate (for the `--rt` rows, the relay under `chrt -f 10` "
        "with the CPUs kept out of deep idle states (`/dev/cpu_dma_latency` held at 0) while it is measured: "
        "both at real-time priority, as Pd takes it by itself when it may, here as root, and both with the "
        "CPUs awake, as `pointat run --rt` keeps them); the *python pty relay* is the mote path's own floor "
        "(the same frames through the same pseudo-terminal, read by a bare Python process with pointat's "
        "frame parser and sent on by python-osc's client): a pseudo-terminal hands bytes on through the "
        "kernel's tty layer, which costs more than a UDP socket.  *matched* = outputs matched to inputs sent in the "
        "measurement window / inputs sent × motes.  *CPU* = CPU time of the process under test (all its "
        "threads) over the window, per wall-clock second.  A real base station adds its USB-serial "
        "adapter, which no pseudo-terminal has: an FTDI chip holds a short frame back for up to its "
        "latency timer, 16 ms by default, more than all of the above; the `mote` node asks the driver for "
        "its low-latency mode (1 ms) when it opens the port (`low_latency`, on by default).  The "
        "`--spin` rows run `pointat run --spin MS` (two sample periods: the scheduler polls for input "
        "instead of sleeping while samples flow; Pd with `-sleepgrain 0.1` sleeps in 0.1 ms grains between "
        "polls) at normal priority.  They are judged against the relays *polling* (`python -m "
        "benchmarks.relay --poll MS`, the same MS: after each input the relay asks `select` with no timeout "
        "in a busy loop, then sleeps again when input stops, as `--spin` does), polling against polling; "
        "their ratio over the relay asleep is beside it, and is not like against like (a process that "
        "polls skips the system's wake-up and finds its caches warm).  Their *CPU* column is the price, "
        "and the polling relays pay it too.",
        "",
        "Published on this kind of machine at 1 kHz (brief): Pd default p50 5.2 / p99 7.5 ms; Pd "
        "-sleepgrain 0.1 p50 0.22 / p99 3.4 ms; python-osc relay p50 0.26-0.45 / p99 1.4-1.6 ms.",
        "",
    ]
    out += _sixteen_gloves(lat)
    out += _where_the_time_goes(lat, per_node=bool(run.throughput and run.throughput.nodes), calls=run.calls)
    if run.handoff is not None and run.handoff.size:
        h = run.handoff
        out += [
            "**The engine's hand-off alone.**  `mote` and `osc_in` are read on the scheduler thread itself "
            "(one `select` over their descriptors and the timers), so their samples take no hand-off; "
            "sources without a descriptor (`replay`, `midi_in`) read in a thread of their own and hand each "
            "sample over with `Runtime.post` (a bounded queue that wakes the `select`).  Measured in one "
            "process, a thread posting at 1 kHz: from `post` to the call "
            f"running on the scheduler thread, p50 {_ms(float(np.percentile(h, 50)))} ms, "
            f"p99 {_ms(float(np.percentile(h, 99)))} ms, max {_ms(float(h.max()))} ms ({h.size} posts).",
            "",
        ]
    out += _timers(run.timers)
    out += ["![Latency distribution at 1 kHz, one glove](figures/latency_cdf_1khz.svg)", ""]
    return out


def _timers(timers: dict[float, tuple[np.ndarray, np.ndarray]]) -> list[str]:
    """How late the scheduler's timers run, beside a bare Python loop sleeping to the same deadlines."""
    rows = []
    for rate, (metro, floor) in sorted(timers.items()):
        if not (metro.size and floor.size):
            continue
        m50, m99, f50, f99 = (float(np.percentile(x, q)) for x in (metro, floor) for q in (50, 99))
        rows.append(
            [
                f"{rate:g} Hz",
                _ms(m50),
                _ms(m99),
                _ms(float(metro.max())),
                _ms(f50),
                _ms(f99),
                _ms(float(floor.max())),
                f"{m50 / f50:.2f}",
                f"{m99 / f99:.2f}",
            ]
        )
    if not rows:
        return []
    return [
        "**Timers.**  What a patch clocks itself (`metro`, `delay`, the simulated glove, a `replay` at "
        "its recorded pace) runs on the scheduler's timers: how long after its due time each tick of a "
        "`metro` reaches the next node, beside a bare Python loop that sleeps (`time.sleep`) until the same "
        "deadlines, in turn in 3 rounds.  Both wake from a sleep the system ends (a normal thread's timer "
        "slack is 50 µs on Linux).  Times in ms.",
        "",
        *_table(
            [
                "rate",
                "metro p50",
                "metro p99",
                "metro max",
                "sleep p50",
                "sleep p99",
                "sleep max",
                "p50 / sleep",
                "p99 / sleep",
            ],
            rows,
            "lrrrrrrrr",
        ),
    ]


def _sixteen_gloves(lat: list[LatencyResult]) -> list[str]:
    """The 16-mote rows side by side: a tqt chain a glove against one tqt_bank for all of them."""
    parts = []
    for rate in (100.0, 1000.0):
        alone, bank = (_find(lat, "pointat-mote", chain, rate, motes=16) for chain in ("tqt", "tqt_bank"))
        if alone is None or bank is None or alone.error or bank.error:
            continue
        cpu = ""
        if alone.cpu_fraction is not None and bank.cpu_fraction is not None:
            cpu = f", CPU {100 * bank.cpu_fraction:.0f} against {100 * alone.cpu_fraction:.0f} %"
        parts.append(
            f"at {rate:g} Hz p50 {_ms(bank.p50)} / p99 {_ms(bank.p99)} ms against {_ms(alone.p50)} / "
            f"{_ms(alone.p99)} ms{cpu}"
        )
    if not parts:
        return []
    return [
        "**Sixteen gloves, one filter.**  The `tqt_bank` rows run the same 16 gloves with one `tqt_bank` "
        "node for all of them (`mote_tqt_bank_16.pat`: each glove's `offset` and `scaling`, the bank, then "
        "each glove's reference, direction and `osc_out`) instead of a `tqt` node a glove: "
        + "; ".join(parts)
        + ".  With the bank every glove's output waits for the tick's last frame, as the bank updates them "
        "together (with a chain a glove, the first gloves of a delivery go out sooner and the last ones "
        "later), and the filters' share of the work is smaller: one compiled update for all of them.",
        "",
    ]


def _where_the_time_goes(
    lat: list[LatencyResult], per_node: bool, calls: Sequence[CallCount] = ()
) -> list[str]:
    """The one-glove rows at 1 kHz split into the transport, the engine and the chain."""
    paths = (
        ("osc_in path", "pointat-udp", ("floor", "python-osc"), "python-osc relay's", "`oscin_relay.pat`: "
         "`osc_in` → `osc_out`", "the fusion half"),
        ("mote path", "pointat-mote", ("floor", "pty"), "python pty relay's", "`mote_relay_1.pat`: `mote` → "
         "`osc_out`", "`offset`, `scaling` and the fusion"),
    )  # fmt: skip
    out = []
    for title, family, (floor_family, floor_chain), floor_name, relay_name, chain_name in paths:
        floor = _find(lat, floor_family, floor_chain, 1000.0)
        relay = _find(lat, family, "relay", 1000.0)
        if not (floor and relay and floor.received and relay.received and floor.p50 > 0 and floor.p99 > 0):
            continue
        parts = [
            f"pointat's own relay ({relay_name}, no filter) has p50 {_ms(relay.p50)} / p99 {_ms(relay.p99)} ms "
            f"against the {floor_name} {_ms(floor.p50)} / {_ms(floor.p99)} ms "
            f"({relay.p50 / floor.p50:.2f} / {relay.p99 / floor.p99:.2f} ×)"
        ]
        for chain in ("torre", "tqt"):
            r = _find(lat, family, chain, 1000.0)
            if r and r.received:
                parts.append(
                    f"{CHAINS[chain]} ({chain_name}): p50 {_ms(r.p50)} / p99 {_ms(r.p99)} ms, "
                    f"{r.p50 - relay.p50:+.0f} / {r.p99 - relay.p99:+.0f} µs from the relay's"
                )
        out.append(f"*{title}*: " + "; ".join(parts) + ".")
    if not out:
        return []
    names = {"python-osc": "the python-osc relay", "relay": "pointat's relay", **CHAINS}
    counted = "; ".join(f"{names[c.path]} {c.calls:.0f} ({c.distinct} different functions)" for c in calls)
    work = _instructions(calls, names)
    return [
        "**Where the time goes (1 kHz, one glove).**  "
        + "  ".join(out)
        + "  The chains are Python work on every sample"
        + (" (section 2 has their cost per node, measured back to back)" if per_node else "")
        + ".  A sample that arrives at a process which slept for a millisecond finds its caches cold, "
        "and on this virtual machine the same Python work then takes more time than it does back to back; "
        "the more code and data a sample touches, the more it pays."
        + (
            f"  Python function calls per sample on the osc_in path (select, receive, parse, chain, encode, "
            f"send; counted with `sys.setprofile`): {counted}."
            if calls
            else ""
        )
        + work
        + _busy_relays(lat),
        "",
    ]


def _busy_relays(lat: list[LatencyResult]) -> str:
    """The sentence on what the 1.2 x goal asks: the python-osc relay with busy work, beside the chains."""
    floor = _find(lat, "floor", "python-osc", 1000.0)
    busy = [
        r
        for r in lat
        if r.family == "floor"
        and r.chain.startswith("python-osc+")
        and r.rate == 1000.0
        and r.received
        and not r.error
    ]
    if not (floor and floor.received and busy):
        return ""
    each = "; ".join(
        f"with {r.chain.split('+')[1].removesuffix('us')} µs, p50 {r.p50 - floor.p50:+.0f} µs and p99 "
        f"{r.p99 / floor.p99:.2f} ×"
        for r in busy
    )
    chains = [(c, _find(lat, "pointat-udp", c, 1000.0)) for c in ("torre", "tqt")]
    beside = "; ".join(
        f"{CHAINS[c]} p50 {r.p50 - floor.p50:+.0f} µs and p99 {r.p99 / floor.p99:.2f} ×"
        for c, r in chains
        if r and r.received
    )
    return (
        "  *What the 1.2 × goal asks*: in the same rounds, the python-osc relay made to spin plain busy "
        f"work on each message before it sends it on has, against its own p50 and p99, {each}."
        + (f"  The osc_in chains, against the same: {beside}." if beside else "")
    )


def _instructions(calls: Sequence[CallCount], names: dict[str, str]) -> str:
    """The sentence on the instructions per sample, each path as a ratio to the python-osc relay's."""
    counted = {c.path: c.instructions for c in calls if c.instructions is not None}
    floor = counted.get("python-osc")
    if not floor:
        return ""
    each = "; ".join(
        f"{names[path]} {n / 1000:.0f} k" + ("" if path == "python-osc" else f" ({n / floor:.2f} ×)")
        for path, n in counted.items()
    )
    return (
        "  Machine instructions per sample on the same paths (user space, the system calls' kernel work "
        "left out; counted by `valgrind --tool=callgrind`, so the same on a busy machine as on an idle "
        f"one, unlike every time in this report): {each}."
    )


# ------------------------------------------------------------------------------------------ throughput
#: The throughput goal: samples per second through the Pointing-at chain on one core.
RATE_GOAL = 20000.0


def _spread(x: Any, digits: int = 1) -> str:
    """``27.9–33.4``: the range of ``x``'s chunks, runs or rounds (``x.min_us``, ``x.max_us``)."""
    return f"{_f(x.min_us, digits)}–{_f(x.max_us, digits)}"


def _rate_goal(p: PatchRate | None) -> tuple[str, str]:
    """The 20,000 samples/s goal on ``p``'s median: (the figure with its range, met or missed)."""
    if p is None or not p.us:
        return "–", _ok(None)
    low, high = 1e6 / p.max_us, 1e6 / p.min_us
    figure = f"{_f(p.per_second)} /s (median of {len(p.us)}; range {_f(low)}–{_f(high)})"
    return figure, _verdict(p.per_second >= RATE_GOAL, f"{p.per_second / RATE_GOAL:.2f} × the goal")


def _throughput_section(tp: ThroughputResults) -> list[str]:
    out = ["## 2. Throughput and cost per update", ""]
    counts = {p.how: len(p.us) for p in tp.patches}
    out += [
        "### Patches, one core, scheduler saturated",
        "",
        "Samples per second through each chain.  *In process*, in this benchmark's own process: (a) "
        "`benchmarks/patches/throughput_CHAIN.pat`, the simulated glove (`simulate output=direct`, 1 kHz "
        "sensor time) into the chain on a manual clock advanced as fast as it goes — the glove's own cost "
        "is in it, and the 'chain only' column takes it out; (b) ADC vectors handed to the chain's first "
        "node by calling its `receive` (no input I/O, no parsing, no scheduler: the chain's own work); (b′) "
        "is (b) with the OSC going to a socket that no process sleeps on: what the chain costs without the "
        "system waking the receiver; (c) the shipped `patches/replay_*.pat` with `replay speed=0` of a "
        "BROAD recording on the real-time runtime (source thread → bounded queue → scheduler thread, 64 "
        "rows a hand-over at this speed; fusion half only, the recording is in SI units).  *Whole "
        "process*: (d) the same replay patch run by `pointat run` in a process of its own, its directions "
        "counted at a UDP socket in the benchmark's process, the rate from the kernel's receive time stamps "
        "of the first and the last (the process's start-up and exit are not in it; the recording is read "
        "and parsed before the first sample goes out, so no input parsing is in it either).  Every figure "
        "is the **median** chunk or run, with the **range (min–max)** of all of them beside it: "
        f"(a) {counts.get('simulated glove, manual clock', CHUNKS)} chunks of one run; (b) and (b′) "
        f"{counts.get(PUSHED, CHUNKS * PUSH_ROUNDS)} chunks ({CHUNKS} in each of {PUSH_ROUNDS} rounds); "
        f"(c) {counts.get(REPLAYED, PUSH_ROUNDS)} runs; (d) {counts.get(WHOLE, PUSH_ROUNDS * WHOLE_RUNS)} "
        f"runs.  The rounds go over both chains at the start, the middle and the end of this section, so "
        "that a slow spell of the shared machine decides no figure alone.",
        "",
    ]
    rows = []
    for p in tp.patches:
        note = ""
        if p.received is not None:
            note = f"{p.received[0]:,} of {p.received[1]:,} directions received"
        rows.append(
            [
                CHAINS[p.chain],
                p.how,
                "whole process" if p.whole_process else "in process",
                _f(p.samples),
                _f(p.median_us, 1),
                _spread(p),
                _f(p.per_second),
                _f(p.chain_per_second) if p.source_us else "–",
                note,
            ]
        )
    out += _table(
        [
            "chain",
            "fed by",
            "measured",
            "samples each",
            "µs / sample, median",
            "range",
            "samples / s, median",
            "chain only, samples / s",
            "notes",
        ],
        rows,
        "lllrrrrrl",
    )
    torre = {p.how: p for p in tp.patches if p.chain == "torre"}
    if PUSHED in torre or WHOLE in torre:
        said = []
        for how, what in ((PUSHED, "in process (b)"), (WHOLE, "whole process (d)")):
            figure, verdict = _rate_goal(torre.get(how))
            said.append(f"{what} {figure}: {verdict}")
        out += [
            f"**The goal, {_f(RATE_GOAL)} samples/s through the Pointing-at chain on one core, on the "
            "median:** " + "; ".join(said) + ".  The whole-process figure is the fusion half only (the "
            "recording is in SI units: no `offset`, no `scaling`) with the engine around it (source thread, "
            "queue, scheduler, `osc_out`); the in-process one is the whole chain from ADC counts without the "
            "engine.",
            "",
        ]
    sim = next((p.source_us for p in tp.patches if p.source_us), None)
    if sim:
        out += [f"The simulated glove alone costs {sim:.0f} µs per sample (the median chunk).", ""]
    if tp.wake:
        asleep, nobody, burst = tp.wake
        out += [
            "**Waking the receiver** (each figure the median of 3 rounds).  One 40-byte `send` 50 µs after the "
            f"previous one costs {asleep:.1f} µs "
            f"to a receiver process asleep in `recv` (the system wakes it inside the sender's call) and "
            f"{nobody:.1f} µs to a socket nobody waits on: about {asleep - nobody:.0f} µs of every sample in "
            "(b) is that wake-up, paid by any sender (a python-osc relay, Pd) on this virtual machine.  "
            f"{WAKE_BURST} sends back to back cost {burst:.1f} µs each"
            + (
                ": the first wakes the receiver, the others find it awake."
                if burst < 0.5 * asleep
                else " (on this machine a burst saves little)."
            )
            + "  `osc_out` sends what a scheduler pass encoded at the end of the pass "
            "(`Runtime.at_pass_end`): when a base station delivers 16 motes' frames in one read, their "
            "datagrams leave in one burst (the 16-mote rows of section 1).",
            "",
        ]
    out += ["### Cost of each node of the chain, alone", ""]
    out += [
        "Every message each node received while ADC vectors were pushed through the chain (b) was recorded "
        "and replayed into a fresh instance of that node alone, its outlets into a sink that does nothing "
        "(so the cost of building its output messages is in, the downstream nodes are not).  µs per input "
        "sample (a node may get several messages per sample); the median of 3 replays.",
        "",
    ]
    for chain in CHAINS:
        rows = [
            [n.node, f"`{n.type_name}`", _f(n.messages), _f(n.us_per_sample, 2)]
            for n in tp.nodes
            if n.chain == chain
        ]
        if not rows:
            continue
        total = sum(n.us_per_sample for n in tp.nodes if n.chain == chain)
        rows.append(["**sum**", "", "", f"**{total:.1f}**"])
        rows.append(["whole chain (b), median chunk", "", "", _f(tp.chain_totals.get(chain), 1)])
        out.append(f"**{CHAINS[chain]}**")
        out.append("")
        out += _table(["node", "type", "messages", "µs / sample"], rows)
    out += ["### Hot spots (cProfile of (b), by own time)", ""]
    for chain, rows in tp.hotspots.items():
        out.append(f"**{CHAINS[chain]}** (profiling inflates the absolute times; read them as shares)")
        out.append("")
        out += _table(
            ["function", "calls", "own µs / sample", "incl. µs / sample"],
            [[f"`{fn}`", _f(n), _f(tt, 1), _f(ct, 1)] for fn, n, tt, ct in rows],
        )
    if tp.gc_pauses:
        out += ["### Garbage-collector pauses", ""]
        out += [
            "Python's cyclic garbage collections while 20,000 ADC vectors go through the chain (b): how many, "
            "and how long each paused the scheduler thread.",
            "",
        ]
        rows = []
        for chain, (n, gens) in tp.gc_pauses.items():
            if not gens:
                rows.append([CHAINS[chain], _f(n), "none", "–", "–"])
            for g, (count, mean, longest) in gens.items():
                rows.append(
                    [
                        CHAINS[chain],
                        _f(n),
                        f"generation {g}: {count}",
                        _f(mean / 1000, 2),
                        _f(longest / 1000, 2),
                    ]
                )
        out += _table(["chain", "samples", "collections", "mean pause, ms", "longest, ms"], rows)
    out += ["### Pure filters against the peers", ""]
    out += [
        "BROAD trial 01 (the same samples for every filter), inputs prepared beforehand in each library's "
        "own format; time per update (per sensor-sample, or per frame where the notes say so), the "
        "**median** of the rounds with their **range (min–max)**.  *Calls* says how each is called, "
        "so that like is set against like: one call a sensor-sample (as a live patch calls a filter); "
        "`TQTBank`, 15 sensors a call (a batch across sensors, which a live patch can make of a body's "
        "sensors); VQF's `updateBatch`, the whole trial a call (a batch across time, which needs the "
        "recording first).  Ratios, on the medians: over imufusion's (a C library called once a sample: "
        "the floor of a per-sample Python call) and over ahrs Madgwick's (a pure-Python peer).",
        "",
    ]
    ref_c = next((f.median_us for f in tp.filters if f.library.startswith("imufusion")), None)
    ref_py = next((f.median_us for f in tp.filters if f.name == "Madgwick"), None)
    rows = []
    for f in tp.filters:
        rows.append(
            [
                f.name,
                f.library,
                f.calls,
                _f(f.median_us, 2),
                _spread(f, 2),
                _f(f.median_us / ref_c, 1) if ref_c else "–",
                _f(f.median_us / ref_py, 3) if ref_py else "–",
                f.note,
            ]
        )
    out += _table(
        ["filter", "library", "calls", "µs / update, median", "range", "× imufusion", "× Madgwick", "notes"],
        rows,
        "lllrrrrl",
    )
    batch = _bank_against_batch(tp)
    if batch:
        out += [batch, ""]
    body = next((f for f in tp.filters if f.name == BODY_ROW), None)
    if body and body.median_us > 0:
        out += [
            f"**A body suit** (15 sensors through one `tqt_bank` into a 15-segment `skeleton`, in a patch): "
            f"{body.median_us:.1f} µs per frame of all 15 (median; range {_spread(body)}), "
            f"{_f(1e6 / body.median_us)} frames/s on one core at the median.",
            "",
        ]
    out += _startup(tp)
    return out


def _bank_against_batch(tp: ThroughputResults) -> str:
    """The sentence that sets the bank against the peers' batch APIs, batch against batch, on medians."""
    bank = next((f for f in tp.filters if f.name.startswith("TQTBank") and f.name.endswith("numba")), None)
    peers = [f for f in tp.filters if f.calls == BATCH]
    if bank is None or not peers:
        return ""
    each = "; ".join(
        f"{p.name} {p.median_us:.2f} µs (range {_spread(p, 2)}): the bank {bank.median_us / p.median_us:.2f} × "
        "its time"
        for p in peers
    )
    return (
        f"**Batch against batch.**  `TQTBank` (numba), 15 sensors a call: {bank.median_us:.2f} µs per "
        f"sensor-sample (median; range {_spread(bank, 2)}); the peers' batch APIs, per sample: {each}.  "
        "(BasicVQF is VQF without its gyro bias estimation and magnetic disturbance rejection: less work "
        "a sample.)"
    )


def _startup(tp: ThroughputResults) -> list[str]:
    """The start-up table: whole-process wall time, median and range."""
    rows = []
    for st in tp.startup:
        if st.error or not st.seconds:
            rows.append([st.label, "–", "–", "–", f"failed: {st.error}" if st.error else "no run"])
            continue
        rows.append(
            [
                st.label,
                f"{statistics.median(st.seconds):.2f}",
                f"{min(st.seconds):.2f}–{max(st.seconds):.2f}",
                str(len(st.seconds)),
                f"`{st.command}`",
            ]
        )
    if not rows:
        return []
    return [
        "### Start-up, whole process",
        "",
        "Wall time of each command from the benchmark's process, start to exit (fork, interpreter, "
        "imports, the patch read, its nodes started and stopped), warm: a first run of each, not counted, "
        "has put the files in the page cache; then the commands in turn.  `pointat run glove_tqt --for 0` "
        "starts the shipped glove patch (the simulated glove and its pseudo-terminal, `mote`, the chain, "
        "`osc_in`, `osc_out`) and stops it at once; `python -c pass` is what any Python program pays "
        "before its first line.  Seconds.",
        "",
        *_table(["command", "median", "range", "runs", "as run"], rows, "lrrrl"),
    ]


# ------------------------------------------------------------------------------------------ accuracy
def _short(trial: str) -> str:
    return trial.split("_")[0]


def _accuracy_section(acc: AccuracyResults, data_note: str) -> list[str]:
    out = ["## 3. Accuracy on BROAD (optical ground truth)", ""]
    out += [
        data_note,
        "",
        "The data set's own metric (`pointat.maths.evaluation.broad_rmse`): error quaternion in the earth "
        "frame, split into heading and inclination, RMS over the `movement` samples, NaN ground truth "
        "skipped; every filter runs causally from sample 0 over the whole trial, **one parameter set for "
        "all trials**, outputs turned into sensor → ENU by fixed frame changes only (pointat's NWU with "
        "`pointat.maths.quaternion.nwu_to_enu`).  Peers use the settings of the data README's table; "
        "'published' is that table's figure for the same filter and trials.  Degrees.",
        "",
    ]
    trials = acc.trials
    names = list(acc.scores)
    header = ["filter", "mean total", "heading", "incl."] + [_short(t) for t in trials]
    if len(trials) == len(PUBLISHED_ORDER):
        header.insert(4, "published mean")
    rows = []
    for name in names:
        m = acc.mean(name)
        row = [name, f"**{m.total:.2f}**", f"{m.heading:.2f}", f"{m.inclination:.2f}"]
        if len(trials) == len(PUBLISHED_ORDER):
            row.append(_f(PUBLISHED_MEAN.get(name), 2))
        row += [_f(acc.scores[name][t].total, 2) if t in acc.scores[name] else "–" for t in trials]
        rows.append(row)
    out += _table(header, rows)
    # published check, per trial
    diffs = []
    for name, pub in PUBLISHED_TRIALS.items():
        if name not in acc.scores:
            continue
        for t in trials:
            k = _short(t)
            if k in PUBLISHED_ORDER and t in acc.scores[name]:
                diffs.append(abs(acc.scores[name][t].total - pub[PUBLISHED_ORDER.index(k)]))
    if diffs:
        out += [
            f"Harness check: the peers' per-trial totals differ from the published table by at most "
            f"{max(diffs):.2f}° (median {np.median(diffs):.2f}°) over {len(diffs)} filter-trial pairs, so "
            "conventions, metric and initialisation match the data README's.",
            "",
        ]
    rows = [[name, f"{acc.seconds.get(name, float('nan')):.1f}"] for name in names]
    out += ["Run time of each filter over these trials (s, this machine):", ""]
    out += _table(["filter", "seconds"], rows)
    out += ["![Mean total RMSE by filter](figures/accuracy_mean.svg)", ""]
    if acc.loo:
        out += ["### Leave-one-trial-out (`python -m benchmarks.loo`)", "", acc.loo]
    if acc.shakes:
        out += [
            "### Strikes and shakes, simulated with known truth (`python -m benchmarks.shakes`)",
            "",
            acc.shakes,
        ]
    return out


# ------------------------------------------------------------------------------------------ memory
def _memory_section(mem: MemoryResult) -> list[str]:
    out = ["## 4. Memory", ""]
    out += [
        f"`benchmarks/patches/soak.pat` (simulated glove at 1 kHz writing mote frames into a pty, the `mote` "
        f"node, both chains, two `osc_out`) run for {mem.seconds:.0f} s; resident set sampled every second, "
        f"growth = least-squares slope after the first {mem.fit_start:.0f} s.",
        "",
    ]
    if mem.error:
        return out + [f"Failed: {mem.error}", ""]
    rss = np.array(mem.rss_kb, dtype=float)
    t = np.array(mem.times)
    after = rss[t >= mem.fit_start]
    rate = mem.datagrams / mem.lifetime if mem.datagrams is not None and mem.lifetime > 0 else None
    out += _table(
        ["peak RSS (VmHWM)", "RSS after warm-up", "RSS at the end", "growth", "CPU", "datagrams out"],
        [
            [
                f"{(mem.peak_kb or 0) / 1024:.1f} MB",
                f"{after[0] / 1024:.1f} MB" if after.size else "–",
                f"{rss[-1] / 1024:.1f} MB" if rss.size else "–",
                f"{mem.slope_kb_per_min:+.2f} ± {mem.slope_stderr:.2f} KB/min",
                _f(100 * mem.cpu_fraction) + " %" if mem.cpu_fraction is not None else "–",
                f"{mem.datagrams:,} ({rate:,.0f}/s incl. start-up; 2,000/s at full rate)"
                if rate is not None
                else "–",
            ]
        ],
        "rrrrrr",
    )
    return out


def _memory_ok(mem: MemoryResult | None) -> bool | None:
    if mem is None or mem.error or not math.isfinite(mem.slope_kb_per_min):
        return None
    return mem.slope_kb_per_min <= max(10.0, 3.0 * mem.slope_stderr)


#: Many performers on one core (issue 35): p99 of 64 gloves at 1 kHz, and the whole chain's cost.
MANY_P99_US = 2000.0
GLOVE_SAMPLE_US = 5.0


def _ratio_goal(goal: str, r: LatencyResult, floor: LatencyResult) -> list[str]:
    """A goal row: ``r``'s p99 at most 1.2 × ``floor``'s, with both figures and each round's ratio."""
    ratio = r.p99 / floor.p99
    return [
        goal,
        f"{ratio:.2f} × ({_ms(r.p99)} vs {_ms(floor.p99)} ms)" + _by_round(r, floor),
        _verdict(ratio <= 1.2, f"{ratio:.2f} ×, goal 1.2 ×"),
    ]


def _many_gloves(lat: list[LatencyResult]) -> list[list[str]]:
    """The goals of many performers on one machine: the compiled chains at 64 gloves, 1 kHz."""
    rows = []
    for spin in (False, True):  # one glove, compiled, against the relays, like against like
        one = _find(lat, "pointat-mote", "tqt", 1000.0, spin=spin, compiled=True)
        for kind, name in (("python-osc", "python-osc relay"), ("pty", "python pty relay")):
            floor = _find(lat, "floor", kind, 1000.0, spin=spin)
            if one and floor:
                how = f" --spin {one.spin:g}" if spin else ""
                goal = f"tqt chain compiled{how}, mote path, 1 kHz, 1 glove: p99 ≤ 1.2 × {name}"
                rows.append(
                    _ratio_goal(goal + (", polling as --spin does" if spin else ", both asleep"), one, floor)
                )
    r = _find(lat, "pointat-mote", "tqt", 1000.0, motes=64, compiled=True)
    plain = _find(lat, "pointat-mote", "tqt", 1000.0, motes=64)
    if r:
        beside = ""
        if plain:
            beside = f"; node by node {_ms(plain.p99)} ms, {plain.received}/{plain.expected} out"
        rows.append(
            [
                "tqt chain compiled, 64 gloves at 1 kHz on one base station, one core: p99 ≤ 2 ms",
                f"{_ms(r.p99)} ms, {r.received}/{r.expected} out{beside}",
                _verdict(
                    r.p99 <= MANY_P99_US and r.received >= 0.99 * r.expected,
                    f"{r.p99 / MANY_P99_US:.2f} × the goal",
                ),
            ]
        )
    return rows


def _cost_rows(costs: list[CostResult]) -> list[list[str]]:
    """The whole-chain cost goal, from the untagged rounds."""
    mine = {(c.motes, c.compiled): c for c in costs if c.us}
    c, plain = mine.get((64, True)), mine.get((64, False))
    if c is None:
        return []
    shown = f"{c.median_us:.1f} µs (range {min(c.us):.1f}–{max(c.us):.1f})"
    if plain:
        shown += f"; node by node {plain.median_us:.1f} µs"
    return [
        [
            "tqt chain compiled, 64 gloves at 1 kHz: ≤ 5 µs of CPU per glove-sample, whole process "
            "(reading the pty, parsing, the chain, sending)",
            shown,
            _verdict(c.median_us <= GLOVE_SAMPLE_US, f"{c.median_us / GLOVE_SAMPLE_US:.2f} × the goal"),
        ]
    ]


def _cost_section(run: Run) -> list[str]:
    """The table of :func:`benchmarks.latency.costs`."""
    if not run.costs:
        return []
    rows = [
        [
            c.label,
            f"{c.median_us:.1f}" if c.us else "failed",
            f"{min(c.us):.1f}–{max(c.us):.1f}" if c.us else c.error[:80],
            f"{np.median(c.delivered):.3f}" if c.delivered else "",
        ]
        for c in run.costs
    ]
    return [
        "### What a glove-sample costs, whole process",
        "",
        "Untagged gloves (`benchmarks/patches/mote_tqt_plain_N.pat`: nothing added to the chain), 1 kHz, "
        "real mote frames into the pty; the `pointat run` process's CPU time over the datagrams counted at "
        "our socket, per round; median and range of the rounds.  A row whose outputs fall short of its "
        "inputs could not keep up (the pty refused frames): its figure is per datagram out.",
        "",
        *_table(["", "µs of CPU per glove-sample", "range", "outputs / inputs"], rows, "lrrr"),
        "",
    ]


# ------------------------------------------------------------------------------------------ summary
def _summary(run: Run) -> list[str]:
    rows = []
    lat = run.latency
    for chain in ("torre", "tqt"):
        r = _find(lat, "pointat-mote", chain, 1000.0)
        name = CHAINS[chain]
        if r:
            rows.append(
                [
                    f"{name}, mote path, 1 kHz, 1 glove: p99 ≤ 1 ms",
                    f"{_ms(r.p99)} ms",
                    _verdict(r.p99 <= 1000, f"{r.p99 / 1000:.2f} × the goal"),
                ]
            )
            rows.append(
                [
                    f"{name}, mote path, 1 kHz, 1 glove: jitter ≤ 0.5 ms",
                    f"{_ms(r.jitter)} ms",
                    _verdict(r.jitter <= 500, f"{r.jitter / 500:.2f} × the goal"),
                ]
            )
        for realtime, spin in ((False, False), (True, False), (False, True)):
            u = _find(lat, "pointat-udp", chain, 1000.0, realtime=realtime, spin=spin)
            m = _find(lat, "pointat-mote", chain, 1000.0, realtime=realtime, spin=spin)
            shown = u or m
            rt_name = name + (" --rt" if realtime else f" --spin {shown.spin:g}" if spin and shown else "")
            # like against like: sleeping rows against the relay asleep, --spin rows against it polling
            floor = _find(lat, "floor", "python-osc", 1000.0, realtime=realtime, spin=spin)
            floor_name = "python-osc relay" + (
                " at real-time priority" if realtime else ", polling as --spin does" if spin else ""
            )
            if floor and u:
                rows.append(
                    [
                        f"{rt_name}, osc_in path, 1 kHz: p99 ≤ 1.2 × {floor_name}",
                        f"{u.p99 / floor.p99:.2f} × ({_ms(u.p99)} vs {_ms(floor.p99)} ms)"
                        + _by_round(u, floor),
                        _verdict(u.p99 <= 1.2 * floor.p99, f"{u.p99 / floor.p99:.2f} ×, goal 1.2 ×"),
                    ]
                )
            if floor and m:
                rows.append(
                    [
                        f"{rt_name}, mote path, 1 kHz: p99 ≤ 1.2 × {floor_name}",
                        f"{m.p99 / floor.p99:.2f} ×" + _by_round(m, floor),
                        _verdict(m.p99 <= 1.2 * floor.p99, f"{m.p99 / floor.p99:.2f} ×, goal 1.2 ×"),
                    ]
                )
            pty_floor = _find(lat, "floor", "pty", 1000.0, spin=spin)
            if pty_floor and m and not realtime:
                goal = (
                    f"{rt_name}, mote path, 1 kHz: p99 ≤ 1.2 × python pty relay (the same pty, a bare reader"
                )
                rows.append(_ratio_goal(goal + (", polling as --spin does)" if spin else ")"), m, pty_floor))
            for pd_kind, pd_name in (("pd", "Pd default"), ("pd-sg0.1", "Pd -sleepgrain 0.1")):
                pd = _find(lat, "floor", pd_kind, 1000.0)
                if pd and u:
                    rows.append(
                        [
                            f"{rt_name}, osc_in path, 1 kHz: beats {pd_name} (p50 and p99)",
                            f"p50 {_ms(u.p50)} vs {_ms(pd.p50)}, p99 {_ms(u.p99)} vs {_ms(pd.p99)} ms",
                            _verdict(
                                u.p50 < pd.p50 and u.p99 < pd.p99,
                                f"p50 {u.p50 / pd.p50:.2f} ×, p99 {u.p99 / pd.p99:.2f} × Pd's",
                            ),
                        ]
                    )
    rows += _many_gloves(lat)
    rows += _cost_rows(run.costs)
    tp = run.throughput
    if tp:
        torre = {p.how: p for p in tp.patches if p.chain == "torre"}
        for how, what in (
            (PUSHED, "in process, ADC vectors handed to the first node (no input I/O, no scheduler)"),
            (WHOLE, "whole process, `pointat run` of the replay patch at speed=0, fusion half"),
        ):
            if how in torre:
                figure, verdict = _rate_goal(torre[how])
                rows.append([f"Pointing-at chain: ≥ 20,000 samples/s on one core, {what}", figure, verdict])
        run_up = next((st for st in tp.startup if st.label.startswith("pointat run") and st.seconds), None)
        if run_up:
            m = statistics.median(run_up.seconds)
            rows.append(
                [
                    f"start-up warm, {run_up.label} (the compiled glove chain loaded from its cache): < 1 s",
                    f"{m:.2f} s (median of {len(run_up.seconds)}; range {min(run_up.seconds):.2f}–"
                    f"{max(run_up.seconds):.2f})",
                    _verdict(m < 1.0, f"{m:.2f} × the goal"),
                ]
            )
        f = next((x for x in tp.filters if x.name == "TQTFilter robust"), None)
        if f:
            rows.append(
                [
                    "tqt, one sensor: ≤ 10 µs per update",
                    f"{f.median_us:.1f} µs (median; range {_spread(f)})",
                    _verdict(f.median_us <= 10, f"{f.median_us / 10:.2f} × the goal"),
                ]
            )
        bank = next(
            (x for x in tp.filters if x.name.startswith("TQTBank") and x.name.endswith("numba")), None
        )
        if bank is None:
            bank = next((x for x in tp.filters if x.name.startswith("TQTBank")), None)
        # the compiled peers, like against like: once a sample (as a live patch calls a filter), and their
        # batch APIs (one call for the whole trial) against the bank's batch across sensors
        for calls, how in (
            (PER_CALL, "called once a sensor-sample"),
            (BATCH, "batch APIs, batch against batch"),
        ):
            peers = [x for x in tp.filters if x.library.startswith(("imufusion", "vqf")) and x.calls == calls]
            if bank and peers:
                peer = min(peers, key=lambda x: x.median_us)
                rows.append(
                    [
                        f"15 sensors at once: per sensor-sample, faster than the compiled peers {how}",
                        f"{bank.median_us:.2f} µs ({bank.name.split(', ')[-1]}) vs {peer.median_us:.2f} µs "
                        f"({peer.library.split()[0]}, {peer.name}), medians",
                        _verdict(
                            bank.median_us < peer.median_us,
                            f"{bank.median_us / peer.median_us:.2f} × its time",
                        ),
                    ]
                )
    acc = run.accuracy
    if acc and acc.scores:
        rob = "tqt robust (TQTFilter defaults)"
        pap = "tqt paper (TQTFilter defaults)"
        full = len(acc.trials) == len(PUBLISHED_ORDER)
        scope = "" if full else f" ({len(acc.trials)} of 10 trials)"
        if rob in acc.scores:
            m = acc.mean(rob).total
            rows.append(
                [
                    f"tqt robust: mean total RMSE ≤ 2.0°{scope}",
                    f"{m:.2f}°",
                    _verdict(m <= 2.0, f"{m / 2.0:.2f} × the goal"),
                ]
            )
            for v in ("VQF defaults (tauAcc=3, tauMag=9)", "VQF tuned (tauMag=30)"):
                if v in acc.scores:
                    vm = acc.mean(v).total
                    wins = sum(acc.scores[rob][t].total < acc.scores[v][t].total for t in acc.trials)
                    rows.append(
                        [
                            f"tqt robust ahead of {v.split(' (')[0]}: mean and most trials{scope}",
                            f"{m:.2f} vs {vm:.2f}°, ahead on {wins}/{len(acc.trials)}",
                            _verdict(
                                m < vm and wins > len(acc.trials) / 2,
                                f"{m / vm:.2f} × its mean error, ahead on {wins}/{len(acc.trials)}",
                            ),
                        ]
                    )
        if pap in acc.scores:
            pm = acc.mean(pap).total
            for peer in (
                "Madgwick gain 0.041 (ahrs default)",
                "Mahony k_P=0.74 k_I=0.0012 (BROAD)",
                "imufusion defaults (gain 0.5)",
            ):
                if peer in acc.scores:
                    em = acc.mean(peer).total
                    rows.append(
                        [
                            f"tqt paper ahead of {peer}{scope}",
                            f"{pm:.2f} vs {em:.2f}°",
                            _verdict(pm < em, f"{pm / em:.2f} × its mean error"),
                        ]
                    )
    mem = run.memory
    if mem and not mem.error:
        short = (
            " — too short to tell warm-up from growth; the 10-min run decides" if mem.seconds < 300 else ""
        )
        rows.append(
            [
                f"no memory growth ({mem.seconds:.0f} s at 1 kHz{short})",
                f"{mem.slope_kb_per_min:+.2f} ± {mem.slope_stderr:.2f} KB/min, peak {(mem.peak_kb or 0) / 1024:.1f} MB",
                _ok(_memory_ok(mem)),
            ]
        )
    rows += run.gesture_goals
    return ["## Goals", ""] + _table(["goal", "measured", ""], rows, "lll")


def render(run: Run) -> str:
    m = run.machine
    out = [
        "# pointat benchmark report",
        "",
        f"Generated by `{run.command}` on {run.started} in {run.seconds / 60:.1f} min"
        + (
            " (**quick** run: shorter measurements, fewer trials; see the README for the full run)."
            if run.quick
            else "."
        ),
        "",
        "## Machine",
        "",
    ]
    out += _table(["", ""], [[k, v] for k, v in m.items()], "ll")
    out += [
        "The machine is shared: other work ran beside this benchmark (see the load averages), so absolute "
        "times move from run to run (the peers' rows in section 2, code that is not pointat's, show how "
        "far); compare the ratios measured side by side in the same run.",
        "",
    ]
    out += _summary(run)
    if run.latency:
        out += _latency_section(run)
        out += _cost_section(run)
    if run.throughput:
        out += _throughput_section(run.throughput)
    if run.accuracy:
        out += _accuracy_section(run.accuracy, run.data_note)
    if run.memory:
        out += _memory_section(run.memory)
    if run.monitor:
        out += ["## 5. The monitor and OSCQuery (`python -m benchmarks.monitor`)", "", run.monitor, ""]
    if run.gestures:
        out += ["## 6. Gesture recognition (`python -m benchmarks.gestures`)", "", run.gestures, ""]
    if run.reload:
        out += ["## 7. Hot reload (`python -m benchmarks.reload`)", "", run.reload, ""]
    out += ["## Commands", ""]
    out += [
        "The benchmark: `"
        + run.command
        + "` (quick: `python -m benchmarks --quick`; full: `python -m benchmarks`).",
        "",
        "Processes it started (ports are picked at run time; `/dev/pts/N` is a pseudo-terminal it opens):",
        "",
        "```",
    ]
    seen = set()
    for r in run.latency:
        if r.command not in seen:
            seen.add(r.command)
            out.append(r.command)
    if run.throughput:
        out += run.throughput.commands
    if run.memory:
        out.append(run.memory.command)
    out += ["```", ""]
    errors = []
    if run.throughput:
        errors += run.throughput.errors
    if run.accuracy:
        errors += run.accuracy.errors
    notes = run.notes + errors
    if notes:
        out += ["## Notes", ""] + [f"- {n}" for n in notes] + [""]
    return "\n".join(out).rstrip() + "\n"


# ------------------------------------------------------------------------------------------ figures
_COLORS = [
    "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#7f7f7f", "#17becf", "#bcbd22",
]  # fmt: skip


def _esc(s: str) -> str:
    return s.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def latency_cdf_svg(results: list[LatencyResult], rate: float = 1000.0) -> str:
    """Cumulative distribution of latency (log time axis) of the one-glove runs at ``rate`` (normal
    priority; the ``--rt`` rows are in the tables).  Floors and pointat's own relays are dashed."""
    series = [
        r
        for r in results
        if r.rate == rate and r.motes == 1 and not (r.realtime or r.spin) and not r.error and r.received
    ]
    W, H, L, R, T, B = 760, 420, 60, 250, 20, 50
    lo, hi = 30.0, 20000.0
    if series:
        lo = max(10.0, min(float(np.percentile(r.latencies_us, 0.1)) for r in series) * 0.8)
        hi = max(float(r.latencies_us.max()) for r in series) * 1.2

    def x(us: float) -> float:
        return L + (math.log10(max(us, lo)) - math.log10(lo)) / (math.log10(hi) - math.log10(lo)) * (
            W - L - R
        )

    def y(p: float) -> float:
        return T + (1 - p) * (H - T - B)

    parts = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" font-family="sans-serif" font-size="12">'
    ]
    parts.append(f'<rect width="{W}" height="{H}" fill="white"/>')
    for dec in range(int(math.floor(math.log10(lo))), int(math.ceil(math.log10(hi))) + 1):
        for mult in (1, 2, 5):
            v = mult * 10**dec
            if lo <= v <= hi:
                parts.append(f'<line x1="{x(v):.1f}" y1="{T}" x2="{x(v):.1f}" y2="{H - B}" stroke="#ddd"/>')
                label = f"{v / 1000:g} ms" if v >= 1000 else f"{v:g} µs"
                parts.append(f'<text x="{x(v):.1f}" y="{H - B + 15}" text-anchor="middle">{label}</text>')
    for p in (0, 0.5, 0.9, 0.99, 1.0):
        parts.append(f'<line x1="{L}" y1="{y(p):.1f}" x2="{W - R}" y2="{y(p):.1f}" stroke="#eee"/>')
        parts.append(f'<text x="{L - 5}" y="{y(p) + 4:.1f}" text-anchor="end">{p:g}</text>')
    parts.append(
        f'<rect x="{L}" y="{T}" width="{W - L - R}" height="{H - T - B}" fill="none" stroke="#333"/>'
    )
    parts.append(
        f'<text x="{(W - R + L) / 2}" y="{H - 10}" text-anchor="middle">latency (log scale), {rate:g} Hz input, one glove</text>'
    )
    for i, r in enumerate(series):
        v = np.sort(r.latencies_us)
        n = v.size
        idx = np.unique(np.linspace(0, n - 1, min(n, 400)).astype(int))
        pts = " ".join(f"{x(float(v[k])):.1f},{y((k + 1) / n):.1f}" for k in idx)
        c = _COLORS[i % len(_COLORS)]
        dash = ' stroke-dasharray="6 3"' if r.family == "floor" or r.chain == "relay" else ""
        parts.append(f'<polyline points="{pts}" fill="none" stroke="{c}" stroke-width="2"{dash}/>')
        ly = T + 15 + 18 * i
        parts.append(
            f'<line x1="{W - R + 10}" y1="{ly - 4}" x2="{W - R + 30}" y2="{ly - 4}" stroke="{c}" stroke-width="3"{dash}/>'
        )
        parts.append(f'<text x="{W - R + 35}" y="{ly}">{_esc(r.label)}</text>')
    parts.append("</svg>")
    return "\n".join(parts) + "\n"


def accuracy_svg(acc: AccuracyResults) -> str:
    """Horizontal bars: mean total RMSE per filter, heading part marked."""
    names = list(acc.scores)
    means = [acc.mean(n) for n in names]
    W, row, L, R, T = 760, 24, 360, 40, 20
    H = T + row * len(names) + 40
    top = max([m.total for m in means] + [1.0])
    top = min(top, 30.0)

    def x(v: float) -> float:
        return L + min(v, top) / top * (W - L - R)

    parts = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" font-family="sans-serif" font-size="12">'
    ]
    parts.append(f'<rect width="{W}" height="{H}" fill="white"/>')
    step = 1 if top <= 8 else 2 if top <= 16 else 5
    for v in np.arange(0, top + 1e-9, step):
        parts.append(f'<line x1="{x(v):.1f}" y1="{T}" x2="{x(v):.1f}" y2="{H - 30}" stroke="#ddd"/>')
        parts.append(f'<text x="{x(v):.1f}" y="{H - 15}" text-anchor="middle">{v:g}°</text>')
    for i, (n, m) in enumerate(zip(names, means, strict=True)):
        yy = T + i * row
        c = "#1f77b4" if acc.families.get(n) == "pointat" else "#999"
        parts.append(
            f'<rect x="{L}" y="{yy + 4}" width="{x(m.total) - L:.1f}" height="{row - 8}" fill="{c}"/>'
        )
        parts.append(f'<text x="{L - 6}" y="{yy + row / 2 + 4}" text-anchor="end">{_esc(n)}</text>')
        label = f"{m.total:.2f}" + ("+" if m.total > top else "")
        parts.append(f'<text x="{x(m.total) + 4:.1f}" y="{yy + row / 2 + 4}">{label}</text>')
    parts.append(
        f'<text x="{(L + W - R) / 2}" y="{H - 2}" text-anchor="middle">mean total RMSE over {len(acc.trials)} BROAD trial(s), degrees (pointat blue)</text>'
    )
    parts.append("</svg>")
    return "\n".join(parts) + "\n"


def write_figures(run: Run, folder: Path) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    if run.latency:
        p = folder / "latency_cdf_1khz.svg"
        p.write_text(latency_cdf_svg(run.latency), encoding="utf-8")
        written.append(p)
    if run.accuracy and run.accuracy.scores:
        p = folder / "accuracy_mean.svg"
        p.write_text(accuracy_svg(run.accuracy), encoding="utf-8")
        written.append(p)
    return written
