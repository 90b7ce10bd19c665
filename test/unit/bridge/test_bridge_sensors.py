"""Per-robot simulated sensors (fiducial, laser, GPS, bumper), targets and movable boxes."""
import math
from pathlib import Path

import numpy as np
import pybullet as p
import pytest

from bridge_core_helpers import SCENARIO_DIR, robot, scenario_dict
from pybullet_bridge.core.errors import ScenarioError
from pybullet_bridge.core.scenario import load_scenario, parse_scenario
from pybullet_bridge.core.scene import Scene
from pybullet_bridge.core.sensors import RobotSensors

PIONEER_RADIUS = 0.23


def make_scene(robots, **sections) -> Scene:
    data = scenario_dict(mobile_robots=robots, **sections)
    return Scene(parse_scenario(data, Path('.')))


def sensing_robot(sensors, pose=(0.0, 0.0, 0.0), name='robot_1', color=(0.9, 0.1, 0.1)) -> dict:
    return robot(name=name, pose=list(pose), color=list(color), sensors=sensors)


def seen(scene, name='robot_1') -> dict:
    reading = RobotSensors(scene, scene.entity(name)).read('fiducial')
    return {d.name: d for d in reading.detections}


def target(name, x, y, **fields) -> dict:
    return {'name': name, 'position': [x, y], **fields}


# -- fiducial -------------------------------------------------------------------------------

def test_fiducial_field_of_view_edges():
    # 90 deg FOV: bearings of +-44 deg are in, +-46 deg are out.
    targets = [target(f'{side}_{angle}', 1.5 * math.cos(math.radians(sign * angle)),
                      1.5 * math.sin(math.radians(sign * angle)))
               for side, sign in (('left', 1), ('right', -1)) for angle in (44, 46)]
    with make_scene([sensing_robot({'fiducial': {'fov_deg': 90.0, 'range': 3.0}})], targets=targets) as scene:
        detections = seen(scene)
    assert set(detections) == {'left_44', 'right_44'}
    assert detections['left_44'].bearing == pytest.approx(math.radians(44), abs=1e-6)
    assert detections['right_44'].bearing == pytest.approx(math.radians(-44), abs=1e-6)
    assert detections['left_44'].kind == 'target'


def test_fiducial_field_of_view_turns_with_the_robot():
    # Facing -y (yaw -90 deg) the robot sees what is below it, not what is ahead along +x.
    targets = [target('ahead_x', 1.5, 0.0), target('below', 0.0, -1.5)]
    sensors = {'fiducial': {'fov_deg': 60.0, 'range': 3.0}}
    with make_scene([sensing_robot(sensors, pose=(0.0, 0.0, -math.pi / 2))], targets=targets) as scene:
        detections = seen(scene)
    assert set(detections) == {'below'}
    below = detections['below']
    assert (below.range, below.bearing, below.x, below.y) == pytest.approx((1.5, 0.0, 1.5, 0.0), abs=1e-6)


def test_fiducial_range_edge_and_relative_position():
    targets = [target('near', 0.0, 1.49), target('far', 0.0, -1.51)]
    with make_scene([sensing_robot({'fiducial': {'fov_deg': 360.0, 'range': 1.5}})], targets=targets) as scene:
        detections = seen(scene)
    assert set(detections) == {'near'}
    near = detections['near']
    # 90 deg to the left of a robot facing +x: x 0, y 1.49 in its frame.
    assert (near.range, near.bearing) == pytest.approx((1.49, math.pi / 2), abs=1e-6)
    assert (near.x, near.y) == pytest.approx((0.0, 1.49), abs=1e-6)


