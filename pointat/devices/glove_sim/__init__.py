r"""A virtual Pointing-at glove: scripted hand motion, a mote's sensor model, and its frames.

Three layers, each usable alone, each in a module of its own (their names are all importable from here):

* :class:`MotionScript` (:mod:`~pointat.devices.glove_sim.motion`) -- ground truth.  A looping list of
  :class:`Segment` moves of the hand (azimuth, elevation and roll of the pointing axis, eased so that the
  angular rate is continuous), giving the orientation :math:`q(t)` (sensor -> NWU) and the angular rate
  :math:`\omega(t)` in the sensor frame.
* :class:`Burst` (:mod:`~pointat.devices.glove_sim.bursts`) -- ground truth of the hand's translation:
  percussive strokes and shakes, bursts of linear acceleration (:func:`burst_acceleration`, earth frame)
  whose velocity and displacement come back to zero, so the hand returns to where it was.
* :class:`SensorModel` (:mod:`~pointat.devices.glove_sim.sensor`) -- what the mote's sensors read in that
  pose, as 12-bit ADC counts: gyro (with a constant bias and white noise), accelerometer (specific force:
  gravity and the hand's linear acceleration) and magnetometer (the Earth's field with its dip), through
  a :class:`~pointat.devices.mote_frame.MoteSpec`; optionally saturating at a full scale of its own.
* :class:`GloveSimulator` (:mod:`~pointat.devices.glove_sim.simulator`) -- samples them at a fixed rate
  into :class:`~pointat.devices.mote_frame.Frame` values with a running ``n_pack``, deterministically for
  a seed; :class:`PtyGlove` (:mod:`~pointat.devices.glove_sim.pty`) writes them in real time into a
  pseudo-terminal, so the real serial path (:class:`~pointat.devices.serial_reader.SerialMoteReader`)
  can be exercised without hardware.

Pose angles (degrees) follow pointat's conventions (:mod:`pointat.maths`): azimuth of the pointing axis
(sensor x), 0 = front = north, positive = left; elevation positive up; roll about the hand axis,
positive turns the back of the hand (sensor z) towards the right (for a right hand: thumb up).  The
orientation is :math:`q = q_z(\mathrm{az}) \otimes q_y(-\mathrm{el}) \otimes q_x(\mathrm{roll})`
(:func:`~pointat.maths.quaternion.euler_to_quat` with yaw = az, pitch = -el).  The hand rotates about
the sensor; it translates only in bursts (:class:`Burst`; without them the accelerometer sees gravity
only), and translation leaves the orientation as it is.  The earth frame is NWU (x north, y west, z up).

The ADC resolutions are :data:`~pointat.devices.mote_frame.DEFAULT_RESOLUTION` (Torre Table 1 units:
°/s, m/s², gauss per count), re-exported here with :class:`MoteSpec` and :data:`DEFAULT_SPEC`.

Examples
--------
>>> sim = GloveSimulator(seed=1)
>>> t, frame, q = sim.sample(0)
>>> t, frame.mote, frame.n_pack, q.round(12).tolist()
(0.0, 1, 0, [1.0, 0.0, 0.0, 0.0])
>>> round(DEFAULT_SPEC.to_units(frame.channels)[5], 1)     # accel z at rest: +g (specific force)
9.8
>>> GloveSimulator(seed=1).sample(250).frame == sim.sample(250).frame    # deterministic, random access
True
>>> drum = GloveSimulator(seed=1, bursts=[Burst(start=1.0, duration=2.0, peak_g=3.0, rate=4.0)])
>>> [drum.sample(k).frame == sim.sample(k).frame for k in (99, 124)]    # before, in the 1st impact
[True, False]
>>> drum.truth(124).linear_acceleration.round(1).tolist()                # up: it stops the strike
[0.0, 0.0, 22.1]
"""

from __future__ import annotations

from pointat.devices.mote_frame import DEFAULT_RESOLUTION, DEFAULT_SPEC, MoteSpec, adc_full_scale

from .bursts import GRAVITY, IMPACT_S, Burst, burst_acceleration
from .motion import MotionScript, Segment, default_script, hold
from .pty import PtyGlove
from .sensor import SensorModel
from .simulator import GloveSimulator, Sample, Truth

__all__ = [
    "DEFAULT_RESOLUTION",
    "DEFAULT_SPEC",
    "GRAVITY",
    "IMPACT_S",
    "Burst",
    "GloveSimulator",
    "MoteSpec",
    "MotionScript",
    "PtyGlove",
    "Sample",
    "Segment",
    "SensorModel",
    "Truth",
    "adc_full_scale",
    "burst_acceleration",
    "default_script",
    "hold",
]
