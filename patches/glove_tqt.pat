# The Pointing-at glove with McGhee and Bachmann's quaternion filter (tqt) at its core.
#
#   mote -> offset -> scaling -> tqt -> reference -> azi_ele -> osc_out
#                                                \-> roll_distance
#
# The source is the built-in simulated glove writing real mote frames into a pseudo-terminal, read by the
# mote node.  For a real base station:  --set glove.output=direct --set base.device=/dev/ttyUSB0
# Point at the front loudspeaker and send /pointat/ref/set (OSC, port 9001) to make it azimuth 0.
# Directions go to 127.0.0.1:9000 as /pointat/1/aed azimuth elevation distance; live control on 9001,
# e.g. /pointat/fuse/k_heading 0.05 or /pointat/nulls/recalibrate.

node glove  simulate rate=100 output=pty
node base   mote ids=[1] rate=100
node nulls  offset samples=150
node units  scaling
node fuse   tqt mode=robust
node ref    reference mode=heading
node dir    azi_ele
node roll   roll_distance
node out    osc_out profile=pointat host=127.0.0.1 port=9000
node ctl    osc_in port=9001
node both   pack 0 0 0
node slow   speedlim 500
node show   print prefix="azimuth elevation distance"

glove.device -> base
base.m1 -> nulls -> units
units.mag -> fuse.mag
units.accel -> fuse.accel
units.gyro -> fuse.gyro
fuse.quat -> ref
ref -> roll
ref -> dir
roll.distance -> out.distance
roll.distance -> both.2
dir.elevation -> out.elevation
dir.elevation -> both.1
dir.azimuth -> out.azimuth
dir.azimuth -> both.0
both -> slow -> show
