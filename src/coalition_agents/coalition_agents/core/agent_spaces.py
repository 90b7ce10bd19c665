"""The bookkeeping of a :class:`~.agent.SchemaAgent`: its executable coalitions, the answers of
its reply spaces and what changed for them since they were last instantiated (no ROS).

Event-driven evaluation (ours; the result is the one of re-instantiating everything every tick):
a potential solution is re-instantiated only when one of its inputs changed. An offer from a new
provider or of a new instance for one of its request labels adds only the instantiations that
use at least one of the new offers (semi-naive, :meth:`~.coalition.RobotReasoner.local_coalition_solutions`
``new_offers``). An offer that is no longer usable -- replaced by its provider's cheaper one, or
(a reply uses the cheapest offer per instance) undercut by another provider's -- is *gone*: only
the answers whose cheapest way used it are instantiated again, each restricted to that answer
(the ways it beat before may be its cheapest now); every other kept answer is still the
cheapest without the new offers. A change in the set of current readings of one of its sensors
(a new detection, a reading that expired) re-instantiates it completely. The answers of every
potential solution are kept; a reply space's best answers are merged from them, and a new
subscriber of an existing reply space is sent the existing best answers without any
re-instantiation (the others only the answers whose cost changed). The task's own potential
solutions (``coalitions``) are cached the same way. Equal-cost answers are decided by
:func:`answer_order` (not by the order instantiations are found), so incremental and full
evaluation choose the same. ``evaluations`` counts instantiations of a potential solution (the
work done), ``repaired_answers`` the answers instantiated again; ``incremental=False``
re-instantiates everything on every call, the reference the unit tests compare against. A tick
consumes the changes pending when it starts: offers a robot sends itself during a tick are
evaluated at the next one, as in a full re-evaluation (which takes its view of the offers when
the tick starts). With a time budget a tick stops between reply spaces and leaves the rest,
with their pending changes, to the next call (round robin), so that a transport can run
between slices.

Coalition cost from offers (ours): offers on the wire carry the helper coalition's cost and
members, not its solution (:mod:`.transport.codec`), so the cost is computed from them:
``own schemas + sum(offer cost - helper MS * offer members) + helper MS * helpers``
(:func:`coalition_cost_from_offers`). It equals :func:`~.coalition_solution.coalition_cost` unless
two offers of one coalition share a helper's LCS (the in-process search counts a shared LCS once;
across robots that sharing is not visible, so it is counted per offer -- an upper bound).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Iterable, Iterator, Sequence

from .coalition_solution import InformationOffer, LocalCoalitionSolution
from .information import InformationInstance
from .requests import InformationRequest
from .schemas import SchemaKind
from .solution_space import COST_DIGITS, PotentialSolution


@dataclass(frozen=True)
class FeasibleCoalition:
    """An executable coalition found by the local robot: its LCS, members (the robot first)
    and coalition cost."""

    lcs: LocalCoalitionSolution
    members: tuple[str, ...]
    cost: float

    @cached_property
    def order(self) -> tuple:
        """Sort key: cost, then the potential solution's rank, the members and the schemas."""
        return self.cost, self.potential_solution.rank, self.members, tuple(self.lcs.step_lines())

    @property
    def potential_solution(self) -> PotentialSolution:
        return self.lcs.potential_solution

    def sensors(self) -> tuple[str, ...]:
        """The local robot's sensors this coalition keeps active."""
        return tuple(dict.fromkeys(step.schema for step, _, _ in self.lcs.sources if step.kind is SchemaKind.ES_EPS))

    def describe(self) -> str:
        lines = [f'coalition of {", ".join(self.members)}: cost {self.cost:g} '
                 f'(potential solution {self.potential_solution.rank + 1}, {self.potential_solution.cost:g})']
        lines.extend(f'  {line}' for line in self.lcs.step_lines())
        return '\n'.join(lines)


