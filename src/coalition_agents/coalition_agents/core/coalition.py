"""One robot's reasoning steps (paper Algorithm 2): what it senses, requests and offers, and its
local coalition solutions (Definition 4.7) given what it sensed and was offered.

:class:`RobotReasoner` is what a distributed ``schema_agent`` uses step by step (Algorithm 2):
the ordered potential solutions of its task, the sensors and requests a potential solution
activates (Distinct Requests applied), what it can provide for a received request (footnote 9
variants and their reply spaces) and the feasible LCSs given what it sensed and was offered.
:mod:`.coalition_search` wires these steps together for a whole team in one process.
"""
from __future__ import annotations

import operator
from dataclasses import dataclass
from typing import Iterable, Iterator, Mapping, Sequence

from .capabilities import RobotCapabilities
from .errors import CoalitionError, InformationError, RequestError
from .information import Entity, InformationInstance, Variable, bind_to_ground, check_entity_name
from .coalition_solution import (
    CoalitionSolution, InformationOffer, LocalCoalitionSolution, coalition_cost, coalition_members,
)
from .requests import (
    InformationRequest, RequestLedger, addressees, answers_request, request_label, request_variants, to_absolute,
)
from .schemas import Costs, SchemaKind, SchemaLibrary
from .solution_space import (
    COST_DIGITS, Constraints, PotentialSolution, SolutionSpace, SolutionSpaceCache, SolutionStep,
)
from .tasks import Task


class _CompiledSolution:
    """A potential solution's labels in one robot's absolute frame, for fast instantiation."""

    __slots__ = ('solution', 'leaves', 'instances', 'input_groups')

    def __init__(self, solution: PotentialSolution, robot: str):
        self.solution = solution
        #: (leaf, absolute label, request label of a CS leaf or None)
        self.leaves = tuple((leaf, to_absolute(leaf.output, robot),  # type: ignore[arg-type]
                             request_label(leaf.output, robot) if leaf.kind is SchemaKind.CS else None)  # type: ignore[arg-type]
                            for leaf in solution.leaves)
        instances = {to_absolute(step.output, robot): None for step in solution.root.walk() if step.output is not None}
        self.instances = tuple(instances)
        #: the inputs of each schema with several inputs (they must stay distinct instances)
        self.input_groups = tuple(tuple(to_absolute(child.output, robot) for child in step.inputs)  # type: ignore[arg-type]
                                  for step in solution.root.walk() if len(step.inputs) > 1)


@dataclass(frozen=True)
class SearchPlan:
    """What one robot does for a solution space it searches (Algorithm 2): the potential
    solutions in non-descending cost, the ES-EPS pairs to activate temporarily and the requests
    to send (Distinct Requests applied). ``variant`` is what it would provide to ``request``
    (local frame); both are None for the robot's own task."""

    solutions: tuple[PotentialSolution, ...]
    sensors: tuple[tuple[str, InformationInstance], ...]
    requests: tuple[InformationRequest, ...]
    request: InformationRequest | None = None
    variant: InformationInstance | None = None


