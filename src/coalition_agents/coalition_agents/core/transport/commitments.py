"""Request-and-wait commitments: the one coalition a robot holds, and a leader's negotiation (no ROS).

Commitments (the paper sets coalitions up
"using the same request-and-wait negotiation protocol as used in the distributed version of
ASyMTRe"; our rendering of it):
    * A robot holds at most one commitment: to the coalition it leads or to one coalition as a
      helper. A COMMIT_REQUEST for another coalition is rejected (with the reason) until that
      commitment is released or its hold time (``hold_seconds``, from the leader; 0 = until
      released) has passed without renewal. A new COMMIT_REQUEST for the coalition already
      held renews it.
    * The leader commits itself, sends COMMIT_REQUEST to every helper and waits. All accept:
      the coalition is *established*. One rejects or cannot be reached: the negotiation *failed*
      and the leader sends RELEASE to every helper (a helper whose ACCEPT was lost holds the
      commitment otherwise until it times out) and frees itself.
    * The leader's view of a helper's commitment ends ``hold_seconds`` after the leader *first*
      sent its request; the helper's starts when it first receives it, which is later -- so the
      leader never believes in a commitment the helper has already dropped. A duplicate
      COMMIT_REQUEST whose accepted commitment is no longer held is answered with a REJECT, and a
      COMMIT_REQUEST that arrives after the RELEASE of its coalition (links reorder messages) is
      rejected. Every negotiation therefore needs a new coalition id.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

from .retry import NEVER


@dataclass(frozen=True)
class Commitment:
    """``robot`` is part of coalition ``coalition_id`` led by ``leader`` until ``expires_at``."""

    coalition_id: str
    leader: str
    members: tuple[str, ...]
    since: float
    expires_at: float

    def conflicts_with(self, coalition_id: str, leader: str) -> bool:
        return (self.coalition_id, self.leader) != (coalition_id, leader)


class CommitmentLedger:
    """The one commitment a robot may hold; ``history`` records every change (time, event, id)."""

    def __init__(self, robot: str):
        self.robot = robot
        self._current: Commitment | None = None
        self.history: list[tuple[float, str, str]] = []

    def active(self, now: float) -> Commitment | None:
        """The commitment held at ``now`` (an expired one is dropped)."""
        current = self._current
        if current is not None and now >= current.expires_at:
            self.history.append((now, 'expired', current.coalition_id))
            self._current = None
        return self._current

    def hold(self, coalition_id: str, leader: str, members: Sequence[str], now: float,
             hold_seconds: float = 0.0) -> tuple[bool, str]:
        """Commit to ``coalition_id`` (or renew it): (True, '') or (False, why not)."""
        current = self.active(now)
        if current is not None and current.conflicts_with(coalition_id, leader):
            return False, f'{self.robot} is committed to coalition {current.coalition_id} of {current.leader}'
        expires_at = now + hold_seconds if hold_seconds > 0 else NEVER
        self._current = Commitment(coalition_id, leader, tuple(members),
                                   now if current is None else current.since, expires_at)
        self.history.append((now, 'renewed' if current is not None else 'committed', coalition_id))
        return True, ''

    def holds(self, coalition_id: str, leader: str, now: float) -> bool:
        current = self.active(now)
        return current is not None and not current.conflicts_with(coalition_id, leader)

    def release(self, coalition_id: str, leader: str, now: float) -> bool:
        """Drop the commitment to ``coalition_id`` of ``leader``; False if it was not held."""
        if not self.holds(coalition_id, leader, now):
            return False
        self._current = None
        self.history.append((now, 'released', coalition_id))
        return True


@dataclass
class Negotiation:
    """A leader's request-and-wait negotiation of one coalition (see the module docstring)."""

    coalition_id: str
    leader: str
    members: tuple[str, ...]
    cost: float
    hold_seconds: float
    started: float
    accepted: set[str] = field(default_factory=set)
    rejected: dict[str, str] = field(default_factory=dict)
    released: bool = False

    @property
    def helpers(self) -> tuple[str, ...]:
        return tuple(robot for robot in self.members if robot != self.leader)

    @property
    def expires_at(self) -> float:
        return self.started + self.hold_seconds if self.hold_seconds > 0 else NEVER

    def state(self, now: float) -> str:
        """'waiting', 'established', 'failed' (a helper rejected or was unreachable), 'expired'
        (the hold time passed before all accepted, or since) or 'released'."""
        if self.released:
            return 'released'
        if self.rejected:
            return 'failed'
        if now >= self.expires_at:
            return 'expired'
        return 'established' if self.accepted >= set(self.helpers) else 'waiting'


__all__ = ['Commitment', 'CommitmentLedger', 'Negotiation']
