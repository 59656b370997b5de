# The fusion half of Torre et al.'s chain (NIME 2008 §3-5), as an abstraction:
# gyro, accel, mag (rad/s, m/s², any field unit) -> orientation, azimuth, elevation, distance.
#
#   gyro -------> gyro_integrator --\
#   accel, mag -> accmag_matrix -----> complementary -> matrix2quat -> reference -> quat2axis
#                                                                              \-> azi_ele, roll_distance
# Send mag and accel before gyro (the hot inlet), as scaling and replay do.
# Beyond the paper, the reference pose (Bachmann's offset quaternion): its "reference" inlet, a bang,
# captures the current pointing direction as azimuth 0.  Until then azimuth 0 is the field's north.

args rate=100 crossover=0.2 integrator=torre
inlet  gyro -> gyro.gyro
inlet  accel -> accmag.accel
inlet  mag -> accmag.mag
inlet  reference -> ref.capture
outlet quat <- ref.quat
outlet axis <- axis.axis
outlet azimuth <- roll.azimuth
outlet elevation <- dir.elevation
outlet distance <- roll.distance

node gyro   gyro_integrator mode=$integrator rate=$rate
node accmag accmag_matrix
node fuse   complementary crossover=$crossover rate=$rate
node quat   matrix2quat
node ref    reference mode=heading
node axis   quat2axis
node dir    azi_ele
node roll   roll_distance

accmag -> fuse.accmag
gyro -> fuse.gyro_orientation
fuse -> quat -> ref
ref -> axis
# dir before roll: the elevation must be in place when roll's azimuth (the hot one downstream) fires
ref -> dir
ref -> roll
