"""The WebSocket codec (:mod:`pointat.websocket`): the examples of RFC 6455, and properties of the frame
reader, which takes bytes from any client on the network.

Properties: a client's messages (text or binary, fragmented, pings and pongs between the fragments, any
masks) come back exactly and in order however the stream is cut into reads; any bytes at all raise
nothing but :class:`WebSocketError` and never give a payload over the limit, and how they are cut
changes nothing; each kind of frame a server must refuse is refused, after any valid messages, with an
error that names what was wrong; a 64-bit length of 2**63 is refused from its header alone.

The masked frames a client sends are written here (:func:`client_frame`), from RFC 6455 section 5.2, so
that the tests can also write the frames a client must not send.  The long fuzz run of the reader is
``python -m tests.fuzz_websocket --n 200000``.
"""

from __future__ import annotations

import base64
import hashlib
import struct
import time
import tracemalloc

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pointat.websocket import (
    BINARY,
    CLOSE,
    PING,
    PONG,
    TEXT,
    FrameReader,
    WebSocketError,
    accept_key,
    encode_frame,
)

CONTINUATION = 0x0
CONTROL = (CLOSE, PING, PONG)
LIMIT = FrameReader().limit

SETTINGS = settings(
    max_examples=100,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


# --------------------------------------------------------------------------- a client's frames
def client_frame(
    opcode: int,
    payload: bytes,
    *,
    fin: bool = True,
    mask: bytes = b"\x00\x00\x00\x00",
    rsv: int = 0,
    masked: bool = True,
    length: int | None = None,
    form: int | None = None,
) -> bytes:
    """One frame as a client writes it (RFC 6455 section 5.2): masked, the length in its shortest form.
    ``length`` writes another length than the payload's, ``form`` (7, 16 or 64) another form of it."""
    n = len(payload) if length is None else length
    b0 = (0x80 if fin else 0) | rsv << 4 | opcode
    m = 0x80 if masked else 0
    if form is None:
        form = 7 if n < 126 else 16 if n < 1 << 16 else 64
    if form == 7:
        head = bytes([b0, m | n])
    elif form == 16:
        head = bytes([b0, m | 126]) + struct.pack("!H", n)
    else:
        head = bytes([b0, m | 127]) + struct.pack("!Q", n)
    if not masked:
        return head + payload
    return head + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(payload))


def feed_in_chunks(reader: FrameReader, data: bytes, cuts: list[int]) -> list[tuple[int, bytes]]:
    """Feed ``data`` cut at ``cuts`` (sorted, repeats give empty reads) and gather what comes out."""
    out: list[tuple[int, bytes]] = []
    pos = 0
    for c in cuts:
        out += reader.feed(data[pos:c])
        pos = c
    out += reader.feed(data[pos:])
    return out


def feed_until_error(
    reader: FrameReader, data: bytes, cuts: list[int]
) -> tuple[list[tuple[int, bytes]], WebSocketError | None]:
    """What comes out of ``data`` cut at ``cuts`` before the first :class:`WebSocketError` (where the
    connection would be closed), and that error or None.  Any other exception goes through."""
    out: list[tuple[int, bytes]] = []
    pos = 0
    for c in [*cuts, len(data)]:
        try:
            out += reader.feed(data[pos:c])
        except WebSocketError as exc:
            return out, exc
        pos = c
    return out, None


masks = st.binary(min_size=4, max_size=4)
texts = st.text(st.characters(codec="utf-8"), max_size=100).map(lambda s: s.encode("utf-8"))
binaries = st.one_of(st.binary(max_size=40), st.binary(min_size=120, max_size=300))
control_payloads = st.one_of(st.binary(max_size=8), st.binary(min_size=120, max_size=125))


@st.composite
def cuts_of(draw, n: int) -> list[int]:
    """Where to cut a stream of ``n`` bytes into reads: anywhere, or into reads of one byte."""
    if draw(st.integers(0, 4)) == 0:
        return list(range(1, n))
    return sorted(draw(st.lists(st.integers(0, n), max_size=30)))


