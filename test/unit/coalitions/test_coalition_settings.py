"""A schema_agent's settings without ROS (core.settings): every bad start parameter or file is a
ConfigurationError naming the parameter, the one a node stops with (exit code 2). One integration
case per executable proves the exit code (test_coalition_parameters.py); these are the rest."""

import pytest

from collab_tools.core.errors import ConfigurationError
from coalition_agents.core.settings import AGENT_SETTINGS, MOTOR_SCHEMAS, AgentSettings

LEADER, HELPER = 'robot_blind', 'robot_helper'
BAD_CAPABILITIES = 'robot_types: {t: {sensors: [{name: gps, provides: [F_Q(local)]}]}}\nrobots: {robot_blind: t}\n'


@pytest.fixture
def files(config_dir):
    return {'capability_file': str(config_dir / 'capabilities' / 'coalition_three_robots.yaml'),
            'schemas_file': str(config_dir / 'schemas.yaml'), 'costs_file': str(config_dir / 'costs.yaml'),
            'tasks_file': str(config_dir / 'tasks.yaml')}


def refused(values, robot=LEADER):
    with pytest.raises(ConfigurationError) as caught:
        AgentSettings.build(values, robot, f'namespace /{robot}')
    return str(caught.value)


def test_good_settings_build_the_agent(files):
    settings = AgentSettings.build({**files, 'task': 'navigation', 'loss_probability': 0.2, 'seed': 3}, LEADER)
    assert settings.task.name == 'navigation' and settings.team_task is None
    assert set(settings.team) == {LEADER, HELPER, 'robot_bystander'}
    assert (settings.link.loss_probability, settings.link.seed) == (0.2, 3)
    assert settings['search_time'] == AGENT_SETTINGS['search_time'].default
    helper = AgentSettings.build({**files, 'team_task': 'navigation', 'exit_after': ['']}, HELPER)
    assert helper.task is None and helper.team_motor_schema == 'navigate' and helper['exit_after'] == []


def test_bad_files_name_their_parameter(files, tmp_path):
    bad = tmp_path / 'caps.yaml'
    bad.write_text(BAD_CAPABILITIES)
    inline = {name: value for name, value in files.items() if name != 'capability_file'}
    assert refused({**files, 'capability_file': str(bad)}).startswith('parameter capability_file:')
    assert refused({**inline, 'capabilities': BAD_CAPABILITIES}).startswith('parameter capabilities: robot_types.t')
    assert refused({**files, 'capabilities': BAD_CAPABILITIES}) == \
        'parameter capability_file / capabilities: give exactly one of them (got both)'
    assert refused({**files, 'capability_file': str(tmp_path / 'missing.yaml')}).startswith(
        'parameter capability_file: no such file')
    assert refused({**files, 'schemas_file': ''}) == 'parameter schemas_file: required'


def test_the_robot_must_be_in_the_team(files):
    assert "namespace /robot_nobody: robot 'robot_nobody' is not in the capability file's robots" in \
        refused(files, 'robot_nobody')


@pytest.mark.parametrize('changes, robot, expected', [
    ({'task': 'teleport'}, LEADER, "parameter task: unknown task 'teleport'"),
    ({}, HELPER, "parameter team_task: required when task is 'none'"),
    ({'team_task': 'fly'}, HELPER, "parameter team_task: unknown task 'fly'"),
    ({'task': 'navigation', 'loss_probability': 1.5}, LEADER, 'parameter loss_probability: must be in [0, 1]'),
    ({'task': 'navigation', 'max_speed': -1.0}, LEADER, 'parameter max_speed: must be in (0, 5]'),
    ({'task': 'navigation', 'stream_rate': 'often'}, LEADER, 'parameter stream_rate: must be a number'),
    ({'task': 'navigation', 'goal_position': [1.0]}, LEADER, 'parameter goal_position: must have exactly 2 elements'),
    ({'task': 'navigation', 'link_preset': 'carrier_pigeon'}, LEADER, 'parameter link_preset: must be one of'),
    ({'task': 'navigation', 'exit_after': ['robot_nobody']}, LEADER,
     "parameter exit_after: 'robot_nobody' is not in the capability file's robots"),
    ({'task': 'navigation', 'search_tme': 3.0}, LEADER, 'parameter search_tme: unknown'),
    ({'task': 'navigation', 'aimed_sensors': ['camera']}, LEADER,
     "parameter aimed_sensors: 'camera' is not a sensor of robot_blind"),
])
def test_bad_parameters_are_refused_with_their_name(files, changes, robot, expected):
    assert expected in refused({**files, **changes}, robot)


def test_a_driving_leader_needs_an_implemented_motor_schema(files):
    task = 'monitoring'  # config/coalitions/tasks.yaml: motor schema report_target (not driven here)
    assert 'report_target' not in MOTOR_SCHEMAS
    AgentSettings.build({**files, 'task': task}, LEADER)  # reasoning about it needs no implementation
    assert refused({**files, 'task': task, 'drive': True}).startswith(
        "parameter drive: task monitoring's motor schema report_target has no implementation here")


def test_the_schema_names_the_node_parameters_and_their_dynamic_ones():
    dynamic = {setting.name for setting in AGENT_SETTINGS if setting.dynamic}
    assert dynamic == {'max_speed', 'goal_tolerance', 'stream_rate', 'tick_period'}
    assert all(setting.description for setting in AGENT_SETTINGS)
