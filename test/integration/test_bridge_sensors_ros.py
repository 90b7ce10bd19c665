"""Robots' simulated sensors over ROS: switched by /<robot>/set_sensor_active, published while active.

The sensors are sensor data (best effort): the tests subscribe best effort (bridge_helpers.collect).
"""

import math

import pytest
from bridge_interfaces.msg import BumperState, FiducialDetections
from bridge_interfaces.srv import ResetScenario, SetSensorActive
from geometry_msgs.msg import PoseWithCovarianceStamped
from sensor_msgs.msg import LaserScan

from bridge_helpers import PHYSICS_HZ, bridge_spec, collect, settle, step

PIONEER_RADIUS = 0.23


@pytest.fixture
def bridge(session, config_dir):
    session.start(bridge_spec(config_dir / 'scenarios' / 'test_sensors.yaml', publish_camera=False))
    session.wait_for_message('/pybullet_bridge/status', 'bridge_interfaces/msg/SimulationStatus',
                             timeout=30.0)
    return session


def set_active(session, robot, sensor, active):
    return session.call_service(f'/{robot}/set_sensor_active', 'bridge_interfaces/srv/SetSensorActive',
                                SetSensorActive.Request(sensor=sensor, active=active))


def test_fiducial_switched_on_reports_names_and_ranges(bridge, ros_node):
    received = collect(ros_node, FiducialDetections, '/robot_1/fiducials')
    assert step(bridge, PHYSICS_HZ // 2).success
    assert settle(received, at_least=1, timeout=1.0) == [], 'an inactive fiducial published'

    response = set_active(bridge, 'robot_1', 'fiducial', True)
    assert response.success, response.message
    assert step(bridge, PHYSICS_HZ // 2).success   # 0.5 s at 10 Hz
    messages = settle(received, at_least=5)
    assert 5 <= len(messages) <= 6
    msg = messages[-1]
    assert msg.header.frame_id == 'robot_1/fiducial_link'
    assert (msg.field_of_view, msg.max_range) == pytest.approx((math.pi, 4.0))
    # test_sensors.yaml: robot_2 2 m straight ahead, target_1 at 45 deg left; robot_3 behind the wall.
    by_name = {d.name: d for d in msg.detections}
    assert set(by_name) == {'robot_2', 'target_1'}
    assert (by_name['robot_2'].kind, by_name['target_1'].kind) == ('mobile_robot', 'target')
    assert by_name['robot_2'].range == pytest.approx(2.0, abs=1e-3)
    assert (by_name['robot_2'].x, by_name['robot_2'].y) == pytest.approx((2.0, 0.0), abs=1e-3)
    assert by_name['target_1'].range == pytest.approx(math.sqrt(2.0), abs=1e-3)
    assert by_name['target_1'].bearing == pytest.approx(math.pi / 4, abs=1e-3)
    stamps = [m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for m in messages]
    assert all(b - a == pytest.approx(0.1, abs=0.01) for a, b in zip(stamps, stamps[1:]))

    assert set_active(bridge, 'robot_1', 'fiducial', False).success
    count = len(received)
    assert step(bridge, PHYSICS_HZ // 2).success
    assert len(settle(received, at_least=count + 1, timeout=1.0)) == count, 'fiducial published after off'


def test_laser_bumper_and_gps_topics(bridge, ros_node):
    scans = collect(ros_node, LaserScan, '/robot_1/scan')
    bumps = collect(ros_node, BumperState, '/robot_1/bumper')
    fixes = collect(ros_node, PoseWithCovarianceStamped, '/robot_2/gps')
    assert step(bridge, PHYSICS_HZ // 4).success
    scan = settle(scans)[-1]
    assert len(scan.ranges) == 181 and scan.angle_min == pytest.approx(-math.pi / 2)
    assert scan.header.frame_id == 'robot_1/laser_link'
    # The middle beam looks along +x at robot_2 (centre 2 m ahead).
    assert scan.ranges[90] == pytest.approx(2.0 - PIONEER_RADIUS, abs=1e-3)
    bump = settle(bumps)[-1]
    assert not bump.pressed and list(bump.contacts) == []
    assert fixes == [], 'robot_2 gps starts inactive'

    assert set_active(bridge, 'robot_2', 'gps', True).success
    assert step(bridge, PHYSICS_HZ // 4).success
    fix = settle(fixes)[-1]
    assert fix.header.frame_id == 'world'
    position, q = fix.pose.pose.position, fix.pose.pose.orientation
    assert (position.x, position.y) == pytest.approx((1.0, 0.0), abs=1e-3)
    assert abs(2.0 * math.atan2(q.z, q.w)) == pytest.approx(math.pi, abs=1e-3)


def test_malformed_sensor_requests_are_refused(bridge):
    unknown = set_active(bridge, 'robot_1', 'sonar', True)
    assert not unknown.success
    assert unknown.message == "robot 'robot_1' has no sensor 'sonar' (it has: fiducial, laser, gps, bumper)"
    empty = set_active(bridge, 'robot_2', '', True)
    assert not empty.success and "no sensor ''" in empty.message and 'fiducial, gps' in empty.message
    missing = set_active(bridge, 'robot_2', 'laser', True)
    assert not missing.success and "no sensor 'laser'" in missing.message
    assert set_active(bridge, 'robot_1', 'gps', True).success
    assert step(bridge, 10).success
    bridge.check_alive()


def test_reset_restores_configured_activity_and_keeps_the_service(bridge, ros_node):
    received = collect(ros_node, FiducialDetections, '/robot_1/fiducials')
    assert set_active(bridge, 'robot_1', 'fiducial', True).success
    assert step(bridge, PHYSICS_HZ // 4).success
    assert settle(received), 'the activated fiducial did not publish'

    reset = bridge.call_service('/pybullet_bridge/reset', 'bridge_interfaces/srv/ResetScenario',
                                ResetScenario.Request())
    assert reset.success, reset.message
    count = len(settle(received, timeout=0.5))
    assert step(bridge, PHYSICS_HZ // 4).success
    assert len(settle(received, at_least=count + 1, timeout=1.0)) == count, \
        'the fiducial starts inactive again after a reset'
    assert set_active(bridge, 'robot_1', 'fiducial', True).success
    assert step(bridge, PHYSICS_HZ // 4).success
    assert len(settle(received, at_least=count + 1)) > count
