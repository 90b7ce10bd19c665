"""Fuzzing the bridge (issue 16): non-finite and huge commands, a flood, bad service requests. The
bridge stays up, counts every dropped command in ~/status, logs each kind once, and still drives."""

import math
import time

from bridge_interfaces.srv import GetCameraFrame, SetSensorActive
from geometry_msgs.msg import Twist
from rclpy.qos import QoSProfile, ReliabilityPolicy

from bridge_helpers import body_pose, bridge_spec, drive, step, wait_for_subscriber
from fuzz_helpers import assert_rejected_once_per_kind, flood


def twist(linear=0.0, angular=0.0):
    msg = Twist()
    msg.linear.x, msg.angular.z = linear, angular
    return msg


def test_bridge_survives_fuzzed_commands_and_requests_and_still_drives(session, ros_node, config_dir):
    began = time.monotonic()
    process = session.start(bridge_spec(config_dir / 'scenarios' / 'test_sensors.yaml'))   # robots with sensors
    session.wait_for_message('/pybullet_bridge/status', 'bridge_interfaces/msg/SimulationStatus', timeout=30.0)
    cmd = ros_node.create_publisher(Twist, '/robot_1/cmd_vel', QoSProfile(depth=10,
                                                                        reliability=ReliabilityPolicy.RELIABLE))
    wait_for_subscriber(cmd)
    x0, y0, _ = body_pose(session, 'robot_1')

    # NaN / inf in both fields, one after the other, with the simulation stepping in between.
    for bad in (math.nan, math.inf, -math.inf):
        cmd.publish(twist(bad, 0.0))
        cmd.publish(twist(0.0, bad))
        time.sleep(0.05)
    assert step(session, 24).success
    # A short flood of NaN commands (best effort input: some may be lost on the way, none may crash it).
    flood(cmd, twist(math.nan, math.nan), 300, seconds=1.0)
    # Bad requests: answered, not fatal.
    assert not step(session, 0).success
    assert not step(session, 2**32 - 1).success
    answer = session.call_service('/robot_1/set_sensor_active', 'bridge_interfaces/srv/SetSensorActive',
                                  SetSensorActive.Request(sensor='x' * 10_000, active=True))
    assert not answer.success and len(answer.message) < 11_000
    frame = session.call_service('/top_camera/get_frame', 'bridge_interfaces/srv/GetCameraFrame',
                                 GetCameraFrame.Request(with_labels=True))
    assert frame.success and frame.image.width > 0
    session.check_alive()

    # Nothing moved the robot; every command dropped is counted, each kind logged once.
    x1, y1, _ = body_pose(session, 'robot_1')
    assert math.hypot(x1 - x0, y1 - y0) < 1e-3
    status = session.wait_for_message('/pybullet_bridge/status', 'bridge_interfaces/msg/SimulationStatus',
                                      predicate=lambda s: s.rejected_messages >= 6 + 100)
    log = process.log_path.read_text()
    assert_rejected_once_per_kind(log, '/robot_1/cmd_vel', ['non-finite velocity'])
    assert '/robot_1/cmd_vel: 100 malformed messages dropped so far' in log
    assert 'Traceback' not in log

    # And it still does its task: a valid command drives the robot as before.
    drive(session, cmd, 0.4, 0.0, seconds=1.0)
    x2, y2, _ = body_pose(session, 'robot_1')
    assert 0.2 < math.hypot(x2 - x1, y2 - y1) < 0.5
    session.check_alive()
    print(f'bridge fuzz: {status.rejected_messages} commands dropped; {time.monotonic() - began:.0f} s (wall)')
