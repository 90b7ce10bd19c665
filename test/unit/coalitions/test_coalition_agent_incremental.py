"""SchemaAgent's event-driven evaluation: the same offers and coalitions as re-instantiating
everything on every tick, and no work when nothing changed."""
from __future__ import annotations

import random

import pytest

from coalition_agents.core import load_capability_file
from coalition_agents.core.agent import SchemaAgent
from coalition_agents.core.capabilities import capability_file_from_dict
from coalition_agents.core.transport.codec import OfferSummary
from coalition_agents.core.errors import InformationError
from coalition_agents.core.requests import InformationRequest, answers_request
from coalition_agents.core.sim_scenarios import COLUMN_TYPES, capability_file, column_placements

from coalition_wire import Wire


def column(library, costs, tasks, robots, incremental):
    team = dict(capability_file_from_dict(capability_file(column_placements(robots), COLUMN_TYPES), library).robots)
    wire = Wire()
    for k in range(1, robots + 1):
        robot = f'robot_{k}'
        task = tasks['navigation'] if k == robots else None
        wire.agents[robot] = SchemaAgent(robot, team, library, costs, task, wire.outbox(robot),
                                         team_task=tasks['navigation'], reading_timeout_s=1.0,
                                         incremental=incremental)
    return wire


def sense(wire, robots, now, blind_sees_ahead=True):
    """Every robot sees the one ahead (the back robot only if ``blind_sees_ahead``), the front
    robot localises; every robot's laser reports."""
    for k in range(1, robots + 1):
        agent = wire.agents[f'robot_{k}']
        ahead = [f'robot_{k - 1}'] if k > 1 and (k < robots or blind_sees_ahead) else []
        agent.observe('fiducial', now, ahead)
        agent.observe('laser', now)
        if k == 1:
            agent.observe('gps', now)


def snapshot(wire, now):
    state = {}
    for robot, agent in wire.agents.items():
        state[robot] = {str(variant): {str(a): (c, m) for a, (c, m, _) in space.best.items()}
                        for variant, space in agent.spaces.items()}
        if agent.task is not None:
            state[robot]['coalitions'] = [(c.cost, c.members, tuple(c.lcs.step_lines())) for c in agent.coalitions(now)]
    return state


def scripted_run(library, costs, tasks, incremental, robots=4):
    """The back robot first sees nobody, then the robot ahead; later the front robot's GPS stops
    reporting (its reading expires) and comes back."""
    wire = column(library, costs, tasks, robots, incremental)
    snapshots = []
    sense(wire, robots, 0.0, blind_sees_ahead=False)
    wire.agents[f'robot_{robots}'].start()
    now = 0.0
    for step in range(40):
        now = round(now + 0.1, 3)
        if step < 5:
            sense(wire, robots, now, blind_sees_ahead=False)
        elif step < 20 or step >= 35:                # from step 5 the back robot sees the robot ahead
            sense(wire, robots, now)                 # readings stay current
        else:                                        # steps 20..34: robot_1's GPS is silent
            for k in range(2, robots + 1):
                wire.agents[f'robot_{k}'].observe('fiducial', now, [f'robot_{k - 1}'])
                wire.agents[f'robot_{k}'].observe('laser', now)
        wire.round(now)
        snapshots.append(snapshot(wire, now))
    return wire, snapshots


def test_incremental_evaluation_sends_the_same_offers_and_finds_the_same_coalitions(library, costs, tasks):
    full, full_snapshots = scripted_run(library, costs, tasks, incremental=False)
    fast, fast_snapshots = scripted_run(library, costs, tasks, incremental=True)
    assert fast.offers == full.offers                        # the same offers, in the same order
    assert fast_snapshots == full_snapshots                  # the same best answers and coalitions at every step
    back = fast_snapshots[-1]['robot_4']['coalitions']
    assert back and back[0][1] == ('robot_4', 'robot_1', 'robot_2', 'robot_3')
    # The script did change the result on the way: nothing executable before the back robot saw
    # the robot ahead; while robot_1's GPS was silent (its reading expired) robot_1 could provide
    # F_G(robot_1) only through robot_2 (offers already sent are not withdrawn, so the leader
    # keeps its list).
    assert fast_snapshots[3]['robot_4']['coalitions'] == []
    assert fast_snapshots[15]['robot_4']['coalitions']
    assert fast_snapshots[15]['robot_1']['F_G(local)']['F_G(robot_1)'] == (7.0, ('robot_1',))
    assert fast_snapshots[33]['robot_1']['F_G(local)']['F_G(robot_1)'][1] == ('robot_1', 'robot_2')
    assert fast_snapshots[39]['robot_1']['F_G(local)'] == fast_snapshots[15]['robot_1']['F_G(local)']
    work = lambda wire: sum(agent.evaluations for agent in wire.agents.values())  # noqa: E731
    assert work(fast) < work(full) / 5


