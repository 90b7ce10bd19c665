"""The role nodes' parameters as schemas (core.node_settings): every bad start value the nodes refuse with
exit code 2, checked without starting a node (one integration test per executable proves the exit)."""
import re
from pathlib import Path

import pytest
import yaml

from collab_tools.core.errors import ConfigurationError
from collab_tools.names import RobotNode
from role_engine.core.environment import RobotType
from role_engine.core.formation_task import load_formation_task
from role_engine.core.node_settings import (ENGINE_SETTINGS, PLAYER_SETTINGS, TRACKER_SETTINGS, engine_settings_file,
                                            engine_tuning_schema, player_settings_file, player_tuning_schema,
                                            team_member, tracking_settings, tuned)
from role_engine.core.tracking import TrackingSettings
from role_engine.core.tuning import EngineTuning, PlayerTuning

CONFIG = Path(__file__).resolve().parents[3] / 'config'
SETTINGS = CONFIG / 'roles' / 'formation_demo.yaml'
BURGER = RobotType('turtlebot3_burger', 0.105, max_linear_velocity=0.22, max_angular_velocity=2.84)


def edited_settings(tmp_path, edit):
    """formation_demo.yaml with ``edit`` (dotted keys) applied, its scenario an absolute path."""
    data = yaml.safe_load(SETTINGS.read_text())
    data['scenario'] = str(CONFIG / 'scenarios' / 'roles_formation.yaml')
    for key, value in edit.items():
        section, _, field = key.partition('.')
        if field:
            data[section][field] = value
        else:
            data[key] = value
    path = tmp_path / 'settings.yaml'
    path.write_text(yaml.safe_dump(data))
    return str(path)


def refused(message):
    return pytest.raises(ConfigurationError, match=re.escape(message))


# --- role_engine --------------------------------------------------------------------------------
def test_engine_settings_defaults_and_team():
    values = ENGINE_SETTINGS.validate({'settings_file': str(SETTINGS)})
    assert values == {'settings_file': str(SETTINGS), 'camera': 'top_camera', 'exit_when_done': False}
    task, scenario, team = engine_settings_file(values['settings_file'])
    assert [m.name for m in team] == ['pioneer_1', 'pioneer_2', 'burger_1', 'burger_2']
    assert scenario.world.frame_id and task.formation['type'] == 'diamond'


@pytest.mark.parametrize('values, message', [
    ({}, 'parameter settings_file: required'),
    ({'settings_file': 'x.yaml', 'exit_when_done': 'yes'}, 'parameter exit_when_done: must be true or false'),
    ({'settings_file': 'x.yaml', 'camera': '/'}, 'parameter camera: must be a non-empty namespace'),
    ({'settings_file': 'x.yaml', 'horizon': 3}, 'parameter horizon: unknown'),
])
def test_engine_read_only_parameters_are_checked(values, message):
    with refused(message):
        ENGINE_SETTINGS.validate(values)


@pytest.mark.parametrize('edit, message', [
    (None, "parameter settings_file: settings file 'missing.yaml': does not exist"),
    ({'silence_timeout': -1.0}, 'silence_timeout: must be > 0.0'),
    ({'problem_detection.stuck_time': 0.0}, 'problem_detection.stuck_time: must be > 0.0'),
    ({'scenario': 'nowhere.yaml'}, 'scenario: scenario file'),
])
def test_engine_settings_file_errors_name_the_field(tmp_path, edit, message):
    path = 'missing.yaml' if edit is None else edited_settings(tmp_path, edit)
    with refused(message) as caught:
        engine_settings_file(path)
    assert str(caught.value).startswith('parameter settings_file: ')


def test_engine_tuning_defaults_come_from_the_settings_file_and_bad_values_are_refused():
    tuning = EngineTuning.from_task(load_formation_task(SETTINGS))
    schema = engine_tuning_schema(tuning)
    assert all(setting.dynamic for setting in schema)
    assert tuned(tuning, schema.validate({})) == tuning
    assert tuned(tuning, schema.validate({'min_robots': 2})).min_robots == 2
    for values, message in (({'min_robots': 0}, 'parameter min_robots: must be in [1, inf]'),
                            ({'silence_timeout': 0.0}, 'parameter silence_timeout: must be in (0, inf]'),
                            ({'problem_detection.off_role_grace': -1.0},
                             'parameter problem_detection.off_role_grace: must be in [0, inf]'),
                            ({'start_delay': 'soon'}, 'parameter start_delay: must be a number')):
        with refused(message):
            schema.validate(values)


