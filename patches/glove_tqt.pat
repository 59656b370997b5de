# The Pointing-at glove with McGhee and Bachmann's quaternion filter (tqt) at its core.
#
#   mote -> offset -> scaling -> tqt -> reference -> azi_ele -> osc_out
#                                                \-> roll_distance
#
# The filter half is the abstraction lib/tqt_fusion.pat, shared with replay_tqt.pat.  The source is the
# built-in simulated glove writing real mote frames into a pseudo-terminal, read by the mote node.
# For a real base station:  --set glove.output=direct --set base.device=/dev/ttyUSB0
# Point at the front loudspeaker and send /pointat/press/bang (OSC to port 9001) to make it azimuth 0.
# Directions go to 127.0.0.1:9000 as /pointat/1/aed azimuth elevation distance, three float32: degrees
# (+ left, + up) and ADM-OSC's distance 0..1 (1 far, 0 near; the console shows the gesture's 0..90).
# Live control on 9001: /pointat/NODE/PARAM value or /pointat/NODE/METHOD, e.g.
# /pointat/tqt/fuse/k_heading 0.05 (a node inside an abstraction is named INSTANCE/NODE) or
# /pointat/nulls/recalibrate (new gyro nulls: hold still).

node glove  simulate rate=100 output=pty
node base   mote ids=[1] rate=100
node nulls  offset samples=150
node units  scaling
node tqt    lib/tqt_fusion.pat rate=100 mode=robust
node press  msg bang
node out    osc_out profile=pointat host=127.0.0.1 port=9000
node ctl    osc_in port=9001
node both   pack 0 0 0
node slow   speedlim 500
node show   print prefix="azimuth elevation distance"
node cue    print prefix="gyro nulls (hold the glove still)"
node state  print prefix="glove"

glove.device -> base
base.m1 -> nulls -> units
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
nulls.status -> cue