def run_to_quiet(wire, robots, budget_s):
    """Sense, start the back robot and deliver messages until none is left; each tick limited
    to ``budget_s`` (0: one reply space per call) and repeated while it reports work left."""
    sense(wire, robots, 0.0)
    wire.agents[f'robot_{robots}'].start()
    calls = 0
    while True:
        for agent in wire.agents.values():
            calls += 1
            while agent.tick(0.0, budget_s=budget_s):
                calls += 1
        if not wire.deliver():
            return calls


def test_answers_built_on_a_replaced_offer_are_repaired_as_a_full_evaluation_would(library, costs, tasks):
    """Every robot sees its neighbour from the start, so cheaper offers overtake dearer ones
    that answers were already built on (an offer replaced by its provider, or undercut by
    another provider's for the same instance)."""
    full = column(library, costs, tasks, 4, incremental=False)
    fast = column(library, costs, tasks, 4, incremental=True)
    run_to_quiet(full, 4, None)
    run_to_quiet(fast, 4, None)
    assert sum(agent.repaired_answers for agent in fast.agents.values()) > 0
    assert fast.offers == full.offers
    assert snapshot(fast, 0.0) == snapshot(full, 0.0)


def test_ticks_with_a_time_budget_reach_the_same_answers_and_coalitions(library, costs, tasks):
    whole = column(library, costs, tasks, 5, incremental=True)
    sliced = column(library, costs, tasks, 5, incremental=True)
    whole_calls = run_to_quiet(whole, 5, None)
    sliced_calls = run_to_quiet(sliced, 5, 0.0)
    assert sliced_calls > 3 * whole_calls                  # the work was really cut into slices
    assert snapshot(sliced, 0.0) == snapshot(whole, 0.0)
    best = sliced.agents['robot_5'].coalitions(0.0)[0]
    assert best.members == ('robot_5', 'robot_1', 'robot_2', 'robot_3', 'robot_4')
    assert not any(agent.pending() for agent in sliced.agents.values())


def settled_column(library, costs, tasks):
    """A 3-robot column whose back robot has searched until no message is left in flight."""
    wire = column(library, costs, tasks, 3, incremental=True)
    sense(wire, 3, 0.0)
    wire.agents['robot_3'].start()
    for _ in range(10):
        if not wire.round(0.0):
            break
    return wire


def test_an_unchanged_tick_does_no_work(library, costs, tasks):
    wire = settled_column(library, costs, tasks)
    assert wire.agents['robot_3'].coalitions(0.0)
    before = {robot: agent.evaluations for robot, agent in wire.agents.items()}
    for now in (0.1, 0.2, 0.3):
        sense(wire, 3, now)                                  # same readings reported again
        assert wire.round(now) == 0                          # nothing sent
        wire.agents['robot_3'].coalitions(now)
    assert {robot: agent.evaluations for robot, agent in wire.agents.items()} == before
    assert not any(agent.pending() for agent in wire.agents.values())


def test_a_new_subscriber_gets_the_existing_answers_without_reevaluation(library, costs, tasks):
    wire = settled_column(library, costs, tasks)
    helper = wire.agents['robot_1']
    space = next(space for space in helper.spaces.values() if space.best and
                 any(request.requester == 'robot_3' for request, _ in space.subscribers))
    request, _ = next((r, to) for r, to in space.subscribers if r.requester == 'robot_3')
    evaluations, sent = helper.evaluations, len(wire.offers)
    helper.on_request(request, 'robot_3')                    # e.g. a re-forming leader asks again
    helper.tick(0.0)
    assert helper.evaluations == evaluations
    new = wire.offers[sent:]
    assert new and all(offer[0] == 'robot_1' and offer[1] == 'robot_3' for offer in new)
    assert {offer[3] for offer in new} == {str(a) for a in space.best if str(a) in {o[3] for o in new}}


def test_a_changed_reading_reevaluates_only_what_uses_that_sensor(library, costs, tasks):
    wire = settled_column(library, costs, tasks)
    back = wire.agents['robot_3']
    seeing = back.coalitions(0.0)
    before = back.evaluations
    back.observe('fiducial', 0.1, [])                        # it loses sight of the robot ahead
    blind = back.coalitions(0.1)
    uses_fiducial = [index for index, solution in enumerate(back.root)
                     if any(sensor == 'fiducial' for sensor, _ in back.reasoner.sensing_needs(solution))]
    assert 0 < len(uses_fiducial) < len(back.root)
    assert back.evaluations - before == len(uses_fiducial)  # only the solutions using the fiducial
    assert len(blind) < len(seeing)
    assert not any('EPS fiducial' in line for coalition in blind for line in coalition.lcs.step_lines())


class Silent:
    """An outbox that only records the offers an agent sends."""

    def __init__(self):
        self.offers = []

    def set_sensor(self, sensor, active):
        pass

    def send_request(self, request, recipients):
        pass

    def send_offer(self, offer, reply_to):
        self.offers.append((reply_to, str(offer.request), str(offer.instance), offer.cost, offer.members))


