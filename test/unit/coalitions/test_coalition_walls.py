"""Coalition worlds with walls (issue 13, item 2): obstacles in the scenario format, per-robot
fields of view, the core's line-of-sight occlusion, and the core agreeing with the bridge's
simulated fiducial (same rule at the FOV edge, same walls) on the generated bridge scenario."""
import math
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from collab_tools.experiments.api import ExperimentRequest
from coalition_agents.core import ConfigError, load_capability_file
from coalition_agents.core.geometric_sensing import FieldOfView, GeometricSensing, Pose
from coalition_agents.core.sim_scenarios import (
    ROBOT_RADIUS_M, SensorSettings, bridge_scenario, capability_file, placements_from_poses,
)
from coalition_agents.experiments.configuration import CoalitionConfig, load_scenario
from coalition_agents.experiments.fig7 import run_core
from coalition_agents.experiments.fig7_sim import FIG7_SENSOR_NAMES

WALLS = 'scenarios/walls.yaml'


def quiet(_line):
    pass


def write_scenario(tmp_path: Path, config_dir: Path, edit=None, name='walls.yaml') -> Path:
    data = yaml.safe_load((config_dir / WALLS).read_text())
    data['team'] = str(config_dir / 'capabilities' / 'walls_team.yaml')
    if edit:
        edit(data)
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def sightings(sensing) -> set[tuple[str, str]]:
    return {(a, b) for a, b, _ in sensing.sightings()}


# --- the core --------------------------------------------------------------------------------

def test_walls_scenario_blocks_one_sighting_and_not_the_others(config_dir):
    scenario = load_scenario(config_dir / WALLS, CoalitionConfig.load(config_dir))
    assert [b.name for b in scenario.obstacles.boxes] == ['wall_red', 'wall_beside', 'kerb_green']
    assert [b.name for b in scenario.obstacles.occluding] == ['wall_red', 'wall_beside']   # the kerb is low
    seen = sightings(scenario.sensing())
    assert ('robot_red', 'helper_1') not in seen          # through wall_red
    assert ('helper_2', 'robot_red') in seen              # wall_beside is 0.55 m off the line of sight
    assert ('robot_green', 'helper_4') in seen            # over the 0.10 m kerb
    assert ('helper_5', 'robot_green') not in seen        # its own fiducial reaches 1.5 m, G is 2.06 m away
    assert seen == {('helper_2', 'robot_red'), ('robot_green', 'helper_4')}
    assert sightings(scenario.sensing(blind=True)) >= {('robot_red', 'helper_1'), ('helper_5', 'robot_green')}


def test_a_wall_removes_the_coalition_the_core_reported_without_it(config_dir, tmp_path):
    walled = run_core(config_dir.parent, tmp_path / 'walled', quiet, config_dir / WALLS).data
    open_path = write_scenario(tmp_path, config_dir, lambda d: d['obstacles']['boxes'].pop(0), 'open.yaml')
    opened = run_core(config_dir.parent, tmp_path / 'open', quiet, open_path).data
    red = {e['robot']: e for e in walled['table5']}['robot_red']
    red_open = {e['robot']: e for e in opened['table5']}['robot_red']
    assert red_open['executable_partners'] == ['helper_1', 'helper_2'] and red_open['executable_costs'] == [16.0, 17.5]
    assert red['executable_partners'] == ['helper_2'] and red['executable_costs'] == [17.5]
    assert red['possible'] == red_open['possible']        # "possible" ignores the configuration, walls too
    assert walled['chosen']['robot_red']['members'] == ['robot_red', 'helper_2']
    assert walled['chosen']['robot_green']['members'] == ['robot_green', 'helper_4']
    assert [o['name'] for o in walled['obstacles'] if o['occludes']] == ['wall_red', 'wall_beside']
    assert walled['robot_sensors']['helper_5'] == {'fiducial': {'fov_deg': 60.0, 'range_m': 1.5}}
    assert (tmp_path / 'walled' / 'fig7.png').is_file()


