# ADM-OSC 1.0 (L-ISA, SPAT Revolution, Nuendo, QLab, d&b Soundscape...): point the glove to move
# object 1; roll the hand 90 degrees and sweep it to bring the object closer (Torre's distance gesture).
#
#   glove -> nulls -> units -> fuse -> ref -> dir --(elevation)-------------> out (osc_out profile=adm)
#                                          \-> roll -(distance, azimuth)----/
#
# Sends /adm/obj/1/aed azimuth elevation distance (float32 "fff": azimuth + left, -180..180; elevation
# + up; distance 1 on the loudspeakers .. 0 at the centre) to 127.0.0.1:4001, at most 50 times a second.
# The direction the hand points at when the patch starts becomes the front (ref, mode=heading).
#     pointat run adm
#     pointat run adm --set out.host=192.168.1.30 --set out.source=3
# Setting up the receiver: examples/README.md.  A real glove: replace "glove" as in patches/pointing_at.pat
# (a simulate or mote node feeding nulls); raise nulls.samples to 150 or more.

node glove  simulate rate=100
node nulls  offset samples=50
node units  scaling
node fuse   tqt mode=robust
node ref    reference mode=heading capture_first=true
node dir    azi_ele
node roll   roll_distance
node out    osc_out profile=adm host=127.0.0.1 port=4001 source=1 rate=50
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