# --- role_player --------------------------------------------------------------------------------
def test_player_settings_need_no_scenario(tmp_path):
    assert PLAYER_SETTINGS.names == ['settings_file', 'engine']
    with refused('parameter settings_file: required'):
        PLAYER_SETTINGS.validate({})
    task = player_settings_file(edited_settings(tmp_path, {'scenario': 'nowhere.yaml'}))
    assert task.replan_period > 0
    assert PLAYER_SETTINGS.validate({'settings_file': 'x'})['engine'] == 'role_engine'
    with refused('parameter engine: must be a ROS node name'):
        PLAYER_SETTINGS.validate({'settings_file': 'x', 'engine': '/role_engine'})


@pytest.mark.parametrize('edit, message', [
    ({'robot_avoidance.sigma': 'stiff'}, 'robot_avoidance.sigma'),
    ({'trajectory.states': 1}, 'trajectory.states'),
])
def test_player_settings_file_errors_name_the_field(tmp_path, edit, message):
    with refused('parameter settings_file: ') as caught:
        player_settings_file(edited_settings(tmp_path, edit))
    assert message in str(caught.value)


def test_a_player_outside_the_team_is_refused():
    team = engine_settings_file(str(SETTINGS))[2]
    assert team_member(team, 'burger_1', '/burger_1').robot_type.name == 'turtlebot3_burger'
    with refused('parameter robot: must be one of pioneer_1, pioneer_2, burger_1, burger_2 '
                 "(got 'pioneer_9', the last component of the namespace /pioneer_9)"):
        team_member(team, 'pioneer_9', '/pioneer_9')


class FakeNode:
    def __init__(self, namespace):
        self.namespace = namespace

    def get_namespace(self):
        return self.namespace


class FakeParameters:
    """Declares like NodeParameters (start values from ``given``, the setting's default otherwise)."""

    def __init__(self, **given):
        self.given = given

    def declare(self, name, default, description, check=None, **_):
        value = self.given.get(name, default)
        problem = check(value) if check else None
        if problem:
            raise ConfigurationError(f'parameter {name}: {problem}')
        return value


@pytest.mark.parametrize('namespace, given, message', [
    ('/', {}, "the node must run in its robot's namespace"),
    ('/burger_1', {'robot': 'burger_2'}, "parameter robot: 'burger_2' differs from the node's namespace /burger_1"),
])
def test_a_player_runs_in_its_robots_namespace(namespace, given, message):
    with refused(message):
        RobotNode(FakeNode(namespace), FakeParameters(**given))
    assert RobotNode(FakeNode('/team/burger_1'), FakeParameters()).robot == 'burger_1'


def test_player_tuning_caps_the_velocities_at_the_robot_types_limits():
    tuning = PlayerTuning.from_task(load_formation_task(SETTINGS), BURGER)
    schema = player_tuning_schema(tuning)
    assert all(setting.dynamic for setting in schema)
    assert tuned(tuning, schema.validate({})) == tuning
    assert tuned(tuning, schema.validate({'max_linear_velocity': 0.1})).gp_config().max_speed == pytest.approx(0.08)
    for values, message in (({'max_linear_velocity': 0.5}, 'parameter max_linear_velocity: must be in (0, 0.22]'),
                            ({'max_angular_velocity': 3.0}, 'parameter max_angular_velocity: must be in (0, 2.84]'),
                            ({'speed_fraction': 1.5}, 'parameter speed_fraction: must be in (0, 1]'),
                            ({'gp.formulation': 'magic'}, 'parameter gp.formulation: must be one of'),
                            ({'gp.max_iterations': 0}, 'parameter gp.max_iterations: must be in [1, inf]'),
                            ({'robot_avoidance.detour_scales': [1.0, -2.0]},
                             'parameter robot_avoidance.detour_scales: must be in [0, inf] for each element')):
        with refused(message):
            schema.validate(values)


def test_a_tuning_check_beyond_the_schema_names_the_parameter():
    tuning = PlayerTuning.from_task(load_formation_task(SETTINGS), BURGER)
    with refused('parameter robot_avoidance.sigma'):
        tuned(tuning, {'robot_avoidance.sigma': 0.0})


# --- robot_tracker ------------------------------------------------------------------------------
def test_tracker_parameters():
    values = TRACKER_SETTINGS.validate({})
    assert tracking_settings(values) == TrackingSettings()
    assert [s.name for s in TRACKER_SETTINGS if s.dynamic] == ['chroma_tolerance', 'min_brightness', 'min_area_px']
    for given, message in (({'min_area_px': 0}, 'parameter min_area_px: must be in [1, inf]'),
                           ({'camera': '/'}, 'parameter camera: must be a non-empty namespace'),
                           ({'chroma_tolerance': 0.0}, 'parameter chroma_tolerance: must be in (0, 1]'),
                           ({'min_brightness': 800.0}, 'parameter min_brightness: must be in [0, 765]')):
        with refused(message):
            TRACKER_SETTINGS.validate(given)
    assert values['camera'] == 'top_camera'
