# The tqt half of the glove patch, as an abstraction: McGhee/Bachmann's quaternion filter, the
# reference pose, then azimuth, elevation and (roll gesture) distance.
# gyro, accel, mag (rad/s, m/s², any field unit) -> quat, azimuth, elevation, distance.
# Send mag and accel before gyro (the hot inlet), as scaling and replay do.
# Its "reference" inlet: a bang captures the current pointing direction as azimuth 0; its "range" inlet
# takes scaling's range (the sensor's full scale), so that a clipped axis is known.

args rate=100 mode=robust
inlet  gyro -> fuse.gyro
inlet  accel -> fuse.accel
inlet  mag -> fuse.mag
inlet  range -> fuse.range
inlet  reference -> ref.capture
outlet quat <- ref.quat
outlet azimuth <- roll.azimuth
outlet elevation <- dir.elevation
outlet distance <- roll.distance
outlet flags <- fuse.flags

node fuse tqt mode=$mode rate=$rate
node ref  reference mode=heading
node dir  azi_ele
node roll roll_distance

fuse.quat -> ref
# dir before roll: the elevation must be in place when roll's azimuth (the hot one downstream) fires
ref -> dir
ref -> roll