def random_offers(agent, library, team, rng, count):
    """``count`` offers for the labels ``agent`` requested, from random providers with random
    members and costs; about a third replace an earlier offer of the same provider and
    instance with a cheaper one."""
    robots = [robot for robot in team if robot != agent.robot]
    labels = list(agent.reasoner.ledger.sent)
    sent = []
    offers = []
    while len(offers) < count:
        if sent and rng.random() < 0.35:
            provider, label, instance, cost, members = sent[rng.randrange(len(sent))]
            cost = round(cost - rng.choice((0.5, 2.0, 6.0)), 1)  # cheaper, maybe other members
            members = (provider, *rng.sample([r for r in robots if r != provider], rng.randrange(0, 4)))
        else:
            label = rng.choice(labels)
            text = str(label)
            for variable in label.variables:
                text = text.replace(variable.name, rng.choice(team))
            try:
                instance = library.parse(text, team)
            except InformationError:
                continue  # a robot drawn twice
            if not answers_request(instance, label):
                continue
            provider = rng.choice(robots)
            members = (provider, *rng.sample([r for r in robots if r != provider], rng.randrange(0, 4)))
            cost = round(4.0 * len(members) + rng.uniform(1.0, 30.0), 1)
        if cost <= 4.0 * len(members):
            continue
        sent.append((provider, label, instance, cost, members))
        offers.append(OfferSummary(provider, label, instance, cost, members))
    return offers


@pytest.mark.parametrize('seed', range(12))
def test_random_offer_sequences_give_the_answers_of_a_full_evaluation(library, costs, tasks, seed):
    """A middle robot of a 5-robot column serves the back robot while offers arrive in random
    order, cheaper ones replacing dearer ones (whose members may make the composed coalition
    dearer: the answer may then come another way). After every tick the incremental agent's
    answers (per potential solution) and the offers it sent equal those of re-instantiating
    everything."""
    rng = random.Random(seed)
    team_caps = dict(capability_file_from_dict(capability_file(column_placements(5), COLUMN_TYPES), library).robots)
    team = list(team_caps)
    agents = {}
    for incremental in (True, False):
        outbox = Silent()
        agent = SchemaAgent('robot_3', team_caps, library, costs, None, outbox, team_task=tasks['navigation'],
                            incremental=incremental)
        for text in ('F_G(X)', 'F_R(robot_5, X)', 'F_R(X, robot_5)', 'F_R(X, Y)'):
            agent.on_request(InformationRequest('robot_5', library.parse(text, team)), 'robot_5')
        agent.observe('fiducial', 0.0, ['robot_2'])
        agent.observe('laser', 0.0)
        agent.tick(0.0)
        agents[incremental] = (agent, outbox)
    fast, full = agents[True][0], agents[False][0]
    offers = random_offers(fast, library, team, rng, 60)
    for step, offer in enumerate(offers):
        for agent in (fast, full):
            agent.on_offer(offer)
        if step % 3 == 2:
            for agent in (fast, full):
                agent.tick(0.0)
            # per potential solution, not only the best of each space: another solution's
            # equal answer must not hide a wrong one
            answers = [{(str(v), index): {str(a): (c, m) for a, (c, m, _) in found.items()}
                        for v, space in agent.spaces.items() for index, found in space.answers.items()}
                       for agent in (fast, full)]
            assert answers[0] == answers[1], f'step {step}'
    assert agents[True][1].offers == agents[False][1].offers
    assert fast.evaluations < full.evaluations


def scripted_leader_view(library, costs, tasks, ask, robots=4):
    """The script of :func:`scripted_run`; at every step the back robot is asked ``ask(agent, now)``."""
    wire = column(library, costs, tasks, robots, incremental=True)
    back = wire.agents[f'robot_{robots}']
    seen = []
    sense(wire, robots, 0.0, blind_sees_ahead=False)
    back.start()
    now = 0.0
    for step in range(40):
        now = round(now + 0.1, 3)
        if step < 5:
            sense(wire, robots, now, blind_sees_ahead=False)
        elif step < 20 or step >= 35:
            sense(wire, robots, now)
        else:
            for k in range(2, robots + 1):
                wire.agents[f'robot_{k}'].observe('fiducial', now, [f'robot_{k - 1}'])
                wire.agents[f'robot_{k}'].observe('laser', now)
        # Asked between the agents' ticks and deliveries, as the leader's settle rule asks.
        for name, agent in wire.agents.items():
            agent.tick(now)
            if agent is back:
                found = ask(back, now)
                seen.append(None if found is None else (found.cost, found.members, tuple(found.lcs.step_lines())))
        wire.deliver()
    return seen, back


def test_the_cheapest_coalition_kept_up_to_date_is_the_first_of_the_sorted_ones(library, costs, tasks):
    """The settle rule's question, answered without sorting (coalitions added by new offers,
    removed by replaced offers and lapsed readings on the way), equals the sorted list's first."""
    fast, back = scripted_leader_view(library, costs, tasks, lambda agent, now: agent.cheapest(now))
    sorted_first, _ = scripted_leader_view(
        library, costs, tasks, lambda agent, now: next(iter(agent.coalitions(now)), None))
    assert fast == sorted_first
    assert fast[3] is None and fast[15] is not None and fast[-1] is not None
    assert back.cheapest(4.0) is back.coalitions(4.0)[0]
