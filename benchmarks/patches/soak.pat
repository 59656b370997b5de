# Memory benchmark: the built-in simulated glove at 1 kHz writing real mote frames into a pseudo-terminal,
# read by a mote node and sent through both chains (glove_torre.pat and glove_tqt.pat) to osc_out.
# The benchmark runs it for 30 s (--quick) or 10 min and samples the process's resident memory.
# The benchmark sets a/out.port and b/out.port.

node glove simulate rate=1000 output=pty
node base  mote ids=[1] rate=1000
node a     glove_torre.pat id=1 port=9000 rate=1000
node b     glove_tqt.pat id=2 port=9000 rate=1000

glove.device -> base
base.m1 -> a.adc
base.m1 -> b.adc
