"""The distributed coalition search of Algorithm 2, simulated for a team in one process.

Each robot runs a :class:`~.coalition.RobotReasoner`. Messages (requests and offers) are
delivered in FIFO order, so a run is deterministic. What the robots' sensors retrieve in the
current situation comes from a :class:`SensingModel` (in tests a table of readings; in the
simulation, later, the bridge) -- this is where the configuration of the robots decides
which coalitions are executable.

Per robot, as in Algorithm 2 with unlimited search time ("given sufficient search time"):

1. an initiating robot creates its task's solution space and takes its potential solutions
   in non-descending cost; for each one it activates the ES-EPS pairs and sends the CS
   requests (each label once: Distinct Requests);
2. a robot receiving a request creates the solution space of every variant it can provide
   (footnote 9) and does the same; whenever its information becomes retrievable (or cheaper)
   it sends an offer with its coalition solution;
3. when no message is left, each initiating robot instantiates its potential solutions with
   what it sensed and was offered: the feasible ones are its executable coalitions, in
   non-descending coalition cost (the paper then negotiates the cheapest; that is the node's
   job).

Efficiency without changing the result (each helper still offers its cheapest solution for
every instance it can provide): messages are delivered in rounds and a service re-instantiates
only the potential solutions whose offers changed, combining only the new offers with the old
(semi-naive, :meth:`RobotReasoner.local_coalition_solutions` ``new_offers``); a reply space for a
fully instantiated instance stops activating (and requesting for) its potential solutions once
one that needs no request provides the instance at most as cheaply, and ignores offers that
cannot beat its best answer. ``potential_solution_limit`` caps the solutions checked per space,
as the paper's search time does; a complete search of the 20-robot column of Fig. 9 exchanges
about 86,000 messages (minutes in one process), with a limit of 4 about 44,000 (seconds).

Messages stop because each robot sends each request label once and re-sends an offer only when
it became strictly cheaper (all reasoning schemas cost > 0). With ``distinct_requests=False``
every activation sends its requests again and every request is served anew, so mutually
dependent robots request each other forever; ``max_messages`` then stops the run with a
:class:`~.errors.SearchError` -- the loop the Distinct Requests constraint prevents.
"""
from __future__ import annotations

import collections
from dataclasses import dataclass, field
from typing import Iterable, Mapping, Protocol, Sequence

from .capabilities import RobotCapabilities
from .coalition import RobotReasoner
from .coalition_solution import (
    CoalitionSolution, InformationOffer, LocalCoalitionSolution, cheapest_per_members, coalition_cost,
    sort_coalitions,
)
from .errors import CoalitionError, InformationError, SearchError
from .information import InformationInstance, check_entity_name
from .reasoning_caches import AnswerMemo, OfferBook
from .requests import InformationRequest, addressees
from .schemas import Costs, SchemaLibrary
from .solution_space import Constraints, PotentialSolution, SolutionSpaceCache
from .tasks import Task


class SensingModel(Protocol):
    """What robot ``robot``'s sensor ``sensor`` retrieves now (fully instantiated, absolute)."""

    def readings(self, robot: str, sensor: str) -> Iterable[InformationInstance]:
        ...


@dataclass(frozen=True)
class StaticSensing:
    """A fixed table of readings: robot -> sensor -> instances (e.g. F_R(robot_2, robot_1))."""

    table: Mapping[str, Mapping[str, tuple[InformationInstance, ...]]]

    def readings(self, robot: str, sensor: str) -> tuple[InformationInstance, ...]:
        return tuple(self.table.get(robot, {}).get(sensor, ()))

    @classmethod
    def from_text(cls, table: Mapping[str, Mapping[str, Sequence[str]]], library: SchemaLibrary,
                  robots: Sequence[str]) -> 'StaticSensing':
        """Parse ``{'robot_1': {'fiducial': ['F_R(robot_2, robot_1)']}}``; readings must be fully
        instantiated and name robots of the team or library objects."""
        parsed: dict[str, dict[str, tuple[InformationInstance, ...]]] = {}
        for robot, sensors in table.items():
            for sensor, texts in sensors.items():
                instances = []
                for index, text in enumerate(texts):
                    try:
                        instance = library.parse(text, robots)
                    except InformationError as exc:
                        raise CoalitionError(f'readings.{robot}.{sensor}[{index}]: {exc}') from None
                    if not instance.is_fully_instantiated or instance.has_local:
                        raise CoalitionError(f'readings.{robot}.{sensor}[{index}]: a reading names '
                                             f'entities only, no variables or local (got {instance})')
                    instances.append(instance)
                parsed.setdefault(robot, {})[sensor] = tuple(instances)
        return cls(parsed)


