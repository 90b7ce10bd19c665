"""Executing a coalition: values flow along the chosen solution (helpers stream what they offered),
the leader's F_G(local) is instantiated from the stream, stale streams make the coalition
infeasible and the leader re-forms with another helper."""
from __future__ import annotations

import math

import pytest

from coalition_agents.core import load_capability_file
from coalition_agents.core.agent import SchemaAgent
from coalition_agents.core.coalition_execution import CoalitionExecution
from coalition_agents.core.errors import ConfigError
from coalition_agents.core.information import Entity, InformationInstance
from coalition_agents.core.transport.information_stream import InformationStream
from coalition_agents.core.information_values import ValueUnavailable, evaluate

from coalition_wire import Wire

LEADER, HELPER, BYSTANDER = 'robot_blind', 'robot_helper', 'robot_bystander'
# Ground truth of the scene: the helper (GPS) stands 2 m behind the blind robot, both facing +x;
# the bystander 2 m to the blind robot's right, facing +y (towards it).
POSES = {LEADER: (1.0, 0.0, 0.0), HELPER: (-1.0, 0.0, 0.0), BYSTANDER: (1.0, -2.0, math.pi / 2)}


def relative(seen, observer):
    (x, y, _), (ox, oy, oyaw) = POSES[seen], POSES[observer]
    dx, dy = x - ox, y - oy
    return {'x': math.cos(-oyaw) * dx - math.sin(-oyaw) * dy, 'y': math.sin(-oyaw) * dx + math.cos(-oyaw) * dy}


@pytest.fixture
def team(library, config_dir):
    return dict(load_capability_file(config_dir / 'capabilities' / 'coalition_three_robots.yaml', library).robots)


def observe(agent, now):
    """Each robot's sensors at ``now``: the helper and the bystander both see the blind robot."""
    robot = agent.robot
    for sensor in agent.sensing.sensors:
        if sensor == 'fiducial':
            seen = [LEADER] if robot in (HELPER, BYSTANDER) else []
            agent.sensing.report(sensor, now, seen, {name: relative(name, robot) for name in seen})
        elif sensor == 'gps':
            x, y, yaw = POSES[robot]
            agent.sensing.report(sensor, now, (), {'x': x, 'y': y, 'yaw': yaw})
        else:
            agent.sensing.report(sensor, now, (), {'min_range': 3.0})


def build(team, library, costs, tasks, now=0.0):
    wire = Wire()
    for robot in team:
        task = tasks['navigation'] if robot == LEADER else None
        wire.agents[robot] = SchemaAgent(robot, team, library, costs, task, wire.outbox(robot),
                                         team_task=tasks['navigation'])
        observe(wire.agents[robot], now)
    wire.agents[LEADER].start()
    wire.run(now)
    return wire


def stream_from(wire, helper, stream, now, sequence):
    """What the helper node does every stream period: evaluate and send each served answer."""
    agent = wire.agents[helper]
    sent = 0
    for requester, answer, lcs in agent.served_answers([LEADER]):
        try:
            value = evaluate(lcs, lambda i: agent.sensing.value(i, now), lambda p, i: None)
        except ValueUnavailable:
            continue  # e.g. an answer through an inversion that needs a heading nobody measured
        stream.update(helper, answer, value[answer], sequence, now)
        sent += 1
    assert sent


def priors(tasks):
    return {InformationInstance('F_G', (Entity('goal', robot=False),)): {'x': 3.0, 'y': 0.0}, InformationInstance('F_M'): {}}


def test_the_leader_position_is_instantiated_from_the_helpers_stream(team, library, costs, tasks):
    wire = build(team, library, costs, tasks)
    leader = wire.agents[LEADER]
    best = leader.coalitions(0.0)[0]
    assert best.members[0] == LEADER and len(best.members) == 2
    helper = best.members[1]
    stream = InformationStream(timeout_s=0.5)
    stream_from(wire, helper, stream, 0.0, 1)
    values = evaluate(best.lcs, lambda i: leader.sensing.value(i, 0.0),
                      lambda p, i: stream.value(p, i, 0.0), priors(tasks))
    position = values[InformationInstance('F_G', (Entity(LEADER, robot=True),))]
    assert (position['x'], position['y']) == pytest.approx(POSES[LEADER][:2])
    assert 'yaw' not in position  # a fiducial sees positions, not headings
    assert values[InformationInstance('F_G', (Entity('goal', robot=False),))] == {'x': 3.0, 'y': 0.0}


def test_a_stale_stream_stops_the_values_and_after_the_timeout_the_coalition_re_forms(team, library, costs, tasks):
    wire = build(team, library, costs, tasks)
    leader = wire.agents[LEADER]
    best = leader.coalitions(0.0)[0]
    helper = best.members[1]
    other = BYSTANDER if helper == HELPER else HELPER
    stream = InformationStream(timeout_s=0.5)
    execution = CoalitionExecution(best.lcs, established_at=0.0, reform_timeout_s=1.0)
    assert execution.helpers == (helper,)

    def check(now):
        observe(leader, now)
        return execution.check(now, lambda p, i: stream.value(p, i, now) is not None,
                               lambda s, i: leader.sensing.value(i, now) is not None)

    stream_from(wire, helper, stream, 0.0, 1)
    assert check(0.2).feasible
    # The helper stops: its value goes stale after 0.5 s; the leader waits 1 s more, then re-forms.
    state = check(0.8)
    assert not state.feasible and not state.reform and state.lost_helpers == (helper,)
    with pytest.raises(ValueUnavailable, match=f'no current value streamed by {helper}'):
        evaluate(best.lcs, lambda i: leader.sensing.value(i, 0.8), lambda p, i: stream.value(p, i, 0.8),
                 priors(tasks))
    assert not check(1.1).reform
    state = check(1.3)
    assert state.reform and state.infeasible_for == pytest.approx(1.1)
    # Re-forming: the helper is down; the leader searches again and finds the other robot.
    wire.down.add(helper)
    for agent in wire.agents.values():
        observe(agent, 1.3)
    leader.restart(exclude=state.lost_helpers)
    wire.run(1.3)
    again = leader.coalitions(1.3)
    assert again and all(helper not in c.members for c in again)
    assert again[0].members == (LEADER, other)


def test_a_stream_that_comes_back_in_time_keeps_the_coalition(team, library, costs, tasks):
    wire = build(team, library, costs, tasks)
    leader = wire.agents[LEADER]
    best = leader.coalitions(0.0)[0]
    stream = InformationStream(timeout_s=0.5)
    execution = CoalitionExecution(best.lcs, 0.0, reform_timeout_s=1.0)
    current = lambda now: (lambda p, i: stream.value(p, i, now) is not None)  # noqa: E731
    own = lambda now: (lambda s, i: leader.sensing.value(i, now) is not None)  # noqa: E731
    stream_from(wire, best.members[1], stream, 0.0, 1)
    observe(leader, 0.9)
    assert not execution.check(0.9, current(0.9), own(0.9)).feasible
    stream_from(wire, best.members[1], stream, 1.0, 2)
    observe(leader, 1.0)
    assert execution.check(1.0, current(1.0), own(1.0)).feasible
    observe(leader, 1.6)
    assert not execution.check(1.6, current(1.6), own(1.6)).reform  # infeasible for 0.1 s only


def test_the_reform_timeout_must_be_positive(team, library, costs, tasks):
    best = build(team, library, costs, tasks).agents[LEADER].coalitions(0.0)[0]
    with pytest.raises(ConfigError, match='reform_timeout: must be a number > 0'):
        CoalitionExecution(best.lcs, 0.0, reform_timeout_s=0.0)
