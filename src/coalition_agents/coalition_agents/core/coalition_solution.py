"""Coalition solutions and their cost (no ROS): what an executable coalition is, once found.

Paper, Sections IV-D and IV-F:

* Definition 4.6 -- a *local coalition*: the local robot and the teammates that directly feed
  it information (:attr:`CoalitionSolution.local_coalition`).
* Definition 4.7 -- a *local coalition solution* (LCS): a potential solution after fully
  instantiating all its information instances from the sensed information and the offers
  received (:class:`LocalCoalitionSolution`, built by
  :meth:`RobotReasoner.local_coalition_solutions`). Instantiation enforces the referent
  instantiation constraint: one entity per variable across the whole solution, no instance
  naming the same entity twice and (our addition, the paper is silent) no schema receiving
  the same instance on two inputs; a potential solution for which no such instantiation
  exists is not executable in the current situation.
* Definition 4.8/4.9 -- a *coalition* includes the robots that support the local robot
  indirectly; its *coalition solution* is the LCS plus, recursively, the solutions of the
  required coalitions (each offer carries the helper's LCS) (:class:`CoalitionSolution`).
* Coalition cost -- "the sum of all these costs" (:func:`coalition_cost`): each LCS's schemas
  once (a CS pair -- requester's CS and helper's reply -- counts once, footnote 14, so a
  helper's reply CS is not charged) plus, when the task names one, the helper MS "to maintain
  the relative position" once per helper robot (footnote 14). With the paper's costs this gives
  Table V's coalition costs 16 and 17.5 for potential solutions 2 and 3 of Table III.

An :class:`InformationOffer` -- a helper's answer to a request -- carries the helper's LCS, so a
coalition solution is a DAG of LCSs linked by offers.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

from .information import Entity, InformationInstance, Variable
from .requests import to_absolute
from .schemas import SchemaKind
from .solution_space import COST_DIGITS, PotentialSolution, SolutionStep


@dataclass(frozen=True, eq=False)
class InformationOffer:
    """A helper's answer: ``provider`` can provide ``instance`` (fully instantiated, absolute)
    for ``request`` (the label as requested), through its coalition ``solution``.

    ``cost`` is the cost of the helper's coalition: its schemas (the reply CS excluded: the
    requester's CS pays for the pair, footnote 14), its helpers' coalitions and a helper MS for
    every robot in it (if the task has one).
    """

    provider: str
    request: InformationInstance
    instance: InformationInstance
    solution: LocalCoalitionSolution
    cost: float

    def __str__(self) -> str:
        return f'{self.provider} offers {self.instance} (cost {self.cost:g})'


@dataclass(frozen=True, eq=False)
class LocalCoalitionSolution:
    """Definition 4.7: robot ``robot``'s potential solution, fully instantiated.

    ``sources`` pairs each leaf of the potential solution (in order) with the instance that
    feeds it and, for a CS leaf, the offer it came from. ``is_reply`` marks a solution that
    answers another robot's request (its root CS is not charged, see :func:`coalition_cost`).
    """

    robot: str
    potential_solution: PotentialSolution
    binding: tuple[tuple[Variable, Entity], ...]
    sources: tuple[tuple[SolutionStep, InformationInstance, InformationOffer | None], ...]
    is_reply: bool
    local_cost: float

    def instantiate(self, instance: InformationInstance) -> InformationInstance:
        """A label of the potential solution with this solution's entities (absolute frame)."""
        return to_absolute(instance.substitute(dict(self.binding)), self.robot)

    @property
    def answer(self) -> InformationInstance | None:
        """For a reply: the instance provided to the requester."""
        root = self.potential_solution.root
        return self.instantiate(root.output) if self.is_reply and root.output is not None else None

    @property
    def offers(self) -> tuple[InformationOffer, ...]:
        return tuple(offer for _, _, offer in self.sources if offer is not None)

    def step_lines(self) -> list[str]:
        """This robot's schemas with their instantiated labels, one per line (pre-order)."""
        lines = []
        offers = iter(self.offers)
        for step in self.potential_solution.root.walk():
            if step.kind is SchemaKind.MS:
                lines.append(f'MS {step.schema}')
            elif step.kind in (SchemaKind.RPS, SchemaKind.PS):
                inputs = ' + '.join(str(self.instantiate(s.output)) for s in step.inputs)  # type: ignore[arg-type]
                lines.append(f'{step.kind.short} {step.schema}: {inputs} => {self.instantiate(step.output)}')
            elif step.kind is SchemaKind.CS and step.inputs:
                lines.append(f'CS reply: {self.instantiate(step.output)}')  # type: ignore[arg-type]
            elif step.kind is SchemaKind.CS:
                offer = next(offers)
                lines.append(f'CS: {offer.instance} from {offer.provider}')
            else:
                lines.append(f'{step.kind.short} {step.schema}: {self.instantiate(step.output)}')  # type: ignore[arg-type]
        return lines


