"""The skeleton file is outside bytes: whatever it holds, reading it gives a skeleton or a ValueError
that names the file (and the segment where there is one), never another exception."""

from __future__ import annotations

import json
import math

from hypothesis import given, settings
from hypothesis import strategies as st

from pointat.maths.skeleton import Segment, Skeleton, forward

SETTINGS = settings(max_examples=300, deadline=None, derandomize=True, database=None)

json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=True) | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=20,
)
numbers = st.floats(-5.0, 5.0, allow_nan=False)
names = st.from_regex(r"[A-Za-z][A-Za-z0-9_]{0,8}", fullmatch=True)


def _read_or_refused(text: str) -> Skeleton | None:
    try:
        return Skeleton.from_json(text, "body.json")
    except ValueError as exc:
        assert str(exc).startswith("body.json"), exc
        return None


@SETTINGS
@given(st.text(max_size=200))
def test_any_text_is_a_skeleton_or_a_refusal_naming_the_file(text):
    _read_or_refused(text)


@SETTINGS
@given(json_values)
def test_any_json_is_a_skeleton_or_a_refusal_naming_the_file(value):
    _read_or_refused(json.dumps(value))


@SETTINGS
@given(
    st.dictionaries(
        st.sampled_from(["name", "parent", "at", "length", "sensor", "pose", "other"]),
        json_values,
        max_size=6,
    )
)
def test_a_segment_of_any_shape_in_a_good_file_is_read_or_named(segment):
    good = {"name": "root", "sensor": 1, "length": [0.3, 0.0, 0.0]}
    body = _read_or_refused(json.dumps({"segments": [good, segment]}))
    if body is not None:  # what was read is what was written, and forward kinematics is finite
        assert len(body.segments) == 2 and body.segments[1].name == str(segment["name"])
        joints, ends = forward(body, [s.pose for s in body.segments])
        assert all(math.isfinite(c) for p in joints + ends for c in p)


@st.composite
def skeletons(draw):
    n = draw(st.integers(1, 6))
    segs = []
    used: set[str] = set()
    for k in range(n):
        name = draw(names.filter(lambda s: s not in used))
        used.add(name)
        parent = None if k == 0 else segs[draw(st.integers(0, k - 1))].name
        vec = st.tuples(numbers, numbers, numbers)
        sensor = k + 1 if k == 0 or draw(st.booleans()) else None
        segs.append(Segment(name, parent, draw(vec), draw(vec), sensor))
    return Skeleton(tuple(segs), draw(st.tuples(numbers, numbers, numbers)))


@SETTINGS
@given(skeletons())
def test_a_skeleton_written_as_json_reads_back_the_same(body):
    text = json.dumps(
        {
            "root": list(body.root),
            "segments": [
                {
                    "name": s.name,
                    "parent": s.parent,
                    "at": list(s.at),
                    "length": list(s.length),
                    "sensor": s.sensor,
                }
                for s in body.segments
            ],
        }
    )
    assert Skeleton.from_json(text, "body.json") == body


def test_bytes_that_are_not_utf8_name_the_file(tmp_path):
    path = tmp_path / "body.json"
    path.write_bytes(b'{"segments": [{"name": "\xe9"}]}')
    try:
        Skeleton.load(path)
    except ValueError as exc:
        assert str(exc).startswith(str(path)) and "not UTF-8 text" in str(exc)
    else:
        raise AssertionError("read")
