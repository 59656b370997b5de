"""Accuracy on the BROAD recordings (Laidig et al. 2021): RMS orientation error against optical ground truth.

The metric is the data set's own (:func:`pointat.maths.evaluation.broad_rmse`: the error quaternion in the
earth frame split into heading and inclination, RMS over the ``movement`` samples, NaN ground truth
skipped).  Every filter runs causally from sample 0 over the whole trial, with **one parameter set for all
trials**; outputs are converted to sensor -> ENU with fixed frame changes only (pointat and ``ahrs``
Madgwick are NWU: :func:`pointat.maths.quaternion.nwu_to_enu`).  The peers use the settings of the data
README's table (``shared/data/broad/README.md``): the ``ahrs`` filters start from the TRIAD (acc/mag)
orientation of sample 0 as the BROAD example code does, ``imufusion`` and ``vqf`` from their own start-up.

pointat's filters:

* ``tqt robust`` / ``tqt paper`` -- :class:`pointat.maths.tqt.TQTFilter` with its defaults, and robust with
  the ``tqt`` node's default ``k_heading=0.03`` (the class's default is 0.05: a patch gets the former);
* ``complementary chain`` -- the nodes of ``patches/evaluate_complementary.pat`` (``gyro_integrator
  mode=exact`` -> ``accmag_matrix`` -> ``complementary crossover=0.05`` -> ``matrix2quat``), messages pushed
  through them one sample at a time exactly as ``replay`` sends them (mag, accel, then gyro).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pointat.maths.evaluation import BROAD_RATE, broad_rmse, load_broad
from pointat.maths.fusion import accmag_quat
from pointat.maths.quaternion import nwu_to_enu
from pointat.maths.tqt import TQTBank, TQTFilter
from pointat.message import vector

log = logging.getLogger("benchmarks.accuracy")

GRAVITY = 9.80665

#: The data README's published peer table (mean total RMSE, degrees, 10 trials) for the same settings.
PUBLISHED_MEAN = {
    "VQF defaults (tauAcc=3, tauMag=9)": 3.03,
    "VQF tuned (tauMag=30)": 2.45,
    "Madgwick gain 0.041 (ahrs default)": 6.21,
    "Madgwick gain 0.08 (tuned)": 5.38,
    "Mahony k_P=0.74 k_I=0.0012 (BROAD)": 8.89,
    "imufusion defaults (gain 0.5)": 13.63,
    "imufusion + Bias tuned (gain 0.05, rejection 10/10, 5 s)": 5.24,
}

#: Published per-trial total RMSE (degrees) of the same settings, by trial number.
PUBLISHED_TRIALS = {
    "VQF defaults (tauAcc=3, tauMag=9)": [1.99, 1.07, 4.03, 1.80, 2.31, 4.08, 1.55, 1.75, 4.04, 7.67],
    "VQF tuned (tauMag=30)": [1.50, 1.75, 3.58, 0.97, 1.14, 3.31, 1.31, 1.68, 3.65, 5.57],
    "Madgwick gain 0.041 (ahrs default)": [2.11, 1.50, 3.81, 1.52, 19.86, 7.18, 1.92, 6.11, 4.96, 13.11],
    "Madgwick gain 0.08 (tuned)": [2.92, 1.60, 1.83, 2.70, 12.81, 6.19, 1.85, 4.69, 5.20, 13.99],
    "Mahony k_P=0.74 k_I=0.0012 (BROAD)": [3.08, 5.08, 4.24, 2.77, 9.39, 12.37, 2.20, 2.46, 6.36, 40.98],
    "imufusion defaults (gain 0.5)": [3.28, 2.26, 3.49, 2.72, 23.67, 18.68, 2.48, 2.95, 13.27, 63.46],
    "imufusion + Bias tuned (gain 0.05, rejection 10/10, 5 s)": [
        5.02,
        5.77,
        2.43,
        1.94,
        4.60,
        11.33,
        2.29,
        2.44,
        9.27,
        7.27,
    ],
}
PUBLISHED_ORDER = ["01", "04", "06", "10", "15", "21", "24", "26", "28", "32"]

Estimator = Callable[[dict[str, np.ndarray]], np.ndarray]


@dataclass
class Score:
    total: float
    heading: float
    inclination: float


@dataclass
class AccuracyResults:
    trials: list[str] = field(default_factory=list)
    scores: dict[str, dict[str, Score]] = field(default_factory=dict)  # filter -> trial -> score
    families: dict[str, str] = field(default_factory=dict)  # filter -> "pointat" | library
    seconds: dict[str, float] = field(default_factory=dict)
    errors: list[str] = field(default_factory=list)
    loo: str = ""  # benchmarks.loo's table (Markdown, without its title)
    shakes: str = ""  # benchmarks.shakes's

    def mean(self, name: str) -> Score:
        s = list(self.scores[name].values())
        return Score(
            *(float(np.mean([getattr(x, f) for x in s])) for f in ("total", "heading", "inclination"))
        )


# ------------------------------------------------------------------------------------- estimators
def _tqt(mode: str, **params: float) -> Estimator:
    def run(d: dict[str, np.ndarray]) -> np.ndarray:
        dt = 1.0 / BROAD_RATE
        if mode == "robust":  # the filter's very updates, the trial in one compiled call
            bank = TQTBank(1, **params)  # type: ignore[arg-type]
            q = bank.update_batch(
                *(np.asarray(d[k], dtype=float)[:, None, :] for k in ("gyr", "acc", "mag")), dt
            )[0]
            return nwu_to_enu(q[:, 0])
        f = TQTFilter(mode=mode, **params)  # type: ignore[arg-type]
        g, a, m = d["gyr"].tolist(), d["acc"].tolist(), d["mag"].tolist()
        q = np.array([f.update(g[i], a[i], m[i], dt) for i in range(len(g))])
        return nwu_to_enu(q)

    return run


_CHAIN = """
node gyro   gyro_integrator mode=exact rate=285.7142857142857
node accmag accmag_matrix
node fuse   complementary crossover=0.05 rate=285.7142857142857
node quat   matrix2quat
node sink   collect
accmag -> fuse.accmag
gyro -> fuse.gyro_orientation
fuse -> quat -> sink
"""


def _complementary_chain(d: dict[str, np.ndarray]) -> np.ndarray:
    from pointat.testing import patch

    rt = patch(_CHAIN)
    rt.start()
    gyro, accmag, sink = rt.nodes["gyro"], rt.nodes["accmag"], rt.nodes["sink"]
    q = np.full((len(d["t"]), 4), np.nan)
    for i, t in enumerate(d["t"].tolist()):
        accmag.receive(1, vector(d["mag"][i], t))
        accmag.receive(0, vector(d["acc"][i], t))
        before = len(sink.messages)  # type: ignore[attr-defined]
        gyro.receive(0, vector(d["gyr"][i], t))
        if len(sink.messages) > before:  # type: ignore[attr-defined]
            q[i] = sink.messages[-1].value  # type: ignore[attr-defined]
    rt.shutdown()
    first = np.flatnonzero(np.isfinite(q[:, 0]))
    q[: first[0] if first.size else len(q)] = (1.0, 0.0, 0.0, 0.0)  # nothing out yet: identity
    return nwu_to_enu(q)


def _triad_nwu(d: dict[str, np.ndarray]) -> np.ndarray:
    for i in range(len(d["t"])):
        q = accmag_quat(d["acc"][i], d["mag"][i])
        if q is not None:
            return np.asarray(q, dtype=float)
    return np.array([1.0, 0.0, 0.0, 0.0])


def _madgwick(gain: float) -> Estimator:
    def run(d: dict[str, np.ndarray]) -> np.ndarray:
        import ahrs

        f = ahrs.filters.Madgwick(frequency=BROAD_RATE, gain=gain)
        q = _triad_nwu(d)
        g, a, m = d["gyr"], d["acc"], d["mag"]
        out = np.empty((len(g), 4))
        for i in range(len(g)):
            q = f.updateMARG(q, g[i], a[i], m[i])
            out[i] = q
        return nwu_to_enu(out)  # ahrs Madgwick: sensor -> NWU

    return run


def _mahony(k_p: float, k_i: float) -> Estimator:
    def run(d: dict[str, np.ndarray]) -> np.ndarray:
        import ahrs

        f = ahrs.filters.Mahony(frequency=BROAD_RATE, k_P=k_p, k_I=k_i)
        q = nwu_to_enu(_triad_nwu(d))  # ahrs Mahony's MARG update works in ENU (data README)
        g, a, m = d["gyr"], d["acc"], d["mag"]
        out = np.empty((len(g), 4))
        for i in range(len(g)):
            q = f.updateMARG(q, g[i], a[i], m[i])
            out[i] = q
        return out

    return run


def _imufusion(tuned: bool) -> Estimator:
    def run(d: dict[str, np.ndarray]) -> np.ndarray:
        import imufusion

        s = imufusion.AhrsSettings()
        s.convention = imufusion.CONVENTION_ENU  # the constructor's keyword is ignored in 1.3.3 (README)
        s.sample_rate = BROAD_RATE
        if tuned:
            s.gain = 0.05
            s.acceleration_rejection = 10.0
            s.magnetic_rejection = 10.0
            s.rejection_timeout = 5.0
            s.gyroscope_range = 2000.0
        f = imufusion.Ahrs()
        f.set_settings(s)
        bias = None
        if tuned:
            bs = imufusion.BiasSettings()
            bs.sample_rate = BROAD_RATE
            bias = imufusion.Bias()
            bias.set_settings(bs)
        g = np.ascontiguousarray(np.degrees(d["gyr"]))
        a = np.ascontiguousarray(d["acc"] / GRAVITY)
        m = np.ascontiguousarray(d["mag"])
        out = np.empty((len(g), 4))
        for i in range(len(g)):
            f.update(bias.update(g[i]) if bias is not None else g[i], a[i], m[i])
            out[i] = f.get_quaternion()
        return out

    return run


def _vqf(tau_mag: float) -> Estimator:
    return _vqf_params(tauAcc=3.0, tauMag=tau_mag)


def _vqf_params(**params: float) -> Estimator:
    def run(d: dict[str, np.ndarray]) -> np.ndarray:
        import vqf

        f = vqf.VQF(1.0 / BROAD_RATE, **params)
        g, a, m = (np.ascontiguousarray(d[k]) for k in ("gyr", "acc", "mag"))
        return f.updateBatch(g, a, m)["quat9D"]

    return run


def estimators() -> list[tuple[str, str, Estimator]]:
    """(name, family, estimator) for every filter compared, pointat's first."""
    out: list[tuple[str, str, Estimator]] = [
        ("tqt robust (TQTFilter defaults)", "pointat", _tqt("robust")),
        ("tqt robust, tqt node's k_heading 0.03", "pointat", _tqt("robust", k_heading=0.03)),
        ("tqt paper (TQTFilter defaults)", "pointat", _tqt("paper")),
        ("complementary chain (crossover 0.05 Hz)", "pointat", _complementary_chain),
    ]
    try:
        import vqf  # noqa: F401

        out += [
            ("VQF defaults (tauAcc=3, tauMag=9)", "vqf", _vqf(9.0)),
            ("VQF tuned (tauMag=30)", "vqf", _vqf(30.0)),
        ]
    except ImportError:
        pass
    try:
        import ahrs  # noqa: F401

        out += [
            ("Madgwick gain 0.041 (ahrs default)", "ahrs", _madgwick(0.041)),
            ("Madgwick gain 0.08 (tuned)", "ahrs", _madgwick(0.08)),
            ("Mahony k_P=0.74 k_I=0.0012 (BROAD)", "ahrs", _mahony(0.74, 0.0012)),
        ]
    except ImportError:
        pass
    try:
        import imufusion  # noqa: F401

        out += [
            ("imufusion defaults (gain 0.5)", "imufusion", _imufusion(False)),
            ("imufusion + Bias tuned (gain 0.05, rejection 10/10, 5 s)", "imufusion", _imufusion(True)),
        ]
    except ImportError:
        pass
    return out


