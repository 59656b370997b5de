# A take recorded by patches/record_glove.pat, played back through the same chain in real time: the
# same directions, sent the same way, without the glove.  Out of the box it plays the simulated glove's
# demo (pointat/data/glove_take.csv.gz, 41 s); yours:
#   pointat run replay_glove --set source.file=take.csv --set source.loop=true
# The reference pose is not part of a take: press again (/pointat/press/bang on port 9001) as it plays.

node source replay file=pointat:data/glove_take.csv.gz speed=1
node nulls  offset samples=150
node units  scaling
node tqt    lib/tqt_fusion.pat rate=100 mode=robust
node press  msg bang
node out    osc_out profile=pointat host=127.0.0.1 port=9000
node ctl    osc_in port=9001
node both   pack 0 0 0
node slow   speedlim 500
node show   print prefix="azimuth elevation distance"
node state  print prefix="glove"

source.row -> nulls -> units
units.mag -> tqt.mag
units.accel -> tqt.accel
units.range -> tqt.range
units.gyro -> tqt.gyro
tqt.flags -> state
tqt.flags -> out.flags
press -> tqt.reference
tqt.distance -> out.distance
tqt.distance -> both.2
tqt.elevation -> out.elevation
tqt.elevation -> both.1
tqt.azimuth -> out.azimuth
tqt.azimuth -> both.0
both -> slow -> show
