"""A pick-and-place task as the bridge adapter sees it: request, phase, progress, outcome."""
from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

#: Feedback phases, in the order a task goes through them (as in PickAndPlace.action).
PHASES = ('approach', 'grasp', 'lift', 'transport', 'place', 'release', 'retreat')


class Outcome(IntEnum):
    """How a task ended; the values are those of PickAndPlace.action's result constants."""

    PLACED = 0
    EXECUTION_FAILED = 1
    REJECTED = 2
    NO_FREE_SPOT = 3
    ABORTED = 4


@dataclass
class PickPlaceTask:
    """One pick-and-place request and its progress; read by the bridge adapter."""

    object_name: str
    region: tuple[float, ...]
    phase: str = 'approach'
    progress: float = 0.0
    outcome: Outcome | None = None
    message: str = ''
    #: Where the object rests when the task ends (world frame); None if it was never checked.
    placed_position: tuple[float, float, float] | None = None
    #: Centre (x, y) the pixel test chose for the object.
    target_position: tuple[float, float] | None = None
    #: The failure draw of this task: True = the grasp slips.
    slipped: bool = False
    started_at: float | None = None
    finished_at: float | None = None

    @property
    def done(self) -> bool:
        return self.outcome is not None

    def finish(self, outcome: Outcome, message: str, sim_time: float | None = None) -> PickPlaceTask:
        self.outcome = outcome
        self.message = message
        self.finished_at = sim_time
        if outcome in (Outcome.PLACED, Outcome.EXECUTION_FAILED):
            self.progress = 1.0
        return self