class _Candidates:
    """A leaf's candidates (instance, offer or None) with a hash index per variable position of
    its label: entity -> the candidates with that entity there (built when first needed).

    Never changed once built: :meth:`extended` makes the next one (sharing what did not change)."""

    __slots__ = ('label', 'entries', 'has_offers', '_index', '_positions')

    def __init__(self, label: InformationInstance, entries: list[tuple[InformationInstance, InformationOffer | None]],
                 positions: dict[InformationInstance, int] | None = None):
        self.label = label
        self.entries = entries
        self.has_offers = any(offer is not None for _, offer in entries)
        self._index: dict[int, dict[Entity, list]] | None = None
        #: cheapest-offer candidates: instance -> its entry's position (what :meth:`extended` updates)
        self._positions = positions

    @classmethod
    def of_offers(cls, label: InformationInstance, offers: Sequence[InformationOffer],
                  cheapest_offers: bool) -> '_Candidates':
        """The candidates of a CS leaf: every offer in arrival order, or (``cheapest_offers``) the
        cheapest offer per instance, at the place of the instance's first offer."""
        if not cheapest_offers:
            return cls(label, [(offer.instance, offer) for offer in offers])
        candidates = cls(label, [], {})
        candidates._take(offers)
        return candidates

    def extended(self, previous: Sequence[InformationOffer], offers: Sequence[InformationOffer],
                 cheapest_offers: bool) -> '_Candidates | None':
        """The candidates of ``offers`` if it is ``previous`` (what these were built from) with
        offers appended -- how an offer book lists a new provider's offer -- else None (an offer
        was replaced in place: build again). Only the appended offers are looked at: a label
        that gathers hundreds of offers one batch at a time is not rebuilt at every batch."""
        known = len(previous)
        if len(offers) < known or not all(map(operator.is_, offers[:known], previous)):
            return None
        positions = None if self._positions is None else dict(self._positions)
        following = _Candidates(self.label, list(self.entries), positions)
        # Shallow copies: the index's lists are replaced, never changed, so these stay as they are.
        following._index = None if self._index is None else {position: dict(table) for position, table in
                                                             self._index.items()}
        if cheapest_offers:
            following._take(offers[known:])
        else:
            for offer in offers[known:]:
                following.entries.append((offer.instance, offer))
                following._index_add(following.entries[-1])
            following.has_offers = following.has_offers or known < len(offers)
        return following

    def _take(self, offers: Iterable[InformationOffer]) -> None:
        """Cheapest-offer candidates: add ``offers`` in place (only while this object is being built)."""
        entries, positions = self.entries, self._positions
        assert positions is not None
        for offer in offers:
            place = positions.get(offer.instance)
            if place is None:
                positions[offer.instance] = len(entries)
                entries.append((offer.instance, offer))
                self._index_add(entries[-1])
                continue
            kept = entries[place][1]
            if (offer.cost, offer.provider) < (kept.cost, kept.provider):  # type: ignore[union-attr]
                old, entries[place] = entries[place], (offer.instance, offer)
                self._index_replace(old, entries[place])
        self.has_offers = self.has_offers or bool(entries)

    def _index_add(self, candidate) -> None:
        if self._index is not None:
            for position, table in self._index.items():
                entity = candidate[0].referents[position]
                table[entity] = table.get(entity, []) + [candidate]

    def _index_replace(self, old, new) -> None:
        if self._index is not None:
            for position, table in self._index.items():
                entity = new[0].referents[position]
                table[entity] = [new if candidate is old else candidate for candidate in table[entity]]

    def consistent(self, binding: Mapping[Variable, Entity]) -> list:
        """The candidates that can agree with ``binding`` (narrowed by the most selective bound
        variable; the join still checks each)."""
        if self._index is None:
            index: dict[int, dict[Entity, list]] = {}
            for position, referent in enumerate(self.label.referents):
                if isinstance(referent, Variable):
                    table: dict[Entity, list] = {}
                    for candidate in self.entries:
                        table.setdefault(candidate[0].referents[position], []).append(candidate)
                    index[position] = table
            self._index = index
        best = self.entries
        for position, table in self._index.items():
            entity = binding.get(self.label.referents[position])  # type: ignore[arg-type]
            if entity is not None:
                narrowed = table.get(entity, [])
                if len(narrowed) < len(best):
                    best = narrowed
        return best


class _Slot:
    """One leaf of a potential solution in a join: its candidates, and (semi-naive joins) the
    offers it must not take."""

    __slots__ = ('index', 'leaf', 'label', 'candidates', 'excluded')

    def __init__(self, index: int, leaf: SolutionStep, label: InformationInstance, candidates: _Candidates,
                 excluded: set[int] | None = None):
        self.index, self.leaf, self.label, self.candidates, self.excluded = index, leaf, label, candidates, excluded

    def consistent(self, binding: Mapping[Variable, Entity]) -> list:
        return self.candidates.consistent(binding)

    def only(self, candidates: _Candidates) -> '_Slot':
        return _Slot(self.index, self.leaf, self.label, candidates)

    def excluding(self, offers: set[int]) -> '_Slot':
        return _Slot(self.index, self.leaf, self.label, self.candidates, offers)


