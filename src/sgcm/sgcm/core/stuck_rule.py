"""When a rearrangement task is stuck: the one rule of the episode loop and the leader_planner node.

The leader decides at the start of every round (see :mod:`.leader_round`); a task that has not
reached its goal ends as *stuck* when the rounds are certain to repeat forever. They are when
the state the leader observes was already observed at the start of an earlier round and every
round since then was **certain**, i.e. nothing in it was left to chance:

* the leader's commitment was pure (she did not sample a mixed policy),
* the follower did not choose by chance (his behaviour is not ``random``),
* every move either robot attempted took effect, and moves cannot fail by chance
  (``moves_can_fail`` off: the abstract game without simulated failures, or a simulation whose
  arms have failure probability 0). A round in which neither arm moved is certain whatever
  ``moves_can_fail`` says: nothing was attempted that could fail.

Both robots decide from the observed state alone, so after certain rounds back to a state seen
before the same rounds come again: the greedy pair's chattering, or both arms idling. Two
special cases are the rules each side used before this module:

* an *idle* round (no arm moved) ends at the state it started from: stuck at once (the sim
  node's "both arms idle");
* without failures, deterministic players, a state seen before comes back: stuck (the abstract
  episode's rule).

A move that did not take effect (nothing to grasp, no room, or in simulation a grasp that
slipped) makes the round uncertain even when failures are off: tried again it may work.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class MoveOutcome:
    """What became of one robot's move in a round."""

    attempted: bool       # False: the empty action (the robot stood still)
    took_effect: bool     # the move happened (meaningless when not attempted)


@dataclass(frozen=True)
class RoundCertainty:
    """What the stuck rule needs to know about one finished round."""

    leader: MoveOutcome
    follower: MoveOutcome | None     # None: the follower's round is unknown (no report came)
    leader_sampled: bool = False     # the leader drew her move from a mixed policy
    follower_by_chance: bool = False  # the follower's choice was a random draw

    @property
    def idle(self) -> bool:
        return self.follower is not None and not self.leader.attempted and not self.follower.attempted

    def certain(self, moves_can_fail: bool) -> bool:
        if self.follower is None or self.leader_sampled or self.follower_by_chance:
            return False
        moves = [m for m in (self.leader, self.follower) if m.attempted]
        return not moves or (not moves_can_fail and all(m.took_effect for m in moves))


class StuckRule:
    """Remembers the round-start states since the last uncertain round; see the module docstring."""

    def __init__(self, moves_can_fail: bool):
        self.moves_can_fail = moves_can_fail
        self._seen: dict[bytes, int] = {}     # state -> the round that started from it
        self._last_idle_round: int | None = None

    def observe(self, state: np.ndarray, next_round: int) -> str | None:
        """Record the state seen before round ``next_round``; the reason it is stuck, or None."""
        key = np.asarray(state).tobytes()
        earlier = self._seen.get(key)
        if earlier is not None:
            if earlier == self._last_idle_round == next_round - 1:
                return f'stuck: both arms idle in round {earlier}'
            return (f'stuck: the state round {earlier} started from came back after round {next_round - 1}, '
                    'nothing left to chance')
        self._seen[key] = next_round
        return None

    def round_ended(self, number: int, certainty: RoundCertainty) -> None:
        """Account for round ``number``: an uncertain round forgets the states seen so far."""
        self._last_idle_round = number if certainty.idle else None
        if not certainty.certain(self.moves_can_fail):
            self._seen.clear()
