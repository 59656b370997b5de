# ICST AmbiPlugins (AmbiEncoder, ZHdK): point the glove to move source 1; roll the hand 90 degrees and
# sweep it to bring the source closer (Torre's distance gesture).
#
#   glove -> nulls -> units -> fuse -> ref -> dir --(elevation)-------------> out (osc_out profile=icst)
#                                          \-> roll -(distance, azimuth)----/
#
# Sends /icst/ambi/sourceindex/xyz index x y z ("ifff": the source index counts from 1; x right, y front,
# z up; radius 1 on the unit circle .. 0 at the centre) to 127.0.0.1:50001.  Cartesian on purpose: the
# encoder's own aed form truncates angles to whole degrees.  The direction the hand points at when the
# patch starts is the front.
#     pointat run icst
#     pointat run icst --set out.source=2
# Setting up the receiver: examples/README.md.  A real glove: replace "glove" as in patches/pointing_at.pat.

node glove  simulate rate=100
node nulls  offset samples=50
node units  scaling
node fuse   tqt mode=robust
node ref    reference mode=heading capture_first=true
node dir    azi_ele
node roll   roll_distance
node out    osc_out profile=icst host=127.0.0.1 port=50001 source=1 rate=50
node state  print prefix="glove"

glove.adc -> nulls -> units
units.mag -> fuse.mag
units.accel -> fuse.accel
units.range -> fuse.range
units.gyro -> fuse.gyro
fuse.flags -> state
fuse.flags -> out.flags
fuse.quat -> ref
ref -> dir
ref -> roll
dir.elevation -> out.elevation
roll.distance -> out.distance
roll.azimuth -> out.azimuth
