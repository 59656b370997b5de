# Latency benchmark: 16 motes on one base station (a pseudo-terminal that the
# benchmark writes real mote frames into), each through the Pointing-at chain (glove_torre.pat).
# Written by benchmarks.latency.mote_patch_text(); the benchmark sets base.device, base.rate and
# every gN/out.port.
#
# Sample tag: the benchmark puts 1548 + (k mod 1000) into the gyro x count of frame k;
# tapN/tagN map it to 0..99.9 in osc_out's spread field, so each OSC message names its frame.

node base mote ids=[1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16] rate=1000
node tap1 unpack f
node tag1 map 1548 2548 0 100
node g1   glove_torre.pat id=1 port=9000 rate=1000
node tap2 unpack f
node tag2 map 1548 2548 0 100
node g2   glove_torre.pat id=2 port=9000 rate=1000
node tap3 unpack f
node tag3 map 1548 2548 0 100
node g3   glove_torre.pat id=3 port=9000 rate=1000
node tap4 unpack f
node tag4 map 1548 2548 0 100
node g4   glove_torre.pat id=4 port=9000 rate=1000
node tap5 unpack f
node tag5 map 1548 2548 0 100
node g5   glove_torre.pat id=5 port=9000 rate=1000
node tap6 unpack f
node tag6 map 1548 2548 0 100
node g6   glove_torre.pat id=6 port=9000 rate=1000
node tap7 unpack f
node tag7 map 1548 2548 0 100
node g7   glove_torre.pat id=7 port=9000 rate=1000
node tap8 unpack f
node tag8 map 1548 2548 0 100
node g8   glove_torre.pat id=8 port=9000 rate=1000
node tap9 unpack f
node tag9 map 1548 2548 0 100
node g9   glove_torre.pat id=9 port=9000 rate=1000
node tap10 unpack f
node tag10 map 1548 2548 0 100
node g10   glove_torre.pat id=10 port=9000 rate=1000
node tap11 unpack f
node tag11 map 1548 2548 0 100
node g11   glove_torre.pat id=11 port=9000 rate=1000
node tap12 unpack f
node tag12 map 1548 2548 0 100
node g12   glove_torre.pat id=12 port=9000 rate=1000
node tap13 unpack f
node tag13 map 1548 2548 0 100
node g13   glove_torre.pat id=13 port=9000 rate=1000
node tap14 unpack f
node tag14 map 1548 2548 0 100
node g14   glove_torre.pat id=14 port=9000 rate=1000
node tap15 unpack f
node tag15 map 1548 2548 0 100
node g15   glove_torre.pat id=15 port=9000 rate=1000
node tap16 unpack f
node tag16 map 1548 2548 0 100
node g16   glove_torre.pat id=16 port=9000 rate=1000

base.m1 -> tap1 -> tag1 -> g1.spread
base.m1 -> g1.adc
base.m2 -> tap2 -> tag2 -> g2.spread
base.m2 -> g2.adc
base.m3 -> tap3 -> tag3 -> g3.spread
base.m3 -> g3.adc
base.m4 -> tap4 -> tag4 -> g4.spread
base.m4 -> g4.adc
base.m5 -> tap5 -> tag5 -> g5.spread
base.m5 -> g5.adc
base.m6 -> tap6 -> tag6 -> g6.spread
base.m6 -> g6.adc
base.m7 -> tap7 -> tag7 -> g7.spread
base.m7 -> g7.adc
base.m8 -> tap8 -> tag8 -> g8.spread
base.m8 -> g8.adc
base.m9 -> tap9 -> tag9 -> g9.spread
base.m9 -> g9.adc
base.m10 -> tap10 -> tag10 -> g10.spread
base.m10 -> g10.adc
base.m11 -> tap11 -> tag11 -> g11.spread
base.m11 -> g11.adc
base.m12 -> tap12 -> tag12 -> g12.spread
base.m12 -> g12.adc
base.m13 -> tap13 -> tag13 -> g13.spread
base.m13 -> g13.adc
base.m14 -> tap14 -> tag14 -> g14.spread
base.m14 -> g14.adc
base.m15 -> tap15 -> tag15 -> g15.spread
base.m15 -> g15.adc
base.m16 -> tap16 -> tag16 -> g16.spread
base.m16 -> g16.adc
