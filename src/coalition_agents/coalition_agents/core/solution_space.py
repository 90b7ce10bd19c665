"""Solution spaces (Algorithm 1) and potential solutions in non-descending cost.

Paper, Sections IV-C and IV-G:

* A *solution space* is an and-or tree whose root (an MS, or a CS that answers a request)
  needs information instances; each instance can be provided by alternative schemas (the
  tOR choice, :class:`RequirementNode`); each schema (:class:`SchemaNode`) needs all of its
  inputs. Leaves are ES-EPS pairs (or prior sources) and CSs.
* Algorithm 1 expands every required instance recursively: ES-EPS pairs that retrieve it,
  RPSs/PSs that produce it (their inputs expanded in turn) and a CS that requests it,
  subject to the *referent instantiation constraint* (:meth:`Conversion.inputs_for`,
  :func:`match_template`) and three constraints:

  - Generality Imposition (GI): an RPS may not produce an instance that is less or as
    general (Definition 4.3) as an instance the same RPS produces downstream on the same
    branching path (:func:`generality_imposition_allows`; Lemma 4.2: spaces are finite);
  - Localness in Reasoning (LR): no schema but a CS provides an instance none of whose
    referents is the local robot, unless all its referents are non-robot entities
    (:func:`localness_allows`);
  - External Communication (EC): a CS is used only when some referent is not the local
    robot (:func:`external_communication_allows`).

* A *potential solution* picks one alternative at every tOR node (:class:`PotentialSolution`);
  its cost is the sum of its schemas' costs. :meth:`SolutionSpace.iter_potential_solutions`
  yields them in non-descending cost (lazy k-best enumeration over the and-or DAG, so the
  first solutions of a huge space are cheap to get) and drops a solution when a cheaper
  (or equally cheap, earlier) one needs the same information -- the same set of sensed and
  communicated instances, up to renaming of its own variables (Section V-A-1: "potential
  solutions that require the same set of information instances with higher costs can be
  removed ... without affecting the completeness").

Generation is memoised per (required instance, GI context): equal sub-problems share one
node, so the tree is stored as a DAG and robots with equal capabilities share one generator
(:class:`SolutionSpaceCache`). Everything is deterministic: alternatives are tried in the
order sensors (capability-file order, then priors), library RPSs, robot PSs, CS.

Choices where the paper is silent (documented here and in ``core/__init__``):

* An instance with no referents (F_M) counts as "all referents non-robot" for LR, and may
  be requested by a CS (EC's intent is "do not request information about yourself").
* Fresh variables are named after the RPS's own variable (RPS3's ``Z``), with a number if
  that name is taken, so printed solutions read like Table III.
"""
from __future__ import annotations

import heapq
import itertools
import math
from dataclasses import dataclass, field
from typing import Iterator, Sequence

from .capabilities import RobotCapabilities
from .errors import CoalitionError
from .information import InformationInstance, Variable, fresh_variable
from .potential_solutions import (
    COST_DIGITS, PotentialSolution, RequirementNode, SchemaNode, SolutionStep, placeholder_robots, rename_entities,
)
from .schemas import Conversion, Costs, SchemaKind, SchemaLibrary, SensorSchema
from .solution_constraints import (
    Constraints, GIContext, external_communication_allows, generality_imposition_allows, localness_allows,
)


# --- Lazy k-best over the and-or DAG ---------------------------------------------------------

def _cost_key(cost: float) -> float:
    return round(cost, COST_DIGITS)


