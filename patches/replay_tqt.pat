# The tqt filter on a real recording: one trial of the BROAD data set (optical ground truth, CC BY 4.0,
# pointat/data/README.md) replayed in real time through lib/tqt_fusion.pat.
#   pointat run replay_tqt --set source.file=OTHER.csv.gz --set source.speed=0

node source replay file=pointat:data/01_undisturbed_slow_rotation_A.csv.gz speed=1
node tqt    lib/tqt_fusion.pat rate=285.7142857142857 mode=robust
node out    osc_out profile=pointat host=127.0.0.1 port=9000
node both   pack 0 0 0
node slow   speedlim 500
node show   print prefix="azimuth elevation distance"

source.mag -> tqt.mag
source.accel -> tqt.accel
source.gyro -> tqt.gyro
tqt.distance -> out.distance
tqt.distance -> both.2
tqt.elevation -> out.elevation
tqt.elevation -> both.1
tqt.azimuth -> out.azimuth
tqt.azimuth -> both.0
both -> slow -> show
tqt.flags -> out.flags
