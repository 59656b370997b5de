# Gestures the glove is taught: three trained movements, strokes, sent as OSC and MIDI.
#
#   mote -> offset -> scaling -> gesture -> route -> OSC /pointat/gesture LABEL SCORE, a MIDI note each
#                             \-> tqt -> stroke -> OSC /pointat/stroke AZIMUTH ELEVATION STRENGTH
#
# The source is the built-in simulated glove playing a performer who points, rests, and makes a circle,
# a flick of the wrist and a nod in turn (simulate script=gestures).  gestures.json beside this patch
# holds three examples of each, taught from it; the first run copies it into the current folder (or
# --out DIR) as yours, loads it from there and recognises at once.
# Teach your own (a real glove: --set glove.output=direct --set base.device=/dev/ttyUSB0), over OSC to
# port 9001, e.g. with `pointat send 9001 ...`:
#   /pointat/moves/clear                   forget the examples
#   /pointat/moves/record circle 3         then make the circle three times, resting between
#   /pointat/moves/record flick 3          ... and the others
#   /pointat/moves/record null 3           ordinary moves that are no gesture (optional)
#   /pointat/moves/train                   learn, and recognise
#   /pointat/moves/save                    into your gestures.json, loaded at the next start
# Recognised gestures go to 127.0.0.1:9000 as /pointat/gesture LABEL SCORE (score 1: like an example,
# 0: at the edge of rejection), strokes as /pointat/stroke (the direction struck towards, in the room,
# from the fused orientation: a strike down is elevation -90; strength in g); each gesture also strikes a MIDI note
# (circle 60, flick 62, nod 64) on the first MIDI output port (--set n1.port=NAME; without a port,
# into NODE.mid files in the working folder).

node glove  simulate rate=100 script=gestures output=pty
node base   mote ids=[1] rate=100
node nulls  offset samples=150
node units  scaling
node moves  gesture channels=[gyr acc] file=gestures.json
node tqt    lib/tqt_fusion.pat rate=100 mode=robust
node hit    stroke threshold=1.5
node which  route circle flick nod
node tell   osc_send address=/pointat/gesture port=9000
node hits   osc_send address=/pointat/stroke port=9000
node ctl    osc_in port=9001
node t1     trigger b
node t2     trigger b
node t3     trigger b
node n1     midi_out kind=note number=60
node n2     midi_out kind=note number=62
node n3     midi_out kind=note number=64
node show   print prefix=gesture
node state  print prefix=moves

glove.device -> base
base.m1 -> nulls -> units
units.accel -> moves.acc
units.gyro -> moves.gyr
units.mag -> tqt.mag
units.accel -> tqt.accel
units.range -> tqt.range
units.gyro -> tqt.gyro
units.accel -> hit.acc
tqt.quat -> hit.q
moves.gesture -> tell
moves.gesture -> show
moves.gesture -> which
moves.status -> state
hit.stroke -> hits
which.0 -> t1 -> n1
which.1 -> t2 -> n2
which.2 -> t3 -> n3
