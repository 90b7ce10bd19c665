"""One robot's distributed Algorithm 2: what a ``schema_agent`` senses, requests and offers next.

:class:`~.coalition_search.CoalitionSearch` runs a whole team in one process with FIFO message
rounds. :class:`SchemaAgent` is the same reasoning for *one* robot, driven by events from a
transport (the ROS node, or an in-process loop in the unit tests): ``start`` (its own task),
``on_request``, ``on_offer``, ``observe`` (what a sensor retrieved), ``tick`` (re-evaluate and
send offers) and ``coalitions`` (its executable coalitions when the search time is over). What
it wants done goes to an :class:`Outbox`: switch a sensor, send a request, send an offer.

Per robot, as in Algorithm 2:

1. a robot with a task takes its task's potential solutions in non-descending cost, temporarily
   activates every ES-EPS pair they need and sends their CS requests (each label once:
   Distinct Requests, :class:`~.requests.RequestLedger`);
2. a request is answered per variant (footnote 9) from one reply space per variant (a later
   request for the same variant subscribes to it: Distinct Requests on the serving side); the
   reply space's sensors are activated and its own requests sent with the extended chain;
3. on every ``tick`` each reply space is instantiated with the current readings and offers, and
   each subscriber is sent every instance it can now get more cheaply than before;
4. ``coalitions`` instantiates the task's potential solutions: the feasible ones, cheapest first.

While a coalition executes, ``served_answers`` names what a helper streams to its coalition and
``own_answers`` how a robot computes the answers it gives itself (footnote 10); ``restart``
searches again when the leader re-forms (:mod:`.coalition_execution`).

Choices where the paper is silent (ours):

* What the sensors retrieve comes from their live reports (:class:`~.live_sensing.LiveSensing`:
  a reading is current for ``reading_timeout_s`` after the sensor's last report).
* Offers on the wire carry the helper coalition's cost and members, not its solution
  (:mod:`.channel_codec`). The coalition cost is therefore computed from the offers:
  ``own schemas + sum(offer cost - helper MS * offer members) + helper MS * helpers``
  (:func:`coalition_cost_from_offers`). It equals :func:`~.coalition.coalition_cost` unless two
  offers of one coalition share a helper's LCS (the in-process search counts a shared LCS once;
  across robots that sharing is not visible, so it is counted per offer -- an upper bound).
* Offers are accepted only for labels this robot requested and only if they answer them; others
  are refused with a reason (:class:`OfferRejected`), never raised into the transport.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable, Mapping, Protocol, Sequence

from .capabilities import RobotCapabilities
from .coalition import LocalCoalitionSolution, RobotReasoner
from .errors import RequestError
from .information import InformationInstance
from .live_sensing import LiveSensing
from .requests import InformationOffer, InformationRequest, addressees, answers_request
from .channel_codec import OfferSummary
from .schemas import Costs, SchemaKind, SchemaLibrary
from .solution_space import COST_DIGITS, PotentialSolution, SolutionSpaceCache
from .tasks import Task

#: The handle of a request this robot sent to itself (footnote 10: answered locally).
SELF = 'self'


class Outbox(Protocol):
    """What the agent asks its transport to do."""

    def set_sensor(self, sensor: str, active: bool) -> None:
        ...

    def send_request(self, request: InformationRequest, recipients: tuple[str, ...]) -> None:
        """``recipients`` never include the agent itself (self-requests are served locally)."""

    def send_offer(self, offer: OfferSummary, reply_to: object) -> None:
        """``reply_to`` is the handle given to :meth:`SchemaAgent.on_request` with the request."""


class OfferRejected(RequestError):
    """An offer the agent cannot use (the message says why)."""


@dataclass(frozen=True)
class FeasibleCoalition:
    """An executable coalition found by the local robot: its LCS, members (the robot first)
    and coalition cost."""

    lcs: LocalCoalitionSolution
    members: tuple[str, ...]
    cost: float

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


@dataclass
class _ReplySpace:
    variant: InformationInstance
    solutions: list[PotentialSolution]
    subscribers: list[tuple[InformationRequest, object]] = field(default_factory=list)
    sent: dict[tuple[int, InformationInstance], float] = field(default_factory=dict)
    #: answer -> (offer cost, members, LCS) of the cheapest way found at the last tick
    best: dict[InformationInstance, tuple[float, tuple[str, ...], LocalCoalitionSolution]] = field(default_factory=dict)


class SchemaAgent:
    """One robot's coalition reasoning (see the module docstring). ``task`` None = a pure
    helper; ``team_task`` is then the task the team works on (its priors and helper MS)."""

    def __init__(self, robot: str, team: Mapping[str, RobotCapabilities], library: SchemaLibrary, costs: Costs,
                 task: Task | None, outbox: Outbox, *, team_task: Task | None = None,
                 reading_timeout_s: float = 1.0, potential_solution_limit: int | None = None,
                 cache: SolutionSpaceCache | None = None):
        if robot not in team:
            raise RequestError(f"robot: '{robot}' is not in the team ({', '.join(team)})")
        context = task if task is not None else team_task
        if context is None:
            raise RequestError('team_task: a pure helper (task none) needs the task the team works on')
        self.robot = robot
        self.team = tuple(team)
        self.task = task
        self.outbox = outbox
        self.reading_timeout_s = reading_timeout_s
        self.reasoner = RobotReasoner(robot, team[robot], library, costs, context, cache=cache,
                                      potential_solution_limit=potential_solution_limit)
        self.root: list[PotentialSolution] = []
        self.spaces: dict[InformationInstance, _ReplySpace] = {}
        self.active_sensors: set[str] = set()
        self.sensing = LiveSensing(robot, team[robot], self.team, library.catalog.objects, reading_timeout_s)
        #: request label -> (provider, instance) -> (offer, members)
        self.offers: dict[InformationInstance, dict[tuple[str, InformationInstance], tuple[InformationOffer, tuple[str, ...]]]] = {}
        self._local: list[InformationRequest] = []
        #: robots left out of the coalitions of the current search (see :meth:`restart`)
        self.excluded: frozenset[str] = frozenset()
        self.requests_sent = 0
        self.offers_received = 0
        self.offers_sent = 0

    @property
    def helper_motor_schema_cost(self) -> float:
        return self.reasoner.helper_motor_schema_cost

    # Algorithm 2: the own task ---------------------------------------------------------------------
    def start(self) -> None:
        """Activate the sensors and send the requests of the task's potential solutions."""
        if self.task is None:
            return
        plan = self.reasoner.plan_task()
        self.root = list(plan.solutions)
        self._activate(sensor for sensor, _ in plan.sensors)
        self._send(plan.requests)

    def restart(self, exclude: Iterable[str] = ()) -> None:
        """Search again (re-forming a coalition that stopped being feasible): forget the offers
        and the requests sent for the own task, then :meth:`start`. Teammates answer the new
        requests from their existing reply spaces with every instance they can provide now.
        Coalitions with a robot of ``exclude`` (helpers that stopped serving; a teammate may still
        offer information it once got from them) are not :meth:`coalitions` of this search."""
        if self.task is None:
            return
        self.excluded = frozenset(exclude)
        self.offers.clear()
        self.reasoner.ledger.sent.clear()
        self.root = []
        self.start()

    # Serving requests --------------------------------------------------------------------------------
    def on_request(self, request: InformationRequest, reply_to: object) -> int:
        """Serve ``request`` (already validated by the codec); returns how many variants this
        robot can provide. Raises RequestError for a label this robot cannot reason about."""
        variants = self.reasoner.variants(request)
        for variant in variants:
            space = self.spaces.get(variant)
            if space is None:
                space = _ReplySpace(variant, self.reasoner.reply_solutions(variant))
                self.spaces[variant] = space
                chain = request.extended_chain
                for solution in space.solutions:
                    self._activate(sensor for sensor, _ in self.reasoner.sensing_needs(solution))
                    self._send(self.reasoner.requests_to_send(solution, chain))
            else:
                # A repeated search (a re-forming leader): the sensors may have been switched off
                # when this robot was released; its own requests stand (Distinct Requests).
                for solution in space.solutions:
                    self._activate(sensor for sensor, _ in self.reasoner.sensing_needs(solution))
            space.subscribers.append((request, reply_to))
        return len(variants)

    def on_offer(self, offer: OfferSummary) -> None:
        """Record an offer for one of this robot's requests (cheaper ones replace dearer)."""
        if offer.request not in self.reasoner.ledger.sent:
            raise OfferRejected(f'{self.robot} did not request {offer.request} (offer of {offer.provider})')
        if not answers_request(offer.instance, offer.request):
            raise OfferRejected(f'{offer.instance} from {offer.provider} does not answer {offer.request}')
        self.offers_received += 1
        offers = self.offers.setdefault(offer.request, {})
        key = (offer.provider, offer.instance)
        kept = offers.get(key)
        if kept is not None and kept[0].cost <= offer.cost:
            return
        offers[key] = (InformationOffer(offer.provider, offer.request, offer.instance, None, offer.cost),  # type: ignore[arg-type]
                       offer.members)

    def observe(self, sensor: str, now: float, detected: Iterable[str] = ()) -> tuple[InformationInstance, ...]:
        """A report of ``sensor`` (``detected``: the entities a fiducial sees); the instances retrieved."""
        return self.sensing.report(sensor, now, detected)

    # Evaluation -------------------------------------------------------------------------------------
    def current_readings(self, now: float) -> dict[str, tuple[InformationInstance, ...]]:
        return self.sensing.current(now)

    def _offer_view(self) -> dict[InformationInstance, list[InformationOffer]]:
        return {label: [offer for offer, _ in offers.values()] for label, offers in self.offers.items()}

    def _members_of(self, lcs: LocalCoalitionSolution) -> list[tuple[str, ...]]:
        return [self.offers[offer.request][(offer.provider, offer.instance)][1] for offer in lcs.offers]

    def tick(self, now: float) -> None:
        """Serve the self-requests, re-instantiate every reply space and send better offers."""
        while self._local:
            self.on_request(self._local.pop(0), SELF)
        sensed = self.current_readings(now)
        offers = self._offer_view()
        for space in self.spaces.values():
            best: dict[InformationInstance, tuple[float, tuple[str, ...], LocalCoalitionSolution]] = {}
            for solution in space.solutions:
                for lcs in self.reasoner.local_coalition_solutions(solution, sensed, offers, reply=True,
                                                                   cheapest_offers=True):
                    answer = lcs.answer
                    if answer is None:
                        continue
                    cost, members = coalition_cost_from_offers(lcs, self._members_of(lcs),
                                                               self.helper_motor_schema_cost, root_is_helped=False)
                    if answer not in best or cost < best[answer][0]:
                        best[answer] = (cost, members, lcs)
            space.best = best
            for position, (request, reply_to) in enumerate(space.subscribers):
                for answer in sorted(best, key=str):
                    if not answers_request(answer, request.label):
                        continue
                    cost, members, _ = best[answer]
                    previous = space.sent.get((position, answer))
                    if previous is not None and previous <= cost:
                        continue
                    space.sent[(position, answer)] = cost
                    summary = OfferSummary(self.robot, request.label, answer, cost, members)
                    self.offers_sent += 1
                    if reply_to == SELF:
                        self.on_offer(summary)
                    else:
                        self.outbox.send_offer(summary, reply_to)

    def coalitions(self, now: float) -> list[FeasibleCoalition]:
        """The executable coalitions of the task now, in non-descending coalition cost."""
        sensed = self.current_readings(now)
        offers = self._offer_view()
        found = []
        for solution in self.root:
            for lcs in self.reasoner.local_coalition_solutions(solution, sensed, offers):
                cost, members = coalition_cost_from_offers(lcs, self._members_of(lcs), self.helper_motor_schema_cost,
                                                           root_is_helped=True)
                if self.excluded.intersection(members):
                    continue
                found.append(FeasibleCoalition(lcs, members, cost))
        found.sort(key=lambda c: (c.cost, c.potential_solution.rank, c.members, tuple(c.lcs.step_lines())))
        return found

    def sensors_serving(self, robot: str) -> tuple[str, ...]:
        """This robot's sensors in the cheapest answers it offered to ``robot`` (what it keeps
        active while it helps ``robot``'s coalition)."""
        sensors: dict[str, None] = {}
        for space in self.spaces.values():
            if not any(request.requester == robot for request, _ in space.subscribers):
                continue
            for _, _, lcs in space.best.values():
                sensors.update((step.schema, None) for step, _, _ in lcs.sources if step.kind is SchemaKind.ES_EPS)
        return tuple(sensors)

    def served_answers(self, requesters: Iterable[str]) -> list[tuple[str, InformationInstance, LocalCoalitionSolution]]:
        """(requester, answer, LCS) of every cheapest answer this robot can give now to a request
        of one of ``requesters``: what it streams while it helps their coalition."""
        wanted = set(requesters)
        served: dict[tuple[str, InformationInstance], LocalCoalitionSolution] = {}
        for space in self.spaces.values():
            for request, _ in space.subscribers:
                if request.requester not in wanted:
                    continue
                for answer, (_, _, lcs) in space.best.items():
                    if answers_request(answer, request.label):
                        served.setdefault((request.requester, answer), lcs)
        return [(requester, answer, lcs) for (requester, answer), lcs in served.items()]

    def own_answers(self, instance: InformationInstance) -> list[LocalCoalitionSolution]:
        """The LCSs of this robot's current ways to provide ``instance`` (its reply spaces' best
        answers), cheapest first: how a self-request (footnote 10) is evaluated while the
        coalition runs."""
        found = [best[instance] for best in (space.best for space in self.spaces.values()) if instance in best]
        return [lcs for _, _, lcs in sorted(found, key=lambda entry: entry[0])]

    def keep_only(self, sensors: Iterable[str]) -> None:
        """Deactivate every temporarily activated sensor not in ``sensors``; activate those."""
        keep = set(sensors)
        for sensor in sorted(self.active_sensors - keep):
            self.outbox.set_sensor(sensor, False)
        self.active_sensors &= keep
        self._activate(sorted(keep))

    # Helpers ----------------------------------------------------------------------------------------
    def _activate(self, sensors: Iterable[str]) -> None:
        for sensor in sensors:
            if sensor == 'prior' or sensor in self.active_sensors:
                continue
            self.active_sensors.add(sensor)
            self.outbox.set_sensor(sensor, True)

    def _send(self, requests: Iterable[InformationRequest]) -> None:
        for request in requests:
            self.requests_sent += 1
            recipients = addressees(request.label, self.team)
            if self.robot in recipients:
                self._local.append(request)  # footnote 10: answered by this robot itself
            others = tuple(robot for robot in recipients if robot != self.robot)
            if others:
                self.outbox.send_request(request, others)


__all__ = ['SELF', 'FeasibleCoalition', 'OfferRejected', 'Outbox', 'SchemaAgent', 'coalition_cost_from_offers']
