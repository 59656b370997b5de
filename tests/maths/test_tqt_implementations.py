"""Every implementation of the TQT update gives the quaternions and flags of Python's TQTFilter, to the bit.

The step is written once (:mod:`pointat.maths.tqt.step`; paper mode's in :mod:`pointat.maths.tqt.paper`)
and runs in eight implementations, each held here to the reference, one ``TQTFilter(backend="python")`` per
sensor fed lists of floats (the step in plain Python):

* ``TQTFilter-python`` -- the same class again, fed numpy rows (its other input path), sharing nothing
  with the reference's run;
* ``TQTFilter-numba`` -- the robust step compiled by numba, one call a sample
  (:func:`pointat.maths.tqt.step.robust_update`; what a filter runs by default; robust mode only);
* ``TQTBank-python`` -- the same step on the rows of a state array, a Python loop over the sensors;
* ``TQTBank-numba`` -- the robust step compiled by numba into one loop (:mod:`pointat.maths.tqt.compiled`;
  robust mode only);
* ``TQTBank-batch-python`` / ``TQTBank-batch-numba`` -- the bank's ``update_batch``, a whole case in
  one call (numba: one compiled loop over the samples and the sensors, robust mode only);
* ``tqt-node`` / ``tqt_bank-node`` -- the nodes that wrap a filter and a bank in a patch (readings as
  messages, the time step from their stamps, settings in the nodes' units: dip in degrees, full scales
  in g and deg/s); both run the compiled step in robust mode, as a patch's ``backend=auto`` does.

Each case runs every implementation that exists for its mode, several sensors at once (a bank's sensors,
or one filter or node each), and asserts that the quaternion and the flag bits of every sensor at every
sample, and the gyro biases learned, are *equal* to the reference's.  No tolerance is granted because
none is needed: the same operations on the same doubles give the same bits, compiled or not (numba,
without ``fastmath``, neither reorders float arithmetic nor fuses it into FMAs, and its ``exp``, ``sin``,
``atan2``... are the C library's, as CPython's are).  Measured: every case below equal to the last bit
(x86-64, numba 0.68); the kernel compiled with ``fastmath`` instead differs from the first BROAD sample
on, by up to 7e-15, which a tolerance of 1e-12 would let through.  A node puts out a quaternion only
once its filter is initialised, and nothing before.

The cases: three slices of the vendored BROAD trial (rest into motion, the fastest motion, motion into
rest: 3 x 3000 samples at 286 Hz); the 18 strokes and shakes of ``test_tqt_strokes.py``, ideal and with
the accelerometer clipped at ±4 g (its full scale given); the demo's rolls through a gyro clipped at
90 °/s (its full scale given); five sensors of synthetic motion with dropped, zeroed and corrupt
readings and a late start (paper mode also with 3 iterations and rho = 1.5; robust also without a gyro);
and four sensors started from a known orientation (the classes only: a node starts from its first valid
sample).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pytest

from pointat.devices.glove_sim import Burst
from pointat.maths.calibration import STANDARD_GRAVITY
from pointat.maths.evaluation import BROAD_RATE, BROAD_SAMPLE, load_broad
from pointat.maths.quaternion import quat_from_axis_angle
from pointat.maths.tqt import TQTBank, TQTFilter
from pointat.message import floats
from pointat.testing import patch
from tests.maths.test_tqt import DIP, FIELD, G, synthetic
from tests.maths.test_tqt_strokes import BURSTS, RANGE, RATE, START, readings


@dataclass(frozen=True)
class Case:
    """Readings of ``n`` sensors, ``gyro``, ``acc``, ``mag`` of shape (samples, n, 3), at ``rate`` Hz."""

    gyro: np.ndarray
    acc: np.ndarray
    mag: np.ndarray
    rate: float
    settings: dict = field(default_factory=dict)  # TQTFilter's keywords, SI units
    start: np.ndarray | None = None  # one known orientation for all, or each starts from its TRIAD

    @property
    def n(self) -> int:
        return self.gyro.shape[1]


@dataclass
class Run:
    q: np.ndarray  # (samples, n, 4); NaN where nothing was put out (a node before its filter started)
    flags: np.ndarray  # (samples, n) int
    bias: np.ndarray  # (n, 3) at the end
    initialised: np.ndarray | None = None  # (samples, n) bool, the reference's: when a node puts out


# --------------------------------------------------------------------------------------------------------
# The cases
# --------------------------------------------------------------------------------------------------------

BROAD_SLICES = (7000, 20000, 44000)  # rest into motion at 9655, the fastest (5.7 rad/s), rest from 45662
BROAD_SAMPLES = 3000


@functools.cache
def broad() -> Case:
    trial = load_broad(BROAD_SAMPLE)
    take = [slice(s, s + BROAD_SAMPLES) for s in BROAD_SLICES]
    g, a, m = (np.stack([trial[k][s] for s in take], axis=1) for k in ("gyr", "acc", "mag"))
    return Case(g, a, m, BROAD_RATE)


@functools.cache
def burst_readings() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gyro, accelerometer and magnetometer of one sensor per burst of ``test_tqt_strokes.py``, ideal."""
    runs = []
    for kind, axis, peak in BURSTS:
        burst = Burst(START, 6.0, peak_g=peak, rate=5.0 if kind == "strokes" else 3.0, axis=axis, kind=kind)
        runs.append(readings([burst], START + burst.length + 3.0, noise=False)[1:])
    g, a, m = (np.stack([r[k] for r in runs], axis=1) for k in range(3))
    return g, a, m


