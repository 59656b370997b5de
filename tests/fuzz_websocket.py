r"""A mutation fuzzer of the monitor's server, over real sockets: mutated WebSocket client streams and
mutated HTTP requests sent to a running :class:`~pointat.monitor.webserver.MonitorServer` (on 127.0.0.1, a free
port) must be answered or closed, never log an error or a traceback, and never stop it serving.

::

    python -m tests.fuzz_websocket                      # 20,000 mutants, seed 0
    python -m tests.fuzz_websocket --n 200000 --seed 7  # 200,000 mutants, reproducible
    python -m tests.fuzz_websocket --seed 7 --case 1234 # one mutant again, shown in full

A WebSocket case (three in four) is a valid handshake, then a valid client stream (text and binary
messages, now and then a real command or OSC message of live control, some in fragments with pings,
pongs and closes between them, masked with random keys, now and then a payload at a length boundary:
125, 126, 65535, 65536 bytes) with zero to four mutations: frames dropped, doubled, swapped or repeated
hundreds of times, header bits changed (FIN, the reserved bits, the opcode, the mask bit), length fields
rewritten (to 0, 125, 126, 127, 65535, 65536, 2**63, 2**64-1, one off, or in another form than the
shortest), bit flips, bytes set to 0x00, 0x7E, 0x7F, 0x80, 0xFF..., the stream cut short or a range of
it cut out, another stream spliced in, random bytes put in or over.  An HTTP case is a request the page
or an OSCQuery client sends (a GET of the tree, an attribute, the page, its state; a handshake; with
its Host, sometimes an Origin, a foreign one too), its bytes mutated the same way.  The bytes are sent
cut into writes at random points (a WebSocket case's with a close frame after them); the client then
reads what comes back until the server closes (2 s at most).  (It does not half-close: the library takes
a client's end of stream before its answer for the end of the connection, and answers nothing.)

The outcome of a case is ``served`` (answered, or closed), ``library`` (the websockets library tripped
over bytes or an end of stream that came before its answer, an assertion of its own: it closed that
connection and served on, and the server told it as one warning), ``crash`` (the server logged an
error or a traceback, or one of its threads raised) or ``dead`` (the server did not answer a plain GET after the
case).  Crashes are grouped into classes (the log line, numbers left out); each class's smallest case is
printed with its bytes in hex.  The exit status is 1 when there was any crash or the server died.
"""

from __future__ import annotations

import argparse
import base64
import logging
import random
import re
import socket
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

from pointat.devices.osc_wire import encode_message

CONTINUATION, TEXT, BINARY, CLOSE, PING, PONG = 0x0, 0x1, 0x2, 0x8, 0x9, 0xA
CONTROL = (CLOSE, PING, PONG)
#: Lengths a length field is rewritten to.
LENGTHS = (0, 1, 125, 126, 127, 65535, 65536, 65537, 2**31, 2**32, 2**63 - 1, 2**63, 2**64 - 1)
#: Bytes a byte is set to.
BYTES = (0x00, 0x01, 0x0F, 0x70, 0x7D, 0x7E, 0x7F, 0x80, 0x81, 0x88, 0x89, 0x8A, 0xFE, 0xFF)
#: Text that UTF-8 decoders get wrong: multibyte characters, to be cut between fragments.
TEXTS = ("", "hi", "é", "€uro", "😀", "a\u0000b", "\ufeff", "\U0010ffff", "日本語のテキスト", "\u2028\u202e")
#: Real messages of the server's protocol, a payload now and then (so that mutants reach the commands).
COMMANDS = (
    b'{"COMMAND": "LISTEN", "DATA": "/pointat/lim/interval"}',
    b'{"COMMAND": "IGNORE", "DATA": "/pointat/lim/interval"}',
    b'{"COMMAND": "MONITOR"}',
    b'{"COMMAND": "LISTEN", "DATA": ["/x"]}',
    b"[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[",
    encode_message("/pointat/lim/interval", [120.0]),
    encode_message("/pointat/m/interval", [5000.0]),
    encode_message("/pointat/nothing/here", [1]),
)
OUTCOMES = ("served", "library", "crash", "dead")
#: What the server logs when the websockets library trips over a client's bytes before its answer.
LIBRARY = "its connection closed ("


# =========================================================================== a client's frames


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
    if rng.random() < 0.2:
        return rng.choice(COMMANDS)
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


