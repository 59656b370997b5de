# Torre et al.'s chain on a real recording: one trial of the BROAD data set (optical ground truth, CC BY
# 4.0, pointat/data/README.md) replayed in real time through lib/torre_fusion.pat.
#   pointat run replay_pointing_at --set source.file=OTHER.csv.gz --set source.speed=0

node source replay file=pointat:data/01_undisturbed_slow_rotation_A.csv.gz speed=1
node torre  lib/torre_fusion.pat rate=285.7142857142857 crossover=0.05 integrator=exact
node out    osc_out profile=pointat host=127.0.0.1 port=9000
node both   pack 0 0 0
node slow   speedlim 500
node show   print prefix="azimuth elevation distance"

source.mag -> torre.mag
source.accel -> torre.accel
source.gyro -> torre.gyro
torre.distance -> out.distance
torre.distance -> both.2
torre.elevation -> out.elevation
torre.elevation -> both.1
torre.azimuth -> out.azimuth
torre.azimuth -> both.0
both -> slow -> show
