"""Tests of the mote wire format and the incremental frame parser."""

from __future__ import annotations

import random

import numpy as np
import pytest

from pointat.devices.mote_frame import (
    ADC_MAX,
    CHANNELS,
    DEFAULT_SPEC,
    FRAME_LEN,
    MAX_LINE,
    SYNC,
    CorruptFrame,
    CounterJump,
    Frame,
    FrameParser,
    Garbage,
    LostPackets,
    MoteSpec,
    NewMote,
    crc16_ccitt_false,
    encode_frame,
    encode_text,
)


def make_frame(mote: int, n: int, seed: int = 0) -> Frame:
    rng = random.Random(mote * 100_003 + n * 7 + seed)
    return Frame(mote, n & 0xFFFF, tuple(rng.randrange(4096) for _ in range(9)))


def clean_frame(mote: int, n: int) -> Frame:
    """A frame whose binary encoding holds no sync pair except at its start (exact corrupt counts)."""
    k = 0
    while True:
        f = make_frame(mote, n, seed=k)
        if encode_frame(f).count(SYNC) == 1:
            return f
        k += 1


def feed_all(parser: FrameParser, chunks: list[bytes]) -> list[Frame]:
    out: list[Frame] = []
    for c in chunks:
        out.extend(parser.feed(c))
    return out


def check_invariant(parser: FrameParser) -> None:
    st = parser.stats
    assert st.bytes_in == st.frame_bytes + st.garbage_bytes + parser.pending


def crc_bitwise(data: bytes) -> int:
    crc = 0xFFFF
    for b in data:
        crc ^= b << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
    return crc


# -- encoding -------------------------------------------------------------------------------------


def test_crc_matches_bitwise_reference_and_check_value():
    assert crc16_ccitt_false(b"123456789") == 0x29B1
    rng = random.Random(1)
    for _ in range(50):
        data = bytes(rng.randrange(256) for _ in range(rng.randrange(40)))
        assert crc16_ccitt_false(data) == crc_bitwise(data)


def test_binary_layout_by_hand():
    f = Frame(0x42, 0xBEEF, (0x123, 0x456, 0x789, 0xABC, 0xDEF, 0x012, 0x345, 0x678, 0x9AB))
    wire = encode_frame(f)
    assert len(wire) == FRAME_LEN
    assert wire[:2] == b"\xa5\x5a"
    assert wire[2] == 0x42
    assert wire[3:5] == b"\xbe\xef"
    assert wire[5:19] == bytes.fromhex("123456 789abc def012 345678 09ab")
    assert int.from_bytes(wire[19:21], "big") == crc_bitwise(wire[2:19])


def test_text_layout_and_options():
    f = Frame(7, 65535, (0, 1, 2, 3, 4, 5, 6, 7, 4095))
    assert encode_text(f) == b"$7 65535 0 1 2 3 4 5 6 7 4095\n"
    assert (
        encode_text(f, tag=False, sep=", ", newline="\r\n") == b"7, 65535, 0, 1, 2, 3, 4, 5, 6, 7, 4095\r\n"
    )
    with pytest.raises(ValueError):
        encode_text(f, sep=";")


@pytest.mark.parametrize(
    "bad",
    [
        Frame(256, 0, (0,) * 9),
        Frame(-1, 0, (0,) * 9),
        Frame(0, 65536, (0,) * 9),
        Frame(0, 0, (0,) * 8),
        Frame(0, 0, (0,) * 8 + (4096,)),
        Frame(0, 0, (0,) * 8 + (-1,)),
        Frame(0, 0, (0,) * 8 + (1.0,)),
    ],
)
def test_encode_rejects_out_of_range(bad):
    with pytest.raises(ValueError):
        encode_frame(bad)
    with pytest.raises(ValueError):
        encode_text(bad)


def test_encode_accepts_numpy_integers():
    f = Frame(np.uint8(3), np.int64(9), tuple(np.arange(9, dtype=np.int16)))
    assert FrameParser().feed(encode_frame(f)) == [Frame(3, 9, tuple(range(9)))]


def test_frame_is_immutable_value_with_sensor_views():
    f = make_frame(1, 2)
    with pytest.raises(AttributeError):
        f.mote = 3  # type: ignore[misc]
    assert f.gyro + f.accel + f.mag == f.channels
    assert len(CHANNELS) == 9 and CHANNELS[0] == "gyro_x" and CHANNELS[8] == "mag_z"


