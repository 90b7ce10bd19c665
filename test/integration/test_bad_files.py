"""Bad input files stop every node kind at start with exit code 2 and a message naming the parameter,
never a traceback (issue 16.6); the bridge's reset service loads scenarios only from its
scenario_directories and stays alive (issue 16.7).

Each node kind gets one bad kind of file (together they cover the kinds the issue found crashing a
node); every kind against every loader is unit tested (test/unit/test_bad_file_loaders.py)."""
import os
from pathlib import Path

import numpy as np
import pytest
import yaml
from bridge_interfaces.srv import ResetScenario

from collab_tools.orchestration.node_process import NodeSpec
from bridge_helpers import bridge_spec
from role_helpers import engine_spec, player_spec

CONFIG = Path(__file__).resolve().parents[2] / 'config'
SCENARIO = ('name: t\ncamera: {rate: 10.0, width: 64, height: 64, altitude: 4.0, fov_deg: 45.0}\n'
            'mobile_robots:\n  - {name: robot_1, type: pioneer_3dx, pose: [0, 0, 0], color: [1, 0, 0]}\n')
ALIAS_BOMB = ''.join(['a: &a ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]\n',
                      *(f'{n}: &{n} [{", ".join([f"*{p}"] * 9)}]\n' for p, n in zip('abcdef', 'bcdefg'))])


def non_utf8(tmp_path) -> str:
    path = tmp_path / 'latin1.yaml'
    path.write_bytes(b'name: caf\xe9\n')
    return str(path)


def fifo(tmp_path) -> str:
    path = tmp_path / 'fifo.yaml'
    os.mkfifo(path)
    return str(path)


def alias_bomb(tmp_path) -> str:
    path = tmp_path / 'bomb.yaml'
    path.write_text(ALIAS_BOMB + 'name: *g\n')
    return str(path)


def random_map_scenario(tmp_path) -> str:
    import cv2
    pixels = (np.random.default_rng(0).random((1000, 1000)) < 0.5).astype(np.uint8) * 255
    cv2.imwrite(str(tmp_path / 'random.png'), pixels)
    path = tmp_path / 'scenario.yaml'
    path.write_text(SCENARIO + 'world: {bounds: [-30, -30, 30, 30]}\n'
                    'obstacles: {map: {image: random.png, resolution: 0.05, origin: [0, 0]}}\n')
    return str(path)


def formation_settings(tmp_path, **change) -> str:
    data = yaml.safe_load((CONFIG / 'roles' / 'formation_demo.yaml').read_text())
    data['scenario'] = str((CONFIG / 'roles' / data['scenario']).resolve())
    path = tmp_path / 'formation.yaml'
    path.write_text(yaml.safe_dump({**data, **change}))
    return str(path)


def coalition_files(**change) -> dict:
    coalitions = CONFIG / 'coalitions'
    return {'capability_file': str(coalitions / 'capabilities' / 'coalition_three_robots.yaml'),
            'schemas_file': str(coalitions / 'schemas.yaml'), 'costs_file': str(coalitions / 'costs.yaml'),
            'tasks_file': str(coalitions / 'tasks.yaml'), 'task': 'navigation', **change}


def sgcm(executable, namespace, task_file) -> NodeSpec:
    return NodeSpec('sgcm', executable, name=executable, namespace=namespace, parameters=[{'task_file': task_file}])


