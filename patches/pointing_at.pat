# Pointing-at (Torre et al., NIME 2008): the paper's chain end to end.
#
#   mote -> offset -> scaling -> gyro_integrator ---\
#                            \-> accmag_matrix -----> complementary -> matrix2quat -> quat2axis
#                                                                                 \-> azi_ele -> osc_out
#                                                                                 \-> roll_distance
#
# The source is the built-in simulated glove, writing real mote frames into a pseudo-terminal that the
# mote node reads.  For a real base station: pointat run patches/pointing_at.pat \
#     --set glove.output=direct --set base.device=/dev/ttyUSB0
# Directions go to 127.0.0.1:9000 as /pointat/1/aed azimuth elevation distance.

node glove  simulate rate=100 output=pty
node base   mote ids=[1] rate=100
node nulls  offset samples=150
node units  scaling
node gyro   gyro_integrator mode=torre
node accmag accmag_matrix
node fuse   complementary crossover=0.2
node quat   matrix2quat
node axis   quat2axis
node dir    azi_ele
node roll   roll_distance
node out    osc_out profile=pointat host=127.0.0.1 port=9000
node both   pack 0 0 0
node slow   speedlim 500
node show   print prefix="azimuth elevation distance"

glove.device -> base
base.m1 -> nulls -> units
units.mag -> accmag.mag
units.accel -> accmag.accel
units.gyro -> gyro
accmag -> fuse.accmag
gyro -> fuse.gyro_orientation
fuse -> quat
quat -> axis
quat -> roll
quat -> dir
roll.distance -> out.distance
roll.distance -> both.2
dir.elevation -> out.elevation
dir.elevation -> both.1
dir.azimuth -> out.azimuth
dir.azimuth -> both.0
both -> slow -> show
