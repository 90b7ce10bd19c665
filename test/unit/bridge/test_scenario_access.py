"""The reset service's scenario directories (issue 16.7): a requested path is loaded only from them,
with symlinks and '..' resolved first, and a refusal says nothing about the file it names."""
import os
from pathlib import Path

import pytest

from pybullet_bridge.core.errors import ScenarioError
from pybullet_bridge.core.scenario_access import DEFAULT_SCENARIO_DIRECTORY, ScenarioDirectories

SCENARIO = ('name: allowed\ncamera: {rate: 10.0, width: 64, height: 64, altitude: 4.0, fov_deg: 45.0}\n'
            'mobile_robots:\n  - {name: robot_1, type: pioneer_3dx, pose: [0, 0, 0], color: [1, 0, 0]}\n')


@pytest.fixture
def layout(tmp_path):
    allowed = tmp_path / 'scenarios'
    allowed.mkdir()
    (allowed / 'good.yaml').write_text(SCENARIO)
    outside = tmp_path / 'private'
    outside.mkdir()
    (outside / 'secret.yaml').write_text('name: top secret value\n')
    (allowed / 'link.yaml').symlink_to(outside / 'secret.yaml')
    return allowed, outside


def test_the_default_is_the_workspace_scenario_directory():
    assert ScenarioDirectories(['']).directories == [DEFAULT_SCENARIO_DIRECTORY.resolve()]
    assert (DEFAULT_SCENARIO_DIRECTORY / 'demo_mobile.yaml').is_file()


def test_scenarios_inside_the_directories_load(layout):
    allowed, _ = layout
    access = ScenarioDirectories([str(allowed)])
    scenario, path = access.load('good.yaml', 'unused')
    assert scenario.name == 'allowed' and path == str(allowed / 'good.yaml')
    scenario, _ = access.load(str(allowed / 'sub' / '..' / 'good.yaml'), 'unused')
    assert scenario.name == 'allowed'
    assert access.load('', str(allowed / 'good.yaml'))[1] == str(allowed / 'good.yaml')   # the current one again


@pytest.mark.parametrize('request_path', [
    '../../etc/passwd', '/etc/passwd', '/dev/zero', '../private/secret.yaml', 'link.yaml',
    '/proc/self/environ', 'a' * 300,
], ids=['../../etc/passwd', 'absolute outside', '/dev/zero', '.. out', 'symlink out', '/proc', 'long name'])
def test_paths_outside_the_directories_are_refused_without_reading_them(layout, request_path):
    allowed, _ = layout
    access = ScenarioDirectories([str(allowed)])
    with pytest.raises(ScenarioError) as caught:
        access.load(request_path, 'unused')
    message = str(caught.value)
    assert message.startswith('scenario_path')
    assert 'outside the directories' in message or 'NAME_MAX' in message
    assert 'secret' not in message.replace('secret.yaml', '') and 'root:' not in message


def test_inside_files_are_still_read_as_input_files(layout):
    allowed, _ = layout
    os.mkfifo(allowed / 'fifo.yaml')
    (allowed / 'latin1.yaml').write_bytes(b'name: caf\xe9\n')
    access = ScenarioDirectories([str(allowed)])
    with pytest.raises(ScenarioError, match='not a regular file'):
        access.load('fifo.yaml', 'unused')
    with pytest.raises(ScenarioError, match='not UTF-8'):
        access.load('latin1.yaml', 'unused')


def test_a_directory_that_does_not_exist_is_a_parameter_error(tmp_path):
    with pytest.raises(ScenarioError, match=r'^parameter scenario_directories\[1\]: .* is not a directory'):
        ScenarioDirectories([str(tmp_path), str(tmp_path / 'nope')])
    assert ScenarioDirectories([str(tmp_path), '']).directories == [Path(tmp_path).resolve()]
