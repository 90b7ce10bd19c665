"""The bridge drives robots from cmd_vel, renders the camera, and survives bad input."""

import math

import numpy as np
import pytest
from bridge_interfaces.srv import ResetScenario
from geometry_msgs.msg import Twist
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image

from bridge_helpers import (body_pose, bridge_spec, collect, drive, set_paused, settle, stamp_seconds, step,
                            wait_for_subscriber)

PIONEER_MAX_LINEAR = 1.2  # m/s, built-in pioneer_3dx limit


@pytest.fixture
def bridge(session, config_dir, tmp_path):
    session.start(bridge_spec(config_dir / 'scenarios' / 'test_single_robot.yaml',
                              scenario_directories=[str(config_dir / 'scenarios'), str(tmp_path)]))
    session.wait_for_message('/pybullet_bridge/status', 'bridge_interfaces/msg/SimulationStatus',
                             timeout=30.0)
    return session


def image_array(msg):
    return np.frombuffer(bytes(msg.data), dtype=np.uint8).reshape(msg.height, msg.width, 3)


def test_cmd_vel_moves_robot_as_commanded_and_camera_sees_it(bridge, ros_node):
    cmd = ros_node.create_publisher(Twist, '/robot_1/cmd_vel', 10)
    wait_for_subscriber(cmd)
    x0, y0, _ = body_pose(bridge, 'robot_1')
    # The camera is sensor data (best effort, no history): listen, then step to the next frame.
    images = collect(ros_node, Image, '/top_camera/image_raw')
    assert step(bridge, 24).success  # 0.1 s: the 10 Hz camera renders a frame
    before = settle(images)[-1]

    drive(bridge, cmd, 0.4, 0.0, seconds=2.0)
    x1, y1, body = body_pose(bridge, 'robot_1')

    # Heading 0: straight along +x; 0.4 m/s for 2 s minus the acceleration ramp.
    assert 0.6 < x1 - x0 <= 0.8 + 1e-3
    assert abs(y1 - y0) < 0.02
    assert body.twist.linear.x == pytest.approx(0.4, abs=0.02)

    count = len(images)
    step(bridge, 48)  # let a new camera frame render (10 Hz camera)
    after = settle(images, at_least=count + 1)[-1]
    assert stamp_seconds(after) > stamp_seconds(before) + 2.0
    assert after.encoding == 'rgb8' and (after.width, after.height) == (160, 160)
    assert after.header.frame_id == 'top_camera_optical_frame'
    changed = np.any(image_array(before) != image_array(after), axis=2)
    assert changed.sum() > 20, 'the camera image did not change after the robot moved'


def test_velocity_limit_and_command_timeout(bridge, ros_node):
    cmd = ros_node.create_publisher(Twist, '/robot_1/cmd_vel', 10)
    wait_for_subscriber(cmd)
    x0, _, _ = body_pose(bridge, 'robot_1')
    drive(bridge, cmd, 5.0, 0.0, seconds=1.0)   # far above the limit
    x1, _, body = body_pose(bridge, 'robot_1')
    assert body.twist.linear.x <= PIONEER_MAX_LINEAR + 1e-3
    assert x1 - x0 <= PIONEER_MAX_LINEAR * 1.0 + 1e-3

    # No further commands: after the 0.5 s timeout the robot brakes to a stop.
    step(bridge, 2 * 240)
    _, _, body = body_pose(bridge, 'robot_1')
    assert abs(body.twist.linear.x) < 1e-3


def test_rotation_follows_angular_command(bridge, ros_node):
    # A best-effort publisher, as many teleop tools are: the bridge listens best effort.
    cmd = ros_node.create_publisher(Twist, '/robot_1/cmd_vel',
                                    QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT))
    wait_for_subscriber(cmd)
    drive(bridge, cmd, 0.0, 1.0, seconds=1.5)
    _, _, body = body_pose(bridge, 'robot_1')
    q = body.pose.orientation
    yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y ** 2 + q.z ** 2))
    assert 0.9 < yaw < 1.5  # 1 rad/s for 1.5 s minus the angular acceleration ramp
    assert body.twist.angular.z == pytest.approx(1.0, abs=0.05)


