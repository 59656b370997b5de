"""Property-based tests of the mote wire format: the parser meets bytes from a serial port or a radio.

Properties: any bytes decode without an exception and with the byte accounting right; valid frames with
garbage between them all come through, in order and unchanged; how the stream is cut into reads changes
nothing; the buffer and the time taken stay bounded.
"""

from __future__ import annotations

import time

from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from pointat.devices.mote_frame import (
    ADC_MAX,
    FRAME_LEN,
    MAX_LINE,
    CorruptFrame,
    Frame,
    FrameParser,
    Garbage,
    encode_frame,
    encode_text,
)

SETTINGS = settings(
    max_examples=150,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow],
)

frames = st.builds(
    Frame,
    st.integers(0, 255),
    st.integers(0, 0xFFFF),
    st.tuples(*[st.integers(0, ADC_MAX)] * 9),
)

#: Bytes the parser treats specially: syncs, '$', digits, separators, line endings.
_SPECIAL = list(b"\xa5\x5a$0123456789 ,\t\r\n") + [0x00, 0xFF]
garbage = st.one_of(
    st.binary(max_size=60),
    st.lists(st.sampled_from(_SPECIAL), max_size=60).map(bytes),
    # the start of a frame, cut short: a sync pair or a tagged line that never ends
    st.tuples(frames, st.integers(1, FRAME_LEN - 1)).map(lambda fn: encode_frame(fn[0])[: fn[1]]),
    st.tuples(frames, st.integers(1, 20)).map(lambda fn: encode_text(fn[0])[: fn[1]]),
)
separators = st.sampled_from([" ", "\t", ",", ", "])
newlines = st.sampled_from(["\n", "\r\n"])


@st.composite
def wire(draw, frame: Frame, after_garbage: bool) -> bytes:
    """One frame as the mote could send it: binary, or a text line (untagged only where no garbage is
    right before it: a stray digit glued to an untagged line changes its id, as the module says)."""
    if draw(st.booleans()):
        return encode_frame(frame)
    tag = True if after_garbage else draw(st.booleans())
    return encode_text(frame, tag=tag, sep=draw(separators), newline=draw(newlines))


@st.composite
def padded_line(draw) -> bytes:
    """A valid text line with extra blanks, often of :data:`MAX_LINE` bytes give or take one."""
    frame = draw(frames)
    fields = [str(v) for v in (frame.mote, frame.n_pack, *frame.channels)]
    pads = draw(st.lists(st.integers(1, 8), min_size=len(fields) - 1, max_size=len(fields) - 1))
    body = " " * draw(st.integers(0, 8)) + "".join(
        f + " " * p for f, p in zip(fields, [*pads, 0], strict=True)
    )
    length = draw(st.one_of(st.sampled_from([MAX_LINE - 1, MAX_LINE, MAX_LINE + 1]), st.integers(0, 160)))
    body = body.ljust(length)  # trailing blanks up to the length wanted (none if already longer)
    return ("$" + body + draw(newlines)).encode("ascii")


def feed_chunks(parser: FrameParser, data: bytes, cuts: list[int]) -> list[Frame]:
    out: list[Frame] = []
    pos = 0
    for c in sorted(cuts):
        out += parser.feed(data[pos:c])
        pos = c
    out += parser.feed(data[pos:])
    return out


def check_accounting(parser: FrameParser) -> None:
    st_ = parser.stats
    assert st_.bytes_in == st_.frame_bytes + st_.garbage_bytes + parser.pending
    # what waits is one incomplete candidate: a binary frame or a '$', MAX_LINE bytes and a CR
    assert parser.pending <= MAX_LINE + 2


def core(f: Frame) -> tuple:
    return f.mote, f.n_pack, f.channels


def is_subsequence(small: list, big: list) -> bool:
    it = iter(big)
    return all(any(x == y for y in it) for x in small)


# --------------------------------------------------------------------------------------------------


@SETTINGS
@given(data=st.binary(max_size=400), fmt=st.sampled_from(["auto", "binary", "text"]))
def test_any_bytes_decode_without_an_exception_and_every_byte_is_accounted_for(data, fmt):
    parser = FrameParser(fmt)
    got = parser.feed(data)
    check_accounting(parser)
    for f in got:  # whatever came out is a frame in range
        assert 0 <= f.mote <= 255 and 0 <= f.n_pack <= 0xFFFF
        assert len(f.channels) == 9 and all(0 <= c <= ADC_MAX for c in f.channels)
    parser.flush()
    assert parser.pending == 0
    st_ = parser.stats
    assert st_.bytes_in == len(data) == st_.frame_bytes + st_.garbage_bytes
    events = parser.pop_events()
    assert sum(e.nbytes for e in events if isinstance(e, Garbage)) == st_.garbage_bytes
    assert sum(isinstance(e, CorruptFrame) for e in events) == st_.corrupt


