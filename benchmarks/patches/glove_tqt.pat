# Benchmark abstraction: one glove through the tqt chain of patches/glove_tqt.pat,
#
#   adc -> offset -> scaling -> lib/tqt_fusion.pat -> osc_out
#
# with the same parameters, except that osc_out uses the generic profile and sends
# /bench/ID n spread az el dist, so that the benchmark can tell motes and samples apart: the spread
# inlet carries the sample tag (the patch that uses this abstraction decides what the tag is).

args id=1 port=9000 rate=1000 samples=150
inlet  adc -> nulls.adc
inlet  spread -> out.spread

node nulls offset samples=$samples still=0   # the sample tag rides in gyro x: it is never still
node units scaling
node tqt   ../../patches/lib/tqt_fusion.pat rate=$rate mode=robust
node out   osc_out profile=generic host=127.0.0.1 port=$port source=$id address="/bench/{n}" \
           fields=[n, spread, az, el, dist]

nulls -> units
units.mag -> tqt.mag
units.accel -> tqt.accel
units.range -> tqt.range
units.gyro -> tqt.gyro
tqt.distance -> out.distance
tqt.elevation -> out.elevation
tqt.azimuth -> out.azimuth