# =========================================================================== HTTP requests
def valid_request(rng: random.Random, port: int) -> bytes:
    """A request the page or an OSCQuery client sends, now and then with an Origin (its own or not)."""
    target = rng.choice(
        ("/", "/?HOST_INFO", "/pointat/lim/interval?VALUE", "/pointat/lim", "/monitor", "/monitor/state",
         "/monitor/monitor.js", "/favicon.ico", "/nothing?RANGE", "/%2e%2e/%00")
    )  # fmt: skip
    lines = [f"GET {target} HTTP/1.1", f"Host: {rng.choice(('127.0.0.1', 'localhost'))}:{port}"]
    if rng.random() < 0.4:
        key = base64.b64encode(rng.randbytes(16)).decode()
        lines += ["Upgrade: websocket", "Connection: Upgrade", f"Sec-WebSocket-Key: {key}"]
        lines.append("Sec-WebSocket-Version: 13")
    if rng.random() < 0.3:
        lines.append(f"Origin: {rng.choice((f'http://127.0.0.1:{port}', 'http://evil.example', 'null'))}")
    if rng.random() < 0.2:
        lines.append("Cookie: " + rng.choice(("a=b", "pointat_token_1=x; c", '"', "=" * 50)))
    if rng.random() < 0.1:  # a header twice
        lines.insert(rng.randrange(1, len(lines) + 1), rng.choice(lines[1:]))
    return ("\r\n".join([*lines, "", ""])).encode()


def handshake(port: int, rng: random.Random) -> bytes:
    key = base64.b64encode(rng.randbytes(16)).decode()
    return (
        f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
        f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\nOrigin: http://127.0.0.1:{port}\r\n\r\n"
    ).encode()


# =========================================================================== cases and outcomes
@dataclass(frozen=True)
class Case:
    """One mutant: its number, its kind (``ws``: after a valid handshake; ``http``: a request), its bytes,
    where they are cut into writes, its mutations, and whether a WebSocket case waits for the handshake's
    answer before its frames (as a browser does) or sends them at once."""

    number: int
    kind: str
    data: bytes
    cuts: tuple[int, ...]
    mutations: tuple[str, ...]
    wait: bool = True


@dataclass
class Outcome:
    kind: str  # one of OUTCOMES
    answer: str = ""  # what came back: a status line, "frames", "closed"
    key: str = ""  # a crash's class
    detail: str = ""


def make_case(seed: int, number: int, port: int) -> Case:
    """Case ``number`` of ``seed``: the same two numbers, the same case (``port`` goes into the Host)."""
    rng = random.Random(seed * 1_000_003 + number)
    kind = "http" if rng.random() < 0.25 else "ws"
    names = rng.sample(MUTATIONS, rng.choice((0, 1, 1, 1, 2, 2, 3, 4)))
    if kind == "ws":
        frames, _want = valid_stream(rng)
        for name in names:
            if name in FRAME_MUTATIONS:
                FRAME_MUTATIONS[name](rng, frames)
        data = bytearray(handshake(port, rng) + b"".join(f.encode() for f in frames))
        start = data.index(b"\r\n\r\n") + 4
    else:
        names = [n for n in names if n in BYTE_MUTATIONS]
        data = bytearray(valid_request(rng, port))
        start = 0
    body = bytearray(data[start:])
    for name in names:
        if name in BYTE_MUTATIONS and (body or name in ("splice", "insert")):
            BYTE_MUTATIONS[name](rng, body) if body else body.extend(rng.randbytes(4))
    data = data[:start] + body
    roll = rng.random()
    if roll < 0.1:
        cuts: tuple[int, ...] = ()
    else:
        cuts = tuple(sorted({rng.randrange(len(data) + 1) for _ in range(rng.randrange(1, 8))}))
    return Case(number, kind, bytes(data), cuts, tuple(names), wait=rng.random() < 0.9)


