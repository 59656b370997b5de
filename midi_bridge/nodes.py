r"""The MIDI nodes: ``midi_out`` (directions and gestures to a DAW, a synth or a file) and ``midi_in`` (a foot
controller).  They open ports only through :mod:`pointat.midi_bridge.ports`."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import mido
import mido.ports

from pointat.maths.scalar import fold_front
from pointat.message import Message, as_float, method
from pointat.node import Inlet, Node, Outlet, Param
from pointat.nodes.mapping import FOLD
from pointat.registry import register
from pointat.runtime import Timer

from . import ports
from .file_writer import acquire_writer, release_writer
from .mapping import MIDI_KINDS, MidiSender, check_mapping
from .ports import PortWatch, first_port, open_port, safe_stem

log = logging.getLogger("pointat.midi")


class _PortSink:
    def __init__(self, port: mido.ports.BaseOutput):
        self.port = port
        self.lost = False  # the port vanished (see PortWatch)

    def send(self, messages: list[mido.Message], time: float) -> None:
        for m in messages:
            self.port.send(m)

    def close(self) -> None:
        self.port.close()

    def __str__(self) -> str:
        return f"MIDI port {getattr(self.port, 'name', '')!r}"


class _FileSink:
    def __init__(self, path: str, bpm: float, ppq: int):
        self.writer = acquire_writer(path, bpm, ppq)

    def send(self, messages: list[mido.Message], time: float) -> None:
        self.writer.write_all(messages, time)

    def close(self) -> None:
        release_writer(self.writer)

    def __str__(self) -> str:
        return f"MIDI file {str(self.writer.path)!r}"


def _check_out_params(values: dict[str, Any]) -> None:
    check_mapping(
        values.get("kind", "cc"),
        values.get("channel", 1),
        values.get("number", 10),
        values.get("range", (0.0, 1.0)),
        values.get("velocity", 100),
    )
    if values.get("file") and (values.get("port") or values.get("virtual")):
        raise ValueError("give file= (a MIDI file) or port=/virtual= (a MIDI port), not both")
    if values.get("length", 100.0) < 0:
        raise ValueError(f"length must be >= 0 ms, got {values.get('length')}")
    if not values.get("bpm", 120.0) > 0:
        raise ValueError(f"bpm must be positive, got {values.get('bpm')}")
    if not 1 <= values.get("ppq", 480) <= 32767:
        raise ValueError(f"ppq must be 1..32767, got {values.get('ppq')}")


_MAPPING_PARAMS = {
    "kind": "kind",
    "channel": "channel",
    "number": "number",
    "range": "in_range",
    "velocity": "velocity",
    "change": "change",
}


@register("midi_out")
class MidiOut(PortWatch, Node):
    r"""Send values as MIDI: 7-bit or 14-bit CC, NRPN, pitch bend, or notes for gestures.

    A number at the inlet is mapped linearly from ``range`` ``[in_lo, in_hi]`` onto the MIDI range of
    ``kind`` (clipped): ``cc`` 0..127 on controller ``number``; ``cc14`` 0..16383 with the MSB on
    ``number`` (0..31) and the LSB on ``number + 32``; ``nrpn`` 0..16383 as CC99/98 (parameter ``number``)
    then CC6/38 (value); ``pitchbend`` 0..16383 (centre 8192).  With ``change`` (the default) a value that
    maps to the MIDI value already sent is not sent again.  A bang resends the last value.

    ``kind=note`` is for gestures: a non-zero number (1 from a threshold) sends note ``number`` on with
    ``velocity``, 0 sends it off; a bang strikes it and releases it ``length`` ms later; a list
    ``note velocity`` plays that note (velocity 0: off); ``off`` releases every note held.  Notes still
    held when the patch stops are released.

    Azimuth -> DAW pan (CC10: 0 left, 64 centre, 127 right; pointat's azimuth is + left): ``number=10
    range=[90, -90] fold=true``: +90 deg -> 0, 0 deg -> 64, -90 deg -> 127; ``fold`` mirrors an azimuth
    behind the listener to the front (135 -> 45, 180 -> 64), so turning round pans smoothly back (without
    it, beyond +-90 deg is clipped and the pan jumps from side to side where the azimuth crosses 180).

    Where it goes: ``file=out.mid`` writes a standard MIDI file (format 0; times from the messages'
    time stamps at ``bpm`` and ``ppq``: 1 tick = 60 / (bpm x ppq) s, 1.04 ms at the defaults; valid on
    disk after every message, closed when the patch stops).  ``port=NAME`` opens that MIDI output port
    (its exact name, or a unique part of it); ``virtual=true`` creates a port named ``port`` (default
    ``pointat``) for a DAW to connect to.  Ports need python-rtmidi (``pip install 'pointat[midi]'``) and
    a MIDI system: without them a port is an error at start that says so.  With neither ``port`` nor
    ``file`` the system's first output port is used when there is one, else ``NODE_NAME.mid`` where the
    patch's own files go (beside it; a shipped patch's in the working directory or ``pointat run
    --out``), with a warning.  Several midi_out nodes may write the same file.  A port named
    by ``port`` is looked for every second while the patch runs: unplugged mid-show, it is reported once
    and what would go to it is dropped (counted in ``dropped``); plugged back in, it is opened again and
    the last value is sent again, so the receiver catches up.
    """

    needs_input = True
    role = "output"

    inlets = (
        Inlet(
            "in",
            ("float", "int", "bang", "list"),
            "a value in range (note: 1/0 gate); bang: resend (note: strike); list: note velocity",
        ),
    )
    outlets = ()
    params = (
        Param("kind", "symbol", "cc", "what to send", choices=MIDI_KINDS),
        Param("channel", "int", 1, "MIDI channel, 1..16", live=True),
        Param(
            "number",
            "int",
            10,
            "controller (cc 0..119: 120..127 are channel mode messages; cc14 0..31), NRPN (0..16383) or note number",
            live=True,
        ),
        Param(
            "range",
            "vector",
            (0.0, 1.0),
            "input values [in_lo, in_hi] mapped to the MIDI range's bottom and top",
            live=True,
            size=2,
        ),
        FOLD,
        Param("change", "bool", True, "send only when the MIDI value changes", live=True),
        Param("velocity", "int", 100, "note-on velocity, 1..127 (kind=note)", live=True),
        Param("length", "float", 100.0, "how long a banged note sounds (kind=note)", unit="ms", live=True),
        Param("port", "symbol", "", "MIDI output port name (needs python-rtmidi and a MIDI system)"),
        Param("virtual", "bool", False, "create a virtual port named port (default 'pointat')"),
        Param("file", "path", "", "write a standard MIDI file here instead of a port", writes=True),
        Param("bpm", "float", 120.0, "tempo of the MIDI file", unit="beats/min"),
        Param("ppq", "int", 480, "MIDI file resolution, ticks per quarter note"),
    )
    example = """