def test_an_initiator_walled_off_from_every_helper_has_no_coalition(config_dir, tmp_path):
    def box_in(data):
        data['obstacles']['boxes'].append({'name': 'wall_2', 'center': [-1.0, 0.0], 'size': [0.1, 1.0], 'height': 0.3})
    data = run_core(config_dir.parent, tmp_path / 'run', quiet, write_scenario(tmp_path, config_dir, box_in)).data
    assert data['chosen']['robot_red'] is None
    assert data['chosen']['robot_green'] is not None


def test_a_map_image_blocks_like_boxes(config_dir, tmp_path):
    image = np.full((20, 20), 255, np.uint8)
    image[:, 9:11] = 0                                    # a dark column: x in [0.9, 1.1) m
    cv2.imwrite(str(tmp_path / 'map.png'), image)

    def with_map(data):
        data['obstacles'] = {'map': {'image': 'map.png', 'resolution': 0.1, 'origin': [0.3, -1.0], 'height': 0.4}}
    scenario = load_scenario(write_scenario(tmp_path, config_dir, with_map), CoalitionConfig.load(config_dir))
    assert len(scenario.obstacles.boxes) == 1
    assert scenario.obstacles.boxes[0].center == pytest.approx((1.3, 0.0))
    assert ('robot_red', 'helper_1') not in sightings(scenario.sensing())
    assert scenario.obstacles.section['map']['image'] == str((tmp_path / 'map.png').resolve())


def test_per_robot_fields_of_view_come_from_the_team_file(config_dir, library):
    team = load_capability_file(config_dir / 'capabilities' / 'walls_team.yaml', library).robots
    assert team['helper_5'].sensor_view('fiducial') == (60.0, 1.5)
    assert team['robot_red'].sensor_view('fiducial') == (180.0, 4.0)
    assert team['robot_red'].sensor_view('laser') is None
    poses = {'robot_red': Pose(0, 0, 0, 'R'), 'helper_5': Pose(1.0, 0.0, 180.0, '5'), 'helper_1': Pose(3.0, 1.5, 180, '1'),
             'helper_2': Pose(-9, 0, 0, '2'), 'robot_green': Pose(0, 9, 0, 'G'), 'helper_4': Pose(9, 9, 0, '4')}
    sensing = GeometricSensing(team, poses, {'fiducial': FieldOfView(10.0, 0.1)})   # defaults unused: own views win
    assert ('helper_5', 'robot_red') in sightings(sensing)     # 1 m, within its 1.5 m
    assert ('helper_1', 'robot_red') in sightings(sensing)     # 3.35 m, within its 4 m
    assert ('helper_5', 'helper_1') not in sightings(sensing)  # behind helper_5's 60 deg view
    assert sensing.view_of('helper_5', 'fiducial') == FieldOfView(60.0, 1.5)


@pytest.mark.parametrize('sensor, message', [
    ({'fov_deg': 90.0}, r'sensors\[0\]\.range_m: required with fov_deg'),
    ({'range_m': 2.0}, r'sensors\[0\]\.fov_deg: required with range_m'),
    ({'fov_deg': 400.0, 'range_m': 2.0}, r'sensors\[0\]\.fov_deg: must be in \(0, 360\]'),
    ({'fov_deg': 90.0, 'range_m': 0.0}, r'sensors\[0\]\.range_m: must be > 0'),
])
def test_a_sensor_view_is_both_fields_in_range(library, sensor, message):
    from coalition_agents.core.capabilities import capability_file_from_dict
    data = {'robot_types': {'t': {'sensors': [{'name': 'fiducial', 'provides': ['F_R(X, local)'], **sensor}]}}}
    with pytest.raises(ConfigError, match=message):
        capability_file_from_dict(data, library)


