# A hand-made patch for the Pd round trip (make_fixtures.py exports it and has Pd save it as exported.pd):
# trigger, pack, route, message boxes with ',' ';' and $1, send / receive, and pointat-only nodes with
# full-precision float parameters, a list parameter and text with spaces.
node go    loadbang
node tr    trigger b b b
node first msg 1 2 , 3 4
node m     msg 7 $1 ; bus 0.5 ; other two words
node pk    pack 0 0 s
node rt    route 1 3 a
node bus   receive bus
node tx    send other
node sh    print prefix="two words; x, y" time=true
node fu    tqt k=0.123456789012 rho=0.25 mode=paper
node sp    speedlim 33.333333333333336
node rec   record file=out.csv columns=[qw, qx]

go -> tr
tr.2 -> first -> rt
tr.1 -> pk.1
tr.0 -> m -> pk
pk -> rt
rt.0 -> sh
rt.1 -> sp -> sh
rt.2 -> fu
rt.3 -> tx
bus -> sh
fu.quat -> rec
