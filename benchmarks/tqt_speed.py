"""Robust ``tqt``'s update against its peers, side by side in one run: one sensor a call, and many at once.

``nice -n 10 python -m benchmarks.tqt_speed [--data FILE] [--rounds 15] [--out benchmarks/TQT_SPEED.md]``

Every contestant updates on the same stretch of a BROAD trial (motion, 286 Hz), its inputs prepared
beforehand in its library's own format, and the rounds are interleaved (round 1 of each, then round 2 of
each...), so that what else the machine does falls on all alike.  Each figure is the median of the
rounds with their interquartile range.

* **One sensor a call** (issue 46's goal: at most 1.5 x imufusion): ``TQTFilter.update`` (robust, the
  compiled step; and the same step in Python), imufusion's ``Ahrs.update`` + ``get_quaternion`` and
  VQF's ``update`` + ``getQuat9D``, each called once a sample from Python, as a live patch calls them.
* **Many sensors** (the goal: ``TQTBank`` at most BasicVQF's ``updateBatch`` per sensor-sample):
  ``TQTBank.update`` over 15 sensors a call (a batch across sensors, one call a sample), beside VQF's and
  BasicVQF's ``updateBatch`` (one call for the whole stretch, run 15 times over: a batch across time, its
  loop in C++), the bank's compiled loop called directly (what the bank costs without its Python
  shell), and ``TQTBank.update_batch`` (the whole stretch of 15 sensors in one call: like with like).
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from benchmarks.throughput import imufusion_loop, package_version
from pointat.maths.evaluation import BROAD_RATE, BROAD_SAMPLE, load_broad
from pointat.maths.tqt import TQTBank, TQTFilter
from pointat.maths.tqt import compiled as tqt_compiled

SENSORS = 15
START, SAMPLES = 20000, 5000  # the vendored trial's fastest stretch (motion throughout)


def contestants(d: dict[str, np.ndarray]) -> list[tuple[str, str, Callable[[], None], int]]:
    """(group, name, one round, items a round): the round's time over its items is the figure."""
    import vqf

    g, a, m = (np.ascontiguousarray(d[k][START : START + SAMPLES]) for k in ("gyr", "acc", "mag"))
    n, dt = len(g), 1.0 / BROAD_RATE
    gl, al, ml = g.tolist(), a.tolist(), m.tolist()
    out: list[tuple[str, str, Callable[[], None], int]] = []

    def filt(backend: str) -> Callable[[], None]:
        def run() -> None:
            upd = TQTFilter(backend=backend).update
            for i in range(n):
                upd(gl[i], al[i], ml[i], dt)

        return run

    fusion = imufusion_loop(g, a, m, n)

    def vqf_loop() -> None:
        f = vqf.VQF(dt)
        upd, get = f.update, f.getQuat9D
        for i in range(n):
            upd(g[i], a[i], m[i])
            get()

    one = "one sensor a call"
    out += [
        (one, "TQTFilter robust (compiled step)", filt("numba"), n),
        (one, "TQTFilter robust (the step in Python)", filt("python"), n),
        (one, f"imufusion {package_version('imufusion')} Ahrs update + get_quaternion", fusion, n),
        (one, f"vqf {package_version('vqf')} VQF update + getQuat9D", vqf_loop, n),
    ]
    G, A, M = (np.ascontiguousarray(np.repeat(x[:, None, :], SENSORS, 1)) for x in (g, a, m))

    def bank() -> None:
        b = TQTBank(SENSORS, backend="numba")
        upd = b.update
        for i in range(n):
            upd(G[i], A[i], M[i], dt)

    def bank_batch() -> None:
        TQTBank(SENSORS, backend="numba").update_batch(G, A, M, dt)

    kernel = tqt_compiled.bank_kernel()

    def bank_kernel() -> None:
        b = TQTBank(SENSORS, backend="numba")
        s, p, flags, here = b._s, b._p, b._flags, np.ones(SENSORS, dtype=bool)
        for i in range(n):
            kernel(G[i], A[i], M[i], dt, here, s, p, flags)

    # the batches run the stretch SENSORS times over (one sensor's), so that every round of the group
    # does as many sensor-samples and lasts about as long: on a shared machine a longer round is the
    # likelier to be interrupted
    gt, at, mt = (np.ascontiguousarray(np.tile(x, (SENSORS, 1))) for x in (g, a, m))

    def batch(cls: type) -> Callable[[], None]:
        return lambda: cls(dt).updateBatch(gt, at, mt)

    many = "many sensors"
    out += [
        (many, f"TQTBank.update, {SENSORS} sensors a call", bank, n * SENSORS),
        (many, "  its compiled loop alone (no Python shell)", bank_kernel, n * SENSORS),
        (many, f"TQTBank.update_batch, {SENSORS} sensors, the whole stretch a call", bank_batch, n * SENSORS),
        (many, "VQF updateBatch (the whole stretch a call)", batch(vqf.VQF), n * SENSORS),
        (many, "BasicVQF updateBatch (the whole stretch a call)", batch(vqf.BasicVQF), n * SENSORS),
    ]
    return out


def measure(rounds: int, d: dict[str, np.ndarray]) -> list[tuple[str, str, list[float]]]:
    """µs per item of every round of every contestant, the rounds interleaved (one warm-up first)."""
    runs = contestants(d)
    times: list[list[float]] = [[] for _ in runs]
    for r in range(rounds + 1):
        for (_, _, fn, items), each in zip(runs, times, strict=True):
            t0 = time.perf_counter()
            fn()
            if r:  # the first round warms caches and compiles: not counted
                each.append(1e6 * (time.perf_counter() - t0) / items)
    return [(group, name, each) for (group, name, _, _), each in zip(runs, times, strict=True)]


def table(results: list[tuple[str, str, list[float]]]) -> str:
    """A Markdown table: median and interquartile range, and the ratio to the group's goal."""
    goals = {"one sensor a call": "imufusion", "many sensors": "BasicVQF"}
    med = {name: statistics.median(us) for _, name, us in results}
    lines = [
        "| calls | contestant | µs per sensor-sample, median | IQR | × the goal's peer |",
        "|---|---|---|---|---|",
    ]
    for group, name, us in results:
        q1, _, q3 = statistics.quantiles(us, n=4)
        peer = next(v for k, v in med.items() if goals[group] in k and "TQT" not in k)
        lines.append(f"| {group} | {name} | {med[name]:.3f} | {q1:.3f}–{q3:.3f} | {med[name] / peer:.2f} |")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.tqt_speed", description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=None, help="a BROAD trial (default: the vendored one)")
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--out", type=Path, default=None, help="write the table there too")
    args = ap.parse_args(argv)
    d = load_broad(args.data or BROAD_SAMPLE)
    text = table(measure(args.rounds, d))
    print(text)
    if args.out:
        args.out.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
