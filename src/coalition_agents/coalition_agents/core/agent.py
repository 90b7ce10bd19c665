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

Event-driven evaluation (ours; the result is the one of re-instantiating everything every tick):
a potential solution is re-instantiated only when one of its inputs changed (see
:mod:`.agent_spaces`); ``incremental=False`` re-instantiates everything on every call, the
reference the unit tests compare against. With a time budget a tick stops between reply spaces
and leaves the rest, with their pending changes, to the next call (round robin), so that a
transport can run between slices.

While a coalition executes, ``served_answers`` names what a helper streams to its coalition and
``own_answers`` how a robot computes the answers it gives itself (footnote 10); ``restart``
searches again when the leader re-forms (:mod:`.coalition_execution`).

Choices where the paper is silent (ours):

* What the sensors retrieve comes from their live reports (:class:`~.live_sensing.LiveSensing`:
  a reading is current for ``reading_timeout_s`` after the sensor's last report).
* Offers on the wire carry the helper coalition's cost and members, not its solution, so the
  coalition cost is computed from the offers (:func:`~.agent_spaces.coalition_cost_from_offers`).
* Offers are accepted only for labels this robot requested and only if they answer them; others
  are refused with a reason (:class:`OfferRejected`), never raised into the transport.
"""
from __future__ import annotations

import time
from typing import Iterable, Mapping, Protocol, Sequence

from .agent_spaces import (
    Answer, FeasibleCoalition, ReceivedOffer, ReplySpace, RootSpace, SpaceChanges, better_answer,
    coalition_cost_from_offers, offer_rank,
)
from .capabilities import RobotCapabilities
from .coalition import RobotReasoner
from .coalition_solution import InformationOffer, LocalCoalitionSolution
from .errors import RequestError
from .information import InformationInstance
from .live_sensing import LiveSensing
from .reasoning_caches import AnswerMemo, OfferBook
from .requests import InformationRequest, addressees, to_absolute
from .schemas import Costs, SchemaKind, SchemaLibrary
from .solution_space import PotentialSolution, SolutionSpaceCache
from .tasks import Task
from .transport.codec import OfferSummary

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


class SchemaAgent:
    """One robot's coalition reasoning (see the module docstring). ``task`` None = a pure
    helper; ``team_task`` is then the task the team works on (its priors and helper MS)."""

    def __init__(self, robot: str, team: Mapping[str, RobotCapabilities], library: SchemaLibrary, costs: Costs,
                 task: Task | None, outbox: Outbox, *, team_task: Task | None = None,
                 reading_timeout_s: float = 1.0, potential_solution_limit: int | None = None,
                 cache: SolutionSpaceCache | None = None, incremental: bool = True):
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
        self._root = RootSpace()
        self.spaces: dict[InformationInstance, ReplySpace] = {}
        self.incremental = incremental
        #: instantiations of a potential solution done so far (the reasoning work)
        self.evaluations = 0
        #: answers instantiated again because an offer their cheapest way used was gone
        self.repaired_answers = 0
        #: sensor -> the readings the cached answers were computed with
        self._readings_used: dict[str, tuple[InformationInstance, ...]] = {}
        #: request label / sensor -> (space, solution index) of every potential solution using it
        self._label_users: dict[InformationInstance, dict[int, tuple[object, list[int]]]] = {}
        self._sensor_users: dict[str, list[tuple[object, int]]] = {}
        #: where the next budgeted :meth:`tick` starts in the reply spaces (round robin)
        self._cursor = 0
        #: answers_request remembered (reasoning_caches: shared with the in-process search)
        self._answers = AnswerMemo()
        self.active_sensors: set[str] = set()
        self.sensing = LiveSensing(robot, team[robot], self.team, library.catalog.objects, reading_timeout_s)
        #: the last :meth:`_refresh_readings` (the same object while the readings stay the same)
        self._sensed: dict[str, tuple[InformationInstance, ...]] = {}
        #: (request label, instance) -> the cheapest offer of it (what a reply uses)
        self._cheapest: dict[tuple[InformationInstance, InformationInstance], InformationOffer] = {}
        #: request label -> (provider, instance) -> (offer, members)
        #: request label -> (provider, instance) -> (offer, members); its view is memoised
        #: (reasoning_caches.OfferBook, shared with the in-process search)
        self.offers: OfferBook[tuple[InformationOffer, tuple[str, ...]]] = OfferBook(lambda entry: entry[0])
        self._local: list[InformationRequest] = []
        #: robots left out of the coalitions of the current search (see :meth:`restart`)
        self.excluded: frozenset[str] = frozenset()
        self.requests_sent = 0
        self.offers_received = 0
        self.offers_sent = 0

    @property
    def helper_motor_schema_cost(self) -> float:
        return self.reasoner.helper_motor_schema_cost

    @property
    def root(self) -> list[PotentialSolution]:
        """The task's potential solutions being searched (empty for a pure helper)."""
        return self._root.solutions

    def _register(self, space: object, solutions: Sequence[PotentialSolution]) -> None:
        """Index which request labels and sensors each potential solution of ``space`` uses."""
        for index, solution in enumerate(solutions):
            for label in self.reasoner.request_labels(solution):
                self._label_users.setdefault(label, {}).setdefault(id(space), (space, []))[1].append(index)
            for sensor in dict.fromkeys(sensor for sensor, _ in self.reasoner.sensing_needs(solution)):
                self._sensor_users.setdefault(sensor, []).append((space, index))
            space.changes.stale.add(index)  # type: ignore[attr-defined]

    def _unregister_root(self) -> None:
        for by_space in self._label_users.values():
            by_space.pop(id(self._root), None)
        for users in self._sensor_users.values():
            users[:] = [(space, index) for space, index in users if space is not self._root]

    # Algorithm 2: the own task ---------------------------------------------------------------------
    def start(self) -> None:
        """Activate the sensors and send the requests of the task's potential solutions."""
        if self.task is None:
            return
        plan = self.reasoner.plan_task()
        self._root = RootSpace(list(plan.solutions))
        self._register(self._root, self._root.solutions)
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
        self._cheapest.clear()
        self.reasoner.ledger.sent.clear()
        self._unregister_root()
        self._root = RootSpace()
        for space in self.spaces.values():  # their offers are gone too
            space.answers.clear()
            space.changes = SpaceChanges(stale=set(range(len(space.solutions))))
        self.start()

    # Serving requests --------------------------------------------------------------------------------
    def on_request(self, request: InformationRequest, reply_to: object) -> int:
        """Serve ``request`` (already validated by the codec); returns how many variants this
        robot can provide. Raises RequestError for a label this robot cannot reason about."""
        variants = self.reasoner.variants(request)
        for variant in variants:
            space = self.spaces.get(variant)
            if space is None:
                space = ReplySpace(variant, self.reasoner.reply_solutions(variant))
                self.spaces[variant] = space
                self._register(space, space.solutions)
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
            space.unserved = True
        return len(variants)

    def on_offer(self, offer: OfferSummary) -> None:
        """Record an offer for one of this robot's requests (cheaper ones replace dearer)."""
        if offer.request not in self.reasoner.ledger.sent:
            raise OfferRejected(f'{self.robot} did not request {offer.request} (offer of {offer.provider})')
        if not self._answers(offer.instance, offer.request):
            raise OfferRejected(f'{offer.instance} from {offer.provider} does not answer {offer.request}')
        self.offers_received += 1
        key = (offer.provider, offer.instance)
        kept = self.offers.get(offer.request, key)
        if kept is not None and kept[0].cost <= offer.cost:
            return
        received = ReceivedOffer(offer.provider, offer.request, offer.instance, None, offer.cost,  # type: ignore[arg-type]
                                  offer.members)
        cheapest = self._cheapest.get((offer.request, offer.instance))
        self.offers.put(offer.request, key, (received, offer.members))
        if cheapest is None or offer_rank(received) < offer_rank(cheapest):
            self._cheapest[(offer.request, offer.instance)] = received
        # What is no longer usable: the task's solutions use every offer (the replaced one is
        # gone); a reply uses the cheapest per instance (an undercut one is gone).
        replaced = None if kept is None else id(kept[0])
        undercut = id(cheapest) if cheapest is not None and offer_rank(received) < offer_rank(cheapest) else None
        for space, indices in self._label_users.get(offer.request, {}).values():
            changes: SpaceChanges = space.changes  # type: ignore[attr-defined]
            changes.add_offer(indices, received)
            gone = replaced if space is self._root else undercut
            if gone is not None:
                changes.gone.add(gone)

    def observe(self, sensor: str, now: float, detected: Iterable[str] = ()) -> tuple[InformationInstance, ...]:
        """A report of ``sensor`` (``detected``: the entities a fiducial sees); the instances retrieved."""
        return self.sensing.report(sensor, now, detected)

    # Evaluation -------------------------------------------------------------------------------------
    def current_readings(self, now: float) -> dict[str, tuple[InformationInstance, ...]]:
        return self.sensing.current(now)

    def _offer_view(self) -> dict[InformationInstance, list[InformationOffer]]:
        """request label -> the offers received, as of now. The same object until an offer
        arrives (:class:`~.reasoning_caches.OfferBook`), so that the reasoner's candidate lists
        and indexes for it serve every slice and every :meth:`coalitions` call in between."""
        return self.offers.view()

    @staticmethod
    def _members_of(lcs: LocalCoalitionSolution) -> list[tuple[str, ...]]:
        return [offer.members for offer in lcs.offers]  # type: ignore[attr-defined]

    def _refresh_readings(self, now: float) -> dict[str, tuple[InformationInstance, ...]]:
        """The current readings; potential solutions using a sensor whose readings changed since
        they were last instantiated become dirty (``incremental=False``: every one)."""
        sensed = self.current_readings(now)
        if not self.incremental:
            for space in (*self.spaces.values(), self._root):
                space.changes.stale.update(range(len(space.solutions)))
            return sensed
        for sensor in set(sensed) | set(self._readings_used):
            readings = sensed.get(sensor, ())
            if self._readings_used.get(sensor, ()) != readings:
                self._readings_used[sensor] = readings
                for space, index in self._sensor_users.get(sensor, ()):
                    space.changes.stale.add(index)  # type: ignore[attr-defined]
        if sensed != self._sensed:
            self._sensed = sensed  # else the same object as before (see _offer_view)
        return self._sensed

    def pending(self) -> bool:
        """Whether a :meth:`tick` has work: self-requests, changed inputs or new subscribers."""
        return bool(self._local) or any(space.has_work for space in self.spaces.values())

    def tick(self, now: float, budget_s: float | None = None) -> bool:
        """Serve the self-requests, re-instantiate the reply spaces whose inputs changed and send
        better offers. With ``budget_s``, stop after the reply space during which that much
        time (s, this process's clock) has passed: the rest is evaluated at the next call
        (round robin over the spaces), so a transport can deliver messages in between. Returns
        whether work is left."""
        started = time.perf_counter()
        while self._local:
            self.on_request(self._local.pop(0), SELF)
        sensed = self._refresh_readings(now)
        spaces = list(self.spaces.values())
        order = spaces[self._cursor:] + spaces[:self._cursor]
        # Every space evaluated in this call sees the offers as they are now; what arrives
        # meanwhile (offers this robot sends itself) is a change for the next call.
        work = [(space, space.changes.take(), space.unserved) for space in order if space.has_work]
        for space, _, _ in work:
            space.unserved = False
        offers = self._offer_view() if any(changes.dirty or changes.stale for _, changes, _ in work) else {}
        for position, (space, changes, _) in enumerate(work):
            if budget_s is not None and position > 0 and time.perf_counter() - started >= budget_s:
                for left, taken, unserved in work[position:]:
                    left.changes.merge(taken)
                    left.unserved = left.unserved or unserved
                self._cursor = spaces.index(space)
                return True
            self._evaluate(space, changes, sensed, offers)
            self._serve(space)
        self._cursor = 0
        return self.pending()

    def _evaluate(self, space: ReplySpace, changes: SpaceChanges, sensed, offers) -> None:
        stale = sorted(changes.stale)
        dirty = sorted(changes.dirty - changes.stale)
        for index in stale:
            space.answers[index] = self._reply_answers(space.solutions[index], sensed, offers, None, {})
        for index in dirty:
            space.answers[index] = self._repaired_answers(space.solutions[index], sensed, offers, changes.new_offers,
                                                          changes.gone, space.answers.get(index, {}))
        if stale or dirty:
            space.merge_best()

    def _repaired_answers(self, solution: PotentialSolution, sensed, offers, new_offers, gone: set[int],
                          answers: dict[InformationInstance, Answer]) -> dict[InformationInstance, Answer]:
        """``answers`` of one reply potential solution after offers arrived (``new_offers``) and
        others became unusable (``gone``): an answer whose cheapest way used a gone offer is
        instantiated again on its own (the ways it lost to may be its cheapest now); every other
        kept answer is still the cheapest way without the new offers, so only the
        instantiations using a new offer are added. The result is that of instantiating
        everything again."""
        broken = [answer for answer, (_, _, lcs) in answers.items()
                  if any(id(offer) in gone for offer in lcs.offers)]
        for answer in broken:
            del answers[answer]
        self.repaired_answers += len(broken)
        for answer in sorted(broken, key=str):
            self._reply_answers(solution, sensed, offers, None, answers, answer=answer)
        return self._reply_answers(solution, sensed, offers, new_offers, answers)

    def _reply_answers(self, solution: PotentialSolution, sensed, offers, new_offers,
                       answers: dict[InformationInstance, Answer], *,
                       answer: InformationInstance | None = None) -> dict[InformationInstance, Answer]:
        """answer -> the cheapest (offer cost, members, LCS) of one reply potential solution:
        ``answers`` updated with the instantiations using ``new_offers`` (None: all of them),
        only those providing ``answer`` if given."""
        self.evaluations += 1
        # A solution that provides one instance only: offers that alone cost more than its
        # cheapest way so far cannot improve it (a coalition costs at least this robot's schemas
        # plus any one offer's coalition; ties are kept, as they may win on the tie order).
        only = self._only_answer(solution)
        bound = None if new_offers is None or only not in answers else answers[only][0]
        for lcs in self.reasoner.local_coalition_solutions(solution, sensed, offers, reply=True, answer=answer,
                                                           cheapest_offers=True, new_offers=new_offers,
                                                           at_most_cost=bound):
            answer = lcs.answer
            if answer is None:
                continue
            cost, members = coalition_cost_from_offers(lcs, self._members_of(lcs),
                                                       self.helper_motor_schema_cost, root_is_helped=False)
            entry = (cost, members, lcs)
            if better_answer(entry, answers.get(answer)):
                answers[answer] = entry
        return answers

    def _only_answer(self, solution: PotentialSolution) -> InformationInstance | None:
        """The instance a reply solution provides if it is fully instantiated (else None)."""
        output = solution.root.output
        if output is None or not output.is_fully_instantiated:
            return None
        return to_absolute(output, self.robot)

    def _serve(self, space: ReplySpace) -> None:
        """Send each subscriber every answer it can now get more cheaply than before: a new
        subscriber every answer, the others the answers whose cost changed since the last time
        (the others it was sent at their present cost already)."""
        best = space.best
        if not space.changed and space.served == len(space.subscribers):
            return
        everything = sorted(best, key=str) if space.served < len(space.subscribers) else []
        changed = sorted(space.changed, key=str)
        space.changed = set()
        for position, (request, reply_to) in enumerate(space.subscribers):
            for answer in (changed if position < space.served else everything):
                if not self._answers(answer, request.label):
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
        space.served = len(space.subscribers)

    def coalitions(self, now: float) -> list[FeasibleCoalition]:
        """The executable coalitions of the task now, in non-descending coalition cost."""
        return list(self._refresh_root(now).sorted_coalitions(self.excluded))

    def cheapest(self, now: float) -> FeasibleCoalition | None:
        """``coalitions(now)[0]`` (None: none), without sorting them all (:meth:`RootSpace.cheapest`)."""
        return self._refresh_root(now).cheapest(self.excluded)

    def _refresh_root(self, now: float) -> RootSpace:
        sensed = self._refresh_readings(now)
        root = self._root
        changes = root.changes.take()
        if changes.dirty or changes.stale:
            offers = self._offer_view()
            new_offers, gone = changes.new_offers, changes.gone
            added: list[FeasibleCoalition] = []
            removed = False
            for index in sorted(changes.stale | changes.dirty):
                self.evaluations += 1
                full = index in changes.stale
                # Every coalition is kept here: drop those built on a replaced offer, add those
                # using a new one.
                kept = root.found.get(index, [])
                found = [] if full else [coalition for coalition in kept
                                         if not any(id(offer) in gone for offer in coalition.lcs.offers)]
                removed = removed or len(found) < len(kept)
                for lcs in self.reasoner.local_coalition_solutions(root.solutions[index], sensed, offers,
                                                                   new_offers=None if full else new_offers):
                    cost, members = coalition_cost_from_offers(lcs, self._members_of(lcs),
                                                               self.helper_motor_schema_cost, root_is_helped=True)
                    found.append(FeasibleCoalition(lcs, members, cost))
                    added.append(found[-1])
                root.found[index] = found
            root.changed(added, removed, self.excluded)
        return root

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
                    if self._answers(answer, request.label):
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
