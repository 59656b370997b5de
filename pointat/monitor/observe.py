"""What a running patch is doing, told to people: the console's status lines, the monitor page, OSCQuery.

An :class:`Observer` watches a built :class:`~pointat.runtime.Runtime` from a thread of its own:

* **Sensor streams**: every wired outlet of a source that carries one sample per message (a node
  class's :attr:`~pointat.node.Node.sample_outlets`: a ``mote``'s ``m1``, a ``replay``'s ``gyro``...).
  A tap on it counts the samples and notes when the last came: the rate, and a *dropout* when none came
  for :attr:`Observer.DROPOUT` seconds (or five sample periods, whichever is longer).
* **Pointers**: every node that declares a ``direction`` reading (:class:`~pointat.node.Reading`, an
  ``osc_out``'s ``aed``): the direction it last sent (azimuth, elevation, distance), read from the node
  (:meth:`~pointat.node.Node.read`), never fed, and its state as its health tells it: ``waiting`` (no
  direction in yet), ``ok``, ``dropout`` (no direction in for the node's ``dropout`` seconds) or the
  filter's flag.
* **Flags**: every ``flags`` outlet is tapped: the filter's state as it changes (``mag_disturbed``,
  ``acc_saturated``...), with when it changed; a filter whose every stream upstream is down is
  ``no input``, whatever its last flag said (a silent filter sends no flag).
* **Health and readings**: what each node's :meth:`~pointat.node.Node.health` says (a filter's rest
  and bias learning, a mote's lost packets, a calibration's step, an ``osc_out``'s refused datagrams),
  and the values of its other readings, with their units.
* **Loudspeakers**: the :class:`~pointat.maths.vbap.Layout` of the patch's first node that holds one as
  its ``layout`` (a ``vbap``), else the one given (``pointat run --layout``), else a ring of eight; the
  VBAP gains of each pointer's direction are worked out here.

The scheduler pays one call per sample and per flag for the taps (a counter and a clock read).  Every
other reading, the history of the last :attr:`Observer.HISTORY` seconds and the gains are the observer
thread's, :attr:`Observer.RATE` times a second, and only while the monitor is served (the console's
status lines take a reading when they are written); a reading hands the interpreter to the scheduler
between gloves, so that it never waits for a whole reading.  A reading that races the scheduler (a
direction being written) is at most one sample old.
"""

from __future__ import annotations

import logging
import math
import re
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..maths.vbap import Layout, make_layout, vbap_gains
from ..message import Message
from ..node import Node, Tap
from ..scheduling import quiet_thread

__all__ = ["Observer", "fmt_direction"]

log = logging.getLogger("pointat.monitor.observe")


@dataclass
class Stream:
    """One sensor stream: a source node's sample outlet."""

    node: Node
    outlet: str
    index: int
    count: int = 0
    first: float = -math.inf  # time.monotonic() of the first sample
    last: float = -math.inf  # time.monotonic() of the last sample
    rate: float = 0.0  # samples per second over the last second
    nominal: float = 0.0  # the node's rate parameter, when it has one
    dropouts: int = 0
    down_since: float | None = None
    down_total: float = 0.0

    @property
    def key(self) -> str:
        return f"{self.node.name}.{self.outlet}"

    #: Seconds without a sample that are a dropout (:attr:`Observer.DROPOUT`, or five of the stream's
    #: periods when that is longer), set by the observer.
    gap: float = math.inf

    def hit(self, _msg: Message) -> None:  # the scheduler's one call per sample
        self.hits(1)

    def hits(self, n: int) -> None:
        """``n`` samples now."""
        now = time.monotonic()
        if not self.count:
            self.first = now
        elif now - self.last > self.gap and self.down_since is None:  # no reading fell in it
            self.dropouts += 1
            self.down_total += now - self.last
        self.count += n
        self.last = now