@SETTINGS
@given(st.data())
def test_valid_frames_with_garbage_between_them_all_come_through_in_order(data):
    items = data.draw(st.lists(st.tuples(garbage, frames), min_size=1, max_size=12))
    tail = data.draw(garbage)
    parts, want = [], []
    for junk, frame in items:
        parts += [junk, data.draw(wire(frame, after_garbage=bool(junk)))]
        want.append(frame)
    stream = b"".join(parts) + tail
    parser = FrameParser()
    got = parser.feed(stream)
    # garbage may hold frames of its own (a valid line is valid wherever it is): the sent ones are a
    # subsequence of what came out, unchanged
    assert is_subsequence([core(f) for f in want], [core(f) for f in got])
    check_accounting(parser)


@SETTINGS
@given(st.data())
def test_valid_frames_alone_come_through_exactly_with_no_garbage_nor_corruption(data):
    want = data.draw(st.lists(frames, min_size=1, max_size=12))
    stream = b"".join(data.draw(wire(f, after_garbage=False)) for f in want)
    parser = FrameParser(max_gap=0)  # every gap a counter jump: lost stays 0 whatever the counters
    got = parser.feed(stream)
    assert [core(f) for f in got] == [core(f) for f in want]
    assert parser.stats.corrupt == 0 and parser.stats.garbage_bytes == 0 and parser.pending == 0


@SETTINGS
@given(
    stream=st.one_of(
        st.binary(max_size=300),
        st.lists(st.one_of(garbage, frames.map(encode_frame), frames.map(encode_text), padded_line())).map(
            b"".join
        ),
    ),
    cuts=st.lists(st.integers(0, 2000), max_size=20),
    fmt=st.sampled_from(["auto", "binary", "text"]),
)
def test_how_the_stream_is_cut_into_reads_changes_nothing(stream, cuts, fmt):
    whole = FrameParser(fmt)
    want = whole.feed(stream)
    parser = FrameParser(fmt)
    got = feed_chunks(parser, stream, [min(c, len(stream)) for c in cuts])
    assert got == want  # lost and jump flags included
    check_accounting(parser)
    a, b = whole.stats, parser.stats
    assert (a.frames, a.frame_bytes, a.garbage_bytes, a.corrupt, a.lost) == (
        b.frames,
        b.frame_bytes,
        b.garbage_bytes,
        b.corrupt,
        b.lost,
    )
    assert a.motes == b.motes and whole.pending == parser.pending
    # the same events, but for where a long run of garbage is cut into Garbage reports
    assert [e for e in whole.pop_events() if not isinstance(e, Garbage)] == [
        e for e in parser.pop_events() if not isinstance(e, Garbage)
    ]


_LINE_128 = b"$1 2 3 4 5 6 7 8 9 10 11".ljust(MAX_LINE + 1) + b"\n"


@SETTINGS
@given(line=padded_line(), back=st.one_of(st.integers(0, 4), st.integers(0, 200)))
@example(line=_LINE_128, back=1)  # cut just before the newline: was refused as too long
@example(line=_LINE_128[:-1] + b"\r\n", back=0)  # MAX_LINE bytes and a CRLF ending: was refused
def test_a_line_of_up_to_max_line_bytes_is_read_however_it_is_cut(line, back):
    cut = max(0, len(line) - back)
    body = len(line.rstrip(b"\r\n")) - 1  # '$' and the line ending excluded, as MAX_LINE counts
    whole = FrameParser()
    parser = FrameParser()
    got = feed_chunks(parser, line, [cut])
    assert got == whole.feed(line)
    if body <= MAX_LINE:
        assert len(got) == 1 and parser.stats.corrupt == 0
    else:
        assert got == [] and parser.stats.corrupt >= 1
    check_accounting(parser)


@settings(max_examples=12, deadline=None, derandomize=True, database=None)
@given(
    unit=st.sampled_from(
        [b"\xa5\x5a", b"\xa5", b"0", b"1 ", b"$", b"$1 2 3 4 5 6 7 8 9 10 ", b"\xa5\x5a\x00" * 7, b"9\n"]
    ),
    chunk=st.sampled_from([1, 7, 4096, 1 << 20]),
)
def test_adversarial_floods_take_linear_time_and_bounded_memory(unit, chunk):
    data = unit * (50_000 // len(unit))
    parser = FrameParser(max_events=100)
    t0 = time.process_time()  # (CPU time: a loaded machine shares the cores, not the work)
    for i in range(0, len(data), chunk):
        parser.feed(data[i : i + chunk])
        assert parser.pending <= MAX_LINE + 2
    elapsed = time.process_time() - t0
    check_accounting(parser)
    assert len(parser.pop_events()) <= 100
    assert elapsed < 5.0, f"{elapsed:.2f} s for 50 kB of {unit!r}"  # quadratic: minutes
