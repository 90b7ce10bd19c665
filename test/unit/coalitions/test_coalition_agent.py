"""SchemaAgent (one robot's distributed Algorithm 2) against the in-process CoalitionSearch."""
from __future__ import annotations

import math

import pytest

from coalition_agents.core import CoalitionSearch, StaticSensing, load_capability_file
from coalition_agents.core.agent import OfferRejected, SchemaAgent
from coalition_agents.core.transport.codec import OfferSummary
from coalition_agents.core.live_sensing import LiveSensing
from coalition_agents.core.errors import ConfigError

from coalition_wire import Wire


SIGHTINGS = {  # robot -> sensor -> what it reports (names it sees)
    'robot_blind': {'fiducial': ['robot_helper', 'target_1'], 'laser': []},
    'robot_helper': {'gps': [], 'laser': [], 'fiducial': []},
    'robot_bystander': {'gps': [], 'laser': [], 'fiducial': []},
}


@pytest.fixture
def team(library, config_dir):
    return dict(load_capability_file(config_dir / 'capabilities' / 'coalition_three_robots.yaml', library).robots)


def build(team, library, costs, tasks, sightings):
    wire = Wire()
    for robot in team:
        task = tasks['navigation'] if robot == 'robot_blind' else None
        agent = SchemaAgent(robot, team, library, costs, task, wire.outbox(robot), team_task=tasks['navigation'])
        for sensor, seen in sightings.get(robot, {}).items():
            agent.observe(sensor, 0.0, seen)
        wire.agents[robot] = agent
    return wire


def reference(team, library, costs, tasks, sightings):
    table = {}
    for robot, sensors in sightings.items():
        for sensor, seen in sensors.items():
            live = LiveSensing(robot, team[robot], team, library.catalog.objects)
            table.setdefault(robot, {})[sensor] = [str(i) for i in live.report(sensor, 0.0, seen)]
    sensing = StaticSensing.from_text(table, library, list(team))
    return CoalitionSearch(library, costs, tasks['navigation'], team, sensing).run(['robot_blind'])['robot_blind']


def test_distributed_agents_find_the_in_process_search_coalitions(team, library, costs, tasks):
    wire = build(team, library, costs, tasks, SIGHTINGS)
    wire.agents['robot_blind'].start()
    wire.run()
    found = wire.agents['robot_blind'].coalitions(0.0)
    expected = reference(team, library, costs, tasks, SIGHTINGS)
    assert found and expected.best is not None
    assert found[0].cost == expected.best.cost
    assert found[0].members == expected.best.members == ('robot_blind', 'robot_helper')
    assert found[0].sensors() == ('fiducial', 'laser')
    # Every coalition of the reference search is found with the same cost (no shared helper LCS here).
    assert sorted((c.cost, c.members) for c in found) == sorted((c.cost, c.members) for c in expected.coalitions)
    # The helper keeps the GPS it serves the leader with; the bystander serves nobody useful.
    assert 'gps' in wire.agents['robot_helper'].sensors_serving('robot_blind')


def test_nothing_feasible_when_the_blind_robot_sees_nobody(team, library, costs, tasks):
    sightings = {**SIGHTINGS, 'robot_blind': {'fiducial': [], 'laser': []}}
    wire = build(team, library, costs, tasks, sightings)
    wire.agents['robot_blind'].start()
    wire.run()
    assert wire.agents['robot_blind'].coalitions(0.0) == []
    assert not reference(team, library, costs, tasks, sightings).coalitions


def test_distinct_requests_each_label_is_requested_once(team, library, costs, tasks):
    wire = build(team, library, costs, tasks, SIGHTINGS)
    wire.agents['robot_blind'].start()
    wire.run()
    for agent in wire.agents.values():
        assert agent.requests_sent == len(agent.reasoner.ledger.sent)