@pytest.mark.parametrize('edit, message', [
    (lambda d: d['obstacles']['boxes'].append({'name': 'on_red', 'center': [0.3, 0.0], 'size': [0.2, 0.2]}),
     r"robots\.robot_red\.position: the robot's footprint \(radius 0\.23 m\) overlaps obstacle 'on_red'"),
    (lambda d: d['obstacles']['boxes'][0].update(size=[0.1, -1.0]), r'obstacles\.boxes\[0\]\.size\[1\]: must be > 0'),
    (lambda d: d['obstacles'].update(walls=[]), r'obstacles\.walls: unknown field'),
    (lambda d: d['obstacles'].update(map={'image': 'nowhere.png', 'resolution': 0.1, 'origin': [0, 0]}),
     r"obstacles\.map\.image: image file .*nowhere\.png': does not exist"),
    (lambda d: d.update(team='nowhere.yaml'), r"team: no file 'nowhere\.yaml' next to the scenario nor in"),
])
def test_obstacle_and_team_errors_name_the_field(config_dir, tmp_path, edit, message):
    with pytest.raises(ConfigError, match=message):
        load_scenario(write_scenario(tmp_path, config_dir, edit), CoalitionConfig.load(config_dir))


def test_the_team_is_found_next_to_the_scenario_or_given_on_the_command_line(config_dir, tmp_path):
    config = CoalitionConfig.load(config_dir)
    (tmp_path / 'team.yaml').write_text((config_dir / 'capabilities' / 'walls_team.yaml').read_text())
    path = write_scenario(tmp_path, config_dir, lambda d: d.update(team='team.yaml'))
    assert load_scenario(path, config).team_file == tmp_path / 'team.yaml'
    fig7 = load_scenario(config_dir / 'scenarios' / 'fig7.yaml', config)      # config/coalitions-relative
    assert fig7.team_file == config_dir / 'capabilities' / 'fig7_team.yaml'
    with pytest.raises(ConfigError, match=r"--team: no file '.*missing\.yaml'"):
        load_scenario(path, config, team_path=config_dir / 'capabilities' / 'missing.yaml')
    with pytest.raises(ConfigError, match=r'robots: no pose for robot_yellow, helper_3, helper_6'):
        load_scenario(path, config, team_path=config_dir / 'capabilities' / 'fig7_team.yaml')


# --- core vs the bridge's fiducial -------------------------------------------------------------

def bridge_sightings(scenario_data: dict) -> set[tuple[str, str]]:
    """(observer, seen robot) of every robot's simulated fiducial in the bridge (pybullet DIRECT)."""
    from pybullet_bridge.core.scenario import parse_scenario
    from pybullet_bridge.core.scene import Scene
    from pybullet_bridge.core.sensors import RobotSensors
    found = set()
    with Scene(parse_scenario(scenario_data, Path('.'))) as scene:
        for entry in scenario_data['mobile_robots']:
            if 'fiducial' not in entry['sensors']:
                continue
            reading = RobotSensors(scene, scene.entity(entry['name'])).read('fiducial')
            found |= {(entry['name'], d.name) for d in reading.detections if d.kind == 'mobile_robot'}
    return found


def generated(scenario) -> dict:
    """The bridge scenario fig7 --mode sim generates for ``scenario``."""
    types = yaml.safe_load(Path(scenario.team_file).read_text())['robot_types']
    views = scenario.views()
    placements = placements_from_poses({r: (p.x, p.y, p.heading_deg) for r, p in scenario.poses.items()},
                                       {r: c.name for r, c in scenario.team.items()},
                                       {r: (v['fiducial'].fov_deg, v['fiducial'].range_m) for r, v in views.items()})
    team = capability_file(placements, types, FIG7_SENSOR_NAMES)
    return bridge_scenario('check', placements, team['robot_types'], SensorSettings(),
                           obstacles=scenario.obstacles.section)


def test_the_bridge_sees_what_the_core_sees_in_the_walls_scenario(config_dir):
    scenario = load_scenario(config_dir / WALLS, CoalitionConfig.load(config_dir))
    data = generated(scenario)
    assert [b['name'] for b in data['obstacles']['boxes']] == ['wall_red', 'wall_beside', 'kerb_green']
    fiducials = {r['name']: (r['sensors']['fiducial']['fov_deg'], r['sensors']['fiducial']['range'])
                 for r in data['mobile_robots']}
    assert fiducials['helper_5'] == (60.0, 1.5) and fiducials['robot_red'] == (180.0, 4.0)
    assert bridge_sightings(data) == sightings(scenario.sensing())


