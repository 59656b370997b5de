"""Leave-one-trial-out cross-validation of robust ``tqt``'s defaults, and of VQF's, on real recordings:
BROAD's trials and the Tyrex smartphone trials together.

``python -m benchmarks.loo [--data DIR] [--tyrex DIR] [--out benchmarks/LOO.md]``

A default chosen on every trial and scored on the same trials flatters: the score to trust is the one on
a trial the choice never saw.  For each trial in turn, the grid point best on the *other* trials is chosen
and scored on the held-out one; the mean of those scores is the leave-one-out figure.  "Best" is the
lowest mean of the two sets' mean total RMSE (each set counts as much, whatever its number of trials;
with one set, its mean).  Beside it: the shipped defaults scored on every trial (in-sample), and the same
procedure for VQF (its two time constants; its defaults are the published ones, tuned on BROAD).  The
grids are small on purpose: a default that only the in-sample mean supports is no default.  Robust
``tqt`` runs compiled (:mod:`benchmarks.realdata`: the very step of
:class:`~pointat.maths.tqt.TQTFilter`), each trial at its own sample time.
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
import time
from collections.abc import Callable, Sequence
from multiprocessing import Pool
from pathlib import Path

import numpy as np

from benchmarks import realdata
from benchmarks.accuracy import trial_files
from pointat.maths.tqt import TQTFilter

#: The robust parameters cross-validated: the tilt's (k, acc_tau) and the magnetic ones (the heading gain
#: once the gyro's bias is known from rest, the gain added per rad/s of sustained turning, the gain before
#: the bias is known, the bias learned from the heading in motion), each at its default and either side
#: (k_heading also at 0.05, its default before k_heading_turn).  Held: mag_dip_tol (10°: 15° scored within
#: 0.01° and was chosen in 2 of 52 folds, LOO.md of commit 129d7ae), bias_tau (10 s, chosen on BROAD's
#: 81-point grid before: this file's history), mag_new_time (VQF's 20 s; 10 s scored the same within
#: 0.01°) and mag_tau (0.2 s: 0.05 / 0.2 / 0.4 s on the first round of this grid, LOO.md of commit
#: 4e6629d, took 0.4; 0.1 / 0.2 / 0.3 / 0.4 s with the phones' error found in the gate, issue 46 point 4,
#: took 0.2 in all 52 folds), mag_lag_tau and mag_lag_max (10 s and 0.02 s: their own 12-point LOO, 10 /
#: 30 / 100 s x 0 / 0.01 / 0.02 / 0.04 s, in benchmarks/README.md).
TQT_GRID: dict[str, Sequence[float]] = {
    "k": (0.5, 1.0),
    "acc_tau": (2.0, 4.0),
    "k_heading": (0.01, 0.015, 0.03, 0.05),
    "k_heading_turn": (0.0, 0.01, 0.02),
    "k_heading_unrested": (0.05, 0.1, 0.2),
    "motion_bias_tau": (0.0, 30.0),
}
#: The strike claim, degrees (tests/maths/test_tqt_strokes.py).
CLAIM = 2.0
TQT_DEFAULTS = {name: getattr(TQTFilter(), name) for name in TQT_GRID}
VQF_GRID: dict[str, Sequence[float]] = {"tauAcc": (1.5, 3.0, 6.0), "tauMag": (9.0, 30.0, 60.0)}
VQF_DEFAULTS = {"tauAcc": 3.0, "tauMag": 9.0}


def _score(job: tuple[str, str, dict[str, float]]) -> float:
    family, path, params = job
    d = realdata.load(path)
    q = realdata.run_tqt(d, **params)[0] if family == "tqt" else realdata.run_vqf(d, **params)
    return realdata.score(d, q)[0]


def grid_points(grid: dict[str, Sequence[float]]) -> list[dict[str, float]]:
    names = list(grid)
    return [dict(zip(names, values, strict=True)) for values in itertools.product(*grid.values())]


def scores(family: str, points: list[dict[str, float]], files: list[Path], workers: int) -> np.ndarray:
    """Total RMSE (degrees), shape (len(points), len(files))."""
    jobs = [(family, str(f), p) for f in files for p in points]  # a worker keeps a trial it has loaded
    with Pool(workers) as pool:
        out = pool.map(_score, jobs, chunksize=max(1, len(points)))
    return np.array(out).reshape(len(files), len(points)).T


def _criterion(s: np.ndarray, groups: np.ndarray | None) -> np.ndarray:
    """Per grid point (row): the mean of the groups' mean scores (the plain mean with no groups)."""
    if groups is None:
        return s.mean(axis=1)
    return np.mean([s[:, groups == g].mean(axis=1) for g in np.unique(groups)], axis=0)


