"""Leave-one-trial-out cross-validation of robust ``tqt``'s defaults, and of VQF's, on the BROAD trials.

``python -m benchmarks.loo [--data DIR] [--out benchmarks/LOO.md]``

A default chosen on every trial and scored on the same trials flatters: the score to trust is the one on
a trial the choice never saw.  For each trial in turn, the grid point with the lowest mean total RMSE on
the *other* trials is chosen and scored on the held-out one; the mean of those scores is the
leave-one-out figure.  Beside it: the shipped defaults scored on every trial (in-sample), and the same
procedure for VQF (its two time constants; its defaults are the published ones, tuned on other data).
The grids are small on purpose: a default that only the in-sample mean supports is no default.
"""

from __future__ import annotations

import argparse
import itertools
import sys
import time
from collections.abc import Callable, Sequence
from multiprocessing import Pool
from pathlib import Path

import numpy as np

from benchmarks.accuracy import _tqt, _vqf_params, trial_files
from pointat.maths.evaluation import broad_rmse, load_broad
from pointat.maths.tqt import TQTFilter

#: The robust parameters cross-validated, each at its default and a factor of two (2.5 for k_heading)
#: either side.
TQT_GRID: dict[str, Sequence[float]] = {
    "k": (0.5, 1.0, 2.0),
    "k_heading": (0.02, 0.05, 0.1),
    "acc_tau": (1.0, 2.0, 4.0),
    "bias_tau": (10.0, 20.0, 40.0),
}
#: The strike claim, degrees (tests/maths/test_tqt_strokes.py).
CLAIM = 2.0
TQT_DEFAULTS = {name: getattr(TQTFilter(), name) for name in TQT_GRID}
VQF_GRID: dict[str, Sequence[float]] = {"tauAcc": (1.5, 3.0, 6.0), "tauMag": (9.0, 30.0, 60.0)}
VQF_DEFAULTS = {"tauAcc": 3.0, "tauMag": 9.0}

_data: dict[str, dict[str, np.ndarray]] = {}


def _score(job: tuple[str, str, dict[str, float]]) -> float:
    family, path, params = job
    if path not in _data:
        _data[path] = load_broad(path)
    d = _data[path]
    q = _tqt("robust", **params)(d) if family == "tqt" else _vqf_params(**params)(d)
    return broad_rmse(q, d["q_gt"], d["movement"])[0]


def grid_points(grid: dict[str, Sequence[float]]) -> list[dict[str, float]]:
    names = list(grid)
    return [dict(zip(names, values, strict=True)) for values in itertools.product(*grid.values())]


def scores(family: str, points: list[dict[str, float]], files: list[Path], workers: int) -> np.ndarray:
    """Total RMSE (degrees), shape (len(points), len(files))."""
    jobs = [(family, str(f), p) for p in points for f in files]
    with Pool(workers) as pool:
        out = pool.map(_score, jobs, chunksize=max(1, len(files) // 2))
    return np.array(out).reshape(len(points), len(files))


def leave_one_out(s: np.ndarray, admissible: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """For each trial (column), the grid point best on the others and its score on this one; only the
    ``admissible`` points (rows) are chosen from, when given.

    >>> s = np.array([[1.0, 1.0, 9.0], [2.0, 2.0, 1.0]])
    >>> leave_one_out(s)[0].tolist(), leave_one_out(s)[1].tolist()
    ([1, 1, 0], [2.0, 2.0, 9.0])
    >>> leave_one_out(s, np.array([False, True]))[0].tolist()
    [1, 1, 1]
    """
    n = s.shape[1]
    barred = np.where(np.ones(len(s), bool) if admissible is None else admissible, 0.0, np.inf)
    chosen = np.array([int(np.argmin(np.delete(s, i, axis=1).mean(axis=1) + barred)) for i in range(n)])
    return chosen, s[chosen, np.arange(n)]


def _claim(point: dict[str, float]) -> float:
    from benchmarks.shakes import claim_error

    return claim_error(**point)


def report(files: list[Path], workers: int, progress: Callable[[str], None]) -> str:
    trials = [f.name.removesuffix(".csv.gz") for f in files]
    lines = ["# Leave-one-trial-out on BROAD", ""]
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
        if family == "tqt":  # the strike claim bars what fails it, whatever BROAD says
            with Pool(workers) as pool:
                claim = np.array(pool.map(_claim, points))
            admissible = claim <= CLAIM
            barred = [p for p, ok in zip(points, admissible, strict=True) if not ok]
            grid_size = len(points)
        chosen, loo = leave_one_out(s, admissible)
        default = points.index(defaults)
        results[family] = (points, s, chosen, loo, default, time.perf_counter() - t0, admissible)
    grids = "; ".join(f"{k} {list(v)}" for k, v in TQT_GRID.items())
    lines += [
        f"Grids: tqt robust {grids} ({len(grid_points(TQT_GRID))} points); VQF "
        + "; ".join(f"{k} {list(v)}" for k, v in VQF_GRID.items())
        + ".  Total RMSE in degrees (the data set's metric).  *in-sample*: the defaults on every trial.  "
        "*LOO*: the grid point best on the nine other trials, scored on this one.",
        "",
        f"Only settings that keep the strike claim are chosen from (tests/maths/test_tqt_strokes.py: within "
        f"{CLAIM:g}° of the truth 1 s after any simulated burst up to 15 g, ideal or clipped at ±4 g; "
        "`benchmarks.shakes.claim_error`): BROAD has no strikes, and a setting it favours that sends the "
        f"sound astray after a shake is no default.  Barred: {len(barred)} of {grid_size} points, "
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
    mean = ["**mean**", f"**{t[1][t[4]].mean():.2f}**", f"**{t[3].mean():.2f}**", ""]
    mean += [f"**{v[1][v[4]].mean():.2f}**", f"**{v[3].mean():.2f}**", ""] if v else ["", "", ""]
    lines.append("| " + " | ".join(mean) + " |")
    if v:
        ahead = int(np.sum(t[3] < v[1][v[4]]))
        ahead_loo = int(np.sum(t[3] < v[3]))
        lines += [
            "",
            f"tqt LOO ahead of VQF defaults on {ahead} of {len(trials)} trials, of VQF LOO on {ahead_loo}.",
        ]
    best = int(np.argmin(t[1].mean(axis=1) + np.where(t[6], 0.0, np.inf)))
    lines += [
        f"The admissible grid point best on all {len(trials)} trials: {_params(t[0][best])}, in-sample mean "
        f"{t[1][best].mean():.2f} (the figure a tuned default would quote; the LOO mean is the honest one).",
        f"Computed in {sum(r[5] for r in results.values()):.0f} s on {workers} processes.",
    ]
    return "\n".join(lines) + "\n"


def _barred(points: list[dict[str, float]]) -> str:
    """What the barred grid points share (the values every one of them has), or how many."""
    if not points:
        return "none"
    common = {k: v for k, v in points[0].items() if all(p[k] == v for p in points)}
    return ("every one with " + _params(common)) if common else "with no one value in common"


def _params(p: dict[str, float]) -> str:
    return ", ".join(f"{k}={v:g}" for k, v in p.items())


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


def main(argv: Sequence[str] | None = None) -> int:
    return table_main(
        argv,
        "loo",
        __doc__,
        "LOO.md",
        3,
        lambda files, n: report(files, n, lambda s: print(s, file=sys.stderr)),
    )


if __name__ == "__main__":
    sys.exit(main())
