"""Top-view geometry, obstacle segmentation and colour tracking on images rendered by the bridge."""
import math
from pathlib import Path

import numpy as np
import pytest

from pybullet_bridge.core import MobileRobot, Scene, parse_scenario
from role_engine.core.errors import RoleEngineError
from role_engine.core.grid import GridFrame
from collab_tools.core.camera_geometry import TopViewGeometry
from role_engine.core.top_view import environment_from_top_view, estimate_floor_colors, robot_disc_mask, segment_obstacles
from role_engine.core.tracking import ColorTracker, TrackedTarget

COLORS = [[0.85, 0.15, 0.15], [0.15, 0.35, 0.85], [0.15, 0.75, 0.25], [0.9, 0.6, 0.1]]
TYPES = ['pioneer_3dx', 'turtlebot3_burger', 'pioneer_3dx', 'turtlebot3_burger']
BOXES = [{'name': 'crate', 'center': [1.0, 0.8], 'size': [0.8, 0.5], 'height': 0.1, 'color': [0.3, 0.3, 0.3]},
         {'name': 'shelf', 'center': [-1.2, -1.0], 'size': [0.4, 1.0], 'height': 0.1, 'color': [0.55, 0.45, 0.3]}]


def scenario(poses) -> dict:
    return {'name': 'tracking', 'world': {'bounds': [-3.0, -3.0, 3.0, 3.0]},
            'camera': {'width': 320, 'height': 320, 'altitude': 8.0},
            'mobile_robots': [{'name': f'robot_{i}', 'type': TYPES[i], 'pose': list(pose), 'color': COLORS[i]}
                              for i, pose in enumerate(poses)],
            'obstacles': {'boxes': BOXES}}


def geometry_of(scene) -> TopViewGeometry:
    """The geometry as a node rebuilds it from CameraInfo.k and the published pose."""
    position, orientation = scene.camera.optical_pose()
    return TopViewGeometry.from_camera_info(scene.camera.intrinsics().ravel(), position, orientation)


def targets_of(scene) -> list[TrackedTarget]:
    return [TrackedTarget(r.name, r.params.color, r.params.radius, r.params.height)
            for r in scene.entities_of(MobileRobot)]


def heading_error(a: float, b: float) -> float:
    return abs((a - b + math.pi) % (2 * math.pi) - math.pi)


def test_geometry_agrees_with_the_bridge_camera():
    with Scene(parse_scenario(scenario([(0.0, 0.0, 0.0)]), Path('.'))) as scene:
        geometry = geometry_of(scene)
        points = np.array([[0.0, 0.0], [2.0, -1.0], [-2.5, 2.2]])
        for z in (0.0, 0.3):
            expected = np.array([scene.camera.world_to_pixel(x, y, z) for x, y in points])
            assert geometry.world_to_pixel(points, z) == pytest.approx(expected)
            assert geometry.pixel_to_world(expected, z) == pytest.approx(points)


@pytest.mark.parametrize('seed', [1, 2, 3])
def test_tracker_finds_every_robot_within_a_pixel(seed):
    rng = np.random.default_rng(seed)
    poses = [(*rng.uniform(-2.6, 2.6, 2), rng.uniform(-math.pi, math.pi)) for _ in range(4)]
    with Scene(parse_scenario(scenario(poses), Path('.'))) as scene:
        geometry = geometry_of(scene)
        tracker = ColorTracker(targets_of(scene), geometry)
        observations = tracker.track(scene.render().rgb)
        metres_per_pixel = geometry.metres_per_pixel()
        for robot in scene.entities_of(MobileRobot):
            x, y, yaw = robot.pose2d(scene.client)
            seen = observations[robot.name]
            assert seen.found
            # The camera sees the robots' sides too; without the cylinder fit the error
            # reaches ~2 pixels at the arena's edge.
            assert math.dist(seen.position, (x, y)) < 1.25 * metres_per_pixel
            if robot.params.radius > 0.2:       # the marker of the small robot is ~2 px long
                assert seen.heading is not None and heading_error(seen.heading, yaw) < 0.15


