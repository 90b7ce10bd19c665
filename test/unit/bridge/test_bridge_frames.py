"""core/frames.py: the scene's TF frames agree with the camera model, the arms, tables and ground truth."""
import numpy as np
import pytest

from bridge_core_helpers import SCENARIO_DIR
from collab_tools.core.tf_tree import TfTree
from pybullet_bridge.core.frames import (BODY_TO_OPTICAL, base_frame, optical_frame, robot_transforms,
                                         sensor_frame, static_transforms)
from pybullet_bridge.core.scenario import load_scenario
from pybullet_bridge.core.scene import Scene


def tree_of(scene: Scene) -> TfTree:
    tree = TfTree()
    position, orientation = scene.camera.optical_pose()
    for t in static_transforms(scene.scenario.world.frame_id, scene.entities, scene.camera.frame_id,
                               position, orientation):
        tree.add(t.parent, t.child, t.pose)
    for t in robot_transforms(scene.scenario.world.frame_id, scene.body_states()):
        tree.add(t.parent, t.child, t.pose)
    return tree


def close(a, b, tol=1e-6):
    return np.allclose(np.asarray(a, dtype=float), np.asarray(b, dtype=float), atol=tol)


@pytest.fixture(scope='module')
def sensors_scene():
    with Scene(load_scenario(SCENARIO_DIR / 'test_sensors.yaml')) as scene:
        scene.step(24)
        yield scene


@pytest.fixture(scope='module')
def tabletop_scene():
    with Scene(load_scenario(SCENARIO_DIR / 'test_tabletop.yaml')) as scene:
        yield scene


def test_optical_frame_projects_world_points_like_the_camera_model(sensors_scene):
    scene = sensors_scene
    tree = tree_of(scene)
    camera = scene.camera
    optical = tree.lookup(optical_frame(camera.frame_id), 'world')
    k = camera.intrinsics()
    for world_point in [(0.0, 0.0, 0.0), (1.5, -0.7, 0.0), (-2.0, 2.0, 0.3)]:
        x, y, z = optical.apply(world_point)
        assert z > 0, 'the camera looks down: ground points lie in front of it'
        u, v = k[0, 0] * x / z + k[0, 2], k[1, 1] * y / z + k[1, 2]
        assert close((u, v), camera.world_to_pixel(*world_point), 1e-6)


def test_camera_body_frame_follows_rep_103(sensors_scene):
    tree = tree_of(sensors_scene)
    body = tree.lookup('world', sensors_scene.camera.frame_id)
    # x forward along the optical axis (down), z towards image up (+y), at the camera position.
    assert close(body.apply((1.0, 0.0, 0.0)), np.add(body.translation, (0.0, 0.0, -1.0)))
    assert close(body.apply((0.0, 0.0, 1.0)), np.add(body.translation, (0.0, 1.0, 0.0)))
    assert close(body.translation, sensors_scene.camera.optical_pose()[0])
    assert tree.parent_of(optical_frame('top_camera')) == 'top_camera'
    assert BODY_TO_OPTICAL.apply((0.0, 0.0, 1.0)) == pytest.approx((1.0, 0.0, 0.0))


def test_robots_base_link_is_their_ground_truth_pose(sensors_scene):
    tree = tree_of(sensors_scene)
    bodies = {b.name: b for b in sensors_scene.body_states()}
    for name in ('robot_1', 'robot_2', 'robot_3'):
        pose = tree.lookup('world', base_frame(name))
        assert close(pose.translation, bodies[name].position)
        q = np.asarray(pose.rotation)
        assert abs(abs(float(q @ np.asarray(bodies[name].orientation_xyzw))) - 1.0) < 1e-9
    # Only mobile robots are dynamic frames.
    assert {t.child for t in robot_transforms('world', sensors_scene.body_states())} == \
        {'robot_1/base_link', 'robot_2/base_link', 'robot_3/base_link'}


def test_sensor_frames_hang_off_their_robot(sensors_scene):
    tree = tree_of(sensors_scene)
    frames = tree.frames()
    # robot_1 carries all four kinds; gps has no frame (it reports world poses).
    assert {sensor_frame('robot_1', s) for s in ('fiducial', 'laser', 'bumper')} <= frames
    assert 'robot_1/gps_link' not in frames
    assert sensor_frame('robot_2', 'fiducial') in frames and sensor_frame('robot_2', 'laser') not in frames
    assert not any(f.startswith('robot_3/') and f != 'robot_3/base_link' for f in frames)
    laser = tree.lookup('world', sensor_frame('robot_1', 'laser'))
    base = tree.lookup('world', base_frame('robot_1'))
    assert close(laser.translation, base.translation) and close(laser.rotation, base.rotation)
    with pytest.raises(KeyError):
        sensor_frame('robot_1', 'gps')


def test_arm_bases_and_table_top(tabletop_scene):
    tree = tree_of(tabletop_scene)
    leader = tree.lookup('world', 'leader_arm/base_link')
    assert close(leader.translation, (-0.565, 0.0, 0.40))
    follower = tree.lookup('world', 'follower_arm/base_link')
    # The follower faces -x (yaw pi): its x axis points back at the table.
    assert close(follower.apply((1.0, 0.0, 0.0)), (0.565 - 1.0, 0.0, 0.40))
    assert close(tree.lookup('world', 'table').translation, (0.0, 0.0, 0.40))
    # The arms see each other's base 1.13 m straight ahead.
    assert close(tree.lookup('leader_arm/base_link', 'follower_arm/base_link').translation, (1.13, 0.0, 0.0))
    # Cubes move: they are ground truth, not frames.
    assert not {'red_1', 'blue_1', 'red_1/base_link'} & tree.frames()
