# Pan a sound by pointing at it, over MIDI: the simulated glove -> the Pointing-at chain -> CC10.
#
#   glove -> nulls -> units -> gyro ------\
#                          \-> accmag -----> fuse -> quat -> ref -> dir.azimuth -> pan (midi_out CC10)
#                                                                              \-> slow -> show
#
# Azimuth 0 (CC 64, centre) is where the glove points when the patch starts (ref captures it): point at
# the centre of the stereo image first.  To capture it again live, add an osc_in as patches/glove_tqt.pat
# does and send /pointat/ref/set.
#
# DAW pan on CC10 is 0 = hard left, 64 = centre, 127 = hard right, while pointat's azimuth is
# POSITIVE LEFT (0 front, -180..180).  So the input range is reversed: range=[90, -90] sends
# +90 deg (pointing left) as 0, 0 deg (front) as 64 and -90 deg (right) as 127.  fold=true mirrors a
# direction behind you to the front, as a stereo pan hears it (135 deg, behind left, pans as 45), so
# turning round pans smoothly back to the centre instead of jumping from hard left to hard right.
#
# By default it writes a standard MIDI file, midi_pan.mid in the current folder (or --out DIR), so it runs anywhere
# (no MIDI system needed); message times are the sensor time stamps at 120 bpm, 480 ticks per beat:
#     pointat run midi_pan --for 20
# To a DAW or synth instead (needs pip install 'pointat[midi]' and a MIDI system):
#     pointat run midi_pan --set pan.file= --set "pan.port=IAC Bus 1"
#     pointat run midi_pan --set pan.file= --set pan.virtual=true   # a port named pointat
# Finer steps (14-bit, CC10 + CC42): --set pan.kind=cc14.  Another channel: --set pan.channel=2.
# With a real glove, replace the first line as in patches/pointing_at.pat (simulate output=pty + mote).

node glove  simulate rate=100
node nulls  offset samples=150
node units  scaling
node gyro   gyro_integrator mode=torre
node accmag accmag_matrix
node fuse   complementary crossover=0.2
node quat   matrix2quat
node ref    reference mode=heading capture_first=true
node dir    azi_ele
node pan    midi_out kind=cc channel=1 number=10 range=[90, -90] fold=true file=midi_pan.mid
node slow   speedlim 500
node show   print prefix="azimuth (deg, + left)"

glove.adc -> nulls -> units
units.mag -> accmag.mag
units.accel -> accmag.accel
units.gyro -> gyro
accmag -> fuse.accmag
gyro -> fuse.gyro_orientation
fuse -> quat -> ref -> dir
dir.azimuth -> pan
dir.azimuth -> slow -> show
