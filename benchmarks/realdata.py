"""Real recordings with optical truth for choosing robust ``tqt``'s defaults: BROAD and the Tyrex smartphones.

Both sets come as BROAD's CSV (:func:`pointat.maths.evaluation.load_broad`); each trial's sample time is
read from its ``t`` column (BROAD 285.7 Hz, the phones 95-199 Hz).  :func:`run_tqt` runs
a whole trial through :meth:`pointat.maths.tqt.TQTBank.update_batch` (one sensor: the compiled step in
one loop over the samples, equal to :class:`~pointat.maths.tqt.TQTFilter`'s updates to the bit, a few
hundred times sooner than calling it a sample);
:func:`run_vqf` runs VQF with the trial's sample time.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from pointat.maths.evaluation import broad_rmse, load_broad
from pointat.maths.quaternion import nwu_to_enu
from pointat.maths.tqt import TQTBank

__all__ = ["dt_of", "run_tqt", "run_vqf", "score", "trial_set", "trials"]

_loaded: dict[str, dict[str, np.ndarray]] = {}


def arguments(prog: str, doc: str, out: Path) -> argparse.ArgumentParser:
    """The command line of a benchmark over both sets: ``--data`` (BROAD), ``--tyrex`` and ``--out``."""
    from benchmarks.__main__ import DEFAULT_DATA

    ap = argparse.ArgumentParser(prog=f"python -m {prog}", description=doc.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of BROAD trials (*.csv.gz)")
    ap.add_argument(
        "--tyrex", type=Path, default=DEFAULT_DATA.parent / "tyrex", help="folder of Tyrex trials (*.csv.gz)"
    )
    ap.add_argument("--out", type=Path, default=out)
    return ap


def trials(*folders: Path) -> list[Path]:
    """The trials (``*.csv.gz``) of every folder that exists, sorted by name within each."""
    out: list[Path] = []
    for folder in folders:
        if folder.is_dir():
            out += sorted(folder.glob("*.csv.gz"))
    return out


def trial_set(path: Path | str) -> str:
    """``"tyrex"`` for a smartphone trial (named after its person, phone and motion), else ``"broad"``."""
    name = Path(path).name
    return "tyrex" if ("Dist_" in name and ("Nexus" in name or "iPhone" in name)) else "broad"


def load(path: Path | str) -> dict[str, np.ndarray]:
    """:func:`~pointat.maths.evaluation.load_broad`, kept for the process's next call."""
    key = str(path)
    if key not in _loaded:
        _loaded[key] = load_broad(path)
    return _loaded[key]


def dt_of(d: dict[str, np.ndarray]) -> float:
    """The trial's sample time (s): the mean step of its uniform time grid."""
    t = d["t"]
    return float((t[-1] - t[0]) / (len(t) - 1))


def run_tqt(d: dict[str, np.ndarray], **settings: float) -> tuple[np.ndarray, np.ndarray]:
    """Robust ``tqt`` with ``settings`` over trial ``d``: (sensor -> ENU quaternions (N, 4), flag bits (N,))."""
    bank = TQTBank(1, backend="numba", **settings)  # type: ignore[arg-type]
    g, a, m = (np.asarray(d[k], dtype=float)[:, None, :] for k in ("gyr", "acc", "mag"))
    q, flags = bank.update_batch(g, a, m, dt_of(d))
    return nwu_to_enu(q[:, 0]), flags[:, 0]


def run_vqf(d: dict[str, np.ndarray], **params: float) -> np.ndarray:
    """VQF 9D (its C++) with ``params`` over trial ``d``, sensor -> ENU."""
    import vqf

    f = vqf.VQF(dt_of(d), **params)
    g, a, m = (np.ascontiguousarray(d[k]) for k in ("gyr", "acc", "mag"))
    return np.asarray(f.updateBatch(g, a, m)["quat9D"])


def score(d: dict[str, np.ndarray], q: np.ndarray) -> tuple[float, float, float]:
    """BROAD's total, heading and inclination RMSE (degrees) of ``q`` on trial ``d``."""
    return broad_rmse(q, d["q_gt"], d["movement"])