@pytest.mark.parametrize('own_yaw, other_yaw', [(0.0, 0.0), (0.3, 1.2), (-2.5, 2.9), (math.pi / 2, -math.pi / 2)])
def test_fiducial_reports_the_seen_robots_relative_orientation(own_yaw, other_yaw):
    robots = [sensing_robot({'fiducial': {'fov_deg': 360.0, 'range': 3.0}}, pose=(0.0, 0.0, own_yaw)),
              robot(name='robot_2', pose=[1.2, 0.4, other_yaw], color=[0.1, 0.9, 0.1])]
    with make_scene(robots) as scene:
        detection = seen(scene)['robot_2']
    expected = (other_yaw - own_yaw + math.pi) % (2 * math.pi) - math.pi
    assert math.cos(detection.yaw - expected) == pytest.approx(1.0, abs=1e-9)
    # The robot's own position in robot_2's frame follows from (x, y, yaw) alone: the inversion
    # a teammate computes from this detection (F_R(Y, X) => F_R(X, Y)).
    c, s = math.cos(detection.yaw), math.sin(detection.yaw)
    back = (-(c * detection.x + s * detection.y), -(-s * detection.x + c * detection.y))
    dx, dy = -1.2, -0.4
    co, so = math.cos(other_yaw), math.sin(other_yaw)
    assert back == pytest.approx((co * dx + so * dy, -so * dx + co * dy), abs=1e-6)


def test_fiducial_occlusion_by_a_box_and_removing_it_restores_the_view():
    robots = [sensing_robot({'fiducial': {'fov_deg': 180.0, 'range': 3.0}}, pose=(-1.0, 0.0, 0.0)),
              robot(name='robot_2', pose=[1.0, 0.0, 0.0], color=[0.1, 0.9, 0.1])]
    obstacles = {'boxes': [{'name': 'crate', 'center': [0.0, 0.0], 'size': [0.2, 0.6], 'height': 0.3}]}
    with make_scene(robots, obstacles=obstacles, targets=[target('beside', -1.0, 1.0)]) as scene:
        assert set(seen(scene)) == {'beside'}
        p.removeBody(scene.entity('crate').main_body, physicsClientId=scene.client)
        detections = seen(scene)
        assert set(detections) == {'beside', 'robot_2'}
        assert detections['robot_2'].range == pytest.approx(2.0, abs=1e-6)
        assert detections['robot_2'].kind == 'mobile_robot'


def test_fiducial_view_is_blocked_by_the_robot_in_front():
    # The paper's column formation: each robot only sees the one immediately in front of it.
    sensors = {'fiducial': {'fov_deg': 180.0, 'range': 4.0}}
    robots = [sensing_robot(sensors, pose=(-1.5, 0.0, 0.0)),
              robot(name='robot_2', pose=[-0.5, 0.0, 0.0], color=[0.1, 0.9, 0.1]),
              robot(name='robot_3', pose=[0.5, 0.0, 0.0], color=[0.1, 0.1, 0.9])]
    with make_scene(robots) as scene:
        assert set(seen(scene)) == {'robot_2'}


def test_fiducial_kinds_and_noise_are_seeded():
    sensors = {'seed': 3, 'fiducial': {'fov_deg': 360.0, 'range': 3.0, 'kinds': ['target'],
                                       'range_noise_std': 0.05, 'bearing_noise_std': 0.02,
                                       'yaw_noise_std': 0.03}}
    robots = [sensing_robot(sensors), robot(name='robot_2', pose=[1.0, 0.0, 0.0], color=[0.1, 0.9, 0.1])]

    def readings():
        with make_scene(robots, targets=[target('goal', 0.0, 1.0)]) as scene:
            sensors_ = RobotSensors(scene, scene.entity('robot_1'))
            return [sensors_.read('fiducial').detections for _ in range(200)]

    first, again = readings(), readings()
    assert first == again
    assert all([d.name for d in detections] == ['goal'] for detections in first)
    ranges = np.array([detections[0].range for detections in first])
    bearings = np.array([detections[0].bearing for detections in first])
    assert ranges.std() == pytest.approx(0.05, rel=0.2) and abs(ranges.mean() - 1.0) < 0.02
    assert bearings.std() == pytest.approx(0.02, rel=0.2) and abs(bearings.mean() - math.pi / 2) < 0.01
    yaws = np.array([detections[0].yaw for detections in first])
    assert yaws.std() == pytest.approx(0.03, rel=0.2) and abs(yaws.mean()) < 0.01
    xy = np.array([(d[0].x, d[0].y) for d in first])
    assert np.allclose(np.hypot(xy[:, 0], xy[:, 1]), ranges)


