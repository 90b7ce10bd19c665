"""Scenario parsing: valid files load, every mistake names its field."""
import math
from pathlib import Path

import pytest

from bridge_core_helpers import SCENARIO_DIR, robot, scenario_dict
from pybullet_bridge.core.errors import ScenarioError
from pybullet_bridge.core.mobile_robot import MobileRobot
from pybullet_bridge.core.obstacles import BoxObstacle
from pybullet_bridge.core.scenario import (
    BUILTIN_ROBOT_TYPES, WallConfig, load_scenario, parse_scenario,
)

HERE = Path('.')


def parse(data: dict):
    return parse_scenario(data, HERE)


def test_demo_scenario_loads():
    scenario = load_scenario(SCENARIO_DIR / 'demo_mobile.yaml')
    assert scenario.name == 'demo_mobile'
    assert scenario.source == (SCENARIO_DIR / 'demo_mobile.yaml').resolve()
    assert scenario.world.bounds == (-3.0, -3.0, 3.0, 3.0)
    assert scenario.world.walls == WallConfig(height=0.3, thickness=0.05)
    assert math.isclose(scenario.world.physics_dt, 1 / 240, rel_tol=1e-6)
    robots = scenario.sections['mobile_robots']
    assert [r.name for r in robots] == ['robot_1', 'robot_2', 'robot_3']
    assert [r.params.type_name for r in robots] == ['pioneer_3dx', 'pioneer_3dx', 'turtlebot3_burger']
    assert all(isinstance(r, MobileRobot) for r in robots)
    obstacles = scenario.sections['obstacles']
    assert all(isinstance(o, BoxObstacle) for o in obstacles)
    assert [o.name for o in obstacles if o.name.startswith('map_')] == ['map_0', 'map_1', 'map_2']
    assert (scenario.camera.width, scenario.camera.height) == (320, 320)


def test_single_robot_test_scenario_loads():
    scenario = load_scenario(SCENARIO_DIR / 'test_single_robot.yaml')
    assert [r.name for r in scenario.sections['mobile_robots']] == ['robot_1']
    assert 'obstacles' not in scenario.sections
    assert scenario.world.walls is not None
    assert (scenario.camera.width, scenario.camera.height) == (160, 160)
    assert scenario.camera.center == (0.0, 0.0)


def test_defaults_and_robot_type_overrides():
    data = scenario_dict(world={'bounds': [0.0, 0.0, 4.0, 2.0]},
                         robot_types={'pioneer_3dx': {'max_linear_velocity': 0.8},
                                      'tiny': {'radius': 0.05, 'height': 0.05, 'mass': 0.2,
                                               'max_linear_velocity': 0.3, 'max_angular_velocity': 1.0,
                                               'max_linear_acceleration': 0.5,
                                               'max_angular_acceleration': 1.0, 'command_timeout': 1.0}},
                         mobile_robots=[robot(pose=[1.0, 1.0, 0.0]),
                                        robot(name='r2', type='tiny', pose=[2.0, 1.0, 0.0], radius=0.08,
                                              color=[0.1, 0.1, 0.9])])
    scenario = parse(data)
    assert scenario.world.walls is None
    assert scenario.camera.center == (2.0, 1.0)  # centre of bounds
    assert (scenario.camera.frame_id, scenario.camera.fov_deg, scenario.camera.rate) == ('top_camera', 45.0, 10.0)
    first, second = scenario.sections['mobile_robots']
    assert first.params.limits.max_linear_velocity == 0.8
    assert first.params.radius == BUILTIN_ROBOT_TYPES['pioneer_3dx']['radius']
    assert second.params.radius == 0.08 and second.params.mass == 0.2
    assert BUILTIN_ROBOT_TYPES['pioneer_3dx']['max_linear_velocity'] == 1.2  # built-ins untouched


def test_minimal_scenario_uses_every_default():
    scenario = parse({'name': 'bare'})
    assert scenario.world.bounds == (-3.0, -3.0, 3.0, 3.0) and scenario.world.walls is None
    assert scenario.world.frame_id == 'world' and scenario.world.gravity == -9.81
    assert (scenario.camera.width, scenario.camera.height, scenario.camera.altitude) == (320, 320, 8.0)
    assert scenario.camera.center == (0.0, 0.0) and scenario.sections == {} and scenario.seed is None


def test_empty_walls_mapping_uses_default_wall_size():
    data = scenario_dict()
    data['world']['walls'] = {}
    assert parse(data).world.walls == WallConfig(height=0.3, thickness=0.05)


def _with(path_and_value):
    """Build a scenario dict with one nested value set, e.g. ('camera.fov_deg', 0)."""
    def build():
        data = scenario_dict()
        *parents, leaf = path_and_value[0].split('.')
        node = data
        for key in parents:
            node = node[int(key)] if key.isdigit() else node[key]
        node[int(leaf) if leaf.isdigit() else leaf] = path_and_value[1]
        return data
    return build


