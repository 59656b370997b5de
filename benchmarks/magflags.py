"""How robust ``tqt``'s ``mag_disturbed`` flag behaves on real recordings: how often it is raised where the
field is the room's own, and how much of a real disturbance it covers.

``python -m benchmarks.magflags [--data DIR] [--tyrex DIR] [--out benchmarks/MAGFLAGS.md]``

Every change of the flag is a status message to the receiver, so a flag that flickers is noise.  The
truth of "disturbed" comes from the optical reference: the field measured in the sensor frame, turned
into the earth frame by the *true* orientation, has a norm, a dip and an azimuth; a sample is **truly
disturbed** where its horizontal direction is more than :data:`HARM` degrees off the room's (the median
azimuth of the trial's first 10 s with truth: :func:`truth_disturbed`) or its norm or dip is off by more
than the gate (the defaults' tolerances): where following the field would turn the heading.

For each trial: the flag's raisings (and per minute), the share of the trial flagged, of the truly
disturbed samples the share flagged (*caught*), and of the others, where the field is the room's, the
share flagged all the same (*wrong*).  Robust ``tqt`` with its defaults: its reported flag
(``MAG_DISTURBED``, with its own hysteresis) and, as the baseline, the gate the estimate runs on
(:attr:`~pointat.maths.tqt.TQTFilter.magnetometer_ignored`: what the flag was before it had a
hysteresis of its own); VQF's ``magDistDetected`` (its defaults) beside them.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from benchmarks import realdata
from pointat.maths.quaternion import quat_rotate
from pointat.maths.tqt import TQTFilter, TQTFlags

#: Degrees of field azimuth off the room's beyond which following the field would turn the heading.
HARM = 15.0
#: Norm (relative) and dip (degrees) off the room's beyond which the field is truly disturbed: the
#: defaults' gate, fixed here so that a filter with another gate is judged by the same truth.
NORM_TOL, DIP_TOL = 0.1, 15.0


def truth_disturbed(d: dict[str, np.ndarray]) -> np.ndarray:
    """Per sample: whether the field, seen through the true orientation, is off the trial's own
    undisturbed field (the median of its first 10 s with truth: the trials start in a quiet spot) by more
    than :data:`HARM` degrees of azimuth, or by more than :data:`NORM_TOL` or :data:`DIP_TOL`.  False where
    there is no truth."""
    ok = np.isfinite(d["q_gt"][:, 0])
    e = np.full(d["mag"].shape, np.nan)
    e[ok] = quat_rotate(d["q_gt"][ok], d["mag"][ok])  # sensor -> ENU
    norm = np.linalg.norm(e, axis=1)
    dip = np.degrees(np.arcsin(np.clip(-e[:, 2] / norm, -1.0, 1.0)))
    az = np.degrees(np.arctan2(e[:, 0], e[:, 1]))
    first = np.flatnonzero(ok)
    first = first[d["t"][first] < d["t"][first[0]] + 10.0]
    n0, d0 = np.median(norm[first]), np.median(dip[first])
    a0 = np.degrees(np.angle(np.mean(np.exp(1j * np.radians(az[first])))))
    off = (
        (np.abs(norm - n0) > NORM_TOL * n0)
        | (np.abs(dip - d0) > DIP_TOL)
        | (np.abs((az - a0 + 180.0) % 360.0 - 180.0) > HARM)
    )
    return off & ok


def flag_stats(flag: np.ndarray, truth: np.ndarray, dt: float) -> tuple[float, float, float, float, float]:
    """(raisings, raisings per minute, % of the trial flagged, % of the truly disturbed samples flagged,
    % of the other samples flagged).

    >>> flag = np.array([True, False, False, True, True, False])
    >>> flag_stats(flag, np.array([False, False, False, True, False, True]), 10.0)
    (2, 2.0, 50.0, 50.0, 50.0)
    """
    raised = int(np.sum(flag[1:] & ~flag[:-1]) + flag[0])
    minutes = len(flag) * dt / 60.0
    caught = 100.0 * float(np.mean(flag[truth])) if truth.any() else math.nan
    wrong = 100.0 * float(np.mean(flag[~truth])) if not truth.all() else math.nan
    return raised, raised / minutes, 100.0 * float(np.mean(flag)), caught, wrong


def run_flag_and_gate(d: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Robust ``tqt`` (defaults, compiled, one call a sample) over trial ``d``: per sample, its reported
    ``MAG_DISTURBED`` and whether its gate ignored the magnetometer (bool arrays)."""
    f = TQTFilter()
    dt = realdata.dt_of(d)
    bit = int(TQTFlags.MAG_DISTURBED)
    n = len(d["t"])
    flag, gate = np.zeros(n, bool), np.zeros(n, bool)
    for i, (g, a, m) in enumerate(zip(d["gyr"].tolist(), d["acc"].tolist(), d["mag"].tolist(), strict=True)):
        f.update(g, a, m, dt)
        flag[i] = f.flag_bits & bit != 0
        gate[i] = f.magnetometer_ignored
    return flag, gate


