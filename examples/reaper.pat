# REAPER: pan track 1 by pointing at the left or right loudspeaker of a stereo pair.
#
#   glove -> nulls -> units -> fuse -> ref -> dir -> out (osc_out profile=reaper)
#
# Sends /track/1/pan with one float32, REAPER's normalised pan: 0 hard left, 0.5 centre, 1 hard right.
# Pointing 90 degrees left gives 0, straight ahead 0.5, 90 degrees right 1; a direction behind you pans
# like its mirror image in front (150 degrees left pans as 30 degrees left), so the pan never jumps.
# Only changes larger than 0.5 degree are sent, at most 30 times a second (REAPER redraws every one).
# The direction the hand points at when the patch starts is the front.
#     pointat run reaper
#     pointat run reaper --set out.source=4          # track 4 (bank-relative)
# Setting up REAPER: examples/README.md.  A real glove: replace "glove" as in patches/pointing_at.pat.

node glove  simulate rate=100
node nulls  offset samples=50
node units  scaling
node fuse   tqt mode=robust
node ref    reference mode=heading capture_first=true
node dir    azi_ele
node out    osc_out profile=reaper host=127.0.0.1 port=8000 source=1 rate=30 deadband=0.5
node state  print prefix="glove"

glove.adc -> nulls -> units
units.mag -> fuse.mag
units.accel -> fuse.accel
units.range -> fuse.range
units.gyro -> fuse.gyro
fuse.flags -> state
fuse.flags -> out.flags
fuse.quat -> ref -> dir
dir.elevation -> out.elevation
dir.azimuth -> out.azimuth
