# Cost benchmark: 16 motes on one base station (a pseudo-terminal that the
# benchmark writes real mote frames into), each through the tqt chain (glove_tqt.pat), untagged: what a glove-sample costs, nothing added.
# Written by benchmarks.latency.mote_patch_text(); the benchmark sets base.device, base.rate and
# every gN/out.port.  No sample tag: the outputs are counted, not matched.

node base mote ids=[1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16] rate=1000
node g1   glove_tqt.pat id=1 port=9000 rate=1000
node g2   glove_tqt.pat id=2 port=9000 rate=1000
node g3   glove_tqt.pat id=3 port=9000 rate=1000
node g4   glove_tqt.pat id=4 port=9000 rate=1000
node g5   glove_tqt.pat id=5 port=9000 rate=1000
node g6   glove_tqt.pat id=6 port=9000 rate=1000
node g7   glove_tqt.pat id=7 port=9000 rate=1000
node g8   glove_tqt.pat id=8 port=9000 rate=1000
node g9   glove_tqt.pat id=9 port=9000 rate=1000
node g10   glove_tqt.pat id=10 port=9000 rate=1000
node g11   glove_tqt.pat id=11 port=9000 rate=1000
node g12   glove_tqt.pat id=12 port=9000 rate=1000
node g13   glove_tqt.pat id=13 port=9000 rate=1000
node g14   glove_tqt.pat id=14 port=9000 rate=1000
node g15   glove_tqt.pat id=15 port=9000 rate=1000
node g16   glove_tqt.pat id=16 port=9000 rate=1000

base.m1 -> g1.adc
base.m2 -> g2.adc
base.m3 -> g3.adc
base.m4 -> g4.adc
base.m5 -> g5.adc
base.m6 -> g6.adc
base.m7 -> g7.adc
base.m8 -> g8.adc
base.m9 -> g9.adc
base.m10 -> g10.adc
base.m11 -> g11.adc
base.m12 -> g12.adc
base.m13 -> g13.adc
base.m14 -> g14.adc
base.m15 -> g15.adc
base.m16 -> g16.adc
