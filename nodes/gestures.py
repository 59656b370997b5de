"""Gestures a performer teaches the glove: trained movements, postures, strokes, and following.

``gesture``, ``posture`` and ``follow`` learn from examples, with one workflow, from the patch or over
OSC (``osc_in``'s live control, ``/pointat/NODE/...``):

* ``record LABEL`` -- the next movement (``gesture``, ``follow``) or the next ``samples`` frames held
  (``posture``) become an example of LABEL; ``record LABEL N``: the next N.  ``record null``: movements
  that are *no* gesture (ordinary pointing), so that they are rejected: ``record null 10`` while moving as
  between gestures, if the node fires on ordinary moves.  Recognition pauses meanwhile.
* ``train`` -- learn from every example, and run.  ``run`` -- recognise again (after ``record``),
  ``stop`` -- stop recording or recognising.
* ``clear`` -- forget every example (``clear LABEL``: that label's).
* ``save``, ``load`` -- to and from ``file`` (JSON, beside the patch); a patch that starts with the file
  there loads it and runs: teach in rehearsal, perform with it.

The maths is :mod:`pointat.maths.gestures`; ``pointat gestures evaluate`` runs the same recognizer over
folders of recordings.  ``stroke`` needs no teaching: a percussive stroke, its direction in the room and
its strength.
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from pointat.gesture_files import MOST_EXAMPLES, load_model, model_text
from pointat.maths.dtw import warm
from pointat.maths.gestures import (
    CHANNELS,
    CUTS,
    NULL,
    REJECT,
    RELATIVE,
    SCALES,
    WARPS,
    Adapted,
    Decided,
    Dropped,
    Ended,
    Event,
    Example,
    Follower,
    GestureModel,
    PostureModel,
    Recognizer,
    Recorded,
    Segmenter,
    Started,
    StrokeDetector,
    channel_slices,
    relative_channels,
)
from pointat.message import Message, as_floats, bang
from pointat.names import check_name
from pointat.node import Inlet, Node, Outlet, Param, names_path
from pointat.registry import register
from pointat.saving import Saver, clean_stray

log = logging.getLogger("pointat.gestures")

_CHANNEL_DOC = {
    "acc": "specific force, m/s² (scaling's accel)",
    "gyr": "angular rate, rad/s (scaling's gyro)",
    "mag": "magnetic field (scaling's mag)",
    "q": "orientation quaternion w x y z (tqt's quat)",
    "x": "any other features, size numbers",
}


def _file_param(default: str) -> Param:
    return Param(
        "file",
        "path",
        default,
        "the examples: save and load go here, loaded at start when there",
        reads=True,
        writes=True,
        optional=True,
    )


def _channels_param(default: tuple[str, ...]) -> Param:
    return Param(
        "channels",
        "list",
        default,
        "what a frame holds, one inlet each, the first hot: acc gyr mag q x",
    )


class _Learner(Node):
    """What ``gesture``, ``posture`` and ``follow`` share: inlets per channel, the record / train / run
    workflow, and the model file."""

    kind: ClassVar[str] = ""
    needs_input = True

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        channels = [str(c) for c in values["channels"]]
        channel_slices(channels, int(values["size"]))  # unknown, repeated, x without size

    @classmethod
    def check_files(cls, values: Mapping[str, Any]) -> None:
        """Read the examples' file as the patch's start will (``pointat check``): a hand edit gone wrong,
        or examples of other channels, are found before the show."""
        path = str(values["file"])
        if not path or not os.path.exists(path):
            return
        channels, size, _ = load_model(path, cls.kind)
        want = tuple(str(c) for c in values["channels"])
        if channels != want or size != int(values["size"]):
            raise ValueError(f"{path} holds channels {' '.join(channels)}; this node takes {' '.join(want)}")

    @classmethod
    def layout(cls, values: Mapping[str, Any]) -> tuple[tuple[Inlet, ...], tuple[Outlet, ...]]:
        channels = [str(c) for c in values["channels"]]
        inlets = tuple(
            Inlet(
                c,
                ("vector", "list") if i else ("vector", "list", "bang"),
                _CHANNEL_DOC.get(c, "") + (" (hot; methods here)" if i == 0 else ""),
            )
            for i, c in enumerate(channels)
            if c in CHANNELS
        )
        return inlets, tuple(cls.outlets)

    def setup(self) -> None:
        self.channels = tuple(str(c) for c in self.p.channels)
        self.slices = channel_slices(self.channels, self.p.size)
        self.width = sum(s.stop - s.start for s in self.slices.values())
        self._latest: dict[str, tuple[float, ...]] = {}
        self.examples: list[Example] = []
        self.recording: str | None = None
        self.to_record = 0
        self.running = False
        self._unread: str | None = None
        self._warned_missing = False
        self._saver = Saver(f"{self.type_name} '{self.name}'")
        self._handlers = [self._make_input(i, c) for i, c in enumerate(self.channels)]
        if type(self).receive is Node.receive:
            self._deliver = self._handlers
        self.build()

    # the model: subclasses ------------------------------------------------------------------------
    def build(self) -> None:
        """Make the (untrained) model from the parameters."""

    def fit(self) -> None:
        """Train the model on ``self.examples``; ``ValueError`` when it cannot."""

    def frame(self, t: float, x: np.ndarray) -> None:
        """One frame of every channel, at time ``t``."""

    # inputs ---------------------------------------------------------------------------------------
    def _make_input(self, index: int, name: str):
        size = self.slices[name].stop - self.slices[name].start

        def store(msg: Message) -> None:
            if msg.kind == "bang":
                raise TypeError(f"'{name}' takes {size} numbers, not a bang")
            values = as_floats(msg, size)
            if not all(math.isfinite(v) for v in values):
                raise ValueError(f"'{name}': a value is not a finite number: {values}")
            self._latest[name] = values
            if index == 0:
                self._hot(msg.time)

        return store

    def _hot(self, t: float) -> None:
        latest = self._latest
        if len(latest) < len(self.channels):
            if not self._warned_missing:
                self._warned_missing = True
                missing = [c for c in self.channels if c not in latest]
                log.warning(
                    "%s '%s': no %s yet: waiting (wire every channel of channels=%s)",
                    self.type_name,
                    self.name,
                    ", ".join(missing),
                    " ".join(self.channels),
                )
            return
        x = np.fromiter((v for c in self.channels for v in latest[c]), float, self.width)
        self.frame(t, x)

    # the workflow ---------------------------------------------------------------------------------
    def tell(self, *what: Any) -> None:
        self.out(len(self.out_specs) - 1, tuple(what))

    def do_record(self, label: Any = None, count: Any = 1) -> None:
        """Record the next example(s) of ``label``."""
        if label is None:
            raise TypeError("record needs a label: record circle (or record null for no gesture)")
        label = check_name("label", str(label))  # it becomes a folder when exported: never a path
        try:
            n = int(float(count))
        except (TypeError, ValueError):
            n = 0
        if not 1 <= n <= 1000:
            raise ValueError(f"record: the count is 1..1000; got {count!r}")
        self.recording, self.to_record = label, n
        self.running = False
        self.start_recording()
        self.tell("recording", label, n)

    def start_recording(self) -> None:
        """The node starts watching for an example."""

    def took(self, example: Example) -> None:
        """An example was recorded."""
        self.examples.append(example)
        n = sum(e.label == example.label for e in self.examples)
        self.tell("example", example.label, n)
        self.to_record -= 1
        if self.to_record <= 0:
            self.recording = None
            self.tell("recorded", example.label, n)

    def do_stop(self) -> None:
        """Stop recording, or recognising."""
        self.recording, self.running = None, False
        self.tell("stopped")

    def do_train(self) -> None:
        """Learn from the examples, and run (a recording under way stops; one that cannot train goes on)."""
        self.fit()
        self.recording = None
        self.running = True
        labels = sorted({e.label for e in self.examples} - {NULL})
        counts = {lab: sum(e.label == lab for e in self.examples) for lab in labels}
        self.tell("trained", len(labels), len(self.examples))
        few = [lab for lab, n in counts.items() if n < 2]
        if few and self.kind != "follow":
            log.warning(
                "%s '%s': one example only of %s: record two or more of each, so that the node learns how"
                " far a performance may stray",
                self.type_name,
                self.name,
                ", ".join(few),
            )

    def do_run(self) -> None:
        """Recognise (after record or stop); the model must be trained."""
        if not self.trained:
            raise ValueError("run: nothing trained yet (record examples, then train; or load)")
        self.recording = None
        self.running = True
        self.tell("running")

    @property
    def trained(self) -> bool:
        return False

    def do_clear(self, label: Any = None) -> None:
        """Forget every example, or those of ``label`` (train again to take it into account)."""
        if label is None:
            self.examples = []
            self._unread = None
        else:
            self.examples = [e for e in self.examples if e.label != str(label)]
        self.tell("cleared", *(() if label is None else (str(label),)), len(self.examples))

    @names_path
    def do_save(self, path: Any = None) -> None:
        target = str(path) if path is not None else self.p.file
        if self._unread is not None and os.path.realpath(target) == os.path.realpath(self._unread):
            raise ValueError(
                f"save: {target} did not read at the start (see the warning then), and its examples would be"
                " lost: mend it and send load, send clear to replace it, or save PATH elsewhere"
            )
        if not self.examples:
            raise ValueError("save: no examples to save (record some first)")
        if len(self.examples) > MOST_EXAMPLES:
            raise ValueError(
                f"save: {len(self.examples)} examples, more than a model file holds (clear some)"
            )
        # written on the saver's thread (the latest save wins), never holding the patch up
        examples, kind, channels, size = list(self.examples), self.kind, self.channels, self.p.size
        self._saver.submit(target, lambda: model_text(kind, channels, size, examples))
        self.tell("saved", target, len(self.examples))

    @names_path
    def do_load(self, path: Any = None) -> None:
        target = str(path) if path is not None else self.p.file
        self._load(target)
        self.tell("loaded", target, len(self.examples))

    def _load(self, target: str) -> None:
        channels, size, examples = load_model(target, self.kind)
        if channels != self.channels or size != self.p.size:
            raise ValueError(
                f"load: {target} holds channels {' '.join(channels)}"
                f"{f' (size {size})' if size else ''}; this node takes {' '.join(self.channels)}"
            )
        old = self.examples
        self.examples = examples
        try:
            self.fit()
        except ValueError:
            self.examples = old
            raise
        self._unread = None
        self.running = True

    def prepare(self) -> None:
        """Read and learn the examples in ``file`` when it is there (before the clock starts: the first
        training of a process compiles the DTW)."""
        self._loaded: tuple[Any, ...] | None = None
        if self.kind != "posture":
            warm()  # every DTW kernel compiled or loaded now, not at the first gesture
        path = self.p.file
        if path:
            clean_stray(path)  # a save a kill cut short
        if not path or not os.path.exists(path):
            return
        try:
            self._load(path)
        except ValueError as exc:
            self._unread = path
            log.warning(
                "%s '%s': %s; starting with nothing learnt (save refuses to replace the file until clear)",
                self.type_name,
                self.name,
                exc,
            )
            return
        self._loaded = ("loaded", path, len(self.examples))
        log.info("%s '%s': %d examples from %s, running", self.type_name, self.name, len(self.examples), path)

    def close(self) -> None:
        """Write a save still waiting."""
        self._saver.close()

    def loadbang(self) -> None:
        """Say what :meth:`prepare` loaded: the node recognises from the first sample."""
        if getattr(self, "_loaded", None) is not None:
            self.tell(*self._loaded)

    def health(self) -> dict[str, Any]:
        labels = sorted({e.label for e in self.examples})
        mode = f"recording {self.recording}" if self.recording else "running" if self.running else "idle"
        return {"mode": mode, "examples": len(self.examples), "labels": " ".join(labels) or "none"}


_COMMON = (
    _file_param("gestures.json"),
    Param("size", "int", 0, "how many numbers channel x holds (0: no x)", minimum=0, maximum=1000),
)
_START = Param(
    "start",
    "float",
    0.3,
    "a movement starts above this share of the examples' peak motion",
    live=True,
    above=0.0,
    maximum=1.0,
)
STATUS = Outlet("status", "list", "what the node did: recording, example, trained, saved, loaded...")


def model_options(p: Any) -> dict[str, Any]:
    """The :class:`GestureModel`'s options from a gesture node's parameters (``pointat gestures evaluate
    --set`` takes the same)."""
    return {
        "size": p.size,
        "band": p.band,
        "reject": p.reject,
        "warp": p.warp,
        "relative": tuple(str(c) for c in p.relative),
        "scale": p.scale,
    }


def recognizer_options(p: Any) -> dict[str, Any]:
    """The :class:`Recognizer`'s options from a gesture node's parameters."""
    return {
        "start": p.start,
        "settle": p.settle / 1000.0,
        "refractory": p.refractory / 1000.0,
        "early": p.early,
        "adapt": p.adapt,
        "keep": p.keep,
        "cut": p.cut,
    }


@register("gesture")
class GestureNode(_Learner):
    """Trained movements: teach a few examples of each, and the node names each movement it sees.

    Movements are cut from rest to rest (a movement starts when the hand moves faster than ``start``
    times the examples' typical peak, and ends ``settle`` ms after it slows), or by a gate: ``gate 1``
    ... ``gate 0`` (a button or a pedal held while the gesture is made).  ``cut=spot`` finds them with
    no rest between them (repetitions one after another): every example is matched anywhere in the
    stream, and the best of overlapping matches is told half an example after it ends (one that begins
    where the last told ended is preferred: repetitions keep a rhythm); it finds a match in ordinary
    moves far more often than a rest-to-rest cut, so keep it for phrases of repetitions, and it tells
    gestures only (no early decision, ``refractory``, ``adapt``, ``none`` or ``motion``).
    Each is compared to every example by dynamic time warping (1-NN DTW; all features warped together,
    or each on its own when that names more of the examples, each left out in turn; the accelerometer
    as it is, so the hand's attitude counts), with a null class.  A movement is no gesture (``none``) when:

    * it is farther from its nearest class than ``reject`` times the class's reach (how far its
      examples are from keeping still);
    * or its class is itself nearly still (standing, a hand held) and it is not;
    * or it is not nearer to the class than three times its own distance from keeping still (a
      tremble, a small turn of the wrist);
    * or it is three times faster or slower, stronger or weaker than the class's examples (a tap, a
      jolt);
    * or its nearest example was recorded as ``null`` (``record null 10`` while moving as between
      gestures, if the node fires on ordinary moves).

    The defaults were chosen on real recordings and tested on others (``benchmarks/GESTURES_REAL.md``).
    A gesture meant to be the same wherever the hand points (a circle made high or low) wants
    ``relative=[acc q]``, the hand's attitude left out: the simulated glove's performer, who gestures at
    other elevations than he rehearsed, was then found 98 -> 100 % and told before the end 69 -> 97 %;
    on real recordings of arm exercises, told apart by the attitude, it cost up to 10 points.
    A gesture is told as soon as the evidence allows (``early``: most of an example matched, every
    other class far behind), else as the movement ends; then nothing for ``refractory`` ms.  With
    ``adapt``, a movement recognised with a clear margin becomes an example of its class (at most
    ``keep`` a class, the oldest taken first; ``status`` says ``adapted LABEL N``; ``save`` keeps
    them), so the examples follow a performer's drift over days.

    ``gesture`` says ``LABEL SCORE`` (score 1 at an example, 0 at the rejection's edge): wire it to a
    ``route`` of the labels.  ``none`` says the nearest label and its distance.  ``motion`` says 1 when
    a movement starts and 0 when it ends.
    """

    kind = "gesture"
    outlets = (
        Outlet("gesture", "list", "LABEL SCORE, once a movement is recognised"),
        Outlet("none", "list", "NEAREST DISTANCE: a movement that is no gesture"),
        Outlet("motion", "int", "1 as a movement starts, 0 as it ends"),
        STATUS,
    )
    params = (
        _channels_param(("gyr", "acc")),
        *_COMMON,
        Param(
            "reject",
            "float",
            REJECT,
            "no gesture beyond this many times its class's reach, its distance from keeping still (0: never)",
            live=True,
            minimum=0.0,
        ),
        _START,
        Param(
            "settle", "float", 100.0, "a movement ends after this long slow", unit="ms", live=True, above=0.0
        ),
        Param(
            "refractory",
            "float",
            250.0,
            "after a gesture, none for this long",
            unit="ms",
            live=True,
            minimum=0.0,
        ),
        Param(
            "early",
            "bool",
            True,
            "tell a gesture before it ends when the evidence allows (with gyr or q)",
            live=True,
        ),
        Param("band", "float", 0.5, "DTW's band, a share of the longer movement", minimum=0.0, maximum=1.0),
        Param(
            "warp",
            "symbol",
            "auto",
            "all features warped together, each on its own, or auto: the one that names more of the"
            " examples, each left out in turn",
            choices=WARPS,
        ),
        Param(
            "relative",
            "list",
            RELATIVE,
            "channels taken relative to how the movement began: acc (the hand's attitude left out), q",
        ),
        Param(
            "scale",
            "symbol",
            "spread",
            "how channel groups are weighed: each by its spread over the examples, or in their units by one"
            " spread (common: acc in g, gyr in rad/s; si: acc in m/s², as plain DTW)",
            choices=SCALES,
        ),
        Param(
            "cut",
            "symbol",
            "rest",
            "how movements are found: from rest to rest, or spot (repetitions with no rest between them)",
            choices=CUTS,
        ),
        Param("adapt", "bool", False, "learn from movements recognised with a clear margin", live=True),
        Param(
            "keep", "int", 10, "adapt: the most examples a class keeps", live=True, minimum=1, maximum=1000
        ),
    )
    example = """
node glove simulate rate=100 script=gestures
node nulls offset samples=150
node units scaling
node moves gesture channels=[gyr acc] file=moves.json
node which route circle flick nod
node cue   print prefix="a circle"
glove.adc -> nulls -> units
units.accel -> moves.acc
units.gyro -> moves.gyr
moves.gesture -> which
which.0 -> cue
"""

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        super().validate(values)
        relative_channels(values["relative"])

    def build(self) -> None:
        self.model = GestureModel(self.channels, **model_options(self.p))
        self.rec = Recognizer(self.model, **recognizer_options(self.p))
        self._moving = False
        self._spot_adapt()

    def _spot_adapt(self) -> None:
        """Say so when ``adapt`` is asked of a spotter, which does not adapt."""
        if self.p.cut == "spot" and self.p.adapt:
            log.warning(
                "%s '%s': adapt does nothing with cut=spot (a spotter tells gestures only); cut=rest adapts",
                self.type_name,
                self.name,
            )

    @property
    def trained(self) -> bool:
        return self.model.trained

    def fit(self) -> None:
        self.model.train(self.examples)
        self.rec.retune()

    def param_changed(self, name: str) -> None:
        self.model.reject = self.p.reject
        rec = self.rec
        rec.start, rec.settle = self.p.start, self.p.settle / 1000.0
        rec.refractory, rec.use_early = self.p.refractory / 1000.0, self.p.early
        rec.adapt, rec.keep = self.p.adapt, self.p.keep
        if name in ("start", "settle"):
            rec.retune()
        elif name == "adapt":
            self._spot_adapt()

    def start_recording(self) -> None:
        self.rec.record = self.recording
        self.rec.retune()

    def do_gate(self, on: Any = 1) -> None:
        """``gate 1``: a movement starts now; ``gate 0``: it ends; ``gate auto``: cut from rest to rest."""
        if str(on) == "auto":
            state = None
        else:
            try:
                state = float(on) != 0.0
            except (TypeError, ValueError):
                raise ValueError(f"gate: expected 1, 0 or auto; got {str(on)[:40]!r}") from None
        self._events(self.rec.gate(state, self.time))

    def frame(self, t: float, x: np.ndarray) -> None:
        if not (self.running or self.recording):
            return
        self.rec.record = self.recording
        self._events(self.rec.push(t, x))

    def _events(self, events: list[Event]) -> None:
        for e in events:
            match e:
                case Started():
                    self._moving = True
                    self.out(2, 1)
                case Ended() | Dropped():
                    if self._moving:
                        self._moving = False
                        self.out(2, 0)
                case Recorded(example):
                    self.took(example)
                    if self.recording is None:
                        self.rec.record = None
                case Adapted(label, count):
                    self.examples = list(self.model.examples)
                    self.tell("adapted", label, count)
                case Decided(d):
                    if d.label is not None:
                        self.out(0, (d.label, round(d.score, 4)))
                    else:
                        self.out(1, (d.nearest, round(d.distance, 4)))


@register("posture")
class PostureNode(_Learner):
    """Postures: hold the hand a way, teach it a name, and the node names it whenever the hand is so.

    By default a posture is the hand's attitude (the direction of gravity in the hand, from the
    orientation ``q``: where the performer faces does not matter; ``heading=true`` takes that in too),
    and any other features wired to ``x`` (flex sensors...).  ``record LABEL`` takes the next
    ``samples`` frames (hold the posture meanwhile; move a little about it to teach its breadth).
    Each frame is named by its ``k`` nearest example frames (k-NN), none when the nearest is farther
    than ``reject`` times the posture's spread.  A new posture is told once it has held ``hold`` ms:
    ``posture`` says ``LABEL`` as it is taken, ``none`` bangs as the hand leaves every posture.
    """

    kind = "posture"
    outlets = (
        Outlet("posture", "symbol", "the posture's label, when the hand takes it"),
        Outlet("none", "bang", "the hand left every posture"),
        STATUS,
    )
    params = (
        _channels_param(("q",)),
        _file_param("postures.json"),
        _COMMON[1],
        Param("samples", "int", 50, "frames taken by one record", minimum=1, maximum=60000),
        Param("k", "int", 5, "neighbours that vote", minimum=1, maximum=100),
        Param(
            "reject",
            "float",
            3.0,
            "none beyond this many spreads of the nearest posture (0: never)",
            live=True,
            minimum=0.0,
        ),
        Param(
            "hold",
            "float",
            100.0,
            "a posture must hold this long to be told",
            unit="ms",
            live=True,
            minimum=0.0,
        ),
        Param("heading", "bool", False, "q: where the hand faces counts too"),
    )
    example = """