class RobotReasoner:
    """One robot's IQ-ASyMTRe reasoning for one task, step by step (Algorithm 2).

    ``cache`` shares generated solution spaces between reasoners of robots with equal
    capabilities; ``potential_solution_limit`` caps how many potential solutions of a space
    are checked (the paper bounds the search by time instead).
    """

    def __init__(self, robot: str, capabilities: RobotCapabilities, library: SchemaLibrary, costs: Costs,
                 task: Task, *, cache: SolutionSpaceCache | None = None,
                 constraints: Constraints = Constraints(), potential_solution_limit: int | None = None):
        self.robot = check_entity_name(robot)
        self.capabilities = capabilities
        self.library = library
        self.costs = costs
        self.task = task
        self.cache = cache if cache is not None else SolutionSpaceCache(library, costs, constraints)
        self.generator = self.cache.generator(capabilities, task.prior_sensors)
        self.potential_solution_limit = potential_solution_limit
        self.ledger = RequestLedger(self.robot)
        self._compiled: dict[int, _CompiledSolution] = {}
        self._cache: dict = {}
        self._variants: dict[InformationInstance, tuple[InformationInstance, ...]] = {}

    @property
    def helper_motor_schema_cost(self) -> float:
        helper = self.task.helper_motor_schema
        return 0.0 if helper is None else self.costs.motor_schema(helper)

    # Algorithm 2, first lines: the task's space and its ordered potential solutions ---------
    def task_space(self, focus: Sequence[InformationInstance] | None = None) -> SolutionSpace:
        if self.task.motor_schema not in self.capabilities.motor_schemas:
            raise CoalitionError(
                f"robot {self.robot} cannot activate motor schema '{self.task.motor_schema}' of task "
                f"{self.task.name} (its motor schemas: {', '.join(sorted(self.capabilities.motor_schemas)) or 'none'})")
        return self.generator.motor_schema_space(self.task.motor_schema, self.task.requirements(focus))

    def task_solutions(self, focus: Sequence[InformationInstance] | None = None) -> list[PotentialSolution]:
        return self.task_space(focus).potential_solutions(self.potential_solution_limit)

    def plan_task(self, focus: Sequence[InformationInstance] | None = None) -> SearchPlan:
        """The robot's own task: what to sense and request to check all its potential solutions."""
        return self._plan(tuple(self.task_solutions(focus)), (), None, None)

    def plan_reply(self, request: InformationRequest) -> list[SearchPlan]:
        """What this robot can provide for ``request`` given the requests already in its chain:
        one plan per variant (footnote 9), empty if the request is not for this robot. Its own
        requests carry the extended chain; labels it requested before are not sent again."""
        return [self._plan(tuple(self.reply_solutions(variant)), request.extended_chain, request, variant)
                for variant in self.variants(request)]

    def _plan(self, solutions: tuple[PotentialSolution, ...], chain: tuple, request: InformationRequest | None,
              variant: InformationInstance | None) -> SearchPlan:
        sensors = dict.fromkeys(need for solution in solutions for need in self.sensing_needs(solution))
        requests = [sent for solution in solutions for sent in self.requests_to_send(solution, chain)]
        return SearchPlan(solutions, tuple(sensors), tuple(requests), request, variant)

    # Serving requests ------------------------------------------------------------------------
    def variants(self, request: InformationRequest) -> tuple[InformationInstance, ...]:
        """What this robot can provide for ``request`` (footnote 9), in its local frame (remembered
        per label: every teammate asks for the same few labels)."""
        known = self._variants.get(request.label)
        if known is not None:
            return known
        if request.label.has_local:
            raise RequestError(f"request.label: a request names robots, not 'local' (got {request.label})")
        try:
            self.library.types.check(request.label)
        except InformationError as exc:
            raise RequestError(f'request.label: {exc}') from None
        known = self._variants[request.label] = request_variants(request.label, self.robot)
        return known

    def reply_solutions(self, variant: InformationInstance) -> list[PotentialSolution]:
        return self.generator.reply_solutions(variant, self.potential_solution_limit)

    # What a potential solution activates -------------------------------------------------------
    def sensing_needs(self, solution: PotentialSolution) -> list[tuple[str, InformationInstance]]:
        """(sensor, absolute label) of each ES-EPS leaf, to activate temporarily."""
        return [(leaf.schema, label) for leaf, label, _ in self.compiled(solution).leaves
                if leaf.kind is SchemaKind.ES_EPS]

    def request_labels(self, solution: PotentialSolution) -> list[InformationInstance]:
        """The distinct request labels of the CS leaves (absolute, canonical), in leaf order."""
        return list(dict.fromkeys(requested for _, _, requested in self.compiled(solution).leaves
                                  if requested is not None))

    def requests_to_send(self, solution: PotentialSolution,
                         chain: tuple[tuple[str, InformationInstance], ...] = ()) -> list[InformationRequest]:
        """The requests this potential solution's CSs send now: Distinct Requests drops every
        label this robot already requested (its answers are shared)."""
        return [InformationRequest(self.robot, label, chain) for label in self.request_labels(solution)
                if self.ledger.admit(label, chain)]

    @staticmethod
    def addressees(request: InformationRequest, team: Sequence[str]) -> tuple[str, ...]:
        return addressees(request.label, team)

    # Instantiation: from a potential solution to local coalition solutions -------------------------
    def compiled(self, solution: PotentialSolution) -> '_CompiledSolution':
        """The solution's labels in this robot's absolute frame (computed once per solution)."""
        compiled = self._compiled.get(id(solution))
        if compiled is None or compiled.solution is not solution:
            compiled = _CompiledSolution(solution, self.robot)
            self._compiled[id(solution)] = compiled
        return compiled

    def local_coalition_solutions(
            self, solution: PotentialSolution, sensed: Mapping[str, Iterable[InformationInstance]],
            offers: Mapping[InformationInstance, Iterable[InformationOffer]], *, reply: bool = False,
            cheapest_offers: bool = False, limit: int | None = None,
            new_offers: Mapping[InformationInstance, Iterable[InformationOffer]] | None = None,
            below_cost: float | None = None, at_most_cost: float | None = None,
            answer: InformationInstance | None = None,
    ) -> Iterator[LocalCoalitionSolution]:
        """Every instantiation of ``solution`` by the sensed instances (per sensor, absolute) and
        the offers received (per request label) that satisfies the referent instantiation
        constraint. ``cheapest_offers`` keeps only the cheapest offer per instance (a helper
        needs one way to provide each instance; the local robot may want every coalition).

        With ``new_offers`` (a subset of ``offers``: those received since the last call) only
        the instantiations that use at least one of them are produced, each once -- the
        semi-naive way to update a robot's solutions as offers arrive. With ``below_cost``,
        offers that alone would bring the coalition to that cost or more are not tried (a
        coalition costs at least this robot's schemas plus any one offer's coalition);
        ``at_most_cost`` does the same keeping ties. With ``answer`` (a reply), only the
        instantiations providing that instance are produced."""
        local_cost = round(solution.cost - (self.costs.cs if reply else 0.0), COST_DIGITS)
        compiled = self.compiled(solution)
        cache = self._view_cache(sensed, offers)
        slots: list[_Slot] = []
        for index, (leaf, label, requested) in enumerate(compiled.leaves):
            kind = leaf.kind
            key = (kind, leaf.schema if kind is SchemaKind.ES_EPS else requested, label,
                   cheapest_offers and kind is SchemaKind.CS)
            # What the candidates are built from: kept while that object stays (see _view_cache).
            source = (sensed.get(leaf.schema) if kind is SchemaKind.ES_EPS
                      else offers.get(requested) if kind is SchemaKind.CS else None)
            entry = cache.get(key)
            if entry is not None and entry[0] is source:
                candidates = entry[1]
            else:
                candidates = None
                if kind is SchemaKind.CS and entry is not None and entry[0] is not None and source is not None:
                    candidates = entry[1].extended(entry[0], source, cheapest_offers)
                if candidates is None:
                    candidates = self._candidates(leaf, label, requested, sensed, offers, cheapest_offers)
                cache[key] = (source, candidates)
            if not candidates.entries:
                return
            slots.append(_Slot(index, leaf, label, candidates))
        # Offers that alone bring the coalition to the cost limit are skipped during the join
        # (the candidate lists and their indexes are shared by every solution of this view).
        if below_cost is not None or at_most_cost is not None:
            def affordable(offer: InformationOffer) -> bool:
                if below_cost is not None and not local_cost + offer.cost < below_cost:
                    return False
                return at_most_cost is None or round(local_cost + offer.cost, COST_DIGITS) <= at_most_cost
        else:
            affordable = None
        start: dict[Variable, Entity] = {}
        if answer is not None:
            root = solution.root.output
            bound = None if root is None else bind_to_ground(to_absolute(root, self.robot), answer, {})
            if bound is None:
                return  # this solution never provides ``answer``
            start = bound
        if new_offers is None:
            yield from self._join(solution, slots, reply, limit, start, affordable)
            return
        fresh = {id(offer) for label_offers in new_offers.values() for offer in label_offers}
        produced = 0
        for lcs in self._delta_join(solution, slots, fresh, reply, start, affordable):
            yield lcs
            produced += 1
            if limit is not None and produced >= limit:
                return

    def _view_cache(self, sensed, offers) -> dict:
        """Candidates per leaf: key -> (the readings tuple / offer list they were built from, the
        candidates), reused while a view still holds that very object. Callers never change a
        readings tuple or an offer list in place: the agent's and the search's
        :class:`~.reasoning_caches.OfferBook` hand out a label's list unchanged until an offer of
        that label arrives, and readings are replaced. So an offer rebuilds only the candidates of
        its own label, not those of every leaf as when the cache lasted one view."""
        return self._cache

    @staticmethod
    def _candidates(leaf: SolutionStep, label: InformationInstance, requested: InformationInstance | None, sensed,
                    offers, cheapest_offers: bool) -> _Candidates:
        if leaf.kind is SchemaKind.PRIOR:
            return _Candidates(label, [(label, None)] if label.is_fully_instantiated else [])
        if leaf.kind is SchemaKind.ES_EPS:
            readings = dict.fromkeys(sensed.get(leaf.schema, ()))
            return _Candidates(label, [(instance, None) for instance in readings if answers_request(instance, label)])
        # The leaf's label is the request label up to renaming, so every offer received for the
        # request (checked on receipt) fits the leaf; offers keep arrival order.
        return _Candidates.of_offers(label, offers.get(requested, ()), cheapest_offers)

    def _delta_join(self, solution: PotentialSolution, slots: list['_Slot'], fresh: set[int], reply: bool,
                    start: Mapping[Variable, Entity], affordable) -> Iterator[LocalCoalitionSolution]:
        """Joins in which slot i takes only new offers, earlier slots only old ones (each
        combination with at least one new offer appears exactly once)."""
        offer_slots = [k for k, slot in enumerate(slots) if slot.candidates.has_offers]
        for position, k in enumerate(offer_slots):
            new_here = [c for c in slots[k].candidates.entries if id(c[1]) in fresh]
            if not new_here:
                continue
            restricted = list(slots)
            restricted[k] = slots[k].only(_Candidates(slots[k].label, new_here))
            for earlier in offer_slots[:position]:
                restricted[earlier] = slots[earlier].excluding(fresh)
            yield from self._join(solution, restricted, reply, None, start, affordable)

    def _join(self, solution: PotentialSolution, slots: list['_Slot'], reply: bool, limit: int | None,
              start: Mapping[Variable, Entity] | None = None, affordable=None) -> Iterator[LocalCoalitionSolution]:
        compiled = self.compiled(solution)
        chosen: dict[int, tuple[InformationInstance, InformationOffer | None]] = {}
        local_cost = round(solution.cost - (self.costs.cs if reply else 0.0), COST_DIGITS)

        def search(remaining: tuple[int, ...], binding: dict[Variable, Entity]) -> Iterator[LocalCoalitionSolution]:
            if not remaining:
                # Every instance of the solution must be fully instantiated, entities distinct,
                # and a schema's inputs distinct pieces of information (a task needing F_B(local)
                # and F_B(Y) needs a teammate Y, not this robot twice).
                for instance in compiled.instances:
                    bound = instance.substitute(binding)
                    if not bound.is_fully_instantiated or bound.is_degenerate:
                        return
                for group in compiled.input_groups:
                    if len({instance.substitute(binding) for instance in group}) != len(group):
                        return
                sources = tuple((slot.leaf, *chosen[slot.index]) for slot in slots)
                binding_items = tuple(sorted(binding.items(), key=lambda kv: kv[0].name))
                yield LocalCoalitionSolution(self.robot, solution, binding_items, sources, reply, local_cost)
                return
            # The leaf with the fewest candidates consistent with the binding is extended next.
            options = [(len(found), k, found) for k in remaining for found in (slots[k].consistent(binding),)]
            _, k, found = min(options, key=lambda option: (option[0], option[1]))
            rest = tuple(other for other in remaining if other != k)
            slot = slots[k]
            for instance, offer in found:
                if offer is not None and ((slot.excluded is not None and id(offer) in slot.excluded)
                                          or (affordable is not None and not affordable(offer))):
                    continue
                extended = bind_to_ground(slot.label, instance, binding)
                if extended is None:
                    continue
                chosen[slot.index] = (instance, offer)
                yield from search(rest, extended)

        produced = 0
        for lcs in search(tuple(range(len(slots))), dict(start or {})):
            yield lcs
            produced += 1
            if limit is not None and produced >= limit:
                return

    def coalition(self, lcs: LocalCoalitionSolution) -> CoalitionSolution:
        """The coalition solution rooted at this robot's LCS, with its coalition cost."""
        return CoalitionSolution(lcs, coalition_cost(lcs, self.helper_motor_schema_cost), coalition_members(lcs))

    def offer(self, request: InformationRequest, lcs: LocalCoalitionSolution) -> InformationOffer:
        """The offer answering ``request`` with the reply LCS ``lcs``."""
        answer = lcs.answer
        if answer is None or not answers_request(answer, request.label):
            raise RequestError(f'{self.robot}: {answer} does not answer {request.label}')
        return InformationOffer(self.robot, request.label, answer, lcs,
                                coalition_cost(lcs, self.helper_motor_schema_cost, root_is_helped=False))


__all__ = ['RobotReasoner', 'SearchPlan']
