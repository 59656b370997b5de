# IEM Plug-in Suite: point the glove to steer a StereoEncoder (or one input of a MultiEncoder).
#
#   glove -> nulls -> units -> fuse -> ref -> dir -> out (osc_out profile=iem_stereo)
#
# Sends /StereoEncoder/azimuth and /StereoEncoder/elevation (one float32 each, degrees, azimuth + left as
# in the plug-ins) to 127.0.0.1:8000, as one bundle per update (the plug-ins ignore its time tag), at
# most 60 times a second.  Each plug-in instance listens on its own port: open its OSC settings (the
# footer) and enter the same port.  The direction the hand points at when the patch starts is the front.
#     pointat run iem
#     pointat run iem --set out.port=8001
# A MultiEncoder input instead (inputs count from 0: /MultiEncoder/azimuth2 for the third one):
#     pointat run iem --set out.profile=iem_multi --set out.source=2
# Setting up the receiver: examples/README.md.  A real glove: replace "glove" as in patches/pointing_at.pat.

node glove  simulate rate=100
node nulls  offset samples=50
node units  scaling
node fuse   tqt mode=robust
node ref    reference mode=heading capture_first=true
node dir    azi_ele
node out    osc_out profile=iem_stereo host=127.0.0.1 port=8000 bundle=true rate=60
node state  print prefix="glove"

glove.adc -> nulls -> units
units.mag -> fuse.mag
units.accel -> fuse.accel
units.range -> fuse.range
units.gyro -> fuse.gyro
fuse.flags -> state
fuse.flags -> out.flags
fuse.quat -> ref -> dir
dir.elevation -> out.elevation
dir.azimuth -> out.azimuth