def coalition_cost_from_offers(lcs: LocalCoalitionSolution, offer_members: Sequence[tuple[str, ...]],
                               helper_motor_schema_cost: float, *, root_is_helped: bool) -> tuple[float, tuple[str, ...]]:
    """(coalition cost, members) of ``lcs`` from its offers' costs and members (see the module
    docstring); ``root_is_helped=False`` gives the cost of an offer (every member a helper)."""
    total = lcs.local_cost
    robots: set[str] = {lcs.robot}
    for offer, members in zip(lcs.offers, offer_members):
        total += offer.cost - helper_motor_schema_cost * len(members)
        robots.update(members)
    helpers = len(robots) - (1 if root_is_helped else 0)
    members = (lcs.robot, *sorted(robots - {lcs.robot}))
    return round(total + helper_motor_schema_cost * helpers, COST_DIGITS), members


Answer = tuple[float, tuple[str, ...], LocalCoalitionSolution]


def answer_order(entry: Answer) -> tuple:
    """Ties between equal-cost ways to one answer: fewer robots, then members, then the
    potential solution's rank, then the instances used (a total order: the choice does not
    depend on the order in which instantiations were found)."""
    cost, members, lcs = entry
    return (cost, len(members), members, lcs.potential_solution.rank,
            tuple(str(instance) for _, instance, _ in lcs.sources),
            tuple((offer.provider, str(offer.instance)) for offer in lcs.offers))


def offer_rank(offer: InformationOffer) -> tuple[float, str]:
    """Which of two offers of one instance a reply uses (the cheapest, ties by provider)."""
    return offer.cost, offer.provider


def better_answer(entry: Answer, kept: Answer | None) -> bool:
    if kept is None or entry[0] < kept[0]:
        return True
    return entry[0] == kept[0] and answer_order(entry) < answer_order(kept)


@dataclass
class SpaceChanges:
    """What changed for a space's potential solutions since they were last instantiated."""

    #: potential solutions with new offers (semi-naive update)
    dirty: set[int] = field(default_factory=set)
    #: potential solutions to instantiate completely (new, or their readings changed)
    stale: set[int] = field(default_factory=set)
    #: the new offers, per request label
    new_offers: dict[InformationInstance, list[InformationOffer]] = field(default_factory=dict)
    #: ids of offers no longer usable (see :meth:`SchemaAgent.on_offer`)
    gone: set[int] = field(default_factory=set)

    def take(self) -> 'SpaceChanges':
        """These changes, leaving none."""
        taken = SpaceChanges(self.dirty, self.stale, self.new_offers, self.gone)
        self.dirty, self.stale, self.new_offers, self.gone = set(), set(), {}, set()
        return taken

    def merge(self, earlier: 'SpaceChanges') -> None:
        """Put back changes taken but not evaluated (they happened before the present ones)."""
        self.dirty |= earlier.dirty
        self.stale |= earlier.stale
        self.gone |= earlier.gone
        for label, offers in earlier.new_offers.items():
            self.new_offers[label] = offers + self.new_offers.get(label, [])

    def add_offer(self, indices: Iterable[int], offer: InformationOffer) -> None:
        """A new offer for the potential solutions ``indices`` (those using its request label)."""
        self.dirty.update(indices)
        self.new_offers.setdefault(offer.request, []).append(offer)


