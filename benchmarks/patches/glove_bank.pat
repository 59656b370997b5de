# Latency benchmark: one glove's half after the tqt_bank of mote_tqt_bank_16.pat, the rest of glove_tqt.pat:
# the reference pose, azimuth, elevation and (roll gesture) distance, then osc_out as there.

args id=1 port=9000
inlet  quat -> ref.quat
inlet  spread -> out.spread

node ref  reference mode=heading
node dir  azi_ele
node roll roll_distance
node out  osc_out profile=generic host=127.0.0.1 port=$port source=$id address="/bench/{n}" \
          fields=[n, spread, az, el, dist]

# dir before roll: the elevation must be in place when roll's azimuth (the hot one downstream) fires
ref -> dir
ref -> roll
roll.distance -> out.distance
dir.elevation -> out.elevation
roll.azimuth -> out.azimuth