# -- round trips, both framings ---------------------------------------------------------------------


@pytest.mark.parametrize("fmt", ["auto", "binary", "text"])
def test_round_trip_extremes(fmt):
    frames = [
        Frame(0, 0, (0,) * 9),
        Frame(255, 65535, (ADC_MAX,) * 9),
        Frame(0xA5, 0xA55A, (0xA55,) * 9),  # sync-like values everywhere
        Frame(10, 0x0A0A, (10,) * 9),  # newline bytes in the binary frame
    ]
    encode = encode_text if fmt == "text" else encode_frame
    parser = FrameParser(fmt, max_gap=0)
    assert parser.feed(b"".join(encode(f) for f in frames)) == frames
    assert parser.stats.corrupt == 0 and parser.stats.garbage_bytes == 0
    check_invariant(parser)


def test_mixed_binary_and_text_in_auto_mode():
    frames = [make_frame(1, n) for n in range(40)]
    stream = b"".join(
        (encode_frame(f) if n % 3 else encode_text(f, tag=n % 2 == 0, sep=", " if n % 5 else "\t"))
        for n, f in enumerate(frames)
    )
    parser = FrameParser()
    assert parser.feed(stream) == frames
    st = parser.stats
    assert st.binary_frames + st.text_frames == 40 and st.text_frames == 14
    assert st.motes[1].received == 40 and st.motes[1].lost == 0 and st.corrupt == 0


def test_format_restriction_ignores_the_other_framing():
    f_bin, f_txt = make_frame(1, 0), make_frame(1, 1)
    stream = encode_frame(f_bin) + encode_text(f_txt)
    assert FrameParser("binary").feed(stream) == [f_bin]
    assert FrameParser("text").feed(stream + b"$") == [f_txt]
    with pytest.raises(ValueError):
        FrameParser("hex")  # type: ignore[arg-type]


def test_text_accepts_separators_and_crlf():
    parser = FrameParser("text", max_gap=0)
    lines = (
        b"1 0 1 2 3 4 5 6 7 8 9\n"
        b"$1,1,1,2,3,4,5,6,7,8,9\r\n"
        b"1 ,2 , 1,2,3  4\t5,6 7 8 9\n"
        b"  $1 3 1 2 3 4 5 6 7 8 9 \r\n"
        b"$0001 00004 0001 2 3 4 5 6 7 8 9\n"
    )
    got = parser.feed(lines)
    assert [f.n_pack for f in got] == [0, 1, 2, 3, 4]
    assert all(f.mote == 1 and f.channels == tuple(range(1, 10)) for f in got)
    assert parser.stats.corrupt == 0 and parser.stats.garbage_bytes == 2  # the two leading spaces


@pytest.mark.parametrize(
    "line, reason",
    [
        (b"$1 0 1 2 3 4 5 6 7 8\n", "fields"),
        (b"$1 0 1 2 3 4 5 6 7 8 9 10\n", "fields"),
        (b"$1 0 1 2 3 4 5 6 7 8 4096\n", "> 4095"),
        (b"$1 0 1 2 3 4 5 6 7 8 -9\n", "unsigned"),
        (b"$1 0 1 2 3 4 5.5 6 7 8 9\n", "unsigned"),
        (b"$1,,1 2 3 4 5 6 7 8 9\n", "unsigned"),
        (b"$256 0 1 2 3 4 5 6 7 8 9\n", "> 255"),
        (b"$1 65536 1 2 3 4 5 6 7 8 9\n", "> 65535"),
        (b"$1 0 1 2 3 4 5 6 7 8 123456\n", "unsigned"),
        (b"$\n", "fields"),
    ],
)
def test_malformed_lines_are_dropped_and_counted(line, reason):
    good = make_frame(1, 5)
    parser = FrameParser()
    got = parser.feed(encode_text(make_frame(1, 4)) + line + encode_text(good))
    assert got[-1] == good and len(got) == 2
    events = [e for e in parser.pop_events() if isinstance(e, CorruptFrame)]
    assert len(events) == 1 and events[0].kind == "text" and reason in events[0].reason
    assert parser.stats.corrupt == 1
    check_invariant(parser)


