"""The MIDI system: the only places that open or list ports (through mido's default backend, python-rtmidi),
and the watch that notices a port vanish mid-show and opens it again when it comes back.

Tests replace :func:`open_output`, :func:`open_input`, :func:`output_names` and :func:`input_names` (and
:data:`WATCH_PERIOD`) here with functions returning real ``mido.ports.BaseOutput`` / ``BaseInput``
subclasses.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from typing import Any

import mido
import mido.ports

from pointat.errors import PointatError
from pointat.node import Node

log = logging.getLogger("pointat.midi")


#: What to do when python-rtmidi is missing, and when the MIDI system is.
FIX_RTMIDI = "install python-rtmidi (pip install 'pointat[midi]' or pip install python-rtmidi)"
FIX_SYSTEM = (
    "make a MIDI system available (Linux: ALSA with its sequencer, so that /dev/snd/seq exists: "
    "modprobe snd-seq, or pass --device /dev/snd to a container; macOS: CoreMIDI; Windows: a loopback "
    "driver such as loopMIDI)"
)


class MidiUnavailable(PointatError):
    """A MIDI port was asked for and cannot be opened; the message names the node and the fix."""


def open_output(name: str | None, *, virtual: bool = False) -> mido.ports.BaseOutput:
    """Open a MIDI output port with mido's backend (python-rtmidi); tests replace this function."""
    return mido.open_output(name, virtual=virtual)


def open_input(
    name: str | None, *, virtual: bool = False, callback: Callable[[mido.Message], None] | None = None
) -> mido.ports.BaseInput:
    """Open a MIDI input port whose messages go to ``callback`` (on the backend's thread); replaceable."""
    return mido.open_input(name, virtual=virtual, callback=callback)


def output_names() -> list[str]:
    """The MIDI output ports of the system; raises ``ImportError`` or ``OSError`` without a MIDI system."""
    return list(mido.get_output_names())


def input_names() -> list[str]:
    """The MIDI input ports of the system; raises ``ImportError`` or ``OSError`` without a MIDI system."""
    return list(mido.get_input_names())


def match_port(name: str, names: Sequence[str]) -> str | None:
    """The port called ``name``, else the only one whose name contains it (case-insensitive)."""
    if name in names:
        return name
    low = name.lower()
    found = [n for n in names if low in n.lower()]
    return found[0] if len(found) == 1 else None


def open_port(
    node: Node, direction: str, name: str, virtual: bool, opener: Callable[[str | None], Any]
) -> Any:
    """Open a port by name (or the system's first when ``name`` is empty) or create a virtual one.

    Every failure becomes :class:`MidiUnavailable` naming the node, the port and the fix.
    """
    lister = output_names if direction == "output" else input_names
    label = f"{node.type_name} '{node.name}'"
    what = (
        f"virtual MIDI {direction} port {name!r}"
        if virtual
        else (f"MIDI {direction} port {name!r}" if name else f"the first MIDI {direction} port")
    )
    fallback = (
        f"write a MIDI file instead with file={safe_stem(node.name)}.mid" if direction == "output" else ""
    )
    try:
        if virtual or not name:
            return opener(name or None)
        try:
            names = lister()
        except OSError:
            names = []  # the opener below reports it
        return opener(match_port(name, names) or name)
    except ImportError as exc:
        raise MidiUnavailable(
            f"{label}: cannot open {what}: python-rtmidi, the backend mido uses, is not installed ({exc}). "
            f"To fix: {FIX_RTMIDI} and {FIX_SYSTEM}" + (f"; or {fallback}" if fallback else "")
        ) from exc
    except OSError as exc:
        try:
            names = lister()
        except (ImportError, OSError):
            raise MidiUnavailable(
                f"{label}: cannot open {what}: no MIDI system ({type(exc).__name__}: {exc}). "
                f"To fix: {FIX_SYSTEM}" + (f"; or {fallback}" if fallback else "")
            ) from exc
        ports = ", ".join(repr(n) for n in names) or "none"
        raise MidiUnavailable(
            f"{label}: cannot open {what}: {exc}. {direction.capitalize()} ports: {ports}. "
            f"To fix: name one of them (or a unique part of its name), or create one with virtual=true"
            + (f"; or {fallback}" if fallback else "")
        ) from exc


def first_port(direction: str) -> tuple[str | None, str]:
    """The port a node with no ``port`` opens, for a person: (the system's first, "") or (None, why none)."""
    lister = output_names if direction == "output" else input_names
    try:
        names = lister()
    except ImportError:
        return None, "python-rtmidi is not installed: pip install 'pointat[midi]'"
    except OSError as exc:
        return None, f"no MIDI system ({exc})"
    return (names[0], "") if names else (None, f"the MIDI system has no {direction} port")


def safe_stem(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in name) or "midi_out"


#: How often a port opened by name is looked for while the patch runs, in seconds: a controller
#: unplugged mid-show is reported, and opened again when it is plugged back in.
WATCH_PERIOD = 1.0


class PortWatch:
    """For a MIDI node with a port opened by name: notice it vanish (a cable pulled mid-show, where the
    backend itself goes quiet without a word) and open it again when it comes back.

    A thread of its own lists the system's ports every :data:`WATCH_PERIOD` s (listing opens a MIDI
    client, too slow for the scheduler thread) and hands the list to the scheduler, where the node
    compares it with the port it has open.  A port back under another client number (ALSA numbers a
    replugged device anew) is found again by the name the patch gives, as at start.
    """

    def _watch(self: Any, direction: str) -> None:
        self._direction = direction
        self._missing = False
        if self.p.virtual or not self.p.port:
            return  # ours (virtual) cannot vanish; "the first port" names nothing to look for again
        lister = output_names if direction == "output" else input_names
        rt = self.rt

        def look() -> None:
            while not rt.stopping.wait(WATCH_PERIOD):
                try:
                    names = lister()
                except (ImportError, OSError):
                    continue  # the MIDI system itself hiccuped: look again next time
                rt.post(self, self._ports_seen, names, block=False)

        self.spawn(look, "watch")

    def _ports_seen(self: Any, names: list[str]) -> None:
        """Scheduler thread: the ports the system has now."""
        if not self._missing:
            if self._port_name() in names:
                return
            self._missing = True
            self._lost()
            log.warning(
                "%s '%s': MIDI %s port %r is gone (unplugged?); waiting for it to come back",
                self.type_name,
                self.name,
                self._direction,
                self._port_name(),
            )
            return
        found = match_port(self.p.port, names)
        if found is None:
            return
        try:
            self._reopen(found)
        except MidiUnavailable as exc:  # still appearing: try again next time
            log.debug("%s", exc)
            return
        self._missing = False
        log.warning("%s '%s': MIDI %s port %r is back", self.type_name, self.name, self._direction, found)

    @staticmethod
    def _close_gone(port: Any) -> None:
        """Close a port that vanished; the backend may refuse to close what is already gone."""
        try:
            port.close()
        except Exception:
            pass