@dataclass
class SearchStats:
    """Message counts and reasoning work of one search (Fig. 9 reports messages per robot)."""

    requests_sent: collections.Counter = field(default_factory=collections.Counter)
    request_deliveries: int = 0
    offers_sent: collections.Counter = field(default_factory=collections.Counter)
    duplicate_requests_suppressed: collections.Counter = field(default_factory=collections.Counter)
    solution_spaces: collections.Counter = field(default_factory=collections.Counter)

    @property
    def messages(self) -> int:
        return self.request_deliveries + sum(self.offers_sent.values())

    def to_dict(self) -> dict:
        return {'messages': self.messages, 'request_deliveries': self.request_deliveries,
                'requests_sent': dict(self.requests_sent), 'offers_sent': dict(self.offers_sent),
                'duplicate_requests_suppressed': dict(self.duplicate_requests_suppressed),
                'solution_spaces': dict(self.solution_spaces)}


@dataclass(frozen=True)
class CoalitionResult:
    """An initiating robot's executable coalitions, cheapest first."""

    robot: str
    task: str
    potential_solutions: tuple[PotentialSolution, ...]
    coalitions: tuple[CoalitionSolution, ...]

    @property
    def best(self) -> CoalitionSolution | None:
        return self.coalitions[0] if self.coalitions else None

    def per_members(self) -> list[CoalitionSolution]:
        """The cheapest coalition for each distinct set of robots."""
        return cheapest_per_members(self.coalitions)


class _Service:
    """One solution space a robot searches: its task (root) or a variant of a request."""

    def __init__(self, variant: InformationInstance | None, solutions: list[PotentialSolution]):
        self.variant = variant
        self.solutions = solutions
        self.subscribers: list[InformationRequest] = []
        self.sent: dict[tuple[int, InformationInstance], float] = {}
        #: request label -> indices of the potential solutions with a CS leaf for it
        self.uses: dict[InformationInstance, list[int]] = collections.defaultdict(list)
        #: per potential solution: answer -> (offer cost, LCS)
        self.answers: dict[int, dict[InformationInstance, tuple[float, LocalCoalitionSolution]]] = {}
        self.dirty: set[int] = set()   # solutions with new offers since their last evaluation
        self.fresh: set[int] = set()   # activated solutions never evaluated yet
        self.new_subscriber = False

    def best(self) -> dict[InformationInstance, tuple[float, LocalCoalitionSolution]]:
        """The cheapest (offer cost, LCS) per answer over all solutions (earlier solution on ties)."""
        best: dict[InformationInstance, tuple[float, LocalCoalitionSolution]] = {}
        for index in sorted(self.answers):
            for answer, (cost, lcs) in self.answers[index].items():
                if answer not in best or cost < best[answer][0]:
                    best[answer] = (cost, lcs)
        return best

    def bound(self) -> float | None:
        """For a fully instantiated variant: the cost of its one answer found so far."""
        if self.variant is None or not self.variant.is_fully_instantiated:
            return None
        costs = [cost for answers in self.answers.values() for cost, _ in answers.values()]
        return min(costs) if costs else None


class _Agent:
    def __init__(self, reasoner: RobotReasoner):
        self.reasoner = reasoner
        #: replaced (never changed in place) when a sensor is read: the reasoner keeps its candidate
        #: lists for as long as it gets the same readings and offer view objects
        self.readings: dict[str, tuple[InformationInstance, ...]] = {}
        #: request label -> (provider, instance) -> offer, the view memoised (as the node's agent's)
        self.offers: OfferBook[InformationOffer] = OfferBook()
        self.services: dict[InformationInstance, _Service] = {}
        self.all_services: list[_Service] = []
        self.users: dict[InformationInstance, list[_Service]] = collections.defaultdict(list)
        self.delta: dict[InformationInstance, list[InformationOffer]] = {}
        self.root: _Service | None = None

    def offer_view(self) -> dict[InformationInstance, list[InformationOffer]]:
        return self.offers.view()


