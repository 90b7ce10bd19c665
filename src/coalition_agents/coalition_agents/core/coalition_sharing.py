"""Which coalitions one robot can serve at once: capability sharing versus conflict (no ROS).

Paper (IQ-ASyMTRe, CITATION.cff): a task may involve "forming one or multiple
coalitions" (footnote 1); "Capability sharing is implicitly achieved through the communication of
information" (Sec. II); in the monitoring task "the same robots can appear in different coalitions
(such as robots 1 and 4 in this simulation), such that synergy between coalitions can be achieved"
(Sec. V-A-3, Fig. 8); in the column "any robot (except the front-most one) can only provide its
localization information to the robot behind it after it localizes itself" (footnote 16): a robot
uses its own localisation and shares it at the same time. What a helper runs for a coalition is
charged to it: "a cost to activate a necessary MS (to maintain the relative position) on the
robot that is chosen to help" (footnote 14), and "the required schemas are always activated during
task execution" (footnote 13). Tasks that cannot run together "may require sequential execution
... to avoid conflicts" (footnote 17).

The rule (ours, in those words; the paper does not say how many coalitions one robot may serve).
A robot's part in one coalition is a set of :class:`Use` s of its schemas:

* ``information`` -- an instance it communicates (CS): one value is sent to any number of
  receivers. Always shared.
* ``sensor`` -- an ES-EPS pair retrieving an instance. A body-fixed sensor's one reading holds
  every referent in its field of view, and that one reading serves every coalition that needs one
  of them: shared.
* ``aimed_sensor`` -- a sensor that must be pointed at its referent (a pan-tilt camera; the
  robot's ``aimed_sensors`` parameter): it retrieves one referent set at a time, so two uses
  retrieving different instances conflict ("a sensor that must point two ways").
* ``motor`` -- the motor schema the robot runs for the coalition (a leader's task MS, a helper's
  maintain_relative_position on its leader) when the agent drives: a robot runs one MS at a
  time, so two motor uses conflict unless they are the same MS for the same target. A robot
  with its own unfinished task reserves its motor schema for it.

:func:`conflict` says why two parts cannot be served at once ('' when they can);
:func:`first_conflict` checks a new part against the held ones (the commitment ledger's
admission rule, :class:`~.transport.commitments.CommitmentLedger`); :func:`solution_parts` and
:func:`team_sharing` apply the same rule to the coalitions the in-process search found
(:class:`~.coalition_search.CoalitionSearch`), and the bag check applies it to the uses the agents
reported (``experiments.coalition_bag``).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Collection, Iterable, Mapping, Sequence

from .coalition_solution import CoalitionSolution, LocalCoalitionSolution
from .schemas import SchemaKind

INFORMATION, SENSOR, AIMED_SENSOR, MOTOR = 'information', 'sensor', 'aimed_sensor', 'motor'
USE_KINDS = (INFORMATION, SENSOR, AIMED_SENSOR, MOTOR)
#: the target of a motor use that runs the robot's own task
OWN_TASK = 'own task'


@dataclass(frozen=True, order=True)
class Use:
    """One schema use of a robot's part in a coalition (module docstring): ``kind``, ``name`` (the
    instance, the sensor or the motor schema) and ``target`` (the instance a sensor retrieves, what
    a motor schema runs for)."""

    kind: str
    name: str
    target: str = ''

    def __post_init__(self) -> None:
        if self.kind not in USE_KINDS:
            raise ValueError(f'use.kind: {self.kind!r} is not one of {", ".join(USE_KINDS)}')

    @property
    def text(self) -> str:
        """``kind:name`` or ``kind:name:target`` (AgentStatus ``commitments[].uses``)."""
        return f'{self.kind}:{self.name}' + (f':{self.target}' if self.target else '')

    @classmethod
    def parse(cls, text: str) -> 'Use':
        parts = str(text).split(':', 2)
        if len(parts) < 2 or not parts[1]:
            raise ValueError(f'use: {text!r} is not kind:name[:target]')
        return cls(parts[0], parts[1], parts[2] if len(parts) == 3 else '')

    def describe(self) -> str:
        if self.kind == MOTOR:
            return f'motor schema {self.name} ({self.target})' if self.target else f'motor schema {self.name}'
        if self.kind in (SENSOR, AIMED_SENSOR):
            return f'{self.name} on {self.target}' if self.target else self.name
        return self.name


@dataclass(frozen=True)
class CoalitionPart:
    """What ``robot`` commits to coalition ``coalition_id`` of ``leader``: its :class:`Use` s."""

    robot: str
    coalition_id: str
    leader: str
    uses: frozenset[Use] = field(default_factory=frozenset)

    @property
    def texts(self) -> tuple[str, ...]:
        return tuple(use.text for use in sorted(self.uses))

    @classmethod
    def from_texts(cls, robot: str, coalition_id: str, leader: str, texts: Iterable[str]) -> 'CoalitionPart':
        return cls(robot, coalition_id, leader, frozenset(Use.parse(text) for text in texts))

    def label(self) -> str:
        if self.leader == self.robot:
            return f'its own coalition {self.coalition_id}' if self.coalition_id else 'its own task'
        return f'coalition {self.coalition_id} of {self.leader}'


def conflict(held: CoalitionPart, new: CoalitionPart) -> str:
    """Why one robot cannot serve both parts at once ('' = it can: they share, module docstring)."""
    if held.coalition_id == new.coalition_id and held.leader == new.leader:
        return ''
    for a in sorted(held.uses):
        for b in sorted(new.uses):
            if a.kind == b.kind == MOTOR and (a.name, a.target) != (b.name, b.target):
                return (f'{new.robot} runs one motor schema at a time: {a.describe()} for {held.label()}, '
                        f'{new.label()} needs {b.describe()}')
            if a.kind == b.kind == AIMED_SENSOR and a.name == b.name and a.target != b.target:
                return (f"{new.robot}'s {a.name} must be aimed at one referent: {a.target} for {held.label()}, "
                        f'{b.target} for {new.label()} (it cannot point two ways)')
    return ''


def first_conflict(held: Sequence[CoalitionPart], new: CoalitionPart) -> str:
    """The first reason ``new`` conflicts with one of ``held`` ('' = it can be served with all of them)."""
    for part in held:
        reason = conflict(part, new)
        if reason:
            return reason
    return ''


def conflicting_pairs(parts: Sequence[CoalitionPart]) -> list[tuple[str, str, str]]:
    """(coalition id, coalition id, reason) of every pair of one robot's parts that conflict."""
    found = []
    for index, a in enumerate(parts):
        for b in parts[index + 1:]:
            reason = conflict(a, b)
            if reason:
                found.append((a.coalition_id, b.coalition_id, reason))
    return found


