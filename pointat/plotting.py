"""``pointat plot``: a recorded take drawn as a PNG and a standalone HTML page.

A take is read as the ``replay`` node reads it (:func:`pointat.nodes.recording.read_csv_table`, its
columns found by the names ``replay`` looks for) and run offline through the chain a patch runs it through:

* raw ADC counts (``adc_gx`` ... ``adc_mz``, as ``patches/record_glove.pat`` records them) go through
  ``offset samples=150`` and ``scaling`` as the glove patches set them: the gyro nulls are the mean of the
  first 150 samples over which the glove held still, the other channels' nulls the ADC mid-scale, and
  ``scaling``'s nominal resolutions turn counts into rad/s, m/s² and gauss.  As in the patch, the filter
  sees nothing until the gyro nulls are taken;
* SI columns (``gyr_x``/``gyro_x``..., ``acc_x``/``accel_x``..., ``mag_x``...; a BROAD trial) go to the
  filter as they are, and a BROAD trial's optical truth (``gt_qw``..., sensor -> ENU) is turned to NWU as
  ``replay``'s ``truth`` outlet turns it.

Then :class:`~pointat.maths.tqt.TQTFilter` (robust mode with the ``tqt`` node's defaults; an ADC take with
``scaling``'s full scale, as ``units.range -> tqt.range`` gives it) and the ``azi_ele`` node's azimuth and
elevation of the hand's x (:func:`pointat.maths.scalar.azimuth_elevation`).  No reference pose is captured:
azimuth 0 is the earth frame's x (north), as in the patch before the first press.

The figure shares one time axis (seconds from the take's first row) over: the direction; the sensor norms;
the filter's flags; and, where the take has truth, the orientation error against it (BROAD's total error,
:func:`pointat.maths.evaluation.broad_errors`), its RMS in the panel's title.  :func:`plot_take` does it
all; of the functions it calls, only :func:`read_take` touches the node modules (for ``replay``'s reading
function and the nodes' numbers): the others work on arrays.  matplotlib (the ``plot`` extra) is imported
when a figure is drawn, and drawn with its Agg renderer alone: no display, no pyplot state.
"""

from __future__ import annotations

import base64
import html
import io
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pointat import shipped
from pointat.devices.mote_frame import ADC_NULL
from pointat.errors import PointatError
from pointat.maths import scalar as sq
from pointat.maths.calibration import STANDARD_GRAVITY, gyro_null
from pointat.maths.evaluation import broad_errors
from pointat.maths.quaternion import enu_to_nwu
from pointat.maths.tqt import TQTBank, TQTFlags

__all__ = [
    "ADC_COLUMNS",
    "FLAGS",
    "MATPLOTLIB_HINT",
    "Take",
    "TakeError",
    "Track",
    "adc_to_si",
    "direction",
    "draw",
    "flag_spans",
    "flagged_seconds",
    "gyro_nulls",
    "html_page",
    "orientation_error",
    "output_paths",
    "plot_take",
    "read_take",
    "require_matplotlib",
    "run_filter",
    "track",
]

#: The columns of a take recorded by ``patches/record_glove.pat``: each mote frame's nine ADC counts.
ADC_COLUMNS = ("adc_gx", "adc_gy", "adc_gz", "adc_ax", "adc_ay", "adc_az", "adc_mx", "adc_my", "adc_mz")

#: Samples averaged for the gyro nulls: ``offset samples=150``, as the glove patches set it.
NULL_SAMPLES = 150
#: ``offset``'s ``still``: an average over which a gyro varied by more (counts rms) is refused.
NULL_STILL = 50.0
#: ``azi_ele``'s defaults: the sensor axis that points, and the cone (degrees) about straight up or down
#: within which the azimuth holds.
POINTING_AXIS = (1.0, 0.0, 0.0)
POLE_DEG = 1.0

#: The flags drawn, each on its own row, by the name the ``tqt`` node's ``flags`` outlet gives it.
FLAGS = (
    ("rest", TQTFlags.REST),
    ("mag_disturbed", TQTFlags.MAG_DISTURBED),
    ("acc_saturated", TQTFlags.ACC_SATURATED),
    ("gyro_saturated", TQTFlags.GYRO_SATURATED),
    ("shaking", TQTFlags.SHAKING),
)

MATPLOTLIB_HINT = 'pointat plot needs matplotlib: pip install "pointat[plot]"'


