# A whole body: 15 sensors (pelvis, chest, head, both arms, both legs) through one tqt_bank, Bachmann's
# posture tracking into 15 segments and their joints, sent as OSC to port 9003
# (/pointat/body/SEGMENT/quat|pos|end) and recorded as a BVH take (body.bvh in the current folder, or
# --out DIR, anew at each run).
#
# Out of the box it runs on a simulated body: 6 s in the calibration pose (the N-pose: upright, arms
# hanging, feet forward), then it walks in place, turns and swings its arms.  One core does it at 100 Hz
# with room to spare (see benchmarks: about 70 us a frame).  With real sensors, stand in the N-pose facing
# the front and send /pointat/body/calibrate (pointat send 9001 /pointat/body/calibrate).

node suit  simulate_body file=pointat:data/body15.json pose=6 heading=-20
node bank  tqt_bank sensors=15
node body  skeleton file=pointat:data/body15.json auto=5 front=-20
node limbs osc_body file=pointat:data/body15.json host=127.0.0.1 port=9003
node take  bvh_record file=body.bvh skeleton=pointat:data/body15.json rate=100
node ctl   osc_in port=9001
node lb    loadbang
node fast  msg k 5, k_heading 2, k_heading_unrested 2
node wait  delay 4500
node calm  msg k 0, k_heading 0.015, k_heading_unrested 0.1
node state print prefix=body

lb -> fast -> bank
lb -> wait -> calm -> bank
suit.mag1 -> bank.mag1
suit.accel1 -> bank.accel1
suit.gyro1 -> bank.gyro1
suit.mag2 -> bank.mag2
suit.accel2 -> bank.accel2
suit.gyro2 -> bank.gyro2
suit.mag3 -> bank.mag3
suit.accel3 -> bank.accel3
suit.gyro3 -> bank.gyro3
suit.mag4 -> bank.mag4
suit.accel4 -> bank.accel4
suit.gyro4 -> bank.gyro4
suit.mag5 -> bank.mag5
suit.accel5 -> bank.accel5
suit.gyro5 -> bank.gyro5
suit.mag6 -> bank.mag6
suit.accel6 -> bank.accel6
suit.gyro6 -> bank.gyro6
suit.mag7 -> bank.mag7
suit.accel7 -> bank.accel7
suit.gyro7 -> bank.gyro7
suit.mag8 -> bank.mag8
suit.accel8 -> bank.accel8
suit.gyro8 -> bank.gyro8
suit.mag9 -> bank.mag9
suit.accel9 -> bank.accel9
suit.gyro9 -> bank.gyro9
suit.mag10 -> bank.mag10
suit.accel10 -> bank.accel10
suit.gyro10 -> bank.gyro10
suit.mag11 -> bank.mag11
suit.accel11 -> bank.accel11
suit.gyro11 -> bank.gyro11
suit.mag12 -> bank.mag12
suit.accel12 -> bank.accel12
suit.gyro12 -> bank.gyro12
suit.mag13 -> bank.mag13
suit.accel13 -> bank.accel13
suit.gyro13 -> bank.gyro13
suit.mag14 -> bank.mag14
suit.accel14 -> bank.accel14
suit.gyro14 -> bank.gyro14
suit.mag15 -> bank.mag15
suit.accel15 -> bank.accel15
suit.gyro15 -> bank.gyro15
bank.quats -> body
body.status -> state
body.ends -> limbs.ends
body.joints -> limbs.joints
body.joints -> take.joints
body.segments -> take.segments
body.segments -> limbs.segments