# (node kind, spec of the node given tmp_path, words its log must show)
CASES = {
    'bridge, non-UTF-8 scenario': (lambda tmp: bridge_spec(non_utf8(tmp)),
                                   "parameter scenario: scenario file '", 'not UTF-8 text (byte 0xe9 at offset 9)'),
    'bridge, 1000x1000 random map': (lambda tmp: bridge_spec(random_map_scenario(tmp)),
                                     'parameter scenario: obstacles.map.image: ', 'more than 4000 boxes'),
    'leader_planner, non-UTF-8 task': (lambda tmp: sgcm('leader_planner', '/leader_arm', non_utf8(tmp)),
                                       'parameter task_file: ', 'not UTF-8 text'),
    'follower_executor, FIFO task': (lambda tmp: sgcm('follower_executor', '/follower_arm', fifo(tmp)),
                                     'parameter task_file: ', 'not a regular file (a FIFO)'),
    'scripted_driver, path over 255': (
        lambda tmp: NodeSpec('collab_tools', 'scripted_driver', use_sim_time=False,
                             parameters=[{'plan_file': str(tmp / ('p' * 300 + '.yaml'))}]),
        'parameter plan_file: ', 'NAME_MAX'),
    'role_engine, grid_resolution 1e-9': (lambda tmp: engine_spec(formation_settings(tmp, grid_resolution=1e-9)),
                                          'parameter settings_file: ', 'grid_resolution: 1e-09 m gives'),
    'role_player, states 1e9': (
        lambda tmp: player_spec('burger_1', formation_settings(tmp, trajectory={'total_time': 20.0,
                                                                                'states': 10 ** 9})),
        'parameter settings_file: ', 'trajectory.states: must be <= 10000'),
    'schema_agent, alias bomb tasks': (
        lambda tmp: NodeSpec('coalition_agents', 'schema_agent', name='schema_agent', namespace='/robot_blind',
                             parameters=[coalition_files(tasks_file=alias_bomb(tmp))]),
        'parameter tasks_file: ', 'aliases are expanded'),
    'schema_agent_host, /dev/zero': (
        lambda tmp: NodeSpec('coalition_agents', 'schema_agent_host',
                             parameters=[{'robots': ['robot_blind'], 'agent_parameters': '/dev/zero'}]),
        'parameter agent_parameters: ', 'not a regular file (a character device)'),
}


@pytest.mark.parametrize('case', CASES)
def test_a_bad_file_stops_the_node_with_exit_2_naming_the_parameter(session, tmp_path, case):
    spec, parameter, words = CASES[case]
    process = session.start(spec(tmp_path))
    assert session.wait_for_exit(process.name, timeout=60.0) == 2
    log = process.log_path.read_text(errors='replace')
    assert parameter in log and words in log, log[-2000:]
    assert 'Traceback' not in log


def test_the_reset_service_refuses_paths_outside_its_directories_and_stays_alive(session, tmp_path):
    allowed = tmp_path / 'scenarios'
    allowed.mkdir()
    (allowed / 'start.yaml').write_text(SCENARIO)
    (allowed / 'other.yaml').write_text(SCENARIO.replace('name: t', 'name: other'))
    os.mkfifo(allowed / 'fifo.yaml')
    (tmp_path / 'private.yaml').write_text('name: secret_value_42\n')
    (allowed / 'link.yaml').symlink_to(tmp_path / 'private.yaml')
    session.start(bridge_spec(allowed / 'start.yaml', scenario_directories=[str(allowed)]))

    def reset(path):
        return session.call_service('/pybullet_bridge/reset', 'bridge_interfaces/srv/ResetScenario',
                                    ResetScenario.Request(scenario_path=path))

    for path in ('../../etc/passwd', '/etc/passwd', '/dev/zero', '../private.yaml', 'link.yaml', 'x' * 300):
        response = reset(path)
        assert not response.success, path
        assert 'outside the directories' in response.message or 'NAME_MAX' in response.message, response.message
        assert 'secret_value' not in response.message and 'root:' not in response.message
    response = reset('fifo.yaml')                      # inside, but no regular file: refused, not blocking
    assert not response.success and 'not a regular file (a FIFO)' in response.message
    response = reset('other.yaml')
    assert response.success, response.message
    status = session.wait_for_message('/pybullet_bridge/status', 'bridge_interfaces/msg/SimulationStatus',
                                      timeout=30.0, predicate=lambda m: m.scenario_name == 'other')
    assert status.scenario_name == 'other'