node glove simulate rate=100
node nulls offset samples=150
node units scaling
node tqt   tqt rate=100
node hand  posture channels=[q] file=hand.json
node show  print prefix=posture
glove.adc -> nulls -> units
units.mag -> tqt.mag
units.accel -> tqt.accel
units.gyro -> tqt.gyro
tqt.quat -> hand.q
hand.posture -> show
"""

    def build(self) -> None:
        self.model = PostureModel(
            self.channels, size=self.p.size, k=self.p.k, reject=self.p.reject, heading=self.p.heading
        )
        self._buffer: list[np.ndarray] = []
        self._times: list[float] = []
        self._current: str | None = None
        self._candidate: str | None = None
        self._since = 0.0

    @property
    def trained(self) -> bool:
        return self.model.trained

    def fit(self) -> None:
        self.model.train(self.examples)
        self._current = self._candidate = None

    def param_changed(self, name: str) -> None:
        self.model.reject = self.p.reject

    def start_recording(self) -> None:
        self._buffer, self._times = [], []

    def frame(self, t: float, x: np.ndarray) -> None:
        if self.recording:
            self._buffer.append(x)
            self._times.append(t)
            if len(self._buffer) >= self.p.samples:
                times = np.array(self._times)
                if not np.all(np.diff(times) > 0):  # frames of one instant: spaced as they came
                    times = np.arange(len(times), dtype=float)
                self.took(Example(self.recording, times, np.array(self._buffer)))
                self._buffer, self._times = [], []
            return
        if not self.running:
            return
        label, _ = self.model.classify(x)
        if label != self._candidate:
            self._candidate, self._since = label, t
        if label != self._current and t - self._since >= self.p.hold / 1000.0:
            self._current = label
            if label is None:
                self.out(1, bang(t))
            else:
                self.out(0, label)


@register("stroke")
class StrokeNode(Node):
    """Percussive strokes: the onset of each, the direction the hand struck towards, and its strength.

    From the accelerometer (``acc``, m/s², scaling's accel) and, wired to ``q``, the fused orientation
    (tqt's quat): the acceleration is turned into the room and gravity taken off, so a stroke's
    direction is the room's (azimuth + left, elevation + up, degrees: a strike down on a drum is
    elevation -90; one forward at the front loudspeaker, azimuth 0 elevation 0).  Without ``q`` the
    direction is in the hand's frame.  A stroke is a sharp peak of the linear acceleration over
    ``threshold`` g (it rises from under half its peak within 20 ms: an impact, not the swing of the
    arm), told one sample after its peak; the next may follow ``gap`` ms later, once the hand has calmed
    under half the threshold.  ``stroke`` says ``AZIMUTH ELEVATION STRENGTH`` (g).
    """

    needs_input = True
    inlets = (
        Inlet("acc", ("vector", "list"), "specific force, m/s² (hot)"),
        Inlet("q", ("vector", "list"), "orientation w x y z (tqt's quat): directions in the room"),
    )
    outlets = (Outlet("stroke", "list", "AZIMUTH ELEVATION STRENGTH: degrees, degrees, g"),)
    params = (
        Param(
            "threshold",
            "float",
            1.5,
            "a stroke peaks above this linear acceleration",
            unit="g",
            live=True,
            above=0.0,
        ),
        Param("gap", "float", 60.0, "the least time between strokes", unit="ms", live=True, minimum=0.0),
    )
    example = """
node glove simulate rate=100 burst=strokes burst_g=5 burst_every=10 burst_length=2
node nulls offset samples=150
node units scaling
node tqt   tqt rate=100
node hit   stroke threshold=1.5
node show  print prefix="stroke (azimuth elevation g)"
glove.adc -> nulls -> units
units.mag -> tqt.mag
units.accel -> tqt.accel
units.gyro -> tqt.gyro
units.accel -> hit.acc
tqt.quat -> hit.q
hit.stroke -> show
"""

    def setup(self) -> None:
        self.detector = StrokeDetector(self.p.threshold, self.p.gap / 1000.0)
        self._q: np.ndarray | None = None
        self.strokes = 0

    def param_changed(self, name: str) -> None:
        self.detector.threshold, self.detector.gap = self.p.threshold, self.p.gap / 1000.0

    def on_q(self, msg: Message) -> None:
        q = np.array(as_floats(msg, 4))
        if not np.all(np.isfinite(q)) or not np.linalg.norm(q) > 0:
            raise ValueError(f"q: expected a rotation quaternion, got {tuple(q)}")
        self._q = q

    def on_acc(self, msg: Message) -> None:
        a = np.array(as_floats(msg, 3))
        if not np.all(np.isfinite(a)):
            raise ValueError(f"acc: a value is not a finite number: {tuple(a)}")
        s = self.detector.push(msg.time, a, self._q)
        if s is not None:
            self.strokes += 1
            self.out(0, (round(s.azimuth, 2), round(s.elevation, 2), round(s.strength, 3)))

    def health(self) -> dict[str, Any]:
        return {"strokes": self.strokes}


@register("follow")
class FollowNode(_Learner):
    """Follow one trained movement as it unfolds: how far through it the hand is (0..1), and how fast.

    Record a few examples of the movement (``record LABEL``; every example counts, whatever its label),
    ``train``, and move: as a movement starts (from rest, as ``gesture`` cuts them) the node follows it
    against the example nearest the others, as XMM and GVF do (a left-to-right model, one state per
    frame), telling ``progress`` 0..1 and ``speed`` (1: as fast as the example, 2: twice) every 20 ms
    until the hand rests again.  ``bang`` starts following at once (without waiting for a movement).
    """

    kind = "follow"
    outlets = (
        Outlet("progress", "float", "0 .. 1 through the movement"),
        Outlet("speed", "float", "1 as fast as the example, 2 twice, 0.5 half"),
        STATUS,
    )
    params = (
        _channels_param(("gyr", "acc")),
        _file_param("follow.json"),
        _COMMON[1],
        _START,
        Param(
            "settle",
            "float",
            200.0,
            "following stops after the hand has been slow this long",
            unit="ms",
            live=True,
            above=0.0,
        ),
    )
    example = """
node glove simulate rate=100 script=gestures
node nulls offset samples=150
node units scaling
node bow   follow channels=[gyr acc] file=bow.json
node show  print prefix=progress
glove.adc -> nulls -> units
units.accel -> bow.acc
units.gyro -> bow.gyr
bow.progress -> show
"""

    def build(self) -> None:
        self.model = GestureModel(self.channels, size=self.p.size, reject=0.0)
        self.follower: Follower | None = None
        self._rec = Recognizer(self.model, start=self.p.start, settle=self.p.settle / 1000.0, early=False)
        self._following = False

    @property
    def trained(self) -> bool:
        return self.follower is not None

    def fit(self) -> None:
        examples = [Example("movement", e.t, e.frames) for e in self.examples]
        if not examples:
            raise ValueError("no examples to train on (record some first: record LABEL, then move)")
        self.model.train(examples)
        self.follower = Follower(self.model)
        self._rec.retune()
        self._segmenter()

    def _segmenter(self) -> None:
        on = self.model.motion_level(self.p.start)
        self.segmenter = Segmenter(on, 0.5 * on, self.p.settle / 1000.0, longest=math.inf)

    def param_changed(self, name: str) -> None:
        self._rec.start, self._rec.settle = self.p.start, self.p.settle / 1000.0
        self._rec.retune()
        if self.follower is not None:
            self._segmenter()

    def start_recording(self) -> None:
        self._rec.record = self.recording
        self._rec.retune()

    def receive(self, index: int, msg: Message) -> None:
        if index == 0 and msg.kind == "bang":
            self.time = msg.time
            if self.follower is not None:
                self.follower.reset()
                self._following = True
            return
        super().receive(index, msg)

    def frame(self, t: float, x: np.ndarray) -> None:
        if self.recording:
            self._rec.record = self.recording
            for e in self._rec.push(t, x):
                if isinstance(e, Recorded):
                    self.took(e.example)
            if self.recording is None:
                self._rec.record = None
            return
        if not self.running or self.follower is None:
            return
        what = self.segmenter.push(t, self._rec.energy(t, x))
        if what == "start" and not self._following:
            self.follower.reset()
            self._following = True
        elif what in ("end", "drop"):
            self._following = False
        if self._following:
            out = self.follower.push(t, x)
            if out is not None:
                self.emit(out[0], out[1])