def test_malformed_commands_are_dropped_not_fatal(bridge, ros_node):
    cmd = ros_node.create_publisher(Twist, '/robot_1/cmd_vel', 10)
    stray = ros_node.create_publisher(Twist, '/no_such_robot/cmd_vel', 10)
    wait_for_subscriber(cmd)
    x0, y0, _ = body_pose(bridge, 'robot_1')
    for bad in (math.nan, math.inf, -math.inf):
        drive(bridge, cmd, bad, 0.0, seconds=0.25)
        drive(bridge, cmd, 0.0, bad, seconds=0.25)
    stray.publish(Twist())
    x1, y1, _ = body_pose(bridge, 'robot_1')
    assert math.hypot(x1 - x0, y1 - y0) < 1e-3

    status = bridge.wait_for_message('/pybullet_bridge/status',
                                     'bridge_interfaces/msg/SimulationStatus')
    assert status.rejected_messages == 6
    bridge.check_alive()

    bad_steps = step(bridge, 0)
    assert not bad_steps.success and 'steps' in bad_steps.message


def test_reset_restores_the_scenario_and_rejects_bad_files(bridge, ros_node, tmp_path):
    cmd = ros_node.create_publisher(Twist, '/robot_1/cmd_vel', 10)
    wait_for_subscriber(cmd)
    drive(bridge, cmd, 0.5, 0.0, seconds=1.0)
    x_moved, _, _ = body_pose(bridge, 'robot_1')
    assert x_moved > 0.2

    bad = tmp_path / 'bad.yaml'
    bad.write_text('name: bad\ncamera: {rate: 10.0, width: 64, height: 64, altitude: 4.0, '
                   'fov_deg: 45.0}\nmobile_robots:\n  - {name: r, type: pioneer_3dx, color: [1, 0, 0]}\n')
    response = bridge.call_service('/pybullet_bridge/reset', 'bridge_interfaces/srv/ResetScenario',
                                   ResetScenario.Request(scenario_path=str(bad)))
    assert not response.success and 'mobile_robots[0].pose' in response.message

    response = bridge.call_service('/pybullet_bridge/reset', 'bridge_interfaces/srv/ResetScenario',
                                   ResetScenario.Request())
    assert response.success, response.message
    step(bridge, 12)
    x_reset, y_reset, _ = body_pose(bridge, 'robot_1')
    assert math.hypot(x_reset, y_reset) < 1e-2


def test_running_simulation_publishes_clock_and_labels(bridge, ros_node):
    legend = bridge.wait_for_message('/top_camera/label_legend', 'bridge_interfaces/msg/LabelLegend',
                                     latched=True)
    robot_label = {e.name: e.label for e in legend.entries}['robot_1']
    assert set_paused(bridge, False).success
    first = bridge.wait_for_message('/clock', 'rosgraph_msgs/msg/Clock')
    later = bridge.wait_for_message(
        '/clock', 'rosgraph_msgs/msg/Clock',
        predicate=lambda m: m.clock.sec + m.clock.nanosec * 1e-9
        > first.clock.sec + first.clock.nanosec * 1e-9 + 0.5)
    assert later is not None
    labels = bridge.wait_for_message('/top_camera/labels', 'sensor_msgs/msg/Image')
    assert labels.encoding == '16UC1'
    pixels = np.frombuffer(bytes(labels.data), dtype=np.uint16).reshape(labels.height, labels.width)
    assert (pixels == robot_label).sum() > 20
    info = bridge.wait_for_message('/top_camera/camera_info', 'sensor_msgs/msg/CameraInfo')
    assert info.k[0] > 0 and info.width == labels.width
