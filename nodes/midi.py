"""The MIDI nodes' former home: they live in :mod:`pointat.midi_bridge` now, beside ``osc_bridge``.

The public names stay importable from here for code written against ``pointat.nodes.midi``; new code
imports them from :mod:`pointat.midi_bridge.mapping`, :mod:`~pointat.midi_bridge.file_writer`,
:mod:`~pointat.midi_bridge.ports` and :mod:`~pointat.midi_bridge.nodes`.  Tests that replace the MIDI
system replace it in :mod:`pointat.midi_bridge.ports`.
"""

from __future__ import annotations

from pointat.midi_bridge.file_writer import MidiFileWriter
from pointat.midi_bridge.mapping import (
    MIDI_KINDS,
    MidiSender,
    cc14_messages,
    cc_messages,
    check_mapping,
    nrpn_messages,
    pitchbend_message,
    scale_to_int,
    split14,
)
from pointat.midi_bridge.nodes import MidiIn, MidiOut
from pointat.midi_bridge.ports import (
    MidiUnavailable,
    input_names,
    open_input,
    open_output,
    output_names,
)

__all__ = [
    "MIDI_KINDS",
    "MidiFileWriter",
    "MidiIn",
    "MidiOut",
    "MidiSender",
    "MidiUnavailable",
    "cc14_messages",
    "cc_messages",
    "check_mapping",
    "input_names",
    "nrpn_messages",
    "open_input",
    "open_output",
    "output_names",
    "pitchbend_message",
    "scale_to_int",
    "split14",
]
