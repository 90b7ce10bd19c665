"""Deferred work of several agents run in bounded steps, one short burst per executor cycle.

Why: rclpy's single-threaded executor runs, per cycle, every callback that was ready when it
last waited -- of every node it spins. Ten hosted schema agents each re-evaluating in their own
callback (even in slices) made one cycle last hundreds of milliseconds during a search, and a
batch arriving in an inbox (a COMMIT_REQUEST, the ACKs a sender's retransmission waits for) was
read only in the next cycle. Here the agents' deferred work -- reasoning slices, channel
messages waiting for the agent -- goes through ONE queue whose runner (one guard condition)
works for at most ``budget_s`` per cycle, round robin over the steps; the inboxes, timers and
sensor reports of all agents run in every cycle in between.

A *step* is a callable returning whether it has more work (it is then queued again, at the
back). Requesting a step that is already queued does nothing, so "something changed" events can
request freely. The runner never raises: a failing step is reported to ``on_error`` and dropped.

Steps requested ``first`` (handing the agents the messages their inboxes hold) run before the
others (reasoning): an agent then evaluates once with every offer that has arrived, not once per
slice of them. Under load this is what keeps the work per message flat: in a 20-robot column a
host that alternated the two re-instantiated the same potential solutions with a few new offers
at a time, and the slower it got the more it evaluated (found 4 s or 7-8 s, with 2.7 or 4.6-5.4 s
of CPU per host, from run to run). Delivery is cheap and bounded by what arrived, so reasoning
waits at most for the inbox to be drained.
"""
from __future__ import annotations

import time
from typing import Callable

Step = Callable[[], bool]


class CooperativeWork:
    """A round-robin queue of steps run by :meth:`run` for at most ``budget_s`` (wall) per call;
    ``wake`` asks the transport to call :meth:`run` soon (e.g. a guard condition's trigger)."""

    def __init__(self, wake: Callable[[], None], budget_s: float = 0.01,
                 on_error: Callable[[Step, Exception], None] | None = None):
        if not budget_s > 0:
            raise ValueError(f'budget_s: must be > 0 (got {budget_s!r})')
        self.wake = wake
        self.budget_s = budget_s
        self.on_error = on_error
        self._queue: dict[Step, None] = {}
        self._first: dict[Step, None] = {}
        self._woken = False
        self.steps_run = 0

    def request(self, step: Step, first: bool = False) -> None:
        """Run ``step`` in a coming :meth:`run` (once, however often it is requested before);
        ``first``: before every step not requested first (module docstring)."""
        (self._first if first else self._queue).setdefault(step)
        if not self._woken:
            self._woken = True
            self.wake()

    def pending(self) -> int:
        return len(self._first) + len(self._queue)

    def run(self) -> None:
        """Run queued steps, oldest first, until the budget is used; wake again if any is left."""
        self._woken = False
        end = time.perf_counter() + self.budget_s
        while self._first or self._queue:
            queue = self._first if self._first else self._queue
            step = next(iter(queue))
            del queue[step]
            self.steps_run += 1
            try:
                again = step()
            except Exception as exc:  # noqa: BLE001 - one agent's failure must not stop the others
                again = False
                if self.on_error is not None:
                    self.on_error(step, exc)
            if again:
                queue.setdefault(step)
            if time.perf_counter() >= end:
                break
        if (self._first or self._queue) and not self._woken:
            self._woken = True
            self.wake()


__all__ = ['CooperativeWork', 'Step']
