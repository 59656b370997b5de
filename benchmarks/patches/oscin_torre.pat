# Latency benchmark, UDP in -> UDP out (to compare like with like with the python-osc and Pd relays):
# one OSC sensor (NGIMU's /sensors: gyro deg/s, accel g, mag uT) through the fusion half of the Pointing-at chain (patches/lib/torre_fusion.pat),
# then osc_out as in glove_torre.pat.  The benchmark sets src.port and out.port.
#
# Sample tag: each datagram is a bundle [/tag k mod 1000, /sensors ...]; /tag leaves osc_in by its any
# outlet and lands, mapped to 0..99.9, in osc_out's spread field before /sensors fires the chain.

node src    osc_in port=9001 device=ngimu control=false
node tagsel route /tag
node tag    map 0 1000 0 100
node fuse   ../../patches/lib/torre_fusion.pat rate=1000 crossover=0.2 integrator=torre
node out    osc_out profile=generic host=127.0.0.1 port=9000 source=1 address="/bench/{n}" \
            fields=[n, spread, az, el, dist]

src.any -> tagsel
tagsel.0 -> tag -> out.spread
src.mag -> fuse.mag
src.accel -> fuse.accel
src.gyro -> fuse.gyro
fuse.distance -> out.distance
fuse.elevation -> out.elevation
fuse.azimuth -> out.azimuth
