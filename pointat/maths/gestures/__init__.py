r"""Gestures learnt from a performer's examples: trained movements, postures, strokes, and following.

Plain classes on numpy arrays; nothing here imports the engine.  The nodes of
:mod:`pointat.nodes.gestures` and ``pointat gestures evaluate`` (:mod:`pointat.gesture_eval`) run the very
same objects, so what the evaluation measures is what the patch does.

Conventions
-----------
* A *frame* is one sample of the channels a model uses, concatenated in the order of its ``channels``:
  ``acc`` (specific force, m/s², +g up at rest, sensor frame), ``gyr`` (rad/s), ``mag`` (any unit: only
  its direction is used), ``q`` (orientation w, x, y, z, sensor -> earth) and ``x`` (any other features,
  ``size`` numbers given by the model).  Times are seconds, strictly increasing.
* A gesture is the frames of one movement, from rest to rest (:class:`Segmenter`), between a gate's
  on and off, or wherever a template matches in a stream that never rests (:class:`Spotter`).  Its
  features (:func:`segment_features`) are resampled at a fixed ``rate`` (50 Hz), so that templates
  recorded at one sample rate match performances at another: ``acc`` in g as it is (gravity's direction
  tells the hand's attitude, which tells real gestures apart), or its change since the gesture began
  when ``relative`` says so; ``mag`` as a unit vector; ``q`` as the rotation since the gesture began (a
  rotation vector, radians: where the performer faces does not matter); each channel group then divided
  by its spread over the examples (:attr:`GestureModel.scales`), so that no unit outweighs another
  (``scale``: or all in their units by one spread, :func:`group_scales`).
* Distances are dynamic time warping's (:mod:`pointat.maths.dtw`), all features warped together (DTW_D)
  or each on its own (DTW_I), whichever names more of the model's examples left out one at a time;
  nearest template wins (1-NN DTW, the baseline the literature holds every newer method against).
* The *null class* (:meth:`GestureModel.decide`): a movement farther from its nearest class than
  ``reject`` times the class's reach (its examples' distance from keeping still) or the examples' spread
  (their leave-one-out distances, pooled over the classes), or, for a class itself nearly still, farther
  from keeping still than its examples by far, or no nearer to it than
  three times its own distance from keeping still, or three times faster, slower, stronger or weaker than
  the class's examples, or whose nearest template is labelled ``null`` (movements the performer showed
  as "no gesture"), is no gesture.  Every default was chosen on real recordings and reported on others
  (``benchmarks/gesture_real.py``).

Examples
--------
>>> import numpy as np
>>> rng = np.random.default_rng(1)
>>> t = np.arange(60) / 50.0
>>> def wave(f):                        # a gyro trace (rad/s): one turn about z, f wiggles
...     return np.column_stack([0.3 * np.sin(f * np.pi * t), 0 * t, 4 * np.sin(np.pi * t / t[-1])])
>>> examples = [Example(label, t, wave(f) + rng.normal(0, 0.05, (60, 3)))
...             for label, f in (("one", 2), ("one", 2), ("two", 6), ("two", 6))]
>>> model = GestureModel(("gyr",)).train(examples)
>>> model.classify(t, wave(6)).label, model.classify(t, wave(2)).label
('two', 'one')
>>> model.classify(t, 0.1 * wave(2)).label is None                  # a tenth of the turn: no gesture
True
"""

from pointat.maths.gestures.events import Adapted, Decided, Dropped, Ended, Event, Recorded, Started
from pointat.maths.gestures.features import (
    CHANNELS,
    GRAVITY,
    NULL,
    RELATIVE,
    SCALES,
    WARPS,
    Example,
    channel_slices,
    group_scales,
    relative_channels,
    resample,
    segment_features,
    transform,
)
from pointat.maths.gestures.follower import Follower
from pointat.maths.gestures.model import REJECT, Decision, GestureModel
from pointat.maths.gestures.postures import PostureModel, posture_features
from pointat.maths.gestures.recognizer import CUTS, Recognizer
from pointat.maths.gestures.segmentation import DEFAULT_ON, Energy, Segmenter
from pointat.maths.gestures.spotter import Spotter
from pointat.maths.gestures.strokes import Stroke, StrokeDetector

__all__ = [
    "CHANNELS",
    "CUTS",
    "DEFAULT_ON",
    "GRAVITY",
    "NULL",
    "REJECT",
    "RELATIVE",
    "SCALES",
    "WARPS",
    "Adapted",
    "Decided",
    "Decision",
    "Dropped",
    "Ended",
    "Energy",
    "Event",
    "Example",
    "Follower",
    "GestureModel",
    "PostureModel",
    "Recognizer",
    "Recorded",
    "Segmenter",
    "Spotter",
    "Started",
    "Stroke",
    "StrokeDetector",
    "channel_slices",
    "group_scales",
    "posture_features",
    "relative_channels",
    "resample",
    "segment_features",
    "transform",
]
