# Evaluate the tqt filter on a recording: one output row per input sample, t,qw,qx,qy,qz, the estimated
# orientation mapping sensor -> the recording's earth frame (ENU for the BROAD data set, like its ground
# truth).  Ends by itself at the end of the file.
#
#   pointat run evaluate_tqt --set source.file=IN.csv.gz --set sink.file=OUT.csv
#
# Try the paper's filter with --set fuse.mode=paper.

node source replay file=pointat:data/01_undisturbed_slow_rotation_A.csv.gz speed=0
node fuse   tqt mode=robust rate=285.7142857142857
node enu    reframe source=nwu target=enu
node sink   record file=evaluate_tqt.csv columns=[qw, qx, qy, qz]

source.mag -> fuse.mag
source.accel -> fuse.accel
source.gyro -> fuse.gyro
fuse.quat -> enu -> sink
