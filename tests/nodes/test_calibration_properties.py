"""Property-based tests of calibration files: JSON a person edits by hand, read by ``offset``, ``scaling``
and ``calibrate`` (:func:`nodes.calibration._load`, :meth:`Calibration.load`).

Properties: any bytes, any JSON, and any valid file with one value or key changed, load or are refused
with a ``ValueError`` that names the file (and the key, where one is wrong), never another exception; a
``scaling`` node either takes the file and turns counts into finite numbers, or refuses it naming the
file once; a calibration saved and loaded again is the same, to the last bit.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from pointat.errors import PatchError
from pointat.maths.calibration import Calibration
from pointat.message import vector
from pointat.nodes.calibration import _load
from pointat.testing import patch

SETTINGS = settings(
    max_examples=80,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow],
)


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("calibration")


def write(folder, content: bytes | str) -> str:
    path = folder / "cal.json"
    if isinstance(content, str):
        path.write_text(content, encoding="utf-8")
    else:
        path.write_bytes(content)
    return str(path)


def load_or_refusal(path: str) -> Calibration | str:
    """The calibration, or the refusal's message: a ValueError naming the file; anything else fails."""
    try:
        return _load(path)
    except ValueError as exc:
        message = str(exc)
        # (what the calibration says of its contents, or what the user-file reader says of the bytes:
        # "PATH:LINE: not UTF-8 text ... expected a calibration file")
        assert message.startswith((f"calibration file {path}: ", f"{path}:")), message
        return message


# --------------------------------------------------------------------------- strategies

finite = st.floats(allow_nan=False, allow_infinity=False)
numbers = st.one_of(
    st.floats(),  # NaN and infinity are written as NaN and Infinity, which Python's json reads
    st.integers(),
    st.integers(-(10**400), 10**400),
    st.sampled_from([0, -0.0, 1e-320, 5e-324, 1e308, 2048, True, False]),
)
json_leaf = st.one_of(st.none(), numbers, st.text(max_size=10))
json_values = st.recursive(
    json_leaf,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=8), inner, max_size=4)
    ),
    max_leaves=12,
)
triples = st.lists(st.one_of(finite, st.integers(-5000, 5000)), min_size=3, max_size=3)
nonzero = st.one_of(
    st.floats(1e-300, 1e300),
    st.floats(-1e300, -1e-300),
    st.integers(1, 5000),
    st.sampled_from([5e-324, -1.7976931348623157e308]),
)
nonzero_triples = st.lists(nonzero, min_size=3, max_size=3)


@st.composite
def calibrations(draw) -> Calibration:
    kw = {}
    for sensor in ("gyro", "acc", "mag"):
        if draw(st.booleans()):
            kw[f"{sensor}_null"] = draw(triples)
        if draw(st.booleans()):
            kw[f"{sensor}_scale"] = draw(nonzero_triples)
    if draw(st.booleans()):
        kw["mag_soft_iron"] = draw(st.lists(triples, min_size=3, max_size=3))
    return Calibration(**kw)


def paths(d, prefix: str = "") -> list[tuple[list, str]]:
    """Every place in a calibration dict as (keys, the name the error messages give it)."""
    out = []
    for k, v in d.items():
        name = f"{prefix}{k}"
        out.append(([k], name))
        if isinstance(v, dict):
            out += [([k, *keys], sub) for keys, sub in paths(v, name + ".")]
    return out


# --------------------------------------------------------------------------- properties


@SETTINGS
@given(content=st.one_of(st.binary(max_size=200), st.text(max_size=200)))
@example(content=b'\xef\xbb\xbf{"version": 1}')
@example(content=b'{"version": 1} caf\xe9')
@example(content="[" * 50_000)
@example(content='{"version": 1, "acc": {"null": [' + "9" * 5000 + ", 2, 3]}}")  # past Python's 4300 digits
def test_any_bytes_load_or_are_refused_naming_the_file(folder, content):
    load_or_refusal(write(folder, content))


@SETTINGS
@given(
    data=st.one_of(
        json_values,
        st.dictionaries(st.sampled_from(["format", "version", "gyro", "acc", "mag"]), json_values),
    )
)
def test_any_json_loads_or_is_refused_naming_the_file(folder, data):
    got = load_or_refusal(write(folder, json.dumps(data)))
    if isinstance(got, Calibration):  # what loads is a calibration: finite numbers, no zero scale
        for sensor in ("gyro", "acc", "mag"):
            assert np.all(np.isfinite(getattr(got, f"{sensor}_null")))
            assert np.all(np.isfinite(getattr(got, f"{sensor}_scale")))
            assert np.all(getattr(got, f"{sensor}_scale") != 0.0)