class _Ranker:
    """The k-th cheapest sub-solution of every node, computed lazily and cached by node uid.

    A schema node's sub-solution is a tuple of indices into its inputs' rankings; a
    requirement node's is (option index, index into that option's ranking). Ties are broken
    by these index tuples, so the order is deterministic.
    """

    def __init__(self) -> None:
        self._ranked: dict[int, list[tuple[float, tuple]]] = {}
        self._heaps: dict[int, list] = {}
        self._seen: dict[int, set] = {}

    def kth(self, node: SchemaNode | RequirementNode, k: int) -> tuple[float, tuple] | None:
        ranked = self._ranked.get(node.uid)
        if ranked is None:
            ranked = self._start(node)
        while len(ranked) <= k:
            if not self._advance(node, ranked):
                return None
        return ranked[k]

    def _and_cost(self, node: SchemaNode, indices: tuple[int, ...]) -> float | None:
        total = node.cost
        for child, index in zip(node.inputs, indices):
            entry = self.kth(child, index)
            if entry is None:
                return None
            total += entry[0]
        return total

    def _start(self, node: SchemaNode | RequirementNode) -> list:
        ranked: list = []
        self._ranked[node.uid] = ranked
        heap: list = []
        if isinstance(node, SchemaNode):
            start = (0,) * len(node.inputs)
            cost = self._and_cost(node, start)
            self._seen[node.uid] = {start}
            if cost is not None:
                heap.append((_cost_key(cost), start, cost))
        else:
            for index, option in enumerate(node.options):
                entry = self.kth(option, 0)
                if entry is not None:
                    heap.append((_cost_key(entry[0]), (index, 0), entry[0]))
            heapq.heapify(heap)
        self._heaps[node.uid] = heap
        return ranked

    def _advance(self, node: SchemaNode | RequirementNode, ranked: list) -> bool:
        heap = self._heaps[node.uid]
        if not heap:
            return False
        _, choice, cost = heapq.heappop(heap)
        ranked.append((cost, choice))
        if isinstance(node, SchemaNode):
            seen = self._seen[node.uid]
            for position in range(len(choice)):
                successor = choice[:position] + (choice[position] + 1,) + choice[position + 1:]
                if successor in seen:
                    continue
                seen.add(successor)
                successor_cost = self._and_cost(node, successor)
                if successor_cost is not None:
                    heapq.heappush(heap, (_cost_key(successor_cost), successor, successor_cost))
        else:
            option_index, sub_index = choice
            entry = self.kth(node.options[option_index], sub_index + 1)
            if entry is not None:
                heapq.heappush(heap, (_cost_key(entry[0]), (option_index, sub_index + 1), entry[0]))
        return True


# --- The generator (Algorithm 1) ------------------------------------------------------------------

@dataclass
class GenerationStats:
    """Work done by a generator (memo misses = requirement nodes actually expanded)."""

    expansions: int = 0
    memo_hits: int = 0
    schema_nodes: int = 0