def _without(dotted):
    def build():
        data = scenario_dict()
        *parents, leaf = dotted.split('.')
        node = data
        for key in parents:
            node = node[int(key)] if key.isdigit() else node[key]
        del node[leaf]
        return data
    return build


BAD_SCENARIOS = {
    # missing fields
    'missing name': (_without('name'), 'name: missing required field'),
    'camera not a mapping': (_with(('camera', [320, 240])), 'camera: must be a mapping (got list)'),
    'missing robot pose': (_without('mobile_robots.0.pose'), 'mobile_robots[0].pose: missing required field'),
    'missing robot color': (_without('mobile_robots.0.color'), 'mobile_robots[0].color: missing required field'),
    'missing box size': (lambda: scenario_dict(obstacles={'boxes': [{'center': [1, 1]}]}),
                         'obstacles.boxes[0].size: missing required field'),
    'incomplete new robot type': (
        lambda: scenario_dict(robot_types={'my_type': {'radius': 0.2}}),
        'robot_types.my_type.height: missing required field'),
    # unknown fields
    'unknown robot field': (_with(('mobile_robots.0.colour', [1, 0, 0])),
                            'mobile_robots[0].colour: unknown field (allowed: name, type, pose, color, radius'),
    'unknown world field': (_with(('world.gravty', -9.8)), 'world.gravty: unknown field (allowed: '),
    'unknown wall field': (_with(('world.walls.hieght', 1.0)), 'world.walls.hieght: unknown field'),
    'unknown top-level key': (lambda: scenario_dict(robots=[]),
                              'robots: unknown top-level field (known fields: name, seed, world, camera, '
                              'robot_types; known sections: mobile_robots, obstacles'),
    'unknown obstacles key': (lambda: scenario_dict(obstacles={'cylinders': []}), 'obstacles.cylinders: unknown field'),
    'unknown robot type field': (lambda: scenario_dict(robot_types={'pioneer_3dx': {'speed': 1.0}}),
                                 'robot_types.pioneer_3dx.speed: unknown field'),
    # unknown robot type
    'unknown robot type': (_with(('mobile_robots.0.type', 'foo')),
                           "mobile_robots[0].type: unknown robot type 'foo' (known: pioneer_3dx, turtlebot3_burger)"),
    # out of range
    'negative velocity override': (
        lambda: scenario_dict(mobile_robots=[robot(), robot(name='r2', pose=[1, 1, 0], color=[0, 0, 1],
                                                            max_linear_velocity=-1.0)]),
        'mobile_robots[1].max_linear_velocity: must be > 0.0 (got -1.0)'),
    'negative robot type mass': (lambda: scenario_dict(robot_types={'turtlebot3_burger': {'mass': 0}}),
                                 'robot_types.turtlebot3_burger.mass: must be > 0.0 (got 0.0)'),
    'fov zero': (_with(('camera.fov_deg', 0)), 'camera.fov_deg: must be > 1.0 (got 0.0)'),
    'fov 170': (_with(('camera.fov_deg', 170)), 'camera.fov_deg: must be < 170.0'),
    'colour channel above 1': (_with(('mobile_robots.0.color', [0.2, 1.5, 0.2])),
                               'mobile_robots[0].color[1]: must be <= 1.0 (got 1.5)'),
    'colour wrong length': (_with(('mobile_robots.0.color', [0.2, 0.5])),
                            'mobile_robots[0].color: must be a list of 3 numbers'),
    'pose outside bounds': (_with(('mobile_robots.0.pose', [5.0, 0.0, 0.0])), 'mobile_robots[0].pose: robot footprint'),
    'pose footprint crosses bounds': (_with(('mobile_robots.0.pose', [1.9, 0.0, 0.0])),
                                      'mobile_robots[0].pose: robot footprint'),
    'pose not a number': (_with(('mobile_robots.0.pose', [0.0, 'a', 0.0])), 'mobile_robots[0].pose[1]: must be a number'),
    'pose nan': (_with(('mobile_robots.0.pose', [0.0, math.nan, 0.0])), 'mobile_robots[0].pose[1]: must be finite'),
    'physics dt too large': (_with(('world.physics_dt', 0.1)), 'world.physics_dt: must be <= 0.05'),
    'bounds inverted': (_with(('world.bounds', [1, 0, 0, 1])), 'world.bounds: must be [xmin, ymin, xmax, ymax]'),
    'camera too small': (_with(('camera.width', 8)), 'camera.width: must be >= 16 (got 8)'),
    'camera width bool': (_with(('camera.width', True)), 'camera.width: must be an integer (got bool True)'),
    'camera width float': (_with(('camera.height', 64.5)), 'camera.height: must be an integer'),
    'camera rate zero': (_with(('camera.rate', 0)), 'camera.rate: must be > 0.0'),
    'altitude negative': (_with(('camera.altitude', -1)), 'camera.altitude: must be > 0.0'),
    'wall thickness zero': (_with(('world.walls.thickness', 0)), 'world.walls.thickness: must be > 0.0'),
    'bad robot name': (_with(('mobile_robots.0.name', '1robot')), "mobile_robots[0].name: invalid name '1robot'"),
    'robot list not a list': (lambda: scenario_dict(mobile_robots={'name': 'x'}), 'mobile_robots: must be a list'),
    'empty name': (_with(('name', '')), 'name: must be a non-empty string'),
    # duplicates
    'duplicate robot names': (
        lambda: scenario_dict(mobile_robots=[robot(), robot(pose=[1, 1, 0], color=[0, 0, 1])]),
        "mobile_robots[1].name: duplicate name 'robot_1' (also used by mobile_robots[0])"),
    'box named like a robot': (
        lambda: scenario_dict(obstacles={'boxes': [{'name': 'robot_1', 'center': [1, 1], 'size': [0.2, 0.2]}]}),
        "obstacles.boxes[0].name: duplicate name 'robot_1' (also used by mobile_robots[0])"),
    'box named walls': (
        lambda: scenario_dict(obstacles={'boxes': [{'name': 'walls', 'center': [1, 1], 'size': [0.2, 0.2]}]}),
        "obstacles.boxes[0].name: duplicate name 'walls' (also used by world.walls)"),
    'indistinct colours': (
        lambda: scenario_dict(mobile_robots=[robot(), robot(name='r2', pose=[1, 1, 0], color=[0.88, 0.1, 0.12])]),
        'mobile_robots[1].color: [0.88, 0.1, 0.12] is too close to the colour of mobile_robots[0]'),
    # map
    'bad map path': (
        lambda: scenario_dict(obstacles={'map': {'image': 'no_such_map.png', 'resolution': 0.05, 'origin': [0, 0]}}),
        'obstacles.map.image: image file'),
    'map missing resolution': (
        lambda: scenario_dict(obstacles={'map': {'image': str(SCENARIO_DIR / '../maps/demo_map.png'),
                                                 'origin': [0, 0]}}),
        'obstacles.map.resolution: missing required field'),
}


