"""Every role-engine experiment takes its inputs from the command line, validated before anything runs:
roles-formation's --settings / --map (experiments.formation_inputs) and roles-table3/4's --config /
--maps / --map-image (experiments.config.table_config)."""
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from collab_tools.experiments.registry import all_experiments
from role_engine.core.errors import RoleEngineError
from role_engine.experiments.config import table_config
from role_engine.experiments.formation_inputs import formation_inputs

WS = Path(__file__).resolve().parents[3]
CONFIG = WS / 'config'
CORRIDOR_MAP = CONFIG / 'maps' / 'pillar_corridors.yaml'
MAPS_DIR = CONFIG / 'roles' / 'maps'


def test_the_options_are_listed():
    experiments = all_experiments()
    flags = {name: {o.flag for o in experiments[name].options} for name in ('roles-table3', 'roles-table4',
                                                                           'roles-formation')}
    for table in ('roles-table3', 'roles-table4'):
        assert {'--only', '--maps', '--map-image', '--resolution', '--origin'} <= flags[table]   # --config: common
    assert {'--settings', '--map', '--stop-player'} <= flags['roles-formation']


# --------------------------------------------------------------------------------- roles-formation
def test_default_formation_inputs_are_the_shipped_files(tmp_path):
    inputs = formation_inputs(CONFIG, tmp_path / 'run')
    assert not inputs.generated and not (tmp_path / 'run').exists()
    assert inputs.radii == {'pioneer_1': 0.23, 'pioneer_2': 0.23, 'burger_1': 0.105, 'burger_2': 0.105}
    # the demo's three boxes and the four arena walls
    assert sorted(b.name for b in inputs.obstacles)[:3] == ['crate', 'pillar', 'shelf'] and len(inputs.obstacles) == 7


def test_a_map_replaces_the_obstacles_of_the_simulated_world(tmp_path):
    run = tmp_path / 'run'
    inputs = formation_inputs(CONFIG, run, map_yaml=CORRIDOR_MAP)
    assert inputs.generated and inputs.scenario_file == run / 'scenario.yaml'
    scenario = yaml.safe_load(inputs.scenario_file.read_text())
    assert scenario['obstacles'] == {'map': str(CORRIDOR_MAP)}
    assert len(inputs.obstacles) == 16 + 4 and {b.name for b in inputs.obstacles} >= {'map_0', 'wall_0'}
    assert inputs.task.source == run / 'settings.yaml' and inputs.task.scenario == run / 'scenario.yaml'
    players = [n for n in inputs.experiment['nodes'] if n['executable'] == 'role_player']
    assert sorted(n['namespace'] for n in players) == ['/burger_1', '/burger_2', '/pioneer_1', '/pioneer_2']
    for node in inputs.experiment['nodes']:
        for entry in node.get('parameters', []):
            if isinstance(entry, dict) and 'settings_file' in entry:
                assert entry['settings_file'] == str(run / 'settings.yaml')
            if isinstance(entry, dict) and 'scenario' in entry:
                assert entry['scenario'] == str(run / 'scenario.yaml')


def test_a_team_file_gives_the_players_and_the_recorded_commands(tmp_path):
    scenario = yaml.safe_load((CONFIG / 'scenarios' / 'roles_formation.yaml').read_text())
    scenario['mobile_robots'] = scenario['mobile_robots'][:3]          # a team of three
    (tmp_path / 'team.yaml').write_text(yaml.safe_dump(scenario))
    settings = yaml.safe_load((CONFIG / 'roles' / 'formation_demo.yaml').read_text())
    settings['scenario'] = 'team.yaml'
    (tmp_path / 'settings.yaml').write_text(yaml.safe_dump(settings))
    inputs = formation_inputs(CONFIG, tmp_path / 'run', settings=tmp_path / 'settings.yaml')
    assert sorted(inputs.radii) == ['burger_1', 'pioneer_1', 'pioneer_2']
    players = [n['namespace'] for n in inputs.experiment['nodes'] if n['executable'] == 'role_player']
    assert sorted(players) == ['/burger_1', '/pioneer_1', '/pioneer_2']
    topics = inputs.experiment['record']['topics']
    assert '/burger_2/cmd_vel' not in topics and '/burger_1/cmd_vel' in topics and '/roles/channel' in topics


def test_bad_formation_inputs_are_refused_before_anything_runs(tmp_path):
    with pytest.raises(RoleEngineError, match=r"--map: file 'nope.yaml' does not exist"):
        formation_inputs(CONFIG, tmp_path / 'run', map_yaml='nope.yaml')
    with pytest.raises(RoleEngineError, match=r"--settings: file .* does not exist"):
        formation_inputs(CONFIG, tmp_path / 'run', settings=tmp_path / 'none.yaml')
    bad = yaml.safe_load(CORRIDOR_MAP.read_text())
    bad['free_thresh'] = 0.9
    bad['image'] = str(CORRIDOR_MAP.with_suffix('.png'))
    (tmp_path / 'bad.yaml').write_text(yaml.safe_dump(bad))
    with pytest.raises(RoleEngineError, match=r'bad\.yaml\.free_thresh: must be <= occupied_thresh'):
        formation_inputs(CONFIG, tmp_path / 'run', map_yaml=tmp_path / 'bad.yaml')
    settings = yaml.safe_load((CONFIG / 'roles' / 'formation_demo.yaml').read_text())
    settings['scenario'] = str(CONFIG / 'scenarios' / 'roles_formation.yaml')
    settings['trajectory']['states'] = 1
    (tmp_path / 's.yaml').write_text(yaml.safe_dump(settings))
    with pytest.raises(RoleEngineError, match=r's\.yaml\.trajectory\.states: must be >= 2'):
        formation_inputs(CONFIG, tmp_path / 'run2', settings=tmp_path / 's.yaml')
    assert not (tmp_path / 'run2' / 'experiment.yaml').exists()


