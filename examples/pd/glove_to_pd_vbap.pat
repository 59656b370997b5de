# Point at a loudspeaker, hear it there: the simulated glove drives VBAP twice, in Pd and in pointat.
#
#   glove -> mote -> offset -> scaling -> tqt_fusion -> osc_out profile=vbap -> Pd: vbap_receiver.pd
#                                                   \-> vbap (pointat's own gains) -> print
#
# Start the receiver first:  pd -path examples/pd -open examples/pd/vbap_receiver.pd
# (add -nogui -noaudio for a headless test; see examples/pd/README.md).  Then:
#   pointat run examples/pd/glove_to_pd_vbap.pat --for 20
# Point at the front loudspeaker and send /pointat/press/bang (OSC to port 9001) to make it azimuth 0:
#   pointat send 9001 /pointat/press/bang
# (until then azimuth 0 is magnetic north).
# The printed gains are what Pd's [vbap] computes too (same layout, azimuth + left).  For the 3-D dome
# open vbap_receiver_3d.pd instead and set the layout below to its 12 loudspeakers:
#   layout=[[0, 0], [45, 0], [90, 0], [135, 0], [180, 0], [-135, 0], [-90, 0], [-45, 0], \
#           [45, 45], [135, 45], [-135, 45], [-45, 45]]

node glove  simulate rate=100 output=pty
node base   mote ids=[1] rate=100
node nulls  offset samples=150
node units  scaling
node tqt    ../../patches/lib/tqt_fusion.pat rate=100 mode=robust
node press  msg bang
node ctl    osc_in port=9001
node pd     osc_out profile=vbap host=127.0.0.1 port=9000 source=1 rate=50
node spk    vbap layout=[0, 45, 90, 135, 180, -135, -90, -45]
node slow   speedlim 500
node show   print prefix="gains" decimals=2

glove.device -> base
press -> tqt.reference
base.m1 -> nulls -> units
units.mag -> tqt.mag
units.accel -> tqt.accel
units.gyro -> tqt.gyro
tqt.elevation -> pd.elevation
tqt.elevation -> spk.elevation
tqt.azimuth -> pd.azimuth
tqt.azimuth -> spk.azimuth
spk.gains -> slow -> show