class Served:
    """A monitor server on a free port of 127.0.0.1 with a running patch (a metro through a speedlim),
    and what it logs at ERROR or with a traceback, and what its threads raise."""

    PATCH = "node lim speedlim 100\nnode m metro 50\nnode on loadbang\non -> m -> lim"

    def __init__(self) -> None:
        from pointat.checking import check
        from pointat.loader import build
        from pointat.monitor.observe import Observer
        from pointat.monitor.webserver import MonitorServer
        from pointat.patchfile import parse_patch
        from pointat.registry import Registry

        self.bad: list[str] = []
        self.rt = build(check(parse_patch(self.PATCH, "fuzz.pat"), Registry().load_builtins()))
        self.obs = Observer(self.rt).attach()
        self.server = MonitorServer(self.rt, self.obs, "127.0.0.1", 0, advertise=False)
        self.port = self.server.port
        self._handler = _Bad(self.bad)
        logging.getLogger().addHandler(self._handler)
        logging.getLogger().setLevel(logging.INFO)
        self._hook = threading.excepthook
        threading.excepthook = lambda a: self.bad.append(
            f"thread {a.thread.name} raised {a.exc_type.__name__}: {a.exc_value}"
        )
        self.server.start()
        self.thread = self.rt.run_in_thread(10**6)
        self.obs.start()

    def alive(self) -> bool:
        """Whether a plain GET is answered 200 (three tries, 5 s each)."""
        for _ in range(3):
            try:
                with socket.create_connection(("127.0.0.1", self.port), timeout=5) as s:
                    s.sendall(f"GET /?HOST_INFO HTTP/1.1\r\nHost: 127.0.0.1:{self.port}\r\n\r\n".encode())
                    if s.recv(64).startswith(b"HTTP/1.1 200 "):
                        return True
            except OSError:
                pass
            time.sleep(0.5)  # a full house (MAX_CONNECTIONS) empties in OPEN_TIMEOUT
        return False

    def close(self) -> None:
        self.obs.stop()
        self.rt.stop()
        self.thread.join(5)
        self.server.close()
        logging.getLogger().removeHandler(self._handler)
        threading.excepthook = self._hook


class _Bad(logging.Handler):
    def __init__(self, out: list[str]):
        super().__init__(logging.DEBUG)
        self.out = out

    def emit(self, record: logging.LogRecord) -> None:
        if record.levelno >= logging.ERROR or record.exc_info or LIBRARY in record.msg:
            self.out.append(f"{record.name} {record.levelname}: {record.getMessage()}"[:300])


def send(served: Served, case: Case) -> Outcome:
    """Send a case, read what comes back (5 s at most), and judge the server by what it logged."""
    before = len(served.bad)
    answer = "closed"
    try:
        with socket.create_connection(("127.0.0.1", served.port), timeout=5) as s:
            pos = 0
            reply = b""
            try:
                if case.kind == "ws" and case.wait:
                    pos = case.data.index(b"\r\n\r\n") + 4
                    s.sendall(case.data[:pos])
                    while b"\r\n\r\n" not in reply:
                        chunk = s.recv(4096)
                        if not chunk:
                            break
                        reply += chunk
                for c in (*[c for c in case.cuts if c > pos], len(case.data)):
                    s.sendall(case.data[pos:c])
                    pos = c
                if case.kind == "ws":  # the client's close: the server answers it and ends
                    s.sendall(Frame(CLOSE, b"\x03\xe8").encode())
            except OSError:  # the server closed first: that is an answer
                pass
            s.settimeout(0.5)
            deadline = time.monotonic() + 2
            while time.monotonic() < deadline:
                try:
                    chunk = s.recv(65536)
                except (TimeoutError, OSError):
                    break
                if not chunk:
                    break
                reply += chunk
                if len(reply) > 1 << 20:
                    break
            if reply.startswith(b"HTTP/1.1 "):
                answer = reply.split(b"\r\n", 1)[0].decode("latin-1")
    except OSError as exc:
        answer = f"connect: {exc}"
    if case.number % 200 == 199 and not served.alive():
        return Outcome("dead", answer, key="the server stopped answering GET /?HOST_INFO")
    time.sleep(0.002)  # (the server's thread tells its log after the close)
    bad = served.bad[before:]
    if bad:
        kind = "library" if all(LIBRARY in b for b in bad) else "crash"
        return Outcome(kind, answer, key=re.sub(r"\d+", "N", bad[0]), detail="\n".join(bad))
    return Outcome("served", answer)


@dataclass
class BadClass:
    """Crashes of one class, and the smallest case that gave one."""

    key: str
    kind: str
    count: int
    case: Case
    detail: str