def bursts(clipped: bool) -> Case:
    """The bursts; clipped: at the glove's ±4 g, the filter told its full scale."""
    g, a, m = burst_readings()
    if clipped:
        return Case(g, np.clip(a, -RANGE, RANGE), m, RATE, {"acc_range": RANGE})
    return Case(g, a, m, RATE)


@functools.cache
def gyro_clipped() -> Case:
    """The demo's 90° rolls (141 °/s) through a gyro that clips at 90 °/s, its full scale given (as
    ``test_a_saturated_gyro_is_flagged_and_changes_nothing_else``)."""
    _, g, a, m = readings([], 41.0, noise=False)
    r = math.radians(90.0)
    return Case(np.clip(g, -r, r)[:, None], a[:, None], m[:, None], RATE, {"gyro_range": r})


@functools.cache
def glitches(**settings) -> Case:
    """Five sensors, each its own motion, with dropped / zeroed channels and a late start."""
    n = 5
    rng = np.random.default_rng(12)
    runs = [
        synthetic(seed=s, seconds=15.0, rest=2.0 + s, noise=True, bias=rng.normal(0, 0.01, 3))
        for s in range(n)
    ]
    gyro, acc, mag = (np.stack([r[k] for r in runs], axis=1) for k in (2, 3, 4))
    for arr in (gyro, acc, mag):
        for fill in (np.nan, 0.0):
            idx, who = rng.integers(0, len(arr), 100), rng.integers(0, n, 100)
            arr[idx, who] = fill
    idx, who = rng.integers(0, len(gyro), 50), rng.integers(0, n, 50)
    gyro[idx, who] = 1e30  # glitches beyond MAX_RATE: refused by every sensor's filter alike
    idx, who = rng.integers(100, len(acc), 50), rng.integers(0, n, 50)
    acc[idx, who] *= rng.choice([5.0, 1e3, 1e30], 50)[:, None]  # beyond ACC_LIMIT x the first: refused alike
    acc[0, 3] *= 0.01  # a first reading far too small: gravity refused, then the limit learned again
    acc[:30, 2] = np.nan  # sensor 2 starts late
    return Case(gyro, acc, mag, 100.0, settings)  # synthetic()'s rate


@functools.cache
def known_start() -> Case:
    """Four sensors started at one orientation, noisy readings of rest about it."""
    rng = np.random.default_rng(3)
    g, a, m = [], [], []
    for _ in range(300):  # (drawn in this order: the readings the bank tests have always had)
        g.append(rng.normal(0.0, 0.3, (4, 3)))
        a.append(np.tile([0.0, 0.0, G], (4, 1)) + rng.normal(0.0, 0.2, (4, 3)))
        m.append(np.tile(FIELD, (4, 1)) + rng.normal(0.0, 0.02, (4, 3)))
    return Case(
        np.array(g), np.array(a), np.array(m), 100.0, start=quat_from_axis_angle([0.3, -0.2, 0.9], 0.7)
    )


CASES: dict[str, Callable[[], Case]] = {
    "broad": broad,
    "bursts_ideal": lambda: bursts(False),
    "bursts_clipped_4g": lambda: bursts(True),
    "gyro_clipped_90dps": gyro_clipped,
    "glitches": glitches,
    "glitches_no_gyro": lambda: glitches(use_gyro=False, dip=DIP),
    "glitches_3_iterations": lambda: glitches(iterations=3, rho=1.5),
    "known_start": known_start,
}
#: (case, mode) pairs run.  Iterations and rho mean something in paper mode only; paper mode has no
#: saturation or shaking rules for the bursts to exercise (which are most of the file's time), so its
#: step runs on BROAD and through the glitches.
RUNS = [
    *((name, "robust") for name in CASES if name != "glitches_3_iterations"),
    *((name, "paper") for name in ("broad", "glitches", "glitches_3_iterations")),
]


# --------------------------------------------------------------------------------------------------------
# The implementations
# --------------------------------------------------------------------------------------------------------


