"""The compiled chains take plain mote frames straight from the parser's buffer (``FrameParser.plain``,
:func:`pointat.compiled.kernel.scan_plain`): nothing about the stream may change by it.

Property: for any stream of a few motes' frames (counters in order, with losses, restarts, damaged frames,
text frames and noise between them), cut into reads anywhere, a parser whose consumer takes the plain
frames itself gives every mote's frames in their order, with the same sensor times (the mote node's
clocks), and the same events and counters, as a parser on its own.  (Per read, the consumer handles the
parser's list first and the frames it took at the end of the read, as the mote node does: between motes
the order may differ, never within one.)
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pointat.compiled.kernel import scan_plain
from pointat.devices.mote_frame import ADC_MAX, Frame, FrameParser, encode_frame, encode_text
from pointat.nodes.sensors import _clocks

SETTINGS = settings(
    max_examples=200,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow],
)

RATE = 100.0
MOTES = (1, 2, 7)


class Taker:
    """A consumer as the mote node with fused chains is: it takes the plain frames of ``accept``."""

    def __init__(self, accept: set[int], scan=scan_plain) -> None:
        self.clock, self.clocks = _clocks(range(256), RATE)
        self.plain_of = np.full(256, -1, np.int64)
        for m in accept:
            self.plain_of[m] = m  # (a chain per mote id, numbered as the ids)
        self.scan = scan
        self.idx = np.zeros(4096, np.int64)
        self.counts = np.zeros((4096, 9))
        self.times = np.zeros(4096)
        self.per = np.zeros(256, np.int64)
        self.taken: list[tuple] = []
        self.total = 0  # frames taken

    def __call__(self, buf, pos, end, last, held, now):
        view = np.frombuffer(buf, np.uint8)
        k, stop = self.scan(
            view,
            pos,
            end,
            last,
            held,
            self.plain_of,
            self.clock,
            RATE,
            self.idx,
            self.counts,
            self.times,
            self.per,
            0,
        )
        del view
        if not k:
            return None
        self.total += k
        for f in range(k):
            self.taken.append((int(self.idx[f]), tuple(int(c) for c in self.counts[f]), float(self.times[f])))
        motes = np.flatnonzero(self.per)
        got = dict(zip(motes.tolist(), self.per[motes].tolist(), strict=True))
        self.per[:] = 0
        return k, int(stop), got


def run(stream: bytes, cuts: list[int], taker: Taker | None) -> tuple[list[tuple], list, object]:
    """Feed ``stream`` in reads cut at ``cuts``; every frame as (mote, channels, time) in the order the
    mote node would handle it, the events, the counters."""
    parser = FrameParser("auto", rate=RATE)
    clock, clocks = (taker.clock, taker.clocks) if taker else _clocks(range(256), RATE)
    parser.plain = taker
    out: list[tuple] = []
    events: list = []
    edges = [0, *sorted(set(c for c in cuts if 0 < c < len(stream))), len(stream)]
    for j, (a, b) in enumerate(zip(edges, edges[1:], strict=False)):
        now = 10.0 + 0.01 * j
        frames = parser.feed(stream[a:b], now)
        if taker:
            out += taker.taken
            taker.taken = []
        out += [(f.mote, tuple(f.channels), clocks[f.mote].time(f, now)) for f in frames]
        events += parser.pop_events()
    return out, events, parser.stats


def by_mote(frames: list[tuple]) -> dict[int, list[tuple]]:
    out: dict[int, list[tuple]] = {}
    for f in frames:
        out.setdefault(f[0], []).append(f)
    return out


@st.composite
def streams(draw) -> bytes:
    """Frames of a few motes, mostly in order, with what a radio link does to them between."""
    n_pack = {m: draw(st.integers(0, 0xFFFF)) for m in MOTES}
    parts = []
    for _ in range(draw(st.integers(1, 80))):
        kind = draw(st.sampled_from(["frame"] * 16 + ["gap", "restart", "damaged", "text", "noise"]))
        m = draw(st.sampled_from(MOTES))
        if kind == "noise":
            parts.append(draw(st.binary(max_size=30)))
            continue
        if kind == "gap":
            n_pack[m] = (n_pack[m] + draw(st.integers(2, 40))) & 0xFFFF
        elif kind == "restart":
            n_pack[m] = draw(st.integers(0, 0xFFFF))
        else:
            n_pack[m] = (n_pack[m] + 1) & 0xFFFF
        frame = Frame(m, n_pack[m], tuple(draw(st.integers(0, ADC_MAX)) for _ in range(9)))
        data = encode_text(frame) if kind == "text" else encode_frame(frame)
        if kind == "damaged":
            at = draw(st.integers(2, len(data) - 1))
            data = data[:at] + bytes([data[at] ^ draw(st.integers(1, 255))]) + data[at + 1 :]
        parts.append(data)
    return b"".join(parts)


@SETTINGS
@given(
    stream=streams(),
    step=st.integers(5, 130),
    cuts=st.lists(st.floats(0.0, 1.0), max_size=10),
    accept=st.sets(st.sampled_from(MOTES), min_size=1),
)
def test_taking_plain_frames_changes_nothing_the_mote_node_sees(stream, step, cuts, accept):
    # reads of a few frames, as a live link gives them, and some cut anywhere
    cuts = [*range(step, len(stream), step), *(int(c * len(stream)) for c in cuts)]
    want = run(stream, cuts, None)
    taker = Taker(accept)
    got = run(stream, cuts, taker)
    TAKEN.append(taker.total)
    assert by_mote(got[0]) == by_mote(want[0])
    assert got[1] == want[1]
    assert got[2] == want[2]


TAKEN: list[int] = []


def test_the_property_took_frames_in_most_of_its_streams():
    """(Run after the property: it is not vacuous.)"""
    assert len(TAKEN) == SETTINGS.max_examples
    assert sum(t > 0 for t in TAKEN) > SETTINGS.max_examples // 2, TAKEN


@pytest.mark.slow
def test_the_compiled_scan_takes_the_same_frames_as_its_source():
    """numba's scan against the Python one (the property's) on a long stream of three motes, clean and
    with a few losses: the same frames, times and counters, most of them taken."""
    from pointat.compiled import build

    rng = np.random.default_rng(5)
    parts, n_pack = [], dict.fromkeys(MOTES, 100)
    for _tick in range(3000):
        for m in MOTES:
            n_pack[m] = (n_pack[m] + (1 if rng.random() > 0.01 else 3)) & 0xFFFF
            parts.append(encode_frame(Frame(m, n_pack[m], tuple(int(c) for c in rng.integers(0, 4096, 9)))))
    stream = b"".join(parts)
    cuts = sorted(rng.integers(0, len(stream), 400).tolist())
    fast = Taker(set(MOTES), build.scan_plain())
    slow = Taker(set(MOTES))
    a, b = run(stream, cuts, fast), run(stream, cuts, slow)
    assert a[0] == b[0] and a[1] == b[1] and a[2] == b[2]
    assert by_mote(a[0]) == by_mote(run(stream, cuts, None)[0])
    assert a[2].frames == 9000
    # (the parser takes the first of each mote, a loss and what follows it in the read, a frame cut in two)
    assert fast.total == slow.total > 8000