def test_tracker_follows_a_moving_robot_and_reports_missing_ones():
    with Scene(parse_scenario(scenario([(-1.0, 0.0, 0.0), (1.5, 1.5, 0.0)]), Path('.'))) as scene:
        targets = targets_of(scene) + [TrackedTarget('ghost', (0.9, 0.1, 0.9), 0.1)]
        tracker = ColorTracker(targets, geometry_of(scene))
        first = tracker.track(scene.render().rgb)
        assert not first['ghost'].found and math.isnan(first['ghost'].position[0])
        robot = scene.entity('robot_0')
        for _ in range(24):                                     # 1 s at up to 0.5 m/s
            robot.set_command(0.5, 0.0, scene.sim_time)
            scene.step(10)
        second = tracker.track(scene.render().rgb, previous=first)
        x, y, _ = robot.pose2d(scene.client)
        assert x > -0.7
        assert math.dist(second['robot_0'].position, (x, y)) < 0.03


def test_top_view_environment_matches_the_obstacles():
    poses = [(-2.0, 2.0, 0.0), (2.0, -2.0, 1.0)]
    with Scene(parse_scenario(scenario(poses), Path('.'))) as scene:
        geometry = geometry_of(scene)
        rgb = scene.render().rgb
        floor = estimate_floor_colors(rgb)
        assert len(floor) == 2
        observations = ColorTracker(targets_of(scene), geometry).track(rgb)
        discs = [(*observations[r.name].position, r.params.radius, r.params.height)
                 for r in scene.entities_of(MobileRobot)]
        frame = GridFrame(0.05, (-2.9, -2.9), (116, 116))      # inside the walls
        env = environment_from_top_view(rgb, geometry, frame, robot_discs=discs)
    centres = frame.cell_to_world(np.argwhere(np.ones(frame.shape, dtype=bool))).reshape(*frame.shape, 2)
    truth = np.zeros(frame.shape, dtype=bool)
    for box in BOXES:
        (cx, cy), (sx, sy) = box['center'], box['size']
        truth |= (np.abs(centres[..., 0] - cx) <= sx / 2) & (np.abs(centres[..., 1] - cy) <= sy / 2)
    # Every obstacle cell is found, and what else is marked hugs the boxes' edges.
    assert env.occupied[truth].all()
    extra = env.occupied & ~truth
    near_box = np.zeros_like(truth)
    for box in BOXES:
        (cx, cy), (sx, sy) = box['center'], box['size']
        near_box |= (np.abs(centres[..., 0] - cx) <= sx / 2 + 0.1) & (np.abs(centres[..., 1] - cy) <= sy / 2 + 0.1)
    assert not (extra & ~near_box).any(), 'robots or floor were segmented as obstacles'


def test_segmentation_and_masks_on_synthetic_images():
    image = np.full((10, 12, 3), 200, dtype=np.uint8)
    image[2:4, 3:6] = (20, 20, 20)
    obstacle = segment_obstacles(image, np.array([[200, 200, 200]]), tolerance=30)
    assert obstacle.sum() == 6 and obstacle[2:4, 3:6].all()
    free = np.zeros((10, 12), dtype=bool)
    free[2, 3] = True
    assert segment_obstacles(image, [[200, 200, 200]], free_mask=free).sum() == 5
    geometry = TopViewGeometry(np.array([[10.0, 0, 5.5], [0, 10.0, 4.5], [0, 0, 1]]), (0.0, 0.0, 10.0))
    mask = robot_disc_mask((10, 12), geometry, [(0.0, 0.0, 1.0)], margin_px=0)
    assert mask[4:6, 5:7].all() and not mask[0, 0]


@pytest.mark.parametrize('call, message', [
    (lambda: segment_obstacles(np.zeros((4, 4)), [[0, 0, 0]]), 'uint8 RGB'),
    (lambda: ColorTracker([TrackedTarget('a', (2, 0, 0), 0.1)], None), "'a'.color"),
    (lambda: ColorTracker([TrackedTarget('a', (1, 0, 0), 0.1), TrackedTarget('a', (0, 1, 0), 0.1)], None),
     'unique'),
])
def test_bad_inputs_raise_clear_errors(call, message):
    with pytest.raises(RoleEngineError, match=message):
        call()
