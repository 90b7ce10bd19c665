"""The arm's task state machine: one pick-and-place task advanced through its motion segments.

Pure Python: segments move the arm themselves (:mod:`.segments`); this class decides, once per
physics step, when a segment is done and the next begins, when one has overrun its planned
duration by more than ``phase_timeout`` (a :class:`MotionFailure`), what a cancel or a failure
changes, how far the task has progressed, and how it ends (:mod:`.outcome`).

Modes::

    running --cancel (object not yet released)--> canceled: rise, put a held object back, go home
    running --motion failure--> recovering: drop a held object, rise, go home
    canceled --motion failure--> recovering (the message keeps both)
    recovering --motion failure--> done at once (the arm stops where it is)
    any mode, no segment left --> done: the outcome is judged from where the object rests

Cancel is refused once the object is released (only the retreat is left) and while recovering.
"""
from __future__ import annotations

from enum import Enum
from typing import Any, Protocol

from .outcome import Ending, task_outcome
from .task import Outcome, PickPlaceTask


class MotionFailure(Exception):
    """A segment did not converge in time, or the tool missed the grasp pose."""


class Step(Protocol):
    """One segment of the motion plan (:class:`.segments.Segment`)."""

    phase: str
    step: str
    estimate: float
    duration: float
    start_time: float

    def begin(self, arm: Any, sim_time: float) -> None: ...

    def command(self, arm: Any, sim_time: float) -> None: ...

    def converged(self, arm: Any) -> bool: ...

    def error_text(self, arm: Any) -> str: ...

    def end(self, arm: Any) -> None: ...


class RunPort(Protocol):
    """What the state machine asks of the simulated arm."""

    def holding(self) -> bool: ...

    def recovery_plan(self, put_back: bool) -> list[Step]: ...

    def drop_plan(self) -> Step: ...

    def object_pose(self) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]: ...


class Mode(Enum):
    RUNNING = 'running'
    CANCELED = 'canceled'
    RECOVERING = 'recovering'
    DONE = 'done'


class PickPlaceRun:
    """The progress of one started task; ``arm`` moves (segments) and answers the port's questions."""

    def __init__(self, task: PickPlaceTask, segments: list[Step], arm: RunPort, *, phase_timeout: float,
                 failure_probability: float, support_height: float, object_edge: float):
        self.task = task
        self.arm = arm
        self.phase_timeout = phase_timeout
        self.failure_probability = failure_probability
        self.support_height = support_height
        self.object_edge = object_edge
        self.segments = list(segments)
        self.segment: Step | None = None
        self.total_estimate = sum(segment.estimate for segment in self.segments)
        self.finished_estimate = 0.0
        self.canceled = False
        self.cancel_reason = ''
        self.put_back = False
        self.released = False
        self.failure = ''
        self.recovering = False

    @property
    def mode(self) -> Mode:
        if self.task.done:
            return Mode.DONE
        if self.recovering:
            return Mode.RECOVERING
        return Mode.CANCELED if self.canceled else Mode.RUNNING

    # -- events -------------------------------------------------------------------------

    def step(self, sim_time: float) -> None:
        """Advance at the start of a physics step (command the current segment)."""
        if self.task.done:
            return
        try:
            self._advance(sim_time)
        except MotionFailure as failure:
            self._fail(str(failure), sim_time)

    def cancel(self, reason: str) -> bool:
        """Put a held object back and go home; False (nothing changes) when that is no longer possible."""
        if self.task.done or self.released or self.canceled or self.recovering:
            return False
        self.canceled = True
        self.cancel_reason = reason
        self.put_back = self.arm.holding()
        self.segments = self._recovery(put_back=self.put_back)
        self.segment = None
        return True

    def abort(self, reason: str) -> None:
        """End at once with ABORTED, without moving (the scene is going away)."""
        if not self.task.done:
            self.task.finish(Outcome.ABORTED, reason)
        self.segments = []
        self.segment = None

    def object_released(self) -> None:
        """The gripper let the object go (a release after a cancel does not count as placing)."""
        self.released = not self.canceled

    # -- transitions --------------------------------------------------------------------

    def _advance(self, sim_time: float) -> None:
        task = self.task
        segment = self.segment
        if segment is not None:
            elapsed = sim_time - segment.start_time
            if elapsed >= segment.duration:
                if segment.converged(self.arm):
                    self.finished_estimate += segment.estimate
                    self.segment = None
                    segment.end(self.arm)
                elif elapsed > segment.duration + self.phase_timeout:
                    raise MotionFailure(f"phase '{segment.phase}' ({segment.step}) did not finish within "
                                        f'{segment.duration + self.phase_timeout:.1f} s of '
                                        f'simulated time: {segment.error_text(self.arm)}')
        if self.segment is None:
            if not self.segments:
                self._complete(sim_time)
                return
            self.segment = self.segments.pop(0)
            self.segment.begin(self.arm, sim_time)
            task.phase = self.segment.phase
        segment = self.segment
        segment.command(self.arm, sim_time)
        within = min(sim_time - segment.start_time, segment.duration) / segment.duration * segment.estimate
        task.progress = max(task.progress, min(1.0, (self.finished_estimate + within) / self.total_estimate))

    def _recovery(self, put_back: bool) -> list[Step]:
        segments = self.arm.recovery_plan(put_back)
        # Progress keeps going up: the remaining estimate is rescaled to what is left.
        self.total_estimate = self.finished_estimate + sum(s.estimate for s in segments)
        return segments

    def _fail(self, message: str, sim_time: float) -> None:
        if self.recovering:
            # The recovery itself is stuck: stop here rather than loop.
            self.segments = []
            self.segment = None
            self.failure = f'{self.failure}; then {message}; the arm stopped where it is'
            self._complete(sim_time)
            return
        self.failure = message
        self.recovering = True
        held = self.arm.holding()
        self.segments = self._recovery(put_back=False)
        if held:
            # Setting a held object down safely needs the very motion that failed: drop it here.
            self.segments.insert(0, self.arm.drop_plan())
        self.segment = None

    def _complete(self, sim_time: float) -> None:
        task = self.task
        position, orientation = self.arm.object_pose()
        task.placed_position = tuple(float(v) for v in position)
        ending = Ending(canceled=self.canceled, cancel_reason=self.cancel_reason, put_back=self.put_back,
                        failure=self.failure)
        task.finish(*task_outcome(task, ending, orientation, self.failure_probability, self.support_height,
                                  self.object_edge), sim_time)
        self.segments = []
        self.segment = None
