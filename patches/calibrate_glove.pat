# Calibrate a glove (Bachmann et al., VRST 2001 §3.2.1): its nulls and scales, into calibration.json.
#
#   mote -> calibrate -> print        (driven by OSC on port 9001, from a second terminal)
#
# Run it, then send each step with `pointat send 9001 ADDRESS [values]` and watch what it prints:
#   1. /pointat/cal/rest                  lay the glove down, hold still 2 s: the gyro nulls
#   2. /pointat/cal/pose  (six times)      each accelerometer axis straight up, then straight down,
#                                          held still 2 s each: accelerometer nulls and scales (Eqs. 29-30),
#                                          and its cross-axis misalignment when the poses are square (the
#                                          glove in a squared box or against a jig: "acc_misalignment")
#   3. /pointat/cal/mag_begin, turn the glove every way for 30 s, /pointat/cal/mag_end
#                                          magnetometer nulls and scales (away from steel and speakers);
#                                          refused when the sweep missed directions ("mag_refused")
#   4. /pointat/cal/turn_begin, turn the glove by a known angle about one of its axes (90 deg flat on
#      a table, against a square edge, counter-clockwise seen from the axis's tip: for z, from above),
#      then /pointat/cal/turn_end 90 2 (the angle, the axis: 0 x, 1 y, 2 z): that gyro axis's scale
#      (Eq. 31).  Again for the other two axes.  After step 1, in the same run.  With all three axes
#      turned, the gyro's cross-axis misalignment too ("gyro_misalignment"); 180 deg turns and
#      --set cal.samples=1000 halve its error (0.02 against 0.04 deg).
#   5. /pointat/cal/save                  writes calibration.json in the current folder (or --out DIR,
#                                          or cal.file=...)
# Steps 2-4 may be left out: a sensor the file does not calibrate keeps Torre's nominal resolution.
# An existing calibration.json is the starting point ("loaded"): redo one step, save, and the others
# stay; /pointat/cal/clear starts from nothing.
# Then play with it:
#   pointat run glove_tqt --set nulls.calibration=calibration.json \
#       --set units.calibration=calibration.json
#
# The source is the built-in simulated glove (it can do steps 1, 3 and 4: its script turns but never
# points an accelerometer axis down; for step 3 run with --set cal.mag_fit=ellipsoid, since its turns
# do not cover every direction, which min/max needs: e.g. mag_begin at 48 s, mag_end at 84 s).  It holds still only from 36 to 43 s after the patch starts (then
# every 41 s): send step 1 then, e.g. `sleep 37; pointat send 9001 /pointat/cal/rest`; sent while it
# moves, the step is refused ("moved ...") and may be sent again.  For a real base station:
#     pointat run calibrate_glove --set glove.output=direct --set base.device=/dev/ttyUSB0

node glove  simulate rate=100 output=pty
node base   mote ids=[1] rate=100
node cal    calibrate file=calibration.json samples=200
node ctl    osc_in port=9001
node show   print prefix=calibrate

glove.device -> base
base.m1 -> cal
cal -> show
