"""A plain libmapper client, pointat's code nowhere in it: what a session tool (webmapper) does.

    python mapper_client.py IFACE SOURCE DESTINATION EXPRESSION

SOURCE and DESTINATION are DEVICE/SIGNAL, the device without its ordinal (``gloveA/out/azimuth``).  The
client waits for both on the bus, maps SOURCE to DESTINATION with EXPRESSION (``y=x*0.5``) and SOURCE to
a signal of its own (``y=x``), then prints one JSON line per event: ``{"asked": EXPRESSION}`` as it asks
for the maps, ``{"mapped": SECONDS}`` when the bus says the first is made, and ``{"x": VALUE}`` for each
value of SOURCE, until it is killed.
Exit status 2 when the signals do not appear within a minute.
"""

import json
import sys
import time

import libmapper as mpr


def find(graph, wanted):
    device, _, signal = wanted.partition("/")
    for sig in list(graph.signals()):  # (read to its end: a list left half read crashes at exit)
        owner = str(sig.device()[mpr.Property.NAME])
        if sig[mpr.Property.NAME] == signal and owner.rpartition(".")[0] == device:
            return sig
    return None


def main(iface, source, destination, expression):
    graph = mpr.Graph(mpr.Type.DEVICE | mpr.Type.SIGNAL)
    graph.set_interface(iface)
    dev = mpr.Device("probe", graph)

    def take(_sig, _event, _inst, value, _time):
        print(json.dumps({"x": value}), flush=True)

    probe = dev.add_signal(
        mpr.Signal.Direction.INCOMING,
        "x",
        1,
        mpr.Type.FLOAT,
        None,
        None,
        None,
        None,
        take,
        mpr.Object.Event.REMOTE_UPDATE,
    )
    deadline = time.monotonic() + 60
    src = dst = None
    while not (dev.ready and src is not None and dst is not None):
        if time.monotonic() > deadline:
            print(json.dumps({"error": f"not on the bus: {source if src is None else destination}"}))
            return 2
        dev.poll(20)
        src = src or find(graph, source)
        dst = dst or find(graph, destination)
    asked = time.monotonic()
    to_patch = mpr.Map(src, dst)
    to_patch[mpr.Property.EXPRESSION] = expression
    to_probe = mpr.Map(src, probe)
    for m in (to_patch, to_probe):
        m.push()
    print(json.dumps({"asked": expression}), flush=True)
    told = False
    while True:
        dev.poll(10)
        if not told and to_patch.ready:
            told = True
            print(json.dumps({"mapped": time.monotonic() - asked}), flush=True)


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:5]))
