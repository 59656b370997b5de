# Latency benchmark: 16 motes on one base station (a pseudo-terminal that the
# benchmark writes real mote frames into), each through the tqt chain with one tqt_bank for all the gloves (glove_bank.pat after it).
# Written by benchmarks.latency.mote_patch_text(); the benchmark sets base.device, base.rate and
# every gN/out.port.
#
# Sample tag: the benchmark puts 1548 + (k mod 1000) into the gyro x count of frame k;
# tapN/tagN map it to 0..99.9 in osc_out's spread field, so each OSC message names its frame.

node base mote ids=[1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16] rate=1000
node bank tqt_bank sensors=16 rate=1000 mode=robust
node tap1 unpack f
node tag1 map 1548 2548 0 100
node nulls1 offset samples=150 still=0
node units1 scaling
node g1   glove_bank.pat id=1 port=9000
node tap2 unpack f
node tag2 map 1548 2548 0 100
node nulls2 offset samples=150 still=0
node units2 scaling
node g2   glove_bank.pat id=2 port=9000
node tap3 unpack f
node tag3 map 1548 2548 0 100
node nulls3 offset samples=150 still=0
node units3 scaling
node g3   glove_bank.pat id=3 port=9000
node tap4 unpack f
node tag4 map 1548 2548 0 100
node nulls4 offset samples=150 still=0
node units4 scaling
node g4   glove_bank.pat id=4 port=9000
node tap5 unpack f
node tag5 map 1548 2548 0 100
node nulls5 offset samples=150 still=0
node units5 scaling
node g5   glove_bank.pat id=5 port=9000
node tap6 unpack f
node tag6 map 1548 2548 0 100
node nulls6 offset samples=150 still=0
node units6 scaling
node g6   glove_bank.pat id=6 port=9000
node tap7 unpack f
node tag7 map 1548 2548 0 100
node nulls7 offset samples=150 still=0
node units7 scaling
node g7   glove_bank.pat id=7 port=9000
node tap8 unpack f
node tag8 map 1548 2548 0 100
node nulls8 offset samples=150 still=0
node units8 scaling
node g8   glove_bank.pat id=8 port=9000
node tap9 unpack f
node tag9 map 1548 2548 0 100
node nulls9 offset samples=150 still=0
node units9 scaling
node g9   glove_bank.pat id=9 port=9000
node tap10 unpack f
node tag10 map 1548 2548 0 100
node nulls10 offset samples=150 still=0
node units10 scaling
node g10   glove_bank.pat id=10 port=9000
node tap11 unpack f
node tag11 map 1548 2548 0 100
node nulls11 offset samples=150 still=0
node units11 scaling
node g11   glove_bank.pat id=11 port=9000
node tap12 unpack f
node tag12 map 1548 2548 0 100
node nulls12 offset samples=150 still=0
node units12 scaling
node g12   glove_bank.pat id=12 port=9000
node tap13 unpack f
node tag13 map 1548 2548 0 100
node nulls13 offset samples=150 still=0
node units13 scaling
node g13   glove_bank.pat id=13 port=9000
node tap14 unpack f
node tag14 map 1548 2548 0 100
node nulls14 offset samples=150 still=0
node units14 scaling
node g14   glove_bank.pat id=14 port=9000
node tap15 unpack f
node tag15 map 1548 2548 0 100
node nulls15 offset samples=150 still=0
node units15 scaling
node g15   glove_bank.pat id=15 port=9000
node tap16 unpack f
node tag16 map 1548 2548 0 100
node nulls16 offset samples=150 still=0
node units16 scaling
node g16   glove_bank.pat id=16 port=9000

base.m1 -> tap1 -> tag1 -> g1.spread
base.m1 -> nulls1 -> units1
units1.mag -> bank.mag1
units1.accel -> bank.accel1
units1.gyro -> bank.gyro1
bank.quat1 -> g1.quat
base.m2 -> tap2 -> tag2 -> g2.spread
base.m2 -> nulls2 -> units2
units2.mag -> bank.mag2
units2.accel -> bank.accel2
units2.gyro -> bank.gyro2
bank.quat2 -> g2.quat
base.m3 -> tap3 -> tag3 -> g3.spread
base.m3 -> nulls3 -> units3
units3.mag -> bank.mag3
units3.accel -> bank.accel3
units3.gyro -> bank.gyro3
bank.quat3 -> g3.quat
base.m4 -> tap4 -> tag4 -> g4.spread
base.m4 -> nulls4 -> units4
units4.mag -> bank.mag4
units4.accel -> bank.accel4
units4.gyro -> bank.gyro4
bank.quat4 -> g4.quat
base.m5 -> tap5 -> tag5 -> g5.spread
base.m5 -> nulls5 -> units5
units5.mag -> bank.mag5
units5.accel -> bank.accel5
units5.gyro -> bank.gyro5
bank.quat5 -> g5.quat
base.m6 -> tap6 -> tag6 -> g6.spread
base.m6 -> nulls6 -> units6
units6.mag -> bank.mag6
units6.accel -> bank.accel6
units6.gyro -> bank.gyro6
bank.quat6 -> g6.quat
base.m7 -> tap7 -> tag7 -> g7.spread
base.m7 -> nulls7 -> units7
units7.mag -> bank.mag7
units7.accel -> bank.accel7
units7.gyro -> bank.gyro7
bank.quat7 -> g7.quat
base.m8 -> tap8 -> tag8 -> g8.spread
base.m8 -> nulls8 -> units8
units8.mag -> bank.mag8
units8.accel -> bank.accel8
units8.gyro -> bank.gyro8
bank.quat8 -> g8.quat
base.m9 -> tap9 -> tag9 -> g9.spread
base.m9 -> nulls9 -> units9
units9.mag -> bank.mag9
units9.accel -> bank.accel9
units9.gyro -> bank.gyro9
bank.quat9 -> g9.quat
base.m10 -> tap10 -> tag10 -> g10.spread
base.m10 -> nulls10 -> units10
units10.mag -> bank.mag10
units10.accel -> bank.accel10
units10.gyro -> bank.gyro10
bank.quat10 -> g10.quat
base.m11 -> tap11 -> tag11 -> g11.spread
base.m11 -> nulls11 -> units11
units11.mag -> bank.mag11
units11.accel -> bank.accel11
units11.gyro -> bank.gyro11
bank.quat11 -> g11.quat
base.m12 -> tap12 -> tag12 -> g12.spread
base.m12 -> nulls12 -> units12
units12.mag -> bank.mag12
units12.accel -> bank.accel12
units12.gyro -> bank.gyro12
bank.quat12 -> g12.quat
base.m13 -> tap13 -> tag13 -> g13.spread
base.m13 -> nulls13 -> units13
units13.mag -> bank.mag13
units13.accel -> bank.accel13
units13.gyro -> bank.gyro13
bank.quat13 -> g13.quat
base.m14 -> tap14 -> tag14 -> g14.spread
base.m14 -> nulls14 -> units14
units14.mag -> bank.mag14
units14.accel -> bank.accel14
units14.gyro -> bank.gyro14
bank.quat14 -> g14.quat
base.m15 -> tap15 -> tag15 -> g15.spread
base.m15 -> nulls15 -> units15
units15.mag -> bank.mag15
units15.accel -> bank.accel15
units15.gyro -> bank.gyro15
bank.quat15 -> g15.quat
base.m16 -> tap16 -> tag16 -> g16.spread
base.m16 -> nulls16 -> units16
units16.mag -> bank.mag16
units16.accel -> bank.accel16
units16.gyro -> bank.gyro16
bank.quat16 -> g16.quat
