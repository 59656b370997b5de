# Any OSC receiver (Max, SuperCollider, TouchDesigner, a game engine...): choose the address and the
# arguments yourself.
#
#   glove -> nulls -> units -> fuse -> ref -> dir --(elevation)-------------> out (osc_out profile=generic)
#                                          \-> roll -(distance, azimuth)----/
#
# Sends /glove/1/direction azimuth elevation distance (float32 "fff": degrees, azimuth + left; distance
# 1 far .. 0 near) to 127.0.0.1:9000, and the same to 127.0.0.1:9002 (a second listener, "to").
# The arguments come from the field names: n (source number, int32), az, az_right, az360, el, dist
# (0 far .. 90 near), dist01, dist_m, spread, x y z (x right, y front, z up), pan (0 left .. 1 right),
# or numbers (constants).  {n} in the address is the source number.
# The direction the hand points at when the patch starts is the front.
#     pointat run generic_osc
#     pointat run generic_osc --set out.address=/hand/xyz --set "out.fields=[x, y, z]"
# Setting up the receiver: examples/README.md.  A real glove: replace "glove" as in patches/pointing_at.pat.

node glove  simulate rate=100
node nulls  offset samples=50
node units  scaling
node fuse   tqt mode=robust
node ref    reference mode=heading capture_first=true
node dir    azi_ele
node roll   roll_distance
node out    osc_out profile=generic address=/glove/{n}/direction fields=[az, el, dist01] \
                    host=127.0.0.1 port=9000 to=[9002] rate=100
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
