"""Every loader of an input file refuses every bad kind of file (issue 16.6), naming the file, with
its package's ConfigurationError (exit code 2 in a node or an experiment), never another exception;
absurd sizes that pass a type check are refused where the simulator or a planner could not build
them. The reader itself is tested in tools/test_input_files.py; these tests prove each loader uses it."""
import os
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from collab_tools.core.drive_plan import load_plan
from collab_tools.core.errors import ConfigurationError
from collab_tools.orchestration.experiment import load_experiment
from coalition_agents.core.capabilities import load_capability_file
from coalition_agents.core.schemas import load_costs, load_library
from coalition_agents.core.settings import load_files
from coalition_agents.core.tasks import load_tasks
from pybullet_bridge.core.occupancy_map import MAX_MAP_BOXES, read_nav2_map
from pybullet_bridge.core.scenario import load_scenario
from role_engine.core.environment import load_map_file
from role_engine.core.formation_task import load_formation_task
from role_engine.core.node_settings import engine_settings_file, player_settings_file
from role_engine.experiments.config import load_experiment_config
from sgcm.core.settings import read_task_parameter
from sgcm.core.task_config import load_cases, load_task

sys.path.insert(0, str(Path(__file__).parent / 'tools'))
from test_input_files import TEXT_KINDS, bad_file, huge_png_header, png  # noqa: E402

CONFIG = Path(__file__).resolve().parents[2] / 'config'
LIBRARY = load_library(CONFIG / 'coalitions' / 'schemas.yaml')
SGCM_TASK = load_task(CONFIG / 'sgcm' / 'task.yaml')
CAPABILITIES = CONFIG / 'coalitions' / 'capabilities' / 'coalition_three_robots.yaml'


def coalition_files(**change):
    values = {'schemas_file': str(CONFIG / 'coalitions' / 'schemas.yaml'),
              'costs_file': str(CONFIG / 'coalitions' / 'costs.yaml'),
              'tasks_file': str(CONFIG / 'coalitions' / 'tasks.yaml'),
              'capability_file': str(CAPABILITIES), 'capabilities': ''}
    return {**values, **change}


#: Every loader of a YAML input file: (name, load(path)).
LOADERS = {
    'bridge scenario': load_scenario,
    'Nav2 map': read_nav2_map,
    'SGCM task': load_task,
    'SGCM task parameter (leader, follower)': read_task_parameter,
    'SGCM cases': lambda path: load_cases(path, SGCM_TASK),
    'formation settings': load_formation_task,
    'role engine settings_file': engine_settings_file,
    'role player settings_file': player_settings_file,
    'role map file': load_map_file,
    'roles experiments file': load_experiment_config,
    'scripted driver plan': load_plan,
    'coalition schemas': load_library,
    'coalition costs': load_costs,
    'coalition tasks': lambda path: load_tasks(path, LIBRARY),
    'coalition capabilities': lambda path: load_capability_file(path, LIBRARY),
    'schema agent tasks_file': lambda path: load_files(coalition_files(tasks_file=path)),
    'schema agent schemas_file': lambda path: load_files(coalition_files(schemas_file=path)),
    'orchestration experiment file': load_experiment,
}


def test_the_config_files_used_above_exist():
    for name in ('schemas.yaml', 'costs.yaml', 'tasks.yaml'):
        assert (CONFIG / 'coalitions' / name).is_file(), name
    load_files(coalition_files())


@pytest.mark.parametrize('kind', TEXT_KINDS)
@pytest.mark.parametrize('loader', LOADERS)
def test_every_loader_refuses_every_bad_kind_of_file(loader, kind, tmp_path):
    path, words = bad_file(kind, tmp_path)
    with pytest.raises(ConfigurationError) as caught:
        LOADERS[loader](path)
    message = str(caught.value)
    assert words in message, message
    assert len(message) < 600 and 'do not echo me' not in message


# --- images and sizes -----------------------------------------------------------------------------

SCENARIO = {'name': 't', 'world': {'bounds': [-60, -60, 60, 60]}}


def write(tmp_path, name, data) -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


def image_kind(kind, tmp_path) -> tuple[str, str]:
    """(image file name in tmp_path, words of the error) of one bad kind of image."""
    path = tmp_path / 'map.png'
    if kind == '10000 x 10000 pixels':
        path.write_bytes(huge_png_header())
        return path.name, '10000 x 10000 pixels (at most'
    if kind == 'truncated':
        path.write_bytes(png(40, 40, truncate=True))
        return path.name, 'truncated PNG file'
    if kind == 'not an image':
        path.write_text('name: not an image\n')
        return path.name, 'not a PNG, JPEG, BMP or PNM'
    if kind == 'FIFO':
        import os
        os.mkfifo(path)
        return path.name, 'not a regular file (a FIFO)'
    raise AssertionError(kind)


