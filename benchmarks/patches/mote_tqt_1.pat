# Latency benchmark: 1 mote on one base station (a pseudo-terminal that the
# benchmark writes real mote frames into), each through the tqt chain (glove_tqt.pat).
# Written by benchmarks.latency.mote_patch_text(); the benchmark sets base.device, base.rate and
# every gN/out.port.
#
# Sample tag: the benchmark puts 1548 + (k mod 1000) into the gyro x count of frame k;
# tapN/tagN map it to 0..99.9 in osc_out's spread field, so each OSC message names its frame.

node base mote ids=[1] rate=1000
node tap1 unpack f
node tag1 map 1548 2548 0 100
node g1   glove_tqt.pat id=1 port=9000 rate=1000

base.m1 -> tap1 -> tag1 -> g1.spread
base.m1 -> g1.adc