def edge_case(tmp_path, config_dir, robots: dict, boxes=()) -> Path:
    """A walls-team scenario with only the given robots (name -> (x, y, heading)) and boxes."""
    team = yaml.safe_load((config_dir / 'capabilities' / 'walls_team.yaml').read_text())
    team['robots'] = {name: team['robots'][name] for name in robots}
    (tmp_path / 'team.yaml').write_text(yaml.safe_dump(team))
    data = {'team': 'team.yaml', 'task': 'navigation', 'initiators': [next(iter(robots))],
            'robots': {name: {'position': [x, y], 'heading_deg': h} for name, (x, y, h) in robots.items()}}
    if boxes:
        data['obstacles'] = {'boxes': list(boxes)}
    path = tmp_path / 'edge.yaml'
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize('beyond_rad, expected', [(0.0, True), (5e-7, True), (1e-4, False), (-1e-4, True)])
@pytest.mark.parametrize('heading_deg', [60.0, -30.0])
def test_core_and_bridge_agree_at_the_exact_field_of_view_edge(config_dir, tmp_path, heading_deg, beyond_rad,
                                                               expected):
    # helper_5's fiducial: 60 deg / 1.5 m; robot_red stands on (or just past) the edge of its view.
    bearing = math.radians(heading_deg) + (math.radians(30.0) + beyond_rad)
    robots = {'robot_red': (1.2 * math.cos(bearing), 1.2 * math.sin(bearing), 0.0), 'helper_5': (0.0, 0.0, heading_deg)}
    scenario = load_scenario(edge_case(tmp_path, config_dir, robots), CoalitionConfig.load(config_dir))
    core = ('helper_5', 'robot_red') in sightings(scenario.sensing())
    assert core is expected
    assert (('helper_5', 'robot_red') in bridge_sightings(generated(scenario))) is core


@pytest.mark.parametrize('clearance_m, expected', [(0.005, True), (-0.005, False), (0.3, True)])
def test_core_and_bridge_agree_beside_a_corner_beyond_the_grazing_tolerance(config_dir, tmp_path, clearance_m,
                                                                             expected):
    # The line of sight runs along y = 0; a tall box's corner points at it from clearance_m below (a
    # negative clearance cuts the corner). Exactly at the corner the core says blocked (closed boxes); the
    # bridge's ray test is arbitrary within GRAZING_TOLERANCE_M: not tested there.
    half_diagonal = 0.15 * math.sqrt(2.0)               # a 0.3 m square turned 45 deg: its top corner
    box = {'name': 'pillar', 'center': [1.0, -half_diagonal - clearance_m], 'size': [0.3, 0.3], 'yaw': math.pi / 4,
           'height': 0.5}
    robots = {'robot_red': (0.0, 0.0, 0.0), 'helper_1': (2.0, 0.0, 0.0)}
    scenario = load_scenario(edge_case(tmp_path, config_dir, robots, [box]), CoalitionConfig.load(config_dir))
    core = ('robot_red', 'helper_1') in sightings(scenario.sensing())
    assert core is expected
    assert (('robot_red', 'helper_1') in bridge_sightings(generated(scenario))) is core


def test_core_and_bridge_agree_that_a_robot_hides_the_one_behind_it(config_dir, tmp_path):
    robots = {'robot_red': (0.0, 0.0, 0.0), 'helper_1': (1.0, 0.1, 0.0), 'helper_2': (2.0, 0.0, 0.0)}
    scenario = load_scenario(edge_case(tmp_path, config_dir, robots), CoalitionConfig.load(config_dir))
    core = sightings(scenario.sensing())
    assert ('robot_red', 'helper_1') in core and ('robot_red', 'helper_2') not in core
    assert ('helper_1', 'helper_2') in core
    assert bridge_sightings(generated(scenario)) == core
    assert ROBOT_RADIUS_M == 0.23