IMAGE_KINDS = ('10000 x 10000 pixels', 'truncated', 'not an image', 'FIFO')
NAV2 = {'resolution': 0.05, 'origin': [-1.0, -1.0, 0.0], 'negate': 0, 'occupied_thresh': 0.65,
        'free_thresh': 0.25}


@pytest.mark.parametrize('kind', IMAGE_KINDS)
def test_every_map_loader_refuses_every_bad_image(kind, tmp_path):
    image, words = image_kind(kind, tmp_path)
    loaders = {
        'scenario obstacles.map.image': (lambda: load_scenario(write(tmp_path, 's.yaml', dict(
            SCENARIO, obstacles={'map': {'image': image, 'resolution': 0.05, 'origin': [0, 0]}}))),
            'obstacles.map.image: image file'),
        'scenario obstacles.map (Nav2)': (lambda: load_scenario(write(tmp_path, 's.yaml', dict(
            SCENARIO, obstacles={'map': write(tmp_path, 'm.yaml', dict(NAV2, image=image)).name}))),
            'image: image file'),
        'role map file': (lambda: load_map_file(write(tmp_path, 'r.yaml', {
            'image': image, 'resolution': 0.05, 'origin': [0, 0]})), 'image: image file'),
    }
    for name, (load, field) in loaders.items():
        with pytest.raises(ConfigurationError) as caught:
            load()
        message = str(caught.value)
        assert field in message and words in message, (name, message)


def random_map(tmp_path, size: int) -> str:
    pixels = (np.random.default_rng(0).random((size, size)) < 0.5).astype(np.uint8) * 255
    cv2.imwrite(str(tmp_path / 'random.png'), pixels)
    return 'random.png'


def test_a_map_the_simulator_cannot_step_in_real_time_is_refused(tmp_path):
    # A random 1000 x 1000 image is 230,000 boxes (it crashed Bullet); 100 x 100 is 2,356 (accepted).
    image = random_map(tmp_path, 1000)
    scenario = write(tmp_path, 's.yaml', dict(SCENARIO, obstacles={'map': {'image': image, 'resolution': 0.05,
                                                                           'origin': [0, 0]}}))
    with pytest.raises(ConfigurationError, match=rf'^obstacles\.map\.image: the map needs more than {MAX_MAP_BOXES} '
                       'boxes'):
        load_scenario(scenario)
    nav2 = write(tmp_path, 'm.yaml', dict(NAV2, image=image))
    with pytest.raises(ConfigurationError, match=rf'^obstacles\.map\.yaml: the map needs more than {MAX_MAP_BOXES}'):
        load_scenario(write(tmp_path, 's.yaml', dict(SCENARIO, obstacles={'map': nav2.name})))
    random_map(tmp_path, 100)
    assert 2000 < len(load_scenario(scenario).entities()) <= MAX_MAP_BOXES


