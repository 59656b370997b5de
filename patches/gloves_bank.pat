# Three Pointing-at gloves, three sound sources: one tqt_bank filters all of them in one update.
#
#   glove I -> offset -> scaling -\
#                                  tqt_bank (sensors=3) -> quatI -> reference -> azi_ele, roll_distance -> osc_out source=I
#
# The bank runs McGhee and Bachmann's filter for every glove at once (one compiled loop, numba; the
# same orientations as a tqt node per glove).  A glove that drops a packet
# stays where it was for that tick; one switched off is not waited for after 5 ticks.
# The sources are the built-in simulated gloves (output=direct: frames straight in, no port).  For one
# real base station with three motes, replace the three simulate nodes by
#     node base mote device=/dev/ttyUSB0 ids=[1, 2, 3] rate=100
# and wire base.m1 -> nulls1, base.m2 -> nulls2, base.m3 -> nulls3.
# Directions go to 127.0.0.1:9000 as /pointat/I/aed azimuth elevation distance (I = 1, 2, 3), the
# convention of patches/glove_tqt.pat; /pointat/press/bang (OSC to 9001) makes where each glove
# points its azimuth 0.  Filter gains are live for all gloves: /pointat/bank/k_heading 0.05.

node glove1 simulate rate=100 output=direct seed=1
node glove2 simulate rate=100 output=direct seed=2
node glove3 simulate rate=100 output=direct seed=3
node nulls1 offset samples=150
node nulls2 offset samples=150
node nulls3 offset samples=150
node units1 scaling
node units2 scaling
node units3 scaling
node bank   tqt_bank sensors=3 rate=100 mode=robust
node ref1   reference mode=heading
node ref2   reference mode=heading
node ref3   reference mode=heading
node dir1   azi_ele
node dir2   azi_ele
node dir3   azi_ele
node roll1  roll_distance
node roll2  roll_distance
node roll3  roll_distance
node out1   osc_out profile=pointat host=127.0.0.1 port=9000 source=1
node out2   osc_out profile=pointat host=127.0.0.1 port=9000 source=2
node out3   osc_out profile=pointat host=127.0.0.1 port=9000 source=3
node press  msg bang
node ctl    osc_in port=9001
node flags  print prefix="glove status"
node both   pack 0 0 0
node slow   speedlim 500
node show   print prefix="glove 1: azimuth elevation distance"

glove1.adc -> nulls1 -> units1
glove2.adc -> nulls2 -> units2
glove3.adc -> nulls3 -> units3
units1.mag -> bank.mag1
units1.accel -> bank.accel1
units1.gyro -> bank.gyro1
units2.mag -> bank.mag2
units2.accel -> bank.accel2
units2.gyro -> bank.gyro2
units3.mag -> bank.mag3
units3.accel -> bank.accel3
units3.gyro -> bank.gyro3
bank.quat1 -> ref1
bank.quat2 -> ref2
bank.quat3 -> ref3
bank.flags -> flags
press -> ref1.capture
press -> ref2.capture
press -> ref3.capture
# dir before roll: the elevation must be in place when roll's azimuth (the hot one downstream) fires
ref1 -> dir1
ref1 -> roll1
ref2 -> dir2
ref2 -> roll2
ref3 -> dir3
ref3 -> roll3
dir1.elevation -> out1.elevation
roll1.distance -> out1.distance
roll1.azimuth -> out1.azimuth
dir2.elevation -> out2.elevation
roll2.distance -> out2.distance
roll2.azimuth -> out2.azimuth
dir3.elevation -> out3.elevation
roll3.distance -> out3.distance
roll3.azimuth -> out3.azimuth
dir1.elevation -> both.1
roll1.distance -> both.2
roll1.azimuth -> both.0
both -> slow -> show
