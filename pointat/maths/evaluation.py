r"""Scoring orientation estimates against optical ground truth: the BROAD benchmark (Laidig et al. 2021).

BROAD trials (CSV export, see ``pointat/data/README.md``) hold gyro, accelerometer and magnetometer samples at
2000/7 Hz with an optical ground-truth orientation ``q_gt`` (sensor -> **ENU**, scalar first) and a
``movement`` mask.  :func:`broad_rmse` is the dataset's own metric (``example_code/broad_utils.py``,
``calculateRMSE``): the error quaternion is expressed in the earth frame and split into heading (rotation
about the vertical) and inclination.

An estimate in pointat's NWU earth frame is compared after :func:`pointat.maths.quaternion.nwu_to_enu`.

>>> import numpy as np
>>> q = np.tile([1.0, 0.0, 0.0, 0.0], (3, 1))
>>> q_est = np.array([[1.0, 0.0, 0.0, 0.0], [np.cos(0.05), 0.0, 0.0, np.sin(0.05)], [1.0, 0.0, 0.0, 0.0]])
>>> [round(float(e), 6) for e in broad_rmse(q_est, q, np.array([1, 1, 0]))]   # 0.1 rad about z, once
[4.051423, 4.051423, 0.0]
"""

from __future__ import annotations

import gzip
import io
import os
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from pointat.maths.quaternion import quat_conjugate, quat_multiply
from pointat.userfiles import open_user_file

__all__ = ["BROAD_COLUMNS", "BROAD_RATE", "BROAD_SAMPLE", "load_broad", "broad_rmse", "broad_errors"]

#: Column names of the BROAD CSV export.
BROAD_COLUMNS = (
    "t,gyr_x,gyr_y,gyr_z,acc_x,acc_y,acc_z,mag_x,mag_y,mag_z,gt_qw,gt_qx,gt_qy,gt_qz,movement".split(",")
)

#: Sampling rate of every BROAD trial, Hz (2000/7).
BROAD_RATE = 2000.0 / 7.0

#: The BROAD trial shipped with pointat (CC BY 4.0, Laidig et al. 2021; see ``pointat/data/README.md``).
BROAD_SAMPLE = Path(__file__).resolve().parents[1] / "data" / "01_undisturbed_slow_rotation_A.csv.gz"


def load_broad(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    r"""Read one BROAD trial exported as (gzipped) CSV.

    Parameters
    ----------
    path : str or path-like
        A ``*.csv.gz`` (or plain ``*.csv``) file with 7 header lines (6 ``#`` lines, then the column names
        :data:`BROAD_COLUMNS`).

    Returns
    -------
    dict of numpy.ndarray
        ``t`` (N,) seconds; ``gyr`` (N, 3) rad/s; ``acc`` (N, 3) m/s² (+g up at rest); ``mag`` (N, 3) µT;
        ``q_gt`` (N, 4) sensor -> ENU, scalar first, NaN where the markers were occluded; ``movement`` (N,)
        bool, the samples that count in the metric.

    Raises
    ------
    ValueError
        If the column line is not the expected one.
    """
    path = Path(path)
    # a regular file of 1 GB at most: a pipe is refused, never waited on
    with (
        open_user_file(path, "take") as raw,
        io.TextIOWrapper(gzip.GzipFile(fileobj=raw) if path.suffix == ".gz" else raw, encoding="utf-8") as fh,
    ):
        header = []
        for line in fh:
            if not line.startswith("#"):
                header = line.strip().split(",")
                break
        if header != BROAD_COLUMNS:
            raise ValueError(f"{path}: expected the BROAD columns {','.join(BROAD_COLUMNS)}, got {header}")
        a = np.loadtxt(fh, delimiter=",", ndmin=2)
    return {
        "t": a[:, 0],
        "gyr": a[:, 1:4],
        "acc": a[:, 4:7],
        "mag": a[:, 7:10],
        "q_gt": a[:, 10:14],
        "movement": a[:, 14] != 0.0,
    }


def broad_errors(q_est: ArrayLike, q_gt: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Per-sample total, heading and inclination errors (radians) of BROAD (Laidig et al. 2021, §4).

    .. math::
        q_e = \hat q \otimes q_{gt}^{-1} \;(\text{earth frame}), \quad
        e_{tot} = 2\arccos|q_{e,w}|, \quad e_{head} = 2\arctan\left|\frac{q_{e,z}}{q_{e,w}}\right|, \quad
        e_{incl} = 2\arccos\sqrt{q_{e,w}^2 + q_{e,z}^2}

    Parameters
    ----------
    q_est, q_gt : array_like, shape (N, 4)
        Sensor -> ENU quaternions, scalar first (normalised here); NaN rows give NaN errors.

    Returns
    -------
    total, heading, inclination : numpy.ndarray, shape (N,)
    """
    q_est = np.asarray(q_est, dtype=float)
    q_gt = np.asarray(q_gt, dtype=float)
    q_est = q_est / np.linalg.norm(q_est, axis=-1, keepdims=True)
    q_gt = q_gt / np.linalg.norm(q_gt, axis=-1, keepdims=True)
    e = quat_multiply(q_est, quat_conjugate(q_gt))
    e = e / np.linalg.norm(e, axis=-1, keepdims=True)
    w, z = e[..., 0], e[..., 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        total = 2.0 * np.arccos(np.clip(np.abs(w), 0.0, 1.0))
        heading = 2.0 * np.arctan(np.abs(z / w))
        incl = 2.0 * np.arccos(np.clip(np.sqrt(w * w + z * z), 0.0, 1.0))
    return total, heading, incl


def broad_rmse(q_est: ArrayLike, q_gt: ArrayLike, movement: ArrayLike) -> tuple[float, float, float]:
    r"""BROAD's RMSE in degrees: total, heading, inclination over the movement phase.

    .. math:: \mathrm{RMSE}_x = \sqrt{\operatorname{nanmean}_{k \in \text{movement}} e_x[k]^2}

    Samples with NaN ground truth are skipped; nothing is aligned, offset or shifted.

    Parameters
    ----------
    q_est : array_like, shape (N, 4)
        Estimate, sensor -> ENU, scalar first (convert NWU with :func:`~pointat.maths.quaternion.nwu_to_enu`).
    q_gt : array_like, shape (N, 4)
        Ground truth, sensor -> ENU.
    movement : array_like, shape (N,)
        Mask (bool or 0/1) of the samples that count.

    Returns
    -------
    tuple of 3 floats
        ``(total, heading, inclination)`` RMSE in degrees.
    """
    mask = np.asarray(movement).astype(bool)
    errors = broad_errors(np.asarray(q_est, dtype=float)[mask], np.asarray(q_gt, dtype=float)[mask])
    return tuple(float(np.degrees(np.sqrt(np.nanmean(e * e)))) for e in errors)  # type: ignore[return-value]
