# Benchmark abstraction: one glove through the Pointing-at chain of patches/pointing_at.pat,
#
#   adc -> offset -> scaling -> lib/torre_fusion.pat -> osc_out
#
# with the same parameters, except that osc_out uses the generic profile and sends
# /bench/ID n spread az el dist, so that the benchmark can tell motes and samples apart: the spread
# inlet carries the sample tag (the patch that uses this abstraction decides what the tag is).

args id=1 port=9000 rate=1000 samples=150
inlet  adc -> nulls.adc
inlet  spread -> out.spread

node nulls offset samples=$samples still=0   # the sample tag rides in gyro x: it is never still
node units scaling
node torre ../../patches/lib/torre_fusion.pat rate=$rate crossover=0.2 integrator=torre
node out   osc_out profile=generic host=127.0.0.1 port=$port source=$id address="/bench/{n}" \
           fields=[n, spread, az, el, dist]

nulls -> units
units.mag -> torre.mag
units.accel -> torre.accel
units.gyro -> torre.gyro
torre.distance -> out.distance
torre.elevation -> out.elevation
torre.azimuth -> out.azimuth