node dir  azi_ele
node pan  midi_out kind=cc number=10 range=[90, -90] fold=true file=pan.mid
dir.azimuth -> pan
"""

    @classmethod
    def validate(cls, values):
        _check_out_params(dict(values))

    def setup(self) -> None:
        self.sender = MidiSender(
            self.p.kind,
            self.p.channel,
            self.p.number,
            self.p.range,
            change=self.p.change,
            velocity=self.p.velocity,
        )
        self._sink: _PortSink | _FileSink | None = None
        self._timer: Timer | None = None
        self.sent = 0
        self.dropped = 0  # while the port was unplugged

    def start(self) -> None:
        self._sink = self._open_sink()
        log.info("midi_out '%s': sending to %s", self.name, self._sink)
        if isinstance(self._sink, _PortSink):
            self._watch("output")

    def _port_name(self) -> str:
        return getattr(self._sink.port, "name", "") if isinstance(self._sink, _PortSink) else ""

    def describe(self) -> str:
        """Where the messages go, named for the console's banner: a file, a port by name (with no
        ``port``, the system's first output as it lists now), or the file written when there is none."""
        if self._sink is not None:
            return str(self._sink)
        if self.p.file:
            return f"MIDI file {self.p.file}"
        if self.p.virtual:
            return f"a virtual MIDI port {self.p.port or 'pointat'!r} for other programs to connect to"
        if self.p.port:
            return f"MIDI port {self.p.port!r}"
        first, why = first_port("output")
        if first is None:
            return f"MIDI file {self._fallback_file()} (no MIDI port: {why})"
        return f"MIDI port {first!r} (the system's first)"

    def _lost(self) -> None:
        """The port vanished: close it; what is sent meanwhile is dropped and counted."""
        sink = self._sink
        if isinstance(sink, _PortSink):
            sink.lost = True
            self._close_gone(sink)

    def _reopen(self, name: str) -> None:
        self._sink = _PortSink(open_port(self, "output", name, False, lambda n: ports.open_output(n)))
        self._send(self.sender.resend(), self.time)  # bring the receiver up to date

    def _open_sink(self) -> _PortSink | _FileSink:
        if self.p.file:
            try:
                return _FileSink(self.p.file, self.p.bpm, self.p.ppq)
            except OSError as exc:  # the folder went away since the patch was checked, a full disk
                raise OSError(f"cannot write {self.p.file}: {exc.strerror or exc}") from exc
        if self.p.port or self.p.virtual:
            name = self.p.port or "pointat"
            port = open_port(
                self, "output", name, self.p.virtual, lambda n: ports.open_output(n, virtual=self.p.virtual)
            )
            return _PortSink(port)
        try:
            names = ports.output_names()
        except (ImportError, OSError) as exc:
            reason = f"no MIDI system ({type(exc).__name__}: {exc})"
        else:
            if names:
                return _PortSink(open_port(self, "output", names[0], False, lambda n: ports.open_output(n)))
            reason = "the MIDI system has no output port"
        path = self._fallback_file()
        log.warning(
            "midi_out '%s': %s; writing %s instead (give port= or file= to choose)", self.name, reason, path
        )
        try:
            return _FileSink(str(path), self.p.bpm, self.p.ppq)
        except OSError as exc:
            raise OSError(
                f"cannot write {path}: {exc.strerror or exc} (give port= or file= to choose)"
            ) from exc

    def _fallback_file(self) -> Path:
        """The file written when there is no MIDI port and none was asked for: ``NODE.mid`` where the
        patch's own relative files go (:attr:`~pointat.node.Node.folder`), never the working directory of
        whoever ran a patch file kept elsewhere."""
        return ((self.folder or Path()) / (safe_stem(self.name) + ".mid")).resolve()

    def on_in(self, msg: Message) -> None:
        if msg.kind == "bang":
            if self.p.kind == "note":
                self._strike()
                return
            messages = self.sender.resend()
        elif msg.kind == "list" and self.p.kind == "note" and len(msg.value) >= 2:
            note, velocity = (float(v) for v in msg.value[:2])
            if not (note.is_integer() and velocity.is_integer()):
                raise ValueError(f"a note list is 'note velocity' in whole numbers, got {msg.describe()}")
            messages = self.sender.note(int(note), int(velocity))
        else:
            x = as_float(msg)
            messages = self.sender.value(fold_front(x) if self.p.fold else x)
        self._send(messages, msg.time)

    def _strike(self) -> None:
        self._cancel()
        self._send(self.sender.hit(), self.time)
        self._timer = self.call_later(self.p.length / 1000.0, self._release_hit, self.sender.number)

    def _release_hit(self, number: int) -> None:
        self._timer = None
        if number in self.sender.held:
            self._send(self.sender.note_off(number), self.time)

    def do_off(self) -> None:
        """Release every note held."""
        self._cancel()
        self._send(self.sender.release(), self.time)

    def _cancel(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None

    def _send(self, messages: list[mido.Message], time: float) -> None:
        if not messages:
            return
        if self._sink is None:
            raise RuntimeError(f"midi_out '{self.name}' has no open output (see the error at start)")
        if getattr(self._sink, "lost", False):  # unplugged: said once when it went
            self.dropped += len(messages)
            return
        try:
            self._sink.send(messages, time)  # a 14-bit value's two halves together, or neither
        except BaseException:
            self.sender.unsent(messages)  # owed still: a fader that stays put is written when room comes
            raise
        self.sent += len(messages)

    def param_changed(self, name: str) -> None:
        key = _MAPPING_PARAMS.get(name)
        if key is not None:  # already validated as a whole by validate()
            owed = self.sender.configure(**{key: getattr(self.p, name)})
            if self._sink is not None:
                self._send(owed, self.time)

    def close(self) -> None:
        self._cancel()
        sink, self._sink = self._sink, None
        if sink is None:
            return
        if getattr(sink, "lost", False):  # closed when it vanished
            return
        try:
            sink.send(self.sender.release(), self.time)
        finally:
            sink.close()


@register("midi_in")
class MidiIn(PortWatch, Node):
    """Receive MIDI from a named port: a foot controller's switches and pedals as control messages.

    Control changes leave by ``cc`` as a list ``number value`` (route them by number with ``route``);
    notes by ``note`` as ``note velocity`` (a note-off is velocity 0); pitch bend by ``bend`` (-8192..8191);
    anything else (program_change, aftertouch...) by ``other`` as a method message named after its type
    with its data (``program_change 5``).  ``channel`` 1..16 keeps one channel (0: all).  Needs
    python-rtmidi and a MIDI system: without them the node reports at start what to install.

    A port named by ``port`` is looked for every second while the patch runs: unplugged mid-show, it is
    reported once, and when it is plugged back in it is opened again (the patch keeps running).
    """

    role = "input"

    outlets = (
        Outlet("cc", "list", "controller number, value 0..127"),
        Outlet("note", "list", "note number, velocity 0..127 (0: note off)"),
        Outlet("bend", "int", "pitch bend -8192..8191 (0: centre)"),
        Outlet("other", "any", "other messages: type, then data (program_change 5)"),
    )
    params = (
        Param("port", "symbol", "", "MIDI input port name, or a unique part of it ('': the first)"),
        Param("virtual", "bool", False, "create a virtual input port named port (default 'pointat')"),
        Param("channel", "int", 0, "only this channel, 1..16 (0: every channel)"),
    )
    example = """
node foot  midi_in port="FCB1010"
node pedal route 64
node press route 127
node ref   reference
foot.cc -> pedal
pedal.0 -> press
press.0 -> ref.capture
"""

    @classmethod
    def validate(cls, values):
        ch = values.get("channel", 0)
        if not 0 <= ch <= 16:
            raise ValueError(f"channel must be 1..16, or 0 for every channel; got {ch}")

    def setup(self) -> None:
        self._port: mido.ports.BaseInput | None = None
        self.received = 0

    def describe(self) -> str:
        """The port it listens on, named for the console's banner (with no ``port``, the system's first
        input as it lists now)."""
        if self._port is not None:
            return f"MIDI port {getattr(self._port, 'name', '')!r}"
        if self.p.virtual:
            return f"a virtual MIDI port {self.p.port or 'pointat'!r} for other programs to connect to"
        if self.p.port:
            return f"MIDI port {self.p.port!r}"
        first, why = first_port("input")
        return f"MIDI port {first!r} (the system's first)" if first else f"no MIDI port: {why}"

    def start(self) -> None:
        name = self.p.port or ("pointat" if self.p.virtual else "")
        self._port = open_port(
            self,
            "input",
            name,
            self.p.virtual,
            lambda n: ports.open_input(n, virtual=self.p.virtual, callback=self._on_midi),
        )
        self.active = True
        log.info("midi_in '%s': listening on %r", self.name, getattr(self._port, "name", name))
        self._watch("input")

    def _port_name(self) -> str:
        return getattr(self._port, "name", "") or ""

    def _lost(self) -> None:
        self.active = False
        self._close_gone(self._port)

    def _reopen(self, name: str) -> None:
        self._port = open_port(
            self, "input", name, False, lambda n: ports.open_input(n, callback=self._on_midi)
        )
        self.active = True

    def _on_midi(self, msg: mido.Message) -> None:
        """Backend thread: hand the message to the scheduler (dropped and counted when it is full)."""
        rt = self.rt
        if rt is not None and not rt.stopping.is_set():
            rt.post(self, self._handle, msg, block=False)  # never block the backend's thread

    def _handle(self, msg: mido.Message) -> None:
        self.time = self.now
        channel = getattr(msg, "channel", None)
        if self.p.channel and channel is not None and channel != self.p.channel - 1:
            return
        self.received += 1
        t = msg.type
        if t == "control_change":
            self.out(0, (msg.control, msg.value))
        elif t == "note_on":
            self.out(1, (msg.note, msg.velocity))
        elif t == "note_off":
            self.out(1, (msg.note, 0))
        elif t == "pitchwheel":
            self.out(2, msg.pitch)
        else:
            data = [v for k, v in msg.dict().items() if k not in ("type", "time", "channel")]
            flat = [x for v in data for x in (v if isinstance(v, (tuple, list)) else (v,))]
            self.out(3, method(t, *flat))

    def close(self) -> None:
        self.active = False
        port, self._port = self._port, None
        if port is not None:
            port.close()