@dataclass
class Pointer:
    """One node with a ``direction`` reading: where it points, and its recent past."""

    node: Node
    reading: str  # the name of its direction reading
    history: deque = field(default_factory=deque)  # (t, az, el, dist)
    heard: tuple[int, float] = (0, -math.inf)  # (directions in, when a reading saw that count change)


def fmt_direction(az: float, el: float, dist: float | None = None) -> str:
    """A direction as a person reads it: degrees to 0.1, distance to 1 (the gesture's 0 far .. 90 near).

    >>> fmt_direction(23.456, -1.04, 12.7)
    'az 23.5°  el -1.0°  dist 13'
    """
    text = f"az {az:5.1f}°  el {el:4.1f}°"
    return text if dist is None else f"{text}  dist {dist:.0f}"


#: What a filter is said to be while every stream upstream of it is down (a silent filter sends no flag).
NO_INPUT = "no input"

#: Flag words a filter sends, in the order the state line prefers them (the first one up is shown).
FLAG_ORDER = ("bad_gyro", "bad_accmag", "gyro_saturated", "acc_saturated", "mag_disturbed", "shaking")


class Observer:
    """Watches a runtime for people (console, monitor, OSCQuery).  :meth:`attach` before the runtime
    starts, :meth:`start` the thread, :meth:`stop` at the end; :meth:`snapshot` any time."""

    #: Readings a second taken by the thread (directions, rates, health).
    RATE = 25.0
    #: Seconds of history kept for the plots.
    HISTORY = 10.0
    #: A stream with no sample for this long (or five of its periods, whichever is longer) is down: as
    #: ``osc_out``'s ``dropout``.  The longest gap between a simulated glove's directions at a receiver,
    #: over three 20 s runs on two cores busy with the test suite beside them, was 128 ms.
    DROPOUT = 0.5

    def __init__(self, rt: Any, *, layout: Layout | None = None, patch: str = "", about: str = ""):
        self.rt = rt
        self.patch = patch
        self.about = about
        self.streams: list[Stream] = []
        self.pointers: list[Pointer] = []
        self.flags: dict[str, list[Any]] = {}  # node name -> [word, since (monotonic), changes]
        self.fed_by: dict[str, list[Stream]] = {}  # a flags node's name -> the streams upstream of it
        self.flag_log: deque = deque(maxlen=200)  # (monotonic, node, word)
        self.layout, self.layout_from = self._layout(layout)
        self.started = time.monotonic()
        self._snapshot: dict[str, Any] = {}
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._listeners: list[Callable[[dict[str, Any]], None]] = []
        self._marks: deque = deque()  # (monotonic, {stream key: count}) for the rates
        #: Work out what only the page shows (the VBAP gains); the monitor's server sets it.
        self.detailed = False
        self.accel: dict[str, list[Any]] = {}  # outlet -> [the last acceleration vector]
        self.accel_history: dict[str, deque] = {}
        self._attached: dict[str, Node] = {}  # the nodes tapped, by name
        self._tapped: set[tuple[str, int]] = set()  # (node, outlet) tapped

    # -- setting up --------------------------------------------------------------------------------
    def _layout(self, given: Layout | None) -> tuple[Layout, str]:
        for node in self.rt.nodes.values():
            if isinstance(getattr(node, "layout", None), Layout):
                return node.layout, f"{node.type_name} '{node.name}'"
        if given is not None:
            return given, "--layout"
        return make_layout(
            [0, 45, 90, 135, 180, -135, -90, -45]
        ), "a ring of eight (no vbap node, no --layout)"

    def attach(self) -> Observer:
        """Find the streams, pointers and flags of the runtime and tap them (before it starts)."""
        for node in self.rt.nodes.values():
            self._attach(node)
        self._upstream()
        return self

    def reattach(self, *_: Any) -> Observer:
        """After a hot reload (:mod:`pointat.reload`, on the scheduler's thread): forget the nodes that
        left the patch and tap the new ones, and the outlets of kept nodes wired only now; the nodes kept
        keep their taps, counts and history."""
        nodes = self.rt.nodes
        gone = {name for name, node in self._attached.items() if nodes.get(name) is not node}
        self.streams = [s for s in self.streams if s.node.name not in gone]
        self.pointers = [p for p in self.pointers if p.node.name not in gone]
        self._tapped = {(name, i) for name, i in self._tapped if name not in gone}
        for name in gone:
            self._attached.pop(name)
            self.flags.pop(name, None)
            for key in [k for k in self.accel if k.startswith(f"{name}.")]:
                self.accel.pop(key)
                self.accel_history.pop(key, None)
        for node in nodes.values():
            self._attach(node)
        self._upstream()
        return self

    def _attach(self, node: Node) -> None:
        """Tap ``node``'s outlets that are wired and not tapped yet."""
        known = self._attached.get(node.name) is node
        self._attached[node.name] = node
        pattern = type(node).sample_outlets
        for i, spec in enumerate(node.out_specs):
            if not node.connected(i) or (node.name, i) in self._tapped:
                continue  # not wired: not used by this patch (or tapped already)
            self._tapped.add((node.name, i))
            if pattern and re.fullmatch(pattern, spec.name):
                nominal = getattr(node.p, "rate", 0.0) if hasattr(node.p, "rate") else 0.0
                stream = Stream(node, spec.name, i, nominal=float(nominal or 0.0))
                stream.gap = max(self.DROPOUT, 5.0 / stream.nominal if stream.nominal > 0 else 0.0)
                self.streams.append(stream)
                node.tap(i, stream.hit, stream.hits)
            elif spec.name == "flags" and spec.kind == "symbol":
                self.flags[node.name] = ["ok", time.monotonic(), 0]
                node.tap(i, self._flag_tap(node.name))
            if spec.name == "accel" and spec.kind == "vector" and len(self.accel) < 4:
                if node.connected(i) and type(node).sample_outlets == "":
                    self.accel[f"{node.name}.accel"] = box = [None]
                    self.accel_history[f"{node.name}.accel"] = deque()
                    node.tap(i, _keep(box))
        if not known:
            for reading in type(node).readings:
                if reading.direction:
                    self.pointers.append(Pointer(node, reading.name))
                    break

    def _upstream(self) -> None:
        self.fed_by = {
            name: [s for s in self.streams if name in _downstream(s.node, s.index)] for name in self.flags
        }

    def _flag_tap(self, name: str) -> Callable[[Message], None]:
        state = self.flags[name]

        def flag(msg: Message) -> None:
            word = str(msg.value)
            state[0], state[1] = word, time.monotonic()
            state[2] += 1
            self.flag_log.append((state[1], name, word))

        return flag

    def listen(self, fn: Callable[[dict[str, Any]], None]) -> None:
        """Call ``fn(snapshot)`` from the observer's thread after each reading."""
        self._listeners.append(fn)

    def start(self) -> None:
        self.started = time.monotonic()
        # it sleeps between readings: a spinning scheduler (--spin) polls beside it without pauses
        self._thread = quiet_thread(threading.Thread(target=self._run, name="pointat-observer", daemon=True))
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(2.0)

    def _run(self) -> None:
        period = 1.0 / self.RATE
        next_at = time.monotonic()
        while not self._stop.is_set():
            try:
                snap = self.read()
                for fn in list(self._listeners):
                    fn(snap)
            except Exception:  # the observer must never take the patch down
                log.exception("observer: a reading failed")
            next_at += period
            self._stop.wait(max(0.0, next_at - time.monotonic()))
            next_at = max(next_at, time.monotonic() - period)

    # -- reading -----------------------------------------------------------------------------------
    def read(self) -> dict[str, Any]:
        """Take one reading now (the thread does this :attr:`RATE` times a second)."""
        now = time.monotonic()
        t = round(now - self.started, 3)
        streams = self._read_streams(now)
        snap = {
            "patch": self.patch,
            "about": self.about,
            "t": t,
            "layout": {
                "from": self.layout_from,
                "dim": self.layout.dim,
                "azimuths": [float(a) for a in self.layout.azimuths],
                "elevations": [float(e) for e in self.layout.elevations],
            },
            "streams": streams,
            "flags": self._read_flags(now, streams),
            "pointers": self._read_pointers(now),
            "history": {p.node.name: list(p.history) for p in self.pointers},
            "accel": self._read_accel(t),
            "accel_history": {k: list(h) for k, h in self.accel_history.items()},
            "nodes": self._read_others(),
            "events": [
                [round(when - self.started, 2), name, word] for when, name, word in list(self.flag_log)[-20:]
            ],
        }
        with self._lock:
            self._snapshot = snap
        return snap

    def _rates_since(self, now: float) -> tuple[float, dict[str, int]]:
        """The seconds since a mark about a second ago, and each stream's count then (the rates' base)."""
        self._marks.append((now, {s.key: s.count for s in self.streams}))
        while len(self._marks) > 2 and now - self._marks[1][0] >= 1.0:
            self._marks.popleft()
        then, before = self._marks[0]
        return now - then, before

    def _read_streams(self, now: float) -> list[dict[str, Any]]:
        """Each sensor stream's rate and state: ``waiting``, ``ok`` or ``dropout`` (counted as it begins)."""
        span, before = self._rates_since(now)
        streams = []
        for s in self.streams:
            _let_others_run()
            if span > 0.2:
                s.rate = (s.count - before.get(s.key, 0)) / span
            elif s.count > 1 and s.last > s.first:  # the first reading: the rate since the first sample
                s.rate = (s.count - 1) / (s.last - s.first)
            late = now - s.last
            down = s.count > 0 and late > s.gap
            # "ok" says samples flow at a rate: none yet, or one alone, is still waiting
            waiting = not down and (s.count == 0 or s.rate <= 0.0)
            if down and s.down_since is None:
                s.down_since = s.last
                s.dropouts += 1
            elif not down and s.down_since is not None:
                s.down_total += s.last - s.down_since
                s.down_since = None
            streams.append(
                {
                    "name": s.key,
                    "node": s.node.name,
                    "type": s.node.type_name,
                    "state": "waiting" if waiting else "dropout" if down else "ok",
                    "rate": round(s.rate, 1),
                    "nominal": s.nominal,
                    "samples": s.count,
                    "dropouts": s.dropouts,
                    "silent_s": round(late, 2) if down else 0.0,
                    **_health(s.node),
                }
            )
        return streams

    def _read_flags(self, now: float, streams: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
        """Each filter's flag as it last said it, or ``no input`` when every stream upstream is down."""
        flags = {}
        down = {s["name"]: s["silent_s"] for s in streams if s["state"] == "dropout"}
        for name, (word, since, changes) in self.flags.items():
            node = self.rt.nodes.get(name)
            fed = [s.key for s in self.fed_by.get(name, ())]
            silent = fed and all(k in down for k in fed)
            flags[name] = {
                "flag": NO_INPUT if silent else word,
                "silent_s": min(down[k] for k in fed) if silent else 0.0,
                "for_s": round(now - since, 1),
                "changes": changes,
                **(_health(node) if node is not None else {}),
            }
        return flags

    def _read_pointers(self, now: float) -> list[dict[str, Any]]:
        """Each pointer's direction, state and (for the page) VBAP gains; its history grows."""
        pointers = []
        for p in self.pointers:
            _let_others_run()
            health = _health(p.node)
            az, el, dist = _direction(p.node, p.reading)
            heard = health.get("heard", health.get("updates", 0))
            if heard != p.heard[0]:
                p.heard = (heard, now)
            silent = now - p.heard[1]
            if not heard:
                state = "waiting"
            elif silent > getattr(p.node.p, "dropout", self.DROPOUT):
                state = "dropout"
            else:
                state = health.get("flag", "ok") or "ok"
            p.history.append((round(now - self.started, 3), round(az, 2), round(el, 2), round(dist, 2)))
            while p.history and p.history[-1][0] - p.history[0][0] > self.HISTORY:
                p.history.popleft()
            if self.detailed and heard:  # the page's; the console needs none
                gains = vbap_gains(self.layout, az, el)
            else:
                gains = np.zeros(self.layout.n)
            pointers.append(
                {
                    **({"sent": health["updates"]} if "updates" in health else {}),
                    **health,
                    "name": p.node.name,
                    "about": p.node.describe(),
                    "azimuth": round(az, 1),
                    "elevation": round(el, 1),
                    "distance": round(dist, 1),
                    "state": state,
                    "silent_s": round(silent, 2) if state == "dropout" else 0.0,
                    "gains": [round(float(g), 3) for g in gains],
                }
            )
        return pointers

    def _read_accel(self, t: float) -> dict[str, float]:
        """Each tapped acceleration's magnitude in g; their history grows."""
        accel = {}
        for key, (value,) in self.accel.items():
            if value is not None:
                g = float(np.linalg.norm(np.asarray(value, dtype=float)[:3])) / _G
                accel[key] = round(g, 3)
                h = self.accel_history[key]
                h.append((t, accel[key]))
                while h and t - h[0][0] > self.HISTORY:
                    h.popleft()
        return accel

    def _read_others(self) -> list[dict[str, str]]:
        """What the other nodes' health and readings say (a calibration's step, a recording's rows), in
        words."""
        seen = {s.node.name for s in self.streams} | set(self.flags) | {p.node.name for p in self.pointers}
        others = []
        for name, node in self.rt.nodes.items():
            if name in seen:
                continue
            words = []
            if type(node).health is not Node.health:
                words += [f"{k.replace('_', ' ')}: {v}" for k, v in _health(node).items()]
            words += _reading_words(node)
            if words:
                others.append({"name": name, "text": ", ".join(words)})
        return others

    def snapshot(self) -> dict[str, Any]:
        """The latest reading (taken now when the thread has not run yet)."""
        with self._lock:
            snap = self._snapshot
        return snap or self.read()

    # -- words for the console ---------------------------------------------------------------------
    def status_lines(self) -> list[str]:
        """One line per pointer and per sensor stream, for the console's status line."""
        snap = self.read()
        lines = []
        worst = _worst_flag(snap["flags"])
        for p in snap["pointers"]:
            where = fmt_direction(p["azimuth"], p["elevation"], p["distance"])
            if p["state"] == "waiting":
                lines.append(f"{p['name']}: waiting for a direction (none sent yet)")
                continue
            if p["state"] == "dropout":
                lines.append(f"{p['name']}: NO DATA for {p['silent_s']:.1f} s (last {where})")
                continue
            sent = f"  ({p['updates']} sent" if "updates" in p else ""
            if sent:
                sent += (
                    f"; {p['refused']} refused: receiver not listening" if p.get("refused") else ""
                ) + ")"
            lines.append(f"{p['name']}: {where}{sent}" + (f"  [{worst}]" if worst else ""))
        for s in snap["streams"]:
            lost = f", {s['lost']} lost" if s.get("lost") else ""
            if s["state"] == "waiting":
                lines.append(
                    f"{s['name']}: waiting for data" + (f" ({s['samples']} so far)" if s["samples"] else "")
                )
            elif s["state"] == "dropout":
                lines.append(f"{s['name']}: NO DATA for {s['silent_s']:.1f} s{lost}")
            else:
                lines.append(f"{s['name']}: ok, {s['rate']:.0f} Hz{lost}")
        for other in snap["nodes"]:  # a calibration's step, a recording's rows
            lines.append(f"{other['name']}: {other['text']}")
        return lines

    def summary(self) -> list[str]:
        """What happened, for the end of a run."""
        snap = self.read()
        took = time.monotonic() - self.started
        lines = [f"ran {took:.1f} s"]
        for s in self.streams:
            mean = s.count / took if took > 0 else 0.0
            down = s.down_total + (time.monotonic() - s.down_since if s.down_since is not None else 0.0)
            extra = _health(s.node)
            lines.append(
                f"{s.key}: {s.count} samples ({mean:.1f} Hz on average)"
                + (f", {extra['lost']} lost" if extra.get("lost") else "")
                + (f", {s.dropouts} dropouts ({down:.1f} s without data)" if s.dropouts else ", no dropout")
            )
        for p in snap["pointers"]:
            to = " to " + ", ".join(p["to"]) if p.get("to") else ""
            if "updates" not in p:  # a pointer that sends nothing, or does not count
                continue
            if p.get("refused"):  # datagrams, beside datagrams (the heartbeats are some of them)
                lines.append(
                    f"{p['name']}: {p['updates']} updates{to} ({p['sent']} datagrams sent, "
                    f"{p['refused']} refused: the receiver was not listening)"
                )
            else:
                lines.append(f"{p['name']}: {p['updates']} updates sent{to}")
        for other in snap["nodes"]:
            lines.append(f"{other['name']}: {other['text']}")
        for name, (word, _since, changes) in self.flags.items():
            seen = sorted({w for _t, n, w in self.flag_log if n == name and w != "ok"})
            if seen:
                lines.append(f"{name}: flagged {', '.join(seen)} ({changes} changes), now {word}")
        return lines


_G = 9.80665


def _keep(box: list[Any]) -> Callable[[Message], None]:
    def keep(msg: Message) -> None:
        box[0] = msg.value

    return keep


def _let_others_run() -> None:
    """Hand the interpreter to any thread that waits for it (the scheduler): a reading of many gloves is
    Python work of a millisecond or more, and the scheduler must not wait for all of it at once."""
    time.sleep(0)


def _health(node: Node) -> dict[str, Any]:
    try:
        return dict(node.health())
    except Exception:  # read from another thread while the node changes: next time
        return {}


def _downstream(node: Node, outlet: int) -> set[str]:
    """The names of the nodes an outlet reaches, through any number of wires (taps left out)."""
    seen: set[str] = set()
    todo = [target for target, _inlet in node.targets(outlet)]
    while todo:
        n = todo.pop()
        if isinstance(n, Tap) or n.name in seen:
            continue
        seen.add(n.name)
        todo += [target for o in range(len(n.out_specs)) for target, _inlet in n.targets(o)]
    return seen


def _reading_words(node: Node) -> list[str]:
    """A node's readings in words, each number with its unit (``level: -6 dB``)."""
    readings = type(node).readings
    values = _read(node) if readings else {}
    words = []
    for r in readings:
        try:
            numbers = np.atleast_1d(np.asarray(values[r.name], dtype=float))
        except (KeyError, TypeError, ValueError):  # not given now, or not numbers: not said
            continue
        said = (f"{v:.4g}{' ' + u if u else ''}" for v, u in zip(numbers, r.units, strict=False))
        words.append(f"{r.name.replace('_', ' ')}: {' '.join(said)}")
    return words


def _direction(node: Node, reading: str) -> tuple[float, float, float]:
    """A node's direction reading now: azimuth, elevation, distance (zeros while it cannot be read)."""
    try:
        az, el, dist = (float(v) for v in _read(node)[reading][:3])
    except (KeyError, TypeError, ValueError):  # not given now, or not three numbers
        return 0.0, 0.0, 0.0
    return az, el, dist


def _read(node: Node) -> Mapping[str, Any]:
    """What a node's :meth:`~pointat.node.Node.read` says now; nothing when it fails (read from another
    thread while the node changes: the next reading tries again; the debug log says why)."""
    try:
        return node.read()
    except Exception:
        log.debug("node '%s' (%s): read() failed", node.name, node.type_name, exc_info=True)
        return {}


def _worst_flag(flags: dict[str, dict[str, Any]]) -> str:
    # "no input" is no flag of a filter's: its glove's own line says NO DATA, the others' stay clear
    up = {f["flag"] for f in flags.values() if f["flag"] not in ("ok", NO_INPUT)}
    for word in FLAG_ORDER:
        if any(word in u for u in up):
            return word
    return sorted(up)[0] if up else ""