def test_a_scene_of_more_entities_than_the_simulator_steps_is_refused(tmp_path):
    boxes = [{'center': [-50 + (i % 100), -50 + (i // 100)], 'size': [0.1, 0.1]} for i in range(MAX_MAP_BOXES + 1)]
    with pytest.raises(ConfigurationError, match=rf'obstacles: the scene has more than {MAX_MAP_BOXES} entities'):
        load_scenario(write(tmp_path, 's.yaml', dict(SCENARIO, obstacles={'boxes': boxes})))


def formation_settings(tmp_path, **change) -> Path:
    data = yaml.safe_load((CONFIG / 'roles' / 'formation_demo.yaml').read_text())
    data['scenario'] = str((CONFIG / 'roles' / data['scenario']).resolve())
    return write(tmp_path, 'formation.yaml', {**data, **change})


@pytest.mark.parametrize('change, loaders, words', [
    ({'trajectory': {'total_time': 20.0, 'states': 10 ** 9}}, (engine_settings_file, player_settings_file),
     'trajectory.states: must be <= 10000 (got 1000000000)'),
    ({'grid_resolution': 1e-9}, (engine_settings_file,), 'grid_resolution: 1e-09 m gives 2.5e+19 cells'),
    ({'gp': {'obstacle_interpolation': 10 ** 6}}, (engine_settings_file, player_settings_file),
     'gp.obstacle_interpolation: must be <= 100'),
    ({'robot_avoidance': {'interpolation': 10 ** 6}}, (engine_settings_file, player_settings_file),
     'robot_avoidance.interpolation: must be <= 100'),
], ids=['states 1e9', 'grid_resolution 1e-9', 'obstacle_interpolation 1e6', 'avoidance interpolation 1e6'])
def test_role_settings_of_absurd_size_are_refused(tmp_path, change, loaders, words):
    path = formation_settings(tmp_path, **change)
    for load in loaders:
        with pytest.raises(ConfigurationError) as caught:
            load(str(path))
        assert str(caught.value).startswith('parameter settings_file: ') and words in str(caught.value)


def test_sgcm_task_of_absurd_size_is_refused(tmp_path):
    data = yaml.safe_load((CONFIG / 'sgcm' / 'task.yaml').read_text())
    data['grid'] = {'rows': 10 ** 9, 'cols': 3}
    with pytest.raises(ConfigurationError, match=r'parameter task_file: .*grid\.rows: must be <= 10'):
        read_task_parameter(str(write(tmp_path, 'task.yaml', data)))


def test_a_huge_field_value_is_echoed_short(tmp_path):
    scenario = write(tmp_path, 's.yaml', dict(SCENARIO, seed='x' * 100_000))
    with pytest.raises(ConfigurationError) as caught:
        load_scenario(scenario)
    assert str(caught.value).startswith('seed: must be an integer') and len(str(caught.value)) < 400


def test_a_planning_map_over_the_grid_bound_is_refused(tmp_path):
    (tmp_path / 'big.png').write_bytes(png(1001, 1000))
    with pytest.raises(ConfigurationError, match=r'image: the image has 1001000 pixels; a planning map has at most'):
        load_map_file(write(tmp_path, 'r.yaml', {'image': 'big.png', 'resolution': 0.05, 'origin': [0, 0]}))
    with pytest.raises(ConfigurationError, match=r'image: the image has 1001000 pixels'):
        load_map_file(write(tmp_path, 'n.yaml', dict(NAV2, image='big.png')))


# --- experiments ---------------------------------------------------------------------------------

@pytest.mark.parametrize('experiment, option, kind, words', [
    ('sgcm-table1', '--task', 'non-UTF-8', "task file '"),
    ('roles-table4', '--maps', 'alias bomb', "map file '"),
    ('coalition-boxpush', '--agents', 'alias bomb', "agents parameter file '"),
    ('sgcm-disturbance', '--cases', 'FIFO', "cases file '"),
    ('coalition-table3', '--config', 'nested 100,000 deep', "file '"),
])
def test_an_experiment_given_a_bad_file_exits_2_naming_it(tmp_path, experiment, option, kind, words):
    path, problem = bad_file(kind, tmp_path)
    done = subprocess.run([sys.executable, str(CONFIG.parent / 'scripts' / 'experiment'), experiment, option, path,
                           '--run-dir', str(tmp_path / 'run')], capture_output=True, text=True, timeout=120,
                          env=dict(os.environ, COLLAB_RUNS_DIR=str(tmp_path)))
    assert done.returncode == 2, done.stderr[-2000:]
    assert words in done.stderr and problem in done.stderr and 'Traceback' not in done.stderr, done.stderr[-2000:]
    assert not (tmp_path / 'run').exists()              # nothing ran, nothing left


@pytest.mark.parametrize('kind', ('FIFO', 'non-UTF-8', 'alias bomb', '/dev/zero'))
def test_an_experiment_files_parameter_file_is_read_before_any_node_gets_it(tmp_path, kind):
    from collab_tools.orchestration.experiment_checks import check_experiment
    parameters, words = bad_file(kind, tmp_path)
    experiment = write(tmp_path, 'experiment.yaml', {
        'name': 'bad', 'until': {'seconds': 1},
        'nodes': [{'package': 'collab_tools', 'executable': 'scripted_driver', 'name': 'driver',
                   'parameters': [parameters]}]})
    with pytest.raises(ConfigurationError) as caught:
        check_experiment(experiment, CONFIG)
    assert 'nodes[0] (driver).parameters[0]: parameter file' in str(caught.value) and words in str(caught.value)


def test_a_physics_step_the_bridge_could_never_tick_is_refused(tmp_path):
    with pytest.raises(ConfigurationError, match=r'^world\.physics_dt: must be >= 0\.0001 \(got 1e-300\)'):
        load_scenario(write(tmp_path, 's.yaml', dict(SCENARIO, world={'physics_dt': 1e-300})))