def run_filters(case: Case, mode: str, *, rows: bool = False, backend: str = "python") -> Run:
    """The reference: one TQTFilter a sensor, fed lists of floats (``rows``: numpy rows instead)."""
    filters = [TQTFilter(mode=mode, backend=backend, **case.settings) for _ in range(case.n)]
    assert all(f.backend == backend for f in filters)
    if case.start is not None:
        for f in filters:
            f.reset(case.start)
    dt = 1.0 / case.rate
    g, a, m = (
        (case.gyro, case.acc, case.mag)
        if rows
        else (case.gyro.tolist(), case.acc.tolist(), case.mag.tolist())
    )
    q = np.empty(case.gyro.shape[:2] + (4,))
    flags = np.empty(case.gyro.shape[:2], dtype=np.int64)
    initialised = np.empty(case.gyro.shape[:2], dtype=bool)
    for i in range(len(g)):
        for j, f in enumerate(filters):
            q[i, j] = f.update(g[i][j], a[i][j], m[i][j], dt)
            flags[i, j] = f.flag_bits
            initialised[i, j] = f.initialised
    return Run(q, flags, np.array([f.bias for f in filters]), initialised)


def run_bank(case: Case, mode: str, backend: str) -> Run:
    bank = TQTBank(case.n, mode=mode, backend=backend, **case.settings)
    assert bank.backend == backend
    if case.start is not None:
        bank.reset(case.start)
    dt = 1.0 / case.rate
    q = np.empty(case.gyro.shape[:2] + (4,))
    flags = np.empty(case.gyro.shape[:2], dtype=np.int64)
    for i in range(len(case.gyro)):
        q[i] = bank.update(case.gyro[i], case.acc[i], case.mag[i], dt)
        flags[i] = bank.flags
    return Run(q, flags, bank.bias)


def run_bank_batch(case: Case, mode: str, backend: str) -> Run:
    """The bank's :meth:`~pointat.maths.tqt.TQTBank.update_batch`: the whole case in one call, its time
    steps as an array (one per sample), after a first block of one sample (a recording replayed in
    pieces continues where the last piece stopped)."""
    bank = TQTBank(case.n, mode=mode, backend=backend, **case.settings)
    assert bank.backend == backend
    if case.start is not None:
        bank.reset(case.start)
    dt = np.full(len(case.gyro), 1.0 / case.rate)
    q0, f0 = bank.update_batch(case.gyro[:1], case.acc[:1], case.mag[:1], dt[0])
    q, flags = bank.update_batch(case.gyro[1:], case.acc[1:], case.mag[1:], dt[1:])
    np.testing.assert_array_equal(bank.flags, flags[-1])
    return Run(np.concatenate([q0, q]), np.concatenate([f0, flags]), bank.bias)


def node_settings(case: Case, mode: str) -> str:
    """The case's settings as a ``tqt`` / ``tqt_bank`` node's parameters, in the node's units; each must
    come back to the very float the filter gets (or the comparison would be of different filters)."""
    words = [f"mode={mode}", f"rate={case.rate!r}"]
    units = {"dip": math.degrees, "acc_range": lambda x: x / STANDARD_GRAVITY, "gyro_range": math.degrees}
    back = {"dip": math.radians, "acc_range": lambda x: x * STANDARD_GRAVITY, "gyro_range": math.radians}
    for name, value in case.settings.items():
        if name in units:
            value = units[name](value)
            assert back[name](value) == case.settings[name], (name, "does not round-trip through the node")
        words.append(f"{name}={str(value).lower()}")  # (a bool as the patch language spells it)
    return " ".join(words)


def feed(case: Case, sensor: Callable[[int, int, float], None], tick_done: Callable[[int], None]) -> None:
    """Each sample of each sensor as messages stamped with sensor time: mag, accel, then the hot gyro."""
    for i in range(len(case.gyro)):
        t = i / case.rate
        for j in range(case.n):
            sensor(i, j, t)
        tick_done(i)


def run_tqt_nodes(case: Case, mode: str, started) -> Run:
    """One ``tqt`` node a sensor."""
    words = node_settings(case, mode)
    rt = started(
        patch("".join(f"node f{j} tqt {words}\nnode o{j} collect\nf{j} -> o{j}\n" for j in range(case.n)))
    )
    nodes = [rt.nodes[f"f{j}"] for j in range(case.n)]
    outs = [rt.nodes[f"o{j}"].messages for j in range(case.n)]
    q = np.full(case.gyro.shape[:2] + (4,), np.nan)
    flags = np.empty(case.gyro.shape[:2], dtype=np.int64)
    g, a, m = case.gyro.tolist(), case.acc.tolist(), case.mag.tolist()

    def sensor(i: int, j: int, t: float) -> None:
        node, before = nodes[j], len(outs[j])
        node.receive(2, floats(tuple(m[i][j]), t))
        node.receive(1, floats(tuple(a[i][j]), t))
        node.receive(0, floats(tuple(g[i][j]), t))
        flags[i, j] = node.filter.flag_bits
        if len(outs[j]) > before:
            q[i, j] = outs[j][-1].value

    feed(case, sensor, lambda i: None)
    return Run(q, flags, np.array([node.filter.bias for node in nodes]))


