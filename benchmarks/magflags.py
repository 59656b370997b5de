"""How robust ``tqt``'s ``mag_disturbed`` flag behaves on real recordings: how often it is raised where the
field is the room's own, and how much of a real disturbance it covers.

``python -m benchmarks.magflags [--data DIR] [--tyrex DIR] [--out benchmarks/MAGFLAGS.md]``

Every change of the flag is a status message to the receiver, so a flag that flickers is noise.  The
truth of "disturbed" comes from the optical reference: the field measured in the sensor frame, turned
into the earth frame by the *true* orientation, has a norm, a dip and an azimuth; a sample is **truly
disturbed** where its horizontal direction is more than :data:`HARM` degrees off the room's (the median
azimuth of the trial's first 10 s with truth: :func:`truth_disturbed`) or its norm or dip is off by more
than the gate (the defaults' tolerances): where following the field would turn the heading.  For each trial: the flag's raisings (and per minute), the share of the trial flagged, and
of the truly disturbed samples the share flagged.  Robust ``tqt`` with its defaults, VQF's
``magDistDetected`` (its defaults) beside it.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from benchmarks import realdata
from pointat.maths.quaternion import quat_rotate
from pointat.maths.tqt.step import F_MAG_DISTURBED

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


def flag_stats(flag: np.ndarray, truth: np.ndarray, dt: float) -> tuple[int, float, float, float]:
    """(raisings, raisings per minute, % of the trial flagged, % of the truly disturbed samples flagged).

    >>> flag = np.array([True, False, False, True, True, False])
    >>> flag_stats(flag, np.array([False, False, False, True, False, True]), 10.0)
    (2, 2.0, 50.0, 50.0)
    """
    raised = int(np.sum(flag[1:] & ~flag[:-1]) + flag[0])
    minutes = len(flag) * dt / 60.0
    caught = 100.0 * float(np.mean(flag[truth])) if truth.any() else math.nan
    return raised, raised / minutes, 100.0 * float(np.mean(flag)), caught


def report(files: list[Path]) -> str:
    lines = [
        "# The `mag_disturbed` flag on real recordings",
        "",
        f"Truly disturbed: the field seen through the optical truth more than {HARM:g}° of azimuth off the "
        "trial's first 10 s, or off in norm or dip by more than the gate (10 %, 15°).  *raised*: the "
        "flag's raisings (each one a status message, and one more when it is lowered); *flagged*: the "
        "share of the trial; *caught*: the share of the truly disturbed samples flagged.",
        "",
        "| trial | truly disturbed | tqt raised | per min | flagged | caught | VQF raised | VQF flagged | VQF caught |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    sums: dict[str, list[tuple[float, ...]]] = {}
    for path in files:
        d = realdata.load(path)
        dt = realdata.dt_of(d)
        truth = truth_disturbed(d)
        flag = (realdata.run_tqt(d)[1] & F_MAG_DISTURBED) != 0
        t = flag_stats(flag, truth, dt)
        v: tuple[float, ...] = (math.nan,) * 4
        try:
            import vqf

            f = vqf.VQF(dt)
            out = f.updateBatch(*(np.ascontiguousarray(d[k]) for k in ("gyr", "acc", "mag")))
            v = flag_stats(np.asarray(out["magDistDetected"], bool), truth, dt)
        except ImportError:
            pass
        name = path.name.removesuffix(".csv.gz")
        kind = realdata.trial_set(path) + (
            " magnetic"
            if ("magnet" in name or "_Dist_" in name)
            else " undisturbed"
            if "undisturbed" in name or "NoDist" in name
            else " other"
        )
        sums.setdefault(kind, []).append((100.0 * truth.mean(), *t, *v))
        lines.append(
            f"| {name} | {100.0 * truth.mean():.1f} % | {t[0]} | {t[1]:.2f} | {t[2]:.1f} % | {t[3]:.0f} % | "
            f"{v[0]:.0f} | {v[2]:.1f} % | {v[3]:.0f} % |"
        )
    lines += [
        "",
        "| kind of trial | trials | truly disturbed | tqt raised per min | flagged | caught | VQF raised per min | VQF flagged | VQF caught |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for kind, rows in sorted(sums.items()):
        a = np.nanmean(np.array(rows), axis=0)
        lines.append(
            f"| {kind} | {len(rows)} | {a[0]:.1f} % | {a[2]:.2f} | {a[3]:.1f} % | {a[4]:.0f} % | "
            f"{a[6]:.2f} | {a[7]:.1f} % | {a[8]:.0f} % |"
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