@dataclass
class ReplySpace:
    variant: InformationInstance
    solutions: list[PotentialSolution]
    subscribers: list[tuple[InformationRequest, object]] = field(default_factory=list)
    sent: dict[tuple[int, InformationInstance], float] = field(default_factory=dict)
    #: answer -> (offer cost, members, LCS) of the cheapest way found at the last evaluation
    best: dict[InformationInstance, Answer] = field(default_factory=dict)
    #: per potential solution (index): answer -> its cheapest (offer cost, members, LCS)
    answers: dict[int, dict[InformationInstance, Answer]] = field(default_factory=dict)
    changes: SpaceChanges = field(default_factory=SpaceChanges)
    #: subscribers that have not been sent the current best answers yet
    unserved: bool = False
    #: answers whose cost changed since the subscribers were last served
    changed: set[InformationInstance] = field(default_factory=set)
    #: how many subscribers (the first ones) were served every answer
    served: int = 0

    @property
    def has_work(self) -> bool:
        return bool(self.changes.dirty or self.changes.stale or self.unserved)

    def merge_best(self) -> None:
        """:attr:`best` from every potential solution's answers; the answers whose cost changed are
        marked for the subscribers."""
        best: dict[InformationInstance, Answer] = {}
        for answers in self.answers.values():
            for answer, entry in answers.items():
                if better_answer(entry, best.get(answer)):
                    best[answer] = entry
        old = self.best
        self.changed.update(answer for answer, entry in best.items() if answer not in old or old[answer][0] != entry[0])
        self.best = best


#: :attr:`RootSpace.best` when it must be looked for among every coalition again
STALE = object()


@dataclass
class RootSpace:
    """The task's potential solutions and, per solution, its feasible coalitions (cached)."""

    solutions: list[PotentialSolution] = field(default_factory=list)
    found: dict[int, list[FeasibleCoalition]] = field(default_factory=dict)
    changes: SpaceChanges = field(default_factory=SpaceChanges)
    #: every found coalition without an excluded robot, sorted (None: to be sorted again)
    ordered: list[FeasibleCoalition] | None = None
    #: the first of them (None: none; :data:`STALE`: to be looked for again)
    best: object = STALE

    def _usable(self, excluded: frozenset[str]) -> Iterator[FeasibleCoalition]:
        """The found coalitions without an ``excluded`` robot, in the order the sort starts from."""
        return (coalition for index in sorted(self.found) for coalition in self.found[index]
                if not excluded.intersection(coalition.members))

    def sorted_coalitions(self, excluded: frozenset[str]) -> list[FeasibleCoalition]:
        """Every usable coalition, sorted by :attr:`FeasibleCoalition.order` (kept until a change)."""
        if self.ordered is None:
            self.ordered = sorted(self._usable(excluded), key=lambda coalition: coalition.order)
            self.best = self.ordered[0] if self.ordered else None
        return self.ordered

    def cheapest(self, excluded: frozenset[str]) -> FeasibleCoalition | None:
        """``sorted_coalitions(excluded)[0]`` (None: none) without sorting them all: the settle
        rule asks for it at every reasoning step of a searching leader while offers keep adding
        coalitions (thousands in the 20-robot column)."""
        if self.best is STALE:
            self.best = min(self._usable(excluded), key=lambda coalition: coalition.order, default=None)
        return self.best  # type: ignore[return-value]

    def changed(self, added: Sequence[FeasibleCoalition], removed: bool, excluded: frozenset[str]) -> None:
        """Coalitions were ``added`` (in found order) and, if ``removed``, some dropped: the sorted
        list is stale; :attr:`best` follows the added ones (a removal: looked for again). A tie on
        the whole order key (equal coalitions of one potential solution) keeps the one found first,
        as the stable sort does."""
        self.ordered = None
        if removed:
            self.best = STALE
            return
        for coalition in ([] if self.best is STALE else added):
            if not excluded.intersection(coalition.members) and (
                    self.best is None or coalition.order < self.best.order):  # type: ignore[attr-defined]
                self.best = coalition


@dataclass(frozen=True, eq=False)
class ReceivedOffer(InformationOffer):
    """An offer from the wire: the helper coalition's members instead of its solution."""

    members: tuple[str, ...] = ()


__all__ = [
    'STALE', 'Answer', 'FeasibleCoalition', 'ReceivedOffer', 'ReplySpace', 'RootSpace', 'SpaceChanges', 'answer_order',
    'better_answer', 'coalition_cost_from_offers', 'offer_rank',
]