@st.composite
def conversation(draw) -> tuple[bytes, list[tuple[int, bytes]]]:
    """A client's stream of whole messages, each maybe in fragments with pings and pongs between them,
    and the (opcode, payload) list the reader must give for it."""
    frames: list[bytes] = []
    want: list[tuple[int, bytes]] = []

    def controls() -> None:
        for _ in range(draw(st.integers(0, 2))):
            opcode, payload = draw(st.sampled_from([PING, PONG])), draw(control_payloads)
            frames.append(client_frame(opcode, payload, mask=draw(masks)))
            want.append((opcode, payload))

    for _ in range(draw(st.integers(0, 5))):
        controls()
        kind = draw(st.sampled_from([TEXT, BINARY]))
        payload = draw(texts if kind == TEXT else binaries)
        # fragments cut anywhere (through a UTF-8 character too), empty ones included
        cuts = sorted(draw(st.lists(st.integers(0, len(payload)), max_size=4)))
        pieces = [payload[a:b] for a, b in zip([0, *cuts], [*cuts, len(payload)], strict=True)]
        for i, piece in enumerate(pieces):
            if i:
                controls()
            opcode = kind if i == 0 else CONTINUATION
            frames.append(client_frame(opcode, piece, fin=i == len(pieces) - 1, mask=draw(masks)))
        want.append((kind, payload))
    controls()
    return b"".join(frames), want


# =========================================================================== RFC 6455 examples
def test_accept_key_of_rfc_6455_section_1_3():
    assert accept_key("dGhlIHNhbXBsZSBub25jZQ==") == "s3pPLMBiTxaQ9kYGzzhZRbK+xOo="
    assert accept_key(" dGhlIHNhbXBsZSBub25jZQ==\r\n") == "s3pPLMBiTxaQ9kYGzzhZRbK+xOo="  # header blanks


@SETTINGS
@given(raw=st.binary(min_size=16, max_size=16))
def test_accept_key_is_base64_of_the_sha1_of_the_key_and_the_guid(raw):
    key = base64.b64encode(raw).decode()
    guid = b"258EAFA5-E914-47DA-95CA-C5AB0DC85B11"
    assert accept_key(key) == base64.b64encode(hashlib.sha1(key.encode() + guid).digest()).decode()


@pytest.mark.parametrize(
    "key, word",
    [("not base64!", "base64"), ("AAAA", "16 bytes"), ("", "16 bytes"), ("dGhlIHNhbXBsZSBub25jZQ", "base64")],
)
def test_accept_key_refuses_a_key_that_is_not_16_bytes_in_base64(key, word):
    with pytest.raises(WebSocketError, match=word):
        accept_key(key)


def test_the_frames_of_rfc_6455_section_5_7():
    hello_masked = bytes([0x37, 0xFA, 0x21, 0x3D, 0x7F, 0x9F, 0x4D, 0x51, 0x58])
    # a single-frame unmasked text message (what a server sends)
    assert encode_frame(TEXT, b"Hello") == bytes([0x81, 0x05, 0x48, 0x65, 0x6C, 0x6C, 0x6F])
    # a single-frame masked text message (what a client sends)
    assert FrameReader().feed(bytes([0x81, 0x85]) + hello_masked) == [(TEXT, b"Hello")]
    # a fragmented unmasked text message: "Hel" then "lo"; masked as a client must, it reads back whole
    fragmented = client_frame(TEXT, b"Hel", fin=False, mask=b"\x01\x02\x03\x04") + client_frame(
        CONTINUATION, b"lo", mask=b"\x05\x06\x07\x08"
    )
    assert FrameReader().feed(fragmented) == [(TEXT, b"Hello")]
    with pytest.raises(WebSocketError, match="masked"):  # and as the RFC writes it, unmasked: refused
        FrameReader().feed(bytes([0x01, 0x03, 0x48, 0x65, 0x6C, 0x80, 0x02, 0x6C, 0x6F]))
    # unmasked ping; masked pong
    assert encode_frame(PING, b"Hello") == bytes([0x89, 0x05, 0x48, 0x65, 0x6C, 0x6C, 0x6F])
    assert FrameReader().feed(bytes([0x8A, 0x85]) + hello_masked) == [(PONG, b"Hello")]
    # 256 bytes of binary in one unmasked frame; 64 KiB
    assert encode_frame(BINARY, bytes(256))[:4] == bytes([0x82, 0x7E, 0x01, 0x00])
    assert encode_frame(BINARY, bytes(65536))[:10] == bytes([0x82, 0x7F, 0, 0, 0, 0, 0, 1, 0, 0])


