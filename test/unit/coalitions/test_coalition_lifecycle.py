"""The coalition life cycle without ROS (core.lifecycle.AgentLifecycle): start, settle rule,
negotiation and its fallback, a helper's commitment and release, re-forming, exit_when_done.
The agents reason in process (coalition_wire); the lifecycle's ports are fakes that record."""
from __future__ import annotations

import math

import pytest

from coalition_agents.core.agent import SchemaAgent
from coalition_agents.core.agent_state import AgentState
from coalition_agents.core.lifecycle import AgentLifecycle
from coalition_agents.core.settings import AgentSettings
from coalition_agents.core.requests import InformationRequest
from coalition_agents.core.transport.codec import (
    ChannelMessage, MessageKind, commit_request_message, release_message, request_message,
)
from coalition_agents.core.transport.commitments import Negotiation
from coalition_agents.core.transport.reliable_channel import Received

from coalition_wire import Wire

LEADER, HELPER, BYSTANDER = 'robot_blind', 'robot_helper', 'robot_bystander'
#: The scene: the helper (GPS) 2 m behind the blind robot, the bystander 2 m to its right; both see it.
POSES = {LEADER: (1.0, 0.0, 0.0), HELPER: (-1.0, 0.0, 0.0), BYSTANDER: (1.0, -2.0, math.pi / 2)}


def relative(seen, observer):
    (x, y, _), (ox, oy, oyaw) = POSES[seen], POSES[observer]
    dx, dy = x - ox, y - oy
    return {'x': math.cos(-oyaw) * dx - math.sin(-oyaw) * dy, 'y': math.sin(-oyaw) * dx + math.cos(-oyaw) * dy}


def observe(agent, now):
    for sensor in agent.sensing.sensors:
        if sensor == 'fiducial':
            seen = [LEADER] if agent.robot in (HELPER, BYSTANDER) else []
            agent.sensing.report(sensor, now, seen, {name: relative(name, agent.robot) for name in seen})
        elif sensor == 'gps':
            agent.sensing.report(sensor, now, (), dict(zip(('x', 'y', 'yaw'), POSES[agent.robot])))
        else:
            agent.sensing.report(sensor, now, (), {'min_range': 3.0})


class Port:
    """The node's side, recorded."""

    def __init__(self, listening=2):
        self.statuses, self.commands, self.logs = [], [], []
        self.finished = False
        self.reasoning = 0
        self.listening = listening

    def publish_status(self, report):
        self.statuses.append(report)

    def command(self, velocity):
        self.commands.append(velocity)

    def log(self, level, text):
        self.logs.append((level, text))

    def finish(self):
        assert not self.finished, 'finish twice'
        self.finished = True

    def request_reasoning(self):
        self.reasoning += 1

    def teammates_listening(self):
        return self.listening


class Channel:
    """The channel's side: negotiations the test decides, releases and streams recorded."""

    def __init__(self):
        self.now = 0.0
        self.ids = 0
        self.negotiations: list[Negotiation] = []
        self.released: list[tuple[str, str]] = []
        self.streamed: list[tuple] = []

    def new_id(self):
        self.ids += 1
        return self.ids

    def propose(self, coalition_id, members, cost, hold_seconds):
        negotiation = Negotiation(coalition_id, members[0], tuple(members), cost, hold_seconds, self.now)
        self.negotiations.append(negotiation)
        return negotiation, ''

    def release(self, coalition_id, reason=''):
        self.released.append((coalition_id, reason))

    def stream(self, receiver, coalition_id, instance, values):
        self.streamed.append((receiver, coalition_id, str(instance), dict(values)))

    def admit_with(self, rule):
        self.admission = rule

    def announce(self):
        self.announced = self.now

    def drop_commitment(self, coalition_id, leader):
        self.dropped = (coalition_id, leader)


@pytest.fixture
def files(config_dir):
    return {'capability_file': str(config_dir / 'capabilities' / 'coalition_three_robots.yaml'),
            'schemas_file': str(config_dir / 'schemas.yaml'), 'costs_file': str(config_dir / 'costs.yaml'),
            'tasks_file': str(config_dir / 'tasks.yaml')}