class TakeError(PointatError):
    """A take that cannot be plotted: the message names the file and what is wrong."""


@dataclass
class Take:
    """A take's samples in the units the filter takes, one row per sample.

    ``t`` is in seconds from the first row; ``gyro`` rad/s, ``accel`` m/s², ``mag`` any unit (the filter
    uses its direction), each (N, 3); ``dt`` (N,) the time step the ``tqt`` node takes for each sample
    (from the time stamps; the nominal step for the first one, and where they do not give a usable one).
    ``truth`` (N, 4) sensor -> NWU, NaN rows where there is none, or None; ``movement`` (N,) the samples
    BROAD's metric counts, or None.  ``start``: the first sample the filter sees (after the gyro nulls of
    an ADC take).  ``acc_range`` (m/s²) and ``gyro_range`` (rad/s): the full scale the filter is told
    (0: not known).  ``source`` says in a few words what the columns held and how they were converted.
    """

    path: Path
    t: np.ndarray
    dt: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    mag: np.ndarray
    truth: np.ndarray | None = None
    movement: np.ndarray | None = None
    start: int = 0
    acc_range: float = 0.0
    gyro_range: float = 0.0
    source: str = ""

    @property
    def rate(self) -> float:
        """The nominal sample rate, Hz: the reciprocal of the median time step."""
        steps = np.diff(self.t)
        steps = steps[np.isfinite(steps) & (steps > 0.0)]
        return 1.0 / float(np.median(steps)) if len(steps) else math.nan

    @property
    def duration(self) -> float:
        """Seconds from the first row to the latest."""
        return float(np.nanmax(self.t)) if len(self.t) else 0.0


@dataclass
class Track:
    """What the filter made of a take, one row per sample: ``q`` (N, 4) sensor -> NWU, NaN where the
    filter gave no orientation (not yet fed, or not yet initialised); ``azimuth`` and ``elevation`` (N,)
    degrees (+ left, + up); ``flags`` (N,) the filter's flag bits (:class:`~pointat.maths.tqt.TQTFlags`);
    ``error`` (N,) degrees against the truth, or None; ``rms`` its RMS in degrees over the samples ``rms_of``
    names, or None."""

    q: np.ndarray
    azimuth: np.ndarray
    elevation: np.ndarray
    flags: np.ndarray
    error: np.ndarray | None = None
    rms: float | None = None
    rms_of: str = ""


# -- reading -------------------------------------------------------------------------------------------------


def read_take(path: str | Path, *, truth: bool = True) -> Take:
    """Read a take as ``replay`` reads it and convert it for the filter (see the module notes).

    ``truth=False`` leaves out the truth and the movement mask.  A file that is not there, does not read
    as a table of numbers, or lacks the sensor columns raises :class:`TakeError`, naming the file and
    what is missing.
    """
    path = Path(path)
    header, rows = _read_table(path)
    col = {name: i for i, name in enumerate(header)}
    if len(rows) < 2:
        raise TakeError(f"{path}: {len(rows)} row{'s' * (len(rows) != 1)} of samples: nothing to plot")
    gyro, accel, mag, start, acc_range, gyro_range, source = _sensors(path, header, rows, col)
    t = rows[:, 0] - rows[0, 0]
    dt = _time_steps(path, t, start)
    q_truth = _group(rows, col, "truth") if truth else None
    if q_truth is not None and not np.isfinite(q_truth).all(axis=1).any():
        q_truth = None
    movement = rows[:, col["movement"]] != 0.0 if q_truth is not None and "movement" in col else None
    return Take(
        path, t, dt, gyro, accel, mag, q_truth, movement, start, float(acc_range), float(gyro_range), source
    )


def _read_table(path: Path) -> tuple[list[str], np.ndarray]:
    """A take's header and rows as ``replay`` reads them (:class:`TakeError` naming the file)."""
    # the node modules, for their reading function and their numbers: the rest of this module needs none
    from pointat.nodes.recording import _format, read_csv_table
    from pointat.spec import path_kind

    if path_kind(path) == "missing":
        raise TakeError(f"{path}: no such file")
    # anything else but a regular file (a pipe, a device, a folder, 1 GB or more): read_csv_table says so
    if _format(str(path), "auto") == "ndjson":
        raise TakeError(
            f"{path}: an NDJSON take has no column names to tell the sensors apart: record the take as .csv"
            " (patches/record_glove.pat does)"
        )
    try:
        return read_csv_table(path)
    except ValueError as exc:  # (replay's own messages: they name the file and the line)
        raise TakeError(str(exc)) from None
    except OSError as exc:
        raise TakeError(f"{path}: {exc.strerror or exc}") from None