class SolutionSpaceGenerator:
    """Algorithm 1 for one robot's capabilities (plus extra sensors such as task priors)."""

    def __init__(self, library: SchemaLibrary, capabilities: RobotCapabilities, costs: Costs, *,
                 extra_sensors: Sequence[SensorSchema] = (), constraints: Constraints = Constraints(),
                 max_depth: int | None = None):
        if not constraints.generality_imposition and max_depth is None:
            raise CoalitionError('without the Generality Imposition constraint the solution space is '
                                 'infinite (Lemma 4.2); give max_depth to bound it')
        self.library = library
        self.capabilities = capabilities
        self.costs = costs
        self.constraints = constraints
        self.max_depth = max_depth
        self.sensors: tuple[SensorSchema, ...] = tuple(capabilities.sensors) + tuple(extra_sensors)
        self.conversions: tuple[Conversion, ...] = tuple(library.reductions) + tuple(capabilities.perceptual_schemas)
        cheapest_other = min(costs.of(kind) for kind in (SchemaKind.ES_EPS, SchemaKind.CS, SchemaKind.RPS, SchemaKind.PS))
        self._prior_is_cheapest = costs.prior <= cheapest_other
        self.stats = GenerationStats()
        self._memo: dict[tuple, RequirementNode | None] = {}
        self._uids = itertools.count()
        self._replies: dict[tuple[InformationInstance, int | None], list[PotentialSolution]] = {}
        self.ranker = _Ranker()

    # Algorithm 1 -----------------------------------------------------------------------
    def expand(self, instance: InformationInstance, downstream: GIContext = frozenset(),
               depth: int = 0) -> RequirementNode | None:
        """The tOR node of every way to provide ``instance`` here, or None if there is none."""
        key = (instance, downstream, depth if self.max_depth is not None else None)
        if key in self._memo:
            self.stats.memo_hits += 1
            return self._memo[key]
        self.stats.expansions += 1
        options: list[SchemaNode] = []
        constraints = self.constraints
        given = self._given_a_priori(instance)
        if given is not None:
            # A priori information is given: its dummy sensor needs no information, is always
            # available and costs no more than any alternative; the instance is fully
            # instantiated, so the choice is independent of the rest of the solution and the
            # alternatives could only be dominated solutions.
            node = RequirementNode(next(self._uids), instance,
                                   (self._node(given.kind, given.sensor, instance, (), ()),))
            self._memo[key] = node
            return node
        if not constraints.localness_in_reasoning or localness_allows(instance):
            for sensor in self.sensors:
                if sensor.retrieves(instance):
                    options.append(self._node(sensor.kind, sensor.sensor, instance, (), ()))
            if self.max_depth is None or depth < self.max_depth:
                for conversion in self.conversions:
                    option = self._conversion_option(conversion, instance, downstream, depth)
                    if option is not None:
                        options.append(option)
        if not constraints.external_communication or external_communication_allows(instance):
            options.append(self._node(SchemaKind.CS, 'CS', instance, (), ()))
        node = RequirementNode(next(self._uids), instance, tuple(options)) if options else None
        self._memo[key] = node
        return node

    def _given_a_priori(self, instance: InformationInstance) -> SensorSchema | None:
        if not instance.is_fully_instantiated:
            return None
        for sensor in self.sensors:
            if sensor.kind is SchemaKind.PRIOR and sensor.output == instance and self._prior_is_cheapest:
                return sensor
        return None

    def _conversion_option(self, conversion: Conversion, instance: InformationInstance,
                           downstream: GIContext, depth: int) -> SchemaNode | None:
        populated = conversion.inputs_for(instance)
        if populated is None:
            return None
        inputs, fresh = populated
        compared = inputs if self.constraints.generality_reading == 'inputs' else (instance,)
        if (self.constraints.generality_imposition
                and not generality_imposition_allows(conversion.name, compared, downstream)):
            return None
        upstream = downstream | {(conversion.name, i.label, i.instantiated_positions) for i in compared}
        children = []
        for required in inputs:
            child = self.expand(required, upstream, depth + 1)
            if child is None:
                return None  # an input nobody can provide: this conversion is a dead end
            children.append(child)
        return self._node(conversion.kind, conversion.name, instance, tuple(children), fresh)

    def _node(self, kind: SchemaKind, schema: str, output: InformationInstance | None,
              inputs: tuple[RequirementNode, ...], fresh: tuple[Variable, ...], cost: float | None = None) -> SchemaNode:
        self.stats.schema_nodes += 1
        return SchemaNode(next(self._uids), kind, schema, output, inputs, fresh,
                          self.costs.of(kind) if cost is None else cost)

    # Roots ----------------------------------------------------------------------------------
    def motor_schema_space(self, motor_schema: str, requirements: Sequence[InformationInstance]) -> 'SolutionSpace':
        """The space of an MS root needing ``requirements`` (the task's inputs)."""
        children = [(instance, self.expand(instance)) for instance in requirements]
        missing = tuple(instance for instance, child in children if child is None)
        root = None if missing else self._node(
            SchemaKind.MS, motor_schema, None, tuple(child for _, child in children), (),
            self.costs.motor_schema(motor_schema))
        fixed = frozenset(v.name for instance in requirements for v in instance.variables)
        return SolutionSpace(self, root, fixed, missing, tuple(requirements))

    def reply_solutions(self, instance: InformationInstance, limit: int | None = None) -> list[PotentialSolution]:
        """The potential solutions of :meth:`request_space` (``limit``: the first ones), memoised.

        Requests differ in the teammates they name (F_R(robot_3, local), F_R(robot_7, local),
        ...) but not in the schemas that answer them: the space of a request naming teammates is
        generated once with placeholders for them (:func:`placeholder_robots`) and renamed for
        each request, which gives the same solutions in the same order as generating it for the
        request itself."""
        key = (instance, limit)
        found = self._replies.get(key)
        if found is None:
            canonical, names = placeholder_robots(instance)
            shared = self._replies.get((canonical, limit))
            if shared is None:
                shared = self._replies[(canonical, limit)] = self.request_space(canonical).potential_solutions(limit)
            found = [rename_entities(solution, names) for solution in shared] if names else shared
            self._replies[key] = found
        return found

    def request_space(self, instance: InformationInstance) -> 'SolutionSpace':
        """The space of a CS root that answers a request for ``instance`` (in the local frame)."""
        child = self.expand(instance)
        root = None if child is None else self._node(SchemaKind.CS, 'CS', instance, (child,), ())
        fixed = frozenset(v.name for v in instance.variables)
        return SolutionSpace(self, root, fixed, () if child else (instance,), (instance,))


