"""Heading after fast rotation (issue 46, point 2): where robust ``tqt``'s heading error comes from on
BROAD's fast trials, printed against time and angular rate, VQF beside it.

``nice -n 10 python -m benchmarks.heading [--data DIR] [--trials 06 21] [--out benchmarks/HEADING.md]``

For each trial: (1) every 5 s, the share of movement, the mean and largest angular rate, the heading
and inclination errors of ``tqt`` (its defaults) and of VQF (its defaults), and the share of samples
``tqt`` flagged ``mag_disturbed``; (2) the lags: the sample shift of the gyro that best matches the
optical truth's rate, and the shift of the magnetometer that best steadies the field seen through the
truth in motion (the spread of its dip); (3) the field's heading seen through the truth in motion, its
mean offset from the field at rest and its spread, as measured and with the magnetometer's lag taken
out.  The error a filter leans towards is the field it sees: a field that lags the turning hand, or a
tilt error times tan(dip), pulls the heading while the hand turns fast.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from benchmarks import realdata
from pointat.maths.evaluation import broad_errors
from pointat.maths.tqt.step import F_MAG_DISTURBED

WINDOW = 5.0  # seconds
SHIFTS = range(-2, 9)  # samples


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rows of ``v`` turned by the rows of unit quaternions ``q`` (w, x, y, z)."""
    u = q[:, 1:]
    t = 2.0 * np.cross(u, v)
    return v + q[:, :1] * t + np.cross(u, t)


def _shifted(x: np.ndarray, k: int) -> np.ndarray:
    """``x(t + k)`` (the last rows repeated)."""
    if k <= 0:
        return np.concatenate([np.repeat(x[:1], -k, 0), x[: len(x) + k]]) if k else x
    return np.concatenate([x[k:], np.repeat(x[-1:], k, 0)])


def windows(d: dict[str, np.ndarray]) -> list[str]:
    q, flags = realdata.run_tqt(d)
    qv = realdata.run_vqf(d)
    _, head, inc = (np.degrees(x) for x in broad_errors(q, d["q_gt"]))
    _, headv, incv = (np.degrees(x) for x in broad_errors(qv, d["q_gt"]))
    t, rate = d["t"], np.degrees(np.linalg.norm(d["gyr"], axis=1))
    moving = d["movement"].astype(bool)
    rows = [
        "| from (s) | moving | mean rate (°/s) | largest | heading tqt | heading VQF | inclination tqt | "
        "inclination VQF | mag_disturbed |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for t0 in np.arange(0.0, t[-1], WINDOW):
        s = (t >= t0) & (t < t0 + WINDOW)
        rows.append(
            f"| {t0:.0f} | {100 * moving[s].mean():.0f} % | {rate[s].mean():.0f} | {rate[s].max():.0f} | "
            f"{np.nanmean(head[s]):.2f} | {np.nanmean(headv[s]):.2f} | {np.nanmean(inc[s]):.2f} | "
            f"{np.nanmean(incv[s]):.2f} | {100 * ((flags[s] & F_MAG_DISTURBED) > 0).mean():.0f} % |"
        )
    return rows


def lags(d: dict[str, np.ndarray]) -> tuple[int, int, list[str]]:
    """(the gyro's shift, the magnetometer's shift, lines): samples by which each trails the truth."""
    q, g, m = d["q_gt"], d["gyr"], d["mag"]
    dt = realdata.dt_of(d)
    ok = np.isfinite(q).all(axis=1)
    ok[-1] = False
    # the truth's body rate between samples k and k+1: 2 vec(conj(q_k) q_k+1) / dt
    a, b = q[:-1], q[1:]
    w = a[:, 0:1] * b[:, 1:] - b[:, 0:1] * a[:, 1:] - np.cross(a[:, 1:], b[:, 1:])
    wt = 2.0 * w * np.sign(np.sum(a * b, axis=1))[:, None] / dt
    good = ok[:-1] & np.isfinite(wt).all(axis=1)
    gyro_err = []
    for k in SHIFTS:
        gm = 0.5 * (_shifted(g, k)[:-1] + _shifted(g, k + 1)[:-1])
        gyro_err.append(float(np.sqrt(np.mean(np.sum((gm - wt)[good] ** 2, axis=1)))))
    moving = d["movement"].astype(bool) & ok
    spread = []
    for k in SHIFTS:
        e = _rotate(q[moving], _shifted(m, k)[moving])
        spread.append(float(np.degrees(np.arctan2(-e[:, 2], np.hypot(e[:, 0], e[:, 1]))).std()))
    kg, km = SHIFTS[int(np.argmin(gyro_err))], SHIFTS[int(np.argmin(spread))]
    lines = [
        "| shift (samples) | " + " | ".join(f"{k:+d}" for k in SHIFTS) + " |",
        "|---|" + "---|" * len(SHIFTS),
        "| gyro against the truth's rate, RMS (rad/s) | " + " | ".join(f"{x:.3f}" for x in gyro_err) + " |",
        "| the field's dip through the truth in motion, spread (°) | "
        + " | ".join(f"{x:.2f}" for x in spread)
        + " |",
    ]
    return kg, km, lines


def field_heading(d: dict[str, np.ndarray], shift: int) -> str:
    """The field's heading seen through the truth in motion against at rest: as measured and shifted."""
    q, m = d["q_gt"], d["mag"]
    ok = np.isfinite(q).all(axis=1)
    moving = d["movement"].astype(bool)
    out = []
    for k in (0, shift):
        e = _rotate(q[ok], _shifted(m, k)[ok])
        psi = np.degrees(np.arctan2(e[:, 1], e[:, 0]))
        dev = (psi - np.median(psi[~moving[ok]]) + 180.0) % 360.0 - 180.0
        mv = moving[ok]
        out.append(f"shift {k:+d}: mean {dev[mv].mean():+.2f}°, spread {dev[mv].std():.2f}°")
    return "; ".join(out)


def report(files: list[Path]) -> str:
    lines = [
        "# Heading after fast rotation (issue 46, point 2)",
        "",
        "`python -m benchmarks.heading` (its docstring says what each table is).  Errors in degrees, "
        "BROAD's split of the total into heading and inclination, means over each 5 s.",
    ]
    for f in files:
        d = realdata.load(f)
        kg, km, lag_lines = lags(d)
        dt = realdata.dt_of(d)
        lines += ["", f"## {f.name.split('.')[0]}", "", *windows(d), "", *lag_lines, ""]
        lines.append(
            f"The gyro trails the truth by {kg} sample(s), the magnetometer by {km} "
            f"({1000 * (km - kg) * dt:.0f} ms after the gyro).  The field's heading through the truth "
            f"in motion, against the field at rest: {field_heading(d, km)}."
        )
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    ap = realdata.arguments("benchmarks.heading", __doc__, Path(__file__).with_name("HEADING.md"))
    ap.add_argument("--trials", nargs="+", default=["06", "21"], help="BROAD trial numbers")
    args = ap.parse_args(argv)
    files = [f for f in realdata.trials(args.data) if f.name[:2] in args.trials]
    if not files:
        print(f"python -m benchmarks.heading: no trial {args.trials} in {args.data}")
        return 2
    text = report(files)
    args.out.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
