"""OSC (and MIDI) for pointat: send directions to spatial-sound systems, receive sensors and control.

* :mod:`pointat.osc_bridge.profiles`: receiver profiles (ADM-OSC, IEM, SPAT, ICST, REAPER, Pd/Max VBAP...) as tables.
* :mod:`pointat.osc_bridge.nodes`: the ``osc_out`` and ``osc_send`` nodes; :mod:`pointat.osc_bridge.listener`:
  the ``osc_in`` node; :mod:`pointat.osc_bridge.body`: the ``osc_body`` node.
* What they stand on: :mod:`~pointat.osc_bridge.sender` (destinations and UDP sockets),
  :mod:`~pointat.osc_bridge.encoder` (an update's messages encoded once), :mod:`~pointat.osc_bridge.tagclock`
  (a sender's bundle time tags on pointat's clock).
"""