def test_overlong_line_is_dropped_without_waiting_forever():
    parser = FrameParser()
    assert parser.feed(b"$" + b"1 " * MAX_LINE) == []
    assert parser.stats.corrupt >= 1
    assert parser.pending <= MAX_LINE + 1
    good = make_frame(2, 0)
    assert parser.feed(b"\n" + encode_frame(good)) == [good]
    check_invariant(parser)


def test_dollar_resynchronises_inside_a_damaged_line():
    a, b = make_frame(1, 0), make_frame(1, 1)
    stream = encode_text(a)[:15] + encode_text(b)  # line a cut short, no newline
    parser = FrameParser()
    assert parser.feed(stream) == [b]
    assert parser.stats.corrupt == 0 and parser.stats.garbage_bytes == 15


# -- resynchronisation ---------------------------------------------------------------------------


def test_split_at_every_byte_boundary():
    frames = [make_frame(1, 0), make_frame(2, 0), make_frame(1, 1), make_frame(2, 1), make_frame(1, 2)]
    stream = (
        b"\x00\xa5"
        + encode_frame(frames[0])
        + b"zz"
        + encode_text(frames[1])
        + encode_frame(frames[2])
        + b"\xa5\x5a\x01"
        + encode_text(frames[3], tag=False, sep=",")
        + encode_frame(frames[4])
    )
    reference = FrameParser()
    assert reference.feed(stream) == frames
    for k in range(len(stream) + 1):
        parser = FrameParser()
        assert feed_all(parser, [stream[:k], stream[k:]]) == frames, k
        assert parser.stats == reference.stats
        check_invariant(parser)
    parser = FrameParser()
    assert feed_all(parser, [stream[i : i + 1] for i in range(len(stream))]) == frames
    assert parser.stats == reference.stats


def test_split_at_every_pair_of_boundaries_of_one_frame():
    f = make_frame(9, 100)
    stream = encode_frame(f) + encode_text(f._replace(n_pack=101))
    for i in range(len(stream) + 1):
        for j in range(i, len(stream) + 1):
            assert feed_all(FrameParser(), [stream[:i], stream[i:j], stream[j:]]) == [
                f,
                f._replace(n_pack=101),
            ]


def test_fuzzed_garbage_between_frames():
    rng = random.Random(20080604)
    frames = [make_frame(m, n) for n in range(150) for m in (1, 2, 3)]
    parts: list[bytes] = []
    for i, f in enumerate(frames):
        junk = bytearray(rng.randrange(256) for _ in range(rng.randrange(0, 40)))
        if rng.random() < 0.3:  # sync bytes and half frames inside the garbage
            junk[rng.randrange(len(junk) + 1) : 0] = SYNC + bytes(rng.randrange(256) for _ in range(10))
        if rng.random() < 0.2:
            junk += encode_frame(make_frame(7, i))[: rng.randrange(1, FRAME_LEN)]  # truncated frame
        junk = junk.replace(b"\n", b"#")  # keep junk from closing a text candidate (ambiguous by design)
        parts.append(bytes(junk))
        parts.append(encode_text(f) if i % 4 == 0 else encode_frame(f))
    stream = b"".join(parts)
    parser = FrameParser()
    chunks, pos = [], 0
    while pos < len(stream):
        step = rng.randrange(1, 64)
        chunks.append(stream[pos : pos + step])
        pos += step
    got = [f for f in feed_all(parser, chunks) if f.mote != 7]
    assert got == frames
    st = parser.stats
    for m in (1, 2, 3):
        assert st.motes[m].received == 150 and st.motes[m].lost == 0
    check_invariant(parser)
    assert st.garbage_bytes > 1000


def test_sync_inside_payload_after_lost_sync():
    """Starting mid-frame, a sync pair inside a payload must not hide the next real frame."""
    sneaky = Frame(1, 0xA55A, (0xA55, 0xA5A, 0x5A5, 0xA5A, 0x5A5, 0xA5A, 0x5A5, 0xA5A, 0x5A5))
    nxt = make_frame(1, 0xA55B)
    wire = encode_frame(sneaky)
    for cut in range(1, FRAME_LEN):
        parser = FrameParser()
        assert parser.feed(wire[cut:] + encode_frame(nxt)) == [nxt], cut
        check_invariant(parser)


