"""set_parameters on the coalition nodes: with three agents hosted in one schema_agent_host on the
bridge, node names are unique, every dynamic parameter of a schema_agent changes what it does,
every other one is refused (read-only), and so is a value of the wrong type or out of range; a bad
start-up parameter stops either node with exit code 2.

Rates are measured in simulated time (/clock, message stamps), so a slow machine cannot fail them.
"""

import threading
import time

import pytest
import yaml
from coalition_interfaces.msg import AgentMessageBundle, AgentStatus
from geometry_msgs.msg import Twist
from rosgraph_msgs.msg import Clock

from collab_tools.orchestration.node_process import NodeSpec
from collab_tools.qos import SENSOR_IN
from bridge_helpers import bridge_spec
from parameter_client import descriptors, get_value, set_one
from coalition_agents.transport.agent_channel import CHANNEL_QOS
from coalition_agents.core.settings import AGENT_SETTINGS, DYNAMIC
from coalition_agents.core.sim_scenarios import agent_parameter_file

LEADER, HELPER, BYSTANDER = 'robot_blind', 'robot_helper', 'robot_bystander'
AGENT = f'/{LEADER}/schema_agent'
STATUS = 'coalition_interfaces/msg/AgentStatus'
OWN = {'robot', 'team_namespace'}  # RobotNode's (read-only)


def files(config_dir):
    coalitions = config_dir / 'coalitions'
    return {'capability_file': str(coalitions / 'capabilities' / 'coalition_three_robots.yaml'),
            'schemas_file': str(coalitions / 'schemas.yaml'), 'costs_file': str(coalitions / 'costs.yaml'),
            'tasks_file': str(coalitions / 'tasks.yaml')}


class SimWindow:
    """Messages of a topic with the simulated time (/clock) they arrived at."""

    def __init__(self, node, msg_type, topic, qos, wall_timeout: float = 30.0):
        self.lock = threading.Lock()
        self.clock = 0.0
        self.received: list[tuple[float, object]] = []
        self.subscriptions = [
            node.create_subscription(Clock, '/clock', self._on_clock, SENSOR_IN),
            node.create_subscription(msg_type, topic, self._on_message, qos)]
        deadline = time.monotonic() + wall_timeout  # both matched and flowing
        while not (self.clock > 0.0 and self.received):
            assert time.monotonic() < deadline, f'nothing on {topic} or /clock'
            time.sleep(0.05)

    def _on_clock(self, msg):
        self.clock = msg.clock.sec + msg.clock.nanosec * 1e-9

    def _on_message(self, msg):
        with self.lock:
            self.received.append((self.clock, msg))

    def collect(self, sim_seconds: float, wall_timeout: float = 60.0) -> list:
        """The messages of the next ``sim_seconds`` of simulated time."""
        start, deadline = self.clock, time.monotonic() + wall_timeout
        with self.lock:
            self.received.clear()
        while self.clock < start + sim_seconds:
            assert time.monotonic() < deadline, 'the simulation does not advance'
            time.sleep(0.05)
        with self.lock:
            return [msg for stamp, msg in self.received if start <= stamp < start + sim_seconds]


def information_from(bundles, sender):
    # The bundle topic carries every agent's batches, messages as columns (kinds: 8 = INFORMATION).
    return sum(1 for bundle in bundles for b in bundle.batches if b.sender == sender for kind in b.kinds if kind == 8)


