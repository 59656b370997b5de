# Evaluate Torre's complementary chain on a recording: one output row per input sample, t,qw,qx,qy,qz,
# the estimated orientation mapping sensor -> the recording's earth frame (ENU for the BROAD data set).
# Ends by itself at the end of the file.
#
#   pointat run evaluate_complementary --set source.file=IN.csv.gz --set sink.file=OUT.csv

node source replay file=pointat:data/01_undisturbed_slow_rotation_A.csv.gz speed=0
node gyro   gyro_integrator mode=exact rate=285.7142857142857
node accmag accmag_matrix
node fuse   complementary crossover=0.05 rate=285.7142857142857
node quat   matrix2quat
node enu    reframe source=nwu target=enu
node sink   record file=evaluate_complementary.csv columns=[qw, qx, qy, qz]

source.mag -> accmag.mag
source.accel -> accmag.accel
source.gyro -> gyro
accmag -> fuse.accmag
gyro -> fuse.gyro_orientation
fuse -> quat -> enu -> sink
