"""Pacing the simulation loop: control ticks against the wall clock, rates in simulated time.

The bridge steps the physics in control ticks (``control_period`` of simulated time, a whole
number of physics steps). With a real-time factor > 0 a tick is due when simulated time lags
``real_time_factor`` x the wall time elapsed since an anchor; a machine that falls behind catches
up at most :data:`MAX_CATCH_UP_TICKS` at once, then re-anchors (it runs slower than asked rather
than spiralling). Factor 0 runs as fast as possible: ``batch_ticks`` ticks per timer call (one by
default; more spare the executor's round trip per tick, and the node handles its incoming commands
and requests between batches, so a batch is also their latency in simulated time).
"""
from __future__ import annotations

from .throttle import EPSILON

#: Ticks run at most this far behind wall-clock pacing before the bridge gives up catching up.
MAX_CATCH_UP_TICKS = 10


def steps_per_tick(control_period: float, physics_dt: float) -> int:
    """Physics steps per control tick: the control period rounded to whole steps, at least one."""
    return max(1, round(control_period / physics_dt))


class TickPacer:
    """How many control ticks are due now for a real-time factor."""

    def __init__(self, control_period: float, real_time_factor: float, batch_ticks: int = 1):
        self.control_period = control_period
        self.real_time_factor = real_time_factor
        self.batch_ticks = batch_ticks          # ticks per call at factor 0
        self._reference: tuple[float, float] | None = None   # (wall time, sim time) of the anchor

    @property
    def timer_period(self) -> float:
        """Wall seconds between timer calls: one tick's worth, or 0 (back to back) as fast as possible."""
        return self.control_period / self.real_time_factor if self.real_time_factor > 0 else 0.0

    def reanchor(self) -> None:
        """Forget the anchor (paused, reset, new factor): pacing restarts from the next call."""
        self._reference = None

    def ticks_due(self, wall_time: float, sim_time: float) -> int:
        if self.real_time_factor <= 0:
            return self.batch_ticks
        if self._reference is None:
            self._reference = (wall_time, sim_time)
        wall0, sim0 = self._reference
        behind = sim0 + (wall_time - wall0) * self.real_time_factor - sim_time
        ticks = int(behind / self.control_period)
        if ticks > MAX_CATCH_UP_TICKS:
            ticks = MAX_CATCH_UP_TICKS
            self._reference = None  # re-anchor instead of spiralling
        return max(ticks, 0)


class SimTimeSchedule:
    """Something due every ``1 / rate`` seconds of simulated time from time 0 (ground truth, /tf)."""

    def __init__(self, rate: float):
        self.rate = rate
        self.next_time = 0.0

    def restart(self) -> None:
        """Time restarts at 0 (scene loaded): due at once."""
        self.next_time = 0.0

    def take_if_due(self, sim_time: float) -> bool:
        if sim_time + EPSILON < self.next_time:
            return False
        self.next_time = sim_time + 1.0 / self.rate
        return True

    def set_rate(self, rate: float, sim_time: float) -> None:
        """A lower rate takes effect after the sample already scheduled; a higher one at once."""
        self.rate = rate
        self.next_time = min(self.next_time, sim_time + 1.0 / rate)


class RealTimeMeter:
    """Simulated seconds per wall second since the previous measurement."""

    def __init__(self, wall_time: float, sim_time: float):
        self._reference = (wall_time, sim_time)

    def restart(self, wall_time: float, sim_time: float) -> None:
        self._reference = (wall_time, sim_time)

    def measure(self, wall_time: float, sim_time: float) -> float:
        wall0, sim0 = self._reference
        elapsed = wall_time - wall0
        self._reference = (wall_time, sim_time)
        return (sim_time - sim0) / elapsed if elapsed > 0 else 0.0
