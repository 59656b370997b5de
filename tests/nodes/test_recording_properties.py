"""Property-based tests of ``replay``: recordings are files people copy, cut, edit and compress.

Recordings are replayed in a real patch (``speed=0``, as fast as it goes).  Properties: a valid
recording (CSV or NDJSON, gzipped or not, with comments, blank lines, CRLF endings) comes out row by row,
unchanged and in order; any bytes, and any valid recording damaged (bytes changed, lines cut, junk
inserted, compressed data cut short), either come out as the rows an independent reading of the file
finds, or are refused with an error that names the file and, when one line is to blame, that line;
nothing hangs.
"""

from __future__ import annotations

import gzip
import json
import math
import re
import time
import warnings
import zlib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pointat.errors import PatchError
from pointat.runtime import StartError
from pointat.testing import patch

# a recording of a header and no row makes numpy warn "input contained no data" (said in the report)
pytestmark = pytest.mark.filterwarnings("ignore:loadtxt. input contained no data:UserWarning")

SETTINGS = settings(
    max_examples=60,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("recordings")


def replay(path: str) -> list | str:
    """The messages of the ``row`` outlet, or the refusal (at check or at start) as text."""
    try:
        rt = patch(
            f"node src replay file={path} speed=0\nnode got collect\nnode end collect\nsrc.row -> got\n"
            "src.done -> end\n",
            realtime=True,
        )
    except PatchError as exc:
        return str(exc)
    t0 = time.monotonic()
    try:
        rt.run(10)
    except StartError as exc:
        return str(exc)
    assert time.monotonic() - t0 < 5.0, "replay at speed=0 took seconds"
    assert len(rt.nodes["end"].messages) == 1, "done never came"
    return rt.nodes["got"].messages


# --------------------------------------------------------------------------- an independent reading


def lines_of(data: bytes) -> list[bytes]:
    """The lines of a file as an editor numbers them (from 1), each without its LF."""
    parts = data.split(b"\n")
    return parts[:-1] if parts[-1] == b"" else parts


def undecodable(data: bytes) -> int | None:
    """The first line that is not UTF-8."""
    for n, raw in enumerate(lines_of(data), 1):
        try:
            raw.decode("utf-8")
        except UnicodeDecodeError:
            return n
    return None


def is_number(cell: str) -> bool:
    """A CSV cell as numpy reads it, the arbiter of what is a number in a CSV recording."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "input contained no data"
        try:
            return np.loadtxt([cell], delimiter=",", ndmin=1, comments=None).size == 1
        except ValueError:
            return False


def read_csv(data: bytes) -> tuple[str, object]:
    """('rows', [(t, values)]) or ('bad', the lines that could be blamed: first bad row, first non-UTF-8)."""
    header: list[str] | None = None
    rows: list[tuple[float, tuple[float, ...]]] = []
    bad: set[int | None] = set()
    utf8 = undecodable(data)
    if utf8 is not None:
        bad.add(utf8)
    for n, raw in enumerate(lines_of(data), 1):
        line = raw.decode("utf-8", errors="replace")
        if header is None:
            if line.strip() and not line.startswith("#"):
                header = [c.strip() for c in line.strip().split(",")]
                if header[0] != "t":
                    return "bad", bad | {None}
            continue
        text = line.split("#", 1)[0].strip()
        if not text:
            continue
        cells = [c.strip() for c in text.split(",")]
        if len(cells) != len(header) or not all(map(is_number, cells)):
            return "bad", bad | {n}
        values = [float(c) for c in cells]
        rows.append((values[0], tuple(values[1:])))
    if header is None:
        return "bad", bad | {None}
    return ("bad", bad) if bad else ("rows", rows)


def recorded(d) -> tuple[str, object] | None:
    """The message an NDJSON line holds, as (kind, value), or None if it holds none."""
    if not isinstance(d, dict) or not {"t", "kind", "value"} <= d.keys():
        return None
    kind, value, t = d["kind"], d["value"], d["t"]
    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    try:
        t = float(t)
        if kind == "float" and number:
            return kind, float(value)
    except (TypeError, ValueError, OverflowError):
        return None
    if not isinstance(kind, str) or not kind:
        return None
    if kind == "vector":
        try:
            flat = np.ravel(np.asarray(value, dtype=float))
        except (TypeError, ValueError, OverflowError):
            return None
        return (kind, tuple(flat.tolist())) if isinstance(value, list) else None
    if kind == "int" and isinstance(value, int) and not isinstance(value, bool):
        return kind, value
    if kind == "symbol" and isinstance(value, str):
        return kind, value
    if kind == "bang":
        return kind, None
    if kind not in ("float", "int", "symbol") and isinstance(value, list):
        return kind, tuple(value)
    return None


def read_ndjson(data: bytes) -> tuple[str, object]:
    utf8 = undecodable(data)
    messages = []
    for n, raw in enumerate(lines_of(data), 1):
        if n == utf8:
            return "bad", {n}
        line = raw.decode("utf-8")
        if not line.strip():
            continue
        try:
            d = json.loads(line)
        except (ValueError, RecursionError):
            return "bad", {n}
        m = recorded(d)
        if m is None:
            return "bad", {n}
        messages.append(m)
    return "rows", messages


def blamed_line(message: str, path: str) -> int | None:
    m = re.search(re.escape(path) + r":(\d+):", message)
    return int(m.group(1)) if m else None


def same_value(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    if isinstance(a, tuple) and isinstance(b, tuple):
        return len(a) == len(b) and all(map(same_value, a, b))
    return a == b and type(a) is type(b)


def check(path: str, data: bytes, fmt: str, got) -> None:
    """What replay did with the (uncompressed) ``data`` is what the independent reading says."""
    outcome, detail = read_csv(data) if fmt == "csv" else read_ndjson(data)
    if isinstance(got, str):
        assert path in got, got
        assert outcome == "bad", f"refused a recording read as good: {got}"
        line = blamed_line(got, path)
        assert line in detail, f"blamed line {line}, the bad ones are {detail}: {got}"
        return
    assert outcome == "rows", f"replayed a recording with bad lines {detail}"
    if fmt == "csv":
        assert len(got) == len(detail)
        for m, (_t, values) in zip(got, detail, strict=True):
            assert m.kind == "vector" and same_value(tuple(m.value), values)
    else:
        assert [m.kind for m in got] == [k for k, _ in detail]
        for m, (_k, value) in zip(got, detail, strict=True):
            assert same_value(m.value, value), (m, value)


# --------------------------------------------------------------------------- recordings

COLUMNS = [
    "gyr_x",
    "gyr_y",
    "gyr_z",
    "acc_x",
    "acc_y",
    "acc_z",
    "mag_x",
    "qw",
    "qx",
    "qy",
    "qz",
    "value",
    "v0",
]
finite = st.floats(allow_nan=False, allow_infinity=False)
values = st.one_of(finite, finite, st.sampled_from([math.nan, math.inf, -math.inf, -0.0, 5e-324]))


@st.composite
def csv_recording(draw) -> tuple[bytes, list]:
    names = draw(st.lists(st.sampled_from(COLUMNS), min_size=1, max_size=6, unique=True))
    n = draw(st.integers(0, 12))
    steps = draw(st.lists(st.floats(0.0, 0.5), min_size=n, max_size=n))
    t0 = draw(st.floats(-100.0, 100.0))
    times = list(np.cumsum([t0, *steps])[1:]) if n else []
    rows = [
        (float(t), tuple(draw(st.lists(values, min_size=len(names), max_size=len(names))))) for t in times
    ]
    eol = draw(st.sampled_from(["\n", "\r\n"]))
    sep = draw(st.sampled_from([",", ", ", " , "]))
    out = [f"# a take{eol}"] if draw(st.booleans()) else []
    out.append(sep.join(["t", *names]) + eol)
    for t, vs in rows:
        if draw(st.integers(0, 9)) == 0:
            out.append(draw(st.sampled_from(["", "# a note", "   "])) + eol)
        out.append(sep.join(repr(v) for v in (t, *vs)) + draw(st.sampled_from(["", " # ok"])) + eol)
    return "".join(out).encode(), rows


json_scalars = st.one_of(st.none(), st.booleans(), st.integers(), finite, st.text(max_size=6))
json_values = st.recursive(
    json_scalars,
    lambda inner: st.one_of(
        st.lists(inner, max_size=3), st.dictionaries(st.text(max_size=4), inner, max_size=3)
    ),
    max_leaves=6,
)


@st.composite
def ndjson_message(draw) -> tuple[str, object]:
    kind = draw(st.sampled_from(["float", "int", "symbol", "bang", "vector", "list", "set", "/imu/acc"]))
    value = {
        "float": finite,
        "int": st.integers(-(2**70), 2**70),
        "symbol": st.text(max_size=8),
        "bang": st.none(),
        "vector": st.lists(finite, max_size=9),
        "list": st.lists(json_scalars, max_size=4),
        "set": st.lists(json_scalars, max_size=3),
        "/imu/acc": st.lists(finite, max_size=3),
    }[kind]
    return kind, draw(value)


@st.composite
def ndjson_recording(draw) -> tuple[bytes, list]:
    messages = draw(st.lists(ndjson_message(), max_size=10))
    eol = draw(st.sampled_from(["\n", "\r\n"]))
    lines = [
        json.dumps({"t": k / 100, "kind": kind, "value": value}) + eol
        for k, (kind, value) in enumerate(messages)
    ]
    return "".join(lines).encode(), messages


def save(folder, name: str, data: bytes) -> str:
    path = folder / name
    path.write_bytes(gzip.compress(data, mtime=0) if name.endswith(".gz") else data)
    return str(path)


# --------------------------------------------------------------------------- properties


@SETTINGS
@given(
    rec=st.one_of(
        csv_recording().map(lambda r: ("csv", *r)), ndjson_recording().map(lambda r: ("ndjson", *r))
    ),
    gz=st.booleans(),
)
def test_a_valid_recording_comes_out_row_by_row_unchanged_and_in_order(folder, rec, gz):
    fmt, data, rows = rec
    path = save(folder, f"take.{fmt}" + (".gz" if gz else ""), data)
    got = replay(path)
    assert not isinstance(got, str), got
    if fmt == "csv":
        assert [m.time for m in got] == [t for t, _ in rows]
        assert all(
            m.kind == "vector" and same_value(tuple(m.value), vs)
            for m, (_, vs) in zip(got, rows, strict=True)
        )
    else:
        assert [m.time for m in got] == [k / 100 for k in range(len(rows))]
        want = [recorded({"t": 0, "kind": kind, "value": value}) for kind, value in rows]
        assert all(same_value(m.value, v) and m.kind == k for m, (k, v) in zip(got, want, strict=True))
    check(path, data, fmt, got)


@SETTINGS
@given(
    rec=csv_recording(), extra=st.lists(st.tuples(st.integers(0, 100), st.sampled_from(range(7))), max_size=4)
)
def test_lines_of_blanks_and_comments_anywhere_lose_no_row(folder, rec, extra):
    data, rows = rec
    lines = data.split(b"\n")
    for at, which in extra:  # anywhere but before the header (where a blank line is no header either)
        k = 1 + at % len(lines)
        lines.insert(k, [b"", b"   ", b"\t", b" \r", b"# a note", b"  # an indented note", b"#"][which])
    path = save(folder, "take.csv", b"\n".join(lines))
    got = replay(path)
    assert not isinstance(got, str), got
    assert [m.time for m in got] == [t for t, _ in rows]
    assert all(same_value(tuple(m.value), vs) for m, (_, vs) in zip(got, rows, strict=True))


#: Lines and cells that tempt a reader: numbers Python reads and numpy does not, line breaks other than
#: LF, JSON nested past the recursion limit, numbers past a float's range.
TRAPS = [
    b"1_0",
    "\uff11".encode(),
    b"0x10",
    b"nan",
    b"1e400",
    b"",
    b"#",
    b" , ",
    b"\r",
    b"\x0c",
    b"\x00",
    b"\xe9",
    "\u2028".encode(),
    b"[" * 3000,
    b"9" * 5000,
    b"1" + b"0" * 400,
    b'{"t": 1e999, "kind": "float", "value": 1}',
    b'{"t": 0, "kind": "float", "value": ' + b"9" * 400 + b"}",
    b'{"t": 0, "kind": "vector", "value": "123"}',
    b'{"t": 0, "kind": "vector", "value": [' + b"9" * 400 + b"]}",
    b'{"t": ' + b"9" * 400 + b', "kind": "bang", "value": null}',
]


#: Lines a hand edit leaves that a reader must take as nothing: blanks, comments, indented comments.
HARMLESS = [b"", b"   ", b"\t", b" \r", b"# a note", b"  # an indented note", b"#"]


@st.composite
def damaged(draw, data: bytes) -> bytes:
    """``data`` with a few edits: most keep it readable (a line dropped, doubled, a digit changed, a blank
    or a comment line added), the others damage it (bytes changed, cut short, junk inserted)."""
    for _ in range(draw(st.integers(1, 3))):
        lines = data.split(b"\n")
        k = draw(st.integers(0, len(lines) - 1))
        how = draw(
            st.sampled_from(
                ["drop", "double", "digit", "harmless", "flip", "insert", "delete", "cut", "trap", "line"]
            )
        )
        if how == "drop":
            del lines[k]
        elif how == "double":
            lines.insert(k, lines[k])
        elif how == "digit" and re.search(rb"\d", lines[k]):
            digits = [m.start() for m in re.finditer(rb"\d", lines[k])]
            at = draw(st.sampled_from(digits))
            lines[k] = (
                lines[k][:at] + draw(st.sampled_from(b"0123456789")).to_bytes(1, "big") + lines[k][at + 1 :]
            )
        elif how == "harmless":
            lines.insert(k, draw(st.sampled_from(HARMLESS)))
        data = b"\n".join(lines)
        if how in ("drop", "double", "digit", "harmless"):
            continue
        buf = bytearray(data)
        at = draw(st.integers(0, len(buf)))
        if how == "flip" and buf:
            buf[min(at, len(buf) - 1)] = draw(st.integers(0, 255))
        elif how == "insert":
            buf[at:at] = draw(st.binary(min_size=1, max_size=6))
        elif how == "delete":
            del buf[at : at + draw(st.integers(1, 8))]
        elif how == "cut":
            del buf[at:]
        elif how == "trap":
            buf[at:at] = draw(st.sampled_from(TRAPS))
        elif how == "line":  # a whole line of junk
            buf[at:at] = b"\n" + draw(st.sampled_from(TRAPS)) + b"\n"
        data = bytes(buf)
    return data


@settings(SETTINGS, max_examples=120)
@given(
    rec=st.one_of(
        csv_recording().map(lambda r: ("csv", r[0])), ndjson_recording().map(lambda r: ("ndjson", r[0]))
    ),
    gz=st.booleans(),
    data=st.data(),
)
def test_a_damaged_recording_comes_out_as_read_or_is_refused_naming_the_file_and_line(folder, rec, gz, data):
    fmt, good = rec
    bad = data.draw(damaged(good))
    path = save(folder, f"take.{fmt}" + (".gz" if gz else ""), bad)
    check(path, bad, fmt, replay(path))


@SETTINGS
@given(
    data=st.one_of(st.binary(max_size=300), st.sampled_from(TRAPS)),
    name=st.sampled_from(["take.csv", "take.ndjson", "take.jsonl", "take.csv.gz", "take.ndjson.gz"]),
)
def test_any_bytes_come_out_as_read_or_are_refused_naming_the_file(folder, data, name):
    path = folder / name
    path.write_bytes(data)  # a .gz name too: not gzip data, or gzip data made of anything
    got = replay(str(path))
    if name.endswith(".gz"):
        try:
            data = gzip.decompress(data)
        except (OSError, EOFError, zlib.error):
            assert isinstance(got, str) and str(path) in got, got
            return
    check(str(path), data, "csv" if ".csv" in name else "ndjson", got)


@SETTINGS
@given(
    rec=st.one_of(csv_recording(), ndjson_recording()),
    fmt=st.sampled_from(["csv", "ndjson"]),
    cut=st.integers(1, 400),
)
def test_compressed_data_cut_short_or_damaged_is_refused_naming_the_file_and_the_line(folder, rec, fmt, cut):
    data = rec[0]
    packed = gzip.compress(data, mtime=0)
    path = folder / f"take.{fmt}.gz"
    path.write_bytes(packed[: max(1, len(packed) - cut)])  # (no byte at all: an empty recording)
    got = replay(str(path))
    assert isinstance(got, str) and str(path) in got, got
    assert re.search(re.escape(str(path)) + r"(:\d+)?: ", got), got


@pytest.mark.parametrize(
    "name, text, said",
    [  # each of these raised something other than a located refusal, or was read as something else
        ("take.csv", "t,value\n0,1\n0.01,1_0\n", "take.csv:3: column 2: '1_0' is not a number"),
        ("take.csv", "t,value\n0,1\n0.01,\uff11\n", "take.csv:3: column 2: '\uff11' is not a number"),
        (
            "take.ndjson",
            '{"t": 0, "kind": "float", "value": 1' + "0" * 400 + "}\n",
            "take.ndjson:1: not a recorded",
        ),
        (
            "take.ndjson",
            '{"t": 1' + "0" * 400 + ', "kind": "bang", "value": null}\n',
            "take.ndjson:1: not a recorded",
        ),
        (
            "take.ndjson",
            '{"t": 0, "kind": "vector", "value": [1' + "0" * 400 + "]}\n",
            "take.ndjson:1: not a recorded",
        ),
        ("take.ndjson", '{"t": 0, "kind": "vector", "value": "123"}\n', "take.ndjson:1: not a recorded"),
        ("take.ndjson", "[" * 100_000 + "\n", "take.ndjson:1: not a recorded message"),
    ],
    ids=[
        "underscore",
        "fullwidth-digit",
        "huge-float",
        "huge-time",
        "huge-in-vector",
        "string-vector",
        "deep",
    ],
)
def test_what_property_testing_found_is_refused_naming_the_file_and_the_line(folder, name, text, said):
    path = folder / name
    path.write_text(text, encoding="utf-8")
    got = replay(str(path))
    assert isinstance(got, str) and said in got, got


@pytest.mark.parametrize(
    "text",
    [  # refused as "not a table of numbers", no line named
        "t,value\n0,1\n0.01,2\n   \n",  # a line of blanks at the end of a hand-edited file
        "t,value\n0,1\n  # an indented note\n0.01,2\n",
        "# take 3\n\t\nt,value\n \r\n0,1\n0.01,2\n",
    ],
    ids=["blank-last-line", "indented-comment", "tab-and-cr-lines"],
)
def test_lines_of_blanks_and_indented_comments_are_skipped(folder, text):
    path = folder / "take.csv"
    path.write_text(text, encoding="utf-8")
    got = replay(str(path))
    assert not isinstance(got, str), got
    assert [(m.time, m.value) for m in got] == [(0.0, (1.0,)), (0.01, (2.0,))]
