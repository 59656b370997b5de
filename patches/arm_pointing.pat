# Point at a place in the room with the whole arm: three sensors (upper arm, forearm, hand), Bachmann's
# posture tracking (each segment's orientation from its own filter, offsets from a calibration pose,
# positions down the arm), and the ray from the shoulder through the fingertips onto the loudspeaker sphere.
#
# Out of the box it runs on a simulated right arm: 6 s in the calibration pose (arm straight ahead,
# level, palm down), then it swings, rises and bends.  The console prints where the arm points: azimuth
# and elevation seen from the listening position (degrees, + left, + up) and the distance to the point
# on the sphere (3 m around the listener at 1.2 m).  OSC: the direction to port 9000 (/pointat/1/aed), the
# whole arm to port 9003 (/pointat/body/SEGMENT/quat|pos|end).  The calibration pose is taken 5 s in
# (auto=5); with real sensors, stand in the pose facing the front and send /pointat/body/calibrate
# (pointat send 9001 /pointat/body/calibrate).  While the arm rests in the pose the filters trust gravity
# and the field at once (fast: the k, k_heading and k_heading_unrested sent to suit), and then go back
# to their defaults (calm), so the pose is taken settled.

node arm   simulate_body pose=6 heading=35
node suit  tqt_bank sensors=3
node body  skeleton auto=5 front=35
node ray   point_ray start=upper_arm through=hand.end radius=3 centre=[0, 0, 1.2]
node out   osc_out profile=pointat host=127.0.0.1 port=9000
node limbs osc_body host=127.0.0.1 port=9003
node ctl   osc_in port=9001
node lb    loadbang
node fast  msg k 5, k_heading 2, k_heading_unrested 2
node wait  delay 4500
node calm  msg k 0, k_heading 0.015, k_heading_unrested 0.1
node both  pack 0 0 0
node slow  speedlim 500
node show  print prefix="arm points at: azimuth elevation metres" decimals=2
node state print prefix=body

lb -> fast -> suit
lb -> wait -> calm -> suit
arm.mag1 -> suit.mag1
arm.accel1 -> suit.accel1
arm.gyro1 -> suit.gyro1
arm.mag2 -> suit.mag2
arm.accel2 -> suit.accel2
arm.gyro2 -> suit.gyro2
arm.mag3 -> suit.mag3
arm.accel3 -> suit.accel3
arm.gyro3 -> suit.gyro3
suit.quats -> body
body.status -> state
body.ends -> ray.ends
body.ends -> limbs.ends
body.joints -> limbs.joints
body.joints -> ray.joints
body.segments -> limbs.segments
ray.distance -> both.2
ray.elevation -> out.elevation
ray.elevation -> both.1
ray.azimuth -> out.azimuth
ray.azimuth -> both
both -> slow -> show
