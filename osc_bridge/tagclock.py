"""A sender's OSC bundle time tags mapped onto pointat's clock (``osc_in timetags=true``)."""

from __future__ import annotations


class TagClock:
    """One sender's bundle time tags (its own clock) mapped onto our ``time.monotonic()``.

    A tag plus the least *lag* seen (arrival - tag: the clocks' offset and the quickest delivery) is
    when the sample was taken, as near as we can tell, and never later than it arrived: samples that
    Wi-Fi delivers in a burst keep the spacing the sender gave them.  The least lag may creep up by
    :attr:`CREEP` (a sender's clock slower than ours by up to 100 ppm), and starts over when every lag
    for :attr:`JUMP` seconds has been more than :attr:`JUMP` above it (the sender's clock was set back).

    >>> c = TagClock()
    >>> [round(c.stamp(tag, arrival), 3) for tag, arrival in [(10.00, 5.003), (10.01, 5.030), (10.02, 5.030)]]
    [5.003, 5.013, 5.023]
    """

    CREEP = 1e-4
    JUMP = 1.0

    def __init__(self) -> None:
        self.lag: float | None = None
        self._at = 0.0
        self._over: tuple[float, float] | None = None  # since when, and the least lag since, lags above

    def stamp(self, tag: float, arrival: float) -> float:
        """When a packet time-tagged ``tag`` (seconds) that arrived at ``arrival`` (monotonic) was sent."""
        lag = arrival - tag
        if self.lag is None or lag <= self.lag:
            self.lag, self._over = lag, None
        else:
            self.lag = min(lag, self.lag + self.CREEP * max(0.0, arrival - self._at))
            if lag - self.lag <= self.JUMP:
                self._over = None
            elif self._over is None:
                self._over = (arrival, lag)
            elif arrival - self._over[0] < self.JUMP:
                self._over = (self._over[0], min(self._over[1], lag))
            else:  # late by more than a second for a second: the sender's clock was set back
                self.lag, self._over = min(self._over[1], lag), None
        self._at = arrival
        return tag + self.lag
