"""Robust ``tqt``'s saturation rules on real recordings they were not made on: BROAD, clipped by hand.

``python -m benchmarks.clipping [--data DIR] [--out benchmarks/CLIPPING.md]``

The rules for a sensor at its full scale (``acc_range``, ``gyro_range``; :mod:`pointat.maths.tqt.step`)
were designed on the simulated glove's strokes.  Here every BROAD trial (real hands, optical truth) is
clipped as a sensor of a smaller range would clip it, accelerometer at ±2, 3 and 4 g (the glove's is 4 g),
gyro at ±300 and 500 °/s, and run three ways: the filter told the full scale (``known``), not told
(``unknown``: the clipped readings taken as they are), and VQF with its defaults on the same clipped
data.  Total RMSE in degrees, the data set's metric; the unclipped run beside them.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from multiprocessing import Pool
from pathlib import Path

import numpy as np

from benchmarks.accuracy import _tqt, _vqf_params
from benchmarks.loo import table_main
from pointat.maths.evaluation import broad_rmse, load_broad

G = 9.80665
ACC_CLIPS_G = (2.0, 3.0, 4.0)
GYRO_CLIPS_DPS = (300.0, 500.0)


def _rmse(d: dict[str, np.ndarray], q: np.ndarray) -> float:
    return broad_rmse(q, d["q_gt"], d["movement"])[0]


def _trial(job: tuple[str, str, float]) -> tuple[str, str, float, float, float, float, float, float]:
    """(trial, sensor, clip, share of samples clipped, unclipped, unknown, known, VQF)."""
    path, sensor, clip = job
    d = load_broad(path)
    key, r, name = (
        ("acc", clip * G, "acc_range") if sensor == "acc" else ("gyr", math.radians(clip), "gyro_range")
    )
    clipped = dict(d, **{key: np.clip(d[key], -r, r)})
    share = float(np.mean(np.any(np.abs(d[key]) >= r, axis=1)))
    try:
        vqf = _rmse(d, _vqf_params()(clipped))
    except ImportError:
        vqf = math.nan
    return (
        Path(path).name[:2],
        sensor,
        clip,
        share,
        _rmse(d, _tqt("robust")(d)),
        _rmse(d, _tqt("robust")(clipped)),
        _rmse(d, _tqt("robust", **{name: r})(clipped)),
        vqf,
    )


def report(files: list[Path], workers: int) -> str:
    jobs = [(str(f), "acc", c) for c in ACC_CLIPS_G for f in files]
    jobs += [(str(f), "gyro", c) for c in GYRO_CLIPS_DPS for f in files]
    with Pool(workers) as pool:
        rows = pool.map(_trial, jobs)
    lines = ["# Saturation on real recordings: BROAD clipped by hand", ""]
    for sensor, unit in (("acc", "g"), ("gyro", "°/s")):
        lines += [
            f"## {'Accelerometer' if sensor == 'acc' else 'Gyro'} clipped",
            "",
            f"| trial | clip ({unit}) | samples clipped | unclipped | unknown | known | VQF clipped |",
            "|---|---|---|---|---|---|---|",
        ]
        mine = [r for r in rows if r[1] == sensor]
        for r in mine:
            lines.append(
                f"| {r[0]} | {r[2]:g} | {100 * r[3]:.1f} % | {r[4]:.2f} | {r[5]:.2f} | {r[6]:.2f} | {r[7]:.2f} |"
            )
        for clip in sorted({r[2] for r in mine}):
            sel = [r for r in mine if r[2] == clip]
            better = sum(r[6] < r[5] - 0.005 for r in sel)
            worse = sum(r[6] > r[5] + 0.005 for r in sel)
            lines.append(
                f"| **mean** | {clip:g} | | {np.mean([r[4] for r in sel]):.2f} | {np.mean([r[5] for r in sel]):.2f} "
                f"| {np.mean([r[6] for r in sel]):.2f} (better {better}, worse {worse}) "
                f"| {np.mean([r[7] for r in sel]):.2f} |"
            )
        lines.append("")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    return table_main(argv, "clipping", __doc__, "CLIPPING.md", 1, report)


if __name__ == "__main__":
    sys.exit(main())
