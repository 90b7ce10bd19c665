"""Three schema_agent processes and the bridge: the robot without localisation forms its
least-cost coalition with the GPS robot its fiducial sees (IQ-ASyMTRe, Algorithm 2).

The expectation is computed with the core: what each robot's sensors retrieve in the scenario's
geometry (fields of view and ranges from the scenario file) goes through the node's own
conversion (LiveSensing) into the in-process CoalitionSearch.
"""

import math
import re
import time

import pytest
import yaml

from collab_tools.orchestration.node_process import NodeSpec
from bridge_helpers import bridge_spec
from coalition_interfaces.msg import AgentMessage, Information
from coalition_agents.core import CoalitionSearch, StaticSensing, load_capability_file, load_costs, load_library, load_tasks
from coalition_agents.core.live_sensing import LiveSensing

LEADER, HELPER, BYSTANDER = 'robot_blind', 'robot_helper', 'robot_bystander'
STATUS = 'coalition_interfaces/msg/AgentStatus'


@pytest.fixture
def files(config_dir):
    coalitions = config_dir / 'coalitions'
    return {'capability_file': str(coalitions / 'capabilities' / 'coalition_three_robots.yaml'),
            'schemas_file': str(coalitions / 'schemas.yaml'), 'costs_file': str(coalitions / 'costs.yaml'),
            'tasks_file': str(coalitions / 'tasks.yaml')}


def sees(observer, other, fov_deg, range_m):
    (x, y, yaw), (ox, oy, _) = observer, other
    bearing = math.degrees(math.atan2(oy - y, ox - x) - yaw)
    bearing = (bearing + 180.0) % 360.0 - 180.0
    return math.hypot(ox - x, oy - y) <= range_m and abs(bearing) <= fov_deg / 2.0


def expected_best(files, scenario_path):
    """The least-cost coalition of the leader computed by the core from the scenario geometry."""
    library = load_library(files['schemas_file'])
    team = dict(load_capability_file(files['capability_file'], library).robots)
    scenario = yaml.safe_load(open(scenario_path))
    robots = {robot['name']: robot for robot in scenario['mobile_robots']}
    table = {}
    for name, capabilities in team.items():
        live = LiveSensing(name, capabilities, team, library.catalog.objects)
        for sensor in capabilities.sensor_names:
            seen = []
            if sensor == 'fiducial':
                view = robots[name]['sensors']['fiducial']
                seen = [other for other in team if other != name
                        and sees(robots[name]['pose'], robots[other]['pose'], view['fov_deg'], view['range'])]
            table.setdefault(name, {})[sensor] = [str(i) for i in live.report(sensor, 0.0, seen)]
    search = CoalitionSearch(library, load_costs(files['costs_file']),
                             load_tasks(files['tasks_file'], library)['navigation'], team,
                             StaticSensing.from_text(table, library, list(team)))
    return search.run([LEADER])[LEADER].best


def start_team(session, files, config_dir, loss):
    scenario = config_dir / 'scenarios' / 'coalition_three_robots.yaml'
    session.start(bridge_spec(scenario, real_time_factor=1.0, start_paused=False, publish_camera=False,
                              ground_truth_rate=1.0))
    for index, robot in enumerate((LEADER, HELPER, BYSTANDER)):
        params = {**files, 'robot': robot, 'task': 'navigation' if robot == LEADER else 'none',
                  'team_task': 'navigation', 'loss_probability': loss, 'seed': 100 + index, 'search_time': 3.0}
        session.start(NodeSpec('coalition_agents', 'schema_agent', name=f'schema_agent_{robot}',
                               parameters=[params]))
    return scenario


