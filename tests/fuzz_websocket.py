r"""A mutation fuzzer for the WebSocket frame reader: every mutant stream gives messages or is refused
with a :class:`~pointat.websocket.WebSocketError`, never another exception.

::

    python -m tests.fuzz_websocket                      # 20,000 mutants, seed 0
    python -m tests.fuzz_websocket --n 200000 --seed 7  # 200,000 mutants, reproducible
    python -m tests.fuzz_websocket --seed 7 --case 1234 # one mutant again, shown in full

A case is a valid client stream (text and binary messages, some in fragments with pings, pongs and
closes between them, masked with random keys, now and then a payload at a length boundary: 125, 126,
65535, 65536 bytes) with zero to four mutations: frames dropped, doubled, swapped or repeated hundreds of
times, header bits changed (FIN, the reserved bits, the opcode, the mask bit), length fields rewritten
(to 0, 125, 126, 127, 65535, 65536, 2**63, 2**64-1, one off, or in another form than the shortest), bit
flips, bytes set to 0x00, 0x7E, 0x7F, 0x80, 0xFF..., the stream cut short or a range of it cut out,
another stream spliced in, random bytes put in or over.  Its reader has the default limit (64 KiB) or,
one case in four, a small one.  The stream is fed cut into reads at random points (one case in ten: a
byte at a time; one in ten: whole).

The outcome of a case is one of: ``messages`` (every byte read, no error), ``refused`` (a
:class:`WebSocketError`, which closes the connection), ``crash`` (any other exception), or ``wrong``: a
payload over the limit, a control payload over 125 bytes, an unknown opcode, text that is not UTF-8, an
unmutated stream that does not give back its messages exactly, or a stream that gives another outcome
read whole than cut into reads.  Crashes and wrongs are grouped into classes (the exception and where it
was raised, or what was wrong); each class's smallest case is printed with its bytes in hex.  The exit
status is 1 when there was any crash or wrong.
"""

from __future__ import annotations

import argparse
import random
import re
import sys
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

from pointat.websocket import BINARY, CLOSE, PING, PONG, TEXT, FrameReader, WebSocketError

ROOT = Path(__file__).resolve().parents[1]

CONTINUATION = 0x0
CONTROL = (CLOSE, PING, PONG)
LIMIT = FrameReader().limit
SMALL_LIMITS = (0, 1, 2, 125, 126, 127, 1000, 65535)
#: Lengths a length field is rewritten to.
LENGTHS = (0, 1, 125, 126, 127, 65535, 65536, 65537, 2**31, 2**32, 2**63 - 1, 2**63, 2**64 - 1)
#: Bytes a byte is set to.
BYTES = (0x00, 0x01, 0x0F, 0x70, 0x7D, 0x7E, 0x7F, 0x80, 0x81, 0x88, 0x89, 0x8A, 0xFE, 0xFF)
#: Text that UTF-8 decoders get wrong: multibyte characters, to be cut between fragments.
TEXTS = ("", "hi", "é", "€uro", "😀", "a\u0000b", "\ufeff", "\U0010ffff", "日本語のテキスト", "\u2028\u202e")
OUTCOMES = ("messages", "refused", "crash", "wrong")


# =========================================================================== a client's frames
@dataclass
class Frame:
    """One frame as a client writes it; ``length`` and ``form`` (7, 16, 64) rewrite its length field."""

    opcode: int
    payload: bytes
    fin: bool = True
    mask: bytes = b"\x00\x00\x00\x00"
    rsv: int = 0
    masked: bool = True
    length: int | None = None
    form: int | None = None

    def encode(self) -> bytes:
        n = len(self.payload) if self.length is None else self.length
        form = self.form or (7 if n < 126 else 16 if n < 1 << 16 else 64)
        n &= (1 << 7) - 1 if form == 7 else (1 << 16) - 1 if form == 16 else (1 << 64) - 1
        b0 = (0x80 if self.fin else 0) | (self.rsv & 7) << 4 | self.opcode & 0x0F
        m = 0x80 if self.masked else 0
        if form == 7:
            head = bytes([b0, m | n])  # (a forced 126 or 127 here announces a longer form)
        elif form == 16:
            head = bytes([b0, m | 126]) + n.to_bytes(2, "big")
        else:
            head = bytes([b0, m | 127]) + n.to_bytes(8, "big")
        if not self.masked:
            return head + self.payload
        return head + self.mask + mask(self.payload, self.mask)