# -- laser ----------------------------------------------------------------------------------

def test_laser_ranges_to_the_walls_and_a_box():
    # MINIMAL's walls stand on the bounds +-2 m; a box's face is 1.0 m ahead.
    sensors = {'laser': {'fov_deg': 360.0, 'beams': 4, 'range': 5.0}}
    obstacles = {'boxes': [{'center': [1.2, 0.0], 'size': [0.4, 0.4]}]}
    with make_scene([sensing_robot(sensors)], obstacles=obstacles) as scene:
        scan = RobotSensors(scene, scene.entity('robot_1')).read('laser')
    # Beams at -180, -90, 0, 90 deg.
    assert (scan.angle_min, scan.angle_increment) == pytest.approx((-math.pi, math.pi / 2))
    assert scan.angle_max == pytest.approx(math.pi / 2)
    assert scan.ranges == pytest.approx([2.0, 2.0, 1.0, 2.0], abs=1e-3)
    assert scan.range_min == PIONEER_RADIUS and scan.range_max == 5.0


def test_laser_turns_with_the_robot_and_reports_inf_beyond_range():
    yaw = 0.3
    with make_scene([sensing_robot({'laser': {'fov_deg': 90.0, 'beams': 3, 'range': 3.0}}, pose=(0, 0, yaw))]) \
            as scene:
        scan = RobotSensors(scene, scene.entity('robot_1')).read('laser')
    # Beams at yaw - 45, yaw, yaw + 45 deg in the world; walls at x = 2 and y = 2.
    expected = [2.0 / math.cos(yaw - math.pi / 4), 2.0 / math.cos(yaw), 2.0 / math.sin(yaw + math.pi / 4)]
    assert scan.ranges == pytest.approx(expected, abs=1e-3)
    with make_scene([sensing_robot({'laser': {'fov_deg': 90.0, 'beams': 3, 'range': 1.5}})]) as scene:
        short = RobotSensors(scene, scene.entity('robot_1')).read('laser')
    assert np.all(np.isinf(short.ranges))


# -- GPS ------------------------------------------------------------------------------------

def test_gps_noise_statistics_with_a_seed():
    def fixes(seed):
        sensors = {'seed': seed, 'gps': {'noise_std': 0.1, 'yaw_noise_std': 0.05}}
        with make_scene([sensing_robot(sensors, pose=(0.5, -0.5, 1.0))]) as scene:
            gps = RobotSensors(scene, scene.entity('robot_1'))
            return np.array([(f.x, f.y, f.yaw) for f in (gps.read('gps') for _ in range(4000))])

    samples = fixes(11)
    assert np.array_equal(samples, fixes(11))
    assert not np.array_equal(samples, fixes(12))
    mean, std = samples.mean(axis=0), samples.std(axis=0)
    # Standard error of the mean: 0.1 / sqrt(4000) = 0.0016 m; allow 4 of them.
    assert mean == pytest.approx((0.5, -0.5, 1.0), abs=4 * 0.1 / math.sqrt(4000))
    assert std == pytest.approx((0.1, 0.1, 0.05), rel=0.05)
    # x and y noise are independent.
    assert abs(np.corrcoef(samples[:, 0], samples[:, 1])[0, 1]) < 0.05


def test_gps_without_noise_is_the_true_pose():
    with make_scene([sensing_robot({'gps': {}}, pose=(0.3, 0.2, -2.0))]) as scene:
        fix = RobotSensors(scene, scene.entity('robot_1')).read('gps')
    assert (fix.x, fix.y, fix.yaw) == pytest.approx((0.3, 0.2, -2.0), abs=1e-6)


# -- bumper and movable boxes --------------------------------------------------------------

def drive(scene, name, linear, seconds):
    entity = scene.entity(name)
    for _ in range(int(round(seconds / scene.physics_dt))):
        entity.set_command(linear, 0.0, scene.sim_time)
        scene.step()


