"""The follower_executor node's behaviour as a pure class: one response per round of guidance.

Phases and events (the node turns Guidance messages, settled camera frames and action results
into these calls):

* ``WAITING`` -- :meth:`FollowerRounds.guidance_heard` with a new round (a round already handled
  is ignored): phase ``SETTLING``. :meth:`task_ended` (the leader's final guidance): ``DONE``.
* ``SETTLING`` -- the node waits until the table has settled after the guidance, then calls
  :meth:`table_seen` with the state it sees: he chooses by his behaviour
  (:class:`~.follower_behaviour.Follower`); an empty move is reported at once (``report``,
  back to ``WAITING``), a real one goes to his arm (``execute``, phase ``EXECUTING``).
* ``EXECUTING`` -- :meth:`move_done` with the arm's outcome: ``report``; the next round's guidance
  may have come meanwhile (then ``SETTLING`` again, else ``WAITING``).

He hears only the leader (one-way communication) and reports every round he handled, to the
leader session it came from. Which guidance is the leader's, and when her session changed (she
restarted: :meth:`session_changed`, the round ordering restarts), is sgcm.core.sessions.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from enum import Enum
from typing import Any, Protocol

import numpy as np

from .follower_behaviour import Follower, FollowerChoice
from .rearrangement import EMPTY


class FollowerPhase(Enum):
    WAITING = 'waiting'        # for the leader's next round
    SETTLING = 'settling'      # a round's guidance came: waiting for the table to settle
    EXECUTING = 'executing'    # his move is with the arm
    DONE = 'done'              # the leader ended the task


@dataclass(frozen=True)
class HeardGuidance:
    """One round's guidance as the follower uses it."""

    round: int
    stamp: Any                  # when it was published (the node's time type): settling counts from it
    round_state: np.ndarray     # the state at the round's start, as the leader estimated it
    leader_action: int
    recommended: int
    session: int = 0            # the leader session it came from (sgcm.core.sessions); the report goes back to it


class FollowerPort(Protocol):
    """What the follower asks of his node."""

    def execute(self, round_number: int, choice: FollowerChoice) -> None:
        """Send his (non-empty) move to the arm; the node answers with :meth:`FollowerRounds.move_done`."""

    def report(self, round_number: int, choice: FollowerChoice, succeeded: bool, message: str,
               leader_session: int = 0) -> None:
        """Tell the leader (her session ``leader_session``) the round is over and what he did."""


class FollowerRounds:
    """See the module docstring."""

    def __init__(self, follower: Follower, port: FollowerPort):
        self.follower = follower
        self.port = port
        self.phase = FollowerPhase.WAITING
        self.last_round = 0
        self.pending: HeardGuidance | None = None       # guidance of a round not yet handled
        self._executing: tuple[HeardGuidance, FollowerChoice] | None = None

    def guidance_heard(self, guidance: HeardGuidance) -> bool:
        """A round's guidance; False when that round was already heard (a duplicate or a late copy)."""
        if self.phase is FollowerPhase.DONE or guidance.round <= self.last_round:
            return False
        self.last_round = guidance.round
        self.pending = guidance
        if self.phase is FollowerPhase.WAITING:
            self.phase = FollowerPhase.SETTLING
        return True

    def session_changed(self) -> None:
        """The leader's session changed (she restarted): rounds count from 0 again, and a round of the old
        session not yet started is dropped (a move in progress finishes and is reported to the old one)."""
        self.last_round = 0
        self.pending = None
        if self.phase is FollowerPhase.SETTLING:
            self.phase = FollowerPhase.WAITING

    def clock_went_back(self, now: Any) -> None:
        """The node's clock went back (a restarted simulation): a round waiting for the table settles from
        ``now``, not from a stamp the new clock would reach only later."""
        if self.pending is not None and self.pending.stamp > now:
            self.pending = replace(self.pending, stamp=now)

    def task_ended(self) -> None:
        self.phase = FollowerPhase.DONE

    def table_seen(self, seen: np.ndarray) -> FollowerChoice | None:
        """The settled table after the leader's move (ignored unless settling): his move."""
        if self.phase is not FollowerPhase.SETTLING:
            return None
        guidance, self.pending = self.pending, None
        choice = self.follower.choose(guidance.round, seen, guidance.round_state, guidance.leader_action,
                                      guidance.recommended)
        if choice.action == EMPTY:
            self._next()
            self.port.report(guidance.round, choice, True, 'no move', guidance.session)
        else:
            self.phase = FollowerPhase.EXECUTING
            self._executing = (guidance, choice)
            self.port.execute(guidance.round, choice)
        return choice

    def move_done(self, succeeded: bool, message: str) -> None:
        """His arm finished (or refused, or could not be given) the move."""
        if self.phase is not FollowerPhase.EXECUTING:
            return
        (guidance, choice), self._executing = self._executing, None
        self._next()
        self.port.report(guidance.round, choice, succeeded, message, guidance.session)

    def _next(self) -> None:
        self.phase = FollowerPhase.SETTLING if self.pending is not None else FollowerPhase.WAITING
