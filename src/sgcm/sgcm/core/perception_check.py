"""Perception judges its own evidence before a state is used (issue 16 item 3; ours, the paper assumes
a working camera).

An arm's state estimate (:mod:`.perception`) counts the cubes it sees per cell. A frame that shows
no cube (the camera looks elsewhere, an empty 0x0 image, a label image of unknown labels) counts
nothing, and an all-zero state equals its own goal state (:meth:`RearrangementModel.goal_state`
puts every object of the state home): the leader reported "goal reached after 0 rounds". Cubes
are never created or destroyed by the task, so a usable estimate sees every cube the camera's
label legend names, each inside the grid:

* :func:`evidence_problem` -- why an estimate is not evidence of the table's state (None: it is);
* :class:`PerceptionCheck` -- what the node does about it: a rejected estimate is never read (the
  arm keeps its last good state and looks again :data:`RETRY_AFTER` s later); rejections in a row
  for ``fault_after`` s (the nodes' ``perception_fault_after`` parameter) are a perception fault
  that the leader reports by ending the task (:class:`~.leader_round.Ending` ``PERCEPTION_FAULT``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .perception import StateEstimate

#: s (the frames' clock) between two looks while the camera's evidence is rejected.
RETRY_AFTER = 0.5
#: s of rejected frames in a row before a perception fault (the nodes' perception_fault_after default).
FAULT_AFTER = 10.0


def evidence_problem(estimate: StateEstimate, expected_objects: int) -> str | None:
    """Why ``estimate`` cannot be the table's state, or None. ``expected_objects``: the cubes the camera's
    legend names (the task's objects)."""
    if expected_objects < 1:
        return "the camera's label legend names no cube: no object of the task can be seen"
    counts = np.asarray(estimate.counts)
    if counts.size == 0 or not np.isfinite(counts).all() or (counts < 0).any():
        return f'the estimate has no valid counts (shape {counts.shape})'
    in_grid = int(counts.sum())
    if in_grid == expected_objects:
        return None
    off_grid = [o.name for o in estimate.off_grid]
    seen = len(estimate.objects)
    text = f'{in_grid} of the {expected_objects} cubes seen in the grid'
    if off_grid:
        text += f" ({len(off_grid)} outside it: {', '.join(off_grid[:5])}{', ...' if len(off_grid) > 5 else ''})"
    elif seen < expected_objects:
        text += f' ({expected_objects - seen} not visible)'
    return text


@dataclass(frozen=True)
class Verdict:
    """The judgement of one estimate: ``accepted`` (use it), else why not; ``fault``: rejected for too long."""

    accepted: bool
    reason: str = ''
    fault: bool = False
    retry_at: float | None = None       # when to look again (the frames' clock), for a rejected one
    rejected_for: float = 0.0           # s of rejected frames in a row


class PerceptionCheck:
    """Rejects estimates that are no evidence; reports a fault after ``fault_after`` s of rejections."""

    def __init__(self, fault_after: float = FAULT_AFTER, retry_after: float = RETRY_AFTER):
        if not fault_after > 0:
            raise ValueError(f'perception_fault_after: must be > 0 (got {fault_after})')
        self.fault_after = float(fault_after)
        self.retry_after = float(retry_after)
        self.last_good: StateEstimate | None = None
        self.rejected = 0                     # estimates rejected since the start
        self._since: float | None = None      # stamp of the first rejected frame of the current run

    def judge(self, estimate: StateEstimate, expected_objects: int, stamp: float) -> Verdict:
        """``stamp``: the frame's time in seconds (the frames' clock)."""
        problem = evidence_problem(estimate, expected_objects)
        if problem is None:
            self.last_good, self._since = estimate, None
            return Verdict(True)
        self.rejected += 1
        if self._since is None or stamp < self._since:     # a new run of rejections (or a clock reset)
            self._since = stamp
        rejected_for = stamp - self._since
        return Verdict(False, problem, fault=rejected_for >= self.fault_after,
                       retry_at=stamp + self.retry_after, rejected_for=rejected_for)