def test_a_map_that_covers_a_start_is_refused_naming_the_robot(tmp_path):
    image = np.full((40, 40), 255, dtype=np.uint8)
    image[-6:, :6] = 0                      # bottom-left 0.75 m square: covers pioneer_1's start (-1.8, -1.8)
    cv2.imwrite(str(tmp_path / 'corner.png'), image)
    (tmp_path / 'corner.yaml').write_text(yaml.safe_dump({'image': 'corner.png', 'resolution': 0.125,
                                                           'origin': [-2.5, -2.5, 0.0], 'negate': 0,
                                                           'occupied_thresh': 0.65, 'free_thresh': 0.25}))
    with pytest.raises(RoleEngineError, match=r'--map: robot pioneer_1 starts at \(-1.8, -1.8\) overlapping '
                                              r'obstacle map_0'):
        formation_inputs(CONFIG, tmp_path / 'run', map_yaml=tmp_path / 'corner.yaml')


# --------------------------------------------------------------------------------- roles-table3/4
def test_a_map_list_replaces_the_environments(tmp_path):
    config = table_config(CONFIG, maps=[CORRIDOR_MAP, MAPS_DIR / 'env_2.yaml'])
    assert config.environments == ('pillar_corridors', 'env_2')
    assert config.map_file('pillar_corridors') == CORRIDOR_MAP and config.map_file('env_2') == MAPS_DIR / 'env_2.yaml'
    narrowed = table_config(CONFIG, ['env_2'], maps=[CORRIDOR_MAP, MAPS_DIR / 'env_2.yaml'])
    assert narrowed.environments == ('env_2',)
    assert table_config(CONFIG).map_file('env_1') == MAPS_DIR / 'env_1.yaml'      # the shipped default


def test_another_settings_file(tmp_path):
    data = yaml.safe_load((CONFIG / 'roles' / 'experiments.yaml').read_text())
    data['maps_dir'] = str(MAPS_DIR)
    data['environments'] = ['env_3']
    (tmp_path / 'mine.yaml').write_text(yaml.safe_dump(data))
    config = table_config(CONFIG, config_file=tmp_path / 'mine.yaml')
    assert config.environments == ('env_3',) and config.path == (tmp_path / 'mine.yaml').resolve()


def test_one_map_image_with_its_resolution(tmp_path):
    image = np.full((80, 100), 255, dtype=np.uint8)
    image[30:50, 40:60] = 0
    cv2.imwrite(str(tmp_path / 'room.png'), image)
    config = table_config(CONFIG, map_image=tmp_path / 'room.png', resolution=0.05, origin=[-2.5, -2.0],
                          run_dir=tmp_path / 'run')
    assert config.environments == ('room',)
    written = yaml.safe_load((tmp_path / 'run' / 'room.yaml').read_text())
    assert written['origin'] == [-2.5, -2.0, 0.0] and written['resolution'] == 0.05 and written['negate'] == 0
    from role_engine.core.environment import load_map_file
    env = load_map_file(config.map_file('room'))
    assert env.shape == (80, 100) and env.occupied.sum() == 400


@pytest.mark.parametrize('kwargs, message', [
    ({'map_image': 'room.png'}, r'--resolution: required with --map-image'),
    ({'map_image': 'room.png', 'resolution': -1.0}, r'--resolution: must be > 0'),
    ({'map_image': 'room.png', 'resolution': 0.05, 'origin': [1.0]}, r'--origin: must be x y or x y yaw'),
    ({'map_image': 'none.png', 'resolution': 0.05}, r"--map-image: file .* does not exist"),
    ({'resolution': 0.05}, r'--resolution, --origin: only with --map-image'),
    ({'maps': ['none.yaml']}, r"--maps: file 'none.yaml' does not exist"),
    ({'maps': [str(MAPS_DIR / 'env_1.yaml')], 'map_image': 'room.png'}, r'give one of them'),
    ({'config_file': 'none.yaml'}, r"--config: file 'none.yaml' does not exist"),
])
def test_bad_table_inputs_are_refused(tmp_path, monkeypatch, kwargs, message):
    monkeypatch.chdir(tmp_path)
    cv2.imwrite(str(tmp_path / 'room.png'), np.full((10, 10), 255, dtype=np.uint8))
    with pytest.raises(RoleEngineError, match=message):
        table_config(CONFIG, run_dir=tmp_path / 'run', **kwargs)


def test_a_bad_map_in_the_list_is_named(tmp_path):
    data = yaml.safe_load(CORRIDOR_MAP.read_text())
    data['image'] = str(CORRIDOR_MAP.with_suffix('.png'))
    data['mode'] = 'raw'
    (tmp_path / 'raw.yaml').write_text(yaml.safe_dump(data))
    with pytest.raises(RoleEngineError, match=r'raw\.yaml\.mode: must be trinary'):
        table_config(CONFIG, maps=[tmp_path / 'raw.yaml'])
