"""The coalition agent's states and status report, as ``coalition_interfaces/AgentStatus.state`` carries them.

The values equal the message's ``uint8`` constants (``AgentStatus.COMMITTED == AgentState.COMMITTED``),
so a status converts with ``AgentState(msg.state)``; :attr:`AgentState.label` is the lowercase name
used in logs, tables and results.json (``'committed'``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum


class AgentState(IntEnum):
    IDLE = 0          # no task and no commitment (also: a helper released from its coalition)
    HELPING = 1       # no task of its own; answering a leader's requests, not committed yet
    SEARCHING = 2     # a leader building executable coalitions until it settles
    NEGOTIATING = 3   # a leader asking one candidate coalition's members to commit
    COMMITTED = 4     # set up: the leader's negotiation succeeded, or a helper accepted
    COMPLETED = 5     # a driving leader's motor schema reached its goal
    FAILED = 6        # no coalition could be set up, re-forming gave up, or the task ran out of time

    @property
    def label(self) -> str:
        return self.name.lower()

    @classmethod
    def from_label(cls, label: str) -> 'AgentState':
        try:
            return cls[label.upper()]
        except KeyError:
            raise ValueError(f"unknown agent state {label!r} (allowed: {', '.join(s.label for s in cls)})") from None

    @property
    def finished(self) -> bool:
        """A leader's final states (``exit_after`` waits for them)."""
        return self in (AgentState.COMPLETED, AgentState.FAILED)


@dataclass(frozen=True)
class HeldCoalition:
    """One coalition a robot is committed to (AgentStatus ``commitments[]``): its own or one it
    helps, and what this robot's schemas do for it (``uses``: :class:`~.coalition_sharing.Use`
    texts, e.g. ``sensor:gps:F_G(robot_1)``, ``motor:maintain_relative_position:robot_3``)."""

    coalition_id: str
    leader: str
    members: tuple[str, ...]
    cost: float
    uses: tuple[str, ...] = ()
    #: when this robot committed to it (its own clock, s)
    since: float = 0.0


@dataclass(frozen=True)
class StatusReport:
    """What an agent reports (``coalition_interfaces/AgentStatus`` without the channel counters):
    its typed state, its coalition and the stamps of its search (its own clock, s; None = not yet)."""

    robot: str
    state: AgentState
    task: str
    coalition_id: str = ''
    leader: str = ''
    members: tuple[str, ...] = ()
    cost: float = 0.0
    #: when the current search started (leaders; re-forming restarts it)
    search_started: float | None = None
    #: when this search first had an executable coalition, and that coalition's cost
    coalition_found: float | None = None
    found_cost: float = 0.0
    #: when the coalition it is (or was last) committed to was set up
    coalition_formed: float | None = None
    #: when a driving leader's task ended (COMPLETED or FAILED)
    task_finished: float | None = None
    #: rank + 1 of the set-up coalition's potential solution (0 = none)
    potential_solution: int = 0
    reforms: int = 0
    #: the motor schema's last distance to its goal, m (NaN before executing)
    goal_distance: float = math.nan
    requests_sent: int = 0
    offers_received: int = 0
    #: human-readable text only (what happened, why); never parsed
    detail: str = ''
    #: every coalition it is committed to now: its own first (a leader), then those it helps
    commitments: tuple[HeldCoalition, ...] = ()
