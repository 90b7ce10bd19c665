"""The coalition agent's states, as ``coalition_interfaces/AgentStatus.state`` carries them.

The values equal the message's ``uint8`` constants (``AgentStatus.COMMITTED == AgentState.COMMITTED``),
so a status converts with ``AgentState(msg.state)``; :attr:`AgentState.label` is the lowercase name
used in logs, tables and results.json (``'committed'``).
"""
from __future__ import annotations

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