def test_temporary_sensors_are_switched_on_then_off_except_the_kept_ones(team, library, costs, tasks):
    wire = build(team, library, costs, tasks, SIGHTINGS)
    blind = wire.agents['robot_blind']
    blind.start()
    wire.run()
    assert ('robot_blind', 'fiducial', True) in wire.switches
    best = blind.coalitions(0.0)[0]
    wire.switches.clear()
    blind.keep_only(best.sensors())
    assert blind.active_sensors == set(best.sensors())
    assert all(active is False for _, _, active in wire.switches)


def test_readings_expire_after_the_timeout(team, library, costs, tasks):
    wire = build(team, library, costs, tasks, SIGHTINGS)
    wire.agents['robot_blind'].start()
    wire.run()
    assert wire.agents['robot_blind'].coalitions(0.5)
    assert wire.agents['robot_blind'].coalitions(5.0) == []


def test_offers_for_labels_never_requested_or_not_answering_are_rejected(team, library, costs, tasks):
    wire = build(team, library, costs, tasks, SIGHTINGS)
    blind = wire.agents['robot_blind']
    blind.start()
    never = library.parse('F_G(robot_bystander)', list(team))
    with pytest.raises(OfferRejected, match='did not request'):
        blind.on_offer(OfferSummary('robot_bystander', never, never, 1.0, ('robot_bystander',)))
    requested = next(label for label in blind.reasoner.ledger.sent
                     if label.label == 'F_R' and 'robot_blind' in map(str, label.referents))
    elsewhere = library.parse('F_R(robot_helper, robot_bystander)', list(team))  # not about robot_blind
    with pytest.raises(OfferRejected, match='does not answer'):
        blind.on_offer(OfferSummary('robot_helper', requested, elsewhere, 1.0, ('robot_helper',)))
    assert blind.offers_received == 0


def test_live_sensing_ignores_unknown_detections_and_rejects_unknown_sensors(team, library):
    live = LiveSensing('robot_blind', team['robot_blind'], team, library.catalog.objects, timeout_s=1.0)
    readings = live.report('fiducial', 2.0, ['robot_helper', 'target_1', 'robot_blind'])
    assert [str(r) for r in readings] == ['F_R(robot_helper, robot_blind)']
    assert live.readings('robot_blind', 'fiducial', 2.5) == readings
    assert live.readings('robot_blind', 'fiducial', 3.5) == ()
    with pytest.raises(ConfigError, match="no such sensor"):
        live.report('gps', 2.0)
    with pytest.raises(ConfigError, match='reading_timeout'):
        LiveSensing('robot_blind', team['robot_blind'], team, timeout_s=0.0)


def test_fiducial_yaw_makes_an_inverted_relative_position_computable(team, library):
    """A fiducial report carries the seen robot's relative heading (bridge FiducialDetection.yaw):
    robot_blind sees robot_helper 2 m ahead, turned +90 deg (reported as -270 deg, wrapped), so
    robot_blind lies 2 m to robot_helper's left -- computed by the Table I inversion, no heading
    estimate needed."""
    from coalition_agents.core.information import Entity, InformationInstance
    from coalition_agents.core.information_values import relative_inverse
    from coalition_agents.core.live_sensing import fiducial_values
    live = LiveSensing('robot_blind', team['robot_blind'], team, library.catalog.objects, timeout_s=1.0)
    names, values = fiducial_values([('robot_helper', 2.0, 0.0, -1.5 * math.pi)])
    assert names == ['robot_helper'] and values['robot_helper']['yaw'] == pytest.approx(math.pi / 2)
    live.report('fiducial', 2.0, names, values)
    seen = InformationInstance('F_R', (Entity('robot_helper', robot=True), Entity('robot_blind', robot=True)))
    value = live.value(seen, 2.1)
    assert value == pytest.approx({'x': 2.0, 'y': 0.0, 'yaw': math.pi / 2})
    inverted = relative_inverse([(seen, value)], {})
    assert (inverted['x'], inverted['y'], inverted['yaw']) == pytest.approx((0.0, 2.0, -math.pi / 2), abs=1e-9)
    # A non-finite yaw is rejected by the report, naming the field.
    with pytest.raises(ValueError, match='yaw'):
        live.report('fiducial', 2.2, *fiducial_values([('robot_helper', 2.0, 0.0, math.nan)]))
