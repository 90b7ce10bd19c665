"""The coalitions one robot is committed to -- the one it leads and those it helps -- and its
admission rule (no ROS).

A robot may serve several coalitions at once where its schemas can serve them together
(capability sharing, :mod:`.coalition_sharing`): the same reading and the same communicated
information go to every leader that needs them. :meth:`Commitments.admit` is the ledger's
admission rule (:class:`~.transport.commitments.CommitmentLedger`): it computes this robot's part
in the proposed coalition (:meth:`Commitments.part`) and refuses it, with the reason, when it
conflicts with a part already held or with the robot's own task:

* a robot with its own task that has not ended keeps its motor schema for it when it drives (its
  task MS reserves the motor), so it declines to run a helper MS for another leader -- it says so
  in the COMMIT_REJECT, it never drops its task.

What each part uses: the ES-EPS pairs and the answers of the robot's cheapest answers to the
coalition's members (:meth:`~.agent.SchemaAgent.served_answers`), its own coalition's LCS for
the coalition it leads, and -- when the agent drives -- the motor schema it runs: the task's MS
for its own, the team task's helper MS (footnote 14: maintain_relative_position) on the leader
for a coalition it helps.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

from .agent import FeasibleCoalition, SchemaAgent
from .agent_state import HeldCoalition
from .coalition_sharing import MOTOR, OWN_TASK, CoalitionPart, Use, first_conflict, lcs_uses
from .settings import AgentSettings
from .transport.commitments import Commitment

#: the helper MS a driving helper runs when the team task names none (what the runner runs)
DEFAULT_HELPER_MS = 'maintain_relative_position'


@dataclass
class Held:
    """A coalition this robot is committed to, with its part in it."""

    coalition_id: str
    leader: str
    members: tuple[str, ...]
    cost: float
    since: float
    part: CoalitionPart

    def report(self) -> HeldCoalition:
        return HeldCoalition(self.coalition_id, self.leader, tuple(self.members), float(self.cost), self.part.texts,
                             self.since)


class Commitments:
    """One robot's held coalitions (module docstring): ``own`` (the coalition it leads, kept for
    its status after its task ended) and ``serving`` (those it helps, in the order it committed)."""

    def __init__(self, agent: SchemaAgent, settings: AgentSettings):
        self.agent = agent
        self.robot = agent.robot
        self.drive = bool(settings['drive'])
        self.aimed = tuple(settings['aimed_sensors'])
        team_task = settings.task if settings.task is not None else settings.team_task
        self.task_motor_schema = settings.task.motor_schema if settings.task is not None else ''
        self.helper_motor_schema = (team_task.helper_motor_schema if team_task is not None else '') or DEFAULT_HELPER_MS
        self.own: Held | None = None
        self.serving: dict[str, Held] = {}
        #: coalition id -> the part admitted for it (the commitment arrives after the admission)
        self.admitted: dict[str, CoalitionPart] = {}
        #: the candidate the robot is proposing now (its own coalition's part)
        self.proposing: FeasibleCoalition | None = None
        #: whether the robot's own task still needs it (set by the life cycle)
        self.task_open = agent.task is not None
        self.declined = 0

    # --- parts ------------------------------------------------------------------------------------
    def part(self, coalition_id: str, leader: str, members: Sequence[str]) -> CoalitionPart:
        """This robot's part in a coalition: what it serves the other members, and its MS if it drives."""
        uses: set[Use] = set()
        if leader == self.robot and self.proposing is not None:
            uses.update(lcs_uses(self.proposing.lcs, self.aimed))
        for _, _, lcs in self.agent.served_answers(robot for robot in members if robot != self.robot):
            uses.update(lcs_uses(lcs, self.aimed))
        if self.drive:
            if leader == self.robot:
                uses.add(Use(MOTOR, self.task_motor_schema, OWN_TASK))
            else:
                uses.add(Use(MOTOR, self.helper_motor_schema, leader))
        return CoalitionPart(self.robot, coalition_id, leader, frozenset(uses))

    def reservation(self) -> CoalitionPart | None:
        """The robot's own task while it is open and not held as a coalition: its motor schema (driving)."""
        if not self.task_open or not self.drive:
            return None
        return CoalitionPart(self.robot, '', self.robot, frozenset({Use(MOTOR, self.task_motor_schema, OWN_TASK)}))

    def admit(self, held: tuple[Commitment, ...], coalition_id: str, leader: str, members: tuple[str, ...]) -> str:
        """The ledger's admission rule: why this robot cannot also commit to ``coalition_id`` ('' = it can)."""
        part = self.part(coalition_id, leader, members)
        parts = [self.admitted.get(c.coalition_id) or self.part(c.coalition_id, c.leader, c.members) for c in held]
        reserved = self.reservation() if leader != self.robot else None
        if reserved is not None and not any(p.leader == self.robot for p in parts):
            parts.insert(0, reserved)
        reason = first_conflict(parts, part)
        if reason:
            self.declined += 1
            return reason
        self.admitted[coalition_id] = part
        return ''

    # --- holding ----------------------------------------------------------------------------------
    def lead(self, coalition_id: str, members: Sequence[str], cost: float, now: float) -> Held:
        part = self.admitted.get(coalition_id) or self.part(coalition_id, self.robot, members)
        self.own = Held(coalition_id, self.robot, tuple(members), cost, now, part)
        return self.own

    def serve(self, coalition_id: str, leader: str, members: Sequence[str], cost: float, now: float) -> Held:
        part = self.admitted.get(coalition_id) or self.part(coalition_id, leader, members)
        held = self.serving.get(coalition_id)
        if held is None:
            held = self.serving[coalition_id] = Held(coalition_id, leader, tuple(members), cost, now, part)
        return held

    def release(self, coalition_id: str, leader: str) -> Held | None:
        held = self.serving.get(coalition_id)
        if held is None or held.leader != leader:
            return None
        self.admitted.pop(coalition_id, None)
        return self.serving.pop(coalition_id)

    def held(self, own_active: bool) -> list[Held]:
        """The coalitions served now: the own one while it runs (``own_active``), then the helped ones."""
        return ([self.own] if own_active and self.own is not None else []) + list(self.serving.values())

    def primary(self) -> Held | None:
        """The coalition a pure helper's status names (the first it helps)."""
        return next(iter(self.serving.values()), None)

    def motor_leader(self) -> str | None:
        """The leader whose coalition runs this robot's helper MS (a driving helper), else None."""
        for held in self.serving.values():
            if any(use.kind == MOTOR for use in held.part.uses):
                return held.leader
        return None

    def accepts(self, coalition_id: str, sender: str, own_active: bool) -> bool:
        """Whether streamed information of ``sender`` for ``coalition_id`` is for a held coalition."""
        return any(held.coalition_id == coalition_id and sender in held.members for held in self.held(own_active))

    def keep_sensors(self, searching: bool, own: FeasibleCoalition | None) -> None:
        """Keep the sensors of what it serves: a searching leader keeps its search's too; else its
        own running coalition's (``own``; and its self-answers', footnote 10) and every helped one's."""
        serving = self.serving_sensors()
        if searching:
            self.agent.keep_only(set(self.agent.active_sensors) | set(serving))
            return
        mine = list(own.sensors()) + list(self.agent.sensors_serving(self.robot)) if own is not None else []
        self.agent.keep_only(mine + serving)

    def serving_sensors(self) -> list[str]:
        """The sensors the helped coalitions need (the answers served to their members; a driving
        helper's MS also needs the leader in view and its own contact)."""
        sensors: list[str] = []
        for held in self.serving.values():
            sensors += self.agent.sensors_serving(held.leader)
            sensors += [use.name for use in sorted(held.part.uses) if use.kind in ('sensor', 'aimed_sensor')]
            if any(use.kind == MOTOR for use in held.part.uses):
                sensors += [s for s in ('fiducial', 'bumper') if s in self.agent.sensing.sensors]
        return list(dict.fromkeys(sensors))


__all__ = ['Commitments', 'DEFAULT_HELPER_MS', 'Held']