@pytest.mark.parametrize('build, expected_prefix', BAD_SCENARIOS.values(), ids=BAD_SCENARIOS.keys())
def test_invalid_scenario_names_the_field(build, expected_prefix):
    with pytest.raises(ScenarioError) as error:
        parse(build())
    assert str(error.value).startswith(expected_prefix), str(error.value)


def test_map_image_that_is_not_an_image(tmp_path):
    (tmp_path / 'map.png').write_text('not a png')
    data = scenario_dict(obstacles={'map': {'image': 'map.png', 'resolution': 0.05, 'origin': [0, 0]}})
    with pytest.raises(ScenarioError, match=r"^obstacles\.map\.image: image file .*: not a PNG"):
        parse_scenario(data, tmp_path)


def test_scenario_must_be_a_mapping():
    with pytest.raises(ScenarioError, match='^scenario: must be a mapping'):
        parse([1, 2])


def test_load_scenario_file_errors_name_the_file(tmp_path):
    missing = tmp_path / 'missing.yaml'
    with pytest.raises(ScenarioError, match=f"scenario file '{missing}': does not exist"):
        load_scenario(missing)
    broken = tmp_path / 'broken.yaml'
    broken.write_text('name: [unclosed\n')
    with pytest.raises(ScenarioError, match=f"scenario file '{broken}': invalid YAML"):
        load_scenario(broken)
    empty = tmp_path / 'empty.yaml'
    empty.write_text('')
    with pytest.raises(ScenarioError, match='file is empty'):
        load_scenario(empty)


def test_load_scenario_field_error_keeps_path_first_and_names_file(tmp_path):
    bad = tmp_path / 'bad.yaml'
    bad.write_text('name: x\nmobile_robots:\n  - {name: r, type: pioneer_3dx, color: [1, 0, 0]}\n')
    with pytest.raises(ScenarioError) as error:
        load_scenario(bad)
    assert str(error.value).startswith('mobile_robots[0].pose: missing required field')
    assert str(bad) in str(error.value)


def test_map_path_is_relative_to_the_scenario_file(tmp_path):
    (tmp_path / 'maps').mkdir()
    (tmp_path / 'scenarios').mkdir()
    (tmp_path / 'maps' / 'm.png').write_bytes((SCENARIO_DIR / '../maps/demo_map.png').read_bytes())
    (tmp_path / 'scenarios' / 's.yaml').write_text(
        'name: s\ncamera: {width: 32, height: 32}\n'
        'obstacles: {map: {image: ../maps/m.png, resolution: 0.05, origin: [-3, -3]}}\n')
    scenario = load_scenario(tmp_path / 'scenarios' / 's.yaml')
    assert len(scenario.sections['obstacles']) == 3
