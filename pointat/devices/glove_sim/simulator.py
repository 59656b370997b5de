"""The simulated glove's samples: script, bursts and sensor model sampled at a fixed rate into mote frames.

:class:`GloveSimulator` gives :class:`~pointat.devices.mote_frame.Frame` values with a running
``n_pack``, deterministically for a seed and in any order (random access by sample index).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import NamedTuple

import numpy as np

from pointat.devices.mote_frame import Frame

from .bursts import Burst, burst_acceleration
from .motion import MotionScript, default_script
from .sensor import SensorModel


class Sample(NamedTuple):
    """One simulated sample: time (s), the mote frame, the true orientation (sensor -> NWU)."""

    t: float
    frame: Frame
    q: np.ndarray


class Truth(NamedTuple):
    r"""Noiseless, unclipped ground truth of a sample.

    ``omega`` (rad/s), ``specific_force`` (m/s², :math:`R(q)^T ((0, 0, g) + a)`) and ``field`` (gauss)
    in the sensor frame; ``linear_acceleration`` :math:`a` (m/s²) of the hand in the earth frame
    (NWU), zero outside bursts (:class:`Burst`).
    """

    t: float
    q: np.ndarray
    omega: np.ndarray
    specific_force: np.ndarray
    field: np.ndarray
    linear_acceleration: np.ndarray


class GloveSimulator:
    """A glove sampled at a fixed rate: frames with ground truth, deterministic for a seed.

    ``sample(k)`` depends only on ``k`` and the seed (each sample draws its noise from its own
    generator), so samples can be produced in any order, again and again.

    Parameters
    ----------
    script : MotionScript, optional
        The motion (default :func:`default_script`).
    rate_hz : float
        Sample rate, Hz.
    mote_id : int
        Mote id in the frames, 0..255.
    seed : int
        Seeds the noise and, for the default sensor model, the gyro bias.
    sensor : SensorModel, optional
        Default ``SensorModel(seed=seed)``.
    n_pack_start : int
        Counter of sample 0 (the counter wraps at 65536).
    bursts : sequence of Burst
        Strokes and shakes of the hand: their linear acceleration (:func:`burst_acceleration`, with the
        true orientation) adds to the specific force the accelerometer reads; the orientation is
        unchanged.  Empty by default: the accelerometer sees gravity only.
    """

    def __init__(
        self,
        script: MotionScript | None = None,
        rate_hz: float = 100.0,
        mote_id: int = 1,
        seed: int = 0,
        sensor: SensorModel | None = None,
        *,
        n_pack_start: int = 0,
        bursts: Sequence[Burst] = (),
    ) -> None:
        if not rate_hz > 0:
            raise ValueError(f"rate_hz must be > 0, got {rate_hz}")
        if not 0 <= mote_id <= 255:
            raise ValueError(f"mote_id must be 0..255, got {mote_id}")
        self.script = script if script is not None else default_script()
        self.rate_hz = float(rate_hz)
        self.mote_id = int(mote_id)
        self.seed = int(seed)
        self.sensor = sensor if sensor is not None else SensorModel(seed=seed)
        self.n_pack_start = int(n_pack_start)
        self.bursts: tuple[Burst, ...] = tuple(bursts)
        bad = [b for b in self.bursts if not isinstance(b, Burst)]
        if bad:
            raise ValueError(f"bursts must be Burst values, got {bad[0]!r}")

    @property
    def period(self) -> float:
        """Sample period, seconds."""
        return 1.0 / self.rate_hz

    def time(self, k: int) -> float:
        """Time of sample ``k``, seconds."""
        return k / self.rate_hz

    def linear_acceleration(self, t: float, q: np.ndarray) -> np.ndarray | None:
        """The bursts' earth-frame acceleration at ``t`` (m/s²), or None without bursts."""
        return burst_acceleration(self.bursts, t, q) if self.bursts else None

    def truth(self, k: int) -> Truth:
        """Noiseless ground truth of sample ``k``."""
        t = self.time(k)
        q = self.script.orientation(t)
        omega = self.script.angular_rate(t)
        a = self.linear_acceleration(t, q)
        v = self.sensor.true_values(q, omega, a)
        return Truth(t, q, omega, v[3:6], v[6:9], np.zeros(3) if a is None else a)

    def sample(self, k: int) -> Sample:
        """Sample ``k``: ``(t, frame, q_true)``."""
        if k < 0:
            raise ValueError(f"sample index must be >= 0, got {k}")
        t = self.time(k)
        q = self.script.orientation(t)
        rng = np.random.default_rng([self.seed, 1, k])
        a = self.linear_acceleration(t, q)
        counts = self.sensor.counts(q, self.script.angular_rate(t), rng, accel_earth=a)
        return Sample(t, Frame(self.mote_id, (self.n_pack_start + k) & 0xFFFF, counts), q)

    def samples(self, n: int, start: int = 0) -> list[Sample]:
        """Samples ``start .. start + n - 1``."""
        return [self.sample(k) for k in range(start, start + n)]

    def __iter__(self) -> Iterator[Sample]:
        """Samples 0, 1, 2, ... without end (the default script loops)."""
        k = 0
        while True:
            yield self.sample(k)
            k += 1
