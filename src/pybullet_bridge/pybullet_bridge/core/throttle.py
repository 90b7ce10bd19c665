"""A rate limit in simulated time for derived streams (the camera's compressed images)."""
from __future__ import annotations

#: Rates are in simulated time and frames land on float sums of the control period.
EPSILON = 1e-9


class RateThrottle:
    """Lets events through at `rate` per second on average; rate 0 lets every event through.

    The next slot is one period after the previous *slot*, not after the event, so a
    2 Hz throttle on a 5 Hz camera passes frames 0.6 s and 0.4 s apart (2 per second),
    not every 0.6 s. After a gap (no subscriber for a while) it re-anchors at the next
    event instead of bursting to catch up.
    """

    def __init__(self, rate: float):
        self.rate = rate
        self._next: float | None = None
        self._last: float | None = None

    def set_rate(self, rate: float) -> None:
        """A new rate, counted from the last event let through (so a higher rate applies at once)."""
        self.rate = rate
        self._next = None if self._last is None or rate <= 0 else self._last + 1.0 / rate

    def reset(self) -> None:
        """Time restarts (scene reloaded): the next event passes."""
        self._next = self._last = None

    def due(self, time: float) -> bool:
        return self.rate <= 0 or self._next is None or time + EPSILON >= self._next

    def take(self, time: float) -> None:
        """Record that an event at `time` went through (call only when due)."""
        self._last = time
        if self.rate <= 0:
            self._next = None
            return
        period = 1.0 / self.rate
        following = (self._next if self._next is not None else time) + period
        self._next = following if following > time + EPSILON else time + period
