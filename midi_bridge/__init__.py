r"""MIDI for pointat, with mido: ``midi_out`` (directions and gestures to a DAW or a synth) and ``midi_in``
(a foot controller).

Cheat sheet::

    node pan  midi_out kind=cc number=10 range=[90, -90] fold=true file=pan.mid   # azimuth -> CC10 pan, to a file
    node pan  midi_out kind=cc number=10 range=[90, -90] fold=true port="IAC Bus 1"   # ... to a named port
    node fine midi_out kind=cc14 number=10 range=[90, -90] fold=true   # 14-bit: CC10 (MSB) + CC42 (LSB)
    node nrpn midi_out kind=nrpn number=300 range=[-180, 180] # NRPN 99/98 (parameter) + 6/38 (value)
    node bend midi_out kind=pitchbend range=[-45, 45]         # 14-bit pitch bend, centre 0 -> 8192
    node hit  midi_out kind=note number=60                    # 1 / non-zero: note on, 0: note off, bang: a hit
    node foot midi_in port="FCB1010"                          # -> (cc number, value), (note, velocity)

The layers, from the bottom:

* :mod:`~pointat.midi_bridge.mapping`: plain functions (:func:`~.mapping.scale_to_int`,
  :func:`~.mapping.cc_messages`...) build port-less ``mido.Message`` objects, and
  :class:`~.mapping.MidiSender` holds one output's mapping and state (last value sent, notes held) and
  turns pointat values into lists of messages; it knows nothing of ports or of the engine;
* :mod:`~pointat.midi_bridge.file_writer`: :class:`~.file_writer.MidiFileWriter` writes a standard MIDI
  file message by message (valid on disk after each one);
* :mod:`~pointat.midi_bridge.ports`: :func:`~.ports.open_output`, :func:`~.ports.open_input`,
  :func:`~.ports.output_names` and :func:`~.ports.input_names` are the only places that touch a MIDI
  system (through mido's default backend, python-rtmidi).  Tests replace them with functions returning
  real ``mido.ports.BaseOutput`` / ``BaseInput`` subclasses;
* :mod:`~pointat.midi_bridge.nodes`: the nodes ``midi_out`` and ``midi_in`` connect those to the patch.
"""
