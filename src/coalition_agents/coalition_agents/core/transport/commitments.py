"""Request-and-wait commitments: the one coalition a robot holds, and a leader's negotiation (no ROS).

Commitments (the paper sets coalitions up
"using the same request-and-wait negotiation protocol as used in the distributed version of
ASyMTRe"; our rendering of it):
    * A robot holds commitments to the coalition it leads and to coalitions it helps. Which
      ones it may hold together is its ``admission`` rule (the agent's: capability sharing,
      :func:`~..coalition_sharing.first_conflict`; it sees the held commitments and the new one
      and returns why not, '' = admitted). Without a rule a robot holds one commitment at a time.
      A COMMIT_REQUEST the rule refuses is rejected with the rule's reason; a commitment ends
      when it is released or its hold time (``hold_seconds``, from the leader; 0 = until
      released) has passed without renewal. A new COMMIT_REQUEST for a coalition already
      held renews it (no admission: it was admitted).
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
from typing import Callable, Sequence

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


#: (held commitments, coalition id, leader, members) -> why the robot cannot also commit to it ('' = it can)
Admission = Callable[[tuple[Commitment, ...], str, str, tuple[str, ...]], str]


class CommitmentLedger:
    """The commitments a robot holds (in the order they were taken); ``history`` records every
    change (time, event, id); ``admission`` decides which may be held together (module docstring)."""

    def __init__(self, robot: str, admission: Admission | None = None):
        self.robot = robot
        self.admission = admission
        self._held: dict[tuple[str, str], Commitment] = {}
        self.history: list[tuple[float, str, str]] = []

    def held(self, now: float) -> tuple[Commitment, ...]:
        """Every commitment held at ``now`` (expired ones are dropped)."""
        for key, commitment in list(self._held.items()):
            if now >= commitment.expires_at:
                self.history.append((now, 'expired', commitment.coalition_id))
                del self._held[key]
        return tuple(self._held.values())

    def active(self, now: float) -> Commitment | None:
        """The first commitment held at ``now`` (None: none)."""
        held = self.held(now)
        return held[0] if held else None

    def hold(self, coalition_id: str, leader: str, members: Sequence[str], now: float,
             hold_seconds: float = 0.0) -> tuple[bool, str]:
        """Commit to ``coalition_id`` (or renew it): (True, '') or (False, why not)."""
        held = self.held(now)
        current = self._held.get((coalition_id, leader))
        if current is None and held:
            if self.admission is None:
                first = held[0]
                return False, f'{self.robot} is committed to coalition {first.coalition_id} of {first.leader}'
            reason = self.admission(held, coalition_id, leader, tuple(members))
            if reason:
                return False, reason
        elif current is None and self.admission is not None:
            reason = self.admission((), coalition_id, leader, tuple(members))
            if reason:
                return False, reason
        expires_at = now + hold_seconds if hold_seconds > 0 else NEVER
        self._held[(coalition_id, leader)] = Commitment(coalition_id, leader, tuple(members),
                                                         now if current is None else current.since, expires_at)
        self.history.append((now, 'renewed' if current is not None else 'committed', coalition_id))
        return True, ''

    def holds(self, coalition_id: str, leader: str, now: float) -> bool:
        self.held(now)
        return (coalition_id, leader) in self._held

    def release(self, coalition_id: str, leader: str, now: float) -> bool:
        """Drop the commitment to ``coalition_id`` of ``leader``; False if it was not held."""
        if not self.holds(coalition_id, leader, now):
            return False
        del self._held[(coalition_id, leader)]
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


__all__ = ['Admission', 'Commitment', 'CommitmentLedger', 'Negotiation']
