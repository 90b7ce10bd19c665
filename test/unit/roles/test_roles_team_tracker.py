"""TeamTracker (the robot_tracker's core): one pose per robot per frame, on images rendered by the bridge."""
import math
from pathlib import Path

import numpy as np
import pytest

from pybullet_bridge.core import MobileRobot, Scene, parse_scenario
from role_engine.core.errors import RoleEngineError
from role_engine.core.tracking import ColorTracker, TeamTracker, TrackedTarget, TrackingSettings

from test_roles_tracking import geometry_of, heading_error, scenario, targets_of

POSES = [(-1.5, -1.0, 0.4), (1.2, 1.4, -2.0), (0.5, -1.8, 1.6), (-1.8, 1.6, 3.0)]


def paint_disc(rgb, geometry, x, y, z, radius_m, colour):
    """Paint a disc of the image (world centre x, y at height z) with one colour."""
    (u, v), = geometry.world_to_pixel(np.array([[x, y]]), z)
    radius_px = radius_m / geometry.metres_per_pixel(z)
    rows, cols = np.mgrid[0:rgb.shape[0], 0:rgb.shape[1]]
    rgb[np.hypot(cols - u, rows - v) <= radius_px] = colour


@pytest.fixture(scope='module')
def frame():
    """(rgb, geometry, {robot: (x, y, yaw, radius, height)}) of four robots."""
    with Scene(parse_scenario(scenario(POSES), Path('.'))) as scene:
        robots = {r.name: (*r.pose2d(scene.client), r.params.radius, r.params.height)
                  for r in scene.entities_of(MobileRobot)}
        return scene.render().rgb, geometry_of(scene), targets_of(scene), robots


def test_every_robot_gets_a_pose_close_to_the_truth(frame):
    rgb, geometry, targets, robots = frame
    poses = TeamTracker(targets).update(rgb, geometry)
    assert set(poses) == set(robots)
    for name, (x, y, yaw, radius, _) in robots.items():
        pose = poses[name]
        assert math.dist((pose.x, pose.y), (x, y)) < 1.25 * geometry.metres_per_pixel()
        assert pose.heading_seen
        if radius > 0.2:                                  # the small robot's marker is ~2 px long
            assert heading_error(pose.yaw, yaw) < 0.15
    # The same positions and headings as one ColorTracker pass (the heading window changes nothing).
    seen = ColorTracker(targets, geometry).track(rgb)
    for name, pose in poses.items():
        assert (pose.x, pose.y) == seen[name].position and pose.yaw == seen[name].heading


def test_a_hidden_marker_keeps_the_last_heading_and_a_lost_robot_has_no_pose(frame):
    rgb, geometry, targets, robots = frame
    tracker = TeamTracker(targets)
    first = tracker.update(rgb, geometry)
    hidden = rgb.copy()
    x, y, _, radius, height = robots['robot_0']
    colour = (np.asarray(targets[0].color) * 200).astype(np.uint8)
    paint_disc(hidden, geometry, x, y, height, radius, colour)                 # marker covered
    floor = hidden[2, 2].copy()
    x1, y1, _, radius1, height1 = robots['robot_1']
    paint_disc(hidden, geometry, x1, y1, height1, 1.6 * radius1, floor)        # robot_1 gone
    paint_disc(hidden, geometry, x1, y1, 0.0, 1.6 * radius1, floor)
    second = tracker.update(hidden, geometry)
    assert 'robot_1' not in second
    assert not second['robot_0'].heading_seen and second['robot_0'].yaw == first['robot_0'].yaw
    assert second['robot_2'].heading_seen
    # A tracker that never saw robot_0's marker has no pose for it (a pose needs a yaw).
    assert 'robot_0' not in TeamTracker(targets).update(hidden, geometry)
    # robot_1 is found again in the next full frame.
    assert 'robot_1' in tracker.update(rgb, geometry)


def test_new_settings_apply_from_the_next_frame(frame):
    rgb, geometry, targets, _ = frame
    tracker = TeamTracker(targets)
    assert len(tracker.update(rgb, geometry)) == 4
    tracker.settings = TrackingSettings(min_area_px=100000)     # larger than any robot's blob
    assert tracker.update(rgb, geometry) == {}
    tracker.settings = TrackingSettings(chroma_tolerance=0.06)
    assert len(tracker.update(rgb, geometry)) == 4


@pytest.mark.parametrize('call, message', [
    (lambda: TrackingSettings(chroma_tolerance=0.0), 'chroma_tolerance: must be > 0'),
    (lambda: TrackingSettings(min_brightness=800.0), r'min_brightness: must be in \[0, 765\]'),
    (lambda: TrackingSettings(min_area_px=0), 'min_area_px: must be an integer >= 1'),
    (lambda: TeamTracker([TrackedTarget('a', (1, 0, 0), 0.0)]), "'a'.radius"),
])
def test_bad_settings_and_targets_raise_clear_errors(call, message):
    with pytest.raises(RoleEngineError, match=message):
        call()