def decode_server_header(frame: bytes) -> tuple[bool, int, int, int]:
    """(fin, opcode, payload length, header length) of a server's frame, read by hand from section 5.2."""
    b0, b1 = frame[0], frame[1]
    assert b0 & 0x70 == 0, "reserved bits"
    assert b1 & 0x80 == 0, "a server's frame is never masked"
    n = b1 & 0x7F
    if n < 126:
        return bool(b0 & 0x80), b0 & 0x0F, n, 2
    if n == 126:
        return bool(b0 & 0x80), b0 & 0x0F, (frame[2] << 8) | frame[3], 4
    assert frame[2] & 0x80 == 0, "the most significant bit of a 64-bit length must be 0"
    return bool(b0 & 0x80), b0 & 0x0F, int.from_bytes(frame[2:10], "big"), 10


@pytest.mark.parametrize(
    "n, header_len",
    [(0, 2), (1, 2), (125, 2), (126, 4), (127, 4), (65535, 4), (65536, 10), (65537, 10), (200_000, 10)],
)
@pytest.mark.parametrize("opcode", [TEXT, BINARY])
def test_encode_frame_uses_the_7_16_or_64_bit_length_at_the_boundaries(n, header_len, opcode):
    payload = bytes(i % 251 for i in range(n))
    frame = encode_frame(opcode, payload)
    fin, op, length, head = decode_server_header(frame)
    assert (fin, op, length, head) == (True, opcode, n, header_len)
    assert frame[head:] == payload
    # the shortest form (section 5.2: "the minimal number of bytes MUST be used")
    assert (head == 2) == (n <= 125) and (head == 4) == (126 <= n <= 65535)


@SETTINGS
@given(opcode=st.sampled_from([TEXT, BINARY, CLOSE, PING, PONG]), n=st.integers(0, 70_000))
def test_encode_frame_writes_any_length_that_a_header_read_by_hand_gives_back(opcode, n):
    frame = encode_frame(opcode, b"\xab" * n)
    fin, op, length, head = decode_server_header(frame)
    assert (fin, op, length, len(frame)) == (True, opcode, n, head + n)


@pytest.mark.parametrize("n", [0, 125, 126, 65535, 65536])
def test_the_reader_takes_every_length_form_up_to_the_limit(n):
    payload = bytes(i % 256 for i in range(n))
    frame = client_frame(BINARY, payload, mask=b"\x9a\x00\xff\x17")
    assert frame[1] & 0x7F == (n if n < 126 else 126 if n < 65536 else 127)
    assert FrameReader().feed(frame) == [(BINARY, payload)]


# =========================================================================== property 1: messages
@SETTINGS
@given(st.data())
def test_a_clients_messages_come_back_exactly_in_order_however_the_stream_is_cut(data):
    stream, want = data.draw(conversation())
    cuts = data.draw(cuts_of(len(stream)))
    reader = FrameReader()
    assert feed_in_chunks(reader, stream, cuts) == want
    assert reader.feed(b"") == []  # nothing held back


@SETTINGS
@given(st.data())
def test_the_stream_read_byte_by_byte_gives_the_same_as_read_whole(data):
    stream, want = data.draw(conversation())
    assert FrameReader().feed(stream) == want
    assert feed_in_chunks(FrameReader(), stream, list(range(1, len(stream)))) == want


# =========================================================================== property 2: any bytes
LIMITS = st.sampled_from([0, 1, 3, 125, 126, 200, LIMIT])


@st.composite
def frame_soup(draw) -> bytes:
    """Bytes that look like frames: headers with any bits and lengths, right or wrong, and junk."""
    parts = []
    for _ in range(draw(st.integers(0, 6))):
        if draw(st.integers(0, 3)) == 0:
            parts.append(draw(st.binary(max_size=20)))
            continue
        payload = draw(st.binary(max_size=140))
        length = draw(
            st.one_of(
                st.none(),
                st.sampled_from([0, 1, 125, 126, 127, 65535, 65536, 65537, 2**63, 2**64 - 1]),
                st.integers(0, 300),
            )
        )
        form = draw(st.sampled_from([None, None, 7, 16, 64]))
        if form == 7 and (length if length is not None else len(payload)) > 127:
            form = None
        if form == 16 and (length if length is not None else len(payload)) >= 1 << 16:
            form = None
        if length is not None and length >= 1 << 16 and form is None:
            form = 64
        parts.append(
            client_frame(
                draw(st.integers(0, 15)),
                payload,
                fin=draw(st.booleans()),
                mask=draw(masks),
                rsv=draw(st.sampled_from([0, 0, 0, 1, 2, 4, 7])),
                masked=draw(st.integers(0, 5)) > 0,
                length=length,
                form=form,
            )
        )
    return b"".join(parts)


