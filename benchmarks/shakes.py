"""Strikes and shakes with known truth: robust ``tqt`` beside VQF on the simulated glove.

``python -m benchmarks.shakes [--out benchmarks/SHAKES.md]``

The simulated hand (:class:`pointat.devices.glove_sim.GloveSimulator`, its demo script: slow pointing
sweeps) makes one 6 s burst from t = 10 s: percussive strokes (5 per second, a sharp impact each) or a
shake (3 cycles per second), vertical or along the pointing axis, peaking at 3, 10 or 15 g.  The
readings carry white noise and a gyro bias of about half a degree per second (a glove that has hardly
rested).  Each case runs with ideal sensors and with the accelerometer clipped at the glove's ±4 g:
``tqt`` told the full scale (``known``; with ideal sensors there is none to tell), ``tqt`` not told,
and VQF with its defaults (9D, ENU, compared with the truth turned to ENU).  The error is the angle
between the estimate and the truth (degrees): the worst during the burst, 1 s and 10 s after it ends,
and the same instants of the same run without a burst (what the noise and bias alone give).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from pointat.devices.glove_sim import GRAVITY, Burst, GloveSimulator
from pointat.maths.quaternion import nwu_to_enu
from pointat.maths.tqt import TQTFilter

RATE = 100.0
START, LENGTH, AFTER = 10.0, 6.0, 12.0
RANGE = 4.0 * GRAVITY  # the glove's accelerometer, per axis
CASES = [
    (kind, axis, peak)
    for kind in ("strokes", "shake")
    for axis in ("vertical", "pointing")
    for peak in (3.0, 10.0, 15.0)
]


def readings(
    burst: Burst | None, seed: int = 0, noise: bool = True, after: float = AFTER
) -> tuple[np.ndarray, ...]:
    """Truth (sensor -> NWU) and readings (rad/s, m/s², gauss), as tests/maths/test_tqt_strokes.py."""
    sim = GloveSimulator(rate_hz=RATE, seed=seed, bursts=[burst] if burst else [])
    truth = [sim.truth(k) for k in range(int((START + LENGTH + after) * RATE))]
    q = np.array([t.q for t in truth])
    g, a, m = (np.array([getattr(t, n) for t in truth]) for n in ("omega", "specific_force", "field"))
    if not noise:
        return q, g, a, m
    rng = np.random.default_rng(seed)
    g = g + np.radians([0.5, -0.3, 0.2]) + rng.normal(0.0, math.radians(0.3), g.shape)
    a = a + rng.normal(0.0, 0.02, a.shape)
    m = m + rng.normal(0.0, 0.002, m.shape)
    return q, g, a, m


def _burst(kind: str, axis: str, peak: float) -> Burst:
    return Burst(START, LENGTH, peak_g=peak, rate=5.0 if kind == "strokes" else 3.0, axis=axis, kind=kind)


#: The cases of the strike claim (tests/maths/test_tqt_strokes.py): every burst, on three axes.
CLAIM_CASES = [
    (kind, axis, peak)
    for kind, _, peak in CASES[:3] + CASES[6:9]
    for axis in ("vertical", "pointing", "both")
]
_claim: dict[tuple[str, str, float], tuple[np.ndarray, ...]] = {}


def claim_error(**settings: float) -> float:
    """The strike claim's figure for robust ``tqt`` with ``settings``: the largest error (degrees) 1 s
    after any burst up to 15 g, noise-free sensors, ideal or clipped at ±4 g (full scale given)."""
    worst = 0.0
    i = int((START + LENGTH + 1.0) * RATE)
    for case in CLAIM_CASES:
        if case not in _claim:
            _claim[case] = readings(_burst(*case), noise=False, after=1.5)
        q, g, a, m = _claim[case]
        for acc_range in (0.0, RANGE):
            f = TQTFilter(acc_range=acc_range, **settings)
            gl, al, ml = g.tolist(), (np.clip(a, -RANGE, RANGE) if acc_range else a).tolist(), m.tolist()
            for j in range(i + 1):
                est = f.update(gl[j], al[j], ml[j], 1.0 / RATE)
            worst = max(worst, float(_angle(np.array([est]), q[i : i + 1])[0]))
    return worst


def _angle(q_est: np.ndarray, q: np.ndarray) -> np.ndarray:
    return np.degrees(2.0 * np.arccos(np.clip(np.abs(np.sum(q_est * q, axis=1)), 0.0, 1.0)))


def errors(q: np.ndarray, g: np.ndarray, a: np.ndarray, m: np.ndarray) -> dict[str, np.ndarray | None]:
    """Per-sample error of each filter (None: VQF not installed)."""
    out: dict[str, np.ndarray | None] = {}
    for name, acc_range in (("known", RANGE), ("unknown", 0.0)):
        f = TQTFilter(acc_range=acc_range)
        gl, al, ml = g.tolist(), a.tolist(), m.tolist()
        est = np.array([f.update(gl[i], al[i], ml[i], 1.0 / RATE) for i in range(len(gl))])
        out[name] = _angle(est, q)
    try:
        import vqf
    except ImportError:
        out["vqf"] = None
    else:
        v = vqf.VQF(1.0 / RATE)
        est = v.updateBatch(*(np.ascontiguousarray(x) for x in (g, a, m)))["quat9D"]
        out["vqf"] = _angle(est, nwu_to_enu(q))
    return out


def _at(e: np.ndarray | None) -> tuple[float, float, float]:
    """(worst during, 1 s after, 10 s after)."""
    if e is None:
        return (math.nan, math.nan, math.nan)
    i0, i1 = int(START * RATE), int((START + LENGTH) * RATE)
    return (float(e[i0:i1].max()), float(e[i1 + int(RATE)]), float(e[i1 + int(10 * RATE)]))


def _cell(v: tuple[float, float, float]) -> str:
    return " / ".join("–" if math.isnan(x) else f"{x:.1f}" for x in v)


def report() -> str:
    t0 = time.perf_counter()
    quiet = errors(*readings(None))
    rows = []
    for kind, axis, peak in CASES:
        burst = Burst(
            START, LENGTH, peak_g=peak, rate=5.0 if kind == "strokes" else 3.0, axis=axis, kind=kind
        )
        q, g, a, m = readings(burst)
        for clipped in (False, True):
            e = errors(q, g, np.clip(a, -RANGE, RANGE) if clipped else a, m)
            rows.append((kind, axis, peak, clipped, e))
    lines = [
        "# Strikes and shakes, simulated with known truth: robust tqt beside VQF",
        "",
        __doc__.split("\n\n", 2)[2].strip(),
        "",
        "Each cell: worst during the burst / 1 s after / 10 s after, degrees.  Without a burst the same "
        f"instants give tqt {_cell(_at(quiet['unknown']))}, VQF {_cell(_at(quiet['vqf']))}.",
        "",
        "| burst | axis | peak (g) | accelerometer | tqt, full scale known | tqt, not told | VQF defaults |",
        "|---|---|---|---|---|---|---|",
    ]
    worst = {"known": [], "unknown": [], "vqf": []}
    for kind, axis, peak, clipped, e in rows:
        known = _at(e["known"]) if clipped else None
        cells = [_cell(known) if known else "(as not told)", _cell(_at(e["unknown"])), _cell(_at(e["vqf"]))]
        lines.append(
            f"| {kind} | {axis} | {peak:g} | {'clipped ±4 g' if clipped else 'ideal'} | "
            + " | ".join(cells)
            + " |"
        )
        for name in worst:
            v = _at(e[name]) if (name != "known" or clipped) else _at(e["unknown"])
            worst[name].append(v)
    lines += [
        "",
        "| over every case | tqt, full scale known (or ideal) | tqt, not told | VQF defaults |",
        "|---|---|---|---|",
    ]
    for label, j in (("worst during", 0), ("worst 1 s after", 1), ("worst 10 s after", 2)):
        lines.append(
            f"| {label} | "
            + " | ".join(
                "–" if not v or math.isnan(v[0][j]) else f"{max(x[j] for x in v):.1f}" for v in worst.values()
            )
            + " |"
        )
    lines += ["", f"Computed in {time.perf_counter() - t0:.0f} s."]
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.shakes", description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=Path(__file__).with_name("SHAKES.md"))
    args = ap.parse_args(argv)
    text = report()
    args.out.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
