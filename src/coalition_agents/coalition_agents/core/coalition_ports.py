"""The ports of a coalition agent's life cycle (:class:`~.lifecycle.AgentLifecycle`): what it asks
of its host (:class:`LifecyclePort`, the node) and of the agent channel (:class:`CoalitionChannel`:
negotiation, release, streaming and the commitment ledger's admission rule). The schema_agent node
implements both on ROS; unit tests use fakes or the in-process channel of their harness.
"""
from __future__ import annotations

from typing import Protocol, Sequence

from .motor_schema import Velocity
from .agent_state import StatusReport
from .transport.commitments import Admission, Negotiation


class LifecyclePort(Protocol):
    """What the life cycle asks of its host (the node)."""

    def publish_status(self, report: StatusReport) -> None: ...

    def command(self, velocity: Velocity) -> None:
        """A velocity for the robot (ignored when the agent does not drive)."""

    def log(self, level: str, text: str) -> None:
        """``level``: info, warning or error."""

    def finish(self) -> None:
        """``exit_when_done``: this agent is done."""

    def request_reasoning(self) -> None:
        """Schedule :meth:`AgentLifecycle.reasoning_step` (its inputs changed)."""

    def teammates_listening(self) -> int:
        """How many teammates' agents listen on the channel now."""


class CoalitionChannel(Protocol):
    """The part of the agent channel the life cycle uses."""

    def new_id(self) -> int: ...

    def propose(self, coalition_id: str, members: Sequence[str], cost: float,
                hold_seconds: float) -> tuple[Negotiation | None, str]: ...

    def release(self, coalition_id: str, reason: str = '') -> None: ...

    def stream(self, receiver: str, coalition_id: str, instance, values) -> None: ...

    def announce(self) -> None:
        """Tell every teammate this agent's session (it started, or restarted)."""

    def drop_commitment(self, coalition_id: str, leader: str) -> None:
        """Forget the commitment to ``coalition_id`` of ``leader`` (presumed dead: no RELEASE will come)."""

    def admit_with(self, rule: Admission) -> None:
        """Install the commitment ledger's admission rule (:class:`~.transport.commitments.CommitmentLedger`)."""


__all__ = ['CoalitionChannel', 'LifecyclePort']