def check_outputs(reader: FrameReader, out: list[tuple[int, bytes]]) -> None:
    for opcode, payload in out:
        assert opcode in (TEXT, BINARY, *CONTROL)
        assert type(payload) is bytes
        assert len(payload) <= reader.limit
        if opcode in CONTROL:
            assert len(payload) <= 125
        if opcode == TEXT:
            payload.decode("utf-8")


@SETTINGS
@given(data=st.data(), stream=st.one_of(st.binary(max_size=300), frame_soup()), limit=LIMITS)
def test_any_bytes_raise_nothing_but_websocket_error_nor_give_a_payload_over_the_limit(data, stream, limit):
    reader = FrameReader(limit)
    out, error = feed_until_error(reader, stream, data.draw(cuts_of(len(stream))))
    check_outputs(reader, out)
    if error is not None:
        assert str(error)  # it says why


@SETTINGS
@given(data=st.data(), stream=st.one_of(st.binary(max_size=300), frame_soup()), limit=LIMITS)
def test_how_any_bytes_are_cut_into_reads_changes_nothing(data, stream, limit):
    by_byte, error_by_byte = feed_until_error(FrameReader(limit), stream, list(range(1, len(stream))))
    cut, error_cut = feed_until_error(FrameReader(limit), stream, data.draw(cuts_of(len(stream))))
    # the same error (or none); what came out before it is the same, but for the messages that shared
    # the error's read (feed raises: they are not returned, the connection closes anyway)
    assert str(error_cut) == str(error_by_byte)
    assert cut == by_byte[: len(cut)]
    if error_cut is None:
        assert cut == by_byte


