"""The pure parts of the coalition nodes' parameters and of the agent host's arguments."""

import pytest

from collab_tools.node_support import ConfigurationError
from coalition_agents.agent_host import HOST_SETTINGS, forwarded_parameter_files, forwarded_remappings
from coalition_agents.core.settings import AGENT_SETTINGS, DYNAMIC, link_model, load_files, retry_policy


def values(**changes):
    return {**AGENT_SETTINGS.defaults(), **changes}


def test_the_host_forwards_its_remappings_but_not_its_name_or_namespace():
    argv = ['schema_agent_host', '--ros-args', '-r', '__node:=host_2', '-r', '__ns:=/sim1', '-r', '/clock:=/sim1/clock',
            '--params-file', 'p.yaml', '--remap', 'coalition/channel:=chan', '-r', 'schema_agent_host:foo:=bar',
            '-r', 'schema_agent:scan:=scan_front', '-p', 'x:=1', '--', '-r', 'a:=b']
    assert forwarded_remappings(argv) == ['-r', '/clock:=/sim1/clock', '-r', 'coalition/channel:=chan',
                                          '-r', 'schema_agent:scan:=scan_front']
    assert forwarded_remappings(['schema_agent_host']) == []


def test_the_host_forwards_its_parameter_files_to_its_agents():
    argv = ['schema_agent_host', '--ros-args', '-r', '__ns:=/sim1', '--params-file', '/run/params/host.0.yaml',
            '-p', 'robots:=[a]', '--params-file', '/run/params/host.1.yaml', '--', '--params-file', 'not_ros.yaml']
    assert forwarded_parameter_files(argv) == ['--params-file', '/run/params/host.0.yaml',
                                               '--params-file', '/run/params/host.1.yaml']
    assert forwarded_parameter_files(['schema_agent_host', '--params-file', 'x.yaml']) == []  # not a ROS argument


@pytest.mark.parametrize('values, message', [
    ({'robots': ['robot_1', 'robot_1']}, "parameter robots: names a robot twice (got ['robot_1', 'robot_1'])"),
    ({'robots': ['1robot']}, 'parameter robots: must be a ROS name token'),
    ({}, 'parameter robots: required'),
    ({'robots': ['a'], 'agent_parameters': '/nowhere/agents.yaml'},
     "parameter agent_parameters: file '/nowhere/agents.yaml': does not exist"),
    ({'robots': ['a'], 'executor': 'many'}, 'parameter executor: must be one of single, multi'),
    ({'robots': ['a'], 'work_slice': 0.0}, 'parameter work_slice: must be in (0, 1]'),
])
def test_bad_host_parameters_name_the_parameter(values, message):
    """The schema_agent_host's start values (one integration case proves the exit code 2)."""
    with pytest.raises(ConfigurationError) as caught:
        HOST_SETTINGS.validate(values)
    assert str(caught.value).startswith(message), caught.value
    assert HOST_SETTINGS.validate({'robots': ['a', 'b']})['executor'] == 'single'


def file_values(config_dir, **changes):
    return values(schemas_file=str(config_dir / 'schemas.yaml'), costs_file=str(config_dir / 'costs.yaml'),
                  tasks_file=str(config_dir / 'tasks.yaml'), **changes)


def test_capabilities_come_from_a_file_or_from_the_capabilities_parameter(config_dir):
    path = config_dir / 'capabilities' / 'coalition_three_robots.yaml'
    *_, from_file = load_files(file_values(config_dir, capability_file=str(path)))
    *_, inline = load_files(file_values(config_dir, capabilities=path.read_text()))
    assert inline == from_file and 'robot_blind' in inline.robots
    assert AGENT_SETTINGS['capability_file'].default == AGENT_SETTINGS['capabilities'].default == ''  # neither is required alone


@pytest.mark.parametrize('changes, message', [
    ({}, 'parameter capability_file / capabilities: give exactly one of them (got neither)'),
    ({'capability_file': 'CAPS', 'capabilities': 'robot_types: {t: {}}'},
     'parameter capability_file / capabilities: give exactly one of them (got both)'),
    ({'capabilities': 'robot_types: [unclosed'}, 'parameter capabilities: invalid YAML'),
    ({'capabilities': 'robot_types: {t: {sensors: [{name: gps, provides: [F_Q(local)]}]}}'},
     'parameter capabilities: robot_types.t.sensors[0].provides[0]'),
    ({'capability_file': 'MISSING'}, 'parameter capability_file: '),
])
def test_capability_errors_name_the_parameter(config_dir, tmp_path, changes, message):
    caps = config_dir / 'capabilities' / 'coalition_three_robots.yaml'
    changes = {name: {'CAPS': str(caps), 'MISSING': str(tmp_path / 'missing.yaml')}.get(value, value)
               for name, value in changes.items()}
    with pytest.raises(ConfigurationError) as caught:
        load_files(file_values(config_dir, **changes))
    assert str(caught.value).startswith(message), caught.value