def sensor_use(sensor: str, instance: object, aimed: Collection[str]) -> Use:
    return Use(AIMED_SENSOR if sensor in aimed else SENSOR, sensor, str(instance))


def lcs_uses(lcs: LocalCoalitionSolution, aimed: Collection[str] = ()) -> set[Use]:
    """The sensor uses of one LCS (its ES-EPS leaves) and, for a reply, the information it provides."""
    uses = {sensor_use(step.schema, instance, aimed) for step, instance, _ in lcs.sources
            if step.kind is SchemaKind.ES_EPS and step.schema != 'prior'}
    if lcs.answer is not None:
        uses.add(Use(INFORMATION, str(lcs.answer)))
    return uses


# --- the coalitions found by the in-process search ---------------------------------------------------
def solution_parts(solution: CoalitionSolution, coalition_id: str, task_motor_schema: str = '',
                   helper_motor_schema: str = '', aimed: Mapping[str, Collection[str]] | None = None,
                   ) -> dict[str, CoalitionPart]:
    """robot -> its part in ``solution`` (every LCS of the DAG): sensors and information; the
    leader's task MS (``task_motor_schema``, '' = not driving) and each helper's MS
    (``helper_motor_schema``, run on the leader) when given."""
    leader = solution.robot
    uses: dict[str, set[Use]] = {}
    stack, seen = [solution.root], set()
    while stack:
        lcs = stack.pop()
        if id(lcs) in seen:
            continue
        seen.add(id(lcs))
        uses.setdefault(lcs.robot, set()).update(lcs_uses(lcs, (aimed or {}).get(lcs.robot, ())))
        stack.extend(offer.solution for offer in lcs.offers)
    for robot in solution.members:
        motor = task_motor_schema if robot == leader else helper_motor_schema
        if motor:
            uses.setdefault(robot, set()).add(Use(MOTOR, motor, OWN_TASK if robot == leader else leader))
    return {robot: CoalitionPart(robot, coalition_id, leader, frozenset(found)) for robot, found in uses.items()}


@dataclass(frozen=True)
class TeamSharing:
    """Several coalitions of one team, robot by robot: who serves several, and which pairs conflict."""

    parts: Mapping[str, tuple[CoalitionPart, ...]]
    conflicts: Mapping[str, tuple[tuple[str, str, str], ...]]

    @property
    def shared(self) -> dict[str, tuple[str, ...]]:
        """robot -> the coalitions it serves at once (two or more) without a conflict."""
        return {robot: tuple(part.coalition_id for part in parts) for robot, parts in self.parts.items()
                if len(parts) > 1 and not self.conflicts.get(robot)}

    def to_dict(self) -> dict:
        return {'shared': {robot: list(ids) for robot, ids in self.shared.items()},
                'conflicting': {robot: [list(pair) for pair in pairs] for robot, pairs in self.conflicts.items()},
                'robots_serving_several': sum(1 for parts in self.parts.values() if len(parts) > 1)}


def team_sharing(parts_by_coalition: Iterable[Mapping[str, CoalitionPart]]) -> TeamSharing:
    """Collect each robot's parts over several coalitions and check them pairwise (:func:`conflict`)."""
    parts: dict[str, list[CoalitionPart]] = {}
    for coalition in parts_by_coalition:
        for robot, part in coalition.items():
            parts.setdefault(robot, []).append(part)
    conflicts = {robot: tuple(pairs) for robot, held in parts.items() if (pairs := conflicting_pairs(held))}
    return TeamSharing({robot: tuple(held) for robot, held in parts.items()}, conflicts)


__all__ = ['AIMED_SENSOR', 'CoalitionPart', 'INFORMATION', 'MOTOR', 'OWN_TASK', 'SENSOR', 'TeamSharing', 'USE_KINDS',
           'Use', 'conflict', 'conflicting_pairs', 'first_conflict', 'lcs_uses', 'sensor_use', 'solution_parts',
           'team_sharing']