def _group(rows: np.ndarray, col: dict[str, int], name: str) -> np.ndarray | None:
    """The columns of one of ``replay``'s outlets, by the first set of names it finds complete."""
    from pointat.nodes.recording import _GROUPS

    for names in _GROUPS[name]:
        if all(n in col for n in names):
            data = rows[:, [col[n] for n in names]]
            if names[0] == "gt_qw":  # BROAD's truth, sensor -> ENU: to NWU, as replay's truth outlet
                data = data.copy()
                ok = np.all(np.isfinite(data), axis=1)
                data[ok] = enu_to_nwu(data[ok])
            return data
    return None


def _sensors(
    path: Path, header: list[str], rows: np.ndarray, col: dict[str, int]
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, float, float, str]:
    """gyro, accel and mag in SI units, the first sample the filter takes, the full scales (0: not known)
    and where the readings came from: the take's own SI columns, or its ADC counts taken as the glove
    patches take them."""
    from pointat.nodes.calibration import Scaling

    si = {name: _group(rows, col, name) for name in ("gyro", "accel", "mag")}
    if all(v is not None for v in si.values()):
        # (replay's range: its acc_range and gyro_range, 0)
        return si["gyro"], si["accel"], si["mag"], 0, 0.0, 0.0, "gyro, accel and mag columns as they are"
    if not all(c in col for c in ADC_COLUMNS):
        raise TakeError(f"{path}: {_missing(col, si)}; its columns: {' '.join(header)}")
    counts = rows[:, [col[c] for c in ADC_COLUMNS]]
    nulls_gyro, start = gyro_nulls(counts[:, :3])
    if start is None:
        raise TakeError(
            f"{path}: the glove never held still for {NULL_SAMPLES} samples in a row (a gyro varied by"
            f" more than {NULL_STILL:g} counts rms in each): offset samples={NULL_SAMPLES} takes no gyro"
            " nulls from it, and the glove patches output nothing"
        )
    units = Scaling("units", {})  # the glove patches' scaling, no calibration file: its numbers
    nulls = np.array([*nulls_gyro, *[float(ADC_NULL)] * 6])
    gyro, accel, mag = adc_to_si(counts, nulls, units.factor)
    acc_range, gyro_range = units.full_scale
    source = f"ADC counts through offset samples={NULL_SAMPLES} and scaling"
    return gyro, accel, mag, start, acc_range, gyro_range, source


def _time_steps(path: Path, t: np.ndarray, start: int) -> np.ndarray:
    """Each sample's time step as the tqt node takes it from the time stamps."""
    from pointat.nodes.orientation import SampleClock, time_step

    steps = np.diff(t)
    steps = steps[np.isfinite(steps) & (steps > 0.0)]
    if not len(steps):
        raise TakeError(f"{path}: its time column t never moves forward: no time line to plot")
    # the tqt node's step where the stamps give none is 1 / its rate: the rate as a patch gives it (100)
    nominal = 1.0 / float(f"{1.0 / float(np.median(steps)):.6g}")
    dt = np.full(len(t), nominal)
    last = None
    for i in range(start, len(t)):  # as the tqt node steps: from the time stamps
        dt[i] = time_step(last, float(t[i]), nominal, SampleClock.MAX_GAP)
        last = float(t[i])
    return dt


def _missing(col: dict[str, int], si: dict[str, np.ndarray | None]) -> str:
    """What a take lacks to be plotted, in the column names it should have."""
    from pointat.nodes.recording import _GROUPS

    adc = [c for c in ADC_COLUMNS if c not in col]
    if len(adc) < len(ADC_COLUMNS):  # some ADC columns: a glove take that lost some
        return f"no column {', '.join(adc)} (a glove take has t,{','.join(ADC_COLUMNS)})"
    lacking = [
        f"{name} ({' or '.join(','.join(names) for names in _GROUPS[name])})"
        for name, data in si.items()
        if data is None
    ]
    return f"no sensor columns for {', '.join(lacking)}, nor the ADC counts {','.join(ADC_COLUMNS)} of a glove take"


