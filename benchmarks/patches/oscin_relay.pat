# Latency benchmark, pointat's own relay: UDP in -> UDP out through the engine, no fusion.
# The same input as oscin_torre.pat and oscin_tqt.pat (a bundle [/tag k mod 1000, /sensors ...]) goes in,
# the gyro's x reading (as a stand-in azimuth) and the tag go out of osc_out as in the fusion patches:
# osc_in's decoding and routing, the engine's dispatch and osc_out's encoding, with no filter between.
# Beside the python-osc relay it shows what the engine itself adds; beside the fusion patches, what the
# fusion adds.  The benchmark sets src.port and out.port.

node src    osc_in port=9001 device=ngimu control=false
node tagsel route /tag
node tag    map 0 1000 0 100
node gx     unpack f
node out    osc_out profile=generic host=127.0.0.1 port=9000 source=1 address="/bench/{n}" \
            fields=[n, spread, az, el, dist]

src.any -> tagsel
tagsel.0 -> tag -> out.spread
src.gyro -> gx
gx.0 -> out.azimuth
