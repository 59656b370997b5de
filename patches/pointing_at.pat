# Pointing-at (Torre et al., NIME 2008): the paper's chain end to end.
#
#   mote -> offset -> scaling -> gyro_integrator --\
#                            \-> accmag_matrix -----> complementary -> matrix2quat -> reference -> quat2axis
#                                                                                       \-> azi_ele -> osc_out
#                                                                                       \-> roll_distance
#
# The fusion half (gyro_integrator ... roll_distance) is the abstraction lib/torre_fusion.pat, shared
# with replay_pointing_at.pat.  The source is the built-in simulated glove writing real mote frames into
# a pseudo-terminal that the mote node reads.  For a real base station:
#     pointat run pointing_at --set glove.output=direct --set base.device=/dev/ttyUSB0
# Point at the front loudspeaker and send /pointat/press/bang (OSC to port 9001) to make it azimuth 0
# (until then azimuth 0 is magnetic north, as in the paper).
# Directions go to 127.0.0.1:9000 as /pointat/1/aed azimuth elevation distance, three float32: degrees
# (+ left, + up) and ADM-OSC's distance 0..1 (1 far, 0 near; the console shows the gesture's 0..90).
# Live control on 9001: /pointat/NODE/PARAM value or /pointat/NODE/METHOD, e.g.
# /pointat/torre/fuse/crossover 0.1 or /pointat/nulls/recalibrate (new gyro nulls: hold still).

node glove  simulate rate=100 output=pty
node base   mote ids=[1] rate=100
node nulls  offset samples=150
node units  scaling
node torre  lib/torre_fusion.pat rate=100 crossover=0.2 integrator=torre
node press  msg bang
node out    osc_out profile=pointat host=127.0.0.1 port=9000
node ctl    osc_in port=9001
node both   pack 0 0 0
node slow   speedlim 500
node show   print prefix="azimuth elevation distance"
node cue    print prefix="gyro nulls (hold the glove still)"

glove.device -> base
base.m1 -> nulls -> units
units.mag -> torre.mag
units.accel -> torre.accel
units.gyro -> torre.gyro
press -> torre.reference
torre.distance -> out.distance
torre.distance -> both.2
torre.elevation -> out.elevation
torre.elevation -> both.1
torre.azimuth -> out.azimuth
torre.azimuth -> both.0
both -> slow -> show
nulls.status -> cue