def mask(payload: bytes, key: bytes) -> bytes:
    n = len(payload)
    if not n:
        return b""
    keys = (key * (n // 4 + 1))[:n]
    return (int.from_bytes(payload, "big") ^ int.from_bytes(keys, "big")).to_bytes(n, "big")


def payload_of(rng: random.Random, kind: int) -> bytes:
    """A message's payload: mostly short, now and then at a length boundary."""
    roll = rng.random()
    if roll < 0.003:
        n = rng.choice((65535, 65536))
    elif roll < 0.05:
        n = rng.choice((124, 125, 126, 127, 128, 1000))
    else:
        n = rng.choice((0, 1, 2, 3, 4, 5, rng.randrange(60)))
    if kind == TEXT:
        text = "".join(rng.choice(TEXTS) for _ in range(n // 3 + 1)).encode()
        text = text[:n].decode("utf-8", "ignore").encode()  # at most n bytes, whole characters
        return text
    return rng.randbytes(n)


def valid_stream(rng: random.Random) -> tuple[list[Frame], list[tuple[int, bytes]]]:
    """A client's frames, and the messages (opcode, payload) the reader must give for them."""
    frames: list[Frame] = []
    want: list[tuple[int, bytes]] = []

    def controls() -> None:
        while rng.random() < 0.25:
            opcode = rng.choice((PING, PONG, PING, PONG, CLOSE))
            payload = rng.randbytes(rng.choice((0, 1, 2, 5, 125, rng.randrange(126))))
            frames.append(Frame(opcode, payload, mask=rng.randbytes(4)))
            want.append((opcode, payload))

    for _ in range(rng.randrange(6)):
        controls()
        kind = rng.choice((TEXT, BINARY))
        payload = payload_of(rng, kind)
        cuts = sorted(rng.randrange(len(payload) + 1) for _ in range(rng.choice((0, 0, 1, 2, 4))))
        pieces = [payload[a:b] for a, b in zip([0, *cuts], [*cuts, len(payload)], strict=True)]
        for i, piece in enumerate(pieces):
            if i:
                controls()
            last = i == len(pieces) - 1
            frames.append(Frame(kind if i == 0 else CONTINUATION, piece, fin=last, mask=rng.randbytes(4)))
        want.append((kind, payload))
    controls()
    return frames, want


# =========================================================================== mutations
# on frames (before they are written out)
def m_drop(rng: random.Random, frames: list[Frame]) -> None:
    if frames:
        del frames[rng.randrange(len(frames))]


def m_double(rng: random.Random, frames: list[Frame]) -> None:
    if frames:
        i = rng.randrange(len(frames))
        frames.insert(i, replace(frames[i]))


def m_swap(rng: random.Random, frames: list[Frame]) -> None:
    if len(frames) > 1:
        i, j = rng.randrange(len(frames)), rng.randrange(len(frames))
        frames[i], frames[j] = frames[j], frames[i]


def m_repeat(rng: random.Random, frames: list[Frame]) -> None:
    """A frame many times over, or a run of empty continuations inside a message."""
    if frames and rng.random() < 0.5:
        i = rng.randrange(len(frames))
        times = rng.randrange(2, 300) if len(frames[i].payload) < 1000 else rng.randrange(2, 4)
        frames[i:i] = [replace(frames[i]) for _ in range(times)]
    else:
        i = rng.randrange(len(frames) + 1)
        first = Frame(BINARY, b"", fin=False)
        frames[i:i] = [first] + [Frame(CONTINUATION, b"", fin=False) for _ in range(rng.randrange(1, 500))]


def m_header(rng: random.Random, frames: list[Frame]) -> None:
    if not frames:
        return
    f = frames[rng.randrange(len(frames))]
    what = rng.randrange(4)
    if what == 0:
        f.fin = not f.fin
    elif what == 1:
        f.rsv = rng.randrange(8)
    elif what == 2:
        f.opcode = rng.randrange(16)
    else:
        f.masked = not f.masked


def m_length(rng: random.Random, frames: list[Frame]) -> None:
    if not frames:
        return
    f = frames[rng.randrange(len(frames))]
    n = len(f.payload)
    f.length = rng.choice((rng.choice(LENGTHS), n + 1, max(n - 1, 0), rng.randrange(200), n))
    f.form = rng.choice((None, None, 7, 16, 64))


def m_big(rng: random.Random, frames: list[Frame]) -> None:
    """A data frame with a payload over (or at) the limit, or control frames over 125 bytes."""
    i = rng.randrange(len(frames) + 1)
    n = rng.choice((126, 127, 1001, 65535, 65536, 65537))
    opcode = rng.choice((TEXT, BINARY, CONTINUATION, PING, PONG, CLOSE))
    frames.insert(i, Frame(opcode, b"a" * n, fin=rng.random() < 0.7, mask=rng.randbytes(4)))


FRAME_MUTATIONS: dict[str, Callable[[random.Random, list[Frame]], None]] = {
    "drop": m_drop,
    "double": m_double,
    "swap": m_swap,
    "repeat": m_repeat,
    "header": m_header,
    "length": m_length,
    "big": m_big,
}


# on bytes (after)
def m_flip(rng: random.Random, data: bytearray) -> None:
    for _ in range(rng.randrange(1, 9)):
        if data:
            data[rng.randrange(len(data))] ^= 1 << rng.randrange(8)


def m_byte(rng: random.Random, data: bytearray) -> None:
    if data:
        # a header byte more often than not: the first two of the stream, or any
        i = rng.choice((0, 1, rng.randrange(len(data)))) % len(data)
        data[i] = rng.choice(BYTES)


def m_truncate(rng: random.Random, data: bytearray) -> None:
    del data[rng.randrange(len(data) + 1) :]


def m_chop(rng: random.Random, data: bytearray) -> None:
    if data:
        i = rng.randrange(len(data))
        del data[i : i + rng.randrange(1, 20)]


def m_splice(rng: random.Random, data: bytearray) -> None:
    other = b"".join(f.encode() for f in valid_stream(rng)[0])
    if other:
        a = rng.randrange(len(other))
        b = rng.randrange(a, len(other) + 1)
        i = rng.randrange(len(data) + 1)
        data[i:i] = other[a:b]


def m_insert(rng: random.Random, data: bytearray) -> None:
    i = rng.randrange(len(data) + 1)
    data[i:i] = rng.randbytes(rng.randrange(1, 16))


def m_overwrite(rng: random.Random, data: bytearray) -> None:
    if data:
        i = rng.randrange(len(data))
        chunk = rng.randbytes(rng.randrange(1, 12))
        data[i : i + len(chunk)] = chunk


BYTE_MUTATIONS: dict[str, Callable[[random.Random, bytearray], None]] = {
    "flip": m_flip,
    "byte": m_byte,
    "truncate": m_truncate,
    "chop": m_chop,
    "splice": m_splice,
    "insert": m_insert,
    "overwrite": m_overwrite,
}
MUTATIONS = tuple(FRAME_MUTATIONS) + tuple(BYTE_MUTATIONS)


# =========================================================================== cases and outcomes
@dataclass(frozen=True)
class Case:
    """One mutant: its number, its bytes, where they are cut into reads, the reader's limit, and the
    messages the stream gives when it was not mutated (None when it was)."""

    number: int
    data: bytes
    cuts: tuple[int, ...]
    limit: int
    mutations: tuple[str, ...]
    want: tuple[tuple[int, bytes], ...] | None


@dataclass
class Outcome:
    kind: str  # one of OUTCOMES
    messages: int = 0
    error: str = ""  # a refusal's message
    key: str = ""  # a crash's or a wrong's class
    detail: str = ""


def make_case(seed: int, number: int) -> Case:
    """Case ``number`` of ``seed``: the same two numbers, the same case."""
    rng = random.Random(seed * 1_000_003 + number)
    frames, want = valid_stream(rng)
    names = rng.sample(MUTATIONS, rng.choice((0, 1, 1, 1, 2, 2, 3, 4)))
    for name in names:
        if name in FRAME_MUTATIONS:
            FRAME_MUTATIONS[name](rng, frames)
    data = bytearray(b"".join(f.encode() for f in frames))
    for name in names:
        if name in BYTE_MUTATIONS:
            BYTE_MUTATIONS[name](rng, data)
    limit = LIMIT if rng.random() < 0.75 else rng.choice(SMALL_LIMITS)
    roll = rng.random()
    if roll < 0.1:
        cuts = tuple(range(1, len(data)))
    elif roll < 0.2:
        cuts = ()
    else:
        cuts = tuple(sorted(rng.randrange(len(data) + 1) for _ in range(rng.randrange(1, 12))))
    return Case(number, bytes(data), cuts, limit, tuple(names), None if names else tuple(want))


def read(data: bytes, cuts: tuple[int, ...], limit: int) -> tuple[list[tuple[int, bytes]], str | None]:
    """What a reader gives for ``data`` cut at ``cuts`` before its first WebSocketError, and that error."""
    reader = FrameReader(limit)
    out: list[tuple[int, bytes]] = []
    pos = 0
    for c in (*cuts, len(data)):
        try:
            out += reader.feed(data[pos:c])
        except WebSocketError as exc:
            return out, str(exc) or "(no message)"
        pos = c
    return out, None


def wrong_output(out: list[tuple[int, bytes]], limit: int) -> str:
    """What is wrong with messages that came out of a reader, or ""."""
    for opcode, payload in out:
        if opcode not in (TEXT, BINARY, *CONTROL):
            return f"opcode {opcode} came out"
        if type(payload) is not bytes:
            return f"a payload of type {type(payload).__name__}"
        if len(payload) > limit:
            return "a payload over the limit"
        if opcode in CONTROL and len(payload) > 125:
            return "a control payload over 125 bytes"
        if opcode == TEXT:
            try:
                payload.decode("utf-8")
            except UnicodeDecodeError:
                return "a text message that is not UTF-8"
    return ""


def check(case: Case) -> Outcome:
    try:
        out, error = read(case.data, case.cuts, case.limit)
        whole, whole_error = read(case.data, (), case.limit)
    except Exception as exc:  # a crash: classed by the exception and where it was raised
        tb = traceback.extract_tb(exc.__traceback__)
        here = [f for f in tb if "pointat" in f.filename and "/tests/" not in f.filename] or tb
        where = f"{Path(here[-1].filename).name}:{here[-1].lineno} in {here[-1].name}"
        detail = "".join(traceback.format_exception(exc))
        name = type(exc).__qualname__
        if type(exc).__module__ != "builtins":
            name = f"{type(exc).__module__}.{name}"
        return Outcome("crash", key=f"{name} at {where}", detail=detail)
    wrong = wrong_output(out, case.limit)
    if not wrong and error != whole_error:
        wrong = "another error read whole than cut into reads"
    elif not wrong and error is None and out != whole:
        wrong = "other messages read whole than cut into reads"
    elif not wrong and case.want is not None and case.limit == LIMIT and (error or out != list(case.want)):
        wrong = "a valid stream did not give back its messages"
    if wrong:
        detail = f"cut: {out!r:.300} error {error!r}\nwhole: {whole!r:.300} error {whole_error!r}"
        return Outcome("wrong", messages=len(out), key=wrong, detail=detail)
    if error is not None:
        return Outcome("refused", messages=len(out), error=error)
    return Outcome("messages", messages=len(out))


@dataclass
class BadClass:
    """Crashes (or wrongs) of one class, and the smallest case that gave one."""

    key: str
    kind: str
    count: int
    case: Case
    detail: str


@dataclass
class Report:
    cases: int = 0
    counts: dict[str, int] = field(default_factory=lambda: dict.fromkeys(OUTCOMES, 0))
    messages: int = 0
    errors: dict[str, int] = field(default_factory=dict)  # refusals by message, numbers left out
    mutations: dict[str, int] = field(default_factory=dict)
    classes: dict[str, BadClass] = field(default_factory=dict)
    bytes_in: int = 0
    seconds: float = 0.0
    slowest: tuple[float, int] = (0.0, -1)  # seconds, case number

    @property
    def failures(self) -> int:
        return self.counts["crash"] + self.counts["wrong"]

    def add(self, case: Case, outcome: Outcome, seconds: float) -> None:
        self.cases += 1
        self.bytes_in += len(case.data)
        self.counts[outcome.kind] += 1
        self.messages += outcome.messages
        for name in case.mutations:
            self.mutations[name] = self.mutations.get(name, 0) + 1
        if outcome.error:
            kind = re.sub(r"\d+", "N", outcome.error)
            self.errors[kind] = self.errors.get(kind, 0) + 1
        if seconds > self.slowest[0]:
            self.slowest = (seconds, case.number)
        if outcome.kind in ("crash", "wrong"):
            known = self.classes.get(outcome.key)
            if known is None:
                self.classes[outcome.key] = BadClass(outcome.key, outcome.kind, 1, case, outcome.detail)
            else:
                known.count += 1
                if len(case.data) < len(known.case.data):
                    known.case, known.detail = case, outcome.detail


def fuzz(
    n: int = 20_000,
    seed: int = 0,
    progress: Callable[[Report], None] | None = None,
    every: int = 20_000,
) -> Report:
    report = Report()
    t0 = time.perf_counter()
    for number in range(n):
        case = make_case(seed, number)
        t = time.perf_counter()
        outcome = check(case)
        report.add(case, outcome, time.perf_counter() - t)
        if progress is not None and (number + 1) % every == 0:
            report.seconds = time.perf_counter() - t0
            progress(report)
    report.seconds = time.perf_counter() - t0
    return report


# =========================================================================== output
def show_case(case: Case, seed: int) -> str:
    return "\n".join(
        [
            f"case {case.number} (--seed {seed} --case {case.number}): {len(case.data)} bytes, "
            f"limit {case.limit}, mutations {', '.join(case.mutations) or 'none'}",
            f"  cut at {list(case.cuts)[:40]}{' ...' if len(case.cuts) > 40 else ''}",
            f"  hex: {case.data.hex()}",
        ]
    )


def summary(report: Report, seed: int) -> str:
    c = report.counts
    lines = [
        f"{report.cases} cases ({report.bytes_in / 1e6:.1f} MB) in {report.seconds:.1f} s "
        f"({report.cases / max(report.seconds, 1e-9):.0f}/s); slowest case {report.slowest[1]}: "
        f"{report.slowest[0] * 1e3:.1f} ms",
        f"  messages  {c['messages']:>8}  (streams read to the end; {report.messages} messages out in all)",
        f"  refused   {c['refused']:>8}  (WebSocketError)",
        f"  crash     {c['crash']:>8}  (any other exception)",
        f"  wrong     {c['wrong']:>8}  (a bad message out, or read whole and cut disagree)",
        "refusals:",
    ]
    for kind, count in sorted(report.errors.items(), key=lambda kv: -kv[1]):
        lines.append(f"  {count:>8}  {kind}")
    lines.append("mutations: " + ", ".join(f"{k} {v}" for k, v in sorted(report.mutations.items())))
    for bad in sorted(report.classes.values(), key=lambda b: -b.count):
        lines += [
            f"{bad.kind.upper()} x {bad.count}: {bad.key}",
            show_case(bad.case, seed),
            bad.detail.rstrip(),
        ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tests.fuzz_websocket", description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=20_000, help="how many mutants (default 20,000)")
    ap.add_argument("--seed", type=int, default=0, help="the mutants' seed: the same seed, the same mutants")
    ap.add_argument("--case", type=int, help="check this one case of the seed only, and show it")
    args = ap.parse_args(argv)
    if args.case is not None:
        case = make_case(args.seed, args.case)
        outcome = check(case)
        print(show_case(case, args.seed))
        print(f"outcome: {outcome.kind}, {outcome.messages} messages", outcome.error or outcome.key)
        if outcome.detail:
            print(outcome.detail.rstrip())
        return 1 if outcome.kind in ("crash", "wrong") else 0
    print(f"fuzzing FrameReader: seed {args.seed}, {args.n} cases", flush=True)

    def progress(r: Report) -> None:
        print(
            f"  {r.cases} cases, {r.counts['refused']} refused, {r.counts['crash']} crashes, "
            f"{r.counts['wrong']} wrong, {r.cases / r.seconds:.0f}/s",
            flush=True,
        )

    report = fuzz(args.n, args.seed, progress)
    print(summary(report, args.seed))
    return 1 if report.failures else 0


if __name__ == "__main__":
    sys.exit(main())