def run_tqt_bank_node(case: Case, mode: str, started) -> Run:
    """One ``tqt_bank`` node for all the sensors (``backend=auto``: numba in robust mode)."""
    text = f"node bank tqt_bank sensors={case.n} {node_settings(case, mode)}\n"
    text += "".join(f"node o{j} collect\nbank.quat{j + 1} -> o{j}\n" for j in range(case.n))
    rt = started(patch(text))
    bank = rt.nodes["bank"]
    outs = [rt.nodes[f"o{j}"].messages for j in range(case.n)]
    q = np.full(case.gyro.shape[:2] + (4,), np.nan)
    flags = np.empty(case.gyro.shape[:2], dtype=np.int64)
    g, a, m = case.gyro.tolist(), case.acc.tolist(), case.mag.tolist()
    counts = [0] * case.n

    def sensor(i: int, j: int, t: float) -> None:
        inlet = 1 + 3 * j  # inlet 0 is range
        bank.receive(inlet + 2, floats(tuple(m[i][j]), t))
        bank.receive(inlet + 1, floats(tuple(a[i][j]), t))
        bank.receive(inlet, floats(tuple(g[i][j]), t))

    def tick_done(i: int) -> None:  # the last sensor's gyro completed the tick: all were updated
        flags[i] = bank.bank.flags
        for j in range(case.n):
            if len(outs[j]) > counts[j]:
                counts[j] = len(outs[j])
                q[i, j] = outs[j][-1].value

    feed(case, sensor, tick_done)
    return Run(q, flags, bank.bank.bias)


IMPLEMENTATIONS: dict[str, Callable[[Case, str, object], Run]] = {
    "TQTFilter-python": lambda case, mode, started: run_filters(case, mode, rows=True),
    "TQTFilter-numba": lambda case, mode, started: run_filters(case, mode, backend="numba"),
    "TQTBank-python": lambda case, mode, started: run_bank(case, mode, "python"),
    "TQTBank-numba": lambda case, mode, started: run_bank(case, mode, "numba"),
    "TQTBank-batch-python": lambda case, mode, started: run_bank_batch(case, mode, "python"),
    "TQTBank-batch-numba": lambda case, mode, started: run_bank_batch(case, mode, "numba"),
    "tqt-node": run_tqt_nodes,
    "tqt_bank-node": run_tqt_bank_node,
}


def implementations() -> list:
    """Every (case, mode, implementation) that exists: numba runs robust mode only, a node cannot be
    started from a known orientation."""
    out = []
    for name, mode in RUNS:
        for impl in IMPLEMENTATIONS:
            if impl.endswith("numba") and mode != "robust":
                continue
            if impl.endswith("node") and name == "known_start":
                continue
            out.append(pytest.param(name, mode, impl, id=f"{name}-{mode}-{impl}"))
    return out


@functools.cache
def reference(name: str, mode: str) -> Run:
    ref = run_filters(CASES[name](), mode)
    assert np.isfinite(ref.q).all()
    return ref


@pytest.mark.parametrize(("name", "mode", "impl"), implementations())
def test_every_implementation_gives_the_filters_bits(name, mode, impl, started):
    case, want = CASES[name](), reference(name, mode)
    got = IMPLEMENTATIONS[impl](case, mode, started)
    out = ~np.isnan(got.q[..., 0])  # where a quaternion was put out
    if impl.endswith("node"):  # nothing before the filter started, the filter's quaternion from then on
        np.testing.assert_array_equal(out, want.initialised)
    else:
        assert out.all()
    for j in range(case.n):  # the first sample that differs, if any, sensor by sensor
        at = np.flatnonzero(out[:, j])
        bad = at[(got.q[at, j] != want.q[at, j]).any(axis=-1)]
        assert not bad.size, f"sensor {j}: {got.q[bad[0], j]} != {want.q[bad[0], j]} at sample {bad[0]}"
        bad = np.flatnonzero(got.flags[:, j] != want.flags[:, j])
        assert not bad.size, (
            f"sensor {j}: flags {got.flags[bad[0], j]} != {want.flags[bad[0], j]} at {bad[0]}"
        )
    np.testing.assert_array_equal(got.bias, want.bias)
