"""The evaluation patches on the vendored BROAD trial: one row per sample, error against optical truth."""

import gzip
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pointat.maths.evaluation import broad_rmse, load_broad

ROOT = Path(__file__).resolve().parents[2]
TRIAL = ROOT / "pointat" / "data" / "01_undisturbed_slow_rotation_A.csv.gz"
ROWS = 20000  # the first 70 s: 34 s of rest, then slow rotations


@pytest.fixture(scope="module")
def excerpt(tmp_path_factory):
    """The trial's first ROWS samples, in the same format (header lines kept)."""
    path = tmp_path_factory.mktemp("broad") / "excerpt.csv.gz"
    with gzip.open(TRIAL, "rt") as src, gzip.open(path, "wt") as dst:
        n = -1
        for line in src:
            dst.write(line)
            if not line.startswith("#"):
                n += 1
                if n == ROWS:
                    break
    return path


@pytest.mark.parametrize("patch, bound", [("evaluate_tqt.pat", 2.5), ("evaluate_complementary.pat", 5.0)])
def test_evaluation_patch_writes_one_row_per_sample_and_tracks_the_truth(patch, bound, excerpt, tmp_path):
    out = tmp_path / "est.csv"
    run = subprocess.run(
        [
            sys.executable,
            "-m",
            "pointat.cli",
            "run",
            ROOT / "patches" / patch,
            "--set",
            f"source.file={excerpt}",
            "--set",
            f"sink.file={out}",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr
    truth = load_broad(excerpt)
    lines = out.read_text().splitlines()
    assert lines[0] == "t,qw,qx,qy,qz"
    est = np.loadtxt(out, delimiter=",", skiprows=1)
    assert est.shape == (ROWS, 5)
    assert np.array_equal(est[:, 0], truth["t"])
    total, heading, inclination = broad_rmse(est[:, 1:], truth["q_gt"], truth["movement"])
    assert truth["movement"].sum() > 8000
    assert total < bound, (total, heading, inclination)
    assert inclination < 1.5