def test_every_dynamic_parameter_is_declared_and_documented():
    assert set(DYNAMIC) <= set(AGENT_SETTINGS.names)
    assert {s.name for s in AGENT_SETTINGS if s.dynamic} == set(DYNAMIC)
    for name in DYNAMIC:
        assert 'dynamic' in AGENT_SETTINGS[name].description


def test_link_model_from_the_parameters():
    model = link_model(values(loss_probability=0.25, seed=3))
    assert (model.loss_probability, model.seed) == (0.25, 3)
    assert model.delay.mean_s == pytest.approx(0.00385)  # the paper_fig9 preset
    model = link_model(values(link_delay_mean=0.02, seed=-1))
    assert (model.delay.mean_s, model.delay.std_s, model.seed) == (0.02, pytest.approx(0.00505), None)
    assert link_model(values(link_preset='ideal')).sample() == (True, 0.0)
    jitter = link_model(values(link_preset='ideal', link_delay_std=0.01)).delay  # the preset's mean, 0
    assert (jitter.distribution, jitter.mean_s, jitter.std_s) == ('normal', 0.0, 0.01)


def test_retry_policy_from_the_parameters():
    policy = retry_policy(values(tail_timeout=12.0, peer_timeout=40.0, reorder_window=0.1))
    assert (policy.tail_timeout_s, policy.max_timeout_s, policy.peer_timeout_s, policy.message_lifetime_s,
            policy.reorder_window_s) == (12.0, 12.0, 40.0, 40.0, 0.1)


def test_boxpush_agents_are_the_robots_of_their_namespaces(config_dir):
    from collab_tools.orchestration.experiment import load_experiment
    from coalition_agents.experiments.boxpush import agent_nodes
    agents = agent_nodes(load_experiment(config_dir.parent / 'experiments' / 'coalition_boxpush.yaml'))
    assert sorted(agents) == ['localizer_l1', 'localizer_l2', 'pusher_g1', 'pusher_r1', 'pusher_r2']
    assert agents['pusher_g1']['exit_after'] == ['pusher_r2'] and agents['pusher_g1']['robot'] == 'pusher_g1'
    with pytest.raises(ValueError, match=r'nodes\[0\] \(schema_agent\): needs namespace'):
        agent_nodes({'nodes': [{'package': 'coalition_agents', 'executable': 'schema_agent', 'parameters': [{}]}]})


def test_boxpush_agents_read_only_tracked_config(config_dir):
    """No agent of the box-pushing experiment reads a generated file: every path it is given is
    under the repository's config/ (the agents can run on any machine with a checkout)."""
    import yaml
    experiment = yaml.safe_load((config_dir.parent / 'experiments' / 'coalition_boxpush.yaml').read_text())
    paths = []
    for node in experiment['nodes']:
        for entry in node.get('parameters', []):
            for value in (entry.values() if isinstance(entry, dict) else [entry]):
                if isinstance(value, str) and ('/' in value or value.endswith('.yaml')):
                    paths.append(value)
    assert paths and all(p.startswith('{config}/') for p in paths), paths


def test_the_status_message_carries_the_typed_state_and_stamps():
    from builtin_interfaces.msg import Time
    from coalition_interfaces.msg import AgentStatus
    from coalition_agents.core.agent_state import AgentState, StatusReport
    from coalition_agents.schema_agent_node import status_message
    report = StatusReport('robot_1', AgentState.COMMITTED, 'navigation', 'robot_1/3', 'robot_1', ('robot_1', 'robot_2'),
                          16.0, search_started=5.0, coalition_found=5.4, found_cost=17.5, coalition_formed=6.25,
                          potential_solution=2, reforms=1, requests_sent=4, offers_received=3, detail='formed')
    msg = status_message(report, {'resent': 2, 'duplicates': 1, 'dropped': 5, 'session': 2 ** 62 + 3}, Time(sec=7))
    assert msg.session == 2 ** 62 + 3  # the agent's session: a restarted agent's statuses are told apart
    assert msg.state == AgentStatus.COMMITTED == AgentState.COMMITTED and AgentState(msg.state).label == 'committed'
    assert (msg.search_started.sec, msg.search_started.nanosec) == (5, 0)
    assert (msg.coalition_found.sec, msg.coalition_found.nanosec) == (5, 400_000_000)
    assert (msg.coalition_formed.sec, msg.coalition_formed.nanosec) == (6, 250_000_000)
    assert (msg.task_finished.sec, msg.task_finished.nanosec) == (0, 0)  # not yet
    assert (msg.found_cost, msg.potential_solution, msg.reforms, msg.retries, msg.duplicates, msg.dropped) == \
        (17.5, 2, 1, 2, 1, 5)
    assert msg.goal_distance != msg.goal_distance  # NaN: not executing
    assert list(msg.members) == ['robot_1', 'robot_2'] and msg.header.stamp.sec == 7
    # Every state the agents use is a message constant with the same value.
    assert {s.name: int(s) for s in AgentState} == {s.name: getattr(AgentStatus, s.name) for s in AgentState}