def test_truncated_frame_then_good_frames():
    a, b, c = make_frame(1, 0), make_frame(1, 1), make_frame(1, 2)
    for cut in range(1, FRAME_LEN):
        parser = FrameParser()
        got = parser.feed(encode_frame(a) + encode_frame(b)[:cut] + encode_frame(c))
        assert got == [a, c._replace(lost=1)], cut  # c says that one packet before it was lost
        assert parser.stats.lost == 1
        check_invariant(parser)


# -- corruption and loss accounting ----------------------------------------------------------------


@pytest.mark.parametrize("byte", range(2, FRAME_LEN))
def test_any_damaged_byte_drops_exactly_that_frame(byte):
    frames = [clean_frame(4, n) for n in range(3)]
    wire = bytearray(b"".join(encode_frame(f) for f in frames))
    wire[FRAME_LEN + byte] ^= 0x10
    parser = FrameParser()
    assert parser.feed(bytes(wire)) == [frames[0], frames[2]._replace(lost=1)]
    st = parser.stats
    assert st.corrupt == 1 and st.garbage_bytes == FRAME_LEN
    assert st.motes[4].received == 2 and st.motes[4].lost == 1
    check_invariant(parser)


def test_bad_checksum_event_names_known_mote():
    a, b, c = clean_frame(5, 0), clean_frame(5, 1), clean_frame(5, 2)
    bad = bytearray(encode_frame(b))
    bad[-1] ^= 0xFF
    parser = FrameParser()
    assert parser.feed(encode_frame(a) + bytes(bad) + encode_frame(c)) == [a, c._replace(lost=1)]
    events = parser.pop_events()
    assert events == [
        NewMote(5, 0),
        CorruptFrame(5, "binary", "bad checksum"),
        Garbage(FRAME_LEN),
        LostPackets(5, expected=1, got=2, count=1),
    ]
    assert parser.stats.motes[5].corrupt == 1
    assert parser.pop_events() == []


def test_non_zero_padding_is_rejected_even_with_a_valid_crc():
    body = bytearray(encode_frame(make_frame(1, 0))[2:19])
    body[15] |= 0x80
    crc = crc16_ccitt_false(body)
    parser = FrameParser()
    assert parser.feed(SYNC + bytes(body) + crc.to_bytes(2, "big")) == []
    assert parser.stats.corrupt == 1


def test_counter_wrap_is_not_a_loss():
    parser = FrameParser()
    frames = [make_frame(1, n) for n in range(65530, 65542)]
    assert frames[6].n_pack == 0
    assert parser.feed(b"".join(encode_frame(f) for f in frames)) == frames
    assert parser.stats.motes[1].lost == 0 and parser.stats.motes[1].jumps == 0


def test_gap_across_wrap_is_counted():
    parser = FrameParser()
    parser.feed(encode_frame(make_frame(1, 65533)) + encode_frame(make_frame(1, 2)))
    assert parser.pop_events()[-1] == LostPackets(1, expected=65534, got=2, count=4)
    assert parser.stats.motes[1].lost == 4 and parser.stats.lost == 4


def test_backwards_and_huge_jumps_are_counter_jumps():
    parser = FrameParser(max_gap=1000)
    seq = [100, 101, 50, 51, 51, 2000, 2001]
    frames = parser.feed(b"".join(encode_frame(make_frame(1, n)) for n in seq))
    events = [e for e in parser.pop_events() if not isinstance(e, NewMote)]
    assert events == [CounterJump(1, 102, 50), CounterJump(1, 52, 51), CounterJump(1, 52, 2000)]
    assert [f.jump for f in frames] == [False, False, True, False, True, True, False]  # each says so too
    assert [f.lost for f in frames] == [0] * 7
    assert parser.stats.motes[1].jumps == 3 and parser.stats.motes[1].lost == 0