def gyro_nulls(
    counts: np.ndarray, samples: int = NULL_SAMPLES, still: float = NULL_STILL
) -> tuple[np.ndarray, int | None]:
    """The gyro nulls ``offset`` takes from a take's first gyro counts (N, 3), and the first sample it
    outputs after them.

    The mean of the first ``samples`` samples (:func:`~pointat.maths.calibration.gyro_null`); when a gyro
    varied over them by more than ``still`` counts rms, the glove moved, and the next ``samples`` are
    taken, as ``offset`` does.  ``(nulls, None)`` when no such stretch is still enough.

    >>> counts = np.array([[2040.0, 2050.0, 2048.0]] * 150 + [[2100.0, 2000.0, 2048.0]] * 10)
    >>> nulls, first = gyro_nulls(counts)
    >>> nulls.tolist(), first
    ([2040.0, 2050.0, 2048.0], 150)
    """
    counts = np.asarray(counts, dtype=float)
    rows = np.flatnonzero(np.isfinite(counts).all(axis=1))  # (offset averages the finite ones only)
    for begin in range(0, len(rows) - samples + 1, samples):
        block = counts[rows[begin : begin + samples]]
        if not still or float(block.std(axis=0).max()) <= still:  # (offset's rms about the mean)
            return gyro_null(block), int(rows[begin + samples - 1]) + 1
    return np.full(3, math.nan), None


def adc_to_si(
    counts: np.ndarray, nulls: np.ndarray, factor: tuple[float, ...] | np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Nine ADC channels (N, 9) less their ``nulls`` times ``scaling``'s ``factor`` (units per count, gyro
    in rad/s): gyro, accelerometer and magnetometer, (N, 3) each.

    >>> g, a, m = adc_to_si(np.array([[2058.0, 2048, 2048, 2048, 2048, 2559, 2448, 2048, 1606]]),
    ...                     np.full(9, 2048.0), [math.radians(0.1)] * 3 + [0.0192] * 3 + [0.001] * 3)
    >>> round(math.degrees(g[0, 0]), 6), round(float(a[0, 2]), 4), m[0].round(3).tolist()
    (1.0, 9.8112, [0.4, 0.0, -0.442])
    """
    si = (np.asarray(counts, dtype=float) - np.asarray(nulls, dtype=float)) * np.asarray(factor, dtype=float)
    return si[:, 0:3], si[:, 3:6], si[:, 6:9]


# -- filtering -----------------------------------------------------------------------------------------------


def run_filter(
    gyro: np.ndarray,
    accel: np.ndarray,
    mag: np.ndarray,
    dt: np.ndarray,
    *,
    start: int = 0,
    acc_range: float = 0.0,
    gyro_range: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Run a :class:`~pointat.maths.tqt.TQTFilter` (robust mode, the ``tqt`` node's defaults) over the
    samples from ``start``: the orientations (N, 4) sensor -> NWU, NaN where the filter gave none (before
    ``start``, or not yet initialised, where the ``tqt`` node outputs nothing), and its flag bits (N,)."""
    n = len(dt)
    q = np.full((n, 4), math.nan)
    flags = np.zeros(n, dtype=np.int64)
    if start >= n:
        return q, flags
    # the filter's very updates, the whole take in one call (TQTBank.update_batch: equal to the bit)
    bank = TQTBank(1, acc_range=acc_range, gyro_range=gyro_range)
    qs, fs = bank.update_batch(
        *(np.asarray(x, dtype=float)[start:, None, :] for x in (gyro, accel, mag)), np.asarray(dt)[start:]
    )
    flags[start:] = fs[:, 0]
    # the filter is initialised from the first sample that neither waits for it nor has no valid dt
    done = np.flatnonzero((fs[:, 0] & (TQTFlags.UNINITIALISED | TQTFlags.DT_INVALID)) == 0)
    if done.size:
        q[start + done[0] :] = qs[done[0] :, 0]
    return q, flags