def _summary(lcs: LocalCoalitionSolution) -> tuple[frozenset, frozenset[str], float]:
    """(every distinct LCS of the coalition solution, their robots, the sum of their local
    costs), cached per LCS. A coalition solution is a DAG: an offer shared by two branches is
    one activation and is counted once."""
    cached = lcs.__dict__.get('_summary')
    if cached is not None:
        return cached
    children = [_summary(offer.solution) for offer in lcs.offers]
    nodes = frozenset([lcs]).union(*(child[0] for child in children))
    robots = frozenset([lcs.robot]).union(*(child[1] for child in children))
    if len(nodes) == 1 + sum(len(child[0]) for child in children):
        total = lcs.local_cost + sum(child[2] for child in children)  # no sharing
    else:
        total = sum(node.local_cost for node in nodes)
    cached = (nodes, robots, total)
    object.__setattr__(lcs, '_summary', cached)
    return cached


def coalition_members(root: LocalCoalitionSolution) -> tuple[str, ...]:
    """Definition 4.8: the root robot first, then every robot supporting it, sorted."""
    others = sorted(_summary(root)[1] - {root.robot})
    return (root.robot, *others)


def coalition_cost(root: LocalCoalitionSolution, helper_motor_schema_cost: float = 0.0,
                   *, root_is_helped: bool = True) -> float:
    """The coalition cost: every distinct LCS's schemas plus a helper MS per helper robot.

    With ``root_is_helped=False`` every member counts as a helper (the cost of an offer as
    seen by a requester outside the coalition).
    """
    _, robots, total = _summary(root)
    helpers = len(robots - {root.robot}) if root_is_helped else len(robots)
    return round(total + helper_motor_schema_cost * helpers, COST_DIGITS)


@dataclass(frozen=True, eq=False)
class CoalitionSolution:
    """Definition 4.9: an LCS with its required coalitions' solutions, and its coalition cost."""

    root: LocalCoalitionSolution
    cost: float
    members: tuple[str, ...]

    @property
    def robot(self) -> str:
        return self.root.robot

    @property
    def local_coalition(self) -> tuple[str, ...]:
        """Definition 4.6: the robot and the teammates that directly feed it information."""
        direct = sorted({offer.provider for offer in self.root.offers} - {self.root.robot})
        return (self.root.robot, *direct)

    def describe(self) -> str:
        """Multi-line text: each robot's instantiated schemas, helpers indented below."""
        lines = [f'coalition of {", ".join(self.members)}: cost {self.cost:g} '
                 f'(potential solution {self.root.potential_solution.rank + 1}, '
                 f'{self.root.potential_solution.cost:g})']

        def add(lcs: LocalCoalitionSolution, depth: int, seen: set[int]) -> None:
            indent = '  ' * depth
            header = (f'{lcs.robot} provides {lcs.answer}' if lcs.is_reply else f'{lcs.robot}')
            lines.append(f'{indent}{header}:')
            lines.extend(f'{indent}  {line}' for line in lcs.step_lines())
            if id(lcs) in seen:
                return
            seen.add(id(lcs))
            for offer in lcs.offers:
                add(offer.solution, depth + 1, seen)

        add(self.root, 1, set())
        return '\n'.join(lines)

    def to_dict(self) -> dict:
        def lcs_dict(lcs: LocalCoalitionSolution) -> dict:
            return {'robot': lcs.robot, 'provides': None if lcs.answer is None else str(lcs.answer),
                    'cost': lcs.local_cost, 'schemas': lcs.step_lines(),
                    'helpers': [lcs_dict(offer.solution) for offer in lcs.offers]}
        return {'cost': self.cost, 'members': list(self.members),
                'potential_solution': self.root.potential_solution.rank + 1, 'solution': lcs_dict(self.root)}


def sort_coalitions(solutions: Iterable[CoalitionSolution]) -> list[CoalitionSolution]:
    """Non-descending coalition cost; ties by potential-solution rank, then members and text."""
    return sorted(solutions, key=lambda s: (s.cost, s.root.potential_solution.rank, s.members,
                                            tuple(s.root.step_lines())))


def cheapest_per_members(solutions: Iterable[CoalitionSolution]) -> list[CoalitionSolution]:
    """One solution per distinct set of members (the cheapest): the paper's count of coalitions."""
    best: dict[frozenset[str], CoalitionSolution] = {}
    for solution in sort_coalitions(solutions):
        best.setdefault(frozenset(solution.members), solution)
    return sort_coalitions(best.values())


__all__ = [
    'CoalitionSolution', 'InformationOffer', 'LocalCoalitionSolution', 'cheapest_per_members', 'coalition_cost',
    'coalition_members', 'sort_coalitions',
]