# =========================================================================== property 3: refusals
@st.composite
def bad_stream(draw) -> tuple[bytes, str, int]:
    """A frame (or frames) a server must refuse: (its bytes, a word of the error, the reader's limit)."""
    mask = draw(masks)
    kind = draw(
        st.sampled_from(
            [
                "unmasked",
                "reserved",
                "opcode",
                "fragmented control",
                "long control",
                "lone continuation",
                "new message",
                "utf-8",
                "long frame",
                "long fragments",
            ]
        )
    )
    any_opcode = st.sampled_from([CONTINUATION, TEXT, BINARY, *CONTROL])
    if kind == "unmasked":
        op = draw(any_opcode)
        return client_frame(op, draw(st.binary(max_size=20)), masked=False), "masked", LIMIT
    if kind == "reserved":
        op, rsv = draw(any_opcode), draw(st.integers(1, 7))
        return client_frame(op, draw(st.binary(max_size=20)), mask=mask, rsv=rsv), "reserved", LIMIT
    if kind == "opcode":
        op = draw(st.sampled_from([3, 4, 5, 6, 7, 0xB, 0xC, 0xD, 0xE, 0xF]))
        return client_frame(op, draw(st.binary(max_size=20)), mask=mask), "opcode", LIMIT
    if kind == "fragmented control":
        op, payload = draw(st.sampled_from(CONTROL)), draw(st.binary(max_size=125))
        return client_frame(op, payload, fin=False, mask=mask), "control", LIMIT
    if kind == "long control":
        op, payload = draw(st.sampled_from(CONTROL)), draw(st.binary(min_size=126, max_size=400))
        return client_frame(op, payload, mask=mask), "125", LIMIT
    if kind == "lone continuation":
        payload = draw(st.binary(max_size=20))
        return client_frame(CONTINUATION, payload, fin=draw(st.booleans()), mask=mask), "continuation", LIMIT
    if kind == "new message":
        first = client_frame(draw(st.sampled_from([TEXT, BINARY])), b"ab", fin=False, mask=mask)
        between = b"".join(
            client_frame(CONTINUATION, b"c", fin=False, mask=mask) for _ in range(draw(st.integers(0, 2)))
        ) + b"".join(client_frame(PING, b"p", mask=mask) for _ in range(draw(st.integers(0, 2))))
        second = client_frame(draw(st.sampled_from([TEXT, BINARY])), b"d", fin=draw(st.booleans()), mask=mask)
        return first + between + second, "new message", LIMIT
    if kind == "utf-8":
        bad = draw(
            st.one_of(
                st.sampled_from(
                    [
                        b"\xff",  # never in UTF-8
                        b"\x80",  # a continuation byte alone
                        b"\xc0\xaf",  # an overlong '/'
                        b"\xe0\x80\xaf",  # overlong again
                        b"\xed\xa0\x80",  # a surrogate (U+D800)
                        b"\xf4\x90\x80\x80",  # above U+10FFFF
                        b"\xe2\x82",  # the euro sign cut short at the end of the message
                        b"\xf0\x9f\x98",  # an emoji cut short
                    ]
                ),
                st.binary(min_size=1, max_size=30).filter(lambda b: not _is_utf8(b)),
            )
        )
        before, after = draw(texts), draw(texts) if not bad.endswith((b"\xe2\x82", b"\xf0\x9f\x98")) else b""
        payload = before + bad + after
        cuts = sorted(draw(st.lists(st.integers(0, len(payload)), max_size=3)))
        pieces = [payload[a:b] for a, b in zip([0, *cuts], [*cuts, len(payload)], strict=True)]
        frames = b"".join(
            client_frame(TEXT if i == 0 else CONTINUATION, p, fin=i == len(pieces) - 1, mask=mask)
            for i, p in enumerate(pieces)
        )
        return frames, "UTF-8", LIMIT
    limit = draw(st.integers(400, 1500))  # above any message of the valid prefix
    if kind == "long frame":
        payload = draw(st.binary(min_size=limit + 1, max_size=limit + 50))
        op = draw(st.sampled_from([TEXT, BINARY]))
        return client_frame(op, payload, fin=draw(st.booleans()), mask=mask), "longer", limit
    # "long fragments": each fragment within the limit, their sum over it
    sizes = draw(st.lists(st.integers(0, limit), min_size=2, max_size=5).filter(lambda s: sum(s) > limit))
    op = draw(st.sampled_from([TEXT, BINARY]))
    frames = b"".join(
        client_frame(op if i == 0 else CONTINUATION, b"a" * n, fin=i == len(sizes) - 1, mask=mask)
        for i, n in enumerate(sizes)
    )
    return frames, "longer", limit


def _is_utf8(b: bytes) -> bool:
    try:
        b.decode("utf-8")
    except UnicodeDecodeError:
        return False
    return True


@SETTINGS
@given(data=st.data(), prefix=conversation(), bad=bad_stream())
def test_each_frame_a_server_must_refuse_is_refused_saying_what_was_wrong(data, prefix, bad):
    (good, want), (wrong, word, limit) = prefix, bad
    stream = good + wrong
    out, error = feed_until_error(FrameReader(limit), stream, data.draw(cuts_of(len(stream))))
    assert error is not None, f"not refused: {wrong.hex()}"
    assert word.lower() in str(error).lower()
    # the messages before it came out, unchanged (the bad part may let a ping through before its error)
    assert out[: len(want)] == want[: len(out)]