@dataclass
class Report:
    cases: int = 0
    counts: dict[str, int] = field(default_factory=lambda: dict.fromkeys(OUTCOMES, 0))
    answers: dict[str, int] = field(default_factory=dict)
    mutations: dict[str, int] = field(default_factory=dict)
    classes: dict[str, BadClass] = field(default_factory=dict)
    bytes_in: int = 0
    seconds: float = 0.0
    threads: tuple[int, int] = (0, 0)  # before, after

    @property
    def failures(self) -> int:
        return self.counts["crash"] + self.counts["dead"]

    def add(self, case: Case, outcome: Outcome) -> None:
        self.cases += 1
        self.bytes_in += len(case.data)
        self.counts[outcome.kind] += 1
        key = f"{case.kind}: {outcome.answer}"
        self.answers[key] = self.answers.get(key, 0) + 1
        for name in case.mutations:
            self.mutations[name] = self.mutations.get(name, 0) + 1
        if outcome.kind != "served":
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
    every: int = 5_000,
    only: int | None = None,
) -> Report:
    report = Report()
    served = Served()
    before = threading.active_count()
    t0 = time.perf_counter()
    try:
        for number in range(n) if only is None else (only,):
            case = make_case(seed, number, served.port)
            report.add(case, send(served, case))
            if progress is not None and (number + 1) % every == 0:
                report.seconds = time.perf_counter() - t0
                progress(report)
        if not served.alive():
            report.add(Case(-1, "http", b"", (), ()), Outcome("dead", key="dead at the end"))
        deadline = time.monotonic() + 10  # the connections' threads end within OPEN_TIMEOUT
        while threading.active_count() > before and time.monotonic() < deadline:
            time.sleep(0.1)
        report.threads = (before, threading.active_count())
    finally:
        report.seconds = time.perf_counter() - t0
        served.close()
    return report


# =========================================================================== output
def show_case(case: Case, seed: int) -> str:
    return "\n".join(
        [
            f"case {case.number} (--seed {seed} --case {case.number}): {case.kind}, {len(case.data)} "
            f"bytes, mutations {', '.join(case.mutations) or 'none'}",
            f"  cut at {list(case.cuts)[:40]}{' ...' if len(case.cuts) > 40 else ''}",
            f"  hex: {case.data[:4000].hex()}{' ...' if len(case.data) > 4000 else ''}",
        ]
    )


def summary(report: Report, seed: int) -> str:
    c = report.counts
    lines = [
        f"{report.cases} cases ({report.bytes_in / 1e6:.1f} MB) in {report.seconds:.1f} s "
        f"({report.cases / max(report.seconds, 1e-9):.0f}/s); threads {report.threads[0]} before, "
        f"{report.threads[1]} after",
        f"  served    {c['served']:>8}  (answered or closed, nothing logged at ERROR, no traceback)",
        f"  library   {c['library']:>8}  (the websockets library tripped over the client's bytes, closed "
        "that connection and served on: told as one warning)",
        f"  crash     {c['crash']:>8}  (an error or a traceback logged, or a thread raised)",
        f"  dead      {c['dead']:>8}  (the server stopped answering)",
        "answers:",
    ]
    for kind, count in sorted(report.answers.items(), key=lambda kv: -kv[1])[:20]:
        lines.append(f"  {count:>8}  {kind}")
    lines.append("mutations: " + ", ".join(f"{k} {v}" for k, v in sorted(report.mutations.items())))
    for bad in sorted(report.classes.values(), key=lambda b: -b.count):
        lines += [f"{bad.kind.upper()} x {bad.count}: {bad.key}", show_case(bad.case, seed), bad.detail]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tests.fuzz_websocket", description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=20_000, help="how many mutants (default 20,000)")
    ap.add_argument("--seed", type=int, default=0, help="the mutants' seed: the same seed, the same mutants")
    ap.add_argument("--case", type=int, help="send this one case of the seed only, and show it")
    args = ap.parse_args(argv)
    if args.case is not None:
        report = fuzz(seed=args.seed, only=args.case)
        print(summary(report, args.seed))
        return 1 if report.failures else 0
    print(f"fuzzing the monitor's server: seed {args.seed}, {args.n} cases", flush=True)

    def progress(r: Report) -> None:
        print(
            f"  {r.cases} cases, {r.counts['crash']} crashes, {r.counts['dead']} dead, "
            f"{r.cases / r.seconds:.0f}/s",
            flush=True,
        )

    report = fuzz(args.n, args.seed, progress)
    print(summary(report, args.seed))
    return 1 if report.failures or report.threads[1] > report.threads[0] else 0


if __name__ == "__main__":
    sys.exit(main())