def leave_one_out(
    s: np.ndarray, admissible: np.ndarray | None = None, groups: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """For each trial (column), the grid point best on the others and its score on this one; only the
    ``admissible`` points (rows) are chosen from, when given; with ``groups`` (a label per trial) "best"
    is the lowest mean of the groups' means.

    >>> s = np.array([[1.0, 1.0, 9.0], [2.0, 2.0, 1.0]])
    >>> leave_one_out(s)[0].tolist(), leave_one_out(s)[1].tolist()
    ([1, 1, 0], [2.0, 2.0, 9.0])
    >>> leave_one_out(s, np.array([False, True]))[0].tolist()
    [1, 1, 1]
    >>> leave_one_out(s, groups=np.array(["a", "a", "b"]))[0].tolist()  # b's one trial weighs as much
    [1, 1, 0]
    """
    n = s.shape[1]
    barred = np.where(np.ones(len(s), bool) if admissible is None else admissible, 0.0, np.inf)
    chosen = []
    for i in range(n):
        rest = np.delete(s, i, axis=1)
        g = None if groups is None else np.delete(groups, i)
        chosen.append(int(np.argmin(_criterion(rest, g) + barred)))
    c = np.array(chosen)
    return c, s[c, np.arange(n)]


def _claim(point: dict[str, float]) -> float:
    from benchmarks.shakes import claim_error

    return claim_error(**point)


def report(files: list[Path], workers: int, progress: Callable[[str], None]) -> str:
    trials = [f.name.removesuffix(".csv.gz") for f in files]
    groups = np.array([realdata.trial_set(f) for f in files])
    sets = list(dict.fromkeys(groups.tolist()))
    lines = ["# Leave-one-trial-out on real recordings (" + " and ".join(sets) + ")", ""]
    vqf_ok = True
    try:
        import vqf  # noqa: F401
    except ImportError:
        vqf_ok = False
    results = {}
    for family, grid, defaults in (("tqt", TQT_GRID, TQT_DEFAULTS), ("vqf", VQF_GRID, VQF_DEFAULTS)):
        if family == "vqf" and not vqf_ok:
            lines.append("VQF is not installed (pip install vqf): its columns are missing.")
            continue
        points = grid_points(grid)
        t0 = time.perf_counter()
        progress(f"loo: {family}, {len(points)} grid points x {len(files)} trials")
        s = scores(family, points, files, workers)
        admissible = None
        if family == "tqt":  # the strike claim bars what fails it, whatever the recordings say
            with Pool(workers) as pool:
                claim = np.array(pool.map(_claim, points))
            admissible = claim <= CLAIM
            barred = [p for p, ok in zip(points, admissible, strict=True) if not ok]
            grid_size = len(points)
        chosen, loo = leave_one_out(s, admissible, groups)
        default = points.index(defaults)
        results[family] = (points, s, chosen, loo, default, time.perf_counter() - t0, admissible)
    grids = "; ".join(f"{k} {_values(k, v)}" for k, v in TQT_GRID.items())
    lines += [
        f"Grids: tqt robust {grids} ({len(grid_points(TQT_GRID))} points; the rest at their defaults); VQF "
        + "; ".join(f"{k} {list(v)}" for k, v in VQF_GRID.items())
        + ".  Total RMSE in degrees (BROAD's metric, on both sets).  *in-sample*: the defaults on every "
        "trial.  *LOO*: the grid point best on the other trials (the lower mean of the sets' means), scored "
        "on this one.",
        "",
        f"Only settings that keep the strike claim are chosen from (tests/maths/test_tqt_strokes.py: within "
        f"{CLAIM:g}° of the truth 1 s after any simulated burst up to 15 g, ideal or clipped at ±4 g; "
        "`benchmarks.shakes.claim_error`): the recordings have no strikes, and a setting they favour that "
        f"sends the sound astray after a shake is no default.  Barred: {len(barred)} of {grid_size} points, "
        f"{_barred(barred)}.",
        "",
        "| trial | tqt defaults (in-sample) | tqt LOO | tqt LOO's choice | VQF defaults | VQF LOO | VQF LOO's choice |",
        "|---|---|---|---|---|---|---|",
    ]
    t = results["tqt"]
    v = results.get("vqf")
    for i, name in enumerate(trials):
        row = [name, f"{t[1][t[4], i]:.2f}", f"{t[3][i]:.2f}", _params(t[0][t[2][i]])]
        row += [f"{v[1][v[4], i]:.2f}", f"{v[3][i]:.2f}", _params(v[0][v[2][i]])] if v else ["", "", ""]
        lines.append("| " + " | ".join(row) + " |")
    for name in sets:
        m = groups == name
        mean = [
            f"**mean, {name} ({int(m.sum())})**",
            f"**{t[1][t[4], m].mean():.2f}**",
            f"**{t[3][m].mean():.2f}**",
            "",
        ]
        mean += [f"**{v[1][v[4], m].mean():.2f}**", f"**{v[3][m].mean():.2f}**", ""] if v else ["", "", ""]
        lines.append("| " + " | ".join(mean) + " |")
    lines.append("")
    if v:
        for name in sets:
            m = groups == name
            ahead = int(np.sum(t[3][m] < v[1][v[4], m]))
            ahead_loo = int(np.sum(t[3][m] < v[3][m]))
            lines.append(
                f"{name}: tqt LOO ahead of VQF defaults on {ahead} of {int(m.sum())} trials, of VQF LOO on "
                f"{ahead_loo}.  "
            )
    best = int(np.argmin(_criterion(t[1], groups) + np.where(t[6], 0.0, np.inf)))
    lines += [
        "",
        f"The admissible grid point best on all {len(trials)} trials: {_params(t[0][best])}, in-sample means "
        + ", ".join(f"{n} {t[1][best][groups == n].mean():.2f}" for n in sets)
        + " (the figure a tuned default would quote; the LOO means are the honest ones).",
        "",
        "Each grid value's evidence (in-sample means of the sets over the grid points with that value, the "
        "others at every grid value; a lower figure favours it):",
        "",
        "| parameter | value | " + " | ".join(f"{n} mean" for n in sets) + " |",
        "|---|---|" + "---|" * len(sets),
    ]
    for k, vals in TQT_GRID.items():
        for val in vals:
            rows = np.array([p[k] == val for p in t[0]])
            figs = [f"{t[1][rows][:, groups == n].mean():.2f}" for n in sets]
            mark = " (default)" if TQT_DEFAULTS[k] == val else ""
            lines.append(f"| {k} | {_value(k, val)}{mark} | " + " | ".join(figs) + " |")
    lines.append(f"\nComputed in {sum(r[5] for r in results.values()):.0f} s on {workers} processes.")
    return "\n".join(lines) + "\n"


def _value(k: str, v: float) -> str:
    return f"{math.degrees(v):g}°" if k.endswith("dip_tol") else f"{v:g}"


def _values(k: str, vs: Sequence[float]) -> str:
    return "[" + ", ".join(_value(k, v) for v in vs) + "]"


def _barred(points: list[dict[str, float]]) -> str:
    """What the barred grid points share (the values every one of them has), or how many."""
    if not points:
        return "none"
    common = {k: v for k, v in points[0].items() if all(p[k] == v for p in points)}
    return ("every one with " + _params(common)) if common else "with no one value in common"


def _params(p: dict[str, float]) -> str:
    return ", ".join(f"{k}={_value(k, v)}" for k, v in p.items())


def table_main(
    argv: Sequence[str] | None,
    module: str,
    doc: str,
    out: str,
    least: int,
    report: Callable[[list[Path], int], str],
) -> int:
    """The command line of a BROAD table (``python -m benchmarks.MODULE``): ``--data``, ``--out`` (default
    ``out`` beside this file), ``--workers``; the table written and printed."""
    from benchmarks.__main__ import DEFAULT_DATA

    ap = argparse.ArgumentParser(prog=f"python -m benchmarks.{module}", description=doc.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of BROAD trials (*.csv.gz)")
    ap.add_argument("--out", type=Path, default=Path(__file__).with_name(out))
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)
    files = trial_files(args.data)
    if len(files) < least:
        print(
            f"python -m benchmarks.{module}: needs {least} or more BROAD trials in {args.data}",
            file=sys.stderr,
        )
        return 2
    text = report(files, args.workers)
    args.out.write_text(text)
    print(text)
    return 0


def narrow(items: Sequence[str]) -> None:
    """Replace :data:`TQT_GRID` by the parameters named in ``items`` (``NAME=V1,V2,...``, degrees for a
    ``*_dip_tol``), for a run around what one change touches: the grid's whole product is the expensive
    part."""
    TQT_GRID.clear()
    TQT_DEFAULTS.clear()
    for item in items:
        name, _, values = item.partition("=")
        if not hasattr(TQTFilter(), name) or not values:
            raise SystemExit(f"--grid {item!r}: expected NAME=V1,V2,... with NAME a TQTFilter setting")
        vals = tuple(float(v) for v in values.split(","))
        TQT_GRID[name] = tuple(math.radians(v) for v in vals) if name.endswith("dip_tol") else vals
        TQT_DEFAULTS[name] = getattr(TQTFilter(), name)


def main(argv: Sequence[str] | None = None) -> int:
    ap = realdata.arguments("benchmarks.loo", __doc__, Path(__file__).with_name("LOO.md"))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument(
        "--grid",
        action="append",
        default=[],
        metavar="NAME=V1,V2,...",
        help="a narrowed grid: only the parameters named (each at the values given), the rest at their defaults",
    )
    args = ap.parse_args(argv)
    if args.grid:
        narrow(args.grid)
    files = realdata.trials(args.data, args.tyrex)
    if len(files) < 3:
        print(
            f"python -m benchmarks.loo: needs 3 or more trials in {args.data} and {args.tyrex}",
            file=sys.stderr,
        )
        return 2
    text = report(files, args.workers, lambda s: print(s, file=sys.stderr))
    args.out.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