def test_bumper_reports_the_box_it_drives_into():
    obstacles = {'boxes': [{'name': 'crate', 'center': [1.0, 0.0], 'size': [0.4, 0.4]}]}
    with make_scene([sensing_robot({'bumper': {}})], obstacles=obstacles) as scene:
        bumper = RobotSensors(scene, scene.entity('robot_1'))
        scene.step()
        assert not bumper.read('bumper').pressed
        drive(scene, 'robot_1', 0.5, 3.0)   # 0.57 m to the box face
        reading = bumper.read('bumper')
        x, _, _ = scene.entity('robot_1').pose2d(scene.client)
    assert x == pytest.approx(0.8 - PIONEER_RADIUS, abs=0.01)
    assert reading.pressed
    assert [(c.name, c.kind) for c in reading.contacts] == [('crate', 'box_obstacle')]
    assert reading.contacts[0].bearing == pytest.approx(0.0, abs=0.05)


def test_bumper_arc_ignores_contacts_behind():
    obstacles = {'boxes': [{'name': 'crate', 'center': [-1.0, 0.0], 'size': [0.4, 0.4]}]}
    with make_scene([sensing_robot({'bumper': {'fov_deg': 180.0}})], obstacles=obstacles) as scene:
        drive(scene, 'robot_1', -0.5, 3.0)
        assert not RobotSensors(scene, scene.entity('robot_1')).read('bumper').pressed
        x, _, _ = scene.entity('robot_1').pose2d(scene.client)
        assert x == pytest.approx(-0.8 + PIONEER_RADIUS, abs=0.01)  # it did hit the crate


def test_robot_pushes_a_movable_box_and_feels_it():
    boxes = [{'name': 'box_1', 'center': [0.6, 0.0], 'size': [0.3, 0.3], 'mass': 2.0, 'friction': 0.5}]
    with make_scene([sensing_robot({'bumper': {}})], movable_boxes=boxes) as scene:
        drive(scene, 'robot_1', 0.4, 3.0)
        box_x = p.getBasePositionAndOrientation(scene.entity('box_1').main_body,
                                                physicsClientId=scene.client)[0][0]
        reading = RobotSensors(scene, scene.entity('robot_1')).read('bumper')
        robot_x, _, _ = scene.entity('robot_1').pose2d(scene.client)
    assert box_x > 1.0                                       # pushed ~0.8 m from 0.6
    assert box_x - robot_x == pytest.approx(0.15 + PIONEER_RADIUS, abs=0.02)  # in contact
    assert [(c.name, c.kind) for c in reading.contacts] == [('box_1', 'movable_box')]


# -- activation and rates ------------------------------------------------------------------

def test_inactive_sensors_produce_nothing_until_activated():
    sensors = {'fiducial': {'active': False, 'rate': 10.0}, 'gps': {'active': False}}
    with make_scene([sensing_robot(sensors)]) as scene:
        suite = RobotSensors(scene, scene.entity('robot_1'))
        produced = []
        for _ in range(240):
            scene.step()
            produced += suite.due(scene.sim_time)
        assert produced == []
        suite.set_active('fiducial', True, scene.sim_time)
        for _ in range(240):   # 1 s at 10 Hz
            produced += suite.due(scene.sim_time)
            scene.step()
        assert [name for name, _ in produced] == ['fiducial'] * 10
        suite.set_active('fiducial', False, scene.sim_time)
        scene.step()
        assert suite.due(scene.sim_time) == []
        with pytest.raises(KeyError, match="robot 'robot_1' has no sensor 'laser' \\(it has: fiducial, gps\\)"):
            suite.set_active('laser', True, scene.sim_time)


def test_robots_without_sensors_have_none():
    with make_scene([robot()]) as scene:
        assert scene.entity('robot_1').sensors is None
        with pytest.raises(ValueError, match='no sensors'):
            RobotSensors(scene, scene.entity('robot_1'))


def test_test_sensors_scenario_sees_what_its_comment_says():
    with Scene(load_scenario(SCENARIO_DIR / 'test_sensors.yaml')) as scene:
        detections = seen(scene)
        other = seen(scene, 'robot_2')
    assert set(detections) == {'robot_2', 'target_1'}
    assert detections['robot_2'].range == pytest.approx(2.0, abs=1e-6)
    assert detections['target_1'].bearing == pytest.approx(math.pi / 4, abs=1e-6)
    assert 'robot_3' in other   # robot_2's 360 deg fiducial sees it past the wall segment


