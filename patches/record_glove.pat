# The tqt glove patch that also records the glove: every mote frame's nine raw ADC counts and its time
# stamp into take.csv (in the current folder, or --out DIR, or --set take.file=...), line by line, nothing
# lost on Ctrl-C.
# Each run starts the file anew: name each take (--set take.file=take2.csv) or --set take.append=true.
# Rehearse with the glove on, then shape the sound without it: patches/replay_glove.pat plays the take
# back through the same chain, with the same results.  Live control on 9001 as in glove_tqt.pat; the
# reference pose (/pointat/press/bang) is not part of the take.
#
#   mote -> offset -> scaling -> lib/tqt_fusion.pat -> osc_out
#       \-> record
#
# For a real base station:  --set glove.output=direct --set base.device=/dev/ttyUSB0

node glove  simulate rate=100 output=pty
node base   mote ids=[1] rate=100
node take   record file=take.csv columns=[adc_gx, adc_gy, adc_gz, adc_ax, adc_ay, adc_az, adc_mx, adc_my, adc_mz]
node nulls  offset samples=150
node units  scaling
node tqt    lib/tqt_fusion.pat rate=100 mode=robust
node press  msg bang
node out    osc_out profile=pointat host=127.0.0.1 port=9000
node ctl    osc_in port=9001
node cue    print prefix="gyro nulls (hold the glove still)"
node state  print prefix="glove"

glove.device -> base
base.m1 -> take
base.m1 -> nulls -> units
units.mag -> tqt.mag
units.accel -> tqt.accel
units.range -> tqt.range
units.gyro -> tqt.gyro
tqt.flags -> state
tqt.flags -> out.flags
press -> tqt.reference
tqt.distance -> out.distance
tqt.elevation -> out.elevation
tqt.azimuth -> out.azimuth
nulls.status -> cue