def test_set_parameters_on_hosted_schema_agents(session, config_dir, tmp_path):
    scenario = config_dir / 'scenarios' / 'coalition_three_robots.yaml'
    session.start(bridge_spec(scenario, real_time_factor=1.0, start_paused=False, publish_camera=False,
                              ground_truth_rate=1.0))
    agents = tmp_path / 'agents.yaml'
    # The leader drives slowly towards a goal 1 m ahead (its helper, which localises it, stays 1 m beyond).
    agents.write_text(yaml.safe_dump(agent_parameter_file(
        {**files(config_dir), 'task': 'none', 'team_task': 'navigation', 'search_time': 3.0, 'seed': 7},
        {LEADER: {'task': 'navigation', 'drive': True, 'goal_position': [1.0, 0.0], 'max_speed': 0.03}})))
    session.start(NodeSpec('coalition_agents', 'schema_agent_host',
                           parameters=[{'robots': [LEADER, HELPER, BYSTANDER], 'agent_parameters': str(agents)}]))
    node = session.observer.node
    deadline = time.monotonic() + 60.0
    while len([n for n in node.get_node_names_and_namespaces() if n[0] == 'schema_agent']) < 3:
        assert time.monotonic() < deadline, node.get_node_names_and_namespaces()
        time.sleep(0.1)
    names = node.get_node_names_and_namespaces()
    assert len(names) == len(set(names)), names
    assert {('schema_agent', f'/{r}') for r in (LEADER, HELPER, BYSTANDER)} | {('schema_agent_host', '/')} \
        <= set(names)

    # Descriptors: a description each; dynamic exactly as declared; ranges where they apply.
    described = descriptors(session, AGENT)
    assert set(described) == set(AGENT_SETTINGS.names) | OWN
    for name, descriptor in described.items():
        assert descriptor.description, name
        assert descriptor.read_only == (name not in DYNAMIC), name
    loss = described['loss_probability'].floating_point_range[0]
    assert (loss.from_value, loss.to_value) == (0.0, 1.0)
    assert described['max_reforms'].integer_range[0].from_value == 0
    # Read-only: refused with a reason, value unchanged (also the host's own).
    for name, value in (('loss_probability', 0.5), ('search_time', 9.0), ('drive', False), ('robot', HELPER)):
        result = set_one(session, AGENT, name, value)
        assert not result.successful and 'read-only' in result.reason, (name, result.reason)
    assert get_value(session, AGENT, 'loss_probability') == 0.0
    assert not set_one(session, '/schema_agent_host', 'linger', 5.0).successful
    # Wrong type and out of range: refused, the value stays.
    assert not set_one(session, AGENT, 'max_speed', 'fast').successful
    assert not set_one(session, AGENT, 'max_speed', 0.0).successful
    assert not set_one(session, AGENT, 'tick_period', -1.0).successful
    assert get_value(session, AGENT, 'max_speed') == 0.03

    leader = session.wait_for_message(f'/{LEADER}/coalition', STATUS, latched=True, timeout=60.0,
                                      predicate=lambda m: m.state in (AgentStatus.COMMITTED, AgentStatus.FAILED))
    assert leader.state == AgentStatus.COMMITTED and tuple(leader.members) == (LEADER, HELPER), leader.detail

    commands = SimWindow(node, Twist, f'/{LEADER}/cmd_vel', 10, wall_timeout=90.0)  # formation first; slow under load
    # tick_period: the leader commands cmd_vel once per tick.
    fast = len(commands.collect(3.0))
    assert set_one(session, AGENT, 'tick_period', 0.5).successful
    commands.collect(0.6)
    slow = commands.collect(3.0)
    assert len(slow) < fast / 2, (fast, len(slow))
    assert set_one(session, AGENT, 'tick_period', 0.1).successful
    # max_speed (0.03 m/s at start): every command within it; raised, the leader drives faster.
    assert slow and max(c.linear.x for c in slow) <= 0.03 + 1e-9

    # stream_rate of the helper: its INFORMATION messages to the leader.
    inbox = SimWindow(node, AgentMessageBundle, '/coalition/bundles', CHANNEL_QOS)
    before = information_from(inbox.collect(3.0), HELPER)
    assert set_one(session, f'/{HELPER}/schema_agent', 'stream_rate', 1.0).successful
    inbox.collect(1.2)
    after = information_from(inbox.collect(3.0), HELPER)
    assert 0 < after < before / 2, (before, after)
    assert set_one(session, f'/{HELPER}/schema_agent', 'stream_rate', 5.0).successful

    assert set_one(session, AGENT, 'max_speed', 0.2).successful
    deadline = time.monotonic() + 30.0
    while not any(c.linear.x > 0.05 for c in commands.collect(0.5)):
        assert time.monotonic() < deadline, 'the leader did not drive faster than the old limit'
    # goal_tolerance: widened beyond the remaining distance, the task is complete at once.
    assert set_one(session, AGENT, 'goal_tolerance', 5.0).successful
    done = session.wait_for_message(f'/{LEADER}/coalition', STATUS, latched=True, timeout=30.0,
                                    predicate=lambda m: m.state in (AgentStatus.COMPLETED, AgentStatus.FAILED))
    assert done.state == AgentStatus.COMPLETED, done.detail
    distance = done.goal_distance
    assert distance > 0.25  # the start-up tolerance would not have completed it
    print(f'\ncmd_vel per 3 sim s: {fast} (tick 0.1 s), {len(slow)} (tick 0.5 s); helper INFORMATION per 3 sim s: '
          f'{before} (5 Hz), {after} (1 Hz); completed {distance:.2f} m from the goal (tolerance 5 m)')


@pytest.mark.parametrize('executable, parameters, expected', [
    # One case per executable; the other bad values are unit tests of the settings
    # (test/unit/coalitions/test_coalition_settings.py, test_coalition_node_parameters.py).
    ('schema_agent', {'task': 'navigation', 'max_speed': -1.0}, 'parameter max_speed: must be in (0, 5]'),
    ('schema_agent_host', {'robots': [LEADER, LEADER]}, 'parameter robots: names a robot twice'),
])
def test_a_bad_start_parameter_stops_the_node_with_exit_code_2(session, config_dir, tmp_path, executable,
                                                               parameters, expected):
    if executable == 'schema_agent':
        spec = NodeSpec('coalition_agents', executable, name='schema_agent', namespace=f'/{LEADER}',
                        parameters=[{**files(config_dir), **parameters}], required=False)
    else:
        agents = tmp_path / 'agents.yaml'
        agents.write_text(yaml.safe_dump(agent_parameter_file({**files(config_dir), 'task': 'navigation'}, {})))
        spec = NodeSpec('coalition_agents', executable, parameters=[{'agent_parameters': str(agents), **parameters}],
                        required=False)
    process = session.start(spec)
    assert session.wait_for_exit(process.name, timeout=60.0) == 2
    log = process.log_path.read_text()
    assert expected in log and 'Traceback' not in log, log