# -- configuration errors ------------------------------------------------------------------

@pytest.mark.parametrize('sensors, message', [
    ({'sonar': {}}, r"mobile_robots\[0\]\.sensors\.sonar: unknown field \(allowed: seed, fiducial, laser, gps"),
    ({}, r'mobile_robots\[0\]\.sensors: lists no sensor'),
    ([], r'mobile_robots\[0\]\.sensors: must be a mapping'),
    ({'fiducial': {'fov_deg': 0}}, r'sensors\.fiducial\.fov_deg: must be > 0\.0 \(got 0\.0\)'),
    ({'fiducial': {'fov_deg': 400}}, r'sensors\.fiducial\.fov_deg: must be <= 360\.0 \(got 400\.0\)'),
    ({'fiducial': {'range': -1}}, r'sensors\.fiducial\.range: must be > 0\.0'),
    ({'fiducial': {'kinds': ['wall']}},
     r"sensors\.fiducial\.kinds\[0\]: unknown kind 'wall' \(allowed: mobile_robot"),
    ({'fiducial': {'active': 'yes'}}, r"sensors\.fiducial\.active: must be true or false \(got 'yes'\)"),
    ({'fiducial': {'fov': 90}}, r'sensors\.fiducial\.fov: unknown field \(allowed: fov_deg'),
    ({'laser': {'beams': 0}}, r'sensors\.laser\.beams: must be >= 1 \(got 0\)'),
    ({'laser': {'beams': 2.5}}, r'sensors\.laser\.beams: must be an integer'),
    ({'gps': {'noise_std': -0.1}}, r'sensors\.gps\.noise_std: must be >= 0\.0'),
    ({'gps': {'rate': 0}}, r'sensors\.gps\.rate: must be > 0\.0'),
    ({'bumper': {'rate': 1000}}, r'sensors\.bumper\.rate: must be <= 100\.0'),
    ({'seed': 'x', 'gps': {}}, r'sensors\.seed: must be an integer'),
])
def test_bad_sensor_config_names_the_field(sensors, message):
    with pytest.raises(ScenarioError, match=message):
        parse_scenario(scenario_dict(mobile_robots=[sensing_robot(sensors)]), Path('.'))


@pytest.mark.parametrize('section, value, message', [
    ('targets', [{'position': [0.0, 1.0]}], r'targets\[0\]\.name: missing required field'),
    ('targets', [{'name': 't', 'position': [1.98, 0.0]}],
     r'targets\[0\]\.position: target footprint .* inside'),
    ('targets', [{'name': 't', 'position': [0.0, 1.0], 'mass': -1}], r'targets\[0\]\.mass: must be >= 0\.0'),
    ('movable_boxes', [{'name': 'b', 'center': [1.9, 0.0], 'size': [0.4, 0.4]}],
     r'movable_boxes\[0\]\.center: box .* must lie inside world\.bounds'),
    ('movable_boxes', [{'name': 'b', 'center': [1.0, 0.0], 'size': [0.4, 0.4], 'mass': 0}],
     r'movable_boxes\[0\]\.mass: must be > 0\.0'),
    ('movable_boxes', [{'name': 'robot_1', 'center': [1.0, 1.0], 'size': [0.2, 0.2]}],
     r"movable_boxes\[0\]\.name: duplicate name 'robot_1'"),
])
def test_bad_targets_and_boxes_name_the_field(section, value, message):
    with pytest.raises(ScenarioError, match=message):
        parse_scenario(scenario_dict(**{section: value}), Path('.'))


def test_sections_keep_earlier_labels_and_add_targets_and_boxes_last():
    data = scenario_dict(targets=[target('goal', 1.0, 1.0)],
                         movable_boxes=[{'name': 'box_1', 'center': [-1.0, 1.0], 'size': [0.3, 0.3]}])
    with Scene(parse_scenario(data, Path('.'))) as scene:
        assert scene.label_legend() == [(1, 'walls', 'wall'), (2, 'robot_1', 'mobile_robot'),
                                        (3, 'goal', 'target'), (4, 'box_1', 'movable_box')]
