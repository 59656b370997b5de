# Throughput benchmark: the built-in simulated glove (output=direct) at 1 kHz into glove_tqt.pat, run in
# one thread with a manual clock (as fast as the CPU allows).  The benchmark sets g/out.port.

node glove simulate rate=1000 output=direct
node g     glove_tqt.pat id=1 port=9000 rate=1000

glove.adc -> g.adc