def test_a_gap_the_mote_could_not_have_sent_in_the_time_is_a_restart_not_loss():
    # read times in seconds; the motes sample at 100 Hz
    parser = FrameParser(rate=100.0)
    frames = parser.feed(encode_frame(make_frame(1, 40000)), now=10.0)
    frames += parser.feed(encode_frame(make_frame(1, 40001)), now=10.01)
    frames += parser.feed(encode_frame(make_frame(1, 0)), now=12.0)  # switched off and on: 25,535 in 2 s?
    frames += parser.feed(
        encode_frame(make_frame(1, 1)) + encode_frame(make_frame(1, 5)), now=12.02
    )  # 3 lost
    frames += parser.feed(encode_frame(make_frame(1, 2005)), now=32.0)  # out of range for 20 s: 1999 lost
    # each frame carries the verdict (a clock counts sample periods by it: the mote node's does)
    assert [(f.n_pack, f.lost, f.jump) for f in frames] == [
        (40000, 0, False),
        (40001, 0, False),
        (0, 0, True),
        (1, 0, False),
        (5, 3, False),
        (2005, 1999, False),
    ]
    events = [e for e in parser.pop_events() if not isinstance(e, NewMote)]
    assert events == [
        CounterJump(1, 40002, 0),
        LostPackets(1, expected=2, got=5, count=3),
        LostPackets(1, expected=6, got=2005, count=1999),
    ]
    assert parser.stats.motes[1].lost == 2002 and parser.stats.motes[1].jumps == 1


def test_without_read_times_the_gap_is_judged_by_max_gap_alone():
    parser = FrameParser(rate=100.0)
    parser.feed(encode_frame(make_frame(1, 40000)) + encode_frame(make_frame(1, 0)))
    assert parser.stats.motes[1].lost == 25535  # what the counter says, with nothing to weigh it


def test_interleaved_motes_have_separate_counters():
    rng = random.Random(5)
    counters = {1: 65000, 2: 0, 3: 40000, 200: 12}
    expected_lost = dict.fromkeys(counters, 0)
    stream, sent = bytearray(), []
    for _ in range(2000):
        m = rng.choice(list(counters))
        if rng.random() < 0.05:  # the radio loses one to three packets of this mote
            skip = rng.randrange(1, 4)
            counters[m] += skip
            expected_lost[m] += skip
        else:
            skip = 0
        f = make_frame(m, counters[m])._replace(lost=skip)  # as the parser marks it
        counters[m] += 1
        sent.append(f)
        stream += encode_frame(f) if rng.random() < 0.7 else encode_text(f)
    parser = FrameParser()
    got = feed_all(parser, [bytes(stream[i : i + 97]) for i in range(0, len(stream), 97)])
    assert got == sent
    for m in counters:
        assert parser.stats.motes[m].lost == expected_lost[m]
        assert parser.stats.motes[m].received == sum(f.mote == m for f in sent)
    lost_events = [e for e in parser.pop_events() if isinstance(e, LostPackets)]
    assert sum(e.count for e in lost_events) == sum(expected_lost.values())


def test_flush_and_reset():
    parser = FrameParser()
    parser.feed(encode_frame(make_frame(1, 0)) + encode_frame(make_frame(1, 1))[:9])
    assert parser.pending == 9
    parser.flush()
    assert parser.pending == 0 and parser.pop_events()[-1] == Garbage(9)
    check_invariant(parser)
    snapshot = parser.stats.copy()
    parser.reset()
    assert parser.stats.frames == 0 and snapshot.frames == 1 and snapshot.motes[1].last_n_pack == 0


def test_long_garbage_is_reported_in_parts_and_buffer_stays_small():
    parser = FrameParser()
    for _ in range(10):
        parser.feed(bytes(1000))
    assert parser.pending == 0
    assert sum(e.nbytes for e in parser.pop_events() if isinstance(e, Garbage)) >= 9000


# -- MoteSpec ------------------------------------------------------------------------------------


def test_mote_spec_defaults_and_round_trip():
    assert DEFAULT_SPEC == MoteSpec()
    assert DEFAULT_SPEC.null == (2048.0,) * 9
    assert DEFAULT_SPEC.resolution == (0.1,) * 3 + (0.0192,) * 3 + (0.001,) * 3
    lo, hi = DEFAULT_SPEC.full_scale[0]
    assert lo == pytest.approx(-204.8) and hi == pytest.approx(204.7)
    values = (12.34, -5.0, 0.0, 9.81, -3.2, 0.5, 0.2, -0.3, 0.41)
    back = DEFAULT_SPEC.to_units(DEFAULT_SPEC.to_counts(values))
    for v, b, r in zip(values, back, DEFAULT_SPEC.resolution, strict=True):
        assert abs(v - b) <= r / 2 + 1e-12
    with pytest.raises(ValueError):
        MoteSpec(null=(2048,) * 8)
    with pytest.raises(ValueError):
        MoteSpec(resolution=(0.0,) * 9)