def direction(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Azimuth and elevation in degrees (+ left, + up) of the hand's x for each orientation (N, 4), as the
    ``azi_ele`` node gives them: pointing within 1 degree of straight up or down, the azimuth holds.  NaN
    where the orientation is NaN.

    >>> az, el = direction(np.array([[1.0, 0, 0, 0], [math.cos(math.pi / 4), 0, 0, math.sin(math.pi / 4)]]))
    >>> az.round(6).tolist(), el.round(6).tolist()
    ([0.0, 90.0], [0.0, 0.0])
    """
    n = len(q)
    az, el = np.full(n, math.nan), np.full(n, math.nan)
    previous: float | None = None
    for i, row in enumerate(np.asarray(q, dtype=float).tolist()):
        if math.isnan(row[0]):
            continue
        previous, el[i] = sq.azimuth_elevation(row, POINTING_AXIS, previous, POLE_DEG)
        az[i] = previous
    return az, el


def orientation_error(q: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """The angle in degrees between each estimate and its truth (both (N, 4), in one earth frame): BROAD's
    total error (:func:`~pointat.maths.evaluation.broad_errors`).  NaN where either is NaN.

    >>> turned = np.array([[math.cos(0.05), 0.0, 0.0, math.sin(0.05)]])  # 0.1 rad about the vertical
    >>> orientation_error(np.array([[1.0, 0.0, 0.0, 0.0]]), turned).round(4)
    array([5.7296])
    """
    with np.errstate(invalid="ignore", divide="ignore"):
        total, _, _ = broad_errors(q, truth)
    return np.degrees(total)


def track(take: Take) -> Track:
    """Run the filter over a take (:func:`run_filter`), its direction (:func:`direction`) and, where it has
    truth, the error against it (:func:`orientation_error`); the RMS over BROAD's movement phase when the
    take marks one (the data set's metric), else over every sample with truth."""
    q, flags = run_filter(
        take.gyro,
        take.accel,
        take.mag,
        take.dt,
        start=take.start,
        acc_range=take.acc_range,
        gyro_range=take.gyro_range,
    )
    az, el = direction(q)
    result = Track(q, az, el, flags)
    if take.truth is not None:
        result.error = orientation_error(q, take.truth)
        counted = np.isfinite(result.error)
        result.rms_of = "every sample with truth"
        if take.movement is not None:
            counted &= take.movement
            result.rms_of = "the movement phase, BROAD's metric"
        if counted.any():
            result.rms = float(np.sqrt(np.mean(result.error[counted] ** 2)))
    return result


def _durations(t: np.ndarray) -> np.ndarray:
    """Each sample's share of the time line: until the next sample (the last: the median step)."""
    steps = np.diff(t)
    ok = steps[np.isfinite(steps) & (steps > 0.0)]
    last = float(np.median(ok)) if len(ok) else 0.0
    out = np.append(steps, last)
    out[~(np.isfinite(out) & (out > 0.0))] = 0.0
    return out


def flag_spans(t: np.ndarray, on: np.ndarray) -> list[tuple[float, float]]:
    """The stretches of time where ``on`` (N,) holds, as (start, length) in seconds, each sample lasting
    until the next.

    >>> flag_spans(np.arange(6) * 0.5, np.array([0, 1, 1, 0, 0, 1], dtype=bool))
    [(0.5, 1.0), (2.5, 0.5)]
    """
    on = np.asarray(on, dtype=bool)
    if not on.any():
        return []
    ends = t + _durations(t)
    edges = np.diff(np.concatenate(([0], on.astype(np.int8), [0])))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return [(float(t[a]), float(ends[b] - t[a])) for a, b in zip(starts, stops, strict=True)]


def flagged_seconds(t: np.ndarray, flags: np.ndarray) -> dict[str, float]:
    """Seconds each of :data:`FLAGS` was up, by name, each sample lasting until the next.

    >>> flagged_seconds(np.arange(4) * 0.5, np.array([int(TQTFlags.REST)] * 2 + [0, 0]))["rest"]
    1.0
    """
    share = _durations(t)
    return {name: float(share[(flags & int(bit)) != 0].sum()) for name, bit in FLAGS}


# -- drawing -------------------------------------------------------------------------------------------------


def require_matplotlib() -> None:
    """Raise :class:`~pointat.errors.PointatError` with the pip command when matplotlib is missing."""
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise PointatError(MATPLOTLIB_HINT) from None


def _breaks(az: np.ndarray) -> np.ndarray:
    """An azimuth with NaN where it wraps between +180 and -180, so that no line is drawn across."""
    out = az.copy()
    with np.errstate(invalid="ignore"):
        out[1:][np.abs(np.diff(az)) > 180.0] = math.nan
    return out


#: Panel titles on the left and legends on the right, both above the panel: neither hides a curve.
_TITLE = {"loc": "left", "fontsize": 10}
_LEGEND = {"loc": "lower right", "bbox_to_anchor": (1.0, 1.0), "fontsize": 8, "ncols": 3, "frameon": False}


def draw(take: Take, result: Track, *, dpi: int = 100) -> bytes:
    """The figure of a take as PNG bytes: direction, sensor norms, flags and (with truth) the error."""
    require_matplotlib()
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    t = take.t
    panels = 4 if result.error is not None else 3
    ratios = [3.0, 2.0, 1.5, 2.0][:panels]
    fig = Figure(figsize=(12.0, 1.2 + 1.6 * sum(ratios)), dpi=dpi, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(panels, 1, sharex=True, height_ratios=ratios)
    fig.suptitle(
        f"{take.path.name}: {take.duration:.1f} s, {len(t)} samples at {take.rate:.4g} Hz ({take.source})",
        fontsize=11,
    )

    ax = axes[0]
    if take.start:  # the gyro nulls of an ADC take: the filter sees nothing yet
        ax.axvspan(t[0], t[take.start], color="0.9", label="gyro nulls (hold still)")
    ax.plot(t, _breaks(result.azimuth), lw=1.0, color="tab:blue", label="azimuth (+ left)")
    ax.plot(t, result.elevation, lw=1.0, color="tab:orange", label="elevation (+ up)")
    ax.set_ylim(-190.0, 190.0)
    ax.set_yticks(np.arange(-180, 181, 90))
    ax.set_ylabel("direction (deg)")
    ax.set_title("where the hand points (tqt, robust; azimuth 0: north, no reference pose)", **_TITLE)
    ax.legend(**_LEGEND)

    ax = axes[1]
    gyro = np.degrees(np.linalg.norm(take.gyro, axis=1))
    acc = np.linalg.norm(take.accel, axis=1) / STANDARD_GRAVITY
    mag = np.linalg.norm(take.mag, axis=1)
    median = float(np.nanmedian(mag))
    mag = mag / median if median > 0.0 else mag
    lines = ax.plot(t, gyro, lw=0.8, color="tab:green", label="|gyro| (deg/s, left)")
    ax.set_ylabel("|gyro| (deg/s)")
    right = ax.twinx()
    lines += right.plot(t, mag, lw=1.2, color="tab:purple", label="|mag| / median (right)")
    lines += right.plot(t, acc, lw=0.8, color="tab:red", label="|acc| (g, right)")  # (over mag: both near 1)
    right.set_ylabel("|acc| (g), |mag| / median")
    top = float(np.nanpercentile(np.concatenate([acc, mag]), 99.9)) if len(t) else 1.0
    right.set_ylim(0.0, max(2.0, 1.1 * top))
    ax.set_ylim(bottom=0.0)
    ax.set_title("sensor norms", **_TITLE)
    ax.legend(lines, [line.get_label() for line in lines], **_LEGEND)

    ax = axes[2]
    seconds = flagged_seconds(t, result.flags)
    colours = ("tab:green", "tab:purple", "tab:red", "tab:orange", "tab:brown")
    for row, ((_, bit), colour) in enumerate(zip(FLAGS, colours, strict=True)):
        spans = flag_spans(t, (result.flags & int(bit)) != 0)
        ax.broken_barh(spans, (row - 0.4, 0.8), facecolors=colour)
    ax.set_yticks(range(len(FLAGS)))
    ax.set_yticklabels([f"{name} ({seconds[name]:.1f} s)" for name, _ in FLAGS], fontsize=8)
    ax.set_ylim(len(FLAGS) - 0.5, -0.5)
    ax.set_title("the filter's flags (time up)", **_TITLE)

    if result.error is not None:
        ax = axes[3]
        if take.movement is not None:  # what the RMS leaves out
            for a, width in flag_spans(t, ~take.movement):
                ax.axvspan(a, a + width, color="0.92", lw=0)
            ax.axvspan(math.nan, math.nan, color="0.92", label="outside the movement phase")
        ax.plot(t, result.error, lw=0.8, color="tab:red", label="angle to the truth")
        ax.set_ylim(bottom=0.0)
        ax.set_ylabel("error (deg)")
        rms = "no sample to count" if result.rms is None else f"RMS {result.rms:.2f} deg over {result.rms_of}"
        ax.set_title(f"orientation error: {rms}", **_TITLE)
        ax.legend(**_LEGEND)

    axes[-1].set_xlabel("time (s)")
    axes[-1].set_xlim(0.0, take.duration)
    for ax in axes:
        ax.grid(True, lw=0.3, alpha=0.6)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    return buffer.getvalue()


def html_page(take: Take, result: Track, png: bytes) -> str:
    """A standalone HTML page: a short table of the take and the PNG, embedded."""
    rows = [  # (label, the value as HTML)
        ("take", html.escape(str(take.path))),
        ("columns", html.escape(take.source)),
        ("duration", f"{take.duration:.2f} s"),
        ("samples", str(len(take.t))),
        ("rate", f"{take.rate:.4g} Hz"),
    ]
    if result.error is not None:
        rms = "none (no sample to count)" if result.rms is None else f"{result.rms:.2f}°"
        rows.append(
            ("RMS orientation error", f'<span class="rms">{rms}</span> over {html.escape(result.rms_of)}')
        )
    for flag, seconds in flagged_seconds(take.t, result.flags).items():
        share = 100.0 * seconds / take.duration if take.duration > 0.0 else 0.0
        rows.append((f"flagged {flag}", f"{seconds:.2f} s ({share:.1f} %)"))
    table = "\n".join(f"<tr><th>{label}</th><td>{value}</td></tr>" for label, value in rows)
    image = base64.b64encode(png).decode("ascii")
    name = html.escape(take.path.name)
    shown = "direction, sensor norms, flags" + (
        ", error against the truth" if result.error is not None else ""
    )
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>pointat plot: {name}</title>
<style>
body {{ font-family: system-ui, sans-serif; margin: 1.5em; color: #222; }}
table {{ border-collapse: collapse; margin-bottom: 1em; }}
th, td {{ text-align: left; padding: 0.2em 1em 0.2em 0; border-bottom: 1px solid #ddd; }}
th {{ font-weight: 600; }}
img {{ max-width: 100%; }}
</style>
</head>
<body>
<h1>{name}</h1>
<table>
{table}
</table>
<img alt="{name}: {shown}" src="data:image/png;base64,{image}">
</body>
</html>
"""


# -- the command ---------------------------------------------------------------------------------------------


def output_paths(take: str | Path, out: str | Path | None = None) -> tuple[Path, Path]:
    """``OUT.png`` and ``OUT.html``; ``OUT`` is the take's path without its extension(s) when not given
    (``take.csv``, ``x.csv.gz``: ``take``, ``x``), and without a ``.png`` or ``.html`` ending when given.

    >>> [str(p) for p in output_paths("a/x.csv.gz")], [str(p) for p in output_paths("t.csv", "b/y.png")]
    (['a/x.png', 'a/x.html'], ['b/y.png', 'b/y.html'])

    A take the package ships (``pointat:data/glove_take.csv.gz``) is drawn into the current folder:
    nothing is written inside the installed package.

    >>> [str(p) for p in output_paths(shipped.resolve("pointat:data/glove_take.csv.gz"))]
    ['glove_take.png', 'glove_take.html']
    """
    if out is None:
        base = Path(take)
        if base.suffix.lower() == ".gz":
            base = base.with_suffix("")
        base = base.with_suffix("")
        if Path(os.path.realpath(take)).is_relative_to(shipped.PACKAGE):
            base = Path(base.name)
    else:
        base = Path(out)
        if base.suffix.lower() in (".png", ".html"):
            base = base.with_suffix("")
    return base.with_name(base.name + ".png"), base.with_name(base.name + ".html")


def _write(path: Path, data: bytes | str) -> None:
    """Write one output file, or say clearly why it cannot be written."""
    try:
        if isinstance(data, bytes):
            path.write_bytes(data)
        else:
            path.write_text(data, encoding="utf-8")
    except OSError as exc:
        raise TakeError(f"cannot write {path}: {exc.strerror or exc}") from None


def plot_take(
    take_path: str | Path, out: str | Path | None = None, *, truth: bool = True
) -> tuple[Path, Path]:
    """Read, filter and draw a take (:func:`read_take`, :func:`track`, :func:`draw`); write ``OUT.png``
    and ``OUT.html`` (:func:`output_paths`) and return their paths.  ``truth=False``: no error panel,
    whatever the take holds."""
    require_matplotlib()
    take_path = shipped.resolve(str(take_path))  # (pointat:data/glove_take.csv.gz: the shipped take)
    take = read_take(take_path, truth=truth)
    result = track(take)
    png = draw(take, result)
    png_path, html_path = output_paths(take_path, out)
    _write(png_path, png)
    _write(html_path, html_page(take, result, png))
    return png_path, html_path