class SolutionSpace:
    """The and-or tree rooted at an MS or a reply CS, with its potential solutions."""

    def __init__(self, generator: SolutionSpaceGenerator, root: SchemaNode | None,
                 fixed_variables: frozenset[str], unsatisfiable: tuple[InformationInstance, ...],
                 requirements: tuple[InformationInstance, ...]):
        self.generator = generator
        self.root = root
        self.fixed_variables = fixed_variables
        self.unsatisfiable = unsatisfiable
        self.requirements = requirements
        self._kept: list[PotentialSolution] = []
        self._pending: Iterator[PotentialSolution] | None = None

    @property
    def is_empty(self) -> bool:
        return self.root is None

    # Size --------------------------------------------------------------------------------------
    def _nodes(self) -> Iterator[SchemaNode | RequirementNode]:
        if self.root is None:
            return
        seen: set[int] = set()
        stack: list[SchemaNode | RequirementNode] = [self.root]
        while stack:
            node = stack.pop()
            if node.uid in seen:
                continue
            seen.add(node.uid)
            yield node
            stack.extend(node.inputs if isinstance(node, SchemaNode) else node.options)

    def distinct_node_count(self) -> int:
        """Schema and tOR nodes stored (shared sub-trees counted once)."""
        return sum(1 for _ in self._nodes())

    def tree_size(self) -> int:
        """Schema nodes of the fully expanded and-or tree (what Section IV-H bounds)."""
        return self._fold(leaf=lambda node: 1, combine_and=lambda node, sizes: 1 + sum(sizes),
                          combine_or=lambda node, sizes: sum(sizes))

    def count_potential_solutions(self) -> int:
        """Number of potential solutions before dominance removal (products and sums, exact)."""
        return self._fold(leaf=lambda node: 1, combine_and=lambda node, counts: math.prod(counts),
                          combine_or=lambda node, counts: sum(counts))

    def _fold(self, leaf, combine_and, combine_or) -> int:
        if self.root is None:
            return 0
        values: dict[int, int] = {}
        # Post-order without recursion limits: children before parents.
        order: list[SchemaNode | RequirementNode] = []
        stack: list[tuple[SchemaNode | RequirementNode, bool]] = [(self.root, False)]
        while stack:
            node, expanded = stack.pop()
            if node.uid in values:
                continue
            if expanded:
                children = node.inputs if isinstance(node, SchemaNode) else node.options
                child_values = [values[child.uid] for child in children]
                if isinstance(node, SchemaNode):
                    values[node.uid] = leaf(node) if not children else combine_and(node, child_values)
                else:
                    values[node.uid] = combine_or(node, child_values)
                order.append(node)
                continue
            stack.append((node, True))
            children = node.inputs if isinstance(node, SchemaNode) else node.options
            stack.extend((child, False) for child in children if child.uid not in values)
        return values[self.root.uid]

    # Potential solutions -------------------------------------------------------------------
    def iter_potential_solutions(self, remove_dominated: bool = True) -> Iterator[PotentialSolution]:
        """Potential solutions in non-descending cost (optionally without dominated ones)."""
        if self.root is None:
            return
        ranker = self.generator.ranker
        seen: set[tuple] = set()
        for rank in itertools.count():
            entry = ranker.kth(self.root, rank)
            if entry is None:
                return
            cost, choice = entry
            step = self._build(self.root, choice, {}, set(self.fixed_variables))
            solution = PotentialSolution(step, round(cost, COST_DIGITS), rank, self.fixed_variables)
            if remove_dominated:
                key = solution.information
                if key in seen:
                    continue
                seen.add(key)
            yield solution

    def potential_solutions(self, limit: int | None = None, remove_dominated: bool = True) -> list[PotentialSolution]:
        """The first ``limit`` (all if None) potential solutions in non-descending cost.

        The non-dominated ones are extracted once and kept: every request a robot serves asks
        for the same space again, and gets the same solution objects back.
        """
        if not remove_dominated:
            return list(itertools.islice(self.iter_potential_solutions(False), limit))
        if self._pending is None:
            self._pending = self.iter_potential_solutions(True)
        while self._pending is not None and (limit is None or len(self._kept) < limit):
            solution = next(self._pending, None)
            if solution is None:
                self._pending = iter(())
                break
            self._kept.append(solution)
        return self._kept[:limit] if limit is not None else list(self._kept)

    def _build(self, node: SchemaNode, choice: tuple, renaming: dict[Variable, Variable],
               used: set[str]) -> SolutionStep:
        """Turn a ranked choice into concrete steps, renaming clashing fresh variables apart."""
        inner = renaming
        if node.fresh:
            inner = dict(renaming)
            for variable in node.fresh:
                new = fresh_variable(variable.name, used)
                used.add(new.name)
                if new != variable:
                    inner[variable] = new
        output = None if node.output is None else node.output.substitute(renaming)
        steps = []
        ranker = self.generator.ranker
        for requirement, index in zip(node.inputs, choice):
            entry = ranker.kth(requirement, index)
            assert entry is not None
            option_index, sub_index = entry[1]
            option = requirement.options[option_index]
            sub = ranker.kth(option, sub_index)
            assert sub is not None
            steps.append(self._build(option, sub[1], inner, used))
        return SolutionStep(node.kind, node.schema, output, tuple(steps), node.cost)


# --- Sharing generators between robots --------------------------------------------------------

@dataclass
class SolutionSpaceCache:
    """One generator per distinct (capabilities, extra sensors, constraints): robots of the same
    type reuse each other's memoised sub-trees and rankings."""

    library: SchemaLibrary
    costs: Costs
    constraints: Constraints = Constraints()
    max_depth: int | None = None
    _generators: dict = field(default_factory=dict)

    def generator(self, capabilities: RobotCapabilities,
                  extra_sensors: Sequence[SensorSchema] = ()) -> SolutionSpaceGenerator:
        key = (capabilities.reasoning_key, tuple(extra_sensors))
        generator = self._generators.get(key)
        if generator is None:
            generator = SolutionSpaceGenerator(self.library, capabilities, self.costs,
                                               extra_sensors=extra_sensors, constraints=self.constraints,
                                               max_depth=self.max_depth)
            self._generators[key] = generator
        return generator

    def __len__(self) -> int:
        return len(self._generators)