class CoalitionSearch:
    """Runs the request/offer exchange of a team for one task until no message is left."""

    def __init__(self, library: SchemaLibrary, costs: Costs, task: Task, team: Mapping[str, RobotCapabilities],
                 sensing: SensingModel, *, constraints: Constraints = Constraints(),
                 distinct_requests: bool = True, max_messages: int = 200_000,
                 potential_solution_limit: int | None = None,
                 focus: Sequence[InformationInstance] | None = None):
        if not team:
            raise CoalitionError('team: at least one robot is needed')
        for robot in team:
            check_entity_name(robot)
        self.library = library
        self.task = task
        self.team = tuple(team)
        self.sensing = sensing
        self.distinct_requests = distinct_requests
        self.max_messages = max_messages
        self.focus = focus
        self.stats = SearchStats()
        cache = SolutionSpaceCache(library, costs, constraints)
        self.agents = {robot: _Agent(RobotReasoner(robot, capabilities, library, costs, task, cache=cache,
                                                   constraints=constraints,
                                                   potential_solution_limit=potential_solution_limit))
                       for robot, capabilities in team.items()}
        self._queue: collections.deque = collections.deque()
        #: answers_request remembered (reasoning_caches, as the node's agent's)
        self._answers = AnswerMemo()

    # Public -------------------------------------------------------------------------------------
    def run(self, initiators: Sequence[str]) -> dict[str, CoalitionResult]:
        """Search coalitions for the task on each initiating robot (all at once, as in the paper)."""
        for robot in initiators:
            if robot not in self.agents:
                raise CoalitionError(f"initiator '{robot}' is not in the team ({', '.join(self.team)})")
        for robot in initiators:
            agent = self.agents[robot]
            solutions = agent.reasoner.task_solutions(self.focus)
            agent.root = _Service(None, solutions)
            self.stats.solution_spaces[robot] += 1
            self._activate(agent, agent.root, chain=())
        self._drain()
        return {robot: self._result(self.agents[robot]) for robot in initiators}

    # Message handling -------------------------------------------------------------------------
    def _drain(self) -> None:
        """Deliver messages in rounds (FIFO); after each round every service whose information
        changed is evaluated once, in team and creation order (deterministic)."""
        delivered = 0
        while self._queue:
            batch = list(self._queue)
            self._queue.clear()
            for kind, recipient, message in batch:
                delivered += 1
                if delivered > self.max_messages:
                    raise SearchError(
                        f'coalition search stopped after {self.max_messages} messages (max_messages): '
                        f'requests keep propagating -- a request loop, which the Distinct Requests '
                        f'constraint prevents (distinct_requests={self.distinct_requests})')
                if kind == 'request':
                    self._on_request(self.agents[recipient], message)
                else:
                    self._on_offer(self.agents[recipient], message)
            for agent in self.agents.values():
                for service in agent.all_services:
                    if service.dirty or service.fresh or service.new_subscriber:
                        self._evaluate(agent, service)
                agent.delta.clear()

    def _send_requests(self, agent: _Agent, solution: PotentialSolution, chain: tuple) -> None:
        reasoner = agent.reasoner
        labels = reasoner.request_labels(solution)
        if self.distinct_requests:
            requests = reasoner.requests_to_send(solution, chain)
            self.stats.duplicate_requests_suppressed[reasoner.robot] += len(labels) - len(requests)
        else:
            requests = [InformationRequest(reasoner.robot, label, chain) for label in labels]
        for request in requests:
            self.stats.requests_sent[reasoner.robot] += 1
            for recipient in addressees(request.label, self.team):
                self.stats.request_deliveries += 1
                self._queue.append(('request', recipient, request))

    def _activate(self, agent: _Agent, service: _Service, chain: tuple, indices: Iterable[int] | None = None) -> None:
        """Temporarily activate the ES-EPS pairs and send the CS requests of the given solutions."""
        reasoner = agent.reasoner
        for index in (range(len(service.solutions)) if indices is None else indices):
            solution = service.solutions[index]
            service.fresh.add(index)
            for sensor, _ in reasoner.sensing_needs(solution):
                if sensor not in agent.readings:
                    agent.readings = {**agent.readings, sensor: tuple(self.sensing.readings(reasoner.robot, sensor))}
            for label in reasoner.request_labels(solution):
                if not service.uses[label]:
                    agent.users[label].append(service)
                service.uses[label].append(index)
            self._send_requests(agent, solution, chain)

    def _activate_reply(self, agent: _Agent, service: _Service, chain: tuple) -> None:
        """Check a reply space's solutions in non-descending cost (Algorithm 2). For a fully
        instantiated variant there is one answer: once a solution that needs no request
        provides it, solutions that cost at least as much cannot offer it more cheaply and are
        never activated (no requests sent for them)."""
        if service.variant is None or not service.variant.is_fully_instantiated:
            self._activate(agent, service, chain)
            return
        for index, solution in enumerate(service.solutions):
            bound = service.bound()
            if bound is not None and solution.cost - agent.reasoner.costs.cs >= bound:
                break
            self._activate(agent, service, chain, (index,))
            if not agent.reasoner.request_labels(solution):
                self._evaluate_solutions(agent, service, [index], None)

    def _on_request(self, agent: _Agent, request: InformationRequest) -> None:
        reasoner = agent.reasoner
        for variant in reasoner.variants(request):
            service = agent.services.get(variant) if self.distinct_requests else None
            if service is None:
                service = _Service(variant, reasoner.reply_solutions(variant))
                self.stats.solution_spaces[reasoner.robot] += 1
                agent.all_services.append(service)
                if self.distinct_requests:
                    agent.services[variant] = service
                service.subscribers.append(request)
                self._activate_reply(agent, service, request.extended_chain)
            else:
                service.subscribers.append(request)
            service.new_subscriber = True

    def _on_offer(self, agent: _Agent, offer: InformationOffer) -> None:
        if not self._answers(offer.instance, offer.request):
            return  # not an instance of what was requested: dropped (a node logs it)
        key = (offer.provider, offer.instance)
        kept = agent.offers.get(offer.request, key)
        if kept is not None and kept.cost <= offer.cost:
            return
        agent.offers.put(offer.request, key, offer)
        agent.delta.setdefault(offer.request, []).append(offer)
        for service in agent.users.get(offer.request, ()):
            service.dirty.update(service.uses[offer.request])

    def _evaluate_solutions(self, agent: _Agent, service: _Service, indices: Iterable[int],
                            delta: Mapping[InformationInstance, list[InformationOffer]] | None) -> None:
        """Instantiate solutions: all combinations (``delta`` None) or only those using new offers."""
        reasoner = agent.reasoner
        offers = agent.offer_view()
        for index in indices:
            service.dirty.discard(index)
            service.fresh.discard(index)
            bound = service.bound()
            local_cost = service.solutions[index].cost - reasoner.costs.cs
            if bound is not None and local_cost >= bound:
                continue  # cannot provide the one answer more cheaply
            answers = {} if delta is None else service.answers.setdefault(index, {})
            for lcs in reasoner.local_coalition_solutions(service.solutions[index], agent.readings, offers,
                                                          reply=True, cheapest_offers=True, new_offers=delta,
                                                          below_cost=bound):
                answer = lcs.answer
                assert answer is not None
                cost = coalition_cost(lcs, reasoner.helper_motor_schema_cost, root_is_helped=False)
                if answer not in answers or cost < answers[answer][0]:
                    answers[answer] = (cost, lcs)
            service.answers[index] = answers

    def _evaluate(self, agent: _Agent, service: _Service) -> None:
        """Update the changed potential solutions; send every subscriber each instance this
        service can now provide more cheaply than before."""
        service.new_subscriber = False
        if service is agent.root:
            service.dirty.clear()
            service.fresh.clear()
            return  # the local robot instantiates its task's solutions once, at the end
        fresh = sorted(service.fresh)
        self._evaluate_solutions(agent, service, fresh, None)
        self._evaluate_solutions(agent, service, sorted(service.dirty - set(fresh)), agent.delta)
        reasoner = agent.reasoner
        best = service.best()
        for position, request in enumerate(service.subscribers):
            for answer in sorted(best, key=str):
                if not self._answers(answer, request.label):
                    continue
                cost, lcs = best[answer]
                previous = service.sent.get((position, answer))
                if previous is not None and previous <= cost:
                    continue
                service.sent[(position, answer)] = cost
                self.stats.offers_sent[reasoner.robot] += 1
                self._queue.append(('offer', request.requester, reasoner.offer(request, lcs)))

    def _result(self, agent: _Agent) -> CoalitionResult:
        reasoner = agent.reasoner
        root = agent.root
        assert root is not None
        offers = agent.offer_view()
        coalitions = [reasoner.coalition(lcs) for solution in root.solutions
                      for lcs in reasoner.local_coalition_solutions(solution, agent.readings, offers)]
        return CoalitionResult(reasoner.robot, self.task.name, tuple(root.solutions),
                               tuple(sort_coalitions(coalitions)))
