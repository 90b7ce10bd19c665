"""Top-view camera: geometry, and renders consistent with that geometry."""
import math
from pathlib import Path

import numpy as np
import pybullet as p
import pytest

from bridge_core_helpers import robot, scenario_dict
from pybullet_bridge.core.camera import TopViewCamera
from pybullet_bridge.core.scenario import CameraConfig, parse_scenario
from pybullet_bridge.core.scene import Scene

CONFIG = CameraConfig(frame_id='top_camera', rate=10.0, width=120, height=80,
                      center=(0.5, -0.25), altitude=6.0, fov_deg=50.0)


def test_intrinsics_follow_vertical_fov_and_pixel_centre_convention():
    camera = TopViewCamera(CONFIG)
    K = camera.intrinsics()
    focal = 80 / (2 * math.tan(math.radians(25.0)))
    assert K == pytest.approx(np.array([[focal, 0, 59.5], [0, focal, 39.5], [0, 0, 1]]))
    assert camera.projection() == pytest.approx(np.hstack([K, np.zeros((3, 1))]))


def test_world_to_pixel_axes():
    camera = TopViewCamera(CONFIG)
    assert camera.world_to_pixel(0.5, -0.25) == pytest.approx((59.5, 39.5))
    u0, v0 = camera.world_to_pixel(0.5, -0.25)
    u1, v1 = camera.world_to_pixel(1.5, 0.75)  # +x and +y
    assert u1 > u0 and v1 < v0  # image right = +x, image up = +y
    # A higher point looks farther from the image centre (perspective).
    assert camera.world_to_pixel(1.5, 0.75, z=1.0)[0] > u1


def test_pixel_world_round_trip():
    camera = TopViewCamera(CONFIG)
    rng = np.random.default_rng(7)
    for x, y, z in rng.uniform([-3, -3, 0], [3, 3, 2], size=(50, 3)):
        u, v = camera.world_to_pixel(x, y, z)
        assert camera.pixel_to_world(u, v, z) == pytest.approx((x, y))
    with pytest.raises(ValueError):
        camera.world_to_pixel(0.0, 0.0, z=7.0)


def test_optical_pose_projects_like_world_to_pixel():
    camera = TopViewCamera(CONFIG)
    position, quaternion = camera.optical_pose()
    rotation = np.array(p.getMatrixFromQuaternion(quaternion)).reshape(3, 3)  # optical -> world
    assert rotation @ [1, 0, 0] == pytest.approx([1, 0, 0])   # x right = world +x
    assert rotation @ [0, 1, 0] == pytest.approx([0, -1, 0])  # y down = world -y
    assert rotation @ [0, 0, 1] == pytest.approx([0, 0, -1])  # z forward = down
    point = np.array([1.2, -0.9, 0.3])
    in_optical = rotation.T @ (point - np.array(position))
    u, v, w = camera.intrinsics() @ in_optical
    assert (u / w, v / w) == pytest.approx(camera.world_to_pixel(*point))


@pytest.fixture
def scene():
    data = scenario_dict(
        camera={'width': 160, 'height': 120, 'altitude': 5.0, 'center': [0.2, -0.1]},
        mobile_robots=[robot(pose=[1.0, 0.5, 0.0]),
                       robot(name='robot_2', type='turtlebot3_burger', pose=[-1.2, -0.6, math.pi / 2],
                             color=[0.1, 0.2, 0.9])],
        obstacles={'boxes': [{'name': 'crate', 'center': [-0.5, 1.0], 'size': [0.4, 0.4], 'height': 0.3}]})
    with Scene(parse_scenario(data, Path('.'))) as created:
        yield created


def label_centroid(labels: np.ndarray, label: int) -> tuple[float, float]:
    rows, cols = np.nonzero(labels == label)
    assert rows.size > 0, f'label {label} not visible'
    return cols.mean(), rows.mean()


def test_render_shapes_types_and_legend(scene):
    frame = scene.render()
    assert frame.rgb.shape == (120, 160, 3) and frame.rgb.dtype == np.uint8
    assert frame.labels.shape == (120, 160) and frame.labels.dtype == np.uint16
    assert frame.sim_time == scene.sim_time
    legend = scene.label_legend()
    assert [name for _, name, _ in legend] == ['walls', 'robot_1', 'robot_2', 'crate']
    assert set(np.unique(frame.labels)) == {0} | {label for label, _, _ in legend}


@pytest.mark.parametrize('name', ['robot_1', 'robot_2', 'crate'])
def test_labels_appear_where_world_to_pixel_puts_them(scene, name):
    entity = scene.entity(name)
    position, _ = p.getBasePositionAndOrientation(entity.body_ids[0], physicsClientId=scene.client)
    top = 2 * position[2]  # bodies stand on the ground, centred at half height
    expected = scene.camera.world_to_pixel(position[0], position[1], top)
    assert label_centroid(scene.render().labels, entity.label) == pytest.approx(expected, abs=1.5)


def test_heading_marker_points_along_robot_heading(scene):
    frame = scene.render()
    for name, direction in (('robot_1', (1, 0)), ('robot_2', (0, -1))):  # yaw 0 -> +u, yaw pi/2 -> -v
        entity = scene.entity(name)
        mask = frame.labels == entity.label
        dark = mask & (frame.rgb.astype(int).sum(axis=2) < 120)
        assert dark.sum() > 0, f'{name}: heading marker not visible'
        rows, cols = np.nonzero(dark)
        cu, cv = label_centroid(frame.labels, entity.label)
        offset = np.array([cols.mean() - cu, rows.mean() - cv])
        radius_px = entity.params.radius * scene.camera.focal / (scene.camera.altitude - entity.params.height)
        along = offset @ np.array(direction)
        across = abs(offset @ np.array([direction[1], -direction[0]]))
        # The marker is centred 0.6 radius ahead of the robot's centre.
        assert along > 0.4 * radius_px and across < 0.2 * radius_px


def test_render_follows_the_robot(scene):
    before = scene.render()
    bot = scene.entity('robot_1')
    for _ in range(10):
        bot.set_command(0.6, 0.0, scene.sim_time)
        scene.step(24)
    after = scene.render()
    assert not np.array_equal(before.rgb, after.rgb)
    moved = label_centroid(after.labels, bot.label)[0] - label_centroid(before.labels, bot.label)[0]
    x0, x1 = bot.initial_pose[0], bot.pose2d(scene.client)[0]
    expected = scene.camera.world_to_pixel(x1, 0)[0] - scene.camera.world_to_pixel(x0, 0)[0]
    assert moved == pytest.approx(expected, abs=1.5) and moved > 3


def test_label_lookup_function_and_array_agree(scene):
    array_rgb, array_labels = scene.camera.render(scene.client, scene.body_label_lookup)
    function_rgb, function_labels = scene.camera.render(scene.client, scene.label_of_body)
    assert np.array_equal(array_labels, function_labels)
    assert np.array_equal(array_rgb, function_rgb)
