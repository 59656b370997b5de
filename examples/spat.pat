# SPAT Revolution (FLUX::): point the glove to move source 1; roll the hand 90 degrees and sweep it to
# bring the source closer (Torre's distance gesture).
#
#   glove -> nulls -> units -> fuse -> ref -> dir --(elevation)-------------> out (osc_out profile=spat)
#                                          \-> roll -(distance, azimuth)----/
#
# Sends /source/1/aed azimuth elevation distance (float32 "fff") to 127.0.0.1:9000.  SPAT's azimuth is
# POSITIVE RIGHT, so the profile negates pointat's (+ left): pointing 30 degrees left sends -30.  The
# distance is in metres: radius=2 puts "far" (the loudspeakers) at 2 m; set it to your room's radius.
# The direction the hand points at when the patch starts is the front.
#     pointat run spat
#     pointat run spat --set out.host=192.168.1.30 --set out.radius=3.5
# SPAT also reads ADM-OSC: examples/adm.pat works too (enable ADM-OSC in SPAT's OSC preferences).
# Setting up the receiver: examples/README.md.  A real glove: replace "glove" as in patches/pointing_at.pat.

node glove  simulate rate=100
node nulls  offset samples=50
node units  scaling
node fuse   tqt mode=robust
node ref    reference mode=heading capture_first=true
node dir    azi_ele
node roll   roll_distance
node out    osc_out profile=spat host=127.0.0.1 port=9000 source=1 radius=2 rate=50
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
