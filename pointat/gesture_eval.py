"""``pointat gestures evaluate``: train on one folder of labelled recordings, test on another.

The model and the recognizer are the ``gesture`` node's own (:class:`~pointat.maths.gestures.GestureModel`,
:class:`~pointat.maths.gestures.Recognizer`), with the node's defaults.  Each test recording is fed to
the recognizer frame by frame between a gate's opening and closing (a recording is one movement, as a
button held would bracket it), so early decisions happen as they would on stage.

``--baseline`` scores plain 1-NN DTW on the same split beside it (:func:`baseline`: the raw channels, all
warped together over the whole length, no resampling or scaling, no rejection), so that anyone can see
whether the node's features help; ``--set NAME=VALUE`` sets any of the gesture node's parameters
(:func:`options`), as a patch would.

Reported: accuracy (a test movement rejected as no gesture counts as wrong), recall per class, the
confusion matrix (rows: the truth; columns: the decision, ``none`` for a rejection), and two latencies:
*when* (the decision's time minus the movement's last sample, ms: negative for an early decision) and
*compute* (the wall time the recognizer took on the frame that decided, ms).

``--stream`` (:func:`stream`) feeds each test recording whole, with no gate, as the node runs live (cut
from rest to rest, or ``--set cut=spot``): for a take of ordinary motion (in ``null/``), the gestures it
would tell a minute (false triggers); for a take of a gesture's repetitions, what it told them.

A training recording in ``null/`` longer than one movement can be (a take of ordinary motion, not a
movement the node recorded) is cut from rest to rest as ``record null`` cuts it live, each movement an
example of no gesture, and the report says how many.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from pointat.gesture_files import COLUMNS, Recording
from pointat.maths.dtw import dtw_many
from pointat.maths.gestures import NULL, Decided, GestureModel, Recognizer

__all__ = [
    "Evaluation",
    "Streamed",
    "baseline",
    "evaluate",
    "format_report",
    "format_stream",
    "options",
    "shared_channels",
    "stream",
]

#: The channel groups taken when a folder has several, in this order.
ORDER = ("gyr", "acc", "q", "mag")


class Outcome(NamedTuple):
    """What became of one test recording: its file, its true label, the label decided (``None``: no
    gesture), whether early, when (ms after the recording's last frame) and the compute spent (ms)."""

    file: str
    truth: str
    decided: str | None
    early: bool
    when_ms: float
    compute_ms: float


class NullCut(NamedTuple):
    """The training takes of ordinary motion cut into examples of no gesture (:func:`_trained`),
    and those in which no movement was found (taught whole); ``longest``: the longest movement kept (s)."""

    takes: int = 0
    movements: int = 0
    whole: int = 0
    longest: float = 0.0

    def said(self) -> list[str]:
        """The report's lines (none when no take was long)."""
        out = []
        if self.takes:
            takes = f"{self.takes} take{'s' if self.takes != 1 else ''}"
            out.append(
                f"null: {self.movements} movement{'s' if self.movements != 1 else ''} cut from rest to rest"
                f" in {takes} of ordinary motion (--train), taught as no gesture, as record null keeps them"
            )
        if self.whole:
            out.append(
                f"null: {self.whole} take{'s' if self.whole != 1 else ''} of ordinary motion (--train) with no"
                f" movement cut from rest to rest (no rest in it, or every move longer than"
                f" {self.longest:.1f} s): taught whole"
            )
        return out


@dataclass
class Evaluation:
    """The outcome of an evaluation (see the module's docstring): an :class:`Outcome` per test recording."""

    channels: tuple[str, ...]
    labels: list[str]
    decisions: list[Outcome] = field(default_factory=list)
    null_cut: NullCut = NullCut()

    def _share(self, which: Callable[[Outcome], bool]) -> float:
        """The share of the test movements (``null`` ones left out) for which ``which`` holds; NaN if none."""
        scored = [d for d in self.decisions if d.truth != NULL]
        return sum(which(d) for d in scored) / len(scored) if scored else float("nan")

    @property
    def accuracy(self) -> float:
        return self._share(lambda d: d.truth == d.decided)

    def missed(self) -> tuple[float, float]:
        """Where the accuracy goes: the shares of the test movements (``null`` ones left out) named as
        another gesture, and rejected as no gesture.

        >>> ev = Evaluation(("acc",), ["a", "b"], [Outcome("f", "a", "b", False, 0.0, 0.0),
        ...     Outcome("g", "a", None, False, 0.0, 0.0), Outcome("h", "b", "b", False, 0.0, 0.0),
        ...     Outcome("i", "null", None, False, 0.0, 0.0)])
        >>> ev.missed(), ev.accuracy
        ((0.3333333333333333, 0.3333333333333333), 0.3333333333333333)
        """
        return (
            self._share(lambda d: d.decided is not None and d.decided != d.truth),
            self._share(lambda d: d.decided is None),
        )

    def recall(self) -> dict[str, float]:
        out = {}
        for label in self.labels:
            mine = [d for d in self.decisions if d.truth == label]
            out[label] = sum(d.decided == label for d in mine) / len(mine) if mine else float("nan")
        return out

    def confusion(self) -> tuple[list[str], list[str], list[list[int]]]:
        """Rows (true labels), columns (decisions, ``none`` last) and counts."""
        rows = sorted({d.truth for d in self.decisions} | set(self.labels))
        cols = [*sorted(set(rows) - {NULL}), "none"]
        counts = [[0] * len(cols) for _ in rows]
        for d in self.decisions:
            counts[rows.index(d.truth)][cols.index(d.decided if d.decided is not None else "none")] += 1
        return rows, cols, counts

    def latency(self) -> dict[str, float]:
        when = np.array([d.when_ms for d in self.decisions if d.decided is not None])
        compute = np.array([d.compute_ms for d in self.decisions])
        early = sum(d.early for d in self.decisions)

        def q(a: np.ndarray, p: float) -> float:
            return float(np.percentile(a, p)) if a.size else float("nan")

        return {
            "when_median_ms": q(when, 50),
            "when_p95_ms": q(when, 95),
            "compute_median_ms": q(compute, 50),
            "compute_p95_ms": q(compute, 95),
            "early": early,
        }

    def as_dict(self) -> dict[str, Any]:
        rows, cols, counts = self.confusion()
        return {
            "channels": list(self.channels),
            "tested": len(self.decisions),
            "accuracy": self.accuracy,
            "recall": self.recall(),
            "confusion": {"rows": rows, "columns": cols, "counts": counts},
            "latency": self.latency(),
            "null_cut": self.null_cut._asdict(),
            "decisions": [d._asdict() for d in self.decisions],
        }


def shared_channels(recordings: Sequence[Recording]) -> tuple[str, ...]:
    """The channel groups every recording has, in :data:`ORDER`."""
    common = set(COLUMNS)
    for r in recordings:
        common &= set(r.groups)
    if not common:
        raise ValueError("the recordings share no channel group (acc_*, gyr_*, mag_*, q*)")
    return tuple(c for c in ORDER if c in common)


def _trained(
    train: Sequence[Recording],
    test: Sequence[Recording],
    channels: Sequence[str] | None,
    model_options: dict[str, Any] | None,
    recognizer_options: dict[str, Any] | None = None,
) -> tuple[GestureModel, NullCut]:
    """The node's model of ``channels`` (every group all the recordings have, when none) taught ``train``;
    a ``null`` recording longer than the longest movement the node records is a take of ordinary motion,
    taught as the movements ``record null`` keeps of it (:meth:`Recognizer.recorded`, by a recognizer of the
    model taught the gestures, with the node's settings), or whole if it has none."""
    channels = tuple(channels) if channels else shared_channels([*train, *test])
    examples = [r.example(channels) for r in train]
    model = GestureModel(channels, **(model_options or {})).train([e for e in examples if e.label != NULL])
    if len(model.examples) == len(examples):
        return model, NullCut()
    cutter = Recognizer(model, **(recognizer_options or {}))
    cutter.record = NULL
    cutter.retune()
    longest = cutter.segmenter.longest  # (the longest movement the node keeps while it records)
    taught, took = [], NullCut(longest=longest)
    for e in examples:
        long = e.label == NULL and float(e.t[-1] - e.t[0]) > longest
        cut = cutter.recorded(e.t, e.frames, NULL) if long else []
        taught += cut or [e]
        if cut:
            took = took._replace(takes=took.takes + 1, movements=took.movements + len(cut))
        elif long:
            took = took._replace(whole=took.whole + 1)
    return GestureModel(channels, **(model_options or {})).train(taught), took


def evaluate(
    train: Sequence[Recording],
    test: Sequence[Recording],
    channels: Sequence[str] | None = None,
    model_options: dict[str, Any] | None = None,
    recognizer_options: dict[str, Any] | None = None,
) -> Evaluation:
    """Train on ``train``, feed each of ``test`` through the recognizer between a gate's open and close."""
    model, cut = _trained(train, test, channels, model_options, recognizer_options)
    rec = Recognizer(model, **(recognizer_options or {}))
    out = Evaluation(model.channels, model.classes, null_cut=cut)
    for r in test:
        example = r.example(model.channels)
        found: Decided | None = None
        found_at, compute = 0.0, 0.0
        rec.reset()  # a recording is a take of its own: its clock may start again at 0
        rec.gate(True, float(example.t[0]))
        for t, frame in zip(example.t, example.frames, strict=True):
            start = time.perf_counter()
            events = rec.push(float(t), frame)
            spent = time.perf_counter() - start
            for e in events:
                if isinstance(e, Decided) and found is None:
                    found, found_at, compute = e, float(t), spent
        start = time.perf_counter()
        events = rec.gate(False, float(example.t[-1]))
        spent = time.perf_counter() - start
        for e in events:
            if isinstance(e, Decided) and found is None:
                found, found_at, compute = e, float(example.t[-1]), spent
        label = found.decision.label if found is not None else None
        early = bool(found is not None and found.decision.early)
        when = (found_at - float(example.t[-1])) * 1000.0 if found is not None else float("nan")
        out.decisions.append(Outcome(r.path, r.label, label, early, when, compute * 1000.0))
    return out


class Take(NamedTuple):
    """One test recording streamed whole (:func:`stream`): its file, its true label, its length (min) and
    the gestures told in it, in order."""

    file: str
    truth: str
    minutes: float
    told: list[str]


@dataclass
class Streamed:
    """The outcome of :func:`stream`: a :class:`Take` per test recording."""

    channels: tuple[str, ...]
    cut: str
    takes: list[Take] = field(default_factory=list)
    null_cut: NullCut = NullCut()

    def by_label(self) -> dict[str, tuple[float, dict[str, int]]]:
        """Per true label (``null``: ordinary motion): the minutes streamed and how often each gesture
        was told."""
        out: dict[str, tuple[float, dict[str, int]]] = {}
        for take in self.takes:
            minutes, told = out.get(take.truth, (0.0, {}))
            for label in take.told:
                told[label] = told.get(label, 0) + 1
            out[take.truth] = (minutes + take.minutes, told)
        return out

    def false_per_minute(self) -> float:
        """Gestures told a minute in the ``null`` recordings (NaN without any)."""
        minutes, told = self.by_label().get(NULL, (0.0, {}))
        return sum(told.values()) / minutes if minutes > 0 else float("nan")

    def as_dict(self) -> dict[str, Any]:
        return {
            "channels": list(self.channels),
            "cut": self.cut,
            "false_triggers_per_minute": self.false_per_minute(),
            "null_cut": self.null_cut._asdict(),
            "takes": [t._asdict() for t in self.takes],
        }


def stream(
    train: Sequence[Recording],
    test: Sequence[Recording],
    channels: Sequence[str] | None = None,
    model_options: dict[str, Any] | None = None,
    recognizer_options: dict[str, Any] | None = None,
) -> Streamed:
    """Train on ``train``, then feed each of ``test`` whole through a recognizer of its own, with no gate,
    as the node runs live: every gesture it tells."""
    model, cut = _trained(train, test, channels, model_options, recognizer_options)
    out = Streamed(model.channels, (recognizer_options or {}).get("cut", "rest"), null_cut=cut)
    for r in test:
        example = r.example(model.channels)
        rec = Recognizer(model, **(recognizer_options or {}))
        told = [
            str(e.decision.label)
            for t, frame in zip(example.t, example.frames, strict=True)
            for e in rec.push(float(t), frame)
            if isinstance(e, Decided) and e.decision.label is not None
        ]
        minutes = float(example.t[-1] - example.t[0]) / 60.0
        out.takes.append(Take(r.path, r.label, minutes, told))
    return out


def format_stream(st: Streamed) -> str:
    """What :func:`stream` found, as a person reads it."""
    minutes = sum(t.minutes for t in st.takes)
    how = "cut from rest to rest" if st.cut == "rest" else "spotted (cut=spot)"
    lines = [
        f"channels: {' '.join(st.channels)}; {len(st.takes)} test recordings streamed whole, {how},"
        f" {minutes:.1f} min"
    ]
    lines += st.null_cut.said()
    for label, (mins, told) in sorted(st.by_label().items()):
        said = (
            ", ".join(f"{n} {name}" for name, n in sorted(told.items(), key=lambda kv: -kv[1])) or "nothing"
        )
        if label == NULL:
            lines.append(
                f"  null ({mins:.1f} min of ordinary motion): told {said}: {st.false_per_minute():.2f}"
                " false triggers a minute"
            )
        else:
            right = told.get(label, 0)
            lines.append(
                f"  {label} ({mins:.1f} min): told {said} ({right} as {label}, {sum(told.values()) - right} other)"
            )
    return "\n".join(lines)


def options(items: Sequence[str]) -> tuple[dict[str, Any], dict[str, Any]]:
    """The model's and the recognizer's options from ``NAME=VALUE`` settings of the gesture node's
    parameters (the node's defaults for the rest), each checked as the node checks it."""
    from pointat.node import Params
    from pointat.nodes.gestures import GestureNode, model_options, recognizer_options
    from pointat.patchfile import parse_value

    declared = {p.name: p for p in GestureNode.params}
    settable = sorted(set(declared) - {"channels", "file", "size"})
    values = {name: p.default for name, p in declared.items()}
    for item in items:
        name, sep, text = item.partition("=")
        name = name.strip()
        if not sep or name not in settable:
            raise ValueError(
                f"--set {item!r}: expected NAME=VALUE with NAME one of the gesture node's parameters"
                f" ({', '.join(settable)})"
            )
        try:
            values[name] = declared[name].coerce(parse_value(text.strip()))
        except ValueError as exc:
            raise ValueError(f"--set {item!r}: {exc}") from None
    GestureNode.validate({**values, "channels": ["acc"]})
    p = Params(values)
    return model_options(p), recognizer_options(p)


def baseline(
    train: Sequence[Recording], test: Sequence[Recording], channels: Sequence[str] | None = None
) -> Evaluation:
    """Plain 1-NN DTW on the same split: each test recording's raw frames against every training
    recording's, all channels warped together over the whole length (no resampling, no scaling, no
    rejection, no early decision): the baseline the literature holds every method against."""
    channels = tuple(channels) if channels else shared_channels([*train, *test])
    templates = [r.example(channels).frames for r in train]
    labels = [r.label for r in train]
    out = Evaluation(channels, sorted(set(labels) - {NULL}))
    for r in test:
        start = time.perf_counter()
        d = dtw_many(r.example(channels).frames, templates, 1.0)
        spent = time.perf_counter() - start
        out.decisions.append(Outcome(r.path, r.label, labels[int(np.argmin(d))], False, 0.0, spent * 1000.0))
    return out


def format_report(ev: Evaluation) -> str:
    """The evaluation as a person reads it."""
    rows, cols, counts = ev.confusion()
    lat = ev.latency()
    lines = [
        f"channels: {' '.join(ev.channels)}; {len(ev.decisions)} test recordings",
        *ev.null_cut.said(),
        f"accuracy: {100 * ev.accuracy:.1f} %",
        "recall:",
    ]
    for label, r in ev.recall().items():
        lines.append(f"  {label:<16} {100 * r:5.1f} %")
    width = max(6, *(len(c) for c in cols), *(len(r) for r in rows)) + 1
    lines.append("confusion (rows: truth, columns: decision):")
    lines.append(" " * (width + 2) + "".join(f"{c:>{width}}" for c in cols))
    for r, row in zip(rows, counts, strict=True):
        lines.append(f"  {r:<{width}}" + "".join(f"{n:>{width}}" for n in row))
    lines.append(
        f"decision time after the last sample: median {lat['when_median_ms']:.0f} ms, p95 {lat['when_p95_ms']:.0f} ms"
        f" ({lat['early']} decided early, before the end)"
    )
    lines.append(
        f"compute on the deciding sample: median {lat['compute_median_ms']:.2f} ms, p95 {lat['compute_p95_ms']:.2f} ms"
    )
    return "\n".join(lines)


def to_json(ev: Evaluation, plain: Evaluation | None = None) -> str:
    out = ev.as_dict()
    if plain is not None:
        out["baseline"] = {"method": "plain 1-NN DTW", **plain.as_dict()}
        del out["baseline"]["latency"]
    return json.dumps(out, indent=2, allow_nan=True)