@pytest.mark.parametrize('loss', [0.0, 0.2])
def test_robot_without_localisation_forms_its_least_cost_coalition(session, files, config_dir, loss):
    wall_start = time.monotonic()
    scenario = start_team(session, files, config_dir, loss)
    expected = expected_best(files, scenario)
    assert expected is not None
    # A malformed message on the channel (unknown information type) is dropped with a message.
    publisher = session.observer.node.create_publisher(AgentMessage, '/coalition/channel', 10)
    deadline = time.monotonic() + 30.0
    while publisher.get_subscription_count() < 3:  # every agent, not just the first to match
        assert time.monotonic() < deadline, 'the agents did not all subscribe to /coalition/channel'
        time.sleep(0.05)
    publisher.publish(AgentMessage(message_id=1, sender=BYSTANDER, kind=AgentMessage.REQUEST,
                                   label=Information(type='F_Q', referents=['X'])))
    leader = session.wait_for_message(f'/{LEADER}/coalition', STATUS, latched=True, timeout=45.0,
                                      predicate=lambda m: m.state in ('committed', 'failed'))
    wall = time.monotonic() - wall_start
    assert leader.state == 'committed', leader.detail
    assert tuple(leader.members) == expected.members == (LEADER, HELPER)
    assert leader.cost == pytest.approx(expected.cost)
    assert leader.leader == LEADER
    helper = session.wait_for_message(f'/{HELPER}/coalition', STATUS, latched=True, timeout=10.0,
                                      predicate=lambda m: m.state == 'committed')
    assert (helper.coalition_id, helper.leader, tuple(helper.members)) == \
        (leader.coalition_id, LEADER, tuple(leader.members))
    bystander = session.wait_for_message(f'/{BYSTANDER}/coalition', STATUS, latched=True, timeout=10.0)
    assert bystander.state != 'committed' and bystander.coalition_id == ''
    # Nobody held two commitments: each agent logs every commitment it took.
    for robot in (LEADER, HELPER, BYSTANDER):
        log = (session.run_dir / 'logs' / f'schema_agent_{robot}.log').read_text()
        committed = re.findall(r'committed to coalition (\S+)|coalition (\S+) established', log)
        assert len(committed) <= 1, f'{robot} committed twice: {committed}'
    leader_log = session.run_dir / 'logs' / f'schema_agent_{LEADER}.log'
    deadline = time.monotonic() + 10.0  # the log is written by another process
    while 'dropped malformed channel message' not in leader_log.read_text():
        assert time.monotonic() < deadline, 'the malformed message was not reported by the leader'
        time.sleep(0.1)
    formed = re.search(r'\((\d+\.\d+) s\)', leader.detail)
    print(f'\nloss {loss}: coalition {leader.coalition_id} cost {leader.cost:g} formed after '
          f'{formed.group(1)} sim s (search_time 3 s), {wall:.1f} wall s from start; '
          f'retries {leader.retries}, dropped {leader.dropped}')


def test_bad_parameters_and_files_stop_the_agent_with_a_message(session, files, tmp_path):
    bad = tmp_path / 'caps.yaml'
    bad.write_text('robot_types: {t: {sensors: [{name: gps, provides: [F_Q(local)]}]}}\nrobots: {robot_blind: t}\n')
    cases = [({**files, 'robot': 'robot_blind', 'capability_file': str(bad)}, 'parameter capability_file:'),
             ({**files, 'robot': 'robot_nobody'}, "parameter robot: 'robot_nobody' is not in"),
             ({**files, 'robot': LEADER, 'task': 'teleport'}, "parameter task: unknown task 'teleport'"),
             ({**files, 'robot': HELPER}, "parameter team_task: required when task is 'none'"),
             ({**files, 'robot': LEADER, 'task': 'navigation', 'loss_probability': 1.5},
              'parameter loss_probability: must be a number in [0, 1]')]
    for index, (params, expected) in enumerate(cases):
        process = session.start(NodeSpec('coalition_agents', 'schema_agent', name=f'bad_agent_{index}',
                                         parameters=[params], required=False))
        assert session.wait_for_exit(f'bad_agent_{index}', timeout=60.0) == 2
        assert expected in process.log_path.read_text(), process.log_path.read_text()