@pytest.mark.parametrize(
    "frames, word, limit",
    [
        (bytes([0x81, 0x02]) + b"hi", "masked", LIMIT),
        (client_frame(TEXT, b"hi", rsv=4), "reserved", LIMIT),  # RSV1: no permessage-deflate here
        (client_frame(TEXT, b"hi", rsv=1), "reserved", LIMIT),
        (client_frame(3, b""), "opcode 3", LIMIT),
        (client_frame(0xB, b""), "opcode 11", LIMIT),
        (client_frame(PING, b"x", fin=False), "final", LIMIT),
        (client_frame(CLOSE, b"\x03\xe8", fin=False), "final", LIMIT),
        (client_frame(PING, bytes(126)), "125", LIMIT),
        (client_frame(PONG, bytes(125), form=16), None, LIMIT),  # 125 bytes, the 16-bit form: taken
        (client_frame(CONTINUATION, b"x"), "continuation", LIMIT),
        (client_frame(TEXT, b"a", fin=False) + client_frame(BINARY, b"b"), "new message", LIMIT),
        (client_frame(TEXT, b"\xed\xa0\x80"), "UTF-8", LIMIT),
        (client_frame(TEXT, b"\xe2\x82", fin=False) + client_frame(CONTINUATION, b"\xac"), None, LIMIT),
        (client_frame(TEXT, b"\xe2\x82", fin=False) + client_frame(CONTINUATION, b"x"), "UTF-8", LIMIT),
        (client_frame(BINARY, bytes(11)), "longer than 10", 10),
        (client_frame(BINARY, bytes(10)), None, 10),
        (client_frame(BINARY, b"x"), "longer than 0", 0),
        (client_frame(BINARY, b""), None, 0),
        (
            client_frame(BINARY, bytes(6), fin=False) + client_frame(CONTINUATION, bytes(5)),
            "longer than 10",
            10,
        ),
        (client_frame(BINARY, bytes(6), fin=False) + client_frame(CONTINUATION, bytes(4)), None, 10),
        (client_frame(BINARY, bytes(LIMIT + 1)), f"longer than {LIMIT}", LIMIT),
    ],
)
def test_refusals_by_example(frames, word, limit):
    reader = FrameReader(limit)
    if word is None:
        assert len(reader.feed(frames)) == 1
        return
    with pytest.raises(WebSocketError, match=word):
        reader.feed(frames)


def test_a_frame_over_the_limit_is_refused_from_its_header_without_its_payload():
    for head in (
        client_frame(BINARY, b"", length=11)[:2],  # the 7-bit length 11 (and no mask yet)
        bytes([0x82, 0x80 | 126]) + struct.pack("!H", 65535),
    ):
        with pytest.raises(WebSocketError, match="longer than 10"):
            FrameReader(10).feed(head)


# =========================================================================== property 4: 2**63
@pytest.mark.parametrize("opcode", [TEXT, BINARY, CONTINUATION, PING])
@pytest.mark.parametrize("length", [2**63, 2**64 - 1, LIMIT + 1])
def test_a_64_bit_length_over_the_limit_is_refused_at_once_without_waiting_nor_allocating(opcode, length):
    head = client_frame(opcode, b"", length=length, form=64)[:10]  # no mask, no payload: only the header
    reader = FrameReader()
    for i in range(9):  # the header cut short: the reader waits for the rest of it
        assert reader.feed(head[i : i + 1]) == []
    tracemalloc.start()
    try:
        t0 = time.process_time()  # (CPU time: a loaded machine shares the cores, not the work)
        with pytest.raises(WebSocketError, match="longer"):
            reader.feed(head[9:])
        elapsed = time.process_time() - t0
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 100_000 and elapsed < 0.5


@SETTINGS
@given(data=st.data(), prefix=conversation(), length=st.integers(2**63, 2**64 - 1))
def test_a_length_of_2_63_or_more_is_refused_after_any_messages_however_cut(data, prefix, length):
    good, want = prefix
    stream = good + client_frame(BINARY, b"", length=length, form=64)[:10]
    out, error = feed_until_error(FrameReader(), stream, data.draw(cuts_of(len(stream))))
    assert error is not None and "longer" in str(error)
    assert out == want[: len(out)]


# =========================================================================== fragments
@pytest.mark.parametrize("payload", [b"", b"a"], ids=["empty", "one byte"])
def test_a_flood_of_small_fragments_is_refused_and_never_piles_up(payload):
    """A client sending empty (or tiny) continuation frames forever never reaches the length limit: the
    reader refuses a message in more than FRAGMENTS fragments, keeping no more than that many."""
    reader = FrameReader()
    n = FrameReader.FRAGMENTS
    ok = [client_frame(BINARY, payload, fin=False)] + [client_frame(CONTINUATION, payload, fin=False)] * (
        n - 2
    )
    ok.append(client_frame(CONTINUATION, payload, fin=True))
    assert reader.feed(b"".join(ok)) == [(BINARY, payload * n)]  # FRAGMENTS of them: a message
    flood = [client_frame(BINARY, payload, fin=False)] + [client_frame(CONTINUATION, payload, fin=False)] * n
    with pytest.raises(WebSocketError, match="fragments"):
        for frame in flood:  # fed one by one, as they come: refused at the first one too many
            reader.feed(frame)
            assert len(reader._parts) <= n