class Team:
    """Three agents reasoning in process; ``robot``'s life cycle (leader or helper) under test."""

    def __init__(self, files, robot=LEADER, **values):
        task = 'navigation' if robot == LEADER else 'none'
        self.settings = AgentSettings.build({**files, 'task': task, 'team_task': 'navigation', **values}, robot)
        self.wire = Wire()
        for name in self.settings.team:
            self.wire.agents[name] = SchemaAgent(name, self.settings.team, self.settings.library, self.settings.costs,
                                                 self.settings.tasks['navigation'] if name == LEADER else None,
                                                 self.wire.outbox(name), team_task=self.settings.tasks['navigation'])
        self.port, self.channel = Port(), Channel()
        self.life = AgentLifecycle(self.wire.agents[robot], self.settings, self.port, self.channel)

    def step(self, now):
        """One tick: readings, the agents' messages, the life cycle's reasoning and tick."""
        self.channel.now = now
        for agent in self.wire.agents.values():
            observe(agent, now)
        self.wire.round(now)
        self.life.reasoning_step(now)
        self.life.on_tick(now)

    def run_until(self, state, start, end, dt=0.1):
        now = start
        while now <= end + 1e-9:
            self.step(now)
            if self.life.state is state:
                return now
            now = round(now + dt, 6)
        raise AssertionError(f'{self.life.state.label} at {end} s, not {state.label}')

    def states(self):
        return [report.state for report in self.port.statuses]


def accept_all(team, now):
    negotiation = team.channel.negotiations[-1]
    negotiation.accepted |= set(negotiation.helpers)
    accept = ChannelMessage(MessageKind.COMMIT_ACCEPT, 99, negotiation.helpers[0], LEADER,
                            coalition_id=negotiation.coalition_id)
    team.life.on_message(accept, Received(deliver=accept), now)


def test_a_leader_waits_for_its_team_then_searches_settles_negotiates_and_commits(files):
    team = Team(files, search_time=3.0, settle_time=1.0, team_wait=2.0)
    team.port.listening = 1  # one teammate's agent is not on the channel yet
    team.life.on_tick(1.0)
    assert team.life.state is AgentState.IDLE and team.life.started_at is None
    team.life.on_tick(3.0)  # team_wait is over: it starts anyway
    assert team.life.state is AgentState.SEARCHING and any('starting anyway' in text for _, text in team.port.logs)
    assert team.port.statuses[-1].search_started == 3.0
    negotiating = team.run_until(AgentState.NEGOTIATING, 3.0, 6.5)
    found = team.life.found_at
    assert found is not None and 3.0 <= found < negotiating
    # Settle rule: the cheapest coalition did not improve for settle_time, well before search_time.
    assert found + 1.0 <= negotiating + 1e-9 and negotiating < 3.0 + 3.0
    settled_for = negotiating - team.life._best_since  # the cheapest did not change since
    assert 1.0 - 1e-9 <= settled_for <= 1.1 + 1e-9  # settle_time, at the tick's resolution
    found_status = next(r for r in team.port.statuses if r.coalition_found is not None)
    assert found_status.state is AgentState.SEARCHING and found_status.found_cost > 0
    negotiation = team.channel.negotiations[0]
    assert negotiation.members[0] == LEADER and negotiation.coalition_id == f'{LEADER}/1'
    accept_all(team, negotiating + 0.05)
    report = team.port.statuses[-1]
    assert report.state is AgentState.COMMITTED and team.states()[-3:] == [
        AgentState.SEARCHING, AgentState.NEGOTIATING, AgentState.COMMITTED]
    assert (report.coalition_id, report.leader, report.members) == (negotiation.coalition_id, LEADER,
                                                                    negotiation.members)
    assert report.coalition_formed == negotiating + 0.05 and report.coalition_found == found
    assert report.potential_solution >= 1 and report.cost == negotiation.cost
    assert 'formed at' in report.detail and not team.port.finished  # exit_when_done is off


