"""OSC (and MIDI) for pointat: send directions to spatial-sound systems, receive sensors and control.

* :mod:`pointat.osc_bridge.profiles`: receiver profiles (ADM-OSC, IEM, SPAT, ICST, REAPER, Pd/Max VBAP...) as tables.
* :mod:`pointat.osc_bridge.nodes`: the ``osc_out`` and ``osc_in`` nodes.
"""
