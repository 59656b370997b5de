# Latency benchmark, pointat's own mote relay: frames from a pseudo-terminal -> osc_out, no fusion.
# The same frames as mote_torre_1.pat; the tag (mapped from the gyro x count) goes out as the spread
# and, as a stand-in, as the azimuth.
# Beside the python pty relay it shows what the engine adds on the mote path; beside mote_CHAIN_1.pat,
# what the calibration and the fusion add.  The benchmark sets base.device, base.rate and g1/out.port.

node base mote ids=[1] rate=1000
node tap1 unpack f
node tag1 map 1548 2548 0 100
node both t f f
node g1/out osc_out profile=generic host=127.0.0.1 port=9000 source=1 address="/bench/{n}" \
            fields=[n, spread, az, el, dist]

base.m1 -> tap1 -> tag1 -> both
both.1 -> g1/out.spread
both.0 -> g1/out.azimuth