def _kind(path: Path) -> str:
    name = path.name
    return realdata.trial_set(path) + (
        " magnetic"
        if ("magnet" in name or "_Dist_" in name)
        else " undisturbed"
        if "undisturbed" in name or "NoDist" in name
        else " other"
    )


def report(files: list[Path]) -> str:
    lines = [
        "# The `mag_disturbed` flag on real recordings",
        "",
        f"Truly disturbed: the field seen through the optical truth more than {HARM:g}° of azimuth off the "
        "trial's first 10 s, or off in norm or dip by more than the gate (10 %, 15°).  *raised*: the "
        "flag's raisings (each one a status message, and one more when it is lowered); *flagged*: the "
        "share of the trial; *caught*: the share of the truly disturbed samples flagged; *wrong*: the "
        "share of the other samples (the field the room's) flagged.  *gate*: robust tqt's gate, what the "
        "estimate runs on (the magnetometer ignored), and what the flag was before it had a hysteresis of "
        "its own; *flag*: `MAG_DISTURBED` as the receiver is told it.  Generated by "
        "`python -m benchmarks.magflags`.",
        "",
        "| trial | truly disturbed | gate raised | flag raised | per min | flagged | caught | wrong | "
        "VQF raised | VQF flagged | VQF caught | VQF wrong |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    sums: dict[str, list[tuple[float, ...]]] = {}
    for path in files:
        d = realdata.load(path)
        dt = realdata.dt_of(d)
        truth = truth_disturbed(d)
        flag, gate = run_flag_and_gate(d)
        t, g = flag_stats(flag, truth, dt), flag_stats(gate, truth, dt)
        v: tuple[float, ...] = (math.nan,) * 5
        try:
            import vqf

            f = vqf.VQF(dt)
            out = f.updateBatch(*(np.ascontiguousarray(d[k]) for k in ("gyr", "acc", "mag")))
            v = flag_stats(np.asarray(out["magDistDetected"], bool), truth, dt)
        except ImportError:
            pass
        name = path.name.removesuffix(".csv.gz")
        sums.setdefault(_kind(path), []).append((100.0 * truth.mean(), *g, *t, *v))
        lines.append(
            f"| {name} | {100.0 * truth.mean():.1f} % | {g[0]} | {t[0]} | {t[1]:.2f} | {t[2]:.1f} % | "
            f"{t[3]:.0f} % | {t[4]:.1f} % | {v[0]:.0f} | {v[2]:.1f} % | {v[3]:.0f} % | {v[4]:.1f} % |"
        )
    lines += [
        "",
        "Means over the trials of each kind (a trial with no truly disturbed sample counts for none in "
        "*caught*):",
        "",
        "| kind of trial | trials | truly disturbed | gate raised per min | gate caught | gate wrong | "
        "flag raised per min | flag flagged | flag caught | flag wrong | VQF raised per min | VQF flagged | "
        "VQF caught | VQF wrong |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for kind, rows in sorted(sums.items()):
        a = np.nanmean(np.array(rows), axis=0)
        gate, flag, vqf_ = a[1:6], a[6:11], a[11:16]
        lines.append(
            f"| {kind} | {len(rows)} | {a[0]:.1f} % | {gate[1]:.2f} | {gate[3]:.0f} % | {gate[4]:.1f} % | "
            f"{flag[1]:.2f} | {flag[2]:.1f} % | {flag[3]:.0f} % | {flag[4]:.1f} % | "
            f"{vqf_[1]:.2f} | {vqf_[2]:.1f} % | {vqf_[3]:.0f} % | {vqf_[4]:.1f} % |"
        )
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    ap = realdata.arguments("benchmarks.magflags", __doc__, Path(__file__).with_name("MAGFLAGS.md"))
    args = ap.parse_args(argv)
    files = realdata.trials(args.data, args.tyrex)
    if not files:
        print(f"python -m benchmarks.magflags: no trials in {args.data} or {args.tyrex}", file=sys.stderr)
        return 2
    text = report(files)
    args.out.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