@SETTINGS
@given(cal=calibrations(), data=st.data())
def test_a_valid_file_with_one_thing_changed_loads_or_is_refused_naming_the_key(folder, cal, data):
    d = cal.to_dict()
    keys, name = data.draw(st.sampled_from(paths(d)))
    *parents, last = keys
    parent = d
    for k in parents:
        parent = parent[k]
    how = data.draw(st.sampled_from(["value", "new key", "drop"]))
    if how == "value":
        parent[last] = data.draw(json_values)
    elif how == "new key":
        extra = data.draw(st.text(min_size=1, max_size=6).filter(lambda k: k not in parent))
        parent[extra] = data.draw(json_values)
        name = f"{name.rpartition('.')[0]}.{extra}" if parents else extra
    else:
        del parent[last]
    got = load_or_refusal(write(folder, json.dumps(d)))
    if isinstance(got, str):  # (a version dropped is named too: "got nothing (missing)")
        assert f"key '{name}" in got, (name, got)  # (mag.soft_iron[1] too)


@SETTINGS
@given(cal=calibrations())
@example(cal=Calibration(acc_null=[5e-324, -0.0, 1e308], acc_scale=[-5e-324, 1.7976931348623157e308, 1e-300]))
def test_a_calibration_saved_and_loaded_again_is_the_same(folder, cal):
    path = write(folder, b"")
    cal.save(path)
    again = _load(path)
    assert again == cal
    for sensor in ("gyro", "acc", "mag"):  # to the last bit, the sign of a zero included
        for part in ("null", "scale"):
            a, b = getattr(cal, f"{sensor}_{part}"), getattr(again, f"{sensor}_{part}")
            assert a.tobytes() == b.tobytes()
    assert Calibration.from_json(cal.to_json(indent=None)) == cal


@st.composite
def plausible_files(draw) -> str:
    """Files near what ``calibrate`` writes, each number possibly far off."""
    # half the files sensible all through (they must load and give finite numbers), half with odd numbers
    odd = (
        st.one_of(st.sampled_from([0.0, 1e-320, 1e300, -1e308]), finite)
        if draw(st.booleans())
        else st.nothing()
    )
    near = st.one_of(st.floats(2000, 2100), odd)
    # counts per unit near the nominal resolutions: gyro ~573 per rad/s, accelerometer ~52 per m/s²
    sensible = {"gyro": st.floats(300, 1000), "acc": st.floats(30, 90), "mag": st.floats(0.5, 2000)}
    d: dict = {"format": "pointat-calibration", "version": 1}
    for sensor in ("gyro", "acc", "mag"):
        if draw(st.booleans()):
            scale = st.one_of(sensible[sensor], sensible[sensor], st.just(1.0), odd)
            d[sensor] = {
                "null": draw(st.lists(near, min_size=3, max_size=3)),
                "scale": draw(st.lists(scale, min_size=3, max_size=3)),
            }
    if "mag" in d and draw(st.booleans()):
        entry = st.one_of(st.floats(-2, 2), st.sampled_from([0.0, 1e-300, 1e300, 1e308]) | odd)
        d["mag"]["soft_iron"] = draw(
            st.lists(st.lists(entry, min_size=3, max_size=3), min_size=3, max_size=3)
        )
    return json.dumps(d)


@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")  # (a determinant past 1e308)
@SETTINGS
@given(
    text=st.one_of(plausible_files(), plausible_files(), json_values.map(json.dumps), st.binary(max_size=60))
)
@example(  # a singular matrix whose determinant overflows to NaN passed the singularity check
    text=json.dumps(
        {
            "version": 1,
            "mag": {"null": [2048.0] * 3, "scale": [500.0] * 3, "soft_iron": [[1e300] * 3] * 3},
        }
    )
)
def test_scaling_takes_a_file_and_makes_finite_numbers_or_refuses_it_naming_it_once(folder, text):
    path = write(folder, text)
    try:
        rt = patch(
            f"node units scaling calibration={path}\nnode g collect\nnode a collect\nnode m collect\n"
            "units.gyro -> g\nunits.accel -> a\nunits.mag -> m\n"
        )
    except PatchError as exc:
        message = str(exc)
        assert message.count(path) == 1 and "units" in message, message
        return
    units = rt.nodes["units"]
    assert all(math.isfinite(f) and f != 0.0 for f in units.factor)
    for counts in ([0.0] * 9, [2047.0] * 9, [-2048.0] * 9, [1.0, -1.0, 0.5] * 3):
        units.receive(0, vector(counts))
    values = [v for n in "gam" for v in rt.nodes[n].values]
    assert values and all(math.isfinite(x) for v in values for x in v), values
    rt.shutdown()