def trial_files(data: Path) -> list[Path]:
    """The BROAD trials in ``data`` (a folder, or one file), sorted by name."""
    if data.is_file():
        return [data]
    return sorted(data.glob("*.csv.gz"))


def run_all(files: list[Path], progress: Callable[[str], None]) -> AccuracyResults:
    res = AccuracyResults()
    ests = estimators()
    missing = {"vqf", "ahrs", "imufusion"} - {fam for _, fam, _ in ests}
    for lib in sorted(missing):
        res.errors.append(f"{lib} is not installed (pip install {lib}): its rows are missing")
    for path in files:
        trial = path.name.removesuffix(".csv.gz")
        res.trials.append(trial)
        d = load_broad(path)
        progress(f"accuracy: {trial}")
        for name, family, est in ests:
            t0 = time.perf_counter()
            try:
                q = est(d)
            except Exception as exc:  # one broken peer must not sink the report
                res.errors.append(f"{name} on {trial}: {type(exc).__name__}: {exc}")
                continue
            res.seconds[name] = res.seconds.get(name, 0.0) + time.perf_counter() - t0
            res.families[name] = family
            res.scores.setdefault(name, {})[trial] = Score(*broad_rmse(q, d["q_gt"], d["movement"]))
    from benchmarks import loo, shakes  # (they import this module)

    if len(files) >= 3:
        res.loo = loo.report(files, 2, progress).split("\n", 2)[2]
    progress("accuracy: strikes and shakes, simulated")
    res.shakes = shakes.report().split("\n", 2)[2]
    return res