def test_a_refused_candidate_gives_way_to_the_next_and_none_left_is_a_failure(files):
    team = Team(files, search_time=2.0, settle_time=5.0, exit_when_done=True)
    started = 1.0
    team.life.on_tick(started)
    negotiating = team.run_until(AgentState.NEGOTIATING, started, started + 2.5)
    assert negotiating == pytest.approx(started + 2.0)  # settle_time >= search_time: the whole search
    candidates = len(team.life.candidates) + 1
    for attempt in range(candidates):
        negotiation = team.channel.negotiations[-1]
        negotiation.rejected[negotiation.helpers[0]] = 'busy'
        team.life.on_tick(negotiating + 0.1 * (attempt + 1))
        assert team.channel.released[-1] == (negotiation.coalition_id, 'negotiation failed')
    assert len(team.channel.negotiations) == candidates
    report = team.port.statuses[-1]
    assert report.state is AgentState.FAILED and 'no executable coalition could be set up' in report.detail
    assert team.port.finished  # exit_when_done: a leader is done once set up or failed


def test_a_helper_helps_commits_and_is_released(files):
    team = Team(files, robot=HELPER, exit_when_done=True)
    life = team.life
    team.wire.agents[LEADER].start()
    team.wire.queue.clear()  # the leader's requests reach the helper's life cycle below instead
    request = team.wire.agents[LEADER].reasoner.ledger.sent
    assert request
    label = next(iter(request))
    message = request_message(InformationRequest(LEADER, label), 7)
    life.on_message(message, Received(deliver=message), 1.0)
    assert life.state is AgentState.HELPING and team.port.reasoning == 1
    commit = commit_request_message(LEADER, 8, HELPER, f'{LEADER}/1', (LEADER, HELPER), 16.0, 0.0)
    life.on_message(commit, Received(deliver=commit, accepted=True), 2.0)
    report = team.port.statuses[-1]
    assert (report.state, report.coalition_id, report.leader, report.coalition_formed) == (
        AgentState.COMMITTED, f'{LEADER}/1', LEADER, 2.0)
    release = release_message(LEADER, 9, HELPER, f'{LEADER}/1', 'task completed')
    life.on_message(release, Received(deliver=release), 3.0)
    assert team.port.statuses[-1].state is AgentState.IDLE and team.port.finished


def test_a_coalition_whose_information_stops_is_re_formed_then_given_up(files):
    team = Team(files, search_time=2.0, settle_time=0.5, reform_timeout=0.5, max_reforms=1)
    team.life.on_tick(1.0)
    negotiating = team.run_until(AgentState.NEGOTIATING, 1.0, 3.5)
    accept_all(team, negotiating)
    assert team.life.state is AgentState.COMMITTED
    helpers = set(team.channel.negotiations[-1].helpers)
    # Nobody streams: the coalition's CS leaves have no current value; after reform_timeout the
    # leader releases it and searches again without the helpers that stopped.
    now = negotiating
    while team.life.state is AgentState.COMMITTED:
        now = round(now + 0.1, 6)
        assert now < negotiating + 1.0
        team.life.on_tick(now)
    assert team.life.state is AgentState.SEARCHING and team.life.reforms == 1
    assert team.channel.released[-1][1].startswith('information stopped: ')
    assert team.life.agent.excluded == frozenset(helpers) and team.port.statuses[-1].search_started == now
    assert team.port.statuses[-1].coalition_found is None and team.port.statuses[-1].reforms == 1
    negotiating = team.run_until(AgentState.NEGOTIATING, now, now + 2.5)
    assert not helpers & set(team.channel.negotiations[-1].members)
    accept_all(team, negotiating)
    now = negotiating
    while team.life.state is AgentState.COMMITTED:
        now = round(now + 0.1, 6)
        assert now < negotiating + 1.0
        team.life.on_tick(now)
    report = team.port.statuses[-1]
    assert report.state is AgentState.FAILED and '1 re-form(s) used' in report.detail
