"""The SGCM nodes' parameters as data (sgcm.core.settings): bad values are refused with the parameter
named, without starting a node (test_sgcm_nodes.py keeps one launch per executable proving the
node exits 2 with such a message)."""
import re

import pytest

from collab_tools.core.errors import ConfigurationError
from sgcm.core.settings import (FOLLOWER_SETTINGS, IMAGE_TRANSPORTS, LEADER_SETTINGS, FollowerExecutorSettings,
                                LeaderSettings)
from sgcm.core.task_config import MAX_HORIZON


@pytest.mark.parametrize('schema, values, message', [
    (LEADER_SETTINGS, {}, 'parameter task_file: required'),
    (LEADER_SETTINGS, {'strategy': 'telepathy'}, "parameter strategy: must be one of sgcm, greedy (got 'telepathy')"),
    (LEADER_SETTINGS, {'solver': 'oracle'}, 'parameter solver: must be one of fast, milp'),
    (LEADER_SETTINGS, {'horizon': 7}, 'parameter horizon: must be in [0, 6] (got 7)'),
    (LEADER_SETTINGS, {'horizon': -1}, 'parameter horizon: must be in [0, 6] (got -1)'),
    (LEADER_SETTINGS, {'settle_time': 'long'}, "parameter settle_time: must be a number (got 'long')"),
    (LEADER_SETTINGS, {'follower_timeout': -1.0}, 'parameter follower_timeout: must be in [0, inf]'),
    (LEADER_SETTINGS, {'round_limit': -2}, 'parameter round_limit: must be in [0, inf]'),
    (LEADER_SETTINGS, {'seed': -1}, 'parameter seed: must be in [0, inf]'),
    (LEADER_SETTINGS, {'moves_can_fail': 'yes'}, "parameter moves_can_fail: must be true or false (got 'yes')"),
    (LEADER_SETTINGS, {'camera': '/'}, "parameter camera: must name the camera's namespace"),
    (LEADER_SETTINGS, {'image_transport': 'theora'}, 'parameter image_transport: must be one of raw, compressed'),
    (LEADER_SETTINGS, {'horizont': 2}, 'parameter horizont: unknown'),
    (FOLLOWER_SETTINGS, {}, 'parameter task_file: required'),
    (FOLLOWER_SETTINGS, {'behaviour': 'sneaky'}, 'parameter behaviour: must be one of obedient, myopic'),
    (FOLLOWER_SETTINGS, {'deviation_probability': 1.5}, 'parameter deviation_probability: must be in [0, 1] (got 1.5)'),
    (FOLLOWER_SETTINGS, {'deviation_rounds': [2, -1]},
     'parameter deviation_rounds: must be in [0, inf] for each element (got [2, -1])'),
    (FOLLOWER_SETTINGS, {'settle_time': -0.5}, 'parameter settle_time: must be in [0, inf]'),
    (FOLLOWER_SETTINGS, {'image_transport': 'theora'}, 'parameter image_transport: must be one of raw, compressed'),
])
def test_bad_values_name_the_parameter(task_file, schema, values, message):
    if values:
        values = {'task_file': str(task_file), **values}
    with pytest.raises(ConfigurationError, match='^' + re.escape(message)):
        schema.validate(values)


def test_only_the_documented_parameters_are_dynamic():
    assert {s.name for s in LEADER_SETTINGS if s.dynamic} == {'horizon', 'round_limit', 'follower_timeout',
                                                             'settle_time', 'perception_fault_after'}
    assert {s.name for s in FOLLOWER_SETTINGS if s.dynamic} == {'settle_time', 'perception_fault_after'}
    assert LEADER_SETTINGS['horizon'].high == MAX_HORIZON
    assert all(s.description for s in (*LEADER_SETTINGS, *FOLLOWER_SETTINGS))


def test_leader_settings_take_the_task_file_values_for_zero(task_file):
    settings = LeaderSettings.from_values(LEADER_SETTINGS.validate({'task_file': str(task_file)}))
    assert settings.horizon == settings.task.horizon == 2
    assert settings.round_limit is None and settings.moves_can_fail and settings.strategy == 'sgcm'
    settings = LeaderSettings.from_values(LEADER_SETTINGS.validate(
        {'task_file': str(task_file), 'horizon': 3, 'round_limit': 5, 'moves_can_fail': False}))
    assert (settings.horizon, settings.round_limit, settings.moves_can_fail) == (3, 5, False)


def test_follower_settings_drop_the_no_round_marker(task_file):
    settings = FollowerExecutorSettings.from_values(FOLLOWER_SETTINGS.validate({'task_file': str(task_file)}))
    assert settings.follower.behaviour == 'obedient' and settings.follower.deviation_rounds == ()
    settings = FollowerExecutorSettings.from_values(FOLLOWER_SETTINGS.validate(
        {'task_file': str(task_file), 'behaviour': 'random', 'deviation_rounds': [0, 2, 5], 'deviation_probability': 0.5}))
    assert settings.follower.deviation_rounds == (2, 5) and settings.follower.deviation_probability == 0.5


@pytest.mark.parametrize('build, schema', [(LeaderSettings, LEADER_SETTINGS),
                                           (FollowerExecutorSettings, FOLLOWER_SETTINGS)])
def test_a_bad_task_file_names_the_parameter_and_the_field(tmp_path, build, schema):
    bad = tmp_path / 'task.yaml'
    bad.write_text('colours: {red: {goal: [5, 0], rgb: [1, 0, 0]}}\n')
    with pytest.raises(ConfigurationError,
                       match=r'^parameter task_file: colours\.red\.goal: cell \[5, 0\] is outside the 3x3 grid'):
        build.from_values(schema.validate({'task_file': str(bad)}))
    with pytest.raises(ConfigurationError, match=r"^parameter task_file: task file '.*missing\.yaml': does not exist"):
        build.from_values(schema.validate({'task_file': str(tmp_path / 'missing.yaml')}))


def test_image_transports_are_the_top_cameras():
    from collab_tools.top_camera import TRANSPORTS
    assert IMAGE_TRANSPORTS == TRANSPORTS
