"""The leader_planner node's behaviour as a pure class: the rounds of one task on real (or simulated) arms.

Phases and the events that move between them (the node turns camera frames, action results,
follower reports and its timers into these calls):

* ``OBSERVING`` -- :meth:`LeaderRounds.table_seen` with the state estimated from a settled frame
  (one the node's :class:`~.perception_check.PerceptionCheck` accepted):
  the :class:`~.leader_round.LeaderRound` ends the task (goal, stuck, round limit; effect
  ``finish``, phase ``DONE``) or decides her move: an empty move is announced at once
  (``announce``, phase ``AWAITING_FOLLOWER``), a real one goes to her arm (``execute``,
  phase ``EXECUTING``). :meth:`perception_fault`: no usable frame for too long; the task ends
  (``finish``, ``DONE``).
* ``EXECUTING`` -- :meth:`move_done` with the arm's outcome: ``announce``, then ``AWAITING_FOLLOWER``.
* ``AWAITING_FOLLOWER`` -- :meth:`follower_reported` for this round (late or duplicate reports are
  ignored) or :meth:`follower_timed_out`: the round is over, back to ``OBSERVING``.

Effects go through a :class:`LeaderPort` (the node publishes, calls the arm's action, stops).
"""
from __future__ import annotations

from enum import Enum
from typing import Protocol

import numpy as np

from .leader_round import Ending, LeaderRound, LeaderTurn, TaskEnd
from .rearrangement import EMPTY
from .stuck_rule import MoveOutcome

#: The follower behaviour whose moves are random draws (FollowerReport.behaviour).
RANDOM_BEHAVIOUR = 'random'


class LeaderPhase(Enum):
    OBSERVING = 'observing'                   # waiting for a settled frame to start the next round
    EXECUTING = 'executing'                   # her move is with the arm
    AWAITING_FOLLOWER = 'awaiting_follower'   # guidance published; the follower has the round
    DONE = 'done'


class LeaderPort(Protocol):
    """What the leader asks of her node."""

    def execute(self, turn: LeaderTurn) -> None:
        """Send her (non-empty) move to the arm; the node answers with :meth:`LeaderRounds.move_done`."""

    def announce(self, turn: LeaderTurn, succeeded: bool) -> None:
        """Publish the round's guidance: her move and its outcome, the recommended follower move."""

    def finish(self, end: TaskEnd) -> None:
        """Publish the end of the task and stop."""


class LeaderRounds:
    """See the module docstring."""

    def __init__(self, leader: LeaderRound, port: LeaderPort):
        self.leader = leader
        self.port = port
        self.phase = LeaderPhase.OBSERVING
        self.end: TaskEnd | None = None
        self.leader_succeeded = True     # her move's outcome in the round in progress

    @property
    def turn(self) -> LeaderTurn | None:
        """The round in progress."""
        return self.leader.turn

    def table_seen(self, state: np.ndarray) -> LeaderTurn | TaskEnd | None:
        """The state at the start of the next round (ignored unless observing)."""
        if self.phase is not LeaderPhase.OBSERVING:
            return None
        decision = self.leader.observe(state)
        if isinstance(decision, TaskEnd):
            self.phase, self.end = LeaderPhase.DONE, decision
            self.port.finish(decision)
        elif decision.action == EMPTY:
            self._announce(succeeded=True)
        else:
            self.phase = LeaderPhase.EXECUTING
            self.port.execute(decision)
        return decision

    def perception_fault(self, reason: str, last_state: np.ndarray) -> TaskEnd | None:
        """The camera gave no evidence of the table for too long (.perception_check): the task ends
        unfinished (ignored unless observing); ``last_state``: the last state seen, for the record."""
        if self.phase is not LeaderPhase.OBSERVING:
            return None
        end = TaskEnd(Ending.PERCEPTION_FAULT, self.leader.rounds, np.asarray(last_state),
                      f'{Ending.PERCEPTION_FAULT.value}: {reason}')
        self.phase, self.end = LeaderPhase.DONE, end
        self.port.finish(end)
        return end

    def move_done(self, succeeded: bool) -> None:
        """Her arm finished (or refused) the move."""
        if self.phase is LeaderPhase.EXECUTING:
            self._announce(succeeded)

    def follower_reported(self, round_number: int, moved: bool, succeeded: bool, behaviour: str) -> bool:
        """The follower's report; False when it is not for the round awaited (late or duplicate)."""
        if self.phase is not LeaderPhase.AWAITING_FOLLOWER or round_number != self.turn.round:
            return False
        self._round_over(MoveOutcome(attempted=moved, took_effect=succeeded), behaviour == RANDOM_BEHAVIOUR)
        return True

    def follower_timed_out(self) -> None:
        """No report within the follower timeout: the round is over, what he did is unknown."""
        if self.phase is LeaderPhase.AWAITING_FOLLOWER:
            self._round_over(None, False)

    def _announce(self, succeeded: bool) -> None:
        self.phase = LeaderPhase.AWAITING_FOLLOWER
        self.leader_succeeded = succeeded
        self.port.announce(self.turn, succeeded)

    def _round_over(self, follower: MoveOutcome | None, by_chance: bool) -> None:
        self.leader.round_over(self.leader_succeeded, follower, by_chance)
        self.phase = LeaderPhase.OBSERVING
